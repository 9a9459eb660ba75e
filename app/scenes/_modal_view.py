"""What the mode-shapes scene and the Model scene share: the eigen solution as a panel shows it.

Both scenes solve a System's modes on the app's executor and show the same
panel: the table of modes (:func:`modes_table`, Eqs. 8.130-8.131), the mode
picker whose options are the table's rows (:class:`ModeChoice`), the
eigenvalues in the complex plane (:func:`complex_plane_svg`) and the chosen
mode animated with the joints closed (:func:`animate_group`, on
:meth:`rigidlab.core.modal.Modes.animate`). :class:`Throttled` lets a sweep reach the
executor one value at a time. Nothing here touches viser.
"""

from __future__ import annotations

import collections
import concurrent.futures
import dataclasses
import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from rigidlab.app.controls import Choice, Refused, describe
from rigidlab.app.jobs import settle
from rigidlab.app.scenes._svg import FONT, Chart

__all__ = ["Animated", "Cancelled", "MAX_CYCLES", "MAX_MODES", "MODE_OPTIONS", "ModalStatus", "ModeChoice",
           "SAMPLES_PER_CYCLE", "SELECTED_COLOR", "STATUS_COLORS", "STATUS_TEXT", "Throttled", "animate_group",
           "complex_plane_svg", "mode_groups", "mode_row", "modes_table", "remember", "ro", "s_text", "settle",
           "sig", "xi_text"]

#: Most modes offered in the *Mode* dropdown (a chain of 10 links has 10).
MAX_MODES = 12
MODE_OPTIONS = tuple(str(k) for k in range(1, MAX_MODES + 1))
#: Samples of an animated mode per period of its oscillation.
SAMPLES_PER_CYCLE = 120
#: Most periods in one clip (a damped or growing mode shows its envelope).
MAX_CYCLES = 6
# Chart colours: eigenvalues by stability; none of them the red / green /
# blue of frame axes.
STATUS_COLORS = {"stable": "#0f766e", "neutral": "#1d4ed8", "unstable": "#c2410c", "mirrored": "#c2410c",
                 "rigid": "#9ca3af"}
SELECTED_COLOR = "#7c3aed"


def ro(a: Any, dtype: Any = float) -> np.ndarray:
    """A read-only copy of ``a``."""
    out = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


def remember(cache: collections.OrderedDict, key: Any, value: Any, capacity: int) -> None:
    """Put ``key: value`` in the LRU ``cache`` of at most ``capacity`` entries."""
    cache[key] = value
    cache.move_to_end(key)
    while len(cache) > capacity:
        cache.popitem(last=False)


class ModalStatus:
    """Mixin of a solution with arrays ``eigenvalues``, ``stable``, ``critical``, ``rigid`` and ``groups``."""

    def status(self, i: int) -> str:
        """Stability of eigenvalue ``i``: rigid, unstable, neutral (undamped: on the boundary), stable
        (damped), or mirrored: Re s < 0, but its mirror ``-conj(s)`` is an eigenvalue too and grows (an
        undamped system's eigenvalues come in such pairs: an inverted or slow heavy top has s = +-1.41;
        the decaying one is no damping, and the equilibrium is unstable)."""
        if self.rigid[i]:
            return "rigid"
        if not self.stable[i]:
            return "unstable"
        if self.critical[i]:
            return "neutral"
        ev = self.eigenvalues
        mirror = -np.conj(ev[i])
        scale = float(np.max(np.abs(ev))) if ev.size else 1.0
        if np.any((np.abs(ev - mirror) <= 1e-8 * scale) & ~self.stable & ~self.rigid):
            return "mirrored"
        return "stable"


