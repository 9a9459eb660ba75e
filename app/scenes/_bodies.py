"""Drawing the bodies of a :class:`rigidlab.core.multibody.System`: rods, balls, boxes and springs, batched.

A scene that shows a System describes each body by simple parts fixed in the
body's frame (:class:`Parts`): rods (cylinders between two body points),
balls (a joint, a point mass) and boxes, plus the springs between body
points. :meth:`Parts.place` turns body poses ``(R, p)`` at many instants into
the instance poses of every part at once (a pure function of arrays, run
where the poses are computed, e.g. on the app's executor), and
:class:`PartsView` draws them with one batched mesh per kind of part and one
line-segment buffer for the springs, created once; a frame then sends a few
arrays (:func:`rigidlab.app.nodes.set_arrays`).

The rods of :mod:`rigidlab.app.scenes.linkages` follow the same rule: a unit cylinder
along its z axis, scaled to ``(r, r, L)`` and turned with its body.

Conventions: metres, global frame, Euler parameters scalar first (viser's
``wxyz``); the ground is body index -1, its parts are given in the global
frame.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import trimesh

from rigidlab.app.meshes import helix_tube
from rigidlab.app.nodes import set_array, set_arrays, set_pose, wxyz_z_to
from rigidlab.app.scenes._arrows import vertex_rgb
from rigidlab.app.scenes.base import PRESENTER_LINE_SCALE
from rigidlab.core.rotations import euler_parameters_from_axis_angle, quaternion_product, rotate_vector

__all__ = ["CoilSpring", "ForceArrow", "Parts", "Placed", "PartsView", "add_body_meshes", "add_disk", "body_point", "disk_meshes",
           "ring_mesh", "rod_mesh", "saturating_arrows", "spring_polyline"]

#: Coils of a spring drawn as a zigzag (segments = 2 coils + 2 straight ends).
SPRING_COILS = 8


def rod_mesh(a: Any, b: Any, radius: float, *, sections: int = 20) -> trimesh.Trimesh:
    """A cylinder of ``radius`` (m) from point ``a`` to point ``b`` (3,) (an axle, a pin, a spoke)."""
    return trimesh.creation.cylinder(radius=radius, segment=np.array([a, b], dtype=float), sections=sections)


def ring_mesh(radius: float, tube: float, *, sections: tuple[int, int] = (72, 12)) -> trimesh.Trimesh:
    """A ring (torus) of ``radius`` and ``tube`` radius (m) in the x-z plane, its axis along y (a gimbal, a tyre)."""
    ring = trimesh.creation.torus(radius, tube, major_sections=sections[0], minor_sections=sections[1])
    return ring.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))


def _ro(a: Any, dtype: Any = float) -> np.ndarray:
    out = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


def _z_to(direction: np.ndarray) -> np.ndarray:
    """Euler parameters (4,) of the rotation that takes +z to ``direction`` (3,), any length > 0."""
    d = direction / np.linalg.norm(direction)
    axis = np.cross((0.0, 0.0, 1.0), d)
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0]) if d[2] > 0 else np.array([0.0, 1.0, 0.0, 0.0])
    return np.asarray(euler_parameters_from_axis_angle(axis / s, math.atan2(s, float(d[2]))), dtype=float)


def body_point(R: np.ndarray, P: np.ndarray, body: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Global points (..., k, 3) of body points ``u`` (k, 3) on bodies ``body`` (k,) (-1: ground, ``u`` global).

    ``R`` (..., n, 3) centres of mass and ``P`` (..., n, 4) Euler parameters of the bodies.
    """
    body = np.asarray(body, dtype=np.intp)
    u = np.asarray(u, dtype=float)
    lead = R.shape[:-2]
    out = np.broadcast_to(u, lead + u.shape).copy()
    moving = body >= 0
    if np.any(moving):
        idx = body[moving]
        out[..., moving, :] = R[..., idx, :] + rotate_vector(P[..., idx, :], u[moving])
    return out


