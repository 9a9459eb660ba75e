"""rigidlab.core.modal against independent oracles: closed-form frequencies, hand-built state-space
matrices, the gyroscope's critical spin, the reduced top and the nonlinear simulation."""

from __future__ import annotations

import concurrent.futures
import csv
import io
import json
import math
import warnings

import numpy as np
import pytest
import scipy.linalg

from rigidlab.core.gyroscope import RotorParams, sleeping_top_critical_spin
from rigidlab.core.multibody import AssemblyError
from rigidlab.core.modal import RIGID_TOL, LinearModel, Modes, _linearize, linearize, sweep
from rigidlab.core.models import (
    disk_rotor,
    pendulum_chain,
    rolling_disk,
    slider_crank,
    spatial_double_pendulum,
    spherical_pendulum,
    steady_top,
    two_mass_oscillator,
)

G = 9.81
TOP = RotorParams(I=0.05, I3=0.02, mgl=0.5)


def _pairs(modes: Modes) -> np.ndarray:
    """omega_n of the oscillating pairs (one per pair), increasing."""
    keep = ~modes.rigid & (modes.eigenvalues.imag > 0)
    return np.sort(modes.omega_n[keep])


# ------------------------------------------------------------------ chains
@pytest.mark.parametrize("length, mass", [(1.0, 1.0), (0.7, 2.5)])
def test_double_pendulum_point_masses(length, mass):
    modes = linearize(pendulum_chain(2, length, mass, "point")).modes()
    expected = np.sqrt(G / length * np.array([2.0 - math.sqrt(2.0), 2.0 + math.sqrt(2.0)]))
    assert modes.method == "symmetric"
    np.testing.assert_allclose(_pairs(modes), expected, rtol=1e-8)
    assert modes.is_stable and np.all(modes.critical)


def test_double_pendulum_uniform_rods():
    L = 1.3
    modes = linearize(pendulum_chain(2, L, 0.8, "rod")).modes()
    expected = np.sqrt(G / L * np.array([3.0 - 6.0 / math.sqrt(7.0), 3.0 + 6.0 / math.sqrt(7.0)]))
    np.testing.assert_allclose(_pairs(modes), expected, rtol=1e-8)


def test_triple_pendulum_characteristic_cubic():
    # equal point masses and links: (omega^2 l / g)^3 - 9 (.)^2 + 18 (.) - 6 = 0
    roots = np.sort(np.roots([1.0, -9.0, 18.0, -6.0]).real)
    modes = linearize(pendulum_chain(3, 1.0, 1.0, "point")).modes()
    np.testing.assert_allclose(_pairs(modes) ** 2 / G, roots, rtol=1e-8)


def test_point_pendulum_needs_geometric_stiffness():
    """In absolute coordinates the restoring stiffness is all geometric (d(C_q^T lambda)/dq)."""
    lin = linearize(pendulum_chain(1, 0.5, 2.0, "point"))
    modes = lin.modes()
    np.testing.assert_allclose(_pairs(modes) ** 2, [G / 0.5], rtol=1e-10)
    # the applied force (gravity) alone has no stiffness: everything comes from the multipliers
    from rigidlab.core.multibody import _linearization as hooks

    system = pendulum_chain(1, 0.5, 2.0, "point")
    eng, ref = hooks.reference(system, 0.0, np.zeros(3))
    assert np.max(np.abs(hooks.constraint_stiffness(eng, ref))) > 1.0


@pytest.mark.parametrize("make", [
    lambda: pendulum_chain(4, kind="rod", tilt=0.0),
    lambda: pendulum_chain(3, kind="point"),
    lambda: spatial_double_pendulum(tilt=(0.0, 0.0), azimuth=(0.0, 0.0), spin=0.0).system,
    lambda: spherical_pendulum().system,
])
def test_analytic_geometric_stiffness_matches_differences(make):
    system = make()
    a = _linearize(system, frame_omega=None, steady_tol=1e-6, constraint_stiffness="analytic")
    d = _linearize(system, frame_omega=None, steady_tol=1e-6, constraint_stiffness="differences")
    scale = np.max(np.abs(a.K))
    np.testing.assert_allclose(a.K, d.K, atol=1e-9 * scale)
    assert d.derivative_error < 1e-6


@pytest.mark.parametrize("make", [lambda: slider_crank().system, lambda: pendulum_chain(3, tilt=0.4),
                                  lambda: spatial_double_pendulum().system])
