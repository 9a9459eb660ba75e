"""Playback shared by the timed scenes (app/scenes/_playback.py).

The clock logic is checked directly; the GUI wiring on a bare
``viser.ViserServer`` with a scene's control panel, clicking and sending
values through the gate exactly as the page does.
"""

from __future__ import annotations

import math

import pytest

from rigidlab.app.gate import Gate
from rigidlab.app.panel import ControlPanel
from rigidlab.app.scenes._playback import MAX_SIM_STEP, PLAYBACK_OPTIONS, TIME_SCALE_RANGE, Playback, Tick
from tests.helpers import click, send_value, wait_until

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


@pytest.mark.parametrize("dt", [0.5, 10.0, 1e6, math.inf])
def test_a_frame_advances_the_clock_by_at_most_max_sim_step(dt: float) -> None:
    playback = Playback()
    playback.set_time_scale(TIME_SCALE_RANGE[1])
    assert playback.tick(dt).step == MAX_SIM_STEP
    assert playback.tick(-1.0).step == 0.0  # a clock never runs backwards


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


def test_gui_needs_the_panel() -> None:
    with pytest.raises(ValueError, match=r"controls: expected the scene's ControlPanel, got None"):
        Playback(PRESETS).add_gui()
    with pytest.raises(ValueError, match=r"controls: expected the scene's ControlPanel, got None"):
        Playback(PRESETS).add_preset_buttons()


@pytest.fixture
def panel(server):
    notices = []
    panel = ControlPanel(server.gui, Gate.for_gui(server.gui), lambda client, *n: notices.append(n))
    panel.notices = notices
    with server.gui.add_folder("Playback test") as folder:
        yield panel
    panel.remove_all()
    folder.remove()


def test_gui_controls_record_requests(panel) -> None:
    playback = Playback(PRESETS, controls=panel)
    handles = playback.add_gui()
    buttons = playback.add_preset_buttons()
    row, scale = handles["playback"], handles["time_scale"]
    assert row.label == "Playback" and tuple(row.options) == PLAYBACK_OPTIONS
    assert (scale.label, scale.min, scale.max, scale.value) == ("Time scale", *TIME_SCALE_RANGE, 1.0)
    assert list(buttons) == list(PRESETS)
    click(panel, "playback", "Pause")  # a click, as the page sends it
    assert playback.tick(0.1) == Tick(reset=False, step=0.0)
    assert not playback.playing
    click(panel, "playback", "Play")
    playback.tick(0.0)
    assert playback.playing
    assert send_value(panel, "time_scale", 3.0)
    assert playback.time_scale == 3.0
    assert playback.tick(0.1).step == pytest.approx(0.3)
    click(panel, "playback", "Reset")
    assert playback.tick(0.0).reset
    click(panel, "preset_1")
    assert playback.take_preset() == "second"
    # the time scale is part of the scene's state; the buttons are not
    assert panel.state() == {"time_scale": 3.0}
    # programmatic changes show on the page
    playback.set_time_scale(0.5)
    assert scale.value == 0.5 and playback.time_scale == 0.5


@pytest.mark.parametrize("raw", [1e6, 0.0, -2.0, math.nan, math.inf, "4", None, True, 10**400])
def test_refused_time_scales_keep_the_value_in_use(panel, raw) -> None:
    """Issue 9: Time scale = 1e6 (the slider's max is 4) froze a scene."""
    playback = Playback(PRESETS, controls=panel)
    handles = playback.add_gui()
    assert send_value(panel, "time_scale", 2.0)
    assert not send_value(panel, "time_scale", raw)
    assert playback.time_scale == 2.0 and handles["time_scale"].value == 2.0
    wait_until(lambda: panel.gate.refused_count > 0)
    assert playback.tick(0.1).step == pytest.approx(0.2)


def test_gui_without_the_time_scale_slider_leaves_the_scale_to_the_scene(panel) -> None:
    # a scene that sets the scale from a control of its own (the cam's seconds per turn: 0.004 and less)
    playback = Playback(controls=panel)
    handles = playback.add_gui(time_scale=False)
    assert list(handles) == ["playback"] and "time_scale" not in panel.specs
    playback.set_time_scale(0.004)  # outside the slider's range: the scene's own
    assert playback.time_scale == 0.004
    assert playback.tick(0.5).step == pytest.approx(0.002, rel=1e-15)
    click(panel, "playback", "Pause")  # the row works as with the slider
    assert playback.tick(0.1) == Tick(reset=False, step=0.0) and not playback.playing
    click(panel, "playback", "Reset")
    assert playback.tick(0.0).reset
    assert panel.state() == {}  # nothing of the playback in the scene's state
    with pytest.raises(ValueError, match=r"scale: expected a finite number > 0, got"):
        playback.set_time_scale(0.0)
