"""Meshes of app/meshes.py: where their origins and axes are, as their docstrings say."""

from __future__ import annotations

import numpy as np
import pytest

from rigidlab.app.meshes import pedestal, spinning_top


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


@pytest.mark.parametrize("roller", [0.0, 0.012])
def test_translating_follower_sits_on_its_face_or_roller_and_carries_a_seat(roller: float) -> None:
    from rigidlab.app.meshes import follower_stand, translating_follower

    (vertices, faces), roller_mesh, seat = translating_follower(travel=0.05, face_halfwidth=0.02, roller_radius=roller)
    assert faces.max() < len(vertices) and vertices[:, 2].max() == pytest.approx(seat + 0.05, abs=1e-6)
    if roller:
        r = roller_mesh[0]
        assert np.hypot(r[:, 0], r[:, 2]).max() == pytest.approx(roller, rel=1e-6) and seat > roller
    else:
        assert roller_mesh is None and vertices[:, 2].min() == pytest.approx(0.0, abs=1e-7)
        assert vertices[:, 0].max() == pytest.approx(0.02, abs=1e-7)
    stand, _ = follower_stand(0.1, base=-0.085, arm=0.008)
    assert stand[:, 2].min() == pytest.approx(-0.093, abs=1e-6) and stand[:, 2].max() == pytest.approx(0.108, abs=1e-6)
