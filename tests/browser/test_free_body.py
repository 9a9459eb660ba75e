"""Browser test of the free-body scene: headless Chromium drives the page.

Switch to the scene with the page's scene chooser, click the Dzhanibekov
preset button in the page, and check that the server applied it (the
initial omega is the preset's), that the body's pose moves, and that the
rendered canvas is not blank.
"""

from __future__ import annotations

import numpy as np

from app.scenes.free_body import PRESETS, FreeBodyScene, body_mesh, preset_omega
from tests.browser._page import drawn_fraction
from tests.helpers import wait_until


def test_free_body_preset_from_the_page(scene_page) -> None:
    _, page, scene = scene_page(FreeBodyScene)
    wait_until(lambda: scene.sim_time > 0.2)

    # start from the stable major-axis spin, then click the flip preset
    scene.apply_preset(PRESETS[0])
    _, _, inertia = body_mesh(scene.inputs.body)
    wait_until(lambda: np.allclose(scene.setup.omega_body0, preset_omega(PRESETS[0], inertia)))
    page.get_by_role("button", name=PRESETS[2], exact=True).click()
    want = preset_omega(PRESETS[2], inertia)
    wait_until(lambda: np.allclose(scene.setup.omega_body0, want) and scene.sim_time > 0.1)
    pose_before = np.array(scene.exact_frame.wxyz)
    # spinning at 6 rad/s: the pose changes within a fraction of a second
    wait_until(lambda: not np.allclose(scene.exact_frame.wxyz, pose_before, atol=1e-2), timeout=10.0)

    page.wait_for_timeout(500)  # a few frames of the software renderer
    fraction = drawn_fraction(page.locator("canvas").first.screenshot())
    # the bodies, sphere and frames cover well over 1 % of the view; blank ~0
    assert fraction > 0.01, f"only {fraction:.2%} of the canvas is drawn"
