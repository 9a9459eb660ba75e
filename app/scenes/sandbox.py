"""Rotation sandbox: one orientation, every representation of the chapter.

A body (hull, red nose along +x_b, blue fin along +z_b, labelled axes) turns
in the fixed global frame. The scene composes the panels of
:mod:`rigidlab.app.panels`:

* :class:`~rigidlab.app.panels.orientation.OrientationInput` drives the orientation
  from one representation at a time (Euler angles of 24 sequences, axis and
  angle, Euler parameters, Rodriguez parameters, rotation vector); a readout
  shows all the others;
* :class:`~rigidlab.app.panels.gimbal.Gimbal` realises the chosen sequence with three
  nested rings and gauges the distance from gimbal lock (cond G, Eq. 8.8);
* :class:`~rigidlab.app.panels.body.RotationAxisView` draws the rotation axis and angle;
* :class:`~rigidlab.app.panels.compose.ComposePanel`,
  :class:`~rigidlab.app.panels.angular_velocity.AngularVelocityPanel` and
  :class:`~rigidlab.app.panels.export.ExportPanel` are the other three panels.

The scene keeps the one orientation (``p``, and the Euler angles the gimbal
shows) and decides, per frame, what changed; the panels turn control values
into core inputs and core results into poses and text. Poses stream at the
loop rate; readouts and 3-D label texts are rewritten at most
``readout_period`` apart (12 Hz) and only when something changed.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, ClassVar

import numpy as np

import rigidlab.core.rotations as rot
from rigidlab.app.controls import Choice
from rigidlab.app.panels import (
    INPUTS,
    AngularVelocityPanel,
    BodyView,
    ComposePanel,
    ExportPanel,
    Gimbal,
    GimbalConditioning,
    GlobalAxes,
    OrientationInput,
    OrientationViews,
    RotationAxisView,
    gimbal_conditioning,
    orientation_views,
    rate_views,
)
from rigidlab.app.panels._views import euler_angles_of, set_readout
from rigidlab.app.panels.orientation import matrix_markdown, parameters_markdown
from rigidlab.app.scenes.base import Scene

__all__ = ["SandboxScene", "PANELS", "INPUTS"]

PANELS = ("Orientation", "Compose q1, q2", "Angular velocity", "Export")
_INITIAL_SEQ = "ZXZ"
_INITIAL_DEG = (30.0, 40.0, 20.0)
_GIMBAL_POSITION = (0.0, 2.7, 0.0)
#: Readouts and label texts are rewritten at most this often (s).
_READOUT_PERIOD = 1.0 / 12.0

_LEGEND = (
    "**Body**: red nose = x<sub>b</sub>, blue fin = z<sub>b</sub>. **Axes**: red x, green y, blue z "
    "(thick: body; thin pale: global X, Y, Z).  \n"
    "**Arrows**: gold = rotation axis (its arc: the angle); magenta = \u03c9.  \n"
    "**Gimbal rings**: orange, purple, teal = Euler angles 1, 2, 3."
)


@dataclasses.dataclass
class _Shown:
    """What one frame must show (from :meth:`SandboxScene._apply`)."""

    values: dict[str, Any]  # the controls' values of this frame
    moved: bool = False  # the orientation changed: poses
    seq: bool = False  # the sequence changed: slider labels, gimbal mounts
    panel: bool = False  # the panel changed: folders and 3-D groups
    input: bool = False  # the input changed: its fields
    sync: bool = False  # the active input's fields must show the orientation
    compose: bool = False  # q1, q2 changed (or their panel was opened)
    omega: bool = False  # the omega arrow may have turned


class SandboxScene(Scene):
    """Rotation sandbox (see the module docstring).

    Parameters
    ----------
    target, notify, context
        As for every scene (see :mod:`rigidlab.app.scenes.base`).
    readout_period : float, keyword-only
        Shortest time (s) between two rewrites of the readouts and label texts.
    """

    name: ClassVar[str] = "sandbox"
    title: ClassVar[str] = "Rotation sandbox"
    order: ClassVar[int] = 10
    help: ClassVar[str] = (
        "One body, one orientation, every representation of the chapter.\n\n"
        "- **Body**: red nose along x<sub>b</sub>, blue fin along z<sub>b</sub>; frame axes red x, "
        "green y, blue z (thin pale lines: the fixed global X, Y, Z).\n"
        "- **Gold arrow**: the rotation axis; its arc and label give the angle: the Rodriguez "
        "formula (Eq. 8.29) and the Euler parameters (Eq. 8.46) of the same rotation.\n"
        "- **Gimbal**: three rings that turn by the three Euler angles of the chosen sequence "
        "(Eqs. 8.7-8.9: \u03c9 = G \u00b7 angle rates). At gimbal lock G is singular and two rings "
        "are coplanar; the gauge fills with cond(G) and turns red.\n"
        "- **Inputs**: Euler angles (24 sequences; upper case intrinsic, lower case extrinsic), axis "
        "and angle (Eqs. 8.29, 8.46), Euler parameters (Eq. 8.46, used as p/|p|), Rodriguez "
        "parameters (Eqs. 8.58-8.60), rotation vector. Numbers take scientific notation (2.5e-3).\n"
        "- **Compose q1, q2**: the ghosts A(q1 q2) and A(q2 q1) (Eqs. 8.69-8.72) differ: finite "
        "rotations do not commute; their relative rotation is Eq. 8.82.\n"
        "- **Angular velocity**: the magenta arrow is \u03c9; the panel gives the rates that produce it: "
        "Euler angle rates (Eq. 8.8 inverted), dp/dt = G\u1d40\u03c9/2 (Eqs. 8.51-8.54), Rodriguez "
        "parameter rates (Eqs. 8.61-8.64); *Animate* turns the body under constant \u03c9.\n"
        "- **Export**: the orientation as JSON, with notes for scipy, viser and MuJoCo."
    )
    #: Default view (global frame, m): the body (origin) on the left, the
    #: gimbal (+Y) beside it, both clear of the GUI panel on the right.
    camera_position: ClassVar[tuple[float, float, float]] = (3.3, -0.05, 1.5)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 2.2, -0.05)

    def __init__(self, target: Any, notify: Any, *, context: Any = None,
                 readout_period: float = _READOUT_PERIOD) -> None:
        super().__init__(target, notify, context=context)
        self.input_panel = OrientationInput(seq=_INITIAL_SEQ, angles_deg=_INITIAL_DEG)
        self.gimbal = Gimbal(position=_GIMBAL_POSITION)
        self.body = BodyView("body")
        self.global_axes = GlobalAxes()
        self.rotation_axis = RotationAxisView()
        self.compose_panel = ComposePanel(positions=((0.0, 0.0, 0.0), _GIMBAL_POSITION))
        self.omega_panel = AngularVelocityPanel()
        self.export_panel = ExportPanel()
        # The orientation and what is shown: read and written by update() only.
        self.seq = _INITIAL_SEQ
        self.input = INPUTS[0]
        self.panel = PANELS[0]
        self.angles = np.radians(_INITIAL_DEG)  # (3,) Euler angles (rad) in seq: the gimbal's
        self.p = rot.euler_parameters_from_euler_angles(self.angles, self.seq)  # (4,) unit, scalar first
        self.animating = False
        self.conditioning: GimbalConditioning | None = None
        self.rates: Any = None  # RateViews of the last angular-velocity readout
        self._readout_period = float(readout_period)
        self._readout_time = -math.inf
        self._text_due = True
        self._text_queue: list[Any] = []  # text work still to do this readout period, one per frame
        self._first = True
        self._pose_version = 0
        self._views: tuple[int, OrientationViews] | None = None
        self._conditioning_version = -1
        self._loaded_pose: tuple[np.ndarray, np.ndarray | None] | None = None
        self._click_keys = (self.input_panel.key_reset, self.compose_panel.key_from_body)

    # -- build ------------------------------------------------------------------------
    def build(self) -> None:
        self.make_root()
        self.global_axes.build(self)
        self.add_ground_grid(width=5.0, height=7.0, position=(0.0, 1.35, -1.3), cell_size=0.25, section_size=1.0)
        self.body.build(self, self.p)
        self.rotation_axis.build(self)
        self.gimbal.build(self)
        gui = self.target.gui
        with self.make_folder():
            self.legend = self.add_readout(_LEGEND)
            self.controls.add(Choice(
                "panel", "Panel", options=PANELS, default=PANELS[0],
                hint="What to explore: orientation inputs, composition, angular velocity, export.",
            ))
            self.input_panel.build(self)
            self.compose_panel.build(self)
            self.omega_panel.build(self)
            self.export_panel.build(self, self.current_views)
            self.gauge_folder = gui.add_folder("Gimbal: closeness to lock")
            with self.gauge_folder:
                self.gimbal.build_gauge(self)
            self.readout_folder = gui.add_folder("Readouts (current orientation)")
            with self.readout_folder:
                # Two readouts, rewritten in two frames: each is a small piece of text work.
                self.readout = self.add_readout("")
                self.readout_more = self.add_readout("")

    @property
    def text_pending(self) -> bool:
        """Whether the next frames will rewrite readouts or label texts (they trail the
        poses by a few frames, and come at most every readout period)."""
        if self._text_queue:
            return True
        return self._text_due and time.monotonic() - self._readout_time >= self._readout_period

    def on_presenter(self, on: bool) -> None:
        self.gimbal.set_presenter(on)

    # -- the orientation, in every representation ---------------------------------------
    def current_views(self) -> OrientationViews:
        """Every representation of the current orientation (computed once per pose)."""
        cached = self._views
        if cached is None or cached[0] != self._pose_version:
            cached = (self._pose_version, orientation_views(self.p, self.seq, euler=self.angles))
            self._views = cached
        return cached[1]

    # -- update -------------------------------------------------------------------------
    def update(self, dt: float) -> None:
        changes = self.controls.take_changes()
        clicks = self.controls.take_clicks(self._click_keys)
        if not (changes or clicks or self.animating or self._first or self._text_due or self._text_queue
                or self._loaded_pose is not None or self.export_panel.busy):
            return  # nothing changed, nothing moves: no work at all
        shown = self._apply(changes, clicks, dt)
        with self.target.atomic():
            self._show(shown)
            self._advance_text(shown.values, bool(changes or clicks or shown.moved))
            self.export_panel.poll()

    def _apply(self, changes: set[str], clicks: list[Any], dt: float) -> _Shown:
        """Read the changes of this frame into the orientation; say what must be shown."""
        values = self.controls.values()
        inputs, compose_panel = self.input_panel, self.compose_panel
        first, self._first = self._first, False
        shown = _Shown(values=values, moved=first, seq=first, panel=first, input=first,
                       compose=first or bool(changes & compose_panel.keys))
        if "panel" in changes and values["panel"] != self.panel:
            self.panel = values["panel"]
            shown.panel = True
        if self.omega_panel.key_animate in changes:
            animating = bool(values[self.omega_panel.key_animate])
            shown.sync = self.animating and not animating  # the fields take over where it stopped
            self.animating = animating
        for key, _, _ in clicks:
            if key == inputs.key_reset:
                self._reset()
                shown.moved = shown.seq = shown.sync = True
            elif key == compose_panel.key_from_body:
                views = self.current_views()
                compose_panel.set_q1(views.axis, views.angle)
                shown.values = values = self.controls.values()  # q1 as now shown
                shown.compose = True
        new_input = str(values[inputs.key_input])
        fields_changed = bool(changes.intersection(inputs.field_keys(new_input)))
        if inputs.key_seq in changes and inputs.seq_of(values) != self.seq:
            self.seq = inputs.seq_of(values)
            shown.seq = True
            if not (fields_changed and new_input == INPUTS[0]):
                # Same orientation, its angles in the new sequence: the gimbal
                # and the sliders follow (unless new slider values came with it).
                self.angles, _ = euler_angles_of(self.p, self.seq)
                shown.moved = True
                shown.sync = shown.sync or self.input == INPUTS[0]
        if inputs.key_input in changes and new_input != self.input:
            self.input = new_input
            shown.input = True
            shown.sync = shown.sync or not fields_changed  # fill the new input from the orientation
        if fields_changed:
            reading = inputs.read(self.input, self.seq, values)
            if reading.p is not None:
                self.p, self.angles = reading.p, reading.angles
                shown.moved = True
            elif reading.error is not None:
                self.notify(self.input, reading.error, "warning")
        if self.animating and dt > 0.0:
            p = self.omega_panel.advance(self.p, values, dt)
            if p is not self.p:
                self.p, self.angles = p, None
                shown.moved = True
        if self._loaded_pose is not None:  # a state's exact pose wins over its rounded fields
            (self.p, self.angles), self._loaded_pose = self._loaded_pose, None
            shown.moved = True
        if shown.moved:
            if self.angles is None:
                self.angles, _ = euler_angles_of(self.p, self.seq)
            self._pose_version += 1
        shown.omega = shown.panel or shown.moved or bool(changes & self.omega_panel.keys)
        shown.compose = shown.compose or shown.panel
        return shown

    def _show(self, shown: _Shown) -> None:
        """Poses and visibility (every frame something moved); fields when they must follow."""
        if shown.panel:
            self._show_panel()
        if shown.seq:
            self.input_panel.show_sequence(self.seq)
        if shown.input:
            self.input_panel.show_input(self.input)
        if shown.moved:
            self.body.show(self.p)
            self.gimbal.show(self.angles, self.seq)
            self.rotation_axis.show(self.p)
        if shown.sync:
            self._sync_fields()
        if shown.compose and self.panel == PANELS[1]:
            self.compose_panel.show(self.compose_panel.read(shown.values))
        if shown.omega and self.panel == PANELS[2]:
            self.omega_panel.show_arrow(self.p, shown.values)

    def _advance_text(self, values: dict[str, Any], changed: bool) -> None:
        """One piece of text work per frame, the pieces of a period at most every readout period."""
        if changed:
            self._text_due = True
        now = time.monotonic()
        if self._text_due and not self._text_queue and now - self._readout_time >= self._readout_period:
            self._readout_time = now
            self._text_due = False
            self._text_queue = self._text_stages()
        if self._text_queue:
            self._text_queue.pop(0)(values)

    def _reset(self) -> None:
        self.seq = _INITIAL_SEQ
        self.angles = np.radians(_INITIAL_DEG)
        self.p = rot.euler_parameters_from_euler_angles(self.angles, self.seq)
        self.animating = False
        self.controls.set(self.omega_panel.key_animate, False)

    def _sync_fields(self) -> None:
        """Show the current orientation in the active input's fields (not a change)."""
        note = self.input_panel.show(self.input, self.current_views())
        if note is not None:
            self.notify(self.input, note, "info")

    def _show_panel(self) -> None:
        orientation, compose, omega, export = (self.panel == p for p in PANELS)
        self.input_panel.folder.visible = orientation
        self.compose_panel.set_visible(compose)
        self.omega_panel.set_visible(omega)
        self.export_panel.set_visible(export)
        self.gauge_folder.visible = not compose
        self.readout_folder.visible = not compose
        # 3-D: the compose panel swaps the body and gimbal for the two ghosts.
        self.body.visible = not compose
        self.gimbal.visible = not compose
        self.rotation_axis.set_enabled(orientation or export)
        self._text_due = True

    def _text_stages(self) -> list[Any]:
        """The text work of one readout period, one piece per frame (each at most 12 Hz).

        Split so that no frame pays for much of it: every representation
        (computed, then written), the gimbal's conditioning (computed, then
        the gauge, then the 3-D labels), the rotation-axis arc and label, and
        the readout of the panel shown.
        """
        if self.panel == PANELS[1]:
            return [self._show_compose_text]
        stages = [self._compute_views, self._show_matrix, self._show_parameters, self._compute_conditioning,
                  self._show_gauge, self._show_gimbal_labels, self._show_axis_arc, self._show_axis_label]
        if self.panel == PANELS[2]:
            stages += [self._compute_rates, self._show_rates]
        elif self.panel == PANELS[3]:
            stages.append(self._request_export)
        return stages

    def _compute_views(self, values: dict[str, Any]) -> None:
        self.current_views()

    def _show_matrix(self, values: dict[str, Any]) -> None:
        set_readout(self.readout, matrix_markdown(self.current_views()))

    def _show_parameters(self, values: dict[str, Any]) -> None:
        set_readout(self.readout_more, parameters_markdown(self.current_views()))

    @property
    def readout_text(self) -> str:
        """Markdown of both readouts of the current orientation."""
        return self.readout.content + "\n\n" + self.readout_more.content

    def _compute_conditioning(self, values: dict[str, Any]) -> None:
        if self._conditioning_version != self._pose_version:
            self.conditioning = gimbal_conditioning(self.angles, self.seq)
            self._conditioning_version = self._pose_version

    def _show_gauge(self, values: dict[str, Any]) -> None:
        self._compute_conditioning(values)
        self.gimbal.show_gauge(self.conditioning, self.seq)

    def _show_gimbal_labels(self, values: dict[str, Any]) -> None:
        self._compute_conditioning(values)
        self.gimbal.show_labels(self.conditioning, self.seq)

    def _show_axis_arc(self, values: dict[str, Any]) -> None:
        self.rotation_axis.show_arc()

    def _show_axis_label(self, values: dict[str, Any]) -> None:
        self.rotation_axis.show_label()

    def _compute_rates(self, values: dict[str, Any]) -> None:
        omega, body_frame = self.omega_panel.omega(values)
        self.rates = rate_views(self.p, self.angles, self.seq, omega, body_frame=body_frame)

    def _show_rates(self, values: dict[str, Any]) -> None:
        if self.rates is not None:
            self.omega_panel.show_text(self.rates, self.seq)

    def _request_export(self, values: dict[str, Any]) -> None:
        self.export_panel.request(self.current_views())

    def _show_compose_text(self, values: dict[str, Any]) -> None:
        if self.compose_panel.views is not None:
            self.compose_panel.show_text(self.compose_panel.views)

    # -- shareable state ------------------------------------------------------------------
    def extra_state(self) -> dict[str, Any]:
        """The exact orientation (the fields show it rounded, an animation leaves it anywhere)."""
        return {"pose": {"p": [float(x) for x in self.p], "angles": [float(a) for a in self.angles]}}

    def load_extra_state(self, extra: dict[str, Any]) -> list[str]:
        refused = []
        for key, value in extra.items():
            if key != "pose":
                refused.append(f"{key!r}: not part of this scene's state")
                continue
            try:
                self._loaded_pose = self._checked_pose(value)
            except ValueError as exc:
                refused.append(f"pose: {exc}")
        return refused

    def _checked_pose(self, pose: Any) -> tuple[np.ndarray, np.ndarray | None]:
        """``(p, angles)`` of a state's pose; angles None unless they match p in the state's sequence."""
        if not isinstance(pose, dict):
            raise ValueError(f"expected an object with p and angles, got {type(pose).__name__}")
        p = _numbers(pose.get("p"), 4, "p")
        if abs(math.hypot(*p) - 1.0) > rot.UNIT_NORM_TOL:
            raise ValueError(f"expected unit Euler parameters p, got |p| = {math.hypot(*p):.6g}")
        angles = pose.get("angles")
        if angles is None:
            return p, None
        angles = _numbers(angles, 3, "angles")
        seq = self.input_panel.seq_of(self.controls.values())
        same = np.abs(rot.matrix_from_euler_angles(angles, seq) - rot.matrix_from_euler_parameters(p))
        return p, (angles if float(np.max(same)) <= 1e-9 else None)


def _numbers(value: Any, size: int, name: str) -> np.ndarray:
    """``value`` as ``size`` finite floats, else ValueError naming ``name``."""
    ok = (isinstance(value, (list, tuple)) and len(value) == size
          and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in value))
    if not ok:
        raise ValueError(f"expected {name} to be {size} finite numbers, got {str(value)[:60]}")
    return np.array(value, dtype=float)
