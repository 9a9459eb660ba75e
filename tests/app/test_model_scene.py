"""Model scene (app/scenes/model.py): a model file named on the command line, its parameters, modes and motion.

The scene is served by a real app built with the Model scene of
examples/four_bar.py or examples/arm.urdf (what ``rigidlab serve --model``
does); tests act as a browser does (values through the gate) and check what
the scene shows: a slider that changes a parameter changes the modes, a mode
animated with its joints closed, the motion's energy and residual, a state
made for another model refused, and the command line's one-line refusal of a
bad model file.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rigidlab.app.scenes import discover_scenes
from rigidlab.app.scenes.model import SIM_VIEW, ModelScene, model_scene_classes
from rigidlab.app.server import create_app
from tests.helpers import send_value, wait_until

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
#: Joint gap of an animated pose (float64): every sample is projected onto C = 0 by Newton to max |C| <= 1e-12
#: (a revolute joint's point rows are the gap in m), so 1e-9 m leaves room for the points' round-off.
GAP_TOL = 1e-9


@pytest.fixture
def model_app():
    """Factory ``model_app(path) -> (app, scene)``: an app showing the Model scene of ``path`` (shared mode)."""
    apps = []

    def start(path: Path):
        classes = model_scene_classes([path])
        app = create_app(host="127.0.0.1", port=0, scene_classes={**classes, **discover_scenes()},
                         run_unwatched=True)
        apps.append(app)
        scene = app.scene_for()
        assert isinstance(scene, ModelScene)
        return app, scene

    yield start
    for app in reversed(apps):
        app.stop()


def wait_for_clip(scene, timeout=120.0, mode=None):
    """Wait until the clip shown is the one the controls ask for and the panel shows it."""
    wait_until(lambda: scene.clip is not None and scene.solution is not None and scene.params_key is not None
               and scene.solution.key == scene.clip.key == scene.params_key and scene.panel_current
               and (mode is None or scene.clip.mode == mode), timeout=timeout)
    return scene.solution, scene.clip


def joint_gaps(scene, clip) -> np.ndarray:
    """(m, joints) distance between each joint's two points over the clip (m), from the body-fixed points of
    the System the file builds (valid at every configuration)."""
    system = scene.model.build(**dict(clip.key.values))
    state = system.state
    gaps = []
    for joint in system.joints:
        ends = []
        for body in (joint.body_i, joint.body_j):
            if body.is_ground:
                ends.append(np.broadcast_to(joint.point, (clip.t.size, 3)))
                continue
            u = state.rotation_matrix(body).T @ (joint.point - state.position(body))
            R, P = clip.positions[:, body.index], clip.orientations[:, body.index]
            from rigidlab.core.rotations import rotate_vector

            ends.append(R + rotate_vector(P, u))
        gaps.append(np.linalg.norm(ends[0] - ends[1], axis=1))
    return np.array(gaps).T


def test_the_scene_is_first_and_titled_by_the_file(model_app):
    app, scene = model_app(EXAMPLES / "four_bar.py")
    assert app.scene_names[0] == "model" and scene.title == "Model: four_bar.py"
    assert set(scene.controls.specs) >= {"param_crank_deg", "param_spring_k", "param_coupler_mass", "mode"}


def test_a_slider_changes_a_parameter_and_the_modes_change(model_app):
    app, scene = model_app(EXAMPLES / "four_bar.py")
    solution, clip = wait_for_clip(scene)
    f0 = float(solution.frequency_hz[solution.groups[0][0]])
    assert "| **1** |" in scene.table.content  # the table of modes, the mode shown in bold
    assert send_value(scene, "param_spring_k", 900.0)
    wait_until(lambda: scene.solution is not None and dict(scene.solution.key.values)["spring_k"] == 900.0
               and scene.panel_current, timeout=120.0)
    f1 = float(scene.solution.frequency_hz[scene.solution.groups[0][0]])
    assert f1 > f0 * 1.05  # a stiffer spring: a higher frequency
    # a value outside the parameter's range is refused at the gate
    assert not send_value(scene, "param_spring_k", 5000.0)


@pytest.mark.parametrize("example", ["four_bar.py", "arm.urdf"])
def test_a_mode_animates_with_its_joints_closed(model_app, example):
    app, scene = model_app(EXAMPLES / example)
    solution, clip = wait_for_clip(scene, mode=1)
    if len(solution.groups) > 1:
        assert send_value(scene, "mode", "2")
        solution, clip = wait_for_clip(scene, mode=2)
    assert send_value(scene, "amplitude", 0.6)
    wait_until(lambda: scene.clip is not None and scene.clip.fraction == 0.6 and scene.panel_current, 120.0)
    clip = scene.clip
    assert clip.positions.shape[0] > 1 and float(np.ptp(clip.positions, axis=0).max()) > 1e-2  # it moves
    assert float(np.max(clip.residual)) <= 1e-10
    assert float(joint_gaps(scene, clip).max()) <= GAP_TOL
    # the poses sent move from frame to frame
    with app.session_for().run_lock:
        before = scene._mode_drawn
    wait_until(lambda: scene._mode_drawn is not None and scene._mode_drawn != before, 60.0)


def test_the_urdf_meshes_are_drawn_on_their_bodies(model_app):
    app, scene = model_app(EXAMPLES / "arm.urdf")
    assert set(scene.meshes) == {0, 1, 2} and len(scene.ground_meshes) == 1  # turret, arms; the base is fixed
    for meshes in scene.meshes.values():
        assert all(v.dtype == np.float32 and f.dtype == np.uint32 and v.size for v, f, _ in meshes)
    assert scene.default_start != "as the file builds it"  # built hanging at rest: the motion starts along a mode


def test_the_simulation_plays_with_energy_and_residual(model_app):
    app, scene = model_app(EXAMPLES / "four_bar.py")
    assert send_value(scene, "view", SIM_VIEW)
    wait_until(lambda: scene.sim_time > 1.5 and scene.setup is not None, 240.0)
    chunk = scene.last_chunk
    assert chunk.table.columns.shape[1] == 2 + 4  # E, max |C|, |F| of the four joints
    assert float(chunk.table.columns[:, 1].max()) <= 1e-8
    assert scene.paused_error is None


def test_a_state_for_another_model_is_refused(model_app):
    app, scene = model_app(EXAMPLES / "four_bar.py")
    wait_for_clip(scene)
    state = scene.state()
    assert state["model"] == {"file": "four_bar.py", "sha256": scene.model.sha256}
    accepted, refused = scene.check_state(state)
    assert not refused
    other = {**state, "model": {"file": "spring_chain.py", "sha256": "0" * 64}}
    with pytest.raises(ValueError, match="made for 'spring_chain.py'"):
        scene.check_state(other)
    other["values"] = {**state["values"], "param_spring_k": 700.0}
    app.session_for().request_state(other, source="a test")
    wait_until(lambda: any("State not loaded" in n[0] for n in app.session_for().notices), 60.0)
    assert scene.controls.value("param_spring_k") == 200.0  # nothing applied


def test_a_model_file_with_a_syntax_error_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "bad_model.py"
    bad.write_text("def build(:\n    pass\n")
    done = subprocess.run([sys.executable, "-m", "rigidlab.app.cli", "serve", "--port", "0", "--model", str(bad)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert f"{bad}:1: syntax error" in lines[0]


def test_the_spring_chain_example_has_the_closed_form_frequencies():
    """examples/spring_chain.py: N equal masses and springs, fixed at one end, free at the other:
    omega_r = 2 sqrt(k/m) sin((2r - 1) pi / (2 (2N + 1)))."""
    from rigidlab.app.model_file import load_model_file
    from rigidlab.app.scenes.model import Key, _reference

    model = load_model_file(EXAMPLES / "spring_chain.py")
    key = Key(str(model.path), model.sha256, (("stiffness", 900.0), ("mass", 2.5), ("stretch", 0.1)))
    ref = _reference(key)
    f = np.array([ref.modes.frequency_hz[g[0]] for g in ref.groups])
    n = 5
    r = np.arange(1, n + 1)
    expected = 2.0 * np.sqrt(900.0 / 2.5) * np.sin((2 * r - 1) * np.pi / (2 * (2 * n + 1))) / (2 * np.pi)
    np.testing.assert_allclose(f, expected, rtol=1e-8)


DOUBLE_PENDULUM_MJCF = """<mujoco model="double">
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <body name="upper" pos="0 0 2">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.04" mass="1" rgba="0.9 0.5 0.2 1"/>
      <body name="lower" pos="0 0 -0.5">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="box" size="0.05 0.05 0.25" pos="0 0 -0.25" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_the_mjcf_geoms_are_drawn_on_their_bodies_and_a_mode_animates(model_app, tmp_path):
    path = tmp_path / "double.xml"
    path.write_text(DOUBLE_PENDULUM_MJCF)
    app, scene = model_app(path)
    assert sorted(scene.meshes) == [0, 1] and not scene.ground_meshes  # the floor plane is left out
    (capsule, _, rgb), = scene.meshes[0]
    assert rgb == (229, 128, 51)  # rgba 0.9 0.5 0.2 (float32) x 255, rounded
    # body frames at the centres of mass: the capsule (0.5 m, radius 0.04) and the box (0.5 m) centred on them
    np.testing.assert_allclose(capsule.max(axis=0), (0.04, 0.04, 0.29), atol=1e-6)
    np.testing.assert_allclose(scene.meshes[1][0][0].max(axis=0), (0.05, 0.05, 0.25), atol=1e-6)
    solution, clip = wait_for_clip(scene)
    assert len(solution.groups) == 2
    assert float(joint_gaps(scene, clip).max()) <= GAP_TOL


