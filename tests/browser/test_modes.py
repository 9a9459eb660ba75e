"""Browser test of the mode-shapes scene: headless Chromium drives the page.

Open the app on the scene; pick a mode in the page's
*Mode* dropdown and check that the server animates that mode (the poses it
streams change from frame to frame, with the chain's joints closed) and that
the 3-D view moves; move the *Links N* slider from the keyboard and check
that the page's table of modes shows the new frequencies.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from rigidlab.app.scenes.modes import ModesScene
from rigidlab.core.rotations import rotate_vector
from tests.browser._page import view, view_changed_from, wait_for_drawn_canvas
from tests.helpers import wait_until

#: Joint gap of the rods viser holds (float32): see GAP_TOL_FLOAT32 in
#: tests/app/test_modes.py (float32 rounding of positions and quaternions).
GAP_TOL_FLOAT32 = 2e-6


@pytest.fixture
def modes_page(running_app, open_page):
    """``(app, page, scene)``: an app started on the mode-shapes scene, its page open."""
    app = running_app(scene=ModesScene.name)
    page = open_page(app)
    scene = app.scene_for()
    assert isinstance(scene, ModesScene)
    return app, page, scene


def _row(page, label: str):
    """The GUI row labelled ``label``."""
    return page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )


def _table_frequencies(page) -> list[float]:
    """The f (Hz) column of the modes table on the page."""
    table = page.locator(".rigidlab-readout table").first
    cells = table.locator("tbody tr td:nth-child(2)").all_inner_texts()
    return [float(c) for c in cells]


def test_choosing_a_mode_in_the_page_animates_it(modes_page) -> None:
    app, page, scene = modes_page
    wait_until(lambda: scene.clip is not None and scene.clip.mode == 1 and scene.panel_current, timeout=60.0)
    select = _row(page, "Mode").locator("input").first
    select.scroll_into_view_if_needed()
    select.click()
    page.get_by_role("option", name=re.compile("^2 \u00b7 ")).click()  # the table's row of mode 2
    wait_until(lambda: scene.controls.value("mode") == "2")
    wait_until(lambda: scene.clip is not None and scene.clip.mode == 2, timeout=60.0)
    solution = scene.solution
    assert scene.clip.eigenvalue == solution.eigenvalues[solution.groups[1][0]]
    # the poses streamed change from frame to frame, and the joints stay closed
    n = solution.n_bodies

    def rod_positions() -> np.ndarray:
        with app.session_for().run_lock:
            pos = np.array(scene.live.rods.batched_positions[:n], dtype=float)
            quat = np.array(scene.live.rods.batched_wxyzs[:n], dtype=float)
            length = np.array(scene.live.rods.batched_scales[:n, 2], dtype=float)
        quat /= np.linalg.norm(quat, axis=1)[:, None]
        half = np.zeros((n, 3))
        half[:, 2] = 0.5 * length
        tops, bottoms = pos + rotate_vector(quat, half), pos - rotate_vector(quat, half)
        assert np.linalg.norm(tops[1:] - bottoms[:-1], axis=1).max() < GAP_TOL_FLOAT32
        return pos

    first_pose = rod_positions()
    wait_until(lambda: np.abs(rod_positions() - first_pose).max() > 1e-3, timeout=120.0)
    # the page shows the mode: the 3-D view moves, the table marks it
    page.mouse.move(5, 745)
    first = view(page)
    view_changed_from(page, first, 100)
    wait_for_drawn_canvas(page)
    bold = page.locator(".rigidlab-readout table tbody tr").nth(1).locator("b")
    wait_until(lambda: bold.count() > 0)


def test_moving_a_parameter_slider_updates_the_frequency_table(modes_page) -> None:
    app, page, scene = modes_page
    wait_until(lambda: scene.solution is not None and scene.panel_current, timeout=60.0)
    wait_until(lambda: len(_table_frequencies(page)) == 3)
    before = _table_frequencies(page)
    thumb = _row(page, "Links N").get_by_role("slider").first
    thumb.scroll_into_view_if_needed()
    thumb.focus()
    page.keyboard.press("End")  # the slider's maximum: 10 links
    wait_until(lambda: scene.controls.value("n_links") == 10)
    wait_until(lambda: scene.solution is not None and scene.solution.key.n_links == 10
               and scene.panel_current, timeout=60.0)
    wait_until(lambda: len(_table_frequencies(page)) == 10, timeout=120.0)
    shown = _table_frequencies(page)
    expected = [float(scene.solution.frequency_hz[g[0]]) for g in scene.solution.groups]
    np.testing.assert_allclose(shown, expected, rtol=1e-3)  # four significant digits
    # ten shorter links: the lowest mode of the same 2 m chain is a little lower, the rest new
    assert shown[0] != before[0] and shown[:3] != before
    thumb.focus()
    page.keyboard.press("Home")  # a single link: one mode, sqrt(3 g / (2 L)) / (2 pi)
    wait_until(lambda: len(_table_frequencies(page)) == 1, timeout=60.0)
    np.testing.assert_allclose(_table_frequencies(page)[0], np.sqrt(3 * 9.81 / (2 * 2.0)) / (2 * np.pi), rtol=1e-3)
