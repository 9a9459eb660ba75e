"""Long work off the 60 Hz loop: a background executor and a chunked timeline.

A scene's frame on the loop thread must stay within its budget (p99 2 ms,
max 8 ms; see ``bench/frames.py``), but an integrator may need tens of
milliseconds for two seconds of motion. Such work runs on a background
executor shared by the app's sessions: the loop submits it, keeps drawing
what it has, and swaps the result in when it is ready.

The app's executor is a pool of worker *processes* (:func:`make_executor`
with ``processes=True``; one per core but the loop's): a pure-Python
integrator in a thread would hold the interpreter lock and stretch every
frame of the loop thread (measured: a 1.5 ms frame took up to 7 ms beside
an rk4 job), while a process runs beside it on the other core. So a job is
a module-level function of picklable arguments (``functools.partial`` of
one, with frozen dataclasses), and it returns picklable results; a scene
used on its own (tests, notebooks) gets a thread instead, with the same
jobs.

:class:`ChunkTimeline` does this for a trajectory computed in chunks of
simulated time ahead of the display clock: ``chunk_at(t)`` returns the chunk
that covers ``t`` if it is ready (else None, and the scene holds its clock),
asks for it and for the next one, and never computes on the calling thread.
Chunks that depend on the previous one (an integrator continuing from the
last state) are computed in order, one job at a time, never recursively.
"""

from __future__ import annotations

import collections
import concurrent.futures
import concurrent.futures.process
import copy
import hashlib
import logging
import math
import multiprocessing
import os
import pickle
import queue
import threading
from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["ChunkTimeline", "make_executor", "settle"]

_log = logging.getLogger(__name__)


def _worker_ready() -> int:
    """A no-op job: returns the worker's pid once its imports are done."""
    return os.getpid()


def _worker_start() -> None:
    """Each worker process, at its start: a compiled kernel it needs while ``rigidlab serve``'s warm-up child
    compiles them waits for the warm-up and loads its result (see :mod:`rigidlab.core._warm`), instead of compiling
    the same kernels beside it; the objects it inherited are frozen out of the garbage collector; SIGINT is
    ignored (Ctrl-C in a terminal reaches the whole process group: the app stops its pool, and a worker
    interrupted in its queue read printed a KeyboardInterrupt traceback)."""
    import gc
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)

    from rigidlab.core._warm import defer_compiles_to_warm_up

    defer_compiles_to_warm_up()
    # the modules the fork server imported (numpy, scipy, numba, the scenes) are never freed: out of the
    # collector's sight, a full collection in a chunk no longer walks them (0.5 s of CPU each in a worker)
    gc.freeze()


def _guard_thread_wakeup() -> None:
    """Make the wake-up pipe of every ``ProcessPoolExecutor`` created from now on safe to close (idempotent).

    A pool's manager thread closes the pool's wake-up pipe once the pool is
    shut down and idle. At the interpreter's exit, ``concurrent.futures``
    wakes every manager thread still running (``_python_exit``) without the
    pool's lock: "closed?" and then a write to the pipe. A pool shut down
    without waiting (the app's, when a worker process stops) has its
    manager thread still running then, and when its close fell between the
    two, the exit printed ``OSError: [Errno 9] Bad file descriptor`` (a
    worker's shutdown in 1 of 4 churn soaks, issue 28; "handle is closed"
    when the close came before the write's own check; a write into a
    reused descriptor otherwise). CPython 3.12.8 and 3.13.1 give the pipe
    its own lock, taken by ``close`` and ``wakeup`` (gh-125451); this gives
    the same lock to the ``_ThreadWakeup`` of a Python without it (3.11).
    The lock is taken inside the pool's (``shutdown``, ``submit``) and
    never the other way round, and ``clear`` (the manager thread's, which
    also closes) keeps going without it, as upstream.
    """
    wakeup_class = concurrent.futures.process._ThreadWakeup
    if "_lock" in wakeup_class.__init__.__code__.co_names:  # upstream's lock, or this one
        return

    class _ThreadWakeup(wakeup_class):  # type: ignore[misc, valid-type]
        def __init__(self) -> None:
            self._lock = threading.Lock()
            super().__init__()

        def close(self) -> None:
            with self._lock:
                super().close()

        def wakeup(self) -> None:
            with self._lock:
                super().wakeup()

    concurrent.futures.process._ThreadWakeup = _ThreadWakeup  # type: ignore[attr-defined]