def test_a_rigid_body_mode_animates_with_a_warning_and_the_modes_export(model_app):
    import json

    app, scene = model_app(EXAMPLES / "arm.urdf")
    solution, clip = wait_for_clip(scene)
    rigid = [k + 1 for k, g in enumerate(solution.groups) if solution.rigid[g[0]]]
    assert rigid == [len(solution.groups)]  # the turret's free yaw, listed once, after the vibration modes
    assert send_value(scene, "mode", str(rigid[0]))
    solution, clip = wait_for_clip(scene, mode=rigid[0])
    assert clip.rigid and not clip.oscillates
    wait_until(lambda: any(n[0] == "Rigid-body mode" and n[2] == "warning" for n in app.session_for().notices), 60.0)
    doc = json.loads(scene.modes_json())
    assert doc["model"] == "arm.urdf" and doc["sha256"] == scene.model.sha256
    assert scene.modes_csv().decode().count("\n") >= len(solution.eigenvalues)


def test_the_motion_plots_show_in_the_simulation_view_only_and_what_you_see_describes_both(model_app):
    app, scene = model_app(EXAMPLES / "four_bar.py")
    wait_for_clip(scene)
    plots = scene.plot_handles
    assert set(plots) == {"energy", "residual", "reactions"}
    # the mode view has no motion: its energy, residual and reaction plots are hidden, not shown empty
    wait_until(lambda: not any(h.visible for h in plots.values()), 60.0)
    assert send_value(scene, "view", SIM_VIEW)
    wait_until(lambda: all(h.visible for h in plots.values()), 60.0)
    assert send_value(scene, "view", "Mode shape")
    wait_until(lambda: not any(h.visible for h in plots.values()), 60.0)
    text = scene.help_readout.content
    assert text == ModelScene.help
    for words in ("**Mode shape**", "**Simulation**", "ghost", "Eqs. 8.125-8.129", "Eq. 8.130", "Eq. 8.131",
                  "root locus", "Campbell"):
        assert words in text


