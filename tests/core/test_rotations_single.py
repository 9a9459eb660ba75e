"""One rotation (no batch axes) takes a float path: same results as the batch.

Every public function with a one-rotation path is called on single inputs
and on the same inputs with a batch axis of length one; the results agree to
1e-15 (the same floating-point operations in the same order, up to the last
bit of a sine or hypot from a different library) and have the same type,
shape and dtype. Validation is unchanged: every bad single input raises the
error of the batched path.
"""

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

SEQUENCES = [
    "".join(axes)
    for axes in itertools.product("XYZ", repeat=3)
    if axes[0] != axes[1] and axes[1] != axes[2]
]
SEQUENCES += [s.lower() for s in SEQUENCES]

SPECIAL_ANGLES = [0.0, np.pi, -np.pi, 0.5 * np.pi, -0.5 * np.pi, 1e-300, 1e-9, 2.0 * np.pi, 1e8]


def _unit(rng, n, size=4):
    x = rng.normal(size=(n, size))
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _same(single, batched):
    """``single`` equals ``batched[0]`` to 1e-15 with the same type and shape."""
    expected = batched[0]
    assert type(single) is type(expected)
    assert np.shape(single) == np.shape(expected)
    assert np.asarray(single).dtype == np.float64
    np.testing.assert_allclose(single, expected, rtol=0, atol=1e-15)


def _angle_triples(rng):
    triples = list(rng.uniform(-np.pi, np.pi, size=(100, 3)))
    triples += [np.array(t) for t in itertools.product(SPECIAL_ANGLES[:5], repeat=3)]
    return triples


def _parameters(rng):
    p = list(_unit(rng, 100))
    p += [
        np.array([1.0, 0.0, 0.0, 0.0]),
        np.array([-1.0, 0.0, 0.0, 0.0]),
        np.array([0.0, 1.0, 0.0, 0.0]),
        np.array([0.0, 0.0, -1.0, 0.0]),
        np.array([0.0, -0.0, 0.0, -1.0]),
        np.array([0.0, 0.6, -0.8, 0.0]),
        np.array([0.5, 0.5, 0.5, 0.5]),
        np.array([1.0, 1e-300, 0.0, 0.0]),
    ]
    # unit within UNIT_NORM_TOL, but not to rounding: normalized first
    p += [q * (1.0 + 1e-7) for q in p[:10]]
    p += [q * (1.0 - 3e-16) for q in p[:10]]
    return p


@pytest.mark.parametrize("seq", SEQUENCES)
def test_matrix_from_euler_angles_single_equals_batch(seq):
    rng = np.random.default_rng(100)
    for angles in _angle_triples(rng):
        _same(
            cr.matrix_from_euler_angles(angles, seq),
            cr.matrix_from_euler_angles(angles[None], seq),
        )


@pytest.mark.parametrize("seq", SEQUENCES)
def test_euler_parameters_from_euler_angles_single_equals_batch(seq):
    rng = np.random.default_rng(101)
    for angles in _angle_triples(rng):
        _same(
            cr.euler_parameters_from_euler_angles(angles, seq),
            cr.euler_parameters_from_euler_angles(angles[None], seq),
        )


@pytest.mark.parametrize("seq", SEQUENCES)
def test_single_euler_angle_matrix_matches_scipy(seq):
    rng = np.random.default_rng(102)
    for angles in rng.uniform(-np.pi, np.pi, size=(50, 3)):
        np.testing.assert_allclose(
            cr.matrix_from_euler_angles(angles, seq),
            Rotation.from_euler(seq, angles).as_matrix(),
            rtol=0,
            atol=2e-15,
        )


