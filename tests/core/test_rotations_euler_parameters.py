"""Euler parameters (Eqs. 8.46-8.57) against scipy, identities and finite differences."""

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


def _canonical(p):
    return p * np.where(p[..., :1] < 0, -1.0, 1.0)


def test_matrix_from_euler_parameters_matches_scipy():
    rng = np.random.default_rng(10)
    p = _unit(rng, (N,))
    # Both are 3-4 roundings of O(1) quadratic forms: a few ulp of 1.
    np.testing.assert_allclose(
        cr.matrix_from_euler_parameters(p),
        Rotation.from_quat(p, scalar_first=True).as_matrix(),
        rtol=0,
        atol=1e-15,
    )


def test_textbook_form_of_the_matrix():
    rng = np.random.default_rng(11)
    p = _unit(rng, (N,))
    t0 = p[:, 0]
    t = p[:, 1:]
    A = (2 * t0**2 - 1)[:, None, None] * np.eye(3) + 2 * (
        t[:, :, None] * t[:, None, :] + t0[:, None, None] * cr.skew(t)
    )
    np.testing.assert_allclose(cr.matrix_from_euler_parameters(p), A, atol=2e-15)


def test_euler_parameters_from_matrix_matches_scipy_with_theta0_nonnegative():
    rng = np.random.default_rng(12)
    p = _unit(rng, (N,))
    A = Rotation.from_quat(p, scalar_first=True).as_matrix()
    ours = cr.euler_parameters_from_matrix(A)
    assert (ours[:, 0] >= 0).all()
    ref = _canonical(Rotation.from_matrix(A).as_quat(scalar_first=True))
    # Shepperd's pivot keeps every component to a few ulp.
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ours, _canonical(p), rtol=0, atol=2e-15)


@pytest.mark.parametrize(
    "axis, angle",
    [
        ([0, 0, 1], 0.0),
        ([1, 0, 0], np.pi),
        ([0, 1, 0], np.pi),
        ([0, 0, 1], np.pi),
        ([1 / np.sqrt(3)] * 3, np.pi),
        ([0.6, 0.0, 0.8], np.pi - 1e-9),
        ([0.6, 0.0, 0.8], 1e-12),
        ([0.0, -0.6, 0.8], -np.pi + 1e-7),
    ],
)
def test_euler_parameters_from_matrix_edge_cases(axis, angle):
    p = cr.euler_parameters_from_axis_angle(axis, angle)
    A = cr.matrix_from_euler_parameters(p)
    ours = cr.euler_parameters_from_matrix(A)
    # Up to sign, and exactly one sign when theta0 > 0.
    err = min(np.abs(ours - p).max(), np.abs(ours + p).max())
    assert err < 2e-15
    assert ours[0] >= 0
    np.testing.assert_allclose(ours, _canonical(Rotation.from_matrix(A).as_quat(scalar_first=True)), atol=2e-15)


