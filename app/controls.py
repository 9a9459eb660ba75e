"""Declared controls: what a scene's GUI inputs accept, and how browser values are checked.

Every GUI input of every scene is declared with one of the small frozen
dataclasses below (a *spec*) and created by :class:`rigidlab.app.panel.ControlPanel`.
A spec knows two checks:

``check(raw)``
    The *gate* check, run by :mod:`rigidlab.app.gate` on the raw value a browser sent,
    before viser stores it or broadcasts it to other browsers: the right type,
    finite, inside the declared range. A refused value never reaches viser's
    state, other browsers or late joiners.
``parse(text)``
    Text controls only (:class:`NumberText`, :class:`VectorText`): the app's
    own parser for what was typed (scientific notation, full precision,
    ``1e-3`` stays ``1e-3``). Text is checked at the gate only for its type and
    length, since every keystroke is sent and ``"1e"`` is on the way to
    ``"1e-3"``; the panel keeps the value in use while the text does not parse
    and, after a short pause in typing, restores it with a notice.

Both raise :class:`Refused`, whose message says what was expected and what was
given; the panel adds the control's label.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

__all__ = [
    "Refused",
    "Control",
    "Slider",
    "NumberText",
    "VectorText",
    "Choice",
    "Toggle",
    "Button",
    "ButtonGroup",
    "Text",
    "format_number",
    "format_vector",
    "describe",
]

#: Longest text accepted from a browser in a numeric text field (characters).
NUMBER_TEXT_MAX = 80
#: Longest text accepted in a free text field (characters): a pasted state.
TEXT_MAX = 20_000


class Refused(ValueError):
    """A value a control does not accept; ``str(exc)`` says expected and got."""


def describe(raw: Any, limit: int = 40) -> str:
    """Short printable form of a value a browser sent (for notices and logs)."""
    if isinstance(raw, float):
        text = repr(raw)
    elif isinstance(raw, str):
        text = repr(raw if len(raw) <= limit else raw[:limit] + "...")
    else:
        text = repr(raw)
    return text if len(text) <= limit + 5 else text[:limit] + "..."


def format_number(x: float) -> str:
    """Shortest text that reads back as ``x`` (``1e-05``, ``0.25``, ``3``)."""
    x = float(x)
    if x.is_integer() and abs(x) < 1e16:
        return str(int(x))
    return repr(x)


def format_vector(values: Any) -> str:
    """``"x, y, z"`` with :func:`format_number` for each component."""
    return ", ".join(format_number(v) for v in values)


def _is_real_number(raw: Any) -> bool:
    return isinstance(raw, (int, float)) and not isinstance(raw, bool)


def _range_text(lo: float, hi: float) -> str:
    if math.isinf(lo) and math.isinf(hi):
        return "a finite number"
    if math.isinf(hi):
        return f"a number >= {format_number(lo)}"
    if math.isinf(lo):
        return f"a number <= {format_number(hi)}"
    return f"a number from {format_number(lo)} to {format_number(hi)}"


def _check_number(x: Any, lo: float, hi: float, *, integer: bool, raw: Any) -> float | int:
    """``x`` as a float (or int) inside ``[lo, hi]``, else :class:`Refused`."""
    what = ("an integer" if integer else "a number") if math.isinf(lo) and math.isinf(hi) else (
        _range_text(lo, hi).replace("a number", "an integer") if integer else _range_text(lo, hi)
    )
    if not _is_real_number(x):
        raise Refused(f"expected {what}, got {describe(raw)}")
    try:
        value = float(x)
    except OverflowError:  # an int too large for a float
        raise Refused(f"expected {what}, got {describe(raw)}") from None
    if not math.isfinite(value):
        raise Refused(f"expected {what}, got {describe(raw)}")
    # A hair of tolerance for values that arrive through float32 or decimal text.
    span = (hi - lo) if math.isfinite(hi - lo) else 0.0
    eps = 1e-9 * max(span, abs(lo) if math.isfinite(lo) else 0.0, abs(hi) if math.isfinite(hi) else 0.0)
    if value < lo - eps or value > hi + eps:
        raise Refused(f"expected {what}, got {describe(raw)}")
    value = min(max(value, lo), hi)
    if integer:
        if not value.is_integer():
            raise Refused(f"expected {what}, got {describe(raw)}")
        return int(value)
    return value


@dataclasses.dataclass(frozen=True)
class Control:
    """Fields every control has.

    Attributes
    ----------
    key : name of the value in the scene's state (a Python identifier)
    label : text shown beside the input
    hint : tooltip
    in_state : whether the value belongs to the scene's shareable state
    """

    key: str
    label: str
    hint: str | None = dataclasses.field(default=None, kw_only=True)
    in_state: bool = dataclasses.field(default=True, kw_only=True)

    #: Kind name used by the panel to create the viser element.
    kind = "control"

    def check(self, raw: Any) -> Any:  # pragma: no cover - abstract
        """Gate check of a raw browser value; returns the value viser stores."""
        raise NotImplementedError

    def parse(self, value: Any) -> Any:
        """The value a scene sees for the stored ``value`` (identity by default)."""
        return value

    def display(self, value: Any) -> Any:
        """What the GUI element shows for the scene value ``value``."""
        return value


@dataclasses.dataclass(frozen=True)
class Slider(Control):
    """A number set by dragging (or typing into the slider's box), in ``[min, max]``."""

    min: float = 0.0
    max: float = 1.0
    step: float = 0.01
    default: float = 0.0
    integer: bool = False
    kind = "slider"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.min) and math.isfinite(self.max) and self.min < self.max):
            raise ValueError(f"{self.key}: expected finite min < max, got {self.min}, {self.max}")
        _check_number(self.default, self.min, self.max, integer=self.integer, raw=self.default)

    def check(self, raw: Any) -> float | int:
        return _check_number(raw, self.min, self.max, integer=self.integer, raw=raw)

    def display(self, value: Any) -> float | int:
        return int(value) if self.integer else float(value)


