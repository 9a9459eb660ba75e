"""Writes from other threads wake viser's event loop thread-safely (:mod:`rigidlab.app.loop_thread`).

The race of issue 28: the session loop's thread pushes messages
(``AsyncMessageBuffer.push``) and viser 1.1.1 sets the buffer's
``asyncio.Event`` from that thread while the event loop adds and removes
the event's waiters (one per client's window generator). Here several
threads push while a hundred loop tasks wait on one buffer, as clients'
generators do. The loop's futures let other threads run whenever a thread
other than the loop's asks whether they are done, as a preemption inside
``Event.set`` would: with asyncio's own event the pushing threads then get
"deque mutated during iteration" (or ``InvalidStateError``) in every run,
with :class:`rigidlab.app.loop_thread.LoopEvent` no thread ever iterates the waiters.
"""

from __future__ import annotations

import asyncio
import threading
import time

from viser import _messages
from viser.infra._async_message_buffer import AsyncMessageBuffer

from rigidlab.app import loop_thread
from tests.helpers import wait_until

WAITERS = 100
THREADS = 4
PUSHES = 50


class _PreemptedFuture(asyncio.Future):
    """A future that lets the other threads run when a thread other than its loop's asks whether it is done
    (``Event.set`` does, for each waiter): the preemption that makes the race, every time instead of by chance."""

    def done(self) -> bool:
        if asyncio._get_running_loop() is None:
            time.sleep(1e-4)
        return super().done()


class _Loop(asyncio.SelectorEventLoop):
    def create_future(self) -> asyncio.Future:
        return _PreemptedFuture(loop=self)


def _push_from_threads(*, plain_event: bool) -> tuple[list[str], int]:
    """Push ``THREADS x PUSHES`` messages from ``THREADS`` threads into one buffer while ``WAITERS`` loop tasks wait
    on its message event; returns the errors the pushing threads got and how many tasks saw the last message.

    ``plain_event`` puts asyncio's own ``Event`` back into the buffer (viser 1.1.1 unpatched).
    """
    loop = _Loop()
    made = threading.Event()
    holder: dict[str, AsyncMessageBuffer] = {}
    stop = False
    seen_last: set[int] = set()
    total = THREADS * PUSHES

    async def generator(index: int, buffer: AsyncMessageBuffer) -> None:
        # what viser's window generator does between windows
        while not stop:
            await buffer.message_event.wait()
            buffer.message_event.clear()
            if buffer.message_counter == total:
                seen_last.add(index)
            await asyncio.sleep(0)

    async def main() -> None:
        buffer = AsyncMessageBuffer(loop, persistent_messages=True)
        if plain_event:
            buffer.message_event = asyncio.Event()
        holder["buffer"] = buffer
        tasks = [asyncio.create_task(generator(i, buffer)) for i in range(WAITERS)]
        made.set()
        while not stop:
            await asyncio.sleep(0.005)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    errors: list[str] = []

    def push(k: int) -> None:
        for i in range(PUSHES):
            try:
                buffer.push(_messages.SetPositionMessage(f"/node_{k}", (float(i), 0.0, 0.0)))
            except Exception as exc:  # noqa: BLE001 - RuntimeError or InvalidStateError from asyncio.Event.set
                errors.append(f"{type(exc).__name__}: {exc}")

    loop_thread_ = threading.Thread(target=loop.run_until_complete, args=(main(),), daemon=True)
    loop_thread_.start()
    try:
        assert made.wait(timeout=60.0)
        buffer = holder["buffer"]
        pushers = [threading.Thread(target=push, args=(k,)) for k in range(THREADS)]
        for thread in pushers:
            thread.start()
        for thread in pushers:
            thread.join()
        if not plain_event and not errors:
            wait_until(lambda: len(seen_last) == WAITERS, timeout=60.0)
    finally:
        stop = True
        loop.call_soon_threadsafe(lambda: None)
        loop_thread_.join(timeout=60.0)
        loop.close()
    return errors, len(seen_last)


def test_threads_pushing_while_the_loop_waits_raise_nothing_and_wake_every_waiter() -> None:
    loop_thread.install()
    errors, woken = _push_from_threads(plain_event=False)
    assert errors == []
    assert woken == WAITERS


def test_the_same_pushes_race_with_asyncio_s_own_event() -> None:
    """The control: without the fix the test above finds the race."""
    errors, _ = _push_from_threads(plain_event=True)
    assert errors
    assert {e.split(":")[0] for e in errors} <= {"RuntimeError", "InvalidStateError"}, errors
    assert any("deque mutated during iteration" in e for e in errors), errors


def test_a_buffer_s_events_are_loop_events_once_installed() -> None:
    loop_thread.install()
    loop_thread.install()  # idempotent
    assert loop_thread.installed()
    loop = asyncio.new_event_loop()
    try:
        buffer = AsyncMessageBuffer(loop, persistent_messages=False)
        assert isinstance(buffer.message_event, loop_thread.LoopEvent)
        assert isinstance(buffer.flush_event, loop_thread.LoopEvent)
    finally:
        loop.close()


def test_an_off_loop_set_on_a_closed_loop_does_nothing() -> None:
    loop = asyncio.new_event_loop()
    event = loop_thread.LoopEvent(loop)
    loop.close()
    event.set()  # a write after the server stopped: no error
    assert not event.is_set()


def test_create_app_installs_it_before_the_server_starts(monkeypatch, running_app) -> None:
    """With the patch taken out (as in a fresh process), the app's server buffers have loop events."""
    loop_thread.install()
    monkeypatch.setattr(AsyncMessageBuffer, "__init__", AsyncMessageBuffer.__init__.__wrapped__)
    assert not loop_thread.installed()
    app = running_app(scene="sandbox")
    assert loop_thread.installed()
    assert isinstance(app.server._websock_server._broadcast_buffer.message_event, loop_thread.LoopEvent)
