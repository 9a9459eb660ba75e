"""Mode-shapes scene (app/scenes/modes.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz and its jobs run in worker
processes; tests act as a browser does (values through the gate with
``send_value``) and check what the scene streams: a chosen mode moving, the
joints of the animated chain and pendulum closed at large amplitude, the
table following a parameter, the frequencies against closed forms, the
sweeps (cancelled when a parameter changes, kept per parameter set, the
Campbell diagram against the whirl formula, the top's stability boundary
against its closed form), the eigen solve only when something changed and
the scene is shown, refused parameters, export and the state round trip.
A few tests build the scene on a bare server and drive ``frame`` themselves,
with an executor whose sweep values are slowed down.
"""

from __future__ import annotations

import concurrent.futures
import csv
import io
import json
import math
import time

import numpy as np
import pytest

from rigidlab.app.scenes.modes import (
    CHAIN,
    MODE_OPTIONS,
    ROTOR,
    SAMPLES_PER_CYCLE,
    SPHERICAL,
    TOP,
    TWO_MASS,
    ModesScene,
    Params,
)
from rigidlab.core.gyroscope import RotorParams, sleeping_top_critical_spin
from rigidlab.core.rotations import rotate_vector
from tests.helpers import send_value, wait_for_frames, wait_until

#: Joint gap of the animated poses (float64, as computed). Every sample is
#: projected onto C(q, t) = 0 by Newton's method until max |C| <= 1e-12; the
#: rows of a revolute or spherical joint are the three components of the gap
#: between its two points (m), so the gap is at most sqrt(3) 1e-12 m. 1e-9 m
#: leaves room for the round-off of the points' evaluation.
GAP_TOL = 1e-9
#: Joint gap of the poses viser holds (float32): positions of a few metres
#: carry 2.4e-7 m of rounding, a unit quaternion's (6e-8 per component)
#: moves the end of a 1 m half-rod by about 1.2e-7 m, so two rod ends that
#: meet in float64 are at most ~1e-6 m apart in float32.
GAP_TOL_FLOAT32 = 2e-6


@pytest.fixture
def modes(running_app):
    app = running_app(scene="modes")
    scene = app.scene_for()
    assert isinstance(scene, ModesScene)
    wait_until(lambda: scene.clip is not None, timeout=60.0)
    return app, scene


def notices_with(app, text):
    return [n for n in app.session_for().notices if text in n[0] or text in n[1]]


def wait_for(scene, timeout=120.0, mode=None, **fields):
    """Wait until the clip shown is the one the controls ask for, with ``fields`` in its
    parameters (and ``mode``)."""
    wait_until(lambda: scene.clip is not None and scene.solution is not None
               and scene.solution.key == scene.clip.key == scene.params
               and scene.clip.fraction == scene.controls.value("amplitude")
               and scene.panel_current  # the panel has caught up (one update per frame)
               and all(getattr(scene.clip.key, k) == v for k, v in fields.items())
               and (mode is None or scene.clip.mode == mode), timeout=timeout)
    return scene.solution, scene.clip


def rod_poses(app, scene):
    with app.session_for().run_lock:
        return (np.array(scene.live.rods.batched_positions, dtype=float),
                np.array(scene.live.rods.batched_wxyzs, dtype=float))


def table_rows(scene):
    """The rows of the modes table as lists of cells (bold marks removed)."""
    text = scene.gui.table.content
    rows = [line for line in text.splitlines() if line.startswith("|")][2:]
    return [[c.strip().strip("*") for c in row.strip("|").split("|")] for row in rows]


def test_scene_is_registered_after_the_linkages():
    from rigidlab.app.scenes import discover_scenes

    scenes = discover_scenes()
    assert "modes" in scenes and ModesScene.order == 60
    assert list(scenes).index("modes") == len([s for s in scenes.values() if s.order <= 60]) - 1


