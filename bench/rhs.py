"""Per-right-hand-side benchmark: one evaluation of rigidlab's equations of motion against MuJoCo and Pinocchio.

For pendulum chains of N = 2, 10, 30, 100 and 300 links
(:func:`rigidlab.core.models.pendulum_chain`, uniform 1 m, 1 kg rods on revolute
joints about x, tilted by 0.5 rad), the CPU time (``time.process_time``)
of one evaluation:

* rigidlab: ``_Dynamics.rhs(t, y)`` of ``rigidlab.core.multibody._simulate``, the
  right-hand side that ``System.simulate`` integrates (absolute
  coordinates: kinematics, constraint rows and the multiplier solve; no
  projection), built as ``simulate`` builds it for the ``"projection"``
  stabilization, at the assembled state with every body-frame angular
  velocity component set to 0.3 rad/s;
* MuJoCo: ``mj_forward`` (the same chain on hinge joints, qvel = 0.3
  rad/s, contacts disabled): positions, velocities, mass matrix and its
  factorization, forward dynamics;
* Pinocchio (for reference): ``pin.aba`` (articulated-body algorithm in
  the joint angles, the same chain, qdot = 0.3 rad/s), the O(N) kernel a
  reduced-coordinate engine calls once per right-hand side.

Each time is the best of :data:`REPEATS` repeats of a loop of calls long
enough for about :data:`LOOP_SECONDS` of CPU, divided by the number of
calls (the first call is made before timing). The ratios (peer / rigidlab,
> 1: rigidlab is faster) are measured in the same run. The growth exponent
is the least-squares slope of log time against log N over N = 10..300
(1: linear in N). A last row gives rigidlab's first ``rhs`` call in a fresh
subprocess for N <= :data:`FIRST_CALL_MAX` (after the imports and the
System's ``assemble``: the compile or cache-loading time of the compiled
kernels, wall clock; the first subprocess compiles when numba's cache of
the kernels is stale, after an edit of core/, the later ones load it).

With ``--baseline DIR`` (another checkout of rigidlab, e.g. ``git worktree
add /tmp/old <commit>``), the same right-hand sides of that checkout are
timed in a subprocess between the chains of this run, giving before/after
rows and their ratio measured together (the machine's load varies).

Run from the project root (about a minute; twice that with a baseline)::

    .venv/bin/python bench/rhs.py
    .venv/bin/python bench/rhs.py --links 2 10 30   # fewer chains
    .venv/bin/python bench/rhs.py --baseline /tmp/old   # before/after

Writes ``bench/out/rhs.json`` (bench/out/ is git-ignored). BLAS runs on one
thread (``OPENBLAS_NUM_THREADS=1``).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from multibody import (  # noqa: E402
    _machine,
    _versions,
    chain_angles0,
    chain_tree,
    git_revision,
    mujoco_model,
)

from rigidlab.core.models import pendulum_chain  # noqa: E402

OUT = Path(__file__).resolve().parent / "out"
LINKS = (2, 10, 30, 100, 300)
#: Chains the growth exponent is fitted over.
FIT_FROM = 10
REPEATS = 5
#: The first-call row runs a subprocess for chains up to this length (building a longer one takes seconds).
FIRST_CALL_MAX = 100
LOOP_SECONDS = 0.05
OMEGA = 0.3  # rad/s, every angular velocity component (rigidlab) or joint rate (MuJoCo, Pinocchio)
TILT = 0.5

#: The first call in a fresh process: the script a subprocess runs (prints the seconds of the first call).
FIRST_CALL = """
import sys, time
import numpy as np
sys.path.insert(0, {root!r})
from rigidlab.core.models import pendulum_chain
from rigidlab.core.multibody._simulate import _Dynamics
N = {n}
s = pendulum_chain(N, tilt={tilt}); s.assemble(); eng = s._engine()
model = _Dynamics(s, eng.workspace(), stabilization="projection", baumgarte=1.0, position_tol=1e-10)
y = np.array(s._y, dtype=float); y[10 * N:] = {omega}
t0 = time.perf_counter(); model.rhs(0.0, y); first = time.perf_counter() - t0
t0 = time.perf_counter(); model.rhs(0.0, y); second = time.perf_counter() - t0
print(first, second)
"""


#: The baseline's timing: the script a subprocess runs in the other checkout (prints the seconds per call).
BASELINE = """
import sys
sys.path.insert(0, {root!r})
sys.path.insert(0, {bench!r})
from rigidlab.core.models import pendulum_chain
from rhs import best_per_call, rigidlab_rhs
print(best_per_call(rigidlab_rhs({n}, pendulum_chain({n}, tilt={tilt}))))
"""


def best_per_call(call) -> float:
    """Seconds of one ``call()``: the best over REPEATS loops of about LOOP_SECONDS of CPU each."""
    call()
    t0 = time.process_time()
    n = 0
    while time.process_time() - t0 < 0.01:
        call()
        n += 1
    per = (time.process_time() - t0) / n
    count = max(1, int(LOOP_SECONDS / max(per, 1e-9)))
    best = float("inf")
    for _ in range(REPEATS):
        t0 = time.process_time()
        for _ in range(count):
            call()
        best = min(best, (time.process_time() - t0) / count)
    return best


def rigidlab_rhs(n: int, s):
    """A callable evaluating rigidlab's right-hand side once for the n-link chain ``s``."""
    from rigidlab.core.multibody._simulate import _Dynamics

    s.assemble()
    eng = s._engine()
    model = _Dynamics(s, eng.workspace(), stabilization="projection", baumgarte=1.0, position_tol=1e-10)
    y = np.array(s._y, dtype=float)
    y[10 * n:] = OMEGA  # some angular velocity
    return lambda: model.rhs(0.0, y)