def _axis_angles(rng):
    axes = list(_unit(rng, 60, 3)) + [np.eye(3)[k] for k in range(3)]
    axes += [a * (1.0 + 5e-7) for a in axes[:5]]  # within UNIT_NORM_TOL
    angles = list(rng.uniform(-2.0 * np.pi, 2.0 * np.pi, size=len(axes)))
    pairs = list(zip(axes, angles))
    pairs += [(axes[k % len(axes)], a) for k, a in enumerate(SPECIAL_ANGLES)]
    return pairs


@pytest.mark.parametrize(
    "name", ["matrix_from_axis_angle", "euler_parameters_from_axis_angle"]
)
def test_axis_angle_functions_single_equal_batch(name):
    f = getattr(cr, name)
    rng = np.random.default_rng(103)
    for axis, angle in _axis_angles(rng):
        batched = f(axis[None], np.array([angle]))
        _same(f(axis, angle), batched)
        _same(f(axis, np.float64(angle)), batched)
        _same(f(axis, np.array(angle)), batched)
        _same(f(axis.tolist(), float(angle)), batched)


def test_single_axis_angle_matrix_matches_scipy():
    rng = np.random.default_rng(104)
    for axis, angle in zip(_unit(rng, 100, 3), rng.uniform(-np.pi, np.pi, 100)):
        np.testing.assert_allclose(
            cr.matrix_from_axis_angle(axis, angle),
            Rotation.from_rotvec(axis * angle).as_matrix(),
            rtol=0,
            atol=2e-15,
        )


@pytest.mark.parametrize(
    "name",
    [
        "matrix_from_euler_parameters",
        "axis_angle_from_euler_parameters",
        "normalize_euler_parameters",
        "canonical_euler_parameters",
        "quaternion_conjugate",
    ],
)
def test_euler_parameter_functions_single_equal_batch(name):
    f = getattr(cr, name)
    rng = np.random.default_rng(105)
    for p in _parameters(rng):
        single = f(p)
        batched = f(p[None])
        if isinstance(single, tuple):
            assert len(single) == len(batched)
            for s, b in zip(single, batched):
                _same(s, b)
        else:
            _same(single, batched)


def test_single_normalize_and_conjugate_of_general_quaternions():
    rng = np.random.default_rng(106)
    qs = list(rng.normal(size=(50, 4)))
    qs += [q * 1e-200 for q in qs[:5]] + [q * 1e300 for q in qs[:5]]
    qs += [np.array([0.0, 0.0, 3.0, 0.0]), np.array([1e308, 1e308, 1e308, 1e308])]
    for q in qs:
        _same(cr.normalize_euler_parameters(q), cr.normalize_euler_parameters(q[None]))
        _same(cr.quaternion_conjugate(q), cr.quaternion_conjugate(q[None]))


def test_quaternion_product_single_equals_batch_and_scipy():
    rng = np.random.default_rng(107)
    a = list(rng.normal(size=(50, 4))) + _parameters(rng)
    b = list(rng.normal(size=(50, 4))) + _parameters(np.random.default_rng(108))
    a.append(np.full(4, 1e300))  # the products overflow: inf as in the batch
    b.append(np.full(4, 1e300))
    for q1, q2 in zip(a, b):
        with np.errstate(over="ignore", invalid="ignore"):
            _same(cr.quaternion_product(q1, q2), cr.quaternion_product(q1[None], q2[None]))
    for p, q in zip(_unit(rng, 50), _unit(rng, 50)):
        ref = (
            Rotation.from_quat(p, scalar_first=True) * Rotation.from_quat(q, scalar_first=True)
        ).as_quat(scalar_first=True)
        ours = cr.quaternion_product(p, q)
        np.testing.assert_allclose(ours * np.sign(ours @ ref), ref, rtol=0, atol=2e-15)


def _rotation_matrices(rng):
    A = list(Rotation.from_quat(_unit(rng, 100), scalar_first=True).as_matrix())
    # every pivot of Shepperd's method: angles near 0 and half turns about
    # each axis, and a matrix off orthogonal by less than ORTHOGONALITY_TOL
    A.append(np.eye(3))
    A += [np.diag(d) for d in ([1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0])]
    A += list(Rotation.from_rotvec(np.pi * _unit(rng, 10, 3)).as_matrix())
    A.append(A[0] + 1e-8)
    return A


