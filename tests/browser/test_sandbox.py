"""Rotation sandbox in headless Chromium: an Euler-angle slider moved from the
page turns the body on the server and in the rendered image, and a number
typed in scientific notation reaches the scene unchanged."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from rigidlab.app.panel import TEXT_RESTORE_SECONDS
from tests.browser._page import field, settled_view, view_changed_from
from tests.helpers import send_value, wait_until


def test_euler_slider_from_page_turns_body(running_app: Any, open_page: Any) -> None:
    app = running_app(scene="sandbox")
    page = open_page(app)
    scene = app.scene_for()
    client = app.server.get_clients()[page.rigidlab_client_id]

    # The first slider of the page is the sandbox's first Euler angle (phi, ZXZ).
    thumb = page.get_by_role("slider").first
    assert wait_until(lambda: thumb.get_attribute("aria-valuenow") == "30")
    assert scene.controls.handles["euler1"].label.startswith("\u03c6")

    # Render from one fixed camera before and after, so that only the scene
    # can make the images differ (arrow keys would also orbit the camera).
    camera = dict(wxyz=client.camera.wxyz.copy(), position=client.camera.position.copy(), fov=client.camera.fov)

    def render(_page: Any) -> np.ndarray:
        return client.get_render(375, 600, **camera, transport_format="png", timeout=120)[..., :3] / 255.0

    before = settled_view(page, render)
    pose_before = np.array(scene.body.frame.wxyz)

    thumb.focus()
    page.keyboard.press("Home")  # slider minimum: phi = -180 deg
    assert wait_until(lambda: scene.controls.value("euler1") == -180.0)
    expected = Rotation.from_euler("ZXZ", [-180.0, 40.0, 20.0], degrees=True).as_quat(scalar_first=True)
    # q and -q are one rotation; 1e-9 covers float64 rounding of a few products.
    assert wait_until(
        lambda: min(np.abs(scene.body.frame.wxyz - expected).max(),
                    np.abs(scene.body.frame.wxyz + expected).max()) < 1e-9
    )
    assert not np.allclose(scene.body.frame.wxyz, pose_before)

    # Half a turn of the body and of the gimbal's outer ring moves thousands
    # of pixels (0.5 % of the render: 1125) by more than 30 of 255; a frozen or blank render changes none.
    view_changed_from(page, before, int(0.005 * 375 * 600), render, tol=30 / 255)


def test_typed_scientific_notation_reaches_the_scene_unchanged(running_app: Any, open_page: Any) -> None:
    app = running_app(scene="sandbox")
    page = open_page(app)
    scene = app.scene_for()
    assert send_value(scene, "input", "Axis and angle")
    assert wait_until(lambda: scene.input == "Axis and angle")
    box = field(page, "Axis")
    box.wait_for(state="visible")
    box.click()
    box.fill("0, 1e-3, 1")  # viser's own number box turned 1e-3 into -13
    box.press("Tab")
    assert wait_until(lambda: scene.controls.value("axis") == (0.0, 1e-3, 1.0), 15.0)
    # past the panel's restore pause, and a loop tick after it: nothing rewrites the text
    typed = time.monotonic()
    assert wait_until(lambda: time.monotonic() - typed > TEXT_RESTORE_SECONDS)
    frames = scene.frames
    assert wait_until(lambda: scene.frames > frames + 1)
    assert box.input_value() == "0, 1e-3, 1"
