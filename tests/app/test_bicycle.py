"""Bicycle scene (app/scenes/bicycle.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz; tests act as a browser does
(values and clicks through the gate with ``send_value`` / ``click``) and check
what the scene streams: the bodies' poses against the ride's lean, a push that
the bicycle recovers from at 5 m/s and one it falls after at 2 m/s, the modes
at the current speed against the paper's equations, the eigenvalue plot, the
CSV export, refused input and the shareable state. The chunk job and the plot
are also checked on their own (core's functions in tests/core).
"""

from __future__ import annotations

import concurrent.futures
import csv
import functools
import io
import math
import threading
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigidlab.app.scenes.bicycle import CSV_HEADER, PRESETS, BicycleScene, _ride_chunk, eigenvalue_svg
from rigidlab.core.models import MEIJAARD_2007_EIGENVALUES, whipple_bicycle_reference, whipple_modes_at, whipple_sweep
from rigidlab.core.multibody import RunState
from tests.helpers import click, send_value, wait_until

RECOVERED = math.radians(1.0)  # |lean| below this: recovered
FALLEN = 0.5  # rad: |lean| beyond this has fallen


@pytest.fixture
def bicycle(running_scene):
    return running_scene(BicycleScene)


def notices_with(app, text):
    return [n for n in app.session_for().notices if text in n[0] or text in n[1]]


def _window_leans(scene):
    t, columns = scene.history.window(0.0, scene.sim_time, max_points=100000)
    return t, np.radians(columns[:, 0]) if t.size else np.zeros(0)


def test_scene_is_registered_last():
    from rigidlab.app.scenes import discover_scenes

    scenes = discover_scenes()
    assert "bicycle" in scenes and BicycleScene.order == 90
    assert list(scenes)[-1] == "bicycle" or all(s.order <= 90 for s in scenes.values())


def test_first_ride_is_pushed_and_recovers(bicycle):
    app, scene = bicycle
    assert scene.pushes == 1  # the first ride starts with the slider's push
    wait_until(lambda: scene.sim_time > 7.0, timeout=120.0)
    t, lean = _window_leans(scene)
    assert np.max(np.abs(lean)) > math.radians(1.0)  # it did lean
    assert np.max(np.abs(lean)) < 0.2
    assert abs(scene.lean) < RECOVERED and not scene.ended


def test_body_poses_follow_the_ride(bicycle):
    app, scene = bicycle
    wait_until(lambda: scene.sim_time > 0.5, timeout=60.0)
    with app.session_for().run_lock:
        wxyz = np.array(scene.bodies[1].wxyz)
        lean = scene.lean
        center = scene.center.copy()
        world = np.array(scene.world.position)
    heading, roll, _ = Rotation.from_quat(wxyz, scalar_first=True).as_euler("ZXY")
    assert roll == pytest.approx(lean, abs=2e-3)  # the frame's lean about its heading (interpolated)
    np.testing.assert_allclose(world[:2], -center, atol=1e-5)  # the view follows the bicycle


def test_push_at_five_metres_a_second_recovers(bicycle):
    app, scene = bicycle
    # three times real time: the motion is the same (computed in chunks ahead of the clock), the wait shorter
    assert send_value(scene, "time_scale", 3.0)
    wait_until(lambda: scene.sim_time > 6.0, timeout=120.0)
    pushes = scene.pushes
    send_value(scene, "impulse", -60.0)
    click(scene, "push")
    wait_until(lambda: scene.pushes == pushes + 1, timeout=10.0)
    t_push = scene.segment.t0
    wait_until(lambda: scene.sim_time > t_push + 1.0, timeout=60.0)
    t, lean = _window_leans(scene)
    after = t > t_push
    assert np.min(lean[after]) < -math.radians(2.0)  # pushed to the left: it leans left
    wait_until(lambda: scene.sim_time > t_push + 8.0, timeout=120.0)
    t, lean = _window_leans(scene)
    after = t > t_push
    assert np.max(np.abs(lean[after])) < 0.25
    # the weave has died out, the capsize mode (-0.32 /s) decays
    assert abs(scene.lean) < 0.25 * np.max(np.abs(lean[after])) and not scene.ended


