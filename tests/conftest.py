"""Suite-wide set-up: the compiled kernels are compiled (or loaded from numba's cache) once, before the
pytest-xdist workers start, so that the workers load them from the cache instead of each compiling its own
copy at the same time (about a minute of CPU each with a cold cache; see core/_warm.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def pytest_configure(config):
    if hasattr(config, "workerinput"):  # a worker: the controller has warmed the cache already
        return
    if not getattr(config.option, "numprocesses", None):  # one process (-n 0): it compiles what it uses itself
        return
    # a child process: the compilation's memory and threads do not stay in this one
    subprocess.run([sys.executable, "-m", "rigidlab.core._warm"], cwd=Path(__file__).resolve().parent.parent, check=False,
                   stdout=subprocess.DEVNULL)
