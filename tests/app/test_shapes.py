"""Shared shape helpers (app/scenes/_shapes.py), the sphere trail (app/scenes/_trail.py) and plotted-only table
columns (app/scenes/_plots.py).

Oracles: trimesh's mass properties of the mesh against core's closed forms, the
ellipsoid's implicit equation, arrow lengths from their definition, and the
sphere trail's nodes as the server holds them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from rigidlab.app.scenes._plots import Table
from rigidlab.app.scenes._shapes import arrow_segments, ellipsoid_wireframe, parts_mesh
from rigidlab.app.scenes._trail import SphereTrail
from rigidlab.core.models import FREE_BODY_NAMES, Cuboid, Prism, free_body_shape
from rigidlab.core.rotations import matrix_from_axis_angle


@pytest.mark.parametrize("name", FREE_BODY_NAMES)
def test_parts_mesh_has_core_s_mass_properties_about_its_origin(name):
    shape = free_body_shape(name)
    vertices, faces = parts_mesh(shape.parts, shape.center_of_mass)
    assert vertices.dtype == np.float32 and faces.dtype == np.uint32 and not vertices.flags.writeable
    mesh = trimesh.Trimesh(vertices.astype(float), faces, process=False)
    mesh.density = shape.density
    assert mesh.is_watertight or len(shape.parts) > 1  # parts touch: their union is closed piecewise
    np.testing.assert_allclose(mesh.center_mass, 0.0, atol=1e-6)  # float32 vertices
    np.testing.assert_allclose(mesh.moment_inertia, shape.inertia, rtol=0, atol=1e-5 * shape.inertia.max())


def test_parts_mesh_places_prisms_along_their_axes():
    for axis in range(3):
        vertices, _ = parts_mesh([Prism(0.1, 2.0, 16, center=(1.0, 0.0, 0.0), axis=axis)])
        extent = vertices.max(axis=0) - vertices.min(axis=0)
        assert extent[axis] == pytest.approx(2.0) and np.delete(extent, axis).max() <= 0.2 + 1e-6
        np.testing.assert_allclose(vertices.mean(axis=0)[0], 1.0, atol=1e-6)
    vertices, _ = parts_mesh([Cuboid((1.0, 2.0, 3.0))], origin=(0.0, 0.0, 1.0))
    np.testing.assert_allclose(vertices.min(axis=0), [-0.5, -1.0, -2.5])
    with pytest.raises(ValueError, match="parts: expected Prism or Cuboid parts"):
        parts_mesh(["a sphere"])


def test_ellipsoid_wireframe_lies_on_the_ellipsoid():
    semi = np.array([0.5, 1.0, 2.0])
    axes = matrix_from_axis_angle(np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0), 0.7)
    segments = ellipsoid_wireframe(semi, axes, scale=0.5, segments=32)
    assert segments.shape == (7 * 32, 2, 3) and segments.dtype == np.float32
    u = segments.reshape(-1, 3).astype(float) / 0.5 @ axes  # principal coordinates
    np.testing.assert_allclose(np.sum((u / semi) ** 2, axis=1), 1.0, atol=1e-5)
    np.testing.assert_array_equal(segments[1:32, 0], segments[:31, 1])  # each ring joins up
    assert not ellipsoid_wireframe(np.zeros(3)).any()
    with pytest.raises(ValueError, match=r"semi_axes, axes: expected shapes \(3,\) and \(3, 3\)"):
        ellipsoid_wireframe([1.0, 2.0])
    with pytest.raises(ValueError, match="segments, latitudes: expected >= 3 and heights in"):
        ellipsoid_wireframe(semi, latitudes=(1.0,))


def test_arrow_segments_fixed_and_saturating_lengths():
    origins = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    vectors = np.array([[[0.0, 0.0, 5.0], [3.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
                        [[0.0, 4.0, 0.0], [30.0, 0.0, 0.0], [1e-12, 0.0, 0.0]]])
    arrows = arrow_segments(origins, vectors, length=1.3, half=(0.0, 3.0, 0.0))
    assert arrows.shape == (2, 3, 2, 3) and arrows.dtype == np.float32
    np.testing.assert_array_equal(arrows[:, :, 0], np.broadcast_to(origins, (2, 3, 3)).astype(np.float32))
    lengths = np.linalg.norm(arrows[..., 1, :] - arrows[..., 0, :], axis=-1)
    np.testing.assert_allclose(lengths, [[1.3, 1.3 * 3 / 6, 0.0], [1.3, 1.3 * 30 / 33, 1.3]], rtol=1e-6)
    np.testing.assert_allclose(arrows[1, 0, 1] - arrows[1, 0, 0], [0.0, 1.3, 0.0], rtol=1e-6)  # along the vector


def test_table_plotted_columns_stay_out_of_the_csv():
    t = np.array([0.0, 0.5])
    table = Table.build(t, np.array([[1.0], [2.0]]), plotted=np.array([[10.0, 11.0], [20.0, 21.0]]))
    assert table.columns.shape == (2, 3) and table.csv == ("0,1", "0.5,2")
    np.testing.assert_array_equal(table.columns[:, 1:], [[10.0, 11.0], [20.0, 21.0]])
    assert Table.build(t, np.array([[1.0], [2.0]])).columns.shape == (2, 1)


class _Owner:
    """What SphereTrail needs of a scene: its target and ``add_lines``."""

    def __init__(self, server) -> None:
        self.target = server

    def add_lines(self, name, points, colors, *, thickness, **kwargs):
        return self.target.scene.add_line_segments(name, points, colors, thickness=thickness, **kwargs)


def test_sphere_trail_traces_on_its_sphere_and_marks_the_newest_point(server):
    trail = SphereTrail(_Owner(server), "/sphere_trail", (0, 160, 150), position=(0.0, -2.0, 0.0), radius=0.9,
                        thickness=0.02, capacity=40, min_step=0.01, marker_color=(20, 20, 20), axes_length=1.1)
    assert trail.name == "/sphere_trail" and trail.sphere.name == "/sphere_trail/sphere"
    u = np.linspace(0.0, 3.0, 60)
    points = 0.9 * np.column_stack([np.cos(u) * np.cos(0.3), np.sin(u) * np.cos(0.3), np.full(u.size, np.sin(0.3))])
    for p in points:
        assert trail.add(p)
        with server.atomic():
            trail.flush()
    drawn = trail.points
    np.testing.assert_allclose(np.linalg.norm(drawn, axis=1), 0.9, rtol=1e-6)
    np.testing.assert_allclose(drawn[-1], points[-1], rtol=1e-6)
    np.testing.assert_allclose(trail.marker.position, points[-1], rtol=1e-6)
    np.testing.assert_allclose(trail.frame.position, (0.0, -2.0, 0.0))
    trail.clear()
    assert trail.points.shape == (0, 3)


def test_closed_path_segments_follow_the_marked_stretches_across_the_start():
    from rigidlab.app.scenes._shapes import closed_path_segments

    n = 12
    points = np.column_stack([np.cos(np.arange(n)), np.sin(np.arange(n)), np.zeros(n)])
    assert closed_path_segments(points, np.zeros(n, bool)) is None
    marked = np.zeros(n, bool)
    marked[[10, 11, 0, 1]] = True  # a stretch across the path's first point
    segments = closed_path_segments(points, marked)
    assert segments.shape == (n, 2, 3) and segments.dtype == np.float32
    pairs = {(int(np.argmin(np.linalg.norm(points - a, axis=1))), int(np.argmin(np.linalg.norm(points - b, axis=1))))
             for a, b in segments}
    assert pairs == {(10, 11), (11, 0), (0, 1)}  # (the rest repeats the first)
    lone = np.zeros(n, bool)
    lone[5] = True
    np.testing.assert_array_equal(closed_path_segments(points, lone)[0], points[[5, 6]].astype(np.float32))
