"""Rotation vectors and modified Rodriguez parameters against scipy."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

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


def test_huge_rotation_vectors_stay_unit_and_match_the_closed_form():
    # Axis-aligned r = (a, 0, 0): p = (cos(a/2), sin(a/2), 0, 0) exactly, with
    # numpy's correctly reduced sin/cos (scipy returns NaN for these).
    a = np.array([1e5, 1e15, 1e200, 1.7e308])
    r = np.zeros((a.size, 3))
    r[:, 0] = a
    p = cr.euler_parameters_from_rotation_vector(r)
    ref = np.zeros((a.size, 4))
    ref[:, 0] = np.cos(0.5 * a)
    ref[:, 1] = np.sin(0.5 * a)
    # O(1) entries from one rounding each: a few ulp.
    np.testing.assert_allclose(p, ref, atol=4e-16)
    # Generic huge directions, including |r| whose squares overflow: unit
    # parameters (this was |p| = 1.08 at |r| = 4e154) and the same rotation
    # as matrix_from_rotation_vector (round-off on O(1) entries).
    rng = np.random.default_rng(51)
    r = rng.normal(size=(200, 3)) * 10.0 ** rng.uniform(3, 307, size=(200, 1))
    p = cr.euler_parameters_from_rotation_vector(r)
    np.testing.assert_allclose(np.linalg.norm(p, axis=-1), 1.0, atol=4e-16)
    np.testing.assert_allclose(cr.matrix_from_euler_parameters(p), cr.matrix_from_rotation_vector(r), atol=2e-15)


def test_rotation_vector_whose_norm_overflows_is_an_error():
    r = [[0.3, 0.0, 0.0], [1.7e308, 1.7e308, 1.7e308]]
    msg = r"Expected `r` to have a norm \(the angle\) below the float64 maximum, got \[1\.7e\+308, 1\.7e\+308, 1\.7e\+308\] at batch index \(1,\)"
    with pytest.raises(ValueError, match=msg):
        cr.euler_parameters_from_rotation_vector(r)
    with pytest.raises(ValueError, match=msg):
        cr.matrix_from_rotation_vector(r)


def test_huge_mrp_tend_to_the_identity_without_overflow():
    # sigma = axis tan(angle / 4) grows without bound as the angle nears 2 pi.
    # Oracle: the shadow set -sigma / |sigma|^2 is the same rotation and small,
    # so it is computed without any scaling; scipy agrees where it can.
    rng = np.random.default_rng(52)
    sigma = rng.normal(size=(300, 3)) * 10.0 ** rng.uniform(0, 300, size=(300, 1))
    norm = np.linalg.norm(sigma / 1e150, axis=-1) * 1e150  # no overflow up to 1e300
    shadow = -(sigma / norm[:, None]) / norm[:, None]
    p = cr.euler_parameters_from_mrp(sigma)
    np.testing.assert_allclose(np.linalg.norm(p, axis=-1), 1.0, atol=4e-16)
    # Round-off on O(1) entries.
    np.testing.assert_allclose(cr.matrix_from_mrp(sigma), cr.matrix_from_mrp(shadow), atol=2e-15)
    moderate = np.abs(sigma).max(axis=-1) < 1e8
    np.testing.assert_allclose(
        cr.matrix_from_mrp(sigma[moderate]), Rotation.from_mrp(sigma[moderate]).as_matrix(), atol=2e-15
    )
    # The limit itself, including components near the float64 maximum.
    for huge in ([1e200, 2e200, -1e200], [1.7e308, 1.7e308, 0.0]):
        p = cr.euler_parameters_from_mrp(huge)
        np.testing.assert_allclose(p, [-1.0, 0.0, 0.0, 0.0], atol=1e-150)
        np.testing.assert_allclose(cr.matrix_from_mrp(huge), np.eye(3), rtol=0, atol=1e-150)


def test_unit_axis_error_reports_the_true_norm_of_huge_and_tiny_axes():
    # The squares of these norms overflow / underflow; the message must not say inf or 0.
    for axis, shown in (([1e200, 0.0, 0.0], r"1e\+200"), ([0.0, 1e-200, 0.0], r"1e-200")):
        msg = rf"Expected `axis` to be a unit vector \(\| \|axis\| - 1 \| <= 1e-06\), got norm {shown}$"
        with pytest.raises(ValueError, match=msg):
            cr.matrix_from_axis_angle(axis, 1.0)
        with pytest.raises(ValueError, match=msg):
            cr.euler_parameters_from_axis_angle(axis, 1.0)