def test_choosing_a_mode_animates_it(modes):
    app, scene = modes
    solution, clip = wait_for(scene, model=CHAIN, mode=1)
    assert send_value(scene, "mode", "2")
    solution, clip = wait_for(scene, model=CHAIN, mode=2)
    assert clip.eigenvalue == solution.eigenvalues[solution.groups[1][0]]
    # the clip spans one period of mode 2 (undamped), 120 samples
    assert clip.t.size == SAMPLES_PER_CYCLE
    np.testing.assert_allclose(clip.period, 2 * math.pi / abs(clip.eigenvalue.imag), rtol=1e-12)
    np.testing.assert_allclose(clip.t[-1] + clip.t[1], clip.period, rtol=1e-12)
    # the poses sent change from frame to frame (two seconds per period on screen)
    before = rod_poses(app, scene)
    wait_until(lambda: np.abs(rod_poses(app, scene)[0] - before[0]).max() > 1e-3)
    # they are the clip's samples, exactly (as float32)
    with app.session_for().run_lock:
        i = scene._drawn[1]
        shown = np.array(scene.live.rods.batched_positions[:3])
    np.testing.assert_array_equal(shown, clip.placed.rod_positions[i])
    # animation off: the largest displacement stands still
    assert send_value(scene, "animate", False)
    wait_until(lambda: scene._drawn == (id(scene.clip), scene.clip.still))
    held = rod_poses(app, scene)
    wait_for_frames(scene, 12)
    np.testing.assert_array_equal(rod_poses(app, scene)[0], held[0])
    assert "animation off" in scene.gui.status.content


@pytest.mark.parametrize("n_links", [3, 10])
def test_the_chain_stays_closed_at_large_amplitude(modes, n_links):
    app, scene = modes
    assert send_value(scene, "n_links", n_links)
    assert send_value(scene, "amplitude", 1.0)  # the lowest link moves 2 m (the chain's length)
    for mode in (1, 2):
        assert send_value(scene, "mode", str(mode))
        solution, clip = wait_for(scene, n_links=n_links, mode=mode)
        if mode == 1:
            assert clip.unit == "m" and clip.amplitude == pytest.approx(2.0) and not clip.reduced
        L = 2.0 / n_links
        up, down = np.array([0.0, 0.0, 0.5 * L]), np.array([0.0, 0.0, -0.5 * L])
        R, P = clip.positions, clip.orientations
        tops = R + rotate_vector(P, up)
        bottoms = R + rotate_vector(P, down)
        gaps = np.linalg.norm(tops[:, 1:] - bottoms[:, :-1], axis=-1)
        gaps = np.concatenate([gaps, np.linalg.norm(tops[:, :1] - (0.0, 0.0, 2.7), axis=-1)], axis=1)
        assert gaps.max() < GAP_TOL, gaps.max()
        assert clip.residual.max() <= 1e-11
        # a large motion: the chain really swings (not a linear sketch)
        assert np.abs(R - R[:1]).max() > 0.25
    # what viser holds: the rods' ends meet to float32 rounding
    for _ in range(5):
        with app.session_for().run_lock:
            pos = np.array(scene.live.rods.batched_positions[:n_links], dtype=float)
            quat = np.array(scene.live.rods.batched_wxyzs[:n_links], dtype=float)
            scales = np.array(scene.live.rods.batched_scales[:n_links], dtype=float)
        quat /= np.linalg.norm(quat, axis=1)[:, None]
        half = np.zeros((n_links, 3))
        half[:, 2] = 0.5 * scales[:, 2]
        ends_top = pos + rotate_vector(quat, half)
        ends_bottom = pos - rotate_vector(quat, half)
        assert np.linalg.norm(ends_top[1:] - ends_bottom[:-1], axis=1).max() < GAP_TOL_FLOAT32
        time.sleep(0.05)


def test_the_spherical_pendulum_stays_on_its_pivot(modes):
    app, scene = modes
    assert send_value(scene, "model", SPHERICAL)
    assert send_value(scene, "amplitude", 1.0)  # 1 rad
    solution, clip = wait_for(scene, model=SPHERICAL)
    L = clip.key.rod_length
    top = clip.positions[:, 0] + rotate_vector(clip.orientations[:, 0], np.array([0.0, 0.0, 0.5 * L]))
    assert np.linalg.norm(top - (0.0, 0.0, 2.7), axis=-1).max() < GAP_TOL
    # omega^2 = 3 g / (2 L), twice; the spin about the rod is rigid
    omega = math.sqrt(3 * 9.81 / (2 * L))
    assert len(solution.groups) == 2 and int(np.count_nonzero(solution.rigid)) == 2
    for group in solution.groups:
        assert solution.omega_n[group[0]] == pytest.approx(omega, rel=1e-9)
    assert clip.unit == "rad" and clip.amplitude == pytest.approx(1.0)


