"""Contact in the System against closed forms: resting and rolling spheres, the eccentric cam, separation."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from rigidlab.core.contact import PlanarCurve, Plane, Sphere, Torus
from rigidlab.core.multibody import System

G = 9.81


def _ball(radius=0.1, mass=2.0, **kw):
    system = System(gravity=(0.0, 0.0, -G))
    J = 0.4 * mass * radius**2
    ball = system.add_body("ball", mass=mass, inertia=(J, J, J), position=(0.0, 0.0, radius), **kw)
    return system, ball


def test_sphere_resting_on_a_plane_presses_with_its_weight():
    system, ball = _ball()
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    traj = system.simulate(np.linspace(0.0, 1.0, 11), rtol=1e-10, atol=1e-12)
    h = traj.contact(c)
    np.testing.assert_allclose(h.normal_force, 2.0 * G, rtol=1e-12)
    np.testing.assert_allclose(h.point, 0.0, atol=1e-14)
    np.testing.assert_allclose(h.normal, np.tile([0.0, 0.0, 1.0], (11, 1)), atol=1e-14)
    np.testing.assert_allclose(h.force, np.tile([0.0, 0.0, 2.0 * G], (11, 1)), rtol=1e-12, atol=1e-12)
    assert np.all(h.constraint) and traj.status == "completed" and traj.separations == ()
    # the chapter's five multipliers: lambda = N * normal force with C_s^T lambda = 0 (Eq. 8.105)
    np.testing.assert_allclose(h.multipliers[:, :3], np.tile([0.0, 0.0, 2.0 * G], (11, 1)), atol=1e-10)
    np.testing.assert_allclose(h.multipliers[:, 3:], 0.0, atol=1e-10)


def _cam(speed, *, stiffness=2000.0, preload=20.0, mass=0.5, radius=0.04, eccentricity=0.01):
    """Eccentric circular cam (turning about global z) under a flat-faced follower sliding along global y."""
    system = System(gravity=(0.0, -G, 0.0))
    cam = system.add_body("cam", mass=1.0, inertia=(1e-3, 1e-3, 1e-3))
    hinge = system.add_joint("revolute", system.ground, cam, point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0))
    system.add_motor(hinge, angle=(lambda t: speed * t, lambda t: speed, lambda t: 0.0))
    y0 = radius + 0.02  # follower's centre of mass, 2 cm above its face; cam angle 0: face at y = radius
    fol = system.add_body("follower", mass=mass, inertia=(1e-4, 1e-4, 1e-4), position=(0.0, y0, 0.0))
    system.add_joint("prismatic", system.ground, fol, point=(0.0, y0, 0.0), axis=(0.0, 1.0, 0.0))
    system.add_spring_damper(system.ground, (0.0, y0 + 0.1, 0.0), fol, (0.0, y0, 0.0), stiffness=stiffness,
                             free_length=0.1 + preload / stiffness)
    c = system.add_contact(cam, PlanarCurve.circle(radius, center=(eccentricity, 0.0)), fol,
                           PlanarCurve.line(point=(0.0, -0.02), normal=(0.0, -1.0)), stiffness=1e7, exponent=1.0)
    system.assemble()  # velocities of the driven cam and of the follower it pushes
    return system, c, fol


def test_flat_follower_on_eccentric_cam_matches_closed_form_lift_and_force():
    speed, e, m, k, F0, R = 30.0, 0.01, 0.5, 2000.0, 20.0, 0.04
    system, c, fol = _cam(speed)
    t = np.linspace(0.0, 2.0 * math.pi / speed, 121)
    traj = system.simulate(t, rtol=1e-11, atol=1e-13)
    th = speed * t
    lift = e * np.sin(th)
    y = traj.position(fol)[:, 1] - (R + 0.02)
    np.testing.assert_allclose(y, lift, atol=1e-12)
    # N = m y'' + m g + F0 + k lift
    N = -m * e * speed**2 * np.sin(th) + m * G + F0 + k * lift
    h = traj.contact(c)
    np.testing.assert_allclose(h.normal_force, N, rtol=1e-9)
    assert np.max(traj.residual_position) < 1e-11
    # the contact point is the cam's point nearest the face: (e, 0) + R (0, 1) turned by the cam angle
    xc = e * np.cos(th)
    np.testing.assert_allclose(h.point[:, 0], xc, atol=1e-12)
    np.testing.assert_allclose(h.point[:, 1], R + lift, atol=1e-12)
    # surface parameters: the cam circle's angle pi/2 - theta, the face's arc length x (along e_z x normal)
    np.testing.assert_allclose(np.unwrap(h.surface_parameters[:, 0]), math.pi / 2 - th, atol=1e-10)
    np.testing.assert_allclose(h.surface_parameters[:, 2], xc, atol=1e-12)
    assert np.all(np.isnan(h.surface_parameters[:, [1, 3]]))


def test_follower_separates_at_the_closed_form_instant():
    e, m, k, F0 = 0.01, 0.5, 2000.0, 20.0
    jump = math.sqrt((m * G + F0 + k * e) / (m * e))
    speed = 1.2 * jump
    system, c, fol = _cam(speed)
    t = np.linspace(0.0, 2.0 * math.pi / speed, 201)
    traj = system.simulate(t, rtol=1e-10, atol=1e-12)
    t_sep = math.asin((m * G + F0) / (m * e * speed**2 - k * e)) / speed
    assert traj.status == "separated"
    (sep,) = traj.separations
    assert sep.contact is c and sep.action == "stopped"
    assert abs(sep.t - t_sep) < 1e-10
    assert traj.t[-1] <= sep.t
    assert abs(sep.point[1] - (0.04 + e * math.sin(speed * sep.t))) < 1e-10
    bil = system.simulate(t, rtol=1e-10, atol=1e-12, on_separation="bilateral")
    assert bil.status == "completed"
    assert [s.action for s in bil.separations] == ["bilateral"]
    assert abs(bil.separations[0].t - t_sep) < 1e-10
    assert np.min(bil.contact(c).normal_force) < 0.0


def test_spinning_sphere_sliding_on_a_plane_tracks_its_contact_point():
    system, ball = _ball(velocity=(1.0, 0.5, 0.0), omega=(3.0, -2.0, 7.0))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    t = np.linspace(0.0, 2.0, 41)
    traj = system.simulate(t, rtol=1e-11, atol=1e-13)
    h = traj.contact(c)
    np.testing.assert_allclose(h.normal_force, 2.0 * G, rtol=1e-10)
    np.testing.assert_allclose(traj.energy, traj.energy[0], rtol=1e-12)
    # the contact point is below the centre; its sphere parameters are those of A^T (0, 0, -r)
    R = traj.position(ball)
    np.testing.assert_allclose(h.point, R - [0.0, 0.0, 0.1], atol=1e-13)
    sphere = Sphere(0.1)
    for k in range(0, 41, 5):
        A = traj.state(k).rotation_matrix(ball)
        u = sphere.point(h.surface_parameters[k, 2:])
        np.testing.assert_allclose(u, A.T @ [0.0, 0.0, -0.1], atol=1e-13)
    # the plane's parameters are the contact point's x, y
    np.testing.assert_allclose(h.surface_parameters[:, :2], R[:, :2], atol=1e-13)


def test_sphere_rolling_down_a_slope():
    alpha, m, r = 0.3, 2.0, 0.1
    n = np.array([-math.sin(alpha), 0.0, math.cos(alpha)])
    system, ball = _ball(radius=r, mass=m)
    system.set_state(system.state.displaced(dq=np.concatenate([r * n - [0.0, 0.0, r], np.zeros(3)])))
    c = system.add_contact(system.ground, Plane(normal=n), ball, Sphere(r), rolling=True)
    system.assemble()
    t = np.linspace(0.0, 1.0, 11)
    traj = system.simulate(t, rtol=1e-11, atol=1e-13)
    down = np.array([-math.cos(alpha), 0.0, -math.sin(alpha)])
    travel = (traj.position(ball) - traj.position(ball)[0]) @ down
    np.testing.assert_allclose(travel, 0.5 * (5.0 / 7.0) * G * math.sin(alpha) * t**2, atol=1e-12)
    h = traj.contact(c)
    np.testing.assert_allclose(h.normal_force, m * G * math.cos(alpha), rtol=1e-10)
    # friction up the slope, (2/7) m g sin(alpha) (on the ball)
    np.testing.assert_allclose(h.tangential_force, np.tile(-(2.0 / 7.0) * m * G * math.sin(alpha) * down, (11, 1)),
                               atol=1e-9)
    np.testing.assert_allclose(traj.energy, traj.energy[0], atol=1e-12)
    assert np.max(traj.residual_velocity) < 1e-12


def _ball_on_ball(theta0, *, rolling, r=0.1, R=0.3, m=1.0):
    system = System(gravity=(0.0, 0.0, -G))
    J = 0.4 * m * r * r
    rho = R + r
    ball = system.add_body("ball", mass=m, inertia=(J, J, J),
                           position=(rho * math.sin(theta0), 0.0, rho * math.cos(theta0)))
    c = system.add_contact(system.ground, Sphere(R), ball, Sphere(r), rolling=rolling)
    system.assemble()
    return system, ball, c, rho


def test_sphere_sliding_off_a_sphere_leaves_at_two_thirds():
    theta0 = 0.1
    system, ball, c, rho = _ball_on_ball(theta0, rolling=False)
    traj = system.simulate(np.linspace(0.0, 3.0, 301), rtol=1e-12, atol=1e-14)
    assert traj.status == "separated"
    (sep,) = traj.separations
    R = sep.state.position(ball)
    cos_sep = R[2] / np.linalg.norm(R)
    assert abs(cos_sep - 2.0 / 3.0 * math.cos(theta0)) < 1e-9
    # N = m g (3 cos(theta) - 2 cos(theta0)) along the way; the contact point on the line of centres
    pos = traj.position(ball)
    cos_t = pos[:, 2] / np.linalg.norm(pos, axis=1)
    h = traj.contact(c)
    np.testing.assert_allclose(h.normal_force, G * (3.0 * cos_t - 2.0 * math.cos(theta0)), atol=1e-9)
    np.testing.assert_allclose(h.point, 0.3 * pos / np.linalg.norm(pos, axis=1)[:, None], atol=1e-13)
    np.testing.assert_allclose(h.normal, pos / np.linalg.norm(pos, axis=1)[:, None], atol=1e-13)
    np.testing.assert_allclose(traj.energy, traj.energy[0], atol=1e-12)
    np.testing.assert_allclose(sep.point, 0.3 * R / np.linalg.norm(R), atol=1e-12)


@pytest.mark.parametrize("r", [0.001, 0.1, 2.0])
@pytest.mark.parametrize("ball_first", [False, True])
def test_a_rolling_rows_residual_is_the_slip_speed_whatever_the_radius_and_order(r, ball_first):
    # a ball slipping at 1 m/s on the ground: the rolling rows' velocity residual is 1 m/s (their rows are
    # unit tangents; with the sphere's raw tangents it was r m/s, so a 1 mm ball passed the start check
    # with 1000 times the slip a 1 m ball could)
    system = System(gravity=(0.0, 0.0, -G))
    ball = system.add_body("ball", mass=1.0, inertia=(0.4 * r * r,) * 3, position=(0.0, 0.0, r),
                           velocity=(1.0, 0.0, 0.0))
    if ball_first:
        system.add_contact(ball, Sphere(r), system.ground, Plane(), rolling=True)
    else:
        system.add_contact(system.ground, Plane(), ball, Sphere(r), rolling=True)
    with pytest.raises(ValueError, match=r"velocity residual 1\.000e\+00"):
        system.simulate([0.0, 0.1])
    # assembled, it rolls at 5/7 of the slip speed, and the residual is at round-off in m/s
    system.assemble()
    traj = system.simulate(np.linspace(0.0, 0.1, 3))
    np.testing.assert_allclose(traj.velocity(ball)[:, 0], 5.0 / 7.0, rtol=1e-12)
    assert np.max(traj.residual_velocity) < 1e-13


def test_sphere_rolling_off_a_sphere_leaves_at_ten_seventeenths():
    theta0 = 0.1
    system, ball, c, rho = _ball_on_ball(theta0, rolling=True)
    traj = system.simulate(np.linspace(0.0, 3.0, 301), rtol=1e-12, atol=1e-14)
    (sep,) = traj.separations
    R = sep.state.position(ball)
    assert abs(R[2] / np.linalg.norm(R) - 10.0 / 17.0 * math.cos(theta0)) < 1e-9
    pos = traj.position(ball)
    cos_t = pos[:, 2] / np.linalg.norm(pos, axis=1)
    h = traj.contact(c)
    np.testing.assert_allclose(h.normal_force, G * (17.0 * cos_t - 10.0 * math.cos(theta0)) / 7.0, atol=1e-9)
    np.testing.assert_allclose(traj.energy, traj.energy[0], atol=1e-12)


def test_sphere_resting_on_a_sphere():
    system, ball, c, rho = _ball_on_ball(0.0, rolling=False)
    traj = system.simulate(np.linspace(0.0, 1.0, 5), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(traj.contact(c).normal_force, G, rtol=1e-13)
    np.testing.assert_allclose(traj.contact(c).point, np.tile([0.0, 0.0, 0.3], (5, 1)), atol=1e-15)


@pytest.mark.parametrize("method, kw", [("DOP853", {"rtol": 1e-11, "atol": 1e-13}), ("rk4", {"dt": 5e-3})])
def test_ball_lifted_off_a_plane_by_a_growing_force(method, kw):
    rate = 50.0  # N/s upward: the ball leaves when the force equals its weight
    system, ball = _ball(mass=2.0)
    system.add_force(ball, lambda t, state: np.array([0.0, 0.0, rate * t]))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    traj = system.simulate(np.linspace(0.0, 0.5, 6), method=method, **kw)
    (sep,) = traj.separations
    assert abs(sep.t - 2.0 * G / rate) < 1e-10
    assert traj.status == "separated" and traj.t[-1] <= sep.t
    np.testing.assert_allclose(traj.contact(c).normal_force, 2.0 * G - rate * traj.t, atol=1e-9)


def _hertz_duration(m, k, v0):
    from scipy.integrate import quad

    d_max = (5.0 * m * v0 * v0 / (4.0 * k)) ** 0.4
    integral = quad(lambda x: 1.0 / math.sqrt(1.0 - x**2.5), 0.0, 1.0, limit=200)[0]
    return d_max, 2.0 * d_max / v0 * integral


def test_hertz_impact_depth_and_duration():
    m, r, k, v0, gap0 = 1.0, 0.1, 1e6, 1.0, 0.01
    system = System(gravity=(0.0, 0.0, 0.0))
    J = 0.4 * m * r * r
    ball = system.add_body("ball", mass=m, inertia=(J, J, J), position=(0.0, 0.0, r + gap0), velocity=(0.0, 0.0, -v0))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(r), model="compliant", stiffness=k)
    d_max, t_c = _hertz_duration(m, k, v0)
    t_in = gap0 / v0
    # outputs at the touch-down, the deepest point (half-way) and the lift-off of the closed form
    t = np.array([0.0, t_in, t_in + 0.5 * t_c, t_in + t_c, 2.0 * t_in + t_c])
    traj = system.simulate(t, rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(traj.energy, traj.energy[0], rtol=1e-9)
    hc = traj.contact(c)
    np.testing.assert_allclose(hc.gap, [gap0, 0.0, -d_max, 0.0, gap0], atol=1e-9 * d_max + 1e-13)
    np.testing.assert_allclose(traj.velocity(ball)[:, 2], [-v0, -v0, 0.0, v0, v0], atol=1e-8)
    assert hc.normal_force[2] > 0.0 and hc.normal_force[4] == 0.0


def test_dropped_ball_rebounds_to_its_height():
    m, r, k, h0 = 1.0, 0.1, 1e6, 0.05
    system, ball = _ball(radius=r, mass=m)
    system.set_state(system.state.displaced(dq=np.array([0.0, 0.0, h0, 0.0, 0.0, 0.0])))
    system.add_contact(system.ground, Plane(), ball, Sphere(r), model="compliant", stiffness=k)
    t_fall = math.sqrt(2.0 * h0 / G)
    t = np.array([0.0, 0.5 * t_fall, 1.5 * t_fall, 1.8 * t_fall])
    traj = system.simulate(t, rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(traj.energy, traj.energy[0], rtol=1e-9)
    z, vz = traj.position(ball)[-1, 2], traj.velocity(ball)[-1, 2]
    assert vz > 0.0
    assert abs(z + vz * vz / (2.0 * G) - (r + h0)) < 1e-8  # the apex of the rebound


def test_hunt_crossley_damping_against_a_one_dimensional_reference():
    from scipy.integrate import solve_ivp

    m, r, k, c_hc, v0 = 1.0, 0.1, 1e6, 0.2, 1.0
    system = System(gravity=(0.0, 0.0, 0.0))
    J = 0.4 * m * r * r
    ball = system.add_body("ball", mass=m, inertia=(J, J, J), position=(0.0, 0.0, r), velocity=(0.0, 0.0, -v0))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(r), model="compliant", stiffness=k, damping=c_hc)
    traj = system.simulate(np.linspace(0.0, 0.05, 11), rtol=1e-11, atol=1e-14)
    v_out = traj.velocity(ball)[-1, 2]

    def rhs(t, x):
        d, dd = x
        f = k * max(d, 0.0) ** 1.5 * (1.0 + 1.5 * c_hc * dd) if d > 0 else 0.0
        return [dd, -max(f, 0.0) / m]

    def left(t, x):
        return x[0]

    left.terminal, left.direction = True, -1
    ref = solve_ivp(rhs, (0.0, 0.05), [0.0, v0], rtol=1e-12, atol=1e-15, events=left, first_step=1e-7)
    v_ref = -ref.y_events[0][-1][1]
    assert abs(v_out - v_ref) < 1e-7
    assert 0.0 < v_out < v0  # a coefficient of restitution below one (about 1 - c v0 for small c v0)
    assert np.all(traj.contact(c).normal_force >= 0.0)


def test_follower_leaves_the_cam_and_lands_with_the_compliant_model():
    e, m, k, F0 = 0.01, 0.5, 2000.0, 20.0
    speed = 1.2 * math.sqrt((m * G + F0 + k * e) / (m * e))
    system, c, fol = _cam(speed)
    t = np.linspace(0.0, 2.0 * math.pi / speed, 121)
    traj = system.simulate(t, rtol=1e-8, atol=1e-11, on_separation="compliant")
    assert traj.status == "completed"
    assert traj.separations[0].action == "compliant"
    t_sep = math.asin((m * G + F0) / (m * e * speed**2 - k * e)) / speed
    assert abs(traj.separations[0].t - t_sep) < 1e-9
    h = traj.contact(c)
    before = traj.t <= t_sep
    assert np.all(h.constraint[before]) and not np.any(h.constraint[~before])
    flight = np.flatnonzero(h.gap > 1e-6)
    assert flight.size
    assert np.any(h.normal_force[flight[0]:] > 0.0)  # it lands again: re-contact and impact
    assert np.all(h.normal_force[~before] >= 0.0)  # the compliant force never pulls


def _rolling_disk(lean, spin, *, rolling=True, radius=0.1, mass=1.0):
    """A thin disk on its rim (symmetry axis = body y), leaning by ``lean`` about x, rolling about its axis."""
    from rigidlab.core.rotations import euler_parameters_from_axis_angle

    system = System(gravity=(0.0, 0.0, -G))
    A = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(lean), -math.sin(lean)], [0.0, math.sin(lean), math.cos(lean)]])
    centre = A @ [0.0, 0.0, radius]
    omega = A @ [0.0, spin, 0.0]
    disk = system.add_body("disk", mass=mass, inertia=(mass * radius**2 / 4, mass * radius**2 / 2, mass * radius**2 / 4),
                           position=centre, orientation=euler_parameters_from_axis_angle(np.array([1.0, 0, 0]), lean),
                           omega=omega, velocity=np.cross(omega, centre))
    c = system.add_contact(disk, Torus(radius, 0.0), system.ground, Plane(), rolling=rolling)
    system.assemble()
    return system, disk, c


def test_upright_rolling_disk_rolls_straight():
    system, disk, c = _rolling_disk(0.0, 20.0)
    t = np.linspace(0.0, 0.5, 11)
    traj = system.simulate(t, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(traj.position(disk)[:, 0], 20.0 * 0.1 * t, atol=1e-12)  # v = omega R along +x
    np.testing.assert_allclose(traj.position(disk)[:, 1:], np.tile([0.0, 0.1], (11, 1)), atol=1e-13)
    np.testing.assert_allclose(traj.contact(c).normal_force, G, rtol=1e-12)
    np.testing.assert_allclose(traj.contact(c).tangential_force, 0.0, atol=1e-10)


@pytest.mark.slow
@pytest.mark.parametrize("rolling", [True, False])
def test_leaning_disk_conserves_energy_over_ten_seconds(rolling):
    system, disk, c = _rolling_disk(0.3, 15.0, rolling=rolling)
    traj = system.simulate(np.linspace(0.0, 10.0, 601), rtol=1e-11, atol=1e-13)
    assert traj.status == "completed"
    np.testing.assert_allclose(traj.energy, traj.energy[0], atol=2e-9)
    assert np.max(traj.residual_position) < 1e-11 and np.max(traj.residual_velocity) < 1e-11
    assert np.all(traj.contact(c).normal_force > 0.0)


@pytest.mark.slow
def test_cam_force_over_ten_revolutions():
    speed, e, m, k, F0 = 60.0, 0.01, 0.5, 2000.0, 20.0
    system, c, fol = _cam(speed)
    t = np.linspace(0.0, 10 * 2.0 * math.pi / speed, 2001)
    traj = system.simulate(t, rtol=1e-11, atol=1e-13)
    th = speed * t
    N = -m * e * speed**2 * np.sin(th) + m * G + F0 + k * e * np.sin(th)
    np.testing.assert_allclose(traj.contact(c).normal_force, N, rtol=1e-8)


def test_a_frictionless_disk_falling_flat_keeps_its_motion_up_to_the_failure():
    # sliding without spin it falls: C_s loses rank as it lies flat (Eq. 8.109); the error carries the outputs
    from rigidlab.core.contact import ContactError
    from rigidlab.core.models import rolling_disk

    system, disk, contact = rolling_disk(lean=math.radians(10.0), spin=0.0, rolling=False)
    t = np.linspace(0.0, 1.0, 101)
    with pytest.raises(ContactError, match=r"loses rank \(Eq\. 8\.109\)") as info:
        system.simulate(t)
    traj = info.value.trajectory
    assert traj.status == "failed" and 0.2 <= traj.t[-1] < 0.25
    np.testing.assert_array_equal(traj.t, t[: traj.t.size])
    np.testing.assert_allclose(traj.energy, traj.energy[0], atol=1e-7)  # (DOP853 at rtol 1e-8 over 0.2 s)
    assert np.all(traj.contact(contact).normal_force > 0.0)
    # a worker process hands such an error to the app: it pickles, without the trajectory (which holds the
    # System and its locks) and with its message and time
    again = pickle.loads(pickle.dumps(info.value))
    assert type(again) is ContactError and str(again) == str(info.value) and again.t == info.value.t
    assert not hasattr(again, "trajectory") and not hasattr(again, "partial")


def test_a_failed_kinematic_analysis_keeps_the_outputs_it_solved():
    from rigidlab.core.integrators import IntegrationError
    from rigidlab.core.models import CamFollower, CamProfile

    cam = CamFollower(CamProfile.eccentric())
    speed = 0.9 * cam.jump_speed()
    system = cam.build_system(speed).system
    t = np.arange(61) / 600.0
    with pytest.raises(IntegrationError, match=r"max_steps=20") as info:
        system.simulate(t, method="kinematic", max_steps=20)
    traj = info.value.trajectory
    assert traj.status == "failed" and 5 < traj.t.size < t.size
    np.testing.assert_array_equal(traj.t, t[: traj.t.size])
    full = cam.simulate(speed, t[: traj.t.size])
    np.testing.assert_allclose(traj.contact(system.contacts[0]).normal_force, full.contact_force, rtol=1e-12)
