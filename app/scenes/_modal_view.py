"""What the mode-shapes scene and the Model scene share: the eigen solution as a panel shows it.

Both scenes solve a System's modes on the app's executor and show the same
panel: the table of modes (:func:`modes_table`, Eqs. 8.130-8.131), the mode
picker whose options are the table's rows (:class:`ModeChoice`,
:func:`send_mode_options`), the chosen mode's status (:func:`mode_status`)
and label (:func:`mode_label`), the eigenvalues in the complex plane
(:func:`complex_plane_svg`) and the chosen mode animated with the joints
closed (:func:`animate_group`, on :meth:`rigidlab.core.modal.Modes.animate`,
kept as a :class:`Clip`). A solution's common part is
:class:`SolutionArrays` (:func:`solution_arrays`). A sweep runs in a
:class:`SweepRun` whose values reach the executor one at a time
(:class:`Throttled`) and is drawn as a Campbell diagram
(:func:`campbell_chart`) or a root locus (:func:`root_locus_chart`).
Nothing here touches viser but the handles a scene passes in.
"""

from __future__ import annotations

import collections
import concurrent.futures
import dataclasses
import json
import math
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from rigidlab.app.controls import Choice, Refused, describe
from rigidlab.app.jobs import settle
from rigidlab.app.scenes._svg import FONT, Chart
from rigidlab.core import RigidModeWarning

__all__ = ["Animated", "CURVE_COLORS", "Cancelled", "Clip", "MAX_CYCLES", "MAX_MODES", "MODE_OPTIONS",
           "ModalResults", "ModalStatus", "ModeChoice", "ProgressBar", "SAMPLES_PER_CYCLE", "SELECTED_COLOR",
           "STATUS_COLORS", "STATUS_TEXT", "SolutionArrays", "SweepRun", "Throttled", "advance", "animate_group",
           "campbell_chart", "complex_plane_svg", "live_branches", "mark_campbell", "mark_root_locus", "mode_groups",
           "mode_label", "mode_row", "mode_status", "modes_table", "remember", "ro", "root_locus_chart", "s_text",
           "send_mode_options", "set_label", "settle", "sig", "solution_arrays", "xi_text"]

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
#: Colours of a sweep's branches.
CURVE_COLORS = ("#0f766e", "#b45309", "#1d4ed8", "#be185d", "#4d7c0f", "#7c3aed", "#0e7490", "#a16207")


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
                with warnings.catch_warnings():  # (a rigid-body mode: the table says so; core warns)
                    warnings.simplefilter("ignore", RigidModeWarning)
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


@dataclasses.dataclass(frozen=True)
class Clip:
    """One mode animated over whole periods, as a scene keeps and draws it (read-only arrays).

    Attributes
    ----------
    key : what the job solved (the modes scene's ``Params``, the Model scene's ``Key``)
    mode : 1-based mode number (into the solution's ``groups``)
    fraction : the amplitude slider's value
    t : (m,) times after the reference (s)
    positions, orientations : (m, n, 3), (m, n, 4) body poses (the scene's display coordinates)
    placed : the parts at every sample
    residual : (m,) max |C| after the projection onto the constraints
    eigenvalue : s of the mode
    period : real period 2 pi / |Im s| (s); inf for a mode that does not oscillate
    cycles : periods in the clip (the samples of a mode that does not oscillate show its shape swinging once)
    amplitude : a (m or rad), as passed to animate
    unit : "m" (the largest displacement is a translation) or "rad"
    reduced : the amplitude was reduced so the projection converged
    still : the sample shown when the animation is off (largest displacement)
    rigid : a rigid-body mode (s = 0), shown as its shape swinging
    """

    key: Any
    mode: int
    fraction: float
    t: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    placed: Any
    residual: np.ndarray
    eigenvalue: complex
    period: float
    cycles: int
    amplitude: float
    unit: str
    reduced: bool
    still: int
    rigid: bool = False

    @property
    def oscillates(self) -> bool:
        return math.isfinite(self.period)

    @classmethod
    def of(cls, key: Any, mode: int, fraction: float, animated: Animated, positions: np.ndarray,
           orientations: np.ndarray, parts: Any, *, rigid: bool = False) -> Clip:
        """The clip of ``animated`` (:func:`animate_group`) with the body poses ``positions``, ``orientations``
        (m, n, 3), (m, n, 4) as the scene draws them, ``parts`` placed at them.

        Raises
        ------
        ValueError
            When a pose is not finite (the animation left the finite range).
        """
        for name, arr in (("positions", positions), ("orientations", orientations)):
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name}: the animation of mode {mode} left the finite range")
        a = animated
        return cls(key, mode, fraction, ro(a.t), ro(positions), ro(orientations), parts.place(positions, orientations),
                   ro(a.residual), a.eigenvalue, a.period, a.cycles, float(a.amplitude), a.unit, a.reduced, a.still,
                   bool(rigid))