def test_euler_parameters_from_matrix_single_equals_batch_and_scipy():
    rng = np.random.default_rng(109)
    for A in _rotation_matrices(rng):
        single = cr.euler_parameters_from_matrix(A)
        _same(single, cr.euler_parameters_from_matrix(A[None]))
        _same(cr.euler_parameters_from_matrix(A.tolist()), cr.euler_parameters_from_matrix(A[None]))
    for A in _rotation_matrices(rng)[:-1]:
        ref = Rotation.from_matrix(A).as_quat(scalar_first=True)
        ref = ref * np.where(ref[0] < 0, -1.0, 1.0)
        np.testing.assert_allclose(cr.euler_parameters_from_matrix(A), ref, rtol=0, atol=2e-15)


def test_rotate_vector_single_equals_batch():
    rng = np.random.default_rng(110)
    for p, u in zip(_parameters(rng), rng.normal(size=(200, 3)) * 10.0):
        _same(cr.rotate_vector(p, u), cr.rotate_vector(p[None], u[None]))
        np.testing.assert_allclose(
            cr.rotate_vector(p, u), cr.matrix_from_euler_parameters(p) @ u, rtol=0, atol=1e-13
        )


def test_rotation_vector_single_equals_batch():
    rng = np.random.default_rng(111)
    axes = _unit(rng, 120, 3)
    lengths = np.concatenate(
        [rng.uniform(0.0, 4.0, 100), [0.0, 1e-300, 1e-9, 0.5, 1.0 - 1e-16, 1.0, np.pi, 1e3, 1e10, 1e300]]
    )
    rs = [a * s for a, s in zip(axes, lengths)] + [np.zeros(3)]
    for r in rs:
        _same(
            cr.euler_parameters_from_rotation_vector(r),
            cr.euler_parameters_from_rotation_vector(r[None]),
        )


def test_single_inputs_are_not_modified_and_results_are_fresh():
    p = np.array([0.5, 0.5, 0.5, 0.5])
    p.setflags(write=False)
    out = cr.canonical_euler_parameters(p)
    assert out.flags.writeable and not np.shares_memory(out, p)
    out = cr.normalize_euler_parameters(p)
    assert out.flags.writeable and not np.shares_memory(out, p)
    A = cr.matrix_from_euler_parameters(p)
    assert A.flags.writeable and A.flags.c_contiguous
    np.testing.assert_array_equal(p, [0.5, 0.5, 0.5, 0.5])


