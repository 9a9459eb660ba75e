"""Free-body scene (app/scenes/free_body.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz; the tests act as a browser
does (values and clicks through the gate with ``send_value`` / ``click``)
and check what the scene streams: the body's pose against core's exact
solution at the displayed time, the Dzhanibekov flip and the stable spins,
the ghost integrator's error and cache, a notice when the ghost fails, the
refused ``Step dt = 0``, the CSV export, the shareable state and the labels
at the default view. A few tests build the scene on a bare server and drive
``frame`` themselves (the bounded time step; the clock holding while the
finest rk4 ghost computes).
"""

from __future__ import annotations

import csv
import io
import math
import time

import numpy as np
import pytest

from rigidlab.app.scenes._playback import MAX_SIM_STEP
from rigidlab.app.scenes.free_body import (
    _LABEL_SCALE,
    BODIES,
    CSV_HEADER,
    CSV_HEADER_GHOST,
    INTEGRATORS,
    PRESETS,
    FreeBodyScene,
    body_mesh,
    initial_orientation,
    preset_omega,
)
from rigidlab.core.rigid_body import (
    free_body_exact,
    free_body_solution,
    principal_axes,
    rotation_angle_between,
)
from rigidlab.core.rotations import matrix_from_euler_parameters
from tests.app._views import Camera, label_box, overlapping_pairs
from tests.app.conftest import GatedExecutor
from tests.helpers import click, send_value, wait_until


def locked(app, predicate):
    """``predicate`` evaluated while the session loop is held (consistent reads)."""

    def check():
        with app.session_for().run_lock:
            return predicate()

    return check


def notices_with(app, text):
    return [n for n in app.session_for().notices if text in n[0] or text in n[1]]


@pytest.fixture
def free(running_scene):
    return running_scene(FreeBodyScene)


def test_scene_is_registered_between_manipulator_and_gyroscope():
    from rigidlab.app.scenes import discover_scenes

    names = list(discover_scenes())
    assert FreeBodyScene.order == 30 and "free_body" in names
    assert all(discover_scenes()[n].order <= 30 for n in names[: names.index("free_body")])


def test_pose_is_the_exact_solution_at_the_displayed_time(free):
    app, scene = free
    wait_until(lambda: scene.setup is not None and scene.ghost_error)
    with app.session_for().run_lock:  # freeze the loop between the reads
        t = scene.display_time
        wxyz = np.array(scene.exact_frame.wxyz)
        ghost = np.array(scene.ghost_frame.wxyz)
        inputs = scene.inputs
        p0 = np.array(scene.setup.p0)
        assert scene.sim_time - 1 / 60 - 1e-9 <= t <= scene.sim_time  # one ghost sample behind at most
    _, _, inertia = body_mesh(inputs.body)
    w0 = [inputs.omega_x, inputs.omega_y, inputs.omega_z]
    expected = free_body_exact(inertia, w0, p0, t).p
    # the scene passes core's Euler parameters straight to wxyz: round-off only
    assert rotation_angle_between(wxyz, expected) < 1e-12
    # the default ghost (splitting, dt = 0.01) is drawn at the same instant;
    # its error in the first seconds is ~1e-4 rad (O(dt^2)), far below the
    # ~0.1 rad a frame of lag at 6 rad/s would show
    assert rotation_angle_between(wxyz, ghost) < 1e-3


