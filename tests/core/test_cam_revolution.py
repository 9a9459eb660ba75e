"""CamFollower.revolution (the closed-form table of one revolution) and CamMotion.periodic."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from rigidlab.core import ArgumentError
from rigidlab.core.models import CamFollower, CamMotion, CamProfile, CamRevolution, largest_roller_radius, smallest_convex_rise

TWO_PI = 2.0 * math.pi


@pytest.mark.parametrize("cam", [
    CamFollower(CamProfile.eccentric()),
    CamFollower(CamProfile.rise_dwell_return(law="cycloidal"), follower="roller", roller_radius=0.01, offset=0.004),
])
def test_the_revolution_table_is_the_closed_forms_sampled(cam):
    speed, n = 1.3 * cam.jump_speed(), 720
    rev = cam.revolution(-speed, samples=n)  # the sign of the speed does not matter
    assert isinstance(rev, CamRevolution) and rev.speed == speed and rev.jump_speed == cam.jump_speed()
    np.testing.assert_allclose(rev.theta, np.arange(n + 1) * TWO_PI / n)
    k = cam.kinematics(rev.theta)
    np.testing.assert_array_equal(rev.lift, k.lift)
    # velocity and acceleration are the lift's time derivatives at constant speed (central differences)
    h = rev.theta[1] / speed
    np.testing.assert_allclose(((rev.lift[2:] - rev.lift[:-2]) / (2 * h)), rev.velocity[1:-1],
                               atol=2e-3 * np.abs(rev.velocity).max())
    np.testing.assert_allclose(((rev.velocity[2:] - rev.velocity[:-2]) / (2 * h)), rev.acceleration[1:-1],
                               atol=1e-2 * np.abs(rev.acceleration).max())  # (the jerk jumps at segment ends)
    np.testing.assert_array_equal(rev.contact_force, cam.contact_force(rev.theta, speed))
    np.testing.assert_array_equal(rev.force_at_jump, cam.contact_force(rev.theta, cam.jump_speed()))
    assert rev.force_at_jump.min() == pytest.approx(0.0, abs=1e-3 * np.abs(rev.force_at_jump).max())
    touch = cam.touch_location(rev.theta)
    np.testing.assert_array_equal(rev.contact_point, touch.point)
    np.testing.assert_array_equal(rev.contact_normal, touch.normal)
    # above the jump speed the force turns negative over the separation intervals, and only there
    assert rev.separations == cam.separation_intervals(speed, samples=n) and rev.separations
    inside = np.zeros(n + 1, dtype=bool)
    for a, b in rev.separations:
        inside |= ((rev.theta - a) % TWO_PI) < (b - a)
    np.testing.assert_array_equal(inside[:-1], rev.contact_force[:-1] < 0)
    i = int(np.argmin(rev.contact_force))
    assert rev.min_force == (rev.contact_force[i], rev.theta[i]) and rev.min_force[0] < 0
    assert cam.revolution(0.9 * cam.jump_speed(), samples=n).separations == ()


@pytest.mark.parametrize(("kwargs", "argument"), [({"speed": 0.0}, "speed"), ({"speed": math.nan}, "speed"),
                                                  ({"speed": 10.0, "samples": 4}, "samples"),
                                                  ({"speed": 10.0, "samples": 10.5}, "samples")])
def test_the_revolution_refuses_a_bad_argument_by_name(kwargs, argument):
    with pytest.raises(ArgumentError) as info:
        CamFollower(CamProfile.eccentric()).revolution(**kwargs)
    assert info.value.argument == argument and str(info.value).startswith(f"{argument}: expected")


def test_a_run_on_the_cam_is_periodic_and_its_next_revolution_repeats_it():
    cam = CamFollower(CamProfile.eccentric())
    speed = 0.8 * cam.jump_speed()
    period = TWO_PI / speed
    first = cam.simulate(speed, np.linspace(0.0, period, 41), on_separation="compliant")
    assert first.periodic
    second = cam.simulate(speed, np.linspace(period, 2 * period, 41), on_separation="compliant",
                          initial=first.final_state)
    scale = np.abs(first.lift).max()
    np.testing.assert_allclose(second.lift, first.lift, atol=1e-7 * scale)
    np.testing.assert_allclose(second.contact_force, first.contact_force, rtol=1e-5, atol=1e-6)


def test_a_run_that_leaves_the_cam_is_not_periodic():
    cam = CamFollower(CamProfile.eccentric(), stiffness=200.0, preload=2.0)
    speed = 1.2 * cam.jump_speed()
    run = cam.simulate(speed, np.linspace(0.0, TWO_PI / speed, 121), on_separation="compliant")
    assert run.separations.size > 0 and not run.periodic
    compliant = cam.simulate(0.5 * cam.jump_speed(), np.linspace(0.0, 0.1, 11), model="compliant")
    assert compliant.separations.size == 0 and not compliant.periodic  # never in the constraint model


@pytest.mark.parametrize("law", ["cycloidal", "harmonic", "345"])
def test_the_smallest_convex_rise_is_where_a_flat_face_starts_to_fit(law):
    base, lift, dwell = 0.02, 0.02, math.radians(30.0)
    rise = smallest_convex_rise(base, lift, dwell, law)
    assert 0.0 < rise < (TWO_PI - dwell) / 2

    def flat(r):
        profile = CamProfile.rise_dwell_return(base_radius=base, lift=lift, rise=r, dwell=dwell, fall=r, law=law)
        return CamFollower(profile, follower="flat")

    # accepted there, convex to the resolution of core's check (1025 samples per segment)
    assert flat(rise).radius_of_curvature(np.linspace(0.0, TWO_PI, 4001)).min() > -1e-6 * base
    with pytest.raises(ArgumentError) as info:
        flat(rise - 1e-6)  # and refused just below
    assert info.value.argument == "base_radius"
    assert base <= info.value.limit < 1.01 * base  # the base radius that would make this cam convex


def test_the_smallest_convex_rise_is_inf_when_no_rise_is_convex_and_refuses_bad_arguments():
    assert smallest_convex_rise(0.001, 0.5, math.radians(300.0), "harmonic") == math.inf
    for kwargs, argument in (({"dwell": TWO_PI}, "dwell"), ({"law": "square"}, "law"), ({"lift": -1.0}, "lift")):
        args = {"base_radius": 0.02, "lift": 0.02, "dwell": 0.5, "law": "cycloidal"} | kwargs
        with pytest.raises(ArgumentError) as info:
            smallest_convex_rise(**args)
        assert info.value.argument == argument


def _pitch_radius_min(profile: CamProfile, roller: float, offset: float, n: int = 400_000) -> float:
    """Smallest convex radius of curvature (m) of the roller centre's path, independent of core's pitch curve:
    the point ``e_o t + (s_0 + s) n`` is at polar radius ``hypot(e_o, s_0 + s)`` and polar angle
    ``u + atan2(e_o, s_0 + s)`` (orientation and sign of the angle do not change a radius of curvature), its
    derivatives by central differences of the points on a grid of ``n`` angles."""
    u = np.arange(n) * (TWO_PI / n)
    h = TWO_PI / n
    s = profile.motion_law(u).lift
    y = math.sqrt((profile.base_radius + roller) ** 2 - offset**2) + s
    radius, angle = np.hypot(offset, y), u + np.arctan2(offset, y)
    x, z = radius * np.cos(angle), radius * np.sin(angle)
    dx, dz = (np.roll(x, -1) - np.roll(x, 1)) / (2 * h), (np.roll(z, -1) - np.roll(z, 1)) / (2 * h)
    ddx, ddz = (np.roll(x, -1) - 2 * x + np.roll(x, 1)) / h**2, (np.roll(z, -1) - 2 * z + np.roll(z, 1)) / h**2
    rho = (dx * dx + dz * dz) ** 1.5 / (dx * ddz - dz * ddx)  # > 0 where the path turns as a whole (counter-clockwise)
    return float(rho[rho > 0].min())


@pytest.mark.parametrize("offset", [0.0, 0.01])
def test_the_largest_roller_radius_needs_only_the_profile(offset):
    # (40 deg rise = fall: an 18-21 mm roller undercuts this cam; a 5 mm one fits)
    profile = CamProfile.rise_dwell_return(0.04, 0.02, math.radians(40.0), math.radians(30.0), math.radians(40.0))
    largest = largest_roller_radius(profile, offset=offset)
    cam = CamFollower(profile, follower="roller", roller_radius=0.005, offset=offset)
    assert largest == cam.largest_roller_radius()
    # at that roller its own pitch curve's smallest convex radius of curvature is the roller's radius. Tolerance
    # 1e-5 relative: core locates the smallest radius on 1025 samples per segment without refining it (a sampled
    # minimum of a smooth function: off by up to about 1e-6 of it here); the differences here err by O(h^2), 1e-10
    assert _pitch_radius_min(profile, largest, offset) == pytest.approx(largest, rel=1e-5)
    # a roller that no cam of this profile can carry is refused when built; the profile still answers
    with pytest.raises(ArgumentError) as refused:
        CamFollower(profile, follower="roller", roller_radius=0.03, offset=offset)
    assert refused.value.argument == "roller_radius"
    # the refusal carries that largest roller (no second search), also across a process boundary
    assert refused.value.limit == largest and f"{largest:.6g} m" in str(refused.value)
    copy = pickle.loads(pickle.dumps(refused.value))
    assert (type(copy), copy.argument, copy.limit, str(copy)) == (ArgumentError, "roller_radius", largest,
                                                                  str(refused.value))
    assert largest_roller_radius(CamProfile.eccentric()) == math.inf
    for args, argument in (({"profile": "cam"}, "profile"), ({"profile": profile, "offset": math.nan}, "offset")):
        with pytest.raises(ArgumentError, match=f"^{argument}: expected") as bad:
            largest_roller_radius(**args)
        assert bad.value.argument == argument


def test_the_separated_angles_are_where_the_closed_form_force_is_negative():
    cam = CamFollower(CamProfile.rise_dwell_return(law="harmonic"), follower="roller", roller_radius=0.01)
    rev = cam.revolution(1.4 * cam.jump_speed(), samples=720)
    assert rev.separations
    theta = np.linspace(-TWO_PI, 2 * TWO_PI, 30_000).reshape(3, -1)  # any shape, any turn
    # the independent reference: the sign of N, away from the intervals' ends (found to 1e-12 rad)
    ends = np.array([e for interval in rev.separations for e in interval])
    far = np.min(np.abs(np.mod(theta[..., None] - ends + math.pi, TWO_PI) - math.pi), axis=-1) > 1e-9
    separated = rev.separated(theta)
    assert separated.shape == theta.shape and np.any(separated[far]) and not np.all(separated[far])
    np.testing.assert_array_equal(separated[far], (cam.contact_force(theta, rev.speed) < 0.0)[far])
    below = cam.revolution(0.9 * cam.jump_speed(), samples=720)
    assert not np.any(below.separated(theta))


def test_a_run_between_its_outputs_is_linear_and_in_flight_only_off_the_constraint_with_a_gap():
    # a hand-made run (no System needed): outputs every 0.1 s, on the cam (constraint), then in flight, then a
    # compliant contact pressed in
    t = np.array([0.0, 0.1, 0.2, 0.3])
    lift, force, gap = np.array([0.0, 1.0, 3.0, 2.0]), np.array([5.0, 1.0, 0.0, 4.0]), np.array([0.0, 0.0, 2e-3, -2e-3])
    point = np.column_stack([t, np.zeros(4), 1.0 + t])
    normal = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    run = CamMotion(t, 10.0 * t, lift, np.zeros(4), force, point, gap, np.zeros((0, 2)), np.zeros((0, 2)), "completed",
                    None, normal, np.array([True, True, False, False]))
    for k in range(4):  # the outputs themselves, exactly
        sample = run.at(float(t[k]))
        assert (sample.lift, sample.contact_force) == (lift[k], force[k])
        np.testing.assert_array_equal(sample.contact_point, point[k])
    quarter = run.at(0.125)  # a quarter of the way from output 1 to output 2 (closed forms of the straight line)
    assert quarter.lift == pytest.approx(1.5, rel=1e-12) and quarter.contact_force == pytest.approx(0.75, rel=1e-12)
    np.testing.assert_allclose(quarter.contact_normal, np.array([0.25, 0.0, 0.75]) / math.hypot(0.25, 0.75), rtol=1e-12)
    assert quarter.in_contact  # nearer the constraint output
    assert not run.at(0.175).in_contact  # nearer the compliant one, the gap 1.5e-3 > 0: in flight
    assert run.at(0.29).in_contact  # the gap closed (pressed in)
    assert run.at(-1.0).lift == 0.0 and run.at(9.0).lift == 2.0  # clamped to the run
    with pytest.raises(ArgumentError, match="^t: expected"):
        run.at(math.nan)


def test_a_run_in_words_names_the_contact_and_counts_the_events_up_to_the_output():
    t = np.array([0.0, 0.1, 0.2, 0.3])
    gap, force = np.array([0.0, 2e-3, 0.0, -2.5e-6]), np.array([5.0, 0.0, 1.0, 4.0])
    run = CamMotion(t, 10.0 * t, np.zeros(4), np.zeros(4), force, np.zeros((4, 3)), gap, np.array([[0.05, 0.5]]),
                    np.array([[0.15, 1.5]]), "completed", None, np.zeros((4, 3)), np.array([True, False, False, False]))
    assert run.describe(0) == (("on the cam", "contact constraint, N = 5.000 N"),
                               ("so far", "0 separation(s), 0 landing(s)"))
    assert run.describe(1) == (("in flight", "gap 2.000 mm, N = 0"), ("so far", "1 separation(s), 0 landing(s)"))
    assert run.describe(3) == (("on the cam", "Hunt-Crossley, pressed in 2.5 µm, N = 4.000 N"),
                               ("so far", "1 separation(s), 1 landing(s)"))


def test_a_revolution_and_a_cam_in_words():
    cam = CamFollower(CamProfile.eccentric(radius=0.04, eccentricity=0.01))
    jump = cam.jump_speed()
    # the flat face on the eccentric cam at half its jump speed: the force is smallest at the bottom (theta = 0;
    # N = m w^2 e cos(theta) + k e (1 - cos(theta)) + F0 + m g, with k e > m w^2 e here)
    (topic, text), (none, smallest) = cam.revolution(0.5 * jump, samples=720).describe()
    assert topic == "Jump speed" and text == (f"{jump * 30 / math.pi:.1f} rpm ({jump:.3f} rad/s); the cam turns at "
                                              f"{0.5 * jump * 30 / math.pi:.6g} rpm, 50.0 % of it")
    force = float(cam.contact_force(0.0, 0.5 * jump))
    assert none == "No separation" and smallest == f"N > 0 all round (smallest {force:.3f} N at θ = 0.00°)"
    rev = cam.revolution(1.5 * jump, samples=720)
    (a, b), = rev.separations
    assert rev.describe()[1] == ("Separation", f"N < 0 from θ = {math.degrees(a):.2f}° to {math.degrees(b):.2f}°: "
                                               "the contact would have to pull")
    assert cam.describe() == (("Cam", "eccentric circle R = 40 mm, e = 10 mm"), (
        "Follower", "flat face, m = 0.5 kg, k = 2000 N/m, F0 = 20 N, g = 9.81 m/s² towards the cam"))
    roller = CamFollower(CamProfile.rise_dwell_return(base_radius=0.04, lift=0.02, rise=math.pi / 2, dwell=math.pi / 6,
                                                      fall=math.pi / 2, law="cycloidal"), follower="roller",
                         roller_radius=0.0105, offset=0.002)
    assert roller.describe()[0][1] == ("cycloidal rise-dwell-return, base circle 40 mm, lift 20 mm, rise 90°, "
                                       "dwell 30°, fall 90°")
    assert roller.describe()[1][1].startswith("roller r = 10.5 mm, offset 2 mm, m = 0.5 kg")
