"""rigidlab.core.gyroscope against independent simulations and closed forms.

The reference is a Newton-Euler simulation in Euler parameters written here
from scratch: state (p, omega_body), p_dot = 1/2 p * (0, omega_body), Euler's
equations with J = diag(I, I, I3) and the gravity torque mgl Z1 x e3. It
never sees an Euler angle: its initial condition is built with scipy's
Rotation and the geometric angular velocity phi_dot Z1 + theta_dot X2 +
psi_dot e3, and its outputs are read from the rotation matrix (cos theta =
A33, turning points by event location, the azimuth of e3).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from rigidlab.core.gyroscope import (
    RotorParams,
    equations_of_motion,
    invariants,
    nutation,
    simulate,
    sleeping_top_critical_spin,
    steady_precession_rates,
    steady_precession_torque,
    top_motion,
)

# DOP853 at rtol 1e-12 over tens of periods: the reference itself is good to
# ~1e-10; every tolerance below is 10-100x that, far below the effects tested.
REF_RTOL = 1e-12
REF_ATOL = 1e-13


def _quat_matrix(p):
    e0, e1, e2, e3 = p
    return np.array([
        [e0 * e0 + e1 * e1 - e2 * e2 - e3 * e3, 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2)],
        [2 * (e1 * e2 + e0 * e3), e0 * e0 - e1 * e1 + e2 * e2 - e3 * e3, 2 * (e2 * e3 - e0 * e1)],
        [2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), e0 * e0 - e1 * e1 - e2 * e2 + e3 * e3],
    ])


def newton_euler_rhs(I, I3, mgl, m_theta=0.0):
    """m_theta: a torque of that size about the line of nodes Z1 x e3 / |Z1 x e3|."""
    J = np.array([I, I, I3])

    def rhs(t, y):
        p, w = y[:4], y[4:]
        A = _quat_matrix(p)
        nodes = np.cross([0.0, 0.0, 1.0], A[:, 2])
        torque_global = mgl * nodes
        if m_theta:
            torque_global = torque_global + m_theta * nodes / np.linalg.norm(nodes)
        torque_body = A.T @ torque_global
        w_dot = (torque_body - np.cross(w, J * w)) / J
        p0, pv = p[0], p[1:]
        p_dot = 0.5 * np.concatenate([[-pv @ w], p0 * w + np.cross(pv, w)])
        return np.concatenate([p_dot, w_dot])

    return rhs


def initial_condition(state):
    phi, theta, psi, phid, thetad, psid = state
    rot = Rotation.from_euler("ZXZ", [phi, theta, psi])
    A = rot.as_matrix()
    x2 = Rotation.from_euler("Z", phi).apply([1.0, 0.0, 0.0])
    omega = phid * np.array([0.0, 0.0, 1.0]) + thetad * x2 + psid * A[:, 2]
    return np.concatenate([rot.as_quat(scalar_first=True), A.T @ omega])


def reference_run(params, state, t_end, t_eval=None, events=None, m_theta=0.0):
    rhs = newton_euler_rhs(params.I, params.I3, params.mgl, m_theta)
    return solve_ivp(rhs, (0.0, t_end), initial_condition(state), method="DOP853", rtol=REF_RTOL,
                     atol=REF_ATOL, t_eval=t_eval, events=events, dense_output=events is not None)


def cos_theta_rate(t, y):
    """d(A33)/dt = Z1 . (omega x e3): zero at the nutation turning points."""
    A = _quat_matrix(y[:4])
    omega = A @ y[4:]
    return np.cross(omega, A[:, 2])[2]


def matrices_from_angles(angles):
    return Rotation.from_euler("ZXZ", angles).as_matrix()


HEAVY = RotorParams(I=1.0, I3=0.8, mgl=2.0)
CASES = [
    ("looping", HEAVY, [0.3, 0.7, 0.1, 2.0, 0.0, 10.0]),
    ("wavy", HEAVY, [0.3, 0.7, 0.1, 0.5, -0.4, 10.0]),
    ("cusp", HEAVY, [0.0, 1.0, 0.0, 0.0, 0.0, 6.0]),
    ("slow spin wide nutation", RotorParams(I=1.3, I3=0.5, mgl=1.0), [1.0, 1.2, -0.5, 0.3, 1.5, 3.0]),
]


@pytest.mark.parametrize(("name", "params", "state"), CASES, ids=[c[0] for c in CASES])
def test_nutation_quantities_match_newton_euler_quaternion_run(name, params, state):
    nu = nutation(params, state)
    period = float(nu.period)
    n_per = 6
    sol = reference_run(params, state, n_per * period + 0.5 * period, events=cos_theta_rate)
    t_turn = sol.t_events[0]
    y_turn = sol.y_events[0]
    cos_turn = np.array([_quat_matrix(y[:4])[2, 2] for y in y_turn])
    theta_turn = np.arccos(np.clip(cos_turn, -1, 1))
    is_max = theta_turn > 0.5 * (nu.theta_min + nu.theta_max)
    assert is_max.sum() >= n_per and (~is_max).sum() >= n_per
    # turning points located by event root finding on the reference: ~1e-10
    np.testing.assert_allclose(theta_turn[is_max], nu.theta_max, atol=1e-9)
    np.testing.assert_allclose(theta_turn[~is_max], nu.theta_min, atol=1e-9)
    t_max = t_turn[is_max]
    np.testing.assert_allclose(np.diff(t_max), period, rtol=1e-9)
    # mean precession: azimuth of e3 (phi = atan2(e3x, -e3y)) over whole periods
    t0, t1 = t_max[0], t_max[-1]
    ts = np.linspace(t0, t1, 200 * (len(t_max) - 1) + 1)
    e3 = np.array([_quat_matrix(sol.sol(tt)[:4])[:, 2] for tt in ts])
    azimuth = np.unwrap(np.arctan2(e3[:, 0], -e3[:, 1]))
    np.testing.assert_allclose((azimuth[-1] - azimuth[0]) / (t1 - t0), nu.mean_precession_rate, rtol=1e-8,
                               atol=1e-9)


def phi_dot_through_pole(params, theta0, psi_dot0):
    """phi_dot that makes d2 = d1 (Eqs. 8.19-8.20): the rotor axis then passes
    exactly through theta = 0 (f(1) = -(d2 - d1)^2 / I^2 = 0 in Eq. 8.21)."""
    u0 = math.cos(theta0)
    return params.I3 * psi_dot0 * (1 - u0) / (params.I * (1 - u0 * u0) - params.I3 * u0 * (1 - u0))


POLE_CASES = [
    # theta reaches 0 within ~1e-8 (A = (d2 - d1)/2I ~ 1e-8 of its scale)
    ("near theta=0", HEAVY, [0.2, 0.5, 0.1, phi_dot_through_pole(HEAVY, 0.5, 3.0) + 1e-8, -1.0, 3.0]),
    ("through theta=0", HEAVY, [0.2, 0.0, 0.1, 0.3, 1.0, 2.0]),
    ("near theta=pi torque-free", RotorParams(I=1.0, I3=0.5), [0.2, math.pi - 0.3, 0.1, 0.0, 1.0, 2.0]),
    ("torque-free generic", RotorParams(I=1.0, I3=0.5), [0.3, 0.7, 0.1, 0.5, 0.4, 3.0]),
    ("sleeping above critical", HEAVY, [0.0, 0.01, 0.0, 0.0, 0.0, 3.8]),
]


@pytest.mark.parametrize(("name", "params", "state"), POLE_CASES, ids=[c[0] for c in POLE_CASES])
def test_simulate_orientation_matches_reference_through_and_near_poles(name, params, state):
    t = np.linspace(0.0, 12.0, 1201)
    tr = simulate(params, state, t)
    assert np.all(np.isfinite(tr.angles)) and np.all(np.isfinite(tr.rates))
    assert np.all((tr.angles[:, 1] >= 0) & (tr.angles[:, 1] <= np.pi))
    sol = reference_run(params, state, t[-1], t_eval=t)
    A_ref = np.array([_quat_matrix(p) for p in sol.y[:4].T])
    # orientation (not the individually ill-defined phi, psi near a pole)
    np.testing.assert_allclose(matrices_from_angles(tr.angles), A_ref, atol=1e-9)
    # angular velocity: rebuild omega from the returned rates away from the poles
    away = np.sin(tr.angles[:, 1]) > 1e-3
    ang, rat = tr.angles[away], tr.rates[away]
    x2 = np.stack([np.cos(ang[:, 0]), np.sin(ang[:, 0]), np.zeros(len(ang))], -1)
    e3 = matrices_from_angles(ang)[:, :, 2]
    omega = rat[:, :1] * np.array([0, 0, 1.0]) + rat[:, 1:2] * x2 + rat[:, 2:3] * e3
    omega_ref = np.einsum("nij,jn->ni", A_ref[away], sol.y[4:][:, away])
    # rates near a pole are ~1/sin(theta) large: relative to |omega|
    np.testing.assert_allclose(omega, omega_ref, atol=1e-8 * max(1.0, np.abs(omega_ref).max()))


def test_closed_form_matches_tight_euler_angle_integration_over_many_periods():
    params = HEAVY
    s0 = np.array([0.3, 0.7, 0.1, 0.5, -0.4, 10.0])
    period = float(nutation(params, s0).period)
    t = np.linspace(0.0, 40 * period, 801)
    tr = simulate(params, s0, t)

    def rhs(_t, y):
        return np.concatenate([y[3:], equations_of_motion(params, y)])

    sol = solve_ivp(rhs, (0, t[-1]), s0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    # the DOP853 reference at rtol 1e-13 over 40 periods is good to ~1e-11
    np.testing.assert_allclose(tr.angles, sol.y[:3].T, atol=2e-10)
    np.testing.assert_allclose(tr.rates, sol.y[3:].T, atol=2e-9)


def test_regular_precession_of_torque_free_rotor_about_angular_momentum():
    """mgl = 0: e3 keeps its angle to L and turns about L at |L| / I."""
    params = RotorParams(I=1.4, I3=0.6)
    s0 = np.array([0.2, 1.1, 0.3, 0.7, 0.9, 4.0])
    t = np.linspace(0, 20.0, 401)
    tr = simulate(params, s0, t)
    A = matrices_from_angles(tr.angles)
    e3 = A[:, :, 2]
    x2 = np.stack([np.cos(tr.angles[:, 0]), np.sin(tr.angles[:, 0]), 0 * t], -1)
    omega = tr.rates[:, :1] * [0, 0, 1.0] + tr.rates[:, 1:2] * x2 + tr.rates[:, 2:3] * e3
    omega_body = np.einsum("nji,nj->ni", A, omega)
    L = np.einsum("nij,nj->ni", A, omega_body * [params.I, params.I, params.I3])
    L0 = L[0]
    # L fixed in space: round-off of O(1) quantities
    np.testing.assert_allclose(L, np.broadcast_to(L0, L.shape), atol=1e-12)
    l_hat = L0 / np.linalg.norm(L0)
    np.testing.assert_allclose(e3 @ l_hat, e3[0] @ l_hat, atol=1e-12)
    # precession angle of e3 about L grows at |L|/I exactly
    b1 = np.cross(l_hat, [1.0, 0, 0])
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(l_hat, b1)
    ang = np.unwrap(np.arctan2(e3 @ b2, e3 @ b1))
    np.testing.assert_allclose(ang - ang[0], np.linalg.norm(L0) / params.I * t, atol=1e-10)


def test_steady_precession_stays_steady():
    params = HEAVY
    theta0, spin = 0.9, 12.0
    rates = steady_precession_rates(params, theta0, spin)
    for phid in (float(rates.slow), float(rates.fast)):
        state = [0.0, theta0, 0.0, phid, 0.0, spin - phid * math.cos(theta0)]
        T = 4 * 2 * math.pi / abs(phid) if abs(phid) > 1 else 8.0
        t = np.linspace(0, T, 201)
        sol = reference_run(params, state, T, t_eval=t)
        cos_theta = np.array([_quat_matrix(p)[2, 2] for p in sol.y[:4].T])
        # steady: theta stays at theta0 to the reference's accuracy (the fast
        # branch is stiffer: rtol 1e-12 over ~100 steps per turn)
        np.testing.assert_allclose(np.arccos(cos_theta), theta0, atol=1e-8)
        tr = simulate(params, state, t)
        assert tr.method == "steady"
        np.testing.assert_allclose(tr.rates[:, 0], phid, rtol=1e-12)
    # balanced rotor held by the torque of Eq. 8.23 (numerical path)
    params0 = RotorParams(I=1.0, I3=0.8)
    phid, psid = 0.7, 25.0
    M = float(steady_precession_torque(params0, theta0, phid, psid))
    t = np.linspace(0, 10.0, 101)
    tr = simulate(params0, [0, theta0, 0, phid, 0, psid], t, torques=(0.0, M, 0.0))
    assert tr.method == "numerical"
    np.testing.assert_allclose(tr.angles[:, 1], theta0, atol=1e-9)
    np.testing.assert_allclose(tr.angles[:, 0], phid * t, atol=1e-8)
    # without the torque theta does not stay
    free = simulate(params0, [0, theta0, 0, phid, 0, psid], t)
    assert np.ptp(free.angles[:, 1]) > 1e-3


def test_sleeping_top_threshold_separates_stable_from_unstable():
    params = HEAVY
    wc = sleeping_top_critical_spin(params)
    theta0 = 1e-3
    t = np.linspace(0, 30.0, 601)
    results = {}
    for factor in (1.1, 0.9):
        state = [0.0, theta0, 0.0, 0.0, 0.0, factor * wc]
        sol = reference_run(params, state, t[-1], t_eval=t)
        cos_theta = np.array([_quat_matrix(p)[2, 2] for p in sol.y[:4].T])
        theta_ref = np.arccos(np.clip(cos_theta, -1, 1))
        results[factor] = theta_ref.max()
        nu = nutation(params, state)
        tr = simulate(params, state, t)
        # predicted bound and the closed form agree with the reference
        assert theta_ref.max() <= nu.theta_max + 1e-9
        np.testing.assert_allclose(tr.angles[:, 1], theta_ref, atol=1e-7)
    # above: stays within a few theta0; below: falls far (u1 = a^2/beta - 1)
    assert results[1.1] < 5 * theta0
    assert results[0.9] > 0.3


def test_numerical_path_matches_closed_form_including_parameter_switch():
    """A zero torque given as a callable forces the numerical path."""
    params = HEAVY
    t = np.linspace(0, 6.0, 301)
    zero = lambda _t, _s: (0.0, 0.0, 0.0)  # noqa: E731
    for state in ([0.3, 0.7, 0.1, 0.5, -0.4, 10.0], [0.2, 0.5, 0.1, phi_dot_through_pole(HEAVY, 0.5, 3.0) + 1e-4, -1.0, 3.0]):
        ref = simulate(params, state, t)
        num = simulate(params, state, t, torques=zero)
        assert num.method == "numerical"
        # DOP853 at rtol 1e-11 (default) over a few periods
        np.testing.assert_allclose(matrices_from_angles(num.angles), matrices_from_angles(ref.angles), atol=1e-8)


def test_torques_change_the_right_momenta():
    """M_theta alone keeps d1 and d2 (Eqs. 8.19-8.20) and changes the energy."""
    params = HEAVY
    s0 = [0.3, 0.7, 0.1, 0.5, -0.4, 10.0]
    t = np.linspace(0, 3.0, 61)
    tr = simulate(params, s0, t, torques=(0.0, 0.5, 0.0))
    inv = invariants(params, np.hstack([tr.angles, tr.rates]))
    i0 = invariants(params, s0)
    # integration tolerance rtol 1e-11 on O(10) momenta
    np.testing.assert_allclose(inv.d1, i0.d1, atol=1e-8)
    np.testing.assert_allclose(inv.d2, i0.d2, atol=1e-8)
    assert np.ptp(inv.energy) > 1e-3
    # M_psi spins the rotor up: d1 grows at M_psi
    tr = simulate(params, s0, t, torques=(0.0, 0.0, 0.2))
    d1 = invariants(params, np.hstack([tr.angles, tr.rates])).d1
    np.testing.assert_allclose(d1 - i0.d1, 0.2 * t, atol=1e-8)


def test_pole_passage_case_really_passes_near_the_pole():
    state = [0.2, 0.5, 0.1, phi_dot_through_pole(HEAVY, 0.5, 3.0), -1.0, 3.0]
    inv = invariants(HEAVY, state)
    # d2 = d1 up to round-off of O(1) momenta, so theta_min is at round-off level
    assert abs(float(inv.d2 - inv.d1)) < 1e-15
    assert float(nutation(HEAVY, state).theta_min) < 1e-12
    state[3] += 1e-8
    assert 1e-10 < float(nutation(HEAVY, state).theta_min) < 1e-8


def test_numerical_path_with_torque_near_the_pole_matches_reference():
    """M_theta (a torque about the line of nodes, regular at the poles) while the
    axis passes within ~1e-3 of theta = 0: the Euler-parameter segment is used."""
    params = HEAVY
    state = [0.2, 0.5, 0.1, phi_dot_through_pole(HEAVY, 0.5, 3.0) + 1e-2, -1.0, 3.0]
    t = np.linspace(0, 4.0, 201)
    tr = simulate(params, state, t, torques=(0.0, 0.05, 0.0))
    assert tr.method == "numerical"
    assert tr.angles[:, 1].min() < 0.05  # it did enter the Euler-parameter region
    sol = reference_run(params, state, t[-1], t_eval=t, m_theta=0.05)
    A_ref = np.array([_quat_matrix(p) for p in sol.y[:4].T])
    # DOP853 at rtol 1e-11 (simulate) vs 1e-12 (reference) over ~5 s
    np.testing.assert_allclose(matrices_from_angles(tr.angles), A_ref, atol=1e-8)


def _falling_top(theta0):
    """A sleeping top below its critical spin started theta0 from the vertical (at rest in theta)."""
    return [0.0, theta0, 0.0, 0.0, 0.0, 1.0]


def _growth_rate(params, psi_dot):
    """sigma of theta ~ theta0 cosh(sigma t) near theta = 0 for a top below its
    critical spin (linearized Eq. 8.21): sigma^2 = mgl/I - (I3 psi_dot / 2I)^2."""
    return math.sqrt(params.mgl / params.I - (params.I3 * psi_dot / (2.0 * params.I)) ** 2)


# Below 1e-8 rad the elliptic parameter m is within round-off of 1; its
# complement 1 - m ~ theta0^2 sets the period.
DECADES = [10.0**-e for e in range(4, 15)]


@pytest.mark.parametrize("theta0", DECADES, ids=[f"1e{round(math.log10(x))}" for x in DECADES])
def test_period_of_a_top_falling_from_near_the_vertical_grows_by_its_log(theta0):
    """Each tenth of theta0 adds 2 ln(10) / sigma to the nutation period: the
    top spends ln(10) / sigma longer leaving the vertical and as long coming
    back. The rest of the period changes by O(theta0^2) relative (1e-8 at the
    first step from 1e-4, measured 2e-9), so the tolerance is 1e-7."""
    params = HEAVY
    sigma = _growth_rate(params, 1.0)
    assert sigma**2 * params.I < params.mgl  # below the critical spin
    step = float(nutation(params, _falling_top(theta0 / 10.0)).period) - float(
        nutation(params, _falling_top(theta0)).period)
    np.testing.assert_allclose(step, 2.0 * math.log(10.0) / sigma, rtol=1e-7)


def test_closed_form_top_falls_later_by_its_log_per_decade_of_theta0():
    """The time simulate's closed form takes to reach theta = 1 rad grows by
    ln(10) / sigma per decade of theta0 down to 1e-14 (same argument as the
    period; crossing times found by brentq to 1e-12 s)."""
    from scipy.optimize import brentq

    params = HEAVY
    sigma = _growth_rate(params, 1.0)
    falls = []
    for theta0 in DECADES:
        motion = top_motion(params, _falling_top(theta0))
        # theta reaches 1 rad about ln(2 / theta0) / sigma after the start
        t_hi = motion.period / 2.0
        falls.append(brentq(lambda t, m=motion: m.at([t]).angles[0, 1] - 1.0, 0.0, t_hi, xtol=1e-12))
    np.testing.assert_allclose(np.diff(falls), math.log(10.0) / sigma, rtol=1e-7)
    # and simulate returns the same motion
    t = np.array([0.0, falls[-1]])
    np.testing.assert_allclose(simulate(params, _falling_top(DECADES[-1]), t).angles[-1, 1], 1.0, atol=1e-9)
