"""The compiled large-batch path of core.rotations against the numpy path and scipy.

Batches of at least ``rigidlab.core.rotations._batch.COMPILED_MIN`` rotations run the
numba kernels of ``rigidlab.core.rotations._kernels``; smaller batches the blocked
numpy kernels; one rotation (no batch axes) a path on Python floats. Each
test forces a path by setting ``COMPILED_MIN`` (0: every batch compiled,
huge: none) and checks that the paths agree with each other (to the last
bit where they do the same arithmetic) and with scipy's ``Rotation``, for
batch shapes ``()``, ``(1,)``, ``(3, 1, 2, 1)``, one above the threshold
and one above the numpy path's block size, non-contiguous and read-only
inputs, and that invalid input raises the usual errors.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr
from rigidlab.core.rotations import _batch

ROOT = Path(__file__).resolve().parents[2]
NUMPY_ONLY = 10**12
SHAPES = [(), (1,), (3, 1, 2, 1), (_batch.COMPILED_MIN + 1,), (_batch.BLOCK + 100,)]


@pytest.fixture
def path(monkeypatch):
    """``path("compiled")`` / ``path("numpy")`` selects the batch path."""

    def select(name):
        monkeypatch.setattr(
            _batch, "COMPILED_MIN", 0 if name == "compiled" else NUMPY_ONLY
        )

    return select


def _both(path, f, *args):
    """``f(*args)`` on the compiled path and on the numpy path."""
    path("compiled")
    compiled = f(*args)
    path("numpy")
    return compiled, f(*args)


def _unit(rng, shape):
    p = rng.normal(size=shape + (4,))
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def _axes(rng, shape):
    v = rng.normal(size=shape + (3,))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _special_matrices():
    """Identity, half turns (pivot ties in Shepperd's method) and near half turns."""
    axes = np.array(
        [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 1]],
        dtype=float,
    )
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    angles = [0.0, np.pi, np.pi - 1e-9, 1e-12, 0.5 * np.pi]
    rotvecs = [a * ax for a in angles for ax in axes]
    return Rotation.from_rotvec(rotvecs).as_matrix()


# ------------------------------------------------------------ Euler parameters -> matrix


@pytest.mark.parametrize("shape", SHAPES)
def test_matrix_from_euler_parameters_paths_agree_with_scipy(path, shape):
    rng = np.random.default_rng(100)
    p = _unit(rng, shape)
    compiled, numpy_path = _both(path, cr.matrix_from_euler_parameters, p)
    assert compiled.shape == numpy_path.shape == shape + (3, 3)
    # Normalization decided per rotation (compiled) or per block (numpy) for
    # parameters that are unit to rounding: a few ulp at most.
    np.testing.assert_allclose(compiled, numpy_path, rtol=0, atol=1e-15)
    ref = Rotation.from_quat(p.reshape(-1, 4), scalar_first=True).as_matrix()
    np.testing.assert_allclose(compiled, ref.reshape(shape + (3, 3)), rtol=0, atol=1e-15)


def test_matrix_from_euler_parameters_paths_equal_bit_for_bit_when_normalizing(path):
    # Norms 1 +- 1e-8: both paths divide every rotation by its norm.
    rng = np.random.default_rng(101)
    p = _unit(rng, (5000,)) * rng.uniform(1 - 1e-8, 1 + 1e-8, size=(5000, 1))
    compiled, numpy_path = _both(path, cr.matrix_from_euler_parameters, p)
    np.testing.assert_array_equal(compiled, numpy_path)
    ref = Rotation.from_quat(p, scalar_first=True).as_matrix()
    np.testing.assert_allclose(compiled, ref, rtol=0, atol=1e-15)


def test_matrix_from_euler_parameters_one_rotation_equals_the_compiled_batch(path):
    rng = np.random.default_rng(102)
    p = _unit(rng, (300,))
    path("compiled")
    batch = cr.matrix_from_euler_parameters(p)
    for k in range(0, 300, 37):
        np.testing.assert_array_equal(cr.matrix_from_euler_parameters(p[k]), batch[k])


def test_quaternion_product_matrix_uses_the_same_kernel(path):
    rng = np.random.default_rng(103)
    p, q = _unit(rng, (500,)), _unit(rng, (500,))
    compiled, numpy_path = _both(path, cr.matrix_from_quaternion_product, p, q)
    np.testing.assert_allclose(compiled, numpy_path, rtol=0, atol=1e-15)
    ref = cr.matrix_from_euler_parameters(p) @ cr.matrix_from_euler_parameters(q)
    np.testing.assert_allclose(compiled, ref, rtol=0, atol=5e-15)


# ------------------------------------------------------------ matrix -> Euler parameters


