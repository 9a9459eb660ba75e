"""Traced curves (polhode, rotor-tip trail, wheel tracks).

:class:`ChunkedTrail` draws a curve as a ring of small line-segment nodes and
sends it incrementally: a new point changes only the newest chunk, a
finished chunk is sent once and never again, and a browser that connects
later still receives the whole curve (viser keeps each node's latest
points). :class:`StickHead` draws the newest stretch of such a curve, up to
a moving body, with poses only (see there for why). :func:`extend_trail` and
:func:`trail_segments` keep a curve as a capped list of points drawn as one
fixed-size buffer (for curves that are re-sent whole). :class:`SphereTrail`
is a curve traced on a translucent sphere with a marker at its newest point
(the free body's polhode on the momentum sphere, a rotor tip's path).

How the page applies what it receives (viser 1.1.1's client, measured in
headless Chromium): a node's pose (``SetPositionMessage``,
``SetOrientationMessage``) and visibility reach the screen in the frame that
handles them, but new line points (``SceneNodeUpdateMessage``) rebuild the
line's geometry in a React render that runs after that frame is drawn, so
they reach the screen one page frame later. At 60 fps that is a frame of
motion (2 cm for the rolling disk); in a software-rendered page at 2-4 fps
it is 0.3-1.3 m, and a line stretched every frame up to a posed body ends
that far behind it. The page builds a new geometry (and its bounds) on every
points update, so a line node is not culled by stale bounds.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import trimesh

from rigidlab.app.nodes import set_array, set_pose, set_visible, wxyz_z_to

__all__ = ["ChunkedTrail", "HeadedTrail", "SampledTrack", "SphereTrail", "StickHead", "curve_pieces", "extend_trail",
           "ring_due", "sampled_curve", "trail_segments", "FAR_SEGMENTS"]

Vec = tuple[float, float, float]

#: Two zero-length segments 5 km away, beyond the view's far plane, added to every
#: chunk node so that its bounds hold anything a scene draws. (They were meant
#: against culling by bounds computed once; the page in fact rebuilds a line's
#: geometry and bounds on every points update, so they are not what keeps a
#: track in view.)
FAR_SEGMENTS = np.array([[[-5000.0, -5000.0, 0.0]] * 2, [[5000.0, 5000.0, 0.0]] * 2], dtype=np.float32)


def extend_trail(points: np.ndarray, point: np.ndarray, *, min_step: float, capacity: int) -> tuple[np.ndarray, bool]:
    """``points`` with ``point`` appended unless it is within ``min_step`` of the last one.

    Parameters
    ----------
    points : (n, 3) ndarray
        The curve so far (global or picture frame, metres), oldest first.
    point : (3,) ndarray
        The newest point, same frame.
    min_step : float, keyword-only
        A point closer than this to the last one is not added (metres).
    capacity : int, keyword-only
        Segments drawn: at most ``capacity + 1`` points are kept (the newest).

    Returns
    -------
    points : (m, 3) ndarray
        The new curve (``points`` itself when nothing was added).
    added : bool
        Whether ``point`` was added.
    """
    n = points.shape[0]
    if n:
        d = point - points[-1]
        if not float(d @ d) > min_step * min_step:
            return points, False
    out = np.empty((n + 1, 3))
    out[:n] = points
    out[n] = point
    return out[-(capacity + 1):], True


def trail_segments(points: np.ndarray, capacity: int) -> np.ndarray:
    """Line segments (capacity, 2, 3) float32 joining consecutive ``points`` (n, 3).

    The curve fills the last ``n - 1`` segments; the unused leading ones
    collapse onto the first point (all segments onto it when ``n == 1``, all
    zero when ``n == 0``).
    """
    segments = np.zeros((capacity, 2, 3), dtype=np.float32)
    n = points.shape[0] - 1
    if n > 0:
        segments[-n:, 0] = points[:-1]
        segments[-n:, 1] = points[1:]
        segments[: capacity - n] = points[0]
    elif points.shape[0] == 1:
        segments[:] = points[0]
    return segments


class _Framed:
    """A curve drawn by nodes under one frame (``self.frame``), shown or hidden as a whole."""

    frame: Any
    _visible: bool = True

    @property
    def visible(self) -> bool:
        return self._visible

    @visible.setter
    def visible(self, visible: bool) -> None:
        visible = bool(visible)
        if visible != self._visible:
            self._visible = visible
            self.frame.visible = visible


class ChunkedTrail(_Framed):
    """A traced curve sent incrementally: a ring of fixed-size line-segment nodes.

    The curve is split into ``chunks`` nodes of ``chunk_segments`` segments
    each, created once (hidden) under the frame ``name``. A new point extends
    the newest chunk; :meth:`flush` sends only the chunks that changed since
    the last flush (normally the newest one, ``chunk_segments * 24`` bytes),
    so a finished chunk is sent once and never again. When the newest chunk
    is full the next point starts the oldest chunk's node afresh (a ring), so
    between ``(chunks - 1) * chunk_segments`` and ``chunks * chunk_segments``
    of the newest segments are drawn. Consecutive chunks share their joining
    point, so the curve has no gaps. viser keeps every node's latest points,
    so a browser that connects later receives the whole curve.
    :attr:`unsent_length` is the length of the curve added since the last
    flush (not on the page yet). Every chunk node also carries
    :data:`FAR_SEGMENTS`. A hidden node holds segments out
    of sight, so that a node shown again does not show its old stretch for
    the page frame before its new points arrive. The page draws new points a
    frame after the poses sent with them: a curve drawn up to a moving body
    ends with a :class:`StickHead`.

    Parameters
    ----------
    scene : app.scenes.base.Scene
        The scene the nodes belong to (their width grows in presenter view).
    name : str
        Path of the frame that holds the chunk nodes (``{name}/c00`` ...).
    color : (3,) RGB in 0..255
        Colour of the curve.
    thickness : float, keyword-only
        Line width (``add_lines``; ``**kwargs`` such as ``thickness_units`` go there too).
    capacity : int, keyword-only
        Segments at least drawn (the newest); the ring holds one chunk more.
    min_step : float, keyword-only
        A point closer than this to the last one is not added (same units as the points).
    chunk_segments : int, keyword-only
        Segments per chunk node: the bytes sent per flush.
    """

    def __init__(self, scene: Any, name: str, color: Any, *, thickness: float, capacity: int, min_step: float,
                 chunk_segments: int = 16, **kwargs: Any) -> None:
        if chunk_segments < 1 or capacity < 1:
            raise ValueError(f"capacity, chunk_segments: expected >= 1, got {capacity}, {chunk_segments}")
        self.chunk_segments = int(chunk_segments)
        self.chunks = -(-int(capacity) // self.chunk_segments) + 1
        self.min_step = float(min_step)
        self.frame = scene.target.scene.add_frame(name, show_axes=False)
        c = self.chunk_segments
        # (chunks, c + 2, 2, 3): each chunk's segments, then the two far ones
        self._segments = np.zeros((self.chunks, c + 2, 2, 3), dtype=np.float32)
        self._segments[:, c:] = FAR_SEGMENTS
        # what a hidden node holds: every segment out of sight, 5 km away (the page shows a node in the
        # frame that receives its visibility, and its new points a frame later: a node shown again
        # would show its old stretch of the curve for a frame)
        self._parked = np.broadcast_to(FAR_SEGMENTS[1], (c + 2, 2, 3)).copy()
        self._parked[c:] = FAR_SEGMENTS
        self.nodes = [
            scene.add_lines(f"{name}/c{i:02d}", self._parked.copy(), color, thickness=thickness, visible=False,
                            **kwargs)
            for i in range(self.chunks)
        ]
        self._shown = np.zeros(self.chunks, dtype=bool)  # as sent
        self._used = np.zeros(self.chunks, dtype=bool)  # holds part of the curve
        self._dirty: set[int] = set()
        self._head = 0  # chunk holding the newest segment
        self._count = 0  # segments in the head chunk
        self._last: tuple[float, float, float] | None = None  # newest point
        self.unsent_length = 0.0  # length of the segments added since the last flush (units of the points)

    @property
    def newest(self) -> np.ndarray | None:
        """The newest point (3,), or None for an empty curve."""
        return None if self._last is None else np.array(self._last)

    @property
    def thickness(self) -> float:
        """Line width of the chunk nodes as drawn (presenter view included)."""
        return float(self.nodes[0].thickness)

    @property
    def points(self) -> np.ndarray:
        """The curve drawn (n, 3), oldest first (float32 as sent)."""
        if self._last is None:
            return np.zeros((0, 3), dtype=np.float32)
        order = [(self._head + 1 + i) % self.chunks for i in range(self.chunks)]
        parts = []
        for k in order:
            if not self._used[k]:
                continue
            n = self._count if k == self._head else self.chunk_segments
            if n:
                parts.append(self._segments[k, :n, 0])
        parts.append(np.array([self._last], dtype=np.float32))
        return np.concatenate(parts)

    def clear(self) -> None:
        """Forget the curve (the chunk nodes are hidden at the next :meth:`flush`)."""
        self._used[:] = False
        self._dirty = {k for k in range(self.chunks) if self._shown[k]}
        self._head = 0
        self._count = 0
        self._last = None
        self.unsent_length = 0.0

    def add(self, point: Any) -> bool:
        """Append ``point`` (3,) unless it is within ``min_step`` of the newest one; whether it was added.

        A point costs the loop thread a few float operations and one row of
        the chunk's buffer (it is called for every point of a curve, every
        frame): the unused segments of the newest chunk collapse onto the
        newest point when :meth:`flush` sends it. Its segment's length adds
        to :attr:`unsent_length`.
        """
        p = (float(point[0]), float(point[1]), float(point[2]))
        last = self._last
        if last is not None:
            dx, dy, dz = p[0] - last[0], p[1] - last[1], p[2] - last[2]
            step2 = dx * dx + dy * dy + dz * dz
            if not step2 > self.min_step * self.min_step:
                return False
            self.unsent_length += math.sqrt(step2)
        self._last = p
        if last is None:  # the first point: a dot (every segment on it, at the flush) in the head chunk
            self._used[self._head] = True
            self._dirty.add(self._head)
            return True
        if self._count == self.chunk_segments:  # the head is full: reuse the oldest node
            self._head = (self._head + 1) % self.chunks
            self._count = 0
            self._used[self._head] = True
        k, n = self._head, self._count
        self._segments[k, n] = (last, p)
        self._count = n + 1
        self._dirty.add(k)
        return True

    def flush(self) -> None:
        """Send the chunks that changed since the last flush (call inside ``target.atomic()``)."""
        if not self._dirty:
            return
        if self._last is not None:  # the newest chunk's unused segments collapse onto the newest point
            self._segments[self._head, self._count:self.chunk_segments] = self._last
        for k in sorted(self._dirty):
            node = self.nodes[k]
            if self._used[k]:
                set_array(node, "points", self._segments[k])
            elif self._shown[k]:  # hidden now, and out of sight when it is shown again
                set_array(node, "points", self._parked)
            if self._used[k] != self._shown[k]:
                node.visible = bool(self._used[k])
                self._shown[k] = self._used[k]
        self._dirty = set()
        self.unsent_length = 0.0

    @property
    def pending(self) -> bool:
        """Whether :meth:`flush` has something to send."""
        return bool(self._dirty)


class StickHead(_Framed):
    """The newest stretch of a traced curve drawn with poses only: a ring of equal straight sticks.

    A track drawn up to a moving body (a wheel's contact point) cannot be a
    line whose points are updated every frame: the page draws new points one
    frame after the poses sent with them (see the module docstring), so the
    line ends a page frame of motion behind the body -- up to a metre in a
    page at 2-4 fps. Here the curve's newest stretch is cut into chords of
    equal length ``length`` (consecutive sticks share their ends, every end on
    the curve as fed, a polyline), and each chord is drawn by one node holding
    the fixed segment ``(0, 0, 0)-(0, 0, length)``, placed by its position and
    orientation. A node is placed once, when its chord is complete, and moved
    again only when the ring reuses it ``count`` chords later. One more stick,
    the *tip*, starts at the newest point and points back along the newest
    chord, over the gap to that chord's end (less than ``length``) and
    overlapping the chord beyond it; it is turned only when a chord is added
    and otherwise only moved, one message a frame (on a curve of radius
    ``R`` it passes the chord's end within about ``length^2 / R``: 0.4 mm
    for 3 cm sticks on a circle of 2 m). Everything sent after the nodes are created is a pose or a
    visibility, which the page draws in the frame it receives them, so the
    drawn curve reaches the body in every frame. The stretch covered,
    :attr:`reach` ``= count * length`` (at least, along the curve), must be
    longer than the body travels in a page frame plus the stretch that the
    :class:`ChunkedTrail` behind it has not sent yet: the two overlap, and the
    chunks may end anywhere along the sticks. :class:`SampledTrack` and
    :class:`HeadedTrail` send the trail's chunk at the latest when that
    stretch reaches half the reach (:func:`ring_due`), a frame that sends a
    plot or not; the other half is left for a page frame's motion.

    Parameters
    ----------
    scene : app.scenes.base.Scene
        The scene the nodes belong to (their width grows in presenter view).
    name : str
        Path of the frame that holds the stick nodes (``{name}/s00`` ..., ``{name}/tip``); its
        coordinates are those of the points fed (the frame of the curve's :class:`ChunkedTrail`).
    color : (3,) RGB in 0..255
        Colour of the sticks.
    thickness : float, keyword-only
        Line width (``add_lines``; ``**kwargs`` such as ``thickness_units`` go there too).
    length : float, keyword-only
        Length of a stick (the chord), same units as the points.
    count : int, keyword-only
        Sticks in the ring.
    """

    def __init__(self, scene: Any, name: str, color: Any, *, thickness: float, length: float, count: int,
                 **kwargs: Any) -> None:
        if not (math.isfinite(length) and length > 0.0) or count < 1:
            raise ValueError(f"length, count: expected > 0 and >= 1, got {length}, {count}")
        self.length = float(length)
        self.count = int(count)
        self.frame = scene.target.scene.add_frame(name, show_axes=False)
        stick = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, self.length]]], dtype=np.float32)
        self.nodes = [scene.add_lines(f"{name}/s{i:02d}", stick, color, thickness=thickness, visible=False,
                                      **kwargs) for i in range(self.count)]
        self.tip = scene.add_lines(f"{name}/tip", stick, color, thickness=thickness, visible=False, **kwargs)
        self._starts = np.zeros((self.count, 3))  # each stick's first end, as placed
        self._ends = np.zeros((self.count, 3))
        self._used = np.zeros(self.count, dtype=bool)
        self._shown = np.zeros(self.count, dtype=bool)  # as sent
        self._tip_shown = False
        self._visibility_due = False
        self._placed: dict[int, tuple[Vec, Vec]] = {}  # sticks placed since the last draw: their ends
        self._next = 0  # the ring's next stick
        # (points as float triples: a frame feeds a point or two, and numpy's calls on 3-vectors cost more than
        # the arithmetic)
        self._anchor: Vec | None = None  # the newest chord's end (the first point before any chord)
        self._last: Vec | None = None  # the newest point
        self._direction: Vec | None = None  # unit direction of the newest chord

    @property
    def reach(self) -> float:
        """The stretch of the curve the sticks cover back from the newest chord's end once the ring is full,
        ``count * length`` (a chord is no longer than the curve between its ends)."""
        return self.count * self.length

    @property
    def segments(self) -> np.ndarray:
        """The sticks drawn (n, 2, 3) as placed (chords oldest first, then the tip from the newest point)."""
        order = [(self._next + i) % self.count for i in range(self.count)]
        order = [k for k in order if self._used[k]]
        out = [np.stack([self._starts[order], self._ends[order]], axis=1)]
        tip = self._tip()
        if tip is not None:
            last = np.array(self._last)
            out.append(np.array([[last, last + self.length * np.array(tip)]]))
        return np.concatenate(out)

    def set_length(self, length: float) -> None:
        """Sticks of ``length`` from now on (a body of another size): the curve is forgot and every stick's
        segment is sent again, ``count + 1`` messages (rare: not a per-frame change)."""
        if not (math.isfinite(length) and length > 0.0):
            raise ValueError(f"length: expected a finite length > 0, got {length!r}")
        if length == self.length:
            return
        self.length = float(length)
        stick = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, self.length]]], dtype=np.float32)
        for node in (*self.nodes, self.tip):
            set_array(node, "points", stick)
        self.clear()

    def clear(self) -> None:
        """Forget the curve (the sticks are hidden at the next :meth:`draw`)."""
        self._used[:] = False
        self._visibility_due = True
        self._placed.clear()
        self._next = 0
        self._anchor = None
        self._last = None
        self._direction = None

    def add(self, point: Any) -> None:
        """Extend the curve to ``point`` (3,) along a straight piece from the newest point."""
        px, py, pz = float(point[0]), float(point[1]), float(point[2])
        if self._anchor is None or self._last is None:
            self._anchor = self._last = (px, py, pz)
            return
        ax, ay, az = self._anchor
        qx, qy, qz = self._last
        length2 = self.length * self.length
        while (px - ax) ** 2 + (py - ay) ** 2 + (pz - az) ** 2 >= length2:
            # the chord's end: the point of [prev, p] at distance `length` from the anchor
            # (|prev - anchor| < length, so exactly one such point lies past prev)
            a = (qx - ax, qy - ay, qz - az)
            bx, by, bz = px - qx, py - qy, pz - qz
            bb = bx * bx + by * by + bz * bz
            ab = a[0] * bx + a[1] * by + a[2] * bz
            aa = a[0] * a[0] + a[1] * a[1] + a[2] * a[2]
            u = min(max((-ab + math.sqrt(max(ab * ab - bb * (aa - length2), 0.0))) / bb, 0.0), 1.0)
            end = (qx + u * bx, qy + u * by, qz + u * bz)
            self._place((ax, ay, az), end)
            ax, ay, az = qx, qy, qz = end
        self._anchor = (ax, ay, az)
        self._last = (px, py, pz)

    def _place(self, start: Vec, end: Vec) -> None:
        k = self._next
        self._next = (k + 1) % self.count
        sx, sy, sz = start
        dx, dy, dz = end[0] - sx, end[1] - sy, end[2] - sz
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        ux, uy, uz = self._direction = (dx / norm, dy / norm, dz / norm)
        stick_end = (sx + self.length * ux, sy + self.length * uy, sz + self.length * uz)
        self._starts[k] = start
        self._ends[k] = stick_end
        if not self._used[k]:
            self._used[k] = True
            self._visibility_due = True
        self._placed[k] = (start, stick_end)

    def _tip(self) -> Vec | None:
        """Unit direction of the tip from the newest point (back along the newest chord), or None (no chord
        yet)."""
        if self._last is None or self._direction is None:
            return None
        ux, uy, uz = self._direction
        return (-ux, -uy, -uz)

    def draw(self) -> None:
        """Send the poses of the sticks placed since the last draw and of the tip (call inside
        ``target.atomic()``, every frame the curve moves).

        The tip's orientation changes only with a new chord; every other
        frame sends one message, its position (each message costs the loop
        thread its share of the websocket thread's work under the GIL).
        """
        new_chord = bool(self._placed)
        for k in sorted(self._placed):
            start, end = self._placed[k]
            dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
            norm = math.sqrt(dx * dx + dy * dy + dz * dz)
            set_pose(self.nodes[k], position=start, wxyz=wxyz_z_to((dx, dy, dz), norm))
        self._placed.clear()
        if self._visibility_due:
            self._visibility_due = False
            for k in np.flatnonzero(self._used != self._shown):
                self.nodes[k].visible = bool(self._used[k])  # after its pose: drawn where it belongs
                self._shown[k] = self._used[k]
        tip = self._tip()
        if tip is not None:
            assert self._last is not None
            set_pose(self.tip, position=self._last, wxyz=wxyz_z_to(tip, 1.0) if new_chord or not self._tip_shown
                     else None)
        if (tip is not None) != self._tip_shown:
            self._tip_shown = tip is not None
            self.tip.visible = self._tip_shown


class SphereTrail:
    """A curve traced on a translucent sphere, with a ball marking the newest point (created once).

    The nodes sit under the frame ``name`` at ``position`` (its axes drawn ``axes_length`` long): the
    sphere (``radius``, ``sphere_color``, ``opacity``), a :class:`ChunkedTrail` ``{name}/trail`` and the
    marker ``{name}/head``. A scene may add nodes of its own under :attr:`name` (they share the frame).
    :meth:`add` feeds a point (frame coordinates), :meth:`flush` sends what changed: the trail's newest
    chunk and the marker's position.
    """

    def __init__(self, scene: Any, name: str, color: Any, *, position: Any, radius: float, thickness: float,
                 capacity: int, min_step: float, marker_color: Any, marker_radius: float = 0.05,
                 axes_length: float = 0.0, sphere_color: Any = (200, 200, 230), opacity: float = 0.15) -> None:
        api = scene.target.scene
        self.name = name
        self.frame = api.add_frame(name, position=tuple(float(x) for x in position), show_axes=axes_length > 0,
                                   axes_length=max(axes_length, 1e-6), axes_radius=0.01)
        sphere = trimesh.creation.icosphere(subdivisions=3, radius=radius)
        self.sphere = api.add_mesh_simple(f"{name}/sphere", sphere.vertices.astype(np.float32),
                                          sphere.faces.astype(np.uint32), color=sphere_color, opacity=opacity)
        self.trail = ChunkedTrail(scene, f"{name}/trail", color, thickness=thickness, capacity=capacity,
                                  min_step=min_step)
        self.marker = api.add_icosphere(f"{name}/head", radius=marker_radius, color=marker_color)

    @property
    def points(self) -> np.ndarray:
        """The curve drawn (n, 3), oldest first."""
        return self.trail.points

    def clear(self) -> None:
        self.trail.clear()

    def add(self, point: Any) -> bool:
        """Feed a point (3,); True when the trail changed (a flush is due)."""
        return self.trail.add(point)

    def flush(self) -> None:
        """Send the trail's newest chunk and place the marker at the newest point."""
        self.trail.flush()
        newest = self.trail.newest
        if newest is not None:
            set_pose(self.marker, position=newest)


def curve_pieces(samples: list[np.ndarray], q2: np.ndarray, *, turn: float = math.radians(3.0),
                 most: int = 8) -> list[np.ndarray]:
    """The points that draw a sampled curve from its last sample to the next one ``q2``, ending with ``q2``.

    ``samples``: up to two samples before ``q2`` (equally spaced in time, oldest first). When the chord to
    ``q2`` turns by more than ``turn`` (rad) from the chord before, it is cut into equal steps of time on
    the parabola through the three samples, ``q(s) = q1 + s (q2 - q0) / 2 + s^2 (q2 - 2 q1 + q0) / 2`` (``s``
    from 0 at ``q1`` to 1 at ``q2``; its error is third order in the time step), so that each piece turns
    by about ``turn``, at most ``most`` pieces: a curve between coarse samples, not a polygon of chords.
    """
    if len(samples) < 2:
        return [q2]
    q0, q1 = samples[-2], samples[-1]
    a, b = q1 - q0, q2 - q1
    la, lb = math.sqrt(float(a @ a)), math.sqrt(float(b @ b))
    if la == 0.0 or lb == 0.0:
        return [q2]
    angle = math.acos(min(max(float(a @ b) / (la * lb), -1.0), 1.0))
    pieces = min(most, math.ceil(angle / turn - 1e-9))
    if pieces <= 1:
        return [q2]
    slope, bend = 0.5 * (q2 - q0), 0.5 * (q2 - 2.0 * q1 + q0)
    return [q1 + (i / pieces) * slope + (i / pieces) ** 2 * bend for i in range(1, pieces)] + [q2]


def sampled_curve(t: np.ndarray, points: np.ndarray, *, before: tuple[float, np.ndarray] | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The points that draw a curve through samples: ``(curve (m, 3), start (n + 1,))``, read-only.

    Sample ``i`` (time ``t[i]``, point ``points[i]``) extends the curve by
    ``curve[start[i]:start[i + 1]]``, the :func:`curve_pieces` from the two
    samples before it (``before = (t_before, points (<= 2, 3))``: the last
    samples of the chunk before, the newest at ``t_before``). A sample at or
    before the time of the one before (a chunk's first, which ends the chunk
    before) adds none.
    Formed once per chunk of samples (off the loop thread); a frame only
    slices it (:class:`SampledTrack`).
    """
    samples = [] if before is None else list(np.asarray(before[1], dtype=float)[-2:])
    last = -math.inf if before is None else float(before[0])
    parts: list[np.ndarray] = []
    start = [0]
    for ti, q in zip(np.asarray(t, dtype=float).tolist(), np.asarray(points, dtype=float)):
        if ti > last:
            parts.extend(curve_pieces(samples, q))
            samples = [*samples[-1:], q]
            last = ti
        start.append(len(parts))
    curve = np.array(parts, dtype=float).reshape(-1, 3)
    starts = np.array(start, dtype=np.intp)
    for a in (curve, starts):
        a.setflags(write=False)
    return curve, starts


def ring_due(trail: ChunkedTrail, head: StickHead, *, waited: float, period: float, hold: bool) -> bool:
    """Whether a track drawn as ``trail`` ended by ``head`` sends the trail's changed chunks in this frame.

    They go when ``period`` s of wall time have passed since the last send
    (``waited``), but not in a frame that sends a plot or the readout already
    (``hold``: the loop thread's work per frame stays small) -- unless the
    stretch not sent yet (``trail.unsent_length``) has reached half the
    head's reach. The head covers that stretch plus a page frame's motion
    only while their sum is below its reach, and ``hold`` alone may hold the
    chunk back for good: a slow server sends a plot or the readout in every
    frame (they are refreshed one a frame, each every 0.25 s: the rolling
    disk's five at 20 frames a second or fewer).
    """
    if not trail.pending:
        return False
    return trail.unsent_length >= 0.5 * head.reach or (not hold and waited >= period)


class SampledTrack:
    """A track that a moving point leaves, up to that point in every frame: a :class:`ChunkedTrail` and a
    :class:`StickHead`, fed with the :func:`sampled_curve` points of the samples a clock passes.

    :meth:`follow` adds the points of the samples passed since the last call
    (the rest of the chunk before, when the clock crossed into the next one)
    and runs the head on to the point drawn; :meth:`draw` sends the trail's
    newest chunk every ``period`` wall seconds and the head's poses.

    Parameters
    ----------
    scene, name, color, thickness, capacity, min_step :
        As :class:`ChunkedTrail` (``{name}/trail``); ``**kwargs`` go to both.
    head_length, head_count :
        The head's sticks (:class:`StickHead`, ``{name}/head``).
    period : float
        Wall seconds between the trail's flushes.
    """

    def __init__(self, scene: Any, name: str, color: Any, *, thickness: float, capacity: int, min_step: float,
                 head_length: float, head_count: int, period: float = 0.1, **kwargs: Any) -> None:
        self.trail = ChunkedTrail(scene, f"{name}/trail", color, thickness=thickness, capacity=capacity,
                                  min_step=min_step, **kwargs)
        self.head = StickHead(scene, f"{name}/head", color, thickness=thickness, length=head_length,
                              count=head_count, **kwargs)
        self.period = float(period)
        self._base = (float(head_length), float(min_step))
        self._fed: tuple[Any, int, int] | None = None  # (chunk key, samples fed, samples in it)
        self._flushed = -math.inf

    def scale(self, s: float) -> None:
        """Sticks and the trail's least step ``s`` times those given (a body of another size: a small coin's
        track stays a curve); the head forgets its points."""
        self.head.set_length(s * self._base[0])
        self.trail.min_step = s * self._base[1]

    @property
    def visible(self) -> bool:
        return self.trail.visible

    @visible.setter
    def visible(self, visible: bool) -> None:
        self.trail.visible = visible
        self.head.visible = visible

    def clear(self) -> None:
        self.trail.clear()
        self.head.clear()
        self._fed = None

    def _add(self, curve: np.ndarray, start: np.ndarray, i0: int, i1: int) -> None:
        for q in curve[start[i0]:start[i1]].tolist():
            self.trail.add(q)
            self.head.add(q)

    def follow(self, key: Any, curve: np.ndarray, start: np.ndarray, j: int, point: Any,
               previous: tuple[Any, np.ndarray, np.ndarray] | None = None) -> None:
        """The clock is at sample ``j`` of chunk ``key`` (its :func:`sampled_curve` ``curve``, ``start``)
        and the point drawn is ``point`` (3,); ``previous``: ``(key, curve, start)`` of the chunk before."""
        fed = self._fed
        if fed is not None and previous is not None and fed[0] == previous[0] != key and fed[1] < fed[2]:
            self._add(previous[1], previous[2], fed[1], fed[2])  # the rest of the chunk before
        i0 = fed[1] if fed is not None and fed[0] == key else 0
        if j + 1 > i0:
            self._add(curve, start, i0, j + 1)
        self._fed = (key, max(i0, j + 1), start.size - 1)
        self.head.add(point)

    def draw(self, *, hold: bool = False) -> None:
        """Send what changed (inside ``target.atomic()``, every frame the point moves); ``hold``: the frame
        sends a plot or a readout already, the trail's chunk waits for a later frame unless the head would no
        longer cover what it holds back (:func:`ring_due`; the head's poses go)."""
        if not self.visible:
            return
        now = time.monotonic()
        if ring_due(self.trail, self.head, waited=now - self._flushed, period=self.period, hold=hold):
            self.trail.flush()
            self._flushed = now
        self.head.draw()


class HeadedTrail:
    """A traced curve up to a moving point: a :class:`ChunkedTrail` flushed every ``period`` s of wall time,
    ended by a :class:`StickHead` of ``count`` sticks of ``length`` (m) placed by poses in every frame.

    ``add(point)`` feeds both; ``draw(visible)`` (inside ``atomic()``) shows or hides them, sends the
    trail's newest chunk when ``period`` s of wall time have passed (not in a frame that sends a plot:
    ``hold=True``, unless the head would no longer cover what the trail holds back: :func:`ring_due`) and
    the head's poses; ``clear()`` empties both.
    """

    def __init__(self, scene: Any, name: str, color: Any, *, thickness: float, capacity: int, min_step: float,
                 length: float, count: int, period: float = 0.1, **kwargs: Any) -> None:
        self.trail = ChunkedTrail(scene, name, color, thickness=thickness, capacity=capacity, min_step=min_step,
                                  **kwargs)
        self.head = StickHead(scene, f"{name}_head", color, thickness=thickness, length=length, count=count,
                              **kwargs)
        self.period = float(period)
        self._sent = -math.inf

    def add(self, point: Any) -> None:
        self.trail.add(point)
        self.head.add(point)

    def clear(self) -> None:
        self.trail.clear()
        self.head.clear()

    def draw(self, visible: bool, *, hold: bool = False) -> None:
        for part in (self.trail, self.head):
            set_visible(part, visible)
        now = time.monotonic()
        if visible and ring_due(self.trail, self.head, waited=now - self._sent, period=self.period, hold=hold):
            self._sent = now
            self.trail.flush()  # the newest chunk only
        if visible:
            self.head.draw()  # poses of the new sticks and of the tip
