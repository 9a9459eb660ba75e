"""bench/rotations.py runs and its outputs agree (no timing is asserted)."""

import importlib.util
from pathlib import Path

BENCH = Path(__file__).resolve().parents[2] / "bench" / "rotations.py"


def _load():
    spec = importlib.util.spec_from_file_location("bench_rotations", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_bench_runs_and_results_agree_with_scipy_and_reference():
    bench = _load()
    results = bench.run(sizes=(200,), repeat=1)
    assert [r["row"] for r in results] == [
        "matrix -> Euler parameters",
        "Euler parameters -> matrix",
        "matrix <- Euler angles ZXZ",
        "quaternion product",
        "axis-angle -> matrix",
    ]
    for r in results:
        assert r["ours_s"] > 0 and r["scipy_s"] > 0
        # Outputs are O(1); both sides round a handful of times.
        assert r["max_dev"] < 2e-15, r
        assert r["ours_err"] < 2e-15, r
    table = bench.format_table(results)
    assert table.count("\n") == len(results) + 1
    assert "ratio (scipy/ours)" in table