@dataclasses.dataclass(frozen=True)
class SolutionArrays(ModalStatus):
    """The eigen solution of one parameter set, as a panel shows it (picklable, read-only arrays); a scene's
    ``Solution`` adds what it draws and says of its model.

    Attributes
    ----------
    key : what the job solved (the modes scene's ``Params``, the Model scene's ``Key``)
    eigenvalues : (k,) complex, sorted as :class:`rigidlab.core.modal.Modes` (pairs adjacent, +Im first)
    omega_n, damping_ratio, frequency_hz : (k,) rad/s, -, Hz
    stable, critical, rigid : (k,) bool
    method : "symmetric" or "state-space"
    groups : the selectable modes: eigenvalue indices of each, the +Im member first
    n_dof, n_bodies : degrees of freedom, bodies
    parts : what is drawn
    ghost : the reference configuration, placed (one instant)
    ghost_R, ghost_P : (n, 3), (n, 4) the reference's body poses, as drawn
    csv, json : :meth:`rigidlab.core.modal.Modes.to_csv` and a JSON document of the modes
    """

    key: Any
    eigenvalues: np.ndarray
    omega_n: np.ndarray
    damping_ratio: np.ndarray
    frequency_hz: np.ndarray
    stable: np.ndarray
    critical: np.ndarray
    rigid: np.ndarray
    method: str
    groups: tuple[tuple[int, ...], ...]
    n_dof: int
    n_bodies: int
    parts: Any
    ghost: Any
    ghost_R: np.ndarray
    ghost_P: np.ndarray
    csv: str
    json: str


def solution_arrays(key: Any, modes: Any, groups: tuple[tuple[int, ...], ...], n_dof: int, parts: Any,
                    R: np.ndarray, P: np.ndarray, doc: dict) -> dict[str, Any]:
    """The fields of :class:`SolutionArrays` (keyword arguments) of :class:`rigidlab.core.modal.Modes`
    ``modes``: the reference drawn at body poses ``R``, ``P`` (1, n, 3), (1, n, 4); ``doc`` the JSON document
    without its ``"modes"``, which this adds."""
    m = modes
    doc = {**doc, "modes": json.loads(m.to_json())}
    return dict(key=key, eigenvalues=ro(m.eigenvalues, complex), omega_n=ro(m.omega_n),
                damping_ratio=ro(m.damping_ratio), frequency_hz=ro(m.frequency_hz), stable=ro(m.stable, bool),
                critical=ro(m.critical, bool), rigid=ro(m.rigid, bool), method=m.method, groups=groups,
                n_dof=int(n_dof), n_bodies=int(m.embedding.n_bodies), parts=parts, ghost=parts.place(R, P),
                ghost_R=ro(R[0]), ghost_P=ro(P[0]), csv=m.to_csv(), json=json.dumps(doc, allow_nan=False))


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


class SweepRun:
    """A sweep in a thread of this process that only waits: :func:`rigidlab.core.modal.sweep` of ``build`` over
    ``values``, its values reaching ``executor`` one at a time (:class:`Throttled`), so a job the scene submits
    meanwhile is not queued behind the whole sweep.

    Once the sweep is done, ``finish(run, result, executor)`` (in this thread; ``executor`` the throttled one,
    for more work such as root finding, see :meth:`wait`) makes :attr:`outcome`, what the scene shows. Setting
    :attr:`cancel` stops the sweep at the next value; :attr:`finished` is set when the thread is done, with
    :attr:`outcome` or :attr:`error` (None both when cancelled); :attr:`done` of :attr:`total` values are
    computed.
    """

    def __init__(self, key: Any, build: Callable[[float], Any], values: np.ndarray,
                 executor: concurrent.futures.Executor, finish: Callable[[SweepRun, Any, Any], Any], *,
                 name: str = "rigidlab-sweep") -> None:
        self.key = key
        self.values = values
        self.total, self.done = int(values.size), 0
        self.cancel = threading.Event()
        self.finished = threading.Event()
        self.outcome: Any = None
        self.error: BaseException | None = None
        self.seconds = 0.0
        self._executor = executor
        self._wall0 = time.perf_counter()
        threading.Thread(target=self._run, args=(build, finish), name=name, daemon=True).start()

    def elapsed(self) -> float:
        """Wall seconds since the sweep started."""
        return time.perf_counter() - self._wall0

    def wait(self, future: concurrent.futures.Future) -> Any:
        """The result of ``future``; raises :class:`Cancelled` (and cancels it) when the sweep is cancelled first."""
        while not future.done():
            if self.cancel.wait(0.05):
                future.cancel()
                raise Cancelled()
        return future.result()

    def _progress(self, done: int, total: int) -> None:
        self.done = done
        if self.cancel.is_set():
            raise Cancelled()

    def _run(self, build: Callable[[float], Any], finish: Callable[[SweepRun, Any, Any], Any]) -> None:
        from rigidlab.core.modal import sweep

        throttled = Throttled(self._executor, 1)
        try:
            result = sweep(build, self.values, executor=throttled, progress=self._progress)
            self.outcome = finish(self, result, throttled)
        except Cancelled:
            pass
        except Exception as exc:  # reported by the scene
            self.error = exc
        finally:
            self.seconds = self.elapsed()
            throttled.shutdown()
            self.finished.set()


