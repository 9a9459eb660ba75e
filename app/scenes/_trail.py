"""Traced curves (polhode, rotor-tip trail, wheel tracks).

:class:`ChunkedTrail` draws a curve as a ring of small line-segment nodes and
sends it incrementally: a new point changes only the newest chunk, a
finished chunk is sent once and never again, and a browser that connects
later still receives the whole curve (viser keeps each node's latest
points). :func:`extend_trail` and :func:`trail_segments` keep a curve as a
capped list of points drawn as one fixed-size buffer (for curves that are
re-sent whole).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.nodes import set_array

__all__ = ["ChunkedTrail", "extend_trail", "trail_segments", "with_far", "FAR_SEGMENTS"]

#: Two zero-length segments 5 km away, beyond the view's far plane, added to every
#: chunk node: the page computes a line buffer's bounds once, from the points it
#: was created with, and a node whose points later leave those bounds would be
#: culled; with these the bounds hold anything a scene draws.
FAR_SEGMENTS = np.array([[[-5000.0, -5000.0, 0.0]] * 2, [[5000.0, 5000.0, 0.0]] * 2], dtype=np.float32)


def with_far(segments: np.ndarray) -> np.ndarray:
    """``segments`` (k, 2, 3) followed by :data:`FAR_SEGMENTS` (float32): the points of a line node that
    moves away from where it was created (a track's newest stretch), so that the page does not cull it."""
    return np.concatenate([np.asarray(segments, dtype=np.float32), FAR_SEGMENTS])


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


class ChunkedTrail:
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
    so a browser that connects later receives the whole curve. Every chunk
    node also carries :data:`FAR_SEGMENTS`, so a reused node is never culled
    by bounds computed where it was first drawn.

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
        self.nodes = [
            scene.add_lines(f"{name}/c{i:02d}", self._segments[i].copy(), color, thickness=thickness, visible=False,
                            **kwargs)
            for i in range(self.chunks)
        ]
        self._shown = np.zeros(self.chunks, dtype=bool)  # as sent
        self._used = np.zeros(self.chunks, dtype=bool)  # holds part of the curve
        self._dirty: set[int] = set()
        self._head = 0  # chunk holding the newest segment
        self._count = 0  # segments in the head chunk
        self._last: np.ndarray | None = None  # newest point
        self._visible = True

    @property
    def visible(self) -> bool:
        return self._visible

    @visible.setter
    def visible(self, visible: bool) -> None:
        visible = bool(visible)
        if visible != self._visible:
            self._visible = visible
            self.frame.visible = visible

    @property
    def newest(self) -> np.ndarray | None:
        """The newest point (3,), or None for an empty curve."""
        return self._last

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
        parts.append(self._last.astype(np.float32)[None])
        return np.concatenate(parts)

    def clear(self) -> None:
        """Forget the curve (the chunk nodes are hidden at the next :meth:`flush`)."""
        self._used[:] = False
        self._dirty = {k for k in range(self.chunks) if self._shown[k]}
        self._head = 0
        self._count = 0
        self._last = None

    def add(self, point: np.ndarray) -> bool:
        """Append ``point`` (3,) unless it is within ``min_step`` of the newest one; whether it was added."""
        point = np.asarray(point, dtype=float)
        last = self._last
        if last is not None:
            d = point - last
            if not float(d @ d) > self.min_step * self.min_step:
                return False
        self._last = point
        if last is None:  # the first point: a dot (every segment on it) in the head chunk
            self._used[self._head] = True
            self._segments[self._head, :self.chunk_segments] = point
            self._dirty.add(self._head)
            return True
        if self._count == self.chunk_segments:  # the head is full: reuse the oldest node
            self._head = (self._head + 1) % self.chunks
            self._count = 0
            self._used[self._head] = True
        k, n = self._head, self._count
        seg = self._segments[k]
        seg[n, 0] = last
        seg[n, 1] = point
        seg[n + 1:self.chunk_segments] = point  # unused segments collapse onto the newest point
        self._count = n + 1
        self._dirty.add(k)
        return True

    def flush(self) -> None:
        """Send the chunks that changed since the last flush (call inside ``target.atomic()``)."""
        if not self._dirty:
            return
        for k in sorted(self._dirty):
            node = self.nodes[k]
            if self._used[k]:
                set_array(node, "points", self._segments[k])
            if self._used[k] != self._shown[k]:
                node.visible = bool(self._used[k])
                self._shown[k] = self._used[k]
        self._dirty = set()

    @property
    def pending(self) -> bool:
        """Whether :meth:`flush` has something to send."""
        return bool(self._dirty)
