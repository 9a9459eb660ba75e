"""Scene registry: every ``Scene`` subclass in a module of this package.

Adding a scene means adding a module under ``app/scenes/``; nothing else is
edited. :func:`discover_scenes` imports every module of the package (with
:mod:`pkgutil`), collects the :class:`~rigidlab.app.scenes.base.Scene` subclasses that
are defined there and have a non-empty ``name``, and orders them by their
``order`` class attribute (sandbox 10, manipulator 20, free body 30,
gyroscope 40; scenes without one go last, then by name).

A module that fails to import is skipped with a logged error, so one broken
scene never takes the server down; :func:`discovery_errors` reports them.
"""

from __future__ import annotations

import importlib
import inspect
import logging
import pkgutil
import threading

from rigidlab.app.scenes.base import Scene

__all__ = ["Scene", "discover_scenes", "discovery_errors", "get_scene_class"]

_log = logging.getLogger(__name__)
_DEFAULT_ORDER = 1000
_lock = threading.Lock()
_errors: dict[str, str] = {}


def _order_key(cls: type[Scene]) -> tuple[int, str]:
    return (int(getattr(cls, "order", _DEFAULT_ORDER)), cls.name)


def discover_scenes() -> dict[str, type[Scene]]:
    """Import every module of ``rigidlab.app.scenes`` and return its scene classes.

    Returns
    -------
    dict
        ``{name: SceneClass}`` in display order (ascending ``order``).

    Raises
    ------
    ValueError
        If two scene classes declare the same ``name``.
    """
    found: dict[str, type[Scene]] = {}
    with _lock:
        for info in pkgutil.iter_modules(__path__):
            if info.name == "base" or info.name.startswith("_"):
                continue
            module_name = f"{__name__}.{info.name}"
            try:
                module = importlib.import_module(module_name)
            except Exception as exc:  # a broken scene must not stop the others
                message = f"{type(exc).__name__}: {exc}"
                if _errors.get(module_name) != message:
                    _log.error("scene module %s failed to import: %s", module_name, message)
                _errors[module_name] = message
                continue
            _errors.pop(module_name, None)
            for _, obj in inspect.getmembers(module, inspect.isclass):
                if (
                    issubclass(obj, Scene)
                    and obj is not Scene
                    and obj.__module__ == module_name
                    and obj.name
                ):
                    other = found.get(obj.name)
                    if other is not None and other is not obj:
                        raise ValueError(
                            f"scene name {obj.name!r} is declared twice: by "
                            f"{other.__module__}.{other.__qualname__} and "
                            f"{obj.__module__}.{obj.__qualname__}"
                        )
                    found[obj.name] = obj
    return dict(sorted(found.items(), key=lambda item: _order_key(item[1])))


def discovery_errors() -> dict[str, str]:
    """Modules that failed to import at the last discovery: ``{module: error}``."""
    with _lock:
        return dict(_errors)


def get_scene_class(name: str) -> type[Scene]:
    """Return the registered scene class called ``name``.

    Raises
    ------
    ValueError
        If no scene of that name is registered (the message lists them).
    """
    scenes = discover_scenes()
    try:
        return scenes[name]
    except KeyError:
        raise ValueError(
            f"scene: expected one of {sorted(scenes)}, got {name!r}"
        ) from None
