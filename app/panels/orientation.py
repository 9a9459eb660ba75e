"""Orientation input panel: one representation at a time drives an orientation.

Five inputs, chosen with *Input with*:

* **Euler angles** of any of the 24 sequences (three sliders, degrees);
* **axis and angle** (Rodriguez formula, Eq. 8.29, through Eq. 8.46);
* **Euler parameters** theta0..theta3 (normalized when |p| is not 1; the
  status under the fields says so at once);
* **Rodriguez parameters** gamma = axis tan(angle / 2) (Eqs. 8.58-8.60);
* a **rotation vector** (axis times angle, rad).

Numbers are typed into app-parsed text fields (:class:`rigidlab.app.controls.NumberText`,
:class:`rigidlab.app.controls.VectorText`): scientific notation and full precision,
never rewritten. :class:`OrientationInput` builds the controls, reads the
active input into Euler parameters (:meth:`OrientationInput.read`) and shows
an orientation in the active input's fields (:meth:`OrientationInput.show`).
It keeps no orientation of its own: the scene does.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

import rigidlab.core.rotations as rot
from rigidlab.app.controls import Button, Choice, NumberText, Slider, VectorText
from rigidlab.app.panels._views import (
    SEQUENCE_LABELS,
    SEQUENCES,
    OrientationViews,
    angle_labels,
    angle_names,
    fmt_g,
    fmt_vector,
    sequence_of_label,
    set_readout,
    unit_direction,
)

__all__ = [
    "OrientationInput", "InputReading", "INPUTS", "representations_markdown", "matrix_markdown", "parameters_markdown",
]

INPUTS = (
    "Euler angles",
    "Axis and angle",
    "Euler parameters",
    "Rodriguez parameters",
    "Rotation vector",
)
#: |p| within this of 1 reads as "unit" (the synced fields carry 6 decimals).
_SHOWN_UNIT_TOL = 5e-6
_RING_COLOR_NAMES = ("orange", "purple", "teal")


@dataclasses.dataclass(frozen=True)
class InputReading:
    """What the active input gives (from :meth:`OrientationInput.read`).

    Attributes
    ----------
    p : (4,) unit Euler parameters, scalar first, or None when refused
    angles : (3,) Euler angles (rad) in the sequence when the input is Euler angles, else None
    error : why the input gives no orientation (for a notice), or None
    """

    p: np.ndarray | None
    angles: np.ndarray | None = None
    error: str | None = None


class OrientationInput:
    """The orientation input panel (see the module docstring).

    Parameters
    ----------
    seq : initial Euler sequence (one of the 24)
    angles_deg : initial Euler angles (deg) in ``seq``
    prefix : prefix of the control keys (two panels in one scene need different ones)
    """

    def __init__(self, *, seq: str = "ZXZ", angles_deg: tuple[float, float, float] = (30.0, 40.0, 20.0),
                 prefix: str = "") -> None:
        if seq not in SEQUENCES:
            raise ValueError(f"seq: expected one of the 24 sequences, got {seq!r}")
        self.initial_seq = seq
        self.initial_angles_deg = tuple(float(a) for a in angles_deg)
        k = prefix
        self.key_input = f"{k}input"
        self.key_seq = f"{k}seq"
        self.key_euler = tuple(f"{k}euler{i + 1}" for i in range(3))
        self.key_axis = f"{k}axis"
        self.key_angle = f"{k}angle"
        self.key_ep = tuple(f"{k}ep{i}" for i in range(4))
        self.key_gamma = f"{k}gamma"
        self.key_rotvec = f"{k}rotvec"
        self.key_reset = f"{k}reset"
        self._fields = {
            "Euler angles": self.key_euler,
            "Axis and angle": (self.key_axis, self.key_angle),
            "Euler parameters": self.key_ep,
            "Rodriguez parameters": (self.key_gamma,),
            "Rotation vector": (self.key_rotvec,),
        }
        self.controls: Any = None
        self.folder: Any = None
        self.folders: dict[str, Any] = {}
        self.ep_status: Any = None

    # -- build ---------------------------------------------------------------------
    def build(self, scene: Any) -> Any:
        """Create the controls in a folder of the current GUI folder; return the folder."""
        gui = scene.target.gui
        controls = self.controls = scene.controls
        seq = self.initial_seq
        self.folder = gui.add_folder("Input (one at a time)")
        with self.folder:
            controls.add(Choice(
                self.key_input, "Input with", options=INPUTS, default=INPUTS[0],
                hint="Which representation drives the body; the others are read out below.",
            ))
            controls.add(Choice(
                self.key_seq, "Euler sequence", options=tuple(SEQUENCE_LABELS[s] for s in SEQUENCES),
                default=SEQUENCE_LABELS[seq],
                hint="Upper case: intrinsic (about the turning axes, primes); lower case: extrinsic "
                     "(about the fixed global axes). Also sets the gimbal and the readouts.",
            ))
            self.folders["Euler angles"] = gui.add_folder("Euler angles (deg)")
            with self.folders["Euler angles"]:
                labels = angle_labels(seq)
                for i in range(3):
                    controls.add(Slider(
                        self.key_euler[i], labels[i], min=-180.0, max=180.0, step=0.1,
                        default=self.initial_angles_deg[i],
                        hint=f"Angle {i + 1} of the sequence: turns the {_RING_COLOR_NAMES[i]} gimbal ring.",
                    ))
            self.folders["Axis and angle"] = gui.add_folder("Axis and angle", visible=False)
            with self.folders["Axis and angle"]:
                controls.add(VectorText(
                    self.key_axis, "Axis", default=(0.0, 0.0, 1.0), nonzero=True,
                    hint="Any non-zero vector, like 1, 2, 2 or 0, 0, 1e-3; it is normalized (Eq. 8.29).",
                ))
                controls.add(Slider(
                    self.key_angle, "Angle (deg)", min=-360.0, max=360.0, step=0.1, default=0.0,
                    hint="Right-hand rule about the axis.",
                ))
            self.folders["Euler parameters"] = gui.add_folder("Euler parameters", visible=False)
            with self.folders["Euler parameters"]:
                for i in range(4):
                    controls.add(NumberText(
                        self.key_ep[i], f"\u03b8{i}", default=1.0 if i == 0 else 0.0,
                        hint="Scalar first: \u03b80 = cos(angle/2), (\u03b81, \u03b82, \u03b83) = axis sin(angle/2) "
                             "(Eq. 8.46). Any four numbers, not all zero: the body uses p/|p|.",
                    ))
                self.ep_status = scene.add_readout("|p| = 1: unit Euler parameters.")
            self.folders["Rodriguez parameters"] = gui.add_folder("Rodriguez parameters", visible=False)
            with self.folders["Rodriguez parameters"]:
                controls.add(VectorText(
                    self.key_gamma, "\u03b3", default=(0.0, 0.0, 0.0),
                    hint="\u03b3 = axis tan(angle/2); any three numbers; a half turn is at infinity "
                         "(Eqs. 8.58-8.60).",
                ))
            self.folders["Rotation vector"] = gui.add_folder("Rotation vector (rad)", visible=False)
            with self.folders["Rotation vector"]:
                controls.add(VectorText(
                    self.key_rotvec, "axis \u00d7 angle", default=(0.0, 0.0, 0.0),
                    hint="Direction: rotation axis; length: angle in radians.",
                ))
            controls.add(Button(
                self.key_reset, "Reset orientation",
                hint=f"Back to the {seq} angles {', '.join(f'{a:g}' for a in self.initial_angles_deg)} deg.",
            ))
        return self.folder

    # -- keys ---------------------------------------------------------------------
    def field_keys(self, input_name: str) -> tuple[str, ...]:
        """Control keys of the fields of one input."""
        return self._fields[input_name]

    def input_of(self, values: dict[str, Any]) -> str:
        return str(values[self.key_input])

    def seq_of(self, values: dict[str, Any]) -> str:
        return sequence_of_label(str(values[self.key_seq]))

    # -- read ---------------------------------------------------------------------
    def read(self, input_name: str, seq: str, values: dict[str, Any]) -> InputReading:
        """Euler parameters given by the fields of ``input_name`` (``values``: the panel's values).

        The Euler-parameter status under the fields is updated at once.
        """
        if input_name == "Euler angles":  # sliders: always in range, the common case per frame
            angles = np.array([math.radians(values[k]) for k in self.key_euler])
            return InputReading(rot.euler_parameters_from_euler_angles(angles, seq), angles=angles)
        try:
            with np.errstate(all="ignore"):
                reading = self._read(input_name, seq, values)
        except ValueError as exc:
            return InputReading(None, error=f"{exc}. The orientation is unchanged.")
        p = reading.p
        if p is not None and not (all(math.isfinite(x) for x in p)
                                  and abs(math.hypot(*p) - 1.0) <= rot.UNIT_NORM_TOL):
            return InputReading(
                None, error="These values are too large to represent a rotation in floating point; "
                            "the orientation is unchanged.",
            )
        return reading

    def _read(self, input_name: str, seq: str, values: dict[str, Any]) -> InputReading:
        if input_name == "Axis and angle":
            unit = unit_direction(values[self.key_axis])
            if unit is None:  # the control refuses zero and non-finite axes already
                raise ValueError("the axis must be a non-zero finite vector")
            angle = math.radians(float(values[self.key_angle]))
            return InputReading(rot.euler_parameters_from_axis_angle(unit, angle))
        if input_name == "Euler parameters":
            raw = np.array([float(values[k]) for k in self.key_ep])
            norm = math.hypot(*raw)
            if norm == 0.0:
                self._ep_status(
                    "**Not a rotation:** all four are zero. Enter four numbers, not all zero; "
                    "the body keeps its orientation."
                )
                return InputReading(None)
            try:
                p = rot.normalize_euler_parameters(raw)
            except ValueError:
                self._ep_status(f"**Not a rotation:** |p| = {fmt_g(norm)} cannot be normalized; "
                                "the body keeps its orientation.")
                return InputReading(None)
            if abs(norm - 1.0) > _SHOWN_UNIT_TOL:
                self._ep_status(
                    f"**Normalized:** |p| = {fmt_g(norm, 4)}, not 1, so the body uses "
                    f"p/|p| = ({fmt_vector(p, 4)}). Euler parameters of a rotation satisfy "
                    "\u03b80\u00b2 + \u03b81\u00b2 + \u03b82\u00b2 + \u03b83\u00b2 = 1."
                )
            else:
                self._ep_status("|p| = 1: unit Euler parameters.")
            return InputReading(p)
        if input_name == "Rodriguez parameters":
            gamma = np.asarray(values[self.key_gamma], dtype=float)
            return InputReading(rot.euler_parameters_from_rodriguez_parameters(gamma))
        if input_name == "Rotation vector":
            r = np.asarray(values[self.key_rotvec], dtype=float)
            return InputReading(rot.euler_parameters_from_rotation_vector(r))
        raise ValueError(f"input_name: expected one of {list(INPUTS)}, got {input_name!r}")

    def _ep_status(self, text: str) -> None:
        set_readout(self.ep_status, text)

    # -- show ---------------------------------------------------------------------
    def show(self, input_name: str, views: OrientationViews) -> str | None:
        """Show the orientation ``views`` in the fields of ``input_name`` (not a change).

        Values are rounded to the digits a person reads (0.1 deg for the
        sliders, 6 decimals otherwise); the scene keeps the exact orientation.
        Returns a note when the fields cannot show it (Rodriguez parameters
        of a half turn), else None.
        """
        # (a value a browser typed into a field since this frame took the changes is newer: it stays)
        controls = self.controls
        if input_name == "Euler angles":
            deg = np.clip(np.round(np.degrees(views.euler), 1), -180.0, 180.0)
            controls.set_many({k: float(d) for k, d in zip(self.key_euler, deg)}, keep_browser=True)
        elif input_name == "Axis and angle":
            controls.set(self.key_axis, tuple(float(x) for x in np.round(views.axis, 6)), keep_browser=True)
            controls.set(self.key_angle, round(math.degrees(views.angle), 2), keep_browser=True)
        elif input_name == "Euler parameters":
            controls.set_many({k: float(x) for k, x in zip(self.key_ep, np.round(views.p, 6))}, keep_browser=True)
            self._ep_status("|p| = 1: the Euler parameters of the current orientation.")
        elif input_name == "Rodriguez parameters":
            if views.gamma is None:
                return ("The angle is 180\u00b0: \u03b3 = axis tan(90\u00b0) is infinite, "
                        "so the fields keep their values.")
            controls.set(self.key_gamma, tuple(float(f"{x:.6g}") for x in views.gamma), keep_browser=True)
        elif input_name == "Rotation vector":
            controls.set(self.key_rotvec, tuple(float(x) for x in np.round(views.rotation_vector, 6)),
                         keep_browser=True)
        return None

    def show_sequence(self, seq: str) -> None:
        """Slider labels for ``seq`` and the dropdown showing it."""
        labels = angle_labels(seq)
        for key, label in zip(self.key_euler, labels):
            self.controls.handles[key].label = label
        self.controls.set(self.key_seq, SEQUENCE_LABELS[seq])

    def show_input(self, input_name: str) -> None:
        """Show only the fields of ``input_name``."""
        for name, folder in self.folders.items():
            folder.visible = name == input_name


def representations_markdown(v: OrientationViews) -> str:
    """Readout of every representation of ``v`` (Markdown subset of :mod:`rigidlab.app.readout`)."""
    return matrix_markdown(v) + "\n\n" + parameters_markdown(v)


def matrix_markdown(v: OrientationViews) -> str:
    """The first half of :func:`representations_markdown`: the matrix and the Euler angles."""
    names = angle_names(v.seq)
    matrix = "\n".join("[" + ", ".join(f"{x:6.3f}" for x in row) + " ]" for row in v.A.tolist())
    lock = ("  \n**gimbal lock:** only the sum or difference of angles 1 and 3 is determined"
            if v.gimbal_lock else "")
    euler = ", ".join(f"{n} = {math.degrees(a):.1f}\u00b0" for n, a in zip(names, v.euler.tolist()))
    return (
        "**A** (body \u2192 global; columns = body axes in global)\n"
        f"```\n{matrix}\n```\n"
        f"**Euler angles {v.seq}:** {euler}{lock}"
    )


def parameters_markdown(v: OrientationViews) -> str:
    """The second half of :func:`representations_markdown`: parameters, axis and angle, vector."""
    gamma = (
        f"({fmt_vector(v.gamma, 3)})" if v.gamma is not None
        else "infinite (angle = 180\u00b0, Eq. 8.58)"
    )
    return (
        f"**Euler parameters** \u03b80..\u03b83: ({fmt_vector(v.p, 4)})  \n"
        "(shown with \u03b80 \u2265 0; \u2212p is the same rotation)\n\n"
        f"**Axis, angle:** ({fmt_vector(v.axis, 3)}), {math.degrees(v.angle):.1f}\u00b0\n\n"
        f"**Rodriguez parameters** \u03b3: {gamma}\n\n"
        f"**Rotation vector** (rad): ({fmt_vector(v.rotation_vector, 3)})"
    )
