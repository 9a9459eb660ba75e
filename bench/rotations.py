"""Throughput of core.rotations against scipy's Rotation, measured in the same run.

Batched rows: matrix -> Euler parameters, Euler parameters -> matrix, matrix
<- Euler angles (ZXZ), quaternion product and axis-angle -> matrix, for
N = 1e3, 1e5 and 1e6 rotations. Each row times both implementations on the
same seeded inputs, alternating them, and reports the best time per call, the
ratio (scipy time / our time; above 1 means core.rotations is faster) and
the largest absolute difference between the two outputs (quaternions are
compared up to their sign). Batches of at least
``rigidlab.core.rotations._batch.COMPILED_MIN`` rotations run core.rotations'
compiled kernels (numba); their first call in the process (the import of
numba and the compile, or the load from numba's cache) is made before
anything is timed, when the outputs are compared.

Single-call rows: the same operations on one rotation (input shape (3,),
(4,) or (3, 3), what a scene does per frame), the Euler-angle matrix for all
24 sequences, against the equivalent scipy call on one rotation
(``Rotation.from_euler(seq, angles).as_matrix()`` and so on), with the time
per call in microseconds, best of ``--repeat``.

Usage::

    python bench/rotations.py [--sizes 1000 100000 1000000] [--repeat 7]
                              [--no-single] [--json bench/out/rotations.json]
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

import rigidlab.core.rotations as cr


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


def _ld_matrix_from_quaternion(p):
    """Matrices of quaternions in extended precision (normalized first)."""
    p = p.astype(np.longdouble)
    p = p / np.sqrt(np.sum(p * p, axis=-1, keepdims=True))
    w, x, y, z = (p[..., k] for k in range(4))
    rows = [
        w * w + x * x - y * y - z * z, 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), w * w - x * x + y * y - z * z, 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), w * w - x * x - y * y + z * z,
    ]
    return np.stack(rows, axis=-1).reshape(p.shape[:-1] + (3, 3))


def _ld_quaternion_from_matrix(A):
    """Unit quaternions (theta0 >= 0) of matrices in extended precision."""
    A = A.astype(np.longdouble)
    tr = A[:, 0, 0] + A[:, 1, 1] + A[:, 2, 2]
    M = np.empty((A.shape[0], 4, 4), dtype=np.longdouble)
    M[:, 0, 0] = 1 + tr
    for k in range(3):
        M[:, k + 1, k + 1] = 1 - tr + 2 * A[:, k, k]
    M[:, 0, 1] = M[:, 1, 0] = A[:, 2, 1] - A[:, 1, 2]
    M[:, 0, 2] = M[:, 2, 0] = A[:, 0, 2] - A[:, 2, 0]
    M[:, 0, 3] = M[:, 3, 0] = A[:, 1, 0] - A[:, 0, 1]
    M[:, 1, 2] = M[:, 2, 1] = A[:, 1, 0] + A[:, 0, 1]
    M[:, 1, 3] = M[:, 3, 1] = A[:, 0, 2] + A[:, 2, 0]
    M[:, 2, 3] = M[:, 3, 2] = A[:, 2, 1] + A[:, 1, 2]
    k = np.argmax(np.stack([M[:, i, i] for i in range(4)], axis=-1), axis=-1)
    q = M[np.arange(A.shape[0]), k]
    q = q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
    return q * np.where(q[:, :1] < 0, -1, 1)


def _ld_zxz(angles):
    a = angles.astype(np.longdouble)
    c1, c2, c3 = (np.cos(a[:, k]) for k in range(3))
    s1, s2, s3 = (np.sin(a[:, k]) for k in range(3))
    rows = [
        c1 * c3 - s1 * c2 * s3, -c1 * s3 - s1 * c2 * c3, s1 * s2,
        s1 * c3 + c1 * c2 * s3, -s1 * s3 + c1 * c2 * c3, -c1 * s2,
        s2 * s3, s2 * c3, c2,
    ]
    return np.stack(rows, axis=-1).reshape(-1, 3, 3)


def _ld_product(p, q):
    a = p.astype(np.longdouble)
    b = q.astype(np.longdouble)
    a0, a1, a2, a3 = (a[:, k] for k in range(4))
    b0, b1, b2, b3 = (b[:, k] for k in range(4))
    return np.stack(
        [
            a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3,
            a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1,
        ],
        axis=-1,
    )


def _ld_rodriguez(axis, angle):
    v = axis.astype(np.longdouble)
    v = v / np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    t = angle.astype(np.longdouble)
    s = np.sin(t)[:, None, None]
    k = (1 - np.cos(t))[:, None, None]
    S = np.zeros((axis.shape[0], 3, 3), dtype=np.longdouble)
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    S[:, 1, 0], S[:, 2, 0], S[:, 2, 1] = v[:, 2], -v[:, 1], v[:, 0]
    return np.eye(3, dtype=np.longdouble) + s * S + k * (S @ S)


def _rows(x):
    """(name, ours, scipy, compare up to sign, extended-precision reference)."""
    return [
        (
            "matrix -> Euler parameters",
            lambda: cr.euler_parameters_from_matrix(x["A"]),
            lambda: Rotation.from_matrix(x["A"]).as_quat(scalar_first=True),
            True,
            lambda: _ld_quaternion_from_matrix(x["A"]),
        ),
        (
            "Euler parameters -> matrix",
            lambda: cr.matrix_from_euler_parameters(x["p"]),
            lambda: Rotation.from_quat(x["p"], scalar_first=True).as_matrix(),
            False,
            lambda: _ld_matrix_from_quaternion(x["p"]),
        ),
        (
            "matrix <- Euler angles ZXZ",
            lambda: cr.matrix_from_euler_angles(x["angles"], "ZXZ"),
            lambda: Rotation.from_euler("ZXZ", x["angles"]).as_matrix(),
            False,
            lambda: _ld_zxz(x["angles"]),
        ),
        (
            "quaternion product",
            lambda: cr.quaternion_product(x["p"], x["q"]),
            lambda: (
                Rotation.from_quat(x["p"], scalar_first=True)
                * Rotation.from_quat(x["q"], scalar_first=True)
            ).as_quat(scalar_first=True),
            True,
            lambda: _ld_product(x["p"], x["q"]),
        ),
        (
            "axis-angle -> matrix",
            lambda: cr.matrix_from_axis_angle(x["axis"], x["angle"]),
            lambda: Rotation.from_rotvec(x["axis"] * x["angle"][:, None]).as_matrix(),
            False,
            lambda: _ld_rodriguez(x["axis"], x["angle"]),
        ),
    ]


def _max_error(result, reference, up_to_sign):
    if up_to_sign:
        result = _align_sign(reference.astype(np.float64), result)
    return float(np.max(np.abs(result.astype(np.longdouble) - reference)))


def _loops_for(f, target=0.05):
    """Number of calls that take about ``target`` seconds."""
    t0 = time.perf_counter()
    f()
    dt = max(time.perf_counter() - t0, 1e-7)
    return max(1, int(target / dt))


def _best_times(f_ours, f_scipy, repeat, target=0.05):
    """Best time per call of each function, alternating them ``repeat`` times
    (each timing loop runs for about ``target`` seconds)."""
    n_ours = _loops_for(f_ours, target)
    n_scipy = _loops_for(f_scipy, target)
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
        ``scipy_s``, ``ratio`` (scipy time / our time), ``max_dev`` (largest
        absolute difference between the outputs) and ``ours_err`` /
        ``scipy_err`` (largest absolute error against the extended-precision
        reference).
    """
    results = []
    for n in sizes:
        x = _inputs(n)
        for name, f_ours, f_scipy, up_to_sign, f_reference in _rows(x):
            ours = f_ours()
            theirs = f_scipy()
            if up_to_sign:
                theirs = _align_sign(ours, theirs)
            dev = float(np.max(np.abs(ours - theirs)))
            reference = f_reference()
            t_ours, t_scipy = _best_times(f_ours, f_scipy, repeat)
            results.append(
                {
                    "row": name,
                    "n": int(n),
                    "ours_s": t_ours,
                    "scipy_s": t_scipy,
                    "ratio": t_scipy / t_ours,
                    "max_dev": dev,
                    "ours_err": _max_error(ours, reference, up_to_sign),
                    "scipy_err": _max_error(theirs, reference, up_to_sign),
                }
            )
    return results


