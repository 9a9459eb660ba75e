"""Rotation vectors and modified Rodriguez parameters against scipy."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import core.rotations as cr

N = 1000


def _unit(rng, shape):
    p = rng.normal(size=shape + (4,))
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def test_rotation_vector_matches_scipy():
    rng = np.random.default_rng(50)
    r = rng.normal(size=(N, 3)) * 1.5
    r[:5] = [[0, 0, 0], [1e-12, 0, 0], [0, 1e-8, 0], [np.pi, 0, 0], [0, 0, -np.pi]]
    A = cr.matrix_from_rotation_vector(r)
    # scipy's own rounding on O(1) entries is ~1e-15.
    np.testing.assert_allclose(A, Rotation.from_rotvec(r).as_matrix(), atol=3e-15)
    p = cr.euler_parameters_from_rotation_vector(r)
    np.testing.assert_allclose(p, Rotation.from_rotvec(r).as_quat(scalar_first=True), atol=1e-15)
    back = cr.rotation_vector_from_matrix(A)
    ref = Rotation.from_matrix(A).as_rotvec()
    # Rotation vectors of angle pi are defined up to sign.
    sign = np.where(np.einsum("ni,ni->n", back, ref) < 0, -1.0, 1.0)
    np.testing.assert_allclose(back, ref * sign[:, None], atol=3e-15)
    np.testing.assert_allclose(cr.rotation_vector_from_euler_parameters(p), back, atol=3e-15)
    np.testing.assert_array_equal(cr.rotation_vector_from_euler_parameters([1.0, 0, 0, 0]), [0, 0, 0])


def test_mrp_matches_scipy():
    rng = np.random.default_rng(51)
    p = _unit(rng, (N,))
    A = cr.matrix_from_euler_parameters(p)
    sigma = cr.mrp_from_matrix(A)
    ref = Rotation.from_quat(p, scalar_first=True).as_mrp()
    np.testing.assert_allclose(sigma, ref, atol=2e-15)
    assert (np.linalg.norm(sigma, axis=-1) <= 1 + 1e-15).all()
    np.testing.assert_allclose(cr.mrp_from_euler_parameters(p), ref, atol=2e-15)
    np.testing.assert_allclose(cr.mrp_from_euler_parameters(-p), ref, atol=2e-15)
    np.testing.assert_allclose(cr.matrix_from_mrp(sigma), A, atol=3e-15)
    np.testing.assert_allclose(cr.euler_parameters_from_mrp(sigma), p * np.sign(p[:, :1]), atol=2e-15)
    # sigma = axis tan(angle / 4)
    axis, angle = cr.axis_angle_from_matrix(A)
    np.testing.assert_allclose(sigma, axis * np.tan(angle / 4)[:, None], atol=2e-15)


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes(batch):
    rng = np.random.default_rng(52)
    r = rng.normal(size=batch + (3,))
    assert cr.matrix_from_rotation_vector(r).shape == batch + (3, 3)
    assert cr.euler_parameters_from_rotation_vector(r).shape == batch + (4,)
    assert cr.matrix_from_mrp(r * 0.3).shape == batch + (3, 3)
    A = cr.matrix_from_rotation_vector(r)
    assert cr.rotation_vector_from_matrix(A).shape == batch + (3,)
    assert cr.mrp_from_matrix(A).shape == batch + (3,)


def test_scipy_boundary_round_trip():
    rng = np.random.default_rng(53)
    p = _unit(rng, (10,))
    rot = cr.to_scipy(p)
    np.testing.assert_allclose(rot.as_matrix(), cr.matrix_from_euler_parameters(p), atol=1e-15)
    np.testing.assert_allclose(cr.from_scipy(rot), cr.canonical_euler_parameters(p), atol=1e-15)
    with pytest.raises(ValueError, match=r"Expected `rotation` to be a scipy.spatial.transform.Rotation, got ndarray"):
        cr.from_scipy(p)
    with pytest.raises(ValueError, match=r"Expected `p` to be unit Euler parameters"):
        cr.to_scipy(2 * p)


def test_errors():
    with pytest.raises(ValueError, match=r"Expected `r` to have shape \(\.\.\., 3\), got shape \(4,\)"):
        cr.matrix_from_rotation_vector([0.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `sigma` to be finite, got nan"):
        cr.matrix_from_mrp([np.nan, 0, 0])
