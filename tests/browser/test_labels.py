"""3-D labels on a fresh page: the sandbox, opened and left alone, draws its labels' text in the 3-D view.

viser 1.1.1's page draws a label's text (black, on a pale box) only once its label renderer has
rasterized every glyph of the label's group, a few glyphs per rendered frame (docs/app.md, "Labels from
the first frame"); no scene draws black.
"""

from __future__ import annotations

from typing import Any

from tests.browser._page import png_pixels
from tests.helpers import wait_until

#: The part of the 1200 x 750 page where only the 3-D view is: left of the control panel, below the
#: "Software WebGL rendering detected" notice, above the orientation gizmo (x0, y0, x1, y1 in px).
_VIEW = (70, 160, 790, 690)
#: Seconds a fresh software-rendered page may take to draw its labels (a loaded machine's page took
#: over 90 s: its GPU process compiles the scene's pipelines before it draws a frame).
_LABELS_TIMEOUT = 300.0


def text_pixels(page: Any) -> int:
    """Near-black pixels (every channel below 60 of 255) in the 3-D view: a label's text."""
    x0, y0, x1, y1 = _VIEW
    png = page.screenshot(clip={"x": x0, "y": y0, "width": x1 - x0, "height": y1 - y0})
    rgb = png_pixels(png)[..., :3] * 255
    return int((rgb.max(axis=-1) < 60).sum())


def test_a_fresh_sandbox_page_draws_its_labels_without_a_control_moving(running_app: Any, open_page: Any) -> None:
    app = running_app(scene="sandbox", run_unwatched=False)
    page = open_page(app)
    scene = app.scene_for()
    # "X", "Y", "Z", "x_b", "rotation axis" ... at 16 px: hundreds of text pixels
    assert wait_until(lambda: text_pixels(page) > 150, _LABELS_TIMEOUT, interval=1.0)
    assert scene.controls.version == 0  # nothing was touched
