"""Disk cams with translating flat-faced and roller followers: profiles, kinematics, contact force, jump speed.

Conventions (cam profile plane, the cam's body frame seen along its shaft):

* The cam turns about its shaft (the plane's normal, right hand) by the cam
  angle ``theta`` (rad), at a constant speed ``omega = theta_dot`` in the
  simulations. Cam angle 0 is the lowest lift.
* The follower translates along the plane's +y direction (the follower
  axis, pointing away from the shaft), on the line ``x = offset``. Seen
  from the cam (kinematic inversion) the follower axis at cam angle
  ``theta`` is ``n(theta) = (sin theta, cos theta)`` and the direction
  across it ``t(theta) = dn/dtheta = (cos theta, -sin theta)``.
* Lift ``s(theta) >= 0`` (m) is the follower's displacement along its axis
  from its lowest position; ``s' = ds/dtheta``, ``s'' = d2s/dtheta2``.
* Contact force ``N`` (N): the normal force between cam and follower along
  their common normal, positive while pressing.
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, InitVar, dataclass, field
from typing import Any, Callable, NamedTuple

import numpy as np
from scipy.optimize import minimize_scalar

from rigidlab.core._constants import CAM_ATOL, CAM_RTOL, SEPARATION_XTOL
from rigidlab.core._errors import ArgumentError
from rigidlab.core._validation import (default_angle, degrees_out, float_array, output_times, radians, real_number,
                                       short_repr)

__all__ = [
    "CAM_CONTACT_MODELS",
    "CAM_LAWS",
    "FOLLOWER_KINDS",
    "CamCurve",
    "CamFollower",
    "CamKinematics",
    "CamMotion",
    "CamProfile",
    "CamRevolution",
    "CamSample",
    "CamSystem",
    "CamTouch",
    "largest_roller_radius",
    "smallest_convex_rise",
]

#: Displacement laws of :meth:`CamProfile.rise_dwell_return`.
CAM_LAWS = ("cycloidal", "harmonic", "345")
#: Follower kinds of :class:`CamFollower`.
FOLLOWER_KINDS = ("flat", "roller")

_TWO_PI = 2.0 * math.pi
# derivative order of the lift stacks: the cam curve's third derivative needs s''''
_ORDER = 4
# samples per segment for the profile checks and the jump-speed search
_SAMPLES = 1025
_BINOMIAL = [[math.comb(n, k) for k in range(n + 1)] for n in range(_ORDER + 1)]


# ------------------------------------------------------------------ derivative stacks
# A stack ``D`` of shape (K + 1, ...) holds a function and its first K
# derivatives with respect to one parameter: D[k] = d^k f / du^k.
def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Leibniz rule: the stack of ``a b``."""
    K = min(a.shape[0], b.shape[0]) - 1
    out = np.zeros(np.broadcast_shapes(a[: K + 1].shape, b[: K + 1].shape))
    for n in range(K + 1):
        for k in range(n + 1):
            out[n] += _BINOMIAL[n][k] * a[k] * b[n - k]
    return out


def _sqrt(a: np.ndarray) -> np.ndarray:
    """The stack of ``sqrt(a)`` (``a > 0``), from ``g^2 = a``."""
    g = np.zeros_like(a)
    g[0] = np.sqrt(a[0])
    for n in range(1, a.shape[0]):
        acc = a[n].copy()
        for k in range(1, n):
            acc -= _BINOMIAL[n][k] * g[k] * g[n - k]
        g[n] = acc / (2.0 * g[0])
    return g


def _reciprocal(a: np.ndarray) -> np.ndarray:
    """The stack of ``1 / a`` (``a != 0``), from ``a g = 1``."""
    g = np.zeros_like(a)
    g[0] = 1.0 / a[0]
    for n in range(1, a.shape[0]):
        acc = np.zeros_like(a[0])
        for k in range(1, n + 1):
            acc += _BINOMIAL[n][k] * a[k] * g[n - k]
        g[n] = -acc / a[0]
    return g


