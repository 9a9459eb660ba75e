"""Linkages scene (app/scenes/linkages.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz; tests act as a browser
does (values through the gate with ``send_value``) and check what the scene
streams: the number of links drawn, the motion, the constraint residual
against the bound the projection guarantees, the presets against closed
forms, the reaction arrows of a hanging chain against statics, the chunks
computed in worker processes, refused input, the CSV export and the state
round trip. A few tests build the scene on a bare server and drive
``frame`` themselves (the clock holding while a chunk is computed, framing
and labels at the default view).
"""

from __future__ import annotations

import csv
import io
import math
import os

import numpy as np
import pytest

from rigidlab.app.scenes._playback import MAX_SIM_STEP
from rigidlab.app.scenes.linkages import (
    CHAIN,
    CRANK,
    DOUBLE,
    METHODS,
    POSITION_TOL,
    PRESETS,
    RESIDUAL_BOUND,
    TOP,
    Inputs,
    LinkagesScene,
    Model,
    _compute_chunk,
)
from rigidlab.core.models import pendulum_chain
from tests.app._views import Camera, drawn_instances, label_box, overlapping_pairs
from tests.app.conftest import GatedExecutor
from tests.helpers import click, send_value, wait_for_frames, wait_until


@pytest.fixture
def linkages(running_scene):
    return running_scene(LinkagesScene)


def notices_with(app, text):
    return [n for n in app.session_for().notices if text in n[0] or text in n[1]]


def wait_for_model(scene, timeout=30.0, **fields):
    """Wait until the model drawn has ``fields`` and has run for 0.2 s."""
    wait_until(lambda: scene.setup is not None
               and all(getattr(scene.setup.model, k) == v for k, v in fields.items())
               and scene.sim_time > 0.2, timeout=timeout)


def test_scene_is_registered_after_the_gyroscope():
    from rigidlab.app.scenes import discover_scenes

    scenes = discover_scenes()
    assert "linkages" in scenes and LinkagesScene.order == 50
    assert list(scenes).index("linkages") == list(scenes).index("gyroscope") + 1
    # the integrators offered are exactly those simulate accepts
    from rigidlab.core.multibody import ADAPTIVE_METHODS, FIXED_STEP_METHODS

    assert set(METHODS) == set(ADAPTIVE_METHODS) | set(FIXED_STEP_METHODS)


def test_moving_n_changes_the_number_of_visible_links(linkages):
    app, scene = linkages
    wait_for_model(scene, preset=CHAIN)
    assert drawn_instances(scene.parts.rods) == Inputs().n_links
    for n in (1, 8, 10, 3):
        assert send_value(scene, "n_links", n)
        wait_until(lambda: scene.setup.model.n_links == n and drawn_instances(scene.parts.rods) == n, timeout=30.0)
        with app.session_for().run_lock:
            scales = np.asarray(scene.parts.rods.batched_scales)
            joint_scales = np.asarray(scene.parts.balls.batched_scales)
        # n rods of length 2 m / n, the others drawn at scale zero; one joint per link
        np.testing.assert_allclose(scales[:n, 2], 2.0 / n, rtol=1e-6)
        assert np.all(scales[n:] == 0.0)
        assert np.count_nonzero(joint_scales) == n
        assert scene.setup.info.n_bodies == n and scene.setup.info.degrees_of_freedom == n  # n revolute joints in a chain


def test_play_advances_the_chain_and_pause_holds_it(linkages):
    app, scene = linkages
    wait_for_model(scene, preset=CHAIN)
    with app.session_for().run_lock:
        before = np.array(scene.parts.rods.batched_positions)
        t_before = scene.sim_time
    wait_until(lambda: scene.sim_time > t_before + 0.3)
    with app.session_for().run_lock:
        after = np.array(scene.parts.rods.batched_positions)
    # released from a tilt, the links swing: their centres move (m)
    assert np.abs(after - before).max() > 0.01
    click(scene, "playback", "Pause")
    wait_until(lambda: not scene.playing)
    wait_for_frames(scene, 2)
    t_paused = scene.sim_time
    with app.session_for().run_lock:
        paused = np.array(scene.parts.rods.batched_positions)
    wait_for_frames(scene, 20)
    assert scene.sim_time == t_paused
    np.testing.assert_array_equal(np.asarray(scene.parts.rods.batched_positions), paused)
    click(scene, "playback", "Play")
    wait_until(lambda: scene.sim_time > t_paused + 0.1)


