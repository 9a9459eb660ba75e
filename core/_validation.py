"""Conversion of user input to float64, shared by the core modules.

``np.asarray(x, dtype=float)`` casts complex input to its real part with
only a ``ComplexWarning``; the helpers here refuse it instead. Messages
follow the ``name: expected ..., got ...`` style of :mod:`rigidlab.core.rigid_body`,
:mod:`rigidlab.core.gyroscope`, :mod:`rigidlab.core.integrators` and :mod:`rigidlab.core.manipulator`
(:mod:`rigidlab.core.rotations` has its own validation module).
"""

from __future__ import annotations

from rigidlab.core._errors import ArgumentError

import math
import numbers
from typing import Any

import numpy as np

_FLOAT64 = np.dtype(np.float64)


def short_repr(x: Any, limit: int = 80) -> str:
    """``repr(x)`` cut to ``limit`` characters for an error message."""
    text = repr(x)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_complex(arr: np.ndarray) -> bool:
    if arr.dtype.kind == "c":
        return True
    return arr.dtype.kind == "O" and any(
        isinstance(v, (complex, np.complexfloating)) for v in arr.flat
    )


def _holds_bool(x: Any) -> bool:
    """Whether ``x`` is or holds a bool (numpy turns ``[0.0, True]`` into ``[0.0, 1.0]``)."""
    if isinstance(x, (bool, np.bool_)):
        return True
    if isinstance(x, (list, tuple)):
        return any(_holds_bool(v) for v in x)
    if isinstance(x, np.ndarray):
        return x.dtype.kind == "b" or (x.dtype.kind == "O" and any(_holds_bool(v) for v in x.ravel().tolist()))
    return False


def float_array(x: Any, name: str, *, expected: str = "an array of real numbers", copy: bool = False) -> np.ndarray:
    """``x`` as a float64 array; complex or non-numeric input raises.

    Parameters
    ----------
    x : array_like
    name : str
        Argument name used in error messages.
    expected : str
        What the argument should be, for the message of a failed conversion.
    copy : bool
        Always return a new array (otherwise a float64 ndarray is returned
        as is).

    Returns
    -------
    ndarray, float64, the shape of ``x``.

    Raises
    ------
    ValueError
        ``{name}: expected real numbers, got complex ...`` for complex input
        (numpy would drop the imaginary part), ``{name}: expected
        {expected}, got ...`` when ``x`` is not numeric or is boolean (True
        is not the number 1 here, as for :func:`real_number`).
    """
    if type(x) is np.ndarray and x.dtype is _FLOAT64:
        return x.copy() if copy else x
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError):
        raise ArgumentError(name, f"{name}: expected {expected}, got {short_repr(x)}") from None
    if _is_complex(arr):
        raise ArgumentError(name, f"{name}: expected real numbers, got complex (dtype {arr.dtype}): {short_repr(x)}")
    if arr.dtype.kind in "USV":  # text is not a number here (numpy would parse "1e-3")
        raise ArgumentError(name, f"{name}: expected {expected}, got text {short_repr(x)}")
    if arr.dtype.kind == "b" or (arr.dtype.kind == "O" or not isinstance(x, np.ndarray)) and _holds_bool(x):
        where = " " if isinstance(x, (bool, np.bool_)) else " in "
        raise ArgumentError(name, f"{name}: expected {expected}, got a boolean{where}{short_repr(x)}")
    try:
        return np.array(arr, dtype=np.float64) if copy else np.asarray(arr, dtype=np.float64)
    except (TypeError, ValueError):
        raise ArgumentError(name, f"{name}: expected {expected}, got {short_repr(x)}") from None


def real_number(x: Any, name: str, *, expected: str = "a finite real number") -> float:
    """``x`` as a finite Python float; bools, complex numbers, arrays,
    non-finite and non-numeric values raise ``{name}: expected ..., got ...``
    (a 0-d array of reals counts as its number)."""
    if isinstance(x, np.ndarray) and x.ndim == 0 and x.dtype.kind in "iuf":
        x = x.item()
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real):
        if isinstance(x, (complex, np.complexfloating)):
            raise ArgumentError(name, f"{name}: expected real numbers, got complex {x!r}")
        raise ArgumentError(name, f"{name}: expected {expected}, got {short_repr(x)}")
    value = float(x)
    if not math.isfinite(value):
        raise ArgumentError(name, f"{name}: expected {expected}, got {value!r}")
    return value


