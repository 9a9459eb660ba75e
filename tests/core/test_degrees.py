"""``degrees=True``: every public function of rigidlab.core that takes angles accepts them in degrees.

The rule (docs/conventions.md): with ``degrees=True`` the angles a function
takes are in degrees and the scalar rates given alongside them (Euler angle
rates, joint rates, a spin, a crank speed) in deg/s and deg/s^2; an array of
angles (or their rates) the function returns is in degrees too. Angular
velocity vectors (``omega``, ``omega_body``, ``alpha``) and result objects
(dataclasses, Systems) stay in radians, and so does an argument left at its
default.

Tolerance of the comparisons: a call with ``degrees=True`` converts with
``np.deg2rad`` (one product with pi/180, rounded once), and the reference
call here gets exactly that product, so the two calls see the same floats;
``rtol = 1e-15`` (with ``atol`` 1e-15 of the largest entry, for entries that
round to about zero) leaves room only for a returned angle multiplied by
180/pi in another order (one rounding, 1.1e-16 relative). A conversion
forgotten or done twice is off by a factor of 57 (relative error > 0.98).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import math
import pkgutil
import re

import numpy as np
import pytest

import rigidlab.core as core
import rigidlab.core.gyroscope as gy
import rigidlab.core.manipulator as mp
import rigidlab.core.models as md
import rigidlab.core.rotations as cr
from rigidlab.core.multibody import System
from rigidlab.core.rigid_body import rotation_angle_between

RTOL = 1e-15

AXES = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
AN, AN2 = np.array([10.0, 200.0]), np.array([40.0, 120.0])
AXIS_DOT = np.array([[0.3, -0.2, 0.0], [0.0, 0.5, 0.0]])  # perpendicular to AXES
E1 = np.array([30.0, 40.0, 20.0])
E = np.array([[30.0, 40.0, 20.0], [-100.0, 10.0, 170.0], [5.0, -60.0, 250.0]])
RATES = np.array([[10.0, -20.0, 300.0], [0.0, 5.0, -45.0], [90.0, 0.0, 1.0]])
RATES_DOT = np.array([[1.0, 2.0, -3.0], [40.0, 0.0, 7.0], [0.0, -9.0, 2.0]])
OMEGA = np.array([0.3, -1.2, 2.0])
A = cr.matrix_from_euler_angles(np.deg2rad(E), "ZXZ")
P = cr.euler_parameters_from_euler_angles(np.deg2rad(E), "zyx")
RV = np.array([[10.0, 20.0, -30.0], [0.0, 0.0, 179.0]])
J1 = np.array([20.0, 35.0, -50.0])
J = np.array([[20.0, 35.0, -50.0], [0.0, 90.0, 180.0]])
ROTOR = gy.RotorParams(I=1.2, I3=0.7, mgl=0.9)
STATE = np.array([[10.0, 35.0, 0.0, 20.0, 5.0, 900.0], [-40.0, 80.0, 10.0, -5.0, 0.0, 700.0]])
STATE0 = STATE[0]
T = np.array([0.0, 0.05, 0.1])
TH = np.array([0.0, 30.0, 100.0, 200.0, 359.0])


def rotations_cases():
    def pair(f, out=None):
        return f, out

    deg = np.rad2deg
    return {
        "rotations.elementary_matrix": pair(lambda a, kw: cr.elementary_matrix(2, a(np.array([10.0, -30.0])), **kw)),
        "rotations.matrix_from_axis_angle": pair(lambda a, kw: cr.matrix_from_axis_angle(AXES, a(AN), **kw)),
        "rotations.matrix_from_axis_angle (one)": pair(lambda a, kw: cr.matrix_from_axis_angle(AXES[1], a(75.0), **kw)),
        "rotations.euler_parameters_from_axis_angle": pair(
            lambda a, kw: cr.euler_parameters_from_axis_angle(AXES, a(AN), **kw)),
        "rotations.omega_from_axis_angle_rates": pair(
            lambda a, kw: cr.omega_from_axis_angle_rates(AXES, a(AN2), AXIS_DOT, a(15.0), **kw)),
        "rotations.omega_body_from_axis_angle_rates": pair(
            lambda a, kw: cr.omega_body_from_axis_angle_rates(AXES, a(AN2), AXIS_DOT, a(15.0), **kw)),
        "rotations.matrix_from_euler_angles": pair(lambda a, kw: cr.matrix_from_euler_angles(a(E), "ZXZ", **kw)),
        "rotations.matrix_from_euler_angles (one)": pair(lambda a, kw: cr.matrix_from_euler_angles(a(E1), "zyx", **kw)),
        "rotations.euler_parameters_from_euler_angles": pair(
            lambda a, kw: cr.euler_parameters_from_euler_angles(a(E), "zyx", **kw)),
        "rotations.euler_parameters_from_euler_angles (one)": pair(
            lambda a, kw: cr.euler_parameters_from_euler_angles(a(E1), "XYX", **kw)),
        "rotations.euler_angle_G": pair(lambda a, kw: cr.euler_angle_G(a(E), "ZXZ", **kw)),
        "rotations.euler_angle_G_bar": pair(lambda a, kw: cr.euler_angle_G_bar(a(E), "yxz", **kw)),
        "rotations.euler_angles_near_singularity": pair(
            lambda a, kw: cr.euler_angles_near_singularity(a(np.array([[0.0, 1e-5, 0.0], [0.0, 0.0, 0.0]])), **kw)),
        "rotations.euler_angle_rates_from_omega": pair(
            lambda a, kw: cr.euler_angle_rates_from_omega(a(E), OMEGA, "ZXZ", **kw), deg),
        "rotations.euler_angle_rates": pair(lambda a, kw: cr.euler_angle_rates(a(E), OMEGA, "ZYX", **kw), deg),
        "rotations.omega_from_euler_angle_rates": pair(
            lambda a, kw: cr.omega_from_euler_angle_rates(a(E), a(RATES), "ZXZ", **kw)),
        "rotations.omega_body_from_euler_angle_rates": pair(
            lambda a, kw: cr.omega_body_from_euler_angle_rates(a(E), a(RATES), "xyz", **kw)),
        "rotations.alpha_from_euler_angle_rates": pair(
            lambda a, kw: cr.alpha_from_euler_angle_rates(a(E), a(RATES), a(RATES_DOT), "ZXZ", **kw)),
        "rotations.alpha_body_from_euler_angle_rates": pair(
            lambda a, kw: cr.alpha_body_from_euler_angle_rates(a(E), a(RATES), a(RATES_DOT), "ZYZ", **kw)),
        "rotations.matrix_from_rotation_vector": pair(lambda a, kw: cr.matrix_from_rotation_vector(a(RV), **kw)),
        "rotations.euler_parameters_from_rotation_vector": pair(
            lambda a, kw: cr.euler_parameters_from_rotation_vector(a(RV), **kw)),
        # functions that return angles: degrees out
        "rotations.axis_angle_from_matrix": pair(lambda a, kw: cr.axis_angle_from_matrix(A, **kw),
                                                 lambda r: (r[0], deg(r[1]))),
        "rotations.axis_angle_from_euler_parameters": pair(lambda a, kw: cr.axis_angle_from_euler_parameters(P, **kw),
                                                           lambda r: (r[0], deg(r[1]))),
        "rotations.axis_angle_from_euler_parameters (one)": pair(
            lambda a, kw: cr.axis_angle_from_euler_parameters(P[1], **kw), lambda r: (r[0], deg(r[1]))),
        "rotations.euler_angles_from_matrix": pair(lambda a, kw: cr.euler_angles_from_matrix(A, "ZXZ", **kw), deg),
        "rotations.euler_angles_from_matrix (one)": pair(
            lambda a, kw: cr.euler_angles_from_matrix(A[0], "zyx", **kw), deg),
        "rotations.euler_angles_from_euler_parameters": pair(
            lambda a, kw: cr.euler_angles_from_euler_parameters(P, "zyx", **kw), deg),
        "rotations.rotation_vector_from_matrix": pair(lambda a, kw: cr.rotation_vector_from_matrix(A, **kw), deg),
        "rotations.rotation_vector_from_euler_parameters": pair(
            lambda a, kw: cr.rotation_vector_from_euler_parameters(P, **kw), deg),
        "rigid_body.rotation_angle_between": pair(lambda a, kw: rotation_angle_between(P[0], P[1:], **kw), deg),
    }


def other_cases():
    deg = np.rad2deg

    def motor_system(a, kw):
        system = System(gravity=(0.0, 0.0, 0.0))
        body = system.add_body("b", mass=1.0, inertia=np.eye(3))
        joint = system.add_joint("revolute", system.ground, body, point=(0, 0, 0), axis=(0, 0, 1.0))
        law = (lambda t: a(90.0) * t, lambda t: a(90.0) + 0.0 * t, lambda t: 0.0 * t)
        motor = system.add_motor(joint, angle=law, **kw)
        spring = system.add_rotational_spring_damper(joint, stiffness=2.0, angle0=a(30.0), **kw)
        return motor.values(0.5), spring.angle0

    def crank(a, kw):
        return md.slider_crank(phi0=a(30.0), speed=a(360.0), **kw)

    def ride(a, kw):
        system = md.whipple_bicycle(2.0)
        system.set_state(md.whipple_push(system, 0.5))
        return md.whipple_ride(system, T, lean_limit=a(0.02), **kw)

    def follower():
        return md.CamFollower(md.CamProfile.rise_dwell_return(), follower="roller", roller_radius=0.01)

    return {
        **{f"manipulator.{name}": (lambda name: (lambda a, kw: getattr(mp, name)(a(J), **kw)))(name)
           for name in ("relative_rotation_matrices", "link_frames_successive", "matrix_from_successive_rotations",
                        "link_frames_global_axis_rotations", "matrix_from_global_axis_rotations", "euler_form")},
        "manipulator.link_frames_successive (one)": lambda a, kw: mp.link_frames_successive(a(J1), **kw),
        "manipulator.end_link_angular_velocity": lambda a, kw: mp.end_link_angular_velocity(a(J), a(J[::-1]), **kw),
        "gyroscope.equations_of_motion": (lambda a, kw: gy.equations_of_motion(ROTOR, a(STATE), **kw), deg),
        "gyroscope.invariants": lambda a, kw: gy.invariants(ROTOR, a(STATE), **kw),
        "gyroscope.rotor_vectors": lambda a, kw: gy.rotor_vectors(ROTOR, a(STATE), **kw),
        "gyroscope.nutation": lambda a, kw: gy.nutation(ROTOR, a(STATE), **kw),
        "gyroscope.top_motion": lambda a, kw: gy.top_motion(ROTOR, a(STATE0), **kw).at(T),
        "gyroscope.simulate": lambda a, kw: gy.simulate(ROTOR, a(STATE0), T, **kw),
        "gyroscope.steady_precession_torque": lambda a, kw: gy.steady_precession_torque(
            ROTOR, a(30.0), a(20.0), a(600.0), **kw),
        "gyroscope.steady_precession_rates": lambda a, kw: gy.steady_precession_rates(ROTOR, a(30.0), a(2000.0), **kw),
        "gyroscope.RotorSetup": lambda a, kw: gy.RotorSetup(ROTOR, tuple(a(STATE0)), **kw).state0,
        "models.heavy_top": lambda a, kw: md.heavy_top(ROTOR, a(STATE0), **kw).system,
        "models.steady_top": lambda a, kw: md.steady_top(ROTOR, spin=a(3000.0), theta=a(30.0), **kw),
        "models.pendulum_chain": lambda a, kw: md.pendulum_chain(3, tilt=a(20.0), **kw),
        "models.pendulum_chain_reduced": lambda a, kw: md.pendulum_chain_reduced(2, T, tilt=a(20.0), **kw),
        "models.linkage": lambda a, kw: md.linkage("slider_crank", tilt=a(50.0), speed=a(360.0), **kw).system,
        "models.slider_crank": lambda a, kw: crank(a, kw),
        "models.SliderCrank.slider_position": lambda a, kw: crank(a, kw).slider_position(a(TH), **kw),
        "models.SliderCrank.slider_velocity": lambda a, kw: crank(a, kw).slider_velocity(a(TH), a(90.0), **kw),
        "models.spatial_double_pendulum": lambda a, kw: md.spatial_double_pendulum(
            tilt=tuple(a(np.array([40.0, 70.0]))), azimuth=tuple(a(np.array([0.0, 60.0]))), spin=a(90.0), **kw),
        "models.rolling_disk": lambda a, kw: md.rolling_disk(
            lean=a(10.0), spin=a(1000.0), heading_rate=a(5.0), lean_rate=a(2.0), **kw)[0],
        "models.rolling_disk_reference": lambda a, kw: md.rolling_disk_reference(
            T, lean=a(10.0), spin=a(1000.0), heading_rate=a(5.0), lean_rate=a(2.0), **kw),
        "models.RollingDisk": lambda a, kw: md.RollingDisk(lean=a(10.0), spin=a(1000.0), heading_rate=a(5.0),
                                                           lean_rate=a(2.0), **kw),
        "models.rolling_disk_run": lambda a, kw: md.rolling_disk_run(*md.rolling_disk(lean=0.2), T[:2],
                                                                      lean_limit=a(80.0), **kw),
        "models.whipple_ride_from": lambda a, kw: md.whipple_ride_from(2.0, T, impulse=0.5, lean_limit=a(0.02), **kw),
        "models.whipple_ride": ride,
        "models.WhippleParameters": lambda a, kw: md.WhippleParameters(**{
            **{f.name: getattr(md.MEIJAARD_2007, f.name) for f in dataclasses.fields(md.WhippleParameters)},
            "steer_axis_tilt": a(18.0)}, **kw),
        "models.CamProfile": lambda a, kw: md.CamProfile("rise_dwell_return", 0.04, lift=0.02, rise=a(100.0),
                                                         dwell=a(40.0), fall=a(80.0), law="harmonic", **kw),
        "models.CamProfile.rise_dwell_return": lambda a, kw: md.CamProfile.rise_dwell_return(
            rise=a(100.0), dwell=a(40.0), fall=a(80.0), **kw),
        "models.CamProfile.motion_law": lambda a, kw: md.CamProfile.rise_dwell_return().motion_law(a(TH), **kw),
        "models.CamFollower.kinematics": lambda a, kw: follower().kinematics(a(TH), **kw),
        "models.CamFollower.pressure_angle": (lambda a, kw: follower().pressure_angle(a(TH), **kw), deg),
        "models.CamFollower.contact_force": lambda a, kw: follower().contact_force(a(TH), a(3000.0), **kw),
        "models.CamFollower.touch_location": lambda a, kw: follower().touch_location(a(TH), **kw),
        "models.CamFollower.contact_normal": lambda a, kw: follower().contact_normal(a(TH), **kw),
        "models.CamRevolution.separated": lambda a, kw: follower().revolution(
            1.3 * follower().jump_speed(), samples=180).separated(a(np.linspace(0.0, 359.0, 200)), **kw),
        "models.smallest_convex_rise": (lambda a, kw: md.smallest_convex_rise(0.04, 0.02, a(30.0), "cycloidal", **kw),
                                        deg),
        "multibody.System.add_motor, add_rotational_spring_damper": motor_system,
    }


CASES = {**rotations_cases(), **other_cases()}


def _values(x, depth=0):
    """The numbers of a result, flattened: arrays, numbers, tuples, dataclasses, Systems (their state)."""
    if isinstance(x, System):
        return _values(x.state.q) + _values(x.state.v)
    if isinstance(x, (np.ndarray, float, int, np.floating, np.integer, np.bool_, bool)):
        return [np.asarray(x, dtype=float)]
    if isinstance(x, (tuple, list)):
        return [v for item in x for v in _values(item, depth + 1)]
    if dataclasses.is_dataclass(x) and depth < 4:
        return [v for f in dataclasses.fields(x) for v in _values(getattr(x, f.name), depth + 1)]
    return []


@pytest.mark.parametrize("name", sorted(CASES))
def test_degrees_equal_radians(name):
    case = CASES[name]
    call, out = case if isinstance(case, tuple) else (case, None)
    in_degrees = call(lambda v: v, {"degrees": True})
    in_radians = call(lambda v: np.deg2rad(v) if isinstance(v, np.ndarray) else v * (math.pi / 180.0), {})
    expected = _values(out(in_radians) if out is not None else in_radians)
    got = _values(in_degrees)
    assert len(got) == len(expected) and got, name
    for g, e in zip(got, expected):
        scale = float(np.max(np.abs(e))) if e.size and np.all(np.isfinite(e)) else 1.0
        np.testing.assert_allclose(g, e, rtol=RTOL, atol=RTOL * scale, err_msg=name)
    # the case can tell: the same numbers without degrees=True give another result (or are refused)
    try:
        unconverted = _values(call(lambda v: v, {}))
    except ValueError:
        return
    assert any(u.shape != g.shape or not np.allclose(u, g, rtol=1e-6, atol=0.0) for u, g in
               zip(unconverted, got)), f"{name}: the result does not tell degrees from radians"


def test_round_trips_in_degrees():
    angles = np.array([[30.0, 40.0, 20.0], [-100.0, 10.0, 170.0]])
    for seq in ("ZXZ", "zyx", "XYZ"):
        A_ = cr.matrix_from_euler_angles(angles, seq, degrees=True)
        back = cr.euler_angles_from_matrix(A_, seq, degrees=True)
        np.testing.assert_allclose(cr.matrix_from_euler_angles(back, seq, degrees=True), A_, atol=1e-15)
    R = cr.matrix_from_axis_angle([0.0, 0.0, 1.0], 90.0, degrees=True)
    axis, angle = cr.axis_angle_from_matrix(R, degrees=True)
    np.testing.assert_allclose(angle, 90.0, rtol=1e-15)
    r = cr.rotation_vector_from_matrix(cr.matrix_from_rotation_vector([0.0, 45.0, 0.0], degrees=True), degrees=True)
    np.testing.assert_allclose(r, [0.0, 45.0, 0.0], atol=1e-13)


def test_defaults_stay_angles():
    # an argument left at its default keeps its angle (it is not read as degrees)
    assert md.linkage("chain", degrees=True).system.state.q.tolist() == md.linkage("chain").system.state.q.tolist()
    assert md.CamProfile.rise_dwell_return(degrees=True) == md.CamProfile.rise_dwell_return()
    assert md.RollingDisk(degrees=True) == md.RollingDisk()


@pytest.mark.parametrize("call", [
    lambda: cr.matrix_from_axis_angle([0.0, 0.0, 1.0], 30.0, degrees=1),
    lambda: cr.euler_angles_from_matrix(np.eye(3), degrees="yes"),
    lambda: mp.euler_form([1.0, 2.0, 3.0], degrees=None),
    lambda: md.pendulum_chain(2, tilt=10.0, degrees=1.0),
    lambda: md.RollingDisk(lean=1.0, degrees="true"),
])
def test_degrees_must_be_a_bool(call):
    with pytest.raises(ValueError, match="degrees: expected True or False, got"):
        call()


def test_errors_name_the_argument_in_degrees():
    with pytest.raises(ValueError, match="`angles`.*shape"):
        cr.matrix_from_euler_angles([1.0, 2.0], degrees=True)
    with pytest.raises(ValueError, match="`angle`"):
        cr.matrix_from_axis_angle([0.0, 0.0, 1.0], "x", degrees=True)
    with pytest.raises(ValueError, match="^tilt: "):
        md.pendulum_chain(2, tilt=float("nan"), degrees=True)
    with pytest.raises(ValueError, match="^state0: "):
        gy.simulate(ROTOR, [0.0, 30.0, 0.0], T, degrees=True)
    with pytest.raises(ValueError, match="^lean: "):
        md.RollingDisk(lean="x", degrees=True)


# ---------------------------------------------------------------- every angle argument has `degrees`
#: Parameter names that hold angles (or their rates alongside them).
ANGLE_PARAMETER = re.compile(
    r"^(angle|angles|angle0|angle_dot|theta|phi|psi|phi0|tilt|azimuth|lean|lean_limit|steer_axis_tilt|rise|dwell"
    r"|fall|joint_angles|joint_positions|[a-z_]*_angles?)$")

#: Records the library returns (their fields are results, in radians), not built from a user's angles.
RECORDS = {
    "gyroscope.GyroscopeTrajectory", "gyroscope.MotionSamples", "manipulator.EulerForm", "models.SteadyTop",
    "models.WhippleAngles", "models.WhippleMode", "models.WhippleRide", "models.CamRevolution",
    "models.ReducedChainMotion", "models.RollingDiskMotion", "models.RollingDiskRun", "models.SliderCrank",
    "models.SpatialDoublePendulum", "models.HeavyTop", "models.CamMotion", "models.GhostComparison",
    "models.PolhodeClass", "multibody.RotationalSpringDamper", "models.LinkageMotion", "models.CamTouch",
    "models.FreeBodyWindow",
}


def public_callables():
    """``(qualified name, callable)`` of every public function, class and method of rigidlab.core."""
    names = [m.name for m in pkgutil.walk_packages(core.__path__, "rigidlab.core.")
             if not any(part.startswith("_") for part in m.name.split(".")[2:])]
    seen = set()
    for module_name in names:
        module = importlib.import_module(module_name)
        short = module_name.removeprefix("rigidlab.core.")
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if not callable(obj) or id(obj) in seen:
                continue
            seen.add(id(obj))
            yield f"{short}.{name}", obj
            if inspect.isclass(obj):
                for attr, value in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    func = value.__func__ if isinstance(value, (classmethod, staticmethod)) else value
                    if inspect.isfunction(func):
                        yield f"{short}.{name}.{attr}", func


def test_every_angle_argument_has_degrees():
    missing, found = [], 0
    for qualname, obj in public_callables():
        if qualname in RECORDS:
            continue
        try:
            params = inspect.signature(obj).parameters
        except (TypeError, ValueError):
            continue
        angles = [p for p in params if ANGLE_PARAMETER.match(p)]
        if angles:
            found += 1
            if "degrees" not in params or params["degrees"].kind is not inspect.Parameter.KEYWORD_ONLY:
                missing.append(f"{qualname}({', '.join(angles)})")
    assert found > 40
    assert not missing, "take angles without a keyword-only degrees=: " + "; ".join(missing)


def test_records_exist():
    names = {name for name, _ in public_callables()}
    assert RECORDS <= names, RECORDS - names
