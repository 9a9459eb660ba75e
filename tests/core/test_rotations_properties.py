"""Property tests with hypothesis: round trips and composition for any rotation."""

import warnings

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

BASE = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ"]

component = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
quaternion = st.tuples(component, component, component, component).filter(
    lambda q: np.linalg.norm(q) > 1e-3
).map(lambda q: np.asarray(q) / np.linalg.norm(q))
sequence = st.sampled_from(BASE + [s.lower() for s in BASE])
SETTINGS = settings(max_examples=int(__import__("os").environ.get("RIGIDLAB_HYPOTHESIS_EXAMPLES", 150)), deadline=None)


@SETTINGS
@given(quaternion)
def test_matrix_parameters_round_trip(p):
    A = cr.matrix_from_euler_parameters(p)
    back = cr.euler_parameters_from_matrix(A)
    assert back[0] >= 0
    # Same rotation up to sign, to a few ulp.
    assert min(np.abs(back - p).max(), np.abs(back + p).max()) < 4e-15
    np.testing.assert_allclose(A, Rotation.from_quat(p, scalar_first=True).as_matrix(), atol=2e-15)


@SETTINGS
@given(quaternion, sequence)
def test_euler_angles_reproduce_the_matrix(p, seq):
    A = cr.matrix_from_euler_parameters(p)
    # No NaN or division by zero on the way (underflow is harmless).
    with np.errstate(invalid="raise", divide="raise", over="raise"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cr.GimbalLockWarning)
            angles = cr.euler_angles_from_matrix(A, seq)
    # Near gimbal lock the third angle is set to 0 and the matrix moves by
    # at most the distance of the middle angle to the singularity (1e-7).
    np.testing.assert_allclose(cr.matrix_from_euler_angles(angles, seq), A, atol=3e-7)


@SETTINGS
@given(quaternion, quaternion)
def test_product_composes_matrices(p, q):
    A = cr.matrix_from_euler_parameters
    np.testing.assert_allclose(A(cr.quaternion_product(p, q)), A(p) @ A(q), atol=4e-15)
    np.testing.assert_allclose(
        A(cr.relative_euler_parameters(p, q)), A(p).T @ A(q), atol=4e-15
    )


@SETTINGS
@given(quaternion)
def test_axis_angle_and_rotation_vector_round_trip(p):
    A = cr.matrix_from_euler_parameters(p)
    axis, angle = cr.axis_angle_from_matrix(A)
    assert 0.0 <= angle <= np.pi
    np.testing.assert_allclose(cr.matrix_from_axis_angle(axis, angle), A, atol=3e-15)
    r = cr.rotation_vector_from_matrix(A)
    np.testing.assert_allclose(cr.matrix_from_rotation_vector(r), A, atol=3e-15)
    sigma = cr.mrp_from_matrix(A)
    np.testing.assert_allclose(cr.matrix_from_mrp(sigma), A, atol=3e-15)
