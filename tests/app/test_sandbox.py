"""Rotation sandbox on a real ViserServer, checked against scipy's Rotation.

Most tests build the scene on a bare server (``server`` fixture) and drive
``scene.frame`` themselves, so each step is deterministic; GUI values are
delivered exactly as a browser sends them, through the gate
(:func:`tests.helpers.send_value`, :func:`tests.helpers.click`). The last
tests go through the full app with plain websocket clients.

Tolerances: every quantity is computed in float64 by a few closed-form
operations, so results agree with scipy to ~1e-12; 1e-9 leaves margin and
still catches any wrong sign, order or convention. Finite differences use a
central step h = 1e-6, whose truncation error O(h^2) and rounding error
O(eps / h) are both below 1e-8, hence their 1e-6 tolerance.
"""

from __future__ import annotations

import json
import math
import re
import time
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigidlab.app.controls import format_vector
from rigidlab.app.panels import (
    SEQUENCES,
    export_document,
    gimbal_conditioning,
    gimbal_layout,
    orientation_views,
)
from rigidlab.app.panels.angular_velocity import OMEGA_FRAMES
from rigidlab.app.panels.gimbal import COND_LOCK, COND_WARN, gauge_fill, lock_state
from rigidlab.app.panels.orientation import INPUTS
from rigidlab.app.scenes.base import PRESENTER_ARROW_SCALE, PRESENTER_LABEL_SCALE
from rigidlab.app.scenes.sandbox import PANELS, SandboxScene
from tests.helpers import click, send_value, wait_for_frames, wait_until

TOL = 1e-9
FD_TOL = 1e-6
DT = 1.0 / 60.0


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


def make_sandbox(server: Any, **kwargs: Any) -> SandboxScene:
    notices = Notices()
    kwargs.setdefault("readout_period", 0.0)  # deterministic: text follows every change
    scene = SandboxScene(server, notices, **kwargs)
    scene.build()
    scene.set_active(True)
    scene.notices = notices
    settle(scene)
    return scene


@pytest.fixture
def sandbox(server: Any) -> Any:
    scene = make_sandbox(server)
    yield scene
    scene.close()


def settle(scene: Any, dt: float = DT) -> None:
    """One frame of ``dt``, then frames of 0 s until every readout is written
    (the text work of a change is spread over a few frames) and the export
    preview, computed in the background, is in."""
    scene.frame(dt)
    for _ in range(200):
        if not scene.text_pending and not scene.export_panel.busy:
            return
        if scene.export_panel.busy:
            time.sleep(0.005)
        scene.frame(0.0)
    raise AssertionError("the sandbox's readouts did not settle")


def send(scene: Any, key: str, raw: Any) -> None:
    """A browser value through the gate, then the frames that show it.

    A value equal to the one the control holds is not sent: it changes
    nothing, and the gate's test path (``Gate.submit``) would still run the
    control's callback later, which could let the next ``send_value``
    return before its own value has arrived.
    """
    spec, handle = scene.controls.specs[key], scene.controls.handles[key]
    try:
        unchanged = spec.check(raw) == handle.value
    except Exception:
        unchanged = False
    if not unchanged:
        assert send_value(scene, key, raw), f"the gate refused {raw!r} for {key}"
    settle(scene)


def choose(scene: Any, *, panel: str | None = None, input: str | None = None, seq: str | None = None) -> None:
    if panel is not None:
        send(scene, "panel", panel)
    if input is not None:
        send(scene, "input", input)
    if seq is not None:
        send(scene, "seq", next(o for o in scene.controls.specs["seq"].options if o.split()[0] == seq))


def set_euler(scene: Any, degrees: Any) -> None:
    for k, value in enumerate(degrees):
        send(scene, f"euler{k + 1}", float(value))


def body_wxyz(scene: Any) -> np.ndarray:
    return np.asarray(scene.body.frame.wxyz, dtype=float)


def ring_global_rotations(scene: Any) -> list[Rotation]:
    """Global orientation of each ring frame, composed with scipy (independent)."""
    out, acc = [], Rotation.identity()
    for frame in scene.gimbal.ring_frames:
        acc = acc * R(frame.wxyz)
        out.append(acc)
    return out


def ring_normals(scene: Any) -> np.ndarray:
    """Global normal (+z of the mount) of each ring's plane."""
    return np.array([
        (rk * R(m.wxyz)).apply([0.0, 0.0, 1.0])
        for rk, m in zip(ring_global_rotations(scene), scene.gimbal.ring_mounts)
    ])


def run_out_text_restore(scene: Any) -> None:
    """Let the panel's 1.5 s pause after unparseable text pass, without waiting."""
    scene.controls.poll(time.monotonic() + 2.0)
    settle(scene)


# -- every input kind -------------------------------------------------------------
@pytest.mark.parametrize("seq", SEQUENCES)
def test_euler_sliders_drive_body_and_gimbal(sandbox: Any, seq: str) -> None:
    choose(sandbox, input="Euler angles", seq=seq)
    degrees = np.array([37.5, -62.0, 115.5])
    set_euler(sandbox, degrees)
    expected = Rotation.from_euler(seq, degrees, degrees=True)
    assert quat_equal(body_wxyz(sandbox), expected.as_quat(scalar_first=True))
    # The rings ARE the angles: each turns by one slider angle about its axle,
    # and the three ring rotations compose to the body's orientation.
    rings = ring_global_rotations(sandbox)
    assert np.allclose(rings[-1].as_matrix(), expected.as_matrix(), atol=TOL)
    index = gimbal_layout(seq).angle_index
    for k, frame in enumerate(sandbox.gimbal.ring_frames):
        rotvec = R(frame.wxyz).as_rotvec()
        assert math.isclose(np.linalg.norm(rotvec), abs(math.radians(degrees[index[k]])), abs_tol=TOL)
    # Slider labels name the axes: primes (turned axes) only for intrinsic sequences.
    labels = [sandbox.controls.handles[f"euler{k + 1}"].label for k in range(3)]
    assert ("\u2032" in labels[1]) == seq.isupper()
    assert labels[0].split()[-1 if seq.isupper() else -2].startswith(seq[0])


