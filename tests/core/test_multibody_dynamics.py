"""Dynamics of core.multibody against independent oracles.

* Newton-Euler and Euler-parameter forms of the equations (Eqs. 8.51-8.57)
  give the same accelerations and multipliers at random states.
* A planar double pendulum of uniform rods on revolute joints against its
  reduced Lagrange equations (core.models.pendulum_chain_reduced),
  integrated by DOP853 at rtol 1e-12.
* The heavy top (one body, one spherical joint) against core.gyroscope's
  exact (elliptic-function) motion.
* A slider-crank against the closed-form slider position and velocity.
* Joint reactions of statically loaded mechanisms against statics by hand.
* Energy conservation without dissipation, dissipation with dampers,
  residuals at round-off, Baumgarte and the fixed-step methods.
* A planar four-bar of revolute joints (three redundant equations) against
  Freudenstein's closed-form position analysis.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigidlab.core.gyroscope import RotorParams
from rigidlab.core.gyroscope import simulate as gyroscope_simulate
from rigidlab.core.models import heavy_top, pendulum_chain, pendulum_chain_reduced, slider_crank, spatial_double_pendulum
from rigidlab.core.multibody import System
from rigidlab.core.rotations import (
    constant_relative_rotation_residual,
    euler_angle_G,
    matrix_from_euler_angles,
    matrix_from_euler_parameters,
)

SEED = 8102


# ------------------------------------------------------------------ two forms
def _random_mixed_system(rng):
    system = System(gravity=(0.3, -0.2, -9.81))
    bodies = []
    for k in range(4):
        J = np.diag(rng.uniform(0.3, 0.6, 3))
        R = np.linalg.qr(rng.standard_normal((3, 3)))[0]
        bodies.append(system.add_body(f"b{k}", mass=rng.uniform(0.5, 2.0), inertia=R @ J @ R.T,
                                      position=rng.standard_normal(3),
                                      orientation=(lambda p: p / np.linalg.norm(p))(rng.standard_normal(4))))
    system.add_joint("revolute", system.ground, bodies[0], point=rng.standard_normal(3), axis=rng.standard_normal(3))
    system.add_joint("spherical", bodies[0], bodies[1], point=rng.standard_normal(3))
    a = rng.standard_normal(3)
    system.add_joint("universal", bodies[1], bodies[2], point=rng.standard_normal(3), axis=a,
                     axis_j=np.cross(a, rng.standard_normal(3)))
    j = system.add_joint("cylindrical", bodies[2], bodies[3], point=rng.standard_normal(3), axis=rng.standard_normal(3))
    system.add_motor(j, angle=lambda t: 0.5 * np.sin(t))
    system.add_spring_damper(bodies[0], rng.standard_normal(3), bodies[3], rng.standard_normal(3), stiffness=20.0,
                             damping=1.0)
    system.add_rotational_spring_damper(system.joints[0], stiffness=3.0, damping=0.2, angle0=0.1)
    system.add_torque(bodies[1], lambda t, s: np.array([0.1, 0.2, -0.3]) * math.cos(t))
    system.add_force(bodies[2], lambda t, s: -0.5 * s.velocity(bodies[2]), point=rng.standard_normal(3))
    return system


def test_newton_euler_and_euler_parameter_forms_agree():
    rng = np.random.default_rng(SEED)
    for _ in range(3):
        system = _random_mixed_system(rng)
        system.assemble()
        n = len(system.bodies)
        state = system.state.displaced(dv=rng.standard_normal(6 * n))
        system.set_state(state)
        system.assemble()  # velocities onto D v + C_t = 0 (accelerations are defined anywhere; keep it physical)
        ev = system.evaluate(t=0.7)
        q_dd, lam = ev.solve_euler_parameter_form()
        scale = max(1.0, float(np.max(np.abs(ev.q_ddot()))))
        np.testing.assert_allclose(q_dd, ev.q_ddot(), rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(lam, ev.multipliers, rtol=0, atol=1e-10 * max(1.0, np.max(np.abs(lam))))
        # the Euler-parameter mass matrix is 4 G_bar^T I G_bar: singular along p, p^T M p = 0
        p = ev._q[3 * n : 3 * n + 4]
        assert abs(p @ ev.M_q[3 * n : 3 * n + 4, 3 * n : 3 * n + 4] @ p) < 1e-12


# ------------------------------------------------------------------ double pendulum
def test_double_pendulum_of_rods_against_reduced_lagrange_equations():
    tilt, T = 1.1, 4.0
    system = pendulum_chain(2, length=0.8, mass=1.3, kind="rod", tilt=tilt)
    t = np.linspace(0.0, T, 41)
    traj = system.simulate(t, method="DOP853", rtol=1e-11, atol=1e-12)
    reduced = pendulum_chain_reduced(2, t, length=0.8, mass=1.3, kind="rod", tilt=tilt, rtol=1e-12, atol=1e-12)
    # chaotic-looking motion (large swing); both solutions at ~1e-11 local accuracy stay within 1e-8 over 4 s
    np.testing.assert_allclose(traj.position(system.bodies[0]), reduced.centres[:, 0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(traj.position(system.bodies[1]), reduced.centres[:, 1], rtol=0, atol=1e-8)
    # angular velocities about x equal the reduced angle rates
    np.testing.assert_allclose(traj.omega(system.bodies[1])[:, 0], reduced.rates[:, 1], rtol=0, atol=1e-7)
    assert np.ptp(traj.energy) < 1e-8 * abs(traj.energy[0] - traj.energy.min() + 1.0)
    assert traj.residual_position.max() < 1e-11 and traj.residual_velocity.max() < 1e-12


def test_point_mass_chain_uses_the_augmented_lu_path():
    """kind='point': zero rotational inertia (singular M); the augmented LU solve gives the reduced motion."""
    system = pendulum_chain(2, length=1.0, mass=1.0, kind="point", tilt=0.4)
    assert system.bodies[0].inertia.max() == 0.0
    t = np.linspace(0.0, 2.0, 21)
    traj = system.simulate(t, rtol=1e-11, atol=1e-12)

    def rhs(_, y):  # point-mass double pendulum, equal masses and lengths
        p1, p2, w1, w2 = y
        d = p1 - p2
        M = np.array([[2.0, math.cos(d)], [math.cos(d), 1.0]])
        f = np.array([-math.sin(d) * w2 * w2 - 2 * 9.81 * math.sin(p1), math.sin(d) * w1 * w1 - 9.81 * math.sin(p2)])
        return [w1, w2, *np.linalg.solve(M, f)]

    sol = solve_ivp(rhs, (0.0, 2.0), [0.4, 0.4, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    tip = np.stack([np.zeros(21), np.sin(sol.y[0]) + np.sin(sol.y[1]), -np.cos(sol.y[0]) - np.cos(sol.y[1])], axis=1)
    np.testing.assert_allclose(traj.position(system.bodies[1]), tip, rtol=0, atol=1e-8)


# ------------------------------------------------------------------ heavy top
def test_heavy_top_on_a_spherical_joint_reproduces_the_gyroscope_module():
    params = RotorParams(I=0.5, I3=0.4, mgl=1.2)
    state0 = np.array([0.3, 0.9, -0.2, 0.4, 0.5, 25.0])
    top = heavy_top(params, state0, mass=1.5, gravity=9.81)
    t = np.linspace(0.0, 3.0, 31)
    traj = top.system.simulate(t, rtol=1e-11, atol=1e-12)
    exact = gyroscope_simulate(params, state0, t)  # elliptic-function closed form
    A_exact = matrix_from_euler_angles(exact.angles, "ZXZ")
    A_mb = matrix_from_euler_parameters(traj.orientation(top.body))
    # the whole attitude (not only the axis): spin psi ~ 25 rad/s makes the matrix the sharpest check
    np.testing.assert_allclose(A_mb, A_exact, rtol=0, atol=1e-9)
    omega_exact = np.einsum("nij,nj->ni", euler_angle_G(exact.angles, "ZXZ"), exact.rates)
    np.testing.assert_allclose(traj.omega(top.body), omega_exact, rtol=0, atol=1e-8 * 25)
    np.testing.assert_allclose(traj.position(top.body), top.length * A_exact[:, :, 2], rtol=0, atol=1e-9)
    # the pivot carries the weight plus the centripetal/nutation loads: check the average over a nutation
    force, _ = traj.reaction(top.joint)
    assert force.shape == (31, 3)


# ------------------------------------------------------------------ slider-crank
def test_slider_crank_against_closed_form_kinematics():
    model = slider_crank(crank_length=0.1, rod_length=0.35, speed=9.0, phi0=0.4)
    t = np.linspace(0.0, 1.5, 61)
    traj = model.system.simulate(t, rtol=1e-10, atol=1e-12)
    phi = model.phi0 + model.speed * t
    np.testing.assert_allclose(traj.position(model.slider)[:, 0], model.slider_position(phi), rtol=0, atol=1e-10)
    np.testing.assert_allclose(traj.velocity(model.slider)[:, 0], model.slider_velocity(phi, model.speed),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.position(model.slider)[:, 1:], 0.0, atol=1e-12)
    # the crank turns at the motor's speed: omega = -speed y
    np.testing.assert_allclose(traj.omega(model.crank), np.tile([0.0, -model.speed, 0.0], (61, 1)), atol=1e-9)


def test_a_motor_at_constant_rate_is_the_constant_relative_rotation_of_eq_8_83():
    """The crank (body j) turns relative to the ground (body i) about -y at the motor's rate: the residual
    of core.rotations.constant_relative_rotation_residual (Eq. 8.83) stays at the integration accuracy."""
    model = slider_crank(speed=7.0, phi0=0.2)
    t = np.linspace(0.0, 1.0, 21)
    traj = model.system.simulate(t, rtol=1e-10, atol=1e-12)
    p = traj.orientation(model.crank)
    residual = constant_relative_rotation_residual(np.tile([1.0, 0.0, 0.0, 0.0], (21, 1)), p, (0.0, -1.0, 0.0), 7.0,
                                                   t, p_ij0=p[0])
    np.testing.assert_allclose(residual, 0.0, atol=1e-12)


# ------------------------------------------------------------------ statics
def test_reactions_of_a_cantilever():
    """A horizontal rod welded to the ground: the weld carries m g up and the moment m g L / 2."""
    m, L, g = 2.0, 1.5, 9.81
    system = System(gravity=(0.0, 0.0, -g))
    rod = system.add_body("rod", mass=m, inertia=(1e-3, m * L * L / 12, m * L * L / 12), position=(L / 2, 0, 0))
    weld = system.add_joint("fixed", system.ground, rod, point=(0.0, 0.0, 0.0))
    traj = system.simulate([0.0])
    F, T = traj.reaction(weld)
    np.testing.assert_allclose(F[0], [0.0, 0.0, m * g], rtol=0, atol=1e-12)
    # the weight at x = L/2 has moment (L/2 x) x (-m g z) = +m g L/2 y about the weld: the weld balances it
    np.testing.assert_allclose(T[0], [0.0, -m * g * L / 2, 0.0], rtol=0, atol=1e-12)
    Fb, Tb = traj.reaction(weld, frame="body")
    np.testing.assert_allclose(Fb, F, atol=1e-12)  # the rod's frame is the global one here


def test_reactions_of_a_beam_held_by_a_motor_with_a_tip_load():
    """Hinged beam held level by its motor, weight m g at L/2 and a load P down at the tip."""
    m, L, g, P = 1.5, 0.8, 9.81, 7.0
    system = System(gravity=(0.0, 0.0, -g))
    beam = system.add_body("beam", mass=m, inertia=(1e-3, m * L * L / 12, m * L * L / 12), position=(L / 2, 0, 0))
    hinge = system.add_joint("revolute", system.ground, beam, point=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    motor = system.add_motor(hinge, angle=(lambda t: 0.0, lambda t: 0.0, lambda t: 0.0))
    system.add_force(beam, lambda t, s: np.array([0.0, 0.0, -P]), point=(L, 0.0, 0.0))
    traj = system.simulate([0.0])
    F, T = traj.reaction(hinge)
    np.testing.assert_allclose(F[0], [0.0, 0.0, m * g + P], rtol=0, atol=1e-12)
    # moment about the hinge of the loads: (m g L/2 + P L) about +y; the motor's torque opposes it
    Fm, Tm = traj.reaction(motor)
    np.testing.assert_allclose(Fm[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(Tm[0], [0.0, -(m * g * L / 2 + P * L), 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(T[0], Tm[0], atol=1e-12)  # the revolute rows carry no moment about the axis


def test_reactions_of_a_slider_crank_at_rest_against_virtual_work():
    """No gravity, crank held by its motor, force P along +x on the slider.

    Virtual work: tau dphi + P dx = 0 -> tau = -P dx/dphi about the crank axis (-y). The rod is a two-force
    member along its line, so the prismatic joint pushes the slider with -F_rod_z where
    F_rod = P / cos(beta) along the rod, beta its angle with the x axis.
    """
    P = 40.0
    model = slider_crank(crank_length=0.1, rod_length=0.3, speed=0.0, phi0=0.7, gravity=0.0)
    model.system.add_force(model.slider, lambda t, s: np.array([P, 0.0, 0.0]))
    traj = model.system.simulate([0.0])
    phi, r, l = model.phi0, model.crank_length, model.rod_length
    root = math.sqrt(l * l - (r * math.sin(phi)) ** 2)
    dx_dphi = -r * math.sin(phi) * (1.0 + r * math.cos(phi) / root)
    _, Tm = traj.reaction(model.motor)
    # torque on the crank about -y that balances: tau = -P dx/dphi, i.e. T = -tau (-y)... in global y:
    np.testing.assert_allclose(Tm[0] @ np.array([0.0, -1.0, 0.0]), -P * dx_dphi, rtol=1e-10)
    # slider: P + rod force x + 0 = 0 and z balance through the prismatic joint
    sin_beta = r * math.sin(phi) / l
    tan_beta = sin_beta / math.sqrt(1.0 - sin_beta**2)
    Fs, _ = traj.reaction(model.slider_joint)
    # rod pushes the slider with -P along x and +P tan(beta) along z (the pin is below the crank pin)
    np.testing.assert_allclose(Fs[0], [0.0, 0.0, -P * tan_beta], rtol=0, atol=1e-9 * P)
    np.testing.assert_allclose(traj.multipliers.shape, (1, model.system.evaluate().C.size))


def test_reaction_on_the_ground_is_the_opposite_of_the_reaction_on_the_body():
    """The same driven hinge added as (ground, rod) and as (rod, ground): action and reaction at the hinge.

    Reversing the joint reverses its angle (the ground relative to the rod), so the motor turns the other way
    round to give the same motion.
    """

    def run(ground_first):
        system = System(gravity=(0.0, 0.0, -9.81))
        rod = system.add_body("rod", mass=2.0, inertia=(1e-3, 0.375, 0.375), position=(0.75, 0.0, 0.0),
                              orientation=(math.cos(0.2), 0.0, math.sin(0.2), 0.0))
        pair = (system.ground, rod) if ground_first else (rod, system.ground)
        hinge = system.add_joint("revolute", *pair, point=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
        w = 0.3 if ground_first else -0.3
        motor = system.add_motor(hinge, angle=(lambda t: w * t, lambda t: w, lambda t: 0.0))
        system.assemble()
        traj = system.simulate(np.linspace(0.0, 1.0, 5))
        return traj.reaction(hinge), traj.reaction(motor), traj.position(rod)

    (F1, T1), (Fm1, Tm1), R1 = run(True)
    (F2, T2), (Fm2, Tm2), R2 = run(False)
    np.testing.assert_allclose(R1, R2, atol=1e-12)
    np.testing.assert_allclose(F1, -F2, atol=1e-12)
    np.testing.assert_allclose(T1, -T2, atol=1e-12)
    np.testing.assert_allclose(Tm1, -Tm2, atol=1e-12)
    assert np.abs(Tm1[:, 1]).min() > 1.0  # the motor really holds the rod's weight


def test_equilibrium_of_a_pendulum_pushed_sideways():
    """A rod on a revolute joint under a constant horizontal tip force: tan(phi) = F L / (m g L/2)."""
    m, L, g, Fx = 1.0, 1.0, 9.81, 3.0
    system = pendulum_chain(1, length=L, mass=m)
    rod = system.bodies[0]
    system.add_force(rod, lambda t, s: np.array([0.0, Fx, 0.0]), point=(0.0, 0.0, -L))
    report = system.equilibrium()
    phi = math.atan2(Fx * L, m * g * L / 2)
    R = system.state.position(rod)
    np.testing.assert_allclose(R, [0.0, 0.5 * L * math.sin(phi), -0.5 * L * math.cos(phi)], atol=1e-10)
    assert report.moved == ("link0",) and report.residual_force < 1e-9
    F, _ = system.simulate([0.0]).reaction(system.joints[0])
    np.testing.assert_allclose(F[0], [0.0, -Fx, m * g], atol=1e-9)


# ------------------------------------------------------------------ conservation
def test_energy_is_conserved_without_dissipation_and_decays_with_dampers():
    model = spatial_double_pendulum()
    t = np.linspace(0.0, 2.0, 21)
    traj = model.system.simulate(t, rtol=1e-10, atol=1e-12)
    assert np.ptp(traj.energy) < 1e-8  # J, energy ~ 10 J: the solver's tolerance

    system = pendulum_chain(2, tilt=0.8)
    a, b = system.bodies
    spring = system.add_spring_damper(system.ground, (0.0, 0.5, 0.0), b, system.state.point(b, (0, 0, -0.5)),
                                      stiffness=15.0, free_length=0.4)
    system.add_rotational_spring_damper(system.joints[1], stiffness=2.0, angle0=0.3)
    traj = system.simulate(t, rtol=1e-10, atol=1e-12)
    assert np.ptp(traj.energy) < 1e-8
    assert spring.free_length == 0.4

    damped = pendulum_chain(2, tilt=0.8)
    damped.add_spring_damper(damped.ground, (0.0, 0.5, 0.0), damped.bodies[1],
                             damped.state.point(damped.bodies[1], (0, 0, -0.5)), stiffness=15.0, damping=0.5)
    damped.add_rotational_spring_damper(damped.joints[0], stiffness=2.0, damping=0.3)
    traj = damped.simulate(t, rtol=1e-10, atol=1e-12)
    assert np.all(np.diff(traj.energy) < 1e-9) and traj.energy[-1] < traj.energy[0] - 0.1


def test_residuals_stay_at_round_off_and_baumgarte_and_none_compare():
    system = pendulum_chain(4, tilt=0.6)
    t = np.linspace(0.0, 5.0, 51)
    proj = system.simulate(t, rtol=1e-7, atol=1e-9)
    assert proj.residual_position.max() <= 1e-12 and proj.residual_velocity.max() <= 1e-13
    none = system.simulate(t, rtol=1e-7, atol=1e-9, stabilization="none")
    baum = system.simulate(t, rtol=1e-7, atol=1e-9, stabilization="baumgarte", baumgarte=20.0)
    # the bare index-1 equations drift; feedback keeps the drift bounded; projection removes it
    assert none.residual_position.max() > 1e-9
    assert baum.residual_position.max() < none.residual_position.max()
    assert baum.residual_position.max() > proj.residual_position.max()


@pytest.mark.parametrize(("method", "dt", "tol"), [("rk4", 1 / 120, 1e-6), ("midpoint", 1 / 480, 1e-3)])
def test_fixed_step_methods_through_core_integrators(method, dt, tol):
    system = pendulum_chain(3, tilt=0.5)
    t = np.linspace(0.0, 0.5, 31)
    ref = system.simulate(t, rtol=1e-11, atol=1e-12)
    run = system.simulate(t, method=method, dt=dt)
    err = max(np.abs(run.position(b) - ref.position(b)).max() for b in system.bodies)
    assert err < tol
    assert run.residual_position.max() <= 1e-12 and run.n_steps == math.ceil(0.5 / dt - 1e-9)


# ------------------------------------------------------------------ redundancy
def _four_bar(a=0.2, b=0.5, c=0.4, d=0.45, theta2=1.0):
    """Planar four-bar in the x-z plane: ground link d along x, crank a at (0, 0), rocker c at (d, 0)."""
    # Freudenstein position analysis for the assembly
    Ax, Az = a * math.cos(theta2), a * math.sin(theta2)
    e = math.hypot(d - Ax, Az)
    alpha = math.atan2(-Az, d - Ax)
    gamma = math.acos((c * c + e * e - b * b) / (2 * c * e))
    theta4 = math.pi + alpha - gamma  # open configuration
    Bx, Bz = d + c * math.cos(theta4), c * math.sin(theta4)
    system = System(gravity=(0.0, 0.0, -9.81))

    def rod(name, p, q, mass):
        direction = (np.array(q) - np.array(p)) / np.linalg.norm(np.array(q) - np.array(p))
        angle = math.atan2(direction[2], direction[0])
        # body x axis along the link: rotation about -y by the link angle
        orientation = (math.cos(angle / 2), 0.0, -math.sin(angle / 2), 0.0)
        length = float(np.linalg.norm(np.array(q) - np.array(p)))
        return system.add_body(name, mass=mass, inertia=(1e-4, mass * length**2 / 12, mass * length**2 / 12),
                               position=0.5 * (np.array(p) + np.array(q)), orientation=orientation)

    A = (Ax, 0.0, Az)
    B = (Bx, 0.0, Bz)
    crank = rod("crank", (0, 0, 0), A, 0.3)
    coupler = rod("coupler", A, B, 0.8)
    rocker = rod("rocker", (d, 0, 0), B, 0.6)
    y = (0.0, 1.0, 0.0)
    system.add_joint("revolute", system.ground, crank, point=(0, 0, 0), axis=y)
    system.add_joint("revolute", crank, coupler, point=A, axis=y)
    system.add_joint("revolute", system.ground, rocker, point=(d, 0, 0), axis=y)
    closing = system.add_joint("revolute", coupler, rocker, point=B, axis=y, name="closing")
    return system, (crank, coupler, rocker), closing, (a, b, c, d)


def test_redundant_four_bar_reports_and_simulates():
    system, (crank, coupler, rocker), closing, (a, b, c, d) = _four_bar()
    report = system.assemble()
    assert report.n_constraints == 20 and report.rank == 17 and report.degrees_of_freedom == 1
    assert len(report.redundant) == 3 and all(r.startswith("closing (revolute)") for r in report.redundant)
    t = np.linspace(0.0, 2.0, 41)
    traj = system.simulate(t, rtol=1e-10, atol=1e-12)
    assert traj.residual_position.max() < 1e-11 and np.ptp(traj.energy) < 1e-8
    # kinematics against Freudenstein: rocker angle from the simulated crank angle
    R_crank = traj.position(crank)
    theta2 = np.arctan2(R_crank[:, 2], R_crank[:, 0])
    Ax, Az = a * np.cos(theta2), a * np.sin(theta2)
    e = np.hypot(d - Ax, Az)
    theta4 = np.pi + np.arctan2(-Az, d - Ax) - np.arccos((c * c + e * e - b * b) / (2 * c * e))
    R_rocker = traj.position(rocker)
    np.testing.assert_allclose(R_rocker[:, 0], d + 0.5 * c * np.cos(theta4), atol=1e-9)
    np.testing.assert_allclose(R_rocker[:, 2], 0.5 * c * np.sin(theta4), atol=1e-9)
    # the redundant rows carry no load (their multipliers are set to zero)
    lam = traj.multipliers
    dropped = sorted(set(range(20)) - set(system.evaluate().independent.tolist()))
    assert len(dropped) == 3 and np.all(lam[:, dropped] == 0.0)
    assert np.all(np.abs(lam[:, 17:]).max(axis=1) > 0)  # ... while the closing joint's kept rows do


@pytest.mark.slow
def test_ten_link_chain_residuals_over_100_seconds():
    system = pendulum_chain(10, tilt=0.5)
    t = np.arange(0.0, 100.0 + 1e-9, 1.0 / 60.0)
    traj = system.simulate(t, rtol=1e-6, atol=1e-8)
    assert traj.residual_position.max() <= 1e-10
    assert traj.residual_velocity.max() <= 1e-10
    # energy is not conserved to round-off (the integrator's tolerance), but it must not drift away
    assert np.ptp(traj.energy) < 1e-3 * abs(traj.energy[0])
