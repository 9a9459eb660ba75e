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

__all__ = ["body_parts", "ring", "pins", "Mesh"]

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
