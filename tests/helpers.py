"""Small helpers shared by the app and browser tests."""

from __future__ import annotations

import time
from collections.abc import Callable


def wait_until(predicate: Callable[[], object], timeout: float = 20.0, *, interval: float = 0.02) -> bool:
    """Poll ``predicate`` until it is true; the session loop runs at ~60 Hz.

    Returns True as soon as ``predicate()`` is true (so ``assert wait_until(...)``
    reads naturally); raises ``AssertionError`` after ``timeout`` seconds.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    if predicate():  # one last look after the deadline
        return True
    raise AssertionError(f"condition not met within {timeout:g} s")
