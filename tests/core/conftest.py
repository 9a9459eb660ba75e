"""Long numerical runs (``@pytest.mark.slow``) are skipped unless asked for.

Run them with ``pytest -m slow tests/core`` (or set ``RIGIDLAB_RUN_SLOW=1``);
the default run stays short.
"""

from __future__ import annotations

import os

import pytest


def pytest_collection_modifyitems(config, items):
    if os.environ.get("RIGIDLAB_RUN_SLOW") == "1" or "slow" in (config.getoption("markexpr") or ""):
        return
    skip = pytest.mark.skip(reason="long run: use `pytest -m slow` or RIGIDLAB_RUN_SLOW=1")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