def spring_polyline(a: np.ndarray, b: np.ndarray, *, width: float, coils: int = SPRING_COILS) -> np.ndarray:
    """Segments (..., 2 coils + 2, 2, 3) of a zigzag spring from ``a`` to ``b`` (..., 3).

    Straight ends of a tenth of the length, ``2 coils`` zigzag segments of
    half-width ``width`` between them, in a plane through the spring's axis
    and the global z axis (or x for a vertical spring). A spring of zero
    length is drawn as segments of zero length.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    axis = b - a
    length = np.linalg.norm(axis, axis=-1, keepdims=True)
    unit = np.divide(axis, length, out=np.zeros_like(axis), where=length > 0)
    up = np.where(np.abs(unit[..., 2:3]) > 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    side = up - np.sum(up * unit, axis=-1, keepdims=True) * unit
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    m = 2 * coils
    fractions = np.concatenate([[0.0], 0.1 + 0.8 * np.arange(m + 1) / m, [1.0]])
    offsets = np.zeros(fractions.size)
    offsets[2:-2:2] = width
    offsets[3:-2:2] = -width
    offsets = offsets * np.minimum(1.0, length / (4.0 * width + 1e-300))  # flat when compressed to nothing
    pts = a[..., None, :] + fractions[:, None] * axis[..., None, :] + offsets[..., :, None] * side[..., None, :]
    return np.stack([pts[..., :-1, :], pts[..., 1:, :]], axis=-2)


def add_body_meshes(scene: Any, name: str, meshes: Sequence[tuple[Any, Any]], *, opacity: float | None = None,
                    **frame_kwargs: Any) -> Any:
    """A frame at ``name`` holding one rigid body drawn as meshes: ``(mesh, rgb)`` each, a mesh being a
    ``trimesh.Trimesh`` or ``(vertices, faces)`` in the body frame (m); ``opacity`` < 1 draws a translucent copy
    (a ghost). Returns the frame: its pose moves the body (``frame_kwargs``: its pose, visibility at creation)."""
    frame = scene.add_frame(name, show_axes=False, **frame_kwargs)
    for k, (mesh, color) in enumerate(meshes):
        vertices, faces = (mesh.vertices, mesh.faces) if isinstance(mesh, trimesh.Trimesh) else mesh
        scene.add_mesh_simple(f"{name}/mesh{k}", np.asarray(vertices, dtype=np.float32),
                              np.asarray(faces, dtype=np.uint32), color=color, opacity=opacity)
    return frame


def saturating_arrows(starts: Any, vectors: Any, *, half: float, longest: float) -> np.ndarray:
    """Arrows (n, 2, 3) float32 from ``starts`` (n, 3) along ``vectors`` (n, 3) (a force, a torque), of
    length ``longest |v| / (|v| + half)`` (m): a vector of size ``half`` gets half the longest arrow, and
    no arrow is longer than ``longest``, however large the vector (zero for a zero vector)."""
    starts = np.asarray(starts, dtype=float)
    vectors = np.asarray(vectors, dtype=float)
    norms = np.sqrt(np.einsum("ij,ij->i", vectors, vectors))
    out = np.empty((starts.shape[0], 2, 3), dtype=np.float32)
    out[:, 0] = starts
    out[:, 1] = starts + vectors * (longest / (norms + half))[:, None]
    return out


@dataclasses.dataclass(frozen=True)
class Placed:
    """Instance poses of :class:`Parts` at ``m`` instants (float32, read-only).

    Attributes
    ----------
    rod_positions : (m, k_r, 3) rod centres (m)
    rod_wxyzs : (m, k_r, 4) rod orientations (the unit rod's z along the rod)
    ball_positions : (m, k_b, 3) ball centres (m)
    box_positions : (m, k_x, 3) box centres (m)
    box_wxyzs : (m, k_x, 4) box orientations (the body's)
    springs : (m, s, 2 SPRING_COILS + 2, 2, 3) spring segments (m)
    """

    rod_positions: np.ndarray  # (m, k_r, 3)
    rod_wxyzs: np.ndarray  # (m, k_r, 4)
    ball_positions: np.ndarray  # (m, k_b, 3)
    box_positions: np.ndarray  # (m, k_x, 3)
    box_wxyzs: np.ndarray  # (m, k_x, 4)
    springs: np.ndarray  # (m, s, segments, 2, 3)

    @property
    def n_times(self) -> int:
        return int(self.rod_positions.shape[0])


@dataclasses.dataclass(frozen=True)
class Parts:
    """Parts drawn for the bodies of a System, each fixed in its body's frame (read-only arrays).

    Attributes
    ----------
    rod_body : (k_r,) body index of each rod
    rod_ends : (k_r, 2, 3) the rod's two end points in its body's frame (m)
    rod_radius : (k_r,) m
    ball_body : (k_b,) body index of each ball (-1: fixed to the ground)
    ball_center : (k_b, 3) centre in the body's frame (global for the ground), m
    ball_radius : (k_b,) m
    box_body : (k_x,) body index of each box (centred on the body's centre of mass)
    box_size : (k_x, 3) edge lengths along the body axes (m)
    spring_bodies : (s, 2) body indices of a spring's two ends (-1: ground)
    spring_points : (s, 2, 3) the end points in those bodies' frames (m)
    spring_width : float
        Half-width of a spring's zigzag (m).
    """

    rod_body: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros(0), np.intp))
    rod_ends: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros((0, 2, 3))))
    rod_radius: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros(0)))
    ball_body: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros(0), np.intp))
    ball_center: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros((0, 3))))
    ball_radius: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros(0)))
    box_body: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros(0), np.intp))
    box_size: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros((0, 3))))
    spring_bodies: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros((0, 2)), np.intp))
    spring_points: np.ndarray = dataclasses.field(default_factory=lambda: _ro(np.zeros((0, 2, 3))))
    spring_width: float = 0.03

    @classmethod
    def build(
        cls,
        *,
        rods: Sequence[tuple[int, Any, Any, float]] = (),
        balls: Sequence[tuple[int, Any, float]] = (),
        boxes: Sequence[tuple[int, Any]] = (),
        springs: Sequence[tuple[int, Any, int, Any]] = (),
        spring_width: float = 0.03,
    ) -> Parts:
        """Parts from lists: rods ``(body, start, end, radius)``, balls ``(body, centre, radius)``,
        boxes ``(body, size)``, springs ``(body_i, point_i, body_j, point_j)`` (body frames, m)."""
        return cls(
            rod_body=_ro([r[0] for r in rods], np.intp),
            rod_ends=_ro(np.array([[r[1], r[2]] for r in rods], dtype=float).reshape(-1, 2, 3)),
            rod_radius=_ro([r[3] for r in rods]),
            ball_body=_ro([b[0] for b in balls], np.intp),
            ball_center=_ro(np.array([b[1] for b in balls], dtype=float).reshape(-1, 3)),
            ball_radius=_ro([b[2] for b in balls]),
            box_body=_ro([b[0] for b in boxes], np.intp),
            box_size=_ro(np.array([b[1] for b in boxes], dtype=float).reshape(-1, 3)),
            spring_bodies=_ro(np.array([[s[0], s[2]] for s in springs], dtype=np.intp).reshape(-1, 2)),
            spring_points=_ro(np.array([[s[1], s[3]] for s in springs], dtype=float).reshape(-1, 2, 3)),
            spring_width=float(spring_width),
        )

    @property
    def counts(self) -> tuple[int, int, int, int]:
        """(rods, balls, boxes, springs)."""
        return (self.rod_body.size, self.ball_body.size, self.box_body.size, self.spring_bodies.shape[0])

    def rod_scales(self) -> np.ndarray:
        """(k_r, 3) scales ``(r, r, L)`` of the unit rod."""
        lengths = np.linalg.norm(self.rod_ends[:, 1] - self.rod_ends[:, 0], axis=-1)
        return np.stack([self.rod_radius, self.rod_radius, lengths], axis=-1)

    def place(self, R: Any, P: Any) -> Placed:
        """Instance poses of every part for bodies at ``R`` (m, n, 3) (m) and ``P`` (m, n, 4) (Euler parameters).

        ``m`` instants of ``n`` bodies; the result is float32 (what viser stores).
        """
        R = np.asarray(R, dtype=float)
        P = np.asarray(P, dtype=float)
        if R.ndim != 3 or R.shape[-1] != 3 or P.shape != R.shape[:-1] + (4,):
            raise ValueError(f"R, P: expected shapes (m, n, 3) and (m, n, 4), got {R.shape} and {P.shape}")
        m = R.shape[0]
        centres = self.rod_ends.mean(axis=1)
        rod_positions = body_point(R, P, self.rod_body, centres)
        if self.rod_body.size:
            turn = np.array([_z_to(e[1] - e[0]) for e in self.rod_ends])
            rod_wxyzs = quaternion_product(P[:, self.rod_body, :], turn)
        else:
            rod_wxyzs = np.zeros((m, 0, 4))
        ball_positions = body_point(R, P, self.ball_body, self.ball_center)
        box_positions = R[:, self.box_body, :] if self.box_body.size else np.zeros((m, 0, 3))
        box_wxyzs = P[:, self.box_body, :] if self.box_body.size else np.zeros((m, 0, 4))
        if self.spring_bodies.size:
            a = body_point(R, P, self.spring_bodies[:, 0], self.spring_points[:, 0])
            b = body_point(R, P, self.spring_bodies[:, 1], self.spring_points[:, 1])
            springs = spring_polyline(a, b, width=self.spring_width)
        else:
            springs = np.zeros((m, 0, 2 * SPRING_COILS + 2, 2, 3))
        return Placed(*(_ro(x, np.float32) for x in (rod_positions, rod_wxyzs, ball_positions, box_positions,
                                                      box_wxyzs, springs)))


class PartsView:
    """The viser nodes that draw :class:`Parts`: batched rods, balls and boxes and one spring buffer.

    Created once with room for ``capacity`` instances of each kind; parts
    not in use are drawn at scale zero. :meth:`show` sets the scales of a
    new set of parts (when the model changes), :meth:`move` the poses of
    one instant (every frame). Everything goes under the frame ``name``.

    Parameters
    ----------
    scene : viser.SceneApi
    name : str
        Node path of the parts (a frame is created there).
    capacity : (rods, balls, boxes, springs)
    rod_colors : (capacity_rods, 3) or (3,) uint8
    ball_color, box_color, spring_color : (3,) uint8
    opacity : float or None
        A translucent copy (a ghost) with opacity < 1.
    """

    def __init__(self, scene: Any, name: str, *, capacity: tuple[int, int, int, int], rod_colors: Any,
                 ball_color: Any, box_color: Any, spring_color: Any, opacity: float | None = None,
                 spring_thickness: float = 2.5) -> None:
        self.capacity = tuple(int(c) for c in capacity)
        k_r, k_b, k_x, k_s = self.capacity
        self.frame = scene.add_frame(name, show_axes=False)
        identity = np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (max(k_r, k_b, k_x), 1))
        rod = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=20)
        ball = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
        common = dict(lod="off", opacity=opacity, cast_shadow=opacity is None)
        self.rods = scene.add_batched_meshes_simple(
            f"{name}/rods", rod.vertices.astype(np.float32), rod.faces.astype(np.uint32),
            batched_wxyzs=identity[:k_r], batched_positions=np.zeros((k_r, 3), dtype=np.float32),
            batched_scales=np.zeros((k_r, 3), dtype=np.float32),
            batched_colors=np.broadcast_to(np.asarray(rod_colors, dtype=np.uint8), (k_r, 3)).copy(), **common,
        )
        self.balls = scene.add_batched_meshes_simple(
            f"{name}/balls", ball.vertices.astype(np.float32), ball.faces.astype(np.uint32),
            batched_wxyzs=identity[:k_b], batched_positions=np.zeros((k_b, 3), dtype=np.float32),
            batched_scales=np.zeros(k_b, dtype=np.float32), batched_colors=np.asarray(ball_color, dtype=np.uint8),
            **common,
        )
        self.boxes = scene.add_batched_meshes_simple(
            f"{name}/boxes", box.vertices.astype(np.float32), box.faces.astype(np.uint32),
            batched_wxyzs=identity[:k_x], batched_positions=np.zeros((k_x, 3), dtype=np.float32),
            batched_scales=np.zeros((k_x, 3), dtype=np.float32),
            batched_colors=np.asarray(box_color, dtype=np.uint8), **common,
        )
        segments = 2 * SPRING_COILS + 2
        self.springs = scene.add_line_segments(
            f"{name}/springs", np.zeros((k_s * segments, 2, 3), dtype=np.float32),
            np.asarray(spring_color, dtype=np.uint8), thickness=spring_thickness, thickness_units="screen",
        )
        self._rod_positions = np.zeros((k_r, 3), dtype=np.float32)
        self._rod_wxyzs = identity[:k_r].copy()
        self._ball_positions = np.zeros((k_b, 3), dtype=np.float32)
        self._box_positions = np.zeros((k_x, 3), dtype=np.float32)
        self._box_wxyzs = identity[:k_x].copy()
        self._springs = np.zeros((k_s * segments, 2, 3), dtype=np.float32)
        self.counts = (0, 0, 0, 0)

    def show(self, parts: Parts) -> None:
        """Use ``parts`` (scales of the instances; the others at scale zero).

        Raises
        ------
        ValueError
            If ``parts`` has more instances of a kind than the view's capacity.
        """
        counts = parts.counts
        for what, n, cap in zip(("rods", "balls", "boxes", "springs"), counts, self.capacity, strict=True):
            if n > cap:
                raise ValueError(f"parts: expected at most {cap} {what}, got {n}")
        k_r, k_b, k_x, _ = self.capacity
        rod_scales = np.zeros((k_r, 3), dtype=np.float32)
        rod_scales[: counts[0]] = parts.rod_scales()
        ball_scales = np.zeros(k_b, dtype=np.float32)
        ball_scales[: counts[1]] = parts.ball_radius
        box_scales = np.zeros((k_x, 3), dtype=np.float32)
        box_scales[: counts[2]] = parts.box_size
        set_array(self.rods, "batched_scales", rod_scales)
        set_array(self.balls, "batched_scales", ball_scales)
        set_array(self.boxes, "batched_scales", box_scales)
        if self._springs.any():  # the springs of the parts shown before go
            self._springs[:] = 0.0
            set_array(self.springs, "points", self._springs)
        self.counts = counts

    def move(self, placed: Placed, i: int) -> None:
        """Poses of instant ``i`` of ``placed`` (float32 arrays: a few copies and messages)."""
        n_r, n_b, n_x, n_s = self.counts
        if n_r:
            self._rod_positions[:n_r] = placed.rod_positions[i]
            self._rod_wxyzs[:n_r] = placed.rod_wxyzs[i]
            set_arrays(self.rods, batched_positions=self._rod_positions, batched_wxyzs=self._rod_wxyzs)
        if n_b:
            self._ball_positions[:n_b] = placed.ball_positions[i]
            set_arrays(self.balls, batched_positions=self._ball_positions)
        if n_x:
            self._box_positions[:n_x] = placed.box_positions[i]
            self._box_wxyzs[:n_x] = placed.box_wxyzs[i]
            set_arrays(self.boxes, batched_positions=self._box_positions, batched_wxyzs=self._box_wxyzs)
        if n_s:
            segments = placed.springs.shape[2]
            self._springs[: n_s * segments] = placed.springs[i].reshape(-1, 2, 3)
            set_array(self.springs, "points", self._springs)


def disk_meshes(*, thickness: float = 0.06, sections: int = 72) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """A unit disk (radius 1, ``thickness`` thick, its axis along body y, centred) and a marker stripe across
    both faces from the centre to the rim along body +x, which shows the spin from either side (a coin, a
    wheel); scale both by the radius."""
    disk = trimesh.creation.cylinder(radius=1.0, height=thickness, sections=sections)
    disk.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1.0, 0.0, 0.0]))
    stripe = trimesh.creation.box(extents=(0.92, 1.25 * thickness, 0.16))
    stripe.apply_translation([0.5, 0.0, 0.0])
    return disk, stripe


def add_disk(scene: Any, name: str, *, color: Any, marker_color: Any, radius: float, opacity: float = 1.0,
             position: Any = (0.0, 0.0, 0.0)) -> tuple[Any, Any, Any]:
    """A frame ``name`` holding :func:`disk_meshes` (``{name}/mesh``, ``{name}/marker``) of ``radius`` (m):
    ``(frame, mesh, marker)``; the meshes' ``scale`` is the radius."""
    disk, stripe = disk_meshes()
    frame = scene.add_frame(name, show_axes=False, position=tuple(position))
    mesh = scene.add_mesh_simple(f"{name}/mesh", disk.vertices, disk.faces, color=color, opacity=opacity, scale=radius)
    marker = scene.add_mesh_simple(f"{name}/marker", stripe.vertices, stripe.faces, color=marker_color, scale=radius)
    return frame, mesh, marker


class ForceArrow:
    """A force drawn at a point: an arrow along +z of its own frame (``{name}``, posed by the caller's
    parent frame at the point), turned by that frame's orientation every frame and of length
    ``scale |F| / (|F| + reference)`` (saturating: a large force stays in view), whose points are sent only
    when the length changed by more than ``resend`` of itself (a pose reaches the page with the other poses
    of its frame; new points a page frame later).

    Parameters
    ----------
    scene : app.scenes.base.Scene
        Its radii grow in presenter view (:meth:`~rigidlab.app.scenes.base.Scene.add_arrows`).
    name, color :
        Path of the frame (the arrow is ``{name}/arrow``) and RGB colour (sRGB, as drawn: :func:`~rigidlab.app.scenes._arrows.vertex_rgb`).
    sizes : dict
        ``shaft_radius``, ``head_radius``, ``head_length`` (m) at scale 1 (:meth:`resize`).
    tip_at_point : bool, keyword-only
        True: the arrow ends at the point (a push drawn from outside the body it acts on, e.g. a contact force);
        False: it starts there.
    """

    def __init__(self, scene: Any, name: str, color: Any, *, sizes: dict[str, float], resend: float = 0.02,
                 tip_at_point: bool = False) -> None:
        self.scene, self.sizes, self.resend, self.length = scene, dict(sizes), float(resend), 0.0
        self.tip_at_point, self.color = bool(tip_at_point), tuple(np.asarray(color).reshape(-1, 3)[0].tolist())
        self.frame = scene.target.scene.add_frame(name, show_axes=False)
        self.arrow = scene.add_arrows(f"{name}/arrow", np.zeros((1, 2, 3), np.float32), vertex_rgb(color), **sizes)

    def resize(self, scale: float) -> None:
        """Shaft and head ``scale`` times their sizes at scale 1 (a body of another size)."""
        self.scene.resize_arrows(self.arrow, **{k: scale * v for k, v in self.sizes.items()})

    def show(self, force: Sequence[float] | None, *, scale: float = 1.0, reference: float = 1.0,
             color: Sequence[int] | None = None) -> None:
        """Draw ``force`` (3,) (None: hide the arrow), in RGB ``color`` when given (sent when it changes); call
        inside ``target.atomic()``."""
        if self.frame.visible != (force is not None):
            self.frame.visible = force is not None
        if force is None:
            return
        fx, fy, fz = (float(x) for x in force)
        magnitude = math.sqrt(fx * fx + fy * fy + fz * fz)
        length = scale * magnitude / (magnitude + reference)
        set_pose(self.frame, wxyz=wxyz_z_to((fx, fy, fz), magnitude))
        if abs(length - self.length) > self.resend * self.length or (length == 0.0) != (self.length == 0.0):
            self.length = length
            start = -length if self.tip_at_point else 0.0
            set_array(self.arrow, "points", (((0.0, 0.0, start), (0.0, 0.0, start + length)),))
        if color is not None and tuple(color) != self.color:
            self.color = tuple(color)
            set_array(self.arrow, "colors", vertex_rgb([color]))


class CoilSpring:
    """A coil spring along +z between two heights: one helix mesh (:func:`rigidlab.app.meshes.helix_tube`) built at
    ``length`` and moved and stretched along z every frame (one position and one scale, :meth:`span`); its
    wire ``PRESENTER_LINE_SCALE`` times thicker in presenter view (the scene calls :meth:`set_presenter` with
    its readouts).

    Parameters
    ----------
    scene : app.scenes.base.Scene
    name, color : path of the batched mesh; RGB (a mesh's colour: sRGB as drawn).
    radius, turns, wire : the helix's radius (m), its turns, the wire's radius (m) at scale 1.
    length : the length (m) the mesh is built at: the middle of the spring's travel keeps the wire near round.
    """

    def __init__(self, scene: Any, name: str, *, radius: float, turns: int, wire: float, color: Any,
                 length: float) -> None:
        self.scene, self.radius, self.turns, self.wire, self.length = scene, radius, turns, wire, float(length)
        self.node = scene.target.scene.add_batched_meshes_simple(
            name, *helix_tube(self.length, self.wire_radius, radius=radius, turns=turns),
            batched_wxyzs=np.array([[1.0, 0.0, 0.0, 0.0]]), batched_positions=np.zeros((1, 3)),
            batched_scales=np.ones((1, 3)), batched_colors=color, lod="off", side="double")
        scene._readouts.append(self)  # (set_presenter with the readouts)

    @property
    def wire_radius(self) -> float:
        """The drawn wire's radius (m): thicker in presenter view."""
        return self.wire * (PRESENTER_LINE_SCALE if self.scene.presenter else 1.0)

    @property
    def solid(self) -> float:
        """Length (m) at which the coils touch, drawn as thick as in presenter view: the shortest it may be drawn."""
        return 2.0 * self.turns * self.wire * PRESENTER_LINE_SCALE

    def rebuild(self, length: float | None = None) -> None:
        """Send the mesh again, built at ``length`` (None: the same) with the wire of the view."""
        self.length = self.length if length is None else float(length)
        vertices, faces = helix_tube(self.length, self.wire_radius, radius=self.radius, turns=self.turns)
        set_arrays(self.node, vertices=vertices, faces=faces)

    def set_presenter(self, on: bool) -> None:
        self.rebuild()

    def span(self, z0: float, z1: float) -> None:
        """Draw the spring from height ``z0`` to ``z1`` (m) on its axis (inside ``target.atomic()``)."""
        set_arrays(self.node, batched_positions=((0.0, 0.0, z0),),
                   batched_scales=((1.0, 1.0, (z1 - z0) / self.length),))