def positive_integer(x: Any, name: str) -> int:
    """``x`` as an int >= 1 (Python or numpy integer, not a bool)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)) or x < 1:
        raise ArgumentError(name, f"{name}: expected an integer >= 1, got {short_repr(x)}")
    return int(x)


def output_times(t: Any, name: str = "t") -> np.ndarray:
    """Output times as a new 1-D float array (a number is one time): non-empty, finite and
    non-decreasing, else ``{name}: expected ...`` naming the first time that is not."""
    tt = float_array(t, name, expected="non-decreasing output times (s)", copy=True)
    if tt.ndim == 0:
        tt = tt.reshape(1)
    if tt.ndim != 1 or tt.size == 0:
        raise ArgumentError(name, f"{name}: expected a non-empty 1-D array of output times (s), got shape {tt.shape}")
    bad = np.flatnonzero(~np.isfinite(tt))
    if bad.size:
        i = int(bad[0])
        raise ArgumentError(name, f"{name}: expected finite times (s), got {name}[{i}] = {float(tt[i])!r}")
    back = np.flatnonzero(np.diff(tt) < 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise ArgumentError(name,
                            f"{name}: expected non-decreasing times (s), got {name}[{i}] = {float(tt[i])!r} after "
                         f"{name}[{i - 1}] = {float(tt[i - 1])!r}")
    return tt


#: Radians per degree: the factor of ``degrees=True`` (the product rounds once,
#: bit for bit as ``np.deg2rad`` and ``math.radians``).
RADIANS_PER_DEGREE = math.pi / 180.0


def check_degrees(degrees: Any) -> bool:
    """The ``degrees`` flag of a public function: True or False, else ``degrees: expected ...``."""
    if not isinstance(degrees, (bool, np.bool_)):
        raise ArgumentError("degrees", f"degrees: expected True or False, got {short_repr(degrees)}")
    return bool(degrees)


class _DefaultAngle(float):
    """A default angle (rad) in a signature: ``degrees=True`` leaves it as it is."""

    __slots__ = ()

    def __reduce__(self):
        return (float, (float(self),))


class _DefaultAngles(tuple):
    """Default angles (rad) in a signature: ``degrees=True`` leaves them as they are."""

    __slots__ = ()

    def __reduce__(self):
        return (tuple, (tuple(self),))


def default_angle(value: Any) -> Any:
    """``value`` (a number or a tuple of numbers, rad) marked as a default angle: with
    ``degrees=True`` an argument left at its default keeps this angle (it is not read
    as degrees); it prints and computes as the plain float or tuple."""
    return _DefaultAngles(value) if isinstance(value, tuple) else _DefaultAngle(value)


def radians(x: Any, name: str, degrees: Any) -> Any:
    """An angle (or angle rate) argument in radians (rad/s): ``x`` itself unless
    ``degrees``, else ``x`` times pi/180, once per call (a number stays a
    float, anything else becomes a float64 array; None stays None).

    The conversion comes before the argument's own validation, which then
    names ``name`` as usual; input that is not real numbers raises here,
    naming ``name`` too. A default marked by :func:`default_angle` (the
    argument was not given) is returned as it is."""
    if not check_degrees(degrees) or x is None:
        return x
    if isinstance(x, (_DefaultAngle, _DefaultAngles)):  # left at its default: already radians
        return x
    if isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)):
        return float(x) * RADIANS_PER_DEGREE
    return np.deg2rad(float_array(x, name, expected="angles in degrees"))


def degrees_out(x: Any, degrees: bool) -> Any:
    """A returned angle (or angle rate) in degrees when ``degrees``: ``x`` times 180/pi."""
    return np.rad2deg(x) if degrees else x
