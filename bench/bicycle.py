"""Whipple bicycle benchmark: CPU of one speed and of the 0-10 m/s sweep, digits against the paper.

One run prints:

1. Building ``core.models.whipple_bicycle`` (bodies, joints, the two
   rolling contacts found and assembled), ``core.modal.linearize`` and
   ``LinearModel.modes`` at 5 m/s: CPU of each part, best of three.
2. For every speed of the paper's Table 2 (0, 1, ..., 10 m/s) the number
   of significant digits of each of the four eigenvalues against the
   published ones (14 decimals) and against the paper's equations built
   from the parameters (``whipple_bicycle_reference``):
   ``-log10(abs(s - s_ref) / abs(s_ref))``.
3. ``core.modal.sweep`` over 0-10 m/s (101 speeds) serially (one worker
   thread) and on the default process pool, then ``boundaries()`` (Brent
   on the engine, ``xtol`` 1e-13 m/s): CPU, wall time, the weave and
   capsize speeds and their digits against the published
   4.29238253634111 and 6.02426201538837 m/s, and the self-stable range.

Usage::

    .venv/bin/python bench/bicycle.py [--points 101]

BLAS runs single-threaded (``OPENBLAS_NUM_THREADS=1`` unless set). The CPU
times are this process's own (the pool's workers are reported as wall
time). Nothing is asserted; it is a report.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import concurrent.futures  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

from core.modal import LinearModel, linearize, sweep  # noqa: E402
from core.models import (  # noqa: E402
    MEIJAARD_2007_EIGENVALUES,
    MEIJAARD_2007_SPEEDS,
    whipple_bicycle,
    whipple_bicycle_reference,
    whipple_modes,
)


def bicycle_model(speed: float) -> LinearModel:
    """The sweep's build function (module level: picklable for the process pool)."""
    return linearize(whipple_bicycle(speed))


def digits(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    """Significant digits of each ``want`` matched one to one with ``got`` (16: exact)."""
    cost = np.abs(got[:, None] - want[None, :])
    rows, cols = linear_sum_assignment(cost)
    rel = np.empty(want.size)
    rel[cols] = cost[rows, cols] / np.abs(want[cols])
    with np.errstate(divide="ignore"):
        return np.minimum(-np.log10(rel), 16.0)


def one_speed(speed: float = 5.0) -> None:
    build = lin = eig = math.inf
    for _ in range(3):
        c0 = time.process_time()
        system = whipple_bicycle(speed)
        c1 = time.process_time()
        model = linearize(system)
        c2 = time.process_time()
        model.modes()
        c3 = time.process_time()
        build, lin, eig = min(build, c1 - c0), min(lin, c2 - c1), min(eig, c3 - c2)
    print(f"one speed ({speed} m/s), CPU best of 3: build + assemble {build * 1e3:.0f} ms, linearize "
          f"{lin * 1e3:.0f} ms, modes {eig * 1e3:.1f} ms; total {(build + lin + eig) * 1e3:.0f} ms")
    names = ", ".join(f"{m.name} {m.eigenvalue:.6g}" for m in whipple_modes(model))
    print(f"  modes: {names}")


def table_digits() -> float:
    ref = whipple_bicycle_reference()
    published = MEIJAARD_2007_EIGENVALUES["eigenvalues"]
    print("\nsignificant digits of the eigenvalues (engine vs the paper's Table 2 | vs its equations):")
    print(f"{'v (m/s)':>8}  {'eigenvalues (engine)':<72}  {'digits vs Table 2':<22}  digits vs equations")
    worst = 16.0
    for v in MEIJAARD_2007_SPEEDS:
        modes = linearize(whipple_bicycle(v)).modes()
        live = modes.eigenvalues[~modes.rigid]
        live = live[np.lexsort((live.imag, live.real))]
        d_pub = digits(live, np.array(published[v]))
        d_ref = digits(live, ref.eigenvalues(v))
        worst = min(worst, float(d_pub.min()))
        text = "  ".join(f"{s.real:+.6f}{s.imag:+.6f}j" if s.imag else f"{s.real:+.8f}" for s in live)
        print(f"{v:>8.1f}  {text:<72}  {' '.join(f'{x:4.1f}' for x in d_pub):<22}  "
              f"{' '.join(f'{x:4.1f}' for x in d_ref)}")
    print(f"  fewest digits vs Table 2: {worst:.1f}")
    return worst


def sweeps(points: int) -> None:
    speeds = np.linspace(0.0, 10.0, points)
    w0, c0 = time.perf_counter(), time.process_time()
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(bicycle_model, speeds, executor=pool)
    w1, c1 = time.perf_counter(), time.process_time()
    print(f"\nsweep 0-10 m/s, {points} speeds, serial: CPU {c1 - c0:.2f} s ({(c1 - c0) / points * 1e3:.0f} ms a "
          f"speed), wall {w1 - w0:.2f} s")
    w0 = time.perf_counter()
    pooled = sweep(bicycle_model, speeds)
    w1 = time.perf_counter()
    agree = float(np.max(np.abs(np.sort_complex(pooled.eigenvalues.ravel()) - np.sort_complex(
        result.eigenvalues.ravel()))))
    print(f"sweep on the default process pool ({os.cpu_count()} CPUs): wall {w1 - w0:.2f} s "
          f"(largest difference to the serial sweep {agree:.1e})")
    c0, w0 = time.process_time(), time.perf_counter()
    b = result.boundaries(xtol=1e-13)
    c1, w1 = time.process_time(), time.perf_counter()
    pub = np.array([MEIJAARD_2007_EIGENVALUES["weave_speed"], MEIJAARD_2007_EIGENVALUES["capsize_speed"]])
    print(f"boundaries() (Brent on the engine, xtol 1e-13): CPU {c1 - c0:.2f} s, wall {w1 - w0:.2f} s")
    for name, got, want in zip(("weave speed", "capsize speed"), b, pub, strict=False):
        d = min(16.0, -math.log10(abs(got - want) / want)) if got != want else 16.0
        print(f"  {name}: {float(got)!r} m/s (published {float(want)!r}; {d:.1f} significant digits)")
    if b.size == 2:
        print(f"  self-stable range: {b[0]:.10f} < v < {b[1]:.10f} m/s")
    stable = np.all(result.stable, axis=1)
    print(f"  stable on the grid: {speeds[stable].min():.2f} to {speeds[stable].max():.2f} m/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=101, help="speeds in the 0-10 m/s sweep")
    args = parser.parse_args()
    one_speed()
    table_digits()
    sweeps(args.points)


if __name__ == "__main__":
    main()