@pytest.mark.parametrize("seq, middle", [("ZXZ", 0.5), ("ZYX", 89.5), ("xyx", 179.5), ("yxz", -89.5)])
def test_gimbal_lock_rings_align_and_gauge_is_unmistakable(sandbox: Any, seq: str, middle: float) -> None:
    choose(sandbox, input="Euler angles", seq=seq)
    set_euler(sandbox, [20.0, 45.0, 30.0])
    normals = ring_normals(sandbox)
    assert abs(normals[0] @ normals[1]) < 0.9  # far from lock: rings 0 and 1 at an angle
    gimbal = sandbox.gimbal
    assert gimbal.gauge_color == "green" and gimbal.gauge_fill < 50.0
    assert "Far from gimbal lock" in sandbox.gimbal.gauge_text.content
    assert not sandbox.gimbal.lock_label.visible
    set_euler(sandbox, [20.0, middle, 30.0])
    normals = ring_normals(sandbox)
    # Half a degree from the singularity the outer and middle rings are
    # coplanar to within cos(0.5 deg) = 0.99996.
    assert abs(normals[0] @ normals[1]) > 0.9999
    # Independent measure: smallest singular value of G = |sin| or |cos| of
    # the middle angle (0.5 deg away) up to a factor of order 1.
    c = sandbox.conditioning
    assert c.singular_values[-1] < 0.02 and c.condition > COND_LOCK
    # At lock: a full red bar, a bold GIMBAL LOCK state, and a 3-D label at the gimbal.
    assert gimbal.gauge_color == "red" and gimbal.gauge_fill == 100.0
    assert "GIMBAL LOCK" in gimbal.gauge.content and "width:100%" in gimbal.gauge.content
    assert "**GIMBAL LOCK**" in sandbox.gimbal.gauge_text.content
    assert sandbox.gimbal.lock_label.visible and sandbox.gimbal.lock_label.text == "GIMBAL LOCK"


def test_gauge_scale_far_near_and_at_lock() -> None:
    assert gauge_fill(1.0) == 0.0 and gauge_fill(COND_LOCK) == 100.0 and gauge_fill(math.inf) == 100.0
    assert 0.0 < gauge_fill(2.75) < gauge_fill(COND_WARN + 1) < 100.0  # grows with cond(G)
    assert lock_state(2.75) == "far" and lock_state(COND_WARN + 1) == "near" and lock_state(math.inf) == "lock"


def test_near_lock_is_orange(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [20.0, 6.0, 30.0])
    condition = gimbal_conditioning(np.radians([20.0, 6.0, 30.0]), "ZXZ").condition
    assert COND_WARN < condition < COND_LOCK  # the test's premise
    assert sandbox.gimbal.gauge_color == "orange"
    assert "Near gimbal lock" in sandbox.gimbal.gauge_text.content
    assert not sandbox.gimbal.lock_label.visible


def test_sequence_change_keeps_orientation(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [10.0, 50.0, -70.0])
    before = body_wxyz(sandbox)
    p_before = sandbox.p.copy()
    choose(sandbox, seq="zyx")
    assert quat_equal(body_wxyz(sandbox), before)
    assert np.array_equal(sandbox.p, p_before)  # the orientation itself is untouched
    shown = [sandbox.controls.value(f"euler{k + 1}") for k in range(3)]  # re-synced, 0.1 deg
    assert np.allclose(
        Rotation.from_euler("zyx", shown, degrees=True).as_matrix(), R(before).as_matrix(), atol=2e-3
    )
    # The gimbal shows the new sequence's exact angles.
    assert np.allclose(ring_global_rotations(sandbox)[-1].as_matrix(), R(before).as_matrix(), atol=TOL)
    assert sandbox.controls.handles["euler1"].label == "\u03b1\u2081 about z (fixed)"


def test_axis_angle_rodriguez_and_rotation_vector_inputs(sandbox: Any) -> None:
    choose(sandbox, input="Axis and angle")
    send(sandbox, "axis", "1, 2, 2")  # not unit: normalized
    send(sandbox, "angle", 250.0)
    expected = Rotation.from_rotvec(np.radians(250.0) * np.array([1.0, 2.0, 2.0]) / 3.0)
    assert quat_equal(body_wxyz(sandbox), expected.as_quat(scalar_first=True))

    choose(sandbox, input="Rodriguez parameters")
    gamma = np.array([0.3, -1.2, 2.0])
    send(sandbox, "gamma", "0.3, -1.2, 2")
    angle = 2 * math.atan(np.linalg.norm(gamma))  # gamma = axis tan(angle / 2)
    expected = Rotation.from_rotvec(angle * gamma / np.linalg.norm(gamma))
    assert quat_equal(body_wxyz(sandbox), expected.as_quat(scalar_first=True))
    # huge gamma (gamma . gamma overflows float64) is a half turn about it
    send(sandbox, "gamma", "1e200, 0, 0")
    assert quat_equal(body_wxyz(sandbox), np.array([0.0, 1.0, 0.0, 0.0]))

    choose(sandbox, input="Rotation vector")
    send(sandbox, "rotvec", "[0.5, -2.5, 1.0]")  # |r| = 2.74 rad; brackets allowed
    expected = Rotation.from_rotvec([0.5, -2.5, 1.0])
    assert quat_equal(body_wxyz(sandbox), expected.as_quat(scalar_first=True))
    assert not sandbox.notices


