"""The public names of DESIGN.md exist, are documented and agree with scipy."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

DESIGN_NAMES = [
    "skew",
    "matrix_from_euler_angles",
    "euler_angles_from_matrix",
    "euler_angle_G",
    "euler_angle_G_bar",
    "matrix_from_axis_angle",
    "axis_angle_from_matrix",
    "euler_parameters_from_axis_angle",
    "axis_angle_from_euler_parameters",
    "matrix_from_euler_parameters",
    "euler_parameters_from_matrix",
    "euler_parameter_G",
    "euler_parameter_G_bar",
    "euler_parameter_rates",
    "matrix_from_rodriguez_parameters",
    "rodriguez_parameters_from_matrix",
    "quaternion_product",
    "quaternion_conjugate",
    "quaternion_norm",
    "relative_euler_parameters",
]


@pytest.mark.parametrize("name", DESIGN_NAMES)
def test_design_name_exported(name):
    assert name in cr.__all__
    assert callable(getattr(cr, name))


@pytest.mark.parametrize("name", sorted(cr.__all__))
def test_every_public_function_cites_an_equation_or_states_shapes(name):
    obj = getattr(cr, name)
    if not callable(obj) or isinstance(obj, type):
        return
    doc = obj.__doc__ or ""
    assert "Parameters" in doc and "Returns" in doc, name
    assert "shape" in doc, name


def test_smoke_against_scipy():
    rng = np.random.default_rng(7)
    p = rng.normal(size=(200, 4))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    A_scipy = Rotation.from_quat(p, scalar_first=True).as_matrix()
    # 4 float64 roundings per entry at most: 1e-15 is a few ulp of 1.
    np.testing.assert_allclose(cr.matrix_from_euler_parameters(p), A_scipy, atol=1e-15)
    p_back = cr.euler_parameters_from_matrix(A_scipy)
    np.testing.assert_allclose(p_back, p * np.sign(p[:, :1]), atol=1e-15)
    angles = Rotation.from_quat(p, scalar_first=True).as_euler("ZXZ")
    np.testing.assert_allclose(cr.matrix_from_euler_angles(angles, "ZXZ"), A_scipy, atol=2e-15)


def test_every_public_name_is_in_the_user_guide():
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "rotations.md").read_text()
    missing = [name for name in cr.__all__ if name not in text]
    assert not missing, missing


def test_equation_table_names_existing_functions():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "rotations.md").read_text()
    rows = re.findall(r"^\| (8\.[0-9.\-]+) \| rigidlab\.core\.rotations\.(\w+) \|$", text, flags=re.M)
    assert len(rows) > 40
    for eq, name in rows:
        assert name in cr.__all__, name
        doc = getattr(cr, name).__doc__
        first = eq.split("-")[0]
        assert first in doc, (eq, name)


def test_empty_batches_keep_their_shape():
    assert cr.matrix_from_euler_parameters(np.zeros((0, 4))).shape == (0, 3, 3)
    assert cr.euler_parameters_from_matrix(np.zeros((0, 3, 3))).shape == (0, 4)
    assert cr.matrix_from_axis_angle(np.zeros((0, 3)), np.zeros(0)).shape == (0, 3, 3)
    assert cr.matrix_from_euler_angles(np.zeros((0, 3)), "zyx").shape == (0, 3, 3)
    assert cr.euler_angles_from_matrix(np.zeros((0, 3, 3))).shape == (0, 3)
    assert cr.quaternion_product(np.zeros((0, 4)), np.zeros((0, 4))).shape == (0, 4)


def test_inputs_are_converted_to_float64_and_never_modified():
    p = np.array([[1, 0, 0, 0], [0, 0, 0, 1]], dtype=np.float32)
    before = p.copy()
    A = cr.matrix_from_euler_parameters(p)
    assert A.dtype == np.float64
    np.testing.assert_array_equal(p, before)
    A_in = np.array(A)
    cr.euler_parameters_from_matrix(A_in[:, ::-1, ::-1].copy())
    np.testing.assert_array_equal(A_in, A)
    # Strided views give the same result as contiguous copies.
    rng = np.random.default_rng(3)
    q = rng.normal(size=(9, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    np.testing.assert_array_equal(
        cr.matrix_from_euler_parameters(q[::2]), cr.matrix_from_euler_parameters(q[::2].copy())
    )


def test_import_does_not_load_scipy_spatial():
    # scipy.spatial is only needed at the scipy boundary; importing the core
    # stays light for the app's start-up.
    import subprocess
    import sys

    code = "import sys, rigidlab.core.rotations; print('scipy.spatial' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