def _trig_stack(theta: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Stacks of ``n(theta) = (sin, cos)`` and ``t(theta) = (cos, -sin)``, shape (order + 1, ..., 2)."""
    n = np.stack([np.sin(theta), np.cos(theta)], axis=-1)
    t = np.stack([np.cos(theta), -np.sin(theta)], axis=-1)
    cycle_n = (n, t, -n, -t)
    cycle_t = (t, -n, -t, n)
    return np.stack([cycle_n[k % 4] for k in range(order + 1)]), np.stack([cycle_t[k % 4] for k in range(order + 1)])


# The same rules on Python floats (lists of derivatives), for one parameter
# value: the contact kernel evaluates the cam contour at one point at a time.
# The contours use stacks of 4 and 5 derivatives; those are written out (the
# general loops cost a quarter of a roller follower's flight in the Cam-follower
# scene). tests/core/test_cam.py checks them against the loops.
def _mul_f(a: list[float], b: list[float]) -> list[float]:
    m = min(len(a), len(b))
    if m == 4 or m == 5:
        a0, a1, a2, a3 = a[0], a[1], a[2], a[3]
        b0, b1, b2, b3 = b[0], b[1], b[2], b[3]
        out = [a0 * b0, a0 * b1 + a1 * b0, a0 * b2 + 2.0 * a1 * b1 + a2 * b0,
               a0 * b3 + 3.0 * (a1 * b2 + a2 * b1) + a3 * b0]
        if m == 5:
            out.append(a0 * b[4] + 4.0 * (a1 * b3 + a3 * b1) + 6.0 * a2 * b2 + a[4] * b0)
        return out
    return _mul_f_loops(a, b)


def _mul_f_loops(a: list[float], b: list[float]) -> list[float]:
    return [sum(_BINOMIAL[n][k] * a[k] * b[n - k] for k in range(n + 1)) for n in range(min(len(a), len(b)))]


def _sqrt_f(a: list[float]) -> list[float]:
    m = len(a)
    if m == 4 or m == 5:
        g0 = math.sqrt(a[0])
        h = 0.5 / g0
        g1 = a[1] * h
        g2 = (a[2] - 2.0 * g1 * g1) * h
        g3 = (a[3] - 6.0 * g1 * g2) * h
        if m == 4:
            return [g0, g1, g2, g3]
        return [g0, g1, g2, g3, (a[4] - 8.0 * g1 * g3 - 6.0 * g2 * g2) * h]
    return _sqrt_f_loops(a)


def _sqrt_f_loops(a: list[float]) -> list[float]:
    g = [math.sqrt(a[0])]
    for n in range(1, len(a)):
        g.append((a[n] - sum(_BINOMIAL[n][k] * g[k] * g[n - k] for k in range(1, n))) / (2.0 * g[0]))
    return g


def _reciprocal_f(a: list[float]) -> list[float]:
    if len(a) == 4:
        a0, a1, a2, a3 = a
        g0 = 1.0 / a0
        g1 = -a1 * g0 * g0
        g2 = -(2.0 * a1 * g1 + a2 * g0) * g0
        return [g0, g1, g2, -(3.0 * (a1 * g2 + a2 * g1) + a3 * g0) * g0]
    return _reciprocal_f_loops(a)


def _reciprocal_f_loops(a: list[float]) -> list[float]:
    g = [1.0 / a[0]]
    for n in range(1, len(a)):
        g.append(-sum(_BINOMIAL[n][k] * a[k] * g[n - k] for k in range(1, n + 1)) / a[0])
    return g


# ------------------------------------------------------------------ displacement laws
def _law_float(law: str, x: float) -> list[float]:
    """:func:`_law_stack` at one point, on floats."""
    if law == "cycloidal":
        w = _TWO_PI
        s, c = math.sin(w * x), math.cos(w * x)
        return [x - s / w, 1.0 - c, w * s, w * w * c, -(w**3) * s]
    if law == "harmonic":
        w = math.pi
        s, c = math.sin(w * x), math.cos(w * x)
        return [0.5 * (1.0 - c), 0.5 * w * s, 0.5 * w * w * c, -0.5 * w**3 * s, -0.5 * w**4 * c]
    x2 = x * x
    return [x2 * x * (10.0 - 15.0 * x + 6.0 * x2), x2 * (30.0 - 60.0 * x + 30.0 * x2),
            x * (60.0 - 180.0 * x + 120.0 * x2), 60.0 - 360.0 * x + 360.0 * x2, -360.0 + 720.0 * x]


def _law_stack(law: str, x: np.ndarray) -> np.ndarray:
    """Normalized rise ``f(x)``, ``f(0) = 0``, ``f(1) = 1``, and its derivatives to order 4 in x."""
    if law == "cycloidal":
        w = _TWO_PI
        s, c = np.sin(w * x), np.cos(w * x)
        return np.stack([x - s / w, 1.0 - c, w * s, w * w * c, -(w**3) * s])
    if law == "harmonic":
        w = math.pi
        s, c = np.sin(w * x), np.cos(w * x)
        return np.stack([0.5 * (1.0 - c), 0.5 * w * s, 0.5 * w * w * c, -0.5 * w**3 * s, -0.5 * w**4 * c])
    x2 = x * x
    return np.stack([
        x2 * x * (10.0 - 15.0 * x + 6.0 * x2),
        x2 * (30.0 - 60.0 * x + 30.0 * x2),
        x * (60.0 - 180.0 * x + 120.0 * x2),
        60.0 - 360.0 * x + 360.0 * x2,
        -360.0 + 720.0 * x,
    ])


@dataclass(frozen=True)
class _Segment:
    """One smooth piece ``[start, stop]`` of a lift law; ``stack(theta)`` is its analytic derivative stack
    (array), ``at(theta)`` the same at one angle (list of floats)."""

    start: float
    stop: float
    stack: Callable[[np.ndarray], np.ndarray]
    at: Callable[[float], list[float]]


# ------------------------------------------------------------------ results
class CamKinematics(NamedTuple):
    """Follower lift and its derivatives with respect to the cam angle (arrays of the shape of ``theta``).

    Attributes
    ----------
    lift : ndarray
        ``s(theta)`` (m), >= 0, 0 at cam angle 0.
    dlift : ndarray
        ``s' = ds/dtheta`` (m/rad); the follower velocity is ``omega s'``.
    d2lift : ndarray
        ``s'' = d2s/dtheta2`` (m/rad^2); at constant cam speed the follower
        acceleration is ``omega^2 s''``.
    """

    lift: np.ndarray
    dlift: np.ndarray
    d2lift: np.ndarray


class CamTouch(NamedTuple):
    """Where cam and follower touch, in the fixed profile plane with the cam turned by ``theta``.

    Attributes
    ----------
    point : ndarray, ``theta.shape + (2,)``
        The contact point (m): :meth:`CamFollower.cam_curve` ``(theta).point``
        turned by ``theta`` about the shaft.
    normal : ndarray, ``theta.shape + (2,)``
        The common unit normal from the cam to the follower:
        :meth:`CamFollower.contact_normal` turned by ``theta``.
    """

    point: np.ndarray
    normal: np.ndarray


class CamRevolution(NamedTuple):
    """One revolution of the closed-form motion at constant cam speed (:meth:`CamFollower.revolution`).

    Rows ``i = 0 .. n`` at cam angles ``theta_i = 2 pi i / n`` (both ends included).

    Attributes
    ----------
    speed, jump_speed : float
        omega and :meth:`CamFollower.jump_speed` (rad/s).
    theta : (n + 1,) rad
    lift, velocity, acceleration : (n + 1,)
        ``s`` (m), ``omega s'`` (m/s), ``omega^2 s''`` (m/s^2).
    contact_force, force_at_jump : (n + 1,) N
        :meth:`CamFollower.contact_force` at ``speed`` and at ``jump_speed`` (> 0 pressing).
    contact_point, contact_normal : (n + 1, 2)
        :meth:`CamFollower.touch_location` (m; unit), fixed profile plane.
    separations : tuple of (float, float)
        :meth:`CamFollower.separation_intervals` at ``speed`` (rad).
    min_force : (float, float)
        The smallest tabulated force (N) and its cam angle (rad).
    """

    speed: float
    jump_speed: float
    theta: np.ndarray
    lift: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    contact_force: np.ndarray
    force_at_jump: np.ndarray
    contact_point: np.ndarray
    contact_normal: np.ndarray
    separations: tuple
    min_force: tuple

    def separated(self, theta: Any, *, degrees: bool = False) -> np.ndarray:
        """Whether the cam angles ``theta`` (rad, any shape, taken modulo 2 pi) lie in a separation interval
        (:attr:`separations`, ends included): where the closed-form contact force ``N < 0`` (the contact would
        have to pull), up to the intervals' ends (found to ``SEPARATION_XTOL``, 1e-12 rad).

        Parameters
        ----------
        degrees : bool, keyword-only
            True: ``theta`` is in degrees.

        Returns
        -------
        ndarray of bool, the shape of ``theta``.
        """
        theta = radians(theta, "theta", degrees)
        th = np.mod(_angles(theta), _TWO_PI)
        out = np.zeros(th.shape, dtype=bool)
        for a, b in self.separations:
            out |= np.mod(th - a, _TWO_PI) <= b - a
        return out

    def describe(self) -> tuple[tuple[str, str], ...]:
        """The revolution in words: ``(topic, text)`` pairs: the jump speed against the speed (rpm and rad/s),
        then ``"Separation"`` (the intervals where N < 0, cam angles in degrees in [0, 360)) or ``"No
        separation"`` (the smallest force and its angle)."""
        rpm = 30.0 / math.pi
        jump = (f"{self.jump_speed * rpm:.1f} rpm ({self.jump_speed:.3f} rad/s); the cam turns at "
                f"{self.speed * rpm:.6g} rpm, {100.0 * self.speed / self.jump_speed:.1f} % of it")
        if self.separations:
            spans = ", ".join(f"θ = {_degrees(a):.2f}° to {_degrees(b):.2f}°" for a, b in self.separations)
            return ("Jump speed", jump), ("Separation", f"N < 0 from {spans}: the contact would have to pull")
        return ("Jump speed", jump), ("No separation", f"N > 0 all round (smallest {self.min_force[0]:.3f} N at "
                                                       f"θ = {_degrees(self.min_force[1]):.2f}°)")


def _degrees(theta: float) -> float:
    """A cam angle (rad) in degrees in [0, 360)."""
    return math.degrees(theta % _TWO_PI)


@dataclass(frozen=True)
class CamCurve:
    """Points of a plane curve and their derivatives with respect to the curve parameter ``u``.

    Coordinates are in the cam profile plane (the cam's body frame; see the
    module conventions). The parameter ``u`` is the cam angle (rad) at which
    the point is the contact point (for the pitch curve: the roller centre),
    so the curve has period 2 pi in ``u``.

    Attributes
    ----------
    point : (..., 2) ndarray
        Points (m).
    d1, d2, d3 : (..., 2) ndarray
        First, second and third derivatives with respect to ``u`` (m/rad^k).
    """

    point: np.ndarray  # (..., 2)
    d1: np.ndarray  # (..., 2)
    d2: np.ndarray  # (..., 2)
    d3: np.ndarray  # (..., 2)


# ------------------------------------------------------------------ validation helpers
def _positive(x: Any, name: str, unit: str) -> float:
    v = real_number(x, name, expected=f"a finite number > 0 ({unit})")
    if not v > 0:
        raise ArgumentError(name, f"{name}: expected a finite number > 0 ({unit}), got {v!r}")
    return v


def _non_negative(x: Any, name: str, unit: str) -> float:
    v = real_number(x, name, expected=f"a finite number >= 0 ({unit})")
    if not v >= 0:
        raise ArgumentError(name, f"{name}: expected a finite number >= 0 ({unit}), got {v!r}")
    return v


def _angles(theta: Any, name: str = "theta") -> np.ndarray:
    arr = float_array(theta, name, expected="cam angles (rad)")
    if not np.all(np.isfinite(arr)):
        raise ArgumentError(name, f"{name}: expected finite cam angles (rad), got {short_repr(theta)}")
    return arr


# ------------------------------------------------------------------ profile
@dataclass(frozen=True)
class CamProfile:
    """A disk cam: an eccentric circle, or a rise-dwell-return follower motion law.

    Build one with :meth:`eccentric` or :meth:`rise_dwell_return`. The
    eccentric cam is a *shape* (its lift depends on the follower); a
    rise-dwell-return profile is a *motion law* ``s(theta)`` (the cam's
    shape depends on the follower: the envelope of the flat face's
    positions, or the inner offset of the roller centre's pitch curve).
    :class:`CamFollower` binds a profile to a follower.

    Attributes
    ----------
    kind : str
        ``"eccentric"`` or ``"rise_dwell_return"``.
    base_radius : float
        Radius of the cam's base circle, the smallest circle about the shaft
        that touches the cam (m): ``radius - eccentricity`` for the
        eccentric cam.
    radius, eccentricity : float or None
        Eccentric cam: circle radius R and distance e of its centre from the
        shaft (m).
    lift, rise, dwell, fall : float or None
        Rise-dwell-return: total lift L (m) and the cam angles of rise, upper
        dwell and fall (rad); the lower dwell fills the rest of the turn.
    law : str or None
        Rise-dwell-return: ``"cycloidal"``, ``"harmonic"`` or ``"345"``.
    degrees : bool, keyword-only
        True: ``rise``, ``dwell``, ``fall`` given in degrees (stored in radians).
    """

    kind: str
    base_radius: float
    radius: float | None = None
    eccentricity: float | None = None
    lift: float | None = None
    rise: float | None = None
    dwell: float | None = None
    fall: float | None = None
    law: str | None = None
    _: KW_ONLY
    degrees: InitVar[bool] = False

    def __post_init__(self, degrees: bool) -> None:
        for name in ("rise", "dwell", "fall"):
            object.__setattr__(self, name, radians(getattr(self, name), name, degrees))
        # built directly rather than by eccentric() or rise_dwell_return(): the same checks, and the fields
        # of the other kind left out
        how = "build a profile with CamProfile.eccentric(...) or CamProfile.rise_dwell_return(...)"
        fields = {"eccentric": ("radius", "eccentricity"),
                  "rise_dwell_return": ("lift", "rise", "dwell", "fall", "law")}
        if not isinstance(self.kind, str) or self.kind not in fields:
            raise ArgumentError("kind",
                                f"kind: expected 'eccentric' or 'rise_dwell_return' ({how}), got {short_repr(self.kind)}")
        other = next(k for k in fields if k != self.kind)
        missing = [f for f in fields[self.kind] if getattr(self, f) is None]
        extra = [f for f in fields[other] if getattr(self, f) is not None]
        if missing or extra:
            names = ", ".join(missing or extra)
            article = "an" if self.kind == "eccentric" else "a"
            raise ArgumentError(names,
                                f"{names}: {article} {self.kind!r} profile {'needs' if missing else 'has no'} {names} "
                                f"({how}), got {short_repr(self)}")
        if self.kind == "eccentric":
            base = _eccentric_fields(self.radius, self.eccentricity)[0]
        else:
            base = _rise_dwell_return_fields(self.base_radius, self.lift, self.rise, self.dwell, self.fall,
                                             self.law)[0]
        if not base == self.base_radius:
            raise ArgumentError("base_radius",
                                f"base_radius: expected {base!r} m for this {self.kind!r} profile ({how}), "
                             f"got {short_repr(self.base_radius)}")

    @classmethod
    def eccentric(cls, radius: float = 0.04, eccentricity: float = 0.01) -> CamProfile:
        """A circular cam of radius ``R`` whose centre is ``e`` from the shaft.

        With a flat-faced follower the lift is ``s = e (1 - cos theta)``;
        with a roller of radius ``r_f`` on a follower line offset ``e_o``
        from the shaft it is the slider-crank's
        ``s = sqrt((R + r_f)^2 - (e_o - e sin b)^2) - e cos b - s_0``,
        ``b = theta + b_0`` (see :meth:`CamFollower.kinematics`).

        Parameters
        ----------
        radius : float
            R (m), > 0.
        eccentricity : float
            e (m), ``0 < e < R``.

        Returns
        -------
        CamProfile
        """
        Rb, R, e = _eccentric_fields(radius, eccentricity)
        return cls("eccentric", Rb, radius=R, eccentricity=e)

    @classmethod
    def rise_dwell_return(
        cls,
        base_radius: float = 0.04,
        lift: float = 0.02,
        rise: float = default_angle(math.pi / 2),
        dwell: float = default_angle(math.pi / 6),
        fall: float = default_angle(math.pi / 2),
        law: str = "cycloidal",
        *,
        degrees: bool = False,
    ) -> CamProfile:
        """A rise-dwell-return-dwell motion law.

        The follower rises by ``lift`` over the cam angles ``[0, rise]``,
        dwells at the top for ``dwell``, falls back over ``fall`` and dwells
        at the bottom for the rest of the turn. With ``x`` the fraction of
        a rise (``theta / rise``), the rise is ``s = L f(x)`` and a fall
        ``s = L (1 - f(x))``:

        * ``"cycloidal"``: ``f = x - sin(2 pi x) / (2 pi)``; s, s', s''
          continuous (s'' = 0 at both ends).
        * ``"harmonic"``: ``f = (1 - cos(pi x)) / 2``; s' continuous, s''
          jumps at the ends (finite acceleration jumps).
        * ``"345"``: ``f = 10 x^3 - 15 x^4 + 6 x^5``; s, s', s'' continuous.

        Derivatives are analytic per segment: ``s^(k) = L f^(k)(x) /
        rise^k``.

        Parameters
        ----------
        base_radius : float
            Radius of the base circle (m), > 0: the distance from the shaft
            to the flat face, or to the cam under the roller, at zero lift.
        lift : float
            L (m), > 0.
        rise, fall : float
            Cam angles of the rise and the fall (rad), > 0.
        dwell : float
            Cam angle of the upper dwell (rad), >= 0; ``rise + dwell +
            fall <= 2 pi`` (the lower dwell is the rest).
        law : str
            ``"cycloidal"``, ``"harmonic"`` or ``"345"``.
        degrees : bool, keyword-only
            True: ``rise``, ``dwell``, ``fall`` are in degrees.

        Returns
        -------
        CamProfile
        """
        rise = radians(rise, "rise", degrees)
        dwell = radians(dwell, "dwell", degrees)
        fall = radians(fall, "fall", degrees)
        Rb, L, b1, b2, b3, law = _rise_dwell_return_fields(base_radius, lift, rise, dwell, fall, law)
        return cls("rise_dwell_return", Rb, lift=L, rise=b1, dwell=b2, fall=b3, law=law)

    # ------------------------------------------------------------ motion law
    def _law_segments(self) -> tuple[_Segment, ...]:
        """Segments of the rise-dwell-return law ``s(theta)`` (the follower motion, any follower)."""
        L, b1, b2, b3, law = self.lift, self.rise, self.dwell, self.fall, self.law
        assert L is not None and b1 is not None and b2 is not None and b3 is not None and law is not None
        scale = [1.0, 1.0 / b1, 1.0 / b1**2, 1.0 / b1**3, 1.0 / b1**4]
        fscale = [1.0, 1.0 / b3, 1.0 / b3**2, 1.0 / b3**3, 1.0 / b3**4]
        a2, a3 = b1 + b2, b1 + b2 + b3

        def rise_stack(theta: np.ndarray) -> np.ndarray:
            f = _law_stack(law, theta / b1)
            return L * f * np.reshape(scale, (-1,) + (1,) * theta.ndim)

        def fall_stack(theta: np.ndarray) -> np.ndarray:
            f = _law_stack(law, (theta - a2) / b3)
            out = -L * f * np.reshape(fscale, (-1,) + (1,) * theta.ndim)
            out[0] += L
            return out

        def rise_at(theta: float) -> list[float]:
            f = _law_float(law, theta / b1)
            return [L * fk * sk for fk, sk in zip(f, scale)]

        def fall_at(theta: float) -> list[float]:
            f = _law_float(law, (theta - a2) / b3)
            out = [-L * fk * sk for fk, sk in zip(f, fscale)]
            out[0] += L
            return out

        def constant(value: float) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[float], list[float]]]:
            def stack(theta: np.ndarray) -> np.ndarray:
                out = np.zeros((_ORDER + 1,) + theta.shape)
                out[0] = value
                return out

            def at(theta: float) -> list[float]:
                return [value, 0.0, 0.0, 0.0, 0.0]

            return stack, at

        segments = [_Segment(0.0, b1, rise_stack, rise_at)]
        if b2 > 0:
            segments.append(_Segment(b1, a2, *constant(L)))
        segments.append(_Segment(a2, a3, fall_stack, fall_at))
        if a3 < _TWO_PI:
            segments.append(_Segment(a3, _TWO_PI, *constant(0.0)))
        return tuple(segments)

    def motion_law(self, theta: Any, *, degrees: bool = False) -> CamKinematics:
        """The rise-dwell-return law ``s(theta)`` with its first and second derivatives.

        For these profiles this is the lift of every follower (the cam is
        built from it); for the eccentric cam the lift depends on the
        follower (use :meth:`CamFollower.kinematics`).

        Parameters
        ----------
        theta : array_like
            Cam angles (rad), any shape; taken modulo 2 pi.
        degrees : bool, keyword-only
            True: ``theta`` is in degrees (the result holds radians).

        Returns
        -------
        CamKinematics
            ``lift``, ``dlift``, ``d2lift`` of the shape of ``theta`` (m,
            m/rad, m/rad^2).
        """
        theta = radians(theta, "theta", degrees)
        if self.kind != "rise_dwell_return":
            raise ArgumentError("kind",
                "kind: the eccentric cam has no motion law of its own (its lift depends on the follower); "
                "use CamFollower(profile, ...).kinematics(theta)"
            )
        D = _evaluate_segments(self._law_segments(), _angles(theta))
        return CamKinematics(D[0], D[1], D[2])


