"""Euler angles, all 12 sequences x intrinsic/extrinsic, against scipy and finite differences."""

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigidlab.core.rotations as cr

BASE = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ"]
SEQS = BASE + [s.lower() for s in BASE]
N = 1000


def _is_proper(seq):
    return seq[0].lower() == seq[2].lower()


def _random_angles(rng, seq, n):
    """Angles in the ranges euler_angles_from_matrix returns, away from gimbal lock."""
    a = rng.uniform(-np.pi, np.pi, size=(n, 3))
    if _is_proper(seq):
        a[:, 1] = rng.uniform(0.05, np.pi - 0.05, size=n)
    else:
        a[:, 1] = rng.uniform(-np.pi / 2 + 0.05, np.pi / 2 - 0.05, size=n)
    return a


def _vee(W):
    return np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)


@pytest.mark.parametrize("seq", SEQS)
def test_matrix_from_euler_angles_matches_scipy(seq):
    rng = np.random.default_rng(abs(hash(seq)) % 2**32)
    angles = rng.uniform(-4.0, 4.0, size=(N, 3))
    ours = cr.matrix_from_euler_angles(angles, seq)
    ref = Rotation.from_euler(seq, angles).as_matrix()
    # Entries are O(1) sums of products of sines and cosines computed by two
    # different float64 paths: a few ulp of 1.
    np.testing.assert_allclose(ours, ref, rtol=0, atol=2e-15)


@pytest.mark.parametrize("seq", SEQS)
def test_euler_angles_from_matrix_matches_scipy_and_round_trips(seq):
    rng = np.random.default_rng(1 + abs(hash(seq)) % 2**32)
    angles = _random_angles(rng, seq, N)
    A = Rotation.from_euler(seq, angles).as_matrix()
    ours = cr.euler_angles_from_matrix(A, seq)
    ref = Rotation.from_matrix(A).as_euler(seq)
    # Away from gimbal lock (middle angle >= 0.05 from singular), angles are
    # well conditioned: errors of a few ulp amplified by 1 / sin(0.05) ~ 20.
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-13)
    np.testing.assert_allclose(ours, angles, rtol=0, atol=1e-13)
    np.testing.assert_allclose(cr.matrix_from_euler_angles(ours, seq), A, atol=2e-15)


@pytest.mark.parametrize("seq", SEQS)
def test_euler_parameters_from_euler_angles_match_scipy(seq):
    rng = np.random.default_rng(2 + abs(hash(seq)) % 2**32)
    angles = rng.uniform(-4.0, 4.0, size=(N, 3))
    p = cr.euler_parameters_from_euler_angles(angles, seq)
    ref = Rotation.from_euler(seq, angles).as_quat(scalar_first=True)
    ref = ref * np.where(ref[:, :1] < 0, -1.0, 1.0)
    assert (p[:, 0] >= 0).all()
    np.testing.assert_allclose(p, ref, rtol=0, atol=2e-15)
    back = cr.euler_angles_from_euler_parameters(p, seq)
    np.testing.assert_allclose(
        cr.matrix_from_euler_angles(back, seq), cr.matrix_from_euler_parameters(p), atol=2e-15
    )


def test_zxz_is_precession_nutation_spin():
    phi, theta, psi = 0.3, 1.1, -0.7
    Rz = lambda a: np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = lambda a: np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    expected = Rz(phi) @ Rx(theta) @ Rz(psi)
    np.testing.assert_allclose(cr.matrix_from_euler_angles([phi, theta, psi]), expected, atol=1e-15)
    # Extrinsic zxz with the same angles applies them about fixed axes.
    np.testing.assert_allclose(
        cr.matrix_from_euler_angles([phi, theta, psi], "zxz"), Rz(psi) @ Rx(theta) @ Rz(phi), atol=1e-15
    )


@pytest.mark.parametrize("seq", SEQS)
def test_edge_cases_identity_and_pi(seq):
    for angles in ([0.0, 0.0, 0.0], [np.pi, 0.3, 0.0], [0.2, 0.3, np.pi], [-np.pi, 1.0, np.pi]):
        np.testing.assert_allclose(
            cr.matrix_from_euler_angles(angles, seq),
            Rotation.from_euler(seq, angles).as_matrix(),
            atol=2e-15,
        )


