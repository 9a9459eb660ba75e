"""Control specs (app/controls.py): the gate checks and the app's text parser.

The references are hand-written: what a browser may send (JSON/msgpack
types) and what each control must accept or refuse, with the message.
"""

from __future__ import annotations

import math
import re

import pytest

from rigidlab.app.controls import (
    Button,
    ButtonGroup,
    Choice,
    NumberText,
    Refused,
    Slider,
    Text,
    Toggle,
    VectorText,
    describe,
    format_number,
    format_vector,
)

SLIDER = Slider("s", "Time scale", min=0.05, max=4.0, step=0.05, default=1.0)
STEPS = Slider("k", "Rodriguez steps", min=0, max=3, step=1, default=3, integer=True)


@pytest.mark.parametrize("raw", [0.05, 1, 2.5, 4.0, 4.0 + 1e-12])
def test_slider_accepts_numbers_in_range(raw: float) -> None:
    value = SLIDER.check(raw)
    assert isinstance(value, float) and 0.05 <= value <= 4.0


@pytest.mark.parametrize(
    "raw", [1e6, -1.0, 0.0, math.nan, math.inf, -math.inf, 1e308, "1", None, True, [1.0], 2**70]
)
def test_slider_refuses_everything_else_naming_range_and_value(raw: object) -> None:
    with pytest.raises(Refused, match=r"expected a number from 0\.05 to 4, got "):
        SLIDER.check(raw)


@pytest.mark.parametrize(("raw", "message"), [
    (1e308, "got 1e+308"), (2.5, "got 2.5"), (-1, "got -1"), (4, "got 4"), (math.nan, "got nan"),
])
def test_integer_slider_takes_integers_only(raw: float, message: str) -> None:
    with pytest.raises(Refused, match="expected an integer from 0 to 3, " + re.escape(message)):
        STEPS.check(raw)
    assert STEPS.check(2.0) == 2 and isinstance(STEPS.check(2.0), int)


def test_slider_declaration_is_checked() -> None:
    with pytest.raises(ValueError, match="expected finite min < max"):
        Slider("x", "x", min=1.0, max=0.0)
    with pytest.raises(Refused):
        Slider("x", "x", min=0.0, max=1.0, default=2.0)


@pytest.mark.parametrize(("text", "value"), [
    ("1e-3", 1e-3), ("  2.5E+10 ", 2.5e10), ("-0.1", -0.1), (".5", 0.5), ("3.", 3.0),
    ("0.123456789012345678", 0.123456789012345678), ("1e-300", 1e-300),
])
def test_number_text_parses_scientific_notation_at_full_precision(text: str, value: float) -> None:
    spec = NumberText("x", "x", default=0.0)
    assert spec.parse(text) == value


@pytest.mark.parametrize("text", ["1e400", "-1e400", "nan", "inf", "-inf", "abc", "", "1e", "0x10", "1_000",
                                  "1,5", "1 2", "1+2j", "--1"])
def test_number_text_refuses_what_is_not_a_finite_number(text: str) -> None:
    spec = NumberText("x", "x", default=0.0)
    with pytest.raises(Refused, match=r"expected a finite number \(like 0\.25 or 2\.5e-3\), got '"):
        spec.parse(text)


def test_number_text_range_and_gate() -> None:
    spec = NumberText("dt", "Step", default=0.01, min=1e-6, max=1.0)
    with pytest.raises(Refused, match=r"expected a number from 1e-06 to 1, got '0'"):
        spec.parse("0")
    assert spec.check("anything short") == "anything short"  # text passes the gate as text
    for raw in (1.0, None, ["1"], "9" * 1000):
        with pytest.raises(Refused, match="expected text of at most 80 characters"):
            spec.check(raw)


@pytest.mark.parametrize(("text", "value"), [
    ("1, 0, 2.5e-3", (1.0, 0.0, 2.5e-3)), ("(1 2 3)", (1.0, 2.0, 3.0)), ("[0.1;0.2;0.3]", (0.1, 0.2, 0.3)),
    ("0.57735026918962584, 0.57735026918962584, 0.57735026918962584", (0.57735026918962584,) * 3),
])
def test_vector_text_parses(text: str, value: tuple[float, ...]) -> None:
    assert VectorText("v", "v").parse(text) == value