@pytest.mark.parametrize("values", [
    {"preset": CHAIN, "n_links": 10, "tilt_deg": 120.0},
    {"preset": CHAIN, "method": "RK45", "rtol": "1e-3"},
    {"preset": DOUBLE, "method": "rk4", "dt": "1/60"},
    {"preset": CRANK, "rpm": 300.0},
    {"preset": TOP},
])
def test_residual_stays_below_the_bound_of_the_projection(running_app, values):
    """Projection after every step and at every output (Newton to max |C| <=
    1e-12, stopped early only at its round-off floor, below 1e-8, else an
    error): no sample shown has max |C| > RESIDUAL_BOUND = 1e-8, even at a
    loose tolerance or with a coarse fixed step."""
    app = running_app(scene="linkages")
    scene = app.scene_for()
    assert send_value(scene, "time_scale", 4.0)
    for key, value in values.items():
        assert send_value(scene, key, value)
    wait_until(lambda: scene.setup is not None and scene.setup.model == Model.from_inputs(scene.inputs)
               and scene.sim_time > 4.0, timeout=60.0)
    wait_until(lambda: scene.plot_handles["residual"].data[0].size > 50)
    with app.session_for().run_lock:
        t, logs, bound, tol = (np.asarray(a) for a in scene.plot_handles["residual"].data)
        chunk = scene.last_chunk
        max_residual = scene.max_residual
    assert scene.timeline.error is None and scene.paused_error is None
    assert np.all(logs < math.log10(RESIDUAL_BOUND))
    np.testing.assert_allclose(bound, -8.0) and np.testing.assert_allclose(tol, math.log10(POSITION_TOL))
    assert 0.0 <= max_residual < RESIDUAL_BOUND
    assert chunk.motion.residual.max() < RESIDUAL_BOUND
    # in practice the projection lands at its Newton tolerance or below
    assert chunk.motion.residual.max() <= 10 * POSITION_TOL


def test_presets_match_their_closed_forms_and_show_their_parts(linkages):
    app, scene = linkages
    for preset in PRESETS:
        assert send_value(scene, "preset", preset)
        wait_for_model(scene, preset=preset)
        wait_until(lambda: scene.sim_time > 1.2)
        setup = scene.setup
        with app.session_for().run_lock:
            slider_shown, top_shown, ghost_shown = scene.slider.visible, scene.top.visible, scene.ghost_pivot.visible
            chunk = scene.last_chunk
            rpm_shown = scene.controls.handles["rpm"].visible
            n_shown = scene.controls.handles["n_links"].visible
        assert slider_shown == (preset == CRANK)
        assert top_shown == ghost_shown == (preset == TOP)
        assert rpm_shown == (preset == CRANK) and n_shown == (preset == CHAIN)
        assert drawn_instances(scene.parts.rods) == {CHAIN: 5, DOUBLE: 2, CRANK: 2, TOP: 0}[preset]
        if preset == CRANK:
            # the slider follows r cos(phi) + sqrt(l^2 - r^2 sin^2 phi), phi = 2 pi t at 60 rpm
            assert setup.info.degrees_of_freedom == 0 and setup.info.motor and not setup.info.conserved
            assert np.abs(chunk.motion.difference).max() < 1e-9
        elif preset == TOP:
            # the multibody top against core.gyroscope's closed form (rtol 1e-6)
            assert np.abs(chunk.motion.difference).max() < 1e-5
            assert setup.info.n_bodies == 1 and setup.info.degrees_of_freedom == 3
        else:
            assert chunk.motion.difference is None
        if setup.info.conserved:
            # DOP853 at rtol 1e-6: the energy drifts by far less than a millijoule
            assert abs(float(chunk.motion.energy[-1]) - setup.energy0) < 1e-3
    assert not notices_with(app, "stopped")


def test_reaction_arrows_of_a_hanging_chain_carry_the_weight_below(linkages):
    app, scene = linkages
    assert send_value(scene, "tilt_deg", 0.0)  # hanging at rest: statics
    assert send_value(scene, "n_links", 4)
    wait_for_model(scene, n_links=4, tilt=0.0)
    with app.session_for().run_lock:
        points = np.asarray(scene.force_arrows.points, dtype=float)
        shown = scene.force_arrows.visible
        setup = scene.setup
        chunk = scene.last_chunk
        forces = np.linalg.norm(chunk.motion.joint_forces[scene.sample_index(chunk)], axis=1)  # at the sample drawn
    assert shown and points.shape == (4, 2, 3)
    weight = 9.81  # N per 1 kg link
    # joint k holds the 4 - k links below it: a force straight up on link k
    np.testing.assert_allclose(forces, weight * np.array([4, 3, 2, 1]), rtol=1e-6)
    direction = points[:, 1] - points[:, 0]
    lengths = np.linalg.norm(direction, axis=1)
    np.testing.assert_allclose(direction[:, :2], 0.0, atol=1e-5)
    assert np.all(direction[:, 2] > 0)
    expected = setup.arrow_max * forces / (forces + setup.info.weight)
    np.testing.assert_allclose(lengths, expected, rtol=1e-5)
    # the arrows start at the joints: the top one at the pivot
    np.testing.assert_allclose(points[0, 0], 0.0, atol=1e-6)
    np.testing.assert_allclose(points[1:, 0, 2], -0.5 * np.arange(1, 4), atol=1e-6)
    # the toggle hides them
    assert send_value(scene, "show_forces", False)
    wait_until(lambda: not scene.force_arrows.visible)