@pytest.mark.parametrize("seq", SEQS)
def test_gimbal_lock_warns_and_keeps_the_matrix(seq):
    rng = np.random.default_rng(3)
    singular = [0.0, np.pi] if _is_proper(seq) else [np.pi / 2, -np.pi / 2]
    for middle in singular:
        angles = np.array([rng.uniform(-3, 3), middle, rng.uniform(-3, 3)])
        A = cr.matrix_from_euler_angles(angles, seq)
        with pytest.warns(cr.GimbalLockWarning, match="third angle is set to zero"):
            back = cr.euler_angles_from_matrix(A, seq)
        # The documented choice: third angle zero, matrix unchanged, middle
        # angle in its documented range.
        assert back[2] == 0.0
        assert abs(back[1] - middle) < 1e-7
        np.testing.assert_allclose(cr.matrix_from_euler_angles(back, seq), A, atol=1e-14)


def test_no_warning_away_from_gimbal_lock():
    A = cr.matrix_from_euler_angles([0.1, 0.5, 0.2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cr.euler_angles_from_matrix(A)


@pytest.mark.parametrize("seq", SEQS)
def test_G_and_G_bar_match_finite_differences(seq):
    rng = np.random.default_rng(4 + abs(hash(seq)) % 2**32)
    n = 50
    a0 = _random_angles(rng, seq, n)
    a1 = rng.normal(size=(n, 3))
    a2 = rng.normal(size=(n, 3))
    angles_at = lambda t: a0 + a1 * t + a2 * t**2
    h = 1e-5
    A = cr.matrix_from_euler_angles(angles_at(0.0), seq)
    A_dot = (
        cr.matrix_from_euler_angles(angles_at(h), seq) - cr.matrix_from_euler_angles(angles_at(-h), seq)
    ) / (2 * h)
    omega_fd = _vee(A_dot @ np.swapaxes(A, -1, -2))
    omega_body_fd = _vee(np.swapaxes(A, -1, -2) @ A_dot)
    rates = a1
    # Central differences: truncation O(h^2) ~ 1e-10, rounding eps / h ~ 1e-11.
    G = cr.euler_angle_G(a0, seq)
    G_bar = cr.euler_angle_G_bar(a0, seq)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", G, rates), omega_fd, atol=1e-8)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", G_bar, rates), omega_body_fd, atol=1e-8)
    np.testing.assert_allclose(cr.omega_from_euler_angle_rates(a0, rates, seq), omega_fd, atol=1e-8)
    np.testing.assert_allclose(
        cr.omega_body_from_euler_angle_rates(a0, rates, seq), omega_body_fd, atol=1e-8
    )
    # G_bar = A^T G (frames differ only by the rotation).
    np.testing.assert_allclose(G_bar, np.swapaxes(A, -1, -2) @ G, atol=1e-15)


def test_zxz_G_closed_forms():
    phi, theta, psi = 0.4, 0.9, -1.3
    G = np.array(
        [
            [0, np.cos(phi), np.sin(theta) * np.sin(phi)],
            [0, np.sin(phi), -np.sin(theta) * np.cos(phi)],
            [1, 0, np.cos(theta)],
        ]
    )
    G_bar = np.array(
        [
            [np.sin(theta) * np.sin(psi), np.cos(psi), 0],
            [np.sin(theta) * np.cos(psi), -np.sin(psi), 0],
            [np.cos(theta), 0, 1],
        ]
    )
    np.testing.assert_allclose(cr.euler_angle_G([phi, theta, psi]), G, atol=1e-15)
    np.testing.assert_allclose(cr.euler_angle_G_bar([phi, theta, psi]), G_bar, atol=1e-15)