@pytest.mark.parametrize("shape", SHAPES)
def test_euler_parameters_from_matrix_paths_equal_and_match_scipy(path, shape):
    rng = np.random.default_rng(110)
    A = Rotation.from_quat(_unit(rng, shape).reshape(-1, 4), scalar_first=True).as_matrix()
    A = A.reshape(shape + (3, 3))
    compiled, numpy_path = _both(path, cr.euler_parameters_from_matrix, A)
    assert compiled.shape == shape + (4,)
    np.testing.assert_array_equal(compiled, numpy_path)  # the same arithmetic
    assert (compiled[..., 0] >= 0).all()
    ref = Rotation.from_matrix(A.reshape(-1, 3, 3)).as_quat(scalar_first=True)
    ref *= np.where(ref[:, :1] < 0, -1.0, 1.0)
    np.testing.assert_allclose(compiled, ref.reshape(shape + (4,)), rtol=0, atol=1e-15)


def test_euler_parameters_from_matrix_pivot_ties_and_half_turns(path):
    A = _special_matrices()
    compiled, numpy_path = _both(path, cr.euler_parameters_from_matrix, A)
    np.testing.assert_array_equal(compiled, numpy_path)
    for k in range(A.shape[0]):
        np.testing.assert_array_equal(cr.euler_parameters_from_matrix(A[k]), compiled[k])
    np.testing.assert_allclose(cr.matrix_from_euler_parameters(compiled), A, atol=2e-15)


def test_conversions_through_shepperd_use_the_same_kernel(path):
    rng = np.random.default_rng(111)
    A = np.concatenate(
        [Rotation.from_quat(_unit(rng, (300,)), scalar_first=True).as_matrix(), _special_matrices()]
    )
    for f in (cr.axis_angle_from_matrix, cr.rotation_vector_from_matrix, cr.mrp_from_matrix):
        compiled, numpy_path = _both(path, f, A)
        if not isinstance(compiled, tuple):
            compiled, numpy_path = (compiled,), (numpy_path,)
        for c, n in zip(compiled, numpy_path):
            np.testing.assert_array_equal(c, n)
    compiled, numpy_path = _both(path, cr.euler_angles_from_matrix, A[:300], "ZXZ")
    np.testing.assert_array_equal(compiled, numpy_path)


# ------------------------------------------------------------ axis-angle -> matrix


@pytest.mark.parametrize("shape", SHAPES)
def test_matrix_from_axis_angle_paths_agree_with_scipy(path, shape):
    rng = np.random.default_rng(120)
    axis = _axes(rng, shape)
    angle = rng.uniform(-2 * np.pi, 2 * np.pi, size=shape)
    compiled, numpy_path = _both(path, cr.matrix_from_axis_angle, axis, angle)
    assert compiled.shape == shape + (3, 3)
    # The same arithmetic up to the last bit of a tangent from another library.
    np.testing.assert_allclose(compiled, numpy_path, rtol=0, atol=1e-15)
    ref = Rotation.from_rotvec((axis * np.asarray(angle)[..., None]).reshape(-1, 3)).as_matrix()
    np.testing.assert_allclose(compiled, ref.reshape(shape + (3, 3)), rtol=0, atol=2e-15)


def test_matrix_from_axis_angle_broadcasts_on_the_compiled_path(path):
    rng = np.random.default_rng(121)
    axis = _axes(rng, ())
    angle = rng.uniform(-np.pi, np.pi, size=(4, 50))
    compiled, numpy_path = _both(path, cr.matrix_from_axis_angle, axis, angle)
    assert compiled.shape == (4, 50, 3, 3)
    np.testing.assert_allclose(compiled, numpy_path, rtol=0, atol=1e-15)
    axes = _axes(rng, (4, 1))
    compiled, numpy_path = _both(path, cr.matrix_from_axis_angle, axes, angle)
    assert compiled.shape == (4, 50, 3, 3)
    ref = Rotation.from_rotvec((axes * angle[..., None]).reshape(-1, 3)).as_matrix()
    np.testing.assert_allclose(compiled, ref.reshape(4, 50, 3, 3), rtol=0, atol=2e-15)


# ------------------------------------------------------------ layouts


def test_non_contiguous_and_read_only_inputs(path):
    rng = np.random.default_rng(130)
    wide = rng.normal(size=(400, 8))
    p = wide[:, ::2]  # strided view
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    assert not p.flags.c_contiguous
    A = np.asfortranarray(Rotation.from_quat(p, scalar_first=True).as_matrix())
    axis = np.asfortranarray(_axes(rng, (400,)))
    angle = rng.uniform(-np.pi, np.pi, size=800)[::2]
    read_only = [x.copy() for x in (p, A, axis, angle)]
    for x in read_only:
        x.setflags(write=False)
    for p_, A_, axis_, angle_ in [(p, A, axis, angle), tuple(read_only)]:
        path("compiled")
        got = (
            cr.matrix_from_euler_parameters(p_),
            cr.euler_parameters_from_matrix(A_),
            cr.matrix_from_axis_angle(axis_, angle_),
        )
        path("numpy")
        want = (
            cr.matrix_from_euler_parameters(np.ascontiguousarray(p_)),
            cr.euler_parameters_from_matrix(np.ascontiguousarray(A_)),
            cr.matrix_from_axis_angle(np.ascontiguousarray(axis_), np.ascontiguousarray(angle_)),
        )
        for g, w in zip(got, want):
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-15)
    # Inputs are never written to.
    np.testing.assert_array_equal(read_only[0], p)


