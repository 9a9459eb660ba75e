"""Histories, plot windows, CSV export and legends shared by the timed scenes.

The gyroscope and free-body scenes compute their motion in chunks of
simulated time on the app's executor (:class:`rigidlab.app.jobs.ChunkTimeline`).
Besides what a scene draws, every chunk carries a :class:`Table`: its sample
times ``t`` (n,), the exported columns (n, m) and the same rows already
formatted as CSV text, all built on the executor. :class:`History` keeps the
tables of the chunks the display clock has reached, and serves from them the
window of the plots (decimated to a few hundred points) and the CSV of the
trajectory shown, so the loop thread only slices arrays.

:func:`window_seconds` sizes a plot window to the motion (at least two of its
periods, within a cap); :class:`Legend` is the panel's colour key of a
scene's arrows and curves (an HTML panel that grows in presenter view, as
readouts do); :class:`PlotRefresh` spreads the refresh of several plots over
consecutive frames at a rate a reader can follow.

Axes that mean something (used by :meth:`rigidlab.app.scenes.base.Scene.show_series`,
which a scene calls to send a plot's data): :func:`axis_offset` and
:func:`offset_label` / :func:`label_with_offset` draw a flat series as
``y - offset`` with the offset in its label, :func:`y_limits` gives y limits
that follow the data, and :func:`round_off_level` / :func:`drift_title` label
a drift plot whose values are round-off.
"""

from __future__ import annotations

import dataclasses
import html
import math
import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from rigidlab.app.readout import PRESENTER_FONT_SCALE

__all__ = [
    "History",
    "LOG_FLOOR",
    "Legend",
    "PlotRefresh",
    "Table",
    "axis_offset",
    "capped_range",
    "drift_title",
    "format_rows",
    "label_with_offset",
    "offset_label",
    "round_off_level",
    "y_limits",
    "hex_color",
    "log10_floor",
    "window_seconds",
]

#: Most points sent per plotted series: a sidebar plot is about 300 px wide, and a
#: window of at least two periods keeps some 55 points per period. viser re-sends a
#: plot's data whole (float64, uncompressed), so each series costs ~1 kB per refresh.
PLOT_POINTS = 120


@dataclasses.dataclass(frozen=True)
class Table:
    """Samples of one chunk of a motion (read-only arrays).

    Attributes
    ----------
    t : (n,) sample times (s), increasing.
    columns : (n, m) the exported columns at those times (the scene's units), then any plotted-only ones.
    csv : n rows ``t, columns...`` formatted as CSV text (no line ends).
    """

    t: np.ndarray  # (n,)
    columns: np.ndarray  # (n, m)
    csv: tuple[str, ...]

    @classmethod
    def build(cls, t: np.ndarray, columns: np.ndarray, *, plotted: np.ndarray | None = None) -> Table:
        """A table of ``t`` (n,) and ``columns`` (n, m), with its CSV rows (run on the executor).

        ``plotted`` (n, e): more columns for the plots only, kept after the exported ones (columns
        ``m .. m + e - 1``) and left out of the CSV rows.
        """
        t = np.array(t, dtype=float)
        columns = np.array(columns, dtype=float).reshape(t.shape[0], -1)
        csv = format_rows(t, columns)
        if plotted is not None:
            columns = np.hstack([columns, np.asarray(plotted, dtype=float).reshape(t.shape[0], -1)])
        for a in (t, columns):
            a.setflags(write=False)
        return cls(t, columns, csv)


def format_rows(t: np.ndarray, columns: np.ndarray) -> tuple[str, ...]:
    """CSV rows ``t, c0, c1, ...`` (15 significant digits; empty fields for NaN)."""
    data = np.column_stack([t, columns])
    template = ",".join(["%.15g"] * data.shape[1])
    if np.all(np.isfinite(data)):
        return tuple(template % tuple(row) for row in data.tolist())
    rows = []
    for row in data.tolist():
        rows.append(",".join("" if not math.isfinite(x) else "%.15g" % x for x in row))
    return tuple(rows)


