"""Meshes and wireframes of simple shapes, for ``add_mesh_simple`` and ``add_lines``.

Geometry only: the caller gives sizes and placement from core (the parts of
:func:`rigidlab.core.models.free_body_shape`, an energy ellipsoid's
:class:`rigidlab.core.rigid_body.MomentumGeometry`). Metres; float32 vertices.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import trimesh

from rigidlab.core.models import Cuboid, Prism

__all__ = ["arrow_segments", "closed_path_segments", "ellipsoid_wireframe", "parts_mesh"]

#: Rotation (angle, axis) that turns a mesh's z axis onto body axis 0, 1, 2.
_Z_ONTO = {0: (math.pi / 2, (0.0, 1.0, 0.0)), 1: (-math.pi / 2, (1.0, 0.0, 0.0)), 2: (0.0, (0.0, 0.0, 1.0))}


def parts_mesh(parts: Sequence[Prism | Cuboid], origin: Any = (0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """One mesh of core's parts (:class:`rigidlab.core.models.Prism`, :class:`rigidlab.core.models.Cuboid`) with ``origin`` (3,)
    of their frame at the mesh's origin (e.g. the centre of mass): vertices (n, 3) float32, faces (m, 3) uint32
    (read-only).

    A prism is drawn as the polygon it is (``sections`` sides), so the mesh's mass properties are core's.
    """
    meshes = []
    for part in parts:
        if isinstance(part, Cuboid):
            mesh = trimesh.creation.box(extents=part.extents)
        elif isinstance(part, Prism):
            mesh = trimesh.creation.cylinder(radius=part.radius, height=part.height, sections=part.sections)
            mesh.apply_transform(trimesh.transformations.rotation_matrix(*_Z_ONTO[part.axis]))
        else:
            raise ValueError(f"parts: expected Prism or Cuboid parts, got {part!r}")
        mesh.apply_translation(np.asarray(part.center, dtype=float) - np.asarray(origin, dtype=float))
        meshes.append(mesh)
    mesh = trimesh.util.concatenate(meshes)
    out = np.ascontiguousarray(mesh.vertices, dtype=np.float32), np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    for a in out:
        a.setflags(write=False)
    return out


def ellipsoid_wireframe(semi_axes: Any, axes: Any = None, *, scale: float = 1.0, segments: int = 64,
                        latitudes: Sequence[float] = (-0.8, -0.45, 0.45, 0.8)) -> np.ndarray:
    """Segments (k, 2, 3) float32 of an ellipsoid: its three principal ellipses and rings of latitude.

    Parameters
    ----------
    semi_axes : (3,) semi-axis lengths along the columns of ``axes``.
    axes : (3, 3) orthonormal axes as columns (None: the coordinate axes).
    scale : factor applied to every point (e.g. to fit a picture).
    segments : segments per ellipse or ring.
    latitudes : heights of the rings along the third axis, as fractions of its semi-axis (each in (-1, 1)).

    Returns
    -------
    ``(3 + len(latitudes)) * segments`` segments, each ``(start, end)``.
    """
    semi = np.asarray(semi_axes, dtype=float)
    basis = np.eye(3) if axes is None else np.asarray(axes, dtype=float)
    if semi.shape != (3,) or basis.shape != (3, 3):
        raise ValueError(f"semi_axes, axes: expected shapes (3,) and (3, 3), got {semi.shape}, {basis.shape}")
    if segments < 3 or any(not -1.0 < z < 1.0 for z in latitudes):
        raise ValueError(f"segments, latitudes: expected >= 3 and heights in (-1, 1), got {segments}, {latitudes}")
    s = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    c, n = np.cos(s), np.sin(s)
    rings = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        u = np.zeros((s.size, 3))
        u[:, i], u[:, j] = c, n
        rings.append(u)
    for z in latitudes:
        r = math.sqrt(1.0 - z * z)
        rings.append(np.stack([r * c, r * n, np.full(s.size, z)], axis=1))
    points = [(u * semi) @ basis.T * scale for u in rings]
    return np.concatenate([np.stack([p[:-1], p[1:]], axis=1) for p in points]).astype(np.float32)


def arrow_segments(origins: Any, vectors: Any, *, length: float, half: Any = 0.0) -> np.ndarray:
    """Arrows (..., k, 2, 3) float32 from ``origins`` (k, 3) along ``vectors`` (..., k, 3), for ``add_arrows``.

    Arrow i is ``length |v| / (|v| + half_i)`` long: ``half`` (k,) or a scalar, in the vectors' units; 0 gives
    every nonzero vector the full ``length`` (a direction), ``half > 0`` a length that grows with ``|v|`` and
    saturates (``length / 2`` at ``|v| = half``). A zero vector gives an arrow of zero length.
    """
    o = np.asarray(origins, dtype=float)
    v = np.asarray(vectors, dtype=float)
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    scale = np.divide(length, norm + np.asarray(half, dtype=float)[..., None], out=np.zeros_like(norm),
                      where=norm > 0)
    o = np.broadcast_to(o, v.shape)
    return np.stack([o, o + v * scale], axis=-2).astype(np.float32)


def closed_path_segments(points: Any, marked: Any) -> np.ndarray | None:
    """Segments (n, 2, 3) float32 of the closed path through ``points`` (n, 3) along its ``marked`` (n,) stretches
    (an arc of a contour), for a line-segment node of constant size: the segments from a marked point to a
    marked next one (a lone marked point: its segment to the next), then the first of them repeated up to n
    (drawn over it). None when no point is marked.
    """
    mark = np.asarray(marked, dtype=bool)
    if not np.any(mark):
        return None
    p = np.asarray(points, dtype=np.float32)
    segments = np.stack([p, np.roll(p, -1, axis=0)], axis=1)
    both = mark & np.roll(mark, -1)
    used = segments[both] if np.any(both) else segments[mark]
    out = np.repeat(used[:1], p.shape[0], axis=0)
    out[: used.shape[0]] = used
    return out
