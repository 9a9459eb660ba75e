"""Rolling disk scene (app/scenes/rolling_disk.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz and the chunks run on the
app's process pool through the System path (``rigidlab.core.models.rolling_disk``,
``System.simulate``); tests act as a browser does (values through the gate
with ``send_value``, preset clicks) and check what the scene streams and
exports: upright rolling above the critical spin stays upright and below
it the lean grows, the energy stays within its bound, the contact point's
track grows on the ground, a disk that cannot stay on the ground stops the
clock with a notice, refused input changes nothing, the state round trip,
the CSV and presenter view. A few tests call the chunk job directly.
"""

from __future__ import annotations

import csv
import io
import math
import os

import numpy as np
import pytest

from rigidlab.app.scenes.rolling_disk import (
    CONTACTS,
    CSV_HEADER,
    PRESETS,
    ROLLING,
    RTOL,
    SLIDING,
    Inputs,
    Model,
    RollingDiskScene,
    _compute_chunk,
    preset_inputs,
    track_pieces,
)
from rigidlab.core.models import rolling_disk_critical_spin
from rigidlab.core.rotations import matrix_from_euler_parameters
from tests.helpers import click, send_value, wait_for_frames, wait_until

# simulated time runs at up to 4 s per second while the pool keeps up
FAST = 4.0


@pytest.fixture
def disk(running_scene):
    return running_scene(RollingDiskScene)


def notices_with(app, text):
    return [n for n in app.session_for().notices if text in n[0] or text in n[1]]


def wait_for_model(scene, timeout=60.0, after=0.2, **fields):
    """Wait until the model drawn has ``fields`` and has run for ``after`` s."""
    wait_until(lambda: scene.drawn_model is not None and scene.drawn_model == scene.model
               and all(getattr(scene.model, k) == v for k, v in fields.items())
               and scene.sim_time > after, timeout=timeout)


def run_until(scene, t, timeout=120.0):
    """Play fast until the clock reaches ``t`` s (or the motion ended)."""
    scene.playback.set_time_scale(FAST)
    wait_until(lambda: scene.sim_time >= t or scene.ended, timeout=timeout)


def csv_rows(scene):
    rows = list(csv.reader(io.StringIO(scene.csv_bytes().decode())))
    assert ",".join(rows[0]) == CSV_HEADER
    return np.array(rows[1:], dtype=float)


def test_scene_is_registered_after_the_multibody_scenes():
    from rigidlab.app.scenes import discover_scenes

    scenes = discover_scenes()
    assert scenes["rolling_disk"] is RollingDiskScene and RollingDiskScene.order == 80
    assert all(cls.order <= 80 for name, cls in scenes.items() if list(scenes).index(name) < list(scenes).index(
        "rolling_disk"))
    # the help cites the contact equations, the rolling constraint and the critical speed
    for text in ("8.90", "8.107", "8.109", "8.95", "v + ω × (r_P − R) = 0", "g / (3 R)"):
        assert text in RollingDiskScene.help


def test_upright_above_the_critical_spin_stays_upright(disk):
    app, scene = disk
    click(scene, "preset_0")  # upright (1 deg), twice the critical spin
    critical = rolling_disk_critical_spin(0.1)
    wait_for_model(scene, spin=round(2.0 * critical, 2), rolling=True)
    run_until(scene, 3.0)
    assert not scene.ended
    data = csv_rows(scene)
    assert data[-1, 0] >= 2.9 and data[0, 0] == 0.0
    lean = np.degrees(data[:, 8])
    # the linearized wobble about upright keeps a 1 deg lean below 1.7 deg
    # (the reduced equations give 1.67); 3 deg is far from any fall
    assert lean.max() < 3.0 and lean.min() > -3.0
    assert "**above** it" in scene.info.content


def test_upright_below_the_critical_spin_leans_over(disk):
    app, scene = disk
    click(scene, "preset_1")  # upright (1 deg), 0.7 times the critical spin
    critical = rolling_disk_critical_spin(0.1)
    wait_for_model(scene, spin=round(0.7 * critical, 2), rolling=True)
    run_until(scene, 3.0)
    data = csv_rows(scene)
    lean = np.degrees(data[:, 8])
    # the lean grows like sinh(6.3 t) from 1 deg; the reduced equations reach 51 deg
    assert lean.max() > 20.0
    assert "**below** it" in scene.info.content


