"""Whipple bicycle benchmark: CPU of one speed and of the 0-10 m/s sweep, digits against the paper.

One run prints:

1. Building ``rigidlab.core.models.whipple_bicycle`` (the first call builds the
   bodies, joints and the two rolling contacts found and assembled; later
   calls copy that System and scale its velocities),
   ``rigidlab.core.modal.linearize`` and ``LinearModel.modes`` at 5 m/s: CPU of
   each part, best of three; then ``rigidlab.core.models.whipple_speed_model``
   (two linearizations, once per parameter set) and one speed from it
   (``linear_model(v).modes()``).
2. For every speed of the paper's Table 2 (0, 1, ..., 10 m/s) the number
   of significant digits of each of the four eigenvalues against the
   published ones (14 decimals) and against the paper's equations built
   from the parameters (``whipple_bicycle_reference``):
   ``-log10(abs(s - s_ref) / abs(s_ref))``; the engine linearized at each
   speed, and the fewest digits of the speed model.
3. ``rigidlab.core.modal.sweep`` over 0-10 m/s (101 speeds) serially (one worker
   thread): from the speed model (its two linearizations counted), and
   with ``linearize(whipple_bicycle(v))`` at every speed; the latter also
   on the default process pool. Then ``boundaries()`` (Brent, ``xtol``
   1e-13 m/s) of each: CPU, wall time, the weave and capsize speeds and
   their digits against the published 4.29238253634111 and
   6.02426201538837 m/s, and the self-stable range.

Usage::

    .venv/bin/python bench/bicycle.py [--points 101] [--direct-points 101]

``--direct-points 0`` leaves out the sweeps that linearize at every speed.
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

from rigidlab.core.modal import LinearModel, linearize, sweep  # noqa: E402
from rigidlab.core.models import (  # noqa: E402
    MEIJAARD_2007_EIGENVALUES,
    MEIJAARD_2007_SPEEDS,
    whipple_bicycle,
    whipple_bicycle_reference,
    whipple_modes,
    whipple_speed_model,
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
    c0 = time.process_time()
    whipple_bicycle(speed)
    first = time.process_time() - c0
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
    print(f"one speed ({speed} m/s), CPU best of 3: build {build * 1e3:.1f} ms (the first call, which assembles: "
          f"{first * 1e3:.0f} ms), linearize {lin * 1e3:.0f} ms, modes {eig * 1e3:.1f} ms; total "
          f"{(build + lin + eig) * 1e3:.0f} ms")
    names = ", ".join(f"{m.name} {m.eigenvalue:.6g}" for m in whipple_modes(model))
    print(f"  modes: {names}")
    c0 = time.process_time()
    speeds = whipple_speed_model()
    coefficients = time.process_time() - c0
    one = math.inf
    for _ in range(3):
        c0 = time.process_time()
        speeds.linear_model(speed).modes()
        one = min(one, time.process_time() - c0)
    print(f"speed model: whipple_speed_model() {coefficients * 1e3:.0f} ms CPU (two linearizations, once per "
          f"parameter set); then one speed, linear_model(v).modes(), {one * 1e3:.1f} ms")


def table_digits() -> float:
    ref = whipple_bicycle_reference()
    published = MEIJAARD_2007_EIGENVALUES["eigenvalues"]
    speeds = whipple_speed_model()
    print("\nsignificant digits of the eigenvalues (engine vs the paper's Table 2 | vs its equations | speed model, "
          "fewest vs Table 2):")
    print(f"{'v (m/s)':>8}  {'eigenvalues (engine)':<72}  {'digits vs Table 2':<22}  {'digits vs equations':<22}  "
          "speed model")
    worst = worst_model = 16.0
    for v in MEIJAARD_2007_SPEEDS:
        live = _live(linearize(whipple_bicycle(v)))
        d_pub = digits(live, np.array(published[v]))
        d_ref = digits(live, ref.eigenvalues(v))
        d_model = float(digits(_live(speeds.linear_model(v)), np.array(published[v])).min())
        worst, worst_model = min(worst, float(d_pub.min())), min(worst_model, d_model)
        text = "  ".join(f"{s.real:+.6f}{s.imag:+.6f}j" if s.imag else f"{s.real:+.8f}" for s in live)
        print(f"{v:>8.1f}  {text:<72}  {' '.join(f'{x:4.1f}' for x in d_pub):<22}  "
              f"{' '.join(f'{x:4.1f}' for x in d_ref):<22}  {d_model:4.1f}")
    print(f"  fewest digits vs Table 2: {worst:.1f} (linearized at each speed), {worst_model:.1f} (speed model)")
    return worst


def _live(model: LinearModel) -> np.ndarray:
    modes = model.modes()
    live = modes.eigenvalues[~modes.rigid]
    return live[np.lexsort((live.imag, live.real))]


def sweeps(points: int, direct_points: int) -> None:
    speeds = np.linspace(0.0, 10.0, points)
    w0, c0 = time.perf_counter(), time.process_time()
    model = whipple_speed_model(reference_speed=10.0 + 1e-9 * points)  # not the cached one: its cost counts
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(model.linear_model, speeds, executor=pool)
    w1, c1 = time.perf_counter(), time.process_time()
    print(f"\nsweep 0-10 m/s, {points} speeds, serial, from the speed model (its two linearizations included): "
          f"CPU {c1 - c0:.2f} s ({(c1 - c0) / points * 1e3:.1f} ms a speed), wall {w1 - w0:.2f} s")
    _boundaries(result)
    if direct_points <= 0:
        return
    speeds = np.linspace(0.0, 10.0, direct_points)
    w0, c0 = time.perf_counter(), time.process_time()
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        direct = sweep(bicycle_model, speeds, executor=pool)
    w1, c1 = time.perf_counter(), time.process_time()
    print(f"\nsweep 0-10 m/s, {direct_points} speeds, serial, linearize(whipple_bicycle(v)) at every speed: CPU "
          f"{c1 - c0:.2f} s ({(c1 - c0) / direct_points * 1e3:.0f} ms a speed), wall {w1 - w0:.2f} s")
    if direct_points == points:
        live = max(float(np.max(np.abs(np.sort_complex(d[~dr]) - np.sort_complex(m[~mr]))))
                   for d, dr, m, mr in zip(direct.eigenvalues, direct.rigid, result.eigenvalues, result.rigid))
        zeros = float(np.max(np.abs(direct.eigenvalues[direct.rigid])))
        print(f"  largest difference of the four live eigenvalues to the speed model's sweep {live:.1e} (1/s); "
              f"the six structural zeros are split by round-off up to {zeros:.1e}")
    w0 = time.perf_counter()
    pooled = sweep(bicycle_model, speeds)
    w1 = time.perf_counter()
    agree = float(np.max(np.abs(np.sort_complex(pooled.eigenvalues.ravel()) - np.sort_complex(
        direct.eigenvalues.ravel()))))
    print(f"sweep on the default process pool ({os.cpu_count()} CPUs): wall {w1 - w0:.2f} s "
          f"(largest difference to the serial sweep {agree:.1e})")
    _boundaries(direct)


def _boundaries(result) -> None:
    c0, w0 = time.process_time(), time.perf_counter()
    b = result.boundaries(xtol=1e-13)
    c1, w1 = time.process_time(), time.perf_counter()
    pub = np.array([MEIJAARD_2007_EIGENVALUES["weave_speed"], MEIJAARD_2007_EIGENVALUES["capsize_speed"]])
    print(f"boundaries() (Brent on the build function, xtol 1e-13): CPU {c1 - c0:.2f} s, wall {w1 - w0:.2f} s")
    for name, got, want in zip(("weave speed", "capsize speed"), b, pub, strict=False):
        d = min(16.0, -math.log10(abs(got - want) / want)) if got != want else 16.0
        print(f"  {name}: {float(got)!r} m/s (published {float(want)!r}; {d:.1f} significant digits)")
    if b.size == 2:
        print(f"  self-stable range: {b[0]:.10f} < v < {b[1]:.10f} m/s")
    stable = np.all(result.stable, axis=1)
    print(f"  stable on the grid: {result.values[stable].min():.2f} to {result.values[stable].max():.2f} m/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=101, help="speeds in the 0-10 m/s sweep")
    parser.add_argument("--direct-points", type=int, default=101,
                        help="speeds of the sweeps that linearize at every speed (0: leave them out)")
    args = parser.parse_args()
    one_speed()
    table_digits()
    sweeps(args.points, args.direct_points)


if __name__ == "__main__":
    main()
