"""Rotation sandbox on a real ViserServer, checked against scipy's Rotation.

Most tests build the scene on a server without the app loop and call
``update`` themselves, so each step is deterministic; GUI values are set on
the server-side handles (viser runs the same callbacks as for a browser
edit). The last tests go through the full app with plain websocket clients.

Tolerances: every quantity is computed in float64 by a few closed-form
operations, so results agree with scipy to ~1e-12; 1e-9 leaves margin and
still catches any wrong sign, order or convention. Finite differences use a
central step h = 1e-6, whose truncation error O(h^2) and rounding error
O(eps / h) are both below 1e-8, hence their 1e-6 tolerance.
"""

from __future__ import annotations

import json
import math
import time
from typing import Any

import numpy as np
import pytest
import viser
from scipy.spatial.transform import Rotation

from app.scenes.sandbox import (
    INPUTS,
    PANELS,
    SEQUENCES,
    SandboxScene,
    export_document,
    orientation_views,
)

TOL = 1e-9
FD_TOL = 1e-6


def quat_equal(p: Any, q: Any, atol: float = TOL) -> bool:
    """Equal as rotations: p == q or p == -q (both scalar first)."""
    p, q = np.asarray(p, float), np.asarray(q, float)
    return bool(np.allclose(p, q, atol=atol) or np.allclose(p, -q, atol=atol))


def R(p: Any) -> Rotation:
    return Rotation.from_quat(np.asarray(p, float), scalar_first=True)


class Notices(list):
    def __call__(self, title: str, body: str, level: str) -> None:
        self.append((title, body, level))

    def titles(self) -> list[str]:
        return [t for t, _, _ in self]


@pytest.fixture(scope="module")
def server() -> Any:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture
def sandbox(server: Any) -> Any:
    notices = Notices()
    scene = SandboxScene(server, notices)
    scene.build()
    scene.set_active(True)
    scene.update(1 / 60)
    scene.notices = notices
    yield scene
    scene.close()


def settle(scene: Any, dt: float = 1 / 60) -> None:
    """Run the update twice, past the readout throttle, as the loop would."""
    scene.update(dt)
    scene._last_readout = 0.0
    scene.update(0.0)


def choose(scene: Any, *, panel: str | None = None, input: str | None = None, seq: str | None = None) -> None:
    if panel is not None:
        scene.panel_dropdown.value = panel
    if input is not None:
        scene.input_dropdown.value = input
    if seq is not None:
        scene.seq_dropdown.value = next(o for o in scene.seq_dropdown.options if o.split()[0] == seq)
    settle(scene)


def set_euler(scene: Any, degrees: Any) -> None:
    for slider, value in zip(scene.euler_sliders, degrees):
        slider.value = float(value)
    settle(scene)


def ring_global_rotations(scene: Any) -> list[Rotation]:
    """Global orientation of each ring frame, composed with scipy (independent)."""
    out, acc = [], Rotation.identity()
    for frame in scene.ring_frames:
        acc = acc * R(frame.wxyz)
        out.append(acc)
    return out


def ring_normals(scene: Any) -> np.ndarray:
    """Global normal (+z of the mount) of each ring's plane."""
    return np.array(
        [(rk * R(m.wxyz)).apply([0.0, 0.0, 1.0]) for rk, m in zip(ring_global_rotations(scene), scene.ring_mounts)]
    )


@pytest.mark.parametrize("seq", SEQUENCES)
def test_euler_sliders_drive_body_and_gimbal(sandbox: Any, seq: str) -> None:
    choose(sandbox, input="Euler angles", seq=seq)
    degrees = np.array([37.5, -62.0, 115.5])
    set_euler(sandbox, degrees)
    expected = Rotation.from_euler(seq, degrees, degrees=True)
    assert quat_equal(sandbox.body_frame.wxyz, expected.as_quat(scalar_first=True))
    # The rings ARE the angles: each turns by one slider angle about its axle,
    # and the three ring rotations compose to the body's orientation.
    rings = ring_global_rotations(sandbox)
    assert np.allclose(rings[-1].as_matrix(), expected.as_matrix(), atol=TOL)
    for k, frame in enumerate(sandbox.ring_frames):
        rotvec = R(frame.wxyz).as_rotvec()
        j = sandbox.gimbal.angle_index[k]
        assert math.isclose(np.linalg.norm(rotvec), abs(math.radians(degrees[j])), abs_tol=TOL)
    # Slider labels name the axes: primes (turned axes) only for intrinsic sequences.
    assert ("\u2032" in sandbox.euler_sliders[1].label) == seq.isupper()
    assert sandbox.euler_sliders[0].label.split()[-1 if seq.isupper() else -2].startswith(seq[0])