def test_switching_input_fills_its_fields_from_the_orientation(sandbox: Any) -> None:
    set_euler(sandbox, [30.0, 40.0, 20.0])
    expected = Rotation.from_euler("ZXZ", [30.0, 40.0, 20.0], degrees=True)
    p = expected.as_quat(scalar_first=True)
    choose(sandbox, input="Euler parameters")
    shown = [sandbox.controls.value(f"ep{k}") for k in range(4)]
    assert quat_equal(shown, p, atol=1e-6)  # 6 decimals
    assert sandbox.controls.handles["ep0"].value == format_vector([round(abs(p[0]), 6)])
    choose(sandbox, input="Rotation vector")
    assert np.allclose(sandbox.controls.value("rotvec"), expected.as_rotvec(), atol=1e-6)
    choose(sandbox, input="Axis and angle")
    rotvec = np.radians(sandbox.controls.value("angle")) * np.asarray(sandbox.controls.value("axis"))
    assert np.allclose(rotvec, expected.as_rotvec(), atol=1e-4)
    # The body did not move: filling fields is not an edit.
    assert quat_equal(body_wxyz(sandbox), p)


def test_euler_parameters_normalize_with_a_status_at_once_and_no_notice(server: Any) -> None:
    # A readout period of an hour: the status must not wait for the readouts.
    scene = make_sandbox(server, readout_period=3600.0)
    try:
        choose(scene, input="Euler parameters")
        for k, value in enumerate(("1", "1", "0", "1")):
            send(scene, f"ep{k}", value)
        expected = np.array([1.0, 1.0, 0.0, 1.0]) / math.sqrt(3.0)
        assert quat_equal(body_wxyz(scene), expected)
        status = scene.input_panel.ep_status.content
        assert "**Normalized:**" in status and "|p| = 1.732" in status
        # The fields keep what was typed: nothing is rewritten.
        assert [scene.controls.handles[f"ep{k}"].value for k in range(4)] == ["1", "1", "0", "1"]
        # A second edit that makes p unit: the status follows at once, never stale.
        send(scene, "ep0", "0")
        send(scene, "ep2", "1")
        send(scene, "ep3", "0")
        send(scene, "ep1", "0")
        assert scene.input_panel.ep_status.content.startswith("|p| = 1")
        assert quat_equal(body_wxyz(scene), [0.0, 0.0, 1.0, 0.0])
        assert not scene.notices  # a status, never a (delayed) notice
    finally:
        scene.close()


def test_all_zero_euler_parameters_keep_the_orientation(sandbox: Any) -> None:
    choose(sandbox, input="Euler parameters")
    before = body_wxyz(sandbox)
    for k in range(4):
        send(sandbox, f"ep{k}", "0")
    assert "**Not a rotation:**" in sandbox.input_panel.ep_status.content
    assert np.allclose(body_wxyz(sandbox), before)
    send(sandbox, "ep0", "1")
    assert quat_equal(body_wxyz(sandbox), [1.0, 0.0, 0.0, 0.0])
    assert "|p| = 1" in sandbox.input_panel.ep_status.content


# -- typed numbers: parsed by the app, never rewritten ------------------------------
def test_text_entry_takes_scientific_notation_and_full_precision(sandbox: Any) -> None:
    choose(sandbox, input="Axis and angle")
    send(sandbox, "angle", 90.0)
    send(sandbox, "axis", "0, 1e-3, 1")  # 1e-3 stays 1e-3 (viser's number box made it -13)
    assert sandbox.controls.value("axis") == (0.0, 1e-3, 1.0)
    expected = Rotation.from_rotvec(math.pi / 2 * np.array([0.0, 1e-3, 1.0]) / math.hypot(1e-3, 1.0))
    assert quat_equal(body_wxyz(sandbox), expected.as_quat(scalar_first=True))
    # Full precision: 17 significant digits reach the core unchanged.
    text = "0.12345678901234568, 0.9876543210987654, -0.3333333333333333"
    send(sandbox, "axis", text)
    axis = np.array([0.12345678901234568, 0.9876543210987654, -0.3333333333333333])
    assert sandbox.controls.value("axis") == tuple(axis)
    assert sandbox.controls.handles["axis"].value == text  # the field shows what was typed
    expected = Rotation.from_rotvec(math.pi / 2 * axis / np.linalg.norm(axis))
    assert quat_equal(sandbox.p, expected.as_quat(scalar_first=True), atol=1e-15)
    choose(sandbox, input="Euler parameters")
    send(sandbox, "ep1", "2.5E-3")
    assert sandbox.controls.value("ep1") == 2.5e-3


