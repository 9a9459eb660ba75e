"""Angular velocity panel: omega -> the rates of every representation, and a constant-omega animation.

omega is typed (app-parsed text, rad/s) in the global frame (omega) or the
body frame (omega-bar); a magenta arrow shows omega at the body. The readout
gives the rates that produce it (problems 10-11): Euler angle rates of the
chosen sequence (Eq. 8.8 inverted, dφ/dt etc.; none at gimbal lock, and the
readout says why), Euler parameter rates ``dp/dt = G^T omega / 2``
(Eqs. 8.51-8.54, never singular) and Rodriguez parameter rates
(Eqs. 8.61-8.64, undefined at a half turn). *Animate* turns the body under
this constant omega: an exact rotation per frame (Eqs. 8.69-8.72).
"""

from __future__ import annotations

from typing import Any

import numpy as np

import rigidlab.core.rotations as rot
from rigidlab.app.controls import Choice, Toggle, VectorText
from rigidlab.app.nodes import set_array, set_pose
from rigidlab.app.panels._views import RateViews, fmt_g, fmt_vector, rate_names, set_readout, wxyz_z_to

__all__ = ["AngularVelocityPanel", "OMEGA_COLOR", "OMEGA_MAX", "OMEGA_FRAMES", "rates_markdown"]

#: The omega arrow: magenta, never a frame-axis colour.
OMEGA_COLOR = (200, 30, 160)
#: Largest |omega component| (rad/s) accepted: far beyond what a frame-by-frame
#: animation can show, and keeps every rate readout a readable, finite number.
OMEGA_MAX = 1e6
OMEGA_FRAMES = ("global frame", "body frame (\u03c9-bar)")
_ARROW_SCALE = 0.9  # metres per rad/s
_ARROW_MAX = 2.0  # m


