"""Cam-follower scene (app/scenes/cam_follower.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz; tests act as a browser
does (values and clicks through the gate with ``send_value`` / ``click``) and
check what the scene streams against closed forms written out here: the
flat face and the roller on the eccentric cam (the lift, the follower's pose,
the contact point, the readout's digits), the jump speed and the separation
interval past it, refused values and refused cams (a roller that would
undercut the cam, a flat face on a cam that would not be convex), the CSV of
a revolution, the shareable state, presenter view, the framing of the
default view, and the compliant run on the process pool: the follower leaves
the cam and lands above the jump speed, and follows the closed form below
it. A few tests build the scene on a bare server and drive ``frame``
themselves (nothing is computed on the loop thread).
"""

from __future__ import annotations

import csv
import io
import math
import re

import numpy as np
import pytest

from rigidlab.app.readout import significant
from rigidlab.app.scenes._arrows import vertex_rgb
from rigidlab.app.scenes._cam import cam_layout
from rigidlab.app.scenes._plots import capped_range
from rigidlab.app.scenes.base import PRESENTER_ARROW_SCALE, PRESENTER_LABEL_SCALE
from rigidlab.app.scenes.cam_follower import (
    CSV_HEADER,
    ECCENTRIC_RADIUS,
    ECCENTRICITY,
    FOLLOWERS,
    GRAVITY,
    PROFILES,
    REVOLUTION_SAMPLES,
    RUN_SAMPLES,
    CamFollowerScene,
    Inputs,
    build_cam,
    compute_chunk,
    compute_revolution,
)
from tests.app._views import Camera, label_box, overlapping_pairs
from tests.app.conftest import GatedExecutor
from tests.helpers import click, send_value, wait_for_frames, wait_until

R, E = ECCENTRIC_RADIUS, ECCENTRICITY
RB = R - E  # base circle of the eccentric cam


def _in_global(frame, points: np.ndarray) -> np.ndarray:
    """``points`` (k, 3) given in the frame of the node ``frame`` (its pose), in global coordinates."""
    w, x, y, z = (float(c) for c in frame.wxyz)
    A = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return np.asarray(frame.position) + points @ A.T


def flat_closed_form(theta, inputs: Inputs):
    """Flat face on the eccentric cam: lift, s', s'' and the contact force (independent of core)."""
    w = inputs.rpm * math.pi / 30.0
    s, ds, dds = E * (1 - np.cos(theta)), E * np.sin(theta), E * np.cos(theta)
    force = inputs.mass * w * w * dds + inputs.stiffness * s + inputs.preload + inputs.mass * GRAVITY
    return s, ds, dds, force


def roller_lift(theta, r):
    """Roller of radius r without offset on the eccentric cam: the slider-crank, crank e, rod R + r."""
    return np.sqrt((R + r) ** 2 - (E * np.sin(theta)) ** 2) - E * np.cos(theta) - (R + r - E)


def flat_jump_speed(inputs: Inputs) -> float:
    force = inputs.preload + inputs.mass * GRAVITY
    return math.sqrt((2 * inputs.stiffness * E + force) / (inputs.mass * E))


def notices_with(app, text):
    return [n for n in app.session_for().notices if text in n[0] or text in n[1]]


@pytest.fixture
def cam_app(running_app):
    """A shared app showing the cam-follower scene, its first revolution computed."""
    app = running_app(scene="cam_follower")
    scene = app.scene_for()
    assert isinstance(scene, CamFollowerScene)
    wait_until(lambda: scene.revolution is not None and scene.frames > 5, timeout=60.0)
    return app, scene


def pause(scene) -> None:
    """Stop the cam (as the page's Pause button does) and wait until the readout shows the angle drawn."""
    click(scene, "playback", "Pause")
    wait_until(lambda: not scene.playing)  # (the clock stands from this frame on; the readout follows)
    wait_until(lambda: scene.drawn_revision == scene.revision
               and f"**θ** = {math.degrees(scene.cam_angle):.2f}°" in scene.status.content)


def wait_for_inputs(scene, timeout=30.0, **fields):
    wait_until(lambda: scene.revolution is not None
               and all(getattr(scene.revolution.inputs, k) == v for k, v in fields.items())
               and scene.drawn_revision == scene.revision, timeout=timeout)


def numbers(text: str, label: str) -> str:
    """The number printed after ``label = `` in a readout."""
    match = re.search(re.escape(label) + r" = (-?[0-9.]+)", text)
    assert match, f"{label!r} not in {text!r}"
    return match.group(1)


def test_scene_is_registered_after_the_multibody_scenes():
    from rigidlab.app.scenes import discover_scenes

    scenes = discover_scenes()
    assert "cam_follower" in scenes and CamFollowerScene.order == 70
    assert all(cls.order < 70 for cls in list(scenes.values())[: list(scenes).index("cam_follower")])