@pytest.mark.parametrize("key, raw", [
    ("ep1", "1e400"), ("ep1", "nan"), ("ep1", "abc"), ("ep1", "inf"),
    ("axis", "0, 0, 0"), ("axis", "nan, 0, 1"), ("axis", "1e400, 0, 1"), ("axis", "1, 2"),
    ("gamma", "inf, 0, 1"), ("rotvec", "nan, 0, 1"), ("omega", "1e200, 0, 0"),
])
def test_unparseable_text_is_refused_with_a_notice_and_restored(sandbox: Any, key: str, raw: str) -> None:
    input_of = {"ep1": "Euler parameters", "axis": "Axis and angle", "gamma": "Rodriguez parameters",
                "rotvec": "Rotation vector"}
    if key in input_of:
        choose(sandbox, input=input_of[key])
    else:
        choose(sandbox, panel="Angular velocity")
    before = sandbox.p.copy()
    in_use = sandbox.controls.value(key)
    shown = sandbox.controls.handles[key].value
    assert send_value(sandbox, key, raw)  # text passes the gate: it may be on its way to a number
    settle(sandbox)
    assert sandbox.controls.value(key) == in_use  # never reaches the scene
    assert np.array_equal(sandbox.p, before)
    run_out_text_restore(sandbox)
    title, body, level = sandbox.notices[-1]
    label = sandbox.controls.specs[key].label
    assert title == f"Refused: {label}" and level == "warning"
    assert repr(raw)[:20] in body or raw[:20] in body
    assert sandbox.controls.handles[key].value == shown  # the field shows the value in use again
    for handle in (sandbox.body.frame, *sandbox.gimbal.ring_frames, sandbox.rotation_axis.frame):
        assert np.all(np.isfinite(handle.wxyz))
    assert sandbox.paused_error is None


@pytest.mark.parametrize("raw", [1e6, -181.0, math.nan, math.inf, 10**30, "30", None, True])
def test_refused_slider_value_keeps_the_value_in_use(sandbox: Any, raw: Any) -> None:
    set_euler(sandbox, [30.0, 40.0, 20.0])
    gate = sandbox.controls.gate
    refused = gate.refused_count
    before = sandbox.p.copy()
    assert not send_value(sandbox, "euler1", raw)
    settle(sandbox)
    assert gate.refused_count == refused + 1
    assert sandbox.controls.handles["euler1"].value == 30.0  # never stored
    assert sandbox.controls.value("euler1") == 30.0
    assert np.array_equal(sandbox.p, before)


def test_every_input_goes_through_the_gate(sandbox: Any) -> None:
    gate = sandbox.controls.gate
    ours = {h._impl.uuid for h in sandbox.controls.handles.values()}
    assert ours <= gate.registered()
    unregistered = gate.input_uuids() - gate.registered()
    assert not unregistered, [sandbox.target.gui._gui_input_handle_from_uuid[u].label for u in unregistered]


# -- readouts ------------------------------------------------------------------------
def test_readouts_show_every_representation_with_meaningful_digits(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [30.0, 40.0, 20.0])
    expected = Rotation.from_euler("ZXZ", [30.0, 40.0, 20.0], degrees=True)
    v = sandbox.current_views()
    assert np.allclose(v.A, expected.as_matrix(), atol=TOL)
    assert np.allclose(v.rotation_vector, expected.as_rotvec(), atol=TOL)
    assert np.allclose(v.axis * math.tan(v.angle / 2), v.gamma, atol=TOL)
    text = sandbox.readout_text
    for piece in ("\u03c6 = 30.0\u00b0", "\u03b8 = 40.0\u00b0", "\u03c8 = 20.0\u00b0", f"{v.p[0]:.4f}",
                  f"{v.A[0, 0]:.3f}", f"{math.degrees(v.angle):.1f}\u00b0"):
        assert piece in text
    # Digits that mean something: never more than 4 decimals.
    assert not re.search(r"\d\.\d{5,}", text)
    assert not re.search(r"\d\.\d{5,}", sandbox.gimbal.gauge_text.content)
    # At 180 degrees Rodriguez parameters are infinite: said, not printed as inf/nan.
    half_turn = orientation_views(np.array([0.0, 0.0, 1.0, 0.0]), "ZXZ")
    assert half_turn.gamma is None
    choose(sandbox, input="Axis and angle")
    send(sandbox, "axis", "0, 1, 0")
    send(sandbox, "angle", 180.0)
    assert "infinite" in sandbox.readout_text
    assert "nan" not in sandbox.readout_text.lower()


def test_labels_follow_the_orientation_at_the_readout_rate(sandbox: Any) -> None:
    set_euler(sandbox, [30.0, 40.0, 20.0])
    angle = math.degrees(sandbox.current_views().angle)
    assert sandbox.rotation_axis.label.text == f"rotation axis\n{angle:.1f}\u00b0"
    assert sandbox.gimbal.caption.text.startswith("ZXZ gimbal\ncond G = 2.7")
    assert [label.text for label in sandbox.gimbal.ring_labels] == ["\u03c6 (Z)", "\u03b8 (X)", "\u03c8 (Z)"]


def test_idle_frames_do_no_work(server: Any) -> None:
    scene = make_sandbox(server, readout_period=0.0)
    try:
        scene.readout.content = "sentinel"
        for _ in range(5):
            scene.frame(DT)  # nothing changed, not animating: nothing is recomputed or sent
        assert scene.readout.content == "sentinel"
        send(scene, "euler2", 41.0)
        assert scene.readout.content != "sentinel"
    finally:
        scene.close()


def test_text_work_is_spread_over_frames_and_rate_limited(server: Any) -> None:
    scene = make_sandbox(server, readout_period=3600.0)
    try:
        text = scene.readout.content
        send_value(scene, "euler1", 50.0)
        scene.frame(DT)
        assert quat_equal(body_wxyz(scene), Rotation.from_euler("ZXZ", [50, 40, 20], degrees=True)
                          .as_quat(scalar_first=True))  # the pose at once
        for _ in range(10):
            scene.frame(0.0)
        assert scene.readout.content == text  # the text waits for the readout period
    finally:
        scene.close()


