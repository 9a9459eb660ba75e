"""The page for a projector, in headless Chromium at 1600 x 900: presenter view scales the whole panel, a
plot is shown beside the 3-D view without scrolling, and a slider's number box refuses text with a notice
and shows the value in use."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from rigidlab.app.scenes.base import NORMAL_PANEL_PX, PRESENTER_PANEL_PX
from tests.helpers import send_value, wait_until

WIDE = {"width": 1600, "height": 900}

#: Computed font sizes (px) of the panel's controls: a row's label, an input, a button, a dropdown.
_FONTS = """() => {
  const visible = sel => [...document.querySelectorAll(sel)].find(e => e.offsetParent !== null
      && e.getBoundingClientRect().width > 0);
  const px = e => e ? parseFloat(getComputedStyle(e).fontSize) : null;
  const label = [...document.querySelectorAll('label')].find(l => l.offsetParent !== null
      && l.textContent.trim() === 'Time scale');
  const panel = label ? label.closest('.mantine-ScrollArea-root') : null;
  return {label: px(label), input: px(visible('input.mantine-Input-input:not(.mantine-Select-input)')),
          button: px(visible('button.mantine-Button-root')), select: px(visible('input.mantine-Select-input')),
          title: px(visible('.uplot .u-title')), legend: px(visible('.uplot .u-legend')),
          panel: panel ? panel.getBoundingClientRect().width : null};
}"""

#: The 3-D canvas's left edge and width (px): the docked plots panel insets it.
_SCENE_BOX = """() => { const c = [...document.querySelectorAll('canvas')].find(c => !c.closest('.uplot'));
    const r = c.getBoundingClientRect(); return [r.left, r.width]; }"""

#: Boxes (left, top, right, bottom) of the plots' canvases that are laid out.
_PLOT_BOXES = """() => [...document.querySelectorAll('.uplot canvas')].map(c => c.getBoundingClientRect())
    .filter(r => r.width > 0).map(r => [r.left, r.top, r.right, r.bottom])"""


@pytest.fixture
def open_wide(chromium: Any) -> Iterator[Callable[[Any], Any]]:
    """Factory ``open_wide(app) -> Page``: a fresh 1600 x 900 page on ``app``, canvas shown, browser registered."""
    contexts: list[Any] = []

    def open_(app: Any) -> Any:
        known = set(app.client_ids())
        context = chromium.new_context(viewport=WIDE)
        contexts.append(context)
        page = context.new_page()
        page.goto(app.url, timeout=60_000)
        page.wait_for_selector("canvas", timeout=60_000)
        page.rigidlab_client_id = app.wait_for_client(known, timeout=60.0)
        return page

    yield open_
    for context in contexts:
        context.close()


def test_presenter_view_scales_the_controls_the_plot_text_and_the_panel(running_app: Any, open_wide: Any) -> None:
    app = running_app(scene="gyroscope", run_unwatched=False)
    page = open_wide(app)
    session = app.session_for()
    assert wait_until(lambda: None not in page.evaluate(_FONTS).values(), 90.0), page.evaluate(_FONTS)
    normal = page.evaluate(_FONTS)
    assert normal["panel"] == pytest.approx(NORMAL_PANEL_PX, abs=4)
    assert send_value(session, "presenter", True)
    assert wait_until(lambda: session.presenter, 30.0)

    def grown() -> bool:
        fonts = page.evaluate(_FONTS)
        return all(fonts[k] is not None and fonts[k] >= 14.0
                   for k in ("label", "input", "button", "select", "title", "legend")) and (
            abs(fonts["panel"] - PRESENTER_PANEL_PX) <= 4)

    assert wait_until(grown, 90.0), page.evaluate(_FONTS)
    # the axes' tick labels are drawn in the canvas, in the font the plot's options give
    for plot in app.scene_for()._plots:
        for axis in plot.axes:
            assert float(axis["font"].split("px")[0]) >= 14.0
    print("font sizes (px) and panel width, normal:", normal, "presenter:", page.evaluate(_FONTS))


def test_a_plot_is_beside_the_3d_view_without_scrolling_at_1600x900(running_app: Any, open_wide: Any) -> None:
    app = running_app(scene="gyroscope", run_unwatched=False)
    page = open_wide(app)

    def beside() -> bool:
        scene_left, scene_width = page.evaluate(_SCENE_BOX)
        return scene_width > 400 and any(
            0 <= left and right <= scene_left + 2 and 0 <= top and bottom <= WIDE["height"] and right - left > 200
            for left, top, right, bottom in page.evaluate(_PLOT_BOXES))

    assert wait_until(beside, 90.0), (page.evaluate(_PLOT_BOXES), page.evaluate(_SCENE_BOX))
    assert page.evaluate("() => [window.scrollX, window.scrollY]") == [0, 0]


def test_text_in_a_slider_box_is_refused_with_a_notice_and_the_box_shows_the_value_in_use(
    running_app: Any, open_wide: Any
) -> None:
    app = running_app(scene="sandbox", run_unwatched=False)
    page = open_wide(app)
    scene = app.scene_for()
    row = page.locator("label:text-is('\u03c6 about Z')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]")
    box = row.locator("input:not([type='hidden'])").last
    box.wait_for(state="visible", timeout=60_000)
    box.click()
    box.press("Control+a")
    box.press_sequentially("nan")
    box.press("Tab")
    page.locator(".rigidlab-notice").first.wait_for(state="visible", timeout=30_000)
    assert "Showing the value in use, 30" in page.locator(".rigidlab-notice").first.inner_text()
    assert wait_until(lambda: box.input_value() == "30", 30.0)
    assert scene.controls.value("euler1") == 30.0
