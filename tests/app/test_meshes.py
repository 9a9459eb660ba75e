"""Meshes of app/meshes.py: where their origins and axes are, as their docstrings say."""

from __future__ import annotations

import numpy as np
import pytest

from app.meshes import pedestal, spinning_top


@pytest.mark.parametrize("depth", [0.2, 0.5])
def test_spinning_top_runs_from_its_fixed_point_to_its_tip_about_z(depth: float) -> None:
    parts = spinning_top(depth, disc_radius=0.3, tip=0.6)
    vertices, faces = parts["body"]
    assert vertices.dtype == np.float32 and faces.dtype == np.uint32 and faces.max() < len(vertices)
    assert vertices[:, 2].min() == pytest.approx(-depth, abs=1e-6)  # the axle starts at the fixed point
    assert vertices[:, 2].max() == pytest.approx(0.645, abs=1e-6)  # the knob (radius 0.045) on the tip
    r = np.hypot(vertices[:, 0], vertices[:, 1])
    assert r.max() == pytest.approx(0.3, rel=1e-6)  # the disc's rim
    marker, _ = parts["marker"]
    assert np.hypot(marker[:, 0], marker[:, 1]).max() <= 0.3 + 0.04 and marker[:, 0].min() > 0.0  # on the rim


def test_pedestal_stands_on_the_ground_below_its_pivot() -> None:
    vertices, faces = pedestal(1.1, radius=0.25)
    assert vertices[:, 2].min() == pytest.approx(-1.1, abs=1e-6)
    assert vertices[:, 2].max() == pytest.approx(-0.05, abs=1e-6)
    assert np.hypot(vertices[:, 0], vertices[:, 1]).max() == pytest.approx(0.25, rel=1e-6)
    assert faces.max() < len(vertices)
