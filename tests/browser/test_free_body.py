"""Browser test of the free-body scene: headless Chromium drives the page.

Switch to the scene with the page's scene chooser, click the Dzhanibekov
preset button in the page, and check that the server applied it (the
initial omega is the preset's), that the body's pose moves, and that the
rendered canvas is not blank; choose a ghost integrator in the page's
dropdown; download the CSV from the page and read it back.
"""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from rigidlab.app.scenes.free_body import (
    CSV_HEADER_GHOST,
    PRESETS,
    FreeBodyScene,
    body_mesh,
    preset_omega,
)
from tests.browser._page import choose_scene, wait_for_drawn_canvas
from tests.helpers import wait_until


@pytest.fixture
def free_page(running_app, open_page):
    """The page of an app started on another scene, switched to the free body in the chooser."""
    app = running_app(scene="manipulator")
    page = open_page(app)
    choose_scene(page, FreeBodyScene.title)
    wait_until(lambda: app.scene_for().name == FreeBodyScene.name)
    return app, page, app.scene_for()


def test_free_body_preset_from_the_page(free_page) -> None:
    _, page, scene = free_page
    wait_until(lambda: scene.sim_time > 0.2)

    # start from the stable major-axis spin, then click the flip preset
    scene.apply_preset(PRESETS[0])
    _, _, inertia = body_mesh(scene.inputs.body)
    wait_until(lambda: scene.setup is not None and np.allclose(scene.setup.omega_body0, preset_omega(PRESETS[0], inertia)))
    page.get_by_role("button", name=PRESETS[2], exact=True).click()
    want = preset_omega(PRESETS[2], inertia)
    wait_until(lambda: np.allclose(scene.setup.omega_body0, want) and scene.sim_time > 0.1)
    pose_before = np.array(scene.exact_frame.wxyz)
    # spinning at 6 rad/s: the pose changes within a fraction of a second
    wait_until(lambda: not np.allclose(scene.exact_frame.wxyz, pose_before, atol=1e-2), timeout=120.0)

    # the bodies, sphere and frames cover well over 1 % of the view; blank ~0
    wait_for_drawn_canvas(page, 0.01)


def test_ghost_method_and_csv_from_the_page(free_page) -> None:
    _, page, scene = free_page
    wait_until(lambda: scene.sim_time > 0.2)
    # the Method dropdown (a Mantine Select) of the ghost integrator
    method = page.locator("input.mantine-Select-input:visible").nth(2)
    method.scroll_into_view_if_needed()
    method.click()
    page.get_by_role("option", name="RK45", exact=True).click()
    wait_until(lambda: scene.config.method == "RK45" and scene.ghost_error.get("t", 0.0) > 0.5)
    button = page.get_by_role("button", name="Download CSV", exact=True)
    button.scroll_into_view_if_needed()
    # one click saves the file (the layer sends downloads with save_immediately)
    with page.expect_download(timeout=20_000) as info:
        button.click()
    download = info.value
    assert download.suggested_filename == "free_body.csv"
    rows = list(csv.reader(io.StringIO(open(download.path(), encoding="utf-8").read())))
    assert ",".join(rows[0]) == CSV_HEADER_GHOST
    data = np.array(rows[1:], dtype=float)
    assert data.shape[1] == 20 and data.shape[0] > 20
    # |p| of the exact body is 1 to round-off; the ghost's angle error is small
    np.testing.assert_allclose(np.linalg.norm(data[:, 1:5], axis=1), 1.0, atol=1e-14)
    assert np.all(data[:, 19] < 1e-3)
