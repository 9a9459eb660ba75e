"""Tests of the manipulator scene (app/scenes/manipulator.py) on a real viser server.

Unit tests build the scene on a bare ``viser.ViserServer`` on a free loopback
port and call ``update`` themselves (deterministic); integration tests use the
running app (``running_app``) and a plain websocket client (``ws_client``)
that changes GUI values exactly as a browser does. Expected poses come from
scipy's ``Rotation`` (an oracle independent of core.rotations).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
import viser
from scipy.spatial.transform import Rotation

from rigidlab.app.scenes.manipulator import ManipulatorScene, joint_sweep, wrap_deg
from rigidlab.core.manipulator import ManipulatorGeometry
from tests.helpers import send_value, wait_until

DT = 1.0 / 60.0
# Poses travel as float64 wxyz / positions built from rotation matrices;
# 1e-12 leaves room for the matrix-to-quaternion conversion's rounding.
POSE_TOL = 1e-12
# The ghost frames are one batched node, whose poses viser stores as float32.
GHOST_TOL = 1e-6


def ghost_wxyz(scene: ManipulatorScene, k: int) -> np.ndarray:
    return np.asarray(scene.ghost_axes.batched_wxyzs[k], dtype=float)


def ghost_position(scene: ManipulatorScene, k: int) -> np.ndarray:
    return np.asarray(scene.ghost_axes.batched_positions[k], dtype=float)


def expected_wxyz(deg: tuple[float, float, float]) -> np.ndarray:
    """wxyz of the three links for Z-X-Z joints (scipy, scalar first, w >= 0)."""
    chain = Rotation.from_euler("ZXZ", [deg[0], deg[1], deg[2]], degrees=True)
    links = [
        Rotation.from_euler("Z", deg[0], degrees=True),
        Rotation.from_euler("ZX", deg[:2], degrees=True),
        chain,
    ]
    quats = np.array([r.as_quat(scalar_first=True) for r in links])
    return quats * np.where(quats[:, :1] < 0, -1.0, 1.0)


def same_rotation(wxyz: np.ndarray, expected: np.ndarray, atol: float = POSE_TOL) -> bool:
    # q and -q are the same rotation.
    wxyz = np.asarray(wxyz)
    return bool(np.allclose(wxyz, expected, atol=atol) or np.allclose(wxyz, -expected, atol=atol))


class Notices:
    def __init__(self) -> None:
        self.items: list[tuple[str, str, str]] = []

    def __call__(self, title: str, body: str, level: str) -> None:
        self.items.append((title, body, level))


@pytest.fixture
def make_scene(server: viser.ViserServer) -> Iterator[Callable[..., tuple[ManipulatorScene, Notices]]]:
    scenes: list[ManipulatorScene] = []

    def make(**kwargs: Any) -> tuple[ManipulatorScene, Notices]:
        notices = Notices()
        kwargs.setdefault("readout_period", 0.0)  # deterministic: refresh on every change
        scene = ManipulatorScene(server, notices, **kwargs)
        scene.build()
        scene.set_active(True)
        scenes.append(scene)
        return scene, notices

    yield make
    for scene in scenes:
        scene.close()


def settle(scene: ManipulatorScene, timeout: float = 10.0) -> str:
    """Run frames until the readout of the last drawn pose is shown (it is built on
    the scene's background executor, off the loop) and return its text."""
    deadline = time.monotonic() + timeout
    scene.update(DT)
    while scene.readout_pending:
        assert time.monotonic() < deadline, "the readout never arrived"
        time.sleep(0.002)
        scene.update(DT)
    return scene.gui.readout.content


def difference_in_readout(scene: ManipulatorScene) -> float:
    settle(scene)
    match = re.search(r"max \|A_a − A_b\| = ([0-9.e+-]+)", scene.gui.readout.content)
    assert match is not None, scene.gui.readout.content
    return float(match.group(1))


# -- unit tests on a bare server ---------------------------------------------


def test_initial_pose_matches_zxz_oracle_and_both_procedures_agree(make_scene) -> None:
    scene, _ = make_scene()
    scene.update(DT)
    expected = expected_wxyz((30.0, 45.0, 60.0))
    for k in range(3):
        assert same_rotation(scene.solid_frames[k].wxyz, expected[k])
        assert same_rotation(ghost_wxyz(scene, k), expected[k], atol=GHOST_TOL)
    # Joint 2 sits on top of the 0.6 m column, joint 3 0.8 m further along link 2.
    np.testing.assert_allclose(scene.solid_frames[1].position, [0, 0, 0.6], atol=POSE_TOL)
    link2_axis = Rotation.from_euler("ZX", [30, 45], degrees=True).apply([0, 0, 0.8])
    np.testing.assert_allclose(scene.solid_frames[2].position, [0, 0, 0.6] + link2_axis, atol=POSE_TOL)
    np.testing.assert_allclose(ghost_position(scene, 2), scene.solid_frames[2].position, atol=GHOST_TOL)
    # Rounding only: three 3x3 products of unit-size entries.
    assert scene.difference < 1e-14
    assert difference_in_readout(scene) < 1e-14


def test_readout_shows_matrix_and_euler_angle_form(make_scene) -> None:
    scene, notices = make_scene()
    text = settle(scene)
    matrix = Rotation.from_euler("ZXZ", [30, 45, 60], degrees=True).as_matrix()
    first_row = " ".join(f"{x:+.4f}" for x in matrix[0])
    assert first_row in text
    assert "Euler-angle form** (ZXZ, intrinsic)" in text
    assert "- A = A_ZXZ(30.0°, 45.0°, 60.0°)" in text
    assert "Euler angles recovered from A: 30.0°, 45.0°, 60.0°" in text
    assert "gimbal lock" not in text
    assert notices.items == []


def test_joint_slider_changes_pose(make_scene) -> None:
    scene, _ = make_scene()
    scene.update(DT)
    before = scene.solid_frames[2].wxyz.copy()
    send_value(scene, "theta1", -120.0)
    send_value(scene, "theta3", 10.0)
    scene.update(DT)
    expected = expected_wxyz((-120.0, 45.0, 10.0))
    for k in range(3):
        assert same_rotation(scene.solid_frames[k].wxyz, expected[k])
    assert not same_rotation(scene.solid_frames[2].wxyz, before, atol=1e-3)
    np.testing.assert_allclose(scene.joint_angles, np.radians([-120.0, 45.0, 10.0]))


def test_update_without_changes_sends_nothing_new(make_scene) -> None:
    scene, _ = make_scene()
    content = settle(scene)
    scene.gui.readout.content = "sentinel"
    assert settle(scene) == "sentinel"  # nothing dirty, not animating: no recomputation
    send_value(scene, "theta2", 46.0)
    assert settle(scene) not in ("sentinel", content)


def test_rodriguez_steps_show_the_construction_of_procedure_b(make_scene) -> None:
    scene, _ = make_scene()
    scene.update(DT)
    assert not scene.ghost_links.visible  # all three steps: ghost links would coincide
    send_value(scene, "steps", 0)
    scene.update(DT)
    assert scene.ghost_links.visible
    for k in range(3):
        assert same_rotation(ghost_wxyz(scene, k), np.array([1.0, 0, 0, 0]), atol=GHOST_TOL)
        assert same_rotation(scene.ghost_link_frames[k].wxyz, np.array([1.0, 0, 0, 0]))
    np.testing.assert_allclose(ghost_position(scene, 2), [0, 0, 1.4], atol=GHOST_TOL)
    np.testing.assert_allclose(scene.ghost_link_frames[2].position, [0, 0, 1.4], atol=POSE_TOL)
    send_value(scene, "steps", 1)  # only joint 3 (global Z through (0, 0, 1.4)) applied
    scene.update(DT)
    spin = Rotation.from_euler("Z", 60, degrees=True).as_quat(scalar_first=True)
    assert same_rotation(scene.ghost_link_frames[2].wxyz, spin)
    assert same_rotation(ghost_wxyz(scene, 2), spin, atol=GHOST_TOL)
    assert same_rotation(scene.ghost_link_frames[1].wxyz, np.array([1.0, 0, 0, 0]))
    assert "Ghost shows (b) after 1 of 3 steps" in settle(scene)
    # The difference readout always compares the full procedures.
    assert difference_in_readout(scene) < 1e-14
    send_value(scene, "steps", 3)
    scene.update(DT)
    assert not scene.ghost_links.visible
    for k in range(3):
        assert same_rotation(ghost_wxyz(scene, k), scene.solid_frames[k].wxyz, atol=GHOST_TOL)


def test_hiding_procedure_b_hides_ghosts_and_global_axes(make_scene) -> None:
    scene, _ = make_scene()
    scene.update(DT)
    assert scene.ghost_root.visible and scene.global_axes.visible
    send_value(scene, "show_b", False)
    scene.update(DT)
    assert not scene.ghost_root.visible and not scene.global_axes.visible
    send_value(scene, "show_b", True)
    scene.update(DT)
    assert scene.ghost_root.visible


def test_animation_sweeps_then_hands_back_to_the_sliders(make_scene) -> None:
    scene, _ = make_scene()
    scene.update(DT)
    send_value(scene, "animate", True)
    poses = []
    for _ in range(30):
        scene.update(DT)
        poses.append(scene.solid_frames[2].wxyz.copy())
        assert all(np.isfinite(scene.solid_frames[k].wxyz).all() for k in range(3))
    assert all(slider.disabled for slider in scene.gui.joint_sliders)
    expected = np.degrees(joint_sweep(30 * DT, np.radians([30.0, 45.0, 60.0])))
    # the (disabled) sliders follow the sweep, within the angles of the last ~0.1 s
    shown = np.array([slider.value for slider in scene.gui.joint_sliders])
    assert not np.allclose(shown, [30.0, 45.0, 60.0])
    recent = [[round(wrap_deg(a), 1) for a in np.degrees(joint_sweep(n * DT, np.radians([30.0, 45.0, 60.0])))]
              for n in range(30 - 7, 31)]  # the frames of the last 0.1 s
    assert any(np.allclose(shown, angles, atol=0.051) for angles in recent), (shown, recent)
    np.testing.assert_allclose(np.degrees(scene.joint_angles), expected, atol=1e-9)
    # Smooth: consecutive frames differ, but by small rotations (q ~ -q).
    steps = [min(np.linalg.norm(b - a), np.linalg.norm(b + a)) for a, b in zip(poses, poses[1:])]
    assert min(steps) > 0 and max(steps) < 0.05
    send_value(scene, "animate", False)
    scene.update(DT)
    assert not any(slider.disabled for slider in scene.gui.joint_sliders)
    values = [slider.value for slider in scene.gui.joint_sliders]
    np.testing.assert_allclose(values, [round(wrap_deg(a), 1) for a in expected])
    scene.update(DT)
    assert same_rotation(scene.solid_frames[2].wxyz, expected_wxyz(tuple(values))[2])


def test_gimbal_lock_gives_a_notice_and_no_nan(make_scene) -> None:
    scene, notices = make_scene()
    send_value(scene, "theta2", 0.0)
    text = settle(scene)
    assert [n[0] for n in notices.items] == ["Gimbal lock"]
    assert "gimbal lock" in text
    for frame in scene.solid_frames:
        assert np.isfinite(frame.wxyz).all() and np.isfinite(frame.position).all()
    assert np.isfinite(scene.ghost_axes.batched_wxyzs).all()
    # The Euler form itself is still exact at the singularity.
    assert "A = A_ZXZ(30.0°, 0.0°, 60.0°)" in scene.gui.readout.content
    send_value(scene, "theta3", 61.0)
    settle(scene)
    assert len(notices.items) == 1  # once per entry into the singular state


def test_non_finite_joint_angle_is_refused_at_the_gate_and_keeps_the_pose(make_scene) -> None:
    scene, notices = make_scene()
    scene.update(DT)
    before = [frame.wxyz.copy() for frame in scene.solid_frames]
    for raw in (float("nan"), float("inf"), 1e308, "45", None):
        assert send_value(scene, "theta2", raw) is False
    scene.update(DT)
    assert scene.gui.joint_sliders[1].value == 45.0 and scene.controls.value("theta2") == 45.0
    for frame, wxyz in zip(scene.solid_frames, before):
        np.testing.assert_array_equal(frame.wxyz, wxyz)
    np.testing.assert_allclose(np.degrees(scene.joint_angles), [30.0, 45.0, 60.0])
    # The next valid value is taken as usual.
    send_value(scene, "theta2", 50.0)
    scene.update(DT)
    assert same_rotation(scene.solid_frames[1].wxyz, expected_wxyz((30.0, 50.0, 60.0))[1])


def test_state_round_trip_reproduces_the_arm(make_scene) -> None:
    scene, _ = make_scene()
    send_value(scene, "theta1", -75.5)
    send_value(scene, "steps", 1)
    scene.update(DT)
    state = scene.state()
    assert state["values"]["theta1"] == -75.5 and state["values"]["steps"] == 1
    pose = [frame.wxyz.copy() for frame in scene.solid_frames]
    send_value(scene, "theta1", 10.0)
    send_value(scene, "steps", 3)
    scene.update(DT)
    assert not same_rotation(scene.solid_frames[0].wxyz, pose[0], atol=1e-3)
    assert scene.load_state(state) == []
    scene.update(DT)
    for frame, wxyz in zip(scene.solid_frames, pose):
        np.testing.assert_allclose(frame.wxyz, wxyz, atol=POSE_TOL)
    assert scene.gui.steps.value == 1 and scene.gui.joint_sliders[0].value == -75.5


def test_general_joint_axes_have_no_euler_form_but_procedures_agree(make_scene) -> None:
    s = np.sqrt(0.5)
    geometry = ManipulatorGeometry(joint_axes=[[0, 0, 1], [s, s, 0], [0, s, s]])
    scene, _ = make_scene(geometry=geometry)
    assert "none for these joint axes" in settle(scene)
    assert scene.difference < 1e-14
    for k in range(3):
        assert same_rotation(ghost_wxyz(scene, k), scene.solid_frames[k].wxyz, atol=GHOST_TOL)


def test_readout_is_throttled_but_always_catches_up(make_scene) -> None:
    scene, _ = make_scene(readout_period=0.2)
    assert "30.0°, 45.0°, 60.0°" in settle(scene)
    send_value(scene, "theta1", 31.0)
    scene.update(DT)  # pose follows at once, the readout waits for its period
    assert same_rotation(scene.solid_frames[0].wxyz, expected_wxyz((31.0, 45.0, 60.0))[0])
    time.sleep(0.05)
    scene.update(DT)
    assert "**Joint angles**: 30.0°, 45.0°, 60.0°" in scene.gui.readout.content
    time.sleep(0.25)
    # nothing new to draw, but the pending readout is computed and written
    assert "**Joint angles**: 31.0°, 45.0°, 60.0°" in settle(scene)


def test_hidden_scene_and_close(make_scene, server) -> None:
    scene, _ = make_scene()
    scene.update(DT)
    scene.set_active(False)
    assert not scene.root_frame.visible and not scene._gui_folder.visible
    scene.set_active(True)
    assert scene.root_frame.visible


# -- integration with the running app -------------------------------------


def test_app_serves_the_manipulator_and_a_websocket_client_moves_a_joint(running_app, ws_client) -> None:
    app = running_app(scene="manipulator")
    scene = app.scene_for()
    assert isinstance(scene, ManipulatorScene)
    client, _ = ws_client(app)
    client.set_gui_value(scene.gui.joint_sliders[0], 100.0)
    expected = expected_wxyz((100.0, 45.0, 60.0))
    wait_until(lambda: same_rotation(scene.solid_frames[0].wxyz, expected[0]))
    wait_until(lambda: same_rotation(scene.solid_frames[2].wxyz, expected[2]))
    assert scene.difference < 1e-14


def test_per_client_mode_gives_each_browser_its_own_arm(per_client_scenes) -> None:
    _, [(first, scene_1), (_, scene_2)] = per_client_scenes(ManipulatorScene)
    first.set_gui_value(scene_1.gui.joint_sliders[2], -90.0)
    wait_until(lambda: np.isclose(np.degrees(scene_1.joint_angles[2]), -90.0))
    expected = expected_wxyz((30.0, 45.0, -90.0))
    wait_until(lambda: same_rotation(scene_1.solid_frames[2].wxyz, expected[2]))
    time.sleep(0.1)
    np.testing.assert_allclose(np.degrees(scene_2.joint_angles), [30.0, 45.0, 60.0])


def test_switching_away_stops_updates_and_back_resumes(running_app) -> None:
    app = running_app(scene="manipulator")
    scene = app.scene_for()
    send_value(scene, "animate", True)
    session = app.session_for()
    wait_until(lambda: session.update_counts["manipulator"] > 5)
    app.switch_scene("sandbox")
    assert app.scene_for().name == "sandbox"
    assert not scene.root_frame.visible
    frozen = scene.solid_frames[2].wxyz.copy()
    count = session.update_counts["manipulator"]
    time.sleep(0.2)
    assert session.update_counts["manipulator"] == count
    np.testing.assert_array_equal(scene.solid_frames[2].wxyz, frozen)
    app.switch_scene("manipulator")
    assert scene.root_frame.visible
    wait_until(lambda: not np.allclose(scene.solid_frames[2].wxyz, frozen))


@pytest.mark.parametrize("presenter", [False, True])
def test_labels_do_not_overlap_at_the_default_view(make_scene, presenter: bool) -> None:
    from tests.app._views import Camera, label_box, overlapping_pairs

    scene, _ = make_scene()
    scene.update(DT)
    scene.set_presenter(presenter)
    camera = Camera(ManipulatorScene.camera_position, ManipulatorScene.camera_look_at)
    boxes = {}
    for handle, _ in scene._labels:  # the fixed axes' labels: parents are identity frames
        x, y = camera.pixels(handle.position)
        box = label_box(x, y, handle.text, handle.anchor, handle.font_screen_scale)
        assert 0 <= box[0] and box[2] <= 800 and 0 <= box[1] and box[3] <= 750, (handle.text, box)
        boxes[handle.text] = box
    assert len(boxes) == 3
    assert overlapping_pairs(boxes) == [], boxes
