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

from rigidlab.core.contact import _search
from rigidlab.core.contact._kernel import ContactKernel
from rigidlab.core.models import CamFollower, CamProfile, pendulum_chain, rolling_disk, slider_crank
from rigidlab.core.multibody import SingularSystemError
from rigidlab.core.multibody._engine import parameter_rates
from rigidlab.core.multibody._simulate import _Dynamics, _kinematic_prediction
from rigidlab.core.multibody._system import exp_parameters

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
    # the kinematic run is not an integration: its error is the Newton tolerance's. At position_tol 1e-14 it is
    # 1e-11 relative (the roller's curvature amplifies round-off to about 2e-12), below DOP853's on the same
    # System at rtol 1e-8
    built = cam.build_system(speed)
    tight = built.system.simulate(t, method="kinematic", position_tol=1e-14).contact(built.contact).normal_force
    np.testing.assert_allclose(tight, N, rtol=0, atol=1e-11 * np.abs(N).max())
    dop = cam.simulate(speed, t, method="DOP853", rtol=1e-8, atol=1e-10)
    assert np.max(np.abs(dop.contact_force - N)) > np.max(np.abs(tight - N))


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


def _hermite_case(t: float):
    """A smooth motion of one body (n = 1): ``(y, f)`` at ``t``, the state and its rates (``f``: R_dot, p_dot,
    R_ddot, omega_body_dot), turning at the constant body angular velocity ``w``."""
    w = np.array([0.3, -1.1, 2.0])
    R = np.array([math.sin(t), math.cos(2.0 * t), math.exp(0.5 * t)])
    v = np.array([math.cos(t), -2.0 * math.sin(2.0 * t), 0.5 * math.exp(0.5 * t)])
    a = np.array([-math.sin(t), -4.0 * math.cos(2.0 * t), 0.25 * math.exp(0.5 * t)])
    p = exp_parameters((t * w)[None, :])[0]
    p_dot = parameter_rates(p[None, :], w[None, :])[0]
    return np.concatenate([R, p, v, w]), np.concatenate([v, p_dot, a, np.zeros(3)]), R, p


def test_kinematic_prediction_orders():
    """The start of a kinematic step's Newton (``_kinematic_prediction``): the quintic Hermite extrapolation of
    the positions one interval ahead has an error of order h^6 (halving the interval divides it by about
    64); the Euler parameters of a body turning at a constant angular velocity are exact to round-off."""
    errors = []
    for H in (0.2, 0.1, 0.05):
        y_p, f_p, _, _ = _hermite_case(1.0 - H)
        y, f, _, _ = _hermite_case(1.0)
        _, _, R_true, p_true = _hermite_case(1.0 + H)
        z = _kinematic_prediction(1, y, 1.0, (1.0 - H, y_p, f_p, f), 1.0 + H)
        errors.append(float(np.abs(z[:3] - R_true).max()))
        np.testing.assert_allclose(z[3:7], p_true, rtol=0, atol=1e-15)
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(45.0 < r < 90.0 for r in ratios), (errors, ratios)  # 2^6 = 64 asymptotically
    # inside the last interval (the event search's dense output): the positions' quintic interpolation, the
    # parameters' cubic Hermite interpolation normalized (errors of order H^6 and H^4)
    H = 0.1
    y_p, f_p, _, _ = _hermite_case(1.0 - H)
    y, f, _, _ = _hermite_case(1.0)
    _, _, R_true, p_true = _hermite_case(1.0 - H / 2)
    z = _kinematic_prediction(1, y, 1.0, (1.0 - H, y_p, f_p, f), 1.0 - H / 2)
    np.testing.assert_allclose(z[:3], R_true, rtol=0, atol=1e-9)
    np.testing.assert_allclose(z[3:7], p_true, rtol=0, atol=1e-6)
    assert np.linalg.norm(z[3:7]) == pytest.approx(1.0, abs=1e-15)
    # the first step (no point before): Taylor's R + h v + h^2 a / 2, an error of order h^3
    y, f, _, _ = _hermite_case(1.0)
    _, _, R_true, p_true = _hermite_case(1.05)
    z = _kinematic_prediction(1, y, 1.0, (None, None, None, f), 1.05)
    np.testing.assert_allclose(z[:3], R_true, rtol=0, atol=8.0 * 0.05**3 / 6.0)  # |R'''| <= 8
    np.testing.assert_allclose(z[3:7], p_true, rtol=0, atol=1e-15)


def test_cam_at_one_output_per_frame_takes_one_step_a_frame(monkeypatch):
    """98 degrees of cam per output (one output per 60 Hz frame at 0.9 times the jump speed): every output is
    one step, whose contact Newton starts from the last output's parameters moved by their rates and
    converges there (no continuation in sub-steps, no search), with the closed-form lift."""
    cam = CamFollower(CamProfile.eccentric())
    speed = 0.9 * cam.jump_speed()
    built = cam.build_system(speed)
    calls = []
    original = ContactKernel._continue_one
    monkeypatch.setattr(ContactKernel, "_continue_one", lambda *a, **k: calls.append(1) or original(*a, **k))
    t = np.arange(61) / 60.0
    traj = built.system.simulate(t, method="kinematic")
    assert traj.n_steps == 60 and calls == []
    lift = traj.q[:, 3 * built.system.bodies.index(built.follower) + 2] - built.lift_origin
    np.testing.assert_allclose(lift, cam.kinematics(speed * t).lift, rtol=0, atol=KINEMATIC_RTOL * 0.02)


