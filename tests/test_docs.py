"""The docs keep up with the code: every public core name is documented.

Checks that ``docs/equations.md`` is the current output of
``docs/build_equations.py``, that every name exported by a public core module
(``__all__``) is mentioned somewhere under docs/, and that every exported
callable has a docstring.
"""

from __future__ import annotations

import importlib
import importlib.util
import pkgutil
from pathlib import Path

import pytest

import rigidlab.core

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _public_core_modules() -> list[str]:
    names = []
    for info in pkgutil.iter_modules(rigidlab.core.__path__):
        if not info.name.startswith("_"):
            names.append(f"rigidlab.core.{info.name}")
    return sorted(names)


def _load_builder():
    spec = importlib.util.spec_from_file_location("build_equations", DOCS / "build_equations.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_equation_index_is_current():
    builder = _load_builder()
    committed = (DOCS / "equations.md").read_text(encoding="utf-8")
    assert committed == builder.render(), "run `python docs/build_equations.py`"
    # The DESIGN.md anchors must be in the index.
    for eq in ("8.29", "8.46", "8.82"):
        assert f"| {eq}" in committed


@pytest.mark.parametrize("module_name", _public_core_modules())
def test_every_public_name_is_documented(module_name):
    module = importlib.import_module(module_name)
    exported = getattr(module, "__all__", None)
    assert exported, f"{module_name} has no __all__"
    text = "\n".join(p.read_text(encoding="utf-8") for p in DOCS.glob("*.md"))
    missing = [name for name in exported if name not in text]
    assert not missing, f"{module_name}: not mentioned under docs/: {missing}"
    undocumented = [
        name
        for name in exported
        if callable(getattr(module, name)) and not (getattr(module, name).__doc__ or "").strip()
    ]
    assert not undocumented, f"{module_name}: no docstring: {undocumented}"
