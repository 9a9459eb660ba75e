"""Tests of core.models' free body (core/models/_free_body.py): bodies, initial states, polhode, ghost windows.

Oracles: trimesh's mass properties of the same polygonal meshes (an independent
volume integration), the principal-axis frame, rotation matrices, the crossings of
L with the intermediate axis in the exact motion (a flip every half period), a tight
DOP853 run against the window's exact samples, and the invariants' definitions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from rigidlab.core.integrators import IntegrationError
from rigidlab.core.models import (
    FREE_BODY_NAMES,
    GHOST_COLUMNS,
    INVARIANT_ROUND_OFF,
    NEAR_SEPARATRIX_ANGLE,
    WINDOW_COLUMNS,
    Cuboid,
    Prism,
    euler_parameters_momentum_up,
    free_body_shape,
    free_body_start,
    free_body_window,
    polhode_class,
    spin_about_principal_axis,
)
from rigidlab.core.rigid_body import free_body_solution, principal_axes, rotation_angle_between
from rigidlab.core.rotations import matrix_from_euler_parameters

RNG_SEED = 28


def _trimesh_of(part):
    if isinstance(part, Cuboid):
        mesh = trimesh.creation.box(extents=part.extents)
    else:
        mesh = trimesh.creation.cylinder(radius=part.radius, height=part.height, sections=part.sections)
        turn = {0: (math.pi / 2, [0, 1, 0]), 1: (-math.pi / 2, [1, 0, 0]), 2: (0.0, [0, 0, 1])}[part.axis]
        mesh.apply_transform(trimesh.transformations.rotation_matrix(*turn))
    mesh.apply_translation(part.center)
    return mesh


@pytest.mark.parametrize("name", FREE_BODY_NAMES)
def test_mass_properties_equal_trimesh_of_the_same_polygonal_meshes(name):
    shape = free_body_shape(name)
    mesh = trimesh.util.concatenate([_trimesh_of(part) for part in shape.parts])
    mesh.density = 1000.0
    assert shape.mass == pytest.approx(mesh.mass, rel=1e-12)
    np.testing.assert_allclose(shape.center_of_mass, mesh.center_mass, atol=1e-13)
    np.testing.assert_allclose(shape.inertia, mesh.moment_inertia, rtol=0, atol=1e-13 * np.abs(shape.inertia).max())
    assert not shape.inertia.flags.writeable


@pytest.mark.parametrize("sections", [3, 4, 7, 32])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_prism_is_the_polygon_it_is_drawn_as(sections, axis):
    prism = Prism(0.3, 0.8, sections, center=(0.1, -0.2, 0.05), axis=axis)
    mesh = _trimesh_of(prism)
    mesh.density = 700.0
    mass, inertia = prism.mass_properties(700.0)
    assert mass == pytest.approx(mesh.mass, rel=1e-12)
    np.testing.assert_allclose(inertia, mesh.moment_inertia, atol=1e-13 * inertia.max())
    # many sides: the cylinder's m r^2 / 2 and m (3 r^2 + h^2) / 12
    m, I = Prism(0.3, 0.8, 4096).mass_properties(1.0)
    assert m == pytest.approx(math.pi * 0.09 * 0.8, rel=1e-6)
    np.testing.assert_allclose(np.diag(I), [m * (3 * 0.09 + 0.64) / 12] * 2 + [m * 0.09 / 2], rtol=1e-6)


def test_the_t_handle_has_three_moments_and_the_disc_two_equal():
    moments, Q = principal_axes(free_body_shape("T-handle").inertia)
    assert moments[0] < moments[1] < moments[2]
    assert abs(Q[0, 1]) == pytest.approx(1.0)  # the intermediate axis is body x
    disc, _ = principal_axes(free_body_shape(FREE_BODY_NAMES[2]).inertia)
    assert disc[0] == pytest.approx(disc[1], rel=1e-12)


def test_shape_errors_name_the_argument():
    with pytest.raises(ValueError, match=r"name: expected one of \['T-handle'"):
        free_body_shape("Teapot")
    for bad in (0.0, -1.0):
        with pytest.raises(ValueError, match="density: expected a positive finite number, got"):
            free_body_shape("T-handle", density=bad)
    for bad in (math.inf, math.nan):
        with pytest.raises(ValueError, match="density: expected a finite real number, got"):
            free_body_shape("T-handle", density=bad)


def test_spin_about_principal_axis():
    J = free_body_shape("T-handle").inertia
    moments, Q = principal_axes(J)
    for k, axis in enumerate(("minor", "intermediate", "major")):
        w = spin_about_principal_axis(J, axis, rate=6.0, offset=0.02)
        w_principal = Q.T @ w
        assert w_principal[k] == pytest.approx(6.0, rel=1e-14)
        np.testing.assert_allclose(np.delete(w_principal, k), 0.12, rtol=1e-13)
    with pytest.raises(ValueError, match=r"axis: expected one of \['minor', 'intermediate', 'major'\], got 'x'"):
        spin_about_principal_axis(J, "x", rate=1.0)
    with pytest.raises(ValueError, match="rate: expected a finite real number, got inf"):
        spin_about_principal_axis(J, "major", rate=math.inf)
    with pytest.raises(ValueError, match="offset: expected a finite real number, got nan"):
        spin_about_principal_axis(J, "major", rate=1.0, offset=math.nan)


def test_momentum_up_turns_L_onto_z():
    rng = np.random.default_rng(RNG_SEED)
    J = free_body_shape("Brick 1 x 0.6 x 0.3").inertia
    for w in rng.normal(size=(50, 3)) * 5:
        p = euler_parameters_momentum_up(J, w)
        L = matrix_from_euler_parameters(p) @ (J @ w)
        np.testing.assert_allclose(L, [0.0, 0.0, np.linalg.norm(J @ w)], atol=1e-13 * np.linalg.norm(J @ w))
    np.testing.assert_array_equal(euler_parameters_momentum_up(np.eye(3), np.zeros(3)), [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(euler_parameters_momentum_up(np.eye(3), [0, 0, 2.0]), [1.0, 0.0, 0.0, 0.0])
    p = euler_parameters_momentum_up(np.eye(3), [0.0, 0.0, -2.0])
    np.testing.assert_allclose(matrix_from_euler_parameters(p) @ [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], atol=1e-15)
    start = free_body_start(J, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(start.L_global[:2], 0.0, atol=1e-13)
    assert start.body == "" and free_body_start(free_body_shape("T-handle"), [1.0, 2.0, 3.0]).body == "T-handle"
    assert start.state0.shape == (7,) and start.polhode.kind == start.solution.kind == "asymmetric"


def test_polhode_of_the_presets_and_the_flip_interval():
    J = free_body_shape("T-handle").inertia
    moments, Q = principal_axes(J)
    for axis, circles in (("major", "major"), ("minor", "minor")):
        c = free_body_start(J, spin_about_principal_axis(J, axis, rate=6.0, offset=0.02)).polhode
        assert c.circles == circles and not c.flips and c.closest_angle > math.radians(80)
        assert c.description.endswith(f"the polhode circles the {circles} axis")
    w = spin_about_principal_axis(J, "intermediate", rate=6.0, offset=0.02)
    start = free_body_start(J, w)
    c = start.polhode
    assert c.flips and c.circles == "major" and 0 < c.below < 1e-2 and c.closest_angle < NEAR_SEPARATRIX_ANGLE
    # the closest approach: the smallest angle between L_body and the intermediate axis in the motion
    t = np.linspace(0.0, start.solution.period, 200_001)
    L_body = start.solution.at(t).omega_body @ J
    cosines = np.abs(L_body @ Q[:, 1]) / np.linalg.norm(L_body, axis=1)
    assert math.acos(cosines.max()) == pytest.approx(c.closest_angle, rel=1e-4)
    # L along the intermediate axis changes sign every flip interval
    t = np.linspace(0.0, 4 * start.solution.period, 400_001)
    along = start.solution.at(t).omega_body @ J @ Q[:, 1]
    crossings = t[1:][np.sign(along[1:]) != np.sign(along[:-1])]
    np.testing.assert_allclose(np.diff(crossings), c.flip_interval, rtol=1e-4)
    assert "the Dzhanibekov effect" in c.description and "Just below 1" in c.description


def test_polhode_of_the_symmetric_steady_and_resting_bodies():
    disc = free_body_shape(FREE_BODY_NAMES[2]).inertia
    c = polhode_class(free_body_solution(disc, [1.0, 0.5, 3.0], [1.0, 0.0, 0.0, 0.0]))
    assert c.kind == "symmetric" and not c.flips and "no intermediate axis and no flip" in c.description
    c = polhode_class(free_body_solution([1.0, 2.0, 3.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0, 0.0]))
    assert c.kind == "steady" and "a point" in c.description
    c = polhode_class(free_body_solution([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]))
    assert c.kind == "rest" and math.isnan(c.ratio) and c.description == "At rest: no polhode"
    # 2 E J2 = |L|^2 exactly: the separatrix (J = 1, 2, 3; w = (a, 0, c) with a^2 = 3 c^2)
    c = polhode_class(free_body_solution([1.0, 2.0, 3.0], [math.sqrt(3.0), 0.1, 1.0], [1.0, 0.0, 0.0, 0.0]))
    assert c.ratio == pytest.approx(1.0, abs=1e-2)


def test_window_of_the_exact_motion_alone():
    J = free_body_shape("T-handle").inertia
    start = free_body_start(J, [6.0, 0.12, 0.12])
    w = free_body_window(start.solution, 2.0, 3.0, sample_dt=1 / 240)
    assert w.t.shape == (241,) and w.ghost is None and w.t[0] == 2.0 and w.t[-1] == 3.0
    exact = start.solution.at(w.t)
    np.testing.assert_array_equal(w.p, exact.p)
    np.testing.assert_allclose(w.omega, np.einsum("nij,nj->ni", matrix_from_euler_parameters(w.p), w.omega_body),
                               atol=1e-13)
    np.testing.assert_allclose(w.L_body, w.omega_body @ J, rtol=1e-14)
    np.testing.assert_allclose(w.energy, start.geometry.energy, rtol=1e-13)
    np.testing.assert_allclose(w.L_norm, start.geometry.L_norm, rtol=1e-13)
    columns = w.columns(every=4)
    assert columns.shape == (61, len(WINDOW_COLUMNS)) and WINDOW_COLUMNS[4] == "omega_x (rad/s)"
    np.testing.assert_array_equal(columns[:, :4], w.p[::4])
    assert not w.p.flags.writeable


def test_a_ghost_window_continues_and_compares_with_the_exact_motion():
    J = free_body_shape("T-handle").inertia
    start = free_body_start(J, [6.0, 0.12, 0.12])
    first = free_body_window(start.solution, 0.0, 1.0, sample_dt=1 / 60, method="DOP853", state0=start.state0,
                             rtol=1e-12)
    second = free_body_window(start.solution, 1.0, 2.0, sample_dt=1 / 60, method="DOP853",
                              state0=first.ghost.final_state, rtol=1e-12)
    g = second.ghost
    assert second.t.shape == (61,) and g.states.shape == (61, 7)
    np.testing.assert_array_equal(g.states[0], first.ghost.final_state)
    assert g.angle_error.max() < 1e-8 and g.energy_drift.max() < 1e-9
    np.testing.assert_allclose(g.angle_error, rotation_angle_between(second.p, g.states[:, :4]), rtol=0, atol=0)
    np.testing.assert_allclose(g.omega_error, np.linalg.norm(g.states[:, 4:] - second.omega_body, axis=1), atol=0)
    np.testing.assert_allclose(g.p_norm_error, np.abs(np.linalg.norm(g.states[:, :4], axis=1) - 1.0), atol=0)
    assert second.columns().shape == (61, len(WINDOW_COLUMNS) + len(GHOST_COLUMNS))
    # the splitting keeps |L| and |p| to round-off: its drifts start at or below INVARIANT_ROUND_OFF (a few
    # roundings) and walk randomly from there (sqrt(n) eps after n steps: ~1e-15 after 100)
    s = free_body_window(start.solution, 0.0, 1.0, sample_dt=1 / 60, method="splitting", state0=start.state0, dt=0.01)
    assert s.t.shape == (61,) and s.ghost.L_drift[:3].max() <= INVARIANT_ROUND_OFF
    assert s.ghost.L_drift.max() < 1e-14 and s.ghost.p_norm_error.max() < 1e-14
    assert 1e-8 < s.ghost.angle_error.max() < 1e-2
    # a coarse fixed step samples every step
    coarse = free_body_window(start.solution, 0.0, 1.0, sample_dt=1 / 60, method="rk4", state0=start.state0, dt=0.1)
    np.testing.assert_allclose(np.diff(coarse.t), 0.1, rtol=1e-12)


def test_window_errors():
    sol = free_body_start([1.0, 2.0, 3.0], [1.0, 0.1, 0.1]).solution
    y0 = np.r_[1.0, 0.0, 0.0, 0.0, 1.0, 0.1, 0.1]
    with pytest.raises(ValueError, match="t0, t1: expected finite times with t1 > t0"):
        free_body_window(sol, 1.0, 1.0, sample_dt=0.1)
    with pytest.raises(ValueError, match="sample_dt: expected a positive finite step"):
        free_body_window(sol, 0.0, 1.0, sample_dt=0.0)
    with pytest.raises(ValueError, match="state0: expected the run's initial state"):
        free_body_window(sol, 0.0, 1.0, sample_dt=0.1, method="rk4", dt=0.01)
    with pytest.raises(ValueError, match="dt: expected a positive finite step"):
        free_body_window(sol, 0.0, 1.0, sample_dt=0.1, method="rk4", state0=y0, dt=0.0)
    with pytest.raises(ValueError, match=r"method: expected one of \["):
        free_body_window(sol, 0.0, 1.0, sample_dt=0.1, method="euler", state0=y0, dt=0.01)
    fast = free_body_start([1.0, 2.0, 3.0], [10.0, 10.0, 10.0])
    with pytest.raises(IntegrationError, match="did not converge"):
        free_body_window(fast.solution, 0.0, 1.0, sample_dt=1 / 60, method="midpoint", state0=fast.state0, dt=0.2)