def test_constraint_stiffness_is_the_derivative_of_the_constraint_forces(make):
    """Every row of the table (motors included), random multipliers, off equilibrium."""
    from dataclasses import replace

    from rigidlab.core.multibody import _linearization as hooks

    system = make()
    eng, ref = hooks.reference(system, 0.37, np.zeros(3))
    rng = np.random.default_rng(5)
    ref = replace(ref, multipliers=rng.normal(size=eng.m))
    K = hooks.constraint_stiffness(eng, ref)
    n = eng.n
    zero = np.zeros(6 * n)
    J = np.zeros_like(K)
    for k in range(6 * n):
        cols = []
        for h in (1e-4, -1e-4):
            d = zero.copy()
            d[k] = h
            y, _, A = hooks.perturbed_state(eng, ref, d, zero, zero)
            At, Y, _ = hooks.selected_vectors(eng, y)
            f = hooks.constraint_force(eng, ref.t, At, Y, ref.multipliers)
            f[3 * n :] = np.matmul(A, f[3 * n :].reshape(n, 3, 1)).ravel()
            cols.append(f)
        J[:, k] = (cols[0] - cols[1]) / 2e-4
    np.testing.assert_allclose(K, J, atol=1e-7 * np.max(np.abs(K)))


def test_spherical_pendulum_swing_and_spin():
    sp = spherical_pendulum(0.8, 1.5)
    modes = linearize(sp.system).modes()
    assert np.sum(modes.rigid) == 2  # free spin about the rod's axis
    np.testing.assert_allclose(_pairs(modes), np.sqrt(1.5 * G / 0.8) * np.ones(2), rtol=1e-8)
    assert np.all(np.isnan(modes.damping_ratio[modes.rigid]))


# ------------------------------------------------------------------ damping
def _random_spd(rng, n):
    X = rng.normal(size=(n, n))
    return X @ X.T + n * np.eye(n)


def test_proportional_damping_closed_form():
    rng = np.random.default_rng(12)
    M, K = _random_spd(rng, 4), _random_spd(rng, 4) * 30.0
    alpha, beta = 0.3, 2e-3
    undamped = LinearModel(M, K).modes()
    damped = LinearModel(M, K, C=alpha * M + beta * K).modes()
    assert undamped.method == "symmetric" and damped.method == "state-space"
    w = _pairs(undamped)
    np.testing.assert_allclose(_pairs(damped), w, rtol=1e-10)
    xi = damped.damping_ratio[damped.eigenvalues.imag > 0]
    np.testing.assert_allclose(np.sort(xi), np.sort(alpha / (2 * w) + beta * w / 2), rtol=1e-9)
    # proportional damping keeps the real normal modes
    up = undamped.shapes[undamped.eigenvalues.imag > 0]
    dp = damped.shapes[damped.eigenvalues.imag > 0]
    np.testing.assert_allclose(np.abs(np.sum(up * dp, axis=1)) / np.sum(up * up, axis=1), 1.0, rtol=1e-8)


def _state_space(M, K, C):
    n = M.shape[0]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.linalg.solve(M, K)
    A[n:, n:] = -np.linalg.solve(M, C)
    return A


def _same_spectrum(a, b, rtol):
    a, b = np.asarray(a), np.asarray(b)
    a = a[np.lexsort((a.real, np.round(a.imag, 6)))]
    b = b[np.lexsort((b.real, np.round(b.imag, 6)))]
    np.testing.assert_allclose(a, b, rtol=rtol, atol=rtol * np.max(np.abs(b)))


def test_non_proportional_damping_against_state_space():
    rng = np.random.default_rng(3)
    M, K = _random_spd(rng, 3), _random_spd(rng, 3) * 10.0
    C = np.diag([2.0, 0.0, 0.1])
    modes = LinearModel(M, K, C).modes()
    _same_spectrum(modes.eigenvalues, np.linalg.eigvals(_state_space(M, K, C)), 1e-12)
    # eigenvectors: A x = s x with x = [u, s u]
    A = _state_space(M, K, C)
    for s, u in zip(modes.eigenvalues, modes.complex_shapes):
        x = np.concatenate([u, s * u])
        np.testing.assert_allclose(A @ x, s * x, atol=1e-10 * np.max(np.abs(x)) * np.max(np.abs(A)))