def test_push_at_two_metres_a_second_falls(bicycle):
    app, scene = bicycle
    send_value(scene, "speed", 2.0)
    wait_until(lambda: scene.config.speed == 2.0 and scene.sim_time > 1.0, timeout=60.0)
    click(scene, "push")  # a push from the state shown: a segment that starts at the clock's time
    wait_until(lambda: scene.ended, timeout=120.0)
    t, lean = _window_leans(scene)
    assert np.max(np.abs(lean)) > FALLEN
    assert notices_with(app, "The bicycle fell")
    t_fall = scene.sim_time
    # the fall is told at the time the clock shows (it was told in the segment's own time)
    assert scene.segment.index == 1 and scene.segment.t0 >= 1.0
    assert abs(float(scene.last_chunk.ride.end.rsplit("t = ", 1)[1].split()[0]) - t_fall) < 0.03
    wait_until(lambda: scene.frames > 0 and scene.sim_time == t_fall)  # the clock holds after the fall
    click(scene, "push")  # a push after the fall asks for a reset
    wait_until(lambda: notices_with(app, "has fallen"))
    click(scene, "playback", "Reset")
    wait_until(lambda: not scene.ended and scene.sim_time < t_fall, timeout=10.0)


def test_modes_at_the_current_speed_match_the_papers_equations(bicycle):
    app, scene = bicycle
    for speed in (5.0, 7.5):
        send_value(scene, "speed", speed)
        wait_until(lambda speed=speed: scene.modes is not None and scene.modes[0] == speed, timeout=120.0)
        rows = scene.modes[1]
        assert [m.name for m in rows] == ["weave", "weave", "capsize", "castering"]
        got = np.array(sorted((m.eigenvalue for m in rows), key=lambda s: (s.real, s.imag)))
        want = whipple_bicycle_reference().eigenvalues(speed)
        np.testing.assert_allclose(got, want, rtol=1e-9)
        # the table follows at the scene's next panel refresh
        wait_until(lambda speed=speed: f"Modes at {speed:.2f} m/s" in scene.modes_readout.content, timeout=10.0)
        assert "castering" in scene.modes_readout.content
    assert "×2 in" in scene.modes_readout.content  # capsize is unstable at 7.5 m/s
    wait_until(lambda: scene.sweep is not None and "<polyline" in scene.eigen_plot.content, timeout=120.0)
    np.testing.assert_allclose(scene.sweep.reference_stable_speeds, [MEIJAARD_2007_EIGENVALUES["weave_speed"],
                                                                     MEIJAARD_2007_EIGENVALUES["capsize_speed"]],
                               atol=1e-10)
    ET.fromstring(scene.eigen_plot.content)  # well-formed SVG


def test_presets_set_speed_and_push(bicycle):
    app, scene = bicycle
    for i, (name, (speed, impulse)) in enumerate(PRESETS.items()):
        click(scene, f"preset_{i}")
        wait_until(lambda speed=speed, impulse=impulse: scene.config.speed == speed
                   and scene.segment_push() == impulse and scene.segment.index == 0, timeout=10.0)
        assert scene.controls.value("speed") == speed


def test_reset_replays_the_start_of_the_ride(bicycle):
    """Reset rides again from t = 0 with the push the ride started with (before, always upright)."""
    app, scene = bicycle
    names = list(PRESETS)
    for i in (names.index("Self-stable: 5 m/s, push"), names.index("Upright at 5 m/s")):
        speed, impulse = PRESETS[names[i]]
        click(scene, f"preset_{i}")
        wait_until(lambda: scene.segment_push() == impulse and scene.segment.index == 0 and scene.sim_time > 0.3,
                   timeout=60.0)
        click(scene, "push")  # a later push starts a new segment; Reset goes back to the first one
        wait_until(lambda: scene.segment.index == 1, timeout=10.0)
        pushes = scene.pushes
        click(scene, "playback", "Reset")
        wait_until(lambda: scene.segment.index == 0, timeout=10.0)
        assert scene.segment_push() == impulse and scene.segment.t0 == 0.0
        assert scene.pushes == pushes + (1 if impulse else 0)
    send_value(scene, "speed", 6.0)  # a new speed rides upright
    wait_until(lambda: scene.config.speed == 6.0, timeout=10.0)
    click(scene, "playback", "Reset")
    wait_until(lambda: scene.segment.index == 0 and scene.sim_time < 0.2, timeout=10.0)
    assert scene.segment_push() == 0.0


def test_refused_speed_keeps_the_ride(bicycle):
    app, scene = bicycle
    before = scene.segment
    assert not send_value(scene, "speed", 25.0)
    assert not send_value(scene, "speed", math.nan)
    assert scene.controls.value("speed") == 5.0
    assert scene.segment == before
    assert scene.paused_error is None


