"""A track drawn up to a moving body reaches it in every frame a slow page draws.

viser 1.1.1's page draws a node's pose and visibility in the frame that
handles them, but new line points only in the frame after (the line's
geometry is rebuilt by a React render that runs after the frame is drawn);
measured in headless Chromium at 1-4 fps, a track head whose points were
sent every frame ended 0.1-1.3 m behind the rolling disk's contact point.
:func:`page_frames` replays what a recorder received as such a page draws
it, every ``every`` server frames; the tests check the drawn track against
the contact point drawn in the same page frame.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from rigidlab.app.scenes._trail import StickHead
from rigidlab.app.scenes.rolling_disk import RollingDiskScene
from rigidlab.core.rotations import matrix_from_euler_parameters
from tests.app._wire import Recorder
from tests.helpers import click, wait_until

_POSE = {"SetPositionMessage": "position", "SetOrientationMessage": "wxyz"}


def page_frames(messages: list[dict], boundary: str, travel: float):
    """``(i, nodes)``: node states ``{name: {"points", "position", "wxyz", "visible"}}`` as a page
    draws them before message ``i``.

    A page frame is drawn before the ``SetPositionMessage`` of the node ``boundary`` (one per server
    frame while it moves) that has moved it by ``travel`` or more since the page frame before:
    poses and visibility as received up to there, line points as received up to the page frame
    before. (Counted in motion, not in server frames: a loaded server draws fewer frames of more
    motion each, and a page at a given frame rate sees the same motion between its frames.)
    """
    nodes: dict[str, dict] = {}
    late: list[tuple[str, np.ndarray]] = []  # points received since the last page frame
    drawn_at = None
    for i, message in enumerate(messages):
        kind, name = message.get("type", ""), message.get("name")
        if kind == "SetPositionMessage" and name == boundary:
            position = np.asarray(message["position"], dtype=float)
            if drawn_at is None or np.linalg.norm(position - drawn_at) >= travel:
                drawn_at = position
                yield i, nodes
                for node, points in late:
                    if node in nodes:
                        nodes[node]["points"] = points
                late = []
        if kind == "LineSegmentsMessage":
            nodes[name] = {"points": np.asarray(message["props"]["points"], dtype=float).reshape(-1, 2, 3),
                           "position": np.zeros(3), "wxyz": np.array([1.0, 0.0, 0.0, 0.0]), "visible": True}
        elif isinstance(message.get("props"), dict) and isinstance(name, str) and not kind.startswith("Gui"):
            nodes[name] = {"points": None, "position": np.zeros(3), "wxyz": np.array([1.0, 0.0, 0.0, 0.0]),
                           "visible": True}
        elif kind in _POSE and name in nodes:
            nodes[name][_POSE[kind]] = np.asarray(message[_POSE[kind]], dtype=float)
        elif kind == "SetSceneNodeVisibilityMessage" and name in nodes:
            nodes[name]["visible"] = bool(message["visible"])
        elif kind == "SceneNodeUpdateMessage" and "points" in message.get("updates", {}):
            late.append((name, np.asarray(message["updates"]["points"], dtype=float).reshape(-1, 2, 3)))


def drawn_segments(nodes: dict[str, dict], under: str) -> np.ndarray:
    """(n, 2, 3) the visible line segments of the nodes under ``under`` (posed; in ``under``'s parent
    frame, whose own pose is the identity; segments out of sight left out)."""
    out = []
    for name, node in nodes.items():
        if not name.startswith(under) or node["points"] is None:
            continue
        path = name.split("/")
        if not all(nodes.get("/".join(path[:i]), {}).get("visible", True) for i in range(2, len(path) + 1)):
            continue
        A = matrix_from_euler_parameters(node["wxyz"] / np.linalg.norm(node["wxyz"]))
        segments = node["points"] @ A.T + node["position"]
        out.append(segments[np.all(np.abs(segments) < 1000.0, axis=(1, 2))])
    return np.concatenate(out) if out else np.zeros((0, 2, 3))


def distance_to_segments(p: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance from each point ``p`` (m, 3) to the nearest of ``segments`` (n, 2, 3)."""
    a, b = segments[None, :, 0], segments[None, :, 1]
    ab = b - a
    t = np.clip(np.einsum("mnk,mnk->mn", p[:, None] - a, ab) / np.maximum(np.einsum("mnk,mnk->mn", ab, ab),
                                                                          1e-300), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p[:, None], axis=2).min(axis=1)


