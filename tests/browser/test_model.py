"""Browser tests of the Model scene: ``rigidlab serve --model examples/arm.urdf`` and
``--model examples/four_bar.py`` in headless Chromium.

The page opens on the Model scene (the scene shown first); the 3-D view is drawn
(the arm's meshes and the ground), picking a mode in the page's *Mode* dropdown
makes the server animate that mode, and the view moves. The four-bar's *Spring
stiffness* typed into its slider's box in the page builds the model again: the
table's frequencies are core's for the new stiffness, and the mode animates.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rigidlab.app.scenes import discover_scenes
from rigidlab.app.scenes.model import ModelScene, model_scene_classes
from rigidlab.app.model_file import load_model_file
from rigidlab.core.modal import linearize
from tests.browser._page import view, view_changed_from, wait_for_drawn_canvas
from tests.helpers import wait_until

ARM = Path(__file__).resolve().parents[2] / "examples" / "arm.urdf"
FOUR_BAR = Path(__file__).resolve().parents[2] / "examples" / "four_bar.py"


@pytest.fixture
def arm_page(running_app, open_page):
    """``(app, page, scene)``: an app serving the Model scene of examples/arm.urdf first, its page open."""
    app = running_app(scene=None, scene_classes={**model_scene_classes([ARM]), **discover_scenes()})
    page = open_page(app)
    scene = app.scene_for()
    assert isinstance(scene, ModelScene) and scene.title == "Model: arm.urdf"
    return app, page, scene


#: Marks the number box of the GUI row whose label reads ``label`` (``data-box``); false while there is none.
_MARK_BOX = """label => {
    const l = [...document.querySelectorAll('label')].find(x => x.textContent.trim() === label);
    for (let e = l; e; e = e.parentElement) {
        const box = e.querySelector("input:not([type='hidden'])");
        if (box) { box.setAttribute('data-box', label); return true; }
    }
    return false;
}"""


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


def test_a_four_bar_parameter_typed_in_the_page_builds_the_model_again_and_its_mode_animates(
        running_app, open_page) -> None:
    app = running_app(scene=None, scene_classes={**model_scene_classes([FOUR_BAR]), **discover_scenes()})
    page = open_page(app)
    scene = app.scene_for()
    assert isinstance(scene, ModelScene) and scene.title == "Model: four_bar.py"
    wait_until(lambda: scene.clip is not None and scene.solution is not None and scene.panel_current, timeout=120.0)
    wait_for_drawn_canvas(page)
    before = scene.solution.eigenvalues
    # the number box of the slider's row: the nearest block around the label that holds a text input
    wait_until(lambda: page.evaluate(_MARK_BOX, "Spring stiffness (N/m)"))
    box = page.locator("input[data-box='Spring stiffness (N/m)']")
    box.scroll_into_view_if_needed()
    box.click()
    box.fill("600")
    box.press("Enter")
    key = scene.parameter_key("spring_k")
    wait_until(lambda: scene.controls.value(key) == 600.0)
    wait_until(lambda: scene.solution is not None and dict(scene.solution.key.values)["spring_k"] == 600.0
               and scene.clip is not None and scene.panel_current, timeout=120.0)
    # the table is core's modes of the model built with the new stiffness (an independent build and solve)
    system = load_model_file(FOUR_BAR).build(**dict(scene.solution.key.values))
    try:
        model = linearize(system)
    except ValueError:  # not at rest as built: about the nearest equilibrium, as the scene says
        system.equilibrium()
        model = linearize(system)
    expected = model.modes().flexible.eigenvalues[0]
    got = scene.solution.eigenvalues[scene.solution.groups[0][0]]
    # the same model and solver in another process: equal to round-off (1e-9 leaves room for the solve's order)
    assert abs(got - expected) <= 1e-9 * abs(expected), (got, expected)
    assert abs(got - before[scene.solution.groups[0][0]]) > 1e-6 * abs(got)  # the stiffer spring moved it
    drawn = scene._mode_drawn  # the new model's mode is streamed (the arm's test shows the page's view move)
    wait_until(lambda: scene._mode_drawn is not None and scene._mode_drawn != drawn, timeout=120.0)
