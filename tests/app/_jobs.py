"""Module-level jobs for the worker-pool tests (process workers import them by name)."""

from __future__ import annotations

import os
import time


def square(x: float) -> float:
    return x * x


def nap(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def die() -> None:
    os._exit(3)  # a worker that dies (killed, out of memory) breaks the pool


def chunk(k: int, previous: tuple[int, int] | None) -> tuple[int, int]:
    """Chunk ``k`` of a sequential timeline: (k, k of the chunk before, or -1)."""
    return (k, -1 if previous is None else previous[0])


def stamped(label: str, seconds: float = 0.0) -> dict:
    """A mutable result that says which process computed it and when (shared-job tests)."""
    time.sleep(seconds)
    return {"label": label, "pid": os.getpid(), "at": time.time(), "values": [1.0, 2.0]}


def fail(message: str) -> None:
    raise ValueError(message)
