"""A user's own mechanism, named on the command line: ``rigidlab serve --model PATH``.

:func:`load_model_file` reads one model file and checks it completely at start,
so that a bad file stops the server with one clear line (exit 2) instead of a
traceback in a browser later. Three kinds of file are accepted, told apart by
the suffix:

``.py``
    A Python file that defines ``build(**parameters) -> System`` (a
    :class:`rigidlab.core.multibody.System`) and, optionally::

        PARAMETERS = {"name": (default, low, high, "unit", "label"), ...}
        SWEEP = "name"

    Each parameter becomes a validated slider (``low < high``, the default
    between them); ``SWEEP`` names the parameter swept for a Campbell diagram
    or a root locus. ``build`` is called once with the defaults to check it.
``.urdf``
    A robot description, through :func:`rigidlab.core.models.from_urdf`.
``.xml`` / ``.mjcf``
    An MJCF model, through MuJoCo's own parser (:func:`rigidlab.core.models.from_mjcf`).

Code in a model file runs only because the person who started the server
named the file on the command line: no browser can upload a file or choose a
path. The file's SHA-256 goes into the shareable state, so a state made for
another model is refused.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import math
import sys
import traceback
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

__all__ = ["MODEL_SUFFIXES", "ModelFile", "ModelFileError", "Parameter", "load_model_file"]

#: The suffixes :func:`load_model_file` accepts, and the kind of file each is.
MODEL_SUFFIXES = {".py": "python", ".urdf": "urdf", ".xml": "mjcf", ".mjcf": "mjcf"}

#: Largest model file read (bytes): a model is text a person wrote; a larger file is a mistake.
MAX_MODEL_BYTES = 20_000_000


class ModelFileError(ValueError):
    """A model file that cannot be used: the message names the file (and the line or element)."""


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One slider of a model file: ``PARAMETERS[name] = (default, low, high, unit, label)``."""

    name: str
    default: float
    low: float
    high: float
    unit: str = ""
    label: str = ""

    @property
    def title(self) -> str:
        """What the slider is labelled: ``"label (unit)"``."""
        text = self.label or self.name
        return f"{text} ({self.unit})" if self.unit else text


@dataclasses.dataclass(frozen=True)
class ModelFile:
    """A checked model file; :meth:`build` makes a fresh System for parameter values."""

    path: Path
    kind: str
    sha256: str
    parameters: tuple[Parameter, ...]
    sweep: str | None
    _build: Callable[..., Any] = dataclasses.field(repr=False, compare=False)

    @property
    def name(self) -> str:
        """The file's name (``four_bar.py``), as the page shows it."""
        return self.path.name

    def defaults(self) -> dict[str, float]:
        """``{name: default}`` of every parameter."""
        return {p.name: p.default for p in self.parameters}

    def build(self, **values: float) -> Any:
        """A new System for ``values`` (missing names take their default).

        Raises
        ------
        ValueError
            For an unknown name or a value outside the parameter's range.
        """
        known = {p.name: p for p in self.parameters}
        for key, value in values.items():
            if key not in known:
                raise ValueError(f"{key}: expected one of the model's parameters {sorted(known)}, got {key!r}")
            p = known[key]
            if not (isinstance(value, (int, float)) and math.isfinite(value) and p.low <= value <= p.high):
                raise ValueError(f"{key}: expected a number in [{p.low:g}, {p.high:g}], got {value!r}")
        return self._build(**{**self.defaults(), **values})


def _where(path: Path, exc: BaseException) -> str:
    """``"path:line"`` of the innermost frame of ``exc`` that is in ``path`` (else ``"path"``)."""
    line = None
    for frame in traceback.extract_tb(exc.__traceback__):
        if Path(frame.filename).resolve() == path:
            line = frame.lineno
    return f"{path}:{line}" if line else str(path)


