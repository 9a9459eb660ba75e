"""The timed scenes' pipeline (app/scenes/_simulation.py), on a toy scene.

The toy's job is a closed form (x = a sin t, sampled at 60 Hz), so what the
layer does with it (the clock, chunks, segments, the end of a motion, plots,
CSV, the rate readout, errors) is checked without any physics. The timed
scenes' own tests check their motions on the same layer.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import pytest

from rigidlab.app.controls import Slider
from rigidlab.app.readout import significant
from rigidlab.app.scenes._plots import Table, capped_range
from rigidlab.app.scenes._simulation import RATE_WINDOW, InputsRefused, PlotSpec, SimulationScene, power_of_ten
from tests.app.conftest import GatedExecutor
from tests.helpers import wait_until


@dataclasses.dataclass(frozen=True)
class _Inputs:
    amplitude: float = 1.0
    end: float = 0.0  # > 0: the motion ends there (a final chunk)


@dataclasses.dataclass(frozen=True)
class _Chunk:
    k: int
    t: np.ndarray
    x: np.ndarray
    table: Table
    final: bool = False
    end: str = ""
    failure: str | None = None


def _toy_job(inputs: _Inputs, t0: float, start: float | None, k: int, previous: Any) -> _Chunk:
    if inputs.amplitude < 0:
        raise ValueError("amplitude: expected >= 0, got a negative value")
    a = inputs.amplitude if start is None else start
    t = t0 + k + np.linspace(0.0, 1.0, 61)
    final = bool(inputs.end > 0 and t[-1] >= t0 + inputs.end)
    if final:
        t = t[t <= t0 + inputs.end + 1e-12]
    x = a * np.sin(t)
    return _Chunk(k, t, x, Table.build(t, x[:, None]), final=final, end="it stopped" if final else "",
                  failure="a side note" if k == 1 else None)


class _Toy(SimulationScene):
    name: ClassVar[str] = "toy"
    title: ClassVar[str] = "Toy"
    Inputs = _Inputs
    presets = ("big",)
    csv_header = "t (s),x (m)"
    window = 3.0

    def job(self, inputs: _Inputs, segment: Any) -> Any:
        return functools.partial(_toy_job, inputs, segment.t0, segment.start)

    def build_nodes(self) -> None:
        self.drawn: list[tuple[float, float]] = []

    def build_controls(self) -> None:
        self.add_playback()
        self.add_presets()
        self.controls.add(Slider("amplitude", "a", min=-1.0, max=5.0, step=0.1, default=1.0))
        self.controls.add(Slider("end", "end", min=0.0, max=10.0, step=0.1, default=0.0))

    def plots(self) -> list[PlotSpec]:
        return [PlotSpec("x", "x(t)", (("x (m)", "#2563eb"),), lambda t, c: (c[:, 0],))]

    def draw(self, chunk: _Chunk, j: int) -> None:
        self.drawn.append((float(chunk.t[j]), float(chunk.x[j])))

    def preset_values(self, name: str) -> dict[str, Any]:
        return {"amplitude": 4.0}

    def check_inputs(self, inputs: _Inputs) -> None:
        if inputs.amplitude > 4.5:
            raise ValueError(f"amplitude: expected <= 4.5 together with end, got {inputs.amplitude!r}")


def _checking_job(inputs: _Inputs, k: int, previous: Any) -> _Chunk:
    if inputs.amplitude > 4.5:  # (a check too slow for the loop thread, made in the job)
        raise InputsRefused(f"amplitude: expected <= 4.5 together with end, got {inputs.amplitude!r}")
    return _toy_job(inputs, 0.0, None, k, previous)


class _CheckingToy(_Toy):
    """The toy checking its inputs in the job, off the loop thread."""

    check_on_loop = False

    def job(self, inputs: _Inputs, segment: Any) -> Any:
        return functools.partial(_checking_job, inputs)


class _KeyedToy(_Toy):
    """The toy with a dashed series and a legend."""

    def build_controls(self) -> None:
        super().build_controls()
        self.legend = self.add_legend((((37, 99, 235), "x"),), "Key:")

    def plots(self) -> list[PlotSpec]:
        return [PlotSpec("x", "x(t)", (("x (m)", "#2563eb"), ("bound", "#888888", {"dash": [6, 4], "width": 1})),
                         lambda t, c: (c[:, 0], np.ones_like(t)))]


def _run(scene: Any, seconds: float, dt: float = 1 / 60) -> None:
    for _ in range(round(seconds / dt)):
        scene.frame(dt)


def _play_until(scene: Any, t: float, dt: float = 1 / 60) -> None:
    def moved() -> bool:
        scene.frame(dt)
        return scene.sim_time >= t

    wait_until(moved, timeout=60.0, interval=0.0)


def test_the_clock_draws_the_closed_form_and_fills_plots_and_csv(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_Toy)
    _play_until(scene, 2.5)
    t, x = scene.drawn[-1]
    assert x == pytest.approx(math.sin(t), abs=1e-15)
    assert t <= scene.sim_time + 1e-9 and scene.sim_time - t < 1 / 60 + 1e-9  # the sample at or before
    wait_until(lambda: (scene.frame(1 / 60), scene.plot_handles["x"].data[0].size > 10)[1], timeout=60.0,
               interval=0.0)
    tp, xp = scene.plot_handles["x"].data
    np.testing.assert_allclose(xp, np.sin(tp), atol=1e-15)
    rows = scene.csv_bytes().decode().splitlines()
    assert rows[0] == "t (s),x (m)"
    assert float(rows[1].split(",")[0]) >= scene.window_start() - 1e-12
    assert ("Toy", "a side note", "warning") in notices  # a chunk's failure: once
    assert sum(n[1] == "a side note" for n in notices) == 1


def test_a_changed_input_restarts_and_a_preset_sets_values(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_Toy)
    _play_until(scene, 1.2)
    scene.controls.apply({"amplitude": 2.0})
    _play_until(scene, 0.3)
    assert scene.config.amplitude == 2.0
    assert scene.sim_time < 1.0  # restarted
    scene.apply_preset("big")
    _play_until(scene, 0.2)
    assert scene.controls.value("amplitude") == 4.0 and scene.drawn[-1][1] == pytest.approx(
        4.0 * math.sin(scene.drawn[-1][0]), abs=1e-14)


def test_a_final_chunk_ends_the_motion_once_and_reset_plays_it_again(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_Toy)
    scene.controls.apply({"end": 1.5})
    wait_until(lambda: (scene.frame(0.05), scene.ended)[1], timeout=60.0, interval=0.0)
    assert scene.sim_time == pytest.approx(1.5, abs=1e-12)
    _run(scene, 0.5)
    assert scene.sim_time == pytest.approx(1.5, abs=1e-12)  # held at the end
    assert [n[0] for n in notices].count("The motion ended") == 1
    scene.request_reset()
    scene.frame(0.05)
    assert not scene.ended and scene.sim_time < 0.2


def test_a_segment_continues_the_clock_from_the_state_shown(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_Toy)
    _play_until(scene, 1.3)
    t_shown = scene.display_time
    scene.continue_from(3.0)
    _play_until(scene, t_shown + 0.5)
    t, x = scene.drawn[-1]
    assert scene.segment.index == 1 and scene.segment.t0 == t_shown
    assert x == pytest.approx(3.0 * math.sin(t), abs=1e-14)  # the new segment's job, on the same clock


def test_a_failed_chunk_stops_the_clock_with_a_notice(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_Toy)
    scene.controls.apply({"amplitude": -0.5})
    wait_until(lambda: (scene.frame(1 / 60), scene.timeline.error is not None)[1], timeout=60.0, interval=0.0)
    scene.frame(1 / 60)
    assert not scene.playing and scene.paused_error is None
    assert any("motion stopped" in n[0] and "amplitude" in n[1] for n in notices)


def test_the_readout_says_the_rate_when_the_chunks_hold_the_clock(make_bare_scene) -> None:
    gate = GatedExecutor()
    scene, _ = make_bare_scene(_Toy, executor=gate)
    gate.open.set()
    _play_until(scene, 0.9)
    gate.open.clear()  # the chunks stop coming: the clock holds at the end of what is computed
    _run(scene, 3.0, dt=0.05)
    assert scene.real_time_rate < 0.5
    text = scene.readout_text()
    assert "real time" in text and "waiting for the computation" in text
    gate.open.set()


def test_the_rate_is_the_simulated_over_the_wall_seconds_of_the_last_window(make_bare_scene) -> None:
    # (running sums of the window: 5 s at full speed, then 5 s at a quarter; the rate forgets the first part)
    scene, _ = make_bare_scene(_Toy)
    scene.playback.set_playing(True)
    for i in range(600):
        scene._measure_rate(1 / 60, (1.0 if i < 300 else 0.25) / 60, True)
    assert scene.real_time_rate == pytest.approx(0.25, rel=1e-9)
    assert len(scene._rate) <= RATE_WINDOW * 60 + 2
    scene._measure_rate(1 / 60, 0.0, False)  # stopped: no rate, and a fresh window
    assert math.isnan(scene.real_time_rate) and not scene._rate


def test_a_change_after_a_failure_runs_again_unless_the_clock_was_paused_by_hand(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_Toy)
    scene.controls.apply({"amplitude": -0.5})
    wait_until(lambda: (scene.frame(1 / 60), scene.timeline.error is not None)[1], timeout=60.0, interval=0.0)
    scene.frame(1 / 60)
    assert not scene.playing
    scene.controls.apply({"amplitude": 1.0})  # the notice said: change a control to run it again
    _play_until(scene, 0.5)
    assert scene.playing and scene.config.amplitude == 1.0
    scene.playback.set_playing(False)  # paused by hand, then a failure: a change does not start the clock
    scene.controls.apply({"amplitude": -0.5})
    wait_until(lambda: (scene.frame(1 / 60), scene.timeline.error is not None)[1], timeout=60.0, interval=0.0)
    scene.controls.apply({"amplitude": 2.0})
    _run(scene, 0.2)
    assert not scene.playing and scene.sim_time == 0.0 and scene.config.amplitude == 2.0


def test_reset_replays_the_chunks_of_the_same_inputs(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_Toy)
    _play_until(scene, 2.5)
    computed = scene.chunks_computed
    scene.request_reset()
    scene.frame(1 / 60)
    assert scene.sim_time < 0.2
    _play_until(scene, 2.5)
    assert scene.chunks_computed <= computed + 1  # (the clock may have asked for one chunk ahead)
    scene.controls.apply({"amplitude": 2.0})  # other inputs: new chunks
    _play_until(scene, 1.5)
    assert scene.chunks_computed >= computed + 2


def test_refused_inputs_keep_the_motion_and_set_the_controls_back(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_Toy)
    _play_until(scene, 0.5)
    scene.controls.apply({"amplitude": 4.8})
    _run(scene, 0.1)
    assert scene.config.amplitude == 1.0 and scene.controls.value("amplitude") == 1.0
    assert scene.sim_time > 0.5  # not restarted
    title, text, level = next(n for n in notices if n[0] == "Invalid values")
    assert "amplitude: expected <= 4.5" in text and "set back" in text and level == "warning"
    assert scene.values_refusal({"amplitude": 4.8, "end": 0.0}).startswith("invalid values: amplitude: expected")
    assert scene.values_refusal({"amplitude": 2.0, "end": 0.0}) is None


def test_inputs_the_job_refuses_set_the_controls_back_to_the_motion_that_ran(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_CheckingToy)
    _play_until(scene, 0.5)
    scene.controls.apply({"amplitude": 2.0})  # taken, then refused values in a row (a dragged slider)
    wait_until(lambda: (scene.frame(1 / 60), scene.last_chunk.x[-1] != 0 and scene._ran.amplitude == 2.0)[1],
               interval=0.0)
    for value in (4.6, 4.8):
        scene.controls.apply({"amplitude": value})
        scene.frame(1 / 60)
    assert scene.config.amplitude == 4.8  # taken on the loop thread unchecked; the job refuses it
    wait_until(lambda: (scene.frame(1 / 60), scene.controls.value("amplitude") == 2.0 and scene.config.amplitude
                        == 2.0 and not scene.waiting)[1], interval=0.0)
    title, text, level = next(n for n in notices if n[0] == "Invalid values")
    assert "amplitude: expected <= 4.5" in text and "set back" in text and level == "warning"
    assert not any("motion stopped" in n[0] for n in notices) and scene.playing
    assert scene.values_refusal({"amplitude": 4.8, "end": 0.0}).startswith("invalid values: amplitude: expected")


def test_series_options_and_a_legend_that_grows_in_presenter_view(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_KeyedToy)
    series = scene.plot_handles["x"].series
    assert series[2]["dash"] == [6, 4] and series[2]["width"] == 1 and series[1]["width"] == 2
    before = scene.legend.handle.content
    scene.set_presenter(True)
    assert scene.legend.handle.content != before and "#2563eb" in before


class _TinyToy(_Toy):
    """The toy with a second plot of 1e-9 x, rescaled, whose title carries the amplitude."""

    def plots(self) -> list[PlotSpec]:
        return [*super().plots(), PlotSpec("tiny", "tiny x", (("x (m)", "#2563eb"),),
                                           lambda t, c: (1e-9 * c[:, 0],), rescale=True)]

    def plot_title(self, spec: PlotSpec) -> str:
        return f"{spec.title}, a = {self.config.amplitude:g}" if spec.name == "tiny" else spec.title


def test_power_of_ten_leaves_readable_series_and_scales_tiny_and_huge_ones() -> None:
    assert power_of_ten((np.array([0.02, -3.0]), np.array([np.nan]))) == 0
    assert power_of_ten((np.zeros(3),)) == 0
    assert power_of_ten((np.array([2.5e-9, -7.0e-9]),)) == -9
    assert power_of_ten((np.array([1e-3]), np.array([np.inf, -4e-3]))) == -3
    assert power_of_ten((np.array([3.0e7]),)) == 7


def test_a_rescaled_plot_divides_its_series_and_says_so_in_its_title(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_TinyToy)

    def plotted() -> bool:
        scene.frame(1 / 60)
        return scene.plot_handles["tiny"].data[0].size > 10 and scene.plot_handles["x"].data[0].size > 10

    wait_until(plotted, timeout=60.0, interval=0.0)
    handle = scene.plot_handles["tiny"]
    t, y = (np.asarray(a) for a in handle.data)
    e = int(handle.title.rsplit("×1e", 1)[1].rstrip("]"))
    assert handle.title == f"tiny x, a = 1 [×1e{e:+03d}]" and e == power_of_ten((1e-9 * np.sin(t),))
    np.testing.assert_allclose(y * 10.0**e, 1e-9 * np.sin(t), rtol=1e-12, atol=1e-24)
    assert 1.0 <= np.abs(y).max() < 10.0  # readable tick labels
    assert scene.plot_handles["x"].title == "x(t)"  # a plot without rescale is left alone


def test_a_display_control_draws_the_sample_again_while_paused(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_Toy)
    _play_until(scene, 0.5)
    scene.playback.set_playing(False)
    _run(scene, 0.1)
    drawn = len(scene.drawn)
    _run(scene, 0.1)
    assert len(scene.drawn) == drawn  # paused: nothing is sent again
    scene.controls.apply({"time_scale": 2.0})  # not an input: the motion goes on, the sample is drawn again
    scene.frame(1 / 60)
    assert len(scene.drawn) == drawn + 1 and scene.drawn[-1] == scene.drawn[-2]
    assert scene.sim_time == scene.drawn[-1][0] or scene.sim_time - scene.drawn[-1][0] < 1 / 60
class _PeriodToy(_Toy):
    """The toy with a plot of the chunk drawn (x from its table) and the failures handled by the scene."""

    name: ClassVar[str] = "period_toy"
    handled: ClassVar[list] = []

    def plots(self) -> list[PlotSpec]:
        return [PlotSpec("period", "x over the chunk", (("x (m)", "#2563eb"),), lambda t, c: (c[:, 0],),
                         x=lambda t, c: t - t[0], per_chunk=True)]

    def on_error(self, error: BaseException) -> bool:
        self.handled.append(error)
        return True

    def time_text(self) -> str:
        return f"**phase** = {self.display_time % 1.0:.2f}"


def test_a_per_chunk_plot_shows_the_whole_chunk_drawn_and_a_scene_may_handle_errors(make_bare_scene) -> None:
    scene, notices = make_bare_scene(_PeriodToy)
    _play_until(scene, 1.5)  # in chunk 1
    wait_until(lambda: (scene.frame(1 / 60), scene.plot_handles["period"].data[0].size == 61)[1], timeout=60.0,
               interval=0.0)
    x, y = scene.plot_handles["period"].data
    chunk = scene.last_chunk
    np.testing.assert_allclose(x, chunk.t - chunk.t[0], atol=1e-12)  # the whole chunk, ahead of the clock too
    np.testing.assert_array_equal(y, chunk.x)
    assert scene.readout_text().startswith("**phase** = ")
    scene.controls.apply({"amplitude": -0.5})
    wait_until(lambda: (scene.frame(1 / 60), scene.handled)[1], timeout=60.0, interval=0.0)
    scene.frame(1 / 60)
    assert scene.playing and not any("motion stopped" in n[0] for n in notices)  # handled: no notice, no pause
    assert len(scene.handled) == 1 and "amplitude" in str(scene.handled[0])


class _FlatToy(_Toy):
    def plots(self) -> list[PlotSpec]:
        return [PlotSpec("x", "x(t)", (("x (m)", "#2563eb"),), lambda t, c: (c[:, 0],), y_span=1.0)]


def test_a_plot_with_y_span_follows_its_data(make_bare_scene) -> None:
    """A flat series gets an axis at least y_span tall about its value (uPlot's own range was 0-100)."""
    scene, _ = make_bare_scene(_FlatToy)
    scene.controls.apply({"amplitude": 0.0})
    handle = scene.plot_handles["x"]

    def y_range() -> list[float] | None:
        scene.frame(1 / 60)
        return (handle.scales or {}).get("y", {}).get("range")

    wait_until(lambda: y_range() is not None and scene.sim_time > 0.5, timeout=60.0, interval=0.0)
    lo, hi = y_range()
    assert lo < 0.0 < hi and 1.0 <= hi - lo <= 1.5
    scene.controls.apply({"amplitude": 4.0})
    wait_until(lambda: (r := y_range()) is not None and r[0] <= -3.9 and r[1] >= 3.9, timeout=60.0, interval=0.0)
    lo, hi = y_range()
    assert -5.0 <= lo and hi <= 5.0  # the data's range (4 sin t), rounded out


class _PeakToy(_Toy):
    """The toy beside a spike 100 times its amplitude at t = 0.5 s (an impact against a closed form)."""

    def plots(self) -> list[PlotSpec]:
        return [PlotSpec("x", "x(t)", (("x (m)", "#2563eb"), ("spiked (m)", "#d97706")), lambda t, c: (
            c[:, 0], c[:, 0] + np.where(np.abs(t - 0.5) < 0.01, 100.0, 0.0)), capped=True)]


def test_a_capped_plot_keeps_its_first_series_readable_and_names_the_peak_off_scale(make_bare_scene) -> None:
    scene, _ = make_bare_scene(_PeakToy)
    handle = scene.plot_handles["x"]

    def drawn() -> bool:
        scene.frame(1 / 60)
        return scene.sim_time > 0.6 and "off scale" in handle.series[2]["label"]

    wait_until(drawn, timeout=60.0, interval=0.0)
    t, x, spiked = (np.asarray(a) for a in handle.data)
    (lo, hi), peak = capped_range(x, spiked)
    assert handle.scales["y"]["range"] == [lo, hi] and hi < 0.5 * peak  # the peak is cut off, x fills the plot
    assert handle.series[2]["label"] == f"spiked (m), peak {significant(peak, 3)} off scale"


class _ExtraToy(_Toy):
    start_amplitude: float | None = None

    def initial_extra(self) -> Any:
        return self.start_amplitude

    def job(self, inputs: _Inputs, segment: Any) -> Any:
        start = segment.extra if segment.index == 0 else segment.start
        return functools.partial(_toy_job, inputs, segment.t0, start)


def test_a_restart_with_another_initial_extra_runs_it_anew(make_bare_scene) -> None:
    """The segment from t = 0 carries initial_extra(); a restart replays the held chunks only while it is the same
    (the bicycle's first push: a preset of the same speed and another push must not replay the last ride)."""
    scene, _ = make_bare_scene(_ExtraToy)
    _play_until(scene, 1.2)
    scene.start_amplitude = 3.0
    scene.restart()
    assert scene.segment.extra == 3.0
    _play_until(scene, 0.3)
    t, x = scene.drawn[-1]
    assert x == pytest.approx(3.0 * math.sin(t), abs=1e-14)
    scene.restart()  # the same: replayed
    _play_until(scene, 0.3)
    t, x = scene.drawn[-1]
    assert x == pytest.approx(3.0 * math.sin(t), abs=1e-14)


def _side_value(x: float) -> float:
    if x < 0:
        raise ValueError(f"x: expected >= 0, got {x}")
    return math.sqrt(x)


def test_side_jobs_hand_back_their_results_once_and_a_failure_is_a_notice(make_bare_scene) -> None:
    """Jobs beside the motion (the bicycle's modes and sweep): each result comes back once, on the loop
    thread (in submission order among those finished by then); a job that raises is dropped with a warning naming its key and the error."""
    scene, notices = make_bare_scene(_Toy)
    scene.submit_side_job("Root of 4", _side_value, 4.0)
    scene.submit_side_job("Root of -1", _side_value, -1.0)
    scene.submit_side_job("Root of 9", _side_value, 9.0)
    got: list[tuple[str, Any]] = []
    wait_until(lambda: (got.extend(scene.side_results()), not scene.side_jobs)[1], timeout=60.0, interval=0.0)
    assert sorted(got) == [("Root of 4", 2.0), ("Root of 9", 3.0)]
    assert ("Root of -1 not computed", "ValueError: x: expected >= 0, got -1.0", "warning") in notices
    assert scene.side_results() == []


def test_paused_the_plots_become_current_and_nothing_more_is_sent(make_bare_scene) -> None:
    """``plots_current``: paused, the layer sends the readout and each plot once more for the time shown (one a
    frame, up to a refresh period later), and then nothing."""
    scene, _ = make_bare_scene(_Toy)
    _play_until(scene, 1.0)
    scene.playback.set_playing(False)
    wait_until(lambda: (scene.frame(1 / 60), scene.plots_current)[1], timeout=60.0, interval=0.0)
    sent = scene.plot_handles["x"].data
    for _ in range(30):
        scene.frame(1 / 60)
        assert scene.plots_current and scene.refresh_due is None
    assert scene.plot_handles["x"].data is sent