def _evaluate_segments(segments: tuple[_Segment, ...], theta: np.ndarray) -> np.ndarray:
    """Stack (order + 1, *theta.shape) of a piecewise law at ``theta`` modulo 2 pi (segments closed on the left)."""
    wrapped = np.mod(theta, _TWO_PI)
    out = np.empty((_ORDER + 1,) + theta.shape)
    starts = np.array([seg.start for seg in segments])
    index = np.clip(np.searchsorted(starts, wrapped, side="right") - 1, 0, len(segments) - 1)
    for k, seg in enumerate(segments):
        mask = index == k
        if np.any(mask):
            out[:, mask] = seg.stack(wrapped[mask])
    return out


def _eccentric_fields(radius: Any, eccentricity: Any) -> tuple[float, float, float]:
    """The checked ``(base_radius, radius, eccentricity)`` of an eccentric cam (m)."""
    R = _positive(radius, "radius", "m")
    e = _positive(eccentricity, "eccentricity", "m")
    if not e < R:
        raise ArgumentError("eccentricity",
                            f"eccentricity: expected less than radius={R!r} (the shaft inside the cam), got {e!r}")
    return R - e, R, e


def _rise_dwell_return_fields(base_radius: Any, lift: Any, rise: Any, dwell: Any, fall: Any,
                              law: Any) -> tuple[float, float, float, float, float, str]:
    """The checked ``(base_radius, lift, rise, dwell, fall, law)`` of a rise-dwell-return cam."""
    Rb = _positive(base_radius, "base_radius", "m")
    L = _positive(lift, "lift", "m")
    b1 = _positive(rise, "rise", "rad")
    b2 = _non_negative(dwell, "dwell", "rad")
    b3 = _positive(fall, "fall", "rad")
    if not isinstance(law, str) or law not in CAM_LAWS:
        raise ArgumentError("law", f"law: expected one of {list(CAM_LAWS)}, got {short_repr(law)}")
    total = b1 + b2 + b3
    if total > _TWO_PI * (1.0 + 1e-12):
        raise ArgumentError("rise, dwell, fall",
            f"rise, dwell, fall: expected rise + dwell + fall <= 2 pi (one turn), got {total!r} rad"
        )
    return Rb, L, b1, b2, b3, law


