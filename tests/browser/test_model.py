"""Browser test of the Model scene: ``rigidlab serve --model examples/arm.urdf`` in headless Chromium.

The page opens on the Model scene of the URDF arm (the scene shown first); the
3-D view is drawn (the arm's meshes and the ground), picking a mode in the
page's *Mode* dropdown makes the server animate that mode, and the view moves.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rigidlab.app.scenes import discover_scenes
from rigidlab.app.scenes.model import ModelScene, model_scene_classes
from tests.browser._page import view, view_changed_from, wait_for_drawn_canvas
from tests.helpers import wait_until

ARM = Path(__file__).resolve().parents[2] / "examples" / "arm.urdf"


@pytest.fixture
def arm_page(running_app, open_page):
    """``(app, page, scene)``: an app serving the Model scene of examples/arm.urdf first, its page open."""
    app = running_app(scene=None, scene_classes={**model_scene_classes([ARM]), **discover_scenes()})
    page = open_page(app)
    scene = app.scene_for()
    assert isinstance(scene, ModelScene) and scene.title == "Model: arm.urdf"
    return app, page, scene


def _row(page, label: str):
    """The GUI row labelled ``label``."""
    return page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )


def test_the_arm_is_drawn_and_a_mode_picked_in_the_page_animates(arm_page) -> None:
    app, page, scene = arm_page
    wait_until(lambda: scene.clip is not None and scene.clip.mode == 1 and scene.panel_current, timeout=120.0)
    wait_for_drawn_canvas(page)
    assert scene.mesh_frames  # the URDF's meshes, on their bodies
    select = _row(page, "Mode").locator("input").first
    select.scroll_into_view_if_needed()
    select.click()
    page.get_by_role("option", name=re.compile("^2 \u00b7 ")).click()  # the table's row of mode 2
    wait_until(lambda: scene.controls.value("mode") == "2")
    wait_until(lambda: scene.clip is not None and scene.clip.mode == 2 and scene.panel_current, timeout=120.0)
    assert scene.clip.eigenvalue == scene.solution.eigenvalues[scene.solution.groups[1][0]]
    # the server streams the mode's poses: the drawn sample changes, and so does the page's view
    drawn = scene._mode_drawn
    wait_until(lambda: scene._mode_drawn is not None and scene._mode_drawn != drawn, timeout=120.0)
    page.mouse.move(5, 745)
    first = view(page)
    view_changed_from(page, first, 100)
