"""viser's message events, set from any thread, wake the event loop only from its own thread.

The session loop (:mod:`rigidlab.app.server`) runs scenes in its own thread, and every
pose, property or GUI write it makes (:mod:`rigidlab.app.nodes`, viser's setters)
ends in viser 1.1.1's ``AsyncMessageBuffer.push``
(``viser/infra/_async_message_buffer.py``). ``push`` stores the message under
a ``threading.Lock`` (safe), wakes the loop with
``loop.call_soon_threadsafe(message_event.set)`` (safe), and *also* calls
``message_event.set()`` directly from the caller's thread. That one call is
not thread-safe: ``asyncio.Event.set`` iterates the event's waiters (a
``collections.deque``) and resolves their futures, while on the event-loop
thread every client's window generator adds and removes its waiter in
``Event.wait()``. When both happen at once the writing thread gets
``RuntimeError: deque mutated during iteration`` (a scene paused for good
under client churn, issue 28). It is the only place where viser 1.1.1
touches an asyncio object from the caller's thread: ``flush``, ``atomic_end``
and ``set_done`` already go through ``call_soon_threadsafe``; GUI callbacks
and handle cleanups through ``run_coroutine_threadsafe``.

:func:`install` (called by :func:`rigidlab.app.server.create_app` before it creates
the ``ViserServer``) makes each message buffer's two events
:class:`LoopEvent`\\ s: on the loop's own thread ``set()`` is asyncio's; from
any other thread it does nothing, because ``push`` (or ``atomic_end``) hands
the same set to the loop with ``call_soon_threadsafe`` anyway. Nothing waits
on ``message_event`` outside the loop and nothing reads ``is_set()``, so
dropping the direct set changes no behaviour beyond removing the race.
"""

from __future__ import annotations

import asyncio
import dataclasses
import functools
from typing import Any

from viser.infra._async_message_buffer import AsyncMessageBuffer

__all__ = ["LoopEvent", "install", "installed"]

_EVENTS = ("message_event", "flush_event")


class LoopEvent(asyncio.Event):
    """An ``asyncio.Event`` of ``loop`` whose :meth:`set` may be called from any thread.

    Parameters
    ----------
    loop : asyncio.AbstractEventLoop
        The loop whose tasks wait on the event (viser's server loop).
    """

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        super().__init__()
        self._home_loop = loop

    def set(self) -> None:
        """Set the event on the loop's thread; from any other thread, do nothing.

        viser 1.1.1's ``push`` is the one caller off the loop, and every such
        call is followed by viser's own thread-safe wake-up of the same event:
        ``call_soon_threadsafe(message_event.set)`` right after it outside an
        ``atomic()`` block, or once at the block's end (``atomic_end``). The
        direct set only made ``is_set()`` true at once for synchronous readers,
        and viser has none. Scheduling a set of our own for every message
        instead (the first form of this adapter) wrote to the loop's wake-up
        socket once per message and undid ``atomic()``'s batching: 2.9 of 5.6 s
        of the rolling disk's loop-thread CPU over 900 frames.
        """
        if asyncio._get_running_loop() is self._home_loop:
            super().set()


def installed() -> bool:
    """Whether :func:`install` has patched viser's message buffers in this process."""
    return getattr(AsyncMessageBuffer.__init__, "rigidlab_loop_events", False)


def install() -> None:
    """Give every viser message buffer created from now on :class:`LoopEvent`\\ s (idempotent).

    Call before creating a ``viser.ViserServer``: its broadcast buffer is made
    when the server starts, a client's buffer when the client connects.

    Raises
    ------
    RuntimeError
        If viser's ``AsyncMessageBuffer`` no longer has the two events (a viser
        other than 1.1.x): the race must then be looked at again.
    """
    if installed():
        return
    names = {field.name for field in dataclasses.fields(AsyncMessageBuffer)}
    if not set(_EVENTS) <= names:
        raise RuntimeError(f"viser's AsyncMessageBuffer: expected fields {_EVENTS}, got {sorted(names)}")
    original = AsyncMessageBuffer.__init__

    @functools.wraps(original)
    def __init__(self: AsyncMessageBuffer, *args: Any, **kwargs: Any) -> None:
        original(self, *args, **kwargs)
        for name in _EVENTS:
            if type(getattr(self, name)) is asyncio.Event:  # nothing waits on it yet
                setattr(self, name, LoopEvent(self.event_loop))

    __init__.rigidlab_loop_events = True  # type: ignore[attr-defined]
    AsyncMessageBuffer.__init__ = __init__  # type: ignore[method-assign]
