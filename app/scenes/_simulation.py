"""The timed scenes' one pipeline: :class:`SimulationScene`.

A timed scene (a motion computed by core and played on a clock) declares
four things and gets the rest from this layer:

* ``Inputs`` -- a frozen dataclass whose fields are the keys of the
  controls the motion depends on (a change of any of them starts the
  motion again from t = 0);
* :meth:`SimulationScene.job` -- one line: a picklable callable
  ``compute(k, previous) -> chunk`` (a ``functools.partial`` of a
  module-level function that calls core) for chunk ``k`` of a segment;
* :meth:`SimulationScene.plots` -- :class:`PlotSpec` s: a title, the
  series' labels and colours, and a function of the window's table columns;
* :meth:`SimulationScene.draw` -- the poses of the sample drawn
  (``draw(chunk, j)``, inside ``target.atomic()``).

The layer owns the clock (:class:`rigidlab.app.scenes._playback.Playback`: play,
pause, reset, time scale, presets), the chunk timeline on the app's
executor (:class:`rigidlab.app.jobs.ChunkTimeline`), the history of the chunks
reached (:class:`rigidlab.app.scenes._plots.History`), the plot refresh spread over
frames (:class:`rigidlab.app.scenes._plots.PlotRefresh`), error notices, the
real-time-rate readout and the CSV export of the plotted window.

Chunks
------
A chunk is any object with ``k`` (its index), ``t`` ((n,) sample times,
display time, increasing) and ``table`` (:class:`rigidlab.app.scenes._plots.Table`);
optionally ``final`` (True: the motion ends at ``t[-1]``, e.g. a fall),
``end`` (why, shown once in a notice) and ``failure`` (a non-fatal message
shown once, e.g. a ghost integrator that stopped). Chunk ``k`` of a segment
covers ``[t0 + k T, t0 + (k + 1) T]`` of display time, ``T`` =
:attr:`chunk_time`.

Segments
--------
A motion is one segment from t = 0 until the scene continues it from a state
it reached (:meth:`continue_from`: the bicycle's push starts a new segment at
the state shown, from core's ``final_state``); the clock runs on. The segment
from t = 0 carries :meth:`initial_extra` (the bicycle's push at the start).

Rate
----
:attr:`real_time_rate` is simulated seconds per wall second over the last
:data:`RATE_WINDOW` seconds while playing; when it stays below
:data:`RATE_SHORTFALL` of the time scale, the readout says the rate the scene
actually runs at (a busy server, or chunks that take longer than they last).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import math
from collections.abc import Callable, Sequence
from concurrent.futures import CancelledError
from typing import Any, ClassVar

import numpy as np

from rigidlab.app.jobs import ChunkTimeline
from rigidlab.app.nodes import set_plot_data
from rigidlab.app.scenes._playback import Playback, PlaybackRequests
from rigidlab.app.readout import significant
from rigidlab.app.scenes._plots import History, Legend, PlotRefresh, capped_range
from rigidlab.app.scenes.base import Scene

__all__ = ["InputsRefused", "PlotSpec", "Segment", "SimulationScene", "RATE_WINDOW", "RATE_SHORTFALL", "power_of_ten"]

#: Wall seconds over which the real-time rate is measured.
RATE_WINDOW = 2.0
#: The readout reports the rate when it is below this fraction of the time scale.
RATE_SHORTFALL = 0.9


class InputsRefused(ValueError):
    """Raised by a scene's job (or :meth:`SimulationScene.check_inputs`) for inputs that cannot run together,
    with the reason in the panel's terms: the layer then sets the controls back to the inputs whose motion ran
    last and says why in a notice titled :attr:`SimulationScene.refusal_title`, as for a refusal on the loop
    thread. A check too slow for a frame's budget (building core's model) runs in the job this way."""


@dataclasses.dataclass(frozen=True)
class PlotSpec:
    """One plot of a timed scene.

    Attributes
    ----------
    name : key of the plot (``scene.plot_handles[name]``)
    title : shown above the plot
    series : ``(label, colour)`` of each y series (CSS colours), or ``(label, colour, options)`` with
        more uPlot series options (e.g. ``{"dash": [6, 4]}``)
    data : ``data(t, columns) -> tuple of (n,) arrays``, one per series, from
        the plotted window's times ``t`` (n,) and table columns (n, m)
    shown : ``shown(inputs) -> bool``: whether the plot is shown for these
        inputs (None: always)
    rescale : divide the y series by a power of ten when the window's largest
        ``|y|`` is below 0.01 or from 1e5 on, and say so in the title
        (``"... [×1e-09]"``): uPlot writes tick labels with at most three
        decimals, so a drift of 1e-9 would read "0" at every tick
    x : ``x(t, columns) -> (n,) array``: the x values (None: ``t``), e.g. an
        angle for a plot over one period
    per_chunk : True: the plot shows the whole chunk drawn (its table: one
        period of a periodic motion, one revolution of a run), sent again
        only when the chunk's table changes; False: the plotted window
    table : ``table(chunk) -> Table``, with ``per_chunk``: the table of the
        chunk drawn that the plot shows (None: ``chunk.table``), e.g. the
        closed form a run's chunk is compared with
    capped : the y range keeps the first series readable beside short peaks
        of the last one far above it (:func:`rigidlab.app.scenes._plots.capped_range`,
        e.g. a landing's impact against a closed form); a peak cut off is
        named in the last series' label (``"..., peak 1234 off scale"``)
    """

    name: str
    title: str
    series: tuple[tuple[Any, ...], ...]
    data: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, ...]]
    shown: Callable[[Any], bool] | None = None
    x_label: str = "t (s)"
    aspect: float = 1.6
    rescale: bool = False
    x: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    per_chunk: bool = False
    #: None: uPlot's own y range; a number: the y axis follows the window's data, at least this tall (a flat
    #: series gets a small axis about its value, not uPlot's 0-100)
    y_span: float | None = None
    table: Callable[[Any], Any] | None = None
    capped: bool = False


def power_of_ten(series: Sequence[np.ndarray]) -> int:
    """The exponent ``e`` a :class:`PlotSpec` with ``rescale`` divides its series by (``10**e``): 0 while the
    largest finite ``|y|`` is in [0.01, 1e5) or zero, else ``floor(log10(max |y|))``."""
    finite = [np.abs(y[np.isfinite(y)]) for y in series]
    top = max((float(y.max()) for y in finite if y.size), default=0.0)
    if top == 0.0 or 0.01 <= top < 1e5:
        return 0
    return math.floor(math.log10(top))


@dataclasses.dataclass(frozen=True)
class Segment:
    """Where a stretch of chunks starts.

    Attributes
    ----------
    index : counts the segments since the last restart (0: from t = 0)
    t0 : display time at the segment's start (s)
    start : what the job continues from (None: the motion's initial state),
        e.g. core's ``final_state`` (picklable)
    extra : anything else the scene's job needs for this segment (e.g. a push)
    """

    index: int = 0
    t0: float = 0.0
    start: Any = None
    extra: Any = None


class SimulationScene(PlaybackRequests, Scene):
    """A scene whose motion core computes in chunks and the layer plays on a clock (module docstring)."""

    #: Frozen dataclass of the control values the motion depends on (field names = control keys).
    Inputs: ClassVar[type]
    #: Preset names, in button order (:meth:`preset_values` gives each one's control values).
    presets: ClassVar[tuple[str, ...]] = ()
    #: Simulated seconds per chunk.
    chunk_time: ClassVar[float] = 1.0
    #: Whether chunk k continues from chunk k - 1 (else chunks are independent).
    sequential: ClassVar[bool] = True
    #: Chunks the timeline keeps for a replay.
    chunks_kept: ClassVar[int] = 8
    #: How far into a chunk the clock is when the next chunk is asked for (0: at once).
    ask_ahead: ClassVar[float] = 0.0
    #: Wall seconds between refreshes of the readout and the plots.
    refresh_period: ClassVar[float] = 0.25
    #: Length of the plotted (and exported) window, s.
    window: float = 10.0
    #: CSV header: one line, column names with units (t first).
    csv_header: ClassVar[str] = ""
    #: Title of the notice when :meth:`check_inputs` refuses the inputs (lower case: the start of the
    #: refusal of a loaded state, :meth:`values_refusal`).
    refusal_title: ClassVar[str] = "Invalid values"
    #: Whether :meth:`check_inputs` fits in a frame's budget (p99 2 ms, max 8 ms): the layer then calls it on the
    #: loop thread at each change; else only off the loop (before a state loads), and the job raises
    #: :class:`InputsRefused` for the inputs it refuses.
    check_on_loop: ClassVar[bool] = True

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.playback = Playback(self.presets, controls=self.controls)
        self._input_keys = frozenset(f.name for f in dataclasses.fields(self.Inputs))
        self.timeline = ChunkTimeline(self.executor, self._no_job, chunk_time=self.chunk_time,
                                      sequential=self.sequential, capacity=self.chunks_kept)
        self.history = History()
        # owned by the loop thread
        self.segment = Segment()
        self.config: Any = None  # the Inputs in use (None until the first frame)
        self._ran: Any = None  # the Inputs of the last motion drawn (kept when a job refuses newer ones)
        self.sim_time = 0.0  # display clock (s)
        self.local_time = 0.0  # clock within the segment (s)
        self.display_time = 0.0  # time of the sample drawn (s)
        self.waiting = False  # the clock holds: the chunk it needs is not ready
        self.ended = False  # the motion ended itself (a final chunk reached)
        self.last_chunk: Any = None
        #: The refresh (``"readout"`` or a plot's name) sent in this frame after :meth:`draw`, or None: a scene
        #: may hold back sends of its own (a traced curve) in a frame that already sends a plot.
        self.refresh_due: str | None = None
        self.plot_handles: dict[str, Any] = {}
        self.status: Any = None  # the layer's readout (time, rate, the scene's lines)
        self._specs: tuple[PlotSpec, ...] = ()
        self._refresh = PlotRefresh(("readout",), self.refresh_period)
        self._plot_window: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros((0, 0)))
        self._chunk_plotted: dict[str, Any] = {}  # per-chunk plot -> the table it shows
        self._y_ranges: dict[int, list[float]] = {}
        self._drawn: tuple | None = None
        self._refreshed_time = -1.0
        self._reported: set[str] = set()
        self._error_paused = False  # an error stopped the running clock (a change of the inputs restarts it)
        self._timeline_inputs: Any = None  # the inputs of the timeline's chunks (None: not a motion from t = 0)
        self._rate: collections.deque[tuple[float, float]] = collections.deque()
        self._rate_sums = [0.0, 0.0]  # wall and simulated seconds in self._rate (running sums: O(1) a frame)
        self.real_time_rate = math.nan
        self.side_jobs: dict[str, Any] = {}  # key -> future of a job beside the motion (submit_side_job)

    @staticmethod
    def _no_job(k: int, previous: Any) -> Any:  # pragma: no cover - replaced at the first frame
        raise RuntimeError("the scene's job is set at its first frame")

    # -- what a scene declares ---------------------------------------------------------------------
    def job(self, inputs: Any, segment: Segment) -> Callable[[int, Any], Any]:  # pragma: no cover - abstract
        """``compute(k, previous) -> chunk`` for ``inputs`` from ``segment`` (picklable; runs on the executor)."""
        raise NotImplementedError

    def build_nodes(self) -> None:  # pragma: no cover - abstract
        """Create the scene's nodes under ``self.root`` (once)."""
        raise NotImplementedError

    def build_controls(self) -> None:
        """Add the scene's controls, legend and readouts inside its folder; :meth:`add_playback` and
        :meth:`add_presets` place the layer's (called after the status readout is placed)."""

    def plots(self) -> Sequence[PlotSpec]:
        """The scene's plots (made once, in :meth:`plot_area`)."""
        return ()

    def draw(self, chunk: Any, j: int) -> None:  # pragma: no cover - abstract
        """Send the poses of sample ``j`` of ``chunk`` (inside ``target.atomic()``; loop thread)."""
        raise NotImplementedError

    def check_inputs(self, inputs: Any) -> None:
        """Hook: raise ValueError (naming the argument) when ``inputs`` cannot run together (each control's
        value passed its own check); the layer then keeps the motion in use, sets the controls back to it
        and says why in a notice titled :attr:`refusal_title`. Also checks a state before it loads (off the loop
        thread). A check too slow for a frame (:attr:`check_on_loop` False) runs only there; the job then raises
        :class:`InputsRefused` itself."""

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            self.check_inputs(self.Inputs(**{key: values[key] for key in self._input_keys}))
        except ValueError as exc:
            return f"{self.refusal_title.lower()}: {exc}"
        return None

    def preset_values(self, name: str) -> dict[str, Any]:
        """Control values of preset ``name`` (set before the motion restarts)."""
        return {}

    def on_configure(self, inputs: Any) -> None:
        """Hook: the motion restarts with new ``inputs`` (visibility of nodes, label texts)."""

    def initial_extra(self) -> Any:
        """Hook: ``extra`` of the segment from t = 0 (e.g. the bicycle's push at the start; None by default).
        A restart replays the chunks it holds only while inputs and this are the same."""
        return None

    def on_restart(self) -> None:
        """Hook: the clock goes back to t = 0 (clear trails)."""

    def readout_lines(self) -> list[str]:
        """Hook: the scene's lines of the status readout (refreshed with the plots)."""
        return []

    def plot_title(self, spec: PlotSpec) -> str:
        """Hook: the title of plot ``spec`` now (default ``spec.title``; e.g. with an offset the data
        subtract); sent when it changes."""
        return spec.title

    def end_notice(self, chunk: Any) -> tuple[str, str]:
        """Title and text of the notice when the motion ends itself (a final chunk)."""
        return "The motion ended", f"{getattr(chunk, 'end', '')}. Press Reset or change a control."

    def on_error(self, error: BaseException) -> bool:
        """Hook: a chunk's job raised ``error``; True when the scene handled it (no notice, the clock runs on)."""
        return False

    def time_text(self) -> str:
        """Hook: the readout's first line (the time shown)."""
        return f"**t** = {self.display_time:.2f} s"

    def background(self) -> None:
        """Hook: once per frame after the clock moved, for side jobs (modes, sweeps): :meth:`submit_side_job`."""

    # -- side jobs --------------------------------------------------------------------------------------
    def submit_side_job(self, key: str, fn: Callable[..., Any], /, *args: Any) -> None:
        """Run ``fn(*args)`` on the scene's executor beside the motion (modes, a sweep); :meth:`side_results`
        hands the result back on the loop thread. ``key`` names the job in a notice if it fails."""
        self.side_jobs[key] = self.executor.submit(fn, *args)

    def side_results(self) -> list[tuple[str, Any]]:
        """``(key, result)`` of the side jobs finished since the last call, in submission order; one that
        raised (or was cancelled) is dropped with a warning notice naming its key and the error."""
        finished = []
        for key, future in list(self.side_jobs.items()):
            if not future.done():
                continue
            del self.side_jobs[key]
            error = CancelledError() if future.cancelled() else future.exception()
            if error is None:
                finished.append((key, future.result()))
            else:
                self.notify(f"{key} not computed", f"{type(error).__name__}: {error}", "warning")
        return finished

    # -- building -----------------------------------------------------------------------------------
    def build(self) -> None:
        self.make_root()
        self.build_nodes()
        with self.make_folder():
            self.build_controls()
            if self.status is None:
                self.add_playback()
            self._specs = tuple(self.plots())
            if self._specs:
                with self.plot_area():
                    for spec in self._specs:
                        n = len(spec.series)
                        self.plot_handles[spec.name] = self.add_plot(
                            (np.zeros(2),) * (n + 1),
                            ({"label": spec.x_label},
                             *({"label": s[0], "stroke": s[1], "width": 2, **(s[2] if len(s) > 2 else {})}
                               for s in spec.series)),
                            title=spec.title, scales={"x": {"time": False}}, aspect=spec.aspect,
                        )
            if self.csv_header:
                self.add_download("download_csv", "Download CSV", f"{self.name}.csv", self.csv_bytes,
                                  hint="the samples of the plotted window, up to the time shown")
        self._refresh = PlotRefresh(("readout", *(s.name for s in self._specs)), self.refresh_period)

    def add_playback(self, *, time_scale: bool = True) -> None:
        """The Play / Pause / Reset row, the time scale and the status readout, here in the folder
        (``time_scale`` False: no time-scale slider, the scene sets the scale: :meth:`Playback.add_gui`)."""
        self.playback.add_gui(time_scale=time_scale)
        self.status = self.add_readout("Computing the motion…")

    def add_legend(self, items: Sequence[tuple[Sequence[int], str]], title: str = "") -> Legend:
        """The colour key of the scene's arrows and curves (:class:`rigidlab.app.scenes._plots.Legend`), here in the
        folder; it grows in presenter view. Give it the colour constants the nodes are drawn with."""
        legend = Legend(self.target.gui, items, title, presenter=self.presenter)
        self._readouts.append(legend)  # type: ignore[arg-type]  # (set_presenter, as a readout has)
        return legend

    def add_presets(self) -> None:
        """The preset buttons, here in the folder."""
        self.playback.add_preset_buttons()

    # -- read by tests and notebooks ------------------------------------------------------------
    @property
    def inputs(self) -> Any:
        """The values of the controls in use, as ``Inputs``."""
        values = self.controls.values()
        return self.Inputs(**{key: values[key] for key in self._input_keys})

    # -- the clock ------------------------------------------------------------------------------------
    def configure(self, inputs: Any) -> None:
        """Use ``inputs``: the motion again from t = 0 (or refuse them: :meth:`check_inputs`)."""
        try:
            if self.check_on_loop:
                self.check_inputs(inputs)
        except ValueError as exc:
            kept = self._set_back(exc, self.config)
            if self.config is not None:
                return
            inputs = kept
        self.config = inputs
        self._reported = set()
        resume, self._error_paused = self._error_paused, False
        self.on_configure(inputs)
        self.restart()
        if resume:  # the failed motion had stopped a running clock: the notice promised a change runs it again
            self.playback.set_playing(True)
        for spec in self._specs:
            if spec.shown is not None:
                self.plot_handles[spec.name].visible = bool(spec.shown(inputs))

    def _set_back(self, refusal: ValueError, kept: Any) -> Any:
        """Say why the inputs are refused and set the controls back to ``kept`` (None: the defaults)."""
        self.notify(self.refusal_title, f"{refusal}. Keeping the previous values (the controls are set back).",
                    "warning")
        kept = kept if kept is not None else self.Inputs()
        self.controls.set_many(dataclasses.asdict(kept))
        return kept

    def restart(self) -> None:
        """The motion from t = 0 (chunks of the same inputs and :meth:`initial_extra` are reused)."""
        self._start(Segment(extra=self.initial_extra()))
        self.sim_time = 0.0
        self.history.clear()
        self._refreshed_time = -1.0
        self._refresh.force()
        self.on_restart()

    def continue_from(self, start: Any, extra: Any = None) -> None:
        """A new segment from ``start`` (core's ``final_state`` of the sample shown) at the time shown."""
        self._start(Segment(self.segment.index + 1, self.display_time, start, extra))
        self.sim_time = self.display_time

    def _start(self, segment: Segment) -> None:
        # a restart of the motion the timeline holds (same inputs, from t = 0) replays its chunks (and stops
        # again where it failed); anything else starts a new timeline
        replay = (segment.index == 0 and self.segment.index == 0 and self._timeline_inputs == self.config
                  and segment.extra == self.segment.extra)
        self.segment = segment
        if not replay:
            self.timeline.reset(self.job(self.config, segment))
            self._timeline_inputs = self.config if segment.index == 0 else None
            self._reported.discard("error")
        self.local_time = 0.0
        self.ended = False
        self._drawn = None
        self._reported.discard("end")

    def update(self, dt: float) -> None:
        self.tick_labels()
        preset = self.playback.take_preset()
        changed = self.controls.take_changes()
        if preset is not None:
            self.controls.set_many(self.preset_values(preset))
            self.playback.set_playing(True)
        if self.config is None or preset is not None or changed & self._input_keys:
            inputs = self.inputs
            if inputs != self.config or preset is not None:
                self.configure(inputs)
        if changed - self._input_keys:
            self._drawn = None  # a display control changed (arrows, trails): the sample is drawn again, also paused
        self.on_frame(changed)
        tick = self.playback.tick(dt)
        if tick.reset:
            ended = self.ended
            self.restart()
            if ended:
                self.playback.set_playing(True)
        step = 0.0 if self.ended else tick.step
        here = self.timeline.chunk_at(self.local_time, ahead=self.ask_ahead)
        if here is not None and getattr(here, "final", False):
            step = min(step, max(0.0, float(here.t[-1]) - self.sim_time))
        before = self.local_time
        self.local_time, chunk, self.waiting = self.timeline.advance(self.local_time, step)
        self.sim_time = self.segment.t0 + self.local_time
        self._measure_rate(dt, self.local_time - before, tick.step > 0.0 or self.waiting)
        error = self.timeline.error
        if error is not None and "error" not in self._reported:
            self._reported.add("error")
            if isinstance(error, InputsRefused):
                self.configure(self._set_back(error, self._ran))
            elif not self.on_error(error):
                self._error_paused = self.playback.playing  # (a clock paused by hand stays paused)
                self.playback.set_playing(False)
                self.notify(f"{self.title}: motion stopped",
                            f"{type(error).__name__}: {error}. The motion stops at t = {self.sim_time:.2f} s; "
                            "change a control to run it again.", "warning")
        self.background()
        if chunk is not None:
            self._frame(chunk, dt)
        elif self.status is not None and self._drawn is None:
            self.status.content = "Computing the motion…"

    def on_frame(self, changed: set[str]) -> None:
        """Hook: once per frame after the inputs were applied (``changed``: the control keys changed), before
        the clock moves (requests such as a push)."""

    def _measure_rate(self, dt: float, advanced: float, running: bool) -> None:
        rate, sums = self._rate, self._rate_sums
        if not running or not self.playback.playing or self.ended:
            rate.clear()
            sums[:] = (0.0, 0.0)
            self.real_time_rate = math.nan
            return
        w, s = max(dt, 0.0), max(advanced, 0.0)
        rate.append((w, s))
        sums[0] += w
        sums[1] += s
        while len(rate) > 1 and sums[0] - rate[0][0] >= RATE_WINDOW:
            w, s = rate.popleft()
            sums[0] -= w
            sums[1] -= s
        if len(rate) == 1:  # (no drift of the running sums)
            sums[:] = rate[0]
        if sums[0] >= 0.5 * RATE_WINDOW:
            self.real_time_rate = max(sums[1], 0.0) / sums[0]

    def _frame(self, chunk: Any, dt: float) -> None:
        if getattr(chunk, "final", False) and self.sim_time >= float(chunk.t[-1]) - 1e-12:
            self.ended = True
            if "end" not in self._reported:
                self._reported.add("end")
                self.notify(*self.end_notice(chunk), "info")
        due = self.refresh_due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
        key = (self.sim_time, chunk.k, self.segment.index)
        if key == self._drawn:  # paused: the poses are on the page; only a last refresh may be due
            if due is not None:
                with self.target.atomic():
                    self._refresh_one(due)
            return
        self._drawn = key
        self.last_chunk, self._ran = chunk, self.config
        self.history.add(self.segment.index * 1_000_000 + chunk.k, chunk.table)
        failure = getattr(chunk, "failure", None)
        if failure is not None and failure not in self._reported:
            self._reported.add(failure)
            self.notify(f"{self.title}", failure, "warning")
        j = self.sample_index(chunk)
        self.display_time = float(chunk.t[j])
        with self.target.atomic():
            self.draw(chunk, j)
            if due is not None:
                self._refresh_one(due)

    def sample_index(self, chunk: Any) -> int:
        """The sample of ``chunk`` at or just before the clock."""
        n = int(chunk.t.size)
        return int(min(max(np.searchsorted(chunk.t, self.sim_time + 1e-9, side="right") - 1, 0), n - 1))

    def interpolated(self, chunk: Any, rows: np.ndarray, j: int) -> np.ndarray:
        """``rows`` (one a sample of ``chunk``) at the clock: linear between sample ``j`` and the next."""
        t, i = chunk.t, min(j, max(chunk.t.size - 2, 0))
        k = min(i + 1, t.size - 1)
        w = 0.0 if k == i else min(max((self.sim_time - t[i]) / (t[k] - t[i]), 0.0), 1.0)
        return (1.0 - w) * rows[i] + w * rows[k]

    # -- readout, plots, export -------------------------------------------------------------------
    def window_start(self) -> float:
        return max(0.0, self.display_time - self.window)

    @property
    def plots_current(self) -> bool:
        """The readout and the plots have been sent for the time shown (paused, nothing more is sent)."""
        return self._refreshed_time == self.sim_time and not self._refresh.queued and self.refresh_due is None

    def rate_text(self) -> str | None:
        """The readout's line on the rate, when the scene runs slower than the time scale asks."""
        rate, scale = self.real_time_rate, self.playback.time_scale
        if not math.isfinite(rate) or rate >= RATE_SHORTFALL * scale:
            return None
        cause = "waiting for the computation" if self.waiting else "the server cannot keep up"
        return f"**Running at {rate:.2f}× real time** ({cause}; Time scale asks {scale:g}×)"

    def _refresh_one(self, what: str) -> None:
        if what == "readout":
            # the readout opens each refresh cycle: the plots of the cycle show the window as it is now
            self._refreshed_time = self.sim_time
            self._plot_window = self.history.trimmed_window(self.window_start(), self.display_time)
            if self.status is not None:
                self.status.content = self.readout_text()
            return
        spec = next(s for s in self._specs if s.name == what)
        if spec.shown is not None and not spec.shown(self.config):
            return
        t, columns = self._plot_window
        if spec.per_chunk:
            table = self.last_chunk.table if spec.table is None else spec.table(self.last_chunk)
            if self._chunk_plotted.get(what) is table:
                return
            self._chunk_plotted[what] = table
            t, columns = table.t, table.columns
        if t.size == 0:
            return
        series = tuple(np.asarray(y, dtype=float) for y in spec.data(t, columns))
        title = self.plot_title(spec)
        if spec.rescale:
            e = power_of_ten(series)
            if e:
                series = tuple(y / 10.0**e for y in series)
                title = f"{title} [×1e{e:+03d}]"
        handle = self.plot_handles[what]
        if handle.title != title:
            handle.title = title
        if spec.y_span is not None:
            self._follow_data(handle, series, spec.y_span)
        if spec.capped:
            self._cap(handle, spec, series)
        self.set_plot_data(handle, (t if spec.x is None else spec.x(t, columns), *series))

    def _follow_data(self, handle: Any, series: Sequence[np.ndarray], span: float) -> None:
        """Set the y range of ``handle`` to the finite values of ``series``, at least ``span`` tall and rounded
        out to a tenth of its height (sent only when it changes)."""
        values = np.concatenate([np.asarray(s, dtype=float).ravel() for s in series])
        values = values[np.isfinite(values)]
        if values.size == 0:
            return
        lo, hi = float(values.min()), float(values.max())
        mid, half = 0.5 * (lo + hi), 0.5 * max(hi - lo, span) * 1.1
        step = 10.0 ** math.floor(math.log10(2.0 * half)) / 10.0
        y_range = [math.floor((mid - half) / step) * step, math.ceil((mid + half) / step) * step]
        if self._y_ranges.get(id(handle)) != y_range:
            self._y_ranges[id(handle)] = y_range
            handle.scales = {"x": {"time": False}, "y": {"auto": False, "range": y_range}}

    def _cap(self, handle: Any, spec: PlotSpec, series: Sequence[np.ndarray]) -> None:
        """The y range of a ``capped`` plot and its last series' label (sent when they change)."""
        y_range, peak = capped_range(series[0], series[-1])
        if self._y_ranges.get(id(handle)) != list(y_range):
            self._y_ranges[id(handle)] = list(y_range)
            handle.scales = {"x": {"time": False}, "y": {"auto": False, "range": list(y_range)}}
        label = spec.series[-1][0] + ("" if peak is None else f", peak {significant(peak, 3)} off scale")
        if handle.series[-1]["label"] != label:
            handle.series = (*handle.series[:-1], {**handle.series[-1], "label": label})

    def set_plot_data(self, handle: Any, data: tuple) -> None:
        """Send a plot's data (non-finite values are sent as gaps by uPlot; nothing else reaches the page), one
        message without viser's per-array type checks (:func:`rigidlab.app.nodes.set_plot_data`)."""
        set_plot_data(handle, data)

    def readout_text(self) -> str:
        lines = [self.time_text()]
        rate = self.rate_text()
        if rate is not None:
            lines.append(rate)
        lines += self.readout_lines()
        if self.waiting and self.playback.playing and not self.ended:
            lines.append("*computing the next chunk…*")
        return "\n\n".join(lines)

    def csv_bytes(self) -> bytes:
        """The CSV of the motion in the plot window, up to the displayed time."""
        return self.history.csv(self.csv_header_for(self.config), self.window_start(), self.display_time)

    def csv_header_for(self, inputs: Any) -> str:
        """Hook: the CSV header for ``inputs`` (default :attr:`csv_header`)."""
        return self.csv_header


def job(fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Callable[[int, Any], Any]:
    """``functools.partial(fn, *args, **kwargs)``: a scene's job, picklable when ``fn`` is module-level."""
    return functools.partial(fn, *args, **kwargs)
