"""Meshes generated with trimesh for the scenes (no files needed).

Every mesh is in metres (scene units), expressed in its own body frame and
returned as ``(vertices (n, 3) float32, faces (m, 3) uint32)`` ready for
``scene.add_mesh_simple``. The conventions (origin, axes) of each mesh are
stated in its docstring and in ``assets/README.md``. Results are cached:
generating them once per process is enough, whatever the number of clients.
"""

from __future__ import annotations

import functools

import numpy as np
import trimesh

__all__ = ["body_parts", "ring", "pins", "pedestal", "spinning_top", "Mesh"]

Mesh = tuple[np.ndarray, np.ndarray]


def _z_to_x(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Turn a mesh built along +z so that it lies along +x.

    The cyclic relabelling (x, y, z) -> (z, x, y) of the coordinates is a
    proper rotation (a permutation with determinant +1), so faces keep their
    outward orientation.
    """
    return trimesh.Trimesh(mesh.vertices[:, [2, 0, 1]], mesh.faces, process=False)


def _pack(mesh: trimesh.Trimesh) -> Mesh:
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


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
    return {"hull": _pack(hull), "nose": _pack(nose), "fin": _pack(fin)}


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
    return _pack(mesh)


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
