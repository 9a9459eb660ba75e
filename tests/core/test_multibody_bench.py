"""bench/multibody.py builds its table on a tiny case (no timing is asserted)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench" / "multibody.py"


def _load():
    spec = importlib.util.spec_from_file_location("bench_multibody", BENCH)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_table_of_a_two_link_chain_over_one_second():
    bench = _load()
    lines = []
    rows, summary = bench.build_table(("chain2",), targets=(1e-6,), t_end=1.0, engines=("rigidlab",), repeats=1,
                                      log=lines.append)
    assert [(r["target"], r["engine"]) for r in rows] == [("-", "reference"), ("1e-06", "rigidlab")]
    for row in rows:
        assert set(bench.COLUMNS) <= set(row)
    ours = rows[1]
    assert ours["reached"] and 0.0 < ours["error_m"] <= 1e-6 and ours["cpu_s"] > 0.0
    assert ours["residual"] < 1e-10 and ours["CPU / rigidlab"] == "-"
    assert rows[0]["error_m"] < 1e-9  # the reference's self-check
    assert summary["cases"]["chain2"]["rtol"]["1e-06"] == pytest.approx(ours["knob"])
    table = bench.format_table(rows)
    assert table.splitlines()[0] == "| " + " | ".join(bench.COLUMNS) + " |"
    assert table.count("\n") == len(rows) + 1


def test_a_missing_peer_is_reported_not_run(monkeypatch):
    bench = _load()
    monkeypatch.setattr(bench.MuJoCo, "missing", lambda self: f"not installed ({bench.INSTALL_HINT})")
    lines = []
    rows, summary = bench.build_table(("chain2",), targets=(1e-6,), t_end=0.5, engines=("MuJoCo",), repeats=1,
                                      log=lines.append)
    assert "MuJoCo: not installed (pip install -e '.[bench]')" in lines
    assert summary["missing"] == {"MuJoCo": "not installed (pip install -e '.[bench]')"}
    assert [r["engine"] for r in rows] == ["reference", "rigidlab"]


def test_slider_crank_reference_is_the_closed_form():
    bench = _load()
    case = bench.make_case("slider_crank", t_end=0.5)
    assert case.reference.shape == (31, 3, 3)
    model = case.build()
    start = np.array([model.system.state.position(b) for b in model.system.bodies])
    np.testing.assert_allclose(case.reference[0], start, atol=1e-14)
    with pytest.raises(ValueError, match="model: expected one of"):
        bench.make_case("four_bar")


@pytest.mark.parametrize(("model", "n_bodies"), [("chain2", 2), ("slider_crank", 3)])
@pytest.mark.parametrize("engine", ["MuJoCo", "Exudyn"])
def test_peers_build_the_same_model(engine, model, n_bodies):
    bench = _load()
    peer = bench.ENGINES[engine]()
    if peer.missing():
        pytest.skip(f"{engine}: {peer.missing()}")
    case = bench.make_case(model, t_end=0.5)
    centres, residual, cpu = peer.run(case, 8)
    assert centres.shape == (31, n_bodies, 3) and cpu >= 0.0
    # the same bodies, masses, joints and initial state: even a coarse step stays close to the reference
    assert bench.position_error(centres, case) < 1e-4
    if engine == "MuJoCo" and model == "slider_crank":
        assert residual < 1e-4  # the loop-closing and driving equalities hold


def test_ratio_summary_counts_reached_targets():
    bench = _load()
    rows = [
        bench._row("m", "-", "reference", "", 0.1, 0.0, None, None),
        bench._row("m", "1e-06", "rigidlab", "", 1.0, 5e-7, 1e-13, None),
        bench._row("m", "1e-06", "Peer", "", 2.0, 5e-7, None, 2.0),
        bench._row("m", "1e-06", "Peer", "not reached", 9.0, 5e-5, None, None, reached=False),
    ]
    summary = bench.ratio_summary(rows)
    assert summary.splitlines()[1] == "- 1e-06: Peer 2 .. 2 (reached on 1 of 2 models)"