def test_chunks_are_computed_in_worker_processes_in_order(linkages):
    app, scene = linkages
    wait_until(lambda: scene.last_chunk is not None and scene.last_chunk.k >= 1, timeout=30.0)
    chunk = scene.last_chunk
    # the app's executor is a pool of processes: never the loop's process
    assert chunk.worker != os.getpid()
    assert scene.timeline.sequential  # each chunk continues from the previous one
    assert chunk.cpu_seconds > 0.0 and chunk.motion.n_steps > 0
    # chunk k + 1 starts where chunk k ends
    k = chunk.k
    with app.session_for().run_lock:
        previous = scene.timeline._chunks.get(k - 1)
    if previous is not None:
        np.testing.assert_array_equal(chunk.t[0], previous.t[-1])
        np.testing.assert_allclose(chunk.motion.R[0], previous.motion.R[-1], atol=1e-12)
        np.testing.assert_allclose(chunk.motion.p[0], previous.motion.p[-1], atol=1e-12)


@pytest.mark.parametrize(("key", "raw"), [
    ("n_links", 11), ("n_links", 2.5), ("n_links", math.nan), ("tilt_deg", 1e308), ("rpm", -1e6),
    ("method", "Radau"), ("rtol", "1e-20"), ("dt", 0.01), ("preset", "Four-bar"), ("time_scale", 1e6),
    ("show_forces", "yes"),
])
def test_refused_values_get_a_notice_and_never_reach_the_scene(linkages, key, raw):
    app, scene = linkages
    wait_for_model(scene)
    before = scene.controls.value(key)
    model = scene.model
    assert not send_value(scene, key, raw)
    assert scene.controls.value(key) == before
    assert scene.controls.handles[key].value == before
    label = scene.controls.specs[key].label
    wait_until(lambda: notices_with(app, f"Refused: {label}"))
    assert scene.model is model
    t0 = scene.sim_time
    wait_until(lambda: scene.sim_time > t0 + 0.05)
    assert scene.paused_error is None


def test_a_failing_integration_stops_the_clock_with_a_notice(linkages):
    app, scene = linkages
    # implicit midpoint at the coarsest step cannot follow a chain falling from 170 deg
    for key, value in (("n_links", 10), ("tilt_deg", 170.0), ("method", "midpoint"), ("dt", "1/60")):
        assert send_value(scene, key, value)
    wait_until(lambda: notices_with(app, "motion stopped"), timeout=60.0)
    assert notices_with(app, "fixed-point iteration did not converge")
    assert scene.paused_error is None and not scene.playing
    with app.session_for().run_lock:
        assert np.all(np.isfinite(np.asarray(scene.parts.rods.batched_positions)))
    # another integrator runs again
    assert send_value(scene, "method", "DOP853")
    click(scene, "playback", "Play")
    wait_until(lambda: scene.model.method == "DOP853" and scene.sim_time > 0.3, timeout=30.0)


def test_csv_export_is_the_motion_shown(linkages):
    app, scene = linkages
    assert send_value(scene, "time_scale", 4.0)
    wait_until(lambda: scene.sim_time > 2.5, timeout=30.0)
    click(scene, "download_csv")  # served by the loop (sent to the browser that clicked)
    with app.session_for().run_lock:
        content = scene.csv_bytes()
        sim_time = scene.sim_time
        header = scene.csv_header_for(scene.config)
    rows = list(csv.reader(io.StringIO(content.decode())))
    assert ",".join(rows[0]) == header
    assert rows[0][:4] == ["t (s)", "link0 x (m)", "link0 y (m)", "link0 z (m)"]
    assert rows[0][-2:] == ["E (J)", "max |C|"]
    data = np.array(rows[1:], dtype=float)
    t = data[:, 0]
    assert t[0] == 0.0 and sim_time - 1 / 60 - 1e-9 <= t[-1] <= sim_time
    np.testing.assert_allclose(np.diff(t), 1 / 60, rtol=1e-9)  # each sample once, in order
    # the first second is core's simulation of the same chain, sample for sample
    system = pendulum_chain(5, 0.4, 1.0, "rod", tilt=math.radians(60.0))
    traj = system.simulate(np.linspace(0.0, 1.0, 61), method="DOP853", rtol=1e-6, atol=1e-8)
    first = data[:61]
    n = 5
    np.testing.assert_allclose(first[:, 1:1 + 7 * n].reshape(61, n, 7)[:, :, :3],
                               traj.q[:, : 3 * n].reshape(61, n, 3), atol=1e-12)
    np.testing.assert_allclose(first[:, 1 + 7 * n], traj.energy, rtol=1e-12)
    assert np.all(data[:, 2 + 7 * n] < RESIDUAL_BOUND)


