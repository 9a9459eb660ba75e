"""The app shell in headless Chromium: the page loads, the scene renders and
the scene chooser switches scenes."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from app.scenes import get_scene_class
from app.server import create_app
from tests.app.test_server import OtherScene


def drawn_fraction(image: np.ndarray) -> float:
    """Fraction of pixels that differ clearly (> 40 of 255 in some channel)
    from the most common colour, i.e. the background."""
    flat = image.reshape(-1, 3)
    values, counts = np.unique(flat, axis=0, return_counts=True)
    background = values[np.argmax(counts)]
    return float(np.mean(np.abs(flat - background).max(axis=1) > 40))


def choose_scene(page: Any, title: str) -> None:
    """Pick ``title`` in the scene chooser (a Mantine Select) as a user would."""
    page.locator("input.mantine-Select-input:visible").first.click()
    page.get_by_role("option", name=title, exact=True).click()


def test_page_renders_and_chooser_switches_scenes(open_page: Any) -> None:
    app = create_app(
        port=0, scene_classes={"sandbox": get_scene_class("sandbox"), "beta": OtherScene}
    )
    try:
        page = open_page(app)
        client = app.server.get_clients()[page.rigidlab_client_id]
        # A few frames for the software renderer, then an image of the 3-D
        # view alone, rendered by the browser (no GUI panel, no notices on it).
        page.wait_for_timeout(500)
        image = client.get_render(375, 600, transport_format="jpeg", timeout=30).astype(float)
        # A blank view has ~0 drawn pixels; the sandbox's body, axes, grid
        # and gimbal rings cover about 4 % of it (measured), a hidden scene 0 %.
        assert drawn_fraction(image) > 0.01
        session = app.session_for()
        sandbox = app.scene_for()
        choose_scene(page, OtherScene.title)
        deadline = time.monotonic() + 15
        while session.active_name != "beta" and time.monotonic() < deadline:
            time.sleep(0.05)
        assert session.active_name == "beta"
        assert sandbox.root_frame.visible is False
        # In the page, the sandbox's GUI folder is gone and Beta's is shown
        # (the chooser shows its value in an <input>, not as text).
        page.get_by_text(OtherScene.title, exact=True).first.wait_for(state="visible")
        assert not any(
            loc.is_visible() for loc in page.get_by_text(sandbox.title, exact=True).all()
        )
        choose_scene(page, sandbox.title)
        deadline = time.monotonic() + 15
        while session.active_name != "sandbox" and time.monotonic() < deadline:
            time.sleep(0.05)
        assert app.scene_for() is sandbox and sandbox.root_frame.visible is True
    finally:
        app.stop()
