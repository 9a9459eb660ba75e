"""The app shell in headless Chromium: the page loads, the scene renders and
the scene chooser switches scenes."""

from __future__ import annotations

from typing import Any

from rigidlab.app.scenes import get_scene_class
from rigidlab.app.server import create_app
from tests.app.test_server import OtherScene
from tests.browser._page import choose_scene, drawn_fraction
from tests.helpers import wait_until


def test_page_renders_and_chooser_switches_scenes(open_page: Any) -> None:
    app = create_app(
        port=0, scene_classes={"sandbox": get_scene_class("sandbox"), "beta": OtherScene}
    )
    try:
        page = open_page(app)
        client = app.server.get_clients()[page.rigidlab_client_id]
        # Images of the 3-D view alone, rendered by the browser (no GUI panel, no notices on it), until the
        # scene is drawn. A blank view has ~0 drawn pixels; the sandbox's body, axes, grid and gimbal rings
        # cover about 4 % of it (measured), a hidden scene 0 %.
        wait_until(lambda: drawn_fraction(client.get_render(375, 600, transport_format="jpeg", timeout=120)) > 0.01,
                   timeout=120.0)
        session = app.session_for()
        sandbox = app.scene_for()
        choose_scene(page, OtherScene.title)
        wait_until(lambda: session.active_name == "beta", timeout=120.0)
        assert sandbox.root_frame.visible is False
        # In the page, the sandbox's GUI folder is gone and Beta's is shown
        # (the chooser shows its value in an <input>, not as text).
        page.get_by_text(OtherScene.title, exact=True).first.wait_for(state="visible")
        assert not any(
            loc.is_visible() for loc in page.get_by_text(sandbox.title, exact=True).all()
        )
        choose_scene(page, sandbox.title)
        wait_until(lambda: session.active_name == "sandbox", timeout=120.0)
        assert app.scene_for() is sandbox and sandbox.root_frame.visible is True
    finally:
        app.stop()
