"""Traced curves (app/scenes/_trail.py): capped point lists, and chunked trails sent incrementally."""

from __future__ import annotations

import time

import numpy as np

from rigidlab.app.scenes._trail import ChunkedTrail, SampledTrack, extend_trail, sampled_curve, trail_segments
from tests.app._wire import Recorder
from tests.helpers import wait_until


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


# -- ChunkedTrail: a curve sent incrementally, whole for a late joiner ---------------------------


class _Owner:
    """What ChunkedTrail needs of a scene: its target and ``add_lines``."""

    def __init__(self, server) -> None:
        self.target = server

    def add_lines(self, name, points, colors, *, thickness, **kwargs):
        return self.target.scene.add_line_segments(name, points, colors, thickness=thickness, **kwargs)


def _curve(n: int, offset: float = 0.0) -> np.ndarray:
    """``n`` points of a helix (m), 0.05 m apart or more."""
    u = np.arange(n) * 0.1 + offset
    return np.column_stack([np.cos(u), np.sin(u), 0.01 * u])


def _trail_updates(recorder, path: str) -> list[tuple[str, int, tuple[int, ...]]]:
    """(node, bytes, shape of the points) of every points update of the chunk nodes under ``path``."""
    out = []
    for message, size in recorder.received():
        if message.get("type") == "SceneNodeUpdateMessage" and message["name"].startswith(path + "/") \
                and "points" in message["updates"]:
            out.append((message["name"], size, message["updates"]["points"].shape))
    return out


def test_chunked_trail_sends_only_the_newest_chunk(server) -> None:
    recorder = Recorder(f"ws://127.0.0.1:{server.get_port()}")
    try:
        trail = ChunkedTrail(_Owner(server), "/trail_incremental", (200, 100, 0), thickness=2.0, capacity=64,
                             min_step=0.01, chunk_segments=8)
        assert trail.chunks == 9  # 64 segments in chunks of 8, and one more for the ring
        points = _curve(200)
        for p in points:  # one point and one flush per frame
            assert trail.add(p)
            assert not trail.add(p + 0.001)  # closer than min_step: not added
            with server.atomic():
                trail.flush()
            time.sleep(0.002)
        assert not trail.pending

        def arrived() -> bool:  # the newest chunk as the server holds it has reached the page
            nodes = recorder.nodes()
            return all(np.array_equal(np.asarray(nodes[h.name]["props"]["points"]).reshape(-1, 2, 3), h.points)
                       for h in trail.nodes if h.name in nodes)

        wait_until(arrived)
        updates = _trail_updates(recorder, "/trail_incremental")
        # at most one small chunk per frame (viser may merge a node's updates that were not
        # sent yet), never the whole curve: 8 segments and the two far ones
        assert 20 <= len(updates) <= 200
        assert {shape for _, _, shape in updates} == {(10 * 2 * 3,)}  # flat float32 buffers as received
        per_frame = max(size for _, size, _ in updates)
        assert per_frame < 10 * 24 + 200  # bytes: the chunk's points and the message around them
        # a finished chunk is not sent again until the ring reuses its node: each node's updates
        # come in runs of at most 8 (its segments), one run per time it is the newest chunk
        names = [name for name, _, _ in updates]
        runs = [1]
        for a, b in zip(names, names[1:]):
            runs[-1:] = [runs[-1] + 1] if a == b else [runs[-1], 1]
        assert max(runs) <= 8 + 1  # the first chunk also carries the first point
        # the curve drawn is the newest points, at least `capacity` segments of them
        drawn = trail.points
        assert 64 + 1 <= drawn.shape[0] <= 72 + 1
        np.testing.assert_allclose(drawn, points[-drawn.shape[0]:], rtol=1e-6, atol=1e-6)
    finally:
        recorder.close()


