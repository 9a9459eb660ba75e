"""Contact surfaces in a body frame: ``u(s1, s2)`` with analytic derivatives (Eqs. 8.84-8.89).

A surface is given in the frame of the body that carries it by two surface
parameters ``s = (s1, s2)``; its global position is ``r = R + A(p) u(s)``
(Eq. 8.84). The tangents are ``t_k = A du/ds_k`` (Eq. 8.85), the outward
normal ``n = t1 x t2`` (Eq. 8.86). The contact constraints (Eqs.
8.90-8.94) contain ``u`` and the tangents; their Jacobian with respect to
the surface parameters (``C_s``, Eq. 8.97) contains second derivatives and
the acceleration terms (Eqs. 8.98-8.104) third derivatives of ``u``
(Eqs. 8.87-8.89). Every surface here gives them in closed form.

Shapes: parameters ``s`` are ``(..., 2)``; ``u`` is ``(..., 3)``,
``du/ds`` ``(..., 3, 2)`` (column k: the derivative with respect to
``s_k``), second derivatives ``(..., 3, 2, 2)`` and third ``(..., 3, 2, 2,
2)`` (symmetric in the parameter indices). All lengths in metres, angles in
radians, all vectors in the body frame.

The *normal field* ``nu(s)`` used in the constraints is ``du/ds1 x du/ds2``
(not normalized, Eq. 8.86) except for the torus, whose unit normal
``cos(psi) e_r + sin(psi) e_y`` stays defined when the minor radius is zero
(the rim of a thin disk: the point then does not depend on ``psi`` and
``psi`` turns the normal about the rim's tangent).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from itertools import product
from typing import Any

import numpy as np

from rigidlab.core._validation import float_array, real_number, short_repr

__all__ = ["Ellipsoid", "ParametricSurface", "Plane", "Sphere", "Surface", "Torus"]

_HALF_PI = 0.5 * math.pi


# ------------------------------------------------------------------ helpers
def _positive(x: Any, name: str, *, allow_zero: bool = False) -> float:
    bound = ">= 0" if allow_zero else "> 0"
    v = real_number(x, name, expected=f"a finite length {bound} (m)")
    if v < 0.0 or (v == 0.0 and not allow_zero):
        raise ValueError(f"{name}: expected a finite length {bound} (m), got {v!r}")
    return v


def _vector3(x: Any, name: str) -> np.ndarray:
    a = float_array(x, name, expected="a (3,) vector of real numbers", copy=True)
    if a.shape != (3,):
        raise ValueError(f"{name}: expected shape (3,), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    a.setflags(write=False)
    return a


def _unit3(x: Any, name: str) -> np.ndarray:
    a = np.array(_vector3(x, name))
    big = float(np.max(np.abs(a)))
    if big == 0.0:
        raise ValueError(f"{name}: expected a nonzero vector, got {a.tolist()}")
    a = a / big
    a = a / float(np.linalg.norm(a))
    a.setflags(write=False)
    return a


def _parameters(s: Any, p: int, name: str = "s") -> np.ndarray:
    a = float_array(s, name, expected=f"surface parameters (..., {p}) of real numbers")
    if p == 1 and (a.ndim == 0 or a.shape[-1] != 1):
        a = a[..., None]
    if a.ndim == 0 or a.shape[-1] != p:
        raise ValueError(f"{name}: expected parameters of shape (..., {p}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite parameters")
    return a


def _index_orders(p: int, k: int) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """Index tuples of the k-th derivative and their orders per parameter."""
    out = []
    for idx in product(range(p), repeat=k):
        out.append((idx, tuple(idx.count(q) for q in range(p))))
    return out


def _assemble(D: Callable[[tuple[int, ...]], np.ndarray], p: int, order: int, shape: tuple[int, ...]):
    """Derivative tensors (..., 3, p, ..., p) of orders 1..order from ``D(orders) -> (..., 3)``."""
    cache: dict[tuple[int, ...], np.ndarray] = {}

    def get(orders):
        if orders not in cache:
            cache[orders] = D(orders)
        return cache[orders]

    out = []
    for k in range(1, order + 1):
        T = np.empty(shape + (3,) + (p,) * k)
        for idx, orders in _index_orders(p, k):
            T[(...,) + (slice(None),) + idx] = get(orders)
        out.append(T)
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over axis -1 of (..., 3) arrays."""
    return np.stack(
        [a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
         a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
         a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def normal_from_tangents(U1: np.ndarray, U2: np.ndarray, U3: np.ndarray | None, order: int):
    """``nu = u_s1 x u_s2`` (Eq. 8.86) and its derivatives by the product rule.

    Parameters
    ----------
    U1 : (..., 3, 2); U2 : (..., 3, 2, 2); U3 : (..., 3, 2, 2, 2) or None
    order : 0, 1 or 2 (needs U3)

    Returns
    -------
    nu (..., 3), nu_s (..., 3, 2) or None, nu_ss (..., 3, 2, 2) or None
    """
    t1, t2 = U1[..., :, 0], U1[..., :, 1]
    nu = _cross(t1, t2)
    if order < 1:
        return nu, None, None
    N1 = np.empty(U1.shape)
    for l in range(2):
        N1[..., :, l] = _cross(U2[..., :, 0, l], t2) + _cross(t1, U2[..., :, 1, l])
    if order < 2:
        return nu, N1, None
    N2 = np.empty(U2.shape)
    for l in range(2):
        for m in range(2):
            N2[..., :, l, m] = (_cross(U3[..., :, 0, l, m], t2) + _cross(U2[..., :, 0, l], U2[..., :, 1, m])
                                + _cross(U2[..., :, 0, m], U2[..., :, 1, l]) + _cross(t1, U3[..., :, 1, l, m]))
    return nu, N1, N2


# ------------------------------------------------------------------ base
class Surface:
    """A contact surface in a body frame: two parameters ``s = (s1, s2)``.

    Subclasses give ``u(s)`` and its derivatives in closed form. Public
    methods take parameters of shape ``(..., 2)`` and return arrays with
    the same leading shape.

    Attributes
    ----------
    n_parameters : int
        2 for surfaces (1 for :class:`~rigidlab.core.contact.PlanarCurve`).
    length_scale : float
        A characteristic length of the surface (m; ``inf`` for a plane):
        the scale of the rank test of Eq. 8.109 and of the contact search.
    """

    n_parameters = 2
    length_scale = math.inf
    #: True when the tangents vanish (the zero-tube torus, a rim): such a
    #: surface supplies the normal of the contact and the other one the tangents.
    degenerate_tangents = False
    #: True when the surface is followed in local charts (sphere, ellipsoid).
    charted = False
    #: True for the unbounded plane (the contact search projects onto it).
    unbounded = False

    def _shape_key(self) -> Any:
        """What makes two surfaces of a body the same: their kind and dimensions for the closed forms
        (``System.add_contact`` refuses a second contact between the same two surfaces); the surface
        itself for user functions, which cannot be compared."""
        return self

    # -- public
    def derivatives(self, s: Any, *, order: int = 3) -> tuple[np.ndarray, ...]:
        """``u`` and its derivatives with respect to the surface parameters (Eqs. 8.84-8.89).

        Parameters
        ----------
        s : (..., 2) array_like
            Surface parameters.
        order : int, keyword-only
            Highest derivative, 0 to 3.

        Returns
        -------
        tuple
            ``(u (..., 3), u_s (..., 3, 2), u_ss (..., 3, 2, 2), u_sss (...,
            3, 2, 2, 2))`` up to ``order``; body frame.
        """
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order not in (0, 1, 2, 3):
            raise ValueError(f"order: expected 0, 1, 2 or 3, got {short_repr(order)}")
        s = _parameters(s, self.n_parameters)
        g = self._geometry(s, order, None)
        return (g[0], *g[1 : 1 + order])

    def point(self, s: Any) -> np.ndarray:
        """(..., 3) the point ``u(s)``, body frame (m)."""
        return self.derivatives(s, order=0)[0]

    def tangents(self, s: Any) -> np.ndarray:
        """(..., 3, 2) the tangents ``du/ds1, du/ds2`` (columns), body frame (Eq. 8.85)."""
        return self.derivatives(s, order=1)[1]

    def normal(self, s: Any) -> np.ndarray:
        """(..., 3) the unit outward normal, body frame (Eq. 8.86)."""
        s = _parameters(s, self.n_parameters)
        nu = self._geometry(s, 1, None)[4]
        norm = np.linalg.norm(nu, axis=-1, keepdims=True)
        if np.any(norm == 0.0):
            raise ValueError(f"s: the normal of {self!r} is undefined at a singular point of its parametrization")
        return nu / norm

    def normal_field(self, s: Any, *, order: int = 2) -> tuple[np.ndarray, ...]:
        """The normal field used in the contact constraints and its derivatives.

        ``nu = du/ds1 x du/ds2`` (Eq. 8.86, not normalized) except for the
        torus (unit normal). Returns ``(nu (..., 3), nu_s (..., 3, 2),
        nu_ss (..., 3, 2, 2))`` up to ``order`` (0 to 2), body frame.
        """
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order not in (0, 1, 2):
            raise ValueError(f"order: expected 0, 1 or 2, got {short_repr(order)}")
        s = _parameters(s, self.n_parameters)
        g = self._geometry(s, order + 1 if order else 0, None)
        return (g[4], *g[5 : 5 + order])

    def parameters(self, u_body: Any) -> np.ndarray:
        """(..., 2) parameters of the point of the surface nearest to body-frame points (m).

        Exact for the plane, sphere and torus; for the ellipsoid the point
        with the same direction from the centre after scaling by the axes.
        Where many points are equally near (the centre of a sphere or an
        ellipsoid, a point of a torus's axis), one of them: longitude 0 (at
        a sphere's or an ellipsoid's centre, latitude 0 too).
        """
        raise NotImplementedError(f"{type(self).__name__} has no inverse map")

    # -- internal
    def _geometry(self, s: np.ndarray, order: int, chart: Any):
        """``(u, U1, U2, U3, nu, N1, N2)`` at ``s`` (..., p); entries above ``order`` are None.

        The normal field's derivatives go one order lower than ``order``
        (``N1`` needs ``order >= 2`` and ``N2`` needs ``order >= 3``).
        """
        raise NotImplementedError

    def _samples(self) -> np.ndarray:
        """(k, p) parameters covering the surface, for the contact search."""
        raise NotImplementedError

    def _derivs_float(self, s: tuple, order: int, chart: Any):
        """Derivatives at one point on Python floats: ``(D, Dn)``.

        ``D[(a, b)]`` is the body-frame 3-tuple ``d^(a+b) u / ds1^a ds2^b``
        (curves: ``D[(k,)]``) for every order up to ``order``; ``Dn`` the
        same for the normal field up to ``order - 1``, or None when the
        normal field is ``du/ds1 x du/ds2`` (the kernel then forms it from
        the rotated tangents). This default converts :meth:`_geometry`.
        """
        g = self._geometry(np.array(s, dtype=float), order, chart)
        return _dicts_from_arrays(g, self.n_parameters, order)

    def _chart_parameters(self, s: np.ndarray, chart: Any) -> np.ndarray:
        """Canonical parameters of the chart parameters ``s`` (identity for surfaces without charts)."""
        return np.array(s, dtype=float)

    def _new_chart(self, s: np.ndarray, chart: Any):
        """A chart centred on the point ``s`` of ``chart``: ``(chart', s')``."""
        return chart, s

    def _default_chart(self, s: np.ndarray):
        """The chart and local parameters to start following the surface at canonical ``s``."""
        return None, np.array(s, dtype=float)


def _with_normal(u, U, order):
    """Complete ``(u, U1, U2, U3)`` with the product-rule normal field up to ``order - 1``."""
    U1 = U[0] if order >= 1 else None
    U2 = U[1] if order >= 2 else None
    U3 = U[2] if order >= 3 else None
    if U1 is None:
        return (u, None, None, None, None, None, None)
    nu, N1, N2 = normal_from_tangents(U1, U2, U3, min(order - 1, 2))
    return (u, U1, U2, U3, nu, N1, N2)


def _dicts_from_arrays(g, p: int, order: int):
    """``(D, Dn)`` dictionaries of :meth:`Surface._derivs_float` from one point's ``_geometry`` arrays."""
    D = {(0,) * p: tuple(g[0].tolist())}
    Dn = {}
    if order >= 1:
        Dn[(0,) * p] = tuple(g[4].tolist())
    for k in range(1, order + 1):
        T = g[k]
        for idx, orders in _index_orders(p, k):
            if orders not in D:
                D[orders] = tuple(T[(slice(None),) + idx].tolist())
        if k < order:
            Tn = g[4 + k]
            for idx, orders in _index_orders(p, k):
                if orders not in Dn:
                    Dn[orders] = tuple(Tn[(slice(None),) + idx].tolist())
    return D, (Dn if order >= 1 else None)


def _trig_cycle(x: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``cos(x + k pi/2)`` and ``sin(x + k pi/2)`` for k = 0..3."""
    c, s = math.cos(x), math.sin(x)
    return (c, -s, -c, s), (s, c, -s, -c)


def _orders2(order: int) -> list[tuple[int, int]]:
    return [(a, k - a) for k in range(order + 1) for a in range(k, -1, -1)]


# ------------------------------------------------------------------ plane
class Plane(Surface):
    """A plane of the body: by default the body's ``z = 0`` plane with outward normal +z.

    ``u(s) = point + s1 e1 + s2 e2`` with ``e1 x e2 = normal`` (for the
    default: ``e1 = x``, ``e2 = y``), so the parameters are coordinates in
    the plane (m). Its normal points out of the body (for the ground: up).

    Parameters
    ----------
    point : (3,), keyword-only
        A point of the plane, body frame (m); default the origin.
    normal : (3,), keyword-only
        Outward normal, body frame (any nonzero length); default ``(0, 0, 1)``.

    Raises
    ------
    ValueError
        For a non-finite point or a zero normal.
    """

    unbounded = True

    def __init__(self, *, point: Any = (0.0, 0.0, 0.0), normal: Any = (0.0, 0.0, 1.0)):
        self.origin = _vector3(point, "point")
        n = np.array(_unit3(normal, "normal"))
        # e1: body x made perpendicular to the normal (body y when the normal is along x)
        e1 = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = e1 - (e1 @ n) * n
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)  # e1 x e2 = n
        self.unit_normal = n
        self.axes = np.stack([e1, e2], axis=1)  # (3, 2)
        for a in (self.unit_normal, self.axes):
            a.setflags(write=False)

    def __repr__(self) -> str:
        return f"Plane(point={self.origin.tolist()}, normal={self.unit_normal.tolist()})"

    def _shape_key(self) -> Any:
        """The plane's normal and its distance from the body origin (any point on it gives the same plane)."""
        return ("plane", tuple(self.unit_normal.tolist()), float(self.origin @ self.unit_normal))

    def _geometry(self, s, order, chart):
        shape = s.shape[:-1]
        u = self.origin + s @ self.axes.T
        if order < 1:
            return (u, None, None, None, None, None, None)
        U1 = np.broadcast_to(self.axes, shape + (3, 2))
        U2 = np.zeros(shape + (3, 2, 2)) if order >= 2 else None
        U3 = np.zeros(shape + (3, 2, 2, 2)) if order >= 3 else None
        nu = np.broadcast_to(self.unit_normal, shape + (3,))
        N1 = np.zeros(shape + (3, 2)) if order >= 2 else None
        N2 = np.zeros(shape + (3, 2, 2)) if order >= 3 else None
        return (u, U1, U2, U3, nu, N1, N2)

    def parameters(self, u_body):
        u = float_array(u_body, "u_body")
        if u.ndim == 0 or u.shape[-1] != 3:
            raise ValueError(f"u_body: expected points of shape (..., 3), got {u.shape}")
        return (u - self.origin) @ self.axes

    def _samples(self):
        return np.zeros((1, 2))

    def _derivs_float(self, s, order, chart):
        o, e1, e2 = self._float
        s1, s2 = s
        D = {(0, 0): (o[0] + s1 * e1[0] + s2 * e2[0], o[1] + s1 * e1[1] + s2 * e2[1], o[2] + s1 * e1[2] + s2 * e2[2])}
        if order >= 1:
            D[(1, 0)] = e1
            D[(0, 1)] = e2
            zero = (0.0, 0.0, 0.0)
            for ab in _orders2(order):
                if ab[0] + ab[1] >= 2:
                    D[ab] = zero
        return D, None

    @property
    def _float(self):
        return (tuple(self.origin.tolist()), tuple(self.axes[:, 0].tolist()), tuple(self.axes[:, 1].tolist()))


# ------------------------------------------------------------------ sphere & ellipsoid
def _unit_sphere_derivative(s1: np.ndarray, s2: np.ndarray, a: int, b: int) -> np.ndarray:
    """``d^a/ds1^a d^b/ds2^b e0``, ``e0 = (cos s2 cos s1, cos s2 sin s1, sin s2)``."""
    c2 = np.cos(s2 + b * _HALF_PI)
    z = np.sin(s2 + b * _HALF_PI) if a == 0 else np.zeros_like(s2)
    return np.stack([c2 * np.cos(s1 + a * _HALF_PI), c2 * np.sin(s1 + a * _HALF_PI), z], axis=-1)


class _Quadric(Surface):
    """Linear image ``u = centre + S Q e0(s)`` of the unit sphere (S diagonal, Q a chart rotation)."""

    charted = True
    _S: np.ndarray
    centre: np.ndarray

    def _geometry(self, s, order, chart):
        s1, s2 = s[..., 0], s[..., 1]
        M = self._S[:, None] * (np.eye(3) if chart is None else chart)  # S Q

        def D(orders):
            return _unit_sphere_derivative(s1, s2, orders[0], orders[1]) @ M.T

        u = self.centre + D((0, 0))
        if order < 1:
            return (u, None, None, None, None, None, None)
        U = _assemble(D, 2, order, s.shape[:-1])
        return _with_normal(u, U, order)

    def parameters(self, u_body):
        u = float_array(u_body, "u_body")
        if u.ndim == 0 or u.shape[-1] != 3:
            raise ValueError(f"u_body: expected points of shape (..., 3), got {u.shape}")
        e = (u - self.centre) / self._S
        r = np.linalg.norm(e, axis=-1)
        r = np.where(r > 0.0, r, 1.0)
        return np.stack([np.arctan2(e[..., 1], e[..., 0]), np.arcsin(np.clip(e[..., 2] / r, -1.0, 1.0))], axis=-1)

    def _derivs_float(self, s, order, chart):
        (c1, s1), (c2, s2) = _trig_cycle(s[0]), _trig_cycle(s[1])
        Sx, Sy, Sz = self._S_float
        if chart is None:
            M = ((Sx, 0.0, 0.0), (0.0, Sy, 0.0), (0.0, 0.0, Sz))
        else:
            q = chart
            M = ((Sx * q[0, 0], Sx * q[0, 1], Sx * q[0, 2]), (Sy * q[1, 0], Sy * q[1, 1], Sy * q[1, 2]),
                 (Sz * q[2, 0], Sz * q[2, 1], Sz * q[2, 2]))
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = M
        D = {}
        for a, b in _orders2(order):
            x, y = c2[b] * c1[a], c2[b] * s1[a]
            z = s2[b] if a == 0 else 0.0
            D[(a, b)] = (m00 * x + m01 * y + m02 * z, m10 * x + m11 * y + m12 * z, m20 * x + m21 * y + m22 * z)
        cx, cy, cz = self._centre_float
        u = D[(0, 0)]
        D[(0, 0)] = (u[0] + cx, u[1] + cy, u[2] + cz)
        return D, None

    def _samples(self):
        lon = np.linspace(-math.pi, math.pi, 24, endpoint=False)
        lat = np.linspace(-_HALF_PI, _HALF_PI, 13)
        g = np.stack(np.meshgrid(lon, lat, indexing="ij"), axis=-1).reshape(-1, 2)
        return g

    # charts: the local parameters are the longitude and latitude about the
    # chart's first axis; a chart is re-centred when the point leaves |s| < 1
    def _chart_parameters(self, s, chart):
        e = _unit_sphere_derivative(s[..., 0], s[..., 1], 0, 0) @ (np.eye(3) if chart is None else chart).T
        return np.stack([np.arctan2(e[..., 1], e[..., 0]), np.arcsin(np.clip(e[..., 2], -1.0, 1.0))], axis=-1)

    def _new_chart(self, s, chart):
        Q = np.eye(3) if chart is None else chart
        s1, s2 = float(s[0]), float(s[1])
        c1 = Q @ _unit_sphere_derivative(np.array(s1), np.array(s2), 0, 0)
        east = Q @ np.array([-math.sin(s1), math.cos(s1), 0.0])
        c3 = np.cross(c1, east)
        return np.stack([c1, east, c3], axis=1), np.zeros(2)

    def _default_chart(self, s):
        return self._new_chart(np.asarray(s, dtype=float), None)


class Sphere(_Quadric):
    """A sphere of the body: ``u = centre + radius (cos s2 cos s1, cos s2 sin s1, sin s2)``.

    ``s1`` is the longitude about the body z axis from body x, ``s2`` the
    latitude (rad). The poles ``s2 = +-pi/2`` are singular points of this
    parametrization; the contact kernel follows the sphere in rotated
    charts of the same form, so a rolling sphere never meets them, and
    reports the parameters in the form above.

    Parameters
    ----------
    radius : float
        m, > 0.
    centre : (3,), keyword-only
        Centre in the body frame (m); default the origin (the centre of mass).

    Raises
    ------
    ValueError
        ``radius: expected a finite length > 0 (m), got 0.0``.
    """

    def __init__(self, radius: float, *, centre: Any = (0.0, 0.0, 0.0)):
        self.radius = _positive(radius, "radius")
        self.centre = _vector3(centre, "centre")
        self._S = np.full(3, self.radius)
        self._S.setflags(write=False)
        self._S_float = tuple(self._S.tolist())
        self._centre_float = tuple(self.centre.tolist())
        self.length_scale = self.radius

    def __repr__(self) -> str:
        return f"Sphere(radius={self.radius!r})"

    def _shape_key(self) -> Any:
        return ("sphere", self.radius, self._centre_float)


class Ellipsoid(_Quadric):
    """An ellipsoid with semi-axes ``a, b, c`` along the body x, y, z axes.

    ``u = centre + (a cos s2 cos s1, b cos s2 sin s1, c sin s2)`` (the
    sphere's longitude and latitude on the unit sphere, scaled by the axes).

    Parameters
    ----------
    a, b, c : float
        Semi-axes (m), > 0.
    centre : (3,), keyword-only
        Centre in the body frame (m).

    Raises
    ------
    ValueError
        ``b: expected a finite length > 0 (m), got 0.0`` (a flat ellipsoid
        is a degenerate surface).
    """

    def __init__(self, a: float, b: float, c: float, *, centre: Any = (0.0, 0.0, 0.0)):
        self.a = _positive(a, "a")
        self.b = _positive(b, "b")
        self.c = _positive(c, "c")
        self.centre = _vector3(centre, "centre")
        self._S = np.array([self.a, self.b, self.c])
        self._S.setflags(write=False)
        self._S_float = tuple(self._S.tolist())
        self._centre_float = tuple(self.centre.tolist())
        self.length_scale = max(self.a, self.b, self.c)

    def __repr__(self) -> str:
        return f"Ellipsoid(a={self.a!r}, b={self.b!r}, c={self.c!r})"

    def _shape_key(self) -> Any:
        return ("ellipsoid", self.a, self.b, self.c, self._centre_float)


# ------------------------------------------------------------------ torus
class Torus(Surface):
    """A torus about the body y axis: a wheel's tread.

    ``u = centre + (R + r cos psi) e_r(phi) + r sin psi e_y`` with
    ``e_r(phi) = (cos phi, 0, -sin phi)`` (body x turned by ``phi`` about
    body y, right hand), ``s = (phi, psi)``: ``phi`` goes round the wheel,
    ``psi`` round the tube (``psi = 0`` on the outer equator). The normal
    field is the unit outward normal ``cos psi e_r + sin psi e_y``.

    With ``minor_radius = 0`` the surface is the rim circle of radius ``R``
    (the edge of a thin disk, a knife-edge wheel): the point does not
    depend on ``psi``, whose role is the direction of the normal in the
    plane spanned by ``e_r`` and the axis. The contact then takes its
    normal from the rim and its tangents from the other surface.

    Parameters
    ----------
    major_radius : float
        ``R``, m, > 0 (the wheel radius to the centre of the tube).
    minor_radius : float
        ``r``, m, ``0 <= r < R`` (0: a rim; ``r >= R`` would
        self-intersect).
    centre : (3,), keyword-only
        Centre in the body frame (m).
    """

    def __init__(self, major_radius: float, minor_radius: float, *, centre: Any = (0.0, 0.0, 0.0)):
        self.major_radius = _positive(major_radius, "major_radius")
        self.minor_radius = _positive(minor_radius, "minor_radius", allow_zero=True)
        if not self.minor_radius < self.major_radius:
            raise ValueError(
                f"minor_radius: expected 0 <= minor_radius < major_radius = {self.major_radius!r} "
                f"(a torus whose tube reaches its axis intersects itself), got {self.minor_radius!r}"
            )
        self.centre = _vector3(centre, "centre")
        self.degenerate_tangents = self.minor_radius == 0.0
        self.length_scale = self.major_radius

    def __repr__(self) -> str:
        return f"Torus(major_radius={self.major_radius!r}, minor_radius={self.minor_radius!r})"

    def _shape_key(self) -> Any:
        return ("torus", self.major_radius, self.minor_radius, tuple(self.centre.tolist()))

    def _geometry(self, s, order, chart):
        phi, psi = s[..., 0], s[..., 1]
        R, r = self.major_radius, self.minor_radius
        zero = np.zeros_like(phi)

        def er(a):
            return np.stack([np.cos(phi + a * _HALF_PI), zero, -np.sin(phi + a * _HALF_PI)], axis=-1)

        ey = np.array([0.0, 1.0, 0.0])

        def D(orders):
            a, b = orders
            rad = (R if b == 0 else 0.0) + r * np.cos(psi + b * _HALF_PI)
            out = rad[..., None] * er(a)
            if a == 0:
                out = out + (r * np.sin(psi + b * _HALF_PI))[..., None] * ey
            return out

        def Dn(orders):
            a, b = orders
            out = np.cos(psi + b * _HALF_PI)[..., None] * er(a)
            if a == 0:
                out = out + np.sin(psi + b * _HALF_PI)[..., None] * ey
            return out

        u = self.centre + D((0, 0))
        if order < 1:
            return (u, None, None, None, None, None, None)
        U = _assemble(D, 2, order, s.shape[:-1])
        nu = Dn((0, 0))
        Nd = _assemble(Dn, 2, order - 1, s.shape[:-1]) if order >= 2 else []
        return (u, U[0], U[1] if order >= 2 else None, U[2] if order >= 3 else None, nu,
                Nd[0] if order >= 2 else None, Nd[1] if order >= 3 else None)

    def parameters(self, u_body):
        u = float_array(u_body, "u_body")
        if u.ndim == 0 or u.shape[-1] != 3:
            raise ValueError(f"u_body: expected points of shape (..., 3), got {u.shape}")
        d = u - self.centre
        phi = np.arctan2(-d[..., 2], d[..., 0])
        rho = np.hypot(d[..., 0], d[..., 2]) - self.major_radius
        psi = np.arctan2(d[..., 1], rho)
        return np.stack([phi, psi], axis=-1)

    def _derivs_float(self, s, order, chart):
        (cp, sp), (cq, sq) = _trig_cycle(s[0]), _trig_cycle(s[1])
        R, r = self.major_radius, self.minor_radius
        D = {}
        Dn = {}
        for a, b in _orders2(order):
            rad = (R if b == 0 else 0.0) + r * cq[b]
            ex, ez = cp[a], -sp[a]
            y = r * sq[b] if a == 0 else 0.0
            D[(a, b)] = (rad * ex, y, rad * ez)
            if a + b < order:
                Dn[(a, b)] = (cq[b] * ex, sq[b] if a == 0 else 0.0, cq[b] * ez)
        cx, cy, cz = self.centre.tolist()
        u = D[(0, 0)]
        D[(0, 0)] = (u[0] + cx, u[1] + cy, u[2] + cz)
        if order == 0:
            return D, None
        return D, Dn

    def _samples(self):
        phi = np.linspace(-math.pi, math.pi, 36, endpoint=False)
        psi = np.linspace(-math.pi, math.pi, 24, endpoint=False)
        return np.stack(np.meshgrid(phi, psi, indexing="ij"), axis=-1).reshape(-1, 2)


# ------------------------------------------------------------------ user surfaces
class _ContourDerivatives:
    """Derivatives of an analytic function by complex steps on a circle (Cauchy's integral).

    For ``f`` analytic in each parameter, ``d^a f / ds^a (s) = a! / (N h^a)
    sum_j f(s + h w^j) w^(-j a)``, ``w = exp(2 pi i / N)`` (the trapezoid rule
    of Cauchy's integral formula, exact up to terms of order ``h^N``), with
    a product grid for mixed derivatives. One call of ``f`` on all the
    ``N^p`` complex points gives every derivative up to the third; the
    round-off is about ``6 eps |f| / h^3`` for the third (1e-11 relative)
    and the truncation ``3! h^N`` times the size of the higher Taylor
    coefficients. ``N = 12`` points per parameter; ``h = 0.05`` for curves
    and 0.04 for surfaces, in the parameter's units.
    """

    def __init__(self, f: Callable, p: int, dim: int):
        self.f = f
        self.p = p
        self.dim = dim
        self.h = 0.05 if p == 1 else 0.04
        self.N = 12

    #: Negative frequencies checked by :meth:`check_analytic` (-1 to -3).
    CHECKED_FREQUENCIES = 3
    #: A negative frequency ``-m`` of an analytic function is only the alias of ``c_(N-m) h^(N-m)``; against its
    #: mirror ``+m`` (``c_m h^m``) that is ``(k h)^(N - 2m) m! / (N - m)!`` for a ripple ``cos(k s)``: 7e-8 at
    #: ``k h = 0.4``, 3e-4 at ``k h = 1.6`` (a 16-lobe cam, a 40 rad/m ripple). A real part, ``abs`` or
    #: ``conj`` of a term puts its mirror there, the same size (ratio 1, ``Re(z^2) = (z^2 + conj(z)^2) / 2``).
    MIRROR_TOL = 1e-3
    #: ... and a negative frequency below this fraction of the values' size is round-off (about 1e-16).
    ROUND_OFF_TOL = 1e-9

    def check_analytic(self, s: np.ndarray, name: str) -> None:
        """Refuse a function that is not analytic round the complex circles at the points ``s`` (..., p).

        On the circle ``z = s + h w^j`` an analytic ``f`` is ``sum_k c_k h^k w^(jk)`` with ``k >= 0`` only; a
        function that drops the imaginary part of its argument in part of a component (``Re(z^2)``, ``abs(z)
        ** 2 + ...``) has ``conj(z)`` terms: negative frequencies as large as their positive mirrors. Complex
        steps of such a function give wrong derivatives (half the curvature of ``Re(z^2) + z^2``), so it is
        refused, component by component, with the fix (see :data:`MIRROR_TOL`).
        """
        p, N, h = self.p, self.N, self.h
        M = self.CHECKED_FREQUENCIES
        w = np.exp(2j * math.pi * np.arange(N) / N)
        s = np.asarray(s, dtype=float).reshape(-1, p)
        if p == 1:
            z = s[:, 0][:, None] + h * w
        else:
            g1, g2 = np.meshgrid(w, w, indexing="ij")
            z = np.stack([s[:, 0][:, None, None] + h * g1, s[:, 1][:, None, None] + h * g2], axis=-1)
            z = z.reshape(s.shape[0], N * N, 2)
        vals = _call_user(self.f, z, name, self.dim, z.shape[: z.ndim - (p > 1)], complex_ok=True)
        vals = vals.reshape((s.shape[0],) + (N,) * p + (self.dim,))
        axes = tuple(range(1, p + 1))
        coef = np.fft.fft2(vals, axes=axes) if p == 2 else np.fft.fft(vals, axis=1)
        coef = np.abs(coef) / N**p  # [k] is the coefficient of w^(jk); k = N - m is the negative frequency -m
        orders = range(-M, M + 1)
        pairs = [((a,), (abs(a),)) for a in orders if a < 0] if p == 1 else [
            ((a, b), (abs(a), abs(b))) for a in orders for b in orders if a < 0 or b < 0]
        scale = np.abs(vals).max(axis=axes)  # (n, dim)
        off = np.zeros(scale.shape, dtype=bool)
        for negative, mirror in pairs:
            c_neg = coef[(slice(None),) + tuple(k % N for k in negative)]
            c_pos = coef[(slice(None),) + mirror]
            off |= (c_neg > self.ROUND_OFF_TOL * np.maximum(scale, 1e-300)) & (c_neg > self.MIRROR_TOL * c_pos)
        if np.any(off):
            q, comp = (int(i) for i in np.argwhere(off)[0])
            where = np.round(s[q], 6).tolist()
            raise ValueError(
                f"{name}: the function is not analytic in its complex parameters (component {comp} of its value "
                f"near s={where[0] if p == 1 else where}: it takes the real part, abs() or conj() of part of its "
                "argument; write it with complex-safe numpy arithmetic, z * z, not abs(z) ** 2 or np.real(z ** 2)), "
                f"or it varies too fast on the complex steps' circle, of radius {h:g} in the parameters' own units "
                "(a feature a few hundredths of a unit across, such as a bump 5 cm wide with parameters in metres, "
                f"or a singularity within {h:g} of s: give the parameters larger units, such as centimetres or an "
                "angle); its derivatives cannot come from complex steps, so fix it or pass first=, second= and "
                "third=")

    def __call__(self, s: np.ndarray, order: int, name: str):
        p, N, h = self.p, self.N, self.h
        w = np.exp(2j * math.pi * np.arange(N) / N)
        shape = s.shape[:-1]
        if p == 1:
            z = s[..., 0][..., None] + h * w  # (..., N)
            z = z[..., None]
        else:
            g1, g2 = np.meshgrid(w, w, indexing="ij")
            z = np.stack([s[..., 0][..., None, None] + h * g1, s[..., 1][..., None, None] + h * g2], axis=-1)
            z = z.reshape(shape + (N * N, 2))
        arg = z if p > 1 else z[..., 0]
        vals = _call_user(self.f, arg, name, self.dim, arg.shape[: arg.ndim - (p > 1)], complex_ok=True)
        # a component that drops the imaginary part returns f(Re z) (or |z|, ...), real and varying round the
        # circle; an analytic one that is real all round the circle is constant (component by component)
        dropped = ~np.any(vals.imag != 0.0, axis=-2) & (
            np.ptp(vals.real, axis=-2) > 1e-14 * (1.0 + np.abs(vals.real).max()))
        if np.any(dropped):
            which = sorted({int(i) for i in np.nonzero(dropped)[-1]})
            raise ValueError(
                f"{name}: the function dropped the imaginary part of complex parameters (component"
                f"{'s' if len(which) > 1 else ''} {', '.join(map(str, which))} of its value), so its derivatives "
                "cannot come from complex steps; pass first=, second= and third=")
        if p == 1:
            vals = vals.reshape(shape + (N, self.dim))
        else:
            vals = vals.reshape(shape + (N, N, self.dim))
        out = {}
        axes = tuple(range(len(shape), len(shape) + p))
        for k in range(1, order + 1):
            for _, orders in _index_orders(p, k):
                if orders in out:
                    continue
                weight = w ** (-orders[0])
                if p == 2:
                    weight = weight[:, None] * (w ** (-orders[1]))[None, :]
                fac = math.prod(math.factorial(o) for o in orders) / (N**p * h ** sum(orders))
                expanded = weight.reshape((1,) * len(shape) + weight.shape + (1,))
                out[orders] = fac * np.sum(vals * expanded, axis=axes).real
        return out


def _call_user(f: Callable, s: Any, name: str, dim: int, lead: tuple[int, ...], *, complex_ok: bool = False) -> np.ndarray:
    """``f(s)`` checked and broadcast to ``lead + (dim,)``; complex values kept when ``complex_ok``."""
    try:
        value = f(s)
    except Exception as exc:  # noqa: BLE001 - reported with the argument's name
        hint = (" (derivatives by complex step need a function of complex parameters; otherwise pass "
                "first=, second= and third=)") if complex_ok else ""
        raise ValueError(f"{name}: the function raised {type(exc).__name__}: {exc}{hint}") from exc
    arr = np.asarray(value)
    if arr.dtype.kind not in "fciu":
        raise ValueError(f"{name}: expected numbers, got {short_repr(value)}")
    if arr.dtype.kind == "c" and not complex_ok:
        raise ValueError(f"{name}: expected real numbers, got complex {short_repr(value)}")
    arr = arr.astype(complex if complex_ok else float)
    want = tuple(lead) + (dim,)
    try:
        arr = np.broadcast_to(arr, want)
    except ValueError:
        raise ValueError(f"{name}: expected values of shape {want} for parameters of shape {np.shape(s)}, "
                         f"got {arr.shape}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values")
    return arr


class ParametricSurface(Surface):
    """A surface ``u(s1, s2)`` given by user callables (body frame, m).

    Parameters
    ----------
    point : callable
        ``point(s) -> (..., 3)`` for parameters ``s`` of shape ``(..., 2)``.
        Orient the parametrization so that ``du/ds1 x du/ds2`` points out of
        the body.
    first, second, third : callable or None, keyword-only
        ``first(s) -> (..., 3, 2)``, ``second(s) -> (..., 3, 2, 2)``,
        ``third(s) -> (..., 3, 2, 2, 2)`` (index ``[..., :, k, l]`` =
        ``d2u/ds_k ds_l``). The missing ones come from complex steps of
        ``point`` on a circle (Cauchy's integral formula, trapezoid rule,
        radius 0.04 in parameter units, 12 x 12 complex points, errors
        about 1e-13 relative for the first, 1e-12 for the second and 1e-11
        for the third derivative of entire functions): ``point`` must
        then accept complex arrays (numpy arithmetic, ``np.sin``, ...) and
        must not branch on its argument.
    bounds : ((s1_min, s1_max), (s2_min, s2_max)), keyword-only
        Parameter ranges searched for the initial contact point.
    length_scale : float or None, keyword-only
        A characteristic size (m); default the largest extent of the
        points sampled over ``bounds``.

    Raises
    ------
    ValueError
        For bad bounds, callables that fail, return the wrong shape or
        non-finite values, or (without derivatives) do not accept complex
        parameters or are not analytic in them (a real part, ``abs`` or
        ``conj`` of part of the argument; checked at 9 points over
        ``bounds``, see docs/contact.md).
    """

    def __init__(self, point: Callable, *, first: Callable | None = None, second: Callable | None = None,
                 third: Callable | None = None, bounds: Any, length_scale: float | None = None):
        for f, name in ((point, "point"), (first, "first"), (second, "second"), (third, "third")):
            if f is not None and not callable(f):
                raise ValueError(f"{name}: expected a callable, got {short_repr(f)}")
        if point is None:
            raise ValueError("point: expected a callable point(s) -> (..., 3), got None")
        b = float_array(bounds, "bounds", expected="((s1_min, s1_max), (s2_min, s2_max))")
        if b.shape != (2, 2) or not np.all(np.isfinite(b)) or not np.all(b[:, 1] > b[:, 0]):
            raise ValueError(f"bounds: expected ((s1_min, s1_max), (s2_min, s2_max)) with min < max, got {short_repr(bounds)}")
        self.bounds = b
        self._point, self._first, self._second, self._third = point, first, second, third
        self._contour = _ContourDerivatives(point, 2, 3)
        g = np.stack(np.meshgrid(np.linspace(b[0, 0], b[0, 1], 25), np.linspace(b[1, 0], b[1, 1], 25),
                                 indexing="ij"), axis=-1).reshape(-1, 2)
        self._grid = g
        pts = _call_user(point, g, "point", 3, g.shape[:-1])
        if length_scale is None:
            ext = float(np.max(np.ptp(pts, axis=0)))
            self.length_scale = ext if ext > 0 else 1.0
        else:
            self.length_scale = _positive(length_scale, "length_scale")
        self._geometry(g[:2], 3, None)  # shapes of the given derivatives
        if first is None or second is None or third is None:
            # a 3 x 3 grid of points over the bounds
            self._contour.check_analytic(g.reshape(25, 25, 2)[::12, ::12].reshape(-1, 2), "point")

    def __repr__(self) -> str:
        return "ParametricSurface(...)"

    def _geometry(self, s, order, chart):
        u = np.array(_call_user(self._point, s, "point", 3, s.shape[:-1]))
        if order < 1:
            return (u, None, None, None, None, None, None)
        shape = s.shape[:-1]
        given = (self._first, self._second, self._third)
        need = [k for k in range(1, order + 1) if given[k - 1] is None]
        contour = self._contour(s, max(need), "point") if need else {}
        U = []
        for k in range(1, order + 1):
            f = given[k - 1]
            want = shape + (3,) + (2,) * k
            if f is not None:
                name = ("first", "second", "third")[k - 1]
                val = np.asarray(_call_user_tensor(f, s, name, want))
            else:
                val = np.empty(want)
                for idx, orders in _index_orders(2, k):
                    val[(...,) + (slice(None),) + idx] = contour[orders]
            U.append(val)
        return _with_normal(u, U, order)

    def _samples(self):
        return self._grid

    def _derivs_float(self, s, order, chart):
        given = (self._first, self._second, self._third)
        if any(given[k - 1] is None for k in range(1, order + 1)):
            return super()._derivs_float(s, order, chart)
        x = np.array(s, dtype=float)
        arrays = []
        for k, (f, name) in enumerate(((self._point, "point"), (self._first, "first"), (self._second, "second"),
                                       (self._third, "third"))[: order + 1]):
            try:
                a = np.asarray(f(x), dtype=float).reshape((3,) + (2,) * k)
            except Exception as exc:  # noqa: BLE001 - reported with the argument's name
                raise ValueError(f"{name}: the function failed at s={s!r}: {type(exc).__name__}: {exc}") from exc
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name}: expected finite values at s={s!r}")
            arrays.append(a)
        D = {(0, 0): tuple(arrays[0].tolist())}
        for k in range(1, order + 1):
            for idx, orders in _index_orders(2, k):
                if orders not in D:
                    D[orders] = tuple(arrays[k][(slice(None),) + idx].tolist())
        return D, None


def _call_user_tensor(f: Callable, s: np.ndarray, name: str, shape: tuple[int, ...]) -> np.ndarray:
    try:
        value = f(s)
    except Exception as exc:  # noqa: BLE001
        raise ValueError(f"{name}: the function raised {type(exc).__name__}: {exc}") from exc
    arr = np.asarray(value)
    if arr.dtype.kind == "c":
        raise ValueError(f"{name}: expected real numbers, got complex values")
    try:
        arr = arr.astype(float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected real numbers, got {short_repr(value)}") from None
    if arr.shape != shape:
        raise ValueError(f"{name}: expected shape {shape} for parameters of shape {s.shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values")
    return arr