_NUMBER_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def _parse_float(token: str) -> float:
    """A decimal number (scientific notation allowed); no nan, inf, hex or underscores."""
    if not _NUMBER_RE.match(token):
        raise ValueError(token)
    return float(token)


@dataclasses.dataclass(frozen=True)
class NumberText(Control):
    """A number typed as text and parsed by the app (``2.5e-3``, full precision)."""

    default: float = 0.0
    min: float = -math.inf
    max: float = math.inf
    integer: bool = False
    kind = "number_text"

    def __post_init__(self) -> None:
        _check_number(self.default, self.min, self.max, integer=self.integer, raw=self.default)

    def check(self, raw: Any) -> str:
        if not isinstance(raw, str) or len(raw) > NUMBER_TEXT_MAX:
            raise Refused(f"expected text of at most {NUMBER_TEXT_MAX} characters, got {describe(raw)}")
        return raw

    def parse(self, value: Any) -> float | int:
        what = _range_text(self.min, self.max)
        try:
            number = _parse_float(str(value).strip())
        except ValueError:
            number = math.nan
        if not math.isfinite(number):
            raise Refused(f"expected {what} (like 0.25 or 2.5e-3), got {describe(value)}")
        return _check_number(number, self.min, self.max, integer=self.integer, raw=value)

    def display(self, value: Any) -> str:
        return format_number(value)


_SPLIT_RE = re.compile(r"[\s,;]+")


