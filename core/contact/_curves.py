"""Planar curves for curve-on-curve contact (a planar cam and its follower).

Two extruded profiles touch along a line: the rank condition of Eq. 8.109
fails for them as surfaces. The chapter's remedy for a planar mechanism is
to describe each profile by its curve in the plane of motion, with one
parameter per body: the contact is then two point-coincidence equations in
the plane and one parallel-normal equation, with two surface parameters
(``C_s`` is 3 x 2 and leaves one independent multiplier, the normal force).

A :class:`PlanarCurve` lies in its body's ``x-y`` plane (body ``z = 0``);
its parameter ``s`` is a scalar. The tangent is ``c'(s)``, the outward
normal ``c'(s) x e_z`` (to the right of the direction of travel: outward
for a closed curve run counter-clockwise about body z).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from rigidlab.core._validation import float_array, short_repr

from ._surfaces import Surface, _call_user, _call_user_tensor, _ContourDerivatives, _positive, _trig_cycle

__all__ = ["PlanarCurve"]

_HALF_PI = 0.5 * math.pi


def _vector2(x: Any, name: str) -> np.ndarray:
    a = float_array(x, name, expected="a (2,) vector of real numbers", copy=True)
    if a.shape != (2,):
        raise ValueError(f"{name}: expected shape (2,), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    return a


class PlanarCurve(Surface):
    """A curve ``c(s) = (x(s), y(s))`` in its body's x-y plane, for curve-on-curve contact.

    Build one with :meth:`polar` (a cam profile ``r(phi)``), :meth:`circle`
    (a roller), :meth:`line` (a flat follower face) or the constructor (any
    parametric curve). Public methods take parameters of shape ``(...,)``
    or ``(..., 1)`` (a trailing axis of length 1 is the parameter axis) and
    return body-frame arrays: ``u (..., 3)`` (``z =
    0``), derivatives ``(..., 3, 1)``, ``(..., 3, 1, 1)``, ``(..., 3, 1, 1,
    1)``.

    Parameters
    ----------
    point : callable
        ``point(s) -> (..., 2)`` for parameters of any shape ``(...)``.
    first, second, third : callable or None, keyword-only
        ``c'(s)``, ``c''(s)``, ``c'''(s)``, each ``(..., 2)``. The missing
        ones come from complex steps of ``point`` on a circle (Cauchy's
        integral formula, radius 0.05, 12 points): ``point`` must then
        accept complex arrays.
    bounds : (s_min, s_max), keyword-only
        Parameter range searched for the initial contact point.
    length_scale : float or None, keyword-only
        A characteristic size (m); default the extent of the sampled curve.
    """

    n_parameters = 1

    def __init__(self, point: Callable, *, first: Callable | None = None, second: Callable | None = None,
                 third: Callable | None = None, bounds: Any, length_scale: float | None = None):
        for f, name in ((point, "point"), (first, "first"), (second, "second"), (third, "third")):
            if (f is not None or name == "point") and not callable(f):
                raise ValueError(f"{name}: expected a callable, got {short_repr(f)}")
        b = float_array(bounds, "bounds", expected="(s_min, s_max)")
        if b.shape != (2,) or not np.all(np.isfinite(b)) or not b[1] > b[0]:
            raise ValueError(f"bounds: expected (s_min, s_max) with s_min < s_max, got {short_repr(bounds)}")
        given = (first, second, third)
        contour = _ContourDerivatives(point, 1, 2) if any(g is None for g in given) else None

        def derivs(s: np.ndarray, order: int) -> list[np.ndarray]:
            out = [np.array(_call_user(point, s, "point", 2, s.shape))]
            need = [k for k in range(1, order + 1) if given[k - 1] is None]
            cont = contour(s[..., None], max(need), "point") if need else {}
            for k in range(1, order + 1):
                f = given[k - 1]
                if f is not None:
                    out.append(_call_user_tensor(f, s, ("first", "second", "third")[k - 1], s.shape + (2,)))
                else:
                    out.append(cont[(k,)])
            return out

        names = ("point", "first", "second", "third")

        def derivs_float(x: float, order: int) -> list[tuple[float, float]]:
            # one point: the user's functions on a float (shapes were checked at construction)
            if any(given[k - 1] is None for k in range(1, order + 1)):
                return [tuple(v) for v in np.asarray(derivs(np.array(x), order)).reshape(order + 1, 2).tolist()]
            out = []
            for k, f in enumerate((point,) + given[:order]):
                try:
                    v = f(x)
                    if type(v) is np.ndarray and v.shape == (2,) and v.dtype == np.float64:
                        a, b_ = v.tolist()  # (the common case, without a conversion)
                    else:
                        a, b_ = np.asarray(v, dtype=float).reshape(2).tolist()
                except Exception as exc:  # noqa: BLE001 - reported with the argument's name
                    raise ValueError(f"{names[k]}: the function failed at s={x!r}: {type(exc).__name__}: {exc}") from exc
                if not (math.isfinite(a) and math.isfinite(b_)):
                    raise ValueError(f"{names[k]}: expected finite values at s={x!r}, got {(a, b_)}")
                out.append((a, b_))
            return out

        if contour is not None:
            contour.check_analytic(np.linspace(b[0], b[1], 7)[:, None], "point")
        self._init(derivs, np.linspace(b[0], b[1], 721), length_scale, "PlanarCurve(...)")
        self._derivs_2d = derivs_float

    # ------------------------------------------------------------ constructors
    @classmethod
    def polar(cls, radius: Callable, *, first: Callable | None = None, second: Callable | None = None,
              third: Callable | None = None) -> PlanarCurve:
        """A closed curve ``c(phi) = r(phi) (cos phi, sin phi)`` about the body origin (a cam profile).

        ``phi`` is the polar angle from body x towards body y (rad); the
        curve is run counter-clockwise, so its normal ``c' x e_z`` points
        outward. ``r`` must be positive.

        Parameters
        ----------
        radius : callable
            ``r(phi)`` (m) for arrays ``phi`` of any shape.
        first, second, third : callable or None, keyword-only
            ``r'``, ``r''``, ``r'''``; the missing ones by complex steps of
            ``r`` (which must then accept complex arrays).

        Raises
        ------
        ValueError
            For callables that fail or return non-finite values, or a
            radius that is not positive over a revolution.
        """
        for f, name in ((radius, "radius"), (first, "first"), (second, "second"), (third, "third")):
            if (f is not None or name == "radius") and not callable(f):
                raise ValueError(f"{name}: expected a callable, got {short_repr(f)}")
        given = (first, second, third)

        def scalar(f, s, name):
            return np.array(_call_user(lambda x: np.asarray(f(x))[..., None], s, name, 1, s.shape)[..., 0])

        contour = _ContourDerivatives(lambda z: np.broadcast_to(np.asarray(radius(z)), np.shape(z))[..., None], 1, 1)

        def derivs(s: np.ndarray, order: int) -> list[np.ndarray]:
            r = [scalar(radius, s, "radius")]
            need = [k for k in range(1, order + 1) if given[k - 1] is None]
            cont = contour(s[..., None], max(need), "radius") if need else {}
            for k in range(1, order + 1):
                f = given[k - 1]
                r.append(scalar(f, s, ("first", "second", "third")[k - 1]) if f is not None else cont[(k,)][..., 0])
            out = []
            for k in range(order + 1):
                acc = np.zeros(s.shape + (2,))
                for j in range(k + 1):
                    a = (k - j) * _HALF_PI
                    e = np.stack([np.cos(s + a), np.sin(s + a)], axis=-1)
                    acc += math.comb(k, j) * r[j][..., None] * e
                out.append(acc)
            return out

        def derivs_float(x: float, order: int) -> list[tuple[float, float]]:
            need = [k for k in range(1, order + 1) if given[k - 1] is None]
            if need:  # complex steps: the array path
                return [tuple(v) for v in np.asarray(derivs(np.array(x), order)).tolist()]
            r = [float(radius(x))] + [float(given[k - 1](x)) for k in range(1, order + 1)]
            c, s = _trig_cycle(x)
            out = []
            for k in range(order + 1):
                ax = ay = 0.0
                for j in range(k + 1):
                    w = math.comb(k, j) * r[j]
                    ax += w * c[k - j]
                    ay += w * s[k - j]
                out.append((ax, ay))
            return out

        curve = cls.__new__(cls)
        phi = np.linspace(-math.pi, math.pi, 721)
        r0 = scalar(radius, phi, "radius")
        if not np.all(r0 > 0.0):
            k = int(np.argmin(r0))
            raise ValueError(f"radius: expected r(phi) > 0 over a revolution, got r({phi[k]:.4g}) = {r0[k]!r}")
        if any(g is None for g in given):
            contour.check_analytic(phi[::120, None], "radius")
        curve._init(derivs, phi, None, "PlanarCurve.polar(...)")
        curve._derivs_2d = derivs_float
        return curve

    @classmethod
    def circle(cls, radius: float, *, center: Any = (0.0, 0.0)) -> PlanarCurve:
        """A circle ``c(phi) = center + radius (cos phi, sin phi)`` (a roller), run counter-clockwise.

        Parameters
        ----------
        radius : float
            m, > 0.
        center : (2,), keyword-only
            Centre in the body's x-y plane (m).
        """
        rho = _positive(radius, "radius")
        c0 = _vector2(center, "center")

        def derivs(s: np.ndarray, order: int) -> list[np.ndarray]:
            out = []
            for k in range(order + 1):
                a = k * _HALF_PI
                v = rho * np.stack([np.cos(s + a), np.sin(s + a)], axis=-1)
                out.append(v + c0 if k == 0 else v)
            return out

        cx, cy = float(c0[0]), float(c0[1])

        def derivs_float(x: float, order: int) -> list[tuple[float, float]]:
            c, s = _trig_cycle(x)
            out = [(cx + rho * c[0], cy + rho * s[0])]
            for k in range(1, order + 1):
                out.append((rho * c[k], rho * s[k]))
            return out

        curve = cls.__new__(cls)
        curve._init(derivs, np.linspace(-math.pi, math.pi, 721), rho, f"PlanarCurve.circle({rho!r})")
        curve._derivs_2d = derivs_float
        curve.radius = rho
        curve._centre2 = c0
        curve._builtin = ("circle", cx, cy, rho)  # (the compiled contact kernel's closed form)
        return curve

    @classmethod
    def line(cls, *, point: Any = (0.0, 0.0), normal: Any = (0.0, 1.0)) -> PlanarCurve:
        """A straight line through ``point`` with outward normal ``normal`` (a flat follower face).

        ``c(s) = point + s d`` with ``d = e_z x normal`` (unit), so that ``d x
        e_z = normal``; ``s`` is the arc length (m).

        Parameters
        ----------
        point : (2,), keyword-only
            A point of the line in the body's x-y plane (m).
        normal : (2,), keyword-only
            Outward normal in the plane (any nonzero length).
        """
        p0 = _vector2(point, "point")
        n = _vector2(normal, "normal")
        norm = float(np.hypot(n[0], n[1]))
        if norm == 0.0:
            raise ValueError(f"normal: expected a nonzero vector, got {n.tolist()}")
        n = n / norm
        d = np.array([-n[1], n[0]])  # e_z x n

        def derivs(s: np.ndarray, order: int) -> list[np.ndarray]:
            out = [p0 + s[..., None] * d]
            for k in range(1, order + 1):
                out.append(np.broadcast_to(d if k == 1 else np.zeros(2), s.shape + (2,)).copy())
            return out

        px, py, dx, dy = float(p0[0]), float(p0[1]), float(d[0]), float(d[1])

        def derivs_float(x: float, order: int) -> list[tuple[float, float]]:
            out = [(px + x * dx, py + x * dy)]
            if order >= 1:
                out.append((dx, dy))
            out += [(0.0, 0.0)] * (order - 1)
            return out

        curve = cls.__new__(cls)
        curve._init(derivs, np.zeros(1), math.inf, f"PlanarCurve.line(point={p0.tolist()}, normal={n.tolist()})")
        curve._derivs_2d = derivs_float
        curve.unbounded = True
        curve.origin2 = p0
        curve.direction2 = d
        curve._builtin = ("line", px, py, dx, dy)  # (the compiled contact kernel's closed form)
        return curve

    # ------------------------------------------------------------ internals
    def _init(self, derivs, samples: np.ndarray, length_scale, label: str) -> None:
        self._derivs = derivs
        self._label = label
        self._grid = np.asarray(samples, dtype=float).reshape(-1, 1)
        c = derivs(self._grid[:, 0], 3)  # checks shapes and finiteness once
        for k, v in enumerate(c):
            if v.shape != (self._grid.shape[0], 2):
                raise ValueError(f"{label}: derivative {k} has shape {v.shape}, expected (k, 2)")
        if length_scale is None:
            ext = float(np.max(np.ptp(c[0], axis=0)))
            self.length_scale = ext if ext > 0 else 1.0
        else:
            self.length_scale = float(length_scale)
        self.unbounded = False

    def __repr__(self) -> str:
        return self._label

    def _geometry(self, s, order, chart):
        x = s[..., 0]
        c = self._derivs(x, max(order, 0))
        zero = np.zeros(x.shape + (1,))

        def lift(v):
            return np.concatenate([v, zero], axis=-1)

        u = lift(c[0])
        if order < 1:
            return (u, None, None, None, None, None, None)
        U1 = lift(c[1])[..., None]
        U2 = lift(c[2])[..., None, None] if order >= 2 else None
        U3 = lift(c[3])[..., None, None, None] if order >= 3 else None

        def right(v):  # v x e_z = (v_y, -v_x, 0)
            return np.concatenate([v[..., 1:2], -v[..., 0:1], zero], axis=-1)

        nu = right(c[1])
        N1 = right(c[2])[..., None] if order >= 2 else None
        N2 = right(c[3])[..., None, None] if order >= 3 else None
        return (u, U1, U2, U3, nu, N1, N2)

    def _derivs_float(self, s, order, chart):
        c = self._derivs_2d(s[0], order)
        D = {(k,): (v[0], v[1], 0.0) for k, v in enumerate(c)}
        Dn = {(k - 1,): (v[1], -v[0], 0.0) for k, v in enumerate(c) if k >= 1}  # c^(k) x e_z
        return D, (Dn if order >= 1 else None)

    def parameters(self, u_body: Any) -> np.ndarray:
        """(..., 1) parameter of the nearest point of a line, or the polar angle for other curves."""
        u = float_array(u_body, "u_body")
        if u.ndim == 0 or u.shape[-1] != 3:
            raise ValueError(f"u_body: expected points of shape (..., 3), got {u.shape}")
        if self.unbounded:
            return ((u[..., :2] - self.origin2) @ self.direction2)[..., None]
        c0 = getattr(self, "_centre2", np.zeros(2))
        return np.arctan2(u[..., 1] - c0[1], u[..., 0] - c0[0])[..., None]

    def _samples(self):
        return self._grid