def test_moving_a_parameter_updates_the_frequency_table(modes):
    app, scene = modes
    solution, _ = wait_for(scene, model=CHAIN, n_links=3)
    rows = table_rows(scene)
    assert len(rows) == 3
    f_long = [float(r[1]) for r in rows]
    # a chain of half the length: every frequency sqrt(2) times higher
    assert send_value(scene, "chain_length", 1.0)
    solution_short, _ = wait_for(scene, chain_length=1.0)
    wait_until(lambda: table_rows(scene) != rows)
    np.testing.assert_allclose(solution_short.frequency_hz, solution.frequency_hz * math.sqrt(2), rtol=1e-9)
    f_short = [float(r[1]) for r in table_rows(scene)]
    np.testing.assert_allclose(f_short, np.array(f_long) * math.sqrt(2), rtol=2e-3)  # 4 digits shown
    # more links: more rows; the point-mass chain of two links against its closed form
    assert send_value(scene, "n_links", 7)
    wait_for(scene, n_links=7)
    wait_until(lambda: len(table_rows(scene)) == 7)
    assert send_value(scene, "n_links", 2)
    assert send_value(scene, "chain_kind", "point masses")
    solution, _ = wait_for(scene, n_links=2, chain_kind="point masses")
    wait_until(lambda: len(table_rows(scene)) == 2)
    g_l = 9.81 / 0.5
    expected = np.sqrt(g_l * np.array([2 - math.sqrt(2), 2 + math.sqrt(2)]))  # omega^2 = g/l (2 -+ sqrt 2)
    np.testing.assert_allclose(solution.omega_n[[g[0] for g in solution.groups]], expected, rtol=1e-9)
    np.testing.assert_allclose([float(r[2]) for r in table_rows(scene)], expected, rtol=1e-3)  # as shown
    # the mode dropdown offers the modes there are, each as its row of the table (number · f · ξ · stability)
    options = tuple(scene.controls.handles["mode"].options)
    assert tuple(o.split(" \u00b7 ")[0] for o in options) == MODE_OPTIONS[:2]
    for option, row in zip(options, table_rows(scene)):
        assert option.split(" \u00b7 ")[1] == f"{row[1]} Hz" and "\u03be" in option


def test_a_mode_beyond_the_models_is_the_last_one(modes):
    app, scene = modes
    wait_for(scene, model=CHAIN, n_links=3)
    assert send_value(scene, "mode", "12")  # in the dropdown's declared range, not this model's
    wait_for(scene, mode=3)
    wait_until(lambda: scene.controls.value("mode") == "3"
               and scene.controls.handles["mode"].value.startswith("3 \u00b7 "))
    # a row of the dropdown, as the page sends it, picks its mode
    row = scene.controls.handles["mode"].options[0]
    assert send_value(scene, "mode", row)
    wait_for(scene, mode=1)
    assert scene.controls.value("mode") == "1" and scene.state()["values"]["mode"] == "1"
    assert scene.paused_error is None