def _parameters(path: Path, raw: Any) -> tuple[Parameter, ...]:
    if not isinstance(raw, Mapping):
        raise ModelFileError(f"{path}: PARAMETERS: expected a dict {{name: (default, low, high, unit, label)}}, "
                             f"got {type(raw).__name__}")
    out = []
    for name, spec in raw.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelFileError(f"{path}: PARAMETERS: expected names that are Python identifiers, got {name!r}")
        if not isinstance(spec, (tuple, list)) or not 3 <= len(spec) <= 5:
            raise ModelFileError(f"{path}: PARAMETERS[{name!r}]: expected (default, low, high, unit, label), "
                                 f"got {spec!r}")
        numbers = spec[:3]
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in numbers):
            raise ModelFileError(f"{path}: PARAMETERS[{name!r}]: expected finite numbers default, low, high, "
                                 f"got {tuple(numbers)!r}")
        default, low, high = (float(x) for x in numbers)
        if not low < high or not low <= default <= high:
            raise ModelFileError(f"{path}: PARAMETERS[{name!r}]: expected low < high and the default between "
                                 f"them, got default {default:g}, low {low:g}, high {high:g}")
        text = [str(x) for x in spec[3:]]
        if any(not isinstance(x, str) for x in spec[3:]):
            raise ModelFileError(f"{path}: PARAMETERS[{name!r}]: expected unit and label as text, got {spec[3:]!r}")
        out.append(Parameter(name, default, low, high, *text))
    return tuple(out)


def _python_model(path: Path) -> tuple[Callable[..., Any], tuple[Parameter, ...], str | None]:
    module_name = f"rigidlab_model_{hashlib.sha1(str(path).encode()).hexdigest()[:12]}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    if spec is None or spec.loader is None:
        raise ModelFileError(f"{path}: cannot be loaded as a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module  # (dataclasses and pickling look a module up by name)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise ModelFileError(f"{path}:{exc.lineno}: syntax error: {exc.msg}") from None
    except Exception as exc:
        raise ModelFileError(f"{_where(path, exc)}: running the file raised {type(exc).__name__}: {exc}") from None
    build = getattr(module, "build", None)
    if not callable(build):
        raise ModelFileError(f"{path}: expected a function build(**parameters) -> System, found none")
    parameters = _parameters(path, getattr(module, "PARAMETERS", {}))
    sweep = getattr(module, "SWEEP", None)
    names = [p.name for p in parameters]
    if sweep is not None and sweep not in names:
        raise ModelFileError(f"{path}: SWEEP: expected one of the PARAMETERS {names}, got {sweep!r}")
    return build, parameters, sweep


def _loader_model(path: Path, kind: str) -> Callable[..., Any]:
    from rigidlab.core.models import from_mjcf, from_urdf

    load = from_urdf if kind == "urdf" else from_mjcf
    return lambda: load(str(path))


def load_model_file(path: str | Path) -> ModelFile:
    """Read and check the model file ``path``; build it once with its defaults.

    Returns
    -------
    ModelFile

    Raises
    ------
    ModelFileError
        One line naming the file, and the line or element where it can: a
        missing or unreadable file, an unknown suffix, a syntax error, a file
        or a ``build`` that raises, malformed ``PARAMETERS``/``SWEEP``, a
        ``build`` that does not return a System, a URDF or MJCF the loader
        refuses.
    """
    from rigidlab.core.multibody import System

    given = Path(path)
    resolved = given.expanduser().resolve()
    kind = MODEL_SUFFIXES.get(resolved.suffix.lower())
    if kind is None:
        raise ModelFileError(f"{given}: expected a model file ending in {', '.join(MODEL_SUFFIXES)}, "
                             f"got {resolved.suffix or 'no suffix'!r}")
    if not resolved.is_file():
        raise ModelFileError(f"{given}: no such file" if not resolved.exists() else f"{given}: not a regular file")
    size = resolved.stat().st_size
    if size > MAX_MODEL_BYTES:
        raise ModelFileError(f"{given}: expected a model file of at most {MAX_MODEL_BYTES} bytes, got {size}")
    try:
        digest = hashlib.sha256(resolved.read_bytes()).hexdigest()
    except OSError as exc:
        raise ModelFileError(f"{given}: cannot be read ({exc.strerror or exc})") from None
    if kind == "python":
        build, parameters, sweep = _python_model(resolved)
    else:
        build, parameters, sweep = _loader_model(resolved, kind), (), None
    model = ModelFile(resolved, kind, digest, parameters, sweep, build)
    try:
        system = model.build()
    except ModelFileError:
        raise
    except ValueError as exc:
        if kind != "python":  # core's loaders name the file and the line already
            raise ModelFileError(str(exc)) from None
        raise ModelFileError(f"{_where(resolved, exc)}: build() raised ValueError: {exc}") from None
    except Exception as exc:
        where = _where(resolved, exc) if kind == "python" else str(given)
        what = "build()" if kind == "python" else f"loading the {kind.upper()}"
        raise ModelFileError(f"{where}: {what} raised {type(exc).__name__}: {exc}") from None
    if not isinstance(system, System):
        raise ModelFileError(f"{given}: build() expected to return a rigidlab.core.multibody.System, "
                             f"got {type(system).__name__}")
    return model