@pytest.mark.parametrize("seq, middle", [("ZXZ", 0.5), ("ZYX", 89.5), ("xyx", 179.5), ("yxz", -89.5)])
def test_gimbal_lock_rings_align_and_gauge_warns(sandbox: Any, seq: str, middle: float) -> None:
    choose(sandbox, input="Euler angles", seq=seq)
    set_euler(sandbox, [20.0, 45.0, 30.0])
    normals = ring_normals(sandbox)
    assert abs(normals[0] @ normals[1]) < 0.9  # far from lock: rings 0 and 1 at an angle
    assert sandbox.gauge.color == "green" and "Far from gimbal lock" in sandbox.gauge_text.content
    set_euler(sandbox, [20.0, middle, 30.0])
    normals = ring_normals(sandbox)
    # Half a degree from the singularity the outer and middle rings are
    # coplanar to within cos(0.5 deg) = 0.99996.
    assert abs(normals[0] @ normals[1]) > 0.9999
    # Independent measure: smallest singular value of G = |sin| or |cos| of
    # the middle angle (0.5 deg away) up to a factor of order 1.
    s = sandbox.gimbal.singular_values
    assert s[-1] < 0.02 and sandbox.gimbal.condition > 40
    assert sandbox.gauge.color == "red" and "Gimbal lock" in sandbox.gauge_text.content
    assert sandbox.gauge.value < 2.0


def test_sequence_change_keeps_orientation(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [10.0, 50.0, -70.0])
    before = np.array(sandbox.body_frame.wxyz)
    choose(sandbox, seq="zyx")
    assert quat_equal(sandbox.body_frame.wxyz, before)
    shown = [s.value for s in sandbox.euler_sliders]  # re-synced, rounded to the 0.5 deg step
    assert np.allclose(
        Rotation.from_euler("zyx", shown, degrees=True).as_matrix(), R(before).as_matrix(), atol=0.02
    )


def test_axis_angle_rodriguez_and_rotation_vector_inputs(sandbox: Any) -> None:
    choose(sandbox, input="Axis and angle")
    sandbox.axis_input.value = (1.0, 2.0, 2.0)  # not unit: normalized
    sandbox.angle_slider.value = 250.0
    settle(sandbox)
    expected = Rotation.from_rotvec(np.radians(250.0) * np.array([1.0, 2.0, 2.0]) / 3.0)
    assert quat_equal(sandbox.body_frame.wxyz, expected.as_quat(scalar_first=True))

    choose(sandbox, input="Rodriguez parameters")
    gamma = np.array([0.3, -1.2, 2.0])
    sandbox.gamma_input.value = tuple(gamma)
    settle(sandbox)
    angle = 2 * math.atan(np.linalg.norm(gamma))  # gamma = axis tan(angle / 2)
    expected = Rotation.from_rotvec(angle * gamma / np.linalg.norm(gamma))
    assert quat_equal(sandbox.body_frame.wxyz, expected.as_quat(scalar_first=True))
    # huge gamma (gamma . gamma overflows float64) is a half turn about it
    sandbox.gamma_input.value = (1e200, 0.0, 0.0)
    settle(sandbox)
    assert quat_equal(sandbox.body_frame.wxyz, np.array([0.0, 1.0, 0.0, 0.0]))

    choose(sandbox, input="Rotation vector")
    sandbox.rotvec_input.value = (0.5, -2.5, 1.0)  # |r| = 2.74 rad
    settle(sandbox)
    expected = Rotation.from_rotvec([0.5, -2.5, 1.0])
    assert quat_equal(sandbox.body_frame.wxyz, expected.as_quat(scalar_first=True))
    assert not sandbox.notices


def test_euler_parameters_input_normalizes_with_notice(sandbox: Any) -> None:
    choose(sandbox, input="Euler parameters")
    for number, value in zip(sandbox.ep_inputs, (1.0, 1.0, 0.0, 1.0)):
        number.value = value
    settle(sandbox)
    expected = np.array([1.0, 1.0, 0.0, 1.0]) / math.sqrt(3.0)
    assert quat_equal(sandbox.body_frame.wxyz, expected)
    title, body, level = sandbox.notices[-1]
    assert title == "Euler parameters normalized" and level == "warning"
    assert "|p| = 1.7321" in body
    assert "Normalized" in sandbox.ep_status.content