# -- compose ---------------------------------------------------------------------------
def test_compose_ghosts_do_not_commute(sandbox: Any) -> None:
    choose(sandbox, panel="Compose q1, q2")
    ghosts = sandbox.compose_panel.ghosts
    assert ghosts[0].visible and not sandbox.body.visible and not sandbox.gimbal.visible
    q1 = Rotation.from_rotvec([math.pi / 2, 0, 0])  # defaults: 90 deg about x, then z
    q2 = Rotation.from_rotvec([0, 0, math.pi / 2])
    assert quat_equal(ghosts[0].wxyz, (q1 * q2).as_quat(scalar_first=True))
    assert quat_equal(ghosts[1].wxyz, (q2 * q1).as_quat(scalar_first=True))
    c = sandbox.compose_panel.views
    relative = (q1 * q2).inv() * (q2 * q1)  # A_i.T A_j (Eq. 8.82)
    assert quat_equal(c.relative, relative.as_quat(scalar_first=True))
    assert math.isclose(c.relative_angle, relative.magnitude(), abs_tol=TOL)
    assert math.isclose(c.difference, np.linalg.norm((q1 * q2).as_matrix() - (q2 * q1).as_matrix()), abs_tol=TOL)
    assert "do not commute" in sandbox.compose_panel.readout.content
    send(sandbox, "q1_axis", "0, 0, 2")  # same axis as q2: they commute
    assert sandbox.compose_panel.views.difference < TOL
    assert "these rotations commute" in sandbox.compose_panel.readout.content
    choose(sandbox, panel="Orientation")
    assert not ghosts[0].visible and sandbox.body.visible