def mode_groups(modes: Any, *, rigid: bool = False) -> tuple[tuple[int, ...], ...]:
    """The selectable modes of :class:`rigidlab.core.modal.Modes` ``modes``: eigenvalue indices of each (a conjugate
    pair once, the +Im member first), rigid-body modes left out unless ``rigid``."""
    ev = modes.eigenvalues
    groups, k = [], 0
    while k < ev.size:
        pair = ev[k].imag > 0 and k + 1 < ev.size and ev[k + 1] == np.conj(ev[k])
        members = (k, k + 1) if pair else (k,)
        if rigid or not modes.rigid[k]:
            groups.append(members)
        k += len(members)
    return tuple(groups)


@dataclasses.dataclass(frozen=True)
class Animated:
    """One mode animated over whole periods (global coordinates; see :func:`animate_group`)."""

    t: np.ndarray  # (m,) s after the reference
    positions: np.ndarray  # (m, n, 3) m
    orientations: np.ndarray  # (m, n, 4) Euler parameters, scalar first
    residual: np.ndarray  # (m,) max |C| after the projection
    eigenvalue: complex
    period: float  # s; inf for a mode that does not oscillate
    cycles: int
    amplitude: float  # m or rad
    unit: str  # "m" or "rad"
    reduced: bool  # the amplitude was halved until the projection converged
    still: int  # the sample shown when the animation is off


def animate_group(modes: Any, system: Any, group: tuple[int, ...], mode: int, fraction: float,
                  size: float) -> Animated:
    """Mode ``group`` (eigenvalue indices, :func:`mode_groups`) of ``modes`` animated by
    :meth:`rigidlab.core.modal.Modes.animate` (Eqs. 8.125-8.129), every sample projected onto the constraints.

    An oscillating mode: whole periods of :data:`SAMPLES_PER_CYCLE` samples (a damped or growing one over
    up to :data:`MAX_CYCLES`, so its envelope shows); one that does not oscillate (real s, a rigid-body
    mode) is its shape swinging once, ``a cos(2 pi k / m)``. ``a`` is ``fraction`` times ``size`` (m) when
    the largest displacement is a translation, ``fraction`` rad for a rotation; it is halved (up to 4
    times) while the projection does not converge. Runs on the executor.
    """
    j = group[0]
    s = complex(modes.eigenvalues[j])
    n = modes.embedding.n_bodies
    shape = modes.body_shapes(system)[j]
    unit = "m" if int(np.argmax(np.abs(shape))) < 3 * n else "rad"
    amplitude = fraction * (size if unit == "m" else 1.0)
    oscillates = len(group) == 2
    if oscillates:
        period = 2.0 * math.pi / abs(s.imag)
        decay = abs(s.real) * period  # log change of the amplitude per period
        cycles = 1 if decay < 1e-3 else int(min(MAX_CYCLES, max(1, round(math.log(4.0) / decay))))
        m = SAMPLES_PER_CYCLE * cycles
        t = np.arange(m) * (cycles * period / m)
        if s.real > 0 and decay >= 1e-3:
            t = t - t[-1]  # a growing mode ends at the amplitude a
        still = m - 1 if s.real > 0 and decay >= 1e-3 else 0
    else:
        period, cycles, m, still = math.inf, 1, SAMPLES_PER_CYCLE, 0
        t = np.zeros(m)
    reduced = False
    for _ in range(4):
        try:
            if oscillates:
                motion = modes.animate(system, j, t, amplitude=amplitude)
                R, P, res = motion.positions, motion.orientations, motion.residual_position
            else:  # no oscillation: the shape swung once, amplitude a cos(2 pi k / m)
                frames = [modes.animate(system, j, [0.0], amplitude=amplitude * math.cos(2 * math.pi * i / m))
                          for i in range(m)]
                R = np.concatenate([f.positions for f in frames])
                P = np.concatenate([f.orientations for f in frames])
                res = np.concatenate([f.residual_position for f in frames])
            break
        except Exception:  # the projection did not converge at this amplitude: halve it
            amplitude *= 0.5
            reduced = True
    else:
        raise ValueError(f"amplitude: the constraints cannot be met for mode {mode} even at {amplitude:.3g} "
                         f"{unit}; choose a smaller amplitude")
    return Animated(t, np.asarray(R), np.asarray(P), np.asarray(res), s, period, cycles, float(amplitude), unit,
                    reduced, still)


