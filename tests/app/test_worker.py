"""The app's process executor: jobs held until a flush, cancellation, a broken pool replaced."""

from __future__ import annotations

import concurrent.futures
import time

import pytest

from app.worker import ChunkTimeline, make_executor
from tests.app import _jobs


@pytest.fixture(scope="module")
def executor():
    executor = make_executor(processes=True, preload=["tests.app._jobs"])
    yield executor
    executor.shutdown(wait=True)


def test_submit_returns_at_once_and_the_job_runs_after_a_flush(executor) -> None:
    future = executor.submit(_jobs.square, 3.0)
    assert not future.done()
    executor.flush()
    assert future.result(timeout=30) == 9.0


def test_held_jobs_run_without_a_flush(executor) -> None:
    """A notebook never calls flush: the dispatcher looks every 20 ms anyway."""
    assert executor.submit(_jobs.square, 4.0).result(timeout=30) == 16.0


def test_a_cancelled_job_that_has_not_started_is_dropped(executor) -> None:
    busy = [executor.submit(_jobs.nap, 0.5) for _ in range(4)]  # more than the workers
    waiting = executor.submit(_jobs.square, 5.0)
    executor.flush()
    time.sleep(0.1)
    assert waiting.cancel()
    assert waiting.cancelled()
    assert [f.result(timeout=30) for f in busy] == [0.5] * 4


def test_a_broken_pool_fails_its_jobs_and_is_replaced(executor) -> None:
    doomed = executor.submit(_jobs.die)
    executor.flush()
    with pytest.raises(concurrent.futures.process.BrokenProcessPool):
        doomed.result(timeout=30)
    # the next job runs on a new pool
    deadline = time.monotonic() + 30
    while True:
        try:
            assert executor.submit(_jobs.square, 6.0).result(timeout=30) == 36.0
            break
        except concurrent.futures.process.BrokenProcessPool:
            assert time.monotonic() < deadline, "the pool was not replaced"


def test_chunk_timeline_on_the_process_executor(executor) -> None:
    timeline = ChunkTimeline(executor, _jobs.chunk, chunk_time=1.0, sequential=True)
    deadline = time.monotonic() + 30
    while timeline.chunk_at(2.5) is None:
        executor.flush()
        assert time.monotonic() < deadline and timeline.error is None
        time.sleep(0.01)
    assert timeline.chunk_at(2.5) == (2, 1)

