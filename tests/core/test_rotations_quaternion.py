"""Quaternion algebra (Eqs. 8.65-8.83) against scipy and closed forms."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

N = 1000


def _unit(rng, shape):
    p = rng.normal(size=shape + (4,))
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def _R(p):
    return Rotation.from_quat(p, scalar_first=True)


def test_product_matches_scipy_composition():
    rng = np.random.default_rng(30)
    p, q = _unit(rng, (N,)), _unit(rng, (N,))
    ours = cr.quaternion_product(p, q)
    ref = (_R(p) * _R(q)).as_quat(scalar_first=True)
    # scipy returns the same product up to sign; components are 4-term dot
    # products of unit-size values.
    sign = np.sign(np.einsum("ni,ni->n", ours, ref))
    np.testing.assert_allclose(ours, ref * sign[:, None], atol=1e-15)


def test_product_of_general_quaternions_closed_form():
    a = np.array([1.0, 2.0, 3.0, 4.0])
    b = np.array([5.0, 6.0, 7.0, 8.0])
    # (a0 b0 - a.b, a0 b + b0 a + a x b) by hand: a.b = 12+21+32 = 65,
    # a x b = (2,3,4) x (6,7,8) = (24-28, 24-16, 14-18) = (-4, 8, -4).
    expected = np.array([5 - 65, 6 + 10 - 4, 7 + 15 + 8, 8 + 20 - 4])
    np.testing.assert_array_equal(cr.quaternion_product(a, b), expected)
    assert not np.array_equal(cr.quaternion_product(b, a), expected)
    np.testing.assert_allclose(
        cr.quaternion_norm(cr.quaternion_product(a, b)), cr.quaternion_norm(a) * cr.quaternion_norm(b)
    )


def test_composition_8_77_to_8_79():
    rng = np.random.default_rng(31)
    p, q = _unit(rng, (N,)), _unit(rng, (N,))
    A = cr.matrix_from_euler_parameters
    np.testing.assert_allclose(A(cr.quaternion_product(p, q)), A(p) @ A(q), atol=3e-15)
    np.testing.assert_allclose(cr.matrix_from_quaternion_product(p, q), A(p) @ A(q), atol=3e-15)


def test_conjugate_norm_inverse_sum():
    rng = np.random.default_rng(32)
    q = rng.normal(size=(N, 4)) * 3
    conj = cr.quaternion_conjugate(q)
    np.testing.assert_array_equal(conj[:, 0], q[:, 0])
    np.testing.assert_array_equal(conj[:, 1:], -q[:, 1:])
    n = cr.quaternion_norm(q)
    np.testing.assert_allclose(n, np.linalg.norm(q, axis=-1), rtol=1e-15)
    # q q* = (|q|^2, 0, 0, 0)
    qq = cr.quaternion_product(q, conj)
    np.testing.assert_allclose(qq[:, 0], n**2, rtol=1e-14)
    np.testing.assert_allclose(qq[:, 1:], 0, atol=1e-13)
    inv = cr.quaternion_inverse(q)
    one = np.broadcast_to([1.0, 0, 0, 0], (N, 4))
    np.testing.assert_allclose(cr.quaternion_product(q, inv), one, atol=1e-14)
    np.testing.assert_allclose(cr.quaternion_product(inv, q), one, atol=1e-14)
    np.testing.assert_array_equal(cr.quaternion_sum(q, conj), np.stack([2 * q[:, 0], 0 * q[:, 0], 0 * q[:, 0], 0 * q[:, 0]], -1))
    # Conjugate of a unit quaternion is the inverse rotation.
    p = _unit(rng, (N,))
    A = cr.matrix_from_euler_parameters
    np.testing.assert_allclose(A(cr.quaternion_conjugate(p)), np.swapaxes(A(p), -1, -2), atol=1e-15)


def test_rotate_vector_matches_scipy_apply():
    rng = np.random.default_rng(33)
    p = _unit(rng, (N,))
    u = rng.normal(size=(N, 3))
    ref = _R(p).apply(u)
    np.testing.assert_allclose(cr.rotate_vector(p, u), ref, atol=1e-14)
    # Equal to the vector part of p (0, u) p*.
    pu = cr.quaternion_product(cr.quaternion_product(p, np.concatenate([np.zeros((N, 1)), u], -1)), cr.quaternion_conjugate(p))
    np.testing.assert_allclose(pu[:, 1:], ref, atol=1e-14)
    np.testing.assert_allclose(pu[:, 0], 0, atol=1e-14)


def test_relative_euler_parameters_8_82():
    rng = np.random.default_rng(34)
    p_i, p_j = _unit(rng, (N,)), _unit(rng, (N,))
    p_ij = cr.relative_euler_parameters(p_i, p_j)
    A = cr.matrix_from_euler_parameters
    np.testing.assert_allclose(A(p_ij), np.swapaxes(A(p_i), -1, -2) @ A(p_j), atol=3e-15)
    ref = (_R(p_i).inv() * _R(p_j)).as_quat(scalar_first=True)
    sign = np.sign(np.einsum("ni,ni->n", p_ij, ref))
    np.testing.assert_allclose(p_ij, ref * sign[:, None], atol=1e-15)
    # Composition back: p_i p_ij = p_j.
    np.testing.assert_allclose(cr.quaternion_product(p_i, p_ij), p_j, atol=1e-15)


def test_constant_relative_rotation_residual_8_83():
    rng = np.random.default_rng(35)
    n = 200
    p_i = _unit(rng, (n,))
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    rate = rng.uniform(-5, 5, size=n)
    t = rng.uniform(0, 3, size=n)
    p_ij0 = _unit(rng, (n,))
    # Body j built to satisfy the constraint: A_j = A_i A(p_ij0) R(axis, rate t).
    A_j = (
        cr.matrix_from_euler_parameters(p_i)
        @ cr.matrix_from_euler_parameters(p_ij0)
        @ cr.matrix_from_axis_angle(axis, rate * t)
    )
    p_j = cr.euler_parameters_from_matrix(A_j)
    res = cr.constant_relative_rotation_residual(p_i, p_j, axis, rate, t, p_ij0=p_ij0)
    assert res.shape == (n, 3)
    np.testing.assert_allclose(res, 0, atol=1e-14)
    # Either sign of p_j satisfies it.
    np.testing.assert_allclose(cr.constant_relative_rotation_residual(p_i, -p_j, axis, rate, t, p_ij0=p_ij0), 0, atol=1e-14)
    # A small extra rotation e about the axis gives |residual| = sin(e / 2).
    e = 1e-3
    A_j_err = A_j @ cr.matrix_from_axis_angle(axis, e)
    res_err = cr.constant_relative_rotation_residual(p_i, cr.euler_parameters_from_matrix(A_j_err), axis, rate, t, p_ij0=p_ij0)
    np.testing.assert_allclose(np.linalg.norm(res_err, axis=-1), np.sin(e / 2), rtol=1e-9)
    # Default p_ij0 is the identity.
    p_j1 = cr.euler_parameters_from_matrix(cr.matrix_from_euler_parameters(p_i) @ cr.matrix_from_axis_angle(axis, rate * t))
    np.testing.assert_allclose(cr.constant_relative_rotation_residual(p_i, p_j1, axis, rate, t), 0, atol=1e-14)


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes_and_broadcasting(batch):
    rng = np.random.default_rng(36)
    p = _unit(rng, batch)
    q = _unit(rng, (2,))
    assert cr.quaternion_product(p, p).shape == batch + (4,)
    assert cr.quaternion_norm(p).shape == batch
    assert cr.quaternion_conjugate(p).shape == batch + (4,)
    assert cr.relative_euler_parameters(p, p).shape == batch + (4,)
    assert cr.rotate_vector(p, [1.0, 0, 0]).shape == batch + (3,)
    expected_batch = np.broadcast_shapes(batch, (2,))
    assert cr.quaternion_product(p, q).shape == expected_batch + (4,)


def test_quaternion_errors():
    with pytest.raises(ValueError, match=r"Expected `q1` to have shape \(\.\.\., 4\), got shape \(3,\)"):
        cr.quaternion_product([1.0, 0, 0], [1.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `q2` to be finite, got nan"):
        cr.quaternion_product([1.0, 0, 0, 0], [np.nan, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected broadcastable batch shapes, got `q1` batch \(2,\), `q2` batch \(3,\)"):
        cr.quaternion_product(np.ones((2, 4)), np.ones((3, 4)))
    with pytest.raises(ValueError, match=r"Expected `q` to be non-zero to invert it, got array\(\[0\., 0\., 0\., 0\.\]\) at batch index \(1,\)"):
        cr.quaternion_inverse([[1.0, 0, 0, 0], [0.0, 0, 0, 0]])
    with pytest.raises(ValueError, match=r"Expected `p_i` to be unit Euler parameters"):
        cr.relative_euler_parameters([2.0, 0, 0, 0], [1.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `u_body` to have shape \(\.\.\., 3\), got shape \(4,\)"):
        cr.rotate_vector([1.0, 0, 0, 0], [1.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `p_ij0` to be unit Euler parameters"):
        cr.constant_relative_rotation_residual([1.0, 0, 0, 0], [1.0, 0, 0, 0], [0, 0, 1.0], 1.0, 0.0, p_ij0=[0.5, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `t` to be finite, got nan"):
        cr.constant_relative_rotation_residual([1.0, 0, 0, 0], [1.0, 0, 0, 0], [0, 0, 1.0], 1.0, np.nan)


def test_norm_inverse_and_normalization_of_huge_and_tiny_quaternions():
    # Oracle: q = scale * u with u of known norm; norm, inverse and the unit
    # direction follow by scaling (exact for powers of two, 1-2 ulp here).
    # These used to overflow (norm inf, inverse 0, normalized p all zeros)
    # or underflow (norm 0, "zero norm" error) in the squares.
    rng = np.random.default_rng(60)
    u = rng.normal(size=(50, 4))
    u_norm = np.linalg.norm(u, axis=-1)
    for scale in (1e-200, 1e-160, 1e160, 1e200, 1e307):
        q = u * scale
        np.testing.assert_allclose(cr.quaternion_norm(q), u_norm * scale, rtol=4e-16)
        np.testing.assert_allclose(cr.normalize_euler_parameters(q), u / u_norm[:, None], rtol=0, atol=4e-16)
        inv = cr.quaternion_inverse(q)
        # entries of u^-1 are O(1): absolute round-off of a few ulp
        np.testing.assert_allclose(inv * scale, cr.quaternion_inverse(u), rtol=0, atol=2e-15)
        # q q^-1 = 1 (products of O(scale) and O(1/scale) entries are O(1)).
        np.testing.assert_allclose(cr.quaternion_product(q, inv), np.tile([1.0, 0, 0, 0], (50, 1)), atol=2e-15)
    # Entries near the float64 maximum: the direction is still exact, the norm is past the range.
    np.testing.assert_allclose(cr.normalize_euler_parameters([1.7e308] * 4), [0.5] * 4, rtol=1e-15)
    assert cr.quaternion_norm([1.7e308] * 4) == np.inf


def test_unit_check_reports_the_true_norm_of_huge_parameters():
    msg = r"Expected `p` to be unit Euler parameters \(\| \|p\| - 1 \| <= 1e-06\), got norm 1e\+200; use normalize_euler_parameters"
    with pytest.raises(ValueError, match=msg):
        cr.matrix_from_euler_parameters([1e200, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=msg):
        cr.check_euler_parameters([0.0, 0.0, 1e200, 0.0])