@pytest.mark.parametrize("seq", SEQS)
def test_alpha_matches_finite_differences_of_omega(seq):
    rng = np.random.default_rng(5 + abs(hash(seq)) % 2**32)
    n = 50
    a0 = _random_angles(rng, seq, n)
    a1 = rng.normal(size=(n, 3))
    a2 = rng.normal(size=(n, 3))
    angles_at = lambda t: a0 + a1 * t + a2 * t**2
    rates_at = lambda t: a1 + 2 * a2 * t
    h = 1e-5
    for body, f_omega, f_alpha in (
        (False, cr.omega_from_euler_angle_rates, cr.alpha_from_euler_angle_rates),
        (True, cr.omega_body_from_euler_angle_rates, cr.alpha_body_from_euler_angle_rates),
    ):
        fd = (f_omega(angles_at(h), rates_at(h), seq) - f_omega(angles_at(-h), rates_at(-h), seq)) / (2 * h)
        alpha = f_alpha(a0, a1, 2 * a2, seq)
        # Same finite-difference error budget as for G.
        np.testing.assert_allclose(alpha, fd, atol=1e-7, err_msg=f"body={body}")


@pytest.mark.parametrize("seq", SEQS)
def test_rates_omega_rates_round_trip(seq):
    rng = np.random.default_rng(6 + abs(hash(seq)) % 2**32)
    angles = _random_angles(rng, seq, N)
    rates = rng.normal(size=(N, 3))
    omega = cr.omega_from_euler_angle_rates(angles, rates, seq)
    omega_body = cr.omega_body_from_euler_angle_rates(angles, rates, seq)
    # Conditioning 1 / |det G| <= 1 / sin(0.05) = 20 on O(1) values.
    np.testing.assert_allclose(cr.euler_angle_rates_from_omega(angles, omega, seq), rates, atol=1e-12)
    np.testing.assert_allclose(cr.euler_angle_rates(angles, omega_body, seq), rates, atol=1e-12)


@pytest.mark.parametrize("seq", ["ZXZ", "zyx", "XYX", "YZX"])
def test_singularity_predicate_and_error(seq):
    middle = 0.0 if _is_proper(seq) else np.pi / 2
    angles = np.array([[0.3, middle, 0.2], [0.3, middle + 0.5, 0.2]])
    near = cr.euler_angles_near_singularity(angles, seq, 1e-6)
    np.testing.assert_array_equal(near, [True, False])
    # The predicate agrees with |det G|.
    detG = np.abs(np.linalg.det(cr.euler_angle_G(angles, seq)))
    np.testing.assert_allclose(detG, [0.0, abs(np.sin(0.5))], atol=1e-15)
    with pytest.raises(ValueError, match=r"Expected `angles` away from the singular configuration .* batch index \(0,\)"):
        cr.euler_angle_rates_from_omega(angles, [0.0, 0.0, 1.0], seq)
    with pytest.raises(ValueError, match=r"angle rates are not defined there"):
        cr.euler_angle_rates(angles[0], [0.0, 0.0, 1.0], seq)


def test_problem_rates_of_euler_angles_from_given_omega():
    # P10-P11: body rotating with omega_body = (1, 2, 3) rad/s at ZXZ angles
    # (0.5, 1.0, -0.4). The oracle propagates the rotation itself with
    # scipy, A(t) = A(0) expm(skew(omega_body t)), and differentiates the
    # angles scipy extracts from it.
    angles = np.array([0.5, 1.0, -0.4])
    omega_body = np.array([1.0, 2.0, 3.0])
    A0 = Rotation.from_euler("ZXZ", angles)
    h = 1e-6
    ang = lambda t: (A0 * Rotation.from_rotvec(omega_body * t)).as_euler("ZXZ")
    fd = (ang(h) - ang(-h)) / (2 * h)
    # Central difference, h = 1e-6: truncation ~1e-12, rounding ~1e-10.
    np.testing.assert_allclose(cr.euler_angle_rates(angles, omega_body), fd, atol=1e-8)
    omega = A0.as_matrix() @ omega_body
    np.testing.assert_allclose(cr.euler_angle_rates_from_omega(angles, omega), fd, atol=1e-8)


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes(batch):
    rng = np.random.default_rng(8)
    angles = rng.uniform(0.1, 1.0, size=batch + (3,))
    A = cr.matrix_from_euler_angles(angles, "ZXZ")
    assert A.shape == batch + (3, 3)
    assert cr.euler_angles_from_matrix(A, "ZXZ").shape == batch + (3,)
    assert cr.euler_angle_G(angles).shape == batch + (3, 3)
    assert cr.euler_angle_G_bar(angles).shape == batch + (3, 3)
    assert cr.euler_angles_near_singularity(angles, "ZXZ", 1e-6).shape == batch
    assert cr.euler_parameters_from_euler_angles(angles).shape == batch + (4,)
    rates = np.ones(batch + (3,))
    assert cr.alpha_from_euler_angle_rates(angles, rates, rates).shape == batch + (3,)
    assert cr.euler_angle_rates(angles, rates).shape == batch + (3,)
    flat = angles.reshape(-1, 3)
    np.testing.assert_allclose(
        A.reshape(-1, 3, 3), Rotation.from_euler("ZXZ", flat).as_matrix(), atol=2e-15
    )


