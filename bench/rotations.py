"""Throughput of core.rotations against scipy's Rotation, measured in the same run.

Rows: matrix -> Euler parameters, Euler parameters -> matrix, matrix <- Euler
angles (ZXZ), quaternion product and axis-angle -> matrix, for N = 1e3,
1e5 and 1e6 rotations. Each row times both implementations on the same
seeded inputs, alternating them, and reports the best time per call, the
ratio (scipy time / our time; above 1 means core.rotations is faster) and
the largest absolute difference between the two outputs (quaternions are
compared up to their sign).

Usage::

    python bench/rotations.py [--sizes 1000 100000 1000000] [--repeat 7]
                              [--json bench/out/rotations.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
import scipy
from scipy.spatial.transform import Rotation

import core.rotations as cr


def _unit_quaternions(rng, n):
    p = rng.normal(size=(n, 4))
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def _inputs(n, seed=0):
    rng = np.random.default_rng(seed)
    p = _unit_quaternions(rng, n)
    q = _unit_quaternions(rng, n)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    return {
        "p": p,
        "q": q,
        "A": Rotation.from_quat(p, scalar_first=True).as_matrix(),
        "angles": rng.uniform(-np.pi, np.pi, size=(n, 3)),
        "axis": axis,
        "angle": rng.uniform(-np.pi, np.pi, size=n),
    }


def _align_sign(ours, theirs):
    """Flip the sign of quaternions in ``theirs`` to match ``ours``."""
    sign = np.where(np.einsum("...i,...i->...", ours, theirs) < 0.0, -1.0, 1.0)
    return theirs * sign[..., None]


def _rows(x):
    """(name, ours, scipy, compare-up-to-sign) for the inputs ``x``."""
    return [
        (
            "matrix -> Euler parameters",
            lambda: cr.euler_parameters_from_matrix(x["A"]),
            lambda: Rotation.from_matrix(x["A"]).as_quat(scalar_first=True),
            True,
        ),
        (
            "Euler parameters -> matrix",
            lambda: cr.matrix_from_euler_parameters(x["p"]),
            lambda: Rotation.from_quat(x["p"], scalar_first=True).as_matrix(),
            False,
        ),
        (
            "matrix <- Euler angles ZXZ",
            lambda: cr.matrix_from_euler_angles(x["angles"], "ZXZ"),
            lambda: Rotation.from_euler("ZXZ", x["angles"]).as_matrix(),
            False,
        ),
        (
            "quaternion product",
            lambda: cr.quaternion_product(x["p"], x["q"]),
            lambda: (
                Rotation.from_quat(x["p"], scalar_first=True)
                * Rotation.from_quat(x["q"], scalar_first=True)
            ).as_quat(scalar_first=True),
            True,
        ),
        (
            "axis-angle -> matrix",
            lambda: cr.matrix_from_axis_angle(x["axis"], x["angle"]),
            lambda: Rotation.from_rotvec(x["axis"] * x["angle"][:, None]).as_matrix(),
            False,
        ),
    ]


def _loops_for(f, target=0.05):
    """Number of calls that take about ``target`` seconds."""
    t0 = time.perf_counter()
    f()
    dt = max(time.perf_counter() - t0, 1e-7)
    return max(1, int(target / dt))


def _best_times(f_ours, f_scipy, repeat):
    """Best time per call of each function, alternating them ``repeat`` times."""
    n_ours = _loops_for(f_ours)
    n_scipy = _loops_for(f_scipy)
    best_ours = best_scipy = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(n_ours):
            f_ours()
        best_ours = min(best_ours, (time.perf_counter() - t0) / n_ours)
        t0 = time.perf_counter()
        for _ in range(n_scipy):
            f_scipy()
        best_scipy = min(best_scipy, (time.perf_counter() - t0) / n_scipy)
    return best_ours, best_scipy


def run(sizes=(1_000, 100_000, 1_000_000), repeat=7):
    """Measure every row at every size.

    Returns
    -------
    results : list of dict
        One entry per (row, N) with keys ``row``, ``n``, ``ours_s``,
        ``scipy_s``, ``ratio`` (scipy time / our time) and ``max_dev``.
    """
    results = []
    for n in sizes:
        x = _inputs(n)
        for name, f_ours, f_scipy, up_to_sign in _rows(x):
            ours = f_ours()
            theirs = f_scipy()
            if up_to_sign:
                theirs = _align_sign(ours, theirs)
            dev = float(np.max(np.abs(ours - theirs)))
            t_ours, t_scipy = _best_times(f_ours, f_scipy, repeat)
            results.append(
                {
                    "row": name,
                    "n": int(n),
                    "ours_s": t_ours,
                    "scipy_s": t_scipy,
                    "ratio": t_scipy / t_ours,
                    "max_dev": dev,
                }
            )
    return results


def format_table(results):
    """Markdown table of :func:`run`'s results."""
    lines = [
        "| row | N | core.rotations (ms) | scipy Rotation (ms) | ratio (scipy/ours) | max deviation |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        lines.append(
            f"| {r['row']} | {r['n']:.0e} | {1e3 * r['ours_s']:.3f} | "
            f"{1e3 * r['scipy_s']:.3f} | {r['ratio']:.2f}x | {r['max_dev']:.1e} |"
        )
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--sizes", type=int, nargs="+", default=[1_000, 100_000, 1_000_000]
    )
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--json", type=Path, default=None, help="also write results here")
    args = parser.parse_args(argv)
    results = run(args.sizes, args.repeat)
    print(
        f"core.rotations vs scipy {scipy.__version__} Rotation, numpy {np.__version__}, "
        f"Python {platform.python_version()}, best of {args.repeat}"
    )
    print(format_table(results))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
