"""Browser test of the rolling disk scene: headless Chromium drives the page.

Switch to the rolling disk with the page's scene chooser; move the *Lean*
slider from the keyboard and check that the server restarts the disk at the
new lean (its pose and the lean plot) and that the 3-D view changes; click a
preset in the page and check that the contact dropdown follows it and that
the plots are on the page.
"""

from __future__ import annotations

import math

import numpy as np

from rigidlab.app.scenes.rolling_disk import SLIDING, RollingDiskScene
from rigidlab.core.rotations import matrix_from_euler_parameters
from tests.browser._page import settled_view, view_changed_from, wait_for_drawn_canvas
from tests.helpers import wait_until


def _slider_thumb(page, label: str):
    """The thumb (role=slider) of the GUI slider labelled ``label``."""
    row = page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )
    return row.get_by_role("slider").first


def _started(scene, lean_deg: float) -> bool:
    """The model in use has ``lean_deg`` and its first chunk is drawn."""
    return (scene.model is not None and math.isclose(scene.model.lean, math.radians(lean_deg), abs_tol=1e-12)
            and scene.drawn_model == scene.model)


def test_lean_slider_from_the_page_changes_the_pose_and_the_plot(scene_page) -> None:
    _, page, scene = scene_page(RollingDiskScene)
    wait_until(lambda: _started(scene, 10.0) and scene.sim_time > 0.2, timeout=60.0)
    # paused, a new model is drawn at t = 0: the pose is the initial one
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
    paused_at = scene.sim_time
    wait_until(lambda: scene.plot_handles["lean"].data[0].size > 2
               and 0.0 <= paused_at - scene.plot_handles["lean"].data[0][-1] < 0.1,
               timeout=120.0)
    t_plot, lean_plot = scene.plot_handles["lean"].data
    if paused_at <= scene.window:  # the plot still starts at t = 0, at the slider's lean
        assert t_plot[0] == 0.0 and math.isclose(float(lean_plot[0]), 10.0, abs_tol=1e-9)
    else:  # a slow machine played past the window: it spans one window back from its last sample
        # (the window was taken at the last refresh, up to a refresh period before the pause; its first
        # and last samples are each within a sample spacing of its ends)
        assert 0.0 <= t_plot[0] - (t_plot[-1] - scene.window) < 0.2
    thumb = _slider_thumb(page, "Lean (deg)")
    wait_until(lambda: thumb.get_attribute("aria-valuenow") == "10")
    before = settled_view(page)  # the paused disk, drawn

    thumb.focus()
    page.keyboard.press("End")  # the slider's maximum: 60 deg
    wait_until(lambda: scene.controls.value("lean_deg") == 60.0)
    wait_until(lambda: _started(scene, 60.0), timeout=60.0)
    assert scene.sim_time == 0.0
    # the disk's axis (body y) rises by the lean: A[2, 1] = sin(60 deg)
    wait_until(lambda: abs(matrix_from_euler_parameters(np.array(scene.disk.wxyz))[2, 1]
                           - math.sin(math.radians(60.0))) < 1e-6, timeout=120.0)
    np.testing.assert_allclose(np.array(scene.disk.position)[2], 0.1 * math.cos(math.radians(60.0)), atol=1e-6)
    # the lean plot starts again, at the new lean
    wait_until(lambda: math.isclose(float(scene.plot_handles["lean"].data[1][0]), 60.0, abs_tol=1e-9), timeout=120.0)
    assert scene.plot_handles["lean"].data[0][-1] == 0.0
    view_changed_from(page, before, 300)

    # playing again, the lean plot grows from t = 0
    page.get_by_role("button", name="Play", exact=True).click()
    wait_until(lambda: scene.playing and scene.sim_time > 0.3, timeout=60.0)
    wait_until(lambda: scene.plot_handles["lean"].data[0][-1] > 0.2, timeout=120.0)
    wait_for_drawn_canvas(page)


def test_preset_and_contact_from_the_page(running_app, open_page) -> None:
    app = running_app(scene=RollingDiskScene.name)  # opened on the scene (the chooser is tested above)
    page = open_page(app)
    scene = app.scene_for()
    wait_until(lambda: _started(scene, 10.0), timeout=60.0)
    page.get_by_role("button", name="Sliding coin", exact=True).click()
    wait_until(lambda: scene.model is not None and not scene.model.rolling and scene.model.spin == 15.0,
               timeout=120.0)
    # the dropdown shows the preset's contact model
    select = page.locator("label:text-is('Contact')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    ).locator("input").first
    wait_until(lambda: select.input_value() == SLIDING, timeout=120.0)
    # the sliding disk's critical spin is sqrt(g / R)
    wait_until(lambda: "√(g / R)" in scene.info.content)
    wait_until(lambda: scene.drawn_model == scene.model and scene.sim_time > 0.2, timeout=60.0)
    title = page.locator(".u-title", has_text="normal force N").first
    title.scroll_into_view_if_needed()
    title.wait_for(state="visible", timeout=30_000)