def test_energy_is_conserved_within_the_integrator_tolerance(disk):
    app, scene = disk
    wait_for_model(scene)
    run_until(scene, 3.0)
    data = csv_rows(scene)
    energy = data[:, 9]
    e0 = scene.energy0
    assert energy[0] == pytest.approx(e0, rel=1e-14)  # the CSV keeps 15 digits
    # Neither contact constraint does work, so E is constant up to the
    # integrator: DOP853 keeps each step's local error within rtol = 1e-6 of
    # the state, and over 3 s (about 60 steps) the measured drift is ~5e-8 E0.
    # The bound rtol * E0 holds with a factor of 20 to spare; a lost
    # constraint force or a wrong projection would break it by far more.
    assert np.abs(energy - e0).max() <= RTOL * abs(e0)
    # the residuals stay at the projection's round-off
    assert data[:, 10].max() < 1e-10 and data[:, 11].max() < 1e-10
    # and the normal force holds the disk up: m g on average
    assert 0.5 * 9.81 < data[:, 12].mean() < 1.5 * 9.81


def test_the_track_grows_on_the_ground(disk):
    app, scene = disk
    wait_for_model(scene)
    n0 = scene.track_points.shape[0]
    t0 = scene.sim_time
    wait_until(lambda: scene.sim_time > t0 + 0.5)
    with app.session_for().run_lock:
        track = scene.track_points
        point = np.array(scene.contact_point)
        # the chunk nodes as viser holds them, without their two far bounds segments
        sent = np.concatenate([np.array(node.points)[:-2] for node in scene.track.nodes if node.visible])
        head = scene.track_head.segments
    assert track.shape[0] > n0 + 5 and track.shape[0] <= scene.track.chunks * scene.track.chunk_segments + 1
    np.testing.assert_allclose(track[:, 2], 0.0015, atol=1e-9)  # on the ground, lifted over the grid
    # the newest point is a computed contact point at most one sample behind the one drawn
    assert np.linalg.norm(track[-1, :2] - point[:2]) < 0.05
    # every point sent is a track point (float32)
    distances = np.linalg.norm(sent.reshape(-1, 1, 3) - track[None], axis=2)
    assert np.max(np.min(distances, axis=1)) < 1e-5
    # the head's sticks (placed by poses) run on from the track to the contact point drawn: the tip
    # starts there, and every stick's end lies on the track's polyline or beyond its newest point
    np.testing.assert_allclose(head[-1, 0, :2], point[:2], atol=1e-9)
    chords = head[:-1]
    np.testing.assert_allclose(np.linalg.norm(chords[:, 1] - chords[:, 0], axis=1), scene.track_head.length,
                               rtol=1e-9)
    a, b = track[None, :-1], track[None, 1:]
    ends = chords.reshape(-1, 1, 3)
    u = np.clip(np.sum((ends - a) * (b - a), axis=2) / np.maximum(np.sum((b - a) ** 2, axis=2), 1e-300), 0, 1)
    off = np.linalg.norm(a + u[..., None] * (b - a) - ends, axis=2).min(axis=1)
    beyond = np.linalg.norm(chords.reshape(-1, 3) - point, axis=1) < 0.05  # past the newest track point
    assert np.all((off < 1e-6) | beyond)


def _turns(points):
    """Angles (deg) between consecutive segments of a polyline (n, 3); repeated points left out."""
    d = np.diff(points, axis=0)
    d = d[np.linalg.norm(d, axis=1) > 0.0]
    u = d / np.linalg.norm(d, axis=1)[:, None]
    return np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0)))


def test_track_pieces_follow_the_curve_between_coarse_samples():
    # samples of a circle (radius rho) 20 degrees apart: a 3 cm coin's contact point on its loops
    rho = 0.05

    def circle(deg):
        return np.array([rho * math.cos(math.radians(deg)), rho * math.sin(math.radians(deg)), 0.0015])

    def worst(step):
        pieces = track_pieces([circle(-step), circle(0.0)], circle(step))
        gap = max(abs(math.hypot(q[0], q[1]) - rho) for q in pieces)
        return pieces, gap

    pieces, gap = worst(20.0)
    assert len(pieces) == 7 and np.array_equal(pieces[-1], circle(20.0))  # ceil(20 / 3) pieces, ending on q2
    # the parabola through three samples is off by at most rho phi^3 max|s (s^2 - 1)| / 6 = 0.064 rho phi^3
    phi = math.radians(20.0)
    assert gap < 0.065 * rho * phi**3
    assert gap < 0.2 * rho * (1.0 - math.cos(phi / 2))  # five times closer than the chord (its sagitta)
    # each piece turns by about 3 degrees, the chord before it included
    assert _turns(np.array([circle(0.0), *pieces])).max() < 3.5
    # third order at least (the distance from a circle is fourth: 1/16): half the step, under an eighth of it
    assert worst(10.0)[1] < gap / 8.0
    # a straight track, a stop, the first two samples: the sample itself
    line = [np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])]
    assert len(track_pieces(line, np.array([2.0, 0.0, 0.0]))) == 1
    assert len(track_pieces([line[1], line[1]], np.array([2.0, 1.0, 0.0]))) == 1
    assert len(track_pieces(line[:1], np.array([2.0, 1.0, 0.0]))) == 1
    assert len(track_pieces([], line[0])) == 1


