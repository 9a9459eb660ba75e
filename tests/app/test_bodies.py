"""Parts of a System's bodies (app/scenes/_bodies.py): placement from body poses, springs, charts."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigidlab.app.scenes._bodies import SPRING_COILS, Parts, saturating_arrows, spring_polyline
from rigidlab.app.scenes._svg import Chart, nice_ticks


def test_parts_are_placed_with_their_bodies() -> None:
    rng = np.random.default_rng(7)
    m, n = 5, 3
    R = rng.normal(size=(m, n, 3))
    rot = Rotation.random(m * n, random_state=11)
    P = rot.as_quat(scalar_first=True).reshape(m, n, 4)
    A = rot.as_matrix().reshape(m, n, 3, 3)
    parts = Parts.build(
        rods=[(0, (0, 0, -0.5), (0, 0, 0.5), 0.03), (2, (0.1, 0, 0), (0.1, 0.8, 0), 0.02)],
        balls=[(1, (0, 0, 0.4), 0.05), (-1, (1.0, 2.0, 3.0), 0.05)],
        boxes=[(2, (0.1, 0.2, 0.3))],
        springs=[(-1, (0.0, 0.0, 0.0), 1, (0.0, 0.0, 0.4))],
    )
    placed = parts.place(R, P)
    assert placed.n_times == m and parts.counts == (2, 2, 1, 1)
    np.testing.assert_allclose(parts.rod_scales(), [[0.03, 0.03, 1.0], [0.02, 0.02, 0.8]])
    # rod 1: centre at u = (0.1, 0.4, 0) on body 2, unit rod's z along the body's y axis
    np.testing.assert_allclose(placed.rod_positions[:, 1], R[:, 2] + A[:, 2] @ [0.1, 0.4, 0.0], atol=1e-6)
    z_axis = Rotation.from_quat(placed.rod_wxyzs[:, 1].astype(float), scalar_first=True).apply([0, 0, 1])
    np.testing.assert_allclose(z_axis, A[:, 2, :, 1], atol=1e-6)
    np.testing.assert_allclose(placed.rod_wxyzs[:, 0], P[:, 0], atol=1e-7)  # along z: the body's own
    np.testing.assert_allclose(placed.ball_positions[:, 0], R[:, 1] + A[:, 1] @ [0, 0, 0.4], atol=1e-6)
    np.testing.assert_allclose(placed.ball_positions[:, 1], np.broadcast_to([1.0, 2.0, 3.0], (m, 3)))
    np.testing.assert_allclose(placed.box_positions[:, 0], R[:, 2], atol=1e-6)
    # the spring runs from the ground point to body 1's point
    ends = placed.springs[:, 0]
    np.testing.assert_allclose(ends[:, 0, 0], 0.0, atol=1e-7)
    np.testing.assert_allclose(ends[:, -1, 1], placed.ball_positions[:, 0], atol=1e-6)
    assert placed.springs.shape == (m, 1, 2 * SPRING_COILS + 2, 2, 3) and placed.springs.dtype == np.float32
    with pytest.raises(ValueError, match=r"R, P: expected shapes \(m, n, 3\) and \(m, n, 4\)"):
        parts.place(R[0], P[0])


def test_spring_polyline_is_connected_and_keeps_its_ends() -> None:
    a, b = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    seg = spring_polyline(a, b, width=0.05)
    np.testing.assert_allclose(seg[0, 0], a) and np.testing.assert_allclose(seg[-1, 1], b)
    np.testing.assert_allclose(seg[1:, 0], seg[:-1, 1])  # each segment starts where the last ended
    assert np.abs(seg[..., 2]).max() == pytest.approx(0.05)  # zigzag in the plane through z
    zero = spring_polyline(a, a, width=0.05)
    assert np.all(np.isfinite(zero)) and np.abs(zero).max() == 0.0


def test_charts_write_only_finite_numbers_and_round_ticks() -> None:
    assert nice_ticks(0.0, 1000.0) == [0.0, 250.0, 500.0, 750.0, 1000.0]
    assert nice_ticks(-3.3, 3.3, 5) == [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]
    chart = Chart((-1.0, 1.0), (math.nan, math.inf), "x", "y")  # a bad range is replaced
    chart.curve([0.0, 0.5, math.nan, 0.7, 0.9], [0.0, 0.2, 0.3, math.inf, 0.1], "#123456")
    chart.points([math.nan, 0.1], [0.0, 0.2], "#654321")
    svg = chart.svg()
    assert "nan" not in svg.lower() and "inf" not in svg.lower()
    assert svg.count("<polyline") == 1 and svg.count("<circle") == 1


def test_saturating_arrows_point_along_their_vectors_and_never_exceed_the_longest() -> None:
    rng = np.random.default_rng(7)
    starts = rng.normal(size=(6, 3))
    vectors = rng.normal(size=(6, 3)) * np.array([0.0, 1e-3, 1.0, 10.0, 1e3, 1e9])[:, None]
    arrows = saturating_arrows(starts, vectors, half=10.0, longest=0.9)
    assert arrows.shape == (6, 2, 3) and arrows.dtype == np.float32
    np.testing.assert_allclose(arrows[:, 0], starts, rtol=1e-6)
    d = arrows[:, 1].astype(float) - starts
    norms = np.linalg.norm(vectors, axis=1)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 0.9 * norms / (norms + 10.0), rtol=1e-5, atol=1e-6)
    assert np.all(np.linalg.norm(d, axis=1) < 0.9 + 1e-6)
    # the arrow of a vector of size `half` is half the longest, along the vector
    one = saturating_arrows(np.zeros((1, 3)), np.array([[0.0, 0.0, 10.0]]), half=10.0, longest=0.9)
    np.testing.assert_allclose(one[0, 1], [0.0, 0.0, 0.45], rtol=1e-6)


def test_add_body_meshes_puts_every_mesh_under_one_frame(server) -> None:
    import trimesh

    from rigidlab.app.scenes._bodies import add_body_meshes

    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    frame = add_body_meshes(server.scene, "/bodies_test/ghost", [(box, (10, 20, 30)), ((box.vertices, box.faces),
                                                                                    (40, 50, 60))],
                            opacity=0.4, position=(1.0, 0.0, 0.0), visible=False)
    assert not frame.visible and np.allclose(frame.position, (1.0, 0.0, 0.0))
    frame.remove()