def test_two_mass_oscillator_linearized_against_hand_built_matrices():
    osc = two_mass_oscillator()
    m1, m2 = osc.masses
    k1, k2 = osc.stiffness
    c1, c2 = osc.damping
    M = np.diag([m1, m2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    C = np.array([[c1 + c2, -c2], [-c2, c2]])
    modes = linearize(osc.system).modes()
    assert modes.method == "state-space"
    _same_spectrum(modes.eigenvalues, np.linalg.eigvals(_state_space(M, K, C)), 1e-9)
    assert modes.is_stable and not np.any(modes.critical)
    # not proportional: no alpha, beta with C = alpha M + beta K
    coef = np.linalg.lstsq(np.stack([M.ravel(), K.ravel()], axis=1), C.ravel(), rcond=None)
    assert coef[1][0] > 1e-3


# ------------------------------------------------------------------ rotors and tops
@pytest.mark.parametrize("speed", [0.0, 80.0, -150.0, 400.0])
def test_rotor_forward_and_backward_whirl(speed):
    rotor = disk_rotor(speed)
    modes = linearize(rotor.system).modes()
    Ip, It, kt = rotor.polar_moment, rotor.transverse_moment, rotor.tilt_stiffness
    root = math.sqrt((Ip * speed) ** 2 + 4 * It * kt)
    whirl = np.sort([(abs(Ip * speed) + root) / (2 * It), (-abs(Ip * speed) + root) / (2 * It)])
    translation = math.sqrt(rotor.translational_stiffness / 1.0)
    expected = np.sort(np.concatenate([whirl, [translation] * 3]))
    np.testing.assert_allclose(_pairs(modes), expected, rtol=1e-8)
    assert np.sum(modes.rigid) == 2  # the free spin
    if speed:
        assert modes.method == "state-space"
        assert np.max(np.abs(linearize(rotor.system).G)) > 0


@pytest.mark.parametrize("spin", [3.0, 10.0, 30.0, 100.0])
def test_rolling_disk_lean_in_steady_rolling(spin):
    """Thin disk rolling upright at spin n (rolling rows, moving reference): the lean obeys
    ``(A + m R^2) th'' + (C (C + m R^2) n^2 / A - m g R) th = 0``, ``A = m R^2 / 4``, ``C = m R^2 / 2``,
    i.e. ``s^2 = -(12 n^2 - 4 g / R) / 5``; the heading, place and spin angle are free."""
    R = 0.1
    system, _, _ = rolling_disk(radius=R, mass=1.3, spin=spin)
    lin = linearize(system)
    assert lin.position_rate_map is not None and lin.velocity_map.shape == (5, 3)
    s2 = -(12.0 * spin**2 - 4.0 * G / R) / 5.0
    root = np.sqrt(complex(s2))
    modes = lin.modes()
    live = modes.eigenvalues[~modes.rigid]
    near = np.min(np.abs(live[:, None] - np.array([root, -root])[None, :]), axis=0)
    np.testing.assert_allclose(near, 0.0, atol=1e-10 * abs(root))
    assert modes.is_stable is (s2 < 0)


def _slow_mode_beside_structural_zeros(lam: float, seed: int) -> LinearModel:
    """u = (a, b, q), s = (w, r): a_dot = w, b_dot = a + q, q_dot = r, w_dot = -lam w, r_dot = -q.

    ``a, b`` are ignorable (no force depends on them; ``b`` is a double zero
    eigenvalue, defective), ``w`` decays slowly at ``-lam`` and drives them,
    ``(q, r)`` is a unit oscillator; coordinates mixed by random rotations."""
    from scipy.stats import ortho_group

    T = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    Y = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    K = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    C = np.diag([lam, 0.0])
    Pu = ortho_group.rvs(3, random_state=seed)
    Ps = ortho_group.rvs(2, random_state=seed + 1)
    return LinearModel(np.eye(2), Ps.T @ K @ Pu, Ps.T @ C @ Ps, velocity_map=Pu.T @ T @ Ps,
                       position_rate_map=Pu.T @ Y @ Pu)


@pytest.mark.parametrize("seed", [1, 5, 9])
def test_slow_mode_beside_structural_zeros(seed):
    lam = 1e-4
    model = _slow_mode_beside_structural_zeros(lam, seed)
    modes = model.modes()
    assert np.sum(modes.rigid) == 2  # a and b, split off
    live = modes.eigenvalues[~modes.rigid]
    np.testing.assert_allclose(np.sort_complex(live), [-lam, -1j, 1j], atol=1e-8 * lam)
    # the plain eigenvalues of the state matrix: round-off splits the defective zero and moves -lam by ~lam^2
    plain = scipy.linalg.eigvals(model.state_matrix())
    assert np.min(np.abs(plain + lam)) > 1e-6 * lam


def _damped_oscillator(c: float) -> LinearModel:
    return LinearModel(np.eye(1), 4.0 * np.eye(1), C=c * np.eye(1))


def test_boundary_is_the_crossing_of_zero():
    """s = -c/2 +- i sqrt(4 - c^2/4): Re(s) = 0 at c = 0 exactly, not at the stability tolerance."""
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(_damped_oscillator, np.linspace(-1.0, 1.0, 4), executor=pool)
    b = result.boundaries(xtol=1e-15)
    assert b.shape == (1,) and abs(b[0]) < 1e-14


def test_undamped_divergence_boundary_is_the_collision_at_zero():
    """s = +-sqrt(-v): imaginary for v > 0 (real parts exactly 0), real for v < 0; the boundary is v = 0,
    not the grid value 0.5 where max Re(s) happens to be exactly 0."""
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(lambda v: LinearModel([[1.0]], [[v]]), [-1.0, 0.5, 1.0], executor=pool)
        b = result.boundaries(xtol=1e-13)
        assert b.shape == (1,) and abs(b[0]) <= 1e-13  # brentq's guarantee; the sign change of h is at 0 exactly
        # two degrees of freedom: det K = 2 v - 1 vanishes at v = 1/2; the smallest stiffness eigenvalue is
        # lam ~ 4/5 (v - 1/2) and counts as rigid while abs(lam) <= RIGID_TOL^2 lam_max (lam_max = 5/2)
        coupled = sweep(lambda v: LinearModel(np.eye(2), [[2.0, -1.0], [-1.0, v]]), [-1.0, 0.9, 2.0], executor=pool)
        b = coupled.boundaries(xtol=1e-14)
    assert b.shape == (1,) and abs(b[0] - 0.5) <= RIGID_TOL**2 * 2.5 / 0.8 + 1e-14


def _gyroscopic_pair(g: float) -> LinearModel:
    """Two inverted pendulum-like coordinates (K = -4 I) coupled by G = g [[0, 1], [-1, 0]]."""
    return LinearModel(np.eye(2), -4.0 * np.eye(2), G=g * np.array([[0.0, 1.0], [-1.0, 0.0]]))


@pytest.mark.parametrize("grid", [np.linspace(1.0, 7.0, 6), [0.0, 3.0, 5.0, 8.0], np.linspace(0.0, 10.0, 3)])
def test_undamped_flutter_boundary_is_the_collision_of_imaginary_roots(grid):
    """s^4 + (g^2 - 8) s^2 + 16 = 0: two imaginary pairs for g >= 2 sqrt(4) = 4, colliding at s = +-2i and
    leaving the axis as +-a +- i b below. Past the collision Re(s) = c sqrt(4 - g) with c ~ 1, so the crossing of
    Re(s) = STABILITY_TOL * scale lies (1e-8 * 2)^2 = 4e-16 from g = 4."""
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(_gyroscopic_pair, grid, executor=pool)
    b = result.boundaries(xtol=1e-13)
    assert b.shape == (1,) and abs(b[0] - 4.0) <= 1e-13 + 1e-15


HEAVY_TOP = RotorParams(I=0.02, I3=0.01, mgl=0.2)


def _heavy_top_model(spin: float) -> LinearModel:
    return linearize(steady_top(HEAVY_TOP, spin=spin).system)


@pytest.mark.parametrize("grid", [np.linspace(0.0, 30.0, 6), np.linspace(1.0, 30.0, 6)])
def test_heavy_top_boundary_from_a_coarse_undamped_grid(grid):
    """The sleeping top is undamped: above the critical spin 2 sqrt(mgl I) / I3 = 12.649 rad/s its real parts
    are round-off of either sign (exactly 0 at 18 and 18.4 rad/s on these grids), below it two imaginary pairs
    have collided. Re(s) ~ 1.26 sqrt(w_c - w) near w_c: the offset crossing lies 6e-16 from it."""
    wc = sleeping_top_critical_spin(HEAVY_TOP)
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(_heavy_top_model, grid, executor=pool)
    b = result.boundaries(xtol=1e-12)
    assert b.shape == (1,)
    # xtol, the offset crossing, and the relative error that linearize estimates for its difference
    # derivatives (2.9e-10; 2e-14 relative seen)
    assert abs(b[0] - wc) <= 1e-12 + 2e-15 + wc * _heavy_top_model(wc).derivative_error


def test_damped_rotor_is_asymptotically_stable():
    modes = linearize(disk_rotor(200.0, damping=20.0).system).modes()
    live = ~modes.rigid
    assert np.all(modes.eigenvalues.real[live] < 0)


@pytest.mark.parametrize("factor, stable", [(0.9, False), (1.1, True)])
def test_sleeping_top_stability_either_side_of_the_critical_spin(factor, stable):
    wc = sleeping_top_critical_spin(TOP)
    modes = linearize(steady_top(TOP, spin=factor * wc).system).modes()
    assert modes.is_stable is stable
    # I w^2 - I3 w3 w + mgl = 0 for the precession frequencies of the sleeping top
    w3 = factor * wc
    roots = np.roots([TOP.I, -TOP.I3 * w3, TOP.mgl])
    live = modes.eigenvalues[~modes.rigid]
    _same_spectrum(np.concatenate([1j * roots, -1j * roots]), live, 1e-8)


def test_precessing_top_nutation_against_the_reduced_top():
    """Nutation about steady precession: omega^2 = V_eff''(theta0) / I (Routh reduction in theta)."""
    w3, th0 = 3.0 * sleeping_top_critical_spin(TOP), 0.5
    top = steady_top(TOP, spin=w3, theta=th0)
    modes = linearize(top.system, frame_omega=top.frame_omega).modes()
    I, I3, mgl = TOP.I, TOP.I3, TOP.mgl
    p_psi = I3 * w3
    p_phi = I * top.phi_dot * math.sin(th0) ** 2 + p_psi * math.cos(th0)

    def V(th):
        return (p_phi - p_psi * math.cos(th)) ** 2 / (2 * I * math.sin(th) ** 2) + mgl * math.cos(th)

    h = 1e-4
    d2 = (-V(th0 + 2 * h) + 16 * V(th0 + h) - 30 * V(th0) + 16 * V(th0 - h) - V(th0 - 2 * h)) / (12 * h * h)
    assert abs(V(th0 + h) - V(th0 - h)) / (2 * h) < 1e-6 * abs(d2)  # the reference is steady
    np.testing.assert_allclose(_pairs(modes), [math.sqrt(d2 / I)], rtol=1e-7)
    assert np.sum(modes.rigid) == 4  # precession angle and spin angle, and their rates


def test_precessing_top_needs_its_frame():
    top = steady_top(TOP, spin=3.0 * sleeping_top_critical_spin(TOP), theta=0.5)
    with pytest.raises(ValueError, match="neither an equilibrium nor a steady motion"):
        linearize(top.system)


def test_released_pendulum_is_refused():
    with pytest.raises(ValueError, match="neither an equilibrium nor a steady motion.*link1"):
        linearize(pendulum_chain(2, tilt=0.3))


# ------------------------------------------------------------------ shapes and animation
def test_body_shapes_keep_the_joints_closed_to_first_order():
    system = pendulum_chain(3, kind="rod")
    modes = linearize(system).modes()
    shapes = modes.body_shapes(system)
    assert shapes.shape == (6, 18)
    eng = system._engine()
    from rigidlab.core.multibody._analysis import constraints_at

    for eps in (1e-3, 5e-4):
        y = np.concatenate([system.state.displaced(dq=eps * shapes[4]).q, system.state.v])
        C = constraints_at(eng.workspace(), 0.0, y, 0)[0]
        assert np.max(np.abs(C)) < 2.0 * eps**2
    np.testing.assert_allclose(np.max(np.abs(shapes), axis=1), 1.0)


def test_animate_projects_onto_the_constraints():
    system = spatial_double_pendulum(tilt=(0.0, 0.0), azimuth=(0.0, 0.0), spin=0.0).system
    modes = linearize(system).modes()
    j = int(np.argmax(modes.eigenvalues.imag))
    period = 2 * math.pi / modes.eigenvalues[j].imag
    motion = modes.animate(system, j, np.linspace(0.0, period, 9), amplitude=0.6)
    assert motion.positions.shape == (9, 2, 3) and motion.orientations.shape == (9, 2, 4)
    assert np.max(motion.residual_position) <= 1e-12
    # moved at t = 0, back after one period
    R0 = system.state.q[:6].reshape(2, 3)
    assert np.max(np.abs(motion.positions[0] - R0)) > 0.1
    np.testing.assert_allclose(motion.positions[-1], motion.positions[0], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(motion.orientations, axis=-1), 1.0)


@pytest.mark.slow
def test_linearized_response_against_nonlinear_simulation():
    """Tangent displacement from the nonlinear run minus eps Re(N S e^(st)): error ~ eps^2."""
    from rigidlab.core.multibody._engine import matrices

    system = pendulum_chain(2, kind="rod")
    lin = linearize(system)
    modes = lin.modes()
    j = int(np.argmax(modes.eigenvalues.imag))
    s = modes.eigenvalues[j]
    shape = modes.body_shapes(system)[j]
    q0 = system.state.q.copy()
    n = 2
    A0 = matrices(q0[3 * n :].reshape(n, 4))
    z_shape = lin.embedding.basis @ lin.embedding.basis.T @ np.concatenate(
        [shape[: 3 * n], np.einsum("nij,nj->ni", A0, shape[3 * n :].reshape(n, 3)).ravel()])
    t = np.linspace(0.0, 2 * 2 * math.pi / s.imag, 41)
    errors = []
    for eps in (2e-2, 1e-2):
        sysx = pendulum_chain(2, kind="rod")
        sysx.set_state(sysx.state.displaced(dq=eps * shape))
        sysx.assemble()
        traj = sysx.simulate(t, rtol=1e-11, atol=1e-13)
        err = 0.0
        for i, ti in enumerate(t):
            st = traj.state(i)
            R = st.q[: 3 * n].reshape(n, 3)
            A = matrices(st.q[3 * n :].reshape(n, 4))
            rho = (R - q0[: 3 * n].reshape(n, 3)).ravel()
            rel = np.einsum("nij,nkj->nik", A, A0)
            theta = np.stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0],
                              rel[:, 1, 0] - rel[:, 0, 1]], axis=1) / 2.0
            z = np.concatenate([rho, theta.ravel()])
            z_lin = eps * np.real(z_shape * np.exp(s * ti))
            err = max(err, float(np.max(np.abs(z - z_lin))))
        errors.append(err)
    ratio = errors[0] / errors[1]
    assert 3.5 < ratio < 4.5, errors