def test_follower_pose_and_readout_are_the_closed_form_at_the_angle_shown(cam_app):
    app, scene = cam_app
    # turning: every drawn frame puts the follower at the closed-form lift of the angle drawn
    for _ in range(20):
        with app.session_for().run_lock:
            theta, z = scene.cam_angle, float(scene.mechanism.follower_frame.position[2])
            wxyz = np.array(scene.mechanism.cam_frame.wxyz)
        s = E * (1 - math.cos(theta))
        assert z == pytest.approx(RB + s, abs=1e-15)
        np.testing.assert_allclose(wxyz, [math.cos(theta / 2), 0, 0, math.sin(theta / 2)], atol=1e-15)
        assert theta == pytest.approx(round(theta / (2 * math.pi / REVOLUTION_SAMPLES)) * 2 * math.pi
                                      / REVOLUTION_SAMPLES, abs=1e-15)
        wait_for_frames(scene, 2)
    pause(scene)
    with app.session_for().run_lock:
        theta, text = scene.cam_angle, scene.status.content
        z = float(scene.mechanism.follower_frame.position[2])
        point = np.array(scene.mechanism.contact_point.position)
        arrow = _in_global(scene.mechanism.contact_point, np.array(scene.mechanism.force_arrow.arrow.points)[0])
        normal = _in_global(scene.mechanism.contact_point, np.array(scene.mechanism.normal_line.points)[0])
    inputs = scene.revolution.inputs
    s, ds, dds, force = flat_closed_form(theta, inputs)
    w = inputs.rpm * math.pi / 30.0
    assert z == pytest.approx(RB + s, abs=1e-15)
    # the readout prints the closed form at that angle, digit for digit
    assert numbers(text, "**s**") == f"{1000 * s:.4f}"
    assert numbers(text, "**v** = ω s′") == f"{w * ds:.4f}"
    assert numbers(text, "**a** = ω² s″") == f"{w * w * dds:.2f}"
    assert numbers(text, "**N**") == f"{force:.3f}"
    assert scene.force == pytest.approx(force, rel=1e-14)
    # the flat face touches the cam at x = s' (the support function's derivative), on top of it
    np.testing.assert_allclose(point[[0, 2]], [ds, RB + s], atol=1e-12)
    # the force arrow ends at the contact point, pointing up into the follower (N > 0)
    np.testing.assert_allclose(arrow[1, [0, 2]], [ds, RB + s], atol=1e-6)
    assert arrow[1, 2] > arrow[0, 2] and abs(arrow[1, 0] - arrow[0, 0]) < 1e-9
    # the common normal is drawn through the contact point, perpendicular to the flat face
    np.testing.assert_allclose(normal.mean(axis=0)[[0, 2]], [ds, RB + s], atol=1e-9)
    assert abs(normal[1, 0] - normal[0, 0]) < 1e-9 < normal[1, 2] - normal[0, 2]


def test_roller_follows_the_slider_crank_closed_form(cam_app):
    app, scene = cam_app
    assert send_value(scene, "follower", FOLLOWERS[1])
    assert send_value(scene, "roller_mm", 15.0)
    wait_for_inputs(scene, follower=FOLLOWERS[1], roller_mm=15.0)
    wait_until(lambda: not scene.controls.handles["roller_mm"].disabled)
    assert scene.controls.handles["rise_deg"].disabled  # no rise on the eccentric cam
    pause(scene)
    r = 0.015
    with app.session_for().run_lock:
        theta, z = scene.cam_angle, float(scene.mechanism.follower_frame.position[2])
        point = np.array(scene.mechanism.contact_point.position)
        normal = _in_global(scene.mechanism.contact_point, np.array(scene.mechanism.normal_line.points)[0])
    s = roller_lift(theta, r)
    assert z == pytest.approx(R + r - E + s, abs=1e-14)  # the roller's centre
    assert numbers(scene.status.content, "**s**") == f"{1000 * s:.4f}"
    # the contact point lies on the roller, r from its centre, and on the cam's circle
    centre_cam = np.array([E * math.sin(theta), -E * math.cos(theta)])  # the circle's centre, turned by theta
    assert math.hypot(point[0], point[2] - z) == pytest.approx(r, abs=1e-12)
    assert math.hypot(point[0] - centre_cam[0], point[2] - centre_cam[1]) == pytest.approx(R, abs=1e-12)
    # the common normal is drawn through the contact point and the roller's centre
    d = normal[1] - normal[0]
    to_centre = np.array([0.0, 0.0, z]) - point
    assert abs(d[0] * to_centre[2] - d[2] * to_centre[0]) < 1e-9 * np.linalg.norm(d) * r
    # the roller's mesh is shown with its radius, the flat face hidden
    wait_until(lambda: scene.mechanism.roller_mesh.visible and not scene.mechanism.follower_meshes["flat"].visible)
    vertices = np.asarray(scene.mechanism.roller_mesh.vertices)
    assert np.max(np.hypot(vertices[:, 0], vertices[:, 2])) == pytest.approx(r, rel=1e-6)