class Cancelled(Exception):
    """Raised by a sweep's progress callback to stop it."""


class Throttled(concurrent.futures.Executor):
    """Forwards at most ``limit`` jobs at a time to ``base``; the others wait here.

    A sweep submits all its values at once; through this they reach the pool
    one by one, so a job the scene submits meanwhile waits for one value, not
    for the whole sweep. A job cancelled before it was forwarded never runs.
    """

    def __init__(self, base: concurrent.futures.Executor, limit: int = 1) -> None:
        self._base = base
        self._limit = int(limit)
        self._lock = threading.Lock()
        self._queue: collections.deque = collections.deque()
        self._running = 0

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> concurrent.futures.Future:
        outer: concurrent.futures.Future = concurrent.futures.Future()
        with self._lock:
            self._queue.append((outer, fn, args, kwargs))
        self._pump()
        return outer

    def _pump(self) -> None:
        while True:
            with self._lock:
                if self._running >= self._limit or not self._queue:
                    return
                outer, fn, args, kwargs = self._queue.popleft()
                if outer.cancelled():
                    continue
                self._running += 1
            try:
                inner = self._base.submit(fn, *args, **kwargs)
            except BaseException as exc:  # the pool is shut down
                with self._lock:
                    self._running -= 1
                settle(outer, None, exc)
                continue
            outer.add_done_callback(lambda o, inner=inner: inner.cancel() if o.cancelled() else None)
            inner.add_done_callback(lambda f, outer=outer: self._done(f, outer))

    def _done(self, inner: concurrent.futures.Future, outer: concurrent.futures.Future) -> None:
        with self._lock:
            self._running -= 1
        if inner.cancelled():
            outer.cancel()
        else:
            exc = inner.exception()
            settle(outer, None if exc is not None else inner.result(), exc)
        self._pump()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            queued, self._queue = list(self._queue), collections.deque()
        for outer, *_ in queued:
            outer.cancel()