class AngularVelocityPanel:
    """Controls, the omega arrow and the rates readout (see the module docstring).

    Parameters
    ----------
    origin : (3,) where the omega arrow starts (the body's origin), global frame (m)
    prefix : prefix of the control keys
    """

    def __init__(self, *, origin: tuple[float, float, float] = (0.0, 0.0, 0.0), prefix: str = "") -> None:
        self.origin = origin
        self.key_omega = f"{prefix}omega"
        self.key_frame = f"{prefix}omega_frame"
        self.key_animate = f"{prefix}animate"
        self.keys = frozenset((self.key_omega, self.key_frame))
        self._shown: tuple[float, ...] | None = None  # omega (global) the arrow shows
        self._length = 1.0  # arrow length (m) as built
        self._step_key: tuple[Any, float] | None = None  # (omega, dt) of the cached rotation step
        self._step = np.array([1.0, 0.0, 0.0, 0.0])

    def build(self, scene: Any) -> Any:
        """The arrow under ``scene.root`` (hidden) and a folder of controls; returns the folder."""
        api = scene.target.scene
        path = f"{scene.root}/omega"
        self.frame = api.add_frame(path, show_axes=False, position=self.origin, visible=False)
        self.arrow = scene.add_arrows(
            f"{path}/arrow", np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]]), OMEGA_COLOR,
            shaft_radius=0.02, head_radius=0.055, head_length=0.12,
        )
        self.label = scene.add_label(
            f"{path}/label", "\u03c9", position=(0.0, 0.0, 1.1), anchor="bottom-center", scale=1.5,
        )
        gui = scene.target.gui
        controls = scene.controls
        self.folder = gui.add_folder("Angular velocity", visible=False)
        with self.folder:
            controls.add(VectorText(
                self.key_omega, "\u03c9 (rad/s)", default=(0.0, 0.0, 1.0), min=-OMEGA_MAX, max=OMEGA_MAX,
                hint=f"Three components, like 0, 0, 1 or 0.3, -2e-1, 1; each within \u00b1{OMEGA_MAX:.0e} rad/s.",
            ))
            controls.add(Choice(self.key_frame, "\u03c9 given in", options=OMEGA_FRAMES, default=OMEGA_FRAMES[0]))
            controls.add(Toggle(
                self.key_animate, "Animate (constant \u03c9)",
                hint="Turn the body under this constant angular velocity (an exact rotation per frame).",
            ))
            self.readout = scene.add_readout("")
        return self.folder

    def set_visible(self, on: bool) -> None:
        self.folder.visible = on
        if not on:
            self.frame.visible = False

    def omega(self, values: dict[str, Any]) -> tuple[np.ndarray, bool]:
        """(omega (3,) rad/s, whether it is in the body frame) from the controls."""
        return np.asarray(values[self.key_omega], dtype=float), values[self.key_frame] == OMEGA_FRAMES[1]

    def advance(self, p: np.ndarray, values: dict[str, Any], dt: float) -> np.ndarray:
        """Euler parameters after turning ``p`` for ``dt`` s under the constant omega (exact)."""
        omega, body_frame = self.omega(values)
        if dt <= 0.0 or not np.any(omega):
            return p
        key = (tuple(omega.tolist()), dt)
        if key != self._step_key:  # the same step every frame at a steady 60 Hz
            self._step_key, self._step = key, rot.euler_parameters_from_rotation_vector(omega * dt)
        step = self._step
        if body_frame:
            p = rot.quaternion_product(p, step)  # A <- A R(omega_body dt)
        else:
            p = rot.quaternion_product(step, p)  # A <- R(omega dt) A
        return rot.normalize_euler_parameters(p)

    def show_arrow(self, p: np.ndarray, values: dict[str, Any]) -> None:
        """Point the arrow along omega (global frame) of the body at ``p``; length grows with |omega|."""
        omega, body_frame = self.omega(values)
        if body_frame:
            omega = rot.rotate_vector(p, omega)
        key = tuple(omega.tolist())
        if key == self._shown and self.frame.visible:
            return  # a constant global omega: nothing to send
        self._shown = key
        norm = float(np.linalg.norm(omega))
        if not (norm > 1e-12 and np.isfinite(norm)):
            self.frame.visible = False
            return
        length = min(_ARROW_SCALE * norm, _ARROW_MAX)
        self.frame.visible = True
        set_pose(self.frame, wxyz=wxyz_z_to(omega / norm))
        if length != self._length:
            self._length = length
            set_array(self.arrow, "points", np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, length]]], dtype=np.float32))
            set_pose(self.label, position=(0.0, 0.0, length + 0.08))

    def show_text(self, rates: RateViews, seq: str) -> None:
        set_readout(self.readout, rates_markdown(rates, seq))


def rates_markdown(r: RateViews, seq: str) -> str:
    """Readout of the rates (Markdown subset of :mod:`rigidlab.app.readout`); rates as dφ/dt."""
    names = rate_names(seq)
    if r.euler_rates is None:
        euler = (
            f"**singular** (|det G| = {fmt_g(r.det_G, 2)}): the first and third axes of {seq} "
            "are aligned, so their rates only enter as a sum or difference; a component of "
            "\u03c9 along the missing direction needs infinite rates. Euler parameters have no such point."
        )
    else:
        euler = ", ".join(f"{n} = {fmt_vector(x, 3)}" for n, x in zip(names, r.euler_rates))
        if r.det_G < 0.1:
            euler += f" (near singular: |det G| = {r.det_G:.3f}; rates grow like 1/|det G|)"
    gamma = (
        f"({fmt_vector(r.gamma_dot, 4)})" if r.gamma_dot is not None
        else "**undefined**: at 180\u00b0 \u03b3 is infinite (Eq. 8.58)"
    )
    return (
        f"\u03c9 (global) = ({fmt_vector(r.omega, 3)}) rad/s  \n"
        f"\u03c9<sub>body</sub> (\u03c9-bar, body frame) = ({fmt_vector(r.omega_body, 3)}) rad/s\n\n"
        f"**Euler angle rates, {seq}** (rad/s; \u03c9 = G \u00b7 rates, Eq. 8.8): {euler}\n\n"
        f"**Euler parameter rates** dp/dt = G\u1d40\u03c9/2 (Eqs. 8.51-8.54): ({fmt_vector(r.p_dot, 4)}); "
        "never singular.\n\n"
        f"**Rodriguez parameter rates** d\u03b3/dt (Eqs. 8.61-8.64): {gamma}"
    )