def test_rotor_whirl_and_campbell_diagram_match_the_closed_form(modes):
    app, scene = modes
    assert send_value(scene, "model", ROTOR)
    assert send_value(scene, "spin", 400.0)
    solution, clip = wait_for(scene, model=ROTOR, spin=400.0)
    m, r, a, k = 1.0, 0.15, 0.25, 2e4
    Ip, It, kt = 0.5 * m * r * r, 0.25 * m * r * r, 2 * k * a * a

    def whirl(spin):
        root = np.sqrt((Ip * spin) ** 2 + 4 * It * kt)
        return np.array([(-Ip * spin + root) / (2 * It), (Ip * spin + root) / (2 * It)])

    omegas = np.sort(solution.omega_n[[g[0] for g in solution.groups]])
    np.testing.assert_allclose(omegas, np.sort(np.r_[[math.sqrt(2 * k / m)] * 3, whirl(400.0)]), rtol=1e-9)
    wait_until(lambda: scene.sweep is not None and scene.sweep.key == solution.key.sweep_key(), timeout=120.0)
    outcome = scene.sweep
    wait_until(lambda: scene.panel_current)  # the caption follows the sweep in a later frame
    f = np.abs(outcome.eigenvalues.imag) / (2 * math.pi)
    for i, spin in enumerate(outcome.values):
        expected = np.sort(np.r_[[math.sqrt(2 * k / m)] * 6, np.repeat(whirl(spin), 2)] / (2 * math.pi))
        np.testing.assert_allclose(np.sort(f[i][~outcome.rigid[i]]), expected, rtol=1e-8)
    assert outcome.values[0] == 0.0 and outcome.values[-1] == 1000.0
    assert "Campbell diagram" in scene.gui.sweep_caption.content
    wait_until(lambda: "<polyline" in scene.gui.sweep_plot.content)
    # the progress bar is hidden once the sweep is in
    assert not scene.gui.progress.visible
    # the spin is marked; moving it moves the mark, not the sweep
    started = scene.sweeps_started
    svg = scene.gui.sweep_plot.content
    assert send_value(scene, "spin", 800.0)
    wait_for(scene, spin=800.0)
    wait_until(lambda: scene.gui.sweep_plot.content != svg)
    assert scene.sweeps_started == started and scene.sweep is outcome
    # the rotor animates; its translations are in m, its tilts in rad
    assert clip.unit in ("m", "rad")


def test_top_root_locus_finds_the_sleeping_tops_critical_spin(modes):
    app, scene = modes
    assert send_value(scene, "model", TOP)
    solution, _ = wait_for(scene, model=TOP)
    wait_until(lambda: scene.sweep is not None and scene.sweep.key == solution.key.sweep_key(), timeout=120.0)
    critical = sleeping_top_critical_spin(RotorParams(I=1.0, I3=0.8, mgl=2.0))
    np.testing.assert_allclose(scene.sweep.boundaries, [critical], rtol=1e-9)
    wait_until(lambda: "Root locus" in scene.gui.sweep_caption.content)
    assert f"{critical:.6g}" in scene.gui.sweep_caption.content
    # below the critical spin the sleeping top is unstable, above it neutral
    assert send_value(scene, "top_spin", 3.0)
    solution, _ = wait_for(scene, top_spin=3.0)
    assert not all(solution.stable)
    wait_until(lambda: "**unstable**" in scene.gui.table.content)
    # the top has no damping: the decaying member of each +-Re pair is not "stable (damped)" (it read so)
    statuses = [solution.status(g[0]) for g in solution.groups]
    assert "stable" not in statuses and statuses.count("mirrored") == statuses.count("unstable") >= 1
    assert "stable (damped)" not in scene.gui.table.content
    assert send_value(scene, "top_spin", 4.0)
    solution, _ = wait_for(scene, top_spin=4.0)
    assert all(solution.stable)
    # an unstable mode that does not oscillate (a still top: s real) swings its shape
    assert send_value(scene, "top_spin", 0.0)
    assert send_value(scene, "mode", "3")
    solution, clip = wait_for(scene, top_spin=0.0, mode=3)
    assert "stable" not in [solution.status(i) for i in range(solution.eigenvalues.size)]  # s = +-1.41: a saddle
    assert clip.eigenvalue.real > 0 and clip.eigenvalue.imag == 0 and not clip.oscillates
    assert "does not oscillate" in scene.gui.status.content or wait_until(
        lambda: "does not oscillate" in scene.gui.status.content)
    orientations = clip.orientations[:, 0]
    assert np.abs(orientations - orientations[0]).max() > 0.05


