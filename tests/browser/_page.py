"""Helpers for browser tests that read or drive the rigidlab page."""

from __future__ import annotations

import io
from typing import Any

import numpy as np


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