def sig(x: float, digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits, plain where it reads well."""
    if x == 0.0 or not math.isfinite(x):
        return "0" if x == 0.0 else f"{x:g}"
    x = float(f"{x:.{digits - 1}e}")  # rounded first: 9.99999 and 10.00001 both read 10.00
    if 1e-3 <= abs(x) < 1e5:
        decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
        return f"{x:.{decimals}f}"
    return f"{x:.{digits - 1}e}"


def xi_text(xi: float) -> str:
    if not math.isfinite(xi):
        return "–"
    return "0" if abs(xi) < 5e-7 else sig(xi, 3)


def s_text(s: complex, pair: bool, scale: float) -> str:
    re = s.real if abs(s.real) > 1e-12 * max(scale, 1.0) else 0.0
    real = "0" if re == 0.0 else sig(re, 3)
    if not pair:
        return real
    imag = f"±{sig(abs(s.imag), 4)}i"
    return imag if re == 0.0 else f"{real} {imag[0]}\u00a0{imag[1:]}"  # (a narrow column breaks before the ±)


STATUS_TEXT = {"stable": "stable (damped)", "neutral": "neutral (undamped)", "unstable": "**unstable**",
                "mirrored": "**unstable**: decays, its mirror grows", "rigid": "rigid"}


@dataclasses.dataclass(frozen=True)
class ModeChoice(Choice):
    """The mode picker: a dropdown whose options are the rows of the modes table.

    The value (in the state, in ``controls.value("mode")``) stays the mode number, ``"1"`` to ``"12"``; the
    dropdown shows each number as its row ("2 · 1.234 Hz · ξ 0.02 · neutral", :func:`mode_row`), which the
    scene writes into :attr:`rows` when a new solution is shown. A browser may send either form.
    """

    rows: dict = dataclasses.field(default_factory=dict, compare=False, kw_only=True)

    def _number(self, raw: Any) -> str | None:
        if not isinstance(raw, str):
            return None
        head = raw.split("\u00b7", 1)[0].strip()
        return head if head in self.options else None

    def check(self, raw: Any) -> str:
        if self._number(raw) is None:
            raise Refused(f"expected a mode number 1 to {len(self.options)} (a row of the table), got {describe(raw)}")
        return raw

    def parse(self, value: Any) -> Any:
        number = self._number(value)
        return value if number is None else number

    def display(self, value: Any) -> Any:
        return self.rows.get(value, value)


def mode_row(solution: Any, number: int) -> str:
    """Mode ``number`` (1-based) as one line of the table: "2 · 1.234 Hz · ξ 0.02 · neutral"."""
    i = solution.groups[number - 1][0]
    return (f"{number} \u00b7 {sig(float(solution.frequency_hz[i]))} Hz \u00b7 "
            f"\u03be {xi_text(float(solution.damping_ratio[i]))} \u00b7 {STATUS_TEXT[solution.status(i)].replace('*', '')}")


def modes_table(solution: Any, selected: int) -> str:
    """The table of modes (Markdown), the ``selected`` (1-based) row in bold."""
    ev = solution.eigenvalues
    scale = float(np.max(np.abs(ev))) if ev.size else 1.0
    rows = ["| # | f (Hz) | ω_n (rad/s) | ξ | s (1/s) | stability |", "|---:|---:|---:|---:|---:|:---|"]
    for number, group in enumerate(solution.groups[:MAX_MODES], start=1):
        i = group[0]
        cells = [str(number), sig(float(solution.frequency_hz[i])), sig(float(solution.omega_n[i])),
                 xi_text(float(solution.damping_ratio[i])), s_text(complex(ev[i]), len(group) == 2, scale)]
        if number == selected:
            cells = [f"**{c}**" for c in cells]
        rows.append("| " + " | ".join(cells) + f" | {STATUS_TEXT[solution.status(i)]} |")
    # a table that lists its rigid-body modes as rows (the Model scene's) needs no note on them
    rigid = 0 if any(solution.rigid[g[0]] for g in solution.groups) else int(np.count_nonzero(solution.rigid))
    lines = ["\n".join(rows)]
    if rigid:
        lines.append(f"and {rigid} rigid-body eigenvalue{'s' if rigid > 1 else ''} s = 0 "
                     "(motions without a restoring force, such as a free spin).")
    if len(solution.groups) > MAX_MODES:
        lines.append(f"{len(solution.groups) - MAX_MODES} more modes are in the export.")
    return "\n\n".join(lines)


def complex_plane_svg(solution: Any, selected: int, *, font: float = FONT) -> str:
    """The eigenvalues in the complex plane, coloured by stability; the selected mode ringed."""
    ev = solution.eigenvalues
    im = float(np.max(np.abs(ev.imag))) if ev.size else 1.0
    re_lo, re_hi = min(0.0, float(np.min(ev.real))), max(0.0, float(np.max(ev.real)))
    y = 1.15 * im if im > 0 else 1.15 * max(abs(re_lo), abs(re_hi), 1.0)
    span = max(re_hi - re_lo, 0.12 * y)
    mid = 0.5 * (re_lo + re_hi)
    chart = Chart((mid - 0.65 * span, mid + 0.65 * span), (-y, y), "Re s (1/s)", "Im s (rad/s)", font=font,
                  height=220)
    chart.shade_right_half("#fdecea")
    for status, color in STATUS_COLORS.items():
        idx = [i for i in range(ev.size) if solution.status(i) == status]
        if idx:
            chart.points(ev.real[idx], ev.imag[idx], color, radius=4.0, hollow=status == "rigid")
    if 1 <= selected <= len(solution.groups):
        g = list(solution.groups[selected - 1])
        chart.points(ev.real[g], ev.imag[g], SELECTED_COLOR, radius=7.5, hollow=True)
    return chart.svg()