def window_seconds(period: float, *, periods: float = 2.2, minimum: float = 6.0, fallback: float = 10.0,
                   cap: float = 60.0) -> float:
    """Length (s) of a plot window that shows ``periods`` periods of a motion.

    ``period`` (s) is the motion's period; ``inf``, 0 or NaN (no periodic
    motion, or not known) give ``fallback``. The window is at least
    ``minimum`` and at most ``cap``.
    """
    if not (math.isfinite(period) and period > 0.0):
        return float(min(max(fallback, minimum), cap))
    return float(min(max(periods * period, minimum), cap))


#: log10 of an exact zero in the log plots.
LOG_FLOOR = -17.0


def log10_floor(x: Any) -> np.ndarray:
    """``log10 |x|`` for the log plots, floored at :data:`LOG_FLOOR` (an exact zero would be -inf)."""
    with np.errstate(divide="ignore"):
        return np.maximum(np.log10(np.abs(np.asarray(x, dtype=float))), LOG_FLOOR)


class History:
    """Tables of the chunks the display clock has reached, by chunk index.

    The loop thread adds the table of every chunk it draws from; the plots and
    the export read the samples between two times from here. Tables older
    than the window are dropped (:meth:`trim`).
    """

    def __init__(self) -> None:
        self._tables: dict[int, Table] = {}

    def clear(self) -> None:
        self._tables = {}

    def __len__(self) -> int:
        return len(self._tables)

    def add(self, k: int, table: Table) -> None:
        if k not in self._tables:
            self._tables[k] = table

    def trim(self, t_start: float) -> None:
        """Forget tables that end before ``t_start``."""
        for k in [k for k, tab in self._tables.items() if tab.t[-1] < t_start]:
            del self._tables[k]

    def trimmed_window(self, t_start: float, t_end: float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`trim` to ``t_start``, then the :meth:`window` ``[t_start, t_end]``: a plot refresh cycle's data."""
        self.trim(t_start)
        return self.window(t_start, t_end)

    def _slices(self, t_start: float, t_end: float) -> list[tuple[Table, int, int]]:
        """``(table, i0, i1)``: samples ``t_start <= t <= t_end``, each time once.

        Most tables of a window lie inside it whole, or but for a first
        sample that repeats the last one of the table before: their bounds
        come from comparing floats, without a search (a plot refresh of a
        window of 20 tables made 40 numpy calls).
        """
        out = []
        last = -math.inf
        for k in sorted(self._tables):
            t = self._tables[k].t
            n = t.shape[0]
            if n == 0:
                continue
            lo = max(t_start, math.nextafter(last, math.inf)) if math.isfinite(last) else t_start
            if float(t[0]) >= lo:
                i0 = 0
            elif n > 1 and float(t[1]) >= lo:
                i0 = 1
            else:
                i0 = int(np.searchsorted(t, lo, side="left"))
            i1 = n if float(t[n - 1]) <= t_end else int(np.searchsorted(t, t_end, side="right"))
            if i1 > i0:
                out.append((self._tables[k], i0, i1))
                last = float(t[i1 - 1])
        return out

    def window(self, t_start: float, t_end: float, *, max_points: int = PLOT_POINTS) -> tuple[np.ndarray, np.ndarray]:
        """Samples with ``t_start <= t <= t_end``: times (n,) and columns (n, m),
        every ``s``-th sample so that ``n <= max_points`` (the latest always kept)."""
        parts = self._slices(t_start, t_end)
        if not parts:
            return np.zeros(0), np.zeros((0, 0))
        total = sum(i1 - i0 for _, i0, i1 in parts)
        stride = max(1, math.ceil(total / max_points))
        ts, cs = [], []
        offset = 0  # index of the first sample of this part in the whole window
        for tab, i0, i1 in parts:
            first = i0 + (-offset) % stride
            ts.append(tab.t[first:i1:stride])
            cs.append(tab.columns[first:i1:stride])
            offset += i1 - i0
        t = np.concatenate(ts)
        columns = np.concatenate(cs)
        tab, _, i1 = parts[-1]
        if t.size == 0 or t[-1] != tab.t[i1 - 1]:  # keep the newest sample
            t = np.append(t, tab.t[i1 - 1])
            columns = np.vstack([columns, tab.columns[i1 - 1]])
        return t, columns

    def csv(self, header: str, t_start: float, t_end: float) -> bytes:
        """The CSV document of the samples ``t_start <= t <= t_end``: ``header`` then the rows."""
        lines = [header]
        for tab, i0, i1 in self._slices(t_start, t_end):
            lines.extend(tab.csv[i0:i1])
        return ("\n".join(lines) + "\n").encode()


def hex_color(rgb: Sequence[int]) -> str:
    """``"#rrggbb"`` of an RGB triple in 0..255."""
    r, g, b = (int(c) for c in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"


class Legend:
    """The colour key of a scene's arrows and curves: an HTML panel in the current folder.

    Parameters
    ----------
    gui : viser.GuiApi
        Where the panel is created.
    items : sequence of (rgb, text)
        A swatch colour (0..255) and what it stands for.
    title : str
        Text before the items.
    presenter : bool, keyword-only
        Start in presenter view (larger font).
    """

    def __init__(self, gui: Any, items: Sequence[tuple[Sequence[int], str]], title: str = "", *,
                 presenter: bool = False) -> None:
        self.items = tuple((tuple(int(c) for c in rgb), str(text)) for rgb, text in items)
        self.title = title
        self._presenter = bool(presenter)
        self.handle = gui.add_html(self.html())

    def html(self) -> str:
        size = f"{PRESENTER_FONT_SCALE:.2f}em" if self._presenter else "0.875em"
        swatch = ("display:inline-block;width:1.6em;height:0.55em;border-radius:2px;"
                  "vertical-align:0.12em;margin-right:0.4em;background:")
        rows = "".join(
            f"<div style='padding-left:2em;text-indent:-2em'><span style='{swatch}{hex_color(rgb)}'></span>"
            f"{html.escape(text)}</div>"
            for rgb, text in self.items
        )
        title = f"<div style='margin-bottom:0.15em'>{html.escape(self.title)}</div>" if self.title else ""
        return (f"<div class='rigidlab-legend' style='font-size:{size};line-height:1.45;"
                f"padding:0 0.75em 0.4em 0.75em'>{title}{rows}</div>")

    def set_presenter(self, on: bool) -> None:
        self._presenter = bool(on)
        self.handle.content = self.html()


class PlotRefresh:
    """When to refresh which plot: every ``period`` seconds of wall time, one plot per frame.

    Sending all plots in one frame makes that frame the slowest of its second;
    spreading them over consecutive frames keeps every frame small.
    """

    def __init__(self, names: Sequence[str], period: float) -> None:
        self.names = tuple(names)
        self.period = float(period)
        self._since = math.inf
        self._queue: list[str] = []

    def force(self) -> None:
        """Refresh every plot as soon as possible (new parameters, restart)."""
        self._since = math.inf
        self._queue = []

    @property
    def queued(self) -> bool:
        """Refreshes of the current cycle are still to come (one a frame)."""
        return bool(self._queue)

    def due(self, dt: float, *, moving: bool, hold: bool = False) -> str | None:
        """The plot to refresh in this frame, if any (``moving``: the data changed).

        ``hold``: the frame has other work of its own (a buffer it sends now
        and then); nothing is refreshed in it, the time still counts, and the
        plot that was due comes in the next frame.
        """
        self._since += dt
        if hold:
            return None
        if not self._queue and moving and self._since >= self.period:
            self._queue = list(self.names)
            self._since = 0.0
        return self._queue.pop(0) if self._queue else None


# -- axes that mean something -------------------------------------------------------------------------------
#: A series is drawn as an offset (``y - offset``) when its spread is below this fraction of its magnitude:
#: uPlot's own ticks of such a series all print the same number ("26.886" on every tick of a flat energy).
OFFSET_SPREAD = 1e-3
#: Values at most this many units of round-off (``ROUND_OFF_ULPS * eps * scale``) are "round-off level".
ROUND_OFF_ULPS = 64.0


def _finite(values: Any) -> np.ndarray:
    a = np.asarray(values, dtype=float).ravel()
    return a[np.isfinite(a)]


def axis_offset(values: Any, *, spread: float = OFFSET_SPREAD) -> float:
    """The offset a plot subtracts from ``values`` so that its ticks differ: 0.0 unless the spread
    (max - min) of the finite values is below ``spread`` times their largest magnitude.

    The offset is the mid-range rounded to one decimal below the spread's leading digit, so it prints
    short ("26.886") and the remainders ``values - offset`` are a few spreads at most. A flat non-zero
    series (spread 0) gets its value (to 12 significant digits) as offset.

    Parameters
    ----------
    values : array_like, any shape
        The plotted values (NaN and inf are ignored).
    spread : float, keyword-only
        Largest relative spread that is still drawn without an offset (positive).

    Raises
    ------
    ValueError
        If ``spread`` is not positive.
    """
    if not (spread > 0.0):
        raise ValueError(f"spread: expected a positive fraction, got {spread!r}")
    a = _finite(values)
    if a.size == 0:
        return 0.0
    lo, hi = float(a.min()), float(a.max())
    size = max(abs(lo), abs(hi))
    if size == 0.0 or hi - lo >= spread * size:
        return 0.0
    mid = 0.5 * (lo + hi)
    if hi == lo:
        return float(f"{mid:.12g}")
    decimals = max(0, -1 - math.floor(math.log10(hi - lo)))
    return float(round(mid, decimals)) if decimals < 16 else mid


def offset_label(name: str, offset: float, unit: str = "") -> str:
    """A series or axis label that states its offset: ``"E − 26.886 (J)"`` (``"E (J)"`` for offset 0)."""
    unit_text = f" ({unit})" if unit else ""
    if offset == 0.0:
        return f"{name}{unit_text}"
    sign = "\u2212" if offset > 0 else "+"
    return f"{name} {sign} {abs(offset):.12g}{unit_text}"


def label_with_offset(label: str, offset: float) -> str:
    """A series label with its offset, the unit kept last: ``"E (J)"`` and 26.886 give ``"E − 26.886 (J)"``."""
    match = re.fullmatch(r"(.*?)\s*\(([^()]*)\)", label)
    if match is None:
        return offset_label(label, offset)
    return offset_label(match.group(1), offset, match.group(2))


def _nice_step(span: float) -> float:
    """A 1-2-5 step of about a twentieth of ``span`` (> 0): the limits are rounded out to it."""
    raw = span / 20.0
    power = 10.0 ** math.floor(math.log10(raw))
    for m in (1.0, 2.0, 5.0, 10.0):
        if raw <= m * power:
            return m * power
    return 10.0 * power  # pragma: no cover - (the loop ends at 10)


def y_limits(values: Any, *, min_span: float = 0.0, pad: float = 0.08,
             include: tuple[float, ...] = ()) -> tuple[float, float]:
    """y-axis limits that follow the data: the finite values' range (and the numbers in ``include``),
    padded by ``pad`` of the span on each side and rounded out to a 1-2-5 tick step.

    A span below ``min_span`` is widened to ``min_span`` about the data's middle (a flat lean angle gets a
    few degrees, not 0-100); a flat series with ``min_span`` 0 gets a span of 1e-6 of its magnitude (1 at 0).
    Without finite values the limits are ``(-1, 1)`` (or ``min_span`` about 0).

    Parameters
    ----------
    values : array_like, any shape
        The plotted values (NaN and inf ignored), in the plot's units (after any offset).
    min_span : float, keyword-only
        Smallest span of the limits (>= 0).
    pad : float, keyword-only
        Margin above and below the data, as a fraction of their span (>= 0).
    include : tuple of float, keyword-only
        Values the limits always contain (a bound drawn as a line, 0).

    Returns
    -------
    (lo, hi) : floats with ``lo < hi``.

    Raises
    ------
    ValueError
        If ``min_span`` or ``pad`` is negative or not finite.
    """
    if not (math.isfinite(min_span) and min_span >= 0.0):
        raise ValueError(f"min_span: expected a finite number >= 0, got {min_span!r}")
    if not (math.isfinite(pad) and pad >= 0.0):
        raise ValueError(f"pad: expected a finite number >= 0, got {pad!r}")
    a = np.concatenate([_finite(values), _finite(include)])
    if a.size == 0:
        half = 0.5 * min_span if min_span > 0.0 else 1.0
        return -half, half
    lo, hi = float(a.min()), float(a.max())
    span = hi - lo
    floor_span = min_span if min_span > 0.0 else (1e-6 * max(abs(lo), abs(hi)) or 1.0)
    if span < floor_span:
        mid = 0.5 * (lo + hi)
        lo, hi = mid - 0.5 * floor_span, mid + 0.5 * floor_span
        span = floor_span
    else:
        lo, hi = lo - pad * span, hi + pad * span
        span = hi - lo
    step = _nice_step(span)
    lo_r, hi_r = math.floor(lo / step) * step, math.ceil(hi / step) * step
    if not (hi_r > lo_r):  # steps below the values' resolution
        return lo, hi
    return lo_r, hi_r


def round_off_level(values: Any, *, scale: float, ulps: float = ROUND_OFF_ULPS) -> bool:
    """Whether every finite value is at round-off level: ``|v| <= ulps * eps * |scale|`` (float64 eps).

    ``scale`` is the size of the quantity the values are errors of (an energy's magnitude, 1 for a unit
    quaternion's norm); a drift plot whose values pass says so (:func:`drift_title`) instead of showing
    square-wave round-off as if it were a trend. No finite value: False.

    Raises
    ------
    ValueError
        If ``scale`` is not finite or ``ulps`` is not positive.
    """
    if not math.isfinite(scale):
        raise ValueError(f"scale: expected a finite number, got {scale!r}")
    if not (ulps > 0.0):
        raise ValueError(f"ulps: expected a positive number, got {ulps!r}")
    a = _finite(values)
    if a.size == 0:
        return False
    return bool(np.max(np.abs(a)) <= ulps * np.finfo(float).eps * max(abs(scale), np.finfo(float).tiny))


def drift_title(title: str, values: Any, *, scale: float, log10: bool = False,
                ulps: float = ROUND_OFF_ULPS) -> str:
    """The title of a drift plot: ``title``, plus "— round-off level (≤ 64 ε)" when the drift is
    (:func:`round_off_level`). ``log10``: the values are ``log10 |drift|`` (as the log plots draw them,
    :func:`log10_floor`)."""
    a = np.asarray(values, dtype=float)
    if log10:
        a = 10.0 ** a
    if round_off_level(a, scale=scale, ulps=ulps):
        return f"{title} \u2014 round-off level (\u2264 {ulps:g} \u03b5)"
    return title


def capped_range(reference: Any, values: Any, *, spans: float = 2.0, margin: float = 0.05,
                 ) -> tuple[tuple[float, float], float | None]:
    """A y range that keeps ``reference`` readable beside ``values`` with short peaks far above it (a landing's
    impact of kilonewtons against a closed form of tens of newtons), and the largest value if it is cut off.

    The range holds zero, ``reference`` and ``values``, but reaches above the top of ``reference`` (or 0) by at
    most ``spans`` times the height of ``reference`` and zero (at least 1), with ``margin`` of its height
    (at least 1) added at both ends. Returns ``((lo, hi), peak)``: ``peak`` is ``max(values)`` when it is
    above that cap (name it in the legend), else None.
    """
    ref, val = np.asarray(reference, dtype=float), np.asarray(values, dtype=float)
    lo, top = min(float(ref.min()), float(val.min()), 0.0), max(float(ref.max()), 0.0)
    cap = top + spans * max(top - min(float(ref.min()), 0.0), 1.0)
    peak = float(val.max())
    hi = max(top, min(peak, cap))
    pad = margin * max(hi - lo, 1.0)
    return (lo - pad, hi + pad), (peak if peak > cap else None)
