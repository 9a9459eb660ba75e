"""A scene started while the kernels' warm-up runs (``rigidlab serve`` on a new install).

The worker's kernels wait for the warm-up instead of compiling beside it
(:mod:`rigidlab.core._warm`, :mod:`rigidlab.app.jobs`), and the audience is told why the scene
waits. A child process stands in for the warm-up: it holds the warm-up's lock
until the test closes its stdin.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import rigidlab.core._warm as warm
from rigidlab.app.scenes.gyroscope import GyroscopeScene
from rigidlab.app.scenes.linkages import LinkagesScene
from tests.helpers import wait_until

#: the warm-up lock is one per machine: tests that hold it run on one xdist worker, one after another
pytestmark = pytest.mark.xdist_group("warm_up_lock")

ROOT = Path(__file__).resolve().parents[2]
COMPILING = "Compiling the kernels (first start only)…"

_HOLDER = textwrap.dedent("""
    import sys
    from rigidlab.core._warm import hold_lock
    print(hold_lock() is not None, flush=True)
    sys.stdin.read()
""")


def _hold() -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", _HOLDER], cwd=ROOT, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "True"
    return proc


def _release(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.stdin.close()
        proc.wait(timeout=30)


def test_a_multibody_scene_waits_for_the_warm_up_and_says_so(running_app) -> None:
    holder = _hold()
    try:
        app = running_app(scene=LinkagesScene.name)  # a new pool: its worker has loaded no kernel yet
        scene = app.scene_for()
        # the first chunk's kernels wait for the warm-up: the clock holds, and the audience is told why
        wait_until(lambda: any(title == COMPILING for title, _, _ in app.session_for().notices), timeout=60.0)
        assert app.session_for().progress_shown  # (it stays up, with a spinner, while the clock holds)
        assert scene.sim_time == 0.0 and scene.waiting
        assert warm.running_for() is not None
    finally:
        _release(holder)
    wait_until(lambda: scene.sim_time > 0.1, timeout=120.0)  # the warm-up ended: the kernels load, it moves
    assert scene.timeline.error is None and scene.paused_error is None
    wait_until(lambda: not app.session_for().progress_shown)  # the notice is taken down
    assert [title for title, _, _ in app.session_for().notices].count(COMPILING) == 1


def test_a_scene_without_kernels_moves_during_the_warm_up(running_app) -> None:
    holder = _hold()
    try:
        app = running_app(scene=GyroscopeScene.name)  # the closed form: no compiled kernel
        scene = app.scene_for()
        wait_until(lambda: scene.sim_time > 0.1, timeout=60.0)
        assert warm.running_for() is not None  # still warming up
        assert not any(title == COMPILING for title, _, _ in app.session_for().notices)
        assert not app.session_for().progress_shown
    finally:
        _release(holder)
