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

Every value a law returns at a real time must be a finite real number (a
complex type with a zero imaginary part, as ``cmath.sin`` returns, counts as
real): ``f(t)`` is taken at every evaluation, also with complex steps, and
a complex value (``(1 + 1j) t``, ``cmath.sqrt(0.05 - t)`` past 0.05 s) is
refused, with a ValueError naming the motor and ``t``, where the motor is
added (at its current time) and at the first evaluation that meets it. A law
that is complex on the real axis made the complex step report its imaginary
part divided by ``1e-30``: rates of 1e29 rad/s.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from rigidlab.core._validation import short_repr

_H1 = 1e-30
_H2 = 1e-4
_W = cmath.exp(0.25j * math.pi)


def _real(value: Any, name: str, t: float) -> float:
    """``value`` (a law's value at the real time ``t``) as a finite float; a complex number with a nonzero
    imaginary part is refused like any other value that is not a real number."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}: expected the function to return a real number, got {short_repr(value)}")
    try:
        v = complex(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected the function to return a real number, got {short_repr(value)}") from None
    if v.imag != 0.0:
        raise ValueError(f"{name}: expected a real number at t={t:g}, got the complex number {v!r} (a motor law "
                         "must be real for real times)")
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
        or ``f(t0)`` (or a derivative at ``t0``) is not a finite real number
        (a complex value included); ``name`` begins the message. The
        returned ``values`` raises the same for a later ``t``.
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
            value = _real(f(t), name, t)  # (the steps below cannot tell an imaginary part of f(t) from f_dot)
            v = complex(f(complex(t, _H1)))
            z1 = complex(f(t + _H2 * _W))
            z2 = complex(f(t - _H2 * _W))
            rate, acceleration = v.imag / _H1, (z1.imag + z2.imag) / (_H2 * _H2)
            if not (math.isfinite(rate) and math.isfinite(acceleration)):
                raise ValueError(f"{name}: expected finite complex-step derivatives at t={t:g}, got f_dot={rate!r}, "
                                 f"f_ddot={acceleration!r}")
            return value, rate, acceleration

        _first(by_complex_step, t0, name)
        return by_complex_step, "complex step"

    def by_differences(t: float) -> tuple[float, float, float]:
        f0 = _real(f(t), name, t)
        h1 = 1e-6 * (1.0 + abs(t))
        h2 = 1e-4 * (1.0 + abs(t))
        d1 = (_real(f(t + h1), name, t) - _real(f(t - h1), name, t)) / (2.0 * h1)
        d2 = (_real(f(t + h2), name, t) - 2.0 * f0 + _real(f(t - h2), name, t)) / (h2 * h2)
        return f0, d1, d2

    _first(by_differences, t0, name)
    return by_differences, "finite differences"


def _first(values: Callable[[float], tuple[float, float, float]], t0: float, name: str) -> None:
    """Evaluate a motor's ``values`` once at ``t0`` (where it is added): its errors are reported there."""
    try:
        values(t0)
    except ValueError:
        raise
    except Exception as exc:  # noqa: BLE001 - reported with the argument's name
        raise ValueError(f"{name}: the function raised {type(exc).__name__} near t={t0:g}: {exc}") from exc


def _call(g: Callable, t: float, name: str) -> Any:
    try:
        return g(t)
    except Exception as exc:  # noqa: BLE001 - reported with the argument's name
        raise ValueError(f"{name}: the function raised {type(exc).__name__} at t={t:g}: {exc}") from exc


class ScaledLaw:
    """A motor law's ``values`` times a constant (a law given in degrees, read in radians)."""

    def __init__(self, values: Callable[[float], tuple[float, float, float]], factor: float):
        self.values, self.factor = values, factor

    def __call__(self, t: float) -> tuple[float, float, float]:
        f, f_dot, f_ddot = self.values(t)
        k = self.factor
        return (f * k, f_dot * k, f_ddot * k)