def path_behind(path: np.ndarray, point: np.ndarray, length: float, step: float) -> np.ndarray:
    """Points every ``step`` along the polyline ``path`` (n, 3) from its point nearest ``point``
    back by ``length`` (or to its start)."""
    j = int(np.argmin(np.linalg.norm(path - point, axis=1)))
    piece = path[:j + 1][::-1]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(piece, axis=0), axis=1))])
    want = np.arange(0.0, min(length, s[-1]), step)
    return np.column_stack([np.interp(want, s, piece[:, i]) for i in range(3)])


# -- StickHead on its own ---------------------------------------------------------------------------


class _Owner:
    def __init__(self, server) -> None:
        self.target = server

    def add_lines(self, name, points, colors, *, thickness, **kwargs):
        return self.target.scene.add_line_segments(name, points, colors, thickness=thickness, **kwargs)


def test_sticks_are_equal_chords_of_the_curve_ending_at_its_newest_point(server) -> None:
    head = StickHead(_Owner(server), "/stick_chords", (0, 150, 140), thickness=2.0, length=0.05, count=40)
    u = np.linspace(0.0, 6.0, 601)  # a helix of radius 0.5 m, 3 m long, points 5 mm apart
    points = np.column_stack([0.5 * np.cos(u), 0.5 * np.sin(u), 0.02 * u])
    for p in points:
        head.add(p)
    with server.atomic():
        head.draw()
    segments = head.segments
    chords, tip = segments[:-1], segments[-1]
    assert chords.shape[0] == 40  # the ring is full: its newest 40 chords, 2 m
    np.testing.assert_allclose(np.linalg.norm(chords[:, 1] - chords[:, 0], axis=1), 0.05, rtol=1e-12)
    np.testing.assert_allclose(chords[1:, 0], chords[:-1, 1], atol=1e-12)  # a chain, no gaps
    # every end on the curve as fed (the polyline through the points)
    assert distance_to_segments(chords.reshape(-1, 3), np.stack([points[:-1], points[1:]], axis=1)).max() < 1e-9
    # the tip starts at the newest point and points back along the newest chord, over the gap to its end
    # (less than a stick away); on this curve (radius 0.5 m, 5 cm sticks) it passes that end within
    # length^2 / R = 5 mm
    np.testing.assert_allclose(tip[0], points[-1])
    gap = chords[-1, 1] - points[-1]
    assert np.linalg.norm(gap) < 0.05
    np.testing.assert_allclose(tip[1] - tip[0], chords[-1, 0] - chords[-1, 1], atol=1e-12)
    assert distance_to_segments(chords[-1, 1][None], tip[None])[0] < 0.05 ** 2 / 0.5
    # the nodes as posed draw the same sticks: each holds the segment 0..length along its z
    for node, chord in zip(sorted(head.nodes, key=lambda n: n.name), chords[np.argsort(
            [(head._next + i) % head.count for i in range(head.count)])]):
        A = matrix_from_euler_parameters(np.array(node.wxyz))
        np.testing.assert_allclose(np.array(node.points)[0] @ A.T + np.array(node.position), chord, atol=1e-6)


def test_after_creation_the_head_sends_only_poses_and_visibility(server) -> None:
    recorder = Recorder(f"ws://127.0.0.1:{server.get_port()}")
    try:
        head = StickHead(_Owner(server), "/stick_poses", (0, 150, 140), thickness=2.0, length=0.02, count=16)
        for i in range(300):  # a point per frame, each frame drawn
            head.add(np.array([0.004 * i, 0.1 * math.sin(0.02 * i), 0.0]))
            with server.atomic():
                head.draw()
            time.sleep(0.001)
        head.clear()
        with server.atomic():
            head.draw()
        wait_until(lambda: any(m.get("type") == "SetSceneNodeVisibilityMessage" and m["name"] == "/stick_poses/tip"
                               and not m["visible"] for m, _ in recorder.received()))
        kinds = {m["type"] for m, _ in recorder.received() if str(m.get("name", "")).startswith("/stick_poses/")
                 and m["type"] != "LineSegmentsMessage"}
        assert kinds <= {"SetPositionMessage", "SetOrientationMessage", "SetSceneNodeVisibilityMessage"}
        assert not any(node.visible for node in (*head.nodes, head.tip))  # cleared: all hidden
    finally:
        recorder.close()


# -- the rolling disk as a page at 3 fps draws it ------------------------------------------------------