def test_steady_precession_is_seen_from_the_turning_frame(modes):
    app, scene = modes
    assert send_value(scene, "model", TOP)
    assert send_value(scene, "top_motion", "slow precession")
    assert send_value(scene, "top_spin", 10.0)
    assert send_value(scene, "amplitude", 0.02)
    solution, clip = wait_for(scene, model=TOP, top_motion="slow precession", top_spin=10.0)
    # the reference precesses in space; in the turning frame only the small
    # nutation is left: the axis stays within the amplitude of its start
    axis = rotate_vector(clip.orientations[:, 0], np.array([0.0, 0.0, 1.0]))
    ghost_axis = rotate_vector(solution.ghost_P[0], np.array([0.0, 0.0, 1.0]))
    angles = np.arccos(np.clip(axis @ ghost_axis, -1.0, 1.0))
    assert angles.max() < 0.05
    assert math.degrees(math.acos(ghost_axis[2])) == pytest.approx(30.0, abs=1e-9)
    # the nutation frequency of the reduced top, omega^2 = V_eff''(theta0) / I
    assert len(solution.groups) == 1 and solution.method == "state-space"


def test_two_masses_have_complex_modes_with_their_damping(modes):
    app, scene = modes
    assert send_value(scene, "model", TWO_MASS)
    solution, clip = wait_for(scene, model=TWO_MASS)
    M = np.diag([1.0, 1.0])
    K = np.array([[3000.0, -1000.0], [-1000.0, 1000.0]])
    C = np.array([[4.5, -0.5], [-0.5, 0.5]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    s = np.linalg.eigvals(A)
    expected = np.sort_complex(s[s.imag > 0])
    got = np.sort_complex(solution.eigenvalues[[g[0] for g in solution.groups]])
    np.testing.assert_allclose(got, expected, rtol=1e-10)
    assert all(solution.status(g[0]) == "stable" for g in solution.groups)  # damped: no mirror grows
    # a damped mode is shown decaying over several periods, starting at a
    assert clip.cycles > 1 and clip.t[0] == 0.0
    x = clip.positions[:, 0, 0]
    first, last = x[:SAMPLES_PER_CYCLE], x[-SAMPLES_PER_CYCLE:]
    assert np.ptp(last) < np.ptp(first)
    assert "decays" in scene.gui.status.content or wait_until(lambda: "decays" in scene.gui.status.content)


def test_eigen_solve_only_when_something_changed_and_the_scene_is_shown(modes):
    app, scene = modes
    wait_for(scene, model=CHAIN)
    submitted = scene.jobs_submitted
    frames = scene.frames
    wait_until(lambda: scene.frames > frames + 60)
    assert scene.jobs_submitted == submitted  # nothing changed: nothing solved
    # back to a parameter set seen before: from the cache, no job
    assert send_value(scene, "n_links", 4)
    wait_for(scene, n_links=4)
    assert send_value(scene, "n_links", 3)
    wait_for(scene, n_links=3)
    submitted = scene.jobs_submitted
    assert send_value(scene, "n_links", 4)
    wait_for(scene, n_links=4)
    assert scene.jobs_submitted == submitted
    # hidden: no frame, no job and no sweep, whatever changes
    assert send_value(scene, "model", ROTOR)
    wait_until(lambda: scene.sweeping)
    app.switch_scene("sandbox")
    assert not scene.active and not scene.sweeping
    submitted, frames = scene.jobs_submitted, scene.frames
    assert send_value(scene, "spin", 123.0)
    wait_for_frames(app.scene_for(), 30)  # the shown scene's loop runs on
    assert scene.jobs_submitted == submitted and scene.frames == frames and not scene.sweeping
    app.switch_scene("modes")
    wait_for(scene, model=ROTOR, spin=123.0)
    assert scene.jobs_submitted > submitted


def test_no_steady_precession_is_refused_and_the_controls_go_back(modes):
    app, scene = modes
    assert send_value(scene, "model", TOP)
    wait_for(scene, model=TOP)
    assert send_value(scene, "top_motion", "slow precession")
    assert send_value(scene, "top_spin", 2.0)  # below 2 sqrt(I mgl cos 30 deg) / I3 = 3.29 rad/s
    wait_until(lambda: notices_with(app, "Invalid parameters"), timeout=60.0)
    assert notices_with(app, "no steady precession exists")
    # the controls show the parameters of the top shown (a valid one) again
    wait_until(lambda: scene.params == scene.solution.key)
    shown = scene.solution.key
    assert shown.model == TOP and shown.top_spin == 6.0
    assert scene.controls.value("top_spin") == 6.0 and scene.controls.handles["top_spin"].value == 6.0
    assert scene.controls.value("top_motion") == shown.top_motion
    assert scene.paused_error is None


def test_export_gives_the_modes_shown(modes):
    app, scene = modes
    solution, _ = wait_for(scene, model=CHAIN)
    rows = list(csv.reader(io.StringIO(scene.csv_bytes().decode())))
    assert rows[0][:6] == ["index", "eigenvalue_real", "eigenvalue_imag", "omega_n_rad_s", "frequency_hz",
                           "damping_ratio"]
    data = np.array([[float(x) for x in row[3:5]] for row in rows[1:]])
    np.testing.assert_allclose(data[:, 0], solution.omega_n, rtol=1e-15)
    np.testing.assert_allclose(data[:, 1], solution.frequency_hz, rtol=1e-15)
    doc = json.loads(scene.json_bytes())
    assert doc["model"] == CHAIN and doc["parameters"]["n_links"] == 3
    assert len(doc["modes"]["modes"]) == solution.eigenvalues.size
    with pytest.raises(ValueError, match="no sweep for this model"):
        scene.sweep_bytes()
    assert send_value(scene, "model", ROTOR)
    wait_until(lambda: scene.sweep is not None, timeout=120.0)
    lines = scene.sweep_bytes().decode().splitlines()
    assert lines[0].startswith("value,re_0,im_0") and len(lines) == 1 + scene.sweep.values.size


def test_presenter_view_enlarges_the_charts(modes):
    app, scene = modes
    wait_until(lambda: "font-size='11'" in scene.gui.plane.content)
    assert send_value(app.session_for(), "presenter", True)  # the session's checkbox
    wait_until(lambda: "font-size='15'" in scene.gui.plane.content)
    assert scene.gui.table.html().startswith("<div class='rigidlab-readout' style='font-size:1.45em")


def test_state_round_trip(running_app):
    first = running_app(scene="modes")
    scene = first.scene_for()
    for key, value in (("model", TWO_MASS), ("c1", 7.5), ("k2", 1500.0), ("mode", "2"), ("amplitude", 0.55),
                       ("cycle_seconds", 3.5), ("show_ghost", False)):
        assert send_value(scene, key, value)
    solution, clip = wait_for(scene, model=TWO_MASS, c1=7.5, k2=1500.0, mode=2)
    state = scene.state()
    assert state["scene"] == "modes" and state["values"]["model"] == TWO_MASS
    assert state["values"]["c1"] == 7.5 and state["values"]["mode"] == "2" and state["values"]["show_ghost"] is False

    second = running_app(scene="modes")
    other = second.scene_for()
    wait_until(lambda: other.clip is not None, timeout=60.0)
    second.session_for().request_state(state)
    other_solution, other_clip = wait_for(other, model=TWO_MASS, c1=7.5, k2=1500.0, mode=2)
    assert other_solution.key == solution.key
    np.testing.assert_array_equal(other_solution.eigenvalues, solution.eigenvalues)
    np.testing.assert_array_equal(other_clip.positions, clip.positions)
    assert other.controls.values() == scene.controls.values()
    wait_until(lambda: not other.ghost.frame.visible)


def test_params_keep_only_the_chosen_models_values():
    values = {"model": ROTOR, "n_links": 5, "chain_kind": "uniform rods", "chain_length": 1.0, "rod_length": 1.0,
              "spin": 250.0, "stiffness_kn": 10.0, "shaft_damping": 1.5, "top_motion": "sleeping (upright)",
              "top_spin": 5.0, "top_theta_deg": 20.0, "c1": 1.0, "c2": 1.0, "k2": 500.0, "m2": 2.0}
    p = Params.from_values(values)
    assert p == Params(ROTOR, spin=250.0, stiffness=1e4, damping=1.5)
    assert Params.from_values(dict(values, n_links=9)) == p  # another model's slider: same parameters
    assert p.sweep_key() == Params(ROTOR, stiffness=1e4, damping=1.5)
    assert Params.from_values(dict(values, model=CHAIN)).sweep_key() is None
    for model in (CHAIN, SPHERICAL, ROTOR, TOP, TWO_MASS):
        q = Params.from_values(dict(values, model=model, top_motion="slow precession"))
        assert Params.from_values({**values, "model": model, **q.control_values()}) == q


# -- a bare scene, frames driven by the test ------------------------------------------------
class SlowSweeps(concurrent.futures.ThreadPoolExecutor):
    """One thread; every value of a sweep (``rigidlab.core.modal._solve``) takes 50 ms longer."""

    def __init__(self) -> None:
        super().__init__(max_workers=1)

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[no-untyped-def]
        from rigidlab.core import modal

        if fn is modal._solve:
            def slow(*a, **k):  # type: ignore[no-untyped-def]
                time.sleep(0.05)
                return fn(*a, **k)

            return super().submit(slow, *args, **kwargs)
        return super().submit(fn, *args, **kwargs)


def drive(scene, predicate, timeout=60.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        scene.frame(1 / 60)
        if predicate():
            return True
        time.sleep(1 / 60)
    raise AssertionError(f"condition not met within {timeout:g} s")


def test_a_sweep_is_cancelled_by_a_parameter_change_and_kept_per_parameter_set(make_bare_scene):
    scene, notices = make_bare_scene(ModesScene, executor=SlowSweeps())
    assert send_value(scene, "model", ROTOR)
    drive(scene, lambda: scene.sweeping and scene.sweep_progress[0] >= 2)
    first = scene._run
    assert scene.gui.progress.visible and 0.0 < scene.gui.progress.value < 100.0
    # the user picks a mode meanwhile: it does not wait for the whole sweep
    assert send_value(scene, "mode", "4")
    t0 = time.monotonic()
    drive(scene, lambda: scene.clip is not None and scene.clip.mode == 4)
    assert scene.sweeping and time.monotonic() - t0 < 3.0
    # a parameter of the sweep changes: the running sweep is cancelled, a new one starts
    cancelled = scene.sweeps_cancelled
    assert send_value(scene, "shaft_damping", 2.0)
    drive(scene, lambda: scene._run is not None and scene._run is not first)
    assert scene.sweeps_cancelled == cancelled + 1 and first.cancel.is_set()
    assert first.finished.wait(10.0) and first.outcome is None  # stopped, no result
    assert first.done < first.total
    drive(scene, lambda: scene.sweep is not None and scene.sweep.key.damping == 2.0, timeout=120.0)
    assert not scene.gui.progress.visible
    started = scene.sweeps_started
    # back to the first parameters: computed again (it was cancelled); then kept
    assert send_value(scene, "shaft_damping", 0.0)
    drive(scene, lambda: scene.sweep is not None and scene.sweep.key.damping == 0.0, timeout=120.0)
    assert scene.sweeps_started == started + 1
    assert send_value(scene, "shaft_damping", 2.0)
    drive(scene, lambda: scene.sweep is not None and scene.sweep.key.damping == 2.0, timeout=5.0)
    assert scene.sweeps_started == started + 1  # from the cache
    # the spin is not a parameter of the sweep: moving it keeps the sweep
    assert send_value(scene, "spin", 700.0)
    drive(scene, lambda: scene.solution is not None and scene.solution.key.spin == 700.0)
    assert scene.sweeps_started == started + 1 and not scene.sweeping
    # another model has no sweep: the running one would stop, the folder hides
    assert send_value(scene, "model", CHAIN)
    drive(scene, lambda: not scene.gui.sweep_folder.visible)
    assert not notices


def test_nothing_is_solved_on_the_loop_thread_while_the_scene_solves_and_sweeps(make_bare_scene, monkeypatch):
    """The loop thread (here the test's, which calls ``scene.frame``) only picks samples and sends arrays:
    every eigen solution and every animated clip is computed on the executor's threads, for every model and
    its sweep. (What a frame costs is measured by bench/frames.py, not asserted here.)"""
    import threading

    from rigidlab.core.modal import LinearModel, Modes

    threads: dict[str, set[int]] = {"modes": set(), "animate": set()}
    solve, animate = LinearModel.modes, Modes.animate

    def recorded(name, fn):
        def wrapper(*args, **kwargs):
            threads[name].add(threading.get_ident())
            return fn(*args, **kwargs)
        return wrapper

    monkeypatch.setattr(LinearModel, "modes", recorded("modes", solve))
    monkeypatch.setattr(Modes, "animate", recorded("animate", animate))
    scene, _ = make_bare_scene(ModesScene)
    drive(scene, lambda: scene.clip is not None)
    for model in (ROTOR, TOP, TWO_MASS, SPHERICAL, CHAIN):
        assert send_value(scene, "model", model)
        drive(scene, lambda: scene.clip is not None and scene.clip.key.model == model and scene.panel_current)
        if model in (ROTOR, TOP):
            drive(scene, lambda: scene.sweep is not None and scene.sweep.key.model == model and scene.panel_current,
                  timeout=120.0)
    loop = threading.get_ident()
    assert threads["modes"] and threads["animate"], threads  # (the records see the solver's calls)
    assert loop not in threads["modes"] and loop not in threads["animate"]
    assert scene.paused_error is None


def test_a_dragged_slider_is_solved_one_value_after_another(modes):
    app, scene = modes
    wait_for(scene, model=CHAIN, n_links=3)
    submitted = scene.jobs_submitted
    shown = set()
    for n in range(4, 11):  # as a drag sends them, faster than the jobs finish
        assert send_value(scene, "n_links", n)
        shown.add(scene.solution.key.n_links)
        time.sleep(0.03)
    solution, _ = wait_for(scene, n_links=10)
    assert solution.n_dof == 10 and len(table_rows(scene)) == 10
    # one job at a time, each for the value the slider had when the last one was done
    assert 1 <= scene.jobs_submitted - submitted <= 7
    assert scene.paused_error is None


def test_the_camera_looks_across_a_modes_motion():
    """The spherical rod's mode 2 swung along the default camera's line of sight: the scene's camera for a
    mode looks perpendicular to the bodies' principal displacement, at the default distance and elevation."""
    from rigidlab.app.scenes.modes import ModesScene, mode_camera

    position, look_at = np.array(ModesScene.camera_position), np.array(ModesScene.camera_look_at)
    sight = (look_at - position) / np.linalg.norm(look_at - position)
    t = np.linspace(0.0, 2.0 * np.pi, 40)
    centre = look_at + np.array([0.1, -0.2, 0.0])
    swing = np.array([sight[0], sight[1], 0.0]) / np.hypot(sight[0], sight[1])  # along the line of sight
    positions = (centre + 0.3 * np.sin(t)[:, None] * swing)[:, None, :]  # (m, 1, 3)
    new_position, new_look_at = mode_camera(positions, position, look_at)
    new_position = np.array(new_position)
    assert np.allclose(new_look_at, look_at)
    new_sight = look_at - new_position
    assert abs(new_sight @ swing) < 1e-9 * np.linalg.norm(new_sight)  # square on to the swing
    assert np.linalg.norm(new_sight) == pytest.approx(np.linalg.norm(look_at - position), rel=1e-12)
    assert new_position[2] == pytest.approx(position[2], rel=1e-12)  # same elevation
    # a motion in a vertical plane is seen along the plane's normal
    normal = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    in_plane = np.cross(normal, [0.0, 0.0, 1.0])
    circle = (centre + 0.3 * np.cos(t)[:, None] * in_plane + 0.3 * np.sin(t)[:, None] * np.array([0, 0, 1.0]))
    p2, _ = mode_camera(circle[:, None, :], position, look_at)
    assert abs((look_at - np.array(p2)) @ in_plane) < 1e-9
    # a spin (no centre moves) and a vertical motion keep the default view
    still = np.repeat(centre[None, None, :], 10, axis=0)
    assert mode_camera(still, position, look_at) == (tuple(position), tuple(look_at))
    bounce = (centre + 0.3 * np.sin(t)[:, None] * np.array([0.0, 0.0, 1.0]))[:, None, :]
    assert mode_camera(bounce, position, look_at) == (tuple(position), tuple(look_at))
