"""Browser test of the manipulator scene: headless Chromium drives the page.

Switch to the manipulator with the page's scene chooser, move joint 1's
slider from the keyboard, and check that the link pose changed on the server
(against scipy's Z rotation) and in the rendered screenshot.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from rigidlab.app.scenes.manipulator import ManipulatorScene
from tests.browser._page import settled_view, view_changed_from
from tests.helpers import wait_until


def test_switch_to_manipulator_and_move_joint_slider(scene_page) -> None:
    _, page, scene = scene_page(ManipulatorScene)
    wait_until(lambda: np.allclose(np.degrees(scene.joint_angles), [30.0, 45.0, 60.0]))

    # The first three sliders of the page are the joint sliders (the scene
    # chooser is a dropdown), in order.
    thumb = page.get_by_role("slider").first
    wait_until(lambda: thumb.get_attribute("aria-valuenow") == "30")
    before = settled_view(page)  # the 3-D view once the software renderer has drawn the arm
    pose_before = scene.solid_frames[0].wxyz.copy()

    thumb.focus()
    page.keyboard.press("Home")  # slider minimum: joint 1 at -180 deg
    wait_until(lambda: abs(np.degrees(scene.joint_angles[0]) + 180.0) < 1e-9)
    expected = Rotation.from_euler("Z", -180.0, degrees=True).as_quat(scalar_first=True)
    # q and -q are the same rotation; 1e-12 covers matrix-to-quaternion rounding.
    wait_until(
        lambda: min(
            np.abs(scene.solid_frames[0].wxyz - expected).max(),
            np.abs(scene.solid_frames[0].wxyz + expected).max(),
        )
        < 1e-12
    )
    assert not np.allclose(scene.solid_frames[0].wxyz, pose_before)

    # Turning the arm half a turn moves many pixels of the 3-D view (left of the control panel); a blank or
    # frozen canvas would give no change at all.
    view_changed_from(page, before, 200)