def test_the_disk_track_reaches_the_contact_point_in_every_page_frame(running_scene, monkeypatch) -> None:
    """Every server frame sends a plot or the readout (refreshed as often as frames come), as on a server whose
    frames are 50 ms or more apart: every frame holds the track's ring back (``draw(hold=True)``), however
    loaded the machine is; the track must still reach back along the whole run."""
    monkeypatch.setattr(RollingDiskScene, "refresh_period", 0.0)
    app, scene = running_scene(RollingDiskScene)
    recorder = Recorder(app.url)
    try:
        # the default motion first goes half a metre from the origin, where the preset's run starts
        wait_until(lambda: np.linalg.norm(scene.centre[:2]) > 0.5, timeout=120.0)
        click(scene, "preset_0")  # upright, twice the critical spin: it rolls away at 1.14 m/s
        wait_until(lambda: scene.model is not None and math.isclose(scene.model.lean, math.radians(1.0))
                   and scene.drawn_model == scene.model and scene.sim_time > 0.1, timeout=120.0)
        ground_name = f"{scene.root}/ground"
        # the preset's run is on the page from the first ground pose near the origin (the recorder receives the
        # frames drawn before the preset a while after them on a loaded machine: counting messages is not enough;
        # viser may replace an unsent pose by a newer one, so no one pose is sure to arrive)
        start: list[int] = []

        def preset_reached() -> bool:
            for i, (m, _) in enumerate(recorder.received()):
                if (m.get("type") == "SetPositionMessage" and m.get("name") == ground_name
                        and np.linalg.norm(np.asarray(m["position"], dtype=float)[:2]) < 0.25):
                    start.append(i)
                    return True
            return False

        wait_until(preset_reached, timeout=120.0)
        wait_until(lambda: scene.sim_time > 3.0, timeout=120.0)
        with app.session_for().run_lock:
            path = np.array(scene.track_points, dtype=float)  # the whole run so far (1000 segments of >= 2 mm)
            root = scene.root
        messages = [m for m, _ in recorder.received()]
    finally:
        recorder.close()
    ground = f"{root}/ground"
    checked = 0
    # a page frame every 0.38 m of motion: the page at 3 fps at the disk's 1.14 m/s, whatever the server's rate
    for i, nodes in page_frames(messages, ground, travel=0.38):
        point = nodes[f"{ground}/point"]["position"]  # the dot's pose: on the ground, lifted as the track
        if i <= start[0] or np.linalg.norm(point[:2]) < 0.5:
            continue  # before the preset's run has gone half a metre (the page frame drawn before its first
            # pose is not of it: viser may have replaced the poses of the frame that cleared the track by newer
            # ones, sent after that frame's visibility messages)
        segments = drawn_segments(nodes, f"{ground}/track")
        # the drawn track ends at the contact point drawn in the same page frame
        end = distance_to_segments(point[None], segments)[0]
        assert end < 1e-4, f"the track drawn ends {end:.3f} m from the contact point"
        # and runs back from it without a gap, along the path the contact point took since the preset (3.4 m:
        # farther than the head's sticks reach, 1.92 m)
        behind = path_behind(path, point, 10.0, 0.01)
        gap = distance_to_segments(behind, segments)
        assert gap.max() < 2e-3, f"no track drawn {0.01 * np.argmax(gap >= 2e-3):.2f} m behind the contact point"
        checked += 1
    assert checked >= 5


def test_headed_trail_feeds_both_and_hides_both(server) -> None:
    """HeadedTrail (the bicycle's wheel tracks): one point feeds the line ring and the sticks; hidden, neither
    shows; the ring's newest chunk is sent at most once per period; clear empties both."""
    from rigidlab.app.scenes._trail import HeadedTrail

    track = HeadedTrail(_Owner(server), "/headed", (0, 150, 140), thickness=2.0, capacity=64, min_step=0.01,
                        length=0.05, count=8, period=3600.0)
    for x in np.linspace(0.0, 1.0, 101):
        track.add((x, 0.0, 0.0))
    with server.atomic():
        track.draw(True)
    assert track.trail.visible and track.head.visible
    assert not track.trail.pending  # sent at the first draw
    np.testing.assert_allclose(track.head.segments[-1][0], (1.0, 0.0, 0.0), atol=1e-12)  # the tip at the newest
    track.add((1.1, 0.0, 0.0))
    with server.atomic():
        track.draw(True)
    assert track.trail.pending  # within the period: not sent again
    with server.atomic():
        track.draw(False)
    assert not track.trail.visible and not track.head.visible
    track.clear()
    assert track.trail.points.shape[0] == 0


