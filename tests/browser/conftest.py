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
teardown. The app fixture ``running_app`` is shared with tests/app.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.app.conftest import running_app  # noqa: F401  (re-exported fixture)

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


@pytest.fixture
def open_page(chromium: Any) -> Iterator[Callable[..., Any]]:
    """Factory ``open_page(app) -> Page`` (canvas shown, browser registered)."""
    contexts: list[Any] = []

    def open_(app: Any, *, timeout: float = 30.0) -> Any:
        known = set(app.client_ids())
        context = chromium.new_context(viewport=VIEWPORT)
        contexts.append(context)
        page = context.new_page()
        page.goto(app.url, timeout=timeout * 1000)
        page.wait_for_selector("canvas", timeout=timeout * 1000)
        page.rigidlab_client_id = app.wait_for_client(known, timeout=timeout)
        return page

    yield open_
    for context in contexts:
        context.close()
