"""rigidlab.core.gyroscope: equations of motion, invariants, steady precession, errors.

Oracles: a finite-difference Euler-Lagrange derivation from the kinetic
energy (Eq. 8.14) and potential, closed-form conditions of steady precession,
conservation laws, and element-by-element evaluation for batches.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.gyroscope import (
    RotorParams,
    equations_of_motion,
    invariants,
    nutation,
    rotor_vectors,
    simulate,
    sleeping_top_critical_spin,
    steady_precession_rates,
    steady_precession_torque,
)

RNG_SEED = 20241122


def lagrangian(params: RotorParams, q: np.ndarray, qd: np.ndarray) -> float:
    """T (Eq. 8.14) minus V = mgl cos(theta), written from scratch."""
    _, theta, _ = q
    phid, thetad, psid = qd
    omega3 = psid + phid * math.cos(theta)
    T = 0.5 * params.I * (thetad**2 + phid**2 * math.sin(theta) ** 2) + 0.5 * params.I3 * omega3**2
    return T - params.mgl * math.cos(theta)


def euler_lagrange_fd(params: RotorParams, q: np.ndarray, qd: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Accelerations from d/dt dL/dqd - dL/dq = Q by central differences of L.

    M qdd = Q + dL/dq - (d^2 L / dqd dq) qd, with M = d^2 L / dqd^2.
    """
    h = 1e-4
    E = np.eye(3)

    def L(qq, vv):
        return lagrangian(params, qq, vv)

    M = np.empty((3, 3))
    C = np.empty((3, 3))  # C[i, j] = d^2 L / dqd_i dq_j
    dLdq = np.empty(3)
    for i in range(3):
        dLdq[i] = (L(q + h * E[i], qd) - L(q - h * E[i], qd)) / (2 * h)
        for j in range(3):
            M[i, j] = (
                L(q, qd + h * E[i] + h * E[j]) - L(q, qd + h * E[i] - h * E[j])
                - L(q, qd - h * E[i] + h * E[j]) + L(q, qd - h * E[i] - h * E[j])
            ) / (4 * h * h)
            C[i, j] = (
                L(q + h * E[j], qd + h * E[i]) - L(q - h * E[j], qd + h * E[i])
                - L(q + h * E[j], qd - h * E[i]) + L(q - h * E[j], qd - h * E[i])
            ) / (4 * h * h)
    return np.linalg.solve(M, Q + dLdq - C @ qd)


def test_equations_of_motion_match_finite_difference_euler_lagrange():
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(20):
        I = rng.uniform(0.5, 2.0)
        params = RotorParams(I=I, I3=rng.uniform(0.2, 2.0 * I), mgl=rng.uniform(0.0, 3.0))
        q = np.array([rng.uniform(-3, 3), rng.uniform(0.3, 2.8), rng.uniform(-3, 3)])
        qd = rng.uniform(-3, 3, size=3)
        Q = rng.uniform(-1, 1, size=3)
        got = equations_of_motion(params, np.r_[q, qd], Q)
        want = euler_lagrange_fd(params, q, qd, Q)
        # central second differences with h = 1e-4 on O(1..10) terms: truncation
        # ~h^2 * |L''''| ~ 1e-7, round-off ~ eps |L| / h^2 ~ 1e-8.
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)


def test_equations_of_motion_batch_and_broadcast():
    rng = np.random.default_rng(RNG_SEED + 1)
    params = RotorParams(I=1.2, I3=0.7, mgl=0.9)
    for shape in [(), (1,), (3, 1, 2, 1)]:
        states = np.concatenate([
            rng.uniform(-1, 1, size=shape + (1,)),
            rng.uniform(0.2, 2.9, size=shape + (1,)),
            rng.uniform(-1, 1, size=shape + (4,)),
        ], axis=-1)
        torques = rng.uniform(-1, 1, size=shape + (3,))
        got = equations_of_motion(params, states, torques)
        assert got.shape == shape + (3,)
        flat_s = states.reshape(-1, 6)
        flat_t = torques.reshape(-1, 3)
        for k in range(flat_s.shape[0]):
            # element-wise evaluation of the same expression: identical to round-off
            np.testing.assert_allclose(got.reshape(-1, 3)[k], equations_of_motion(params, flat_s[k], flat_t[k]),
                                       rtol=1e-14, atol=1e-14)
        inv = invariants(params, states)
        assert inv.d1.shape == inv.d2.shape == inv.energy.shape == shape
        nu = nutation(params, states)
        assert nu.theta_min.shape == nu.period.shape == shape