def test_state_round_trip_reproduces_the_motion(running_app):
    first = running_app(scene="linkages")
    scene = first.scene_for()
    for key, value in (("preset", CRANK), ("rpm", 120.0), ("method", "RK45"), ("rtol", "1e-8"),
                       ("time_scale", 2.5), ("show_forces", False)):
        assert send_value(scene, key, value)
    wait_until(lambda: scene.setup is not None and scene.setup.model.preset == CRANK and scene.sim_time > 1.0,
               timeout=30.0)
    state = scene.state()
    assert state["scene"] == "linkages"
    assert state["values"]["preset"] == CRANK and state["values"]["rpm"] == 120.0
    assert state["values"]["method"] == "RK45" and state["values"]["rtol"] == "1e-8"
    assert state["values"]["time_scale"] == 2.5 and state["values"]["show_forces"] is False

    click(scene, "playback", "Pause")  # the first motion holds while the second app starts, however slowly
    wait_until(lambda: not scene.playing)

    second = running_app(scene="linkages")
    other = second.scene_for()
    wait_until(lambda: other.sim_time > 0.5, timeout=60.0)
    second.session_for().request_state(state)
    wait_until(lambda: other.model == scene.model and other.setup is not None
               and other.setup.model == scene.model and other.sim_time > 0.5, timeout=60.0)
    assert other.playback.time_scale == 2.5 and not other.force_arrows.visible
    # the same inputs give the same motion, sample for sample: the rows of the times both windows hold
    with first.session_for().run_lock:
        rows_first = scene.csv_bytes().decode().splitlines()
    with second.session_for().run_lock:
        rows_second = other.csv_bytes().decode().splitlines()
    assert rows_first[0] == rows_second[0]
    by_time = {row.split(",", 1)[0]: row for row in rows_first[1:]}
    common = [row for row in rows_second[1:] if row.split(",", 1)[0] in by_time]
    assert len(common) > 20
    assert all(by_time[row.split(",", 1)[0]] == row for row in common)
    # a state with a refused value: the other values apply, a notice lists the refusal
    bad = dict(state, values=dict(state["values"], n_links=99, rpm=-60.0))
    second.session_for().request_state(bad)
    wait_until(lambda: other.model.speed == pytest.approx(-2 * math.pi))
    assert other.controls.value("n_links") == Inputs().n_links


def test_per_client_sessions_are_isolated(per_client_scenes):
    _, [(_, a), (_, b)] = per_client_scenes(LinkagesScene)
    wait_until(lambda: a.model is not None and b.model is not None)
    assert send_value(a, "preset", TOP)
    wait_until(lambda: a.model.preset == TOP)
    wait_for_frames(b, 12)
    assert b.model.preset == CHAIN