# ----------------------------------------------------------- validation
P = np.array([1.0, 0.0, 0.0, 0.0])
AXIS = np.array([0.0, 0.0, 1.0])
BAD_SINGLE_CALLS = [
    # (function, args, match)
    (cr.matrix_from_euler_angles, ([0.0, np.nan, 0.0],), r"`angles` to be finite, got nan"),
    (cr.matrix_from_euler_angles, ([0.0, np.inf, 0.0],), r"`angles` to be finite, got inf"),
    (cr.matrix_from_euler_angles, ([0.0, 1.0],), r"`angles` to have shape \(\.\.\., 3\), got shape \(2,\)"),
    (cr.matrix_from_euler_angles, ([0.0, 1j, 0.0],), r"`angles` to be real numbers, got complex"),
    (cr.matrix_from_euler_angles, ([0.0, 1.0, 0.0], "ZZX"), r"consecutive axes of `seq` to be different"),
    (cr.euler_parameters_from_euler_angles, ([np.nan, 0.0, 0.0],), r"`angles` to be finite, got nan"),
    (cr.euler_parameters_from_euler_angles, (np.array([1.0, 2.0, 3.0], complex),), r"`angles` to be real numbers, got complex"),
    (cr.matrix_from_axis_angle, (AXIS, np.nan), r"`angle` to be finite, got nan"),
    (cr.matrix_from_axis_angle, (AXIS, np.inf), r"`angle` to be finite, got inf"),
    (cr.matrix_from_axis_angle, (AXIS, 1j), r"`angle` to be real numbers, got complex"),
    (cr.matrix_from_axis_angle, ([0.0, 0.0, 2.0], 1.0), r"`axis` to be a unit vector .* got norm 2\.0"),
    (cr.matrix_from_axis_angle, ([0.0, np.nan, 1.0], 1.0), r"`axis` to be finite, got nan"),
    (cr.matrix_from_axis_angle, ([0.0, 1.0], 1.0), r"`axis` to have shape \(\.\.\., 3\), got shape \(2,\)"),
    (cr.matrix_from_axis_angle, ([0.0, 0.0, 1.0 + 0j], 1.0), r"`axis` to be real numbers, got complex"),
    (cr.euler_parameters_from_axis_angle, ([0.0, 0.0, 2.0], 1.0), r"`axis` to be a unit vector .* got norm 2\.0"),
    (cr.euler_parameters_from_axis_angle, (AXIS, np.nan), r"`angle` to be finite, got nan"),
    (cr.euler_parameters_from_axis_angle, (AXIS, 1.0 + 0j), r"`angle` to be real numbers, got complex"),
    (cr.matrix_from_euler_parameters, ([2.0, 0.0, 0.0, 0.0],), r"`p` to be unit Euler parameters .* got norm 2\.0"),
    (cr.matrix_from_euler_parameters, ([np.nan, 0.0, 0.0, 1.0],), r"`p` to be finite, got nan"),
    (cr.matrix_from_euler_parameters, ([1.0, 0.0, 0.0],), r"`p` to have shape \(\.\.\., 4\), got shape \(3,\)"),
    (cr.matrix_from_euler_parameters, (P + 0j,), r"`p` to be real numbers, got complex"),
    (cr.euler_parameters_from_matrix, (2.0 * np.eye(3),), r"`A` to be orthogonal"),
    (cr.euler_parameters_from_matrix, (-np.eye(3),), r"`A` to have determinant \+1"),
    (cr.euler_parameters_from_matrix, (np.full((3, 3), np.nan),), r"`A` to be finite, got nan"),
    (cr.euler_parameters_from_matrix, (np.eye(2),), r"`A` to have shape \(\.\.\., 3, 3\), got shape \(2, 2\)"),
    (cr.euler_parameters_from_matrix, (np.eye(3) + 0j,), r"`A` to be real numbers, got complex"),
    (cr.quaternion_product, (P, [1.0, np.inf, 0.0, 0.0]), r"`q2` to be finite, got inf"),
    (cr.quaternion_product, ([np.nan, 0.0, 0.0, 0.0], P), r"`q1` to be finite, got nan"),
    (cr.quaternion_product, (P, [1.0, 0.0, 0.0]), r"`q2` to have shape \(\.\.\., 4\), got shape \(3,\)"),
    (cr.quaternion_product, (P, P * 1j), r"`q2` to be real numbers, got complex"),
    (cr.quaternion_conjugate, ([np.nan, 0.0, 0.0, 0.0],), r"`q` to be finite, got nan"),
    (cr.quaternion_conjugate, (P + 1j,), r"`q` to be real numbers, got complex"),
    (cr.rotate_vector, ([2.0, 0.0, 0.0, 0.0], AXIS), r"`p` to be unit Euler parameters"),
    (cr.rotate_vector, (P, [0.0, np.nan, 0.0]), r"`u_body` to be finite, got nan"),
    (cr.rotate_vector, (P, [0.0, 1.0]), r"`u_body` to have shape \(\.\.\., 3\), got shape \(2,\)"),
    (cr.rotate_vector, (P, AXIS * 1j), r"`u_body` to be real numbers, got complex"),
    (cr.normalize_euler_parameters, (np.zeros(4),), r"`p` to have non-zero norm, got norm 0\.0"),
    (cr.normalize_euler_parameters, ([1.0, np.nan, 0.0, 0.0],), r"`p` to be finite, got nan"),
    (cr.normalize_euler_parameters, ([np.inf, 1.0, 0.0, 0.0],), r"`p` to be finite, got inf"),
    (cr.normalize_euler_parameters, (P * 1j,), r"`p` to be real numbers, got complex"),
    (cr.axis_angle_from_euler_parameters, ([2.0, 0.0, 0.0, 0.0],), r"`p` to be unit Euler parameters"),
    (cr.axis_angle_from_euler_parameters, ([np.nan, 0.0, 0.0, 0.0],), r"`p` to be finite, got nan"),
    (cr.axis_angle_from_euler_parameters, (P + 0j,), r"`p` to be real numbers, got complex"),
    (cr.canonical_euler_parameters, ([0.0, 0.0, 0.0, 0.0],), r"`p` to be unit Euler parameters"),
    (cr.canonical_euler_parameters, (P + 0j,), r"`p` to be real numbers, got complex"),
    (cr.euler_parameters_from_rotation_vector, ([np.nan, 0.0, 0.0],), r"`r` to be finite, got nan"),
    (cr.euler_parameters_from_rotation_vector, ([1.5e308, 1.5e308, 0.0],), r"`r` to have a norm \(the angle\) below the float64 maximum"),
    (cr.euler_parameters_from_rotation_vector, ([1.0, 0.0, 0.0, 0.0],), r"`r` to have shape \(\.\.\., 3\), got shape \(4,\)"),
    (cr.euler_parameters_from_rotation_vector, (AXIS * 1j,), r"`r` to be real numbers, got complex"),
]