def test_compose_q1_from_current_body(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ")
    set_euler(sandbox, [30.0, 40.0, 20.0])
    body = R(body_wxyz(sandbox))
    choose(sandbox, panel="Compose q1, q2")
    click(sandbox, "q1_from_body")
    settle(sandbox)
    # q1 is shown as axis (6 decimals) and angle (3 decimals of a degree):
    # it reproduces the body to ~1e-5.
    assert quat_equal(sandbox.compose_panel.views.q1, body.as_quat(scalar_first=True), atol=1e-4)
    q2 = Rotation.from_rotvec([0, 0, math.pi / 2])
    assert quat_equal(sandbox.compose_panel.ghosts[0].wxyz,
                      (R(sandbox.compose_panel.views.q1) * q2).as_quat(scalar_first=True))


@pytest.mark.parametrize("scale", ["1e200", "1e-12", "1e-200"])
def test_huge_and_tiny_axes_keep_their_direction(sandbox: Any, scale: str) -> None:
    """Any non-zero finite axis is normalized, also where its squares overflow or underflow."""
    direction = np.array([0.0, 3.0, 4.0]) / 5.0
    typed = f"0, 3{scale[1:]}, 4{scale[1:]}"  # e.g. "0, 3e200, 4e200"
    choose(sandbox, input="Axis and angle")
    send(sandbox, "axis", typed)
    send(sandbox, "angle", 90.0)
    expected = Rotation.from_rotvec(direction * math.pi / 2).as_quat(scalar_first=True)
    assert quat_equal(body_wxyz(sandbox), expected)
    assert "Axis and angle" not in sandbox.notices.titles()
    choose(sandbox, panel="Compose q1, q2")
    send(sandbox, "q1_axis", typed)
    q1 = Rotation.from_rotvec(direction * math.pi / 2)  # q1 angle slider default: 90 deg
    assert quat_equal(sandbox.compose_panel.views.q1, q1.as_quat(scalar_first=True))
    assert sandbox.paused_error is None and not sandbox.notices


# -- angular velocity ------------------------------------------------------------------
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
    send(sandbox, "omega", "0.4, -1.1, 0.7")
    send(sandbox, "omega_frame", OMEGA_FRAMES[int(body_frame)])
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
    text = sandbox.omega_panel.readout.content
    # Rates written as d.../dt (a combining dot is lost over phi and psi in Chromium).
    assert "d\u03b1\u2081/dt" in text and "\u0307" not in text
    assert "Euler parameter rates" in text and not re.search(r"\d\.\d{5,}", text)
    assert sandbox.omega_panel.frame.visible
    # The omega arrow points along omega (global frame).
    arrow_dir = R(sandbox.omega_panel.frame.wxyz).apply([0.0, 0.0, 1.0])
    assert np.allclose(arrow_dir, omega / np.linalg.norm(omega), atol=TOL)


def test_angular_velocity_zxz_rates_are_named_dphi_dt(sandbox: Any) -> None:
    choose(sandbox, seq="ZXZ", panel="Angular velocity")
    text = sandbox.omega_panel.readout.content
    assert "d\u03c6/dt = " in text and "d\u03b8/dt = " in text and "d\u03c8/dt = " in text


def test_angular_velocity_singular_cases_are_explained(sandbox: Any) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ", panel="Angular velocity")
    set_euler(sandbox, [30.0, 0.0, 20.0])  # theta = 0: G singular
    assert sandbox.rates.euler_rates is None
    assert "singular" in sandbox.omega_panel.readout.content
    assert sandbox.rates.p_dot is not None and np.all(np.isfinite(sandbox.rates.p_dot))
    choose(sandbox, panel="Orientation", input="Axis and angle")
    send(sandbox, "axis", "1, 0, 0")
    send(sandbox, "angle", 180.0)
    choose(sandbox, panel="Angular velocity")
    assert sandbox.rates.gamma_dot is None and "undefined" in sandbox.omega_panel.readout.content


@pytest.mark.parametrize("body_frame", [False, True])
def test_animation_under_constant_omega(sandbox: Any, body_frame: bool) -> None:
    choose(sandbox, input="Euler angles", seq="ZXZ", panel="Angular velocity")
    start = R(sandbox.p)
    omega = np.array([0.3, -0.2, 1.0])
    send(sandbox, "omega", "0.3, -0.2, 1")
    send(sandbox, "omega_frame", OMEGA_FRAMES[int(body_frame)])
    assert send_value(sandbox, "animate", True)
    sandbox.frame(0.0)
    for _ in range(20):
        sandbox.frame(0.05)  # 1 s in total
    step = Rotation.from_rotvec(omega * 1.0)
    expected = start * step if body_frame else step * start
    assert quat_equal(sandbox.p, expected.as_quat(scalar_first=True), atol=1e-9)
    assert quat_equal(body_wxyz(sandbox), expected.as_quat(scalar_first=True), atol=1e-9)
    send(sandbox, "animate", False)
    frozen = sandbox.p.copy()
    sandbox.frame(0.05)
    assert np.array_equal(sandbox.p, frozen)
    # The sliders were re-synced to the final pose (0.1 deg).
    shown = [sandbox.controls.value(f"euler{k + 1}") for k in range(3)]
    assert np.allclose(Rotation.from_euler("ZXZ", shown, degrees=True).as_matrix(), expected.as_matrix(), atol=2e-3)


# -- export --------------------------------------------------------------------------
def test_export_json_in_every_representation(sandbox: Any, monkeypatch: Any) -> None:
    choose(sandbox, input="Euler angles", seq="XYZ", panel="Export")
    set_euler(sandbox, [15.0, 25.0, 35.0])
    content = sandbox.export_panel.readout.content
    assert content.startswith("```\n") and content.endswith("\n```")
    doc = json.loads(content[4:-4])
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
    monkeypatch.setattr(sandbox.target, "send_file_download",
                        lambda name, data, *a, **k: sent.append((name, data)))
    click(sandbox, "download")
    sandbox.frame(0.0)
    assert sent and sent[0][0] == "orientation.json"
    assert json.loads(sent[0][1]) == export_document(sandbox.current_views())


def test_hidden_then_shown_keeps_state(sandbox: Any) -> None:
    set_euler(sandbox, [5.0, 60.0, 5.0])
    pose = body_wxyz(sandbox)
    sandbox.set_active(False)
    assert sandbox.root_frame.visible is False and sandbox._gui_folder.visible is False
    sandbox.set_active(True)
    settle(sandbox)
    assert np.allclose(body_wxyz(sandbox), pose)
    assert set(INPUTS) and set(PANELS)


# -- shareable state -------------------------------------------------------------------
def _round_trip(server: Any, scene: Any) -> Any:
    """Load ``scene.state()`` (through JSON) into a fresh sandbox; returns it."""
    state = json.loads(json.dumps(scene.state()))
    scene.close()
    other = make_sandbox(server)
    assert other.load_state(state) == []
    settle(other, 0.0)
    return other, state


@pytest.mark.parametrize("input_name, entries", [
    ("Euler angles", [("seq", "yxz (extrinsic, fixed axes)"), ("euler1", 12.3), ("euler2", -45.6),
                      ("euler3", 178.9)]),
    ("Axis and angle", [("axis", "0.1, 1e-3, -2.5"), ("angle", -123.4)]),
    ("Euler parameters", [("ep0", "0.3"), ("ep1", "-0.2"), ("ep2", "1.5e-1"), ("ep3", "0.9")]),
    ("Rodriguez parameters", [("gamma", "0.3, -1.2, 2")]),
    ("Rotation vector", [("rotvec", "0.5, -2.5, 1.0")]),
])
def test_state_round_trip_reproduces_the_pose_exactly(server: Any, input_name: str, entries: Any) -> None:
    scene = make_sandbox(server)
    choose(scene, input=input_name)
    for key, value in entries:
        send(scene, key, value)
    p, angles, seq = scene.p.copy(), scene.angles.copy(), scene.seq
    other, state = _round_trip(server, scene)
    try:
        assert state["scene"] == "sandbox" and state["values"]["input"] == input_name
        assert np.array_equal(other.p, p)  # bit for bit
        assert np.array_equal(other.angles, angles) and other.seq == seq and other.input == input_name
        assert quat_equal(body_wxyz(other), p)
        for key, value in entries:
            assert other.controls.value(key) == scene.controls.value(key)
    finally:
        other.close()


def test_state_round_trip_after_animation_and_while_animating(server: Any) -> None:
    scene = make_sandbox(server)
    choose(scene, panel="Angular velocity")
    send(scene, "omega", "0.7, -0.3, 1.1")
    send(scene, "animate", True)
    for _ in range(37):
        scene.frame(1 / 60)
    # While animating: the pose reached is in the state (the sliders show it rounded).
    p = scene.p.copy()
    other, state = _round_trip(server, scene)
    assert state["values"]["animate"] is True
    assert np.array_equal(other.p, p)
    send(other, "animate", False)  # stops where it is...
    stopped = other.p.copy()
    third, _ = _round_trip(server, other)  # ...and that pose survives a round trip too
    try:
        assert np.array_equal(third.p, stopped)
    finally:
        third.close()


def test_state_refuses_bad_entries_and_names_them(sandbox: Any) -> None:
    state = sandbox.state()
    before = sandbox.p.copy()
    state["values"]["euler1"] = 1e6
    state["pose"] = {"p": [1.0, 1.0, 0.0, 0.0], "angles": [0.0, 0.0, 0.0]}
    state["extra"] = 1
    refused = sandbox.load_state(state)
    settle(sandbox, 0.0)
    assert any(r.startswith("\u03c6 about Z") for r in refused)
    assert any(r.startswith("pose: expected unit Euler parameters") for r in refused)
    assert any(r.startswith("'extra'") for r in refused)
    assert np.allclose(sandbox.p, before)
    with pytest.raises(ValueError, match="expected a state of scene 'sandbox'"):
        sandbox.load_state({"scene": "gyroscope", "values": {}})


# -- presenter view and readability ------------------------------------------------------
def test_presenter_view_enlarges_labels_arrows_and_readouts(sandbox: Any) -> None:
    labels = _label_handles(sandbox)
    normal = {id(h): h.font_screen_scale for h in labels}
    arrow = sandbox.rotation_axis.arrow
    shaft = arrow.shaft_radius
    sandbox.set_presenter(True)
    for h in labels:
        assert math.isclose(h.font_screen_scale, PRESENTER_LABEL_SCALE * normal[id(h)])
    assert math.isclose(arrow.shaft_radius, PRESENTER_ARROW_SCALE * shaft)
    assert "font-size:1.45em" in sandbox.readout.html()
    sandbox.set_presenter(False)
    assert all(math.isclose(h.font_screen_scale, normal[id(h)]) for h in labels)
    assert min(normal.values()) >= 1.2  # readable without presenter view too (> 12 px)


def test_arrow_colours_are_not_axis_colours_and_the_legend_names_them(sandbox: Any) -> None:
    from rigidlab.app.panels.angular_velocity import OMEGA_COLOR
    from rigidlab.app.panels.body import ROTATION_AXIS_COLOR

    axis_colours = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255]])
    for colour in (ROTATION_AXIS_COLOR, OMEGA_COLOR):
        # far from pure red, green and blue (and from each other)
        assert np.min(np.linalg.norm(axis_colours - np.array(colour), axis=1)) > 150
    assert np.linalg.norm(np.subtract(ROTATION_AXIS_COLOR, OMEGA_COLOR)) > 150
    legend = sandbox.legend.content
    assert "gold = rotation axis" in legend and "magenta = \u03c9" in legend
    assert all(eq in SandboxScene.help for eq in (
        "8.7-8.9", "8.29", "8.46", "8.51-8.54", "8.58-8.60", "8.61-8.64", "8.69-8.72", "8.82"))


