"""Free-body scene (app/scenes/free_body.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz; the tests act through the
server-side handles as a user would (presets, dropdowns, sliders, reset) and
check what the scene streams: the body's pose against core's exact solution
at the displayed time, the Dzhanibekov flip and the stable spins, the ghost
integrator's error and cache, and a notice when the ghost integrator fails.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from app.scenes.free_body import BODIES, PRESETS, FreeBodyScene, body_mesh, preset_omega
from core.rigid_body import free_body_exact, principal_axes, rotation_angle_between
from core.rotations import matrix_from_euler_parameters
from tests.helpers import wait_until


def locked(app, predicate):
    """``predicate`` evaluated while the session loop is held (consistent reads)."""

    def check():
        with app.session_for().run_lock:
            return predicate()

    return check


@pytest.fixture
def free(running_scene):
    return running_scene(FreeBodyScene)


def test_scene_is_registered_between_manipulator_and_gyroscope():
    from app.scenes import discover_scenes

    names = list(discover_scenes())
    assert FreeBodyScene.order == 30 and "free_body" in names
    assert all(discover_scenes()[n].order <= 30 for n in names[: names.index("free_body")])


def test_pose_is_the_exact_solution_at_the_displayed_time(free):
    app, scene = free
    with app.session_for().run_lock:  # freeze the loop between the reads
        t = scene.display_time
        wxyz = np.array(scene.exact_frame.wxyz)
        ghost = np.array(scene.ghost_frame.wxyz)
        inputs = scene.inputs
        assert scene.sim_time - 1 / 60 - 1e-9 <= t <= scene.sim_time  # one ghost sample behind at most
    _, _, inertia = body_mesh(inputs.body)
    w0 = [inputs.omega_x, inputs.omega_y, inputs.omega_z]
    expected = free_body_exact(inertia, w0, [1, 0, 0, 0], t).p
    # the scene passes core's Euler parameters straight to wxyz: round-off only
    assert rotation_angle_between(wxyz, expected) < 1e-12
    # the default ghost (splitting, dt = 0.01) is drawn at the same instant;
    # its error in the first seconds is ~1e-4 rad (O(dt^2)), far below the
    # ~0.1 rad a frame of lag at 6 rad/s would show
    assert rotation_angle_between(wxyz, ghost) < 1e-3


def _axis_alignment(scene, app, axis_index, seconds):
    """cos of the angle between a principal axis (global frame) and L, sampled."""
    _, _, inertia = body_mesh(scene.inputs.body)
    _, Q = principal_axes(inertia)
    axis_body = Q[:, axis_index]
    values = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        with app.session_for().run_lock:
            p, w = np.array(scene.exact_frame.wxyz), scene.omega_exact.copy()
        A = matrix_from_euler_parameters(p)
        L = A @ (inertia @ w)
        values.append(float((A @ axis_body) @ L / np.linalg.norm(L)))
        time.sleep(0.03)
    return np.array(values)


def test_presets_flip_or_spin_stably(free):
    app, scene = free
    scene.gui.time_scale.value = 4.0
    _, _, inertia = body_mesh(BODIES[0])
    for name, axis in zip(PRESETS, (2, 0, 1), strict=True):
        scene.apply_preset(name)
        want = preset_omega(name, inertia)
        wait_until(lambda: np.allclose(scene.setup.omega_body0, want) and 0.1 < scene.sim_time < 1.0)
        # the page's sliders show the preset
        assert [scene.gui.sliders[k].value for k in ("omega_x", "omega_y", "omega_z")] == pytest.approx(want)
        cosines = _axis_alignment(scene, app, axis, 2.0)  # >= 8 s of simulated time
        if axis == 1:
            # intermediate axis: it starts along L (cos ~ 1) and turns over
            # (the flip takes ~2.3 s of simulated time with a 2 % offset)
            assert cosines.max() > 0.99 and cosines.min() < -0.9
        else:
            # major or minor axis: a 2 % offset keeps the axis within ~2 deg of L
            assert cosines.min() > 0.99


def test_ghost_integrators_error_and_cache(free):
    app, scene = free
    scene.gui.method.value = "DOP853"
    scene.gui.rtol_exp.value = -12.0
    wait_until(locked(app, lambda: scene.setup.inputs.method == "DOP853" and scene.ghost_error.get("t", 0) > 0.5))
    # DOP853 at rtol = 1e-12 over ~1 s: orientation error far below 1e-8
    assert scene.ghost_error["angle"] < 1e-8 and scene.ghost_error["energy"] < 1e-9
    # the splitting keeps |p| = 1 to round-off and |L| exactly; its energy
    # error at dt = 0.05 is O(dt^2) but bounded
    scene.gui.method.value = "splitting"
    scene.gui.dt.value = 0.05
    wait_until(locked(app, lambda: scene.setup.inputs.method == "splitting" and scene.setup.inputs.dt == 0.05
                      and scene.ghost_error.get("t", 0) > 0.5))
    assert scene.ghost_error["p_norm"] < 1e-14 and scene.ghost_error["L"] < 1e-13
    assert 0 < scene.ghost_error["angle"] < 0.1
    with app.session_for().run_lock:
        ghost = np.array(scene.ghost_frame.wxyz)
        assert scene.ghost_frame.visible and np.all(np.isfinite(ghost))
    # reset replays cached chunks: no recomputation while parameters are unchanged
    computed = scene.chunks_computed
    with app.session_for().run_lock:
        t_before = scene.sim_time
    scene.request_reset()
    wait_until(lambda: scene.sim_time < t_before)
    wait_until(lambda: scene.sim_time > 0.3)
    if t_before < 0.9:  # still in the first chunk before the reset: nothing new computed
        assert scene.chunks_computed == computed
    scene.gui.method.value = "none"
    wait_until(lambda: not scene.ghost_frame.visible)


def test_failing_ghost_gives_a_notice_and_the_scene_keeps_running(free):
    app, scene = free
    for key, value in (("omega_x", 10.0), ("omega_y", 10.0), ("omega_z", 10.0)):
        scene.gui.sliders[key].value = value
    scene.gui.dt.value = 0.2
    scene.gui.method.value = "midpoint"  # fixed-point iteration cannot converge at |omega| dt ~ 3.5
    session = app.session_for()
    wait_until(lambda: any("Ghost integrator stopped" in n[0] for n in session.notices))
    assert any("did not converge" in n[1] for n in session.notices)
    t0 = scene.sim_time
    wait_until(lambda: scene.sim_time > t0 + 0.2)  # the exact body keeps moving
    assert not scene.ghost_frame.visible


def test_body_choice_and_polhode(free):
    app, scene = free
    scene.gui.body.value = BODIES[1]
    wait_until(lambda: scene.setup.inputs.body == BODIES[1] and scene.sim_time > 0.5)
    with app.session_for().run_lock:
        assert scene.body_frames[BODIES[1]].visible and not scene.body_frames[BODIES[0]].visible
        pts = np.array(scene.polhode.points)
    # the traced polhode lies on the momentum sphere (radius 0.9 in the picture)
    radii = np.linalg.norm(pts.reshape(-1, 3), axis=1)
    assert np.allclose(radii, 0.9, atol=1e-6)
    with pytest.raises(ValueError, match=r"name: expected one of \["):
        scene.apply_preset("no such preset")
    with pytest.raises(ValueError, match=r"name: expected one of \["):
        body_mesh("no such body")


def test_per_client_sessions_are_isolated(per_client_scenes):
    # Two browsers (plain websocket clients) get their own free-body scene:
    # a preset in one does not touch the other.
    _, [(_, s1), (_, s2)] = per_client_scenes(FreeBodyScene)
    wait_until(lambda: s1.setup is not None and s2.setup is not None and s2.sim_time > 0.1)
    s1.apply_preset(PRESETS[0])
    _, _, inertia = body_mesh(BODIES[0])
    wait_until(lambda: np.allclose(s1.setup.omega_body0, preset_omega(PRESETS[0], inertia)))
    assert np.allclose(s2.setup.omega_body0, [6.0, 0.12, 0.12])  # still the default flip
