"""rigidlab numerical core: numpy + scipy only (never imports viser).

Conventions are stated once in ``docs/conventions.md``.
"""