# ------------------------------------------------------------------ follower
@dataclass(frozen=True)
class CamFollower:
    """A disk cam driving a spring-loaded translating follower, flat-faced or roller.

    Geometry and signs follow the module conventions: the cam turns by the
    cam angle ``theta`` about its shaft; the follower slides along its axis
    (lift ``s`` away from the shaft) on a line ``offset`` from the shaft;
    cam angle 0 is the lowest lift. The follower's equation of motion
    along its axis, at constant cam speed ``omega`` (``s_ddot = omega^2
    s''``), gives the contact force

    .. math::

        N \\cos\\varphi = m \\omega^2 s'' + k s + F_0 + m g

    (``N > 0`` pressing; the spring force ``k s + F_0``, the preload ``F_0``
    at zero lift, and gravity ``m g`` all push the follower towards the
    cam; ``varphi`` the pressure angle, 0 for a flat face whose face is
    normal to its axis; the guide takes the force across the axis).

    Parameters
    ----------
    profile : CamProfile
    follower : str
        ``"flat"`` (a flat face normal to the follower axis) or
        ``"roller"`` (a roller of radius ``roller_radius`` whose centre is
        on the follower axis; frictionless, so it need not turn).
    roller_radius : float
        r_f (m): > 0 for a roller, 0 for a flat face.
    mass : float
        Follower mass m (kg), > 0.
    stiffness : float
        Spring rate k (N/m), >= 0.
    preload : float
        Spring force at zero lift F_0 (N), >= 0.
    gravity : float
        Component g of gravity along the follower axis towards the cam
        (m/s^2); negative when gravity pulls the follower away from the cam.
        ``preload + mass * gravity > 0`` (the follower presses on the cam at
        rest).
    offset : float
        e_o (m): distance of the follower axis from the shaft, along the
        plane's +x (the direction ``t`` at cam angle 0). It does not change
        a flat face's lift; for a roller ``|e_o| < R_b + r_f`` (the
        eccentric cam: ``|e_o| < R + r_f - e``).

    Raises
    ------
    ValueError
        Naming the argument: a wrong type, kind or range; a flat face on a
        rise-dwell-return law whose cam would not be convex (radius of
        curvature ``R_b + s + s'' <= 0``; names the base radius needed); a
        roller larger than the pitch curve's smallest convex radius of
        curvature (an undercut cam).
    """

    profile: CamProfile
    follower: str = "flat"
    roller_radius: float = 0.0
    mass: float = 0.5
    stiffness: float = 2000.0
    preload: float = 20.0
    gravity: float = 9.81
    offset: float = 0.0
    _segments: tuple[_Segment, ...] = field(init=False, repr=False, compare=False)
    _pitch_height: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.profile, CamProfile):
            raise ArgumentError("profile", f"profile: expected a CamProfile, got {type(self.profile).__name__}")
        if not isinstance(self.follower, str) or self.follower not in FOLLOWER_KINDS:
            raise ArgumentError("follower",
                                f"follower: expected one of {list(FOLLOWER_KINDS)}, got {short_repr(self.follower)}")
        rf = _non_negative(self.roller_radius, "roller_radius", "m")
        if self.follower == "flat" and rf != 0.0:
            raise ArgumentError("roller_radius",
                                f"roller_radius: a flat-faced follower has no roller, expected 0.0, got {rf!r}")
        if self.follower == "roller" and not rf > 0:
            raise ArgumentError("roller_radius",
                                f"roller_radius: expected a roller radius > 0 (m) for follower='roller', got {rf!r}")
        m = _positive(self.mass, "mass", "kg")
        k = _non_negative(self.stiffness, "stiffness", "N/m")
        F0 = _non_negative(self.preload, "preload", "N")
        g = real_number(self.gravity, "gravity", expected="a finite acceleration (m/s^2)")
        eo = real_number(self.offset, "offset", expected="a finite distance (m)")
        if not F0 + m * g > 0:
            raise ArgumentError("preload",
                f"preload: expected preload + mass * gravity > 0 (the follower must press on the cam at rest), "
                f"got {F0!r} + {m!r} * {g!r} = {F0 + m * g!r} N"
            )
        for name, value in (("roller_radius", rf), ("mass", m), ("stiffness", k), ("preload", F0), ("gravity", g),
                            ("offset", eo)):
            object.__setattr__(self, name, value)
        prof = self.profile
        Rp = prof.base_radius + rf
        if self.follower == "roller":
            if not abs(eo) < Rp:
                what = "radius - eccentricity + roller_radius" if prof.kind == "eccentric" else "base_radius + roller_radius"
                raise ArgumentError("offset",
                    f"offset: expected |offset| < {what} = {Rp!r} m (the follower axis must cross the roller "
                    f"centre's lowest circle), got {eo!r}"
                )
            pitch_height = math.sqrt(Rp * Rp - eo * eo)
        else:
            pitch_height = prof.base_radius
        object.__setattr__(self, "_pitch_height", pitch_height)
        object.__setattr__(self, "_segments", self._build_segments())
        self._check_shape()

    def __reduce__(self):
        # the lift segments are closures: rebuild them from the public fields (pickling for process pools)
        return (CamFollower, (self.profile, self.follower, self.roller_radius, self.mass, self.stiffness,
                              self.preload, self.gravity, self.offset))

    # ------------------------------------------------------------ lift
    def _build_segments(self) -> tuple[_Segment, ...]:
        prof = self.profile
        if prof.kind == "rise_dwell_return":
            return prof._law_segments()
        R, e = prof.radius, prof.eccentricity
        assert R is not None and e is not None
        if self.follower == "flat":
            def flat_stack(theta: np.ndarray) -> np.ndarray:
                s, c = np.sin(theta), np.cos(theta)
                return np.stack([e * (1.0 - c), e * s, e * c, -e * s, -e * c])

            def flat_at(theta: float) -> list[float]:
                s, c = math.sin(theta), math.cos(theta)
                return [e * (1.0 - c), e * s, e * c, -e * s, -e * c]

            return (_Segment(0.0, _TWO_PI, flat_stack, flat_at),)
        Rr, eo, y0 = R + self.roller_radius, self.offset, self._pitch_height
        b0 = math.asin(-eo / (Rr - e))

        def roller_stack(theta: np.ndarray) -> np.ndarray:
            b = theta + b0
            S = np.stack([np.sin(b), np.cos(b), -np.sin(b), -np.cos(b), np.sin(b)])
            C = np.stack([np.cos(b), -np.sin(b), -np.cos(b), np.sin(b), np.cos(b)])
            w = -e * S
            w[0] += eo
            q2 = -_mul(w, w)
            q2[0] += Rr * Rr
            y = _sqrt(q2) - e * C
            y[0] -= y0
            return y

        def roller_at(theta: float) -> list[float]:
            sb, cb = math.sin(theta + b0), math.cos(theta + b0)
            S = [sb, cb, -sb, -cb, sb]
            C = [cb, -sb, -cb, sb, cb]
            w = [-e * v for v in S]
            w[0] += eo
            q2 = [-v for v in _mul_f(w, w)]
            q2[0] += Rr * Rr
            y = [a - e * b for a, b in zip(_sqrt_f(q2), C)]
            y[0] -= y0
            return y

        return (_Segment(0.0, _TWO_PI, roller_stack, roller_at),)

    @property
    def phase(self) -> float:
        """Angle ``b_0`` (rad) of the eccentric cam's centre at cam angle 0, measured from the direction
        opposite the follower (0 unless an offset roller rides on an eccentric cam:
        ``sin b_0 = -e_o / (R + r_f - e)``)."""
        prof = self.profile
        if prof.kind != "eccentric" or self.follower == "flat":
            return 0.0
        assert prof.radius is not None and prof.eccentricity is not None
        return math.asin(-self.offset / (prof.radius + self.roller_radius - prof.eccentricity))

    def _stack(self, theta: np.ndarray) -> np.ndarray:
        return _evaluate_segments(self._segments, theta)

    def kinematics(self, theta: Any, *, degrees: bool = False) -> CamKinematics:
        """Lift ``s`` and its derivatives ``s'``, ``s''`` with respect to the cam angle.

        Closed forms (eccentric cam of radius R, eccentricity e):

        * flat face: ``s = e (1 - cos theta)``, ``s' = e sin theta``,
          ``s'' = e cos theta``;
        * roller of radius r_f on the axis offset e_o (the slider-crank with
          crank e and rod ``R + r_f``): with ``b = theta + b_0`` (see
          :attr:`phase`), ``w = e_o - e sin b``, ``q = sqrt((R + r_f)^2 -
          w^2)``: ``s = q - e cos b - s_0``, ``s_0 = sqrt((R + r_f - e)^2 -
          e_o^2)``, ``s' = e sin b + e w cos b / q``, ``s'' = e cos b - e (e
          cos^2 b + w sin b) / q - (e w cos b)^2 / q^3``;
        * rise-dwell-return: the motion law (:meth:`CamProfile.motion_law`).

        Parameters
        ----------
        theta : array_like
            Cam angles (rad), any shape; periodic with period 2 pi.
        degrees : bool, keyword-only
            True: ``theta`` is in degrees (the result holds radians).

        Returns
        -------
        CamKinematics
            ``(lift, dlift, d2lift)``, each of the shape of ``theta`` (m,
            m/rad, m/rad^2).
        """
        theta = radians(theta, "theta", degrees)
        D = self._stack(_angles(theta))
        return CamKinematics(D[0], D[1], D[2])

    def pressure_angle(self, theta: Any, *, degrees: bool = False) -> np.ndarray:
        """Pressure angle ``varphi`` (rad) between the follower axis and the common normal.

        0 for a flat face; for a roller ``tan varphi = (s' - e_o) / (s_0 +
        s)``, ``s_0 = sqrt((R_b + r_f)^2 - e_o^2)`` (positive: the normal
        leans towards -t, against the cam's motion under the follower).

        Parameters
        ----------
        theta : array_like
            Cam angles (rad), any shape.
        degrees : bool, keyword-only
            True: ``theta`` in degrees, the pressure angle returned in degrees.

        Returns
        -------
        ndarray of the shape of ``theta`` (rad), in (-pi/2, pi/2).
        """
        theta = radians(theta, "theta", degrees)
        th = _angles(theta)
        if self.follower == "flat":
            return np.zeros(th.shape)
        D = self._stack(th)
        return degrees_out(np.arctan2(D[1] - self.offset, self._pitch_height + D[0]), degrees)

    def contact_force(self, theta: Any, speed: float, *, degrees: bool = False) -> np.ndarray:
        """Contact force ``N`` (N) at cam angles ``theta`` with the cam turning at constant ``speed``.

        ``N = (m omega^2 s'' + k s + F_0 + m g) / cos varphi`` (see the class
        docstring for the signs); negative values mean the follower would
        need a pull to stay on the cam: it leaves it.

        Parameters
        ----------
        theta : array_like
            Cam angles (rad), any shape.
        speed : float
            omega (rad/s); its sign does not matter.
        degrees : bool, keyword-only
            True: ``theta`` in degrees and ``speed`` in deg/s.

        Returns
        -------
        ndarray of the shape of ``theta`` (N).
        """
        theta = radians(theta, "theta", degrees)
        speed = radians(speed, "speed", degrees)
        th = _angles(theta)
        w = real_number(speed, "speed", expected="a finite cam speed (rad/s)")
        D = self._stack(th)
        axial = self.mass * w * w * D[2] + self.stiffness * D[0] + self.preload + self.mass * self.gravity
        if self.follower == "flat":
            return axial
        y = self._pitch_height + D[0]
        return axial * np.hypot(y, D[1] - self.offset) / y

    def jump_speed(self) -> float:
        """Lowest constant cam speed (rad/s) at which the contact force reaches zero in a revolution.

        ``N`` vanishes where ``m omega^2 s'' + k s + F_0 + m g = 0`` (the
        pressure angle does not enter), which needs ``s'' < 0``:
        ``omega_jump^2 = min over s'' < 0 of (k s + F_0 + m g) / (-m s'')``.
        Closed form for the flat-faced follower on the eccentric cam (the
        minimum is at theta = pi): ``omega_jump = sqrt((2 k e + F_0 + m g)
        / (m e))``. Otherwise the maximum of ``-m s'' / (k s + F_0 + m g)``
        is searched per smooth segment (samples, then Brent's method to
        ``1e-12`` rad, one-sided values at the segment ends where ``s''``
        jumps).

        Returns
        -------
        float
            omega_jump (rad/s); below it the follower stays on the cam at
            every angle.
        """
        m, k, F = self.mass, self.stiffness, self.preload + self.mass * self.gravity
        prof = self.profile
        if prof.kind == "eccentric" and self.follower == "flat":
            e = prof.eccentricity
            assert e is not None
            return math.sqrt((2.0 * k * e + F) / (m * e))
        return math.sqrt(1.0 / self._max_ratio()[0])

    def separation_intervals(self, speed: float, *, samples: int = 1440) -> tuple[tuple[float, float], ...]:
        """Cam-angle intervals ``(start, end)`` (rad) of one revolution where the closed-form force ``N < 0``.

        The follower leaves the cam where :meth:`contact_force` ``N(theta)``
        turns negative and lands where it returns to ``>= 0`` (one boundary
        convention for every contact test in core: the contact holds while
        ``N >= 0``, see :func:`rigidlab.core.contact.gap_crossings`). The force is
        tabulated at ``samples + 1`` angles ``2 pi j / samples`` (``j = 0 ..
        samples``); each sign change is refined by Brent's method on
        :meth:`contact_force` to ``rigidlab.core._constants.SEPARATION_XTOL``
        (1e-12 rad); a sample where ``N == 0`` exactly is the boundary
        itself. ``start`` is in ``[0, 2 pi)``; ``end > start`` and may
        exceed ``2 pi`` (an interval across cam angle 0 ends in the next
        revolution). Below :meth:`jump_speed` there is none.

        Parameters
        ----------
        speed : float
            Cam speed omega (rad/s); its sign does not matter.
        samples : int, keyword-only
            Samples per revolution of the tabulated force (>= 8): an
            interval shorter than about two samples may be missed.

        Returns
        -------
        tuple of (float, float)
            In increasing ``start``; ``((0, 2 pi),)`` if the force is
            negative at every sample.
        """
        from scipy.optimize import brentq

        from rigidlab.core._validation import positive_integer

        w = real_number(speed, "speed", expected="a finite cam speed (rad/s)")
        count = positive_integer(samples, "samples")
        if count < 8:
            raise ArgumentError("samples", f"samples: expected an integer >= 8, got {count!r}")
        step = _TWO_PI / count
        theta = np.arange(count + 1) * step
        force = np.asarray(self.contact_force(theta, w))
        if not np.any(force[:-1] < 0.0):
            return ()

        def f(x: float) -> float:
            return float(self.contact_force(x, w))

        def root(i: int) -> float:  # N changes sign between samples i and i + 1
            a, b = float(theta[i]), float(theta[i + 1])
            if force[i] == 0.0:
                return a
            if force[i + 1] == 0.0:
                return b
            return float(brentq(f, a, b, xtol=SEPARATION_XTOL))

        starts = [i for i in range(count) if force[i] >= 0.0 > force[i + 1]]
        ends = [i for i in range(count) if force[i] < 0.0 <= force[i + 1]]
        if not starts:
            return ((0.0, _TWO_PI),)
        end_roots = sorted(root(i) for i in ends)
        intervals = []
        for i in starts:
            a = root(i)
            later = [e for e in end_roots if e > a]
            intervals.append((a, later[0] if later else end_roots[0] + _TWO_PI))
        return tuple(intervals)

    def revolution(self, speed: float, *, samples: int = 1440) -> CamRevolution:
        """The closed-form motion over one revolution at constant ``speed``, tabulated at ``samples + 1`` angles.

        Lift, velocity ``omega s'`` and acceleration ``omega^2 s''`` from
        :meth:`kinematics`, the contact force ``N`` at ``speed`` and at
        :meth:`jump_speed` (:meth:`contact_force`), the contact point and
        normal (:meth:`touch_location`) and the separation intervals
        (:meth:`separation_intervals`, refined from the same ``samples``).
        The motion is periodic: revolution ``k`` is this one at times
        ``theta / omega + k 2 pi / omega``.

        Parameters
        ----------
        speed : float
            omega (rad/s), nonzero; its sign does not matter.
        samples : int, keyword-only
            Intervals per revolution (>= 8).

        Returns
        -------
        CamRevolution
        """
        from rigidlab.core._validation import positive_integer

        w = abs(real_number(speed, "speed", expected="a finite nonzero cam speed (rad/s)"))
        if w == 0.0:
            raise ArgumentError("speed", f"speed: expected a finite nonzero cam speed (rad/s), got {speed!r}")
        n = positive_integer(samples, "samples")
        if n < 8:
            raise ArgumentError("samples", f"samples: expected an integer >= 8, got {n!r}")
        theta = np.arange(n + 1) * (_TWO_PI / n)
        kin, touch, jump = self.kinematics(theta), self.touch_location(theta), float(self.jump_speed())
        force = np.asarray(self.contact_force(theta, w))
        k = int(np.argmin(force))
        return CamRevolution(w, jump, theta, np.asarray(kin.lift), w * np.asarray(kin.dlift),
                             w * w * np.asarray(kin.d2lift), force, np.asarray(self.contact_force(theta, jump)),
                             np.asarray(touch.point), np.asarray(touch.normal),
                             self.separation_intervals(w, samples=n), (float(force[k]), float(theta[k])))

    def touch_location(self, theta: Any, *, degrees: bool = False) -> CamTouch:
        """The contact point and common normal at cam angle ``theta`` in the fixed profile plane.

        The cam frame's :meth:`cam_curve` ``(theta).point`` and
        :meth:`contact_normal` turned by ``theta`` about the shaft (the
        plane rotation ``(x cos theta - y sin theta, x sin theta + y cos
        theta)``): where the follower touches the cam while it rides on it
        (the closed form; a run's contact point is ``CamMotion.contact_point``).

        Parameters
        ----------
        theta : array_like
            Cam angles (rad), any shape.
        degrees : bool, keyword-only
            True: ``theta`` is in degrees (the result holds radians).

        Returns
        -------
        CamTouch
            ``point`` (m) and ``normal``, each ``theta.shape + (2,)``.
        """
        theta = radians(theta, "theta", degrees)
        th = _angles(theta)
        c, s = np.cos(th)[..., None], np.sin(th)[..., None]
        p = np.asarray(self.cam_curve(th).point)
        nrm = np.asarray(self.contact_normal(th))

        def turned(v: np.ndarray) -> np.ndarray:
            return np.concatenate([c * v[..., :1] - s * v[..., 1:], s * v[..., :1] + c * v[..., 1:]], axis=-1)

        return CamTouch(turned(p), turned(nrm))

    def build_system(
        self,
        speed: float,
        *,
        start: float = 0.0,
        model: str = "constraint",
        contact_stiffness: float = 1e8,
        contact_damping: float = 0.5,
        contact_exponent: float = 1.5,
    ) -> CamSystem:
        """The cam and follower as a :class:`rigidlab.core.multibody.System` at time ``start``, assembled.

        Bodies: the cam (1 kg, a disk's inertia; it only loads the motor)
        on a revolute joint driven by a motor at ``speed``, and the follower
        (``mass``) on a prismatic joint, pressed by the spring
        (``add_spring_damper`` with free length set for ``preload`` at zero
        lift; a constant force when ``stiffness = 0``) and gravity, in
        contact with the cam through ``system.add_contact`` between the cam
        contour (:meth:`cam_curve` as a :class:`~rigidlab.core.contact.PlanarCurve`
        in the cam's body x-y plane) and a line (flat face) or a circle
        (roller) of the follower. See :class:`CamSystem` for the frames.

        Parameters
        ----------
        speed : float
            Cam speed omega (rad/s); the cam angle is ``omega t``. Refused
            above :data:`MAX_CAM_SPEED` (1e100 rad/s) in magnitude, where
            the accelerations overflow.
        start : float, keyword-only
            Time of the initial state (s): cam angle ``omega start``, the
            follower at its lift and velocity there.
        model : str, keyword-only
            ``"constraint"`` (the contact constraints, Eqs. 8.90-8.109) or
            ``"compliant"`` (Hunt-Crossley; the follower starts pressed in by
            the quasi-static penetration).
        contact_stiffness, contact_damping, contact_exponent : float, keyword-only
            Hunt-Crossley ``F = k delta^e (1 + 3/2 c delta_dot)`` (N/m^e,
            s/m): the compliant model, and the constraint model after a
            separation with ``on_separation="compliant"``.

        Returns
        -------
        CamSystem
        """
        return _build_system(self, speed, start, model, contact_stiffness, contact_damping, contact_exponent)

    def simulate(
        self,
        speed: float,
        t: Any,
        *,
        model: str = "constraint",
        on_separation: str = "stop",
        contact_stiffness: float = 1e8,
        contact_damping: float = 0.5,
        contact_exponent: float = 1.5,
        rtol: float = CAM_RTOL,
        atol: float = CAM_ATOL,
        method: str | None = None,
        initial: Any = None,
    ) -> CamMotion:
        """Run the cam at constant ``speed`` on :class:`rigidlab.core.multibody.System` (see :meth:`build_system`).

        Parameters
        ----------
        speed : float
            Cam speed omega (rad/s), at most :data:`MAX_CAM_SPEED` in
            magnitude (see :meth:`build_system`).
        t : (n,) array_like
            Non-decreasing output times (s); the cam angle is ``omega t``.
        model : str, keyword-only
            ``"constraint"`` (default: the contact constraints, normal force
            from the multiplier, Eq. 8.107) or ``"compliant"`` (Hunt-Crossley;
            the follower starts pressed in by the quasi-static penetration).
        on_separation : str, keyword-only
            Constraint model, when the normal force would turn negative
            (above :meth:`jump_speed`): ``"stop"`` (the outputs end before
            it), ``"compliant"`` (continue with the Hunt-Crossley contact:
            the follower leaves the cam and lands) or ``"bilateral"`` (the
            constraint pulls). The compliant model has no constraint to
            leave: it ignores ``on_separation`` (its follower leaves and
            lands by itself).
        contact_stiffness, contact_damping, contact_exponent : float, keyword-only
            The Hunt-Crossley law (see :meth:`build_system`).
        rtol, atol : float, keyword-only
            DOP853's tolerances (defaults ``rigidlab.core._constants.CAM_RTOL`` 1e-10,
            ``CAM_ATOL`` 1e-12).
        method : str or None, keyword-only
            ``System.simulate``'s method: ``"kinematic"``, ``"DOP853"`` or
            ``"RK45"`` (the fixed-step ones would need a ``dt``). Default: ``"kinematic"`` for the
            constraint model (the motor turns the cam and the contact holds
            the follower on it: no degree of freedom is left, so every
            output is a kinematic analysis with the contact force from the
            multiplier, exact to the Newton tolerance; a separation
            continued in the compliant model is integrated by DOP853 at
            ``rtol``, ``atol``), ``"DOP853"`` for the compliant model.
        initial : RunState or None, keyword-only
            Continue a run: ``motion.final_state`` of an earlier run of this
            cam at this ``speed`` with the same ``model`` and contact law
            (the System is built at ``initial.t`` and the run starts from
            that state, the contact in the model it was in: a follower that
            separated with ``on_separation="compliant"`` continues in
            flight, integrated by DOP853). ``t[0] >= initial.t``. Split at
            an output, two runs equal one long run to the Newton tolerance
            on the cam (``"kinematic"``) and to DOP853's tolerance in flight
            (docs/models.md).

        Returns
        -------
        CamMotion
        """
        return _simulate(self, speed, t, model, on_separation, contact_stiffness, contact_damping,
                         contact_exponent, rtol, atol, method, initial)

    def _max_ratio(self) -> tuple[float, float]:
        """``max over theta of -m s'' / (k s + F_0 + m g)`` and its angle."""
        m, k, F = self.mass, self.stiffness, self.preload + self.mass * self.gravity
        best, where = -math.inf, 0.0
        for seg in self._segments:
            u = np.linspace(seg.start, seg.stop, _SAMPLES)
            D = seg.stack(u)
            q = -m * D[2] / (k * D[0] + F)
            i = int(np.argmax(q))
            if q[i] > best:
                best, where = float(q[i]), float(u[i])
            if np.ptp(D[2]) == 0.0:
                continue

            def negative(x: float, seg: _Segment = seg) -> float:
                Dx = seg.stack(np.array([x]))
                return float(m * Dx[2, 0] / (k * Dx[0, 0] + F))

            lo, hi = u[max(i - 1, 0)], u[min(i + 1, u.size - 1)]
            res = minimize_scalar(negative, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
            if -res.fun > best:
                best, where = float(-res.fun), float(res.x)
        return best, where

    # ------------------------------------------------------------ geometry
    def pitch_curve(self, u: Any) -> CamCurve:
        """Path of the roller centre (flat face: of the point of the face on its axis) in the cam frame.

        ``c(u) = e_o t(u) + (s_0 + s(u)) n(u)`` with ``s_0 = sqrt((R_b +
        r_f)^2 - e_o^2)`` (roller) or ``R_b`` (flat face), derivatives by
        the product rule from the analytic derivatives of ``s`` (the first
        three derivatives need ``s`` to order 3).

        Parameters
        ----------
        u : array_like
            Cam angles (rad), any shape.

        Returns
        -------
        CamCurve
            ``point``, ``d1``, ``d2``, ``d3`` of shape ``u.shape + (2,)`` (m).
        """
        th = _angles(u, "u")
        c = self._pitch_stack(th, 3)
        return CamCurve(c[0], c[1], c[2], c[3])

    def _pitch_stack(self, theta: np.ndarray, order: int, pitch_height: float | None = None) -> np.ndarray:
        s = self._stack(theta)
        y = s.copy()
        y[0] += self._pitch_height if pitch_height is None else pitch_height
        n, t = _trig_stack(theta, order)
        c = self.offset * t
        for kk in range(order + 1):
            for j in range(kk + 1):
                c[kk] = c[kk] + _BINOMIAL[kk][j] * y[j][..., None] * n[kk - j]
        return c

    def cam_curve(self, u: Any) -> CamCurve:
        """The cam's contour in its body plane, with the derivatives the contact constraints need.

        The parameter ``u`` is the cam angle at which the point is in
        contact, so ``cam_curve(theta).point`` is the contact point on the
        cam (cam frame) at cam angle ``theta``.

        * Flat face: the envelope of the face's positions ``{p : p . n(u) =
          h(u)}``, ``h = R_b + s`` (the support function of the cam):
          ``p = h n + h' t``, ``p' = rho t``, ``p'' = rho' t - rho n``,
          ``p''' = (rho'' - rho) t - 2 rho' n`` with the radius of curvature
          ``rho = R_b + s + s''`` (> 0: the cam is convex).
        * Roller: the inner offset of the pitch curve, ``p = c - r_f nu``,
          ``nu = rot90(c') / |c'|`` the outward unit normal of the pitch
          curve (rot90 turns by +90 degrees in the plane).

        Parameters
        ----------
        u : array_like
            Cam angles (rad), any shape.

        Returns
        -------
        CamCurve
            ``point``, ``d1``, ``d2``, ``d3`` of shape ``u.shape + (2,)`` (m,
            m/rad^k).
        """
        th = _angles(u, "u")
        if self.follower == "flat":
            h = self._stack(th)
            h[0] += self.profile.base_radius
            n, t = _trig_stack(th, 0)
            n, t = n[0], t[0]
            rho, rho1, rho2 = (h[0] + h[2])[..., None], (h[1] + h[3])[..., None], (h[2] + h[4])[..., None]
            return CamCurve(h[0][..., None] * n + h[1][..., None] * t, rho * t, rho1 * t - rho * n,
                            (rho2 - rho) * t - 2.0 * rho1 * n)
        nu = self._normal_stack(th)
        c = self._pitch_stack(th, 3)
        p = c - self.roller_radius * nu
        return CamCurve(p[0], p[1], p[2], p[3])

    def _stack_float(self, theta: float) -> list[float]:
        """Lift and its first four derivatives at one cam angle (floats)."""
        wrapped = theta % _TWO_PI
        segments = self._segments
        for seg in reversed(segments):
            if wrapped >= seg.start:
                return seg.at(wrapped)
        return segments[0].at(wrapped)

    def _curve_float(self, u: float) -> tuple[tuple[float, float], ...]:
        """:meth:`cam_curve` at one parameter: ``(point, d1, d2, d3)`` as pairs of floats."""
        h = self._stack_float(u)
        sn, cs = math.sin(u), math.cos(u)
        n_, t_ = (sn, cs), (cs, -sn)
        if self.follower == "flat":
            h[0] += self.profile.base_radius
            rho, rho1, rho2 = h[0] + h[2], h[1] + h[3], h[2] + h[4]
            return (
                (h[0] * n_[0] + h[1] * t_[0], h[0] * n_[1] + h[1] * t_[1]),
                (rho * t_[0], rho * t_[1]),
                (rho1 * t_[0] - rho * n_[0], rho1 * t_[1] - rho * n_[1]),
                ((rho2 - rho) * t_[0] - 2.0 * rho1 * n_[0], (rho2 - rho) * t_[1] - 2.0 * rho1 * n_[1]),
            )
        # the pitch curve c = y n + e_o t and its derivatives (n' = t, t' = -n), as a_k n + b_k t
        y0, y1, y2, y3, y4 = h
        y0 += self._pitch_height
        eo = self.offset
        ab = ((y0, eo), (y1 - eo, y0), (y2 - y0, 2.0 * y1 - eo), (y3 - 3.0 * y1 + eo, 3.0 * y2 - y0),
              (y4 - 6.0 * y2 + y0, 4.0 * (y3 - y1) + eo))
        c = [(a * sn + b * cs, a * cs - b * sn) for a, b in ab]
        dx, dy = [v[0] for v in c[1:]], [v[1] for v in c[1:]]
        inv = _reciprocal_f(_sqrt_f([a + b for a, b in zip(_mul_f(dx, dx), _mul_f(dy, dy))]))
        nx, ny = _mul_f([-v for v in dy], inv), _mul_f(dx, inv)
        rf = self.roller_radius
        return tuple((c[k][0] - rf * nx[k], c[k][1] - rf * ny[k]) for k in range(4))

    def _normal_stack(self, theta: np.ndarray) -> np.ndarray:
        """Stack (4, ..., 2) of the pitch curve's outward unit normal ``nu = rot90(c') / |c'|``."""
        c = self._pitch_stack(theta, 4)
        d = c[1:]
        norm2 = _mul(d[..., 0], d[..., 0]) + _mul(d[..., 1], d[..., 1])
        inv = _reciprocal(_sqrt(norm2))
        rot = np.stack([-d[..., 1], d[..., 0]], axis=-1)
        return _mul(rot, inv[..., None])

    def contact_normal(self, theta: Any, *, degrees: bool = False) -> np.ndarray:
        """Common normal at cam angle ``theta``, in the cam frame, pointing from the cam to the follower.

        ``n(theta)`` for a flat face; the pitch curve's outward normal for a
        roller.

        Parameters
        ----------
        degrees : bool, keyword-only
            True: ``theta`` is in degrees.

        Returns
        -------
        ndarray, shape ``theta.shape + (2,)``.
        """
        theta = radians(theta, "theta", degrees)
        th = _angles(theta)
        if self.follower == "flat":
            return _trig_stack(th, 0)[0][0]
        return self._normal_stack(th)[0]

    def radius_of_curvature(self, u: Any) -> np.ndarray:
        """Signed radius of curvature of the cam contour (m), positive where the cam is convex.

        Flat face: ``rho = R_b + s + s''``. Roller: ``rho_pitch - r_f``,
        ``rho_pitch = -|c'|^3 / (c' x c'')`` the pitch curve's (the contour
        is traversed clockwise as u grows); where the pitch curve is
        concave the cam is concave with radius ``|rho_pitch| + r_f``.

        Parameters
        ----------
        u : array_like
            Cam angles (rad), any shape.

        Returns
        -------
        ndarray of the shape of ``u`` (m).
        """
        th = _angles(u, "u")
        if self.follower == "flat":
            D = self._stack(th)
            return self.profile.base_radius + D[0] + D[2]
        return self._pitch_radius(th) - self.roller_radius

    def _pitch_radius(self, theta: np.ndarray, pitch_height: float | None = None) -> np.ndarray:
        c = self._pitch_stack(theta, 2, pitch_height)
        d1, d2 = c[1], c[2]
        cross = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
        with np.errstate(divide="ignore"):
            return -np.linalg.norm(d1, axis=-1) ** 3 / cross

    def _check_shape(self) -> None:
        """Refuse a flat face on a non-convex cam and an undercut roller cam."""
        prof = self.profile
        if prof.kind == "eccentric":
            return  # a circle: rho = R (flat face) and a pitch circle of radius R + r_f > r_f (roller)
        if self.follower == "flat":
            worst, where = math.inf, 0.0
            for seg in self._segments:
                u = np.linspace(seg.start, seg.stop, _SAMPLES)
                D = seg.stack(u)
                need = -(D[0] + D[2])
                i = int(np.argmax(need))
                if prof.base_radius - need[i] < worst:
                    worst, where = float(prof.base_radius - need[i]), float(u[i])
            if not worst > 0:
                needed = prof.base_radius - worst
                raise ArgumentError("base_radius",
                    f"base_radius: a flat-faced follower needs a convex cam, radius of curvature R_b + s + s'' > 0, "
                    f"but it is {worst:.6g} m at cam angle {where:.6g} rad; use base_radius > {needed:.6g} m, "
                    f"longer rise/fall angles or a smaller lift, or a roller follower",
                    limit=needed,
                )
            return
        rho, where = self._smallest_convex_pitch_radius()
        if rho <= self.roller_radius:
            largest = self.largest_roller_radius()
            fix = (f"use roller_radius < {largest:.6g} m (the largest roller that does not undercut this cam) or a "
                   "larger base_radius" if largest > 0 else "no roller fits this motion: use a larger base_radius, "
                   "longer rise/fall angles or a smaller lift")
            raise ArgumentError("roller_radius",
                f"roller_radius: expected less than the pitch curve's smallest convex radius of curvature, which is "
                f"{rho:.6g} m (at cam angle {where:.6g} rad) with this roller, got {self.roller_radius!r}: the cam "
                f"would be undercut; {fix}",
                limit=largest,
            )

    def _smallest_convex_pitch_radius(self, pitch_height: float | None = None) -> tuple[float, float]:
        """The pitch curve's smallest convex radius of curvature (m) and its cam angle (rad); inf if none.
        ``pitch_height``: that of another roller (default this follower's)."""
        worst, where = math.inf, 0.0
        for seg in self._segments:
            u = np.linspace(seg.start, seg.stop, _SAMPLES)
            rho = self._pitch_radius(u, pitch_height)
            convex = rho > 0
            if np.any(convex):
                i = int(np.argmin(np.where(convex, rho, np.inf)))
                if rho[i] < worst:
                    worst, where = float(rho[i]), float(u[i])
        return worst, where

    def describe(self) -> tuple[tuple[str, str], ...]:
        """The cam and the follower in words: ``(topic, text)`` pairs ``("Cam", ...)``, ``("Follower", ...)``
        (lengths in mm, angles in degrees, the loads in SI units)."""
        p, mm = self.profile, lambda x: f"{1000.0 * x:.6g} mm"
        cam = (f"eccentric circle R = {mm(p.radius)}, e = {mm(p.eccentricity)}" if p.kind == "eccentric" else
               f"{p.law} rise-dwell-return, base circle {mm(p.base_radius)}, lift {mm(p.lift)}, rise "
               f"{math.degrees(p.rise):.6g}°, dwell {math.degrees(p.dwell):.6g}°, fall {math.degrees(p.fall):.6g}°")
        face = "flat face" if self.follower == "flat" else f"roller r = {mm(self.roller_radius)}"
        offset = f", offset {mm(self.offset)}" if self.offset else ""
        return ("Cam", cam), ("Follower", f"{face}{offset}, m = {self.mass:g} kg, k = {self.stiffness:g} N/m, "
                                          f"F0 = {self.preload:g} N, g = {self.gravity:g} m/s² towards the cam")

    def largest_roller_radius(self) -> float:
        """The largest roller radius (m) that does not undercut this cam with this follower offset:
        :func:`largest_roller_radius` ``(self.profile, offset=self.offset)`` (the follower's own roller aside)."""
        return largest_roller_radius(self.profile, offset=self.offset)


def largest_roller_radius(profile: CamProfile, *, offset: float = 0.0) -> float:
    """The largest roller radius (m) that does not undercut the cam of ``profile`` with the follower axis at ``offset``.

    The profile alone decides it (no roller need be given, nor fit): the
    pitch curve (the roller centre's path, :meth:`CamFollower.pitch_curve`,
    ``c(u) = e_o t(u) + (s_0 + s(u)) n(u)`` with ``s_0 = sqrt((R_b + r_f)^2
    - e_o^2)``) grows with the roller, so its smallest convex radius of
    curvature ``rho_min(r_f)`` does too; the cam is undercut when
    ``rho_min(r_f) <= r_f`` (the inner offset of the pitch curve by ``r_f``
    would cross itself). Returns the root of ``rho_min(r_f) = r_f`` by
    Brent's method (to 1e-9 m).

    Parameters
    ----------
    profile : CamProfile
    offset : float, keyword-only
        e_o (m): distance of the follower axis from the shaft (as in :class:`CamFollower`).

    Returns
    -------
    float
        r_f (m); inf when no roller undercuts the cam: the eccentric circle
        (its pitch curve is a circle of radius ``R + r_f``) and a
        rise-dwell-return cam whose pitch curve stays convex and no tighter
        than the roller at every size (the default ``rise_dwell_return()``);
        0.0 when no roller fits.
    """
    from scipy.optimize import brentq

    if not isinstance(profile, CamProfile):
        raise ArgumentError("profile", f"profile: expected a CamProfile, got {type(profile).__name__}")
    eo = real_number(offset, "offset", expected="a finite distance (m)")
    if profile.kind == "eccentric":
        return math.inf
    # the roller's geometry without its refusals: the pitch curves of every roller size are evaluated below
    probe = object.__new__(CamFollower)
    for name, value in (("profile", profile), ("follower", "roller"), ("roller_radius", 0.0), ("offset", eo),
                        ("_segments", profile._law_segments()), ("_pitch_height", 0.0)):
        object.__setattr__(probe, name, value)
    lo = max(0.0, abs(eo) - profile.base_radius) * (1.0 + 1e-12) + 1e-12

    def margin(r: float) -> float:  # (the pitch curve of roller r: its height at zero lift)
        height = math.sqrt((profile.base_radius + r) ** 2 - eo**2)
        return probe._smallest_convex_pitch_radius(height)[0] - r

    if not margin(lo) > 0:
        return 0.0
    hi = max(2.0 * lo, profile.base_radius)
    while margin(hi) > 0:
        hi *= 2.0
        if hi > 1e6 * (profile.base_radius + profile.lift):
            return math.inf
    return float(brentq(margin, lo, hi, xtol=1e-9))


def smallest_convex_rise(base_radius: float, lift: float, dwell: float, law: str, *, xtol: float = default_angle(1e-9),
                         degrees: bool = False) -> float:
    """The smallest rise = fall angle (rad) whose :meth:`CamProfile.rise_dwell_return` cam is convex.

    A flat-faced follower needs ``R_b + s + s'' > 0`` at every cam angle
    (:meth:`CamFollower.radius_of_curvature`); ``s'' = L f''(x) / rise^2``
    shrinks as the rise lengthens, so the cam is convex above one rise
    angle, found here by bisection to ``xtol`` (rad) between 0 and the
    longest rise ``(2 pi - dwell) / 2`` (``rise + dwell + fall = 2 pi``).
    A roller follower's cam may be undercut at any rise
    (:meth:`CamFollower.largest_roller_radius`).

    Parameters
    ----------
    base_radius, lift, dwell, law :
        As in :meth:`CamProfile.rise_dwell_return` (m, m, rad).
    xtol : float, keyword-only
        Bracket width (rad), > 0; the returned angle is the bracket's convex end.
    degrees : bool, keyword-only
        True: ``dwell`` and ``xtol`` in degrees, the rise returned in degrees.

    Returns
    -------
    float
        The rise (rad); inf when even the longest rise leaves the cam concave.
    """
    dwell = radians(dwell, "dwell", degrees)
    xtol = radians(xtol, "xtol", degrees)
    b2 = _non_negative(dwell, "dwell", "rad")
    if not b2 < _TWO_PI:
        raise ArgumentError("dwell", f"dwell: expected less than 2 pi (room for a rise and a fall), got {b2!r} rad")
    Rb, L, _, b2, _, law = _rise_dwell_return_fields(base_radius, lift, 1e-12, b2, 1e-12, law)
    tol = _positive(xtol, "xtol", "rad")

    def convex(rise: float) -> bool:
        profile = CamProfile.rise_dwell_return(base_radius=Rb, lift=L, rise=rise, dwell=b2, fall=rise, law=law)
        try:
            CamFollower(profile, follower="flat")
        except ArgumentError as exc:
            if exc.argument != "base_radius":
                raise
            return False
        return True

    lo, hi = 0.0, (_TWO_PI - b2) / 2.0
    if not convex(hi):
        return math.inf
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if convex(mid) else (mid, hi)
    return float(degrees_out(hi, degrees))


# ------------------------------------------------------------------ simulation on the multibody System
#: Contact models of :meth:`CamFollower.simulate`.
CAM_CONTACT_MODELS = ("constraint", "compliant")


class CamSample(NamedTuple):
    """A :class:`CamMotion` at one time between its outputs (:meth:`CamMotion.at`).

    Attributes
    ----------
    lift : float
        Follower lift (m).
    contact_force : float
        Normal force (N), > 0 pressing.
    contact_point, contact_normal : (3,) ndarray
        Global (m; unit, from the cam to the follower).
    in_contact : bool
        False while the follower is in flight (no contact normal, no force).
    """

    lift: float
    contact_force: float
    contact_point: np.ndarray
    contact_normal: np.ndarray
    in_contact: bool


@dataclass(frozen=True)
class CamMotion:
    """A cam-follower run on :class:`rigidlab.core.multibody.System` (see :meth:`CamFollower.simulate`).

    Attributes
    ----------
    t : (n,) ndarray
        Output times (s); with ``on_separation="stop"`` they end before a
        separation.
    cam_angle : (n,) ndarray
        ``theta = speed t`` (rad), not wrapped.
    lift : (n,) ndarray
        Follower displacement along its axis from its lowest position on
        the cam (m), from the simulated follower body (negative while a
        compliant contact is pressed in).
    lift_rate : (n,) ndarray
        Its rate (m/s).
    contact_force : (n,) ndarray
        Normal force between cam and follower (N), positive while pressing:
        the contact's independent multiplier (Eq. 8.107) in the constraint
        model, the Hunt-Crossley force in the compliant model (0 while
        apart).
    contact_point : (n, 3) ndarray
        Contact point on the cam, global (m).
    gap : (n,) ndarray
        Distance between cam and follower along the common normal (m);
        negative: the compliant contact's penetration.
    separations : (k, 2) ndarray
        ``(time (s), cam angle (rad))`` where the follower leaves the cam:
        the zero crossings of the constraint's normal force (Brent's method
        on the dense output), and in the compliant model the openings of
        the gap (linear interpolation between outputs).
    landings : (k, 2) ndarray
        ``(time, cam angle)`` where a compliant contact closes again.
    status : str
        ``"completed"`` or ``"separated"`` (stopped at a separation).
    trajectory : MultibodyTrajectory or None
        The System's run (poses of ``system.bodies``: cam, follower); None
        in a pickled copy (the trajectory holds the System's compiled
        model, which does not pickle).
    contact_normal : (n, 3) ndarray
        Common normal at the contact, global, from the cam to the follower.
    constraint : (n,) ndarray of bool
        The contact was in the constraint model at the output (False: the
        compliant model, from the start or after a separation).
    final_state : RunState or None
        The state the run ended in (``trajectory.final_state``; it
        pickles): ``cam.simulate(speed, t2, initial=motion.final_state)``
        continues the run.
    """

    t: np.ndarray  # (n,)
    cam_angle: np.ndarray  # (n,)
    lift: np.ndarray  # (n,)
    lift_rate: np.ndarray  # (n,)
    contact_force: np.ndarray  # (n,)
    contact_point: np.ndarray  # (n, 3)
    gap: np.ndarray  # (n,)
    separations: np.ndarray  # (k, 2)
    landings: np.ndarray  # (k, 2)
    status: str
    trajectory: Any = field(repr=False)
    contact_normal: np.ndarray | None = field(default=None, repr=False)  # (n, 3)
    constraint: np.ndarray | None = field(default=None, repr=False)  # (n,)
    final_state: Any = field(default=None, repr=False)

    @property
    def periodic(self) -> bool:
        """True when the run is in its periodic steady state: the contact held in the constraint model at every
        output and never separated, so the follower is driven by the cam alone (no degree of freedom of its
        own) and the next revolution repeats this one a period later. A compliant stretch (after a
        separation, or from the start) is not: its flight and bounces depend on the state it began in."""
        return self.separations.size == 0 and self.constraint is not None and bool(np.all(self.constraint))

    def at(self, t: float) -> CamSample:
        """The run between its outputs at time ``t`` (s; clamped to ``[t[0], t[-1]]``), linear between the two
        outputs around it: what a display shows between outputs (the outputs themselves exactly).

        The contact holds (``in_contact``) while the contact is in the constraint model at the nearer output or
        the interpolated gap is ``<= 0`` (the one boundary convention of :func:`rigidlab.core.contact.gap_crossings`);
        else the follower is in flight, ``contact_point`` is the cam's point nearest it and ``contact_normal``
        (unit, renormalized after the interpolation) points from it to the follower.

        Returns
        -------
        CamSample
        """
        time = real_number(t, "t", expected="a finite time (s)")
        n = self.t.size
        k = int(min(max(np.searchsorted(self.t, time, side="right") - 1, 0), max(n - 2, 0)))
        span = float(self.t[k + 1] - self.t[k]) if n > 1 else 0.0
        w = min(max((time - float(self.t[k])) / span, 0.0), 1.0) if span > 0.0 else 0.0

        def lerp(a: np.ndarray) -> Any:
            return a[k] if n == 1 else a[k] + w * (a[k + 1] - a[k])

        normal = np.asarray(lerp(self.contact_normal), dtype=float)
        norm = float(np.linalg.norm(normal))
        held = self.constraint is not None and bool(self.constraint[min(k + 1, n - 1) if w >= 0.5 else k])
        return CamSample(float(lerp(self.lift)), float(lerp(self.contact_force)), np.asarray(lerp(self.contact_point)),
                         normal / norm if norm > 0.0 else normal, held or float(lerp(self.gap)) <= 0.0)

    def describe(self, i: int) -> tuple[tuple[str, str], ...]:
        """Output ``i`` in words: ``(topic, text)`` pairs: the contact (``"in flight"`` with the gap, or ``"on
        the cam"`` with the model and the force) and ``"so far"``: the separations and landings up to ``t[i]``."""
        i = int(i)
        gap, force = float(self.gap[i]), float(self.contact_force[i])
        held = self.constraint is not None and bool(self.constraint[i])
        if gap > 0.0 and not held:
            contact = ("in flight", f"gap {1000.0 * gap:.3f} mm, N = 0")
        elif held:
            contact = ("on the cam", f"contact constraint, N = {force:.3f} N")
        else:
            contact = ("on the cam", f"Hunt-Crossley, pressed in {1e6 * -gap:.3g} µm, N = {force:.3f} N")
        now = self.t[i]
        return contact, ("so far", f"{int(np.count_nonzero(self.separations[:, 0] <= now))} separation(s), "
                                   f"{int(np.count_nonzero(self.landings[:, 0] <= now))} landing(s)")

    def __reduce__(self):
        arrays = (self.t, self.cam_angle, self.lift, self.lift_rate, self.contact_force, self.contact_point, self.gap,
                  self.separations, self.landings)
        return (CamMotion, (*arrays, self.status, None, self.contact_normal, self.constraint, self.final_state))


@dataclass(frozen=True)
class CamSystem:
    """The cam-follower as a :class:`rigidlab.core.multibody.System` (see :meth:`CamFollower.build_system`).

    The profile plane is the global x-z plane (profile x -> global x,
    profile y -> global z): the follower slides along global +z above the
    shaft, gravity acts along -z, and the cam turns about the global -y axis
    through the origin (its body z axis; body x-y is the profile plane).

    Attributes
    ----------
    system : System
    cam, follower : Body
    cam_joint : Joint
        Revolute joint ground-cam at the origin, axis global -y.
    motor : Motor
        Drives the cam angle: ``theta(t) = speed t``.
    follower_joint : Joint
        Prismatic joint ground-follower along global +z.
    spring : SpringDamper or Force
        The follower spring (a constant force ``F_0`` when ``stiffness =
        0``).
    contact : Contact
        Cam contour (a :class:`~rigidlab.core.contact.PlanarCurve` on the cam) on the
        flat face (a line) or the roller (a circle) of the follower.
    lift_origin : float
        Global z of the follower's centre of mass at zero lift (m).
    speed : float
        Cam speed (rad/s).
    """

    system: Any
    cam: Any
    follower: Any
    cam_joint: Any
    motor: Any
    follower_joint: Any
    spring: Any
    contact: Any
    lift_origin: float
    speed: float


_CAM_ORIENTATION = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)  # body x-y plane = global x-z plane, body z = -y