# ------------------------------------------------------------------ sorting, flags, export
def test_sorting_pairs_and_flags():
    M = np.diag([1.0, 2.0, 1.0])
    K = np.diag([4.0, -2.0, 0.0])
    modes = LinearModel(M, K).modes()
    s = modes.eigenvalues
    assert np.all(np.diff(np.abs(s.imag)[::1]) >= -1e-12)
    assert modes.rigid.sum() == 2 and (~modes.stable).sum() == 1
    np.testing.assert_allclose(np.sort(s.real[~modes.rigid & (s.imag == 0)]), [-1.0, 1.0])
    k = int(np.flatnonzero(s.imag > 0)[0])
    assert s[k + 1] == np.conj(s[k])
    np.testing.assert_allclose(modes.omega_n[k], 2.0)
    np.testing.assert_allclose(modes.frequency_hz[k], 2.0 / (2 * math.pi))


def test_export_csv_and_json():
    modes = linearize(two_mass_oscillator().system).modes()
    rows = list(csv.DictReader(io.StringIO(modes.to_csv())))
    assert len(rows) == 4
    np.testing.assert_allclose([float(r["eigenvalue_imag"]) for r in rows], modes.eigenvalues.imag)
    np.testing.assert_allclose([float(r["shape_1"]) for r in rows], modes.shapes[:, 1])
    doc = json.loads(modes.to_json())
    assert doc["method"] == "state-space" and doc["bodies"] == ["block1", "block2"]
    z = np.array([[complex(*c) for c in m["complex_shape"]] for m in doc["modes"]])
    np.testing.assert_allclose(z, modes.complex_shapes)
    rigid = json.loads(linearize(spherical_pendulum().system).modes().to_json())
    assert rigid["modes"][0]["rigid"] and rigid["modes"][0]["damping_ratio"] is None