def mujoco_forward(n: int, s):
    """A callable running ``mj_forward`` once on the n-link chain ``s`` (None without MuJoCo)."""
    try:
        import mujoco
    except ImportError:
        return None
    xml, _, _ = mujoco_model(s, "chain", 1e-3)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[:] = OMEGA
    return lambda: mujoco.mj_forward(m, d)


def pinocchio_aba(n: int, s):
    """A callable running ``pin.aba`` once on the n-link chain ``s`` (None without Pinocchio)."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    from multibody import pinocchio_chain_model

    model, data = pinocchio_chain_model(pin, chain_tree(n, system=s, tilt=TILT))
    q, v, tau = chain_angles0(n), np.full(n, OMEGA), np.zeros(n)
    return lambda: pin.aba(model, data, q, v, tau)


def first_call(n: int) -> tuple[float, float] | None:
    """(first, second) rhs call in a fresh subprocess (s, wall clock), or None when it fails."""
    code = FIRST_CALL.format(root=str(ROOT), n=n, tilt=TILT, omega=OMEGA)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    if res.returncode:
        print(f"  first call, {n} links: failed: {res.stderr.strip().splitlines()[-1:]}")
        return None
    first, second = (float(x) for x in res.stdout.split())
    return first, second


def baseline_rhs(root: Path, n: int) -> float | None:
    """Seconds per rigidlab right-hand side of the checkout at ``root`` (this script's timing, run there in a
    subprocess; None when it fails)."""
    code = BASELINE.format(root=str(root), bench=str(Path(__file__).resolve().parent), n=n, tilt=TILT)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(root))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=900,
                         cwd=str(root))
    if res.returncode:
        print(f"  baseline, {n} links: failed: {res.stderr.strip().splitlines()[-1:]}")
        return None
    return float(res.stdout.split()[-1])


def growth(links, times) -> float | None:
    """Least-squares slope of log time vs log N over N >= FIT_FROM (None with fewer than two points)."""
    pts = [(n, t) for n, t in zip(links, times, strict=True) if n >= FIT_FROM and t]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def _revision(root: Path) -> str:
    """The short commit of the checkout at ``root``."""
    res = subprocess.run(["git", "log", "-1", "--format=%h"], cwd=root, capture_output=True, text=True)
    return res.stdout.strip() or str(root)


def _us(t) -> str:
    return "-" if t is None else (f"{t * 1e6:.1f}" if t < 1e-3 else f"{t * 1e6:.0f}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", nargs="+", type=int, default=list(LINKS), metavar="N",
                        help=f"chain lengths (default {' '.join(map(str, LINKS))})")
    parser.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                        help="another rigidlab checkout whose right-hand side is timed in the same run")
    args = parser.parse_args(argv)
    links = args.links
    base_root = None if args.baseline is None else args.baseline.resolve()
    if base_root is not None and not (base_root / "core" / "multibody").is_dir():
        raise ValueError(f"--baseline: expected a rigidlab checkout (with core/multibody), got {args.baseline}")
    started = time.perf_counter()
    machine, versions = _machine(), _versions()
    print(f"# rigidlab right-hand-side benchmark, {datetime.date.today().isoformat()}, rigidlab {git_revision()}")
    print(f"{machine}; " + ", ".join(f"{k} {v}" for k, v in versions.items()))
    print(f"CPU (process time) of one evaluation, best of {REPEATS} loops of ~{LOOP_SECONDS * 1e3:.0f} ms\n")
    engines = {"rigidlab rhs": rigidlab_rhs, "MuJoCo mj_forward": mujoco_forward, "Pinocchio aba": pinocchio_aba}
    times: dict[str, list] = {name: [] for name in engines}
    base_name = None if base_root is None else f"rigidlab rhs at {_revision(base_root)}"
    if base_name is not None:
        times[base_name] = []
    for n in links:
        system = pendulum_chain(n, tilt=TILT)  # one System per chain (building 300 links takes seconds)
        for name, make in engines.items():
            call = make(n, system)
            times[name].append(None if call is None else best_per_call(call))
        if base_name is not None:
            times[base_name].append(baseline_rhs(base_root, n))
        print(f"  {n} links: " + ", ".join(f"{k} {_us(v[-1])} us" for k, v in times.items()), flush=True)
    firsts = []
    for n in links:
        if n > FIRST_CALL_MAX:
            firsts.append(None)
            continue
        firsts.append(first_call(n))
        print(f"  {n} links: first rhs call in a fresh process "
              f"{'-' if firsts[-1] is None else f'{firsts[-1][0] * 1e3:.1f} ms'}", flush=True)

    base = times["rigidlab rhs"]
    header = ["us per call"] + [f"N = {n}" for n in links] + [f"growth N^p ({FIT_FROM}..{max(links)})"]
    table = []
    for name, ts in times.items():
        p = growth(links, ts)
        table.append([name] + [_us(t) for t in ts] + ["-" if p is None else f"{p:.2f}"])
    for name, ts in times.items():
        if name == "rigidlab rhs":
            continue
        table.append([f"{name} / rigidlab" if name != base_name else "baseline / rigidlab (> 1: now faster)"] + [("-" if (t is None or b is None) else f"{t / b:.2f}")
                                              for t, b in zip(ts, base, strict=True)] + ["-"])
    table.append(["rigidlab first rhs call, fresh process (ms, wall)"]
                 + [("-" if f is None else f"{f[0] * 1e3:.1f}") for f in firsts] + ["-"])
    table.append(["rigidlab second call there (us, wall)"]
                 + [("-" if f is None else _us(f[1])) for f in firsts] + ["-"])
    print()
    print("| " + " | ".join(header) + " |")
    print("|---|" + "---:|" * (len(header) - 1))
    for row in table:
        print("| " + " | ".join(row) + " |")
    print("\n(peer / rigidlab > 1: rigidlab's right-hand side is faster; rigidlab integrates 13 N first-order "
          "states with N x 5 constraint rows, the peers 2 N)")
    elapsed = time.perf_counter() - started
    print(f"\n(bench wall time {elapsed:.0f} s)")
    OUT.mkdir(exist_ok=True)
    (OUT / "rhs.json").write_text(json.dumps({
        "date": datetime.date.today().isoformat(), "rigidlab": git_revision(), "machine": machine,
        "versions": versions, "links": links, "seconds_per_call": times,
        "growth_exponent": {k: growth(links, v) for k, v in times.items()},
        "first_call_s": [None if f is None else f[0] for f in firsts],
        "second_call_s": [None if f is None else f[1] for f in firsts], "wall_s": elapsed}, indent=1))
    print(f"wrote {OUT / 'rhs.json'}")


if __name__ == "__main__":
    main()
