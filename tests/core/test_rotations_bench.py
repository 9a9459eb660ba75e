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


def test_single_call_rows_cover_the_five_operations_and_all_24_sequences():
    bench = _load()
    results = bench.run_single(repeat=1, target=0.002)
    rows = [r["row"] for r in results]
    assert rows[:4] == [
        "matrix -> Euler parameters",
        "Euler parameters -> matrix",
        "quaternion product",
        "axis-angle -> matrix",
    ]
    seqs = [row.rsplit(" ", 1)[1] for row in rows[4:]]
    assert len(set(seqs)) == 24 and all(row.startswith("matrix <- Euler angles") for row in rows[4:])
    for r in results:
        assert r["ours_s"] > 0 and r["scipy_s"] > 0
        assert r["max_dev"] < 3e-15, r
    table = bench.format_single_table(results)
    assert table.count("\n") == len(results) + 1
    assert "(us)" in table