def test_a_small_coins_track_is_a_smooth_curve(disk):
    # a 3 cm coin circles on loops of a few centimetres, its samples 1/60 s apart turn by up to 20 degrees
    app, scene = disk
    assert send_value(scene, "radius", 0.03)
    wait_for_model(scene, radius=0.03, after=1.5)
    with app.session_for().run_lock:
        track = scene.track_points
        samples = scene.last_chunk.frames[:, 7:10]  # (the contact point)
    assert _turns(samples[:, :2]).max() > 10.0
    # pieces of about 3 degrees; where the 0.6 mm minimum step of the track merges two, up to about twice that
    assert track.shape[0] > 50 and _turns(track).max() < 7.0


def test_the_camera_follows_the_disk_or_not(disk):
    app, scene = disk
    wait_for_model(scene)
    wait_until(lambda: abs(scene.centre[0]) > 0.05)
    with app.session_for().run_lock:
        centre = np.array(scene.centre)
        ground = np.array(scene.ground.position)
        drawn = np.array(scene.disk.position)
    # (a pose is sent when it moves by more than 1e-5 relative: viser's rule)
    np.testing.assert_allclose(ground[:2], -centre[:2], atol=1e-5)
    np.testing.assert_allclose(drawn, [0.0, 0.0, centre[2]], atol=1e-5)
    assert send_value(scene, "follow", False)
    wait_until(lambda: not np.allclose(scene.disk.position[:2], 0.0))
    with app.session_for().run_lock:
        np.testing.assert_allclose(np.array(scene.disk.position), scene.centre, atol=1e-5)
        np.testing.assert_array_equal(np.array(scene.ground.position), 0.0)


def test_the_pose_is_the_systems_and_the_disk_rolls(disk):
    app, scene = disk
    wait_for_model(scene)
    with app.session_for().run_lock:
        p = np.array(scene.disk.wxyz)
        centre = np.array(scene.centre)
        lean = float(scene.columns[7])
    np.testing.assert_allclose(np.linalg.norm(p), 1.0, atol=1e-9)
    # the disk's axis (body y) rises by the lean; the centre is R cos(lean) high
    A = matrix_from_euler_parameters(p)
    assert abs(A[2, 1] - math.sin(lean)) < 0.05
    assert abs(centre[2] - 0.1 * math.cos(lean)) < 2e-3
    wait_until(lambda: scene.last_chunk is not None and scene.last_chunk.k >= 1)
    assert scene.last_chunk.worker != os.getpid()  # computed in a worker process


def test_the_force_arrow_is_the_contact_force_at_the_contact_point(disk):
    app, scene = disk
    wait_for_model(scene)
    click(scene, "playback", "Pause")
    wait_until(lambda: not scene.playing)
    wait_until(lambda: scene._drawn is not None and scene._drawn[0] == scene.sim_time)
    with app.session_for().run_lock:
        chunk = scene.last_chunk
        t = scene.sim_time
        wxyz = np.array(scene.force_frame.wxyz)
        points = np.array(scene.force_arrow.points)
        at = np.array(scene.point.position)
    # the sample drawn: the layer draws the sample at or before the clock
    j = scene.sample_index(chunk)
    assert chunk.t[j] <= t + 1e-9 and (j == chunk.t.size - 1 or chunk.t[j + 1] > t)
    force, point = chunk.frames[j, 10:13], chunk.frames[j, 7:10]
    np.testing.assert_allclose(at[:2], point[:2], atol=1e-6)  # the arrow's frame sits on the contact point
    direction = matrix_from_euler_parameters(wxyz)[:, 2]
    np.testing.assert_allclose(direction, force / np.linalg.norm(force), atol=1e-5)
    # mostly the normal force, up: the ground pushes
    assert direction[2] > 0.9
    magnitude = np.linalg.norm(force)
    length = 3 * 0.1 * magnitude / (magnitude + 9.81)
    assert points[0, 1, 2] == pytest.approx(length, rel=0.03)  # resent when it changes by 2 %


