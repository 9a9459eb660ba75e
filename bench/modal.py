"""Modal analysis benchmark: linearization and eigen solution, a Campbell sweep, Exudyn as the peer.

One run prints one table:

1. ``linearize`` + ``LinearModel.modes`` (full eigen solution) of the
   pendulum chain of 10, 50 and 100 uniform rods hanging at rest (target:
   <= 0.2 s for 100 links, linearization included); wall time, best of
   three, and the first call (which compiles the row tables).
2. A 200-point Campbell sweep of ``rigidlab.core.models.disk_rotor`` (spin 0 to
   1500 rad/s: build, assemble, linearize, state-space eigen solution per
   point) on the default process pool (target: <= 5 s on 2 cores), with
   the serial time (one worker thread) beside it.
3. The same chains' frequencies from Exudyn (``ComputeODE2Eigenvalues``):
   (a) its eigenvalue analysis of the constrained system in absolute
   coordinates (rigid bodies with Euler parameters and revolute joints),
   and (b) the chain as a ``KinematicTree`` in joint angles; CPU of its
   eigen call against ours and the largest relative difference of the
   frequencies. Without exudyn (the optional ``bench`` extra) a line says
   it is not installed.

Usage::

    .venv/bin/python bench/modal.py

BLAS runs single-threaded (``OPENBLAS_NUM_THREADS=1`` unless set), as in
docs/multibody.md. Nothing is asserted; it is a report.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import concurrent.futures  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from rigidlab.core.modal import LinearModel, linearize, sweep  # noqa: E402
from rigidlab.core.models import disk_rotor, pendulum_chain  # noqa: E402

CHAINS = (10, 50, 100)
SWEEP_POINTS = 200
SPEEDS = (0.0, 1500.0)


def rotor_model(speed: float) -> LinearModel:
    """The Campbell sweep's build function (module level: picklable for the process pool)."""
    return linearize(disk_rotor(speed).system)


def chain_frequencies(n: int) -> tuple[np.ndarray, float, float, float]:
    """(omega of the pairs, first call s, best wall s, best CPU s) of linearize + modes for n rods."""
    system = pendulum_chain(n, kind="rod")
    t0 = time.perf_counter()
    modes = linearize(system).modes()
    first = time.perf_counter() - t0
    wall, cpu = math.inf, math.inf
    for _ in range(3):
        w0, c0 = time.perf_counter(), time.process_time()
        modes = linearize(system).modes()
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, time.process_time() - c0)
    omega = np.sort(modes.omega_n[(modes.eigenvalues.imag > 0) & ~modes.rigid])
    return omega, first, wall, cpu


def exudyn_chain(n: int, *, tree: bool) -> tuple[np.ndarray, float]:
    """(omega, CPU s of ComputeODE2Eigenvalues) of the rod chain in Exudyn."""
    import exudyn as exu
    from exudyn.rigidBodyUtilities import HT0, HTtranslate, RigidBodyInertia, TreeLink

    L, m = 1.0, 1.0
    r = 0.01 * L
    J = np.diag([m * L * L / 12.0, m * L * L / 12.0, 0.5 * m * r * r])
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    if tree:
        links = [TreeLink(linkInertia=RigidBodyInertia(mass=m, inertiaTensor=J, com=[0.0, 0.0, -0.5 * L],
                                                       inertiaTensorAtCOM=True),
                          jointType=exu.JointType.RevoluteX, jointHT=HT0() if k == 0 else HTtranslate([0.0, 0.0, -L]),
                          parent=k - 1) for k in range(n)]
        mbs.CreateKinematicTree(listOfTreeLinks=links, gravity=[0.0, 0.0, -9.81], show=False)
    else:
        ground = mbs.CreateGround(referencePosition=[0.0, 0.0, 0.0])
        prev = ground
        for k in range(n):
            body = mbs.CreateRigidBody(inertia=RigidBodyInertia(mass=m, inertiaTensor=J, inertiaTensorAtCOM=True),
                                       referencePosition=[0.0, 0.0, -(k + 0.5) * L], gravity=[0.0, 0.0, -9.81],
                                       nodeType=exu.NodeType.RotationEulerParameters, show=False)
            mbs.CreateRevoluteJoint(itemNumbers=[prev, body], position=[0.0, 0.0, -k * L], axis=[1.0, 0.0, 0.0],
                                    useGlobalFrame=True, show=False)
            prev = body
    mbs.Assemble()
    settings = exu.SimulationSettings()
    best = math.inf
    for _ in range(3):
        c0 = time.process_time()
        ev, _ = mbs.ComputeODE2Eigenvalues(settings, useAbsoluteValues=False)
        best = min(best, time.process_time() - c0)
    ev = np.sort(np.asarray(ev, dtype=float))
    return np.sqrt(np.maximum(ev, 0.0)), best


