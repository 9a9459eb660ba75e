"""The System API of core.multibody: handles, state, reports, and every error the issue lists.

Bad input raises ValueError naming the argument (``pytest.raises(match=)``
on the argument's name and the expectation); no NaN leaves the solver
without a clear error.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from rigidlab.core.integrators import IntegrationError
from rigidlab.core.models import pendulum_chain
from rigidlab.core.multibody import (
    JOINT_KINDS,
    AssemblyError,
    AssemblyReport,
    MultibodyTrajectory,
    SingularSystemError,
    State,
    System,
)


@pytest.fixture
def two():
    system = System()
    a = system.add_body("a", mass=1.0, inertia=(0.1, 0.2, 0.25), position=(0.0, 0.0, -0.5))
    b = system.add_body("b", mass=1.0, inertia=(0.1, 0.2, 0.25), position=(0.0, 0.0, -1.5))
    return system, a, b


# ------------------------------------------------------------------ bodies
@pytest.mark.parametrize("mass", [0.0, -1.0, math.nan, math.inf, True, "1", None])
def test_mass_must_be_finite_and_positive(mass):
    with pytest.raises(ValueError, match=r"^mass: expected a finite mass > 0"):
        System().add_body("a", mass=mass, inertia=(1.0, 1.0, 1.0))


@pytest.mark.parametrize(
    ("inertia", "message"),
    [
        ((1.0, -0.1, 1.0), r"inertia: expected principal moments >= 0"),
        ([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"inertia: expected a symmetric tensor"),
        ((1.0, 1.0, 3.0), r"inertia: expected principal moments that satisfy the triangle inequality"),
        ((1.0, 1.0), r"inertia: expected principal moments \(3,\) or a tensor \(3, 3\)"),
        ((1.0, math.nan, 1.0), r"inertia: expected finite values"),
        ((1.0, 1.0, 1.0 + 1e-3j), r"inertia: expected real numbers, got complex"),
    ],
)
def test_inertia_is_validated(inertia, message):
    with pytest.raises(ValueError, match=message):
        System().add_body("a", mass=1.0, inertia=inertia)


def test_zero_rotational_inertia_and_flat_bodies_are_allowed():
    system = System()
    point = system.add_body("point", mass=2.0, inertia=(0.0, 0.0, 0.0))
    plate = system.add_body("plate", mass=1.0, inertia=(1.0, 2.0, 3.0))  # J3 = J1 + J2: a flat plate
    assert point.inertia.max() == 0.0 and plate.inertia[2, 2] == 3.0
    assert not point.inertia.flags.writeable


@pytest.mark.parametrize("p", [(1.0, 0.0, 0.0, 0.1), (0.0, 0.0, 0.0, 0.0), (2.0, 0.0, 0.0, 0.0)])
def test_orientation_must_be_unit_euler_parameters(p):
    with pytest.raises(ValueError, match=r"^orientation: expected unit Euler parameters .* got norm"):
        System().add_body("a", mass=1.0, inertia=(1.0, 1.0, 1.0), orientation=p)


def test_body_names_and_vectors():
    system = System()
    system.add_body("a", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=r"name: a body named 'a' already exists"):
        system.add_body("a", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=r"name: a body named 'ground' already exists"):
        system.add_body("ground", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=r"name: expected a non-empty string"):
        system.add_body("", mass=1.0, inertia=(1.0, 1.0, 1.0))
    system.add_torque(system.bodies[0], lambda state: (0.0, 0.0, 0.0), name="s")
    with pytest.raises(ValueError, match=r"name: an item named 's' already exists in this System"):
        system.add_torque(system.bodies[0], lambda state: (0.0, 0.0, 0.0), name="s")
    with pytest.raises(ValueError, match=r"position: expected shape \(3,\)"):
        system.add_body("b", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(0.0, 1.0))
    with pytest.raises(ValueError, match=r"velocity: expected finite values"):
        system.add_body("b", mass=1.0, inertia=(1.0, 1.0, 1.0), velocity=(0.0, math.inf, 0.0))
    with pytest.raises(ValueError, match=r"omega, omega_body: expected at most one"):
        system.add_body("b", mass=1.0, inertia=(1.0, 1.0, 1.0), omega=(1, 0, 0), omega_body=(1, 0, 0))
    with pytest.raises(ValueError, match=r"position: expected real numbers, got complex"):
        system.add_body("b", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(0.0, 1.0 + 0j, 0.0))
    with pytest.raises(ValueError, match=r"gravity: expected shape \(3,\)"):
        System(gravity=(0.0, -9.81))


def test_omega_and_omega_body_are_the_same_vector_in_two_frames():
    p = (math.cos(0.4), 0.0, math.sin(0.4), 0.0)  # 0.8 rad about y
    s1, s2 = System(), System()
    b1 = s1.add_body("a", mass=1.0, inertia=(1.0, 2.0, 2.5), orientation=p, omega=(1.0, 2.0, 3.0))
    b2 = s2.add_body("a", mass=1.0, inertia=(1.0, 2.0, 2.5), orientation=p,
                     omega_body=s1.state.omega_body(b1))
    np.testing.assert_allclose(s2.state.omega(b2), [1.0, 2.0, 3.0], atol=1e-15)


# ------------------------------------------------------------------ joints
def test_joint_kinds_and_row_counts(two):
    system, a, b = two
    assert set(JOINT_KINDS) == {"fixed", "spherical", "revolute", "prismatic", "cylindrical", "universal"}
    j = system.add_joint("revolute", system.ground, a, point=(0, 0, 0), axis=(2.0, 0, 0))
    np.testing.assert_allclose(j.axis, [1.0, 0.0, 0.0])  # normalized
    assert j.kind == "revolute" and j.name == "revolute1" and j.body_i is system.ground and j.body_j is a
    assert system.evaluate().C.shape == (5,)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(kind="hinge"), r"kind: expected one of"),
        (dict(axis=(0.0, 0.0, 0.0)), r"axis: expected a nonzero axis"),
        (dict(axis=None), r"axis: a revolute joint needs an axis"),
        (dict(axis=(1e-300, 0, 0)), None),  # tiny but nonzero: its direction is used
        (dict(point=(0.0, 0.0)), r"point: expected shape \(3,\)"),
        (dict(point=(0.0, math.nan, 0.0)), r"point: expected finite values"),
        (dict(kind="spherical"), r"axis: a spherical joint takes no axis"),
        (dict(kind="universal", axis_j=None), r"axis_j: a universal joint needs axis_j"),
        (dict(kind="universal", axis_j=(1.0, 1.0, 0.0)), r"axis_j: expected perpendicular to axis"),
        (dict(axis_j=(0.0, 1.0, 0.0)), r"axis_j: only universal joints take axis_j"),
    ],
)
def test_joint_arguments_are_validated(two, kwargs, message):
    system, a, b = two
    args = dict(kind="revolute", point=(0.0, 0.0, -1.0), axis=(1.0, 0.0, 0.0))
    args.update(kwargs)
    kind = args.pop("kind")
    if message is None:
        system.add_joint(kind, a, b, **args)
        return
    with pytest.raises(ValueError, match=message):
        system.add_joint(kind, a, b, **args)


def test_joint_on_an_unknown_body_or_a_body_of_another_system(two):
    system, a, b = two
    other = System()
    c = other.add_body("c", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=r"body_i: expected a Body of this System"):
        system.add_joint("spherical", "a", b, point=(0, 0, 0))
    with pytest.raises(ValueError, match=r"body_j: body 'c' belongs to another System"):
        system.add_joint("spherical", a, c, point=(0, 0, 0))
    with pytest.raises(ValueError, match=r"body_i: body 'ground' belongs to another System"):
        system.add_joint("spherical", other.ground, a, point=(0, 0, 0))
    with pytest.raises(ValueError, match=r"body_i, body_j: expected two different bodies"):
        system.add_joint("spherical", a, a, point=(0, 0, 0))
    joint = other.add_joint("revolute", other.ground, c, point=(0, 0, 0), axis=(1, 0, 0))
    with pytest.raises(ValueError, match=r"joint: joint 'revolute1' belongs to another System"):
        system.add_motor(joint, angle=lambda t: t)
    with pytest.raises(ValueError, match=r"body: body 'c' belongs to another System"):
        system.add_force(c, lambda t, s: np.zeros(3))
    with pytest.raises(ValueError, match=r"body: expected a moving body, got the ground"):
        system.add_torque(system.ground, lambda t, s: np.zeros(3))


def test_motor_arguments(two):
    system, a, b = two
    hinge = system.add_joint("revolute", system.ground, a, point=(0, 0, 0), axis=(1, 0, 0))
    ball = system.add_joint("spherical", a, b, point=(0, 0, -1))
    with pytest.raises(ValueError, match=r"angle, displacement: expected exactly one"):
        system.add_motor(hinge)
    with pytest.raises(ValueError, match=r"displacement: a revolute joint has no driven displacement"):
        system.add_motor(hinge, displacement=lambda t: t)
    with pytest.raises(ValueError, match=r"angle: a spherical joint has no driven angle"):
        system.add_motor(ball, angle=lambda t: t)
    with pytest.raises(ValueError, match=r"angle: expected a callable f\(t\) or a tuple"):
        system.add_motor(hinge, angle=0.3)
    with pytest.raises(ValueError, match=r"angle: expected a finite value"):
        system.add_motor(hinge, angle=lambda t: math.nan)
    with pytest.raises(ValueError, match=r"angle: the function raised ZeroDivisionError"):
        system.add_motor(hinge, angle=lambda t: 1.0 / t)
    motor = system.add_motor(hinge, angle=lambda t: 0.0 * t)
    assert motor.coordinate == "angle" and motor.derivatives == "complex step"
    with pytest.raises(ValueError, match=r"joint: the angle of joint 'revolute1' is already driven"):
        system.add_motor(hinge, angle=lambda t: t)


def _hinged_rod(law):
    """A rod on a revolute joint about x, hanging from the origin, driven by ``law`` (assembled at t = 0)."""
    system = System(gravity=(0.0, 0.0, -9.81))
    rod = system.add_body("rod", mass=1.0, inertia=(0.1, 0.1, 0.01), position=(0.0, 0.0, -0.5))
    hinge = system.add_joint("revolute", system.ground, rod, point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    return system, hinge, system.add_motor(hinge, angle=law, name="drive")


@pytest.mark.parametrize(
    ("law", "message"),
    [
        (lambda t: 0.5j + t, r"motor 'motor1', angle: expected a real number at t=0, got the complex number 0.5j"),
        (lambda t: np.complex128(0.1j), r"motor 'motor1', angle: expected a real number at t=0, got the complex "
                                        r"number 0.1j"),
        ((lambda t: t, lambda t: 1.0 + 1.0j, lambda t: 0.0),
         r"motor 'motor1', angle \(f_dot\): expected a real number at t=0, got the complex number \(1\+1j\)"),
    ],
)
def test_a_motor_law_with_a_complex_value_is_refused_where_it_is_added(law, message):
    """The complex step took Im f(t + 1e-30 i) / 1e-30 as the rate: a law with an imaginary part reported
    rates of 1e29 rad/s."""
    system = System()
    rod = system.add_body("rod", mass=1.0, inertia=(0.1, 0.1, 0.01), position=(0.0, 0.0, -0.5))
    hinge = system.add_joint("revolute", system.ground, rod, point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=message):
        system.add_motor(hinge, angle=law)
    assert system.add_motor(hinge, angle=lambda t: 0.0 * t).name == "motor1"  # the refused one took no name


def test_a_motor_law_that_turns_complex_is_refused_where_its_value_is_first_taken():
    import cmath

    # real (zero) at t = 0, where it is added; complex at every later time
    system, _, motor = _hinged_rod(lambda t: (1.0 + 1.0j) * t)
    with pytest.raises(ValueError, match=r"motor 'drive', angle: expected a real number at t=0.1, got the complex "
                                         r"number \(0.1\+0.1j\)"):
        motor.values(0.1)
    system.assemble()
    with pytest.raises(ValueError, match=r"motor 'drive', angle: expected a real number at t=\S+, got the complex"):
        system.simulate([0.0, 0.1])
    # real until 0.05 s, then sqrt of a negative number: complex
    _, _, motor = _hinged_rod(lambda t: cmath.sqrt(0.05 - t))
    with pytest.raises(ValueError, match=r"motor 'drive', angle: expected a real number at t=0.1, got the complex "
                                         r"number 0.2236\d*j"):
        motor.values(0.1)
    # a complex type with a zero imaginary part on the real axis is a real law (and gets complex steps):
    # f = sin, f_dot = cos (exact to round-off), f_ddot = -sin (h2^4 f^(6) / 360 = 3e-19 plus the round-off of
    # Im f(t +- h2 w) ~ h2 |f'|, over h2^2: eps |f'| / h2 = 2e-12; 9e-13 seen)
    _, _, motor = _hinged_rod(cmath.sin)
    assert motor.derivatives == "complex step"
    f, fd, fdd = motor.values(0.3)
    assert f == math.sin(0.3) and abs(fd - math.cos(0.3)) <= 1e-15 and abs(fdd + math.sin(0.3)) <= 1e-11


def test_force_elements_are_validated(two):
    system, a, b = two
    hinge = system.add_joint("revolute", system.ground, a, point=(0, 0, 0), axis=(1, 0, 0))
    ball = system.add_joint("spherical", a, b, point=(0, 0, -1))
    with pytest.raises(ValueError, match=r"stiffness: expected a finite number >= 0"):
        system.add_spring_damper(a, (0, 0, 0), b, (0, 0, -1), stiffness=-1.0)
    with pytest.raises(ValueError, match=r"damping: expected a finite number >= 0"):
        system.add_spring_damper(a, (0, 0, 0), b, (0, 0, -1), stiffness=1.0, damping=math.nan)
    with pytest.raises(ValueError, match=r"free_length: expected a finite number >= 0"):
        system.add_spring_damper(a, (0, 0, 0), b, (0, 0, -1), stiffness=1.0, free_length=-0.1)
    with pytest.raises(ValueError, match=r"joint: a rotational spring-damper needs a revolute or cylindrical"):
        system.add_rotational_spring_damper(ball, stiffness=1.0)
    with pytest.raises(ValueError, match=r"f: expected a callable"):
        system.add_force(a, np.zeros(3))
    spring = system.add_spring_damper(a, (0, 0, 0), b, (0, 0, -1.5), stiffness=2.0)
    assert spring.free_length == pytest.approx(1.5)  # default: the current distance
    system.add_rotational_spring_damper(hinge, stiffness=1.0)
    system.add_force(b, lambda t, s: np.zeros(2), name="bad")
    system.assemble()
    with pytest.raises(ValueError, match=r"force 'bad': expected a \(3,\) vector, got shape \(2,\)"):
        system.simulate([0.0, 0.1])


# ------------------------------------------------------------------ assembly
def test_assemble_moves_bodies_onto_the_joints_and_reports_it(two):
    system, a, b = two
    system.add_joint("revolute", system.ground, a, point=(0.0, 0.0, 0.0), axis=(1, 0, 0))
    system.add_joint("revolute", a, b, point=(0.0, 0.0, -1.0), axis=(1, 0, 0))
    assert system.assemble().moved == ()  # joints are added in the current configuration
    # move both bodies up by 1 cm and give them velocities the joints forbid
    system.set_state(system.state.displaced(dq=np.r_[0, 0, 0.01, 0, 0, 0.01, np.zeros(6)],
                                            dv=np.r_[0.3, 0, 0, 0, 0, 0, np.zeros(6)]))
    report = system.assemble()
    assert isinstance(report, AssemblyReport)
    assert report.residual_position <= 1e-12 and report.residual_velocity <= 1e-14
    assert report.n_constraints == 10 and report.rank == 10 and report.degrees_of_freedom == 2
    assert set(report.moved) == {"a", "b"} and report.redundant == ()
    np.testing.assert_allclose(system.state.position(a), [0.0, 0.0, -0.5], atol=1e-12)
    assert report.displacement["a"] == pytest.approx(0.01, abs=1e-12) and report.iterations >= 1
    assert report.velocity_change["a"] == pytest.approx(0.3, rel=1e-12)  # x is not a direction a hinge about x allows
    assert "moved a" in str(report)
    again = system.assemble()
    assert again.moved == () and again.iterations == 0


def test_joints_added_in_incompatible_configurations_cannot_be_assembled():
    """A 1 m rod on ball joints at x = 0 and at x = 6: the loop cannot close."""
    system = System()
    rod = system.add_body("rod", mass=1.0, inertia=(1e-3, 0.1, 0.1), position=(0.5, 0.0, 0.0))
    system.add_joint("spherical", system.ground, rod, point=(0.0, 0.0, 0.0), name="left")
    system.set_state(system.state.displaced(dq=np.r_[5.0, 0, 0, 0, 0, 0]))  # the rod now spans x = 5..6
    system.add_joint("spherical", system.ground, rod, point=(6.0, 0.0, 0.0), name="right")
    with pytest.raises(AssemblyError, match=r"assemble: .*largest residual .* in (left|right) \(spherical\): point x"):
        system.assemble()


def test_conflicting_drivers_cannot_be_assembled():
    from rigidlab.core.models import slider_crank

    model = slider_crank(phi0=0.5)
    model.system.add_motor(model.slider_joint, displacement=lambda t: 0.05, name="push")
    # least squares spreads the conflict over the loop: the message names the row left with the largest residual
    with pytest.raises(AssemblyError, match=r"assemble: Newton stalled .* cannot all hold at once .* in \w+ \((spherical|revolute|universal|prismatic|motor \w+)\)"):
        model.system.assemble()


def test_simulate_refuses_a_state_off_the_constraints(two):
    system, a, b = two
    system.add_joint("spherical", system.ground, a, point=(0.0, 0.0, 0.0))
    system.set_state(system.state.displaced(dq=np.r_[0.0, 0.0, 0.1, np.zeros(9)]))
    with pytest.raises(AssemblyError, match=r"simulate: the current state violates the constraints .* call system\.assemble"):
        system.simulate([0.0, 1.0])


@pytest.mark.parametrize("f0", [2.0, -3.0, 3.1, 0.4])
def test_assemble_turns_a_driven_joint_to_its_angle_from_any_offset(f0):
    """sin(theta - f) = 0 also at theta = f + pi: assembly works on the wrapped angle error instead."""
    system = System()
    rod = system.add_body("rod", mass=1.0, inertia=(1 / 12, 1 / 12, 1e-4), position=(0.0, 0.0, -0.5))
    hinge = system.add_joint("revolute", system.ground, rod, point=(0, 0, 0), axis=(1, 0, 0))
    system.add_motor(hinge, angle=lambda t: f0 + 0.0 * t)
    report = system.assemble()
    p = system.state.orientation(rod)
    assert 2.0 * math.atan2(p[1], p[0]) == pytest.approx(f0, abs=1e-12)
    assert report.rotation["rod"] == pytest.approx(abs(f0), abs=1e-12)


def test_simulate_refuses_a_motor_half_a_turn_off():
    system = System()
    rod = system.add_body("rod", mass=1.0, inertia=(1 / 12, 1 / 12, 1e-4), position=(0.0, 0.0, -0.5))
    hinge = system.add_joint("revolute", system.ground, rod, point=(0, 0, 0), axis=(1, 0, 0))
    system.add_motor(hinge, angle=lambda t: math.pi + 0.0 * t, name="drive")
    assert abs(system.evaluate().C[-1]) < 1e-15  # the sine form is satisfied ...
    with pytest.raises(AssemblyError, match=r"simulate: motor 'drive' holds its joint half a turn from its angle"):
        system.simulate([0.0, 0.1])  # ... but the joint is half a turn from f
    system.assemble()
    assert system.simulate([0.0, 0.1]).position(rod)[0] == pytest.approx([0.0, 0.0, 0.5], abs=1e-12)


def test_singular_constrained_mass_matrix_is_a_clear_error():
    """A point mass on a spherical joint: its rotation is free and has no inertia."""
    system = System()
    p = system.add_body("p", mass=1.0, inertia=(0.0, 0.0, 0.0), position=(0.0, 0.0, -1.0))
    system.add_joint("spherical", system.ground, p, point=(0.0, 0.0, 0.0))
    with pytest.raises(SingularSystemError, match=r"constrained mass matrix is singular.*\['p'\]"):
        system.assemble()
    with pytest.raises(SingularSystemError, match=r"singular"):
        system.simulate([0.0, 1.0])


def test_a_free_point_mass_without_joints_is_singular_too():
    system = System()
    system.add_body("p", mass=1.0, inertia=(0.0, 0.0, 0.0))
    with pytest.raises(SingularSystemError, match=r"singular"):
        system.simulate([0.0, 0.1])


# ------------------------------------------------------------------ state and trajectory
def test_state_snapshot_and_set_state(two):
    system, a, b = two
    state = system.state
    assert isinstance(state, State) and state.n_bodies == 2 and state.t == 0.0
    assert not state.q.flags.writeable
    np.testing.assert_allclose(state.position(a), [0.0, 0.0, -0.5])
    np.testing.assert_allclose(state.orientation(system.ground), [1.0, 0.0, 0.0, 0.0])
    moved = state.displaced(dq=np.r_[0.1, 0, 0, np.zeros(9)])
    np.testing.assert_allclose(moved.position(a), [0.1, 0.0, -0.5])
    system.set_state(moved)
    np.testing.assert_allclose(system.state.position(a), [0.1, 0.0, -0.5])
    other = System()
    with pytest.raises(ValueError, match=r"state: belongs to another System"):
        other.set_state(state)
    with pytest.raises(ValueError, match=r"dq: expected finite increments of shape \(12,\)"):
        state.displaced(dq=np.zeros(3))


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        (dict(t=math.nan), r"state.t: expected a finite time \(s\), got nan"),
        (dict(t=math.inf), r"state.t: expected a finite time \(s\), got inf"),
        (dict(t="0"), r"state.t: expected a finite time \(s\), got '0'"),
        (dict(q=np.zeros(0)), r"state.q: expected shape \(14,\) for 2 bodies \(\[R \(3n\) \| Euler parameters "
                              r"\(4n\)\]\), got \(0,\)"),
        (dict(q=np.zeros(0), v=np.zeros(0)), r"state.q: expected shape \(14,\) for 2 bodies"),
        (dict(v=np.zeros(5)), r"state.v: expected shape \(12,\) for 2 bodies"),
        (dict(v=np.full(12, math.nan)), r"state.v: expected finite values"),
        (dict(q=np.zeros(14) + 0j), r"state.q: expected real numbers, got complex"),
        (dict(q=np.r_[np.zeros(6), np.zeros(4), 1.0, 0.0, 0.0, 0.0]),
         r"state.q: expected Euler parameters of norm 1, got norm 0 for body 'link0' \(q\[6:10\]\)"),
    ],
)
def test_set_state_refuses_a_state_whose_fields_a_system_cannot_hold(fields, message):
    """A State is frozen, but dataclasses.replace makes any: t = nan was taken as the System's time, and an
    empty q failed in a reshape (or was taken, with v, for a state of 0 bodies)."""
    import dataclasses

    system = pendulum_chain(2)
    before = system.state
    with pytest.raises(ValueError, match=message):
        system.set_state(dataclasses.replace(before, **fields))
    assert system.state.t == before.t and np.array_equal(system.state.q, before.q)


def test_a_body_added_after_simulate_is_unknown_to_the_results():
    system = pendulum_chain(2, tilt=0.3)
    traj = system.simulate([0.0, 0.05, 0.1])
    assert isinstance(traj, MultibodyTrajectory) and traj.q.shape == (3, 14)
    state = system.state
    late = system.add_body("late", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(3.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"body: 'late' was added after this trajectory was computed"):
        traj.position(late)
    with pytest.raises(ValueError, match=r"body: 'late' was added after this state was taken"):
        state.position(late)
    with pytest.raises(ValueError, match=r"state: describes 2 bodies, this System has 3"):
        system.set_state(state)
    late_joint = system.add_joint("spherical", system.ground, late, point=(3.0, 0.0, 0.5))
    with pytest.raises(ValueError, match=r"item: 'spherical1' was added after this trajectory was computed"):
        traj.reaction(late_joint)
    # the System itself knows the new body: a new run includes it
    traj2 = system.simulate([0.0, 0.1])
    assert traj2.position(late).shape == (2, 3)


def test_trajectory_accessors_and_continuation():
    system = pendulum_chain(2, tilt=0.3)
    t = np.linspace(0.0, 1.0, 11)
    traj = system.simulate(t)
    b0 = system.bodies[0]
    for array in (traj.t, traj.q, traj.v, traj.energy, traj.residual_position, traj.residual_velocity):
        assert not array.flags.writeable
    assert traj.position(b0).shape == (11, 3) and traj.orientation(b0).shape == (11, 4)
    assert traj.velocity(b0).shape == (11, 3) and traj.omega(b0).shape == (11, 3)
    np.testing.assert_allclose(np.linalg.norm(traj.orientation(b0), axis=1), 1.0, atol=1e-15)
    F, T = traj.reaction(system.joints[0])
    assert F.shape == T.shape == (11, 3)
    with pytest.raises(ValueError, match=r"frame: expected 'global' or 'body'"):
        traj.reaction(system.joints[0], frame="local")
    with pytest.raises(ValueError, match=r"item: expected a Joint or Motor"):
        traj.reaction(b0)
    # continuing from the last state reproduces one long run
    system.set_state(traj.state(-1))
    second = system.simulate(np.linspace(1.0, 2.0, 11))
    system.set_state(traj.state(0))
    whole = system.simulate(np.linspace(0.0, 2.0, 21))
    np.testing.assert_allclose(second.q[-1], whole.q[-1], atol=1e-7)
    with pytest.raises(ValueError, match=r"index: expected -11 <= index < 11"):
        traj.state(11)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(method="Radau"), r"method: expected one of"),
        (dict(dt=0.01), r"dt: adaptive method 'DOP853' takes rtol/atol"),
        (dict(method="rk4"), r"dt: method 'rk4' needs a finite step"),
        (dict(method="rk4", dt=0.01, rtol=1e-6), r"rtol, atol: fixed-step method 'rk4' takes dt"),
        (dict(rtol=-1.0), r"rtol, atol: expected > 0"),
        (dict(stabilization="penalty"), r"stabilization: expected one of"),
        (dict(baumgarte=0.0), r"baumgarte: expected a finite rate > 0"),
        (dict(position_tol=0.0), r"position_tol: expected a finite tolerance > 0"),
        (dict(rtol=1e-8 + 0j), r"rtol: expected real numbers, got complex"),
    ],
)
def test_simulate_options_are_validated(kwargs, message):
    system = pendulum_chain(1)
    with pytest.raises(ValueError, match=message):
        system.simulate([0.0, 0.1], **kwargs)


@pytest.mark.parametrize(
    ("t", "message"),
    [([], r"t: expected a non-empty 1-D array"),
     ([0.0, 1.0, 0.5], r"t: expected non-decreasing times \(s\), got t\[2\] = 0.5 after t\[1\] = 1.0"),
     ([0.0, math.nan], r"t: expected finite times \(s\), got t\[1\] = nan"),
     ([0.0, 1.0 + 0j], r"t: expected real numbers, got complex"),
     (["0", "1"], r"t: expected non-decreasing output times \(s\), got text \['0', '1'\]"),
     ([False, True], r"t: expected non-decreasing output times \(s\), got a boolean in \[False, True\]"),
     ([0.0, True], r"t: expected non-decreasing output times \(s\), got a boolean in \[0\.0, True\]")],
)
def test_simulate_times_are_validated(t, message):
    with pytest.raises(ValueError, match=message):
        pendulum_chain(1).simulate(t)


def test_a_run_that_exceeds_max_steps_stops_with_an_error():
    system = pendulum_chain(2, tilt=1.0)
    with pytest.raises(IntegrationError, match=r"max_steps=50"):
        system.simulate([0.0, 10.0], max_steps=50)


def test_a_failed_run_carries_the_outputs_before_the_failure():
    # the same outputs as a run stopped before the failure, status "failed"
    system = pendulum_chain(2, tilt=1.0)
    t = np.linspace(0.0, 10.0, 101)
    with pytest.raises(IntegrationError, match=r"max_steps=400") as info:
        system.simulate(t, max_steps=400)
    traj = info.value.trajectory
    assert traj.status == "failed" and 2 < traj.t.size < t.size
    np.testing.assert_array_equal(traj.t, t[: traj.t.size])
    reference = system.simulate(t[: traj.t.size])
    assert reference.status == "completed"
    np.testing.assert_allclose(traj.q, reference.q, atol=1e-9)
    assert np.max(np.abs(traj.energy - traj.energy[0])) < 1e-6
    with pytest.raises(ValueError, match=r"dt: the output times with dt=1e-05 need 100000 steps"):
        system.simulate([0.0, 1.0], method="rk4", dt=1e-5, max_steps=1000)


def test_simulate_does_not_change_the_system():
    system = pendulum_chain(2, tilt=0.3)
    before = system.state
    system.simulate([0.0, 0.5])
    np.testing.assert_array_equal(system.state.q, before.q)
    np.testing.assert_array_equal(system.state.v, before.v)


def test_simulations_on_two_threads_do_not_interfere():
    from concurrent.futures import ThreadPoolExecutor

    system = pendulum_chain(3, tilt=0.4)
    t = np.linspace(0.0, 0.5, 11)
    ref = system.simulate(t)
    with ThreadPoolExecutor(2) as pool:
        runs = list(pool.map(lambda _: system.simulate(t), range(4)))
    for run in runs:
        np.testing.assert_array_equal(run.q, ref.q)
        np.testing.assert_allclose(run.multipliers, ref.multipliers, rtol=0, atol=1e-12)


# ------------------------------------------------------------------ reviewed edge cases
def _pendulum_with_fixed_joint(angle):
    s = System()
    b = s.add_body("b", mass=1.0, inertia=(1 / 12, 1 / 12, 0.01), position=(0.0, 0.0, -0.5))
    j = s.add_joint("revolute", s.ground, b, point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    s.add_joint("fixed", s.ground, b, point=(0.0, 0.0, 0.0))
    s.add_motor(j, angle=angle)
    return s


def test_assemble_refuses_drivers_that_contradict_the_joints_in_velocity():
    # a motor turning a joint that a fixed joint holds: redundant in the positions at t = 0, but 1 rad/s against
    # 0 (simulate used to refuse the assembled state and tell the user to call assemble again)
    s = _pendulum_with_fixed_joint(lambda t: t)
    y0 = np.array(s._y)
    with pytest.raises(AssemblyError, match=r"velocity constraints contradict .* motor1 \(motor angle\)"):
        s.assemble()
    np.testing.assert_array_equal(s._y, y0)  # nothing changed
    # a motor holding the same joint still: consistent, only redundant
    report = _pendulum_with_fixed_joint(lambda t: 0.0 * t).assemble()
    assert "motor1 (motor angle): angle" in report.redundant and report.residual_velocity == 0.0


def test_non_finite_or_boolean_inputs_found_by_review_are_refused():
    s = System()
    b = s.add_body("b", mass=1.0, inertia=(0.1, 0.1, 0.1), position=(0.0, 0.0, -1.0))
    with pytest.raises(ValueError, match=r"dq: expected finite increments of shape \(6,\)"):
        s.state.displaced(np.full(6, np.nan))
    with pytest.raises(ValueError, match=r"dv: expected finite increments"):
        s.state.displaced(dv=[0.0, 0.0, math.inf, 0.0, 0.0, 0.0])
    j = s.add_joint("revolute", s.ground, b, point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="angle: expected the function to return a real number, got True"):
        s.add_motor(j, angle=lambda t: True)
    s.add_force(b, lambda t, state: (True, False, False))
    s.assemble()
    with pytest.raises(ValueError, match=r"force 'force1': expected a \(3,\) vector of real numbers"):
        s.simulate([0.0, 0.1])
    with pytest.raises(ValueError, match="system: has no bodies to hold in equilibrium"):
        System().equilibrium()


def test_a_step_too_small_to_count_is_refused_without_a_warning():
    s = System()
    s.add_body("b", mass=1.0, inertia=(0.1, 0.1, 0.1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="dt: .* more than max_steps"):
            s.simulate([0.0, 1.0], method="rk4", dt=1e-300)


@pytest.mark.parametrize(
    ("t", "kwargs", "message"),
    [
        ([0.0, 1.0], dict(stabilization="baumgarte", baumgarte=1e300),
         r"baumgarte: expected a finite rate > 0 and <= core.multibody._system.MAX_BAUMGARTE = 100000 rad/s .*, "
         r"got 1e\+300"),
        ([0.0, 1.0], dict(baumgarte=2e5), r"baumgarte: expected a finite rate > 0 and <= .*, got 200000.0"),
        ([0.0, 1000.0], dict(stabilization="baumgarte", baumgarte=1e5),
         r"baumgarte: an adaptive run follows the feedback's time 1/alpha with at least one right-hand side each: "
         r"alpha=100000 rad/s over t\[-1\] - t\[0\] = 1000 s needs at least 1e\+08, more than max_steps=10000000"),
        ([0.0, 1e300], dict(stabilization="baumgarte"),
         r"baumgarte: .* alpha=20 rad/s over t\[-1\] - t\[0\] = 1e\+300 s needs at least 2e\+301"),
        ([0.0, 1e4], dict(rtol=1e-16),
         r"rtol: expected a relative tolerance >= core.integrators.MIN_RTOL = 2.22e-14 .*, got 1e-16"),
        ([0.0, 1e300], dict(method="rk4", dt=0.01), r"dt: t_span \(0, 1e\+300\) with dt=0.01 needs 1e\+302 steps"),
    ],
)
def test_runs_that_could_not_end_are_refused_before_they_start(t, kwargs, message):
    # MAX_BAUMGARTE: 1e5 rad/s took 1e6 right-hand sides (a minute) for 1 s of this chain, 1e6 diverged in 5 ms,
    # 1e300 overflowed alpha^2; an rtol of 1e-16 over 1e4 s, or a horizon of 1e300 s, ran until max_steps
    from rigidlab.core.multibody._system import MAX_BAUMGARTE

    assert MAX_BAUMGARTE == 1e5
    system = pendulum_chain(2, tilt=0.3)
    with pytest.raises(ValueError, match=message):
        system.simulate(t, **kwargs)


@pytest.mark.parametrize("method", ["DOP853", "RK45"])
def test_a_horizon_of_1e300_seconds_stops_at_the_first_pace_check(method, monkeypatch):
    """It ran until max_steps (ten million right-hand sides: about ten minutes for this chain). The interpreted
    loop checks its pace after core.integrators.PACE_CHECK_CALLS (1e4) evaluations, a compiled loop at
    LONG_RUN_CALLS (scaled down here to keep the test short either way)."""
    import rigidlab.core.integrators as integrators

    monkeypatch.setattr(integrators, "LONG_RUN_CALLS", 20_000)
    system = pendulum_chain(2, tilt=0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # (the long-run warning at LONG_RUN_CALLS)
        with pytest.raises(IntegrationError, match=r"stopped at t=\S+ before t1=1e\+300: at its pace so far "
                                                   r"\((10|20),000 right-hand-side evaluations .* more than 2 x "
                                                   r"max_steps=10000000") as info:
            system.simulate([0.0, 1e300], method=method)
    assert info.value.trajectory is not None and info.value.trajectory.status == "failed"


def test_a_run_that_would_take_most_of_an_hour_warns_early(monkeypatch):
    # a 1e10 N/m spring on a 1 kg block: DOP853 needs about 2e8 right-hand sides for 100 s, which the default
    # max_steps (1e7) would stop only after about 40 minutes; the warning comes at LONG_RUN_CALLS (scaled
    # down here, with max_steps, to keep the test short)
    import rigidlab.core.integrators as integrators

    monkeypatch.setattr(integrators, "LONG_RUN_CALLS", 2000)
    s = System()
    b = s.add_body("b", mass=1.0, inertia=(0.1, 0.1, 0.1), position=(0.0, 0.0, -1.0))
    s.add_joint("prismatic", s.ground, b, point=(0.0, 0.0, -1.0), axis=(0.0, 0.0, 1.0))
    s.add_spring_damper(s.ground, (0.0, 0.0, 0.0), b, (0.0, 0.0, -1.0), stiffness=1e10)
    s.assemble()
    with pytest.warns(RuntimeWarning, match=r"used 2,000 right-hand sides to reach t=.* of t1=100 .* needs about"):
        with pytest.raises(IntegrationError, match="max_steps=3000"):
            s.simulate(np.linspace(0.0, 100.0, 11), max_steps=3000)