def make_executor(
    *, processes: bool = False, preload: Iterable[str] = (), name: str = "rigidlab-worker"
) -> concurrent.futures.Executor:
    """The background executor of an app (``processes=True``) or of a lone scene.

    Parameters
    ----------
    processes : bool, keyword-only
        A pool of worker processes (one per core beyond the first, at least
        one), started by a fork server that has imported ``preload`` (module
        names: the scenes' modules, whose job functions the workers run), and
        warmed up at once; a worker's kernels wait for a running warm-up of
        the compiled kernels (:mod:`rigidlab.core._warm`). Otherwise one thread.
    preload : iterable of str, keyword-only
        Modules the fork server imports before it forks workers.
    name : str, keyword-only
        Thread name prefix (threads only).
    """
    if not processes:
        return concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)
    _guard_thread_wakeup()  # (its pools are shut down without waiting)
    # The workers' numerical kernels run one BLAS thread each: the cores are
    # shared with the loop. The fork server, started at the first submit,
    # inherits this environment before it imports numpy.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    context = multiprocessing.get_context("forkserver")
    modules = ["numpy", "scipy.special", "scipy.integrate", "rigidlab.app.jobs"]
    modules += [m for m in dict.fromkeys(preload) if m not in modules]
    context.set_forkserver_preload(modules)
    workers = max(1, (os.cpu_count() or 2) - 1)

    def pool() -> concurrent.futures.ProcessPoolExecutor:
        executor = concurrent.futures.ProcessPoolExecutor(max_workers=workers, mp_context=context,
                                                          initializer=_worker_start)
        executor.submit(_worker_ready)  # start the workers now, not at the first chunk
        return executor

    return _Dispatcher(pool, name=f"{name}-dispatch")


class _Dispatcher(concurrent.futures.Executor):
    """Hands jobs to a process pool from its own thread; the caller never waits.

    ``ProcessPoolExecutor.submit`` writes to a wake-up pipe and wakes the
    pool's threads, which then pickle the job holding the interpreter lock:
    a submit from the loop thread stretched its frame by 2-6 ms (measured
    with a slider moving in the free-body scene). Here ``submit`` only
    appends the job to a list and returns a future at once. The app's loop
    calls :meth:`flush` at the end of its tick, after the frame's poses are
    sent, and a dispatcher thread forwards the held jobs while the loop
    sleeps; without a flush (a notebook) the dispatcher still looks every
    20 ms. The future stays pending until the pool's result is in, so
    :meth:`Future.cancel` still drops a job that has not started. A pool
    broken by a worker that died (killed, out of memory) fails the jobs it
    had and is replaced, so the next job runs again. Identical jobs (the
    same function and pickled arguments: sessions on the same scene and
    parameters) run once, each submitter getting its own copy of the result
    (:meth:`_forward`).
    """

    def __init__(self, make_pool: Callable[[], concurrent.futures.Executor], *, name: str) -> None:
        self._make_pool = make_pool
        self._pool = make_pool()
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._held: collections.deque = collections.deque()
        self._closed = False
        self.completed = 0  # jobs finished with a result (benchmarks report it)
        self.shared = 0  # submits answered by an identical job in flight or done (benchmarks report it)
        self._memo: collections.OrderedDict[bytes, concurrent.futures.Future] = collections.OrderedDict()
        self._memo_lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> concurrent.futures.Future:
        """A future of ``fn(*args, **kwargs)`` run on the pool; identical jobs run once (see :meth:`_forward`)."""
        if self._closed:
            raise RuntimeError("cannot schedule new jobs after shutdown")
        outer: concurrent.futures.Future = concurrent.futures.Future()
        self._held.append((outer, fn, args, kwargs))  # no wake-up: see flush
        return outer

    def flush(self) -> None:
        """Hand the held jobs to the dispatcher thread now (end of a loop tick)."""
        if self._held:
            self._queue.put(True)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._closed = True
        self._queue.put(None)
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)

    def _run(self) -> None:
        while True:
            try:
                if self._queue.get(timeout=0.02) is None:
                    return
            except queue.Empty:
                pass
            while self._held:
                self._forward(*self._held.popleft())

    def _forward(self, outer: concurrent.futures.Future, fn: Callable[..., Any], args: Any, kwargs: Any) -> None:
        """Hand one held job to the pool, or to an identical job already in flight or done (dispatcher thread).

        Sessions showing the same scene with the same parameters ask for the
        same chunks (a class that has just opened the default preset): the
        job runs once and every submitter's future gets its own deep copy of
        the result, so no session sees another's changes; cancelling one
        future cancels the job only when every submitter of it cancelled.
        The last :data:`MEMO_SIZE` finished jobs are kept. The job's key (a
        digest of its pickle, :func:`_job_key`) is computed here, off the
        loop thread.
        """
        if outer.cancelled():
            return
        key = _job_key(fn, args, kwargs)
        if key is not None:
            with self._memo_lock:
                job = self._memo.get(key)
                if job is not None and not (job.cancelled() or (job.done() and job.exception() is not None)):
                    self._memo.move_to_end(key)
                    self.shared += 1
                    _follow(job, outer)
                    return
                job = concurrent.futures.Future()  # the job itself, never handed out
                job.followers = []  # type: ignore[attr-defined]
                self._memo[key] = job
                while len(self._memo) > MEMO_SIZE:
                    self._memo.popitem(last=False)
            _follow(job, outer)
            outer = job
        try:
            inner = self._pool.submit(fn, *args, **kwargs)
        except concurrent.futures.process.BrokenProcessPool as exc:
            self._replace_pool()
            settle(outer, None, exc)
            return
        except BaseException as exc:  # shut down, or the job could not be queued
            settle(outer, None, exc)
            return
        outer.add_done_callback(lambda o, inner=inner: inner.cancel() if o.cancelled() else None)
        inner.add_done_callback(lambda f, outer=outer: self._done(f, outer))

    def _done(self, inner: concurrent.futures.Future, outer: concurrent.futures.Future) -> None:
        if inner.cancelled():
            outer.cancel()
            return
        exc = inner.exception()
        if isinstance(exc, concurrent.futures.process.BrokenProcessPool):
            self._replace_pool()
        if exc is None:
            self.completed += 1  # only this thread's callbacks write it
        settle(outer, None if exc is not None else inner.result(), exc)

    def _replace_pool(self) -> None:
        if self._closed:
            return
        broken, self._pool = self._pool, self._make_pool()
        _log.error("the worker pool broke (a worker process died); a new pool takes over")
        broken.shutdown(wait=False, cancel_futures=True)


