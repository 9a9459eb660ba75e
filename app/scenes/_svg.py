"""Small SVG charts for a scene's control panel: points and curves on linear axes.

The panel's uPlot charts need increasing x values and draw no scatter, so
the eigenvalues in the complex plane, a Campbell diagram and a root locus
are drawn as inline SVG in an HTML panel (viser's ``add_html``) instead.
:class:`Chart` maps data to the drawing, chooses round tick values, and
collects curves, points, dashed lines and labels; :meth:`Chart.svg` returns
the document. Every number written is finite (non-finite points are
skipped), so nothing non-finite reaches a browser. A chart scales with the
panel's width; presenter view passes a larger ``font`` (px of the 340-px
wide drawing).
"""

from __future__ import annotations

import copy
import html
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["Chart", "nice_ticks"]

WIDTH = 340
FONT = 11.0
PRESENTER_FONT = 15.0


def nice_ticks(lo: float, hi: float, count: int = 5) -> list[float]:
    """Round tick values (1, 2, 2.5 or 5 times a power of ten) inside ``[lo, hi]``, as close to
    ``count`` of them as these steps allow (more rather than fewer on a tie)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo] if math.isfinite(lo) else []
    power = 10.0 ** math.floor(math.log10((hi - lo) / max(count - 1, 1)))
    best: list[float] = []
    for step in (m * p for p in (power / 10.0, power, power * 10.0) for m in (1.0, 2.0, 2.5, 5.0)):
        first = math.ceil(lo / step - 1e-9)
        last = math.floor(hi / step + 1e-9)
        ticks = [0.0 if k == 0 else k * step for k in range(first, last + 1)]
        if len(ticks) > 50:
            continue
        if not best or (abs(len(ticks) - count), -len(ticks)) < (abs(len(best) - count), -len(best)):
            best = ticks
    return best


def _tick_text(x: float, step: float) -> str:
    """Tick label of ``x`` with the decimals the step needs (``25``, ``2.5``, ``0.25``)."""
    if x == 0.0:
        return "0"
    if abs(x) >= 1e5 or abs(x) < 1e-3:
        return f"{x:.1e}"
    decimals = next((d for d in range(7) if abs(round(step, d) - step) <= 1e-9 * step), 6)
    return f"{x:.{decimals}f}"


def _f(x: float) -> str:
    return f"{x:.1f}"


class Chart:
    """A chart of ``x_range`` by ``y_range`` (data units) in a ``WIDTH``-px wide SVG.

    Parameters
    ----------
    x_range, y_range : (lo, hi)
        Data shown (hi > lo; a degenerate range is widened).
    x_label, y_label : str
        Axis titles.
    height : int, keyword-only
        Drawing height (px at width 340).
    font : float, keyword-only
        Font size (px of the drawing).
    """

    def __init__(self, x_range: Sequence[float], y_range: Sequence[float], x_label: str, y_label: str, *,
                 height: int = 230, font: float = FONT, title: str = "") -> None:
        self.x0, self.x1 = _widened(*x_range)
        self.y0, self.y1 = _widened(*y_range)
        self.font = float(font)
        self.height = int(height)
        self.title = title
        self.left = 10 + 3.6 * self.font
        self.right = WIDTH - 10.0
        self.top = 8.0 + (1.6 * self.font if title else 0.0)
        self.bottom = self.height - 10 - 2.6 * self.font
        self.x_label, self.y_label = x_label, y_label
        self._items: list[str] = []

    # -- mapping -------------------------------------------------------------
    def px(self, x: Any) -> np.ndarray:
        return self.left + (np.asarray(x, dtype=float) - self.x0) / (self.x1 - self.x0) * (self.right - self.left)

    def py(self, y: Any) -> np.ndarray:
        return self.bottom - (np.asarray(y, dtype=float) - self.y0) / (self.y1 - self.y0) * (self.bottom - self.top)

    def _inside(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.isfinite(x) & np.isfinite(y)

    # -- items -------------------------------------------------------------------
    def curve(self, x: Any, y: Any, color: str, *, width: float = 1.8, dash: str | None = None,
              opacity: float = 1.0) -> None:
        """A polyline through the finite points (a gap where a point is not finite)."""
        X, Y = self.px(x), self.py(y)
        ok = self._inside(X, Y)
        runs: list[list[str]] = [[]]
        for xi, yi, good in zip(X.tolist(), Y.tolist(), ok.tolist()):
            if good:
                runs[-1].append(f"{_f(xi)},{_f(yi)}")
            elif runs[-1]:
                runs.append([])
        extra = f" stroke-dasharray='{dash}'" if dash else ""
        for run in runs:
            if len(run) >= 2:
                self._items.append(
                    f"<polyline points='{' '.join(run)}' fill='none' stroke='{color}' stroke-width='{width:g}'"
                    f" stroke-opacity='{opacity:g}' stroke-linejoin='round'{extra}/>"
                )

    def points(self, x: Any, y: Any, color: str, *, radius: float = 4.0, hollow: bool = False,
               stroke: str | None = None) -> None:
        X, Y = self.px(x), self.py(y)
        for xi, yi, good in zip(X.tolist(), Y.tolist(), self._inside(X, Y).tolist()):
            if not good:
                continue
            if hollow:
                self._items.append(f"<circle cx='{_f(xi)}' cy='{_f(yi)}' r='{radius:g}' fill='none' "
                                   f"stroke='{color}' stroke-width='2'/>")
            else:
                ring = f" stroke='{stroke}' stroke-width='1.2'" if stroke else ""
                self._items.append(f"<circle cx='{_f(xi)}' cy='{_f(yi)}' r='{radius:g}' fill='{color}'{ring}/>")

    def vline(self, x: float, color: str, *, dash: str | None = "4 3", width: float = 1.2) -> None:
        if not math.isfinite(x) or not self.x0 <= x <= self.x1:
            return
        X = float(self.px(x))
        extra = f" stroke-dasharray='{dash}'" if dash else ""
        self._items.append(f"<line x1='{_f(X)}' y1='{_f(self.top)}' x2='{_f(X)}' y2='{_f(self.bottom)}' "
                           f"stroke='{color}' stroke-width='{width:g}'{extra}/>")

    def hline(self, y: float, color: str, *, dash: str | None = "4 3", width: float = 1.2) -> None:
        if not math.isfinite(y) or not self.y0 <= y <= self.y1:
            return
        Y = float(self.py(y))
        extra = f" stroke-dasharray='{dash}'" if dash else ""
        self._items.append(f"<line x1='{_f(self.left)}' y1='{_f(Y)}' x2='{_f(self.right)}' y2='{_f(Y)}' "
                           f"stroke='{color}' stroke-width='{width:g}'{extra}/>")

    def shade_right_half(self, color: str) -> None:
        """Shade ``x > 0`` (the unstable half of the complex plane)."""
        if self.x1 <= 0:
            return
        X = float(self.px(max(0.0, self.x0)))
        self._items.append(f"<rect x='{_f(X)}' y='{_f(self.top)}' width='{_f(self.right - X)}' "
                           f"height='{_f(self.bottom - self.top)}' fill='{color}'/>")

    def band(self, x0: float, x1: float, color: str) -> None:
        """Shade ``x0 <= x <= x1`` over the chart's height (clipped to the x range; nothing if not finite)."""
        if not (math.isfinite(x0) and math.isfinite(x1)) or x1 <= self.x0 or x0 >= self.x1:
            return
        X0, X1 = float(self.px(max(x0, self.x0))), float(self.px(min(x1, self.x1)))
        self._items.append(f"<rect x='{_f(X0)}' y='{_f(self.top)}' width='{_f(X1 - X0)}' "
                           f"height='{_f(self.bottom - self.top)}' fill='{color}'/>")

    def text(self, x: float, y: float, text: str, *, color: str = "#333", anchor: str = "start",
             dx: float = 0.0, dy: float = 0.0, scale: float = 1.0) -> None:
        X, Y = float(self.px(x)) + dx, float(self.py(y)) + dy
        if not (math.isfinite(X) and math.isfinite(Y)):
            return
        self._items.append(f"<text x='{_f(X)}' y='{_f(Y)}' fill='{color}' font-size='{self.font * scale:g}' "
                           f"text-anchor='{anchor}'>{html.escape(text)}</text>")

    def copy(self) -> Chart:
        """A chart with the same axes and items (add more to it without changing this one)."""
        other = copy.copy(self)
        other._items = list(self._items)
        return other

    # -- document --------------------------------------------------------------
    def svg(self) -> str:
        """The chart as an SVG element (width 100 % of the panel)."""
        f = self.font
        parts = [
            f"<svg viewBox='0 0 {WIDTH} {self.height}' width='100%' xmlns='http://www.w3.org/2000/svg' "
            f"style='display:block;font-family:sans-serif'>",
            f"<rect x='{_f(self.left)}' y='{_f(self.top)}' width='{_f(self.right - self.left)}' "
            f"height='{_f(self.bottom - self.top)}' fill='#fbfbfc' stroke='#d4d6dc'/>",
        ]
        if self.title:
            parts.append(f"<text x='{WIDTH / 2:g}' y='{_f(self.top - 0.55 * f)}' font-size='{f:g}' fill='#222' "
                         f"text-anchor='middle' font-weight='600'>{html.escape(self.title)}</text>")
        xt = nice_ticks(self.x0, self.x1, 5)
        yt = nice_ticks(self.y0, self.y1, 5)
        xs = (xt[1] - xt[0]) if len(xt) > 1 else 1.0
        ys = (yt[1] - yt[0]) if len(yt) > 1 else 1.0
        for x in xt:
            X = float(self.px(x))
            color = "#b8bcc6" if x == 0.0 else "#e6e8ec"
            parts.append(f"<line x1='{_f(X)}' y1='{_f(self.top)}' x2='{_f(X)}' y2='{_f(self.bottom)}' "
                         f"stroke='{color}'/>")
            parts.append(f"<text x='{_f(X)}' y='{_f(self.bottom + 1.15 * f)}' font-size='{f:g}' fill='#555' "
                         f"text-anchor='middle'>{_tick_text(x, xs)}</text>")
        for y in yt:
            Y = float(self.py(y))
            color = "#b8bcc6" if y == 0.0 else "#e6e8ec"
            parts.append(f"<line x1='{_f(self.left)}' y1='{_f(Y)}' x2='{_f(self.right)}' y2='{_f(Y)}' "
                         f"stroke='{color}'/>")
            parts.append(f"<text x='{_f(self.left - 0.35 * f)}' y='{_f(Y + 0.35 * f)}' font-size='{f:g}' "
                         f"fill='#555' text-anchor='end'>{_tick_text(y, ys)}</text>")
        parts.append(f"<text x='{_f((self.left + self.right) / 2)}' y='{_f(self.height - 0.5 * f)}' "
                     f"font-size='{f:g}' fill='#333' text-anchor='middle'>{html.escape(self.x_label)}</text>")
        mid = (self.top + self.bottom) / 2
        parts.append(f"<text x='{_f(0.95 * f)}' y='{_f(mid)}' font-size='{f:g}' fill='#333' text-anchor='middle' "
                     f"transform='rotate(-90 {_f(0.95 * f)} {_f(mid)})'>{html.escape(self.y_label)}</text>")
        parts.append(f"<svg x='{_f(self.left)}' y='{_f(self.top)}' width='{_f(self.right - self.left)}' "
                     f"height='{_f(self.bottom - self.top)}' viewBox='{_f(self.left)} {_f(self.top)} "
                     f"{_f(self.right - self.left)} {_f(self.bottom - self.top)}' overflow='hidden'>")
        parts.extend(self._items)
        parts.append("</svg></svg>")
        return "".join(parts)


def _widened(lo: float, hi: float) -> tuple[float, float]:
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return 0.0, 1.0
    if hi - lo <= 1e-12 * max(1.0, abs(lo), abs(hi)):
        pad = 0.5 * max(abs(lo), 1.0)
        return lo - pad, hi + pad
    return lo, hi