def stop_without_spin(scene):
    """Set the spin to 0 and play until the disk has left the ground and stopped the clock itself."""
    assert send_value(scene, "spin", 0.0)
    wait_for_model(scene, spin=0.0, after=0.0)
    run_until_stopped(scene)


def run_until_stopped(scene):
    run_until(scene, 2.0)
    wait_until(lambda: scene.ended)  # the clock holds at the end


def test_leaving_the_ground_stops_the_clock_with_a_notice(disk):
    app, scene = disk
    stop_without_spin(scene)
    assert "left the ground" in scene.last_chunk.end
    assert notices_with(app, "Rolling disk stopped")
    t_end = scene.sim_time
    data = csv_rows(scene)
    assert data[-1, 0] == pytest.approx(t_end)
    assert data[-1, 12] < 0.05 * 9.81  # the normal force went to zero there
    # Reset plays again from the start
    click(scene, "playback", "Reset")
    wait_until(lambda: scene.playing and scene.sim_time < t_end and not scene.ended)


def test_a_control_changed_after_the_disk_stopped_itself_plays_again(disk):
    # the notice says "Change a control, pick a preset or press Reset": a control must run it again, and a
    # Reset after that control too
    app, scene = disk
    stop_without_spin(scene)
    assert send_value(scene, "lean_deg", 30.0)
    wait_until(lambda: scene.model.lean == pytest.approx(math.radians(30.0)))
    wait_until(lambda: scene.playing and scene.sim_time > 0.05)
    run_until_stopped(scene)
    click(scene, "playback", "Reset")
    wait_until(lambda: scene.playing and scene.sim_time > 0.05 and not scene.ended)
    # a pause by hand is kept: a control then starts the new motion paused
    scene.playback.set_playing(False)
    assert send_value(scene, "lean_deg", 20.0)
    wait_until(lambda: scene.model.lean == pytest.approx(math.radians(20.0)))
    wait_for_frames(scene, 20)
    assert not scene.playing and scene.sim_time == 0.0


def test_bad_inputs_are_refused_and_change_nothing(disk):
    app, scene = disk
    wait_for_model(scene)
    model = scene.model
    for key, raw in (("radius", 0.0), ("radius", -0.1), ("radius", 5.0), ("mass", 0.0), ("lean_deg", 90.0),
                     ("spin", math.nan), ("spin", math.inf), ("heading_rate", 1e308), ("contact", "sticky"),
                     ("contact", 3), ("lean_deg", "10")):
        assert not send_value(scene, key, raw), (key, raw)
    assert scene.model == model
    assert scene.controls.value("radius") == 0.1 and scene.controls.value("contact") == ROLLING
    # a state with bad entries: they are listed, the good ones applied
    refused = scene.load_state({"scene": "rolling_disk", "values": {"radius": -1.0, "mass": 2.0, "spin": "fast"}})
    assert len(refused) == 2 and any("radius" in r.lower() or "Radius" in r for r in refused)
    wait_until(lambda: scene.model.mass == 2.0)
    assert scene.model.radius == 0.1
    # the core refuses what the controls cannot send
    with pytest.raises(ValueError, match="contact: expected one of"):
        Model.from_inputs(Inputs(contact="sticky"))
    with pytest.raises(ValueError, match="radius"):
        Model.from_inputs(Inputs(radius=0.0))
    with pytest.raises(ValueError, match="name: expected one of"):
        preset_inputs("Spinning top")


def test_state_round_trip(disk, running_app):
    app, scene = disk
    assert send_value(scene, "contact", SLIDING)
    assert send_value(scene, "lean_deg", 25.5)
    assert send_value(scene, "spin", -17.25)
    assert send_value(scene, "heading_rate", 1.5)
    assert send_value(scene, "radius", 0.15)
    assert send_value(scene, "show_track", False)
    wait_for_model(scene, rolling=False, radius=0.15, after=0.0)
    state = scene.state()
    assert state["scene"] == "rolling_disk"
    other = running_app(scene="rolling_disk").scene_for()
    assert other.load_state(state) == []
    wait_until(lambda: other.model == scene.model)
    assert other.state() == state
    assert other.model == Model(0.15, 1.0, math.radians(25.5), -17.25, 1.5, False)