# ------------------------------------------------------------------ sweeps
def rotor_model(speed: float) -> LinearModel:
    return linearize(disk_rotor(speed).system)


def top_model(spin: float) -> LinearModel:
    return linearize(steady_top(TOP, spin=spin).system)


def test_sweep_tracks_modes_by_shape_and_finds_the_top_boundary():
    wc = sleeping_top_critical_spin(TOP)
    calls = []
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        result = sweep(top_model, np.linspace(0.5 * wc, 1.5 * wc, 7), executor=pool,
                       progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (7, 7) and len(calls) == 7
    b = result.boundaries()
    assert b.shape == (1,)
    np.testing.assert_allclose(b[0], wc, rtol=1e-8)
    assert result.eigenvalues.shape == (7, 6)


def test_sweep_campbell_columns_follow_whirl():
    speeds = np.linspace(0.0, 400.0, 9)
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        result = sweep(rotor_model, speeds, executor=pool)
    rotor = disk_rotor(0.0)
    Ip, It, kt = rotor.polar_moment, rotor.transverse_moment, rotor.tilt_stiffness
    forward = (Ip * speeds + np.sqrt((Ip * speeds) ** 2 + 4 * It * kt)) / (2 * It)
    f = result.frequency_hz * 2 * math.pi
    # one tracked column is the forward whirl at every speed
    hits = [j for j in range(f.shape[1]) if np.allclose(f[1:, j], forward[1:], rtol=1e-8)]
    assert hits
    assert result.boundaries().size == 0
    assert result.to_csv().count("\n") == 10
    assert len(json.loads(result.to_json())["values"]) == 9


def test_sweep_stops_when_progress_raises():
    class Stop(Exception):
        pass

    def progress(done, total):
        raise Stop

    with concurrent.futures.ThreadPoolExecutor(1) as pool, pytest.raises(Stop):
        sweep(rotor_model, np.linspace(0.0, 100.0, 6), executor=pool, progress=progress)


@pytest.mark.slow
def test_sweep_default_process_pool():
    wc = sleeping_top_critical_spin(TOP)
    result = sweep(top_model, np.linspace(0.8 * wc, 1.2 * wc, 4))
    np.testing.assert_allclose(result.boundaries(), [wc], rtol=1e-8)


@pytest.mark.slow
def test_sweep_on_a_dask_cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        result = sweep(rotor_model, np.linspace(0.0, 300.0, 4), executor=client.get_executor())
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        serial = sweep(rotor_model, np.linspace(0.0, 300.0, 4), executor=pool)
    np.testing.assert_allclose(result.eigenvalues, serial.eigenvalues, atol=1e-9)


# ------------------------------------------------------------------ errors
def test_errors():
    with pytest.raises(ValueError, match="M: expected a positive definite"):
        LinearModel(np.diag([1.0, -1.0]), np.eye(2))
    with pytest.raises(ValueError, match="M: expected a symmetric"):
        LinearModel(np.array([[1.0, 0.5], [0.0, 1.0]]), np.eye(2))
    with pytest.raises(ValueError, match=r"K: expected shape \(2, 2\)"):
        LinearModel(np.eye(2), np.eye(3))
    with pytest.raises(ValueError, match="G: expected a skew-symmetric"):
        LinearModel(np.eye(2), np.eye(2), G=np.eye(2))
    with pytest.raises(ValueError, match="M: expected real numbers, got complex"):
        LinearModel(np.eye(2) * 1j, np.eye(2))
    matrix_modes = LinearModel(np.eye(2), np.eye(2)).modes()
    with pytest.raises(ValueError, match="built from matrices"):
        matrix_modes.body_shapes(pendulum_chain(1))
    modes = linearize(pendulum_chain(2)).modes()
    with pytest.raises(ValueError, match="the System that was linearized"):
        modes.body_shapes(pendulum_chain(3))
    with pytest.raises(ValueError, match="index: expected an integer mode index"):
        modes.animate(pendulum_chain(2), 9, [0.0], amplitude=0.1)
    with pytest.raises(ValueError, match="system: expected a rigidlab.core.multibody.System"):
        linearize("chain")
    with pytest.raises(ValueError, match="frame_omega: expected a finite"):
        linearize(pendulum_chain(1), frame_omega=(0.0, 1.0))
    with pytest.raises(ValueError, match="values: expected a non-empty 1-d array"):
        sweep(rotor_model, [1.0, 1.0])
    with pytest.raises(ValueError, match="build: the default process pool needs a picklable build"):
        sweep(lambda v: rotor_model(v), [1.0, 2.0])
    with pytest.raises(ValueError, match="executor: expected a concurrent.futures.Executor"):
        sweep(rotor_model, [1.0, 2.0], executor="pool")
    with concurrent.futures.ThreadPoolExecutor(1) as pool, pytest.raises(ValueError, match="build: expected"):
        sweep(lambda v: None, [1.0, 2.0], executor=pool)
    assert RIGID_TOL > 0


# ------------------------------------------------------------------ reviewed edge cases
def _spring_block(arm: float, *, attach: float | None = None, gravity=(0.0, 0.0, 0.0)):
    """A 1 kg block on a prismatic guide along x at x = ``arm``, held by a 100 N/m spring from the origin to the
    block point at x = ``attach`` (default: its centre of mass); sqrt(k / m) = 10 rad/s."""
    from rigidlab.core.multibody import System

    s = System(gravity=gravity)
    b = s.add_body("m", mass=1.0, inertia=(0.01,) * 3, position=(arm, 0.0, 0.0))
    s.add_joint("prismatic", s.ground, b, point=(arm, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    s.add_spring_damper(s.ground, (0.0, 0.0, 0.0), b, (arm if attach is None else attach, 0.0, 0.0), stiffness=100.0)
    s.assemble()
    return s


@pytest.mark.parametrize("length", [1.0, 5e-4, 3e-4, 1e-6])
def test_a_short_spring_at_the_centre_of_mass_has_its_stiffness(length):
    # the steps are no longer than the spring (they were 0.3 mm whatever its length: 13 % stiff at 0.5 mm, an
    # error at 0.3 mm); with steps of 3e-4 of it the differences' truncation is about (3e-4)^4
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        omega = linearize(_spring_block(length)).modes().omega_n
    np.testing.assert_allclose(omega, 10.0, rtol=1e-10)


def test_a_spring_equilibrium_without_gravity_is_not_refused_for_round_off():
    # the spring balances to 4e-17 m/s^2: the steady check's scale is the springs' k l / m, not 1e-12 m/s^2
    s = _spring_block(0.0105, attach=0.0005)
    np.testing.assert_allclose(linearize(s).modes().omega_n, 10.0, rtol=1e-10)


def test_a_state_off_the_constraints_is_refused():
    s = _spring_block(0.5)
    dq = np.zeros(6)
    dq[2] = 0.2  # 0.2 m off the guide
    s.set_state(s.state.displaced(dq=dq))
    with pytest.raises(AssemblyError, match=r"linearize: the current state violates the constraints .* prismatic"):
        linearize(s)


def test_a_body_turning_in_the_frame_without_symmetry_is_warned_about():
    from rigidlab.core.multibody import System

    # spin about the intermediate axis: unstable, s = +-w sqrt((I1 - I2)(I2 - I3) / (I1 I3)) = +-1 in its own frame
    s = System(gravity=(0.0, 0.0, 0.0))
    s.add_body("b", mass=1.0, inertia=(3.0, 2.0, 1.5), omega_body=(0.0, 3.0, 0.0))
    s.assemble()
    with pytest.warns(RuntimeWarning, match=r"body 'b' turns at 3 rad/s .* inertia is not symmetric"):
        linearize(s)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        modes = linearize(s, frame_omega=(0.0, 3.0, 0.0)).modes()
    assert not modes.is_stable
    assert np.max(modes.eigenvalues.real) == pytest.approx(1.0, rel=1e-8)
    # a pendulum whose joint axis turns in the frame
    with pytest.warns(RuntimeWarning, match=r"the axis of joint 'joint0' is not that axis"):
        linearize(pendulum_chain(2), frame_omega=(0.0, 0.0, 1.0))
    # symmetric rotors spinning about their axes: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        linearize(disk_rotor(80.0).system)


@pytest.mark.parametrize("axis", [0, 2])
def test_a_free_spinner_in_its_own_frame_is_stable_about_its_major_and_minor_axes(axis):
    from rigidlab.core.multibody import System

    w = np.zeros(3)
    w[axis] = 3.0
    s = System(gravity=(0.0, 0.0, 0.0))
    s.add_body("b", mass=1.0, inertia=(3.0, 2.0, 1.5), omega_body=w)
    s.assemble()
    modes = linearize(s, frame_omega=w).modes()
    # the translations across the axis seen from the turning frame: +-3i twice, split by round-off (real
    # parts about 3e-8); with a tilt of the whole spin, six roots at +-3i
    assert modes.is_stable
    near = np.abs(np.abs(modes.eigenvalues.imag) - 3.0) < 1e-6
    assert near.sum() == 6 and np.all(modes.critical[near])
    # nutation: w sqrt((I1 - I2)(I1 - I3) / (I2 I3)) about the major axis, sqrt((I1 - I3)(I2 - I3) / (I1 I2)) about
    # the minor one
    nutation = 3.0 * math.sqrt(1.0 * 1.5 / 3.0) if axis == 0 else 3.0 * math.sqrt(1.5 * 0.5 / 6.0)
    assert np.min(np.abs(np.abs(modes.eigenvalues.imag) - nutation)) < 1e-8


def test_animate_refuses_a_motion_that_left_the_floating_point_range():
    from rigidlab.core.multibody import System

    s = System(gravity=(0.0, 0.0, -9.81))
    b = s.add_body("bob", mass=1.0, inertia=(0.0,) * 3, position=(0.0, 0.0, 0.8))  # inverted: s = sqrt(g / L)
    s.add_joint("revolute", s.ground, b, point=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    s.assemble()
    modes = linearize(s).modes()
    k = int(np.argmax(modes.eigenvalues.real))
    assert modes.eigenvalues[k].real == pytest.approx(math.sqrt(9.81 / 0.8), rel=1e-9)
    with pytest.raises(ValueError, match=r"amplitude, t: .* not finite at t=300"):
        modes.animate(s, k, [0.0, 1.0, 300.0], amplitude=0.1)
    with pytest.raises(AssemblyError, match="animate: the configuration at t=0 could not be projected"):
        modes.animate(s, k, [0.0], amplitude=1e300)
    with pytest.raises(ValueError, match=r"t: expected a time or a 1-D array of times"):
        modes.animate(s, k, [[0.0, 1.0]], amplitude=0.1)


def test_linear_model_refuses_scales_out_of_range_and_bad_derivative_errors():
    with pytest.raises(ValueError, match="left the floating-point range"):
        LinearModel(1e-200 * np.eye(2), 1e200 * np.array([[2.0, -1.0], [-1.0, 1.0]])).modes()
    for bad in ("abc", None, float("nan"), -1.0, True):
        with pytest.raises(ValueError, match="derivative_error: expected a finite relative error >= 0"):
            LinearModel(np.eye(1), np.eye(1), derivative_error=bad)
    # an undamped mode's damping ratio is 0, not -0.0 (written "-0.0" in the CSV)
    ratio = LinearModel(np.eye(1), np.eye(1)).modes().damping_ratio
    assert np.all(ratio == 0.0) and not np.any(np.signbit(ratio))


def test_animating_a_rigid_body_mode_warns_and_a_vibration_mode_does_not():
    """The spherical pendulum's free spin about the rod is a rigid-body mode: animating it warns (it drifts,
    it does not oscillate); its swing modes animate silently."""
    import warnings

    from rigidlab.core.modal import RigidModeWarning

    sp = spherical_pendulum(0.8, 1.5)
    modes = linearize(sp.system).modes()
    rigid, swing = int(np.flatnonzero(modes.rigid)[0]), int(np.flatnonzero(~modes.rigid)[0])
    with pytest.warns(RigidModeWarning, match=rf"mode {rigid} is a rigid-body mode"):
        modes.animate(sp.system, rigid, [0.0, 0.1], amplitude=0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RigidModeWarning)
        modes.animate(sp.system, swing, [0.0, 0.1], amplitude=0.1)
        modes.flexible.animate(sp.system, 0, [0.0, 0.1], amplitude=0.1)
