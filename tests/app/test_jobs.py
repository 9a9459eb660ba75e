"""The app's process executor: jobs held until a flush, cancellation, a broken pool replaced."""

from __future__ import annotations

import concurrent.futures
import threading
import time

import pytest

from rigidlab.app.jobs import ChunkTimeline, make_executor
from tests.app import _jobs
from tests.helpers import wait_until


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
    naps = [0.5 + 0.001 * i for i in range(4)]  # distinct jobs (identical ones would run once), more than the workers
    busy = [executor.submit(_jobs.nap, s) for s in naps]
    waiting = executor.submit(_jobs.square, 5.0)
    executor.flush()
    time.sleep(0.1)
    assert waiting.cancel()
    assert waiting.cancelled()
    assert [f.result(timeout=30) for f in busy] == naps


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



class _Inline(concurrent.futures.Executor):
    """Runs a job at once, in the caller's thread."""

    def submit(self, fn, /, *args, **kwargs):
        future: concurrent.futures.Future = concurrent.futures.Future()
        future.set_result(fn(*args, **kwargs))
        return future


def test_chunk_timeline_restarted_at_zero_after_a_long_run_shows_chunk_zero_again() -> None:
    """A scene's Reset sets its clock to 0 and keeps the chunks (same parameters). After a run longer than
    the timeline holds, chunk 0 had been dropped; computed again, it was the lowest of too many and was
    dropped at once: the clock held at 0 for good and chunk 0 was computed at every frame."""
    calls: list[int] = []

    def compute(k: int, previous: tuple | None) -> tuple:
        calls.append(k)
        return (k, None if previous is None else previous[0])

    timeline = ChunkTimeline(_Inline(), compute, chunk_time=1.0, sequential=True, capacity=4)


    def play(t: float, until: float) -> tuple:
        for _ in range(200):  # (a chunk asked for is stored at the next call)
            t, chunk, _ = timeline.advance(t, 0.25)
            if t >= until:
                return t, chunk
        raise AssertionError(f"the clock held at t={t}")

    t, chunk = play(0.0, 10.0)  # a run of 10 chunks
    assert chunk == (10, 9) and sorted(timeline._chunks) == [7, 8, 9, 10]  # (11 asked for, not yet stored)
    calls.clear()
    t, chunk = play(0.0, 2.0)  # Reset: the clock from 0 again
    assert chunk == (2, 1)
    assert calls == [0, 1, 2]  # each once
    assert len(timeline._chunks) == 4 and {0, 1, 2} <= set(timeline._chunks)  # (the farthest ones dropped)


# -- identical jobs run once (sessions of a class on the same preset) ---------------------------


def test_identical_jobs_run_once_and_every_submitter_gets_its_own_copy(executor) -> None:
    shared = executor.shared
    futures = [executor.submit(_jobs.stamped, "same", 0.2) for _ in range(5)]
    executor.flush()
    results = [f.result(timeout=30) for f in futures]
    assert executor.shared - shared == 4
    assert all(r == results[0] for r in results)  # one run: the same process and time stamp
    assert len({id(r) for r in results}) == 5 and len({id(r["values"]) for r in results}) == 5
    results[0]["values"].append(3.0)  # one session changing its result changes no other
    later = executor.submit(_jobs.stamped, "same", 0.2).result(timeout=30)  # kept: not run again
    assert later == results[1] and later["values"] == [1.0, 2.0]
    other = executor.submit(_jobs.stamped, "other").result(timeout=30)  # other arguments: another run
    assert other["label"] == "other" and other["at"] > results[0]["at"]


def test_a_shared_job_is_cancelled_only_when_every_submitter_cancels(executor) -> None:
    blockers = [executor.submit(_jobs.nap, 0.6 + 0.001 * i) for i in range(4)]  # keep the workers busy
    a = executor.submit(_jobs.stamped, "cancel-one")
    b = executor.submit(_jobs.stamped, "cancel-one")
    executor.flush()
    assert a.cancel()
    assert b.result(timeout=30)["label"] == "cancel-one"  # b still gets it
    c = executor.submit(_jobs.stamped, "cancel-all")
    d = executor.submit(_jobs.stamped, "cancel-all")
    executor.flush()
    assert c.cancel() and d.cancel()
    again = executor.submit(_jobs.stamped, "cancel-all")  # the cancelled job is not reused
    assert again.result(timeout=30)["label"] == "cancel-all"
    [f.result(timeout=30) for f in blockers]


def test_a_failed_job_fails_every_submitter_and_is_not_kept(executor) -> None:
    futures = [executor.submit(_jobs.fail, "boom") for _ in range(2)]
    executor.flush()
    for f in futures:
        with pytest.raises(ValueError, match="boom"):
            f.result(timeout=30)
    shared = executor.shared
    with pytest.raises(ValueError, match="boom"):
        executor.submit(_jobs.fail, "boom").result(timeout=30)  # run again, not answered from the failure
    assert executor.shared == shared


def test_jobs_that_do_not_pickle_by_name_are_not_shared() -> None:
    from rigidlab.app.jobs import _job_key

    assert _job_key(_jobs.square, (2.0,), {}) == _job_key(_jobs.square, (2.0,), {})
    assert _job_key(_jobs.square, (2.0,), {}) != _job_key(_jobs.square, (3.0,), {})
    assert _job_key(lambda x: x, (2.0,), {}) is None


class _WatchedLock:
    """A lock that tells when a thread had to wait for it (``contended``)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.contended = threading.Event()

    def __enter__(self) -> None:
        if not self._lock.acquire(blocking=False):
            self.contended.set()
            self._lock.acquire()

    def __exit__(self, *exc: object) -> None:
        self._lock.release()


def test_a_pool_wakeup_is_not_closed_under_a_write() -> None:
    """The interpreter's exit wakes a pool's manager thread while that thread closes the wake-up pipe
    (issue 28: ``OSError: [Errno 9] Bad file descriptor`` when a worker process stopped): the close waits
    for the write."""
    from concurrent.futures import process

    from rigidlab.app.jobs import _guard_thread_wakeup

    _guard_thread_wakeup()  # (as make_executor(processes=True) does)
    wakeup = process._ThreadWakeup()
    wakeup._lock = lock = _WatchedLock()
    writing, release = threading.Event(), threading.Event()
    send = wakeup._writer.send_bytes

    def preempted_send(buf: bytes) -> None:  # the exit's write, held between its "closed?" and the write
        writing.set()
        release.wait(timeout=60.0)
        send(buf)

    wakeup._writer.send_bytes = preempted_send
    errors: list[BaseException] = []

    def wake() -> None:
        try:
            wakeup.wakeup()
        except OSError as exc:
            errors.append(exc)

    waker = threading.Thread(target=wake)
    waker.start()
    assert writing.wait(timeout=60.0)
    closer = threading.Thread(target=wakeup.close)
    closer.start()
    wait_until(lambda: lock.contended.is_set() or not closer.is_alive(), timeout=60.0)
    release.set()
    waker.join(timeout=60.0)
    closer.join(timeout=60.0)
    assert errors == []
    assert wakeup._closed
