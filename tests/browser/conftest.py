"""Fixtures for browser tests: Debian's Chromium driven by Playwright.

``chromium`` is a session-scoped Playwright ``Browser`` (headless, software
WebGL through SwiftShader) running Debian's ``/usr/bin/chromium`` (another
binary can be named in ``RIGIDLAB_CHROMIUM``). Without Playwright or ``/usr/bin/chromium`` the
browser tests are skipped with the reason, unless ``RIGIDLAB_REQUIRE_BROWSER=1``
(set by CI), which turns the skip into a failure.

``open_page(app)`` opens ``app.url`` in a new 1200x750 page, waits for the 3-D
canvas and for the server to register the browser (a browser registers only
after its first camera message), and returns the Playwright ``Page``; the
browser's client id is ``page.rigidlab_client_id``. Pages are closed at
teardown. ``scene_page(SceneClass)`` starts an app on the sandbox, opens it
and switches to ``SceneClass`` with the page's scene chooser, as a user
does. The app fixture ``running_app`` is shared with tests/app; plain
helpers (``wait_until``, ``drawn_fraction``, ``choose_scene``) live in
tests/helpers.py and tests/browser/_page.py.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.app.conftest import running_app  # noqa: F401  (re-exported fixture)
from tests.browser._page import choose_scene
from tests.helpers import wait_until

CHROMIUM_PATH = os.environ.get("RIGIDLAB_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]
VIEWPORT = {"width": 1200, "height": 750}


def _unavailable(reason: str) -> None:
    if os.environ.get("RIGIDLAB_REQUIRE_BROWSER") == "1":
        pytest.fail(f"browser required (RIGIDLAB_REQUIRE_BROWSER=1) but {reason}")
    pytest.skip(reason)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    here = Path(__file__).resolve().parent
    for item in items:
        if here in Path(str(item.fspath)).resolve().parents:
            item.add_marker(pytest.mark.browser)


@pytest.fixture(scope="session")
def chromium() -> Iterator[Any]:
    """Session-scoped headless Chromium (Playwright ``Browser``)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError as exc:
        _unavailable(f"Playwright is not installed ({exc})")
    if not Path(CHROMIUM_PATH).exists():
        _unavailable(f"Chromium not found at {CHROMIUM_PATH} (apt-get install chromium)")
    manager = sync_playwright().start()
    try:
        browser = manager.chromium.launch(
            executable_path=CHROMIUM_PATH, args=CHROMIUM_ARGS, headless=True
        )
    except Exception as exc:
        manager.stop()
        _unavailable(f"Chromium failed to launch: {exc}")
    try:
        yield browser
    finally:
        browser.close()
        manager.stop()


#: Seconds any wait on a page may take (Playwright's default is 30 s; a page on a machine at load 20 took longer).
PAGE_TIMEOUT = 120.0


@pytest.fixture
def open_page(chromium: Any) -> Iterator[Callable[..., Any]]:
    """Factory ``open_page(app) -> Page`` (canvas shown, browser registered)."""
    contexts: list[Any] = []

    def open_(app: Any, *, timeout: float = PAGE_TIMEOUT) -> Any:
        known = set(app.client_ids())
        context = chromium.new_context(viewport=VIEWPORT)
        contexts.append(context)
        page = context.new_page()
        # one generous timeout for every wait on the page (a click waits for its element): a loaded machine
        # makes the software-rendered page slower, not the test red
        page.set_default_timeout(timeout * 1000)
        page.goto(app.url, timeout=timeout * 1000)
        page.wait_for_selector("canvas", timeout=timeout * 1000)
        page.rigidlab_client_id = app.wait_for_client(known, timeout=timeout)
        return page

    yield open_
    for context in contexts:
        context.close()


@pytest.fixture
def scene_page(running_app: Callable[..., Any], open_page: Callable[..., Any]) -> Callable[[type], tuple[Any, Any, Any]]:
    """Factory ``scene_page(SceneClass) -> (app, page, scene)``: an app started
    on the sandbox, its page open, switched to ``SceneClass`` in the page's
    scene chooser; ``scene`` is the now active ``SceneClass`` instance."""

    def open_scene(scene_class: type) -> tuple[Any, Any, Any]:
        app = running_app(scene="sandbox")
        page = open_page(app)
        choose_scene(page, scene_class.title)
        wait_until(lambda: app.scene_for().name == scene_class.name)
        scene = app.scene_for()
        assert isinstance(scene, scene_class)
        return app, page, scene

    return open_scene
