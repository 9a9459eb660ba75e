"""bench/contact.py builds its table on a tiny case (no timing is asserted)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench" / "contact.py"


def _load():
    spec = importlib.util.spec_from_file_location("bench_contact", BENCH)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_table_of_a_short_cam_and_disk_run():
    bench = _load()
    lines = []
    rows, summary = bench.build_table(rtols=(1e-8,), revolutions=0.25, t_end=0.25, compliant=False,
                                      mujoco_timesteps=(), repeats=1, log=lines.append)
    # the cam: DOP853, then the kinematic analysis (it has no degree of freedom); the disk: DOP853
    assert [(r["engine"], r["formulation"]) for r in rows] == [("reference", "-"), ("rigidlab", "constraint"),
                                                              ("rigidlab", "constraint"), ("reference", "-"),
                                                              ("rigidlab", "constraint")]
    for row in rows:
        assert set(bench.COLUMNS) <= set(row)
    cam, kinematic, disk = rows[1], rows[2], rows[4]
    assert cam["setting"] == "DOP853 rtol 1e-08" and kinematic["setting"].startswith("kinematic analysis")
    assert cam["cpu_s"] > 0.0 and cam["position_m"] < 1e-9 and cam["force_rel"] < 1e-8
    # solved to the Newton tolerance (see tests/core/test_kinematic.py): no integration error
    assert kinematic["cpu_s"] > 0.0 and kinematic["position_m"] < 1e-12 and kinematic["force_rel"] < 1e-10
    assert disk["cpu_s"] > 0.0 and disk["position_m"] < 1e-6 and disk["force_rel"] < 1e-6
    assert summary["cases"]["cam"]["constraint"]["1e-08"]["force_rel"] == cam["force_rel"]
    assert summary["cases"]["cam"]["kinematic"]["force_rel"] == kinematic["force_rel"]
    table = bench.format_table(rows)
    assert table.splitlines()[0] == "| " + " | ".join(bench.COLUMNS) + " |"
    assert table.count("\n") == len(rows) + 1


def test_cam_reference_is_the_closed_form_at_0_9_jump_speed():
    bench = _load()
    case = bench.make_case("cam", revolutions=1)
    cam = bench.cam_model()
    assert case.speed == pytest.approx(0.9 * cam.jump_speed())
    assert case.t.shape == (61,) and case.t[-1] == pytest.approx(2 * np.pi / case.speed)
    np.testing.assert_allclose(case.position, 0.01 * (1 - np.cos(case.speed * case.t)), atol=1e-15)
    assert case.force.min() > 0.0  # below the jump speed the follower presses throughout
    with pytest.raises(ValueError, match="model: expected one of"):
        bench.make_case("bicycle")


def test_the_disk_has_no_compliant_variant():
    bench = _load()
    rows, _ = bench.build_table(("disk",), rtols=(), t_end=0.1, compliant=True, mujoco_timesteps=(), repeats=1,
                                log=lambda _: None)
    assert rows[-1]["formulation"] == "compliant" and rows[-1]["setting"].startswith("not available")


def test_a_missing_mujoco_is_reported_not_run(monkeypatch):
    bench = _load()
    monkeypatch.setattr(bench, "mujoco_missing", lambda: f"not installed ({bench.INSTALL_HINT})")
    lines = []
    rows, summary = bench.build_table(("disk",), rtols=(), t_end=0.1, compliant=False, repeats=1,
                                      log=lines.append)
    assert "MuJoCo: not installed (pip install -e '.[bench]')" in lines
    assert summary["missing"] == {"MuJoCo": "not installed (pip install -e '.[bench]')"}
    assert [r["engine"] for r in rows] == ["reference", "MuJoCo"] and rows[1]["CPU (s)"] == "-"


def test_mujoco_builds_the_same_disk():
    bench = _load()
    if bench.mujoco_missing():
        pytest.skip(f"MuJoCo: {bench.mujoco_missing()}")
    case = bench.make_case("disk", t_end=0.25)
    centre, force, cpu = bench.run_mujoco(case, 1.0 / 1200.0)
    assert centre.shape == (16, 3) and force.shape == (16,) and cpu >= 0.0
    np.testing.assert_allclose(centre[0], case.position[0], atol=1e-12)  # the same initial state
    assert bench.position_error(centre, case) < 1e-2  # soft contact: close, not exact
    assert bench.force_error(force, case) < 0.1
    with pytest.raises(ValueError, match="timestep: expected an integer fraction"):
        bench.run_mujoco(case, 1e-3)