class ModalResults:
    """A scene's modal jobs on the loop thread: the one job queued or running (:attr:`job`, ``(want, future)``
    with ``want = (key, mode, fraction)``), and what the jobs gave, kept: the solutions per key and the clips
    per ``(key, mode, fraction)``, the last ``kept`` of each."""

    def __init__(self, kept: int = 24) -> None:
        self.kept = int(kept)
        self.solutions: collections.OrderedDict[Any, Any] = collections.OrderedDict()
        self.clips: collections.OrderedDict[tuple[Any, int, float], Clip] = collections.OrderedDict()
        self.job: tuple[tuple[Any, int, float], concurrent.futures.Future] | None = None

    def lookup(self, want: tuple[Any, int, float]) -> tuple[tuple[Any, int, float], tuple[Any, Clip] | None]:
        """``(want, shown)``: ``want`` with its mode clamped to the kept solution's (a mode beyond its last: the
        last), and ``(solution, clip)`` when both are kept, else None."""
        key, mode, fraction = want
        solution = self.solutions.get(key)
        if solution is None:
            return want, None
        want = (key, min(max(mode, 1), min(len(solution.groups), MAX_MODES)), fraction)
        clip = self.clips.get(want)
        return want, None if clip is None else (solution, clip)

    def submit(self, executor: concurrent.futures.Executor, want: tuple[Any, int, float],
               fn: Callable[..., Any], *args: Any) -> bool:
        """Submit ``fn(*args)``, the job of ``want``, unless a job is queued or running (one at a time: while a
        slider is dragged, each job takes the value it has when the one before is done); False when nothing was
        submitted (also when the executor is shut down, as the app stops)."""
        if self.job is not None:
            return False
        try:
            future = executor.submit(fn, *args)
        except RuntimeError:  # the executor is shut down
            return False
        self.job = (want, future)
        return True

    def take(self) -> tuple[tuple[Any, int, float], Any, BaseException | None] | None:
        """``(want, result, None)`` or ``(want, None, error)`` of the job once it is done, else None (also for a
        cancelled job); a result (with ``solution`` and ``clip``) is kept."""
        if self.job is None or not self.job[1].done():
            return None
        want, future = self.job
        self.job = None
        if future.cancelled():
            return None
        exc = future.exception()
        if exc is not None:
            return want, None, exc
        result = future.result()
        clip = result.clip
        remember(self.solutions, result.solution.key, result.solution, self.kept)
        remember(self.clips, (clip.key, clip.mode, clip.fraction), clip, self.kept)
        if want[1] != clip.mode:  # a mode number beyond this model's: the last one
            remember(self.clips, want, clip, self.kept)
        return want, result, None

    def cancel(self) -> None:
        """Cancel the job queued or running."""
        if self.job is not None:
            self.job[1].cancel()


class ProgressBar:
    """A sweep's progress bar (a viser progress-bar handle): shown while a sweep runs, sent when it moved by
    1 % (or reached 100 %)."""

    def __init__(self, handle: Any) -> None:
        self.handle = handle
        self._shown = -1.0

    def set(self, value: float | None) -> None:
        """Show ``value`` (percent), or hide the bar (None)."""
        bar = self.handle
        if value is None:
            if bar.visible:
                bar.visible = False
            self._shown = -1.0
            return
        if not bar.visible:
            bar.visible = True
        if abs(value - self._shown) >= 1.0 or (value >= 100.0 and self._shown < 100.0):
            bar.value = float(min(max(value, 0.0), 100.0))
            self._shown = value


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


