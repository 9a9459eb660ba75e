"""Rodriguez formula (Eqs. 8.29-8.38) and the chapter's problems P1-P4."""

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

N = 1000


def _axes(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _vee(W):
    return np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)


def test_skew_is_the_cross_product_matrix():
    rng = np.random.default_rng(20)
    a = rng.normal(size=(N, 3))
    b = rng.normal(size=(N, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", cr.skew(a), b), np.cross(a, b), atol=1e-14)
    np.testing.assert_array_equal(cr.vector_from_skew(cr.skew(a)), a)
    with pytest.raises(ValueError, match=r"Expected `S` to be skew-symmetric \(max \|S \+ S\^T\| <= 1e-09\), got 2"):
        cr.vector_from_skew(np.eye(3))
    with pytest.raises(ValueError, match=r"Expected `S` to have shape \(\.\.\., 3, 3\), got shape \(3,\)"):
        cr.vector_from_skew(np.zeros(3))
    with pytest.raises(ValueError, match=r"Expected `S` to be finite, got nan in \[\[0\.0, nan, 0\.0\]"):
        cr.vector_from_skew([[0.0, np.nan, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"Expected `v` to have shape \(\.\.\., 3\), got shape \(2,\)"):
        cr.skew([1.0, 2.0])


def test_rodriguez_formula_matches_scipy_and_textbook_form():
    rng = np.random.default_rng(21)
    axis = _axes(rng, N)
    angle = rng.uniform(-2 * np.pi, 2 * np.pi, size=N)
    A = cr.matrix_from_axis_angle(axis, angle)
    # scipy's path (rotation vector -> quaternion -> matrix) carries ~1e-15
    # of its own rounding on O(1) entries.
    np.testing.assert_allclose(A, Rotation.from_rotvec(axis * angle[:, None]).as_matrix(), atol=3e-15)
    v = cr.skew(axis)
    textbook = (
        np.eye(3)
        + v * np.sin(angle)[:, None, None]
        + 2 * (v @ v) * (np.sin(angle / 2) ** 2)[:, None, None]
    )
    np.testing.assert_allclose(A, textbook, atol=2e-15)
    # Independent oracle: the matrix exponential of angle * skew(axis).
    for i in range(0, N, 100):
        np.testing.assert_allclose(A[i], expm(angle[i] * v[i]), atol=1e-14)


def test_problem_1_rodriguez_matrix_is_orthogonal():
    rng = np.random.default_rng(22)
    A = cr.matrix_from_axis_angle(_axes(rng, N), rng.uniform(-10, 10, size=N))
    np.testing.assert_allclose(A @ np.swapaxes(A, -1, -2), np.broadcast_to(np.eye(3), A.shape), atol=2e-15)
    np.testing.assert_allclose(np.linalg.det(A), 1.0, atol=2e-15)


def test_problem_2_axis_is_eigenvector_with_eigenvalue_one():
    rng = np.random.default_rng(23)
    axis = _axes(rng, N)
    A = cr.matrix_from_axis_angle(axis, rng.uniform(0.1, 3.0, size=N))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", A, axis), axis, atol=2e-15)
    # And numpy's eigen-solver finds eigenvalue 1 with that eigenvector.
    w, V = np.linalg.eig(A[:20])
    k = np.argmin(np.abs(w - 1.0), axis=-1)
    vec = np.real(V[np.arange(20), :, k])
    vec /= np.linalg.norm(vec, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.einsum("ni,ni->n", vec, axis[:20])), 1.0, atol=1e-12)


def test_problem_3_infinitesimal_rotation_is_identity_plus_skew():
    rng = np.random.default_rng(24)
    axis = _axes(rng, 10)
    for theta in (1e-2, 1e-3, 1e-4):
        A = cr.matrix_from_axis_angle(axis, theta)
        approx = np.eye(3) + cr.skew(axis * theta)
        err = np.abs(A - approx).max()
        # The remainder is v~^2 theta^2 / 2: second order, bounded by theta^2.
        assert err <= theta**2
        assert err >= 0.1 * theta**2


def test_problem_4_finite_rotations_do_not_commute():
    A1 = cr.matrix_from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)
    A2 = cr.matrix_from_axis_angle([0.0, 1.0, 0.0], np.pi / 2)
    assert np.abs(A1 @ A2 - A2 @ A1).max() > 0.5
    # Infinitesimal rotations commute to first order: the commutator is
    # second order in the angles.
    for eps in (1e-3, 1e-4):
        B1 = cr.matrix_from_axis_angle([1.0, 0.0, 0.0], eps)
        B2 = cr.matrix_from_axis_angle([0.0, 1.0, 0.0], eps)
        assert np.abs(B1 @ B2 - B2 @ B1).max() <= 1.01 * eps**2


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-6, 1.0, np.pi - 1e-6, np.pi - 1e-10, np.pi])
def test_axis_angle_from_matrix_is_robust_near_zero_and_pi(angle):
    rng = np.random.default_rng(25)
    axis = _axes(rng, 200)
    A = cr.matrix_from_axis_angle(axis, angle)
    axis2, angle2 = cr.axis_angle_from_matrix(A)
    np.testing.assert_allclose(angle2, angle, atol=2e-15)
    np.testing.assert_allclose(cr.matrix_from_axis_angle(axis2, angle2), A, atol=2e-15)
    if angle >= 1e-6:
        # Near pi the axis is still recovered (up to sign at exactly pi,
        # where both are the same rotation) to rounding over sin(angle).
        sign = np.sign(np.einsum("ni,ni->n", axis2, axis))
        np.testing.assert_allclose(axis2 * sign[:, None], axis, atol=1e-9 if angle < 1e-5 else 1e-14)
    if angle == 0.0:
        np.testing.assert_array_equal(axis2, np.broadcast_to([0.0, 0.0, 1.0], (200, 3)))
    ours = axis2 * angle2[:, None]
    ref = Rotation.from_matrix(A).as_rotvec()
    if angle == np.pi:
        # At exactly pi, r and -r are the same rotation; scipy may pick either.
        ref = ref * np.sign(np.einsum("ni,ni->n", ours, ref))[:, None]
    np.testing.assert_allclose(ours, ref, atol=3e-15)