@pytest.mark.parametrize(
    "input_name, setter, title",
    [
        ("Euler parameters", lambda s: [setattr(n, "value", 0.0) for n in s.ep_inputs], "Euler parameters"),
        ("Axis and angle", lambda s: setattr(s, "_x", setattr(s.axis_input, "value", (0.0, 0.0, 0.0))), "Axis and angle"),
        ("Rotation vector", lambda s: setattr(s.rotvec_input, "value", (math.nan, 0.0, 1.0)), "Rotation vector"),
        ("Rodriguez parameters", lambda s: setattr(s.gamma_input, "value", (math.inf, 0.0, 1.0)), "Rodriguez parameters"),
        ("Euler parameters", lambda s: [setattr(n, "value", 1e308) for n in s.ep_inputs], "Euler parameters"),
    ],
)
def test_invalid_input_gives_notice_and_keeps_orientation(
    sandbox: Any, input_name: str, setter: Any, title: str
) -> None:
    choose(sandbox, input=input_name)
    before = np.array(sandbox.body_frame.wxyz)
    setter(sandbox)
    settle(sandbox)
    assert title in sandbox.notices.titles()
    after = np.array(sandbox.body_frame.wxyz)
    assert np.all(np.isfinite(after)) and np.allclose(after, before)
    for handle in (*sandbox.ring_frames, *sandbox.ring_mounts, sandbox.axis_frame):
        assert np.all(np.isfinite(handle.wxyz))


def test_readouts_show_every_representation(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [30.0, 40.0, 20.0])
    expected = Rotation.from_euler("ZXZ", [30.0, 40.0, 20.0], degrees=True)
    v = sandbox.views
    assert np.allclose(v.A, expected.as_matrix(), atol=TOL)
    assert np.allclose(v.rotation_vector, expected.as_rotvec(), atol=TOL)
    assert np.allclose(v.axis * math.tan(v.angle / 2), v.gamma, atol=TOL)
    text = sandbox.readout_text.content
    for piece in ("\u03c6 = 30.00", "\u03b8 = 40.00", "\u03c8 = 20.00", f"{v.p[0]:.4f}", f"{v.A[0, 0]:.4f}"):
        assert piece in text
    # At 180 degrees Rodriguez parameters are infinite: said, not printed as inf/nan.
    half_turn = orientation_views(np.array([0.0, 0.0, 1.0, 0.0]), "ZXZ")
    assert half_turn.gamma is None
    choose(sandbox, input="Axis and angle")
    sandbox.axis_input.value = (0.0, 1.0, 0.0)
    sandbox.angle_slider.value = 180.0
    settle(sandbox)
    assert "infinite" in sandbox.readout_text.content
    assert "nan" not in sandbox.readout_text.content.lower()


def test_compose_ghosts_do_not_commute(sandbox: Any) -> None:
    choose(sandbox, panel="Compose q1, q2")
    assert sandbox.ghosts[0][0].visible and not sandbox.body_frame.visible
    q1 = Rotation.from_rotvec([math.pi / 2, 0, 0])  # defaults: 90 deg about x, then z
    q2 = Rotation.from_rotvec([0, 0, math.pi / 2])
    assert quat_equal(sandbox.ghosts[0][1].wxyz, (q1 * q2).as_quat(scalar_first=True))
    assert quat_equal(sandbox.ghosts[1][1].wxyz, (q2 * q1).as_quat(scalar_first=True))
    c = sandbox.compose
    relative = (q1 * q2).inv() * (q2 * q1)  # A_i.T A_j (Eq. 8.82)
    assert quat_equal(c.relative, relative.as_quat(scalar_first=True))
    assert math.isclose(c.relative_angle, relative.magnitude(), abs_tol=TOL)
    assert math.isclose(c.difference, np.linalg.norm((q1 * q2).as_matrix() - (q2 * q1).as_matrix()), abs_tol=TOL)
    assert "do not commute" in sandbox.compose_text.content
    sandbox.q_axes[0].value = (0.0, 0.0, 2.0)  # same axis as q2: they commute
    settle(sandbox)
    assert sandbox.compose.difference < TOL and "commute" in sandbox.compose_text.content
    choose(sandbox, panel="Orientation")
    assert not sandbox.ghosts[0][0].visible and sandbox.body_frame.visible


