"""Shared helpers the bicycle scene brought: readout.mode_table, _svg.Chart.band, meshes.tube/spoked_wheel."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np

from rigidlab.app.meshes import bicycle_meshes, spoked_wheel, tube
from rigidlab.app.readout import markdown_to_html, mode_table
from rigidlab.app.scenes._svg import Chart
from rigidlab.core.models import MEIJAARD_2007


def test_mode_table_rows_times_and_shape_column():
    text = mode_table("**Modes**", [("weave", -0.5 + 4j), ("weave", -0.5 - 4j), ("capsize", 0.25), ("c", 0.0)],
                      shape=("φ : δ", ["1 : 2", "1 : 2", "3 : 4", "5 : 6"]))
    rows = [r for r in text.splitlines() if r.startswith("| ") and "---" not in r]
    assert len(rows) == 4  # header, the weave pair as one row, capsize, c
    assert f"½ in {math.log(2) / 0.5:.2f} s" in rows[1] and f"{4 / (2 * math.pi):.3f}" in rows[1]
    assert f"×2 in {math.log(2) / 0.25:.2f} s" in rows[2] and "3 : 4" in rows[2]
    assert "neutral" in rows[3]
    assert "<table" in markdown_to_html(text)
    assert "φ" not in mode_table("m", [("a", -1.0)])


def test_chart_band_is_clipped_to_the_x_range():
    chart = Chart((0.0, 10.0), (-1.0, 1.0), "x", "y")
    chart.band(-5.0, 5.0, "#dcfce7")
    chart.band(math.nan, 1.0, "#000000")
    chart.band(11.0, 12.0, "#000000")
    svg = chart.svg()
    rects = [e for e in ET.fromstring(svg).iter() if e.tag.endswith("rect") and e.get("fill") == "#dcfce7"]
    assert len(rects) == 1 and "#000000" not in svg
    assert float(rects[0].get("x")) == float(chart.px(0.0)) and math.isclose(
        float(rects[0].get("width")), float(chart.px(5.0) - chart.px(0.0)), abs_tol=0.06)


def test_tube_wheel_and_bicycle_meshes():
    t = tube((0, 0, 0), (0, 0, 2), 0.1)
    np.testing.assert_allclose(t.bounds, [[-0.1, -0.1, 0.0], [0.1, 0.1, 2.0]], atol=1e-9)
    wheel, mark = spoked_wheel(0.3)
    assert abs(wheel.bounds[1, 0] - 0.3) < 1e-9 and abs(wheel.bounds[1, 2] - 0.3) < 1e-9  # in the x-z plane
    assert mark.bounds[1, 0] > 0.25 and abs(mark.bounds[1, 2]) < 0.02  # the marked spoke along +x
    meshes = bicycle_meshes(MEIJAARD_2007)
    assert set(meshes) == {"rear_wheel", "rear_mark", "front_wheel", "front_mark", "frame", "rider", "fork"}
    assert bicycle_meshes(MEIJAARD_2007) is meshes  # built once per process