def test_invariants_are_first_integrals_of_eq_8_16():
    """d/dt of d1, d2 and E along Eq. 8.16 equals the torque power terms."""
    rng = np.random.default_rng(RNG_SEED + 2)
    params = RotorParams(I=1.0, I3=0.6, mgl=1.5)
    s = np.concatenate([rng.uniform(-1, 1, (50, 1)), rng.uniform(0.2, 2.9, (50, 1)), rng.uniform(-2, 2, (50, 4))], -1)
    Q = rng.uniform(-1, 1, (50, 3))
    acc = equations_of_motion(params, s, Q)
    h = 1e-6
    sdot = np.concatenate([s[:, 3:], acc], -1)
    a, b = invariants(params, s + h * sdot), invariants(params, s - h * sdot)
    # central difference along the flow: error ~h^2 |d3/dt3| + eps/h ~ 1e-9
    np.testing.assert_allclose((a.d1 - b.d1) / (2 * h), Q[:, 2], atol=1e-7)
    np.testing.assert_allclose((a.d2 - b.d2) / (2 * h), Q[:, 0], atol=1e-7)
    power = np.sum(Q * s[:, 3:], -1)
    np.testing.assert_allclose((a.energy - b.energy) / (2 * h), power, atol=1e-7)


def test_steady_precession_torque_zeroes_theta_acceleration():
    rng = np.random.default_rng(RNG_SEED + 3)
    for mgl in (0.0, 1.3):
        params = RotorParams(I=1.1, I3=0.9, mgl=mgl)
        theta = rng.uniform(0.2, 2.9, 30)
        phid, psid = rng.uniform(-3, 3, 30), rng.uniform(-20, 20, 30)
        M = steady_precession_torque(params, theta, phid, psid)
        state = np.stack([np.zeros(30), theta, np.zeros(30), phid, np.zeros(30), psid], -1)
        acc = equations_of_motion(params, state, np.stack([np.zeros(30), M, np.zeros(30)], -1))
        # exact cancellation of O(10..100) terms: round-off only
        np.testing.assert_allclose(acc, 0.0, atol=1e-12)
    # the theta = pi/2 form of Eq. 8.23: M = I3 phi_dot psi_dot - mgl
    params = RotorParams(I=1.1, I3=0.9, mgl=1.3)
    np.testing.assert_allclose(steady_precession_torque(params, np.pi / 2, 0.7, 30.0), 0.9 * 0.7 * 30.0 - 1.3,
                               rtol=1e-14)


def test_steady_precession_rates_are_roots_and_ordered():
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    theta = np.array([0.3, 1.0, np.pi / 2, 2.5])
    spin = np.array([20.0, 15.0, 10.0, 5.0])
    r = steady_precession_rates(params, theta, spin)
    for phid in (r.slow, r.fast):
        finite = np.isfinite(phid)
        psid = spin - phid * np.cos(theta)
        M = steady_precession_torque(params, theta[finite], phid[finite], psid[finite])
        # roots of a quadratic with O(1..100) coefficients: round-off
        np.testing.assert_allclose(M, 0.0, atol=1e-11)
    assert np.isinf(r.fast[2])
    np.testing.assert_allclose(r.slow[2], 2.0 / (0.8 * 10.0), rtol=1e-14)
    assert np.all(np.abs(r.slow[:2]) < np.abs(r.fast[:2]))
    # fast-top limit: slow -> mgl / (I3 spin), fast -> I3 spin / (I cos theta)
    fast_top = steady_precession_rates(params, 0.5, 1e4)
    np.testing.assert_allclose(fast_top.slow, 2.0 / (0.8e4), rtol=1e-6)
    np.testing.assert_allclose(fast_top.fast, 0.8e4 / math.cos(0.5), rtol=1e-6)


def test_sleeping_top_critical_spin_formula():
    params = RotorParams(I=1.3, I3=0.6, mgl=2.2)
    wc = sleeping_top_critical_spin(params)
    # a^2 = 2 beta at the threshold (Goldstein sec. 5.7)
    a, beta = params.I3 * wc / params.I, 2 * params.mgl / params.I
    assert a**2 == pytest.approx(2 * beta, rel=1e-14)
    assert sleeping_top_critical_spin(RotorParams(I=1.0, I3=1.0)) == 0.0


