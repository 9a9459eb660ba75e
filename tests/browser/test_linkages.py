"""Browser test of the linkages scene: headless Chromium drives the page.

Switch to the linkages scene with the page's scene chooser; move the
*N links* slider from the keyboard and check that the server draws that many
links and the canvas changes; pause and play from the page's buttons and
check that the chain holds, then moves; and check that the residual plot is
on the page with every plotted value below the projection's bound.
"""

from __future__ import annotations

import math

import numpy as np

from rigidlab.app.scenes.linkages import RESIDUAL_BOUND, LinkagesScene
from tests.app._views import drawn_instances
from tests.browser._page import (
    canvas_view,
    changed_pixels,
    next_frames,
    settled_view,
    view,
    view_changed_from,
    wait_for_drawn_canvas,
)
from tests.helpers import wait_until


def _slider_thumb(page, label: str):
    """The thumb (role=slider) of the GUI slider labelled ``label``."""
    row = page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )
    return row.get_by_role("slider").first


def test_moving_n_changes_the_links_drawn(scene_page) -> None:
    _, page, scene = scene_page(LinkagesScene)
    wait_until(lambda: scene.setup is not None and scene.sim_time > 0.3, timeout=120.0)
    assert drawn_instances(scene.parts.rods) == 5
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
    thumb = _slider_thumb(page, "N links")
    wait_until(lambda: thumb.get_attribute("aria-valuenow") == "5")
    before = settled_view(page)

    thumb.focus()
    page.keyboard.press("End")  # the slider's maximum: 10 links
    wait_until(lambda: scene.controls.value("n_links") == 10)
    wait_until(lambda: drawn_instances(scene.parts.rods) == 10 and scene.setup.model.n_links == 10, timeout=120.0)
    # ten joints and arrows against five, then one: many pixels of the 3-D view differ
    view_changed_from(page, before, 300)
    ten = settled_view(page)
    thumb.focus()
    page.keyboard.press("Home")  # one link
    wait_until(lambda: drawn_instances(scene.parts.rods) == 1 and scene.setup.model.n_links == 1, timeout=120.0)
    view_changed_from(page, ten, 300)
    wait_for_drawn_canvas(page)


def test_play_moves_the_chain_and_pause_holds_it(scene_page) -> None:
    _, page, scene = scene_page(LinkagesScene)
    wait_until(lambda: scene.setup is not None and scene.sim_time > 0.3, timeout=120.0)
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
    frames = scene.frames
    wait_until(lambda: scene.frames > frames + 1)  # a loop tick after the pause
    t_paused = scene.sim_time
    positions = np.array(scene.parts.rods.batched_positions)
    # After the pause the readout and the plots docked on the left are sent once more, up to a refresh period
    # later and one a loop tick: a redrawn plot can change the panel's width and so the 3-D canvas' (every edge
    # of the view moved by a pixel in a fresh-clone run). The view is held once they have all been sent.
    wait_until(lambda: scene.plots_current)
    held = settled_view(page, take=canvas_view)
    # half a second of loop ticks and a few page frames later, nothing has moved
    frames = scene.frames
    wait_until(lambda: scene.frames > frames + 30, timeout=120.0)
    next_frames(page, 3)
    assert scene.sim_time == t_paused
    np.testing.assert_array_equal(np.asarray(scene.parts.rods.batched_positions), positions)
    assert changed_pixels(canvas_view(page), held) == 0  # nothing moves while paused

    page.get_by_role("button", name="Play", exact=True).click()
    wait_until(lambda: scene.playing and scene.sim_time > t_paused + 0.5, timeout=120.0)
    assert np.abs(np.asarray(scene.parts.rods.batched_positions) - positions).max() > 0.01
    view_changed_from(page, held, 200, take=canvas_view)


def test_residual_plot_stays_below_its_bound(scene_page) -> None:
    _, page, scene = scene_page(LinkagesScene)
    scene.playback.set_time_scale(4.0)
    wait_until(lambda: scene.sim_time > 4.0 and scene.plot_handles["residual"].data[0].size > 100, timeout=60.0)
    # paused, the plots stop being redrawn (the page re-creates a plot's
    # elements when its data changes)
    page.get_by_role("button", name="Pause", exact=True).click()
    wait_until(lambda: not scene.playing)
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