def mode_status(solution: Any, clip: Clip, cycle: float, *, animate: bool = True) -> str:
    """The chosen mode in a few lines (Markdown): f, ω_n, ξ and stability (Eqs. 8.130-8.131), how the clip shows
    it (``cycle`` seconds per period on screen), the amplitude a and the constraint residual after the
    projection; ``animate`` False: the still sample is shown."""
    i = solution.groups[clip.mode - 1][0]
    s = clip.eigenvalue
    lines = [f"**Mode {clip.mode}** of {min(len(solution.groups), MAX_MODES)}: f = "
             f"{sig(float(solution.frequency_hz[i]))} Hz · ω_n = {sig(float(solution.omega_n[i]))} rad/s · "
             f"ξ = {xi_text(float(solution.damping_ratio[i]))} · {STATUS_TEXT[solution.status(i)]}"]
    if clip.rigid:
        line = "**rigid-body mode** (s = 0): no restoring force; its shape is shown swinging"
    elif clip.oscillates:
        ratio = cycle / clip.period
        speed = f"{sig(ratio, 3)}× slower" if ratio >= 1 else f"{sig(1 / ratio, 3)}× faster"
        line = (f"period {sig(clip.period, 3)} s, shown in {cycle:g} s ({speed})"
                + (f", {clip.cycles} periods per loop" if clip.cycles > 1 else ""))
        if abs(s.real) * clip.period >= 1e-3:
            line += f"; the amplitude {'grows' if s.real > 0 else 'decays'} as e^({sig(s.real, 3)} t)"
    else:
        line = (f"does not oscillate: s = {sig(s.real, 3)} 1/s (the shape {'grows' if s.real > 0 else 'decays'} "
                "as e^(st)); its shape is shown swinging")
    lines.append(line)
    what = "largest translation" if clip.unit == "m" else "largest rotation"
    amp = f"a = {sig(clip.amplitude, 3)} {clip.unit} ({what})"
    if clip.reduced:
        amp += ", reduced so that the projection onto the constraints converges"
    lines.append(amp + f"; max |C| after projection {float(np.max(clip.residual)):.0e}")
    if not animate:
        lines.append("*animation off: the largest displacement is shown*")
    return "  \n".join(lines)


def mode_label(solution: Any, clip: Clip) -> str:
    """The 3-D label of the mode shown: "mode 2: 1.234 Hz", and whether it is unstable or a rigid-body mode."""
    i = solution.groups[clip.mode - 1][0]
    text = f"mode {clip.mode}: {sig(float(solution.frequency_hz[i]))} Hz"
    if solution.status(i) in ("unstable", "mirrored"):
        text += " (unstable)"
    elif clip.rigid:
        text += " (rigid-body mode)"
    return text


def set_label(handle: Any, text: str) -> None:
    """Write ``text`` on the 3-D label ``handle`` when it changed (viser 1.1.1's page draws a label changed while
    it is connected only once its visibility changes, so it is hidden and shown again)."""
    if handle.text != text:
        handle.text = text
        handle.visible = False
        handle.visible = True


def advance(clip: Clip, phase: float, dt: float, *, cycle: float, animate: bool) -> tuple[float, int]:
    """``(phase, i)``: the phase (0 to 1 over the clip) ``dt`` s of the display clock later (at most 0.1 s a
    frame), one period taking ``cycle`` s, and the clip's sample there; ``animate`` False: the still sample."""
    if not animate:
        return phase, clip.still
    phase = (phase + min(dt, 0.1) / (cycle * clip.cycles)) % 1.0
    return phase, min(int(phase * clip.t.size), clip.t.size - 1)


def send_mode_options(controls: Any, solution: Any, *, current: bool) -> None:
    """Make the *Mode* dropdown of ``controls`` list the rows of ``solution``'s table (:func:`mode_row`).

    ``current``: the solution is of the parameters the controls ask for; a solution shown while the controls
    move on does not move a mode number beyond its own (the next solution sets the list).
    """
    count = max(1, min(len(solution.groups), MAX_MODES))
    handle, spec = controls.handles["mode"], controls.specs["mode"]
    numbers = MODE_OPTIONS[:count]
    rows = {n: mode_row(solution, int(n)) for n in numbers} if solution.groups else {n: n for n in numbers}
    options = tuple(rows[n] for n in numbers)
    if tuple(handle.options) != options:
        value = controls.value("mode")
        if value not in numbers:
            if not current:
                return
            value = numbers[-1]
        spec.rows.clear()
        spec.rows.update(rows)
        handle.options = options  # (viser moves a value not in the options to the first one)
        controls.set("mode", value)
        if handle.value != rows[value]:
            handle.value = rows[value]