def test_the_sweep_draws_a_campbell_diagram_and_a_root_locus_of_the_eigenvalues(model_app):
    """examples/rotor.py sweeps the spin: the root locus's data are the eigenvalues that rigidlab.core.modal
    gives for the System the file builds at every swept value, and the chart draws one curve per branch."""
    from rigidlab.app.scenes._modal_view import live_branches
    from rigidlab.app.scenes.model import SWEEP_VALUES
    from rigidlab.core.modal import linearize

    app, scene = model_app(EXAMPLES / "rotor.py")
    wait_for_clip(scene)
    wait_until(lambda: scene.sweep_result is not None and scene.panel_current and "<polyline" in
               scene.locus_plot.content, timeout=600.0)
    result = scene.sweep_result
    p = next(p for p in scene.model.parameters if p.name == "spin")
    np.testing.assert_allclose(result.values, np.linspace(p.low, p.high, SWEEP_VALUES))
    live = live_branches(result.rigid)
    values = dict(scene.solution.key.values)
    for k, spin in enumerate(result.values):
        modes = linearize(scene.model.build(**{**values, "spin": float(spin)})).modes()
        want = np.sort_complex(modes.eigenvalues[~modes.rigid])
        got = np.sort_complex(result.eigenvalues[k, live])
        np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-7 * float(np.max(np.abs(want))))
    svg = scene.locus_plot.content
    assert svg.count("<polyline") >= len(live)  # a curve per tracked branch
    assert "Root locus" in scene.locus_caption.content and "spin" in scene.locus_caption.content
    # the eigenvalues in use are marked on the locus (purple), and they are the solution's
    assert "#7c3aed" in svg
    assert "<polyline" in scene.sweep_plot.content and "Campbell" not in scene.locus_caption.content
