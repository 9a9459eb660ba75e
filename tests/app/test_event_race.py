"""The scene layer drops a frame hit by viser's cross-thread ``asyncio.Event.set`` race instead of pausing."""

from __future__ import annotations

import asyncio
import collections

from app.scenes.base import _asyncio_event_race


def _race_error() -> RuntimeError:
    """The error ``asyncio.Event.set`` raises when another thread adds a waiter while it iterates them."""
    event = asyncio.Event()

    class Waiter:
        def done(self) -> bool:
            event._waiters.append(Waiter())  # the other thread's waiter arrives mid-iteration
            return True

    event._waiters = collections.deque([Waiter(), Waiter()])
    try:
        event.set()
    except RuntimeError as exc:
        return exc
    raise AssertionError("asyncio.Event.set did not raise on a deque mutated during iteration")


def test_the_race_in_asyncio_event_set_is_recognized() -> None:
    assert _asyncio_event_race(_race_error())


def test_other_errors_still_pause_the_scene() -> None:
    try:
        raise RuntimeError("deque mutated during iteration")  # same words, raised by scene code: a real error
    except RuntimeError as exc:
        assert not _asyncio_event_race(exc)
    assert not _asyncio_event_race(ValueError("x"))
