"""The one validation boundary for every GUI value a browser sends.

viser stores a GUI value a browser sends, broadcasts it to every other
browser (and keeps it for late joiners) *before* any callback of ours runs.
A value it cannot serialize (an integer beyond 64 bits, say) then breaks the
connection of every browser, and a NaN or an out-of-range number reaches
every other screen. So the check has to come first: :class:`Gate` takes
viser's handler of ``GuiUpdateMessage`` off a GUI API (the server's in shared
mode, a client's in per-client mode) and puts itself in front of it:

* an update to an element that no control registered, or to any property
  other than ``value``, is dropped;
* the value goes through the control's ``check`` (:mod:`rigidlab.app.controls`); a
  refused value is dropped before viser sees it, so it is never stored,
  broadcast or replayed; the browser that sent it is told why (a notice) and
  gets the value in use back, so its control shows it again;
* an accepted value (cast to the control's type) is handed to viser's own
  handler, which stores it, broadcasts it and runs the callbacks.

This module reaches into viser's private attributes (``_websock_interface``,
``_gui_input_handle_from_uuid``, ``_handle_gui_updates``), as do three other
places, each for one purpose: :func:`client_request_path` (the page's
address), the incoming-message guards of :mod:`rigidlab.app.server` (camera messages
and messages viser cannot decode, dropped before viser stores them) and
:mod:`rigidlab.app.loop_thread` (viser's message events kept to its event loop). All
are checked against viser 1.1.x, which ``pyproject.toml`` pins.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from viser import _messages

from rigidlab.app.controls import Refused, describe

__all__ = ["Gate", "RefusedValue", "client_request_path"]

_log = logging.getLogger(__name__)

#: A refused value of one element is logged at most this often (s).
_LOG_REPEAT_SECONDS = 10.0
#: A browser is told about refused values of one element at most this often (s).
_NOTICE_REPEAT_SECONDS = 2.0


class RefusedValue:
    """What :class:`Gate` tells its owner about a refused value.

    Attributes
    ----------
    client_id : the browser that sent it
    label : the control's label
    raw : the value as sent (short printable form in ``shown``)
    reason : what was expected and what was given
    in_use : the value the control keeps
    """

    __slots__ = ("client_id", "label", "raw", "shown", "reason", "in_use")

    def __init__(self, client_id: int, label: str, raw: Any, reason: str, in_use: Any) -> None:
        self.client_id = client_id
        self.label = label
        self.raw = raw
        self.shown = describe(raw)
        self.reason = reason
        self.in_use = in_use


class Gate:
    """Validation of GUI values in front of viser's handler (see module docstring).

    Parameters
    ----------
    gui_api : viser.GuiApi
        ``server.gui`` (shared mode) or ``client.gui`` (per-client mode).
    on_refused : callable, keyword-only
        ``on_refused(RefusedValue)``, called on viser's event loop thread for
        each refused value (at most every 2 s per browser and element); it
        should only show a notice to ``client_id``.

    Notes
    -----
    Installing two gates on one GUI API is refused (``ValueError``); use
    :meth:`for_gui` to get the one gate of a GUI API.
    """

    def __init__(self, gui_api: Any, *, on_refused: Callable[[RefusedValue], None] | None = None) -> None:
        if getattr(gui_api, "_rigidlab_gate", None) is not None:
            raise ValueError("gui_api: expected a GUI API without a gate, got one that has one")
        self._gui = gui_api
        self._lock = threading.Lock()
        self._checks: dict[str, tuple[str, Callable[[Any], Any]]] = {}
        self._on_refused = on_refused
        self._last_log: dict[tuple[str, str], float] = {}
        self._last_notice: dict[tuple[int, str], float] = {}
        self.refused_count = 0
        interface = gui_api._websock_interface
        self._viser_handler = gui_api._handle_gui_updates
        interface.unregister_handler(_messages.GuiUpdateMessage, self._viser_handler)
        interface.register_handler(_messages.GuiUpdateMessage, self._handle)
        gui_api._rigidlab_gate = self

    @classmethod
    def for_gui(cls, gui_api: Any, *, on_refused: Callable[[RefusedValue], None] | None = None) -> Gate:
        """The gate of ``gui_api``, installed on first use."""
        gate = getattr(gui_api, "_rigidlab_gate", None)
        if gate is None:
            gate = cls(gui_api, on_refused=on_refused)
        elif on_refused is not None:
            gate._on_refused = on_refused
        return gate

    def set_on_refused(self, on_refused: Callable[[RefusedValue], None] | None) -> None:
        """Replace the refusal callback."""
        self._on_refused = on_refused

    # -- registry -----------------------------------------------------------
    def register(self, handle: Any, label: str, check: Callable[[Any], Any]) -> None:
        """Accept browser values of ``handle`` that ``check(raw)`` returns (it raises
        :class:`~rigidlab.app.controls.Refused` otherwise)."""
        with self._lock:
            self._checks[handle._impl.uuid] = (label, check)

    def unregister(self, handle: Any) -> None:
        with self._lock:
            self._checks.pop(handle._impl.uuid, None)

    def registered(self) -> set[str]:
        """uuids of the elements that accept browser values."""
        with self._lock:
            return set(self._checks)

    def input_uuids(self) -> set[str]:
        """uuids of every live GUI element a browser can change (registered or not).

        Progress bars are listed by viser among its inputs, but no page sends
        them values; the gate drops whatever is sent to them (unregistered).
        """
        from viser._gui_handles import GuiProgressBarHandle

        return {
            uuid for uuid, handle in list(self._gui._gui_input_handle_from_uuid.items())
            if not handle._impl.removed and not isinstance(handle, GuiProgressBarHandle)
        }

    # -- the boundary ---------------------------------------------------------
    async def _handle(self, client_id: int, message: Any, *, simulated: bool = False) -> None:
        uuid = getattr(message, "uuid", None)
        updates = getattr(message, "updates", None)
        if not isinstance(uuid, str) or not isinstance(updates, dict):
            self._log_once("?", "malformed GuiUpdateMessage", client_id)
            return
        handle = self._gui._gui_input_handle_from_uuid.get(uuid)
        if handle is None or handle._impl.removed:
            return
        with self._lock:
            entry = self._checks.get(uuid)
        if entry is None:
            self._log_once(uuid, "update of an element that takes no browser values", client_id)
            return
        label, check = entry
        if set(updates) != {"value"}:
            self._log_once(uuid, f"update of properties {sorted(map(str, updates))} of {label!r}", client_id)
            return
        raw = updates["value"]
        try:
            value = check(raw)
        except Refused as exc:
            self._refuse(client_id, handle, label, raw, str(exc))
            return
        except Exception as exc:  # a check must never take the event loop down
            _log.error("check of %r failed on %s: %s", label, describe(raw), exc, exc_info=True)
            self._refuse(client_id, handle, label, raw, f"could not check {describe(raw)}")
            return
        before = handle._impl.value
        await self._viser_handler(client_id, _messages.GuiUpdateMessage(uuid, {"value": value}))
        if simulated and self._gui._resolve_client(client_id) is None:
            # No browser of that id: viser skipped the callbacks; run them as it would
            # (only when the value changed, or for a button).
            from viser._gui_handles import GuiEvent

            if handle._impl.is_button or before != value:
                for callback in handle._impl.update_cb:
                    self._gui._thread_executor.submit(callback, GuiEvent(None, client_id, handle))

    def _refuse(self, client_id: int, handle: Any, label: str, raw: Any, reason: str) -> None:
        self.refused_count += 1
        in_use = handle._impl.value
        self._log_once(handle._impl.uuid, f"refused {label!r}: {reason}", client_id, level=logging.INFO)
        # The sender's control shows what it sent; show it the value in use.
        if not handle._impl.is_button:
            self._send_to(client_id, _messages.GuiUpdateMessage(handle._impl.uuid, {"value": in_use}))
        now = time.monotonic()
        key = (client_id, handle._impl.uuid)
        with self._lock:
            last = self._last_notice.get(key)
            if last is not None and now - last < _NOTICE_REPEAT_SECONDS:
                return
            self._last_notice[key] = now
            if len(self._last_notice) > 10_000:
                self._last_notice.clear()
        if self._on_refused is not None:
            try:
                self._on_refused(RefusedValue(client_id, label, raw, reason, in_use))
            except Exception:
                _log.debug("on_refused failed", exc_info=True)

    def _send_to(self, client_id: int, message: Any) -> None:
        try:
            client = self._gui._resolve_client(client_id)
            if client is not None:
                client._websock_connection.queue_message(message)
        except Exception:
            _log.debug("could not send the value in use back", exc_info=True)

    def _log_once(self, uuid: str, text: str, client_id: int, *, level: int = logging.WARNING) -> None:
        now = time.monotonic()
        key = (uuid, text)
        with self._lock:
            last = self._last_log.get(key)
            if last is not None and now - last < _LOG_REPEAT_SECONDS:
                return
            self._last_log[key] = now
            if len(self._last_log) > 10_000:
                self._last_log.clear()
        _log.log(level, "client %s: %s", client_id, text)

    # -- for tests and benchmarks ---------------------------------------------
    def submit(self, handle: Any, raw: Any, *, client_id: int = -1) -> concurrent.futures.Future:
        """Deliver ``raw`` to ``handle`` exactly as a browser message would arrive
        (on viser's event loop, through the check); returns a future."""
        message = _messages.GuiUpdateMessage(handle._impl.uuid, {"value": raw})
        loop: asyncio.AbstractEventLoop = self._gui._event_loop
        return asyncio.run_coroutine_threadsafe(self._handle(client_id, message, simulated=True), loop)


def client_request_path(server: Any, client_id: int) -> str | None:
    """Path of the websocket request of browser ``client_id`` (``"/"`` normally).

    viser's page connects its websocket to the page's URL without the query
    string, or to the address given by its ``?websocket=`` parameter; a link
    ``http://host:port/?websocket=ws://host:port/state/<state>`` therefore
    shows the server a path that carries a state (see :mod:`rigidlab.app.state`).
    """
    try:
        connection = server._websock_server._live_connections.get(client_id)
        return None if connection is None else str(connection.request.path)
    except Exception:
        _log.debug("no request path for client %s", client_id, exc_info=True)
        return None