def test_the_body_starts_with_L_pointing_up(free):
    app, scene = free
    wait_until(lambda: scene.setup is not None)
    setup = scene.setup
    L = matrix_from_euler_parameters(setup.p0) @ (setup.inertia @ setup.omega_body0)
    np.testing.assert_allclose(L / np.linalg.norm(L), [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(setup.L_global, L, rtol=1e-12, atol=1e-12 * np.linalg.norm(L))
    # the L arrow is drawn along +Z from the exact body
    with app.session_for().run_lock:
        points = np.array(scene.arrows.points)
    np.testing.assert_allclose(points[0, 1] - points[0, 0], [0.0, 0.0, 1.3], atol=1e-6)
    # a body at rest keeps the identity; L along -Z gets half a turn
    np.testing.assert_array_equal(initial_orientation(np.eye(3), np.zeros(3)), [1.0, 0.0, 0.0, 0.0])
    p = initial_orientation(np.eye(3), [0.0, 0.0, -2.0])
    np.testing.assert_allclose(matrix_from_euler_parameters(p) @ [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], atol=1e-15)


def _axis_alignment(scene, app, axis_index, seconds):
    """cos of the angle between a principal axis (global frame) and L, sampled."""
    _, _, inertia = body_mesh(scene.inputs.body)
    _, Q = principal_axes(inertia)
    axis_body = Q[:, axis_index]
    values = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        with app.session_for().run_lock:
            p, w = np.array(scene.exact_frame.wxyz), scene.omega_exact.copy()
        A = matrix_from_euler_parameters(p)
        L = A @ (inertia @ w)
        values.append(float((A @ axis_body) @ L / np.linalg.norm(L)))
        time.sleep(0.03)
    return np.array(values)


def test_presets_flip_or_spin_stably(free):
    app, scene = free
    assert send_value(scene, "time_scale", 4.0)
    _, _, inertia = body_mesh(BODIES[0])
    for i, (name, axis) in enumerate(zip(PRESETS, (2, 0, 1), strict=True)):
        click(scene, f"preset_{i}")  # the preset's button, as the page sends a click
        want = preset_omega(name, inertia)
        wait_until(lambda: scene.setup is not None and np.allclose(scene.setup.omega_body0, want)
                   and 0.1 < scene.sim_time < 1.0)
        # the page's sliders show the preset
        assert [scene.controls.handles[k].value for k in ("omega_x", "omega_y", "omega_z")] == pytest.approx(want)
        cosines = _axis_alignment(scene, app, axis, 2.0)  # >= 6 s of simulated time
        if axis == 1:
            # intermediate axis: it starts along L (cos ~ 1) and turns over
            # (the flip takes ~2.3 s of simulated time with a 2 % offset)
            assert cosines.max() > 0.99 and cosines.min() < -0.9
        else:
            # major or minor axis: a 2 % offset keeps the axis within ~2 deg of L
            assert cosines.min() > 0.99
    with pytest.raises(ValueError, match=r"name: expected one of \["):
        scene.apply_preset("no such preset")


def test_ghost_integrators_error_and_cache(free):
    app, scene = free
    assert send_value(scene, "method", "DOP853")
    assert send_value(scene, "rtol_exp", -12.0)
    wait_until(locked(app, lambda: scene.config.method == "DOP853" and scene.config.rtol == 1e-12
                      and scene.ghost_error.get("t", 0) > 0.5))
    # DOP853 at rtol = 1e-12 over ~1 s: orientation error far below 1e-8
    assert scene.ghost_error["angle"] < 1e-8 and scene.ghost_error["energy"] < 1e-9
    # the splitting keeps |p| = 1 to round-off and |L| exactly; its energy
    # error at dt = 0.05 is O(dt^2) but bounded
    assert send_value(scene, "method", "splitting")
    assert send_value(scene, "dt", 0.05)
    wait_until(locked(app, lambda: scene.config.method == "splitting" and scene.config.dt == 0.05
                      and scene.ghost_error.get("t", 0) > 0.5))
    assert scene.ghost_error["p_norm"] < 1e-14 and scene.ghost_error["L"] < 1e-13
    assert 0 < scene.ghost_error["angle"] < 0.1
    with app.session_for().run_lock:
        ghost = np.array(scene.ghost_frame.wxyz)
        assert scene.ghost_frame.visible and np.all(np.isfinite(ghost))
        assert scene.labels["ghost"].text == "ghost\nsplitting, dt 0.05 s"
    # reset replays cached chunks: no recomputation while parameters are unchanged
    click(scene, "playback", "Pause")
    wait_until(locked(app, lambda: scene.chunks_computed >= 2 and not scene.timeline.busy))
    with app.session_for().run_lock:
        computed = scene.chunks_computed
        t_before = scene.sim_time
    click(scene, "playback", "Reset")
    click(scene, "playback", "Play")
    wait_until(lambda: 0.3 < scene.sim_time < t_before or scene.sim_time > 0.6)
    assert scene.chunks_computed == computed
    assert send_value(scene, "method", "none")
    wait_until(lambda: not scene.ghost_frame.visible)
    assert not scene.plot_handles["error"].visible and not scene.plot_handles["drift"].visible


def test_failing_ghost_gives_a_notice_and_the_scene_keeps_running(free):
    app, scene = free
    for key in ("omega_x", "omega_y", "omega_z"):
        assert send_value(scene, key, 10.0)
    assert send_value(scene, "dt", 0.2)
    assert send_value(scene, "method", "midpoint")  # fixed-point iteration cannot converge at |omega| dt ~ 3.5
    wait_until(lambda: notices_with(app, "Ghost integrator stopped"))
    assert notices_with(app, "did not converge")
    t0 = scene.sim_time
    wait_until(lambda: scene.sim_time > t0 + 0.2)  # the exact body keeps moving
    assert not scene.ghost_frame.visible and scene.paused_error is None


def test_step_dt_zero_is_refused_and_the_scene_keeps_running(free):
    """Issue 9: Step dt = 0 gave a ZeroDivisionError every frame."""
    app, scene = free
    assert send_value(scene, "method", "rk4")
    for raw in (0.0, -0.01, math.inf, math.nan, 1e308):
        assert not send_value(scene, "dt", raw)
        assert scene.controls.value("dt") == 0.01 and scene.controls.handles["dt"].value == 0.01
    assert scene.controls.specs["dt"].min > 0
    wait_until(lambda: notices_with(app, "Refused: Step dt (s)"))
    wait_until(lambda: scene.config.method == "rk4" and scene.sim_time > 0.5)
    assert scene.paused_error is None
    assert not notices_with(app, "ZeroDivisionError")


def test_body_choice_and_polhode(free):
    app, scene = free
    assert send_value(scene, "body", BODIES[1])
    assert not send_value(scene, "body", "Teapot")  # not an option
    wait_until(lambda: scene.setup is not None and scene.setup.body == BODIES[1] and scene.sim_time > 0.5)
    wait_until(locked(app, lambda: np.count_nonzero(np.array(scene.polhode.points)) > 0))
    with app.session_for().run_lock:
        assert scene.body_frames[BODIES[1]].visible and not scene.body_frames[BODIES[0]].visible
        pts = np.array(scene.polhode.points)
    # the traced polhode lies on the momentum sphere (radius 0.9 in the picture)
    radii = np.linalg.norm(pts.reshape(-1, 3), axis=1)
    assert np.allclose(radii, 0.9, atol=1e-6)
    with pytest.raises(ValueError, match=r"name: expected one of \["):
        scene.apply_preset("no such preset")
    with pytest.raises(ValueError, match=r"name: expected one of \["):
        body_mesh("no such body")


def test_plot_window_spans_two_omega_periods_and_plots_only_what_runs(free):
    app, scene = free
    wait_until(lambda: scene.setup is not None)
    period = scene.setup.solution.period  # the default flip: ~9.6 s
    assert period > 9.0
    assert scene.window >= 2 * period and scene.window <= 120.0
    assert send_value(scene, "time_scale", 4.0)
    wait_until(lambda: scene.sim_time > 6.0, timeout=20.0)
    # the plots refresh in turn (one per refresh, a few Hz): wait for both
    wait_until(locked(app, lambda: np.asarray(scene.plot_handles["omega"].data[0]).size > 100
                      and np.asarray(scene.plot_handles["error"].data[0]).size > 100))
    with app.session_for().run_lock:
        t, wx, wy, wz = (np.asarray(a) for a in scene.plot_handles["omega"].data)
        err_t = np.asarray(scene.plot_handles["error"].data[0])
        display_time = scene.display_time
    # refreshed every 0.2 s of wall time: at scale 4, up to ~1 s of simulated time old
    assert t.size <= 401 and t[0] == 0.0 and display_time - 1.2 < t[-1] <= display_time
    assert scene.plot_handles["omega"].scales["x"]["time"] is False
    # omega_x of the flip reverses within the window
    assert wx.max() > 5.0 and wx.min() < -5.0
    assert err_t.size > 100 and scene.plot_handles["error"].visible


def test_readout_shows_meaningful_digits(free):
    app, scene = free
    wait_until(lambda: "**Ghost**" in scene.status.content)
    text = scene.status.content
    # the motion's constants, in their own readout (sent when they change)
    info = scene.info.content
    assert "ω period 9.58 s" in info
    assert "**E** = 63.84 J, **|L|** = 21.27 kg m²/s" in info
    assert "2E J2/|L|² = 0.9995" in info
    # ghost errors with one or two significant digits, not ten
    ghost_line = next(line for line in text.splitlines() if line.startswith("**Ghost**"))
    assert "angle error" in ghost_line and len(ghost_line) < 140


def test_readout_after_the_flip_preset_explains_the_flip(free):
    """The Dzhanibekov preset starts just off the separatrix, on the side where
    the polhode circles the major axis: the readout said only "circles the
    major axis", which read as a contradiction of the button. Now it says the
    body spins about its intermediate axis and flips over every half period
    (checked against core's solution: the sign changes of L along the
    intermediate axis), and that just off the separatrix the polhode circles
    the major axis. The stable presets still read "circles the major (minor)
    axis" without a flip; the symmetric disc has no intermediate axis."""
    app, scene = free
    for body in BODIES:
        assert send_value(scene, "body", body)
        _, _, inertia = body_mesh(body)
        moments, Q = principal_axes(inertia)
        for i, name in enumerate(PRESETS):
            click(scene, f"preset_{i}")
            want = preset_omega(name, inertia)
            wait_until(lambda: scene.setup is not None and scene.setup.body == body
                       and np.allclose(scene.setup.omega_body0, want)
                       and scene.info.content == scene.info_text(scene.setup))
            info = scene.info.content
            if body == BODIES[2]:  # two equal moments
                assert "no intermediate axis and no flip" in info and "Dzhanibekov" not in info, info
                continue
            if i < 2:
                assert f"the polhode circles the {('major', 'minor')[i]} axis" in info, info
                assert "flip" not in info and "separatrix" not in info, info
                continue
            assert "near 1 (the separatrix): the body spins about its intermediate axis and flips over every" in info
            assert "the Dzhanibekov effect" in info
            assert "Just below 1, the polhode passes" in info and "circles the major axis" in info, info
            # the flip interval is half the omega period, as the motion shows
            flip = float(info.split("flips over every ")[1].split(" s")[0])
            t = np.linspace(0.0, 40.0, 400_001)
            L_intermediate = (free_body_solution(inertia, want, [1.0, 0.0, 0.0, 0.0]).at(t).omega_body
                              @ Q[:, 1]) * moments[1]
            crossings = t[1:][np.sign(L_intermediate[1:]) != np.sign(L_intermediate[:-1])]
            assert crossings.size >= 4
            assert np.diff(crossings) == pytest.approx(flip, rel=2e-3)
            angle = float(info.split("polhode passes ")[1].split("°")[0])
            assert 0.3 < angle < 3.0  # the preset's 2 % offset


def test_csv_export_is_the_trajectory_shown(free):
    app, scene = free
    wait_until(lambda: scene.sim_time > 2.0)
    click(scene, "download_csv")  # served by the loop (sent to the browser that clicked)
    with app.session_for().run_lock:
        content = scene.csv_bytes()
        display_time = scene.display_time
        setup = scene.setup
    rows = list(csv.reader(io.StringIO(content.decode())))
    assert ",".join(rows[0]) == CSV_HEADER_GHOST
    assert rows[0][:2] == ["t (s)", "p0"] and rows[0][5] == "omega_x (rad/s)" and rows[0][9] == "|L| (kg m^2/s)"
    data = np.array(rows[1:], dtype=float)
    t = data[:, 0]
    assert t[0] == 0.0 and display_time - 1e-9 <= t[-1] <= display_time + 1e-9
    np.testing.assert_allclose(np.diff(t), 1 / 60, rtol=1e-6)
    exact = free_body_exact(setup.inertia, setup.omega_body0, setup.p0, t)
    np.testing.assert_allclose(data[:, 1:5], exact.p, atol=1e-13)
    np.testing.assert_allclose(data[:, 5:8], exact.omega_body, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(data[:, 8], setup.geometry.energy, rtol=1e-12)
    np.testing.assert_allclose(data[:, 9], setup.geometry.L_norm, rtol=1e-12)
    # the ghost's columns: its Euler parameters and the angle to the exact body
    ghost_p = data[:, 10:14]
    np.testing.assert_allclose(data[:, 19], rotation_angle_between(exact.p, ghost_p), rtol=1e-9, atol=1e-14)  # 15 digits
    assert 0 < data[-1, 19] < 1e-2
    # without a ghost: the exact columns only
    assert send_value(scene, "method", "none")
    wait_until(lambda: scene.config.method == "none" and scene.sim_time > 0.5)
    with app.session_for().run_lock:
        content = scene.csv_bytes()
    rows = list(csv.reader(io.StringIO(content.decode())))
    assert ",".join(rows[0]) == CSV_HEADER and all(len(row) == 10 for row in rows)


def test_state_round_trip_reproduces_the_motion(running_app):
    first = running_app(scene="free_body")
    scene = first.scene_for()
    assert send_value(scene, "body", BODIES[1])
    assert send_value(scene, "method", "RK45")
    assert send_value(scene, "rtol_exp", -10.0)
    scene.apply_preset(PRESETS[2])
    _, _, inertia = body_mesh(BODIES[1])
    wait_until(lambda: scene.setup is not None and np.allclose(scene.setup.omega_body0, preset_omega(PRESETS[2], inertia)))
    state = scene.state()
    assert state["values"]["body"] == BODIES[1] and state["values"]["method"] == "RK45"

    second = running_app(scene="free_body")
    other = second.scene_for()
    wait_until(lambda: other.sim_time > 1.0)
    second.session_for().request_state(state)
    wait_until(lambda: other.config == scene.config)
    with second.session_for().run_lock:  # (the loop sets the new inputs, then restarts the clock)
        assert other.sim_time < 1.0  # the motion restarts
    wait_until(lambda: other.sim_time > 0.5)
    with first.session_for().run_lock:
        rows_first = scene.csv_bytes().decode().splitlines()
    with second.session_for().run_lock:
        rows_second = other.csv_bytes().decode().splitlines()
    n = min(len(rows_first), len(rows_second))
    assert n > 20
    assert rows_first[:n] == rows_second[:n]  # the same motion, sample for sample
    # values a control refuses are reported; the others are used
    bad = dict(state, values=dict(state["values"], dt=0.0, omega_x=1.0))
    second.session_for().request_state(bad)
    wait_until(lambda: notices_with(second, "State loaded in part"))
    wait_until(lambda: other.config.omega[0] == 1.0)
    assert other.controls.value("dt") == state["values"]["dt"]


def test_per_client_sessions_are_isolated(per_client_scenes):
    # Two browsers (plain websocket clients) get their own free-body scene:
    # a preset in one does not touch the other.
    _, [(_, s1), (_, s2)] = per_client_scenes(FreeBodyScene)
    wait_until(lambda: s1.setup is not None and s2.setup is not None and s2.sim_time > 0.1)
    s1.apply_preset(PRESETS[0])
    _, _, inertia = body_mesh(BODIES[0])
    wait_until(lambda: np.allclose(s1.setup.omega_body0, preset_omega(PRESETS[0], inertia)))
    assert np.allclose(s2.setup.omega_body0, [6.0, 0.12, 0.12])  # still the default flip


def test_arrow_points_stay_finite(free):
    app, scene = free
    assert send_value(scene, "time_scale", 4.0)
    for method in ("rk4", "midpoint", "LSODA"):
        assert send_value(scene, "method", method)
        t_end = time.monotonic() + 0.5
        while time.monotonic() < t_end:
            with app.session_for().run_lock:
                points = np.asarray(scene.arrows.points)
                omega_label = np.asarray(scene.labels["omega"].position)
            assert np.all(np.isfinite(points)) and np.all(np.isfinite(omega_label))
            time.sleep(0.03)


# -- a scene on a bare server, driven frame by frame ----------------------------
@pytest.fixture
def bare_scene(make_bare_scene):
    """``bare_scene(executor=None) -> (scene, notices)``: a FreeBodyScene on a bare server."""
    return lambda executor=None: make_bare_scene(FreeBodyScene, executor)


def test_time_step_per_frame_is_bounded(bare_scene):
    scene, _ = bare_scene()
    scene.playback.set_time_scale(4.0)
    scene.frame(1 / 60)
    wait_until(lambda: scene.timeline.ready(0))
    for _ in range(5):
        before = scene.sim_time
        scene.frame(10.0)  # a stalled loop: 10 s of wall time at scale 4
        assert 0.0 <= scene.sim_time - before <= MAX_SIM_STEP + 1e-12
        wait_until(lambda: scene.timeline.ready(scene.timeline.index(scene.sim_time + MAX_SIM_STEP)))
    assert scene.paused_error is None


def test_the_clock_holds_while_the_finest_rk4_ghost_computes(bare_scene):
    executor = GatedExecutor()
    scene, _ = bare_scene(executor)
    scene.frame(1 / 60)
    assert send_value(scene, "method", "rk4")
    assert send_value(scene, "dt", 0.001)
    for _ in range(20):
        scene.frame(1 / 60)
    # no chunk yet: the clock holds
    assert scene.sim_time == 0.0 and scene.waiting and scene.timeline.computed == 0
    executor.open.set()
    wait_until(lambda: scene.timeline.ready(0))
    for _ in range(10):
        scene.frame(1 / 60)
    assert scene.sim_time == pytest.approx(10 / 60) and not scene.waiting
    assert scene.config.method == "rk4" and scene.ghost_error["angle"] < 1e-9


def test_labels_do_not_overlap_at_the_default_view(bare_scene):
    """Project every label anchor with the scene's default camera (1200 x 750):
    no two label boxes overlap and all lie left of the GUI panel, for the
    default inputs and every preset (and body) at t = 0, with the longest
    ghost label."""
    scene, _ = bare_scene()
    camera = Camera(FreeBodyScene.camera_position, FreeBodyScene.camera_look_at)
    assert send_value(scene, "method", "splitting8")
    assert send_value(scene, "dt", 0.001)
    cases = [(None, BODIES[0])] + [(preset, body) for body in BODIES for preset in PRESETS]
    for preset, body in cases:
        scene.playback.set_playing(False)
        if scene.controls.value("body") != body:  # (an unchanged value still runs the callbacks, later)
            assert send_value(scene, "body", body)
        if preset is not None:
            scene.apply_preset(preset)
        scene.frame(1 / 60)
        scene.playback.set_playing(False)
        wait_until(lambda: scene.timeline.ready(0))
        scene.frame(1 / 60)
        assert scene.paused_error is None, scene.paused_error
        assert scene.sim_time == 0.0 and scene.setup.body == body
        boxes = {}
        for name, label in scene.labels.items():
            if not label.visible:
                continue
            x, y = camera.pixels(np.asarray(label.position))
            boxes[name] = label_box(x, y, label.text, label.anchor, _LABEL_SCALE)
        assert set(boxes) == {"exact", "ghost", "sphere", "L", "omega"}
        assert overlapping_pairs(boxes) == [], (preset, body, boxes)
        for name, (left, top, right, bottom) in boxes.items():
            assert 0 <= left and right <= 1200 - 400 and 0 <= top and bottom <= 750, (preset, body, name)


def test_help_and_labels_have_no_combining_marks():
    # a combining mark (a dot or bar over a letter) is lost in some browsers
    texts = [FreeBodyScene.help] + [line for line in CSV_HEADER_GHOST.split(",")]
    assert not any(0x300 <= ord(ch) <= 0x36F for text in texts for ch in text)
    assert "Eqs. 8.53-8.54" in FreeBodyScene.help and "Landau & Lifshitz" in FreeBodyScene.help


def test_integrator_list_and_slider_ranges():
    assert INTEGRATORS[0] == "none" and "rk4" in INTEGRATORS and "DOP853" in INTEGRATORS
    solution = free_body_solution(body_mesh(BODIES[0])[2], [6.0, 0.12, 0.12], [1.0, 0.0, 0.0, 0.0])
    assert solution.kind == "asymmetric"
