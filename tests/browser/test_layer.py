"""The scene layer in headless Chromium: presenter view, Load state, refused values.

Driven from the page as a user would, on the manipulator scene (a registry
scene that renders fast in software WebGL).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from rigidlab.app import state as codec
from tests.browser._page import field
from tests.helpers import send_value, wait_until


def _font_px(page: Any) -> float:
    return float(page.locator(".rigidlab-readout:visible").first.evaluate(
        "e => parseFloat(getComputedStyle(e).fontSize)"))


def _plot_css_in_page(page: Any) -> bool:
    return bool(page.evaluate(
        "() => [...document.querySelectorAll('style')].some(s => s.textContent.includes('.uplot .u-title{font-size'))"))


def test_presenter_toggle_enlarges_labels_arrows_and_readouts(running_app: Any, open_page: Any) -> None:
    app = running_app(scene="manipulator", run_unwatched=False)
    page = open_page(app)
    scene = app.scene_for()
    page.locator(".rigidlab-readout:visible").first.wait_for(state="visible")
    small_px = _font_px(page)
    small_scale = [h.font_screen_scale for h, _ in scene._labels]
    box = page.get_by_label("Presenter view").first
    box.check()
    assert wait_until(lambda: scene.presenter, 30.0)
    # Labels (drawn in WebGL) grow on the server's nodes; readouts grow in the page's DOM.
    assert all(h.font_screen_scale >= 1.5 * s for (h, _), s in zip(scene._labels, small_scale))
    assert wait_until(lambda: _font_px(page) >= 1.4 * small_px, 30.0)
    # the plots' titles and legends (page elements of uPlot) grow by the session's style sheet
    assert wait_until(lambda: _plot_css_in_page(page), 30.0)
    box.uncheck()
    assert wait_until(lambda: not scene.presenter, 30.0)
    assert wait_until(lambda: abs(_font_px(page) - small_px) < 0.5, 30.0)
    assert wait_until(lambda: not _plot_css_in_page(page), 30.0)


def _load_report(page: Any, session: Any, box: Any, string: str) -> str:
    """What a load that did not happen left behind: the text on the page and in the server, the loads
    pending, the notices."""
    stored = session.controls.handles["state_in"].value
    return (f"nothing loaded; pasted {string!r}; the page's field holds {box.input_value()!r}, the server's "
            f"{stored!r} (in use {session.controls.value('state_in')!r}); loads pending "
            f"{[(entry[1], entry[4].done()) for entry in session._loads]}; notices {list(session.notices)[-5:]}; "
            f"the page's notices {page.locator('.mantine-Notification-root').all_inner_texts()}")


def test_load_state_from_the_page_reproduces_a_pose(running_app: Any, open_page: Any) -> None:
    app = running_app(scene="manipulator", run_unwatched=False)
    page = open_page(app)
    scene = app.scene_for()
    wait_until(lambda: np.allclose(np.degrees(scene.joint_angles), [30.0, 45.0, 60.0]))
    string = codec.encode({"scene": "manipulator", "values": {"theta1": -100.0, "theta2": 20.5, "theta3": 7.0}})
    page.get_by_text("Share", exact=True).first.click()  # open the folder
    box = field(page, "State to load")
    box.wait_for(state="visible")
    box.fill(string)
    # The page's panel sends its messages through a 50 ms throttle that keeps only the newest: a click within
    # 50 ms of the paste (no person is that quick) could replace the text's message. Click once it has arrived.
    session = app.session_for()
    wait_until(lambda: session.controls.handles["state_in"].value == string)
    page.get_by_role("button", name="Load state", exact=True).click()
    try:
        wait_until(lambda: np.allclose(np.degrees(scene.joint_angles), [-100.0, 20.5, 7.0]), 15.0)
    except AssertionError:
        raise AssertionError(_load_report(page, app.session_for(), box, string)) from None
    # The page's sliders show the loaded values and a notice confirms.
    thumb = page.get_by_role("slider").first
    assert wait_until(lambda: thumb.get_attribute("aria-valuenow") == "-100", 15.0)
    page.get_by_text("State loaded").first.wait_for(state="visible")
    # Copy state gives back a string that decodes to the same values.
    page.get_by_role("button", name="Copy state", exact=True).click()
    out = field(page, "State")
    assert wait_until(lambda: out.input_value().startswith("rl1."), 15.0)
    assert codec.decode(out.input_value())["values"]["theta1"] == -100.0


def test_a_refused_value_shows_a_notice_and_the_control_shows_the_value_in_use(
    running_app: Any, open_page: Any
) -> None:
    app = running_app(scene="manipulator", run_unwatched=False)
    page = open_page(app)
    scene = app.scene_for()
    # The number box beside joint 1's slider: type a value beyond its range.
    box = field(page, "θ1 (deg)")
    box.click()
    box.fill("500")
    box.press("Enter")
    page.get_by_text("Refused: θ1 (deg)").first.wait_for(state="visible")
    assert scene.controls.value("theta1") == 30.0
    assert wait_until(lambda: box.input_value() == "30", 120.0)


_TABLES_OVERFLOW = """() => [...document.querySelectorAll('table')]
    .filter(t => t.offsetParent !== null && t.getBoundingClientRect().width > 0)
    .map(t => t.getBoundingClientRect().right - t.parentElement.getBoundingClientRect().right)"""


@pytest.mark.parametrize(("name", "values"), [("modes", {"model": "Heavy top", "top_spin": 3.0}), ("bicycle", {})],
                         ids=["modes", "bicycle"])
def test_presenter_view_tables_fit_the_panel(running_app: Any, open_page: Any, name: str, values: dict) -> None:
    """The mode tables (six columns, eigenvalue pairs, the status of a mirrored mode) at the presenter size
    were wider than the panel, whose right-hand columns were cut off."""
    app = running_app(scene=name, run_unwatched=False)
    page = open_page(app)
    scene = app.scene_for()
    for key, value in values.items():
        assert send_value(scene, key, value)
    assert send_value(app.session_for(), "presenter", True)
    assert wait_until(lambda: scene.presenter, 30.0)
    assert wait_until(lambda: page.evaluate(_TABLES_OVERFLOW), 60.0)  # the table is in
    assert wait_until(lambda: max(page.evaluate(_TABLES_OVERFLOW)) <= 1.0, 30.0), page.evaluate(_TABLES_OVERFLOW)
