"""Screen geometry of a scene's default view, for tests of framing and labels.

viser's perspective camera has a 75 deg vertical field of view and +Z up; a
screen-space label (``font_size_mode="screen"``) is about 12 px per unit of
``font_screen_scale`` tall, anchored at its position by one of nine anchors
("top-left": the point is the label's top-left corner). The label boxes here
are generous (0.62 em per character, 1.35 em per line), so two boxes that do
not overlap are two labels that cannot touch on the page.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

VIEWPORT = (1200, 750)  # px, the page size of the browser tests and screenshots
FOV_Y_DEG = 75.0  # viser's default vertical field of view
EM_PX = 12.0  # px per unit of font_screen_scale


class Camera:
    """A perspective camera at ``eye`` looking at ``look_at`` (+Z up), on a 1200 x 750 page."""

    def __init__(self, eye: Sequence[float], look_at: Sequence[float], viewport: tuple[int, int] = VIEWPORT):
        self.eye = np.asarray(eye, dtype=float)
        target = np.asarray(look_at, dtype=float)
        self.forward = (target - self.eye) / np.linalg.norm(target - self.eye)
        right = np.cross(self.forward, [0.0, 0.0, 1.0])
        self.right = right / np.linalg.norm(right)
        self.up = np.cross(self.right, self.forward)
        self.width, self.height = viewport
        self.tan_half = math.tan(math.radians(FOV_Y_DEG) / 2)

    def ndc(self, point: Sequence[float]) -> tuple[float, float]:
        """Normalized device coordinates (x right, y up, both in [-1, 1] on the page)."""
        rel = np.asarray(point, dtype=float) - self.eye
        depth = rel @ self.forward
        aspect = self.width / self.height
        return float(rel @ self.right / (depth * self.tan_half * aspect)), float(rel @ self.up / (depth * self.tan_half))

    def pixels(self, point: Sequence[float]) -> tuple[float, float]:
        """Page pixels (x right, y down) of ``point``."""
        x, y = self.ndc(point)
        return (x + 1.0) * 0.5 * self.width, (1.0 - y) * 0.5 * self.height


def label_box(x: float, y: float, text: str, anchor: str, scale: float) -> tuple[float, float, float, float]:
    """Page box ``(left, top, right, bottom)`` of a screen-space label anchored at pixel (x, y)
    (``text`` may have several lines)."""
    em = EM_PX * scale
    lines = text.split("\n")
    w = 0.62 * em * max(len(line) for line in lines) + 6.0
    h = 1.35 * em * len(lines) + 4.0
    vertical, _, horizontal = anchor.partition("-")
    left = x if horizontal == "left" else x - w if horizontal == "right" else x - w / 2
    top = y if vertical == "top" else y - h if vertical == "bottom" else y - h / 2
    return left, top, left + w, top + h


def overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    """Whether two page boxes overlap."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def overlapping_pairs(boxes: dict[str, tuple[float, float, float, float]]) -> list[tuple[str, str]]:
    """Names of the label pairs whose boxes overlap."""
    names = list(boxes)
    return [(a, b) for i, a in enumerate(names) for b in names[i + 1:] if overlap(boxes[a], boxes[b])]


def drawn_instances(batched: object) -> int:
    """Instances of a batched mesh drawn at a nonzero scale (e.g. the links of a chain shown)."""
    scales = np.asarray(getattr(batched, "batched_scales"), dtype=float)
    return int(np.count_nonzero(np.any(scales.reshape(scales.shape[0], -1) != 0.0, axis=1)))
