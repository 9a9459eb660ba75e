"""Cheap, checked writes of scene-node poses and buffers on the loop thread.

viser's ``wxyz`` / ``position`` setters compare the new value with the old
through ``np.allclose`` (about 70 us a call); a scene that moves a dozen
nodes spends a millisecond of its frame budget there. :func:`set_pose` does
the same thing for a handful of floats in plain Python: the same skip rule
(``|new - old| <= 1e-8 + 1e-5 |old|`` for every component, viser's
``allclose`` tolerance), the same message, and refuses non-finite values
(``ValueError``), so no NaN reaches a browser.

:func:`set_array` does the same for an array property of a node (the points
of line segments or arrows, their colours): viser's generic setter resolves
type hints and casts recursively (about 100 us); here the array is cast to
the stored dtype, compared with ``np.array_equal`` (nothing is sent when
equal), checked finite, and sent as one update message.

Like :mod:`rigidlab.app.gate`, this module reaches into viser 1.1's handle internals
(``_impl.wxyz``, ``_impl.position``, ``_impl.props``,
``_impl.api._queue_scene_message``).

:func:`set_plot_data` is the same for a plot's data (``gui.add_uplot``):
viser's setter compares the type hint with each of its array types for
every array (about 100 us a plot on a loop thread that slept between
frames); here each series is copied as float64 and the data sent as one
update message, as viser's setter does (``_impl.props``, ``_queue_update``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from viser import _messages

__all__ = ["set_pose", "set_array", "set_arrays", "set_plot_data", "set_visible", "wxyz_z_to"]

_RTOL = 1e-5
_ATOL = 1e-8


def _changed(new: tuple[float, ...], old: Any) -> bool:
    for a, b in zip(new, old):
        b = float(b)
        if abs(a - b) > _ATOL + _RTOL * abs(b):
            return True
    return False


def _floats(values: Any, length: int, what: str, name: str) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if len(out) != length:
        raise ValueError(f"{what}: expected {length} numbers for {name}, got {len(out)}")
    for v in out:
        if not math.isfinite(v):
            raise ValueError(f"{what}: expected finite numbers for {name}, got {out}")
    return out


def set_pose(handle: Any, *, wxyz: Any = None, position: Any = None) -> None:
    """Set the orientation (Euler parameters, scalar first) and/or position of a node.

    Raises
    ------
    ValueError
        For a non-finite or wrongly sized value (nothing is sent).
    """
    impl = handle._impl
    if impl.removed:
        return
    if wxyz is not None:
        value = _floats(wxyz, 4, "wxyz", impl.name)
        if _changed(value, impl.wxyz):
            impl.wxyz[:] = value
            impl.api._queue_scene_message(_messages.SetOrientationMessage(impl.name, value))
    if position is not None:
        value = _floats(position, 3, "position", impl.name)
        if _changed(value, impl.position):
            impl.position[:] = value
            impl.api._queue_scene_message(_messages.SetPositionMessage(impl.name, value))


def set_visible(handle: Any, visible: Any) -> None:
    """Show or hide a node (or a GUI element), sending a message only when that changes (viser sends one for
    every assignment of ``visible``, changed or not)."""
    visible = bool(visible)
    if handle.visible != visible:
        handle.visible = visible


def set_array(handle: Any, name: str, value: Any) -> None:
    """Set the array property ``name`` of a node (e.g. ``"points"``) to ``value``.

    The value is cast to the stored array's dtype; a value of another shape
    goes through viser's own setter (it re-creates the buffer).

    Raises
    ------
    ValueError
        For non-finite values in a floating-point array (nothing is sent).
    """
    set_arrays(handle, **{name: value})


def set_arrays(handle: Any, **values: Any) -> None:
    """:func:`set_array` for several array properties of one node, in one message."""
    impl = handle._impl
    if impl.removed:
        return
    changed = {}
    for name, value in values.items():
        current = getattr(impl.props, name)
        array = np.asarray(value, dtype=current.dtype)
        if array.dtype.kind == "f" and not np.isfinite(array).all():
            raise ValueError(f"{name}: expected finite numbers for {impl.name}, got non-finite values")
        if array.shape != current.shape:
            setattr(handle, name, array)
            continue
        if np.array_equal(array, current):
            continue
        current[...] = array
        changed[name] = array.copy()
    if changed:
        impl.api._queue_scene_message(_messages.SceneNodeUpdateMessage(impl.name, changed))


def set_plot_data(handle: Any, data: Any) -> None:
    """Set the data of a plot (a ``gui.add_uplot`` handle): ``data`` is a sequence of 1-D series, x first.

    Each series is copied as a float64 array (so the caller may reuse its
    buffers) and the tuple is sent as one update message, as viser's own
    setter does. Nothing is sent for a removed plot.
    """
    impl = handle._impl
    if impl.removed:
        return
    value = tuple(np.array(series, dtype=np.float64) for series in data)
    impl.props.data = value
    handle._queue_update("data", value)


def wxyz_z_to(v: Any, norm: float) -> tuple[float, float, float, float]:
    """Euler parameters (scalar first) of the shortest rotation taking +z to ``v`` (3,) of length ``norm``
    (identity for a zero vector)."""
    if not norm > 0.0:
        return (1.0, 0.0, 0.0, 0.0)
    x, y, z = (float(c) / norm for c in v)
    w = 1.0 + z
    if w < 1e-12:  # v along -z: half a turn about x
        return (0.0, 1.0, 0.0, 0.0)
    k = 1.0 / math.sqrt(w * w + x * x + y * y)
    return (w * k, -y * k, x * k, 0.0)