def test_past_the_jump_speed_the_separation_interval_is_marked(cam_app):
    app, scene = cam_app
    inputs = scene.revolution.inputs
    jump = flat_jump_speed(inputs)
    assert scene.revolution.closed.jump_speed == pytest.approx(jump, rel=1e-14)
    wait_until(lambda: "**Jump speed**: 1088.0 rpm" in scene.info.content)
    assert f"**Jump speed**: {jump * 30 / math.pi:.1f} rpm" in scene.info.content
    assert "No separation" in scene.info.content and not scene.mechanism.separation_arc.visible
    force_plot = scene.plot_handles["force"]
    assert np.all(np.asarray(force_plot.data[4]) == 0.0)  # nothing shaded
    # just below the jump speed: still no separation; just above: an interval around theta = pi
    rpm_jump = jump * 30 / math.pi
    assert send_value(scene, "rpm", math.floor(rpm_jump))
    wait_for_inputs(scene, rpm=float(math.floor(rpm_jump)))
    assert scene.revolution.closed.separations == ()
    assert send_value(scene, "rpm", 1300.0)
    wait_for_inputs(scene, rpm=1300.0)
    wait_until(lambda: "Separation" in scene.info.content and scene.mechanism.separation_arc.visible)
    assert "Turn on *Compliant contact* to see the follower jump." in scene.info.content
    (start, end), = scene.revolution.closed.separations
    # N = 0 where m w^2 e cos(theta) + k e (1 - cos theta) + F = 0 (closed form, both roots)
    w = 1300 * math.pi / 30
    k, m, force = inputs.stiffness, inputs.mass, inputs.preload + inputs.mass * GRAVITY
    root = math.acos(-(k * E + force) / (m * w * w * E - k * E))
    assert start == pytest.approx(root, abs=1e-9) and end == pytest.approx(2 * math.pi - root, abs=1e-9)
    assert f"θ = {math.degrees(root):.2f}° to {360 - math.degrees(root):.2f}°" in scene.info.content
    # shaded in the plots: the negative part of N, and the other curves over the same interval
    wait_until(lambda: np.any(np.asarray(scene.plot_handles["force"].data[4]) < 0.0)
               and np.any(np.asarray(scene.plot_handles["lift"].data[2]) > 0.0))
    x, n, zero, at_jump, shaded = (np.asarray(a) for a in scene.plot_handles["force"].data)
    inside = (np.radians(x) > root) & (np.radians(x) < 2 * math.pi - root)
    assert np.all(shaded[inside] < 0) and np.all(shaded[~inside] == 0) and np.all(zero == 0)
    # the dashed curve: the force at the jump speed touches zero at theta = pi
    assert at_jump.min() == pytest.approx(0.0, abs=1e-9) and x[np.argmin(at_jump)] == pytest.approx(180.0)
    lift_shade = np.asarray(scene.plot_handles["lift"].data[2])
    assert np.all(lift_shade[~inside] == 0) and np.all(lift_shade[inside] > 0)
    # the arc on the cam: contour points u of the interval, on the cam's front face (body frame)
    segments = np.asarray(scene.mechanism.separation_arc.points, dtype=float)
    u = np.arange(720) * (2 * math.pi / 720)
    contour = build_cam(inputs).cam_curve(u).point
    nearest = np.argmin(np.linalg.norm(segments[:, 0, None, :2] - contour[None], axis=-1), axis=1)
    assert np.all(np.linalg.norm(segments[:, 0, :2] - contour[nearest], axis=-1) < 1e-6)
    assert np.all(u[nearest] >= root - 1e-9) and np.all(u[nearest] <= 2 * math.pi - root + 1e-9)
    assert np.ptp(u[nearest]) > 2 * math.pi - 2 * root - 3 * (2 * math.pi / 720)  # the whole interval
    assert np.all(segments[:, :, 2] > 0.006)  # in front of the cam's face
    # pulling force drawn in purple when the angle shown is in the interval
    pause(scene)
    load = {"scene": "cam_follower", "values": {}, "cam_angle_deg": 180.0}
    with app.session_for().run_lock:
        assert scene.load_state(load) == []
    wait_until(lambda: scene.index == REVOLUTION_SAMPLES // 2)
    wait_until(lambda: "would have to pull" in scene.status.content)
    colors = np.asarray(scene.mechanism.force_arrow.arrow.colors)
    assert scene.force < 0 and np.array_equal(colors[0], vertex_rgb((150, 60, 200)))


@pytest.mark.parametrize(("key", "raw"), [("rpm", 1e308), ("rpm", math.nan), ("mass", -1.0), ("stiffness", "abc"),
                                          ("profile", "Square"), ("roller_mm", 0.0), ("turn_seconds", 1e6),
                                          ("compliant", "yes")])
def test_refused_values_never_reach_the_scene(cam_app, key, raw):
    app, scene = cam_app
    before = scene.controls.value(key)
    revolution = scene.revolution
    assert not send_value(scene, key, raw)
    assert scene.controls.value(key) == before
    assert scene.controls.handles[key].value == before
    label = scene.controls.specs[key].label
    wait_until(lambda: notices_with(app, f"Refused: {label}"))
    frames = scene.frames
    wait_until(lambda: scene.frames > frames + 10)  # frames keep streaming
    assert scene.revolution is revolution and scene.paused_error is None


def test_a_roller_that_would_undercut_the_cam_is_refused_and_set_back(cam_app):
    app, scene = cam_app
    assert send_value(scene, "profile", PROFILES[1])
    assert send_value(scene, "follower", FOLLOWERS[1])
    assert send_value(scene, "rise_deg", 40.0)
    wait_for_inputs(scene, profile=PROFILES[1], follower=FOLLOWERS[1], rise_deg=40.0)
    kept = scene.revolution
    # the refusal in the panel's terms, naming the largest roller (a slider value) that fits
    with pytest.raises(ValueError, match=r"Roller radius: a 30 mm roller would undercut this cam .* at most 20\.5 mm"):
        build_cam(Inputs(profile=PROFILES[1], follower=FOLLOWERS[1], rise_deg=40.0, roller_mm=30.0))
    build_cam(Inputs(profile=PROFILES[1], follower=FOLLOWERS[1], rise_deg=40.0, roller_mm=20.5))
    with pytest.raises(ValueError, match="undercut"):
        build_cam(Inputs(profile=PROFILES[1], follower=FOLLOWERS[1], rise_deg=40.0, roller_mm=21.0))
    assert send_value(scene, "roller_mm", 30.0)  # in the slider's range, but the cam would be undercut
    wait_until(lambda: notices_with(app, "Cam refused"))
    assert notices_with(app, "use a roller of at most 20.5 mm or a longer rise")
    assert not notices_with(app, "base_radius") and not notices_with(app, "at cam angle")  # (core's terms)
    assert notices_with(app, "the controls are set back")
    wait_until(lambda: scene.controls.handles["roller_mm"].value == 10.0)
    assert scene.controls.value("roller_mm") == 10.0 and scene.revolution is kept
    assert scene.paused_error is None
    frames = scene.frames
    wait_until(lambda: scene.frames > frames + 10)
    # a flat face on a cam that would not be convex names the smallest rise that makes it convex
    with pytest.raises(ValueError, match=r"Flat-faced follower: at rise = fall = 40° .* a rise of at least 85°"):
        build_cam(Inputs(profile=PROFILES[1], follower=FOLLOWERS[0], rise_deg=40.0))
    build_cam(Inputs(profile=PROFILES[1], follower=FOLLOWERS[0], rise_deg=85.0))
    with pytest.raises(ValueError, match="convex"):
        build_cam(Inputs(profile=PROFILES[1], follower=FOLLOWERS[0], rise_deg=84.0))
    assert send_value(scene, "follower", FOLLOWERS[0])
    wait_until(lambda: notices_with(app, "use a rise of at least 85° or the roller follower"))
    wait_until(lambda: scene.controls.handles["follower"].value == FOLLOWERS[1])
    assert scene.revolution is kept
    # a valid change afterwards is taken as usual
    assert send_value(scene, "roller_mm", 12.0)
    wait_for_inputs(scene, roller_mm=12.0)


def test_csv_export_is_one_revolution_of_the_closed_form(cam_app):
    app, scene = cam_app
    click(scene, "download_csv")  # served by the loop (sent to the browser that clicked)
    with app.session_for().run_lock:
        content = scene.csv_bytes()
        inputs = scene.revolution.inputs
    rows = list(csv.reader(io.StringIO(content.decode())))
    assert ",".join(rows[0]) == CSV_HEADER
    data = np.array(rows[1:], dtype=float)
    assert data.shape == (REVOLUTION_SAMPLES, 5)
    np.testing.assert_allclose(data[:, 0], np.arange(REVOLUTION_SAMPLES) * 0.25, atol=1e-12)
    s, ds, dds, force = flat_closed_form(np.radians(data[:, 0]), inputs)
    w = inputs.rpm * math.pi / 30.0
    np.testing.assert_allclose(data[:, 1], s, rtol=1e-13, atol=1e-17)
    np.testing.assert_allclose(data[:, 2], w * ds, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(data[:, 3], w * w * dds, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(data[:, 4], force, rtol=1e-13)


def test_state_round_trip_reproduces_the_cam_and_the_angle(running_app):
    first = running_app(scene="cam_follower")
    scene = first.scene_for()
    wait_until(lambda: scene.revolution is not None)
    for key, value in (("profile", PROFILES[3]), ("follower", FOLLOWERS[1]), ("roller_mm", 7.5), ("rpm", 640.0),
                       ("stiffness", 3500.0), ("turn_seconds", 8.0), ("show_contact", False)):
        assert send_value(scene, key, value)
    wait_for_inputs(scene, profile=PROFILES[3], roller_mm=7.5, rpm=640.0, stiffness=3500.0)
    pause(scene)
    state = scene.state()
    assert state["scene"] == "cam_follower" and state["values"]["profile"] == PROFILES[3]
    assert state["playing"] is False and 0.0 <= state["cam_angle_deg"] < 360.0

    second = running_app(scene="cam_follower")
    other = second.scene_for()
    wait_until(lambda: other.revolution is not None)
    second.session_for().request_state(state)
    wait_for_inputs(other, profile=PROFILES[3], roller_mm=7.5, rpm=640.0, stiffness=3500.0)
    wait_until(lambda: other.index == scene.index and not other.playing)
    assert other.revolution.inputs == scene.revolution.inputs
    assert other.cam_angle == scene.cam_angle and not other.mechanism.contact_frame.visible
    assert other.mechanism.follower_z == scene.mechanism.follower_z and other.force == scene.force
    assert other.csv_bytes() == scene.csv_bytes()
    # refused entries are listed, the others applied
    with second.session_for().run_lock:
        refused = other.load_state({"scene": "cam_follower", "values": {"rpm": -5.0}, "cam_angle_deg": math.inf,
                                    "extra": 1, "playing": "no"})
    assert len(refused) == 4 and any("cam_angle_deg: expected a number from 0 to 360" in r for r in refused)
    assert any("playing: expected true or false, got 'no'" in r for r in refused) and not other.playing


def test_presenter_view_scales_labels_arrow_and_lines(cam_app):
    app, scene = cam_app
    base = scene.mechanism.force_arrow.arrow.shaft_radius
    label = scene.mechanism.labels["cam"].font_screen_scale
    wire = scene.mechanism.spring.wire_radius
    extent = np.ptp(np.array(scene.mechanism.spring.node.vertices)[:, 0])
    app.session_for().set_presenter(True)
    wait_until(lambda: scene.presenter)
    assert scene.mechanism.force_arrow.arrow.shaft_radius == pytest.approx(base * PRESENTER_ARROW_SCALE)
    assert scene.mechanism.labels["cam"].font_screen_scale == pytest.approx(label * PRESENTER_LABEL_SCALE)
    assert scene.mechanism.force_label.font_screen_scale == pytest.approx(label * PRESENTER_LABEL_SCALE)
    assert scene.mechanism.spring.wire_radius > wire
    assert np.ptp(np.array(scene.mechanism.spring.node.vertices)[:, 0]) > extent  # the wire's mesh was sent again
    assert "1.45em" in scene.legend.html()
    app.session_for().set_presenter(False)
    wait_until(lambda: not scene.presenter)
    assert scene.mechanism.force_arrow.arrow.shaft_radius == pytest.approx(base)


def test_help_cites_the_contact_equations_and_the_closed_forms():
    text = CamFollowerScene.help
    for eq in ("Eqs. 8.84-8.89", "Eqs. 8.90-8.94", "Eqs. 8.95-8.108", "Eq. 8.109"):
        assert eq in text
    assert "N = (m ω² s″ + k s + F0 + m g) / cos φ" in text
    assert "ω_j = √((2 k e + F0 + m g) / (m e))" in text
    assert not any(0x300 <= ord(ch) <= 0x36F for ch in text)  # no combining characters


def test_compliant_run_leaves_the_cam_and_lands_past_the_jump_speed(cam_app):
    app, scene = cam_app
    assert send_value(scene, "rpm", 1300.0)
    assert send_value(scene, "turn_seconds", 0.5)
    wait_for_inputs(scene, rpm=1300.0)
    assert send_value(scene, "compliant", True)
    wait_until(lambda: scene.compliant and scene.run_chunk is not None, timeout=120.0)
    chunk, run = scene.run_chunk, scene.run_chunk.run
    assert chunk.k == 0 and chunk.t.size == RUN_SAMPLES + 1
    assert scene.plot_handles["run_lift"].visible
    # the separation's advice follows the toggle
    wait_until(lambda: "The compliant run (its plots below) shows the follower" in scene.info.content)
    assert "Turn on *Compliant contact*" not in scene.info.content
    # on the cam at first (the constraint), then in flight by over a millimetre, then landed
    assert run.constraint[0] and run.separations.size >= 1 and run.landings.size >= 1
    assert run.gap.max() > 1e-3
    i = int(np.argmax(run.gap))
    assert run.contact_force[i] == 0.0  # no force in flight
    # it leaves where the closed form turns negative (within two outputs of 2 deg)
    inputs = scene.revolution.inputs
    w = inputs.speed
    force = inputs.preload + inputs.mass * GRAVITY
    root = math.acos(-(inputs.stiffness * E + force) / (inputs.mass * w * w * E - inputs.stiffness * E))
    assert w * run.separations[0, 0] == pytest.approx(root, abs=math.radians(4.0))
    # the readout counts the events of the revolution so far: none before the first separation, one after it
    before = int(run.separations[0, 0] / (chunk.t[1] - chunk.t[0])) - 1
    assert "**so far**: 0 separation(s), 0 landing(s)" in scene.run_lines(chunk, before)[2]
    assert "**so far**: 1 separation(s)" in scene.run_lines(chunk, before + 2)[2]
    # the scene draws the run: wait for a frame in flight (the arrow hidden, the follower above the cam)
    wait_until(lambda: scene.run_chunk is not None and "in flight" in scene.status.content, timeout=60.0)
    # in flight: no force arrow and no contact normal (the dot is the cam's point nearest the follower)
    marks = scene.mechanism
    wait_until(lambda: not marks.force_arrow.frame.visible and not marks.normal_line.visible, timeout=10.0)
    # on the cam again: the normal is back
    wait_until(lambda: "on the cam" in scene.status.content and scene.mechanism.normal_line.visible, timeout=60.0)
    # the next revolution continues from the last state of this one; its plots start at exactly 0 deg (uPlot
    # drops the axis's 0 tick for 5.7e-14)
    wait_until(lambda: scene.run_chunk is not None and scene.run_chunk.k >= 1, timeout=180.0)
    assert scene.paused_error is None and not notices_with(app, "Compliant run stopped")
    # the force plot is scaled to the closed form, not to the landing's impact (named in the legend)
    plot = scene.plot_handles["run_force"]

    def plotted() -> bool:  # (the revolution shown may move on while this waits: each try reads it again)
        columns = scene.run_chunk.table.columns
        (lo, hi), peak = capped_range(columns[:, 3], columns[:, 4])
        label = "System (N)" + ("" if peak is None else f", peak {significant(peak, 3)} off scale")
        return plot.scales["y"]["range"] == [lo, hi] and plot.series[2]["label"] == label

    wait_until(plotted)
    assert send_value(scene, "compliant", False)
    wait_until(lambda: not scene.compliant and not scene.plot_handles["run_lift"].visible)


def test_a_follower_thrown_beyond_the_stand_stops_the_compliant_run_with_a_notice(cam_app):
    # no spring force at 3000 rpm: only gravity pulls the follower back, and each landing throws it higher;
    # the drawn spring must never be squeezed shorter than its coils (the model has no stop: the run stops)
    app, scene = cam_app
    for key, value in (("stiffness", 0.0), ("preload", 0.0), ("rpm", 3000.0), ("turn_seconds", 0.5)):
        assert send_value(scene, key, value)
    wait_for_inputs(scene, rpm=3000.0, stiffness=0.0, preload=0.0)
    limit = scene.mechanism.travel_limit
    geometry = scene.mechanism.layout
    assert 0.01 < limit - float(np.max(scene.revolution.closed.lift)) < 0.02  # room above the cam's highest lift
    assert send_value(scene, "compliant", True)
    drawn = []

    def stopped() -> bool:  # (each look records the lift drawn)
        with app.session_for().run_lock:
            if scene.compliant:
                drawn.append(scene.mechanism.follower_z - geometry.pitch_height)
        return bool(notices_with(app, "Compliant run stopped"))

    wait_until(stopped, timeout=240.0)
    (notice,) = notices_with(app, "Compliant run stopped")
    assert "flew to the end of its travel" in notice[1] and "gravity alone (k = 0, F0 = 0)" in notice[1]
    wait_until(lambda: not scene.compliant and not scene.plot_handles["run_lift"].visible)
    # it flew (well above the cam's highest lift) and was never drawn beyond the stand's travel
    assert max(drawn) > float(np.max(scene.revolution.closed.lift)) + 0.005
    assert max(drawn) <= limit + 1e-3  # (one frame of motion past the limit at most)
    assert scene.paused_error is None


def test_the_run_plots_span_exactly_0_to_360_degrees_in_every_revolution():
    # degrees(theta) - 360 k is 5.7e-14 at revolution 1's start at 1300 rpm: uPlot then drops the 0 tick
    inputs = Inputs(rpm=1300.0)
    chunk = compute_chunk(inputs, 0, None)
    for k in range(1, 3):
        chunk = compute_chunk(inputs, k, chunk)
        x = chunk.table.columns[:, 0]
        assert x[0] == 0.0 and x[-1] == 360.0 and np.all(np.diff(x) > 0.0)


def test_the_compliant_force_plot_keeps_the_closed_form_readable_under_impact_peaks():
    # past the jump speed a landing's impact reaches kilonewtons against a closed form of about +-100 N
    def force_range(chunk):
        return capped_range(chunk.table.columns[:, 3], chunk.table.columns[:, 4])

    chunk = compute_chunk(Inputs(rpm=1300.0), 0, None)
    closed_force, force = chunk.table.columns[:, 3], chunk.run.contact_force
    closed_lo, closed_hi = float(closed_force.min()), float(closed_force.max())
    assert force.max() > 10.0 * closed_hi
    (lo, hi), peak = force_range(chunk)
    span = closed_hi - min(closed_lo, 0.0)
    assert lo < closed_lo and closed_hi < hi
    assert hi - lo < 4.0 * span  # the closed form fills over a quarter of the height
    assert peak == force.max()
    # below the jump speed nothing is off scale: the range is the forces' own, with 5 % margins
    calm = compute_chunk(Inputs(rpm=700.0), 0, None)
    (lo, hi), peak = force_range(calm)
    calm_force = calm.run.contact_force
    top, bottom = max(calm_force.max(), calm.table.columns[:, 3].max()), min(calm_force.min(), 0.0)
    assert peak is None
    assert hi == pytest.approx(top + 0.05 * (top - bottom)) and lo == pytest.approx(bottom - 0.05 * (top - bottom))


def test_compliant_run_below_the_jump_speed_follows_the_closed_form():
    inputs = Inputs(rpm=700.0)
    chunk = compute_chunk(inputs, 0, None)
    run = chunk.run
    s, ds, dds, force = flat_closed_form(run.cam_angle, inputs)
    np.testing.assert_allclose(run.lift, s, atol=1e-10)
    np.testing.assert_allclose(run.contact_force, force, rtol=1e-7)
    assert np.all(run.constraint) and run.separations.size == 0 and run.periodic
    revolution = compute_revolution(inputs)
    # the System's contact point is the scene's closed-form contact point
    np.testing.assert_allclose(run.contact_point[:, 0], E * np.sin(run.cam_angle), atol=1e-9)
    np.testing.assert_allclose(run.contact_point[:, 2], RB + s, atol=1e-9)
    i = REVOLUTION_SAMPLES // 4  # 90 deg, also an output of the run (every 2 deg)
    j = RUN_SAMPLES // 4
    np.testing.assert_allclose(revolution.closed.contact_point[i], run.contact_point[j, [0, 2]], atol=1e-9)
    with pytest.raises(ValueError, match="previous: revolution 2 continues from revolution 1"):
        compute_chunk(inputs, 2, chunk)
    # on the cam throughout: the next revolution repeats this one a period later, not computed again;
    # a run of the System over that revolution (kinematic, as the chunk's) is the same motion
    period = 2.0 * math.pi / inputs.speed
    second = compute_chunk(inputs, 1, chunk)
    assert second.k == 1 and second.t[0] == pytest.approx(period, rel=1e-15) and second.run is run
    np.testing.assert_allclose(second.t * inputs.speed, run.cam_angle + 2.0 * math.pi, rtol=0, atol=1e-12)
    cam = build_cam(inputs)
    direct = cam.simulate(inputs.speed, period * (1.0 + np.arange(RUN_SAMPLES + 1) / RUN_SAMPLES))
    # both are solved from the constraints to the Newton tolerance (1e-12 m, about 1e-10 of the lift)
    np.testing.assert_allclose(second.run.lift, direct.lift, rtol=0, atol=1e-11)
    np.testing.assert_allclose(second.run.contact_force, direct.contact_force, rtol=1e-10)


def test_every_cam_and_follower_gives_a_closed_mesh_and_finite_tables():
    for profile in PROFILES:
        for follower in FOLLOWERS:
            inputs = Inputs(profile=profile, follower=follower, rpm=2000.0)
            rev = compute_revolution(inputs).closed
            cam = build_cam(inputs)
            theta = np.arange(REVOLUTION_SAMPLES + 1) * (2 * math.pi / REVOLUTION_SAMPLES)
            np.testing.assert_array_equal(rev.lift, cam.kinematics(theta).lift)
            np.testing.assert_array_equal(rev.contact_force, cam.contact_force(theta, inputs.speed))
            vertices, faces = cam_layout(build_cam(inputs, shape_only=True)).cam
            assert faces.max() < vertices.shape[0] and np.all(np.isfinite(vertices))
            # the contour drawn passes through every contact point (turned back into the cam frame)
            c, s = np.cos(theta), np.sin(theta)
            body = np.column_stack([c * rev.contact_point[:, 0] + s * rev.contact_point[:, 1],
                                    -s * rev.contact_point[:, 0] + c * rev.contact_point[:, 1]])
            np.testing.assert_allclose(body, cam.cam_curve(theta).point, atol=1e-12)
            assert rev.jump_speed == pytest.approx(cam.jump_speed(), rel=1e-12)
            assert rev.separations  # 2000 rpm is past every default cam's jump speed


def test_extruded_contours_are_closed_with_outward_faces():
    from rigidlab.app.meshes import extrude as _extrude

    # star-shaped about the origin (fan caps) and a C shape that is not (ear clipping)
    t = np.linspace(0, 2 * math.pi, 200, endpoint=False)
    ellipse = np.column_stack([0.05 * np.cos(t), 0.03 * np.sin(t)])[::-1]  # clockwise, as cam_curve runs
    arc = np.linspace(0.3, 2 * math.pi - 0.3, 60)
    c_shape = np.concatenate([np.column_stack([np.cos(arc), np.sin(arc)]),
                              np.column_stack([0.6 * np.cos(arc[::-1]), 0.6 * np.sin(arc[::-1])])]) + [0.2, 0.0]
    for contour in (ellipse, c_shape):
        x, y = contour[:, 0], contour[:, 1]
        area = abs(0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
        mesh = _extrude(contour, -0.5, 0.5)
        assert mesh.vertices.shape[0] == 4 * contour.shape[0] + 2
        assert mesh.faces.shape[0] == 4 * contour.shape[0]  # same counts either way (buffers replaced in place)
        # the prism's volume from its outward faces (divergence theorem) is area x height
        v = mesh.vertices[mesh.faces]
        volume = np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0
        assert volume == pytest.approx(area * 1.0, rel=1e-12)


# -- a scene on a bare server, driven frame by frame ----------------------------
@pytest.fixture
def bare_scene(make_bare_scene):
    return lambda executor=None: make_bare_scene(CamFollowerScene, executor)


def test_nothing_is_computed_on_the_loop_and_the_frames_go_on(bare_scene):
    executor = GatedExecutor()
    scene, _ = bare_scene(executor)
    for _ in range(20):
        scene.frame(1 / 60)
    assert scene.revolution is None and scene.paused_error is None  # waiting for the job
    executor.open.set()
    wait_until(lambda: (scene.frame(1 / 60), scene.revolution is not None)[1], interval=0.0)
    # a stalled loop advances the cam by at most 0.1 s of wall time
    before = scene.sim_time
    scene.frame(30.0)
    turn = scene.controls.value("turn_seconds")
    period = 2 * math.pi / scene.revolution.closed.speed
    assert 0 < scene.sim_time - before <= period * 0.1 / turn + 1e-12


def test_labels_are_framed_left_of_the_panel_and_do_not_overlap(bare_scene):
    scene, _ = bare_scene()
    wait_until(lambda: (scene.frame(1 / 60), scene.revolution is not None)[1])
    camera = Camera(CamFollowerScene.camera_position, CamFollowerScene.camera_look_at)
    click(scene, "playback", "Pause")
    for angle in (0.0, 90.0, 180.0, 270.0):
        scene.load_state({"scene": "cam_follower", "values": {}, "cam_angle_deg": angle})
        for _ in range(3):
            scene.frame(1 / 60)
        boxes = {}
        for name, handle in (*scene.mechanism.labels.items(), ("N", scene.mechanism.force_label)):
            x, y = camera.pixels(np.asarray(handle.position))
            boxes[name] = label_box(x, y, _LABEL_TEXT[name], handle._impl.props.anchor, 1.3)
            assert 0 < x < 0.62 * 1200 and 0 < y < 750, (name, x, y)
        assert overlapping_pairs(boxes) == [], angle
    # the mechanism fills a good part of the view, left of the panel
    top = camera.pixels((0.0, 0.0, scene.mechanism.layout.spring_top))
    bottom = camera.pixels((0.0, 0.0, -0.05))
    assert 250 < bottom[1] - top[1] < 700 and top[0] < 0.62 * 1200


_LABEL_TEXT = {"cam": "cam (turns at ω)", "follower": "follower", "spring": "spring k, F0", "N": "N"}


def test_the_mechanism_draws_the_cam_and_follower_it_is_given(bare_scene):
    # the drawing component alone (app/scenes/_cam.py), on a scene whose clock never ran: use() swaps in a cam's
    # meshes and its separation arc, pose() draws one instant
    scene, _ = bare_scene()
    mechanism = scene.mechanism
    assert mechanism.follower_meshes["flat"].visible and not mechanism.roller_mesh.visible
    cam = build_cam(Inputs(follower=FOLLOWERS[1], roller_mm=15.0), shape_only=True)
    layout = cam_layout(cam)
    assert cam_layout(cam) is layout and layout.pitch_height == pytest.approx(R + 0.015 - E, abs=1e-15)
    rev = cam.revolution(1.3 * cam.jump_speed(), samples=720)  # past the jump speed: an interval to mark
    mechanism.use(layout, rev.separated)
    assert mechanism.layout is layout and mechanism.roller_mesh.visible and mechanism.follower_meshes["roller"].visible
    assert not mechanism.follower_meshes["flat"].visible and mechanism.separation_arc.visible
    vertices = np.asarray(mechanism.roller_mesh.vertices)
    assert np.max(np.hypot(vertices[:, 0], vertices[:, 2])) == pytest.approx(0.015, rel=1e-6)
    mechanism.use(layout)  # no separation to mark
    assert not mechanism.separation_arc.visible
    # the follower at the pitch height plus the lift, the cam turned by theta about -y (its plane's z)
    theta, lift = 0.7, 0.004
    mechanism.pose(theta, lift, np.array([0.01, 0.05]), np.array([0.6, 0.8]), 25.0, in_contact=True,
                   show_contact=True)
    assert float(mechanism.follower_frame.position[2]) == pytest.approx(layout.pitch_height + lift, abs=1e-15)
    assert mechanism.follower_z == pytest.approx(layout.pitch_height + lift, abs=1e-15)
    np.testing.assert_allclose(mechanism.cam_frame.wxyz, [math.cos(theta / 2), 0, 0, math.sin(theta / 2)], atol=1e-15)
    np.testing.assert_allclose(np.asarray(mechanism.contact_point.position)[[0, 2]], [0.01, 0.05], atol=1e-15)
    normal = _in_global(mechanism.contact_point, np.array(mechanism.normal_line.points)[0])
    direction = (normal[1] - normal[0]) / np.linalg.norm(normal[1] - normal[0])
    np.testing.assert_allclose(direction[[0, 2]], [0.6, 0.8], atol=1e-7)
    assert mechanism.contact_frame.visible and mechanism.normal_line.visible and mechanism.force_label.visible
    arrow = mechanism.force_arrow
    assert arrow.frame.visible
    for force, color in ((-5.0, (150, 60, 200)), (25.0, (245, 140, 0))):  # a pull purple, a push orange
        mechanism.pose(theta, lift, np.array([0.01, 0.05]), np.array([0.6, 0.8]), force, in_contact=True,
                       show_contact=True)
        assert np.array_equal(np.asarray(arrow.arrow.colors)[0], vertex_rgb(color))
    # in flight: the dot only; contact marks off: nothing
    mechanism.pose(theta, 0.02, np.array([0.01, 0.05]), np.array([0.0, 1.0]), 0.0, in_contact=False,
                   show_contact=True)
    assert not (arrow.frame.visible or mechanism.normal_line.visible or mechanism.force_label.visible)
    mechanism.pose(theta, lift, np.array([0.01, 0.05]), np.array([0.0, 1.0]), 25.0, in_contact=True,
                   show_contact=False)
    assert not mechanism.contact_frame.visible
    # the stand's travel ends where the drawn spring is solid
    assert mechanism.travel_limit == pytest.approx(layout.spring_top - layout.pitch_height - layout.seat
                                                   - mechanism.spring.solid, abs=1e-15)
    assert mechanism.travel_limit > float(np.max(rev.lift)) + 0.01
