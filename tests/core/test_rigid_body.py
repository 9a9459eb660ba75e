"""Tests of core.rigid_body: Newton-Euler models and the exact free-body motion.

Oracles: a tight DOP853 integration of the equations (independent of the
elliptic-function solution), conservation laws (energy, angular momentum in
the global frame, |p|), central finite differences of the exact p(t)
against the kinematic equation p_dot = G_bar(p).T omega_body / 2 (Eq. 8.54),
the closed-form motion under a constant force, core.rotations' own G_bar
and Rodriguez-rate functions, and convergence orders against the exact
solution.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from rigidlab.core import integrators as itg
from rigidlab.core import rigid_body as rb
from rigidlab.core.rotations import (
    euler_parameter_G_bar,
    euler_parameters_from_rodriguez_parameters,
    matrix_from_euler_parameters,
    rodriguez_parameter_rates,
)

RNG_SEED = 20071


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _qdist(p, q):
    """Distance between Euler parameters up to sign (p and -p are one rotation)."""
    return np.minimum(np.linalg.norm(p - q, axis=-1), np.linalg.norm(p + q, axis=-1))


def _random_rotation(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.linalg.det(Q))


P0 = _unit([0.9, 0.1, -0.3, 0.2])


def _reference(inertia, w0, p0, t):
    """DOP853 at rtol=1e-13, atol=1e-14 on the 7-state free-body equations."""
    model = rb.FreeBodyModel(inertia)
    run = itg.integrate(
        model, np.concatenate([p0, w0]), (0.0, float(t[-1])), method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t
    )
    return run.states


# (inertia, omega_body0, tolerance). Tolerance: DOP853 at rtol=1e-13 over
# t <= 20 accumulates a global error of ~1e-12..1e-11 on these O(1) states;
# 1e-9 leaves room for that and still catches any wrong sign, phase or
# period (those give O(1e-3..1) errors). Near the separatrix both solutions
# are ill-conditioned (errors grow like exp(lambda t) while the body passes
# the unstable axis), so the tolerance is looser there.
CASES = {
    "asymmetric": ([1.0, 2.0, 3.0], [0.8, -0.5, 0.6], 1e-9),
    "asymmetric_minor_circling": ([1.0, 2.0, 3.0], [1.5, 0.4, 0.2], 1e-9),
    "separatrix_exact": ([3.0, 4.0, 6.0], [2.0, 0.5, 1.0], 1e-9),
    "separatrix_other_branch": ([3.0, 4.0, 6.0], [-2.0, 0.5, 1.0], 1e-9),
    "near_separatrix_1e-4": ([1.0, 2.0, 3.0], [1e-4, 1.0, 1e-4], 1e-9),
    "near_separatrix_1e-8": ([1.0, 2.0, 3.0], [1e-8, 1.0, 1e-8], 1e-7),
    "symmetric_oblate": ([1.0, 1.0, 1.8], [0.3, 0.5, 2.0], 1e-9),
    "symmetric_prolate": ([0.5, 2.0, 2.0], [0.3, 0.5, 2.0], 1e-9),
    "nearly_equal_1e-9": ([1.0, 3.0 - 3e-9, 3.0], [0.3, 0.5, 2.0], 1e-9),
    "nearly_equal_1e-6": ([1.0, 1.0 + 1e-6, 1.9], [0.3, 0.5, 2.0], 1e-9),
    "rod_like": ([1.0, 1.001, 1e-3], [0.3, 0.5, 2.0], 1e-9),
    "spherical": ([2.0, 2.0, 2.0], [0.3, 0.5, 2.0], 1e-9),
    "steady_intermediate": ([1.0, 2.0, 3.0], [0.0, 1.3, 0.0], 1e-9),
}


@pytest.mark.parametrize("case", CASES)
def test_exact_matches_dop853(case):
    J, w0, tol = CASES[case]
    t = np.linspace(0.0, 20.0, 401)
    m = rb.free_body_exact(J, w0, P0, t)
    ref = _reference(J, np.asarray(w0, float), P0, t)
    assert np.all(np.isfinite(m.p)) and np.all(np.isfinite(m.omega_body))
    assert _qdist(m.p, ref[:, :4]).max() < tol
    assert np.abs(m.omega_body - ref[:, 4:]).max() < tol * max(1.0, np.abs(w0).max())


def test_exact_with_full_tensor_matches_dop853():
    # A general (non-diagonal) tensor is diagonalized inside; the result is in
    # the original body frame. Tolerance as in CASES.
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(3):
        R = _random_rotation(rng)
        J = R @ np.diag(rng.uniform(1.0, 2.0, 3)) @ R.T
        w0, p0 = rng.normal(size=3), _unit(rng.normal(size=4))
        t = np.linspace(0.0, 15.0, 151)
        m = rb.free_body_exact(J, w0, p0, t)
        ref = _reference(J, w0, p0, t)
        assert _qdist(m.p, ref[:, :4]).max() < 1e-9
        assert np.abs(m.omega_body - ref[:, 4:]).max() < 1e-9


def test_exact_conserves_invariants_to_round_off():
    # Energy, L in the global frame and |p| are evaluated independently of the
    # solution's construction and must stay at round-off: for t <= 50, 1e-13
    # relative (a few hundred ulps of sums of O(1) terms); at t ~ 1e4 the
    # angles (phi +- psi) / 2 ~ 1e4 rad carry ~1e4 eps = 2e-12 absolute error,
    # which tilts the orientation, so L gets 1e-11 there. Energy and |p| do
    # not depend on those angles.
    rng = np.random.default_rng(RNG_SEED + 1)
    R = _random_rotation(rng)
    J = R @ np.diag([1.0, 1.7, 2.2]) @ R.T
    w0 = np.array([0.4, -1.1, 0.7])
    t = np.concatenate([np.linspace(0, 50, 500), np.linspace(1e4 - 5, 1e4, 50)])
    m = rb.free_body_exact(J, w0, P0, t)
    E = rb.rotational_kinetic_energy(J, m.omega_body)
    L = rb.angular_momentum_global(J, m.omega_body, m.p)
    assert np.abs(E / E[0] - 1).max() < 1e-13
    dL = np.linalg.norm(L - L[0], axis=1) / np.linalg.norm(L[0])
    assert dL[:500].max() < 1e-13 and dL.max() < 1e-11
    assert np.abs(rb.euler_parameter_norm_error(m.p)).max() < 1e-14


def test_exact_satisfies_kinematic_equation():
    # Central differences of p(t) (h = 1e-4: truncation ~h^2 |p'''| / 6 ~ 1e-9,
    # round-off ~1e-16 / h = 1e-12) against p_dot = G_bar(p).T omega_body / 2
    # (Eq. 8.54) with G_bar from core.rotations.
    J, w0 = [1.0, 2.0, 3.0], [0.8, -0.5, 0.6]
    sol = rb.free_body_solution(J, w0, P0)
    t, h = np.linspace(0.0, 30.0, 301), 1e-4
    m = sol.at(t)
    p_dot = (sol.at(t + h).p - sol.at(t - h).p) / (2 * h)
    expected = 0.5 * np.einsum("nij,ni->nj", euler_parameter_G_bar(m.p), m.omega_body)
    assert np.abs(p_dot - expected).max() < 1e-8


def test_initial_values_shapes_and_continuity():
    sol = rb.free_body_solution([1.0, 2.0, 3.0], [0.8, -0.5, 0.6], P0)
    m0 = sol.at(0.0)
    assert m0.p.shape == (4,) and m0.omega_body.shape == (3,)
    np.testing.assert_allclose(m0.p, P0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(m0.omega_body, [0.8, -0.5, 0.6], rtol=0, atol=1e-15)
    m = sol.at(np.zeros((3, 1, 2)))
    assert m.p.shape == (3, 1, 2, 4) and m.omega_body.shape == (3, 1, 2, 3)
    # p is continuous in t (no sign flips across half periods): on a grid of
    # dt = 1e-3 consecutive values differ by ~|p_dot| dt <= 1e-3.
    t = np.linspace(-40.0, 40.0, 80001)
    p = sol.at(t).p
    assert np.linalg.norm(np.diff(p, axis=0), axis=1).max() < 2e-3
    # omega_body is periodic with the reported period
    T = sol.period
    np.testing.assert_allclose(sol.at(t[:100] + 7 * T).omega_body, sol.at(t[:100]).omega_body, rtol=0, atol=1e-12)


def test_large_times_reduce_by_the_period():
    # omega(t + k T) = omega(t) for t ~ 1e6: the argument reduction keeps the
    # error at ~|lambda t| eps ~ 1e-10 instead of losing the phase.
    sol = rb.free_body_solution([1.0, 2.0, 3.0], [0.3, 1.0, 0.4], P0)
    T = sol.period
    k = np.floor(1e6 / T)
    t = np.linspace(0.0, T, 17)
    np.testing.assert_allclose(sol.at(t + k * T).omega_body, sol.at(t).omega_body, rtol=0, atol=1e-9)
    assert np.all(np.isfinite(sol.at(np.array([1e9, -1e9])).p))


@pytest.mark.parametrize(
    ("J", "w0", "kind"),
    [
        ([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], "rest"),
        ([1.0, 2.0, 3.0], [0.0, 2.0, 0.0], "steady"),  # exactly on the unstable axis
        ([1.0, 2.0, 3.0], [5.0, 0.0, 0.0], "steady"),
        ([2.0, 2.0, 2.0], [1.0, 2.0, 3.0], "steady"),
        ([1.0, 1.0, 2.0], [1.0, 2.0, 3.0], "symmetric"),
        ([3.0, 4.0, 6.0], [2.0, 0.5, 1.0], "separatrix"),
        ([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], "asymmetric"),
        ([1e-6, 1.0, 1.0 + 5e-7], [1e3, 1.0, 0.5], "asymmetric"),  # needle: tiny I, huge spin
    ],
)
def test_special_cases_are_finite_and_conservative(J, w0, kind):
    sol = rb.free_body_solution(J, w0, P0)
    assert sol.kind == kind
    m = sol.at(np.linspace(0.0, 100.0, 1001))
    assert np.all(np.isfinite(m.p)) and np.all(np.isfinite(m.omega_body))
    E = rb.rotational_kinetic_energy(J, m.omega_body)
    L = rb.angular_momentum_global(J, m.omega_body, m.p)
    # Round-off only: the angles reach |omega| t (up to 1e5 rad for the huge
    # spin) and carry |omega| t eps absolute error, which tilts L; allow
    # 4 eps (1 + |omega| t) relative.
    tol = 4 * np.finfo(float).eps * (1.0 + np.linalg.norm(w0) * 100.0)
    assert np.abs(E - E[0]).max() <= tol * max(E[0], 1e-300)
    assert np.abs(L - L[0]).max() <= tol * max(np.linalg.norm(L[0]), 1e-300)


@pytest.mark.parametrize(("method", "dt"), [("rk4", 0.2), ("midpoint", 0.1), ("splitting", 0.1),
                                             ("splitting4", 0.2), ("splitting6", 0.5), ("splitting8", 0.6)])
def test_free_body_convergence_order(method, dt):
    # Global error at T = 10 against the exact solution; halving the step
    # divides it by ~2^k (|log2 ratio - k| < 0.25, errors >= 1e-13, well
    # above the ~1e-15 round-off of these short runs).
    model = rb.FreeBodyModel([1.0, 2.0, 3.0])
    y0 = np.concatenate([P0, [0.8, -0.5, 0.6]])
    ex = model.exact(y0, 10.0)
    errs = []
    for i in range(3):
        y = itg.integrate(model, y0, (0.0, 10.0), method=method, dt=dt / 2**i, save_every=10**9).states[-1]
        errs.append(max(float(_qdist(y[:4], ex[:4])), float(np.abs(y[4:] - ex[4:]).max())))
    k = itg.METHOD_ORDERS[method]
    rates = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    assert errs[-1] > 1e-13 and all(abs(r - k) < 0.25 for r in rates), (errs, rates)


def test_structure_preserving_methods_keep_invariants():
    # 5000 steps: the splitting's flows are exact rotations, so |p| - 1 and
    # |L| - |L0| change only by the rounding of the rotations (<= ~1e-17 per
    # flow, 15000 flows: < 2e-13) with no renormalization, while RK4 at the
    # same step loses |p| by truncation error (> 1e-10). The splitting's
    # energy error is bounded (O(dt^2), no drift).
    # Implicit midpoint conserves the quadratic invariants |p|^2 and E to its
    # fixed-point tolerance (4e-16 per step -> 1e-13 over 5000 steps).
    J = np.array([1.0, 2.0, 3.0])
    model = rb.FreeBodyModel(J)
    y0 = np.concatenate([P0, [0.8, -0.5, 0.6]])
    run = itg.integrate(model, y0, (0.0, 500.0), method="splitting", dt=0.1, save_every=10)
    p, w = run.states[:, :4], run.states[:, 4:]
    assert np.abs(rb.euler_parameter_norm_error(p)).max() < 2e-13
    Ln = np.linalg.norm(w * J, axis=1)
    assert np.abs(Ln / Ln[0] - 1).max() < 2e-13
    E = rb.rotational_kinetic_energy(J, w)
    half = len(E) // 2
    assert np.ptp(E[half:]) < 1.5 * np.ptp(E[:half]) and np.abs(E / E[0] - 1).max() < 1e-2
    assert run.drift.max_abs["p_norm"] < 2e-13
    mid = itg.integrate(model, y0, (0.0, 100.0), method="midpoint", dt=0.1, save_every=10)
    assert mid.drift.max_rel["energy"] < 1e-13 and mid.drift.max_abs["p_norm"] < 1e-13
    # RK4 at the same step drifts in |p| (no structure): a visible contrast
    rk = itg.integrate(model, y0, (0.0, 500.0), method="rk4", dt=0.1, save_every=10)
    assert rk.drift.max_abs["p_norm"] > 1e-10


def _loads():
    def force(t, y):
        return np.array([0.0, 0.0, -9.81 * 2.0]) + 0.3 * np.array([math.sin(t), 0.0, 0.0])

    def torque_body(t, y):
        w = y[-3:]
        return np.array([0.2 * math.cos(2 * t), 0.1, 0.0]) - 0.05 * w

    return force, torque_body


def test_euler_and_rodriguez_formulations_agree():
    # Same body, same time- and state-dependent loads, two orientation
    # coordinates; DOP853 at rtol=1e-12 leaves ~1e-10 differences.
    R = _random_rotation(np.random.default_rng(RNG_SEED + 2))
    force, torque = _loads()
    body = rb.RigidBody(2.0, R @ np.diag([0.3, 0.5, 0.7]) @ R.T, force=force, torque_body=torque)
    gamma0 = np.array([0.2, -0.1, 0.3])
    p0 = euler_parameters_from_rodriguez_parameters(gamma0)
    r0, v0, w0 = np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.0, 4.0]), np.array([1.0, -0.4, 0.8])
    t = np.linspace(0.0, 1.5, 16)
    kw = dict(method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    ep = itg.integrate(rb.EulerParameterModel(body), rb.euler_parameter_state(r0, p0, v0, w0), (0, 1.5), **kw)
    rp = itg.integrate(rb.RodriguezModel(body), rb.rodriguez_state(r0, gamma0, v0, w0), (0, 1.5), **kw)
    np.testing.assert_allclose(rp.states[:, 9:12], ep.states[:, 10:13], rtol=0, atol=1e-9)
    np.testing.assert_allclose(rp.states[:, 0:3], ep.states[:, 0:3], rtol=0, atol=1e-9)
    assert _qdist(rb.RodriguezModel.euler_parameters(rp.states), ep.states[:, 3:7]).max() < 1e-9
    # translation has a closed form: r = r0 + v0 t + (g t^2 / 2) + 0.3/m (t - sin t) e_x
    r_exact = r0 + np.outer(t, v0) + np.outer(t**2 / 2, [0, 0, -9.81])
    r_exact[:, 0] += 0.3 / 2.0 * (t - np.sin(t))
    np.testing.assert_allclose(ep.states[:, 0:3], r_exact, rtol=0, atol=1e-9)


def test_torque_free_models_agree_with_exact_solution():
    J = np.array([0.4, 0.9, 1.2])
    body = rb.RigidBody(1.0, J)
    w0 = np.array([0.3, 1.2, -0.5])
    t = np.linspace(0.0, 10.0, 11)
    run = itg.integrate(
        rb.EulerParameterModel(body), rb.euler_parameter_state(np.zeros(3), P0, np.zeros(3), w0), (0.0, 10.0),
        method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t,
    )
    ex = rb.free_body_exact(J, w0, P0, t)
    assert _qdist(run.states[:, 3:7], ex.p).max() < 1e-10  # DOP853 global error ~1e-12
    np.testing.assert_allclose(run.states[:, 10:13], ex.omega_body, rtol=0, atol=1e-10)
    assert run.drift.max_rel["kinetic_energy"] < 1e-11


def test_rhs_uses_chapter_matrices():
    # The models' kinematics equal core.rotations' G_bar (Eq. 8.54) and
    # Rodriguez rates (Eqs. 8.61-8.64) to round-off.
    rng = np.random.default_rng(RNG_SEED + 3)
    body = rb.RigidBody(1.5, [1.0, 2.0, 3.0])
    for _ in range(20):
        p, w, g = _unit(rng.normal(size=4)), rng.normal(size=3), rng.normal(size=3)
        y = rb.euler_parameter_state(np.zeros(3), p, np.zeros(3), w)
        np.testing.assert_allclose(rb.EulerParameterModel(body).rhs(0.0, y)[3:7],
                                   0.5 * euler_parameter_G_bar(p).T @ w, rtol=0, atol=1e-15)
        y = rb.rodriguez_state(np.zeros(3), g, np.zeros(3), w)
        np.testing.assert_allclose(rb.RodriguezModel(body).rhs(0.0, y)[3:6],
                                   rodriguez_parameter_rates(g, w), rtol=0, atol=1e-14)
        y = rb.free_body_state(p, w)
        np.testing.assert_allclose(rb.FreeBodyModel([1.0, 2.0, 3.0]).rhs(0.0, y)[:4],
                                   0.5 * euler_parameter_G_bar(p).T @ w, rtol=0, atol=1e-15)


def test_invariants_against_definitions():
    rng = np.random.default_rng(RNG_SEED + 4)
    R = _random_rotation(rng)
    J = R @ np.diag([1.0, 2.0, 3.0]) @ R.T
    p, w = _unit(rng.normal(size=4)), rng.normal(size=3)
    A = matrix_from_euler_parameters(p)
    assert rb.rotational_kinetic_energy(J, w) == pytest.approx(0.5 * w @ J @ w, rel=1e-15)
    np.testing.assert_allclose(rb.angular_momentum_global(J, w, p), A @ J @ w, rtol=0, atol=1e-14)
    np.testing.assert_allclose(rb.angular_momentum_body(J, w), J @ w, rtol=0, atol=1e-15)
    batch = rb.angular_momentum_global(J, np.tile(w, (3, 1, 2, 1, 1)), np.tile(p, (3, 1, 2, 1, 1)))
    assert batch.shape == (3, 1, 2, 1, 3)
    moments, Q = rb.principal_axes(J)
    np.testing.assert_allclose(moments, [1.0, 2.0, 3.0], rtol=1e-14)
    np.testing.assert_allclose(Q @ np.diag(moments) @ Q.T, J, atol=1e-14)
    assert np.linalg.det(Q) == pytest.approx(1.0)


def test_rodriguez_singularity_is_a_clear_error():
    # Spin about x at 1 rad/s from the identity: the rotation angle reaches pi
    # at t = pi, where gamma = x tan(angle / 2) is infinite.
    body = rb.RigidBody(1.0, [1.0, 1.0, 1.0])
    y0 = rb.rodriguez_state(np.zeros(3), np.zeros(3), np.zeros(3), [1.0, 0.0, 0.0])
    with pytest.raises(rb.RodriguezSingularityError, match=r"near the singular angle pi at t=3\.1.*use Euler parameters"):
        itg.integrate(rb.RodriguezModel(body), y0, (0.0, 4.0), method="rk4", dt=1e-3)
    # the same motion in Euler parameters passes through pi without trouble
    y0 = rb.euler_parameter_state(np.zeros(3), [1, 0, 0, 0], np.zeros(3), [1.0, 0.0, 0.0])
    run = itg.integrate(rb.EulerParameterModel(body), y0, (0.0, 4.0), method="rk4", dt=1e-2)
    np.testing.assert_allclose(run.states[-1, 3:7], [math.cos(2.0), math.sin(2.0), 0, 0], atol=1e-9)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: rb.free_body_exact([1.0, 2.0], [1, 0, 0], P0, 0.0), r"inertia: expected principal moments \(3,\) or a tensor \(3, 3\), got shape \(2,\)"),
        (lambda: rb.free_body_exact([[1, 1, 0], [0, 1, 0], [0, 0, 1]], [1, 0, 0], P0, 0.0), r"inertia: expected a symmetric tensor"),
        (lambda: rb.free_body_exact([1.0, -2.0, 3.0], [1, 0, 0], P0, 0.0), r"inertia: expected positive-definite .* got moments"),
        (lambda: rb.free_body_exact([1.0, np.nan, 3.0], [1, 0, 0], P0, 0.0), r"inertia: expected finite values"),
        (lambda: rb.free_body_exact([1.0, 2.0, 3.0], [1, 0], P0, 0.0), r"omega_body0: expected shape \(3,\), got \(2,\)"),
        (lambda: rb.free_body_exact([1.0, 2.0, 3.0], [1, 0, 0], [1, 1, 0, 0], 0.0), r"p0: expected unit Euler parameters .* got norm 1.414"),
        (lambda: rb.free_body_exact([1.0, 2.0, 3.0], [1, 0, 0], P0, [0.0, np.inf]), r"t: expected finite times, got \[inf\]"),
        (lambda: rb.RigidBody(0.0, [1.0, 1.0, 1.0]), r"mass: expected a finite number > 0, got 0.0"),
        (lambda: rb.RodriguezModel(rb.RigidBody(1.0, [1, 1, 1]), gamma_max=-1.0), r"gamma_max: expected a finite number > 0, got -1.0"),
        (lambda: rb.euler_parameter_state([0, 0], P0, [0, 0, 0], [0, 0, 0]), r"r: expected shape \(3,\), got \(2,\)"),
        (lambda: rb.free_body_state([2, 0, 0, 0], [0, 0, 0]), r"p: expected unit Euler parameters"),
    ],
)
def test_validation_messages(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_rotation_angle_and_momentum_geometry():
    # rotation_angle_between: a known rotation about z by 0.3 rad, and 1e-9 rad
    # (the atan2 form keeps full relative accuracy for tiny angles).
    p = P0
    for angle in (0.3, 1e-9, math.pi):
        q = np.array(rb.free_body_exact([1, 1, 1], [0, 0, angle], p, 1.0).p)
        assert rb.rotation_angle_between(p, q) == pytest.approx(angle, rel=1e-12)
        assert rb.rotation_angle_between(p, -q) == pytest.approx(angle, rel=1e-12)
    g = rb.momentum_geometry([1.0, 2.0, 3.0], [0.8, -0.5, 0.6])
    L = np.array([0.8, -1.0, 1.8])
    assert g.L_norm == pytest.approx(np.linalg.norm(L), rel=1e-15)
    assert g.energy == pytest.approx(0.5 * (0.64 + 2 * 0.25 + 3 * 0.36), rel=1e-15)
    # the polhode lies on both surfaces: sum L_k^2 / a_k^2 = 1 on the ellipsoid
    m = rb.free_body_exact([1.0, 2.0, 3.0], [0.8, -0.5, 0.6], P0, np.linspace(0, 20, 50))
    Lb = m.omega_body * [1.0, 2.0, 3.0]
    Lp = Lb @ g.axes
    np.testing.assert_allclose(np.sum(Lp**2 / g.semi_axes**2, axis=1), 1.0, rtol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(Lb, axis=1), g.L_norm, rtol=1e-13)


@pytest.mark.parametrize("method", ["splitting", "splitting4", "splitting6", "splitting8"])
def test_fast_split_loop_equals_the_generic_composition(method):
    # FreeBodyModel.split_run merges consecutive half steps of the same
    # planar rotation (exact in exact arithmetic); against the flow-by-flow
    # composition it may differ only by round-off: 200 steps x <= 7 stages
    # x a few ulps, amplified by the flow's O(1) Lyapunov growth -> 1e-12.
    model = rb.FreeBodyModel([1.0, 2.0, 3.0])
    y0 = np.concatenate([P0, [0.8, -0.5, 0.6]])
    z = model.to_split_state(y0)
    generic = z
    for _ in range(200):
        generic = itg._split_advance(model, generic, 0.05, itg._COMPOSITIONS[method])
    fast = model.split_run(z, 0.05, itg._COMPOSITIONS[method], 200)
    np.testing.assert_allclose(model.from_split_state(fast), model.from_split_state(generic), rtol=0, atol=1e-12)
    assert model.split_run(z, 0.05, itg._COMPOSITIONS[method], 0) == z


@pytest.mark.parametrize(("J", "w0"), [([1.0, 2.0, 3.0], [0.8, -0.5, 0.6]), ([1.0, 2.0, 3.0], [1.5, 0.4, 0.2]),
                                       ([1.0, 2.0, 3.0], [1e-4, 1.0, 1e-4]), ([1.0, 2.0, 3.0], [0.3, 0.5, 1e3])])
def test_tabulated_and_direct_evaluation_agree(J, w0):
    # The piecewise Chebyshev tables reproduce ellipj + Carlson to round-off
    # (their last coefficients are checked at build time); near the
    # separatrix the tables are declined and both paths are the direct one.
    # Tolerance: the elliptic argument u ~ |omega| t (up to 1e4 here) is
    # reduced by the period differently in the two paths, each carrying
    # ~|u| eps absolute rounding: 1e-13 + 8 eps |omega| t_max.
    t = np.random.default_rng(RNG_SEED + 5).uniform(-10.0, 10.0, 2000)
    a = rb.free_body_solution(J, w0, P0).at(t)
    b = rb.free_body_solution(J, w0, P0, tables=False).at(t)
    tol = 1e-13 + 8 * np.finfo(float).eps * np.abs(w0).max() * 10.0
    assert _qdist(a.p, b.p).max() < tol
    np.testing.assert_allclose(a.omega_body, b.omega_body, rtol=0, atol=tol * np.abs(w0).max())


def test_compensated_splitting_keeps_the_norm_at_one_ulp():
    # Same method, same trajectory up to round-off (the rotation angles are
    # rounded differently, tan vs cos/sin: ~eps per step, a random walk
    # amplified by the flow's O(1) Lyapunov growth -> 1e-11 after 2e4 steps),
    # but |p| - 1 stays at ~1 ulp instead of a sqrt(n) eps random walk:
    # after 2e4 Strang steps (8e4 rotations) the plain version is typically
    # at 1e-14; the compensated one must stay below 2e-15 (~9 ulps).
    y0 = np.concatenate([P0, [0.8, -0.5, 0.6]])
    plain = itg.integrate(rb.FreeBodyModel([1.0, 2.0, 3.0]), y0, (0.0, 200.0), method="splitting", dt=0.01,
                          save_every=100)
    comp = itg.integrate(rb.FreeBodyModel([1.0, 2.0, 3.0], compensated=True), y0, (0.0, 200.0),
                         method="splitting", dt=0.01, save_every=100)
    np.testing.assert_allclose(comp.states, plain.states, rtol=0, atol=1e-11)
    assert comp.drift.max_abs["p_norm"] < 2e-15
    # the flow-by-flow path (step function) agrees with the fast loop
    m = rb.FreeBodyModel([1.0, 2.0, 3.0], compensated=True)
    y = y0
    for _ in range(20):
        y = itg.splitting4_step(m, y, 0.05)
    run = itg.integrate(m, y0, (0.0, 1.0), method="splitting4", dt=0.05)
    np.testing.assert_allclose(run.states[-1], y, rtol=0, atol=1e-13)


# ------------------------------------------------------------ fuzz findings
def _rotated_tensor(moments, seed=3):
    q = np.random.default_rng(seed).normal(size=4)
    R = matrix_from_euler_parameters(q / np.linalg.norm(q))
    return R @ np.diag(moments) @ R.T


@pytest.mark.parametrize(
    "call",
    [
        lambda J: rb.FreeBodyModel(J),
        lambda J: rb.RigidBody(1.0, J),
        lambda J: rb.free_body_solution(J, [1.0, 0.2, 0.1], P0),
        lambda J: rb.principal_axes(J),
        lambda J: rb.rotational_kinetic_energy(J, [1.0, 0.0, 0.0]),
        lambda J: rb.angular_momentum_global(J, [1.0, 0.0, 0.0], P0),
    ],
)
def test_inertia_must_satisfy_the_triangle_inequality(call):
    # (1, 1, 3) belongs to no mass distribution (J3 <= J1 + J2 for every
    # body); it was accepted and integrated.
    for J in ([1.0, 1.0, 3.0], [3.0, 1.0, 1.0], _rotated_tensor([1.0, 1.0, 2.5]), [1e-6, 1.0, 1.001]):
        with pytest.raises(ValueError, match=r"inertia: expected principal moments that satisfy the triangle "
                                             r"inequality J1 \+ J2 >= J3 \(within 1e-12 of J3.* got moments"):
            call(J)
    # equality is a flat body (a plate), within the stated tolerance
    assert rb.INERTIA_TRIANGLE_TOL == 1e-12
    call([1.0, 1.0, 2.0])
    call([1.0, 1.5, 2.5 * (1.0 + 0.5e-12)])
    call(_rotated_tensor([1.0, 1.5, 2.5]))
    with pytest.raises(ValueError, match=r"inertia: expected positive-definite .* got moments"):
        call([0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"inertia: expected positive-definite .* got moments"):
        call([-1.0, 2.0, 2.0])


def test_angular_momentum_global_refuses_non_unit_euler_parameters():
    J = [1.0, 2.0, 2.5]
    w = np.array([0.3, -1.0, 0.2])
    with pytest.raises(ValueError, match=r"p: expected unit Euler parameters \(\| \|p\| - 1 \| <= 1e-06\), got norm 2\.0; "
                                         r"renormalize with core.rotations.normalize_euler_parameters"):
        rb.angular_momentum_global(J, w, 2.0 * P0)
    batch = np.stack([P0, P0 * (1.0 + 1e-3)])
    with pytest.raises(ValueError, match=r"got norm 1\.001 at index \(1,\)"):
        rb.angular_momentum_global(J, w, batch)
    for bad, shown in ((np.full(4, np.nan), "nan"), (np.array([1e200, 0, 0, 0]), r"1e\+200")):
        with pytest.raises(ValueError, match=rf"p: expected unit Euler parameters .* got norm {shown}"):
            rb.angular_momentum_global(J, w, bad)
    with pytest.raises(ValueError, match=r"p: expected shape \(\.\.\., 4\)"):
        rb.angular_momentum_global(J, w, P0[:3])
    # within the tolerance: normalized before use
    p = _unit([0.9, 0.1, -0.3, 0.2])
    np.testing.assert_allclose(rb.angular_momentum_global(J, w, p * (1 + 5e-7)),
                               matrix_from_euler_parameters(p) @ (np.array(J) * w), rtol=0, atol=2e-15)
    # the model's invariants still show a drift of |p| (the integrators' report)
    y = np.concatenate([2.0 * p, w])
    L = rb.FreeBodyModel(J).invariants(y)["angular_momentum_global"]
    np.testing.assert_allclose(L, 4.0 * matrix_from_euler_parameters(p) @ (np.array(J) * w), rtol=1e-14)


def test_free_body_model_angular_momentum_equals_the_free_function():
    rng = np.random.default_rng(RNG_SEED + 11)
    for J in ([1.0, 2.0, 2.5], _rotated_tensor([1.0, 1.4, 2.0], seed=5)):
        model = rb.FreeBodyModel(J)
        w = rng.normal(size=(20, 3))
        p = rng.normal(size=(20, 4))
        p /= np.linalg.norm(p, axis=-1, keepdims=True)
        ref = rb.angular_momentum_global(J, w, p)
        np.testing.assert_allclose(model.angular_momentum_global(w, p), ref, rtol=0, atol=1e-14)
        for k in range(20):  # one body at a time: the float path
            np.testing.assert_allclose(model.angular_momentum_global(w[k], p[k]), ref[k], rtol=0, atol=1e-14)
            np.testing.assert_allclose(rb.angular_momentum_global(J, w[k], p[k]), ref[k], rtol=0, atol=1e-14)
        # broadcasting: one orientation, many angular velocities
        np.testing.assert_allclose(model.angular_momentum_global(w, p[0]), rb.angular_momentum_global(J, w, p[0]),
                                   rtol=0, atol=1e-14)
        with pytest.raises(ValueError, match=r"p: expected unit Euler parameters"):
            model.angular_momentum_global(w[0], 2.0 * p[0])
        with pytest.raises(ValueError, match=r"omega_body: expected real numbers, got complex"):
            model.angular_momentum_global(w[0] + 0j, p[0])


def test_free_body_energy_is_exact_at_large_phases():
    # |omega| = 1e12 rad/s, times next to the half periods 2K of the elliptic
    # argument at u ~ 4e12: the old reduction computed j and u - 2 K j
    # separately, so sn, cn and the sign of omega disagreed there (energy
    # errors of 1e-8). One consistent (j, r) pair keeps the energy exact.
    J = np.array([1.0, 2.0, 3.0])
    w0 = np.array([1.0, 2.0, 3.0]) * 1e12 / math.sqrt(14.0)
    E0 = rb.rotational_kinetic_energy(J, w0)
    for tables in (True, False):
        sol = rb.free_body_solution(J, w0, P0, tables=tables)
        c = sol._c
        K, lam, u0 = c["K"], c["lam"], c["u0"]
        k = np.arange(1, 1001) * 17 + int(4e12 / (2 * K))
        t_b = ((2 * k + 1) * K - u0) / lam
        t = np.concatenate([t_b, np.nextafter(t_b, np.inf), np.nextafter(t_b, -np.inf)])
        m = sol.at(t)
        E = rb.rotational_kinetic_energy(J, m.omega_body)
        assert np.abs(E / E0 - 1.0).max() < 1e-14
        np.testing.assert_allclose(np.linalg.norm(m.p, axis=-1), 1.0, rtol=0, atol=1e-15)


def test_free_body_times_beyond_the_phase_bound_are_refused():
    # At |omega| >= 1e14 rad/s and t ~ 1 s the phases exceed 1e14 rad, where
    # float64 rounding alone turns the body by a degree; the energy came out
    # 10-33 % wrong. Refused, naming t and the bound.
    assert rb.FREE_BODY_MAX_PHASE == 1e14
    J = np.array([1.0, 2.0, 3.0])
    for w in (1e14, 1e15, 1e16):
        w0 = np.array([1.0, 2.0, 3.0]) * w / math.sqrt(14.0)
        sol = rb.free_body_solution(J, w0, P0)
        rate = np.linalg.norm(J * w0) / J[0]
        t_ok = 0.99 * rb.FREE_BODY_MAX_PHASE / rate
        E = rb.rotational_kinetic_energy(J, sol.at(np.linspace(0.0, t_ok, 101)).omega_body)
        assert np.abs(E / E[0] - 1.0).max() < 1e-14
        with pytest.raises(ValueError, match=r"t: expected \|t\| <= .* s for this motion, got \|t\| = 1 s: its phases "
                                             r"\(\|L\| \|t\| / J_min, .*\) would exceed FREE_BODY_MAX_PHASE = 1e\+14 rad"):
            sol.at([0.0, 1.0])
        with pytest.raises(ValueError, match=r"FREE_BODY_MAX_PHASE"):
            rb.free_body_exact(J, w0, P0, -1.0)
    # ordinary motions are not affected: a day at 10 rad/s is a phase of 2.6e6 rad
    m = rb.free_body_exact(J, [3.0, 5.0, 7.0], P0, [0.0, 86400.0])
    assert np.all(np.isfinite(m.p))


def test_free_body_angular_velocity_beyond_float64_is_refused():
    # |omega| ~ 1e160 overflowed: OverflowError or NaN energies.
    for J in ([1.0, 2.0, 3.0], [1.0, 1.0, 1.5]):
        with pytest.raises(ValueError, match=r"omega_body0: expected an angular velocity whose angular momentum squared "
                                             r"fits float64 .* got \|omega_body0\| = 1e\+160 rad/s"):
            rb.free_body_solution(J, [0.0, 0.0, 1e160], P0)
    sol = rb.free_body_solution([1.0, 2.0, 3.0], np.array([1.0, 2.0, 3.0]) * 1e140, P0)
    E = rb.rotational_kinetic_energy([1.0, 2.0, 3.0], sol.at(np.linspace(0, 1e-139, 50)).omega_body)
    assert np.abs(E / E[0] - 1.0).max() < 1e-14


def test_free_body_solution_does_not_freeze_the_callers_array():
    w0 = np.array([0.3, 1.0, 0.2])
    rb.free_body_solution([1.0, 2.0, 3.0], w0, P0)
    assert w0.flags.writeable


# ------------------------------------------------ orientations and loads given by the user
@pytest.mark.parametrize("scale", [1.0 + 0.9e-6, 1.0 - 0.9e-6, 1.0 + 1.1e-6, 0.0, 2.0])
def test_every_orientation_entry_applies_one_unit_norm_rule(scale):
    # free_body_exact, the state packers and angular_momentum_global share
    # core.rotations.UNIT_NORM_TOL: within it the parameters are normalized,
    # beyond it (norm 0, 2, or just past 1e-6) a ValueError names the
    # argument and the norm. (free_body_exact refused 1 + 1e-8 before.)
    from rigidlab.core.rotations import UNIT_NORM_TOL

    J, w = [1.0, 2.0, 3.0], [0.3, -0.5, 0.2]
    p = scale * P0
    calls = {
        "p0": lambda: rb.free_body_exact(J, w, p, 0.0).p,
        "p": lambda: rb.free_body_state(p, w)[:4],
        "p ": lambda: rb.euler_parameter_state(np.zeros(3), p, np.zeros(3), w)[3:7],
        "p  ": lambda: rb.angular_momentum_global(J, w, p),
    }
    if abs(scale - 1.0) <= UNIT_NORM_TOL:
        np.testing.assert_allclose(calls["p0"](), P0, rtol=0, atol=1e-15)
        np.testing.assert_allclose(calls["p"](), P0, rtol=0, atol=1e-15)
        np.testing.assert_allclose(calls["p "](), P0, rtol=0, atol=1e-15)
        calls["p  "]()
        return
    shown = re.escape(repr(float(np.linalg.norm(p))))
    for name, call in calls.items():
        name = name.strip()
        with pytest.raises(ValueError, match=rf"^{name}: expected unit Euler parameters "
                                             rf"\(\| \|{name}\| - 1 \| <= 1e-06\), got norm {shown}; renormalize"):
            call()


@pytest.mark.parametrize("method", ["rk4", "splitting", "DOP853"])
def test_integrate_refuses_euler_parameters_that_are_no_orientation(method):
    # norm 0 or 2 used to run silently (p = 0 stays 0: no orientation at all)
    w = np.array([0.3, -0.5, 0.2])
    free = rb.FreeBodyModel([1.0, 2.0, 3.0])
    body = rb.EulerParameterModel(rb.RigidBody(1.0, [1.0, 2.0, 3.0]))
    kw = {"dt": 0.1} if method != "DOP853" else {}
    half = np.full(4, 0.5)  # unit, exactly: the norms below are exact
    for scale in (0.0, 2.0, 3.5):
        cases = [(free, np.concatenate([scale * half, w]), r"state0\[0:4\]")]
        if not method.startswith("splitting"):
            cases.append((body, np.concatenate([np.zeros(3), scale * half, np.zeros(3), w]), r"state0\[3:7\]"))
        for model, y0, where in cases:
            with pytest.raises(ValueError, match=rf"^state0: expected Euler parameters {where} of norm within "
                                                 rf"max_drift=1 of 1 .* got norm {re.escape(repr(scale))};"):
                itg.integrate(model, y0, (0.0, 1.0), method=method, **kw)
    # a drifted state (what a previous run ended in) continues; the rule is
    # the run's own divergence limit max_drift on |p|
    y0 = np.concatenate([1.5 * P0, w])
    run = itg.integrate(free, y0, (0.0, 1.0), method=method, **kw)
    assert abs(np.linalg.norm(run.states[-1, :4]) - 1.5) < 1e-3
    with pytest.raises(ValueError, match=r"state0: expected Euler parameters state0\[0:4\] of norm within max_drift=0.1"):
        itg.integrate(free, y0, (0.0, 1.0), method=method, max_drift=0.1, **kw)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"force": 3}, r"^force: expected None, a constant \(3,\) vector \(N, global frame\) or a callable "
                       r"\(t, state\) -> \(3,\), got 3 \(shape \(\)\)"),
        ({"force": [1.0, 2.0]}, r"^force: expected None, a constant \(3,\) vector .* got \[1.0, 2.0\] \(shape \(2,\)\)"),
        ({"force": "up"}, r"^force: expected None, a constant \(3,\) vector .* got text 'up'"),
        ({"force": [0.0, True, 0.0]}, r"^force: expected None, a constant \(3,\) vector .* got a boolean in"),
        ({"force": [0.0, np.nan, 0.0]}, r"^force: expected finite values, got \[0.0, nan, 0.0\]"),
        ({"torque_body": 1j}, r"^torque_body: expected real numbers, got complex"),
        ({"torque_body": {"x": 1}}, r"^torque_body: expected None, a constant \(3,\) vector \(N m, body frame\)"),
    ],
)
def test_rigid_body_loads_are_validated_when_the_body_is_built(kwargs, match):
    # RigidBody(force=3) was accepted and failed later with a TypeError
    # ('int' object is not callable) inside the integrator.
    with pytest.raises(ValueError, match=match):
        rb.RigidBody(1.0, [1.0, 2.0, 3.0], **kwargs)


def test_constant_loads_are_vectors_and_give_the_closed_form_motion():
    # constant force: r = r0 + v0 t + F t^2 / (2 m) (RK4 is exact for it);
    # constant body torque about a principal axis of a body at rest:
    # omega_body = n t / J about that axis.
    F, n = np.array([0.0, 0.0, -9.81]), np.array([0.0, 0.0, 0.6])
    body = rb.RigidBody(2.0, [1.0, 2.0, 3.0], force=list(F), torque_body=n)
    assert body.force.flags.writeable is False and body.force.dtype == np.float64
    n[2] = 99.0  # the body keeps its own copy
    y0 = rb.euler_parameter_state([0, 0, 1.0], [1, 0, 0, 0], [1.0, 0, 0], [0, 0, 0])
    run = itg.integrate(rb.EulerParameterModel(body), y0, (0.0, 2.0), method="rk4", dt=0.1)
    np.testing.assert_allclose(run.states[-1, 0:3], [2.0, 0.0, 1.0 - 9.81], rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.states[-1, 10:13], [0.0, 0.0, 0.6 * 2.0 / 3.0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", ["rk4", "midpoint", "RK45"])
def test_a_load_callable_returning_the_wrong_shape_is_named(method):
    # was numpy's "could not broadcast input array from shape (2,) into shape (3,)"
    y0 = rb.euler_parameter_state(np.zeros(3), P0, np.zeros(3), [0.1, 0.2, 0.3])
    kw = {"dt": 0.1} if method != "RK45" else {}
    for kwargs, name, shape in (({"force": lambda t, y: np.zeros(2)}, "force", r"\(2,\)"),
                                ({"torque_body": lambda t, y: np.zeros((3, 1))}, "torque_body", r"\(3, 1\)"),
                                ({"force": lambda t, y: 0.0}, "force", r"\(\)")):
        model = rb.EulerParameterModel(rb.RigidBody(1.0, [1.0, 2.0, 3.0], **kwargs))
        with pytest.raises(ValueError, match=rf"^{name}: expected the callable to return shape \(3,\), got shape "
                                             rf"{shape} at t=0(\.05)?:"):
            itg.integrate(model, y0, (0.0, 1.0), method=method, **kw)
    model = rb.EulerParameterModel(rb.RigidBody(1.0, [1.0, 2.0, 3.0], force=lambda t, y: "up"))
    with pytest.raises(ValueError, match=r"^force: expected the callable to return a \(3,\) vector of real numbers "
                                         r"at t=0(\.05)?, got text 'up'"):
        itg.integrate(model, y0, (0.0, 1.0), method=method, **kw)


@pytest.mark.parametrize("method", ["rk4", "RK45"])
def test_a_load_callable_returning_nan_is_named_with_the_time_and_value(method):
    # was DivergenceError "non-finite state at step 3 (t=0.3); reduce the
    # step or tighten the tolerances", which blames the step size
    def force(t, y):
        return np.array([math.nan if t > 0.25 else 0.0, 0.0, 1.0])

    y0 = rb.euler_parameter_state(np.zeros(3), P0, np.zeros(3), [0.1, 0.2, 0.3])
    model = rb.EulerParameterModel(rb.RigidBody(1.0, [1.0, 2.0, 3.0], force=force))
    kw = {"dt": 0.1} if method == "rk4" else {"rtol": 1e-6}
    with pytest.raises(ValueError, match=r"^force: expected the callable to return finite values, got "
                                         r"\[nan, 0.0, 1.0\] at t=0\.[23]\d* for a finite state") as info:
        itg.integrate(model, y0, (0.0, 1.0), method=method, **kw)
    assert not isinstance(info.value, itg.DivergenceError)
    torque = rb.RigidBody(1.0, [1.0, 2.0, 3.0], torque_body=lambda t, y: np.array([0.0, math.inf, 0.0]))
    with pytest.raises(ValueError, match=r"^torque_body: expected the callable to return finite values, got "
                                         r"\[0.0, inf, 0.0\] at t=0 "):
        itg.integrate(rb.EulerParameterModel(torque), y0, (0.0, 1.0), method=method, **kw)