def _fd_omega(matrix_of_t: Any, h: float = 1e-6) -> np.ndarray:
    """Global angular velocity from skew(omega) = A_dot A.T by central differences."""
    A0 = matrix_of_t(0.0)
    A_dot = (matrix_of_t(h) - matrix_of_t(-h)) / (2 * h)
    W = A_dot @ A0.T
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


@pytest.mark.parametrize("body_frame", [False, True])
def test_angular_velocity_rates_reproduce_omega(sandbox: Any, body_frame: bool) -> None:
    choose(sandbox, input="Euler angles", seq="ZYX", panel="Angular velocity")
    set_euler(sandbox, [25.0, -35.0, 60.0])
    omega_in = np.array([0.4, -1.1, 0.7])
    sandbox.omega_input.value = tuple(omega_in)
    sandbox.omega_frame_dropdown.value = sandbox.omega_frame_dropdown.options[int(body_frame)]
    settle(sandbox)
    r = sandbox.rates
    A = Rotation.from_euler("ZYX", [25.0, -35.0, 60.0], degrees=True).as_matrix()
    omega = A @ omega_in if body_frame else omega_in
    assert np.allclose(r.omega, omega, atol=TOL)
    assert np.allclose(r.omega_body, A.T @ omega, atol=TOL)
    angles = np.radians([25.0, -35.0, 60.0])
    # Euler angle rates: moving the angles at these rates turns the body at omega.
    fd = _fd_omega(lambda t: Rotation.from_euler("ZYX", angles + t * r.euler_rates).as_matrix())
    assert np.allclose(fd, omega, atol=FD_TOL)
    # Euler parameter and Rodriguez parameter rates, from the exact motion under omega.
    p0 = Rotation.from_matrix(A)

    def p_of(t: float) -> np.ndarray:
        p = (Rotation.from_rotvec(omega * t) * p0).as_quat(scalar_first=True)
        return p * np.sign(p[0]) * np.sign(sandbox.p[0] if sandbox.p[0] != 0 else 1.0)

    h = 1e-6
    p_dot = (p_of(h) - p_of(-h)) / (2 * h)
    assert np.allclose(r.p_dot, p_dot * np.sign(p_of(0.0) @ sandbox.p), atol=FD_TOL)
    gamma_dot = (p_of(h)[1:] / p_of(h)[0] - p_of(-h)[1:] / p_of(-h)[0]) / (2 * h)
    assert np.allclose(r.gamma_dot, gamma_dot, atol=FD_TOL)
    assert "\u03c6\u0307" not in sandbox.rates_text.content  # not ZXZ: alpha names
    assert "Euler parameter rates" in sandbox.rates_text.content
    assert sandbox.omega_frame.visible


