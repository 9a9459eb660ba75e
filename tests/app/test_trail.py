"""Traced-curve buffers shared by the free-body and gyroscope scenes (app/scenes/_trail.py)."""

from __future__ import annotations

import numpy as np

from app.scenes._trail import extend_trail, trail_segments


def test_extend_trail_skips_close_points_and_keeps_the_newest() -> None:
    points = np.zeros((0, 3))
    points, added = extend_trail(points, np.array([0.0, 0.0, 0.0]), min_step=0.1, capacity=3)
    assert added and points.shape == (1, 3)
    # 0.05 from the last point: not added, the same array comes back
    same, added = extend_trail(points, np.array([0.05, 0.0, 0.0]), min_step=0.1, capacity=3)
    assert not added and same is points
    for x in (1.0, 2.0, 3.0, 4.0):
        points, added = extend_trail(points, np.array([x, 0.0, 0.0]), min_step=0.1, capacity=3)
        assert added
    # capacity 3 segments = 4 points, the newest ones in order
    np.testing.assert_array_equal(points[:, 0], [1.0, 2.0, 3.0, 4.0])


def test_segments_join_consecutive_points_and_collapse_the_rest() -> None:
    assert not trail_segments(np.zeros((0, 3)), 4).any()
    one = trail_segments(np.array([[1.0, 2.0, 3.0]]), 4)
    assert one.shape == (4, 2, 3) and one.dtype == np.float32
    np.testing.assert_array_equal(one, np.broadcast_to([1.0, 2.0, 3.0], (4, 2, 3)))
    rng = np.random.default_rng(7)
    points = rng.normal(size=(3, 3))
    segments = trail_segments(points, 4)
    # the two real segments at the end, in order; float32 rounding of the inputs only
    np.testing.assert_allclose(segments[2:, 0], points[:-1], rtol=1e-6)
    np.testing.assert_allclose(segments[2:, 1], points[1:], rtol=1e-6)
    # the unused segments are points at the curve's start (drawn as nothing)
    np.testing.assert_allclose(segments[:2], np.broadcast_to(points[0], (2, 2, 3)), rtol=1e-6)
    # a full buffer: every segment is a real one
    full = rng.normal(size=(5, 3))
    np.testing.assert_allclose(trail_segments(full, 4)[:, 1], full[1:], rtol=1e-6)
