"""Browser test of the gyroscope scene: headless Chromium drives the page.

Switch to the gyroscope with the page's scene chooser, click every preset
button in the page, and check that the server applied it (the model's
initial state is the preset's), that the gimbal poses move, and that the
rendered canvas is not blank; then download the CSV from the page and read
it back.
"""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

from rigidlab.app.scenes.gyroscope import CSV_HEADER, PRESETS, GyroscopeScene, preset_inputs
from tests.browser._page import choose_scene, wait_for_drawn_canvas
from tests.helpers import wait_until


@pytest.fixture
def gyro_page(running_app, open_page):
    """The page of an app started on another scene, switched to the gyroscope in the chooser."""
    app = running_app(scene="manipulator")
    page = open_page(app)
    choose_scene(page, GyroscopeScene.title)
    wait_until(lambda: app.scene_for().name == GyroscopeScene.name)
    return app, page, app.scene_for()


def test_gyroscope_presets_from_the_page(gyro_page) -> None:
    _, page, scene = gyro_page
    wait_until(lambda: scene.sim_time > 0.2)

    for name in PRESETS:
        want = preset_inputs(name)
        page.get_by_role("button", name=name, exact=True).click()
        wait_until(lambda: scene.model is not None
                   and math.isclose(scene.model.state0[5], want.psi_dot0, rel_tol=1e-12)
                   and math.isclose(scene.model.state0[1], math.radians(want.theta0_deg), rel_tol=1e-12)
                   and scene.model.torques == (want.m_phi, want.m_theta, want.m_psi))
        wait_until(lambda: scene.sim_time > 0.1)
        pose_before = np.array(scene.rotor_frame.wxyz)
        outer_before = np.array(scene.outer_frame.wxyz)
        # the rotor spins (psi_dot >= 2.6 rad/s in every preset) and the
        # outer gimbal precesses (all presets but the sleeping tops start
        # with phi_dot > 0 or gain it): poses change within half a second
        wait_until(lambda: not np.allclose(scene.rotor_frame.wxyz, pose_before, atol=1e-3), timeout=120.0)
        if not name.startswith("Sleeping"):
            wait_until(lambda: not np.allclose(scene.outer_frame.wxyz, outer_before, atol=1e-4), timeout=120.0)

    # the rings, rotor, base and sphere cover well over 1 % of the view; a
    # blank canvas has ~0
    wait_for_drawn_canvas(page, 0.01)


def test_download_csv_from_the_page(gyro_page) -> None:
    _, page, scene = gyro_page
    wait_until(lambda: scene.sim_time > 1.0)
    button = page.get_by_role("button", name="Download CSV", exact=True)
    button.scroll_into_view_if_needed()
    # one click saves the file (the layer sends downloads with save_immediately)
    with page.expect_download(timeout=20_000) as info:
        button.click()
    download = info.value
    assert download.suggested_filename == "gyroscope.csv"
    rows = list(csv.reader(io.StringIO(open(download.path(), encoding="utf-8").read())))
    assert ",".join(rows[0]) == CSV_HEADER
    data = np.array(rows[1:], dtype=float)
    assert data.shape[1] == 10 and data.shape[0] > 100
    assert np.all(np.diff(data[:, 0]) > 0)
    assert data[0, 0] >= 0.0 and data[-1, 0] - data[0, 0] <= scene.window + 1e-9  # the plotted window
    # d1 = I3 * 12 rad/s for the default rotor, conserved
    np.testing.assert_allclose(data[:, 7], 0.8 * 12.0, rtol=1e-12)