@pytest.mark.parametrize(
    "seq, match",
    [
        ("ZX", r"Expected `seq` to be a string of 3 axes such as 'ZXZ', got 'ZX'"),
        (3, r"Expected `seq` to be a string of 3 axes such as 'ZXZ', got 3"),
        ("ZxZ", r"Expected `seq` axes all from 'XYZ' \(intrinsic\) or all from 'xyz' \(extrinsic\), got 'ZxZ'"),
        ("ZAZ", r"got 'ZAZ'"),
        ("ZZX", r"Expected consecutive axes of `seq` to be different, got 'ZZX'"),
    ],
)
def test_bad_sequence_errors(seq, match):
    with pytest.raises(ValueError, match=match):
        cr.matrix_from_euler_angles([0.1, 0.2, 0.3], seq)


def test_angle_errors_name_the_argument():
    with pytest.raises(ValueError, match=r"Expected `angles` to have shape \(\.\.\., 3\), got shape \(2,\)"):
        cr.matrix_from_euler_angles([0.1, 0.2])
    with pytest.raises(ValueError, match=r"Expected `angles` to be finite, got nan in \[0.1, nan, 0.3\] at batch index \(1,\)"):
        cr.matrix_from_euler_angles([[0.1, 0.2, 0.3], [0.1, np.nan, 0.3]])
    with pytest.raises(ValueError, match=r"Expected `angles` to be an array of real numbers"):
        cr.matrix_from_euler_angles(["a", "b", "c"])
    with pytest.raises(ValueError, match=r"Expected `rates` to be finite, got inf"):
        cr.omega_from_euler_angle_rates([0.1, 0.2, 0.3], [np.inf, 0, 0])
    with pytest.raises(ValueError, match=r"Expected broadcastable batch shapes, got `angles` batch \(2,\), `omega` batch \(3,\)"):
        cr.euler_angle_rates_from_omega(np.ones((2, 3)), np.ones((3, 3)))


