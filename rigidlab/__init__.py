"""rigidlab: spatial rigid-body dynamics, a numerical core and an interactive lab.

``rigidlab.core`` is the numerical core (numpy and scipy; rotations, multibody
systems, contact, modal analysis; see docs/guide/); ``rigidlab.app`` is the viser
server and its scenes (``rigidlab serve``).

In the repository the two live in the top-level folders ``core/`` and ``app/``.
An installed copy (``pip install .``) has them inside this package; a source
checkout on ``sys.path`` (or an editable install) finds them through the package
path extended below. No top-level ``core`` or ``app`` module is ever installed.
"""

from pathlib import Path as _Path

__version__ = "0.1.0"

_here = _Path(__file__).resolve().parent
if not (_here / "core").is_dir() and (_here.parent / "core" / "__init__.py").is_file() \
        and (_here.parent / "app" / "__init__.py").is_file():
    # a source checkout: rigidlab/ beside core/ and app/
    __path__.append(str(_here.parent))  # noqa: F821 (a package's own __path__)
del _Path, _here
