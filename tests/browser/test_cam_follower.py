"""Browser test of the cam-follower scene: headless Chromium drives the page.

Open the page of an app showing the cam-follower; stop the cam with
the page's Pause button; pick the roller in the *Follower* dropdown and move the
*Roller radius* slider from the keyboard: the follower rises by the change of
radius (its pose is the closed form) and the lift plot changes; then move
the *Cam speed* slider past the jump speed: the force plot shows the
separation interval and the rendered view changes.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigidlab.app.scenes.cam_follower import (
    ECCENTRIC_RADIUS,
    ECCENTRICITY,
    FOLLOWERS,
    CamFollowerScene,
)
from tests.browser._page import settled_view, view_changed_from, wait_for_drawn_canvas
from tests.helpers import wait_until

_CLICK_MS = 120_000


def _row(page, label: str):
    """The GUI row labelled ``label``."""
    return page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )


def test_sliders_from_the_page_move_the_follower_and_change_the_plots(running_app, open_page) -> None:
    app = running_app(scene=CamFollowerScene.name, run_unwatched=False)
    page = open_page(app)
    scene = app.scene_for()
    assert isinstance(scene, CamFollowerScene)
    wait_until(lambda: scene.revolution is not None and scene.frames > 10, timeout=60.0)

    # stop the cam from the page: the pose then changes only when a control does
    # (generous timeouts: the software renderer of a loaded machine can take seconds per frame)
    page.get_by_role("button", name="Pause", exact=True).click(timeout=_CLICK_MS)
    wait_until(lambda: not scene.playing)

    # the roller, chosen in the page's dropdown
    _row(page, "Follower").locator("input.mantine-Select-input").first.click(timeout=_CLICK_MS)
    page.get_by_role("option", name=FOLLOWERS[1], exact=True).click(timeout=_CLICK_MS)
    wait_until(lambda: scene.revolution.inputs.follower == FOLLOWERS[1] and scene.mechanism.roller_mesh.visible,
               timeout=120.0)
    wait_until(lambda: not scene.controls.handles["roller_mm"].disabled)
    frames = scene.frames
    wait_until(lambda: scene.frames > frames + 1)  # a loop tick after the roller is drawn
    z_before = float(scene.mechanism.follower_frame.position[2])
    theta = scene.cam_angle
    lift_before = np.array(scene.plot_handles["lift"].data[1])
    view_before = settled_view(page)

    thumb = _row(page, "Roller radius (mm)").get_by_role("slider").first
    wait_until(lambda: thumb.get_attribute("aria-disabled") != "true")
    thumb.focus()
    page.keyboard.press("End")  # the slider's maximum: 40 mm
    wait_until(lambda: scene.controls.value("roller_mm") == 40.0)
    wait_until(lambda: scene.revolution.inputs.roller_mm == 40.0
               and not np.array_equal(np.asarray(scene.plot_handles["lift"].data[1]), lift_before), timeout=120.0)
    wait_until(lambda: float(scene.mechanism.follower_frame.position[2]) != z_before)
    assert scene.cam_angle == theta  # the cam stands still
    # the roller's centre: the slider-crank of crank e and rod R + r (closed form), 30 mm higher pitch
    r, R, e = 0.04, ECCENTRIC_RADIUS, ECCENTRICITY
    lift = np.sqrt((R + r) ** 2 - (e * np.sin(theta)) ** 2) - e * np.cos(theta) - (R + r - e)
    assert float(scene.mechanism.follower_frame.position[2]) == pytest.approx(R + r - e + lift, abs=1e-14)
    view_changed_from(page, view_before, 300)

    # the cam speed past the jump speed: the force plot shades the separation interval
    force_before = np.array(scene.plot_handles["force"].data[1])
    speed = _row(page, "Cam speed (rpm)").get_by_role("slider").first
    speed.focus()
    page.keyboard.press("End")  # 3000 rpm
    wait_until(lambda: scene.revolution.inputs.rpm == 3000.0 and scene.mechanism.separation_arc.visible, timeout=120.0)
    wait_until(lambda: np.any(np.asarray(scene.plot_handles["force"].data[4]) < 0.0))
    assert not np.array_equal(np.asarray(scene.plot_handles["force"].data[1]), force_before)
    wait_until(lambda: "Separation" in scene.info.content)
    page.get_by_text("the cam turns at 3000 rpm", exact=False).first.wait_for(state="visible")
    wait_for_drawn_canvas(page)
