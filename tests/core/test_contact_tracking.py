"""Tracking the contact point along a run: the surface parameters follow one solution, step by step.

The surface parameters are solved from the extremal conditions at every
evaluation, warm-started from the solution tracked along the accepted steps
(see ``rigidlab.core.contact._kernel.ContactKernel.evaluate``). Regressions:

* a cam follower in flight above the jump speed at a loose tolerance: the
  outputs inside a long step were projected after the step's end and moved
  the warm start back in time, so the next evaluation started far away,
  was searched afresh and compared with a point of another time ("the
  contact point jumped by 0.078 m");
* the frictionless sliding disk with sparse outputs: the history of the
  contact followed the point from output to output instead of using the
  run's solution, and landed on the top of the rim (0.2 m off).

Oracles: closed forms (the flat face touches the eccentric circle where its
normal is the follower axis, at ``x = e sin(theta)``; a roller's centre lies
on the common normal at ``gap + r`` from the cam's point; the disk touches
the ground at the lowest point of its rim), and runs with other output
densities, which integrate the same steps.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.contact import Plane, Torus
from rigidlab.core.contact._kernel import ContactError, _Group, frames_of, solve_parameters
from rigidlab.core.models import CamFollower, CamProfile, rolling_disk
from rigidlab.core.multibody import System
from rigidlab.core.rotations import euler_parameters_from_axis_angle, matrix_from_euler_parameters


def _cam_run(cam, factor, n_out, rtol, revolutions=4):
    w = factor * cam.jump_speed()
    built = cam.build_system(w)
    t = np.linspace(0.0, revolutions * 2.0 * math.pi / w, n_out)
    traj = built.system.simulate(t, rtol=rtol, atol=1e-2 * rtol, on_separation="compliant")
    return built, traj, w


@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
def test_flat_follower_on_eccentric_cam_leaves_and_lands_at_loose_tolerances(rtol):
    # 1.2 times the jump speed, four revolutions: four flights, each one longer than a DOP853 step
    e = 0.01
    cam = CamFollower(CamProfile.eccentric(radius=0.04, eccentricity=e))
    built, traj, w = _cam_run(cam, 1.2, 241, rtol)
    assert traj.status == "completed" and traj.t[-1] == pytest.approx(4.0 * 2.0 * math.pi / w)
    h = traj.contact(built.contact)
    assert not h.constraint[-1] and np.max(h.gap) > 5e-3  # the follower flies (gap up to 9 mm)
    theta = w * traj.t
    # the face touches (or faces) the circle where the circle's normal is the follower axis
    np.testing.assert_allclose(h.point[:, 0], e * np.sin(theta), rtol=0, atol=1e-12)
    np.testing.assert_allclose(h.point[:, 1], 0.0, atol=1e-12)
    assert np.all(np.isfinite(h.normal_force)) and np.all(np.isfinite(h.surface_parameters[:, [0, 2]]))


@pytest.mark.parametrize("law", ["345", pytest.param("harmonic", marks=pytest.mark.slow)])
def test_roller_follower_in_flight_is_followed_whatever_the_output_density(law):
    # twice the jump speed at rtol 1e-6: steps of up to 2 rad of the cam in flight (was: "contact point jumped")
    cam = CamFollower(CamProfile.rise_dwell_return(law=law), follower="roller", roller_radius=0.01)
    runs = [_cam_run(cam, 2.0, n, 1e-6, revolutions=2) for n in (31, 121)]
    for built, traj, _ in runs:
        assert traj.status == "completed"
        h = traj.contact(built.contact)
        assert np.max(h.gap) > 0.02
        # the roller's centre is on the common normal through the cam's point, gap + r away
        centre = traj.position(built.follower)
        np.testing.assert_allclose(centre - h.point, (h.gap + 0.01)[:, None] * h.normal, rtol=0, atol=1e-12)
    (b1, t1, _), (b2, t2, _) = runs
    np.testing.assert_allclose(t2.t[::4], t1.t, rtol=0, atol=0)
    # The same motion, to the run's tolerance: an output's projection may warm-start the contact Newton of
    # the next stage, whose round-off can then flip a step's acceptance (the harmonic cam: 1.5e-7 m apart
    # after 2 revolutions at rtol 1e-6; the 345 cam: identical). The failure this guards against, a contact
    # point that jumps to another branch with sparse outputs, moved the point by centimetres.
    np.testing.assert_allclose(t2.q[::4], t1.q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(t2.contact(b2.contact).point[::4], t1.contact(b1.contact).point, rtol=0, atol=1e-6)


def _lowest_rim_point(traj, disk, R):
    """Closed form: the centre plus R along the steepest descent within the disk's plane."""
    A = matrix_from_euler_parameters(traj.orientation(disk))
    axis = A[:, :, 1]  # symmetry axis, body y
    down = -(np.array([0.0, 0.0, 1.0]) - axis[:, 2:3] * axis)
    down /= np.linalg.norm(down, axis=1)[:, None]
    return traj.position(disk) + R * down