@pytest.mark.parametrize(
    "f, args, match",
    BAD_SINGLE_CALLS,
    ids=[f"{f.__name__}-{k}" for k, (f, _, _) in enumerate(BAD_SINGLE_CALLS)],
)
def test_bad_single_inputs_raise_as_in_the_batch(f, args, match):
    with pytest.raises(ValueError, match=match):
        f(*args)


@pytest.mark.parametrize("seq", SEQUENCES)
def test_euler_angles_from_matrix_single_equals_batch_and_warns_the_same(seq):
    # Same formulas on floats: agreement to a few ulps of pi (angles are
    # compared modulo 2 pi, where -pi and pi are the same angle).
    rng = np.random.default_rng(7)
    q = rng.normal(size=(200, 4))
    A = cr.matrix_from_euler_parameters(q / np.linalg.norm(q, axis=1, keepdims=True))
    batch = cr.euler_angles_from_matrix(A, seq)
    single = np.array([cr.euler_angles_from_matrix(a, seq) for a in A])
    difference = np.abs(batch - single)
    assert np.minimum(difference, np.abs(difference - 2 * np.pi)).max() <= 4 * np.finfo(float).eps * np.pi
    # At gimbal lock both paths warn once and give the same angles.
    proper = seq[0].upper() == seq[2].upper()
    locked = cr.matrix_from_euler_angles(np.array([0.3, 0.0 if proper else np.pi / 2, 0.2]), seq)
    with pytest.warns(cr.GimbalLockWarning, match=f"Gimbal lock in sequence '{seq}'"):
        one = cr.euler_angles_from_matrix(locked, seq)
    with pytest.warns(cr.GimbalLockWarning):
        many = cr.euler_angles_from_matrix(locked[None], seq)[0]
    np.testing.assert_allclose(cr.matrix_from_euler_angles(one, seq), locked, atol=1e-15)
    difference = np.abs(one - many)
    assert np.minimum(difference, np.abs(difference - 2 * np.pi)).max() <= 4 * np.finfo(float).eps * np.pi