def _cam_planar_curve(cam: CamFollower):
    """The cam contour as a counter-clockwise PlanarCurve in the cam body's x-y plane: ``c(sigma) = p(-sigma)``.

    The kernel asks for the point and its three derivatives one after the
    other at the same parameter: the last evaluation is kept (a small
    cache per curve; a lock keeps it consistent across threads).
    """
    import threading

    from rigidlab.core.contact import PlanarCurve

    lock = threading.Lock()
    last: list[Any] = [None, None]
    signs = (1.0, -1.0, 1.0, -1.0)

    def evaluate(s: Any) -> list[np.ndarray]:
        arr = np.asarray(s, dtype=float)
        key = (arr.shape, arr.tobytes())
        with lock:
            if last[0] == key:
                return last[1]
        if arr.ndim == 0:
            values = [np.array(v) * sign for v, sign in zip(cam._curve_float(-float(arr)), signs)]
        else:
            c = cam.cam_curve(-arr)
            values = [c.point, -c.d1, c.d2, -c.d3]
        with lock:
            last[0], last[1] = key, values
        return values

    curve = PlanarCurve(lambda s: evaluate(s)[0], first=lambda s: evaluate(s)[1], second=lambda s: evaluate(s)[2],
                        third=lambda s: evaluate(s)[3], bounds=(-math.pi, math.pi),
                        length_scale=cam.profile.base_radius)
    curve_float = cam._curve_float

    def derivs_float(x: float, order: int) -> list[tuple[float, float]]:
        # one point on floats, straight from the closed form (the kernel's float path calls this)
        (p0, p1), (a0, a1), d2, (b0, b1) = curve_float(-x)
        return [(p0, p1), (-a0, -a1), d2, (-b0, -b1)][: order + 1]

    curve._derivs_2d = derivs_float
    return curve