def test_csv_export_and_state(bicycle):
    app, scene = bicycle
    wait_until(lambda: scene.sim_time > 1.5, timeout=60.0)
    text = scene.csv_bytes().decode()
    rows = list(csv.reader(io.StringIO(text)))
    assert ",".join(rows[0]) == CSV_HEADER
    data = np.array(rows[1:], dtype=float)
    assert data.shape[1] == 7 and data.shape[0] > 20
    assert np.all(np.diff(data[:, 0]) > 0)
    np.testing.assert_allclose(data[:, 6], 5.0, atol=0.2)  # the rear hub: 5 m/s and the lean's sway
    send_value(scene, "speed", 6.5)
    state = scene.state()
    assert state["values"]["speed"] == 6.5
    send_value(scene, "speed", 3.0)
    assert scene.load_state(state) == []
    wait_until(lambda: scene.config.speed == 6.5, timeout=10.0)


class _RecordingExecutor(concurrent.futures.Executor):
    """One worker thread that records what is submitted, in order (the name of the job's function)."""

    def __init__(self) -> None:
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=1)
        self._lock = threading.Lock()
        self.names: list[str] = []

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[no-untyped-def]
        inner = fn.func if isinstance(fn, functools.partial) else fn
        name = getattr(inner, "__name__", repr(inner))
        if name == "_ride_chunk":
            name = "chunk"
        with self._lock:
            self.names.append(name)
        return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)


def test_the_first_ride_goes_to_the_worker_before_the_curves_and_the_modes(make_bare_scene):
    """The first two chunks of the ride are the first jobs: the modes wait until the ride has its next chunk
    in hand, and the eigenvalues against speed after them; the modes still arrive (from the speed model)
    and agree with the paper's equations."""
    executor = _RecordingExecutor()
    scene, _ = make_bare_scene(BicycleScene, executor)

    def frames_until(condition, timeout=120.0):
        def step():
            scene.frame(1 / 60)
            return condition()
        wait_until(step, timeout=timeout, interval=1 / 60)

    frames_until(lambda: scene.modes is not None and scene.sweep is not None)
    names = list(executor.names)
    assert names[:2] == ["chunk", "chunk"], names
    assert names.index("whipple_modes_at") < names.index("whipple_sweep")
    assert scene.sim_time > 0.0
    got = np.array(sorted((m.eigenvalue for m in scene.modes[1]), key=lambda s: (s.real, s.imag)))
    np.testing.assert_allclose(got, whipple_bicycle_reference().eigenvalues(5.0), rtol=1e-9)  # as the test above


# ------------------------------------------------------------------ the job and the plot, on their own
def test_chunks_continue_and_a_push_starts_from_a_sample():
    chunks = [_ride_chunk(2.0, 0.0, None, 40.0, 0, None)]
    assert chunks[0].ride.lean[3] > 0  # pushed to the right: leans right
    while not chunks[-1].final and len(chunks) < 12:
        chunks.append(_ride_chunk(2.0, 0.0, None, 40.0, len(chunks), chunks[-1]))
    assert chunks[-1].final and ("left the ground" in chunks[-1].ride.end or "fell" in chunks[-1].ride.end)
    for a, b in zip(chunks, chunks[1:]):
        assert b.t[0] == a.t[-1]  # each chunk starts where the one before ended, from its final state
        np.testing.assert_allclose(b.ride.q[0], a.ride.q[-1], atol=1e-12)
    j = 10  # a segment from a displayed sample continues it (no jump), on the display clock
    c = chunks[0]
    cont = _ride_chunk(2.0, float(c.t[j]), RunState(c.t[j], c.ride.q[j], c.ride.v[j]), 0.0, 0, None)
    assert cont.t[0] == c.t[j]
    np.testing.assert_allclose(cont.ride.lean[0], c.ride.lean[j], atol=1e-12)
    np.testing.assert_allclose(cont.ride.steer[5], c.ride.steer[j + 5], atol=1e-4)
    assert c.table.columns.shape == (c.t.size, 6)


def test_eigenvalue_plot():
    sweep = whipple_sweep(np.linspace(0.0, 10.0, 41))
    svg = eigenvalue_svg(sweep, (5.0, whipple_modes_at(5.0)))
    root = ET.fromstring(svg)
    assert root.tag.endswith("svg") and "self-stable" in svg
    assert svg.count("<circle") >= 21 * 4
    sizes = [float(e.get("font-size")) for e in root.iter() if e.get("font-size")]
    assert min(sizes) >= 14.0  # px of the 340-px drawing (the panel is about as wide): readable
    assert "<circle" not in eigenvalue_svg(None, None)
