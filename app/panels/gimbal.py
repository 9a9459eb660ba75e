"""A cardan gimbal: three nested rings that turn by the three Euler angles, and a lock gauge.

The rings realise a sequence (Eqs. 8.7-8.9): each ring turns by one Euler
angle about its axle, carried by the ring outside it; the inner ring
carries a small copy of the body. At gimbal lock (G singular) the outer and
middle rings become coplanar. The gauge shows how close the angles are to
that: a bar that fills as cond(G) grows (log scale, full at cond(G) =
:data:`COND_LOCK`), green far from lock, orange near it (cond(G) >
:data:`COND_WARN`), full and red at lock with a bold **GIMBAL LOCK** state
in the panel and a 3-D label at the gimbal.

:class:`Gimbal` builds the rings (``build``) and the gauge
(``build_gauge``); per frame, :meth:`Gimbal.show` turns the rings whose angle
changed (one small core call each); at the readout rate
:meth:`Gimbal.show_gauge` and :meth:`Gimbal.show_labels` update the gauge and
the 3-D labels. What depends only on the sequence (ring axes, mounts) is
cached by :func:`rigidlab.app.panels._views.gimbal_layout`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import rigidlab.core.rotations as rot
from rigidlab.app import meshes
from rigidlab.app.nodes import set_pose
from rigidlab.app.panels._views import (
    GimbalConditioning,
    angle_names,
    cond_text,
    gimbal_layout,
    set_readout,
)
from rigidlab.app.panels.body import LABEL_SCALE, add_body_meshes

__all__ = [
    "Gimbal", "RING_COLORS", "RING_COLOR_NAMES", "COND_WARN", "COND_LOCK", "lock_state", "gauge_fill", "gauge_html",
]

#: Colours of the rings by the angle that turns them (first, second, third):
#: none is a frame-axis colour.
RING_COLORS = ((238, 146, 38), (142, 88, 196), (32, 160, 160))
RING_COLOR_NAMES = ("orange", "purple", "teal")
_RING_RADII = (1.0, 0.84, 0.68)
_RING_TUBE = 0.03
_STATOR_RADIUS = 1.16
#: Gauge thresholds on cond(G) = sigma_max / sigma_min.
COND_WARN = 8.0
COND_LOCK = 40.0
#: Bar colours by state (and their names, for tests and the legend).
GAUGE_COLORS = {"far": ("green", "#2f9e44"), "near": ("orange", "#f08c00"), "lock": ("red", "#e03131")}


def lock_state(condition: float) -> str:
    """``"far"``, ``"near"`` (cond(G) > :data:`COND_WARN`) or ``"lock"`` (> :data:`COND_LOCK`)."""
    if not math.isfinite(condition) or condition > COND_LOCK:
        return "lock"
    return "near" if condition > COND_WARN else "far"


def gauge_fill(condition: float) -> float:
    """Bar length in percent: log cond(G) from 0 (cond 1, G orthogonal) to 100 at :data:`COND_LOCK`."""
    if not math.isfinite(condition) or condition >= COND_LOCK:
        return 100.0
    return float(np.clip(100.0 * math.log(max(condition, 1.0)) / math.log(COND_LOCK), 0.0, 100.0))


def gauge_html(fill: float, state: str, *, presenter: bool = False) -> str:
    """HTML of the gauge bar: ``fill`` percent in the colour of ``state``.

    At lock the bar is full, red, twice as tall and says **GIMBAL LOCK**
    in bold white, so it cannot be missed from the back of a room.
    """
    color = GAUGE_COLORS[state][1]
    size = "1.3em" if presenter else "0.875em"
    if state == "lock":
        bar = (f"<div style='width:100%;background:{color};color:white;font-weight:700;"
               "letter-spacing:0.08em;text-align:center;line-height:1.7em;border-radius:0.85em'>"
               "GIMBAL LOCK</div>")
    else:
        bar = (f"<div style='height:0.8em;background:#e9ecef;border-radius:0.4em;overflow:hidden'>"
               f"<div style='width:{fill:.0f}%;height:100%;background:{color}'></div></div>")
    return f"<div class='rigidlab-gauge' style='font-size:{size};padding:0.2em 0.75em 0.4em 0.75em'>{bar}</div>"


class Gimbal:
    """Cardan gimbal of three rings at ``position`` (see the module docstring).

    Parameters
    ----------
    name : node name under the scene root
    position : (3,) centre of the gimbal, global frame (m)
    """

    def __init__(self, name: str = "gimbal", *, position: tuple[float, float, float] = (0.0, 2.7, 0.0)) -> None:
        self.name = name
        self.position = tuple(float(x) for x in position)
        self.seq: str | None = None
        self.state = "far"
        self.ring_frames: list[Any] = []
        self.ring_mounts: list[Any] = []
        self.ring_meshes: list[Any] = []
        self.ring_labels: list[Any] = []
        self.gauge: Any = None  # the bar (viser HTML element)
        self.gauge_text: Any = None  # the status (app.readout.Readout)
        self.gauge_fill = 0.0  # percent
        self.gauge_color = "green"
        self.presenter = False
        self._sent: list[float | None] = [None, None, None]  # ring angles last sent (rad)

    # -- build -------------------------------------------------------------------
    def build(self, scene: Any) -> None:
        """Rings, bearings, inner body and labels under ``scene.root``."""
        api = scene.target.scene
        base = f"{scene.root}/{self.name}"
        self.root = api.add_frame(base, show_axes=False, position=self.position)
        self.stator = api.add_frame(f"{base}/stator", show_axes=False)
        vertices, faces = meshes.pins(_STATOR_RADIUS - 0.02, _STATOR_RADIUS + 0.1, 0.055)
        api.add_mesh_simple(f"{base}/stator/bearings", vertices, faces, color=(120, 120, 128))
        parent = base
        outer = _STATOR_RADIUS
        for k in range(3):
            name = f"{parent}/ring{k}"
            frame = api.add_frame(name, show_axes=False)
            mount = api.add_frame(f"{name}/mount", show_axes=False)
            v, f = meshes.ring(_RING_RADII[k], _RING_TUBE)
            mesh = api.add_mesh_simple(f"{name}/mount/ring", v, f, color=RING_COLORS[k])
            v, f = meshes.pins(_RING_RADII[k], outer, 0.022)
            api.add_mesh_simple(f"{name}/mount/pins", v, f, color=(150, 150, 158))
            # Each ring's label sits on the ring, a quarter turn from its axle,
            # at a different place on each ring so that they never stack up.
            label = scene.add_label(
                f"{name}/mount/label", "ring", position=self._label_position(k),
                anchor="center-center", scale=LABEL_SCALE,
            )
            self.ring_frames.append(frame)
            self.ring_mounts.append(mount)
            self.ring_meshes.append(mesh)
            self.ring_labels.append(label)
            parent = name
            outer = _RING_RADII[k]
        inner = f"{parent}/body"
        api.add_frame(inner, axes_length=0.5, axes_radius=0.012)
        add_body_meshes(api, inner, 0.62)
        self.caption = scene.add_label(
            f"{base}/caption", "gimbal", position=(0.0, 0.0, _STATOR_RADIUS + 0.28),
            anchor="bottom-center", scale=LABEL_SCALE,
        )
        self.lock_label = scene.add_label(
            f"{base}/lock", "GIMBAL LOCK", position=(0.0, 0.0, -_STATOR_RADIUS - 0.2),
            anchor="top-center", scale=1.5 * LABEL_SCALE, visible=False,
        )

    @staticmethod
    def _label_position(k: int) -> tuple[float, float, float]:
        """Where ring ``k``'s label sits in its mount frame (the ring is the mount's x-y circle)."""
        angle = math.radians((90.0, 150.0, 120.0)[k])
        r = _RING_RADII[k]
        return (r * math.cos(angle), r * math.sin(angle), 0.0)

    def build_gauge(self, scene: Any) -> None:
        """The gauge (a bar and a status readout) in the current GUI folder.

        The bar is HTML, not a viser progress bar: a progress bar is an
        input element that browsers may send values to.
        """
        self.presenter = bool(scene.presenter)
        self.gauge = scene.target.gui.add_html(gauge_html(0.0, "far", presenter=self.presenter))
        self.gauge_text = scene.add_readout("")

    def set_presenter(self, on: bool) -> None:
        """Large gauge in presenter view (the status readout grows by itself)."""
        self.presenter = bool(on)
        self._show_gauge()

    def _show_gauge(self) -> None:
        if self.gauge is not None:
            html = gauge_html(self.gauge_fill, self.state, presenter=self.presenter)
            if self.gauge.content != html:
                self.gauge.content = html

    # -- show ----------------------------------------------------------------------
    @property
    def visible(self) -> bool:
        return bool(self.root.visible)

    @visible.setter
    def visible(self, on: bool) -> None:
        self.root.visible = bool(on)

    def set_sequence(self, seq: str) -> None:
        """Mount the rings for ``seq``: axle directions, colours by angle, labels."""
        if seq == self.seq:
            return
        self.seq = seq
        self._sent = [None, None, None]  # the ring axes changed: every ring is sent again
        layout = gimbal_layout(seq)
        names = angle_names(seq)
        for k in range(3):
            j = layout.angle_index[k]
            self.ring_mounts[k].wxyz = layout.mount_wxyz[k]
            self.ring_meshes[k].color = RING_COLORS[j]
            self.ring_labels[k].text = f"{names[j]} ({seq[j]})"
        self.stator.wxyz = layout.stator_wxyz

    def show(self, angles: np.ndarray, seq: str) -> None:
        """Turn the rings by Euler ``angles`` (rad) of ``seq``.

        Only rings whose angle changed are computed and sent (one slider
        turns one ring); the product of the ring rotations, outer to inner,
        is ``matrix_from_euler_angles(angles, seq)`` (see
        :func:`rigidlab.app.panels._views.ring_rotations`).
        """
        self.set_sequence(seq)
        layout = gimbal_layout(seq)
        for k in range(3):
            angle = float(angles[layout.angle_index[k]])
            if angle != self._sent[k]:
                self._sent[k] = angle
                set_pose(self.ring_frames[k], wxyz=rot.euler_parameters_from_axis_angle(layout.axes[k], angle))

    def show_conditioning(self, c: GimbalConditioning, seq: str) -> None:
        """Gauge, status and 3-D labels for conditioning ``c`` of G (Eq. 8.8)."""
        self.show_gauge(c, seq)
        self.show_labels(c, seq)

    def show_gauge(self, c: GimbalConditioning, seq: str) -> None:
        """The bar and the status readout in the panel."""
        state = lock_state(c.condition)
        self.state = state
        self.gauge_fill = gauge_fill(c.condition)
        self.gauge_color = GAUGE_COLORS[state][0]
        self._show_gauge()
        s = c.singular_values
        measure = (f"cond(G) = {cond_text(c.condition)}, \u03c3_min = {s[-1]:.3f}, "
                   f"|det G| = {c.det:.3f}")
        if state == "lock":
            text = (
                "**GIMBAL LOCK** \u2014 the outer and middle rings are (nearly) coplanar: the first and "
                "third axes align and one degree of freedom is lost. Euler-angle rates grow like "
                f"1/|det G|.\n\n{measure} (G of {seq}: \u03c9 = G \u00b7 angle rates, Eq. 8.8)."
            )
        elif state == "near":
            text = (
                "**Near gimbal lock:** the Euler-angle rates for a given \u03c9 grow like 1/|det G|.\n\n"
                f"{measure} (G of {seq}, Eq. 8.8)."
            )
        else:
            text = f"Far from gimbal lock.\n\n{measure} (G of {seq}: \u03c9 = G \u00b7 angle rates, Eq. 8.8)."
        if self.gauge_text is not None:
            set_readout(self.gauge_text, text)

    def show_labels(self, c: GimbalConditioning, seq: str) -> None:
        """The caption above the gimbal and the GIMBAL LOCK label under it."""
        self.caption.text = f"{seq} gimbal\ncond G = {cond_text(c.condition)}"
        self.lock_label.visible = lock_state(c.condition) == "lock"
