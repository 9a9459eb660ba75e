"""The kernels' warm-up lock (core/_warm.py): a compile in another process waits for a running warm-up.

A child process stands in for the warm-up: it takes the lock as ``python -m
core._warm`` does and holds it until its stdin closes, so the tests decide
when the warm-up ends (no sleeps, no timings). Each test has a lock file of
its own (``RIGIDLAB_WARM_LOCK``).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest
from numba.core.dispatcher import Dispatcher

import rigidlab.core._warm as warm
from tests.helpers import wait_until

#: the warm-up lock is one per machine: tests that hold it run on one xdist worker, one after another
pytestmark = pytest.mark.xdist_group("warm_up_lock")

ROOT = Path(__file__).resolve().parents[2]

_HOLDER = textwrap.dedent("""
    import sys
    from rigidlab.core._warm import hold_lock
    print(hold_lock() is not None, flush=True)
    sys.stdin.read()  # held until the test closes stdin
""")


@pytest.fixture(autouse=True)
def own_lock(tmp_path, monkeypatch):
    """A lock file of this test's own (a warm-up elsewhere, or another test's holder, is not seen)."""
    monkeypatch.setenv("RIGIDLAB_WARM_LOCK", str(tmp_path / "warm.lock"))


@pytest.fixture
def holder(own_lock):
    """A process holding the test's warm-up lock until ``holder.stdin.close()``."""
    proc = subprocess.Popen([sys.executable, "-c", _HOLDER], cwd=ROOT, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "True"
        yield proc
    finally:
        if proc.poll() is None:
            proc.stdin.close()
            proc.wait(timeout=30)


def test_no_warm_up_runs_unless_a_process_holds_the_lock(holder) -> None:
    assert warm.running_for() is not None and warm.running_for() >= 0.0
    holder.stdin.close()
    holder.wait(timeout=30)
    assert warm.running_for() is None
    assert warm.wait_for_warm_up() < warm.WAIT_LIMIT  # returns at once: nothing runs


def test_the_lock_ends_with_its_process_however_it_ends(holder) -> None:
    holder.kill()  # a warm-up killed half way does not leave the app's jobs waiting
    holder.wait(timeout=30)
    assert warm.running_for() is None


def test_a_compile_during_a_warm_up_waits_for_it_then_compiles(holder, monkeypatch) -> None:
    seen = []

    def wait_for_warm_up(limit: float = warm.WAIT_LIMIT) -> float:
        seen.append(warm.running_for() is not None)  # the warm-up still ran when the compile asked
        holder.stdin.close()  # the warm-up ends
        holder.wait(timeout=30)
        return 0.0

    monkeypatch.setattr(warm, "wait_for_warm_up", wait_for_warm_up)
    original = Dispatcher.compile
    try:
        warm.defer_compiles_to_warm_up()
        wrapped = Dispatcher.compile
        warm.defer_compiles_to_warm_up()  # a second call does not wrap twice
        assert wrapped is not original and Dispatcher.compile is wrapped

        @numba.njit(cache=False)
        def twice(x):
            return 2.0 * x

        assert twice(1.5) == 3.0
        assert seen == [True]  # one wait, before the compile; the nested compiles found no warm-up
        assert twice(2.0) == 4.0 and seen == [True]  # compiled: no more waits
    finally:
        Dispatcher.compile = original
    wait_until(lambda: warm.running_for() is None)


def test_without_a_warm_up_a_compile_does_not_wait(monkeypatch) -> None:
    assert warm.running_for() is None
    calls = []
    monkeypatch.setattr(warm, "wait_for_warm_up", lambda limit=warm.WAIT_LIMIT: calls.append(limit) or 0.0)
    original = Dispatcher.compile
    try:
        warm.defer_compiles_to_warm_up()

        @numba.njit(cache=False)
        def thrice(x):
            return 3.0 * x

        assert thrice(1.0) == 3.0 and calls == []
    finally:
        Dispatcher.compile = original
