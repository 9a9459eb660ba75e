"""Every ```python block of the user guide (docs/guide/*.md) runs.

The blocks of one page run in order in one namespace, in a temporary
directory. A block (of any language) right after ``<!-- file: NAME -->`` is
the text of a file the reader saves: it is written to NAME there, for the
blocks after it to use. A block right after ``<!-- requires: name -->`` is
skipped, with the rest of the page, when the module ``name`` is not
installed; one right after ``<!-- no-run -->`` is not run (only for things
such as starting a server). The design notes' own examples (docs/*.md) are
run by the test at the end, marked slow where they integrate for long.
"""

from __future__ import annotations

import importlib.util
import re
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "guide"
PAGES = ("getting_started", "rotations", "multibody", "contact", "modal", "own_model", "app")

_BLOCK = re.compile(
    r"(?:<!--\s*(no-run|requires:\s*([\w.,]+)|file:\s*([\w.-]+))\s*-->\s*\n)?```(\w*)\n(.*?)^```", re.S | re.M)


def blocks(path: Path) -> list[tuple[int, str | None, str | None, str]]:
    """``(line, marker, argument, code)`` of every python block and every ``file:`` block of a page, in order."""
    text = path.read_text(encoding="utf-8")
    found = []
    for m in _BLOCK.finditer(text):
        head = m.group(1) or ""
        marker = {"n": "no-run", "r": "requires", "f": "file"}.get(head[:1])
        if m.group(4) != "python" and marker != "file":
            continue
        line = text.count("\n", 0, m.start(5))
        found.append((line, marker, m.group(2) or m.group(3), m.group(5)))
    return found


def run_page(path: Path) -> int:
    """Run a page's blocks in one namespace (in the current directory); the number of blocks run.

    The namespace is a module registered while the page runs, so that a
    function a page defines pickles as a module-level function of a file
    does (a process pool's ``build``).
    """
    module = types.ModuleType(f"_docs_{path.parent.name}_{path.stem}")
    sys.modules[module.__name__] = module
    ran = 0
    try:
        for line, marker, argument, code in blocks(path):
            if marker == "no-run":
                continue
            if marker == "file":
                Path(argument).write_text(code, encoding="utf-8")
                continue
            if marker == "requires":
                for name in argument.split(","):
                    if importlib.util.find_spec(name) is None:
                        pytest.skip(f"{path.name}:{line}: needs {name}")
            # Blank lines keep the block's line numbers in tracebacks.
            exec(compile("\n" * line + code, str(path), "exec"), module.__dict__)
            ran += 1
    finally:
        del sys.modules[module.__name__]
    return ran


def test_guide_has_its_pages():
    assert sorted(p.stem for p in GUIDE.glob("*.md")) == sorted(PAGES + ("index",))
    index = (GUIDE / "index.md").read_text(encoding="utf-8")
    for page in PAGES:
        assert f"({page}.md)" in index, f"index.md does not link {page}.md"
    assert "docs/guide/" in (ROOT / "README.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("page", PAGES)
def test_guide_page_examples_run(page, tmp_path, monkeypatch):
    path = GUIDE / f"{page}.md"
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    assert blocks(path), f"{path.name} has no python example"
    assert run_page(path) > 0


_NOTES_SLOW = {"bicycle", "multibody", "modal"}


@pytest.mark.parametrize(
    "page",
    [pytest.param(p.stem, marks=[pytest.mark.slow] if p.stem in _NOTES_SLOW else [])
     for p in sorted((ROOT / "docs").glob("*.md")) if blocks(p)],
)
def test_design_note_examples_run(page, tmp_path, monkeypatch):
    """The design notes' examples run too (from the repository root, where examples/ is)."""
    monkeypatch.chdir(ROOT)
    run_page(ROOT / "docs" / f"{page}.md")


def test_readme_examples_run(tmp_path, monkeypatch):
    """The README's library section runs."""
    monkeypatch.chdir(tmp_path)
    assert run_page(ROOT / "README.md") >= 2