# ------------------------------------------------------------ validation


def _bad(x, index, value):
    x = x.copy()
    x[index] = value
    return x


def test_invalid_input_raises_the_usual_errors_on_the_compiled_path(path):
    rng = np.random.default_rng(140)
    path("compiled")
    p = _unit(rng, (6, 50))
    with pytest.raises(ValueError, match=r"unit Euler parameters .* at batch index \(4, 17\)"):
        cr.matrix_from_euler_parameters(_bad(p, (4, 17, 0), 2.0))
    with pytest.raises(ValueError, match=r"`p` to be finite, got nan .*at batch index \(1, 3\)"):
        cr.matrix_from_euler_parameters(_bad(p, (1, 3, 2), np.nan))
    A = Rotation.from_quat(p.reshape(-1, 4), scalar_first=True).as_matrix().reshape(6, 50, 3, 3)
    with pytest.raises(ValueError, match=r"`A` to be orthogonal .* at batch index \(2, 9\)"):
        cr.euler_parameters_from_matrix(_bad(A, (2, 9, 0, 0), 1.5))
    with pytest.raises(ValueError, match=r"determinant \+1 .* at batch index \(5, 0\)"):
        cr.euler_parameters_from_matrix(_bad(A, (5, 0), -A[5, 0]))
    with pytest.raises(ValueError, match=r"`A` to be finite, got inf"):
        cr.euler_parameters_from_matrix(_bad(A, (0, 1, 2, 2), np.inf))
    axis = _axes(rng, (300,))
    angle = rng.uniform(-np.pi, np.pi, size=300)
    with pytest.raises(ValueError, match=r"`axis` to be a unit vector .* at batch index \(7,\)"):
        cr.matrix_from_axis_angle(_bad(axis, (7, 1), 3.0), angle)
    with pytest.raises(ValueError, match=r"`angle` to be finite, got inf at batch index \(250,\)"):
        cr.matrix_from_axis_angle(axis, _bad(angle, 250, np.inf))
    with pytest.raises(ValueError, match=r"`axis` to be finite, got nan"):
        cr.matrix_from_axis_angle(_bad(axis, (299, 0), np.nan), angle)


def test_norms_within_tolerance_are_accepted_and_normalized(path):
    rng = np.random.default_rng(141)
    path("compiled")
    p = _unit(rng, (200,)) * (1 + 0.9e-6)
    np.testing.assert_allclose(
        cr.matrix_from_euler_parameters(p),
        Rotation.from_quat(p, scalar_first=True).as_matrix(),
        rtol=0,
        atol=1e-15,
    )
    axis = _axes(rng, (200,)) * (1 - 0.9e-6)
    angle = rng.uniform(-np.pi, np.pi, size=200)
    np.testing.assert_allclose(
        cr.matrix_from_axis_angle(axis, angle),
        Rotation.from_rotvec(axis / np.linalg.norm(axis, axis=-1, keepdims=True) * angle[:, None]).as_matrix(),
        rtol=0,
        atol=2e-15,
    )


# ------------------------------------------------------------ laziness


def test_kernels_are_cached_and_compiled_on_first_use_only():
    code = """
import sys
import numpy as np
import rigidlab.core.rotations as cr
from rigidlab.core.rotations import _batch
assert "numba" not in sys.modules and "rigidlab.core.rotations._kernels" not in sys.modules
p = np.array([[1.0, 0.0, 0.0, 0.0]] * (_batch.COMPILED_MIN - 1))
cr.matrix_from_euler_parameters(p)
assert "rigidlab.core.rotations._kernels" not in sys.modules, "small batch loaded the kernels"
from rigidlab.core.rotations import _kernels
kernels = [_kernels.matrix_from_euler_parameters, _kernels.euler_parameters_from_matrix,
           _kernels.matrix_from_axis_angle]
assert all(k.signatures == [] for k in kernels), "compiled at import"
assert all(type(k._cache).__name__ != "NullCache" for k in kernels), "cache=True missing"
cr.matrix_from_euler_parameters(np.concatenate([p, p]))
assert _kernels.matrix_from_euler_parameters.signatures
print("ok")
"""
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_empty_batches(path):
    for name in ("compiled", "numpy"):
        path(name)
        assert cr.matrix_from_euler_parameters(np.empty((0, 4))).shape == (0, 3, 3)
        assert cr.euler_parameters_from_matrix(np.empty((2, 0, 3, 3))).shape == (2, 0, 4)
        assert cr.matrix_from_axis_angle(np.empty((0, 3)), np.empty(0)).shape == (0, 3, 3)