def test_a_compliant_continuation_from_the_start_integrates_with_outputs_inside_steps(monkeypatch):
    """A kinematic run whose contact already pulls at t0 continues at once with DOP853 (compliant): its outputs
    fall inside the integrator's steps, so they must not become the contact's warm-start prediction (the flag
    that lets a kinematic step's end do so is off for the whole integration)."""
    cam = CamFollower(CamProfile.eccentric())
    w = 1.5 * cam.jump_speed()
    t0 = math.pi / w  # the force is most negative at theta = pi
    assert cam.contact_force(w * t0, w) < 0.0
    seen = []
    original = _Dynamics._record_output
    monkeypatch.setattr(_Dynamics, "_record_output",
                        lambda self, t, y: seen.append((t, self.outputs_end_steps)) or original(self, t, y))
    motion = cam.simulate(w, t0 + np.arange(31) / 600.0, on_separation="compliant")
    assert motion.status == "completed" and motion.separations[0, 0] == pytest.approx(t0, abs=1e-15)
    assert [flag for t, flag in seen if t > t0] and not any(flag for t, flag in seen if t > t0)
    assert motion.trajectory._model.outputs_end_steps is False


# ------------------------------------------------------------------ a motor driving a linkage into its dead point
def _non_grashof_four_bar():
    """Crank 1.5 m, coupler 1 m, rocker 1.2 m, ground 2 m (no link turns fully: 1.5 + 2 > 1 + 1.2), the crank
    turned by a motor at 1 rad/s from 1 rad. Coupler and rocker stretch out (|B - D| = 1 + 1.2) when the crank
    is at acos((1.5^2 + 2^2 - 2.2^2) / (2 1.5 2)), at t = 0.3335777587 s: the dead point."""
    from rigidlab.core.multibody import System

    a, b, c, d = 1.5, 1.0, 1.2, 2.0
    A, D = np.zeros(3), np.array([d, 0.0, 0.0])
    B = a * np.array([math.cos(1.0), 0.0, math.sin(1.0)])
    e = (D - B) / np.linalg.norm(D - B)
    x = (b * b - c * c + np.dot(D - B, D - B)) / (2.0 * np.linalg.norm(D - B))
    C = B + x * e + math.sqrt(b * b - x * x) * np.cross(e, [0.0, 1.0, 0.0])
    s = System()

    def rod(name, p, q, length):
        u = (q - p) / length  # the rod's z axis along it: a rotation about y
        half = 0.5 * math.atan2(u[0], u[2])
        return s.add_body(name, mass=1.0, inertia=(length**2 / 12, length**2 / 12, 1e-4), position=(p + q) / 2,
                          orientation=(math.cos(half), 0.0, math.sin(half), 0.0))

    crank, coupler, rocker = rod("crank", A, B, a), rod("coupler", B, C, b), rod("rocker", D, C, c)
    pivot = s.add_joint("revolute", s.ground, crank, point=A, axis=(0.0, -1.0, 0.0))
    s.add_joint("revolute", crank, coupler, point=B, axis=(0.0, -1.0, 0.0))
    s.add_joint("revolute", coupler, rocker, point=C, axis=(0.0, -1.0, 0.0))
    s.add_joint("revolute", s.ground, rocker, point=D, axis=(0.0, -1.0, 0.0))
    s.add_motor(pivot, angle=lambda t: t)
    s.assemble()
    return s


DEAD_POINT_T = math.acos((1.5**2 + 2.0**2 - 2.2**2) / (2 * 1.5 * 2.0)) - 1.0


@pytest.mark.parametrize("method", ["kinematic", "DOP853"])
def test_a_motor_driving_a_linkage_into_its_dead_point_is_a_singular_system_error(method):
    # (it was "the extrapolation ... is too far ...; give closer output times" and, with DOP853 after 15 s of
    # CPU, "Required step size is less than spacing between numbers": advice that never helps; DOP853 now stops
    # at its first step shorter than 1e-9 of the span, 0.3 s of CPU)
    system = _non_grashof_four_bar()
    with pytest.raises(SingularSystemError, match=r"dead point at t=0\.33357") as info:
        system.simulate(np.linspace(0.0, 3.0, 31), method=method)
    assert info.value.t == pytest.approx(DEAD_POINT_T, abs=1e-5)
    assert info.value.trajectory.t[-1] == pytest.approx(0.3)  # the outputs before it are kept
    # short of the dead point the same run is fine
    system.simulate(np.linspace(0.0, 0.3, 4), method=method)