# Labels by projection with the scene's default camera, as viser draws them:
# a perspective camera with viser's default vertical field of view (75 deg,
# the value a Chromium page reports for client.camera.fov), a 1200 x 750
# page, screen-space labels of 12 * font_screen_scale px per 800 px of page
# height. A label's box is estimated generously (0.56 em per character, 1.25
# em per line plus padding) and placed by its anchor.
VIEWPORT = (1200, 750)
FOV_DEG = 75.0
GUI_PANEL_LEFT = 800  # the control panel covers the page right of this (px)
MIN_GAP_PX = 4.0


def _label_handles(scene: Any) -> list[Any]:
    return [
        *scene.global_axes.label_handles, *scene.body.label_handles, scene.rotation_axis.label,
        *scene.gimbal.ring_labels, scene.gimbal.caption, scene.gimbal.lock_label, scene.omega_panel.label,
        *scene.compose_panel.ghost_labels,
    ]


def _world_poses(scene: Any) -> dict[str, Any]:
    """Node name -> handle of every frame a label may hang from."""
    handles = [scene.root_frame, scene.body.frame, scene.rotation_axis.frame, scene.gimbal.root,
               scene.gimbal.stator, *scene.gimbal.ring_frames, *scene.gimbal.ring_mounts, scene.omega_panel.frame]
    for ghost in scene.compose_panel.ghosts:
        handles.append(ghost.frame)
    return {h.name: h for h in handles}


def _label_boxes(scene: Any) -> list[tuple[str, tuple[float, float, float, float]]]:
    """Screen boxes (x0, y0, x1, y1) in px of the visible labels at the default camera."""
    width, height = VIEWPORT
    eye = np.array(scene.camera_position, dtype=float)
    forward = np.array(scene.camera_look_at, dtype=float) - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_half = math.tan(math.radians(FOV_DEG) / 2)
    frames = _world_poses(scene)
    out = []
    for label in _label_handles(scene):
        parts = label.name.split("/")
        rotation, origin, visible = Rotation.identity(), np.zeros(3), bool(label.visible)
        for k in range(2, len(parts)):
            frame = frames.get("/".join(parts[:k]))
            if frame is None:
                continue
            visible = visible and bool(frame.visible)
            origin = origin + rotation.apply(frame.position)
            rotation = rotation * R(frame.wxyz)
        if not visible:
            continue
        rel = origin + rotation.apply(label.position) - eye
        depth = rel @ forward
        assert depth > 0.5, f"label {label.text!r} is behind or at the camera"
        x = (1 + rel @ right / (depth * tan_half * width / height)) / 2 * width
        y = (1 - rel @ up / (depth * tan_half)) / 2 * height
        em = 12.0 * label.font_screen_scale * height / 800.0
        lines = label.text.split("\n")
        w = 0.56 * em * max(len(line) for line in lines) + 6.0
        h = 1.25 * em * len(lines) + 4.0
        vertical, horizontal = label.anchor.split("-")
        x0 = {"left": x, "center": x - w / 2, "right": x - w}[horizontal]
        y0 = {"top": y, "center": y - h / 2, "bottom": y - h}[vertical]
        out.append((label.text, (x0, y0, x0 + w, y0 + h)))
    return out