def test_nutation_steady_and_sleeping_cases_have_constant_theta():
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    r = steady_precession_rates(params, 0.6, 12.0)
    state = [0.0, 0.6, 0.0, float(r.slow), 0.0, 12.0 - float(r.slow) * math.cos(0.6)]
    nu = nutation(params, state)
    assert nu.theta_min == pytest.approx(0.6, abs=1e-7) and nu.theta_max == pytest.approx(0.6, abs=1e-7)
    # sleeping top above the critical spin stays at theta = 0 exactly
    wc = sleeping_top_critical_spin(params)
    nu = nutation(params, [0, 0, 0, 0, 0, 1.2 * wc])
    assert nu.theta_max == 0.0 and math.isinf(nu.period)
    # below it, the top falls to u1 = a^2/beta - 1
    s = 0.8 * wc
    nu = nutation(params, [0, 1e-9, 0, 0, 0, s])
    a, beta = params.I3 * s / params.I, 2 * params.mgl / params.I
    assert math.cos(nu.theta_max) == pytest.approx(a * a / beta - 1, abs=1e-8)


def test_closed_form_conserves_invariants_to_round_off_over_many_periods():
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    s0 = np.array([0.3, 0.7, 0.1, 0.5, -0.4, 10.0])
    T = float(nutation(params, s0).period)
    t = np.linspace(0, 1e4 * T, 20001)
    tr = simulate(params, s0, t)
    assert tr.method == "closed_form"
    inv = invariants(params, np.hstack([tr.angles, tr.rates]))
    i0 = invariants(params, s0)
    # rates are rebuilt from the exact d1, d2: drift is round-off of O(10) values
    assert np.max(np.abs(inv.d1 - i0.d1)) < 1e-12
    assert np.max(np.abs(inv.d2 - i0.d2)) < 1e-12
    assert np.max(np.abs(inv.energy - i0.energy)) < 1e-11


def test_zero_torques_use_closed_form_and_results_are_read_only():
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    tr = simulate(params, [0, 0.7, 0, 0.5, 0, 10], np.linspace(0, 1, 5), torques=(0, 0, 0))
    assert tr.method == "closed_form"
    with pytest.raises(ValueError, match="read-only"):
        tr.angles[0, 0] = 1.0


def test_theta_outside_range_is_mapped_to_same_orientation():
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    tr = simulate(params, [0.3, -0.7, 0.2, 0.5, 0.1, 10], [0.0])
    np.testing.assert_allclose(tr.angles[0], [0.3 + np.pi, 0.7, 0.2 + np.pi], rtol=0, atol=1e-15)
    # rates are rebuilt from d1, d2 (Eqs. 8.19-8.20): a few ulps of |psi_dot| = 10
    np.testing.assert_allclose(tr.rates[0], [0.5, -0.1, 10], rtol=0, atol=1e-13)


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(I=0.0, I3=1.0), r"I: expected a transverse moment of inertia > 0, got 0.0"),
        (dict(I=1.0, I3=-1.0), r"I3: expected an axial moment of inertia > 0"),
        (dict(I=1.0, I3=2.5), r"I3: expected I3 <= 2\*I \(triangle inequality"),
        (dict(I=1.0, I3=1.0, mgl=-0.1), r"mgl: expected >= 0"),
        (dict(I=float("nan"), I3=1.0), r"I: expected a finite number, got nan"),
        (dict(I="1", I3=1.0), r"I: expected a real number, got '1'"),
        (dict(I=1.0, I3=True), r"I3: expected a real number, got True"),
    ],
)
def test_rotor_params_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RotorParams(**kwargs)


