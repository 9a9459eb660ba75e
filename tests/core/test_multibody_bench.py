"""bench/multibody.py and bench/rhs.py on tiny cases (no timing is asserted)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"


def _load(name="multibody"):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCH / f"{name}.py")
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


#: Every peer path of bench/multibody.py, by class name (the paths of a peer are tried on their own).
PEER_PATHS = ("MuJoCo", "ExudynAlpha", "ExudynAlphaSparse", "ExudynTreeRK44", "ExudynTreeDOPRI5")


def test_every_peer_path_is_listed():
    bench = _load()
    listed = {cls.__name__ for paths in bench.ENGINES.values() for cls in paths}
    assert listed == {"Rigidlab", *PEER_PATHS}
    names = [cls().name for paths in bench.ENGINES.values() for cls in paths]
    assert len(set(names)) == len(names)  # the search memo is keyed by name


@pytest.mark.parametrize(("model", "n_bodies"), [("chain2", 2), ("slider_crank", 3)])
@pytest.mark.parametrize("path", PEER_PATHS)
def test_peers_build_the_same_model(path, model, n_bodies):
    bench = _load()
    peer = getattr(bench, path)()
    if peer.missing():
        pytest.skip(f"{peer.name}: {peer.missing()}")
    case = bench.make_case(model, t_end=0.5)
    if not peer.applies(case):
        assert path.startswith("ExudynTree") and model == "slider_crank"  # the tree paths are for chains
        return
    # a coarse setting: 8 steps per frame, or rtol 1e-8 for the adaptive DOPRI5
    effort = peer.effort_for(1e-8) if peer.grid == "rtol" else 8
    centres, residual, cpu = peer.run(case, effort)
    assert centres.shape == (31, n_bodies, 3) and cpu >= 0.0
    # the same bodies, masses, joints and initial state: even a coarse step stays close to the reference
    assert bench.position_error(centres, case) < 1e-4
    if path == "MuJoCo" and model == "slider_crank":
        assert residual < 1e-4  # the loop-closing and driving equalities hold


def test_the_kinematic_tree_is_the_chain():
    bench = _load()
    system = bench.pendulum_chain(3, tilt=bench.CHAIN_TILT)
    tree = bench.chain_tree(3)
    centres, tip = bench.tree_points(tree, bench.chain_angles0(3))
    np.testing.assert_allclose(centres, [system.state.position(b) for b in system.bodies], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(tip - tree.offset[0]), 3.0, rtol=1e-12)  # 3 rods of 1 m, straight


def test_ratio_summary_counts_reached_targets():
    bench = _load()
    rows = [
        bench._row("m", "-", "reference", "-", "", 0.1, 0.0, None, None),
        bench._row("m", "1e-06", "rigidlab", "DOP853", "", 1.0, 5e-7, 1e-13, None),
        bench._row("m", "1e-06", "Peer", "RK4", "", 2.0, 5e-7, None, 2.0),
        bench._row("m", "1e-06", "Peer", "RK4", "not reached", 9.0, 5e-5, None, None, reached=False),
    ]
    summary = bench.ratio_summary(rows)
    assert summary.splitlines()[1] == "- 1e-06: Peer 2 .. 2 (reached on 1 of 2 models)"
    table = bench.format_table(rows)
    assert table.splitlines()[3].split(" | ")[3] == "DOP853"  # the path column


def test_rhs_bench_times_rigidlab_and_fits_the_growth_exponent():
    rhs = _load("rhs")
    for n in (2, 3):
        system = rhs.pendulum_chain(n, tilt=rhs.TILT)
        call = rhs.rigidlab_rhs(n, system)
        dy = np.asarray(call())
        assert dy.shape == (13 * n,) and np.all(np.isfinite(dy))
        assert rhs.best_per_call(call) > 0.0
        for make in (rhs.mujoco_forward, rhs.pinocchio_aba):
            peer = make(n, system)  # None when the peer is not installed
            if peer is not None:
                peer()
    links = [2, 10, 30, 100]
    assert rhs.growth(links, [1e-6 * n**1.5 for n in links]) == pytest.approx(1.5)
    assert rhs.growth(links, [5.0, 1e-5, 3e-5, 1e-4]) == pytest.approx(1.0)  # N = 2 is left out of the fit
    assert rhs.growth(links, [1e-6, 1e-5, None, None]) is None  # fewer than two points