#: Finished jobs a dispatcher keeps to answer identical submits (see ``_Dispatcher.submit``).
MEMO_SIZE = 64


def _job_key(fn: Callable[..., Any], args: tuple, kwargs: dict) -> bytes | None:
    """A digest of the pickled job (a module-level function and its arguments), None if it does not pickle.

    Jobs are pure functions of their pickled arguments (they run in other
    processes), so equal pickles mean equal results.
    """
    try:
        data = pickle.dumps((fn, args, sorted(kwargs.items())), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # a lambda, a lock, ...: run it, unshared
        return None
    return hashlib.blake2b(data, digest_size=20).digest()


def _follow(job: concurrent.futures.Future, outer: concurrent.futures.Future) -> None:
    """Make a submitter's future ``outer`` follow ``job``: its outcome, the result deep-copied (each its own).

    ``job`` is cancelled when every follower is cancelled before it is done.
    """
    followers = job.followers  # type: ignore[attr-defined]
    followers.append(outer)

    def on_outer(o: concurrent.futures.Future) -> None:
        if o.cancelled() and all(f.cancelled() for f in followers) and not job.done():
            job.cancel()

    def on_job(j: concurrent.futures.Future) -> None:
        if j.cancelled():
            outer.cancel()
            return
        exc = j.exception()
        if exc is not None:
            settle(outer, None, exc)
            return
        settle(outer, copy.deepcopy(j.result()), None)

    outer.add_done_callback(on_outer)
    job.add_done_callback(on_job)


def settle(future: concurrent.futures.Future, result: Any, exc: BaseException | None) -> None:
    """Complete a pending ``future`` unless it was cancelled meanwhile."""
    if not future.set_running_or_notify_cancel():
        return
    if exc is not None:
        future.set_exception(exc)
    else:
        future.set_result(result)


class ChunkTimeline:
    """Chunks ``k`` covering ``[k T, (k + 1) T]`` of simulated time, computed in the background.

    Parameters
    ----------
    executor : concurrent.futures.Executor
        Where chunks are computed.
    compute : callable
        ``compute(k, previous) -> chunk``; ``previous`` is chunk ``k - 1``
        when ``sequential`` (None for ``k = 0``), else None. Runs on the
        executor's thread, so it must only read what it is given.
    chunk_time : float, keyword-only
        ``T``, simulated seconds per chunk (> 0).
    sequential : bool, keyword-only
        Whether chunk ``k`` needs chunk ``k - 1``.
    capacity : int, keyword-only
        Chunks kept (those farthest from the chunk last computed are dropped first).

    Notes
    -----
    All methods are for the loop thread. ``error`` holds the exception of a
    chunk that failed (no more chunks are asked for until :meth:`reset`). A
    chunk whose ``final`` attribute is true ends the motion: no later chunk is
    asked for.
    """

    def __init__(
        self,
        executor: concurrent.futures.Executor,
        compute: Callable[[int, Any], Any],
        *,
        chunk_time: float,
        sequential: bool,
        capacity: int = 64,
    ) -> None:
        if not (math.isfinite(chunk_time) and chunk_time > 0):
            raise ValueError(f"chunk_time: expected a finite number > 0, got {chunk_time!r}")
        self._executor = executor
        self._compute = compute
        self.chunk_time = float(chunk_time)
        self.sequential = bool(sequential)
        self.capacity = int(capacity)
        self._chunks: dict[int, Any] = {}
        self._jobs: dict[int, concurrent.futures.Future] = {}
        self.error: BaseException | None = None
        self.computed = 0

    def reset(self, compute: Callable[[int, Any], Any] | None = None) -> None:
        """Forget every chunk (new parameters); jobs in flight are dropped."""
        for future in self._jobs.values():
            future.cancel()
        self._jobs = {}
        self._chunks = {}
        self.error = None
        if compute is not None:
            self._compute = compute

    def index(self, t: float) -> int:
        """The chunk that covers simulated time ``t``."""
        return max(0, int(t // self.chunk_time))

    def chunk_at(self, t: float, *, ahead: float = 0.5) -> Any | None:
        """The chunk covering ``t`` if computed, else None; asks for what is missing.

        Once ``t`` is past ``ahead`` of its chunk, the next chunk is asked for
        too, so it is ready when the clock gets there.
        """
        self._collect()
        k = self.index(t)
        if self.error is None:
            self._request(k)
            if t - k * self.chunk_time >= ahead * self.chunk_time:
                self._request(k + 1)
        return self._chunks.get(k)

    def advance(self, t: float, step: float) -> tuple[float, Any | None, bool]:
        """Move a display clock at ``t`` by ``step`` if the chunk it lands in is ready.

        Returns ``(time, chunk, waiting)``: the new clock time, the chunk to
        draw at it (None if none is computed yet) and whether the clock held
        because the chunk at ``t + step`` is not ready (it then stays at
        ``t``, drawn from the chunk covering ``t`` if there is one).
        """
        target = t + step
        chunk = self.chunk_at(target)
        if chunk is not None:
            return target, chunk, False
        return t, (self.chunk_at(t) if step > 0.0 else None), True

    def ready(self, k: int) -> bool:
        self._collect()
        return k in self._chunks

    @property
    def busy(self) -> bool:
        """Whether a job is queued or running."""
        return any(not f.done() for f in self._jobs.values())

    def _collect(self) -> None:
        for k, future in list(self._jobs.items()):
            if not future.done():
                continue
            del self._jobs[k]
            if future.cancelled():
                continue
            exc = future.exception()
            if exc is not None:
                self.error = exc
                continue
            self._store(k, future.result())

    def _store(self, k: int, chunk: Any) -> None:
        self._chunks[k] = chunk
        self.computed += 1
        if len(self._chunks) > self.capacity:
            # drop the chunks farthest from the one just stored (never that one): playing on, those are the
            # oldest; after a restart at t = 0 with the chunks of a long run kept, they are the latest, and
            # dropping the lowest instead threw the new chunk 0 away at once, which was asked for again at
            # every frame while the clock held at 0
            far = sorted(self._chunks, key=lambda j: (-abs(j - k), j))
            for old in far[: len(self._chunks) - self.capacity]:
                del self._chunks[old]

    def _request(self, k: int) -> None:
        if k in self._chunks or k in self._jobs:
            return
        if any(getattr(c, "final", False) for j, c in self._chunks.items() if j < k):
            return  # the motion ends in an earlier chunk (a fall, a separation): nothing comes after it
        if not self.sequential:
            self._jobs[k] = self._executor.submit(self._compute, k, None)
            return
        # In order: the first missing chunk at or before k (never recursive).
        j = k
        while j > 0 and (j - 1) not in self._chunks:
            j -= 1
        if any(i <= k for i in self._jobs):
            return  # an earlier chunk is on its way; ask again when it is in
        previous = self._chunks.get(j - 1) if j > 0 else None
        self._jobs[j] = self._executor.submit(self._compute, j, previous)