def test_public_functions_validate_input():
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    good = [0, 0.7, 0, 0.5, 0, 10]
    with pytest.raises(ValueError, match=r"params: expected a RotorParams, got dict"):
        invariants({"I": 1}, good)
    with pytest.raises(ValueError, match=r"state: expected shape \(\.\.\., 6\)"):
        invariants(params, [1, 2, 3])
    with pytest.raises(ValueError, match=r"state: expected finite values"):
        nutation(params, [0, np.inf, 0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"torques: expected shape \(\.\.\., 3\)"):
        equations_of_motion(params, good, (1, 2))
    with pytest.raises(ValueError, match=r"singular at sin\(theta\) = 0"):
        equations_of_motion(params, [0, 0, 0, 1, 1, 1])
    with pytest.raises(ValueError, match=r"spin: no steady precession exists"):
        steady_precession_rates(params, 0.5, 1.0)
    with pytest.raises(ValueError, match=r"spin: no steady precession at theta = pi/2 without spin"):
        steady_precession_rates(params, np.pi / 2, 0.0)
    with pytest.raises(ValueError, match=r"theta: steady precession needs sin\(theta\) != 0"):
        steady_precession_rates(params, 0.0, 10.0)
    with pytest.raises(ValueError, match=r"phi_dot: expected finite values"):
        steady_precession_torque(params, 0.5, np.nan, 1.0)
    with pytest.raises(ValueError, match=r"state0: expected shape \(6,\), got \(2, 6\)"):
        simulate(params, [good, good], [0, 1])
    with pytest.raises(ValueError, match=r"t: expected a non-empty 1-D array"):
        simulate(params, good, [[0, 1]])
    with pytest.raises(ValueError, match=r"t: expected non-decreasing times \(s\), got t\[2\] = 1.0 after t\[1\] = 2.0"):
        simulate(params, good, [0, 2, 1])
    with pytest.raises(ValueError, match=r"t: expected times >= 0 \(s\), got t\[0\] = -1.0"):
        simulate(params, good, [-1, 2])
    with pytest.raises(ValueError, match=r"torques: expected \(M_phi, M_theta, M_psi\) of shape \(3,\)"):
        simulate(params, good, [0, 1], torques=[1, 2, 3, 4])
    with pytest.raises(ValueError, match=r"torques: the callable must return 3 finite numbers"):
        simulate(params, good, [0, 1], torques=lambda t, s: (1.0, 2.0))
    with pytest.raises(ValueError, match=r"rtol, atol: expected > 0"):
        simulate(params, good, [0, 1], torques=(0, 1, 0), rtol=0.0)


def test_rotor_vectors_against_scipy_and_generalized_forces():
    rng = np.random.default_rng(RNG_SEED + 4)
    from scipy.spatial.transform import Rotation

    params = RotorParams(I=1.2, I3=0.9, mgl=1.7)
    s = np.concatenate([rng.uniform(-3, 3, (20, 1)), rng.uniform(0.2, 2.9, (20, 1)), rng.uniform(-3, 3, (20, 4))], -1)
    Q = rng.uniform(-1, 1, (20, 3))
    v = rotor_vectors(params, s, Q)
    A = Rotation.from_euler("ZXZ", s[:, :3]).as_matrix()
    np.testing.assert_allclose(v.rotor_axis, A[:, :, 2], atol=1e-14)
    # omega from a central difference of A(t): skew(omega) = A_dot A^T
    h = 1e-6
    Ap = Rotation.from_euler("ZXZ", s[:, :3] + h * s[:, 3:]).as_matrix()
    Am = Rotation.from_euler("ZXZ", s[:, :3] - h * s[:, 3:]).as_matrix()
    W = np.einsum("nij,nkj->nik", (Ap - Am) / (2 * h), A)
    omega_fd = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)
    # central difference: h^2 truncation + eps/h round-off ~ 1e-10
    np.testing.assert_allclose(v.omega, omega_fd, atol=1e-8)
    J = np.diag([params.I, params.I, params.I3])
    L = np.einsum("nij,jk,nlk,nl->ni", A, J, A, v.omega)
    np.testing.assert_allclose(v.angular_momentum, L, atol=1e-12)
    # the torque vector's power with each angle rate reproduces Q (virtual work)
    # plus the gravity generalized force mgl sin(theta) on theta
    G = np.stack([np.broadcast_to([0, 0, 1.0], (20, 3)),
                  np.stack([np.cos(s[:, 0]), np.sin(s[:, 0]), 0 * s[:, 0]], -1), A[:, :, 2]], -1)
    gen = np.einsum("nij,ni->nj", G, v.torque)
    want = Q + np.stack([0 * s[:, 1], params.mgl * np.sin(s[:, 1]), 0 * s[:, 1]], -1)
    np.testing.assert_allclose(gen, want, atol=1e-12)


def test_torques_singular_at_gimbal_lock_raise_a_clear_error():
    # M_phi alone at theta = 0: the torque vector (M_phi - M_psi cos)/sin^2 Z1 + ... is unbounded
    params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    with pytest.raises(ValueError, match=r"torques: the motion reached sin\(theta\) = 0"):
        simulate(params, [0, 0.0, 0, 0, 0, 10], np.linspace(0, 2, 50), torques=(5.0, 0.0, 0.0))