def main() -> None:
    rows: list[tuple[str, str, str]] = []
    ours: dict[int, tuple[np.ndarray, float]] = {}
    for n in CHAINS:
        omega, first, wall, cpu = chain_frequencies(n)
        ours[n] = (omega, cpu)
        note = "target <= 0.2 s" if n == 100 else ""
        rows.append((f"chain of {n} rods: linearize + eigen ({n} DOF)",
                     f"{wall * 1e3:.1f} ms wall, {cpu * 1e3:.1f} ms CPU (first call {first * 1e3:.1f} ms)", note))

    speeds = np.linspace(SPEEDS[0], SPEEDS[1], SWEEP_POINTS)
    workers = os.cpu_count() or 1
    t0 = time.perf_counter()
    result = sweep(rotor_model, speeds)
    parallel = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as one:
        serial_result = sweep(rotor_model, speeds, executor=one)
    serial, serial_cpu = time.perf_counter() - t0, time.process_time() - c0
    same = float(np.max(np.abs(result.eigenvalues - serial_result.eigenvalues)))
    rows.append((f"Campbell sweep, {SWEEP_POINTS} speeds of disk_rotor, process pool ({workers} workers)",
                 f"{parallel:.2f} s (serial {serial:.2f} s wall, {serial_cpu:.2f} s CPU)",
                 f"target <= 5 s on 2 cores; results equal to {same:.0e}"))

    try:
        import exudyn  # noqa: F401
    except ImportError:
        rows.append(("Exudyn peer", "not installed", "pip install -e '.[bench]'"))
    else:
        for n in CHAINS:
            omega, cpu = ours[n]
            ex_abs, cpu_abs = exudyn_chain(n, tree=False)
            rows.append((f"Exudyn, {n} rods, constrained (Euler parameters, revolute joints)",
                         f"largest omega {ex_abs.max():.3g} rad/s (ours {omega.max():.4g})",
                         "no d(C_q^T lambda)/dq in its Jacobian: no gravity stiffness"))
            ex_tree, cpu_tree = exudyn_chain(n, tree=True)
            k = min(ex_tree.size, omega.size)
            rel = float(np.max(np.abs(ex_tree[:k] - omega[:k]) / omega[:k]))
            rows.append((f"Exudyn, {n} rods, KinematicTree (joint angles)",
                         f"max rel. frequency difference {rel:.1e}",
                         f"CPU ours / Exudyn eigen call: {cpu * 1e3:.1f} / {cpu_tree * 1e3:.1f} ms "
                         f"= {cpu / cpu_tree:.1f}"))

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rows.append(("machine", f"{workers} CPUs, load average {load:.1f} at the end", "wall times grow with the load"))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    header = ("case", "result", "note")
    widths = [max(w, len(h)) for w, h in zip(widths, header)]
    line = " | ".join(h.ljust(w) for h, w in zip(header, widths))
    print(line)
    print("-" * len(line))
    for r in rows:
        print(" | ".join(c.ljust(w) for c, w in zip(r, widths)))


if __name__ == "__main__":
    main()