def test_a_late_joiner_sees_the_whole_chunked_curve(server) -> None:
    trail = ChunkedTrail(_Owner(server), "/trail_late", (0, 150, 140), thickness=2.0, capacity=40,
                         min_step=0.01, chunk_segments=8)
    points = _curve(130, offset=1.0)  # the ring has wrapped more than twice
    for p in points:
        trail.add(p)
        with server.atomic():
            trail.flush()
    late = Recorder(f"ws://127.0.0.1:{server.get_port()}")
    try:
        nodes = late.nodes()
        chunks = {name: node for name, node in nodes.items() if name.startswith("/trail_late/")}
        assert len(chunks) == trail.chunks
        # the late joiner holds each chunk node exactly as the server does
        for handle in trail.nodes:
            node = chunks[handle.name]
            np.testing.assert_array_equal(np.asarray(node["props"]["points"]).reshape(-1, 2, 3), handle.points)
            assert node["visible"] == handle.visible
        # and its visible chunks draw the whole curve: every segment joins consecutive added points
        segments = np.concatenate([np.asarray(node["props"]["points"]).reshape(-1, 2, 3)[:-2]
                                   for node in chunks.values() if node["visible"]])
        segments = segments[np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1) > 0]  # drop collapsed ones
        drawn = trail.points
        assert segments.shape[0] == drawn.shape[0] - 1
        expected = {tuple(np.round(a, 5)) + tuple(np.round(b, 5)) for a, b in zip(drawn[:-1], drawn[1:])}
        got = {tuple(np.round(a, 5)) + tuple(np.round(b, 5)) for a, b in segments}
        assert got == expected
        np.testing.assert_allclose(drawn, points[-drawn.shape[0]:], rtol=1e-6, atol=1e-6)
        # clearing hides every chunk; a browser joining then sees no curve
        trail.clear()
        with server.atomic():
            trail.flush()
        assert trail.points.shape == (0, 3)
        assert not any(handle.visible for handle in trail.nodes)
    finally:
        late.close()
    empty = Recorder(f"ws://127.0.0.1:{server.get_port()}")
    try:
        assert not any(node["visible"] for name, node in empty.nodes().items() if name.startswith("/trail_late/"))
    finally:
        empty.close()


def test_a_flush_sends_the_newest_chunk_with_its_unused_segments_on_the_newest_point(server) -> None:
    # points come every frame, flushes a few frames apart (a scene's track at 10 Hz): what is sent is the
    # curve up to the newest point, and the chunk's remaining segments are that point (drawn as nothing)
    trail = ChunkedTrail(_Owner(server), "/trail_between_flushes", (0, 150, 140), thickness=2.0, capacity=32,
                         min_step=0.01, chunk_segments=8)
    points = _curve(40, offset=2.0)
    trail.add(points[0])
    with server.atomic():
        trail.flush()  # the first point alone: a dot, every segment on it
    first = np.asarray(trail.nodes[0].points)[:-2]
    np.testing.assert_allclose(first, np.broadcast_to(points[0], first.shape), rtol=1e-6)
    for i, p in enumerate(points[1:], start=1):
        assert trail.add(p)
        if i % 3 == 0 or i == len(points) - 1:
            with server.atomic():
                trail.flush()
            assert not trail.pending
            sent = np.concatenate([np.asarray(h.points)[:-2] for h in trail.nodes if h.visible])
            real = sent[np.linalg.norm(sent[:, 1] - sent[:, 0], axis=1) > 0]
            # the segments drawn join consecutive points, up to the newest one
            assert np.linalg.norm(real[:, 1] - points[i], axis=1).min() < 1e-6
            drawn = trail.points
            np.testing.assert_allclose(drawn[-1], points[i], rtol=1e-6)
            assert real.shape[0] == drawn.shape[0] - 1
            # the rest collapse onto the newest point
            newest = np.asarray(trail.nodes[trail._head].points)[:-2]
            rest = newest[trail._count:]
            np.testing.assert_allclose(rest, np.broadcast_to(points[i], rest.shape), rtol=1e-6)
    np.testing.assert_array_equal(trail.newest, points[-1])


# -- sampled_curve and SampledTrack: a track fed with the samples a clock passes ---------------------------


def test_a_sampled_track_adds_each_sample_once_across_frames_and_chunks(server) -> None:
    # two chunks of a circle's samples (the second's first sample ends the first), drawn frame by frame: a frame
    # that draws the same chunk again, or the same sample, adds nothing; crossing into the next chunk adds the
    # rest of the chunk before first
    u = np.linspace(0.0, 1.0, 11)
    circle = np.column_stack([np.cos(u), np.sin(u), np.zeros_like(u)])
    first = sampled_curve(u[:6], circle[:6])
    second = sampled_curve(u[5:], circle[5:], before=(float(u[5]), circle[4:6]))
    assert second[1][1] == 0  # (its first sample was drawn with the first chunk)
    track = SampledTrack(_Owner(server), "/sampled", (0, 150, 140), thickness=2.0, capacity=100, min_step=1e-6,
                         head_length=0.05, head_count=8)
    for j in (0, 1, 1, 3, 3, 4):  # (the clock skips sample 2 and stops at sample 3)
        track.follow("a", *first, j, circle[j])
    with server.atomic():
        track.draw()
    np.testing.assert_allclose(track.trail.points, first[0][:first[1][5]], atol=1e-6)
    track.follow("b", *second, 2, circle[7], previous=("a", *first))
    track.follow("b", *second, 2, circle[7], previous=("b", *second))
    expected = np.concatenate([first[0], second[0][:second[1][3]]])
    np.testing.assert_allclose(track.trail.points, expected, atol=1e-6)
    # the curve through the samples: each sample point on it, in order
    for q in circle[:8]:
        assert np.min(np.linalg.norm(track.trail.points - q, axis=1)) < 1e-6
    track.clear()
    assert track.trail.points.shape == (0, 3)