def test_omega_from_axis_angle_rates_against_finite_differences():
    rng = np.random.default_rng(26)
    n = 100
    a0 = rng.normal(size=(n, 3))
    a1 = rng.normal(size=(n, 3))
    th0 = rng.uniform(-3, 3, size=n)
    th1 = rng.normal(size=n)
    axis_at = lambda t: (a0 + a1 * t) / np.linalg.norm(a0 + a1 * t, axis=-1, keepdims=True)
    angle_at = lambda t: th0 + th1 * t + 0.3 * t**2
    h = 1e-5
    axis = axis_at(0.0)
    axis_dot = (axis_at(h) - axis_at(-h)) / (2 * h)
    angle_dot = (angle_at(h) - angle_at(-h)) / (2 * h)
    axis_dot -= np.einsum("ni,ni->n", axis_dot, axis)[:, None] * axis  # remove O(h^2) drift
    A = cr.matrix_from_axis_angle(axis, angle_at(0.0))
    A_dot = (cr.matrix_from_axis_angle(axis_at(h), angle_at(h)) - cr.matrix_from_axis_angle(axis_at(-h), angle_at(-h))) / (2 * h)
    omega_fd = _vee(A_dot @ np.swapaxes(A, -1, -2))
    omega_body_fd = _vee(np.swapaxes(A, -1, -2) @ A_dot)
    # Central differences, h = 1e-5: truncation ~1e-10, rounding ~1e-11.
    omega = cr.omega_from_axis_angle_rates(axis, angle_at(0.0), axis_dot, angle_dot)
    omega_body = cr.omega_body_from_axis_angle_rates(axis, angle_at(0.0), axis_dot, angle_dot)
    np.testing.assert_allclose(omega, omega_fd, atol=1e-8)
    np.testing.assert_allclose(omega_body, omega_body_fd, atol=1e-8)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", A, omega_body), omega, atol=1e-13)


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes_and_broadcasting(batch):
    rng = np.random.default_rng(27)
    axis = _axes(rng, int(np.prod(batch, dtype=int))).reshape(batch + (3,))
    angle = rng.uniform(-3, 3, size=batch)
    A = cr.matrix_from_axis_angle(axis, angle)
    assert A.shape == batch + (3, 3)
    ax2, an2 = cr.axis_angle_from_matrix(A)
    assert ax2.shape == batch + (3,) and an2.shape == batch
    # One axis, many angles broadcast.
    B = cr.matrix_from_axis_angle([0.0, 0.0, 1.0], angle)
    assert B.shape == batch + (3, 3)
    np.testing.assert_allclose(B[..., 2, 2], 1.0)
    np.testing.assert_allclose(
        A.reshape(-1, 3, 3),
        Rotation.from_rotvec((axis * angle[..., None]).reshape(-1, 3)).as_matrix(),
        atol=3e-15,
    )


