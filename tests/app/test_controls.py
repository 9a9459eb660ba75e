"""Playback controls shared by the timed scenes (app/scenes/_controls.py).

The clock logic is checked directly; the GUI wiring on a bare
``viser.ViserServer``, setting the handles' values as the page does.
"""

from __future__ import annotations

import math

import pytest

from app.scenes._controls import Playback, Tick
from tests.helpers import wait_until

PRESETS = ("first", "second")


def test_clock_plays_pauses_scales_and_resets_once() -> None:
    playback = Playback(PRESETS)
    assert playback.playing and playback.time_scale == 1.0
    assert playback.tick(0.02) == Tick(reset=False, step=0.02)
    playback.set_time_scale(2.5)
    # dt * scale in float64, as the scenes advanced their clocks before
    assert playback.tick(0.02) == Tick(reset=False, step=0.02 * 2.5)
    playback.set_playing(False)
    assert playback.tick(0.02) == Tick(reset=False, step=0.0)
    playback.request_reset()
    assert playback.tick(0.02).reset is True
    assert playback.tick(0.02).reset is False  # a request is consumed by one frame
    playback.set_playing(True)
    assert playback.tick(0.04).step == pytest.approx(0.1, rel=1e-15)


def test_presets_are_validated_and_taken_once() -> None:
    playback = Playback(PRESETS)
    assert playback.take_preset() is None
    playback.request_preset("second")
    playback.request_preset("first")  # the latest request wins
    assert playback.take_preset() == "first"
    assert playback.take_preset() is None
    with pytest.raises(ValueError, match=r"name: expected one of \['first', 'second'\], got 'third'"):
        playback.request_preset("third")
    assert playback.take_preset() is None


@pytest.mark.parametrize("scale", [0.0, -1.0, math.nan, math.inf])
def test_time_scale_must_be_finite_and_positive(scale: float) -> None:
    playback = Playback()
    with pytest.raises(ValueError, match=r"scale: expected a finite number > 0, got"):
        playback.set_time_scale(scale)
    assert playback.time_scale == 1.0


def test_gui_controls_record_requests(server) -> None:
    playback = Playback(PRESETS)
    with server.gui.add_folder("Playback test") as folder:
        gui = playback.add_gui(server.gui)
        buttons = playback.add_preset_buttons(server.gui)
    try:
        assert [gui.play.label, gui.pause.label, gui.reset.label, gui.time_scale.label] == [
            "Play", "Pause", "Reset", "Time scale"]
        assert (gui.time_scale.min, gui.time_scale.max, gui.time_scale.value) == (0.05, 4.0, 1.0)
        assert list(buttons) == list(PRESETS)
        gui.pause.value = True  # a click, as the page sends it
        wait_until(lambda: not playback.playing)
        gui.play.value = True
        wait_until(lambda: playback.playing)
        gui.time_scale.value = 3.0
        wait_until(lambda: playback.time_scale == 3.0)
        gui.reset.value = True
        wait_until(lambda: playback.tick(0.0).reset)
        buttons["second"].value = True
        wait_until(lambda: playback.take_preset() == "second")
    finally:
        folder.remove()