SEQUENCES = tuple(
    seq
    for letters in ("XYZ", "xyz")
    for seq in (a + b + c for a in letters for b in letters for c in letters)
    if seq[0] != seq[1] and seq[1] != seq[2]
)


def _single_rows(seed=1):
    """(name, ours, scipy, compare up to sign) on one rotation each."""
    rng = np.random.default_rng(seed)
    p = _unit_quaternions(rng, 1)[0]
    q = _unit_quaternions(rng, 1)[0]
    A = Rotation.from_quat(p, scalar_first=True).as_matrix()
    angles = rng.uniform(-np.pi, np.pi, size=3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = float(rng.uniform(-np.pi, np.pi))
    rows = [
        (
            "matrix -> Euler parameters",
            lambda: cr.euler_parameters_from_matrix(A),
            lambda: Rotation.from_matrix(A).as_quat(scalar_first=True),
            True,
        ),
        (
            "Euler parameters -> matrix",
            lambda: cr.matrix_from_euler_parameters(p),
            lambda: Rotation.from_quat(p, scalar_first=True).as_matrix(),
            False,
        ),
        (
            "quaternion product",
            lambda: cr.quaternion_product(p, q),
            lambda: (
                Rotation.from_quat(p, scalar_first=True)
                * Rotation.from_quat(q, scalar_first=True)
            ).as_quat(scalar_first=True),
            True,
        ),
        (
            "axis-angle -> matrix",
            lambda: cr.matrix_from_axis_angle(axis, angle),
            lambda: Rotation.from_rotvec(axis * angle).as_matrix(),
            False,
        ),
    ]
    for seq in SEQUENCES:
        rows.append(
            (
                f"matrix <- Euler angles {seq}",
                lambda seq=seq: cr.matrix_from_euler_angles(angles, seq),
                lambda seq=seq: Rotation.from_euler(seq, angles).as_matrix(),
                False,
            )
        )
    return rows


def run_single(repeat=7, target=0.05):
    """Measure every single-call row (one rotation per call), each timing
    loop running for about ``target`` seconds.

    Returns
    -------
    results : list of dict
        One entry per row with keys ``row``, ``ours_s``, ``scipy_s`` (best
        time per call), ``ratio`` (scipy time / our time) and ``max_dev``
        (largest absolute difference between the outputs).
    """
    results = []
    for name, f_ours, f_scipy, up_to_sign in _single_rows():
        ours = f_ours()
        theirs = f_scipy()
        if up_to_sign:
            theirs = _align_sign(ours, theirs)
        t_ours, t_scipy = _best_times(f_ours, f_scipy, repeat, target)
        results.append(
            {
                "row": name,
                "ours_s": t_ours,
                "scipy_s": t_scipy,
                "ratio": t_scipy / t_ours,
                "max_dev": float(np.max(np.abs(ours - theirs))),
            }
        )
    return results


def format_single_table(results):
    """Markdown table of :func:`run_single`'s results."""
    lines = [
        "| single call | core.rotations (us) | scipy Rotation (us) | ratio (scipy/ours) "
        "| max deviation |",
        "|---|---:|---:|---:|---:|",
    ]
    for r in results:
        lines.append(
            f"| {r['row']} | {1e6 * r['ours_s']:.2f} | {1e6 * r['scipy_s']:.2f} | "
            f"{r['ratio']:.2f}x | {r['max_dev']:.1e} |"
        )
    return "\n".join(lines)


def format_table(results):
    """Markdown table of :func:`run`'s results."""
    lines = [
        "| row | N | core.rotations (ms) | scipy Rotation (ms) | ratio (scipy/ours) "
        "| max deviation | error ours | error scipy |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        lines.append(
            f"| {r['row']} | {r['n']:.0e} | {1e3 * r['ours_s']:.3f} | "
            f"{1e3 * r['scipy_s']:.3f} | {r['ratio']:.2f}x | {r['max_dev']:.1e} | "
            f"{r['ours_err']:.1e} | {r['scipy_err']:.1e} |"
        )
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--sizes", type=int, nargs="+", default=[1_000, 100_000, 1_000_000]
    )
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument(
        "--no-single", action="store_true", help="skip the single-call rows"
    )
    parser.add_argument("--json", type=Path, default=None, help="also write results here")
    args = parser.parse_args(argv)
    results = run(args.sizes, args.repeat)
    print(
        f"rigidlab.core.rotations vs scipy {scipy.__version__} Rotation, numpy {np.__version__}, "
        f"Python {platform.python_version()}, best of {args.repeat}"
    )
    print(format_table(results))
    single = []
    if not args.no_single:
        single = run_single(args.repeat)
        print()
        print(format_single_table(single))
    print(
        "ratio > 1: core.rotations is faster. max deviation: largest |ours - scipy|. "
        "error: largest |result - reference| with the reference evaluated in "
        f"np.longdouble (eps {np.finfo(np.longdouble).eps:.1e})."
    )
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"batched": results, "single": single}, indent=2))
    return results, single


if __name__ == "__main__":
    main()
