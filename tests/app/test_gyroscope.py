"""Gyroscope scene (app/scenes/gyroscope.py) on a running rigidlab app.

The session loop drives the scene at about 60 Hz; tests act as a user would
(presets, sliders, play/pause/reset through the server-side handles) and
check what the scene streams: the three nested gimbal poses against scipy's
ZXZ rotation, presets against core.gyroscope's predictions, notices for bad
input, and the chunk cache.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from app.scenes.gyroscope import PRESETS, GyroscopeScene, Inputs, preset_inputs
from core.gyroscope import RotorParams, nutation, steady_precession_rates
from tests.helpers import wait_until


@pytest.fixture
def gyro(running_scene):
    return running_scene(GyroscopeScene)


def test_scene_is_registered_after_the_others():
    from app.scenes import discover_scenes

    scenes = discover_scenes()
    assert "gyroscope" in scenes
    assert GyroscopeScene.order == 40
    assert list(scenes).index("gyroscope") == len([s for s in scenes.values() if s.order <= 40]) - 1


def test_nested_frames_compose_to_the_zxz_orientation(gyro):
    app, scene = gyro
    with app.session_for().run_lock:  # freeze the loop between the reads
        angles = scene.angles.copy()
        q = [np.array(f.wxyz) for f in (scene.outer_frame, scene.inner_frame, scene.rotor_frame)]
    composed = Rotation.from_quat(q[0], scalar_first=True) * Rotation.from_quat(q[1], scalar_first=True) \
        * Rotation.from_quat(q[2], scalar_first=True)
    expected = Rotation.from_euler("ZXZ", angles)
    # float64 quaternions of single-axis rotations: round-off only
    np.testing.assert_allclose(composed.as_matrix(), expected.as_matrix(), atol=1e-12)
    # each frame turns about its own axis only
    np.testing.assert_allclose(Rotation.from_quat(q[0], scalar_first=True).as_rotvec()[:2], 0, atol=1e-12)
    np.testing.assert_allclose(Rotation.from_quat(q[1], scalar_first=True).as_rotvec()[1:], 0, atol=1e-12)
    np.testing.assert_allclose(Rotation.from_quat(q[2], scalar_first=True).as_rotvec()[:2], 0, atol=1e-12)


def test_presets_drive_the_expected_motion(gyro):
    app, scene = gyro
    for name in PRESETS:
        scene.apply_preset(name)
        want = preset_inputs(name)
        wait_until(lambda: scene.model is not None and scene.model.params.mgl == want.mgl
                   and math.isclose(scene.model.state0[5], want.psi_dot0) and 0.2 < scene.sim_time)
        for field, slider in scene.gui.sliders.items():
            # the page's sliders show the preset (they round to their step)
            assert slider.value == pytest.approx(getattr(want, field), abs=slider.step)
        params, state0 = scene.model.params, scene.model.state0
        thetas = []
        t_end = time.monotonic() + 1.0
        while time.monotonic() < t_end:
            thetas.append(scene.angles[1])
            time.sleep(0.02)
        thetas = np.array(thetas)
        if name.startswith("Steady"):
            # steady precession: theta stays put (closed form or DOP853 at 1e-9)
            np.testing.assert_allclose(thetas, state0[1], atol=1e-6)
        elif name.startswith("Sleeping top above"):
            assert thetas.max() < 3 * state0[1]
        else:
            nu = nutation(params, state0)
            # the displayed theta stays inside the predicted bounds (linear
            # interpolation between samples cannot leave them)
            assert thetas.min() >= float(nu.theta_min) - 1e-9
            assert thetas.max() <= float(nu.theta_max) + 1e-9
    # the gravity preset really uses the slow steady rate
    want = preset_inputs(PRESETS[1])
    slow = steady_precession_rates(RotorParams(I=1.0, I3=0.8, mgl=2.0), math.radians(60), 15.0).slow
    assert want.phi_dot0 == pytest.approx(float(slow), rel=1e-12)
    with pytest.raises(ValueError, match=r"name: expected one of \["):
        scene.apply_preset("no such preset")


def test_sleeping_top_below_critical_falls(gyro):
    app, scene = gyro
    scene.gui.time_scale.value = 4.0
    scene.apply_preset("Sleeping top below critical")
    wait_until(lambda: scene.model.state0[1] == pytest.approx(math.radians(3.0)) and scene.sim_time > 0.0)
    nu = nutation(scene.model.params, scene.model.state0)
    assert float(nu.theta_max) > math.radians(30)
    wait_until(lambda: scene.angles[1] > math.radians(20), timeout=20.0)


def test_invalid_parameters_give_a_notice_and_keep_running(gyro):
    app, scene = gyro
    params_before = scene.model.params
    scene.gui.sliders["I3"].value = 3.0  # > 2 I with I = 1
    session = app.session_for()
    wait_until(lambda: any("Invalid rotor parameters" in n[0] for n in session.notices))
    assert any("I3: expected I3 <= 2*I" in n[1] for n in session.notices)
    assert scene.model.params == params_before
    t0 = scene.sim_time
    wait_until(lambda: scene.sim_time > t0 + 0.1)
    # The slider shows the value in use again, and the motion was not restarted.
    wait_until(lambda: scene.gui.sliders["I3"].value == params_before.I3)
    assert scene.sim_time > t0
    assert any("the sliders are set back" in n[1] for n in session.notices)
    # A valid change afterwards is taken as usual.
    scene.gui.sliders["I3"].value = 1.5
    wait_until(lambda: scene.model.params.I3 == 1.5)
    assert scene.gui.sliders["I3"].value == 1.5


def test_pause_reset_and_chunk_cache(gyro):
    app, scene = gyro
    scene.gui.pause.value = True  # a click, as the page sends it
    wait_until(lambda: not scene.playing)
    time.sleep(0.1)
    t_paused = scene.sim_time
    time.sleep(0.3)
    assert scene.sim_time == t_paused
    scene.gui.play.value = True
    wait_until(lambda: scene.playing)
    scene.gui.time_scale.value = 4.0
    wait_until(lambda: scene.sim_time > 5.0, timeout=20.0)
    computed = scene.chunks_computed
    scene.gui.reset.value = True
    wait_until(lambda: scene.sim_time < 1.0)
    wait_until(lambda: scene.sim_time > 3.0)
    # parameters unchanged: the replay reads the cached chunks
    assert scene.chunks_computed <= computed + 1
    # a slider change drops the cache and restarts
    scene.gui.sliders["psi_dot0"].value = 20.0
    wait_until(lambda: scene.model.state0[5] == 20.0)
    assert scene.sim_time < 2.0


def test_torque_sliders_use_the_numerical_path(gyro):
    app, scene = gyro
    scene.gui.sliders["m_psi"].value = 1.0
    wait_until(lambda: scene.model.torques[2] == 1.0 and scene.sim_time > 1.0)
    traj = scene._chunks[0]
    assert traj.method == "numerical"
    # M_psi spins the rotor up: psi_dot grows at M_psi / I3 (Eq. 8.16, d1' = M_psi)
    assert scene.rates[2] > scene.model.state0[5]


def test_preset_inputs_rejects_unknown_names():
    with pytest.raises(ValueError, match=r"name: expected one of \['Steady precession"):
        preset_inputs("Spinning plate")


def test_per_client_sessions_are_isolated(per_client_scenes):
    _, [(_, a), (_, b)] = per_client_scenes(GyroscopeScene)
    wait_until(lambda: a.model is not None and b.model is not None)
    a.apply_preset("Cuspidal motion")
    wait_until(lambda: a.model.state0[5] == preset_inputs("Cuspidal motion").psi_dot0)
    time.sleep(0.2)
    assert b.model.state0[5] == Inputs().psi_dot0  # the default, untouched


def test_framing_shows_the_suspension_large_and_left_of_the_gui_panel():
    """Project the suspension with viser's camera model (75 deg vertical fov).

    The GUI panel covers about the right third of a 1200 x 750 page, so the
    suspension's centre must project into the left two thirds, and it must
    fill a good part of the height, seen from above (elevated 3/4 view).
    """
    from app.scenes import gyroscope as g

    eye = np.array(GyroscopeScene.camera_position, dtype=float)
    target = np.array(GyroscopeScene.camera_look_at, dtype=float)
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_half = math.tan(math.radians(75.0) / 2)  # viser's default vertical fov
    aspect = 1200 / 750

    def ndc(point):
        rel = np.asarray(point, dtype=float) - eye
        depth = rel @ forward
        return rel @ right / (depth * tan_half * aspect), rel @ up / (depth * tan_half)

    centre = np.array([0.0, 0.0, 0.5 * (g._BASE_Z + g._TIP_RADIUS)])
    x, y = ndc(centre)
    assert -0.9 < x < 1 / 3 - 0.25  # centred in the free part, clear of the panel
    assert abs(y) < 0.5
    top = ndc([0.0, 0.0, g._TIP_RADIUS])[1]
    bottom = ndc([0.0, 0.0, g._BASE_Z])[1]
    assert 0.8 < top - bottom < 1.9  # 40-95 % of the page height
    assert eye[2] > centre[2] + 1.0  # seen from above
    assert abs(eye[0]) > 0.5 and abs(eye[1]) > 0.5  # 3/4 view, not head-on


@pytest.mark.parametrize("name", PRESETS)
def test_preset_values_fit_their_sliders(name: str) -> None:
    # A preset the page cannot show (outside a slider's range) would jump as
    # soon as someone touches that slider; every value must lie in its range.
    from app.scenes.gyroscope import _SLIDERS

    values = preset_inputs(name)
    for field, label, lo, hi, _step, _hint in _SLIDERS:
        value = getattr(values, field)
        assert lo <= value <= hi, f"{name}: {label} = {value} outside [{lo}, {hi}]"


def test_plots_use_seconds_and_a_readable_log_drift(gyro):
    """The plots' x axis is simulated time in seconds (uPlot would show
    calendar dates by default) and the drift plot is log10 |drift|: round-off
    drifts ~1e-15 printed as '0' on a linear axis."""
    from app.scenes.gyroscope import DRIFT_FLOOR_LOG10, drift_log10

    app, scene = gyro
    for plot in (scene.gui.plot_theta, scene.gui.plot_phi_dot, scene.gui.plot_drift):
        assert plot.scales["x"]["time"] is False
    wait_until(lambda: scene.sim_time > 1.0)
    wait_until(lambda: scene.gui.plot_drift.data[0].size > 5)
    t, *drift = scene.gui.plot_drift.data
    drift = np.array(drift)
    assert np.all(np.isfinite(drift))
    assert np.all(drift >= DRIFT_FLOOR_LOG10)
    # Closed-form motion without torques: drifts are round-off of O(1) invariants.
    assert np.all(drift < -10.0)
    # The transform itself: exact zeros floor, others are log10 |x|.
    np.testing.assert_array_equal(
        drift_log10(np.array([0.0, -1e-15, 2.0, 1e-30])), [DRIFT_FLOOR_LOG10, -15.0, math.log10(2.0), DRIFT_FLOOR_LOG10]
    )