def test_angular_velocity_singular_cases_are_explained(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ", panel="Angular velocity")
    set_euler(sandbox, [30.0, 0.0, 20.0])  # theta = 0: G singular
    assert sandbox.rates.euler_rates is None
    assert "singular" in sandbox.rates_text.content
    assert sandbox.rates.p_dot is not None and np.all(np.isfinite(sandbox.rates.p_dot))
    choose(sandbox, input="Axis and angle")
    sandbox.axis_input.value = (1.0, 0.0, 0.0)
    sandbox.angle_slider.value = 180.0
    settle(sandbox)
    assert sandbox.rates.gamma_dot is None and "undefined" in sandbox.rates_text.content


@pytest.mark.parametrize("body_frame", [False, True])
def test_animation_under_constant_omega(sandbox: Any, body_frame: bool) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ", panel="Angular velocity")
    start = R(sandbox.body_frame.wxyz)
    omega = np.array([0.3, -0.2, 1.0])
    sandbox.omega_input.value = tuple(omega)
    sandbox.omega_frame_dropdown.value = sandbox.omega_frame_dropdown.options[int(body_frame)]
    sandbox.animate_checkbox.value = True
    sandbox.update(0.0)
    for _ in range(20):
        sandbox.update(0.05)  # 1 s in total
    step = Rotation.from_rotvec(omega * 1.0)
    expected = start * step if body_frame else step * start
    assert quat_equal(sandbox.body_frame.wxyz, expected.as_quat(scalar_first=True), atol=1e-9)
    sandbox.animate_checkbox.value = False
    sandbox.update(0.05)
    frozen = np.array(sandbox.body_frame.wxyz)
    sandbox.update(0.05)
    assert np.allclose(sandbox.body_frame.wxyz, frozen)
    # The sliders were re-synced to the final pose.
    shown = [s.value for s in sandbox.euler_sliders]
    assert np.allclose(Rotation.from_euler("ZXZ", shown, degrees=True).as_matrix(), expected.as_matrix(), atol=0.02)


def test_export_json_in_every_representation(sandbox: Any, monkeypatch: Any) -> None:
    choose(sandbox, input="Euler angles", seq="XYZ", panel="Export")
    set_euler(sandbox, [15.0, 25.0, 35.0])
    doc = json.loads(sandbox.export_text.value)
    expected = Rotation.from_euler("XYZ", [15.0, 25.0, 35.0], degrees=True)
    assert np.allclose(doc["matrix_body_to_global"], expected.as_matrix(), atol=TOL)
    assert quat_equal(doc["euler_parameters"], expected.as_quat(scalar_first=True))
    assert np.allclose(doc["rotation_vector_rad"], expected.as_rotvec(), atol=TOL)
    assert np.allclose(doc["euler_angles"]["degrees"], [15.0, 25.0, 35.0], atol=TOL)
    assert doc["euler_angles"]["mujoco_eulerseq"] == "xyz"  # MuJoCo: lower case is intrinsic
    assert len(doc["euler_angles_all_sequences_rad"]) == 24
    for seq, angles in doc["euler_angles_all_sequences_rad"].items():
        assert np.allclose(Rotation.from_euler(seq, angles).as_matrix(), expected.as_matrix(), atol=TOL)
    notes = doc["conventions"]
    assert "scalar_first=True" in notes["scipy"] and "wxyz" in notes["viser"] and "eulerseq" in notes["mujoco"]
    # The button sends the same document as a file download.
    sent: list[tuple[str, bytes]] = []
    monkeypatch.setattr(sandbox.target, "send_file_download", lambda name, content, *a, **k: sent.append((name, content)))
    sandbox.download_button.value = True  # what a click does on the server
    sandbox.update(0.0)
    assert sent and sent[0][0] == "orientation.json"
    assert json.loads(sent[0][1]) == export_document(sandbox.views)


def test_hidden_then_shown_keeps_state(sandbox: Any) -> None:
    set_euler(sandbox, [5.0, 60.0, 5.0])
    pose = np.array(sandbox.body_frame.wxyz)
    sandbox.set_active(False)
    assert sandbox.root_frame.visible is False and sandbox._gui_folder.visible is False
    sandbox.set_active(True)
    assert np.allclose(sandbox.body_frame.wxyz, pose)
    assert set(INPUTS) and set(PANELS)


# -- through the app, with plain websocket clients as browsers ---------------
def wait_until(predicate: Any, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return bool(predicate())


def test_app_slider_from_client_moves_body_and_bad_input_keeps_serving(running_app: Any, ws_client: Any) -> None:
    app = running_app(scene="sandbox", mode="shared")
    client, _ = ws_client(app)
    scene = app.scene_for()
    client.set_gui_value(scene.euler_sliders[2], 75.0)
    expected = Rotation.from_euler("ZXZ", [30.0, 40.0, 75.0], degrees=True).as_quat(scalar_first=True)
    assert wait_until(lambda: quat_equal(scene.body_frame.wxyz, expected))
    client.set_gui_value(scene.input_dropdown, "Euler parameters")
    # Switching the input re-fills its fields from the current orientation;
    # wait for that before typing, as a person would.
    assert wait_until(lambda: scene.input == "Euler parameters" and not scene._dirty)
    time.sleep(0.05)
    for number in scene.ep_inputs:
        client.set_gui_value(number, 0.0)
    session = app.session_for()
    assert wait_until(lambda: any(t == "Euler parameters" and lvl == "error" for t, _, lvl in session.notices))
    assert np.all(np.isfinite(scene.body_frame.wxyz))
    ticks = app._ticks
    assert wait_until(lambda: app._ticks > ticks + 3)  # still serving
    client.set_gui_value(scene.ep_inputs[0], 1.0)
    assert wait_until(lambda: quat_equal(scene.body_frame.wxyz, (1.0, 0.0, 0.0, 0.0)))


def test_app_per_client_sandboxes_are_isolated(running_app: Any, ws_client: Any) -> None:
    app = running_app(scene="sandbox", mode="per-client")
    client_a, id_a = ws_client(app)
    client_b, id_b = ws_client(app)
    scene_a, scene_b = app.scene_for(id_a), app.scene_for(id_b)
    before_b = np.array(scene_b.body_frame.wxyz)
    client_a.set_gui_value(scene_a.euler_sliders[0], -120.0)
    expected = Rotation.from_euler("ZXZ", [-120.0, 40.0, 20.0], degrees=True).as_quat(scalar_first=True)
    assert wait_until(lambda: quat_equal(scene_a.body_frame.wxyz, expected))
    time.sleep(0.1)
    assert np.allclose(scene_b.body_frame.wxyz, before_b)
    assert scene_b.euler_sliders[0].value == 30.0


def test_compose_q1_from_current_body(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [30.0, 40.0, 20.0])
    body = R(sandbox.body_frame.wxyz)
    choose(sandbox, panel="Compose q1, q2")
    sandbox.q1_from_body_button.value = True  # what a click does on the server
    settle(sandbox)
    # q1 is shown as axis (6 decimals) and angle (3 decimals of a degree):
    # it reproduces the body to ~1e-5.
    assert quat_equal(sandbox.compose.q1, body.as_quat(scalar_first=True), atol=1e-4)
    q2 = Rotation.from_rotvec([0, 0, math.pi / 2])
    assert quat_equal(sandbox.ghosts[0][1].wxyz, (R(sandbox.compose.q1) * q2).as_quat(scalar_first=True))


@pytest.mark.parametrize("scale", [1e200, 1e-12, 1e-200])
def test_huge_and_tiny_axes_keep_their_direction(sandbox: Any, scale: float) -> None:
    """Any non-zero finite axis is normalized: the squares of these overflow
    or underflow, which used to give a confusing 'unit vector, got norm 0.0'
    notice (axis and angle), a rejection of a non-zero axis, or an uncaught
    error in the session loop (compose)."""
    direction = np.array([0.0, 3.0, 4.0]) / 5.0
    choose(sandbox, input="Axis and angle")
    sandbox.axis_input.value = tuple(direction * scale)
    sandbox.angle_slider.value = 90.0
    settle(sandbox)
    expected = Rotation.from_rotvec(direction * math.pi / 2).as_quat(scalar_first=True)
    assert quat_equal(sandbox.body_frame.wxyz, expected)
    assert "Axis and angle" not in sandbox.notices.titles()
    choose(sandbox, panel="Compose q1, q2")
    sandbox.q_axes[0].value = tuple(direction * scale)
    settle(sandbox)
    q1 = Rotation.from_rotvec(direction * math.pi / 2)  # q1 angle slider default: 90 deg
    assert quat_equal(sandbox.compose.q1, q1.as_quat(scalar_first=True))
    assert "Compose" not in sandbox.notices.titles()
    choose(sandbox, panel="Orientation")


def test_huge_omega_gives_a_notice_and_no_unreadable_rates(sandbox: Any) -> None:
    """omega = 1e200 rad/s used to print 200-digit rates and animate with
    overflow warnings; it is now refused with a notice."""
    choose(sandbox, panel="Angular velocity")
    before = np.array(sandbox.body_frame.wxyz)
    sandbox.omega_input.value = (1e200, 0.0, 0.0)
    sandbox.animate_checkbox.value = True
    settle(sandbox)
    sandbox.update(0.1)
    settle(sandbox)
    title, body, level = [n for n in sandbox.notices if n[0] == "Angular velocity"][-1]
    assert "within \u00b11e+06 rad/s, got (1e+200, 0, 0)" in body and level == "warning"
    assert np.allclose(sandbox.body_frame.wxyz, before)  # not animated
    assert max(len(word) for word in sandbox.rates_text.content.split()) < 40
    # nothing of the previous, valid omega stays on screen
    assert "No valid" in sandbox.rates_text.content
    assert sandbox.omega_arrow.visible is False and sandbox.omega_label.visible is False
    for handle in (sandbox.body_frame, *sandbox.ring_frames, sandbox.axis_frame):
        assert np.all(np.isfinite(handle.wxyz))
    sandbox.animate_checkbox.value = False
    sandbox.omega_input.value = (0.0, 0.0, 1.0)
    choose(sandbox, panel="Orientation")
