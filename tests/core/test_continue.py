"""Runs continue from the state they ended in: ``system.simulate(t, initial=traj.final_state)``.

Every check splits a run at an interior output time into two runs, the second
started from the first's ``final_state`` (pickled and unpickled, as it crosses
the app's process pool), and compares it with one long run over the same
outputs. The tolerances say where the difference comes from:

* fixed steps that end on the split, and the kinematic analysis (the cam on its
  follower: every output solved from the constraints), take the same
  arithmetic: equal, or equal to the Newton tolerance;
* an adaptive method (DOP853) restarts its step-size control at the split, so
  the second run takes other steps than the long one: the two agree to the
  integrator's tolerance, and the difference shrinks with ``rtol`` (checked at
  two tolerances);
* a compliant contact's touch is located on the dense output: its time, and the
  impact that follows, agree to that location's tolerance.

The measured differences are in docs/multibody.md ("Continuing a run").
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from rigidlab.core import ArgumentError
from rigidlab.core.contact import Plane, Sphere, gap_crossings
from rigidlab.core.integrators import DEFAULT_ATOL, DEFAULT_RTOL
from rigidlab.core.models import CamFollower, CamProfile, rolling_disk, whipple_bicycle, whipple_push, whipple_ride
from rigidlab.core.multibody import RunState, System


def _pendulum() -> System:
    system = System(gravity=(0.0, 0.0, -9.81))
    link = system.add_body("link", mass=1.0, inertia=(1 / 12, 1 / 12, 1e-4), position=(0.0, 0.3, -0.4))
    system.add_joint("revolute", system.ground, link, point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    system.assemble()
    return system


def _round_trip(state: RunState) -> RunState:
    return pickle.loads(pickle.dumps(state))


def _split(system: System, t: np.ndarray, k: int, **options):
    """The long run over ``t`` and the second half of the run split at ``t[k]``."""
    long = system.simulate(t, **options)
    first = system.simulate(t[: k + 1], **options)
    second = system.simulate(t[k:], initial=_round_trip(first.final_state), **options)
    assert second.t[0] == first.t[-1] == t[k]
    return long, second


def _difference(long, second, k: int) -> tuple[float, float]:
    return float(np.max(np.abs(second.q - long.q[k:]))), float(np.max(np.abs(second.v - long.v[k:])))


def test_fixed_steps_ending_on_the_split_give_the_long_run_exactly():
    t = np.linspace(0.0, 2.0, 41)
    long, second = _split(_pendulum(), t, 17, method="rk4", dt=0.01)
    np.testing.assert_array_equal(second.q, long.q[17:])
    np.testing.assert_array_equal(second.v, long.v[17:])


def test_an_adaptive_split_agrees_to_the_integrators_tolerance():
    t = np.linspace(0.0, 2.0, 41)
    coarse = _difference(*_split(_pendulum(), t, 17, rtol=1e-8, atol=1e-10), 17)
    fine = _difference(*_split(_pendulum(), t, 17, rtol=1e-11, atol=1e-13), 17)
    # (measured: 5e-9 m, 2e-8 m/s at rtol 1e-8; 1e-11 of those at 1e-11): the restart's steps, not a jump
    assert coarse[0] < 1e-6 and coarse[1] < 1e-5
    assert fine[0] < 1e-9 and fine[1] < 1e-8
    assert fine[0] < coarse[0]


def test_the_continued_run_starts_at_the_states_time_and_leaves_the_system_alone():
    system = _pendulum()
    before = system.state
    first = system.simulate(np.linspace(0.0, 0.5, 6))
    second = system.simulate([0.5, 0.75, 1.0], initial=first.final_state)
    assert system.state.t == before.t
    np.testing.assert_array_equal(system.state.q, before.q)
    np.testing.assert_array_equal(second.q[0], first.q[-1])
    later = system.simulate([0.75, 1.0], initial=first.final_state)  # outputs may start after the state
    np.testing.assert_allclose(later.q[-1], second.q[-1], atol=1e-7)


def test_final_state_is_small_frozen_and_pickles():
    system, _, contact = rolling_disk(0.15, 2.0, lean=0.2, spin=8.0, heading_rate=1.0)
    traj = system.simulate(np.linspace(0.0, 0.2, 5))
    state = traj.final_state
    assert traj.final_state is state  # (kept)
    assert state.t == 0.2 and state.n_bodies == 1
    assert state.contact_models == ("constraint",)
    assert len(state.contact_parameters) == 1 and len(state.contact_charts) == 1
    copy = _round_trip(state)
    for a, b in ((copy.q, state.q), (copy.v, state.v), (copy.contact_parameters[0], state.contact_parameters[0])):
        np.testing.assert_array_equal(a, b)
        assert not a.flags.writeable
    with pytest.raises(ValueError):
        copy.q[0] = 1.0
    with pytest.raises(AttributeError):
        copy.t = 1.0  # type: ignore[misc]
    mid = traj.run_state(2)
    assert mid.t == traj.t[2]
    np.testing.assert_array_equal(mid.q, traj.q[2])


@pytest.mark.parametrize("rolling", [True, False])
def test_the_rolling_disk_continues_with_its_contact(rolling):
    system, _, contact = rolling_disk(0.15, 2.0, lean=0.2, spin=8.0, rolling=rolling, heading_rate=1.0,
                                      lean_rate=-0.3)
    t = np.linspace(0.0, 1.0, 51)
    long, second = _split(system, t, 22, rtol=1e-11, atol=1e-13)
    dq, dv = _difference(long, second, 22)
    # (measured: 7e-12 m / 2e-11, 3e-10 m/s; normal force 1e-10 / 4e-10 N)
    assert dq < 1e-9 and dv < 1e-8
    force = np.asarray(second.contact(contact).normal_force)
    np.testing.assert_allclose(force, np.asarray(long.contact(contact).normal_force)[22:], atol=1e-8)


def test_a_bouncing_ball_continues_in_the_compliant_contact():
    system = System(gravity=(0.0, 0.0, -9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004,) * 3, position=(0.0, 0.0, 0.2), velocity=(0.3, 0.0, 0.0))
    contact = system.add_contact(system.ground, Plane(), ball, Sphere(0.1), model="compliant", stiffness=1e5,
                                 damping=0.2)
    t = np.linspace(0.0, 0.6, 61)
    long, second = _split(system, t, 26, rtol=1e-10, atol=1e-12)
    assert np.min(np.asarray(long.contact(contact).gap)[26:]) < 0.0  # it lands after the split
    dq, dv = _difference(long, second, 26)
    assert dq < 1e-8 and dv < 1e-6  # (measured: 1.3e-10 m, 1.2e-8 m/s)


def _cam() -> CamFollower:
    return CamFollower(CamProfile.eccentric(radius=0.04, eccentricity=0.01), follower="flat", mass=0.5,
                       stiffness=200.0, preload=5.0)


def test_the_cam_on_its_follower_continues_to_round_off():
    cam = _cam()
    w = 0.8 * cam.jump_speed()
    t = np.linspace(0.0, 2.0 * math.pi / w, 41)
    long = cam.simulate(w, t)
    first = cam.simulate(w, t[:24])
    second = cam.simulate(w, t[23:], initial=_round_trip(first.final_state))
    assert first.final_state.contact_models == ("constraint",)
    # every output is a kinematic analysis (Newton to 1e-12): measured 1.4e-17 m, 2.8e-14 N
    np.testing.assert_allclose(second.lift, long.lift[23:], rtol=0.0, atol=1e-13)
    np.testing.assert_allclose(second.contact_force, long.contact_force[23:], rtol=0.0, atol=1e-9)


def test_the_cam_continues_in_flight_after_a_separation():
    cam = _cam()
    w = 1.15 * cam.jump_speed()
    t = np.linspace(0.0, 2.0 * math.pi / w, 41)
    long = cam.simulate(w, t, on_separation="compliant")
    first = cam.simulate(w, t[:24], on_separation="compliant")
    state = _round_trip(first.final_state)
    assert state.contact_models == ("compliant",)  # it left the cam before the split and lands after it
    second = cam.simulate(w, t[23:], on_separation="compliant", initial=state)
    assert not second.constraint.any()
    assert long.separations[0, 0] < t[23] < long.landings[0, 0]
    # the landing time is located on the dense output (measured: 4e-11 s apart); the lift then agrees to
    # 8e-10 m of its 2 cm (1.5e-14 m at rtol 1e-12)
    np.testing.assert_allclose(second.landings[:, 0], long.landings[:, 0], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(second.lift, long.lift[23:], rtol=0.0, atol=1e-8)
    np.testing.assert_array_equal(second.constraint, long.constraint[23:])
    assert _round_trip(second).final_state.t == second.t[-1]


def test_the_bicycle_ride_continues_on_a_new_system():
    system = whipple_bicycle(5.0)
    system.set_state(whipple_push(system, 2.0))
    t = np.linspace(0.0, 1.0, 61)
    # one piece per ride, so the split at 0.3 s is inside the long ride's piece
    long = whipple_ride(system, t, piece=10.0, rtol=1e-10, atol=1e-12)
    first = whipple_ride(system, t[:19], piece=10.0, rtol=1e-10, atol=1e-12)
    second = whipple_ride(whipple_bicycle(5.0), t[18:], piece=10.0, rtol=1e-10, atol=1e-12,
                          initial=_round_trip(first.final_state))
    assert not long.fallen and not second.fallen
    np.testing.assert_allclose(second.q, long.q[18:], rtol=0.0, atol=1e-8)
    np.testing.assert_allclose(second.lean, long.lean[18:], rtol=0.0, atol=1e-8)
    assert second.final_state.t == 1.0


def test_initial_is_checked():
    system = _pendulum()
    other = System()
    other.add_body("a", mass=1.0, inertia=(1.0, 1.0, 1.0))
    other.add_body("b", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(1.0, 0.0, 0.0))
    end = system.simulate([0.0, 0.5]).final_state
    with pytest.raises(ArgumentError, match=r"^initial: expected a RunState") as info:
        system.simulate([0.0, 1.0], initial=system.state)
    assert info.value.argument == "initial"
    with pytest.raises(ArgumentError, match=r"^initial: expected the state of 2 bodies") as info:
        other.simulate([0.5, 1.0], initial=end)
    with pytest.raises(ArgumentError, match=r"^t: a run from initial starts at initial.t = 0.5") as info:
        system.simulate([0.25, 1.0], initial=end)
    assert info.value.argument == "t"
    with pytest.raises(ArgumentError, match=r"^initial: describes 1 contacts, the System has 0"):
        system.simulate([0.5, 1.0], initial=RunState(end.t, end.q, end.v, contact_models=("constraint",)))
    with pytest.raises(ArgumentError, match=r"^initial: expected a RunState \(motion.final_state\)"):
        _cam().simulate(1.0, [0.0, 0.1], initial="state")


# ------------------------------------------------------------------ contact tests in core, one convention
def test_gap_crossings_count_a_zero_gap_as_touching():
    t = np.arange(7.0)
    gap = np.array([-1.0, 0.0, 1.0, 0.0, -2.0, 2.0, 3.0])
    opened, closed = gap_crossings(t, gap)
    np.testing.assert_array_equal(opened, [1.0, 4.5])  # 0 -> 1 opens at the zero; -2 -> 2 halfway
    np.testing.assert_array_equal(closed, [3.0])  # 1 -> 0 closes at the zero
    opened, closed = gap_crossings(t, gap, compliant=[True, True, True, True, True, False, True])
    np.testing.assert_array_equal(opened, [1.0])
    with pytest.raises(ArgumentError, match=r"^gap: expected 7 values"):
        gap_crossings(t, gap[:3])


def test_separation_intervals_are_where_the_closed_form_force_is_negative():
    cam = _cam()
    assert cam.separation_intervals(0.99 * cam.jump_speed()) == ()
    w = 1.15 * cam.jump_speed()
    intervals = cam.separation_intervals(w)
    assert len(intervals) == 1
    a, b = intervals[0]
    assert abs(float(cam.contact_force(a, w))) < 1e-8 and abs(float(cam.contact_force(b, w))) < 1e-8
    theta = np.linspace(0.0, 2.0 * math.pi, 20001)
    inside = (theta > a) & (theta < b)
    force = cam.contact_force(theta, w)
    assert np.all(force[inside] < 0.0) and np.all(force[~inside & ((theta < a - 1e-6) | (theta > b + 1e-6))] > 0.0)
    # the flat face on the eccentric cam: N < 0 around theta = pi, symmetric
    assert a + b == pytest.approx(2.0 * math.pi, abs=1e-10)
    with pytest.raises(ArgumentError, match=r"^samples: expected an integer >= 8"):
        cam.separation_intervals(w, samples=4)


def test_touch_location_is_the_contact_point_turned_with_the_cam():
    cam = CamFollower(CamProfile.eccentric(radius=0.04, eccentricity=0.01), follower="roller", roller_radius=0.01)
    theta = np.linspace(0.0, 2.0 * math.pi, 13).reshape(13, 1)
    touch = cam.touch_location(theta)
    assert touch.point.shape == (13, 1, 2) and touch.normal.shape == (13, 1, 2)
    np.testing.assert_allclose(np.linalg.norm(touch.normal, axis=-1), 1.0, atol=1e-14)
    p = cam.cam_curve(theta).point
    np.testing.assert_allclose(np.linalg.norm(touch.point, axis=-1), np.linalg.norm(p, axis=-1), atol=1e-15)
    c, s = math.cos(theta[3, 0]), math.sin(theta[3, 0])
    np.testing.assert_allclose(touch.point[3, 0], [c * p[3, 0, 0] - s * p[3, 0, 1], s * p[3, 0, 0] + c * p[3, 0, 1]],
                               atol=1e-16)
    # the follower's roller centre is on the normal line through the touch point, a roller radius away
    centre = touch.point[:, 0] + cam.roller_radius * touch.normal[:, 0]
    np.testing.assert_allclose(centre[:, 0], cam.offset, atol=1e-12)


def test_a_refused_argument_carries_its_name():
    profile = CamProfile.rise_dwell_return(base_radius=0.03, lift=0.02, rise=math.radians(40.0),
                                           dwell=math.radians(20.0), fall=math.radians(40.0), law="cycloidal")
    with pytest.raises(ValueError, match=r"^roller_radius: expected less than") as info:
        CamFollower(profile, follower="roller", roller_radius=0.05)
    exc = info.value
    assert isinstance(exc, ArgumentError) and exc.argument == "roller_radius"
    copy = pickle.loads(pickle.dumps(exc))
    assert copy.argument == "roller_radius" and str(copy) == str(exc)
    with pytest.raises(ArgumentError) as info:
        CamFollower(profile, follower="roller", roller_radius=0.01, mass=-1.0)
    assert info.value.argument == "mass"


def test_the_default_tolerances_live_in_one_place():
    import inspect

    from rigidlab.core import integrators

    signature = inspect.signature(integrators.integrate)
    assert signature.parameters["rtol"].default is DEFAULT_RTOL
    assert signature.parameters["atol"].default is DEFAULT_ATOL
    system = _pendulum()
    t = np.linspace(0.0, 0.5, 3)
    np.testing.assert_array_equal(system.simulate(t).q, system.simulate(t, rtol=DEFAULT_RTOL, atol=DEFAULT_ATOL).q)