def test_radius_scales_the_disk_and_the_critical_spin(disk):
    app, scene = disk
    assert send_value(scene, "radius", 0.2)
    wait_for_model(scene, radius=0.2)
    wait_until(lambda: scene.disk_mesh.scale == 0.2)
    assert scene.disk_marker.scale == 0.2
    # the force arrow's shaft and head in proportion (twice the default radius: twice as thick)
    assert scene.force_arrow.shaft_radius == pytest.approx(2 * 0.0035)
    assert scene.force_arrow.head_length == pytest.approx(2 * 0.02)
    # and the track head's sticks (6 cm: a small coin's track is not a polygon of 3 cm chords)
    assert scene.track_head.length == pytest.approx(0.06)
    assert np.asarray(scene.track_head.tip.points)[0, 1, 2] == pytest.approx(0.06)
    critical = rolling_disk_critical_spin(0.2)
    assert f"{critical:.2f} rad/s" in scene.info.content
    # the view is scaled with the disk (twice the default radius: twice as far, about the origin)
    camera = app.server.initial_camera
    np.testing.assert_allclose(camera.position, 2.0 * np.array(RollingDiskScene.camera_position), rtol=1e-6)
    np.testing.assert_allclose(camera.look_at, 2.0 * np.array(RollingDiskScene.camera_look_at), rtol=1e-6)
    assert send_value(scene, "contact", SLIDING)
    wait_for_model(scene, rolling=False)
    assert f"{rolling_disk_critical_spin(0.2, rolling=False):.2f} rad/s" in scene.info.content



def test_reset_after_a_run_longer_than_the_chunks_kept_plays_again(disk):
    """Reset keeps the computed chunks; after a run longer than the timeline holds, chunk 0 is computed
    again, and was dropped at once as the lowest of too many: the clock held at 0 for good."""
    app, scene = disk
    wait_for_model(scene)
    with app.session_for().run_lock:
        scene.timeline.capacity = 3  # (24 chunks of 0.5 s in the scene: 12 s of play)
    run_until(scene, 2.6)
    assert not scene.ended and 0 not in scene.timeline._chunks
    click(scene, "playback", "Reset")
    assert wait_until(lambda: scene.sim_time < 0.5, timeout=10.0)
    assert wait_until(lambda: scene.sim_time > 0.6, timeout=60.0), f"the clock held at t = {scene.sim_time}"


def test_a_preset_whose_values_are_set_starts_again(disk):
    app, scene = disk
    click(scene, "preset_3")  # sliding coin
    wait_for_model(scene, rolling=False, after=1.0)
    click(scene, "preset_3")
    assert wait_until(lambda: scene.sim_time < 0.5, timeout=10.0), "the preset did not start the motion again"


@pytest.mark.parametrize("name", PRESETS)
def test_presets_set_their_values(name):
    inputs = preset_inputs(name, radius=0.05, mass=0.5)
    assert inputs.radius == 0.05 and inputs.mass == 0.5 and inputs.contact in CONTACTS
    model = Model.from_inputs(inputs)  # within the controls' ranges
    if name.startswith("Upright"):  # every preset sets its contact: the upright ones roll
        factor = 2.0 if "2 ×" in name else 0.7
        critical = rolling_disk_critical_spin(0.05, rolling=True)
        assert model.spin == pytest.approx(factor * critical, abs=0.005) and model.rolling


def test_an_upright_preset_after_the_sliding_coin_rolls(disk):
    # the upright presets set the contact too: after "Sliding coin" they do not keep sliding (critical 9.90 rad/s)
    app, scene = disk
    click(scene, "preset_3")
    wait_for_model(scene, rolling=False, after=0.0)
    click(scene, "preset_0")
    wait_for_model(scene, rolling=True, spin=round(2.0 * rolling_disk_critical_spin(0.1), 2), after=0.0)
    assert scene.controls.value("contact") == ROLLING and scene.model.spin == pytest.approx(11.44)
    assert "5.72 rad/s" in scene.info.content


def test_the_scene_computes_only_while_shown(disk):
    app, scene = disk
    wait_for_model(scene)
    app.switch_scene("sandbox")
    wait_until(lambda: app.scene_for().name == "sandbox")
    wait_until(lambda: not scene.timeline.busy, timeout=30.0)
    computed, frames = scene.chunks_computed, scene.frames
    wait_for_frames(app.scene_for(), 90)  # the shown scene's loop runs on
    assert scene.frames == frames  # a hidden scene gets no frames
    assert scene.chunks_computed == computed


