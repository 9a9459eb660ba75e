"""Plots of the timed scenes (app/scenes/_plots.py): the refresh schedule (one plot per frame, at the refresh
period, held by busy frames) and the history's windows."""

from __future__ import annotations

import numpy as np
import pytest

from rigidlab.app.scenes._plots import History, PlotRefresh, Table

DT = 1.0 / 64.0  # (exact in binary: a period of 0.25 s is 16 frames)


def _run(refresh: PlotRefresh, frames: int, *, hold_every: int = 0) -> list[str | None]:
    out = []
    for i in range(frames):
        hold = bool(hold_every) and i % hold_every == 0
        out.append(refresh.due(DT, moving=True, hold=hold))
    return out


def test_one_plot_per_frame_each_period():
    refresh = PlotRefresh(("a", "b", "c"), 0.25)
    due = _run(refresh, 30)
    assert due[:3] == ["a", "b", "c"] and due[3:16] == [None] * 13
    assert due[16:19] == ["a", "b", "c"]  # 0.25 s later
    # still data: nothing is refreshed again
    assert refresh.due(1.0, moving=False) is None


def test_a_held_frame_refreshes_nothing_and_the_plot_comes_in_the_next_frame():
    refresh = PlotRefresh(("a", "b", "c"), 0.25)
    due = _run(refresh, 48, hold_every=6)  # a buffer sent every sixth frame (the track's 10 Hz)
    held = [due[i] for i in range(0, 48, 6)]
    assert held == [None] * len(held)
    # every plot still comes, in order, one per frame and none in a held frame; a cycle starts a period
    # after the one before, or in the next frame when that one is held
    names = [d for d in due if d is not None]
    assert names == ["a", "b", "c"] * 3
    assert [i for i, d in enumerate(due) if d == "a"] == [1, 17, 33]
    assert [i for i, d in enumerate(due) if d == "c"] == [3, 20, 35]  # (18 is held: b and c come a frame later)


def _reference_window(tables: list[tuple[np.ndarray, np.ndarray]], t_start: float, t_end: float,
                      max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """The window by definition: the samples in [t_start, t_end], a table's first left out where it repeats
    the time before, decimated to every s-th sample counted from the oldest, the newest time always kept."""
    ts, cs, last = [], [], -np.inf
    for t, columns in tables:
        keep = (t >= t_start) & (t <= t_end) & (t > last)
        ts.append(t[keep])
        cs.append(columns[keep])
        if keep.any():
            last = t[keep][-1]
    t, columns = np.concatenate(ts), np.concatenate(cs)
    if t.size == 0:
        return np.zeros(0), np.zeros((0, 0))
    stride = max(1, -(-t.size // max_points))
    picked = list(range(0, t.size, stride))
    if t[picked[-1]] != t[-1]:  # the newest time (a held sample repeats it)
        picked.append(t.size - 1)
    return t[picked], columns[picked]


def test_history_windows_and_csv_hold_each_sample_once():
    rng = np.random.default_rng(11)
    for _ in range(200):
        period, n = float(rng.choice([0.5, 1.0 / 3.0])), int(rng.integers(1, 40))
        history, tables = History(), []
        for k in range(int(rng.integers(1, 25))):
            t = np.linspace(k * period, (k + 1) * period, n + 1)  # each chunk's first time ends the one before
            if rng.random() < 0.1:
                t = np.repeat(t[-1:], 2)  # a motion that ended: its last sample held
            elif rng.random() < 0.1:
                t = t[: int(rng.integers(1, t.size + 1))]  # a run cut short
            columns = rng.normal(size=(t.size, 2))
            history.add(k, Table.build(t, columns))
            tables.append((t, columns))
        span = len(tables) * period
        for _ in range(5):
            a = float(rng.uniform(-0.5, span + 0.5))
            if rng.random() < 0.3:  # a window starting on a sample
                a = float(tables[int(rng.integers(0, len(tables)))][0][0])
            b = float(rng.uniform(a, span + 1.0))
            t, columns = history.window(a, b, max_points=50)
            t_ref, columns_ref = _reference_window(tables, a, b, 50)
            np.testing.assert_array_equal(t, t_ref)
            if t.size:
                np.testing.assert_array_equal(columns, columns_ref)
            # the CSV: every sample of the window, not decimated
            every, _ = _reference_window(tables, a, b, 10**9)
            rows = history.csv("h", a, b).decode().splitlines()[1:]
            assert [row.split(",")[0] for row in rows] == ["%.15g" % x for x in every]


def test_capped_range_keeps_the_reference_readable_and_names_the_cut_peak():
    from rigidlab.app.scenes._plots import capped_range

    reference = np.array([-20.0, 10.0, 40.0])
    (lo, hi), peak = capped_range(reference, np.array([0.0, 30.0, 5000.0]))
    # the cap: 40 + 2 (40 - (-20)) = 160; margins 5 % of 180
    assert peak == 5000.0 and (lo, hi) == pytest.approx((-20.0 - 9.0, 160.0 + 9.0))
    (lo, hi), peak = capped_range(reference, np.array([-30.0, 50.0]))
    assert peak is None and (lo, hi) == pytest.approx((-30.0 - 4.0, 50.0 + 4.0))