def test_the_job_continues_from_the_previous_chunk_and_refuses_a_gap():
    model = Model.from_inputs(Inputs(preset=DOUBLE))
    c0 = _compute_chunk(model, 0, None)
    c1 = _compute_chunk(model, 1, c0)
    assert c1.t[0] == c0.t[-1] == 1.0
    # the same state: the run's start only normalizes the Euler parameters again (a few ulps, as the machine rounds)
    np.testing.assert_allclose(c1.motion.R[0], c0.motion.R[-1], rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(c1.motion.p[0], c0.motion.p[-1], rtol=0.0, atol=1e-15)
    assert abs(float(c1.motion.energy[-1]) - c0.energy0) < 1e-4
    with pytest.raises(ValueError, match="previous: chunk 2 continues from chunk 1, which was not given"):
        _compute_chunk(model, 2, c0)
    with pytest.raises(ValueError, match=r"preset: expected one of \["):
        Model.from_inputs(Inputs(preset="Four-bar"))


# -- a scene on a bare server, driven frame by frame ----------------------------
@pytest.fixture
def bare_scene(make_bare_scene):
    """``bare_scene(executor=None) -> (scene, notices)``: a LinkagesScene on a bare server."""
    return lambda executor=None: make_bare_scene(LinkagesScene, executor)


def test_the_clock_holds_until_its_chunk_is_ready_and_nothing_runs_on_the_loop(bare_scene):
    executor = GatedExecutor()
    scene, _ = bare_scene(executor)
    assert send_value(scene, "n_links", 10)
    for _ in range(20):
        scene.frame(1 / 60)
    # no chunk yet: nothing was computed on the loop thread, the clock holds, nothing is drawn
    assert scene.sim_time == 0.0 and scene.waiting and scene.timeline.computed == 0
    assert scene.setup is None and drawn_instances(scene.parts.rods) == 0
    executor.open.set()
    wait_until(lambda: scene.timeline.ready(0), timeout=30.0)
    for _ in range(10):
        scene.frame(1 / 60)
    assert scene.sim_time == pytest.approx(10 / 60) and not scene.waiting
    assert drawn_instances(scene.parts.rods) == 10


def test_time_step_per_frame_is_bounded(bare_scene):
    scene, _ = bare_scene()
    scene.playback.set_time_scale(4.0)
    scene.frame(1 / 60)
    wait_until(lambda: scene.timeline.ready(0), timeout=30.0)
    for _ in range(3):
        before = scene.sim_time
        scene.frame(10.0)  # a stalled loop: 10 s of wall time at scale 4
        assert 0.0 <= scene.sim_time - before <= MAX_SIM_STEP + 1e-12
        wait_until(lambda: scene.timeline.ready(scene.timeline.index(scene.sim_time + MAX_SIM_STEP)), timeout=30.0)
    assert scene.paused_error is None


def _model_to_global(scene, points):
    """Model-frame points (n, 3) to the global frame (the model frame's pose)."""
    from scipy.spatial.transform import Rotation

    rotation = Rotation.from_quat(np.asarray(scene.model_frame.wxyz, dtype=float), scalar_first=True)
    return rotation.apply(np.asarray(points, dtype=float)) + np.asarray(scene.model_frame.position, dtype=float)


def test_every_preset_is_framed_left_of_the_panel_and_its_labels_do_not_overlap(bare_scene):
    """Project each preset at t = 0 with the default camera (1200 x 750 page,
    the GUI panel over the right 400 px): its joints, rod ends, slider and
    tops lie in the free part of the page, and no two labels overlap."""
    scene, _ = bare_scene()
    camera = Camera(LinkagesScene.camera_position, LinkagesScene.camera_look_at)
    for preset in PRESETS:
        scene.playback.set_playing(False)
        assert send_value(scene, "preset", preset)
        scene.frame(1 / 60)
        wait_until(lambda: scene.timeline.ready(0), timeout=30.0)
        scene.frame(1 / 60)
        assert scene.setup.model.preset == preset and scene.sim_time == 0.0
        setup = scene.setup
        points = [np.asarray(scene.parts.balls.batched_positions, dtype=float)[: len(setup.info.joint_names)]]
        positions = np.asarray(scene.parts.rods.batched_positions, dtype=float)
        scales = np.asarray(scene.parts.rods.batched_scales, dtype=float)
        for i in range(len(setup.info.links)):
            from scipy.spatial.transform import Rotation

            axis = Rotation.from_quat(np.asarray(scene.parts.rods.batched_wxyzs[i], dtype=float),
                                      scalar_first=True).apply([0.0, 0.0, 0.5 * scales[i, 2]])
            points.append(np.array([positions[i] + axis, positions[i] - axis]))
        if setup.info.slider >= 0:
            points.append(np.asarray(scene.slider.position, dtype=float)[None])
        if setup.info.top >= 0:
            ghost = np.asarray(scene.ghost.position, dtype=float) + np.asarray(scene.ghost_pivot.position)
            points.append(np.array([scene.top.position, ghost]))
        for point in _model_to_global(scene, np.concatenate(points)):
            x, y = camera.pixels(point)
            assert 40 <= x <= 1200 - 420 and 40 <= y <= 750 - 40, (preset, point, (x, y))
        boxes = {}
        for name, label in scene.labels.items():
            if label.visible:
                x, y = camera.pixels(_model_to_global(scene, [label.position])[0])
                boxes[name] = label_box(x, y, label.text, label.anchor, label.font_screen_scale)
        assert overlapping_pairs(boxes) == [], (preset, boxes)
        for name, (left, top, right, bottom) in boxes.items():
            assert 0 <= left and right <= 1200 - 400 and 0 <= top and bottom <= 750, (preset, name)