#: Largest cam speed (rad/s) a run takes: the System's accelerations stay finite (see :func:`_build_system`).
MAX_CAM_SPEED = 1e100


def _build_system(cam: CamFollower, speed: Any, start: Any, model: Any, contact_stiffness: Any,
                  contact_damping: Any, contact_exponent: Any) -> CamSystem:
    from rigidlab.core.contact import PlanarCurve
    from rigidlab.core.multibody import System
    from rigidlab.core.rotations import quaternion_product

    w = real_number(speed, "speed", expected="a finite cam speed (rad/s)")
    if abs(w) > MAX_CAM_SPEED:
        # the accelerations carry omega^2 times lengths and products of such terms: past this they overflow,
        # and the contact search then reports a degenerate curve instead of the speed
        raise ArgumentError("speed",
                            f"speed: expected a cam speed (rad/s) of magnitude at most {MAX_CAM_SPEED:g}, got {w!r}")
    t0 = real_number(start, "start", expected="a finite start time (s)")
    if not isinstance(model, str) or model not in CAM_CONTACT_MODELS:
        raise ArgumentError("model", f"model: expected one of {list(CAM_CONTACT_MODELS)}, got {short_repr(model)}")
    kc = _positive(contact_stiffness, "contact_stiffness", "N/m^exponent")
    cc = _non_negative(contact_damping, "contact_damping", "s/m")
    ec = real_number(contact_exponent, "contact_exponent", expected="a finite exponent >= 1")
    if not ec >= 1.0:
        raise ArgumentError("contact_exponent", f"contact_exponent: expected a finite exponent >= 1, got {ec!r}")
    theta0 = w * t0
    kin = cam.kinematics(theta0)
    s0, ds0 = float(kin.lift), float(kin.dlift)
    height = cam._pitch_height  # follower's centre of mass at zero lift: face point or roller centre
    penetration = 0.0
    if model == "compliant":
        # start pressed in by the quasi-static Hunt-Crossley penetration
        force = float(cam.contact_force(theta0, w))
        penetration = (max(force, 0.0) / kc) ** (1.0 / ec)
        scale = min(cam.profile.base_radius, cam.roller_radius if cam.follower == "roller" else math.inf)
        if penetration > 0.5 * scale:  # (System.add_contact would refuse it, blaming the bodies' placement)
            raise ArgumentError("contact_stiffness",
                f"contact_stiffness: expected a contact stiff enough to hold the follower near the cam's surface, "
                f"got {kc!r} N/m^{ec:g}: the contact force of {force:.4g} N presses it {penetration:.3g} m into "
                f"the cam, more than half the cam's length scale {scale:g} m; use contact_stiffness > "
                f"{force / (0.5 * scale) ** ec:.3g} N/m^{ec:g} (the default 1e8 presses it in by "
                f"{(force / 1e8) ** (1.0 / ec):.2g} m)")
    m = cam.mass
    system = System(gravity=(0.0, 0.0, -cam.gravity))
    half = 0.5 * theta0
    # cam turned by theta0 about its body z axis
    qc = np.array(_CAM_ORIENTATION)
    turn = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])
    p_cam = quaternion_product(qc, turn)
    R_max = float(np.max(np.linalg.norm(cam.cam_curve(np.linspace(0.0, _TWO_PI, 361)).point, axis=-1)))
    cam_mass = 1.0
    cam_body = system.add_body("cam", mass=cam_mass, inertia=(cam_mass * R_max**2 / 4,) * 2 + (cam_mass * R_max**2 / 2,),
                               position=(0.0, 0.0, 0.0), orientation=p_cam, omega_body=(0.0, 0.0, w))
    z_origin = height
    z0 = z_origin + s0 - penetration
    side = max(cam.profile.base_radius, 0.01) / 2
    follower = system.add_body("follower", mass=m, inertia=(m * side * side / 6.0,) * 3,
                               position=(cam.offset, 0.0, z0), orientation=_CAM_ORIENTATION,
                               velocity=(0.0, 0.0, w * ds0))
    cam_joint = system.add_joint("revolute", system.ground, cam_body, point=(0.0, 0.0, 0.0), axis=(0.0, -1.0, 0.0),
                                 name="cam_joint")
    motor = system.add_motor(cam_joint, angle=(lambda t: w * (t - t0), lambda t: w, lambda t: 0.0), name="cam_motor")
    follower_joint = system.add_joint("prismatic", system.ground, follower, point=(cam.offset, 0.0, z0),
                                      axis=(0.0, 0.0, 1.0), name="follower_joint")
    k, F0 = cam.stiffness, cam.preload
    if k > 0:
        reach = 0.1 + 2.0 * float(np.max(cam.kinematics(np.linspace(0.0, _TWO_PI, 361)).lift))
        anchor = (cam.offset, 0.0, z_origin + reach)
        spring = system.add_spring_damper(system.ground, anchor, follower, (cam.offset, 0.0, z0), stiffness=k,
                                          free_length=reach + F0 / k, name="follower_spring")
    else:
        spring = system.add_force(follower, lambda t, state: np.array([0.0, 0.0, -F0]), name="follower_preload")
    if cam.follower == "flat":
        follower_curve = PlanarCurve.line(point=(0.0, 0.0), normal=(0.0, -1.0))
    else:
        follower_curve = PlanarCurve.circle(cam.roller_radius)
    contact = system.add_contact(cam_body, _cam_planar_curve(cam), follower, follower_curve, model=model,
                                 stiffness=kc, damping=cc, exponent=ec, name="cam_contact")
    system.assemble(t=t0)
    return CamSystem(system, cam_body, follower, cam_joint, motor, follower_joint, spring, contact, z_origin, w)


