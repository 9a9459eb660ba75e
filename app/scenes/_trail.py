"""A traced curve (polhode, rotor-tip trail) kept as a capped list of points
and drawn as a fixed-size line-segment buffer.

The segment node is created once with ``capacity`` segments; every update
sends the same number of segments (unused ones collapse onto the first
point), so viser replaces one small buffer and never re-creates the node.
"""

from __future__ import annotations

import numpy as np

__all__ = ["extend_trail", "trail_segments"]


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