# ------------------------------------------------ huge angles, the lower pole, the horizontal
def test_state_angles_beyond_the_max_angle_are_refused():
    # phi = psi = 1e300 used to run: sin and cos of an angle known to no digit
    from rigidlab.core.gyroscope import GYROSCOPE_MAX_ANGLE, top_motion
    from rigidlab.core.rigid_body import FREE_BODY_MAX_PHASE

    assert GYROSCOPE_MAX_ANGLE == FREE_BODY_MAX_PHASE == 1e14
    params = RotorParams(I=1.0, I3=1.5, mgl=0.5)
    for state, name, shown in (([1e300, 1.0, 1e300, 0.1, 0.0, 30.0], "phi", r"1e\+300"),
                               ([0.0, -2e14, 0.0, 0.1, 0.0, 30.0], "theta", r"-200000000000000\.0"),
                               ([[0.0, 1.0, 0.0, 0.1, 0.0, 30.0], [0.0, 1.0, 1.5e14, 0.1, 0.0, 30.0]], "psi",
                                r"150000000000000\.0 at index \(1,\)")):
        calls = [("state", f) for f in (nutation, invariants, rotor_vectors, equations_of_motion)]
        if np.ndim(state) == 1:
            calls += [("state0", lambda p, s: simulate(p, s, [0.0, 1.0])), ("state0", top_motion)]
        for arg, f in calls:
            with pytest.raises(ValueError, match=rf"^{arg}: expected angles \|phi\|, \|theta\|, \|psi\| <= "
                                                 rf"GYROSCOPE_MAX_ANGLE = 1e\+14 rad, got {name} = {shown}"):
                f(params, state)
    # at the bound: accepted; a motion sampled where psi passes it: refused, naming t
    state = [0.0, 1.0, 1e14, 0.1, 0.0, 30.0]
    assert np.isfinite(invariants(params, state).energy)
    motion = top_motion(params, state)
    with pytest.raises(ValueError, match=r"^t: expected times at which the angles stay within GYROSCOPE_MAX_ANGLE = "
                                         r"1e\+14 rad, got t\[1\] = 1\.0 s where psi = 1e\+14 rad"):
        motion.at([0.0, 1.0])
    state = [0.0, 1.0, 0.0, 0.1, 0.0, 30.0]
    with pytest.raises(ValueError, match=r"^t: .* got t\[2\] = 10000000000000\.0 s where psi = 3\.0048\de\+14 rad"):
        simulate(params, state, [0.0, 1.0, 1e13])
    with pytest.raises(ValueError, match=r"^t: .* got t\[1\] = 1\.0 s where psi = 1e\+14 rad"):  # numerical path
        simulate(params, [0.0, 1.0, 1e14 - 1.0, 0.1, 0.0, 30.0], [0.0, 1.0], torques=(0.0, 0.1, 0.0))


