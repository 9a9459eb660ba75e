"""Plot refresh schedule (app/scenes/_plots.py): one plot per frame, at the refresh period, held by busy frames."""

from __future__ import annotations

from app.scenes._plots import PlotRefresh

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
