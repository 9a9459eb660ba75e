"""Compile (or load from numba's cache) every compiled kernel once: ``python -m rigidlab.core._warm``.

The kernels are compiled with ``cache=True``: the first process on a machine
compiles them (about a minute of CPU, once per change of their source) and
writes numba's cache beside the modules; every later process, pytest worker
and app worker loads them from there in well under a second. ``rigidlab
serve`` runs this module in a child process at start, so that the first scene
never waits on compilation, and the test suite runs it once before its
workers start.

While it runs, the warm-up holds a lock file (:func:`lock_path`, one per copy
of ``core`` and numba cache directory; released when the process ends, however
it ends). Another process that is about to compile or load a kernel meanwhile
(an app worker after :func:`defer_compiles_to_warm_up`) waits for the warm-up
and then loads what it wrote, instead of compiling the same kernels beside it
(on a new install the two compiled at the same time, each about a minute of
CPU, and the first scene waited for both). :func:`running_for` tells the app
how long a warm-up has been running, for its notice.
"""

from __future__ import annotations

import fcntl
import hashlib
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

#: Longest wait (s) of a compile for a warm-up (a warm-up that hangs does not stop the process for good).
WAIT_LIMIT = 900.0
_POLL = 0.1  # s between looks at the lock while waiting


def lock_path() -> Path:
    """The warm-up's lock file: one per copy of ``core`` and numba cache directory (numba's cache lives
    beside the modules, or under ``NUMBA_CACHE_DIR``); the environment variable ``RIGIDLAB_WARM_LOCK``
    names another file (tests that must not meet each other's warm-ups)."""
    named = os.environ.get("RIGIDLAB_WARM_LOCK")
    if named:
        return Path(named)
    here = os.path.realpath(os.path.dirname(os.path.abspath(__file__)))
    key = f"{here}\0{os.environ.get('NUMBA_CACHE_DIR', '')}"
    digest = hashlib.blake2b(key.encode(), digest_size=8).hexdigest()
    return Path(tempfile.gettempdir()) / f"rigidlab-warm-{digest}.lock"


def hold_lock() -> int | None:
    """Take the warm-up's lock for this process (waiting for another warm-up of the same copy, which then has
    written the cache) and write the time it was taken into it; returns the file descriptor (the lock lasts
    until it is closed or the process ends), or None when the file cannot be used (the warm-up runs
    unannounced)."""
    try:
        fd = os.open(lock_path(), os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{time.time():.3f}".encode(), 0)
    except OSError:
        os.close(fd)
        return None
    return fd


def running_for() -> float | None:
    """Seconds a warm-up of this copy of ``core`` has been running in another process, or None when none
    runs. (A few system calls: cheap enough for the app's loop twice a second.)"""
    try:
        fd = os.open(lock_path(), os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                started = float(os.pread(fd, 64, 0).decode() or "nan")
            except (OSError, ValueError):
                started = math.nan
            return max(time.time() - started, 0.0) if math.isfinite(started) else 0.0
        except OSError:
            return None
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def wait_for_warm_up(limit: float = WAIT_LIMIT) -> float:
    """Wait until no warm-up of this copy of ``core`` runs (at most ``limit`` seconds); returns the seconds
    waited."""
    t0 = time.monotonic()
    while running_for() is not None and time.monotonic() - t0 < limit:
        time.sleep(_POLL)
    return time.monotonic() - t0


def defer_compiles_to_warm_up() -> None:
    """From now on, in this process, a kernel about to be compiled or loaded from the cache while a warm-up
    runs in another process waits for the warm-up first (:func:`wait_for_warm_up`), then loads the
    warm-up's result from the cache.

    numba compiles a kernel, or loads it from its cache, in
    ``Dispatcher.compile`` at the first call of each signature; that method is
    wrapped here, so a process that never calls a kernel never waits (the
    closed-form scenes start at once during a warm-up). Calling it again does
    nothing.
    """
    from numba.core.dispatcher import Dispatcher

    original = Dispatcher.compile
    if getattr(original, "defers_to_warm_up", False):
        return

    def compile(self, sig):  # noqa: A001 - numba's method name
        if running_for() is not None:
            wait_for_warm_up()
        return original(self, sig)

    compile.defers_to_warm_up = True  # type: ignore[attr-defined]
    compile.__doc__ = original.__doc__
    Dispatcher.compile = compile


def warm() -> float:
    """Run each compiled entry point once on a small model; returns the CPU seconds it took."""
    t0 = time.process_time()
    from rigidlab.core.models import pendulum_chain
    from rigidlab.core.multibody._simulate import _Dynamics
    from rigidlab.core.rotations import matrix_from_axis_angle, matrix_from_euler_parameters, euler_parameters_from_matrix

    system = pendulum_chain(2, tilt=0.5)
    system.add_spring_damper(system.ground, (0.0, 0.5, 0.0), system.bodies[1], (0.0, 0.0, -1.5), stiffness=1.0)
    system.assemble()
    system.simulate([0.0, 0.05, 0.1])  # the compiled step loop and projection
    eng = system._engine().workspace()
    model = _Dynamics(system, eng, stabilization="projection", baumgarte=1.0, position_tol=1e-10)
    y = np.array(system._y)
    model.rhs(0.0, y)  # the right-hand side as the interpreted loops call it
    kc = eng.compiled
    kc.select(None)
    kc.evaluate(0.0, y, 2)
    kc.applied(0.0, y, model._loads)
    kc.solve(0, kc.Q, kc.gamma, np.zeros(6 * eng.n))
    _warm_contacts()
    from rigidlab.core.modal import linearize

    linearize(pendulum_chain(2))  # the tree's null-space basis (_tree_basis)
    rng = np.random.default_rng(0)
    p = rng.normal(size=(128, 4))
    A = matrix_from_euler_parameters(p / np.linalg.norm(p, axis=1, keepdims=True))
    euler_parameters_from_matrix(A)
    axis = rng.normal(size=(128, 3))
    matrix_from_axis_angle(axis / np.linalg.norm(axis, axis=1, keepdims=True), rng.normal(size=128))
    return time.process_time() - t0


def _warm_contacts() -> None:
    """The compiled contact kernel (``rigidlab.core.contact._compiled``): a ball on the ground, every evaluation level."""
    from rigidlab.core.contact import Plane, Sphere
    from rigidlab.core.multibody import System
    from rigidlab.core.multibody._engine import matrices

    system = System(gravity=(0.0, 0.0, -9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004,) * 3, position=(0.0, 0.0, 0.1), omega_body=(1.0, 0, 0))
    system.add_contact(system.ground, Plane(), ball, Sphere(0.1), rolling=True)
    eng = system._engine().workspace()
    ker = eng.contact_kernel
    y = np.array(system._y)
    A = matrices(y[3:7].reshape(1, 4))
    for level in (0, 1, 2):
        ker.evaluate(y, A, level, ker.copy_state(eng.contact_state), t=0.0)


if __name__ == "__main__":
    hold_lock()  # (released when this process ends)
    print(f"rigidlab: compiled kernels ready ({warm():.1f} s of CPU)")
