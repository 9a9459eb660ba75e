"""Bad input to System.add_contact, simulate and trajectories: every error is clear, no NaN leaves the solver."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.contact import (
    CONTACT_RANK_TOL,
    ContactError,
    Ellipsoid,
    ParametricSurface,
    PlanarCurve,
    Plane,
    Sphere,
    Torus,
)
from rigidlab.core.multibody import System
from rigidlab.core.rotations import euler_parameters_from_axis_angle


def _ball_system(z=0.1, radius=0.1, vz=0.0):
    system = System(gravity=(0.0, 0.0, -9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004, 0.004, 0.004), position=(0.0, 0.0, z),
                           velocity=(0.0, 0.0, vz))
    return system, ball


def _cylinder(s):  # radius 0.1 about the body y axis, outward normal
    return np.stack([0.1 * np.cos(s[..., 1]), s[..., 0], 0.1 * np.sin(s[..., 1])], axis=-1)


def test_bodies_that_do_not_touch_or_penetrate():
    system, ball = _ball_system(z=0.15)
    with pytest.raises(ValueError, match=r"body_i, body_j: 'ground' and 'ball' do not touch: gap 5.000e-02 m > "
                                         r"tolerance 1e-06 m .*use model='compliant'"):
        system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    system, ball = _ball_system(z=0.09)
    with pytest.raises(ValueError, match=r"penetrate by 1.000e-02 m > tolerance 1e-06 m"):
        system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    # within a stated tolerance the contact is accepted and assemble closes the gap
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1), tolerance=0.02)
    assert abs(c.initial_gap + 0.01) < 1e-15
    with pytest.raises(ValueError, match=r"violates the constraints .*contact1 \(contact\): normal"):
        system.simulate([0.0, 0.1])
    system.assemble()
    assert abs(system.state.position(ball)[2] - 0.1) < 1e-14
    assert system.contacts == (c,)
    # a compliant contact may start apart, not deeply inside
    system, ball = _ball_system(z=0.02)
    with pytest.raises(ValueError, match=r"penetrate by 8.000e-02 m, more than half the length scale"):
        system.add_contact(system.ground, Plane(), ball, Sphere(0.1), model="compliant", stiffness=1e5)


@pytest.mark.parametrize("vz, way", [(2.0, "apart"), (-2.0, "into each other")])
@pytest.mark.parametrize("ground_first", [True, False])
def test_a_normal_velocity_of_a_held_contact_is_explained(vz, way, ground_first):
    """A ball launched from the floor: the constraint contact cannot start with the ball leaving, and the
    error says what assemble() would do to the launch and what keeps it."""
    system, ball = _ball_system(vz=vz)
    pair = (system.ground, Plane(), ball, Sphere(0.1))
    system.add_contact(*(pair if ground_first else pair[2:] + pair[:2]))
    with pytest.raises(ValueError, match=rf"contact1 \(contact\): normal\); call system.assemble\(t=0\) first\. "
                                         rf"The surfaces of contact 'contact1' move {way} at 2 m/s along its normal: "
                                         r"assemble\(\) removes that velocity.*model='compliant'"):
        system.simulate([0.0, 0.1])
    # the compliant contact keeps the launch: the ball rises by v^2 / (2 g) and falls back
    system, ball = _ball_system(vz=2.0)
    system.add_contact(system.ground, Plane(), ball, Sphere(0.1), model="compliant", stiffness=1e8)
    traj = system.simulate(np.linspace(0.0, 0.4, 41), rtol=1e-10, atol=1e-12)
    assert abs(float(np.max(traj.q[:, 2])) - (0.1 + 2.0**2 / (2 * 9.81))) < 1e-3  # (outputs every 10 ms)


def test_numbers_as_0d_arrays_are_numbers():
    """A 0-d array (what numpy reductions and indexing of 0-d data give) is taken as its number."""
    assert Sphere(np.array(0.1)).radius == 0.1
    system, ball = _ball_system()
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1), model="compliant", stiffness=np.array(1e6),
                           damping=np.array(0.5))
    assert c.stiffness == 1e6 and c.damping == 0.5
    with pytest.raises(ValueError, match=r"radius: expected a finite length > 0 \(m\), got array\(\[0.1\]\)"):
        Sphere(np.array([0.1]))


def test_the_same_contact_twice_is_refused():
    system, ball = _ball_system()
    plane, sphere = Plane(), Sphere(0.1)
    c = system.add_contact(system.ground, plane, ball, sphere)
    # the same objects in either order, and equal new ones (the same plane through another point)
    for args in ((system.ground, plane, ball, sphere), (ball, sphere, system.ground, plane),
                 (system.ground, Plane(point=(0.3, -0.2, 0.0)), ball, Sphere(0.1))):
        with pytest.raises(ValueError, match=r"surface_i, surface_j: these surfaces of '(ground|ball)' and "
                                             r"'(ball|ground)' already touch in contact 'contact1'"):
            system.add_contact(*args)
    assert system.contacts == (c,)
    # another surface: a plane 5 mm below, or a ball of another radius
    system.add_contact(system.ground, Plane(point=(0.0, 0.0, -0.005)), ball, sphere, model="compliant", stiffness=1e5)
    system.add_contact(system.ground, plane, ball, Sphere(0.099), model="compliant", stiffness=1e5)


def test_line_contact_is_refused_with_what_to_do():
    system, body = _ball_system(z=0.1)
    cyl = ParametricSurface(_cylinder, bounds=((-0.5, 0.5), (-math.pi, math.pi)))
    with pytest.raises(ContactError, match=r"C_s has lost rank at the contact point \(Eq. 8.109.*along a line .*"
                                           r"PlanarCurve"):
        system.add_contact(system.ground, Plane(), body, cyl)
    # a torus lying on its side touches along a circle
    system = System()
    flat = euler_parameters_from_axis_angle(np.array([1.0, 0.0, 0.0]), math.pi / 2)  # body y along global z
    wheel = system.add_body("wheel", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(0.0, 0.0, 0.05), orientation=flat)
    with pytest.raises(ContactError, match=r"lost rank"):
        system.add_contact(system.ground, Plane(), wheel, Torus(0.3, 0.05))
    assert system.contacts == ()


@pytest.mark.parametrize("si, sj, message", [
    (Plane(), Plane(), r"two planes \(parallel flat faces\)"),
    (PlanarCurve.line(), PlanarCurve.line(normal=(0, -1)), r"two lines \(parallel flat faces\)"),
    (Plane(), PlanarCurve.circle(0.1), r"a planar curve touches only another planar curve"),
    (Torus(0.2, 0.0), Torus(0.3, 0.0), r"two rims"),
    ("plane", Sphere(0.1), r"surface_i: expected a Plane, Sphere, Ellipsoid, Torus, ParametricSurface or PlanarCurve"),
])
def test_pairs_that_have_no_contact_point(si, sj, message):
    system, ball = _ball_system()
    with pytest.raises(ValueError, match=message):
        system.add_contact(system.ground, si, ball, sj)


@pytest.mark.parametrize("kwargs, message", [
    ({"model": "soft"}, r"model: expected one of \['constraint', 'compliant'\], got 'soft'"),
    ({"model": "compliant"}, r"stiffness: the compliant model needs a finite stiffness > 0"),
    ({"stiffness": -1.0}, r"stiffness: expected a finite stiffness > 0 \(N/m\^exponent\), got -1.0"),
    ({"stiffness": 0.0}, r"stiffness: expected a finite stiffness > 0"),
    ({"stiffness": float("inf")}, r"stiffness: expected a finite stiffness > 0"),
    ({"stiffness": 1e5j}, r"stiffness: expected real numbers, got complex"),
    ({"damping": -0.1}, r"damping: expected a finite number >= 0 \(s/m\), got -0.1"),
    ({"exponent": 0.5}, r"exponent: expected a finite exponent >= 1, got 0.5"),
    ({"tolerance": 0.0}, r"tolerance: expected a finite number > 0 \(m\), got 0.0"),
    ({"rolling": 1}, r"rolling: expected True or False"),
    ({"rolling": True, "model": "compliant", "stiffness": 1e5}, r"rolling: rolling without slip needs "
                                                                r"model='constraint'"),
])
def test_model_options_are_validated(kwargs, message):
    system, ball = _ball_system()
    with pytest.raises(ValueError, match=message):
        system.add_contact(system.ground, Plane(), ball, Sphere(0.1), **kwargs)
    assert system.contacts == ()
    system.add_contact(system.ground, Plane(), ball, Sphere(0.1), name="contact1")  # the name is still free


def test_bodies_are_validated():
    system, ball = _ball_system()
    other, stranger = _ball_system()
    with pytest.raises(ValueError, match=r"body_j: body 'ball' belongs to another System"):
        system.add_contact(system.ground, Plane(), stranger, Sphere(0.1))
    with pytest.raises(ValueError, match=r"body_i, body_j: expected two different bodies"):
        system.add_contact(ball, Sphere(0.1), ball, Sphere(0.1))
    with pytest.raises(ValueError, match=r"body_i: expected a Body"):
        system.add_contact("ground", Plane(), ball, Sphere(0.1))


def test_planar_curves_need_parallel_planes():
    system = System()
    tilted = euler_parameters_from_axis_angle(np.array([1.0, 0.0, 0.0]), 0.2)
    cam = system.add_body("cam", mass=1.0, inertia=(1.0, 1.0, 1.0), orientation=tilted)
    fol = system.add_body("follower", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(0.0, 0.05, 0.0))
    with pytest.raises(ValueError, match=r"planar curves lie in their bodies' x-y planes, which must be parallel"):
        system.add_contact(cam, PlanarCurve.circle(0.05), fol, PlanarCurve.line(normal=(0.0, -1.0)))


def test_degenerate_parametric_surface_is_refused():
    system, ball = _ball_system()
    flat_strip = ParametricSurface(lambda s: np.stack([s[..., 0] + s[..., 1], s[..., 0] + s[..., 1],
                                                       0.0 * s[..., 0]], axis=-1), bounds=((-1, 1), (-1, 1)))
    with pytest.raises(ContactError, match=r"surface_i: ParametricSurface\(\.\.\.\) is degenerate near s=.*its normal "
                                           r"du/ds1 x du/ds2 vanishes"):
        system.add_contact(system.ground, flat_strip, ball, Sphere(0.1))


def _lat_long_sphere(r, pole_axis):
    """A longitude-latitude sphere of radius r whose poles lie on body axis ``pole_axis`` (2: z, 1: y)."""
    def point(s):
        c = np.cos(s[..., 1])
        u = [c * np.cos(s[..., 0]), c * np.sin(s[..., 0]), np.sin(s[..., 1])]
        if pole_axis == 1:
            u = [u[0], u[2], -u[1]]
        return r * np.stack(u, axis=-1)
    return ParametricSurface(point, bounds=((-math.pi, math.pi), (-math.pi / 2, math.pi / 2)))


def test_a_contact_at_a_pole_of_a_parametrization_is_refused_as_degenerate():
    # resting on its pole, du/ds1 vanishes there: the error names the parametrization (not a line contact)
    system, ball = _ball_system()
    with pytest.raises(ContactError, match=r"surface_j: ParametricSurface\(\.\.\.\) is degenerate near "
                                           r"s=\[[-0-9.]+, -1\.570796\]: its normal du/ds1 x du/ds2 vanishes"):
        system.add_contact(system.ground, Plane(), ball, _lat_long_sphere(0.1, pole_axis=2))
    # the same sphere with its poles on the side rests on the plane with N = m g
    system, ball = _ball_system()
    c = system.add_contact(system.ground, Plane(), ball, _lat_long_sphere(0.1, pole_axis=1))
    force = system.simulate([0.0, 0.1]).contact(c).normal_force
    np.testing.assert_allclose(force, -system.gravity[2] * ball.mass, rtol=1e-12)


def test_regularity_is_scale_free_a_large_rim_and_torus_stand_on_a_plane():
    # (the check compares the tangents' cross product with their lengths, not a unit normal with R^2)
    for major, minor in ((2000.0, 0.0), (2000.0, 10.0)):
        system = System(gravity=(0.0, 0.0, -9.81))
        wheel = system.add_body("wheel", mass=1.0, inertia=(1.0, 2.0, 1.0), position=(0.0, 0.0, major + minor))
        c = system.add_contact(system.ground, Plane(), wheel, Torus(major, minor))
        np.testing.assert_allclose(system.simulate([0.0, 0.01]).contact(c).normal_force, 9.81, rtol=1e-12)


def test_a_surface_oriented_into_its_body_gets_the_hint_to_orient_it_outward():
    def inward(s):  # the side-pole sphere with its parameters swapped: du/ds1 x du/ds2 points to the centre
        c = np.cos(s[..., 0])
        return 0.1 * np.stack([c * np.cos(s[..., 1]), np.sin(s[..., 0]), -c * np.sin(s[..., 1])], axis=-1)

    surface = ParametricSurface(inward, bounds=((-math.pi / 2, math.pi / 2), (-math.pi, math.pi)))
    system, ball = _ball_system()
    with pytest.raises(ContactError, match=r"no (regular )?pair of points with opposed normals found .*the normal "
                                           r"of surface_j .* orient the parametrization outward"):
        system.add_contact(system.ground, Plane(), ball, surface)


def test_simulate_options_for_separation():
    system, ball = _ball_system()
    system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    with pytest.raises(ValueError, match=r"on_separation: expected one of \['stop', 'compliant', 'bilateral'\]"):
        system.simulate([0.0, 0.1], on_separation="ignore")
    with pytest.raises(ValueError, match=r"on_separation: 'compliant' continues contact 'contact1' with the "
                                         r"compliant model, which needs its stiffness"):
        system.simulate([0.0, 0.1], on_separation="compliant")


def test_a_contact_that_pulls_at_the_start_separates_there():
    system = System(gravity=(0.0, 0.0, 9.81))  # gravity pulls the ball off the plane
    ball = system.add_body("ball", mass=1.0, inertia=(0.004, 0.004, 0.004), position=(0.0, 0.0, 0.1))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    traj = system.simulate([0.0, 0.1, 0.2])
    assert traj.status == "separated"
    assert traj.t.tolist() == [0.0]
    assert traj.separations[0].t == 0.0 and traj.separations[0].contact is c
    # continued in the compliant model, the ball falls up, free (no constraint row is left)
    system = System(gravity=(0.0, 0.0, 9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004, 0.004, 0.004), position=(0.0, 0.0, 0.1))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1), stiffness=1e5)
    traj = system.simulate([0.0, 0.1, 0.2], on_separation="compliant")
    assert traj.status == "completed" and traj.separations[0].action == "compliant"
    np.testing.assert_allclose(traj.contact(c).gap, 0.5 * 9.81 * np.array([0.0, 0.01, 0.04]), atol=1e-12)
    assert traj.contact(c).constraint.tolist() == [True, False, False]


def test_trajectory_contact_arguments():
    system, ball = _ball_system()
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    traj = system.simulate([0.0, 0.1])
    other, b2 = _ball_system()
    c2 = other.add_contact(other.ground, Plane(), b2, Sphere(0.1))
    with pytest.raises(ValueError, match=r"contact: expected a Contact"):
        traj.contact(ball)
    with pytest.raises(ValueError, match=r"contact: 'contact1' belongs to another System"):
        traj.contact(c2)
    late = system.add_contact(system.ground, Plane(), ball, Sphere(0.099), model="compliant", stiffness=1e5,
                              name="late")
    with pytest.raises(ValueError, match=r"contact: 'late' was added after this trajectory was computed"):
        traj.contact(late)
    assert traj.contact(c).normal_force.shape == (2,)


def test_a_contact_that_becomes_a_line_contact_stops_the_run_with_its_time():
    # a thin disk without spin falls over on its rim (held by the bilateral constraint) until it lies flat
    system = System(gravity=(0.0, 0.0, -9.81))
    lean = 0.3
    p = euler_parameters_from_axis_angle(np.array([1.0, 0.0, 0.0]), lean)
    A = np.array([[1, 0, 0], [0, math.cos(lean), -math.sin(lean)], [0, math.sin(lean), math.cos(lean)]])
    disk = system.add_body("disk", mass=1.0, inertia=(0.0025, 0.005, 0.0025), position=A @ [0.0, 0.0, 0.1],
                           orientation=p)
    system.add_contact(disk, Torus(0.1, 0.0), system.ground, Plane())
    with pytest.raises(ContactError, match=r"contact 'contact1': the contact passed a configuration where C_s "
                                           r"loses rank \(Eq. 8.109\) between t=0.\d+ and t=0.\d+"):
        system.simulate(np.linspace(0.0, 3.0, 31), on_separation="bilateral")


def test_rank_tolerance_is_public():
    assert 0.0 < CONTACT_RANK_TOL < 1e-6


def _rank_at_start(surface_i, surface_j, z):
    """The rank indicator (Eq. 8.109) that add_contact tests, for surface_j on a body at height z."""
    import rigidlab.core.contact._search as search

    seen = []
    real = search.check_rank

    def spy(name, info):
        seen.append(float(info["rank"]))
        return real(name, info)

    system = System()
    body = system.add_body("b", mass=1.0, inertia=(1.0, 1.0, 1.0), position=(0.0, 0.0, z))
    search.check_rank = spy
    try:
        system.add_contact(system.ground, surface_i, body, surface_j)
    finally:
        search.check_rank = real
    return seen[0]


@pytest.mark.parametrize("scale", [1e-5, 1e-3, 1.0, 1e3])
def test_rank_indicator_does_not_depend_on_the_units(scale):
    """The same shapes in other units give the same indicator: a 0.1 mm ball is a point contact as a 10 cm
    one is (the normal rows carried an extra factor of the length scale, so the indicator went as L^2 and
    refused a sphere of 9e-5 m on a plane). Reference: the shapes at 1 m."""
    cases = [(Plane(), Sphere(scale), scale), (Sphere(2.0 * scale), Sphere(scale), 3.0 * scale),
             (Plane(), Ellipsoid(scale, 2.0 * scale, 0.5 * scale), 0.5 * scale),
             (Plane(), Torus(scale, 0.2 * scale), 1.2 * scale)]
    for (si, sj, z), (ri, rj, z1) in zip(cases, [(Plane(), Sphere(1.0), 1.0), (Sphere(2.0), Sphere(1.0), 3.0),
                                                 (Plane(), Ellipsoid(1.0, 2.0, 0.5), 0.5),
                                                 (Plane(), Torus(1.0, 0.2), 1.2)], strict=True):
        # the indicator is formed from derivatives good to ~1e-15 relative; 1e-9 leaves room for the search
        np.testing.assert_allclose(_rank_at_start(si, sj, z), _rank_at_start(ri, rj, z1), rtol=1e-9)
    # and a line contact stays refused at every scale
    system, body = _ball_system(z=0.1 * scale / 0.1)
    cyl = ParametricSurface(lambda s: scale / 0.1 * _cylinder(s), bounds=((-0.5, 0.5), (-math.pi, math.pi)))
    with pytest.raises(ContactError, match=r"C_s has lost rank"):
        system.add_contact(system.ground, Plane(), body, cyl)


@pytest.mark.parametrize("socket_radius", [0.1, 0.1 * (1.0 + 1e-6)])
def test_a_ball_in_a_socket_of_its_own_radius_gets_the_conforming_advice(socket_radius):
    """A socket's normal rightly points inward (a bowl): the conforming pair is a rank loss (the advice
    names the socket), not a surface to turn outward. A socket 1 % larger is a point contact."""

    def bowl(r):
        return lambda u: r * np.stack([np.cos(u[..., 0]) * np.cos(u[..., 1]), -np.sin(u[..., 0]),
                                       np.cos(u[..., 0]) * np.sin(u[..., 1])], -1)

    def build(r):
        system = System(gravity=(0.0, 0.0, -9.81))
        ball = system.add_body("ball", mass=1.5, inertia=(1.0, 1.0, 1.0), position=(0.0, 0.0, -(r - 0.1)))
        socket = ParametricSurface(bowl(r), bounds=((-1.4, 1.4), (-math.pi, math.pi)))
        return system, system.add_contact(system.ground, socket, ball, Sphere(0.1))

    with pytest.raises(ContactError, match=r"C_s has lost rank.*give the socket a larger radius"):
        build(socket_radius)
    system, c = build(0.101)
    np.testing.assert_allclose(system.simulate([0.0, 0.1]).contact(c).normal_force, 1.5 * 9.81, rtol=1e-12)