def _gap_crossings(t: np.ndarray, speed: float, gap: np.ndarray, compliant: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Openings and closings of a compliant contact between outputs: ``(k, 2)`` times and cam angles each
    (:func:`rigidlab.core.contact.gap_crossings`: only pairs of outputs both in the compliant model; ``gap <= 0``
    counts as closed; the time interpolated linearly in the gap)."""
    from rigidlab.core.contact import gap_crossings

    return tuple(np.stack([times, speed * times], axis=-1).reshape(-1, 2)
                 for times in gap_crossings(t, gap, compliant=compliant))


#: Methods of :meth:`CamFollower.simulate`: the adaptive ones and the kinematic analysis.
_CAM_METHODS = ("kinematic", "DOP853", "RK45")


def _simulate(cam: CamFollower, speed: Any, t: Any, model: Any, on_separation: Any, contact_stiffness: Any,
              contact_damping: Any, contact_exponent: Any, rtol: Any, atol: Any, method: Any = None,
              initial: Any = None) -> CamMotion:
    from rigidlab.core.multibody import RunState

    times = output_times(t)
    if initial is not None and not isinstance(initial, RunState):
        raise ArgumentError("initial", f"initial: expected a RunState (motion.final_state), got "
                                       f"{short_repr(initial)}")
    start = float(times[0]) if initial is None else float(initial.t)
    built = _build_system(cam, speed, start, model, contact_stiffness, contact_damping, contact_exponent)
    if method is None:
        method = "kinematic" if model == "constraint" else "DOP853"
    elif method not in _CAM_METHODS:
        raise ArgumentError("method",
                            f"method: expected one of {', '.join(map(repr, _CAM_METHODS))} or None (the cam's run "
                         f"takes rtol and atol, not a fixed step), got {method!r}")
    traj = built.system.simulate(times, method=method, rtol=rtol, atol=atol, on_separation=on_separation,
                                 initial=initial)
    history = traj.contact(built.contact)
    follower = built.system.bodies.index(built.follower)
    z = traj.q[:, 3 * follower + 2]
    zd = traj.v[:, 3 * follower + 2]
    w = built.speed
    lift = z - built.lift_origin
    force = np.array(history.normal_force)
    gap = np.array(history.gap)
    events = np.array([(sep.t, w * sep.t) for sep in traj.separations], dtype=float).reshape(-1, 2)
    compliant = ~np.asarray(history.constraint, dtype=bool)
    opened, landings = _gap_crossings(np.asarray(traj.t), w, gap, compliant)
    both = np.concatenate([events, opened])
    sep = both[np.argsort(both[:, 0], kind="stable")]
    return CamMotion(
        t=np.array(traj.t), cam_angle=w * np.array(traj.t), lift=lift, lift_rate=np.array(zd), contact_force=force,
        contact_point=np.array(history.point), gap=gap, separations=sep, landings=landings, status=traj.status,
        trajectory=traj, contact_normal=np.array(history.normal), constraint=~compliant,
        final_state=traj.final_state,
    )
