"""Axes that mean something: offset notation for flat series, y limits that follow the data, drift plots
labelled as round-off (app/scenes/_plots.py), and Scene.show_series, which applies them to a plot."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from rigidlab.app.scenes._plots import (
    axis_offset,
    drift_title,
    label_with_offset,
    offset_label,
    round_off_level,
    y_limits,
)
from rigidlab.app.scenes.base import Scene


def test_a_flat_series_gets_an_offset_and_its_remainders_differ_at_four_significant_digits() -> None:
    # the linkages' energy: 26.886 J, wobbling by 3e-5 J; every tick of uPlot's own axis read "26.886"
    rng = np.random.default_rng(28)
    energy = 26.88612 + 3e-5 * np.sin(np.linspace(0.0, 6.0, 200)) + 1e-7 * rng.standard_normal(200)
    offset = axis_offset(energy)
    assert offset == pytest.approx(26.8861, abs=1e-12)
    rest = energy - offset
    assert np.ptp(rest) == pytest.approx(np.ptp(energy), rel=1e-9)
    assert np.abs(rest).max() < 10 * np.ptp(energy)  # a few spreads, not 26.886
    assert f"{rest.min():.3g}" != f"{rest.max():.3g}"
    assert offset_label("E", offset, "J") == "E \u2212 26.8861 (J)"
    assert label_with_offset("E (J)", offset) == "E \u2212 26.8861 (J)"
    assert label_with_offset("E0", -2.5) == "E0 + 2.5"


@pytest.mark.parametrize("values", [np.linspace(-3.0, 40.0, 50), np.zeros(10), np.array([np.nan, np.inf]),
                                    np.array([1e-300, 2e-300]), np.array([-5.0, -5.0 + 1e-2])])
def test_no_offset_for_a_series_that_varies_or_is_zero(values: np.ndarray) -> None:
    assert axis_offset(values) == 0.0


def test_a_constant_series_is_its_own_offset() -> None:
    assert axis_offset(np.full(7, 9.80665)) == 9.80665
    assert offset_label("g", 0.0, "m/s²") == "g (m/s²)"


def test_offset_refuses_a_spread_that_is_not_positive() -> None:
    with pytest.raises(ValueError, match=r"spread: expected a positive fraction, got 0\.0"):
        axis_offset([1.0], spread=0.0)


def test_limits_follow_the_data_and_a_flat_line_gets_min_span_not_0_to_100() -> None:
    # the bicycle's lean and steer: a flat line near 0 kept a 0-100 degree axis
    lo, hi = y_limits(np.full(100, 0.2), min_span=5.0)
    assert hi - lo == pytest.approx(5.0, rel=0.25) and lo < 0.2 < hi
    lo, hi = y_limits(np.linspace(0.0, 97.0, 9))
    assert -10.0 <= lo <= 0.0 and 97.0 <= hi <= 110.0
    rng = np.random.default_rng(5)
    for _ in range(200):
        data = rng.normal(rng.normal(0, 1e3), 10.0 ** rng.uniform(-6, 3), size=20)
        lo, hi = y_limits(data, include=(0.0,) if rng.random() < 0.3 else ())
        assert lo <= data.min() and data.max() <= hi and lo < hi
        assert hi - lo <= 1.5 * np.ptp(np.append(data, 0.0 if lo <= 0.0 <= hi else data[0])) + 2e-6 * abs(data).max()


def test_limits_contain_include_and_handle_no_data() -> None:
    assert y_limits([], min_span=4.0) == (-2.0, 2.0)
    assert y_limits([np.nan]) == (-1.0, 1.0)
    lo, hi = y_limits([-17.0, -15.0], include=(-8.0,))
    assert lo <= -17.0 and hi >= -8.0
    lo, hi = y_limits([0.0, 0.0])
    assert lo < 0.0 < hi
    with pytest.raises(ValueError, match=r"min_span: expected a finite number >= 0, got -1\.0"):
        y_limits([1.0], min_span=-1.0)
    with pytest.raises(ValueError, match=r"pad: expected a finite number >= 0, got nan"):
        y_limits([1.0], pad=float("nan"))


def test_round_off_level_and_drift_title() -> None:
    eps = np.finfo(float).eps
    energy = 26.9
    drift = np.array([0.0, 4 * eps * energy, -8 * eps * energy, 2 * eps * energy])  # square-wave round-off
    assert round_off_level(drift, scale=energy)
    assert not round_off_level(drift + 1e-9, scale=energy)
    assert not round_off_level([np.nan], scale=1.0)
    title = drift_title("energy drift", drift, scale=energy)
    assert title.startswith("energy drift") and "round-off level" in title
    assert drift_title("energy drift", drift + 1e-9, scale=energy) == "energy drift"
    # the log plots draw log10 |drift| floored at -17
    logs = np.log10(np.maximum(np.abs(drift), 1e-17))
    assert "round-off" in drift_title("log10 drift", logs, scale=energy, log10=True)
    with pytest.raises(ValueError, match=r"scale: expected a finite number, got inf"):
        round_off_level(drift, scale=float("inf"))
    with pytest.raises(ValueError, match=r"ulps: expected a positive number, got 0"):
        round_off_level(drift, scale=1.0, ulps=0)


class _Plot:
    """Stands in for viser's uPlot handle: the attributes show_series assigns, and a count of sends."""

    def __init__(self, series: tuple) -> None:
        self.series, self.scales, self.title, self.data = series, {"x": {"time": False}}, "energy", ()
        self.sent: list[str] = []

    def __setattr__(self, name: str, value: Any) -> None:
        if name != "sent" and hasattr(self, "sent"):
            self.sent.append(name)
        object.__setattr__(self, name, value)


def test_show_series_draws_a_flat_energy_with_an_offset_and_keeps_its_range_while_the_data_fit() -> None:
    scene = Scene.__new__(Scene)
    scene._plot_axes = {}
    plot = _Plot(({"label": "t (s)"}, {"label": "E (J)"}, {"label": "E0"}))
    t = np.linspace(0.0, 5.0, 100)
    energy = 26.88612 + 3e-5 * np.sin(t)
    scene.show_series(plot, t, (energy, np.full_like(t, 26.88612)), title="energy E(t)", unit="J")
    assert plot.series[1]["label"] == "E \u2212 26.8861 (J)" and plot.series[2]["label"] == "E0 \u2212 26.8861"
    assert "E(t)" in plot.title and "26.8861" in plot.title
    lo, hi = plot.scales["y"]["range"]
    assert plot.scales["x"] == {"time": False}
    assert lo <= (energy - 26.8861).min() and (energy - 26.8861).max() <= hi and hi - lo < 1e-3
    np.testing.assert_allclose(plot.data[1], energy - 26.8861, rtol=0, atol=1e-15)
    # the next refresh, data inside the range: only the data are sent
    plot.sent.clear()
    scene.show_series(plot, t, (energy[::-1], np.full_like(t, 26.88612)), title="energy E(t)", unit="J")
    assert plot.sent == ["data"]


def test_show_series_labels_a_drift_at_round_off() -> None:
    scene = Scene.__new__(Scene)
    scene._plot_axes = {}
    plot = _Plot(({"label": "t (s)"}, {"label": "log10 |E − E0| (J)"}))
    t = np.linspace(0.0, 1.0, 10)
    scene.show_series(plot, t, (np.full(10, -15.2),), title="energy drift (log10)", drift_scale=26.9, log10=True)
    assert "round-off level" in plot.title
    assert plot.series[1]["label"] == "log10 |E − E0| (J)"  # (a log plot's offset would hide the level)
