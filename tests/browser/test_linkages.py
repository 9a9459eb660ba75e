"""Browser test of the linkages scene: headless Chromium drives the page.

Switch to the linkages scene with the page's scene chooser; move the
*N links* slider from the keyboard and check that the server draws that many
links and the canvas changes; pause and play from the page's buttons and
check that the chain holds, then moves; and check that the residual plot is
on the page with every plotted value below the projection's bound.
"""

from __future__ import annotations

import math
import time

import numpy as np

from app.scenes.linkages import RESIDUAL_BOUND, LinkagesScene
from tests.app._views import drawn_instances
from tests.browser._page import drawn_fraction, png_pixels
from tests.helpers import wait_until


def _slider_thumb(page, label: str):
    """The thumb (role=slider) of the GUI slider labelled ``label``."""
    row = page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )
    return row.get_by_role("slider").first


def _view(png: bytes) -> np.ndarray:
    """The 3-D view of a page screenshot: the part left of the control panel."""
    pixels = png_pixels(png)[..., :3]
    return pixels[:, : int(0.6 * pixels.shape[1])]


def _settled_view(page, timeout: float = 20.0) -> np.ndarray:
    """The 3-D view once two screenshots 0.3 s apart agree: a page on a loaded machine may still be drawing
    frames the server sent before it paused."""
    deadline = time.monotonic() + timeout
    last = _view(page.screenshot())
    while True:
        page.wait_for_timeout(300)
        now = _view(page.screenshot())
        if np.abs(now - last).max() < 0.05 or time.monotonic() > deadline:
            return now
        last = now


def test_moving_n_changes_the_links_drawn(scene_page) -> None:
    _, page, scene = scene_page(LinkagesScene)
    wait_until(lambda: scene.setup is not None and scene.sim_time > 0.3, timeout=120.0)
    assert drawn_instances(scene.rods) == 5
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
    thumb = _slider_thumb(page, "N links")
    wait_until(lambda: thumb.get_attribute("aria-valuenow") == "5")
    page.wait_for_timeout(800)  # a few frames of the software renderer
    before = _view(page.screenshot())

    thumb.focus()
    page.keyboard.press("End")  # the slider's maximum: 10 links
    wait_until(lambda: scene.controls.value("n_links") == 10)
    wait_until(lambda: drawn_instances(scene.rods) == 10 and scene.setup.model.n_links == 10, timeout=120.0)
    page.wait_for_timeout(800)
    ten = _view(page.screenshot())
    thumb.focus()
    page.keyboard.press("Home")  # one link
    wait_until(lambda: drawn_instances(scene.rods) == 1 and scene.setup.model.n_links == 1, timeout=120.0)
    page.wait_for_timeout(800)
    one = _view(page.screenshot())
    # ten joints and arrows against one: many pixels of the 3-D view differ
    for a, b in ((before, ten), (ten, one)):
        changed = np.any(np.abs(a - b) > 0.05, axis=-1)
        assert changed.sum() > 300, f"only {changed.sum()} pixels changed"
    assert drawn_fraction(page.locator("canvas").first.screenshot()) > 0.01


def test_play_moves_the_chain_and_pause_holds_it(scene_page) -> None:
    _, page, scene = scene_page(LinkagesScene)
    wait_until(lambda: scene.setup is not None and scene.sim_time > 0.3, timeout=120.0)
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
    page.wait_for_timeout(300)
    t_paused = scene.sim_time
    positions = np.array(scene.rods.batched_positions)
    held = _settled_view(page)
    page.wait_for_timeout(500)
    assert scene.sim_time == t_paused
    np.testing.assert_array_equal(np.asarray(scene.rods.batched_positions), positions)
    still = _view(page.screenshot())
    assert np.abs(still - held).max() < 0.05  # nothing moves while paused

    page.get_by_role("button", name="Play", exact=True).click()
    wait_until(lambda: scene.playing and scene.sim_time > t_paused + 0.5, timeout=120.0)
    assert np.abs(np.asarray(scene.rods.batched_positions) - positions).max() > 0.01
    moved = _view(page.screenshot())
    changed = np.any(np.abs(moved - held) > 0.05, axis=-1)
    assert changed.sum() > 200, f"only {changed.sum()} pixels of the 3-D view changed"


def test_residual_plot_stays_below_its_bound(scene_page) -> None:
    _, page, scene = scene_page(LinkagesScene)
    scene.playback.set_time_scale(4.0)
    wait_until(lambda: scene.sim_time > 4.0 and scene.plot_handles["residual"].data[0].size > 100, timeout=60.0)
    # paused, the plots stop being redrawn (the page re-creates a plot's
    # elements when its data changes)
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
    page.wait_for_timeout(1000)
    title = page.locator(".u-title", has_text="constraint residual (log10)").first
    title.wait_for(state="visible", timeout=30_000)
    title.scroll_into_view_if_needed()
    t, residual, bound, _ = (np.asarray(a) for a in scene.plot_handles["residual"].data)
    assert t[-1] > 2.0
    assert np.all(residual < math.log10(RESIDUAL_BOUND))
    np.testing.assert_allclose(bound, math.log10(RESIDUAL_BOUND))
    assert scene.max_residual < RESIDUAL_BOUND
    # the readout states the bound beside the residual
    assert "(bound 1e-08)" in scene.status.content
