"""A scene's controls: viser elements made from specs, values checked once.

:class:`ControlPanel` creates the GUI element of each declared control
(:mod:`rigidlab.app.controls`) in the current GUI folder, registers the control's check
with the gate of the GUI API (:mod:`rigidlab.app.gate`), and records what browsers
change. It is the only way a scene gets GUI input, so every value a scene sees
has passed one boundary:

* at the gate, before viser stores or broadcasts it: type, finiteness, range;
* here, for text controls: the app's own parser (scientific notation, full
  precision). Text that does not parse is kept out of the scene; after a
  short pause in typing the field is set back to the value in use and the
  browser that typed it gets a notice naming the control and the value.

Threads: viser runs the element callbacks in its thread pool; they only
record, under the panel's lock. The session loop reads the values and the
changes (:meth:`values`, :meth:`take_changes`, :meth:`take_clicks`) and shows
scene values (:meth:`set`); a value shown by the loop is not a change.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from rigidlab.app.controls import (
    Button,
    ButtonGroup,
    Choice,
    Control,
    NumberText,
    Refused,
    Slider,
    Text,
    Toggle,
    VectorText,
    describe,
)
from rigidlab.app.gate import Gate

__all__ = ["ControlPanel", "NotifyClient", "TEXT_RESTORE_SECONDS"]

_log = logging.getLogger(__name__)

#: Text that does not parse is set back to the value in use after this many
#: seconds without a new keystroke (s).
TEXT_RESTORE_SECONDS = 1.5

#: ``notify_client(client_or_None, title, body, level)``: a notice to the
#: browser that acted (or to the whole audience when ``client`` is None).
NotifyClient = Callable[[Any, str, str, str], None]


class ControlPanel:
    """The declared controls of one scene (or of the session shell).

    Parameters
    ----------
    gui : viser.GuiApi
        Where elements are created (``server.gui`` or ``client.gui``).
    gate : app.gate.Gate
        The gate of ``gui``.
    notify_client : callable
        ``notify_client(client, title, body, level)``; ``client`` is the
        ``viser.ClientHandle`` that sent a refused value, or None.
    """

    def __init__(self, gui: Any, gate: Gate, notify_client: NotifyClient) -> None:
        self.gui = gui
        self.gate = gate
        self._notify_client = notify_client
        self._lock = threading.Lock()
        self.specs: dict[str, Control] = {}
        self.handles: dict[str, Any] = {}
        self._values: dict[str, Any] = {}
        self._changed: set[str] = set()
        self._clicks: list[tuple[str, Any, Any]] = []  # (key, value, client)
        self._pending: dict[str, tuple[float, str, str, Any]] = {}  # key -> (time, text, reason, client)
        self._version = 0

    # -- creation ------------------------------------------------------------
    def add(self, spec: Control, **element_kwargs: Any) -> Any:
        """Create the element of ``spec`` in the current GUI folder; return its handle.

        ``element_kwargs`` go to viser's ``add_*`` call (``order``, ``visible``,
        ``disabled``, ``color``...).

        Raises
        ------
        ValueError
            If a control with the same key exists already.
        """
        if spec.key in self.specs:
            raise ValueError(f"spec: expected a new key, got {spec.key!r} twice")
        gui = self.gui
        hint = spec.hint
        if isinstance(spec, Slider):
            handle = gui.add_slider(
                spec.label, min=spec.min, max=spec.max, step=spec.step,
                initial_value=spec.display(spec.default), hint=hint, **element_kwargs,
            )
            value: Any = spec.display(spec.default)
        elif isinstance(spec, (NumberText, VectorText)):
            handle = gui.add_text(spec.label, initial_value=spec.display(spec.default), hint=hint, **element_kwargs)
            value = spec.parse(spec.display(spec.default))
        elif isinstance(spec, Choice):
            handle = gui.add_dropdown(spec.label, options=spec.options, initial_value=spec.default, hint=hint,
                                      **element_kwargs)
            value = spec.default
        elif isinstance(spec, Toggle):
            handle = gui.add_checkbox(spec.label, initial_value=spec.default, hint=hint, **element_kwargs)
            value = spec.default
        elif isinstance(spec, ButtonGroup):
            handle = gui.add_button_group(spec.label, options=spec.options, hint=hint, **element_kwargs)
            value = None
        elif isinstance(spec, Button):
            handle = gui.add_button(spec.label, hint=hint, **element_kwargs)
            value = None
        elif isinstance(spec, Text):
            handle = gui.add_text(spec.label, initial_value=spec.default, multiline=spec.multiline,
                                  disabled=spec.disabled, hint=hint, **element_kwargs)
            value = spec.default
        else:
            raise ValueError(f"spec: expected a control of app.controls, got {type(spec).__name__}")
        self.specs[spec.key] = spec
        self.handles[spec.key] = handle
        self._values[spec.key] = value
        self.gate.register(handle, spec.label, spec.check)
        if isinstance(spec, (Button, ButtonGroup)):
            handle.on_click(lambda event, key=spec.key: self._on_click(key, event))
        else:
            handle.on_update(lambda event, key=spec.key: self._on_update(key, event))
        return handle

    def remove_all(self) -> None:
        """Unregister every control from the gate (the elements go with their folder)."""
        for handle in self.handles.values():
            self.gate.unregister(handle)

    # -- browser side (viser's thread pool) --------------------------------
    def _on_update(self, key: str, event: Any) -> None:
        if event.client_id is None:
            return  # the loop showed a value (set), not a browser change
        spec = self.specs[key]
        stored = event.target.value
        try:
            value = spec.parse(stored)
        except Refused as exc:
            with self._lock:
                self._pending[key] = (time.monotonic(), str(stored), str(exc), event.client)
            return
        with self._lock:
            self._pending.pop(key, None)
            self._values[key] = value
            self._changed.add(key)
            self._version += 1

    def _on_click(self, key: str, event: Any) -> None:
        value = getattr(event.target, "value", None) if isinstance(self.specs[key], ButtonGroup) else True
        with self._lock:
            self._clicks.append((key, value, event.client))
            self._version += 1

    # -- loop side ---------------------------------------------------------------
    @property
    def version(self) -> int:
        """Counts browser changes and clicks (a paused scene resumes when it moves)."""
        with self._lock:
            return self._version

    def value(self, key: str) -> Any:
        """The value in use of control ``key``."""
        with self._lock:
            return self._values[key]

    def values(self) -> dict[str, Any]:
        """Snapshot of every control's value in use."""
        with self._lock:
            return dict(self._values)

    def take_changes(self) -> set[str]:
        """Keys changed by browsers since the last call (and forget them)."""
        with self._lock:
            changed, self._changed = self._changed, set()
        return changed

    def take_clicks(self, keys: Iterable[str] | None = None) -> list[tuple[str, Any, Any]]:
        """Clicks ``(key, value, client)`` since the last call, oldest first.

        With ``keys``, only clicks of those controls are taken; others stay.
        ``value`` is the option clicked for a button group, else True.
        """
        with self._lock:
            if keys is None:
                taken, self._clicks = self._clicks, []
            else:
                wanted = set(keys)
                taken = [c for c in self._clicks if c[0] in wanted]
                self._clicks = [c for c in self._clicks if c[0] not in wanted]
        return taken

    def set(self, key: str, value: Any, *, keep_browser: bool = False) -> None:
        """Show the scene value ``value`` in control ``key`` (not a change).

        ``keep_browser``: for a field that only shows the scene's state (the
        sandbox fills the fields of a newly chosen input from the current
        orientation), a browser's value of ``key`` that arrived after the
        loop's last :meth:`take_changes` is newer than what the loop shows:
        it is kept and taken as a change next frame, not overwritten (which
        dropped an axis typed in the frame the input was switched).

        Raises
        ------
        ValueError
            If the control would refuse ``value`` (a scene bug, never user input).
        """
        spec = self.specs[key]
        checked = self._checked(spec, value)
        handle = self.handles[key]
        shown = spec.display(checked)
        with self._lock:
            if keep_browser and key in self._changed:
                return
            self._values[key] = checked
            self._pending.pop(key, None)
        if handle.value != shown:
            handle.value = shown

    def set_many(self, values: Mapping[str, Any], *, keep_browser: bool = False) -> None:
        """:meth:`set` for several controls."""
        for key, value in values.items():
            self.set(key, value, keep_browser=keep_browser)

    @staticmethod
    def _checked(spec: Control, value: Any) -> Any:
        """``value`` as the scene value ``spec`` accepts (``Refused`` -> ValueError)."""
        try:
            if isinstance(spec, NumberText):
                if isinstance(value, str):
                    return spec.parse(value)
                return spec.parse(spec.display(value) if _is_finite_number(value) else describe(value))
            if isinstance(spec, VectorText):
                if isinstance(value, str):
                    return spec.parse(value)
                if not isinstance(value, (list, tuple)):
                    raise Refused(f"expected {spec.size} numbers, got {describe(value)}")
                items = list(value)
                if not all(_is_finite_number(v) for v in items):
                    raise Refused(f"expected {spec.size} finite numbers, got {describe(value)}")
                return spec.parse(spec.display(items))
            if isinstance(spec, Text):  # the server may fill a read-only field
                if not isinstance(value, str) or len(value) > spec.max_length:
                    raise Refused(f"expected text of at most {spec.max_length} characters, got {describe(value)}")
                return value
            if isinstance(spec, Slider) and _is_finite_number(value):
                return spec.check(float(value) if not spec.integer else value)
            return spec.check(value)
        except Refused as exc:
            raise ValueError(f"{spec.key}: {exc}") from None

    def poll(self, now: float | None = None) -> None:
        """Set text that did not parse back to the value in use, once typing paused."""
        now = time.monotonic() if now is None else now
        with self._lock:
            due = [(k, v) for k, v in self._pending.items() if now - v[0] >= TEXT_RESTORE_SECONDS]
            for key, _ in due:
                del self._pending[key]
        for key, (_, text, reason, client) in due:
            spec = self.specs[key]
            in_use = self.value(key)
            self._notify_client(
                client,
                f"Refused: {spec.label}",
                f"{reason}. Showing the value in use, {spec.display(in_use)}.",
                "warning",
            )
            self.handles[key].value = spec.display(in_use)

    # -- shareable state ---------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """Values of the controls that belong to the state (JSON types)."""
        values = self.values()
        out: dict[str, Any] = {}
        for key, spec in self.specs.items():
            if not spec.in_state:
                continue
            value = values[key]
            out[key] = list(value) if isinstance(value, tuple) else value
        return out

    def load(self, values: Mapping[str, Any]) -> list[str]:
        """Show and use ``values`` (``{key: value}``, as :meth:`state` gives).

        Each value passes the control's check; keys not given keep their
        value. Returns one message per refused key (unknown key or refused
        value); the accepted ones are applied and count as changes.
        """
        accepted, refused = self.check(values)
        self.apply(accepted)
        return refused

    def check(self, values: Mapping[str, Any]) -> tuple[dict[str, Any], list[str]]:
        """``(accepted, refused)``: the values of ``values`` each control accepts (as scene values) and one
        message per refused key, without applying anything (see :meth:`load`)."""
        refused = []
        accepted: dict[str, Any] = {}
        for key, value in values.items():
            spec = self.specs.get(key)
            if spec is None or not spec.in_state:
                refused.append(f"{key!r}: not a control of this scene")
                continue
            try:
                accepted[key] = self._checked(spec, value)
            except ValueError as exc:
                refused.append(f"{spec.label}: {str(exc).split(': ', 1)[-1]}")
            except (TypeError, OverflowError, RecursionError):  # a value of a type no check foresaw: that key only
                refused.append(f"{spec.label}: expected a value like {describe(spec.display(self.value(key)))}, "
                               f"got a {type(value).__name__}")
        return accepted, refused

    def apply(self, accepted: Mapping[str, Any]) -> None:
        """Show and use ``accepted`` (values :meth:`check` accepted); they count as changes."""
        for key, value in accepted.items():
            self.set(key, value)
        with self._lock:
            self._changed |= set(accepted)
            if accepted:
                self._version += 1


def _is_finite_number(x: Any) -> bool:
    if not isinstance(x, (int, float)) or isinstance(x, bool):
        return False
    try:
        return math.isfinite(float(x))
    except OverflowError:  # an int too large for a float
        return False