def test_axis_angle_errors():
    with pytest.raises(ValueError, match=r"Expected `axis` to be a unit vector \(\| \|axis\| - 1 \| <= 1e-06\), got norm 2\.0 at batch index \(1,\)"):
        cr.matrix_from_axis_angle([[1.0, 0, 0], [2.0, 0, 0]], [0.1, 0.2])
    with pytest.raises(ValueError, match=r"Expected `axis` to have shape \(\.\.\., 3\), got shape \(2,\)"):
        cr.matrix_from_axis_angle([1.0, 0.0], 0.1)
    with pytest.raises(ValueError, match=r"Expected `angle` to be finite, got inf at batch index \(0,\)"):
        cr.matrix_from_axis_angle([[1.0, 0, 0]], [np.inf])
    with pytest.raises(ValueError, match=r"Expected `axis` to be finite, got nan"):
        cr.matrix_from_axis_angle([np.nan, 0, 0], 1.0)
    with pytest.raises(ValueError, match=r"Expected broadcastable batch shapes, got `axis` batch \(2,\), `angle` batch \(3,\)"):
        cr.matrix_from_axis_angle(np.eye(3)[:2], np.zeros(3))
    with pytest.raises(ValueError, match=r"Expected `axis_dot` to be perpendicular to `axis` .* got axis \. axis_dot = 1"):
        cr.omega_from_axis_angle_rates([1.0, 0, 0], 0.3, [1.0, 0, 0], 0.0)
    with pytest.raises(ValueError, match=r"Expected `axis` to be a unit vector"):
        cr.euler_parameters_from_axis_angle([0.0, 0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match=r"Expected `axis` to be 0, 1 or 2, got 3"):
        cr.elementary_matrix(3, 0.1)
    assert cr.is_rotation_matrix(cr.elementary_matrix(2, 0.3))
    assert not cr.is_rotation_matrix(np.diag([1.0, 1.0, -1.0]))


def test_axis_of_a_subnormal_rotation_is_unit():
    # A vector part of (5e-324, 5e-324, 0): its hypot rounds to 5e-324 on
    # the subnormal grid, and dividing by it gave the axis (1, 1, 0) of norm
    # sqrt(2), which matrix_from_axis_angle then refused (found by hypothesis).
    p = np.array([1.0, 5e-324, 5e-324, 0.0])
    A = cr.matrix_from_euler_parameters(p)
    for axis, angle in (cr.axis_angle_from_euler_parameters(p), cr.axis_angle_from_matrix(A)):
        np.testing.assert_allclose(axis, [2**-0.5, 2**-0.5, 0.0], rtol=0, atol=2e-16)
        assert 0.0 < angle < 1e-322
        np.testing.assert_allclose(cr.matrix_from_axis_angle(axis, angle), np.eye(3), rtol=0, atol=1e-300)
    axes, _ = cr.axis_angle_from_euler_parameters(np.stack([p, -p, [1.0, 0.0, -5e-324, 0.0]]))
    np.testing.assert_allclose(np.linalg.norm(axes, axis=-1), 1.0, rtol=0, atol=2e-16)