# -- sweeps ------------------------------------------------------------------------------------------------------
def live_branches(rigid: np.ndarray) -> list[int]:
    """The tracked branches (columns of a sweep's (v, k) ``rigid``) that are not rigid-body at every value."""
    return [k for k in range(rigid.shape[1]) if not np.all(rigid[:, k])]


def campbell_chart(values: np.ndarray, eigenvalues: np.ndarray, rigid: np.ndarray, x_label: str, *,
                   spin_line: bool = False, font: float = FONT) -> Chart:
    """The modes over the swept parameter: f = |Im s| / 2 pi of every tracked branch (v, k), a conjugate pair
    once (a Campbell diagram when the parameter is a spin). ``spin_line``: the swept values are a spin (rad/s),
    drawn dashed as the frequency f = Ω / 2 pi that meets a branch at a critical speed."""
    v = values
    f = np.abs(eigenvalues.imag) / (2 * math.pi)
    live = live_branches(rigid)
    top = float(np.max(f[:, live])) if live and f.size else 1.0
    chart = Chart((float(v[0]), float(v[-1])), (0.0, 1.08 * max(top, 1e-6)), x_label, "f (Hz)", font=font)
    if spin_line:
        chart.curve(v, v / (2 * math.pi), "#6b7280", width=1.2, dash="5 4")
    shown: list[np.ndarray] = []
    for k in live:
        if any(np.allclose(f[:, k], g, rtol=1e-9, atol=1e-9) for g in shown):
            continue  # the other member of a conjugate pair
        shown.append(f[:, k])
        chart.curve(v, f[:, k], CURVE_COLORS[len(shown) % len(CURVE_COLORS)], width=1.8)
    if spin_line:
        x_label_at = min(float(v[-1]), 2 * math.pi * top)
        chart.text(x_label_at, x_label_at / (2 * math.pi), "1× (f = Ω/2π)", color="#4b5563", anchor="end", dx=-4,
                   dy=-6)
    return chart


def root_locus_chart(eigenvalues: np.ndarray, rigid: np.ndarray, *, font: float = FONT) -> Chart:
    """The tracked eigenvalues (v, k) of a sweep in the complex plane, one curve a branch, a small ring at the
    first value; the unstable half shaded."""
    ev = eigenvalues
    live = live_branches(rigid)
    re, im = ev.real[:, live], ev.imag[:, live]
    y = 1.1 * max(float(np.max(np.abs(im))) if im.size else 1.0, 1e-3)
    lo = min(0.0, float(np.min(re))) if re.size else 0.0
    hi = max(0.0, float(np.max(re))) if re.size else 0.0
    span = max(hi - lo, 0.15 * y)
    mid = 0.5 * (lo + hi)
    chart = Chart((mid - 0.6 * span, mid + 0.6 * span), (-y, y), "Re s (1/s)", "Im s (rad/s)", font=font)
    chart.shade_right_half("#fdecea")
    for n, k in enumerate(live):
        color = CURVE_COLORS[n % len(CURVE_COLORS)]
        chart.curve(ev.real[:, k], ev.imag[:, k], color, width=1.6, opacity=0.85)
        chart.points([ev.real[0, k]], [ev.imag[0, k]], color, radius=2.5, hollow=True)
    return chart


def mark_campbell(chart: Chart, value: float, solution: Any | None) -> Chart:
    """A copy of ``chart`` (:func:`campbell_chart`) with the value in use ``value`` as a purple line and, with
    ``solution`` (solved at that value), its modes' frequencies on it."""
    chart = chart.copy()
    chart.vline(value, SELECTED_COLOR)
    if solution is not None:
        live = [g[0] for g in solution.groups if not solution.rigid[g[0]]]
        chart.points(np.full(len(live), value), solution.frequency_hz[live], SELECTED_COLOR, radius=3.5)
    return chart


def mark_root_locus(chart: Chart, solution: Any) -> Chart:
    """A copy of ``chart`` (:func:`root_locus_chart`) with the eigenvalues of ``solution`` (solved at the value in
    use) as purple points."""
    chart = chart.copy()
    idx = [i for g in solution.groups if not solution.rigid[g[0]] for i in g]
    chart.points(solution.eigenvalues.real[idx], solution.eigenvalues.imag[idx], SELECTED_COLOR, radius=4.5,
                 stroke="#ffffff")
    return chart
