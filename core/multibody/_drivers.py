"""Time functions of motors: ``f(t)`` and its first two derivatives.

A driving constraint needs ``f``, ``f_dot`` (for ``C_t`` and the velocity
projection) and ``f_ddot`` (for the acceleration right side). They come from

* ``"given"``: a tuple ``(f, f_dot, f_ddot)`` of callables (exact);
* ``"complex step"``: when ``f`` accepts a complex time and returns a
  complex number, ``f_dot = Im f(t + i h1) / h1`` with ``h1 = 1e-30``
  (exact to round-off, no subtraction) and
  ``f_ddot = Im[f(t + h2 w) + f(t - h2 w)] / h2^2`` with ``w = e^{i pi/4}``
  and ``h2 = 1e-4`` s (``(t +- h2 w)^2`` terms give ``i h2^2 f''``; the
  error is ``h2^4 f^(6) / 360`` plus ``eps |f'| / (h2 |f''|)``: about 1e-11
  relative for ``sin(omega t)`` up to omega = 100 rad/s);
* ``"finite differences"`` otherwise: central differences with steps
  ``h = 1e-6 (1 + |t|)`` for ``f_dot`` (error ~ 1e-10 |f|) and
  ``h = 1e-4 (1 + |t|)`` for ``f_ddot`` (error ~ 1e-8 (|f| + |f''''|)).

Functions that branch on their argument (``abs``, ``max``, ``np.clip``)
give wrong complex-step derivatives; pass the tuple for those.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from core._validation import short_repr

_H1 = 1e-30
_H2 = 1e-4
_W = cmath.exp(0.25j * math.pi)


def _real(value: Any, name: str, t: float) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}: expected the function to return a real number, got {short_repr(value)}")
    try:
        v = complex(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected the function to return a real number, got {short_repr(value)}") from None
    if v.imag != 0.0 and not isinstance(value, complex):
        raise ValueError(f"{name}: expected a real number at t={t:g}, got {short_repr(value)}")
    r = v.real
    if not math.isfinite(r):
        raise ValueError(f"{name}: expected a finite value at t={t:g}, got {r!r}")
    return r


def driver_function(spec: Any, name: str, t0: float) -> tuple[Callable[[float], tuple[float, float, float]], str]:
    """Return ``(values(t) -> (f, f_dot, f_ddot), rule)`` for a motor argument.

    Raises
    ------
    ValueError
        When ``spec`` is neither a callable nor a tuple of three callables,
        or ``f(t0)`` is not a finite real number.
    """
    if isinstance(spec, tuple):
        if len(spec) != 3 or not all(callable(g) for g in spec):
            raise ValueError(f"{name}: expected a callable f(t) or a tuple (f, f_dot, f_ddot) of callables, got {short_repr(spec)}")
        f, fd, fdd = spec
        for g, label in ((f, "f"), (fd, "f_dot"), (fdd, "f_ddot")):
            _real(_call(g, t0, name), f"{name} ({label})", t0)

        def given(t: float) -> tuple[float, float, float]:
            return (_real(f(t), name, t), _real(fd(t), name, t), _real(fdd(t), name, t))

        return given, "given"
    if not callable(spec):
        raise ValueError(f"{name}: expected a callable f(t) or a tuple (f, f_dot, f_ddot), got {short_repr(spec)}")
    f = spec
    _real(_call(f, t0, name), name, t0)
    complex_ok = False
    try:
        z = f(complex(t0, _H1))
        complex_ok = isinstance(z, complex) or getattr(getattr(z, "dtype", None), "kind", "") == "c"
    except Exception:  # noqa: BLE001 - any failure means: no complex step
        complex_ok = False

    if complex_ok:

        def by_complex_step(t: float) -> tuple[float, float, float]:
            v = complex(f(complex(t, _H1)))
            z1 = complex(f(t + _H2 * _W))
            z2 = complex(f(t - _H2 * _W))
            value = v.real
            if not math.isfinite(value):
                raise ValueError(f"{name}: expected a finite value at t={t:g}, got {value!r}")
            return value, v.imag / _H1, (z1.imag + z2.imag) / (_H2 * _H2)

        return by_complex_step, "complex step"

    def by_differences(t: float) -> tuple[float, float, float]:
        f0 = _real(f(t), name, t)
        h1 = 1e-6 * (1.0 + abs(t))
        h2 = 1e-4 * (1.0 + abs(t))
        d1 = (_real(f(t + h1), name, t) - _real(f(t - h1), name, t)) / (2.0 * h1)
        d2 = (_real(f(t + h2), name, t) - 2.0 * f0 + _real(f(t - h2), name, t)) / (h2 * h2)
        return f0, d1, d2

    return by_differences, "finite differences"


def _call(g: Callable, t: float, name: str) -> Any:
    try:
        return g(t)
    except Exception as exc:  # noqa: BLE001 - reported with the argument's name
        raise ValueError(f"{name}: the function raised {type(exc).__name__} at t={t:g}: {exc}") from exc
