"""rigidlab numerical core: numpy + scipy only (never imports viser).

Conventions are stated once in ``docs/conventions.md``.
"""

from rigidlab.core._errors import ArgumentError, RigidModeWarning  # (a leaf module: importing core stays cheap)

__all__ = ["ArgumentError", "RigidModeWarning"]
