"""The library installs as itself: ``rigidlab``, ``rigidlab.core``, ``rigidlab.app``, and nothing else.

The folders ``core/`` and ``app/`` stay at the top of the repository and map onto the package
(pyproject's ``package-dir``). A top-level ``core`` or ``app`` module would shadow, or be shadowed
by, anything else of that name, so none may be imported or installed.
"""

import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PROBE = """
import importlib.util, os, sys
import rigidlab, rigidlab.core, rigidlab.app
import rigidlab.core.models, rigidlab.core.modal, rigidlab.core.rotations, rigidlab.core.contact
import rigidlab.app.cli, rigidlab.app.model_file
from rigidlab.app.scenes import discover_scenes
scenes = discover_scenes()
assert {"gyroscope", "modes", "cam_follower"} <= set(scenes), sorted(scenes)
top = sorted({m.split(".")[0] for m in sys.modules} & {"core", "app"})
assert not top, f"top-level modules imported: {top}"
# a checkout put on sys.path by hand (PYTHONPATH=<repository>) shows its folders; nothing installed may
root = os.path.realpath(sys.argv[1])
sys.path[:] = [p for p in sys.path if os.path.realpath(p or ".") != root]
found = [name for name in ("core", "app") if importlib.util.find_spec(name) is not None]
assert not found, f"importable as top-level modules: {found}"
print("ok", rigidlab.__version__)
"""


def test_the_package_imports_as_rigidlab_and_never_as_core_or_app(tmp_path):
    """From a directory outside the repository (so the repository is not on sys.path by accident):
    every public module imports under ``rigidlab.``, every scene is discovered, and neither ``core``
    nor ``app`` is imported or importable at the top level."""
    done = subprocess.run([sys.executable, "-c", PROBE, str(ROOT)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.startswith("ok ")


def test_the_package_list_names_every_folder_of_core_and_app():
    """pyproject lists the packages explicitly (a ``package-dir`` mapping cannot be found by
    ``packages.find``): every folder with an ``__init__.py`` under core/ and app/ is in the list, as
    ``rigidlab.<path>``, and nothing else is installed at the top level."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert config["package-dir"] == {"rigidlab": "rigidlab", "rigidlab.core": "core", "rigidlab.app": "app"}
    on_disk = {"rigidlab"} | {
        "rigidlab." + ".".join(init.parent.relative_to(ROOT).parts)
        for top in ("core", "app") for init in (ROOT / top).rglob("__init__.py")
        if "__pycache__" not in init.parts}
    assert set(config["packages"]) == on_disk
    assert {name.split(".")[0] for name in config["packages"]} == {"rigidlab"}


def test_the_command_line_entry_point_is_in_the_package():
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts == {"rigidlab": "rigidlab.app.cli:main"}
