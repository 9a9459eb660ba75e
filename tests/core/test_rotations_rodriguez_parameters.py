"""Rodriguez parameters (Eqs. 8.58-8.64) and problems P9, P11."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

N = 1000


def _unit(rng, shape):
    p = rng.normal(size=shape + (4,))
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def _vee(W):
    return np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)


def _away_from_pi(rng, n):
    """Unit parameters with |theta0| >= 0.1 (angles below ~2.94 rad)."""
    p = _unit(rng, (n,))
    p = p[np.abs(p[:, 0]) >= 0.1]
    return p


def test_problem_9_relation_to_euler_parameters():
    rng = np.random.default_rng(40)
    p = _away_from_pi(rng, N)
    gamma = cr.rodriguez_parameters_from_euler_parameters(p)
    np.testing.assert_allclose(gamma, p[:, 1:] / p[:, :1], rtol=1e-15)
    # gamma = axis tan(angle / 2), from scipy's rotation vector.
    rv = Rotation.from_quat(p, scalar_first=True).as_rotvec()
    angle = np.linalg.norm(rv, axis=-1)
    # |gamma| <= 1 / 0.1; relative error a few ulp.
    np.testing.assert_allclose(gamma, rv / angle[:, None] * np.tan(angle / 2)[:, None], rtol=1e-12, atol=1e-14)
    # theta0 = 1 / sqrt(1 + gamma^2), theta = gamma theta0.
    back = cr.euler_parameters_from_rodriguez_parameters(gamma)
    np.testing.assert_allclose(back, p * np.sign(p[:, :1]), atol=1e-15)
    np.testing.assert_allclose(back[:, 0], 1 / np.sqrt(1 + np.einsum("ni,ni->n", gamma, gamma)), rtol=1e-15)


def test_matrix_8_60_matches_scipy_and_round_trips():
    rng = np.random.default_rng(41)
    p = _away_from_pi(rng, N)
    gamma = cr.rodriguez_parameters_from_euler_parameters(p)
    A = cr.matrix_from_rodriguez_parameters(gamma)
    np.testing.assert_allclose(A, Rotation.from_quat(p, scalar_first=True).as_matrix(), atol=3e-15)
    g = cr.skew(gamma)
    textbook = np.eye(3) + 2 / (1 + np.einsum("ni,ni->n", gamma, gamma))[:, None, None] * (g + g @ g)
    np.testing.assert_allclose(A, textbook, atol=3e-15)
    np.testing.assert_allclose(cr.rodriguez_parameters_from_matrix(A), gamma, rtol=1e-12, atol=1e-14)


def test_omega_maps_against_finite_differences():
    rng = np.random.default_rng(42)
    n = 100
    g0 = rng.normal(size=(n, 3))
    g1 = rng.normal(size=(n, 3))
    g_at = lambda t: g0 + g1 * t + 0.5 * t**2
    h = 1e-5
    gamma = g_at(0.0)
    gamma_dot = g1
    A = cr.matrix_from_rodriguez_parameters(gamma)
    A_dot = (cr.matrix_from_rodriguez_parameters(g_at(h)) - cr.matrix_from_rodriguez_parameters(g_at(-h))) / (2 * h)
    omega_fd = _vee(A_dot @ np.swapaxes(A, -1, -2))
    omega_body_fd = _vee(np.swapaxes(A, -1, -2) @ A_dot)
    # Central differences, h = 1e-5: truncation ~1e-10, rounding ~1e-11.
    omega = cr.omega_from_rodriguez_parameter_rates(gamma, gamma_dot)
    omega_body = cr.omega_body_from_rodriguez_parameter_rates(gamma, gamma_dot)
    np.testing.assert_allclose(omega, omega_fd, atol=1e-8)
    np.testing.assert_allclose(omega_body, omega_body_fd, atol=1e-8)
    # Inverse maps round trip.
    np.testing.assert_allclose(cr.rodriguez_parameter_rates_from_omega(gamma, omega), gamma_dot, atol=1e-12)
    np.testing.assert_allclose(cr.rodriguez_parameter_rates(gamma, omega_body), gamma_dot, atol=1e-12)


def test_problem_11_rodriguez_parameter_rates_from_given_omega():
    # P11: gamma_dot for omega_body = (0.2, -1, 3) rad/s at gamma = (0.1, 0.2, -0.3).
    # Oracle: propagate A(t) = A(0) expm(skew(omega_body t)) with scipy and
    # differentiate gamma = theta / theta0 of scipy's quaternions.
    gamma = np.array([0.1, 0.2, -0.3])
    w = np.array([0.2, -1.0, 3.0])
    p0 = cr.euler_parameters_from_rodriguez_parameters(gamma)
    def g_at(t):
        q = (Rotation.from_quat(p0, scalar_first=True) * Rotation.from_rotvec(w * t)).as_quat(scalar_first=True)
        return q[1:] / q[0]
    h = 1e-6
    fd = (g_at(h) - g_at(-h)) / (2 * h)
    # Central difference, h = 1e-6: truncation ~1e-12, rounding ~1e-10.
    np.testing.assert_allclose(cr.rodriguez_parameter_rates(gamma, w), fd, atol=1e-8)
    omega = cr.matrix_from_rodriguez_parameters(gamma) @ w
    np.testing.assert_allclose(cr.rodriguez_parameter_rates_from_omega(gamma, omega), fd, atol=1e-8)


def test_singularity_at_pi_predicate_and_errors():
    p = cr.euler_parameters_from_axis_angle([[0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0]], [np.pi, np.pi - 1e-7, 3.0])
    near = cr.rodriguez_parameters_near_singularity(p)
    np.testing.assert_array_equal(near, [True, True, False])
    np.testing.assert_array_equal(cr.rodriguez_parameters_near_singularity(p, tol=1e-8), [True, False, False])
    with pytest.raises(ValueError, match=r"Expected `p` to be a rotation by an angle away from pi \(\|theta0\| > 1e-06\), got theta0 = 6\.12e-17 at batch index \(0,\); Rodriguez parameters are infinite there"):
        cr.rodriguez_parameters_from_euler_parameters(p)
    A = cr.matrix_from_euler_parameters(p)
    with pytest.raises(ValueError, match=r"Expected `A` to be a rotation by an angle away from pi"):
        cr.rodriguez_parameters_from_matrix(A)
    # Just outside the tolerance it works and |gamma| ~ 1 / theta0.
    gamma = cr.rodriguez_parameters_from_matrix(A[2])
    np.testing.assert_allclose(np.linalg.norm(gamma), np.tan(1.5), rtol=1e-12)


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes(batch):
    rng = np.random.default_rng(43)
    gamma = rng.normal(size=batch + (3,))
    A = cr.matrix_from_rodriguez_parameters(gamma)
    assert A.shape == batch + (3, 3)
    assert cr.rodriguez_parameters_from_matrix(A).shape == batch + (3,)
    assert cr.euler_parameters_from_rodriguez_parameters(gamma).shape == batch + (4,)
    assert cr.rodriguez_parameter_rates(gamma, np.ones(3)).shape == batch + (3,)
    np.testing.assert_allclose(cr.rodriguez_parameters_from_matrix(A), gamma, rtol=1e-11, atol=1e-13)


def test_rodriguez_errors():
    with pytest.raises(ValueError, match=r"Expected `g` to have shape \(\.\.\., 3\), got shape \(4,\)"):
        cr.matrix_from_rodriguez_parameters([0.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `g` to be finite, got inf"):
        cr.matrix_from_rodriguez_parameters(g=[np.inf, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `gamma` to be finite, got inf"):
        cr.euler_parameters_from_rodriguez_parameters([np.inf, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `gamma_dot` to have shape \(\.\.\., 3\)"):
        cr.omega_from_rodriguez_parameter_rates([0.0, 0, 0], [1.0])


@pytest.mark.parametrize("scale", [1e3, 1e50, 1e154, 1e200, 1e300])
def test_huge_gamma_tends_to_the_half_turn(scale):
    # gamma = axis tan(angle/2) grows without bound as the angle -> pi; for
    # |gamma| ~ scale the rotation differs from the half turn about gamma's
    # direction by an angle ~ 2/scale, so the scipy half turn is the oracle to
    # within 2/scale plus round-off (1e-15 per entry).
    rng = np.random.default_rng(44)
    axis = rng.normal(size=(20, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    gamma = axis * scale
    p = cr.euler_parameters_from_rodriguez_parameters(gamma)
    A = cr.matrix_from_rodriguez_parameters(gamma)
    assert np.all(np.isfinite(p)) and np.all(np.isfinite(A))
    np.testing.assert_allclose(np.linalg.norm(p, axis=-1), 1.0, atol=1e-15)
    reference = Rotation.from_rotvec(np.pi * axis).as_matrix()
    tol = 2.0 / scale + 1e-15
    np.testing.assert_allclose(A, reference, atol=tol)
    np.testing.assert_allclose(cr.matrix_from_euler_parameters(p), reference, atol=tol)


def test_rates_that_overflow_are_a_clear_error():
    # gamma_dot ~ |gamma|^2 |omega| / 2: with |gamma| = 1e200 that is beyond float64.
    with pytest.raises(ValueError, match=r"Expected `gamma` small enough for finite Rodriguez parameter rates.*1e\+200"):
        cr.rodriguez_parameter_rates_from_omega([1e200, 0.0, 0.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"Expected `gamma` small enough .*at index \(1,\)"):
        cr.rodriguez_parameter_rates([[0.0, 0.0, 0.0], [0.0, 1e200, 0.0]], [0.0, 1.0, 0.0])
    # a large but representable gamma still gives the closed form
    gamma = np.array([1e100, 0.0, 0.0])
    rates = cr.rodriguez_parameter_rates_from_omega(gamma, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(rates, [0.5 * (1.0 + 1e200), 0.0, 0.0], rtol=1e-15)