@pytest.mark.parametrize("text", ["1, 2", "1, 2, 3, 4", "1, nan, 3", "a, b, c", "1e400, 0, 0", ""])
def test_vector_text_refuses(text: str) -> None:
    with pytest.raises(Refused, match=r"expected 3 numbers like 1, 0, 2\.5e-3, got "):
        VectorText("v", "v").parse(text)


def test_vector_text_nonzero_and_range() -> None:
    spec = VectorText("axis", "Axis", default=(0.0, 0.0, 1.0), nonzero=True, min=-10.0, max=10.0)
    with pytest.raises(Refused, match="expected 3 numbers not all zero, got '0 0 0'"):
        spec.parse("0 0 0")
    with pytest.raises(Refused, match="each from -10 to 10"):
        spec.parse("11, 0, 0")
    with pytest.raises(ValueError, match="expected a default of 3 numbers"):
        VectorText("v", "v", default=(1.0, 2.0))


def test_choice_toggle_buttons_text() -> None:
    choice = Choice("c", "Method", options=("rk4", "splitting"), default="rk4")
    assert choice.check("splitting") == "splitting"
    with pytest.raises(Refused, match=r"expected one of \['rk4', 'splitting'\], got 'euler'"):
        choice.check("euler")
    with pytest.raises(Refused, match="got 1"):
        choice.check(1)
    with pytest.raises(ValueError, match="expected a default in"):
        Choice("c", "c", options=("a",), default="b")
    assert Toggle("t", "t").check(True) is True
    with pytest.raises(Refused, match="expected true or false, got 1"):
        Toggle("t", "t").check(1)
    assert Button("b", "b").check(True) is True
    group = ButtonGroup("p", "Playback", options=("Play", "Pause"))
    with pytest.raises(Refused, match=r"expected one of \['Play', 'Pause'\], got 'Stop'"):
        group.check("Stop")
    text = Text("t", "State", max_length=10)
    with pytest.raises(Refused, match="expected text of at most 10 characters"):
        text.check("x" * 11)
    with pytest.raises(Refused, match="this field is read-only"):
        Text("t", "t", disabled=True).check("x")
    assert not Button("b", "b").in_state and not text.in_state and choice.in_state


def test_formatting_round_trips() -> None:
    for x in (1e-3, 0.1, 1.0 / 3.0, 12345.678, -2.5e-300, 3.0, 1e17):
        assert float(format_number(x)) == x
    assert format_number(3.0) == "3" and format_number(1e-5) == "1e-05"
    assert format_vector((1.0, 0.5, -2e-9)) == "1, 0.5, -2e-09"
    assert describe("x" * 100).endswith("...'") and describe(math.nan) == "nan"


def test_a_browser_value_not_yet_taken_survives_the_loop_showing_another(server) -> None:
    """The loop fills a field that only shows the scene's state (``set(..., keep_browser=True)``) in the
    frame a browser typed into it: the browser's value is newer, so it stays and is taken as a change next
    frame. A plain ``set`` (a preset, a scene's own change) and a loaded state replace it."""
    from rigidlab.app.gate import Gate
    from rigidlab.app.panel import ControlPanel
    from tests.helpers import send_value

    with server.gui.add_folder("Race test") as folder:
        panel = ControlPanel(server.gui, Gate.for_gui(server.gui), lambda client, *notice: None)
        panel.add(VectorText("axis", "Axis", default=(0.0, 0.0, 1.0), nonzero=True))
        panel.add(NumberText("angle", "Angle", default=0.0))
        try:
            panel.take_changes()
            assert send_value(panel, "axis", "1, 2, 3")
            panel.set("axis", (0.0, 1.0, 0.0), keep_browser=True)  # the loop, before its next take_changes
            assert panel.value("axis") == (1.0, 2.0, 3.0)
            assert panel.take_changes() == {"axis"}
            panel.set("axis", (0.0, 1.0, 0.0), keep_browser=True)  # taken: the loop's value shows
            assert panel.value("axis") == (0.0, 1.0, 0.0)
            assert panel.handles["axis"].value == "0, 1, 0"
            assert send_value(panel, "axis", "1, 2, 3")
            panel.set("axis", (0.0, 0.0, 1.0))  # a scene's own change
            assert panel.value("axis") == (0.0, 0.0, 1.0)
            panel.take_changes()
            assert send_value(panel, "angle", "30")
            assert panel.load({"angle": 45.0}) == []
            assert panel.value("angle") == 45.0 and panel.take_changes() == {"angle"}
        finally:
            panel.remove_all()
            folder.remove()
