"""Every scene's plots go through ``Scene.add_plot``: a y axis wide enough for tick labels such as
"-5.625" (uPlot's default 50 px cut off their first character), and tick labels that grow in
presenter view and shrink back. Parametrized over the registry, so a new scene is covered."""

from __future__ import annotations

from typing import Any

import pytest

from rigidlab.app.readout import PRESENTER_FONT_SCALE
from rigidlab.app.scenes import discover_scenes
from rigidlab.app.scenes.base import (PLOT_FONT_PX, PLOT_Y_AXIS_PX, PRESENTER_CONTROL_PX, plot_axes, plot_padding,
                             plot_text_css, presenter_css)
from tests.helpers import send_value, wait_until

SCENES = list(discover_scenes())


def _font_px(axis: dict) -> float:
    return float(axis["font"].split("px")[0])


def test_plot_axes_grow_with_the_presenter_font():
    x, y = plot_axes(False)
    assert y["size"] == PLOT_Y_AXIS_PX and _font_px(x) == _font_px(y) == PLOT_FONT_PX
    x, y = plot_axes(True)
    assert y["size"] == round(PLOT_Y_AXIS_PX * PRESENTER_FONT_SCALE)
    assert _font_px(y) == round(PLOT_FONT_PX * PRESENTER_FONT_SCALE)


@pytest.mark.parametrize("name", SCENES)
def test_every_plot_of_a_scene_has_the_scene_axes_and_follows_presenter_view(server: Any, make_bare_scene: Any,
                                                                              name: str) -> None:
    made: list[Any] = []
    add_uplot = server.gui.add_uplot

    def counting(*args: Any, **kwargs: Any) -> Any:
        handle = add_uplot(*args, **kwargs)
        made.append(handle)
        return handle

    server.gui.add_uplot = counting
    try:
        scene, _ = make_bare_scene(discover_scenes()[name])
    finally:
        server.gui.add_uplot = add_uplot
    # no plot bypasses add_plot (it would keep uPlot's narrow axis and its small font in presenter view)
    assert [id(h) for h in made] == [id(h) for h in scene._plots]
    for on in (True, False, True):
        scene.set_presenter(on)
        for plot in scene._plots:
            assert tuple(plot.axes) == plot_axes(on)
            # room above the plot area for the top tick label's upper half (uPlot's own cut it off)
            assert tuple(plot.padding) == plot_padding(on) and plot.padding[0] >= 0.5 * _font_px(plot.axes[1])


def test_plot_titles_and_legends_grow_in_presenter_view(running_app: Any) -> None:
    """uPlot draws titles and legends as page elements, outside a plot's options: the session's panel carries
    a style sheet that enlarges them in presenter view (a title to a presenter readout's size) and is empty
    otherwise."""
    assert plot_text_css(False) == ""
    css = plot_text_css(True)
    assert f".uplot .u-title{{font-size:{PRESENTER_FONT_SCALE:.2f}em !important" in css
    assert ".uplot .u-legend{font-size:1.16em !important}" in css  # 0.7 em scaled as the title's 0.875
    # the session's sheet carries it in presenter view, with the controls' sizes
    assert presenter_css(False) == ""
    sheet = presenter_css(True)
    assert css in sheet and f"font-size:{PRESENTER_CONTROL_PX}px !important" in sheet
    app = running_app(scene="cam_follower")
    session = app.session_for()
    assert session._plot_css.content == ""
    assert send_value(session, "presenter", True)
    assert wait_until(lambda: session._plot_css.content == sheet, 10.0)
    assert send_value(session, "presenter", False)
    assert wait_until(lambda: session._plot_css.content == "", 10.0)