def test_axis_angle_round_trip_and_definition():
    rng = np.random.default_rng(13)
    axis = rng.normal(size=(N, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = rng.uniform(0, np.pi, size=N)
    p = cr.euler_parameters_from_axis_angle(axis, angle)
    np.testing.assert_allclose(p[:, 0], np.cos(angle / 2), atol=1e-16)
    np.testing.assert_allclose(p[:, 1:], axis * np.sin(angle / 2)[:, None], atol=1e-16)
    axis2, angle2 = cr.axis_angle_from_euler_parameters(p)
    # angle = 2 atan2(|theta|, theta0): well conditioned everywhere.
    np.testing.assert_allclose(angle2, angle, atol=1e-15)
    np.testing.assert_allclose(axis2[angle > 1e-3], axis[angle > 1e-3], atol=1e-12)
    np.testing.assert_allclose(
        p, Rotation.from_rotvec(axis * angle[:, None]).as_quat(scalar_first=True), atol=1e-15
    )
    # -p is the same rotation.
    axis3, angle3 = cr.axis_angle_from_euler_parameters(-p)
    np.testing.assert_allclose(angle3, angle, atol=1e-15)
    identity_axis, zero = cr.axis_angle_from_euler_parameters([1.0, 0.0, 0.0, 0.0])
    assert zero == 0.0 and identity_axis.tolist() == [0.0, 0.0, 1.0]


def test_G_identities_8_55_8_56():
    rng = np.random.default_rng(14)
    p = _unit(rng, (N,))
    p_dot = rng.normal(size=(N, 4))
    p_dot -= np.einsum("ni,ni->n", p_dot, p)[:, None] * p  # p . p_dot = 0
    G = cr.euler_parameter_G(p)
    G_bar = cr.euler_parameter_G_bar(p)
    A = cr.matrix_from_euler_parameters(p)
    I3 = np.broadcast_to(np.eye(3), (N, 3, 3))
    I4 = np.broadcast_to(np.eye(4), (N, 4, 4))
    GT = np.swapaxes(G, -1, -2)
    GbT = np.swapaxes(G_bar, -1, -2)
    ppT = p[:, :, None] * p[:, None, :]
    # Products of unit-size entries: a few ulp.
    atol = 2e-15
    np.testing.assert_allclose(np.einsum("nij,nj->ni", G, p), 0, atol=atol)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", G_bar, p), 0, atol=atol)
    np.testing.assert_allclose(G @ GT, I3, atol=atol)
    np.testing.assert_allclose(G_bar @ GbT, I3, atol=atol)
    np.testing.assert_allclose(GT @ G, I4 - ppT, atol=atol)
    np.testing.assert_allclose(GbT @ G_bar, I4 - ppT, atol=atol)
    np.testing.assert_allclose(G @ GbT, A, atol=atol)
    np.testing.assert_allclose(G_bar, np.swapaxes(A, -1, -2) @ G, atol=atol)
    # G(p) p_dot = -G(p_dot) p, and G(p_dot) p_dot = 0 (so alpha = 2 G p_ddot).
    Gd = cr.euler_parameter_G(p_dot / np.linalg.norm(p_dot, axis=-1, keepdims=True))
    Gd = Gd * np.linalg.norm(p_dot, axis=-1)[:, None, None]
    np.testing.assert_allclose(np.einsum("nij,nj->ni", G, p_dot), -np.einsum("nij,nj->ni", Gd, p), atol=1e-14)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", Gd, p_dot), 0, atol=1e-14)


def _trajectory(rng, n):
    """p(t) = normalized (p0 + p1 t + p2 t^2) and its exact derivatives at t = 0."""
    p0 = _unit(rng, (n,))
    p1 = rng.normal(size=(n, 4))
    p2 = rng.normal(size=(n, 4))
    raw = lambda t: p0 + p1 * t + p2 * t**2
    p_at = lambda t: raw(t) / np.linalg.norm(raw(t), axis=-1, keepdims=True)
    return p_at


def test_G_matrices_against_finite_differences_of_A():
    rng = np.random.default_rng(15)
    p_at = _trajectory(rng, 100)
    h = 1e-5
    p = p_at(0.0)
    p_dot = (p_at(h) - p_at(-h)) / (2 * h)
    A = cr.matrix_from_euler_parameters(p)
    A_dot = (cr.matrix_from_euler_parameters(p_at(h)) - cr.matrix_from_euler_parameters(p_at(-h))) / (2 * h)
    omega_fd = _vee(A_dot @ np.swapaxes(A, -1, -2))
    omega_body_fd = _vee(np.swapaxes(A, -1, -2) @ A_dot)
    # Central differences with h = 1e-5: O(h^2) truncation, eps / h rounding.
    np.testing.assert_allclose(cr.omega_from_euler_parameter_rates(p, p_dot), omega_fd, atol=1e-8)
    np.testing.assert_allclose(cr.omega_body_from_euler_parameter_rates(p, p_dot), omega_body_fd, atol=1e-8)
    np.testing.assert_allclose(2 * np.einsum("nij,nj->ni", cr.euler_parameter_G(p), p_dot), omega_fd, atol=1e-8)
    np.testing.assert_allclose(
        2 * np.einsum("nij,nj->ni", cr.euler_parameter_G_bar(p), p_dot), omega_body_fd, atol=1e-8
    )


def test_rates_omega_rates_round_trip_in_both_frames():
    rng = np.random.default_rng(16)
    p = _unit(rng, (N,))
    omega_body = rng.normal(size=(N, 3))
    p_dot = cr.euler_parameter_rates(p, omega_body)
    np.testing.assert_allclose(np.einsum("ni,ni->n", p, p_dot), 0, atol=1e-15)
    np.testing.assert_allclose(cr.omega_body_from_euler_parameter_rates(p, p_dot), omega_body, atol=1e-14)
    omega = np.einsum("nij,nj->ni", cr.matrix_from_euler_parameters(p), omega_body)
    np.testing.assert_allclose(cr.euler_parameter_rates_from_omega(p, omega), p_dot, atol=1e-14)
    np.testing.assert_allclose(cr.omega_from_euler_parameter_rates(p, p_dot), omega, atol=1e-14)


def test_problem_euler_parameter_rates_from_given_omega():
    # P10: p_dot for omega_body = (1, -2, 0.5) rad/s at p = (0.5, 0.5, 0.5, 0.5).
    # Oracle: p(t) = p (x) (cos(|w| t / 2), w_hat sin(|w| t / 2)) (constant
    # body angular velocity) differentiated by central differences.
    p = np.array([0.5, 0.5, 0.5, 0.5])
    w = np.array([1.0, -2.0, 0.5])
    p_at = lambda t: (
        Rotation.from_quat(p, scalar_first=True) * Rotation.from_rotvec(w * t)
    ).as_quat(scalar_first=True)
    h = 1e-6
    fd = (p_at(h) - p_at(-h)) / (2 * h)
    # Central difference, h = 1e-6: truncation ~1e-12, rounding ~1e-10.
    np.testing.assert_allclose(cr.euler_parameter_rates(p, w), fd, atol=1e-9)
    # G_bar = [-theta, -theta~ + theta0 I] for this p, written out by hand.
    G_bar = np.array([[-0.5, 0.5, 0.5, -0.5], [-0.5, -0.5, 0.5, 0.5], [-0.5, 0.5, -0.5, 0.5]])
    expected = 0.5 * G_bar.T @ w
    np.testing.assert_allclose(cr.euler_parameter_G_bar(p), G_bar, atol=0)
    np.testing.assert_allclose(cr.euler_parameter_rates(p, w), expected, atol=1e-16)


def test_angular_acceleration_8_57_and_parameter_accelerations():
    rng = np.random.default_rng(17)
    p_at = _trajectory(rng, 100)
    h = 1e-4
    p = p_at(0.0)
    p_dot = (p_at(h) - p_at(-h)) / (2 * h)
    p_ddot = (p_at(h) - 2 * p + p_at(-h)) / h**2
    f = cr.omega_body_from_euler_parameter_rates
    pd = lambda t: (p_at(t + 1e-6) - p_at(t - 1e-6)) / 2e-6
    alpha_body_fd = (f(p_at(h), pd(h)) - f(p_at(-h), pd(-h))) / (2 * h)
    # Nested central differences: truncation ~h^2 = 1e-8, rounding ~1e-10 / h.
    np.testing.assert_allclose(cr.alpha_body_from_euler_parameters(p, p_ddot), alpha_body_fd, atol=1e-5)
    g = cr.omega_from_euler_parameter_rates
    alpha_fd = (g(p_at(h), pd(h)) - g(p_at(-h), pd(-h))) / (2 * h)
    np.testing.assert_allclose(cr.alpha_from_euler_parameters(p, p_ddot), alpha_fd, atol=1e-5)
    # p_ddot recovered from (p, omega_body, alpha_body) satisfies both 8.57
    # and the second derivative of p . p = 1.
    omega_body = f(p, p_dot)
    alpha_body = cr.alpha_body_from_euler_parameters(p, p_ddot)
    p_ddot2 = cr.euler_parameter_accelerations(p, omega_body, alpha_body)
    np.testing.assert_allclose(cr.alpha_body_from_euler_parameters(p, p_ddot2), alpha_body, atol=1e-12)
    np.testing.assert_allclose(
        np.einsum("ni,ni->n", p, p_ddot2), -np.einsum("ni,ni->n", p_dot, p_dot), atol=1e-6
    )


def test_normalize_and_validator():
    p = np.array([[2.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]])
    np.testing.assert_allclose(cr.normalize_euler_parameters(p), [[1, 0, 0, 0], [0.5, 0.5, 0.5, 0.5]])
    # Within the stated tolerance: accepted and returned normalized.
    q = np.array([1.0 + 0.9 * cr.UNIT_NORM_TOL, 0, 0, 0])
    np.testing.assert_array_equal(cr.check_euler_parameters(q), [1.0, 0, 0, 0])
    np.testing.assert_allclose(cr.matrix_from_euler_parameters(q), np.eye(3), atol=0)
    # Beyond it: rejected, with the norm in the message.
    bad = np.array([1.0 + 1.1 * cr.UNIT_NORM_TOL, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `p` to be unit Euler parameters \(\| \|p\| - 1 \| <= 1e-06\), got norm 1\.0000011"):
        cr.check_euler_parameters(bad)
    with pytest.raises(ValueError, match=r"use normalize_euler_parameters"):
        cr.matrix_from_euler_parameters(bad)
    with pytest.raises(ValueError, match=r"Expected `p` to have non-zero norm, got norm 0\.0 at batch index \(1,\)"):
        cr.normalize_euler_parameters([[1.0, 0, 0, 0], [0, 0, 0, 0]])
    with pytest.raises(ValueError, match=r"Expected `p` to be finite, got nan"):
        cr.normalize_euler_parameters([np.nan, 0, 0, 0])


def test_canonical_euler_parameters():
    p = np.array([[-0.5, 0.5, 0.5, 0.5], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, -1.0], [0.5, -0.5, 0.5, 0.5]])
    c = cr.canonical_euler_parameters(p)
    np.testing.assert_array_equal(c, [[0.5, -0.5, -0.5, -0.5], [0, 1, 0, 0], [0, 0, 0, 1], [0.5, -0.5, 0.5, 0.5]])
    np.testing.assert_array_equal(cr.canonical_euler_parameters(-p), c)


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes(batch):
    rng = np.random.default_rng(18)
    p = _unit(rng, batch)
    A = cr.matrix_from_euler_parameters(p)
    assert A.shape == batch + (3, 3)
    assert cr.euler_parameters_from_matrix(A).shape == batch + (4,)
    assert cr.euler_parameter_G(p).shape == batch + (3, 4)
    assert cr.euler_parameter_G_bar(p).shape == batch + (3, 4)
    assert cr.euler_parameter_rates(p, np.ones(3)).shape == batch + (4,)
    axis, angle = cr.axis_angle_from_euler_parameters(p)
    assert axis.shape == batch + (3,) and angle.shape == batch
    assert cr.euler_parameters_from_axis_angle(axis, angle).shape == batch + (4,)
    np.testing.assert_allclose(
        A.reshape(-1, 3, 3),
        Rotation.from_quat(p.reshape(-1, 4), scalar_first=True).as_matrix(),
        atol=1e-15,
    )


def test_matrix_validation_errors():
    with pytest.raises(ValueError, match=r"Expected `A` to have shape \(\.\.\., 3, 3\), got shape \(3, 4\)"):
        cr.euler_parameters_from_matrix(np.zeros((3, 4)))
    A = np.broadcast_to(np.eye(3), (2, 3, 3)).copy()
    A[1, 0, 0] = 1.1
    with pytest.raises(ValueError, match=r"Expected `A` to be orthogonal \(max \|A A\^T - I\| <= 1e-06\), got deviation 0\.21 at batch index \(1,\)"):
        cr.euler_parameters_from_matrix(A)
    with pytest.raises(ValueError, match=r"Expected `A` to have determinant \+1 \(a proper rotation\), got determinant -1 at batch index \(0,\)"):
        cr.euler_parameters_from_matrix(np.diag([1.0, 1.0, -1.0])[None])
    A[1, 0, 0] = np.inf
    with pytest.raises(ValueError, match=r"Expected `A` to be finite, got inf"):
        cr.euler_parameters_from_matrix(A)
    with pytest.raises(ValueError, match=r"Expected `p` to have shape \(\.\.\., 4\), got shape \(3,\)"):
        cr.matrix_from_euler_parameters([1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"Expected `p` to be finite, got nan in \[nan, 0\.0, 0\.0, 0\.0\] at batch index \(0, 1\)"):
        cr.matrix_from_euler_parameters(np.array([[[1.0, 0, 0, 0], [np.nan, 0, 0, 0]]]))
    with pytest.raises(ValueError, match=r"Expected `p` to be unit Euler parameters .* got norm 2\.0 at batch index \(1,\)"):
        cr.euler_parameter_G([[1.0, 0, 0, 0], [2.0, 0, 0, 0]])
    with pytest.raises(ValueError, match=r"Expected `omega_body` to have shape \(\.\.\., 3\), got shape \(4,\)"):
        cr.euler_parameter_rates([1.0, 0, 0, 0], [1.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"Expected `A` to be an array of real numbers"):
        cr.euler_parameters_from_matrix("identity")