def _gap(a: Any, b: Any) -> float:
    """Screen distance between two boxes (negative: they overlap)."""
    return max(max(a[0], b[0]) - min(a[2], b[2]), max(a[1], b[1]) - min(a[3], b[3]))


@pytest.mark.parametrize("presenter", [False, True])
@pytest.mark.parametrize("state", ["default", "gimbal lock", "compose"])
def test_labels_never_overlap_at_the_default_view(sandbox: Any, presenter: bool, state: str) -> None:
    if state == "gimbal lock":
        send(sandbox, "euler2", 0.0)
    elif state == "compose":
        choose(sandbox, panel="Compose q1, q2")
    sandbox.set_presenter(presenter)
    boxes = _label_boxes(sandbox)
    assert len(boxes) >= (11 if state != "compose" else 5)
    texts = [t for t, _ in boxes]
    if state == "gimbal lock":
        assert "GIMBAL LOCK" in texts
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            gap = _gap(boxes[i][1], boxes[j][1])
            assert gap >= MIN_GAP_PX, f"labels {boxes[i][0]!r} and {boxes[j][0]!r} overlap ({gap:.0f} px)"
    for text, (x0, y0, x1, y1) in boxes:
        # on the page and clear of the control panel
        assert 0 <= x0 and x1 <= GUI_PANEL_LEFT and 0 <= y0 and y1 <= VIEWPORT[1], (text, x0, y0, x1, y1)


# -- through the app, with plain websocket clients as browsers ---------------------------
def test_app_slider_from_client_moves_body_and_bad_input_keeps_serving(running_app: Any, ws_client: Any) -> None:
    app = running_app(scene="sandbox", mode="shared")
    client, _ = ws_client(app)
    observer, _ = ws_client(app)
    scene = app.scene_for()
    client.set_gui_value(scene.controls.handles["euler3"], 75.0)
    expected = Rotation.from_euler("ZXZ", [30.0, 40.0, 75.0], degrees=True).as_quat(scalar_first=True)
    assert wait_until(lambda: quat_equal(scene.body.frame.wxyz, expected))
    # Refused values (out of range, NaN, 1e308, text) change nothing; the sender gets a notice.
    session = app.session_for()
    for bad in (1e308, -1e308, 500.0, "abc", None):
        client.set_gui_value(scene.controls.handles["euler1"], bad)
    assert wait_until(lambda: any(t == "Refused: \u03c6 about Z" for t, _, _ in session.notices))
    client.set_gui_value(scene.controls.handles["input"], "Euler parameters")
    assert wait_until(lambda: scene.input == "Euler parameters")
    for k in range(4):  # each edit is applied as it arrives; the last one leaves no rotation
        client.set_gui_value(scene.controls.handles[f"ep{k}"], "0")
    assert wait_until(lambda: "Not a rotation" in scene.input_panel.ep_status.content)
    assert np.all(np.isfinite(scene.body.frame.wxyz)) and np.all(np.isfinite(scene.p))
    ticks = app._ticks
    assert wait_until(lambda: app._ticks > ticks + 3)  # still serving
    client.set_gui_value(scene.controls.handles["ep0"], "1")
    assert wait_until(lambda: quat_equal(scene.body.frame.wxyz, (1.0, 0.0, 0.0, 0.0)))
    frames = observer.frames
    assert wait_until(lambda: observer.frames > frames)  # the observer is still connected
    assert scene.paused_error is None


def test_app_per_client_sandboxes_are_isolated(running_app: Any, ws_client: Any) -> None:
    app = running_app(scene="sandbox", mode="per-client")
    client_a, id_a = ws_client(app)
    client_b, id_b = ws_client(app)
    scene_a, scene_b = app.scene_for(id_a), app.scene_for(id_b)
    before_b = np.array(scene_b.body.frame.wxyz)
    client_a.set_gui_value(scene_a.controls.handles["euler1"], -120.0)
    expected = Rotation.from_euler("ZXZ", [-120.0, 40.0, 20.0], degrees=True).as_quat(scalar_first=True)
    assert wait_until(lambda: quat_equal(scene_a.body.frame.wxyz, expected))
    wait_for_frames(scene_b, 6)
    assert np.allclose(scene_b.body.frame.wxyz, before_b)
    assert scene_b.controls.value("euler1") == 30.0


def test_app_load_state_reproduces_a_pose(running_app: Any, ws_client: Any) -> None:
    app = running_app(scene="sandbox", mode="shared")
    scene = app.scene_for()
    client, _ = ws_client(app)
    client.set_gui_value(scene.controls.handles["input"], "Axis and angle")
    assert wait_until(lambda: scene.input == "Axis and angle")
    client.set_gui_value(scene.controls.handles["axis"], "1, 2, 3")
    client.set_gui_value(scene.controls.handles["angle"], 77.7)
    expected = Rotation.from_rotvec(math.radians(77.7) * np.array([1, 2, 3]) / math.sqrt(14))
    assert wait_until(lambda: quat_equal(scene.p, expected.as_quat(scalar_first=True)))
    state = scene.state()
    p = scene.p.copy()
    client.set_gui_value(scene.controls.handles["input"], "Euler angles")
    client.set_gui_value(scene.controls.handles["euler1"], -10.0)
    assert wait_until(lambda: not quat_equal(scene.p, p))
    app.session_for().request_state(state, source="a test")
    assert wait_until(lambda: np.array_equal(scene.p, p) and scene.input == "Axis and angle")
