"""Meshes generated with trimesh for the scenes (no files needed).

Every mesh is in metres (scene units), expressed in its own body frame and
returned as ``(vertices (n, 3) float32, faces (m, 3) uint32)`` ready for
``scene.add_mesh_simple``. The conventions (origin, axes) of each mesh are
stated in its docstring and in ``assets/README.md``. Results are cached:
generating them once per process is enough, whatever the number of clients.
"""

from __future__ import annotations

import functools
import math

from typing import Any

import numpy as np
import trimesh

__all__ = ["bicycle_meshes", "body_parts", "box", "cylinder_z", "extrude", "follower_stand", "helix_tube", "pack",
           "pedestal", "pins", "ring", "spinning_top", "spoked_wheel", "translating_follower", "triangulate", "tube",
           "Mesh"]

Mesh = tuple[np.ndarray, np.ndarray]


def _z_to_x(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Turn a mesh built along +z so that it lies along +x.

    The cyclic relabelling (x, y, z) -> (z, x, y) of the coordinates is a
    proper rotation (a permutation with determinant +1), so faces keep their
    outward orientation.
    """
    return trimesh.Trimesh(mesh.vertices[:, [2, 0, 1]], mesh.faces, process=False)


def pack(mesh: trimesh.Trimesh) -> Mesh:
    """``(vertices (n, 3) float32, faces (m, 3) uint32)`` of ``mesh``, read-only, for ``add_mesh_simple``."""
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


_pack = pack


@functools.lru_cache(maxsize=None)
def body_parts(length: float = 1.0) -> dict[str, Mesh]:
    """A small asymmetric "brick with a nose and a fin", to read orientation.

    Origin at the centre of the hull; body axes: +x through the nose, +z
    through the fin, +y completing a right-handed frame. Sizes scale with
    ``length`` (the hull's extent along x).

    Returns
    -------
    dict
        ``{"hull": mesh, "nose": mesh, "fin": mesh}``.
    """
    s = float(length)
    hull = trimesh.creation.box(extents=(1.0 * s, 0.56 * s, 0.24 * s))
    nose = trimesh.creation.cone(radius=0.17 * s, height=0.3 * s, sections=32)
    # cone along +z from z=0 to its height: turn it to +x, onto the front face
    nose = _z_to_x(nose)
    nose.apply_translation((0.5 * s, 0.0, 0.0))
    fin = trimesh.creation.box(extents=(0.3 * s, 0.05 * s, 0.22 * s))
    fin.apply_translation((-0.3 * s, 0.0, 0.12 * s + 0.11 * s))
    return {"hull": pack(hull), "nose": pack(nose), "fin": pack(fin)}


@functools.lru_cache(maxsize=None)
def ring(radius: float, tube: float) -> Mesh:
    """A torus (gimbal ring) of centre-line ``radius`` and tube radius ``tube``.

    Origin at the ring's centre; the ring lies in its local x-y plane
    (normal +z).
    """
    mesh = trimesh.creation.torus(
        major_radius=float(radius), minor_radius=float(tube),
        major_sections=96, minor_sections=16,
    )
    return pack(mesh)


@functools.lru_cache(maxsize=None)
def pins(inner: float, outer: float, radius: float) -> Mesh:
    """Two axle pins on the local x axis, from ``inner`` to ``outer`` on both sides.

    Origin at the centre between them; they join a ring of radius ``inner``
    to its carrier of radius ``outer`` (the rotation axis of the ring).
    """
    parts = []
    length = float(outer - inner)
    for sign in (1.0, -1.0):
        pin = trimesh.creation.cylinder(radius=float(radius), height=length, sections=20)
        pin = _z_to_x(pin)
        pin.apply_translation((sign * (inner + outer) / 2.0, 0.0, 0.0))
        parts.append(pin)
    return _pack(trimesh.util.concatenate(parts))


@functools.lru_cache(maxsize=None)
def spinning_top(pivot_depth: float, *, disc_radius: float = 0.32, tip: float = 0.6) -> dict[str, Mesh]:
    """A top: a disc, an axle from its fixed point to a knob, and a block on the disc's rim (shows the spin).

    Origin at the disc's centre (the centre of mass); the rotor axis is +z; the axle runs from the fixed
    point at ``z = -pivot_depth`` to the knob at ``z = tip`` (m).

    Returns
    -------
    dict
        ``{"body": mesh, "marker": mesh}``.
    """
    disc = trimesh.creation.cylinder(radius=float(disc_radius), height=0.07, sections=48)
    axle = trimesh.creation.cylinder(radius=0.025, segment=((0.0, 0.0, -float(pivot_depth)), (0.0, 0.0, float(tip))),
                                     sections=16)
    knob = trimesh.creation.icosphere(subdivisions=2, radius=0.045).apply_translation((0.0, 0.0, float(tip)))
    marker = trimesh.creation.box(extents=(0.12, 0.07, 0.08)).apply_translation((float(disc_radius) - 0.06, 0.0, 0.0))
    return {"body": _pack(trimesh.util.concatenate([disc, axle, knob])), "marker": _pack(marker)}


@functools.lru_cache(maxsize=None)
def pedestal(height: float, *, radius: float = 0.25, post: float = 0.035) -> Mesh:
    """A round foot of ``radius`` on the ground with a post up to a pivot (m).

    Origin at the pivot, ``height`` above the ground (the foot at ``z = -height``), the post along z ending
    0.05 m below the pivot.
    """
    h = float(height)
    column = trimesh.creation.cylinder(radius=float(post), segment=((0.0, 0.0, -h), (0.0, 0.0, -0.05)), sections=16)
    foot = trimesh.creation.cylinder(radius=float(radius), height=0.05, sections=32).apply_translation(
        (0.0, 0.0, 0.025 - h))
    return _pack(trimesh.util.concatenate([column, foot]))


def _cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the cross product of plane vectors (..., 2)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def triangulate(points: np.ndarray) -> np.ndarray:
    """Triangles (n - 2, 3) of a simple counter-clockwise polygon ``points`` (n, 2), by ear clipping.

    Raises
    ------
    ValueError
        For a polygon without an ear (not simple).
    """
    idx = list(range(points.shape[0]))
    triangles = []
    while len(idx) > 3:
        m = len(idx)
        poly = points[idx]
        prev, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
        convex = _cross2(poly - prev, nxt - poly) > 0
        for k in np.flatnonzero(convex):
            a, b, c = poly[k - 1], poly[k], poly[(k + 1) % m]
            others = np.delete(np.arange(m), [(k - 1) % m, k, (k + 1) % m])
            p = poly[others][~convex[others]]  # only reflex vertices can lie inside an ear
            if p.size:
                d1 = _cross2(b - a, p - a)
                d2 = _cross2(c - b, p - b)
                d3 = _cross2(a - c, p - c)
                if np.any((d1 >= 0) & (d2 >= 0) & (d3 >= 0)):
                    continue
            triangles.append((idx[(k - 1) % m], idx[k], idx[(k + 1) % m]))
            del idx[k]
            break
        else:
            raise ValueError("points: expected a simple polygon, got one without an ear")
    triangles.append(tuple(idx))
    return np.array(triangles, dtype=np.int64)


def extrude(contour: np.ndarray, z0: float, z1: float) -> trimesh.Trimesh:
    """The prism over the closed plane curve ``contour`` (n, 2) from z0 to z1, outward faces.

    The caps are fans from the origin where the contour is star-shaped about it
    (a cam about its shaft), else ear-clipped (:func:`triangulate`); either way the
    mesh has ``4 n + 2`` vertices and ``4 n`` faces (padded with an unused vertex
    and degenerate faces), so a new contour of ``n`` points replaces the buffers in place.
    """
    ccw = contour if _signed_area(contour) > 0 else contour[::-1]
    n = ccw.shape[0]
    i = np.arange(n)
    j = (i + 1) % n
    side_v = np.concatenate([np.column_stack([ccw, np.full(n, z0)]), np.column_stack([ccw, np.full(n, z1)])])
    side_f = np.concatenate([np.column_stack([i, j, n + j]), np.column_stack([i, n + j, n + i])])
    top_v = np.vstack([np.column_stack([ccw, np.full(n, z1)]), [0.0, 0.0, z1]])
    angle = np.unwrap(np.arctan2(ccw[:, 1], ccw[:, 0]))
    if np.all(np.diff(angle) > 0) and angle[-1] - angle[0] < 2 * np.pi:
        top_f = np.column_stack([np.full(n, n), i, j])
    else:
        top_f = np.vstack([triangulate(ccw), np.full((2, 3), n)])
    bottom_v = top_v.copy()
    bottom_v[:, 2] = z0
    offset = side_v.shape[0]
    vertices = np.concatenate([side_v, top_v, bottom_v])
    faces = np.concatenate([side_f, top_f + offset, top_f[:, ::-1] + offset + top_v.shape[0]])
    return trimesh.Trimesh(vertices, faces, process=False)


def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    """The axis-aligned box from corner ``lo`` to corner ``hi`` (m)."""
    lo_a, hi_a = np.array(lo, dtype=float), np.array(hi, dtype=float)
    return trimesh.creation.box(extents=hi_a - lo_a,
                                transform=trimesh.transformations.translation_matrix((lo_a + hi_a) / 2))


def cylinder_z(radius: float, z0: float, z1: float, sections: int = 32) -> trimesh.Trimesh:
    """A cylinder of ``radius`` on the z axis from ``z0`` to ``z1`` (m)."""
    return trimesh.creation.cylinder(radius=radius, segment=np.array([[0.0, 0.0, z0], [0.0, 0.0, z1]]),
                                     sections=sections)


def helix_tube(length: float, wire_radius: float, *, radius: float, turns: int, points_per_turn: int = 36,
               sides: int = 6) -> Mesh:
    """A coil spring: a wire of ``wire_radius`` along a helix of ``radius`` and ``turns`` about +z, from z = 0
    up to ``length`` (m); ``sides`` vertices around the wire, float32 vertices and uint32 faces.

    Drawn with a scale along z of (current length) / ``length``, a spring follows its ends with one position
    and one scale per frame; built at the middle of its travel, the wire's section stays near round.
    """
    n = turns * points_per_turn + 1
    u = np.linspace(0.0, 1.0, n)
    x, y = radius * np.cos(2.0 * np.pi * turns * u), radius * np.sin(2.0 * np.pi * turns * u)
    centre = np.column_stack([x, y, length * u])
    tangent = np.gradient(centre, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    radial = np.column_stack([x, y, np.zeros(n)]) / radius
    normal = np.cross(tangent, radial)
    phi = np.arange(sides) * (2.0 * np.pi / sides)
    ring_ = np.cos(phi)[None, :, None] * radial[:, None, :] + np.sin(phi)[None, :, None] * normal[:, None, :]
    vertices = (centre[:, None, :] + wire_radius * ring_).reshape(-1, 3).astype(np.float32)
    i = np.arange(n - 1)[:, None] * sides
    j = np.arange(sides)[None, :]
    a, b, c, d = i + j, i + (j + 1) % sides, i + sides + j, i + sides + (j + 1) % sides
    faces = np.concatenate([np.stack([a, c, b], axis=-1).reshape(-1, 3), np.stack([b, c, d], axis=-1).reshape(-1, 3)])
    return vertices, faces.astype(np.uint32)

def translating_follower(*, travel: float, face_halfwidth: float = 0.0, roller_radius: float = 0.0,
                         depth: float = 0.014, stem_radius: float = 0.004, collar_radius: float = 0.015,
                         collar: float = 0.003) -> tuple[Mesh, Mesh | None, float]:
    """A follower that slides along +z (a cam's, a guided plunger's) in its own frame: origin at the centre of its
    flat face (``roller_radius`` 0: a plate ``2 face_halfwidth`` wide along x, ``depth`` along y, on z = 0) or at
    the centre of its roller (a fork holding a roller of ``roller_radius`` on an axle along y); a stem from
    there 0.03 m up to a spring collar (``collar_radius``, ``collar`` thick), then ``travel`` further.

    Returns
    -------
    ``(follower, roller or None, seat)``: the meshes (roller about the origin) and the height of the collar's
    top, where a spring sits (m).
    """
    if roller_radius > 0.0:
        r = roller_radius
        parts = [trimesh.creation.cylinder(radius=r, height=0.010, sections=64),
                 trimesh.creation.cylinder(radius=min(0.0025, 0.5 * r), height=0.016, sections=16)]
        roller = trimesh.util.concatenate(parts)
        roller.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1.0, 0.0, 0.0)))
        foot = r + 0.004
        lower = [box((-0.004, y0, -0.002), (0.004, y1, foot)) for y0, y1 in ((-0.0075, -0.0055), (0.0055, 0.0075))]
        lower.append(box((-0.006, -0.0075, foot - 0.003), (0.006, 0.0075, foot)))
    else:
        roller, foot = None, 0.004
        lower = [box((-face_halfwidth, -depth / 2, 0.0), (face_halfwidth, depth / 2, foot))]
    seat = foot + 0.03 + collar
    follower = trimesh.util.concatenate(lower + [cylinder_z(stem_radius, foot, seat + travel),
                                                 cylinder_z(collar_radius, seat - collar, seat, 40)])
    return pack(follower), None if roller is None else pack(roller), seat


def follower_stand(top: float, *, base: float = -0.085, column: float = -0.095, arm: float = 0.008) -> Mesh:
    """The stand of a shaft on the y axis and a follower guided along +z above it (global frame, m): a base
    plate at z = ``base``, a bearing pedestal and hub for the shaft, a column at x = ``column`` and an arm from
    z = ``top`` (the guide's underside, where a spring ends) to ``top + arm`` across the follower's axis."""
    hub = trimesh.creation.cylinder(radius=0.013, segment=np.array([[0.0, 0.009, 0.0], [0.0, 0.03, 0.0]]), sections=40)
    return pack(trimesh.util.concatenate([
        box((-0.12, -0.04, base - 0.008), (0.09, 0.045, base)), box((-0.012, 0.012, base), (0.012, 0.03, 0.0)), hub,
        box((column - 0.007, 0.015, base), (column + 0.007, 0.03, top + arm)),
        box((column - 0.007, -0.012, top), (0.02, 0.03, top + arm))]))


def tube(a: object, b: object, radius: float, *, sections: int = 12) -> trimesh.Trimesh:
    """A cylinder of ``radius`` from point ``a`` to point ``b`` (a trimesh, in the frame of the points;
    concatenate several with ``trimesh.util.concatenate`` and pack them for ``add_mesh_simple``)."""
    return trimesh.creation.cylinder(radius=float(radius), segment=np.array([a, b], dtype=float), sections=sections)


def spoked_wheel(radius: float, *, tire: float = 0.018, spokes: int = 8,
                 spoke_radius: float = 0.004) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """``(wheel, marked spoke)`` of a wheel of outer ``radius`` (m) about its body origin, axle along +y:
    a tire (torus of tube radius ``tire``), a hub and ``spokes - 1`` thin spokes, and apart (for another
    colour, so that the wheel's turn shows) a thicker spoke along +x."""
    turn = trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0])
    rim = trimesh.creation.torus(radius - tire, tire, major_sections=64, minor_sections=10)
    rim.apply_transform(turn)
    parts = [rim, trimesh.creation.cylinder(radius=0.03, height=0.1, sections=16, transform=turn)]
    for k in range(1, spokes):
        a = 2 * math.pi * k / spokes
        parts.append(tube((0, 0, 0), (radius * math.cos(a), 0, radius * math.sin(a)), spoke_radius))
    return trimesh.util.concatenate(parts), tube((0, 0, 0), (radius - tire, 0, 0), 3 * spoke_radius)


@functools.lru_cache(maxsize=4)  # one set per process, shared by every session: read them, never modify them
def bicycle_meshes(p: Any) -> dict[str, trimesh.Trimesh]:
    """Meshes of a :func:`rigidlab.core.models.whipple_bicycle` of parameters ``p`` (``WhippleParameters``), each in
    its body's frame (origin at the body's centre of mass, axes global in the upright reference
    configuration: x forward, z up): ``"rear_wheel"``, ``"front_wheel"`` (with ``"rear_mark"``,
    ``"front_mark"``: one marked spoke each), ``"frame"``, ``"rider"`` (on the frame) and ``"fork"``. The
    frame's tubes, the rider and the handlebar are drawn at fixed places (m) for the benchmark's size."""
    steer_point = lambda h: np.array([p.wheelbase + p.trail - h * math.tan(p.steer_axis_tilt), 0.0, h])  # noqa: E731
    com_frame = np.array([p.frame_position[0], 0.0, -p.frame_position[1]])
    com_fork = np.array([p.fork_position[0], 0.0, -p.fork_position[1]])
    hub_r, hub_f = np.array([0.0, 0.0, p.rear_radius]), np.array([p.wheelbase, 0.0, p.front_radius])
    bb, seat, bar, head_lo, head_hi = (0.42, 0.0, 0.28), (0.3, 0.0, 0.88), *map(steer_point, (0.98, 0.62, 0.86))
    bb, seat = np.array(bb), np.array(seat)
    frame = [tube(hub_r, bb, 0.014), tube(bb, seat, 0.02), tube(seat, head_hi, 0.018), tube(bb, head_lo, 0.022),
             tube(hub_r, seat, 0.012), tube(head_lo, head_hi, 0.026)]
    rider = [tube(seat + (0, 0, 0.05), (0.5, 0.0, 1.42), 0.13),
             trimesh.creation.icosphere(subdivisions=2, radius=0.11).apply_translation((0.56, 0.0, 1.6))]
    fork = [tube(head_lo - (0, 0, 0.02), bar, 0.016), tube(bar + (0, -0.28, 0), bar + (0, 0.28, 0), 0.014)]
    for side in (-0.05, 0.05):
        frame.append(tube(hub_r + (0, side, 0), bb + (0, side * 0.5, 0), 0.008))
        fork.append(tube(head_lo + (0, side * 0.9, 0), hub_f + (0, side * 0.9, 0), 0.01))
        knee = np.array([0.58, side * 2.2, 0.62])
        rider += [tube(seat + (0, side * 2.2, 0.02), knee, 0.06), tube(knee, bb + (0.05, side * 3.3, 0.0), 0.045),
                  tube((0.48, side * 3.5, 1.36), bar + (0.0, side * 4.8, 0.0), 0.035)]
    (rear, rear_mark), (front, front_mark) = spoked_wheel(p.rear_radius), spoked_wheel(p.front_radius)
    cat = trimesh.util.concatenate
    return {"rear_wheel": rear, "rear_mark": rear_mark, "front_wheel": front, "front_mark": front_mark,
            "frame": cat(frame).apply_translation(-com_frame), "rider": cat(rider).apply_translation(-com_frame),
            "fork": cat(fork).apply_translation(-com_fork)}