@pytest.mark.parametrize(("heading_rate", "sparse"), [(6.0, 61), pytest.param(1.5, 31, marks=pytest.mark.slow)])
def test_sliding_disk_contact_history_does_not_depend_on_the_output_density(heading_rate, sparse):
    # 61 outputs over 3 s put the contact point on the top of the rim (0.19 m off) at heading rate 6 rad/s,
    # 31 outputs at 1.5 rad/s
    R = 0.1
    runs = {}
    for n in (sparse, 601):
        system, disk, contact = rolling_disk(radius=R, lean=0.4, spin=9.0, heading_rate=heading_rate,
                                             lean_rate=-0.4, rolling=False)
        traj = system.simulate(np.linspace(0.0, 3.0, n))
        assert traj.status == "completed"
        h = traj.contact(contact)
        np.testing.assert_allclose(h.point[:, 2], 0.0, atol=1e-12)  # on the ground plane
        np.testing.assert_allclose(h.point, _lowest_rim_point(traj, disk, R), rtol=0, atol=1e-11)
        np.testing.assert_allclose(h.gap, 0.0, atol=1e-12)
        runs[n] = (traj, h)
    t_ref, h_ref = runs[601]
    for n, step in ((sparse, 600 // (sparse - 1)),):
        traj, h = runs[n]
        np.testing.assert_allclose(t_ref.t[::step], traj.t, rtol=0, atol=1e-15)
        np.testing.assert_allclose(t_ref.q[::step], traj.q, rtol=0, atol=1e-10)  # the same steps
        np.testing.assert_allclose(h_ref.point[::step], h.point, rtol=0, atol=1e-10)
        np.testing.assert_allclose(h_ref.normal_force[::step], h.normal_force, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(h_ref.surface_parameters[::step], h.surface_parameters, rtol=0, atol=1e-9)


def test_a_search_afresh_refuses_the_far_side_of_a_rim():
    # Newton from the top of a leaning rim converges there with the normal field flipped into the disk
    # (cos psi < 0), facing the ground like the lowest point: a fresh search must refuse it
    lean = 0.3
    system = System()
    p = euler_parameters_from_axis_angle(np.array([1.0, 0.0, 0.0]), lean)
    disk = system.add_body("disk", mass=1.0, inertia=(0.0025, 0.005, 0.0025), position=(0.0, 0.0, 0.3),
                           orientation=p)
    c = system.add_contact(system.ground, Plane(), disk, Torus(0.1, 0.0), model="compliant", stiffness=1e5)
    assert c.initial_gap == pytest.approx(0.3 - 0.1 * math.cos(lean), abs=1e-12)  # the lowest point
    group = _Group([c], 2, 1)
    A_ext = np.stack([matrix_from_euler_parameters(p), np.eye(3)])
    R_ext = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.0]])
    fr = frames_of(group, A_ext, R_ext, None, None)
    top = np.array([[0.0, 0.0, -0.5 * math.pi, 0.95 * math.pi]])  # plane (x, y), rim (phi, psi): phi = -pi/2 is up
    s, gi, gj, *_ = solve_parameters(group, fr, top.copy(), [[None, None]], 2, damped=True)
    assert gj.rho[0, 2] + 0.3 > 0.3 and math.cos(s[0, 3]) < 0.0  # the top, normal flipped
    with pytest.raises(ContactError, match=r"rim's normal pointing into the disk"):
        solve_parameters(group, fr, top.copy(), [[None, None]], 2, damped=True, outward=True)
