"""Compose panel: two rotations q1, q2 and their products in both orders (problem 4, Eq. 8.82).

Two ghost bodies show ``A(q1 q2)`` (orange) and ``A(q2 q1)`` (purple): finite
rotations do not commute. The readout gives both products (Eqs. 8.69-8.72),
``|A(q1 q2) - A(q2 q1)|`` and the relative rotation of the purple body seen
from the orange one, ``(q1 q2)* (q2 q1)`` (Eq. 8.82). q1 and q2 are typed as
an axis (app-parsed text, any non-zero vector) and an angle (slider).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import rigidlab.core.rotations as rot
from rigidlab.app.controls import Button, Slider, VectorText
from rigidlab.app.panels._views import ComposeViews, compose_views, fmt_vector, set_readout, unit_direction
from rigidlab.app.panels.body import LABEL_SCALE, BodyView

__all__ = ["ComposePanel", "GHOST_COLORS", "compose_markdown"]

#: Ghost of q1 q2 (orange) and of q2 q1 (purple).
GHOST_COLORS = ((238, 146, 38), (142, 88, 196))
_DEFAULTS = (((1.0, 0.0, 0.0), 90.0), ((0.0, 0.0, 1.0), 90.0))


class ComposePanel:
    """Controls, two ghost bodies and a readout (see the module docstring).

    Parameters
    ----------
    positions : where the two ghosts stand (global frame, m)
    prefix : prefix of the control keys
    """

    def __init__(self, *, positions: tuple[tuple[float, float, float], tuple[float, float, float]] = (
        (0.0, 0.0, 0.0), (0.0, 2.7, 0.0)), prefix: str = "") -> None:
        self.positions = positions
        self.key_axis = (f"{prefix}q1_axis", f"{prefix}q2_axis")
        self.key_angle = (f"{prefix}q1_angle", f"{prefix}q2_angle")
        self.key_from_body = f"{prefix}q1_from_body"
        self.keys = frozenset(self.key_axis + self.key_angle)
        self.ghosts: list[BodyView] = []
        self.ghost_labels: list[Any] = []
        self.views: ComposeViews | None = None

    def build(self, scene: Any) -> Any:
        """Ghosts under ``scene.root`` (hidden) and a folder of controls; returns the folder."""
        for k, (color, text) in enumerate(zip(GHOST_COLORS, ("A(q1 q2)", "A(q2 q1)"))):
            ghost = BodyView(f"ghost{k}", axes_length=0.9, axes_radius=0.018, labels=False,
                             color=color, opacity=0.6, position=self.positions[k])
            ghost.build(scene, np.array([1.0, 0.0, 0.0, 0.0]))
            ghost.visible = False
            # Upright above the ghost, whatever its orientation: not a child of it.
            self.ghost_labels.append(scene.add_label(
                f"{scene.root}/ghost{k}_label", text, position=np.add(self.positions[k], (0.0, 0.0, 1.2)),
                anchor="bottom-center", scale=LABEL_SCALE, visible=False,
            ))
            self.ghosts.append(ghost)
        gui = scene.target.gui
        self.controls = scene.controls
        self.folder = gui.add_folder("Compose q1, q2", visible=False)
        with self.folder:
            for k, (axis, angle) in enumerate(_DEFAULTS):
                self.controls.add(VectorText(
                    self.key_axis[k], f"q{k + 1} axis", default=axis, nonzero=True,
                    hint="Any non-zero vector (normalized), like 1, 0, 0 or 0, 3, 4.",
                ))
                self.controls.add(Slider(
                    self.key_angle[k], f"q{k + 1} angle (deg)", min=-180.0, max=180.0, step=1.0,
                    default=angle,
                ))
            self.controls.add(Button(
                self.key_from_body, "q1 \u2190 current body orientation",
                hint="Copy the orientation set in the Orientation panel into q1 (axis and angle).",
            ))
            self.readout = scene.add_readout("")
        return self.folder

    def set_visible(self, on: bool) -> None:
        self.folder.visible = on
        for ghost, label in zip(self.ghosts, self.ghost_labels):
            ghost.visible = on
            label.visible = on

    def read(self, values: dict[str, Any]) -> ComposeViews:
        """q1, q2 from the controls and their products (the axes are non-zero: the controls say so)."""
        qs = []
        for k in range(2):
            unit = unit_direction(values[self.key_axis[k]])
            if unit is None:
                raise ValueError(f"q{k + 1} axis: expected a non-zero finite vector, "
                                 f"got {values[self.key_axis[k]]!r}")
            qs.append(rot.euler_parameters_from_axis_angle(unit, math.radians(float(values[self.key_angle[k]]))))
        self.views = compose_views(qs[0], qs[1])
        return self.views

    def set_q1(self, axis: np.ndarray, angle: float) -> None:
        """Show q1 = rotation ``angle`` (rad, in [0, pi]) about unit ``axis`` in its controls."""
        self.controls.set(self.key_axis[0], tuple(float(x) for x in np.round(axis, 6)))
        self.controls.set(self.key_angle[0], round(math.degrees(angle), 3))

    def show(self, views: ComposeViews) -> None:
        """Orient the two ghosts."""
        self.ghosts[0].show(views.p12)
        self.ghosts[1].show(views.p21)

    def show_text(self, views: ComposeViews) -> None:
        set_readout(self.readout, compose_markdown(views))


def compose_markdown(c: ComposeViews) -> str:
    """Readout of a composition (Markdown subset of :mod:`rigidlab.app.readout`)."""
    same = c.difference < 1e-9
    verdict = (
        "The two products are equal: these rotations commute (same axis, or an angle is 0)."
        if same else
        f"**A(q1 q2) \u2260 A(q2 q1)**: \u2016A(q1 q2) \u2212 A(q2 q1)\u2016 = {c.difference:.3f}. "
        "Finite rotations do not commute (problem 4)."
    )
    return (
        f"q1 = ({fmt_vector(c.q1, 4)})  \nq2 = ({fmt_vector(c.q2, 4)})\n\n"
        f"**q1 q2** = ({fmt_vector(c.p12, 4)}): orange ghost  \n"
        f"**q2 q1** = ({fmt_vector(c.p21, 4)}): purple ghost (Eqs. 8.69-8.72)\n\n{verdict}\n\n"
        f"**Relative rotation** of the purple body seen from the orange one, "
        f"p = (q1 q2)* (q2 q1) (Eq. 8.82): ({fmt_vector(c.relative, 4)}), "
        f"{math.degrees(c.relative_angle):.1f}\u00b0 about ({fmt_vector(c.relative_axis, 3)}) "
        "in the orange body's frame."
    )