@pytest.mark.parametrize("seq", ["ZXZ", "zxz", "ZYX", "xyz"])
def test_near_gimbal_lock_within_tolerance(seq):
    # Within GIMBAL_LOCK_TOL of the singular middle angle the warning fires
    # and the matrix is still reproduced to round-off.
    singular = 0.0 if _is_proper(seq) else np.pi / 2
    for offset in (1e-9, 5e-8):
        angles = np.array([0.4, singular + offset if singular == 0.0 else singular - offset, -1.2])
        A = cr.matrix_from_euler_angles(angles, seq)
        with pytest.warns(cr.GimbalLockWarning):
            back = cr.euler_angles_from_matrix(A, seq)
        np.testing.assert_allclose(cr.matrix_from_euler_angles(back, seq), A, rtol=0, atol=2e-15)
    # Just outside it: no warning, angles recovered (conditioning 1 / offset).
    angles = np.array([0.4, singular + 1e-5 if singular == 0.0 else singular - 1e-5, -1.2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = cr.euler_angles_from_matrix(cr.matrix_from_euler_angles(angles, seq), seq)
    np.testing.assert_allclose(back, angles, atol=1e-9)


BOOL_ANGLE_CALLS = [
    (cr.matrix_from_euler_angles, ([True, False, True],), "angles", r"in \[True, False, True\]"),
    (cr.matrix_from_euler_angles, (np.array([True, False, True]),), "angles", r"in array\(\[ True, False,  True\]\)"),
    (cr.matrix_from_euler_angles, ([0.1, np.True_, 0.2],), "angles", r"in \[0.1, np.True_, 0.2\]"),
    (cr.matrix_from_euler_angles, ([[0.1, 0.2, 0.3], [0.1, True, 0.3]],), "angles", "in"),
    (cr.euler_parameters_from_euler_angles, ([0.1, True, 0.2],), "angles", "in"),
    (cr.euler_angle_G, ([True, 0.2, 0.3],), "angles", "in"),
    (cr.euler_angle_G_bar, ([0.1, 0.2, False],), "angles", "in"),
    (cr.euler_angles_near_singularity, ([0.1, True, 0.3],), "angles", "in"),
    (cr.omega_from_euler_angle_rates, ([0.1, 0.2, 0.3], [True, 0.0, 0.0]), "rates", "in"),
    (cr.euler_angle_rates, ([0.1, 0.5, 0.3], [0.0, False, 0.0]), "omega_body", "in"),
    (cr.matrix_from_axis_angle, ([0.0, 0.0, 1.0], True), "angle", r"True"),
    (cr.elementary_matrix, (2, np.True_), "angle", r"np.True_"),
]


@pytest.mark.parametrize(
    "f, args, name, shown", BOOL_ANGLE_CALLS, ids=[f"{f.__name__}-{k}" for k, (f, *_) in enumerate(BOOL_ANGLE_CALLS)]
)
def test_boolean_angles_are_refused(f, args, name, shown):
    # True is not the angle 1 rad: numpy would silently turn it into 1.0.
    with pytest.raises(ValueError, match=rf"Expected `{name}` to be an array of real numbers, got a boolean {shown}"):
        f(*args)


def _lock_offsets(seq, offset):
    """Middle angles ``offset`` rad inside the documented range from each singular value of ``seq``."""
    if _is_proper(seq):
        return [0.0 + offset, np.pi - offset]
    return [np.pi / 2 - offset, -np.pi / 2 + offset]


@pytest.mark.parametrize("seq", SEQS)
def test_angles_at_and_near_gimbal_lock_rebuild_the_matrix_to_round_off(seq):
    # Within GIMBAL_LOCK_TOL the first and third angles are ill-conditioned
    # separately, but the matrix depends on their difference (or sum) only
    # through sin(distance): angles taken from the full quaternion rebuild it
    # to a few ulps at every distance. (Zeroing the third angle there, as
    # scipy does, misses by about the distance: 1e-9 at 1e-9 rad.)
    rng = np.random.default_rng(abs(hash(seq)) % 2**32)
    for offset in (0.0, 1e-12, 1e-9, 1e-7, 1e-5):
        for middle in _lock_offsets(seq, offset):
            angles = np.array([rng.uniform(-3, 3), middle, rng.uniform(-3, 3)])
            A = cr.matrix_from_euler_angles(angles, seq)
            reference = Rotation.from_euler(seq, angles).as_matrix()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                single = cr.euler_angles_from_matrix(A, seq)
                batch = cr.euler_angles_from_matrix(A[None], seq)[0]
                from_p = cr.euler_angles_from_euler_parameters(cr.euler_parameters_from_matrix(A), seq)
            locked = [w for w in caught if issubclass(w.category, cr.GimbalLockWarning)]
            if offset <= 1e-9:
                assert len(locked) == 3 and "within GIMBAL_LOCK_TOL" in str(locked[0].message)
            if offset >= 1e-5:
                assert not locked
                # away from lock: scipy's angles (the same formulas)
                ref_angles = Rotation.from_matrix(A).as_euler(seq)
                np.testing.assert_allclose(single, ref_angles, rtol=0, atol=1e-10)
            for back in (single, batch, from_p):
                np.testing.assert_allclose(cr.matrix_from_euler_angles(back, seq), A, rtol=0, atol=2e-15)
                np.testing.assert_allclose(Rotation.from_euler(seq, back).as_matrix(), reference, rtol=0, atol=3e-15)
                assert abs(back[1] - middle) <= 4e-15  # the middle angle is well conditioned
            if offset == 0.0:
                # exactly singular: the documented choice, third angle zero
                assert single[2] == batch[2] == 0.0