def test_a_held_frame_sends_no_track_buffer_and_the_next_frame_does(server) -> None:
    """HeadedTrail and SampledTrack: ``draw(hold=True)`` (a frame that sends a plot) moves the head but keeps
    the ring's newest chunk for the next frame that is not held (the stretch held back, 1 m, is shorter than
    half the head's reach, 2.4 m)."""
    from rigidlab.app.scenes._trail import HeadedTrail, SampledTrack, sampled_curve

    headed = HeadedTrail(_Owner(server), "/held", (0, 150, 140), thickness=2.0, capacity=64, min_step=0.01,
                         length=0.3, count=8, period=0.0)
    for x in np.linspace(0.0, 1.0, 51):
        headed.add((x, 0.0, 0.0))
    with server.atomic():
        headed.draw(True, hold=True)
    assert headed.trail.pending
    np.testing.assert_allclose(headed.head.segments[-1][0], (1.0, 0.0, 0.0), atol=1e-12)  # the head moved
    with server.atomic():
        headed.draw(True)
    assert not headed.trail.pending

    u = np.linspace(0.0, 1.0, 11)
    curve = sampled_curve(u, np.column_stack([u, np.zeros_like(u), np.zeros_like(u)]))
    sampled = SampledTrack(_Owner(server), "/held_sampled", (0, 150, 140), thickness=2.0, capacity=100,
                           min_step=1e-6, head_length=0.3, head_count=8, period=0.0)
    sampled.follow("a", *curve, 10, (1.0, 0.0, 0.0))
    with server.atomic():
        sampled.draw(hold=True)
    assert sampled.trail.pending
    with server.atomic():
        sampled.draw()
    assert not sampled.trail.pending


def _posed_segments(ring, head) -> np.ndarray:
    """(n, 2, 3) the segments of a track's visible nodes as sent: the ring's chunk nodes (``ring``: their
    (points, visible) when the page draws them) and the head's sticks placed by their poses."""
    out = [points[np.all(np.abs(points) < 1000.0, axis=(1, 2))] for points, visible in ring if visible]
    for node in (*head.nodes, head.tip):
        if node.visible:
            A = matrix_from_euler_parameters(np.array(node.wxyz))
            out.append(np.array(node.points, dtype=float) @ A.T + np.array(node.position))
    return np.concatenate(out) if out else np.zeros((0, 2, 3))


@pytest.mark.parametrize("kind", ["SampledTrack", "HeadedTrail"])
def test_a_track_held_in_every_frame_reaches_back_along_its_whole_path(server, kind) -> None:
    """A server whose frames are 50 ms or more apart sends a plot or the readout in every frame (the rolling
    disk's five, one a frame, each every 0.25 s), so every frame holds the ring's chunk back (``draw(hold=True)``); the ring must still be
    sent before the stretch it holds back outruns the head: the drawn track runs back from the point along
    its whole path in every page frame. (The rolling disk's track: sticks of 3 cm, 64 of them, a point every
    19 mm, 3 points a server frame, a page frame every 7 server frames: 0.4 m, a page at 3 fps.)"""
    from rigidlab.app.scenes._trail import HeadedTrail, SampledTrack, sampled_curve

    u = np.arange(320) * 0.019 / 1.5  # 6 m of a circle of radius 1.5 m
    path = np.column_stack([1.5 * np.sin(u), 1.5 * (1.0 - np.cos(u)), np.full_like(u, 0.0015)])
    options = dict(thickness=2.0, capacity=1000, min_step=0.002, period=0.0)
    if kind == "SampledTrack":
        track = SampledTrack(_Owner(server), "/held_always_sampled", (0, 150, 140), head_length=0.03,
                             head_count=64, **options)
        curve = sampled_curve(u, path)
    else:
        track = HeadedTrail(_Owner(server), "/held_always_headed", (0, 150, 140), length=0.03, count=64, **options)
    ring, head = track.trail, track.head
    page_ring: list[tuple[np.ndarray, bool]] = []  # the ring as the page draws it: points a page frame late
    checked = 0
    for frame, j in enumerate(range(2, path.shape[0], 3)):
        with server.atomic():
            if kind == "SampledTrack":
                track.follow("chunk", *curve, j, path[j])
                track.draw(hold=True)
            else:
                for point in path[j - 2:j + 1]:
                    track.add(point)
                track.draw(True, hold=True)
        if frame % 7:
            continue
        segments = _posed_segments(page_ring, head)
        assert distance_to_segments(path[j][None], segments)[0] < 1e-4  # the track ends at the point
        behind = path_behind(path[:j + 1], path[j], 10.0, 0.01)  # back to the path's start
        gap = distance_to_segments(behind, segments)
        assert gap.max() < 2e-3, f"no track drawn {0.01 * np.argmax(gap >= 2e-3):.2f} m behind the point"
        page_ring = [(np.array(node.points, dtype=float), bool(node.visible)) for node in ring.nodes]
        checked += 1
    assert checked >= 10
    assert ring.unsent_length < 0.5 * head.reach
