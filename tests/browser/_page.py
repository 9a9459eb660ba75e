"""Helpers for browser tests that read or drive the rigidlab page."""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from tests.helpers import wait_until


def png_pixels(png: bytes) -> np.ndarray:
    """RGB(A) pixels (h, w, channels), floats in [0, 1], of a PNG image."""
    import matplotlib.image

    return matplotlib.image.imread(io.BytesIO(png), format="png")


def drawn_fraction(image: np.ndarray | bytes) -> float:
    """Fraction of pixels that differ clearly (> 40 of 255 in some channel)
    from the most common colour, i.e. the background.

    ``image`` is PNG bytes (a Playwright screenshot) or an (h, w, >= 3) array
    in 0..255 (``client.get_render``).
    """
    if isinstance(image, bytes):
        image = png_pixels(image)[..., :3] * 255
    rgb = np.rint(np.asarray(image, dtype=float)[..., :3]).astype(np.int64).reshape(-1, 3)
    # the most common colour from one integer per pixel (np.unique over rows of floats took ~3 s a page)
    keys = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    values, counts = np.unique(keys, return_counts=True)
    background = rgb[np.argmax(keys == values[np.argmax(counts)])]
    return float(np.mean(np.abs(rgb - background).max(axis=1) > 40))


def choose_scene(page: Any, title: str) -> None:
    """Pick ``title`` in the scene chooser (a Mantine Select) as a user would."""
    page.locator("input.mantine-Select-input:visible").first.click()
    page.get_by_role("option", name=title, exact=True).click()


def field(page: Any, label: str) -> Any:
    """The text input (or textarea) in the GUI row labelled ``label``."""
    row = page.locator(f"label:text-is('{label}')").first.locator(
        "xpath=ancestor::div[contains(@class,'mantine-Flex-root')][1]"
    )
    return row.locator("input:not([type='hidden']), textarea").first


# -- waiting on what the page draws ---------------------------------------------------------------------------------
# A software-rendered page on a loaded machine draws a frame every few hundred milliseconds or slower, so a test
# never sleeps "a few frames": it waits, with one generous timeout, for the image it needs.

#: A channel difference (of 1) that counts a pixel as changed: well above the renderer's antialiasing jitter.
PIXEL_TOL = 0.05


def view(page: Any) -> np.ndarray:
    """The 3-D view of a page screenshot: RGB in [0, 1], the part left of the control panel."""
    pixels = png_pixels(page.screenshot())[..., :3]
    return pixels[:, : int(0.6 * pixels.shape[1])]


def canvas_view(page: Any) -> np.ndarray:
    """The 3-D view alone: :func:`view` from the 3-D canvas's left edge on, without a plot panel docked on the
    left (a timed scene redraws its plots once more after a pause, the window up to the time shown)."""
    left = int(page.locator("canvas").first.bounding_box()["x"])
    pixels = png_pixels(page.screenshot())[..., :3]
    return pixels[:, left: int(0.6 * pixels.shape[1])]


def next_frames(page: Any, n: int = 2) -> None:
    """Return once the page has drawn ``n`` more animation frames (``requestAnimationFrame``)."""
    page.evaluate(
        "n => new Promise(done => { const step = k => k ? requestAnimationFrame(() => step(k - 1)) : done(); step(n); })",
        n,
    )


def changed_pixels(a: np.ndarray, b: np.ndarray, tol: float = PIXEL_TOL) -> int:
    """How many pixels differ by more than ``tol`` in some channel."""
    return int(np.any(np.abs(a - b) > tol, axis=-1).sum())


def settled_view(page: Any, take: Any = view, timeout: float = 120.0) -> np.ndarray:
    """The image ``take(page)`` once two takes a few page frames apart agree: the renderer has caught up with a
    scene that holds still. Raises ``AssertionError`` if it never does within ``timeout``."""
    last = [take(page)]

    def agrees() -> bool:
        next_frames(page, 3)
        now = take(page)
        same = changed_pixels(now, last[0]) == 0
        last[0] = now
        return same

    wait_until(agrees, timeout, interval=0.0)
    return last[0]


def view_changed_from(page: Any, reference: np.ndarray, pixels: int, take: Any = view,
                      timeout: float = 120.0, tol: float = PIXEL_TOL) -> np.ndarray:
    """Wait until ``take(page)`` differs from ``reference`` in more than ``pixels`` pixels; return that image.
    On timeout the assertion names how many pixels changed at most."""
    most = [0]
    out: list[np.ndarray] = []

    def changed() -> bool:
        now = take(page)
        n = changed_pixels(now, reference, tol)
        most[0] = max(most[0], n)
        if n > pixels:
            out.append(now)
            return True
        next_frames(page, 1)
        return False

    try:
        wait_until(changed, timeout, interval=0.0)
    except AssertionError:
        raise AssertionError(f"at most {most[0]} pixels of the view changed within {timeout:g} s (want > {pixels})") from None
    return out[0]


def wait_for_drawn_canvas(page: Any, fraction: float = 0.01, timeout: float = 120.0) -> float:
    """Wait until more than ``fraction`` of the 3-D canvas is drawn (see :func:`drawn_fraction`); return it."""
    seen = [0.0]

    def drawn() -> bool:
        seen[0] = drawn_fraction(page.locator("canvas").first.screenshot())
        return seen[0] > fraction

    try:
        wait_until(drawn, timeout, interval=0.1)
    except AssertionError:
        raise AssertionError(f"only {seen[0]:.2%} of the canvas is drawn after {timeout:g} s") from None
    return seen[0]