def test_presenter_view_thickens_the_track_and_enlarges_labels(disk):
    app, scene = disk
    wait_for_model(scene)
    with app.session_for().run_lock:
        scene.set_presenter(True)
    assert scene.track.thickness == pytest.approx(6.0)
    assert scene.point_label.font_screen_scale == pytest.approx(1.2 * 1.8)
    assert scene.force_arrow.shaft_radius == pytest.approx(0.0035 * 1.8)
    with app.session_for().run_lock:
        scene.set_presenter(False)
    assert scene.track.thickness == pytest.approx(3.0)


def test_chunks_continue_the_system_and_a_fall_ends_them():
    model = Model.from_inputs(Inputs())
    c0 = _compute_chunk(model, 0, None)
    c1 = _compute_chunk(model, 1, c0)
    assert not c0.final and not c1.final
    assert c1.t[0] == c0.t[-1] == 0.5 and c1.t[-1] == 1.0
    np.testing.assert_allclose(c1.frames[0], c0.frames[-1], atol=1e-9)  # continued from chunk 0's end
    assert c1.energy0 == c0.energy0
    with pytest.raises(ValueError, match="chunk 2 continues from chunk 1"):
        _compute_chunk(model, 2, c0)
    # a frictionless disk without spin falls flat: the run ends before the contact loses rank (the layer asks
    # for no chunk after a final one)
    flat = Model.from_inputs(Inputs(lean_deg=20.0, spin=0.0, contact=SLIDING))
    f0 = _compute_chunk(flat, 0, None)
    assert f0.final and ("flat" in f0.end) and f0.t[-1] < 0.5


def test_chunks_carry_the_tracks_pieces_and_the_plotted_columns():
    # a frame only slices these: the track's points (the contact point's samples lifted over the ground, with
    # the pieces between sharply turning samples) and the table the plots and the CSV read, formed by the job
    model = Model.from_inputs(Inputs(radius=0.03, lean_deg=20.0, spin=10.0))  # a small coin's loops
    c0 = _compute_chunk(model, 0, None)
    c1 = _compute_chunk(model, 1, c0)
    lift = np.array([0.0, 0.0, 0.0015])
    # the samples in the order the clock passes them (chunk 1's first is chunk 0's last), each extending the
    # track from the two before it
    samples = [*(c0.frames[:, 7:10] + lift), *(c1.frames[1:, 7:10] + lift)]
    expected, before = [], []
    for q in samples:
        expected.extend(track_pieces(before, q))
        before = [*before[-1:], q]
    np.testing.assert_array_equal(np.concatenate([c0.track, c1.track]), np.array(expected))
    assert len(expected) > len(samples)  # pieces between the samples of the loops
    for chunk in (c0, c1):
        assert chunk.track_start.shape == (chunk.t.size + 1,) and chunk.track_start[0] == 0
        assert chunk.track_start[-1] == chunk.track.shape[0] and np.all(np.diff(chunk.track_start) >= 0)
        assert np.all(np.diff(chunk.track_start)[1:] >= 1)  # every sample after the first adds its own point
    assert c0.track_start[1] == 1 and c1.track_start[1] == 0  # chunk 1's first sample was drawn with chunk 0
    for chunk in (c0, c1):  # the table is core's run (the CSV's columns)
        run, columns = chunk.run, chunk.table.columns
        np.testing.assert_array_equal(chunk.table.t, run.t)
        np.testing.assert_array_equal(columns[:, :7], run.q)
        np.testing.assert_array_equal(columns[:, 7:], np.column_stack([run.lean, run.energy, run.residual_position,
                                                                       run.residual_velocity, run.normal_force]))
    # the plotted series, from those columns
    scene_plots = {spec.name: spec for spec in RollingDiskScene.plots(type("S", (), {"energy0": c0.energy0})())}
    columns = c1.table.columns
    (lean,) = scene_plots["lean"].data(c1.t, columns)
    np.testing.assert_array_equal(lean, np.degrees(columns[:, 7]))
    (drift,) = scene_plots["energy"].data(c1.t, columns)
    with np.errstate(divide="ignore"):  # (E - E0 = 0 at t = 0: the log plots' floor)
        np.testing.assert_array_equal(drift, np.maximum(np.log10(np.abs(columns[:, 8] - c0.energy0)), -17.0))
