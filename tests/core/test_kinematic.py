"""``System.simulate(method="kinematic")``: kinematic analysis of systems with no degree of freedom.

Oracles: the slider-crank's closed-form slider position, velocity and
acceleration; the eccentric cam's closed-form lift and contact force
(Eq. 8.107's multiplier) and the closed-form angle at which it reaches zero;
DOP853 at tight tolerances on the same System (multipliers, the compliant
continuation after a separation). Also: the refusals (degrees of freedom,
rolling contacts, another stabilization), and a trajectory's state carrying
the contact parameters into the next run (chunks agree with one run, with no
global contact search).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.contact import _search
from core.models import CamFollower, CamProfile, pendulum_chain, rolling_disk, slider_crank

TWO_PI = 2.0 * math.pi
#: The position Newton stops at max |C| <= 1e-12 (m); with a lift of about 1e-2 m
#: that is a relative position error of 1e-10 at worst. The force is a smooth
#: function of the solved configuration, so it inherits the same relative bound.
KINEMATIC_RTOL = 1e-10


def slider_closed_form(r, l, w, t):
    """Slider position and velocity at the crank angle w t (x from the crank shaft)."""
    phi = w * t
    s, c = np.sin(phi), np.cos(phi)
    root = np.sqrt(l * l - (r * s) ** 2)
    return r * c + root, -r * s * w - r * r * s * c * w / root


def test_slider_crank_against_its_closed_form_and_dop853():
    model = slider_crank(speed=7.0)
    system, slider = model.system, model.slider
    r, l, w = model.crank_length, model.rod_length, 7.0
    t = np.linspace(0.0, 2.0 * TWO_PI / w, 97)
    kin = system.simulate(t, method="kinematic")
    assert kin.method == "kinematic" and kin.status == "completed" and kin.n_steps == t.size - 1
    x, dx = slider_closed_form(r, l, w, t)
    i = system.bodies.index(slider)
    # Newton stops at max |C| <= 1e-12 m; the mechanism's inverse Jacobian maps that onto the slider
    # with a gain of a few (the slider moves up to ~2.5 times faster than the crank pin): 1e-11 m
    np.testing.assert_allclose(kin.q[:, 3 * i], x, rtol=0, atol=1e-11)
    np.testing.assert_allclose(kin.v[:, 3 * i], dx, rtol=0, atol=1e-11 * w)
    assert np.max(kin.residual_position) <= 1e-12
    # the multipliers against DOP853 at rtol 1e-12 (its own error ~1e-10 relative)
    ref = system.simulate(t, rtol=1e-12, atol=1e-14)
    scale = np.max(np.abs(ref.multipliers))
    np.testing.assert_allclose(kin.multipliers, ref.multipliers, rtol=0, atol=1e-8 * scale)


@pytest.mark.parametrize("follower, rf, eo", [("flat", 0.0, 0.01), ("roller", 0.01, 0.008)])
def test_cam_force_to_the_newton_tolerance(follower, rf, eo):
    cam = CamFollower(CamProfile.eccentric(), follower=follower, roller_radius=rf, offset=eo)
    speed = 0.9 * cam.jump_speed()
    t = np.linspace(0.0, 2.0 * TWO_PI / speed, 121)
    motion = cam.simulate(speed, t, method="kinematic")
    assert motion.status == "completed" and motion.trajectory.method == "kinematic"
    k = cam.kinematics(motion.cam_angle)
    np.testing.assert_allclose(motion.lift, k.lift, rtol=0, atol=KINEMATIC_RTOL * np.abs(k.lift).max())
    N = cam.contact_force(motion.cam_angle, speed)
    np.testing.assert_allclose(motion.contact_force, N, rtol=0, atol=KINEMATIC_RTOL * np.abs(N).max())
    # DOP853 on the same System is 1e-8 off at its default tolerances: the kinematic run is not an integration
    dop = cam.simulate(speed, t, method="DOP853", rtol=1e-8, atol=1e-10)
    assert np.max(np.abs(dop.contact_force - N)) > np.max(np.abs(motion.contact_force - N))


def test_separation_at_the_closed_form_angle_and_the_compliant_continuation():
    cam = CamFollower(CamProfile.eccentric(), stiffness=200.0, preload=2.0)
    speed = 1.2 * cam.jump_speed()
    m, k, e = cam.mass, cam.stiffness, 0.01
    F = cam.preload + m * cam.gravity
    expected = math.acos(-(k * e + F) / (m * speed**2 * e - k * e))
    t = np.linspace(0.0, TWO_PI / speed, 61)
    stop = cam.simulate(speed, t, method="kinematic")
    assert stop.status == "separated" and stop.separations.shape == (1, 2)
    # Brent's method on solved states: the angle to round-off, not to an integrator's tolerance
    assert stop.separations[0, 1] == pytest.approx(expected, abs=1e-11)
    # continued with the compliant contact: integrated by DOP853, as the DOP853 run is after its separation
    kin = cam.simulate(speed, t, method="kinematic", on_separation="compliant", rtol=1e-9, atol=1e-11)
    dop = cam.simulate(speed, t, method="DOP853", on_separation="compliant", rtol=1e-9, atol=1e-11)
    assert kin.status == dop.status == "completed"
    assert kin.separations[0, 0] == pytest.approx(dop.separations[0, 0], abs=1e-9 / speed)
    # both integrate the same flight from states that agree to the integrator's tolerance
    np.testing.assert_allclose(kin.lift, dop.lift, rtol=0, atol=1e-7)
    assert len(kin.landings) == len(dop.landings) >= 1


def test_chunks_continue_from_the_trajectorys_contact_parameters(monkeypatch):
    cam = CamFollower(CamProfile.eccentric())
    speed = 0.9 * cam.jump_speed()
    built = cam.build_system(speed)
    system = built.system
    whole = system.simulate(np.arange(31) / 60.0, method="kinematic")
    searches = []
    original = _search.find_contact
    monkeypatch.setattr(_search, "find_contact", lambda *a, **k: searches.append(1) or original(*a, **k))
    for j in range(30):
        part = system.simulate(np.array([j, j + 1]) / 60.0, method="kinematic")
        system.set_state(part.state(-1))
        assert part.state(-1)._contacts is not None
    # each chunk starts its contact Newton from the last chunk's parameters: no global search
    assert searches == []
    # and ends where the one run does (each output solved to the Newton tolerance)
    np.testing.assert_allclose(system.state.q, whole.q[-1], rtol=0, atol=1e-12)


def test_refusals():
    chain = pendulum_chain(2)
    with pytest.raises(ValueError, match=r"method: 'kinematic' needs a System whose constraints fix every "
                                         r"coordinate \(0 degrees of freedom\); this one has 2"):
        chain.simulate([0.0, 0.1], method="kinematic")
    system, _, _ = rolling_disk(spin=20.0)
    with pytest.raises(ValueError, match="rolling contacts"):
        system.simulate([0.0, 0.1], method="kinematic")
    model = slider_crank(speed=3.0)
    with pytest.raises(ValueError, match="stabilization: method 'kinematic'"):
        model.system.simulate([0.0, 0.1], method="kinematic", stabilization="baumgarte")
    with pytest.raises(ValueError, match="method: expected one of .*'kinematic'"):
        model.system.simulate([0.0, 0.1], method="kinematics")
    with pytest.raises(ValueError, match=r"dt: method 'kinematic' solves at the output times .*not dt \(got dt=0.1\)"):
        model.system.simulate([0.0, 0.1], method="kinematic", dt=0.1)


def test_sparse_outputs_stay_on_the_mechanisms_assembly():
    """Outputs 179 degrees of crank apart: the extrapolation lands nearer the other assembly (the motor's
    flipped angle, the slider on the far side); the step is halved until Newton's correction is small
    against the motion, and every output is the closed form."""
    model = slider_crank(speed=1.0)
    t = math.radians(179.0) * np.arange(13)
    kin = model.system.simulate(t, method="kinematic")
    assert kin.n_steps > t.size - 1  # steps were halved
    x, _ = slider_closed_form(model.crank_length, model.rod_length, 1.0, t)
    i = model.system.bodies.index(model.slider)
    np.testing.assert_allclose(kin.q[:, 3 * i], x, rtol=0, atol=1e-11)
