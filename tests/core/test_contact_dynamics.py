"""Contact in the System against closed forms: resting and rolling spheres, the eccentric cam, separation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.contact import PlanarCurve, Plane, Sphere
from core.multibody import System

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