@dataclasses.dataclass(frozen=True)
class VectorText(Control):
    """``size`` numbers typed as ``"x, y, z"`` (commas or spaces; brackets allowed)."""

    default: tuple[float, ...] = (0.0, 0.0, 0.0)
    size: int = 3
    min: float = -math.inf
    max: float = math.inf
    nonzero: bool = False
    kind = "vector_text"

    def __post_init__(self) -> None:
        if len(self.default) != self.size:
            raise ValueError(f"{self.key}: expected a default of {self.size} numbers, got {self.default}")

    def check(self, raw: Any) -> str:
        if not isinstance(raw, str) or len(raw) > self.size * NUMBER_TEXT_MAX:
            raise Refused(
                f"expected text of at most {self.size * NUMBER_TEXT_MAX} characters, got {describe(raw)}"
            )
        return raw

    def parse(self, value: Any) -> tuple[float, ...]:
        example = ", ".join(["1", "0", "2.5e-3", "4", "5"][: self.size])
        what = f"{self.size} numbers like {example}"
        if not (math.isinf(self.min) and math.isinf(self.max)):
            what += ", each " + _range_text(self.min, self.max).replace("a number ", "")
        text = str(value).strip().strip("()[]").strip()
        tokens = [t for t in _SPLIT_RE.split(text) if t]
        if len(tokens) != self.size:
            raise Refused(f"expected {what}, got {describe(value)}")
        try:
            numbers = tuple(_parse_float(t) for t in tokens)
        except ValueError:
            raise Refused(f"expected {what}, got {describe(value)}") from None
        for x in numbers:
            if not (math.isfinite(x) and self.min <= x <= self.max):
                raise Refused(f"expected {what}, got {describe(value)}")
        if self.nonzero and not any(numbers):
            raise Refused(f"expected {self.size} numbers not all zero, got {describe(value)}")
        return numbers

    def display(self, value: Any) -> str:
        return format_vector(value)


@dataclasses.dataclass(frozen=True)
class Choice(Control):
    """One of a fixed tuple of options (a dropdown)."""

    options: tuple[str, ...] = ()
    default: str = ""
    kind = "choice"

    def __post_init__(self) -> None:
        if self.default not in self.options:
            raise ValueError(f"{self.key}: expected a default in {self.options}, got {self.default!r}")

    def check(self, raw: Any) -> str:
        if not isinstance(raw, str) or raw not in self.options:
            shown = list(self.options) if len(self.options) <= 6 else list(self.options[:6]) + ["..."]
            raise Refused(f"expected one of {shown}, got {describe(raw)}")
        return raw


@dataclasses.dataclass(frozen=True)
class Toggle(Control):
    """On or off (a checkbox)."""

    default: bool = False
    kind = "toggle"

    def check(self, raw: Any) -> bool:
        if not isinstance(raw, bool):
            raise Refused(f"expected true or false, got {describe(raw)}")
        return raw


@dataclasses.dataclass(frozen=True)
class Button(Control):
    """A click (not part of the state)."""

    in_state: bool = dataclasses.field(default=False, kw_only=True)
    kind = "button"

    def check(self, raw: Any) -> bool:
        if not isinstance(raw, bool):
            raise Refused(f"expected a click, got {describe(raw)}")
        return raw


@dataclasses.dataclass(frozen=True)
class ButtonGroup(Control):
    """A row of buttons; a click gives the option clicked (not part of the state)."""

    options: tuple[str, ...] = ()
    in_state: bool = dataclasses.field(default=False, kw_only=True)
    kind = "button_group"

    def check(self, raw: Any) -> str:
        if not isinstance(raw, str) or raw not in self.options:
            raise Refused(f"expected one of {list(self.options)}, got {describe(raw)}")
        return raw


@dataclasses.dataclass(frozen=True)
class Text(Control):
    """Free text (a pasted state, a note); not part of the state by default."""

    default: str = ""
    multiline: bool = False
    max_length: int = TEXT_MAX
    disabled: bool = False
    in_state: bool = dataclasses.field(default=False, kw_only=True)
    kind = "text"

    def check(self, raw: Any) -> str:
        if self.disabled:
            raise Refused(f"this field is read-only, got {describe(raw)}")
        if not isinstance(raw, str) or len(raw) > self.max_length:
            raise Refused(f"expected text of at most {self.max_length} characters, got {describe(raw)}")
        return raw
