"""Browser test of the bicycle scene: headless Chromium drives the page.

Open an app showing the bicycle scene; at 5 m/s press
*Push* on the page and check that the bicycle leans and recovers (the lean
stays below 0.25 rad and 8 s after the push is below a quarter of its largest value); move the
*Speed* slider to 2 m/s from the keyboard, press *Push* and check that it
falls (the lean passes 0.5 rad) and that the 3-D view shows it; the plot of
the eigenvalues against speed and the mode table are on the page.
"""

from __future__ import annotations

import math
import re

import numpy as np

from rigidlab.app.scenes.bicycle import BicycleScene
from tests.browser._page import view, view_changed_from, wait_for_drawn_canvas
from tests.helpers import wait_until

FALLEN = 0.5  # rad


def _slider_thumb(page, label: str):
    """The thumb (role=slider) of the GUI slider labelled ``label`` (a '/' in the label defeats ``:text-is``)."""
    pattern = re.compile(f"^{re.escape(label)}$")
    row = page.locator("label").filter(has_text=pattern).first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )
    return row.get_by_role("slider").first


def _press(page, name: str) -> None:
    """Click the panel's button ``name``: a click event dispatched on the button itself. The panel's plots
    re-render several times a second, so the software renderer starves the animation frames Playwright's
    stability check waits for, and a forced click at the button's coordinates could land elsewhere when the
    panel's layout moved in between (a push was lost once in 30 s)."""
    button = page.get_by_role("button", name=name, exact=True)
    button.wait_for(state="visible", timeout=60_000)
    button.dispatch_event("click")


def _leans_since(scene, t0: float) -> np.ndarray:
    t, columns = scene.history.window(t0, scene.sim_time, max_points=100000)
    return np.radians(columns[:, 0]) if t.size else np.zeros(0)


def _bicycle_page(running_app, open_page):
    app = running_app(scene="bicycle")
    page = open_page(app)
    wait_until(lambda: app.scene_for().name == "bicycle")
    scene = app.scene_for()
    assert isinstance(scene, BicycleScene)
    return app, page, scene


def test_push_recovers_at_five_and_falls_at_two(running_app, open_page) -> None:
    _, page, scene = _bicycle_page(running_app, open_page)
    wait_until(lambda: scene.sim_time > 1.0, timeout=120.0)
    assert scene.config.speed == 5.0
    pushes = scene.pushes
    _press(page, "Push")
    wait_until(lambda: scene.pushes == pushes + 1, timeout=120.0)
    t_push = scene.segment.t0
    wait_until(lambda: scene.sim_time > t_push + 8.0, timeout=180.0)
    lean = _leans_since(scene, t_push)
    assert np.max(np.abs(lean)) > math.radians(1.0)  # the push made it lean
    assert np.max(np.abs(lean)) < 0.25
    assert abs(scene.lean) < 0.25 * np.max(np.abs(lean)) and not scene.ended  # weave gone, capsize decaying
    upright = view(page)

    thumb = _slider_thumb(page, "Speed (m/s)")
    thumb.focus()
    page.keyboard.press("Home")  # 0 m/s
    for _ in range(20):  # step 0.1 m/s
        page.keyboard.press("ArrowRight")
    wait_until(lambda: scene.controls.value("speed") == 2.0 and scene.config.speed == 2.0, timeout=120.0)
    wait_until(lambda: scene.sim_time > 0.2, timeout=60.0)
    pushes = scene.pushes
    _press(page, "Push")
    wait_until(lambda: scene.pushes == pushes + 1, timeout=120.0)
    wait_until(lambda: scene.ended, timeout=180.0)
    assert np.max(np.abs(_leans_since(scene, 0.0))) > FALLEN
    assert abs(scene.lean) > FALLEN
    view_changed_from(page, upright, 2000)  # once the software renderer catches up with the last poses
    wait_for_drawn_canvas(page)


def test_eigenvalue_plot_and_mode_table_are_on_the_page(running_app, open_page) -> None:
    _, page, scene = _bicycle_page(running_app, open_page)
    wait_until(lambda: scene.modes is not None and scene.sweep is not None, timeout=120.0)
    wait_until(lambda: "self-stable" in scene.eigen_plot.content, timeout=120.0)
    # read the page in one evaluation: the plot is replaced as the engine's dots arrive
    page.wait_for_function(
        """() => [...document.querySelectorAll('svg')].some(s => s.textContent.includes('speed v (m/s)')
                 && s.querySelectorAll('polyline').length >= 5 && s.textContent.includes('self-stable'))""",
        timeout=60_000)
    page.wait_for_function(
        """() => [...document.querySelectorAll('table')].some(t => ['weave', 'capsize', 'castering']
                 .every(n => [...t.querySelectorAll('td')].some(td => td.textContent.trim() === n)))""",
        timeout=60_000)
    # the figure's text is readable: at least 12 px on the page (it was 6-7 px)
    sizes = page.evaluate("""() => [...document.querySelectorAll('svg text')].map(t => {
        let s = t.ownerSVGElement; while (s.ownerSVGElement) s = s.ownerSVGElement;
        if (!s.textContent.includes('speed v (m/s)')) return null;  // font px of the drawing, as rendered
        return parseFloat(t.getAttribute('font-size')) * s.getBoundingClientRect().width / s.viewBox.baseVal.width;
    }).filter(x => x !== null)""")
    assert sizes and min(sizes) >= 12.0, sizes
