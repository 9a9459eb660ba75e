"""Screenshots of every registered scene for the README and docs/app.md.

Starts the app on a free loopback port, opens it in headless Chromium (the
same launch options as the browser tests: Debian's /usr/bin/chromium with
software WebGL), shows each scene in turn and saves ``docs/img/<scene>.png``
(1200 x 750, palette PNG, well under 300 kB).

With ``--views normal presenter`` it writes ``docs/img/<scene>-<view>.png``
instead, at 1600 x 900 (a projector's page), one per view.

With ``--model PATH`` (repeatable) it serves the Model scene of each model
file (as ``rigidlab serve --model PATH``) and writes
``docs/img/model-<file stem>.png`` at 1600 x 900.

Usage::

    .venv/bin/python docs/make_screenshots.py            # every scene
    .venv/bin/python docs/make_screenshots.py sandbox    # only some
    .venv/bin/python docs/make_screenshots.py sandbox manipulator modes --views normal presenter
    .venv/bin/python docs/make_screenshots.py --model examples/arm.urdf --model examples/four_bar.py
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

CHROMIUM_PATH = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]
VIEWPORT = {"width": 1200, "height": 750}
WIDE = {"width": 1600, "height": 900}
VIEWS = ("normal", "presenter")
OUT_DIR = Path(__file__).resolve().parent / "img"
MAX_BYTES = 300_000


def _compress(png: bytes) -> bytes:
    """Re-encode as an optimized palette PNG (keeps it small, crisp text)."""
    from PIL import Image

    image = Image.open(io.BytesIO(png)).convert("RGB")
    for colors in (256, 128, 64):
        out = io.BytesIO()
        # k-means refinement keeps the colours of small swatches (a legend's),
        # which plain median cut merges into the greys around them
        image.quantize(colors=colors, method=Image.Quantize.MEDIANCUT, kmeans=4, dither=Image.Dither.NONE).save(
            out, format="PNG", optimize=True
        )
        if out.tell() <= MAX_BYTES:
            break
    return out.getvalue()


def _close_webgl_notice(page) -> None:  # type: ignore[no-untyped-def]
    """Close the "Software WebGL rendering detected" notice if it is shown."""
    notice = page.locator(".mantine-Notification-root", has_text="Software WebGL")
    try:
        notice.first.wait_for(state="visible", timeout=3000)
        notice.first.locator("button").first.click()
        notice.first.wait_for(state="hidden", timeout=3000)
    except Exception:  # not shown (hardware WebGL) or already closed
        pass


def main(argv: list[str] | None = None) -> int:
    """Save one screenshot per scene; returns the exit status."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from playwright.sync_api import sync_playwright

    from rigidlab.app.server import create_app

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", help="scene names (default: all)")
    parser.add_argument("--settle", type=float, default=2.0, help="seconds to let a scene render")
    parser.add_argument("--views", nargs="+", choices=VIEWS, default=None,
                        help="write <scene>-<view>.png at 1600 x 900 for these views")
    parser.add_argument("--model", action="append", default=[], metavar="PATH",
                        help="a model file: write docs/img/model-<file stem>.png of its Model scene at 1600 x 900")
    args = parser.parse_args(argv)
    viewport = WIDE if args.views or args.model else VIEWPORT

    files: dict[str, str] = {}  # Model scene name -> the image's name
    if args.model:
        from rigidlab.app.scenes import discover_scenes
        from rigidlab.app.scenes.model import model_scene_classes

        models = model_scene_classes(args.model)
        files = {name: f"model-{Path(path).stem}" for name, path in zip(models, args.model)}
        app = create_app(port=0, scene_classes={**models, **discover_scenes()})
    else:
        app = create_app(port=0)
    names = args.scenes or (list(files) if files else list(app.scene_names))
    unknown = sorted(set(names) - set(app.scene_names))
    if unknown:
        app.stop()
        print(f"scenes: expected names from {list(app.scene_names)}, got {unknown}", file=sys.stderr)
        return 2
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=CHROMIUM_PATH, args=CHROMIUM_ARGS, headless=True
            )
            page = browser.new_page(viewport=viewport)
            page.goto(app.url, timeout=120_000)
            page.wait_for_selector("canvas", state="attached", timeout=120_000)
            app.wait_for_client(set(), timeout=120.0)
            _close_webgl_notice(page)
            for view in args.views or [None]:
                if view is not None:
                    app.session_for().set_presenter(view == "presenter")
                for name in names:
                    app.switch_scene(name)
                    page.mouse.move(viewport["width"] // 2, viewport["height"] - 5)  # no hover highlight
                    time.sleep(args.settle)
                    page.evaluate("() => document.querySelectorAll('.mantine-Notification-root').forEach("
                                  "n => { if (n.textContent.includes('Software WebGL')) n.remove(); })")
                    png = _compress(page.screenshot(timeout=300_000))
                    stem = files.get(name, name)
                    path = OUT_DIR / (f"{stem}.png" if view is None else f"{stem}-{view}.png")
                    path.write_bytes(png)
                    print(f"{path.relative_to(OUT_DIR.parent.parent)}: {len(png) / 1000:.0f} kB")
            browser.close()
    finally:
        app.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
