"""Arrows from one point with 3-D labels at their tips: :class:`PointArrows`.

A scene that shows vectors from a fixed point (the gyroscope's ω, L and
torque; any angular velocity or momentum) draws them as one batched arrows
node, lengths saturating as ``longest |v| / (|v| + half)`` (:func:`saturated_tips`,
a pure function of arrays, run where the vectors are computed), and names
each by a label that moves in the same message batch as its arrow.

Label placement: each label sits ``beyond`` (m) past its tip along its
arrow. Two arrows that often point the same way (ω and L of a fast top) make
a *pair*: seen along them their tips fall on one spot of the screen, so
their labels keep the vertical order of their tips -- the label of the
higher tip sits ``aside`` (m) above it, perpendicular to its arrow (along
``Z - (Z . u) u``, which shortens as the arrow turns vertical: below sin =
:data:`SINE_FLOOR` the offset shrinks with it instead of swinging round the
arrow), with a screen anchor that puts its text above the point; the other's
below. A camera with +Z up sees these offsets as up and down from any side.
The order swaps only when the other tip is higher by ``swap`` (m), so two
level tips do not flicker. The other labels are centred beyond their tips.
Projected over every gyroscope preset with 73 cameras, two labels overlapped
in 22 % of the views with the labels at their tips and fixed anchors, in 2 %
with this placement (42 % and 0.1 % with the camera on the arrows' line).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from rigidlab.app.nodes import set_array, set_pose

__all__ = ["PointArrows", "saturated_tips", "vertex_rgb", "SINE_FLOOR"]

#: The pair's up/down offset shrinks for arrows nearer than asin(this) to the vertical.
SINE_FLOOR = 0.5
UPPER_ANCHOR = "bottom-right"  # the point is the label's bottom-right corner: text above and left of it
LOWER_ANCHOR = "top-left"  # text below and right of the point
CENTRE_ANCHOR = "center-center"


def vertex_rgb(colors: Any) -> np.ndarray:
    """The colours (..., 3) 0..255 to give viser's arrows and line segments so that they are drawn in ``colors``.

    The page treats the colours of these nodes as linear light and encodes them as sRGB on output, while a
    mesh's colour, a legend's swatch and CSS colours are sRGB already: an orange (245, 140, 0) arrow was
    drawn gold (about (213, 184, 66) lit). Decoding sRGB to linear here (IEC 61966-2-1) gives back the
    colour asked for, so one colour constant serves the node and its legend."""
    c = np.asarray(colors, dtype=float) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return np.round(255.0 * linear).astype(np.uint8)


def saturated_tips(vectors: Any, longest: Sequence[float], half: Sequence[float]) -> np.ndarray:
    """Arrow tips ``v longest / (|v| + half)`` (m) of ``vectors`` (..., k, 3), one ``longest`` (m) and
    ``half`` (the vector's units) per arrow (k,): lengths saturate at ``longest``. Returns (..., k, 3)."""
    v = np.asarray(vectors, dtype=float)
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v * (np.asarray(longest, dtype=float)[:, None] / (norm + np.asarray(half, dtype=float)[:, None]))


class PointArrows:
    """Arrows from the origin of frame ``name`` with a label at each tip (module docstring).

    Parameters
    ----------
    scene : app.scenes.base.Scene
        Owner of the nodes (arrows and labels grow in presenter view).
    name : str
        Path of the frame holding the arrows (``{name}/arrows``) and labels (``{name}/label_i``).
    texts, colors : one label text and RGB colour (0..255, sRGB: as drawn, see :func:`vertex_rgb`) per arrow.
    beyond : (k,) m past each tip along its arrow, where its label sits.
    pair : indices of the two arrows whose labels keep their tips' vertical order (None: no pair).
    aside, swap : m, the pair's up/down offset and the hysteresis of their order.
    label_scale : the labels' size (``Scene.add_label``); ``**arrow`` : radii and head length (m).
    """

    def __init__(self, scene: Any, name: str, texts: Sequence[str], colors: Sequence[Sequence[int]], *,
                 beyond: Sequence[float], pair: tuple[int, int] | None = (0, 1), aside: float = 0.1,
                 swap: float = 0.05, label_scale: float = 1.0, **arrow: float) -> None:
        k = len(texts)
        self.frame = scene.target.scene.add_frame(name, show_axes=False)
        self.arrows = scene.add_arrows(f"{name}/arrows", np.zeros((k, 2, 3), dtype=np.float32),
                                       vertex_rgb(colors), **arrow)
        self.beyond, self.pair, self.aside, self.swap = tuple(beyond), pair, float(aside), float(swap)
        self.upper = pair[1] if pair is not None else -1  # the pair's arrow whose label is above
        self.labels = [scene.add_label(f"{name}/label_{i}", text, anchor=self.anchor(i), scale=label_scale)
                       for i, text in enumerate(texts)]
        for label in self.labels:  # every arrow is zero until the first draw: its label would sit at the origin
            label.visible = False
        self._shown = [False] * k

    @property
    def visible(self) -> bool:
        return bool(self.frame.visible)

    @visible.setter
    def visible(self, on: bool) -> None:
        if bool(self.frame.visible) != bool(on):
            self.frame.visible = bool(on)

    def anchor(self, i: int) -> str:
        """Screen anchor of label ``i``: text above its point (the pair's upper), below (the other), centred."""
        if self.pair is None or i not in self.pair:
            return CENTRE_ANCHOR
        return UPPER_ANCHOR if i == self.upper else LOWER_ANCHOR

    def draw(self, tips: np.ndarray) -> None:
        """Arrows to ``tips`` (k, 3) and their labels, in the caller's ``atomic()`` batch (loop thread)."""
        set_array(self.arrows, "points", np.stack([np.zeros_like(tips), tips], axis=1))
        if self.pair is not None:
            a, b = self.pair
            z_upper, z_other = (tips[a, 2], tips[b, 2]) if self.upper == a else (tips[b, 2], tips[a, 2])
            if z_other > z_upper + self.swap:
                self.upper = b if self.upper == a else a
                for i in self.pair:
                    self.labels[i].anchor = self.anchor(i)
        for i, (label, position) in enumerate(zip(self.labels, self.label_positions(tips), strict=True)):
            if position is not None:
                set_pose(label, position=position)
            if (position is not None) != self._shown[i]:
                self._shown[i] = position is not None
                label.visible = self._shown[i]

    def label_positions(self, tips: np.ndarray) -> list[tuple[float, float, float] | None]:
        """Where the labels of ``tips`` (k, 3) sit (None: a zero arrow, its label hidden). Plain floats."""
        out: list[tuple[float, float, float] | None] = []
        for i, (x, y, z) in enumerate(np.asarray(tips, dtype=float).tolist()):
            length = math.sqrt(x * x + y * y + z * z)
            if length == 0.0:
                out.append(None)
                continue
            ux, uy, uz = x / length, y / length, z / length
            px, py, pz = x + self.beyond[i] * ux, y + self.beyond[i] * uy, z + self.beyond[i] * uz
            if self.pair is not None and i in self.pair:
                vx, vy, vz = -uz * ux, -uz * uy, 1.0 - uz * uz  # Z minus its part along u: |v| = sine
                sine = math.sqrt(vx * vx + vy * vy + vz * vz)
                k = (self.aside if i == self.upper else -self.aside) / max(sine, SINE_FLOOR)
                px, py, pz = px + k * vx, py + k * vy, pz + k * vz
            out.append((px, py, pz))
        return out
