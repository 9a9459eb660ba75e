"""Rotation sandbox in headless Chromium: an Euler-angle slider moved from the
page turns the body on the server and in the rendered image."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from tests.helpers import wait_until


def test_euler_slider_from_page_turns_body(running_app: Any, open_page: Any) -> None:
    app = running_app(scene="sandbox")
    page = open_page(app)
    scene = app.scene_for()
    client = app.server.get_clients()[page.rigidlab_client_id]

    # The first slider of the page is the sandbox's first Euler angle (phi, ZXZ).
    thumb = page.get_by_role("slider").first
    assert wait_until(lambda: thumb.get_attribute("aria-valuenow") == "30")
    assert scene.euler_sliders[0].label.startswith("\u03c6")

    # Render from one fixed camera before and after, so that only the scene
    # can make the images differ (arrow keys would also orbit the camera).
    camera = dict(wxyz=client.camera.wxyz.copy(), position=client.camera.position.copy(), fov=client.camera.fov)
    page.wait_for_timeout(500)
    before = client.get_render(375, 600, **camera, transport_format="png", timeout=30)
    pose_before = np.array(scene.body_frame.wxyz)

    thumb.focus()
    page.keyboard.press("Home")  # slider minimum: phi = -180 deg
    assert wait_until(lambda: scene.euler_sliders[0].value == -180.0)
    expected = Rotation.from_euler("ZXZ", [-180.0, 40.0, 20.0], degrees=True).as_quat(scalar_first=True)
    # q and -q are one rotation; 1e-9 covers float64 rounding of a few products.
    assert wait_until(
        lambda: min(np.abs(scene.body_frame.wxyz - expected).max(), np.abs(scene.body_frame.wxyz + expected).max()) < 1e-9
    )
    assert not np.allclose(scene.body_frame.wxyz, pose_before)

    page.wait_for_timeout(500)
    after = client.get_render(375, 600, **camera, transport_format="png", timeout=30)
    assert before.shape == after.shape
    changed = np.any(np.abs(after[..., :3].astype(int) - before[..., :3].astype(int)) > 30, axis=-1)
    # Half a turn of the body and of the gimbal's outer ring moves thousands
    # of pixels; a frozen or blank render changes none.
    assert changed.mean() > 0.005, f"only {changed.mean():.3%} of the pixels changed"