@pytest.mark.parametrize("mgl", [0.5, 0.0])
@pytest.mark.parametrize(("phi_dot", "psi_dot"), [(0.0, 0.0), (0.0, 5.0), (1.0, 5.0), (0.3, -2.0)])
def test_nutation_at_the_lower_pole_is_steady_and_the_limit_of_nearby_states(mgl, phi_dot, psi_dot):
    # theta = pi (np.pi, the double nearest pi) with theta_dot = 0: the rotor
    # axis points straight down; the state is an equilibrium (hanging top)
    # or a steady spin about the vertical. It used to report a nutation of
    # amplitude 4e-13 and period 4.44 s (mgl = 0.5, at rest).
    params = RotorParams(I=1.0, I3=1.5, mgl=mgl)
    at_pole = nutation(params, [0.2, math.pi, 0.1, phi_dot, 0.0, psi_dot])
    assert at_pole.theta_min == at_pole.theta_max == math.pi
    assert math.isinf(at_pole.period)
    # at the pole only phi - psi is an orientation (Rz(phi) Rx(pi) Rz(psi) = Rz(phi - psi) Rx(pi))
    rate = float(at_pole.mean_precession_rate - at_pole.mean_spin_rate)
    assert rate == pytest.approx(phi_dot - psi_dot, rel=1e-15, abs=1e-15)
    tr = simulate(params, [0.2, math.pi, 0.1, phi_dot, 0.0, psi_dot], np.linspace(0.0, 3.0, 7))
    assert tr.method == "steady" and np.all(tr.angles[:, 1] == math.pi)
    np.testing.assert_allclose(np.diff(tr.angles[:, 0] - tr.angles[:, 2]), 0.5 * (phi_dot - psi_dot), atol=1e-14)
    # the limit theta0 -> pi: the bounds close on pi (the axis circles within
    # a few delta of the vertical), and for the heavy top the period tends to
    # the small oscillation about the lower pole: a gyroscopic pendulum whose
    # two circular modes beat at sqrt(I3^2 w3^2 + 4 I mgl) / I
    w3 = psi_dot - phi_dot
    omega = math.sqrt((params.I3 * w3) ** 2 + 4.0 * params.I * mgl) / params.I
    for delta in (1e-9, 1e-12):
        near = nutation(params, [0.2, math.pi - delta, 0.1, phi_dot, 0.0, psi_dot])
        assert math.pi - 3.0 * delta <= near.theta_min <= near.theta_max <= math.pi
        assert float(near.mean_precession_rate - near.mean_spin_rate) == pytest.approx(phi_dot - psi_dot, abs=1e-9)
        if mgl > 0.0:
            assert float(near.period) == pytest.approx(2.0 * math.pi / omega, rel=1e-9)


def test_steady_precession_rates_at_the_horizontal_balance_gravity_with_signed_limits():
    # At theta = pi/2, Eq. 8.23 with M_theta = 0 is I3 phi_dot psi_dot = mgl:
    # one (slow) root. The fast root I3 spin / (I cos theta) leaves for
    # infinity with the sign of spin cos(theta); it used to be +inf for
    # either sign of the spin.
    params = RotorParams(I=1.0, I3=1.5, mgl=0.5)
    above, below = math.pi / 2, np.nextafter(math.pi / 2, 4.0)  # cos = +6e-17, -1.6e-16
    assert math.cos(above) > 0.0 > math.cos(below)
    spins = np.array([5.0, -5.0, 0.5, -1e-3])
    for theta, side in ((above, 1.0), (below, -1.0)):
        r = steady_precession_rates(params, theta, spins)
        # the slow rate balances gravity exactly (the torque of Eq. 8.23 vanishes)
        psi_dot = spins - r.slow * math.cos(theta)
        M = steady_precession_torque(params, theta, r.slow, psi_dot)
        # to round-off, plus the term I cos(theta) phi_dot^2 of the float theta
        # that the horizontal (|cos theta| < 1e-15) leaves out
        dropped = params.I * abs(math.cos(theta)) * r.slow**2
        assert np.all(np.abs(M) <= 4 * np.finfo(float).eps * params.mgl + dropped)
        np.testing.assert_allclose(r.slow, params.mgl / (params.I3 * spins), rtol=1e-15)
        assert np.all(np.isinf(r.fast)) and np.all(np.sign(r.fast) == side * np.sign(spins))
        # the limit: the finite fast root just off the horizontal on the same
        # side has that sign and balances gravity too
        off = theta - side * 1e-7
        finite = steady_precession_rates(params, off, spins)
        assert np.all(np.sign(finite.fast) == np.sign(r.fast)) and np.all(np.abs(finite.fast) > 1e4)
        psi_dot = spins - finite.fast * math.cos(off)
        terms = np.abs(finite.fast * params.I3 * psi_dot) + params.mgl
        M = steady_precession_torque(params, off, finite.fast, psi_dot)
        assert np.all(np.abs(M) <= 1e-8 * terms)
        # and 1 / fast = 0 solves the equation divided by phi_dot^2:
        # I cos(theta) - I3 spin / phi_dot + mgl / phi_dot^2 = 0 at cos(theta) = 0
        inverse = 1.0 / r.fast
        assert np.all(inverse == 0.0)
    # the balanced rotor without spin: every phi_dot is steady at pi/2, and the
    # fast root is 0 at every other theta, so its limit is 0 (was inf)
    balanced = RotorParams(I=1.0, I3=1.5, mgl=0.0)
    r = steady_precession_rates(balanced, above, 0.0)
    assert r.slow == 0.0 and r.fast == 0.0
    assert steady_precession_rates(balanced, above - 1e-7, 0.0).fast == 0.0
