"""The free rigid body of the Dzhanibekov demonstration: bodies, initial states, the polhode, a ghost run.

Torque-free rotation, state ``(p, omega_body)`` of :class:`rigidlab.core.rigid_body.FreeBodyModel`:
``I omega_body_dot = (I omega_body) x omega_body`` and ``p_dot = G_bar(p).T omega_body / 2``
(Eqs. 8.53-8.54), solved exactly by :func:`rigidlab.core.rigid_body.free_body_solution` (Landau & Lifshitz
sec. 37). This module gives what a demonstration of it needs beyond the equations:

* :func:`free_body_shape` -- three bodies (a T-handle, a brick, a disc) as parts of uniform density
  (prisms of regular polygonal cross-section, cuboids) with their mass properties in closed form;
* :func:`spin_about_principal_axis`, :func:`euler_parameters_momentum_up` and :func:`free_body_start` --
  initial states and the exact motion from them;
* :func:`polhode_class` -- which axis the polhode circles, how close it passes to the intermediate
  axis, and whether the body flips (the Dzhanibekov effect), with a sentence saying so;
* :func:`free_body_window` -- the exact motion over a time window and, optionally, a numerical run
  of :mod:`rigidlab.core.integrators` from a state, compared with the exact motion sample by sample
  (orientation angle error, Eq. 8.82; drifts of the invariants E, ``|L|`` and ``|p|``).

SI units; ``omega_body`` in the body frame, ``omega`` and ``L`` in the global frame; Euler
parameters scalar first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigidlab.core._validation import real_number
from rigidlab.core.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS, integrate
from rigidlab.core.rigid_body import (
    FreeBodyModel,
    FreeBodySolution,
    MomentumGeometry,
    _inertia,
    _vec,
    angular_momentum_global,
    free_body_solution,
    momentum_geometry,
    principal_axes,
    rotation_angle_between,
)
from rigidlab.core.rotations import euler_parameters_from_axis_angle, normalize_euler_parameters, rotate_vector

__all__ = [
    "FREE_BODY_NAMES",
    "GHOST_COLUMNS",
    "INVARIANT_ROUND_OFF",
    "NEAR_SEPARATRIX_ANGLE",
    "PRINCIPAL_AXIS_NAMES",
    "WINDOW_COLUMNS",
    "Cuboid",
    "FreeBodyShape",
    "FreeBodyStart",
    "FreeBodyWindow",
    "GhostComparison",
    "PolhodeClass",
    "Prism",
    "euler_parameters_momentum_up",
    "free_body_shape",
    "free_body_start",
    "free_body_window",
    "polhode_class",
    "spin_about_principal_axis",
]

#: The bodies of :func:`free_body_shape`.
FREE_BODY_NAMES = ("T-handle", "Brick 1 x 0.6 x 0.3", "Disc (symmetric top)")
#: Principal axes by ascending moment.
PRINCIPAL_AXIS_NAMES = ("minor", "intermediate", "major")
#: A relative drift of E or ``|L|`` (or ``||p| - 1|``) at or below this is round-off: ten machine epsilons
#: (each invariant is a short sum of products of the state, a few roundings of relative size eps).
INVARIANT_ROUND_OFF = 10.0 * float(np.finfo(float).eps)
#: Names (with units) of the columns of :meth:`FreeBodyWindow.columns`: the exact motion, then the run's.
WINDOW_COLUMNS = ("p0", "p1", "p2", "p3", "omega_x (rad/s)", "omega_y (rad/s)", "omega_z (rad/s)", "E (J)",
                  "|L| (kg m^2/s)")
GHOST_COLUMNS = tuple(f"ghost {name}" for name in WINDOW_COLUMNS) + ("ghost angle error (rad)",)
#: :func:`polhode_class` calls a motion a flip about the intermediate axis when the polhode passes within
#: this angle (rad) of that axis: 10 deg (a 2 % offset from that axis: ~2 deg; stable spins: over 80 deg).
NEAR_SEPARATRIX_ANGLE = math.radians(10.0)


# -- bodies ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Prism:
    """A right prism whose cross-section is a regular polygon (a cylinder as a mesh draws it).

    ``radius`` is the polygon's circumradius (m), ``height`` its length along body axis ``axis``
    (0, 1, 2: x, y, z) (m), ``sections`` its number of sides (>= 3), ``center`` (3,) its centroid
    in the body's modelling frame (m).
    """

    radius: float
    height: float
    sections: int
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: int = 2

    def mass_properties(self, density: float) -> tuple[float, np.ndarray]:
        """Mass (kg) and inertia tensor (3, 3) about the centroid (kg m^2).

        A regular n-gon of circumradius r has area ``n r^2 sin(a) / 2`` and polar second moment
        ``n r^4 sin(a) (2 + cos(a)) / 12`` (a = 2 pi / n; n triangles from the centre), the same
        about every in-plane axis through the centre (half the polar one) for n >= 3.
        """
        n, r, h = self.sections, self.radius, self.height
        a = 2.0 * math.pi / n
        area = 0.5 * n * r * r * math.sin(a)
        polar = n * r**4 * math.sin(a) * (2.0 + math.cos(a)) / 12.0
        mass = density * area * h
        moments = np.full(3, density * (0.5 * polar * h + area * h**3 / 12.0))
        moments[self.axis] = density * polar * h
        return mass, np.diag(moments)


@dataclass(frozen=True)
class Cuboid:
    """A rectangular box of ``extents`` (3,) (m) along the body axes, centred at ``center`` (3,) (m)."""

    extents: tuple[float, float, float]
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def mass_properties(self, density: float) -> tuple[float, np.ndarray]:
        """Mass (kg) and inertia tensor (3, 3) about the centre (kg m^2): ``m (b^2 + c^2) / 12`` etc."""
        a, b, c = self.extents
        mass = density * a * b * c
        return mass, np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * (mass / 12.0)


@dataclass(frozen=True)
class FreeBodyShape:
    """A body made of parts of one ``density`` (kg/m^3) that touch without overlapping.

    Attributes
    ----------
    name : one of :data:`FREE_BODY_NAMES`
    parts : tuple of :class:`Prism` / :class:`Cuboid`, in the modelling frame (body axes)
    density : kg/m^3
    mass : kg
    center_of_mass : (3,) in the modelling frame (m); the body frame has its origin here
    inertia : (3, 3) inertia tensor about the centre of mass, body axes (kg m^2) (parallel axes)
    """

    name: str
    parts: tuple[Prism | Cuboid, ...]
    density: float
    mass: float
    center_of_mass: np.ndarray  # (3,)
    inertia: np.ndarray  # (3, 3)


def free_body_shape(name: str, *, density: float = 1000.0) -> FreeBodyShape:
    """Body ``name`` of :data:`FREE_BODY_NAMES` with its mass properties.

    * ``"T-handle"``: a bar (32-sided prism, r 0.08 m, 1.2 m along x), a stem below it (r 0.07 m,
      0.62 m along z) and a knob (0.22 x 0.22 x 0.12 m box): three distinct moments, the
      intermediate axis along x;
    * ``"Brick 1 x 0.6 x 0.3"``: a box;
    * ``"Disc (symmetric top)"``: a 64-sided prism, r 0.6 m, 0.15 m thick along z (two equal moments).

    Raises
    ------
    ValueError
        For an unknown name or a density that is not a positive finite number.
    """
    rho = real_number(density, "density")
    if not (math.isfinite(rho) and rho > 0.0):
        raise ValueError(f"density: expected a positive finite number, got {density!r}")
    if name == FREE_BODY_NAMES[0]:
        parts: tuple[Prism | Cuboid, ...] = (
            Prism(0.08, 1.2, 32, axis=0),
            Prism(0.07, 0.62, 32, center=(0.0, 0.0, -0.39)),
            Cuboid((0.22, 0.22, 0.12), center=(0.0, 0.0, -0.76)),
        )
    elif name == FREE_BODY_NAMES[1]:
        parts = (Cuboid((1.0, 0.6, 0.3)),)
    elif name == FREE_BODY_NAMES[2]:
        parts = (Prism(0.6, 0.15, 64),)
    else:
        raise ValueError(f"name: expected one of {list(FREE_BODY_NAMES)}, got {name!r}")
    props = [part.mass_properties(rho) for part in parts]
    centers = np.array([part.center for part in parts], dtype=float)
    masses = np.array([m for m, _ in props])
    mass = float(masses.sum())
    com = masses @ centers / mass
    inertia = np.zeros((3, 3))
    for (m, I_part), c in zip(props, centers - com, strict=True):
        inertia += I_part + m * (float(c @ c) * np.eye(3) - np.outer(c, c))  # parallel axes
    for a in (com, inertia):
        a.setflags(write=False)
    return FreeBodyShape(name, parts, rho, mass, com, inertia)


# -- initial states -------------------------------------------------------------------------------------
def spin_about_principal_axis(inertia: Any, axis: str, *, rate: float, offset: float = 0.0) -> np.ndarray:
    """``omega_body`` (3,) of a spin ``rate`` (rad/s) about principal axis ``axis`` (one of
    :data:`PRINCIPAL_AXIS_NAMES`), plus ``offset * rate`` about each of the other two principal axes.

    The principal axes are :func:`rigidlab.core.rigid_body.principal_axes` (columns, ascending moments).

    Raises
    ------
    ValueError
        For an unknown axis name, a bad inertia tensor, or a non-finite rate or offset.
    """
    if axis not in PRINCIPAL_AXIS_NAMES:
        raise ValueError(f"axis: expected one of {list(PRINCIPAL_AXIS_NAMES)}, got {axis!r}")
    w, eps = real_number(rate, "rate"), real_number(offset, "offset")
    _, Q = principal_axes(inertia)
    w_principal = np.full(3, eps * w)
    w_principal[PRINCIPAL_AXIS_NAMES.index(axis)] = w
    return Q @ w_principal


def euler_parameters_momentum_up(inertia: Any, omega_body: Any) -> np.ndarray:
    """Euler parameters (4,) (scalar first) of the smallest rotation that turns ``L_body = I omega_body``
    onto global +Z: the identity at rest or when L is along +Z already, half a turn about X when it is
    along -Z; otherwise the axis ``l x Z`` and angle ``atan2(|l x Z|, l_z)`` (Eq. 8.46)."""
    L = _inertia(inertia) @ _vec(omega_body, "omega_body")
    n = float(np.linalg.norm(L))
    if n == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    l = L / n
    axis = np.array([l[1], -l[0], 0.0])
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0]) if l[2] > 0.0 else np.array([0.0, 1.0, 0.0, 0.0])
    return np.asarray(euler_parameters_from_axis_angle(axis / s, math.atan2(s, float(l[2]))), dtype=float)


@dataclass(frozen=True)
class FreeBodyStart:
    """The exact torque-free motion of a body started with its angular momentum along +Z (read-only arrays).

    Attributes
    ----------
    inertia : (3, 3) inertia tensor about the centre of mass, body frame (kg m^2)
    omega_body0 : (3,) initial angular velocity, body frame (rad/s)
    p0 : (4,) initial Euler parameters (scalar first): :func:`euler_parameters_momentum_up`
    solution : :class:`rigidlab.core.rigid_body.FreeBodySolution` from ``p0``, ``omega_body0``
    geometry : :class:`rigidlab.core.rigid_body.MomentumGeometry` (momentum sphere, energy ellipsoid)
    L_global : (3,) the constant angular momentum, global frame: ``(0, 0, |L|)`` to round-off (kg m^2/s)
    polhode : :class:`PolhodeClass`
    body : the name of the :class:`FreeBodyShape` it was started from ("" for a bare inertia tensor)
    """

    inertia: np.ndarray
    omega_body0: np.ndarray
    p0: np.ndarray
    solution: FreeBodySolution
    geometry: MomentumGeometry
    L_global: np.ndarray
    polhode: PolhodeClass
    body: str = ""

    @property
    def state0(self) -> np.ndarray:
        """(7,) ``(p0, omega_body0)``: the state of :class:`rigidlab.core.rigid_body.FreeBodyModel` at t = 0."""
        return np.concatenate([self.p0, self.omega_body0])

    @property
    def motion(self) -> str:
        """The motion in a few words (plain text): the solution's kind and the period of ``omega_body``."""
        period, kind = float(self.solution.period), self.solution.kind
        if 0.0 < period < math.inf:
            return f"{kind}, ω period {period:.3g} s"
        if period > 0.0:
            return "on the separatrix (ω period infinite)"
        return f"{'steady rotation' if kind == 'steady' else 'at rest'}, ω constant"


def free_body_start(body: FreeBodyShape | Any, omega_body0: Any) -> FreeBodyStart:
    """The motion of ``body`` (a :class:`FreeBodyShape` or an inertia tensor (3, 3) about the centre of mass,
    kg m^2) from ``omega_body0`` (3,) (body frame, rad/s) with ``L = A(p0) I omega_body0`` along +Z.

    Raises
    ------
    ValueError
        For a bad inertia tensor (:func:`rigidlab.core.rigid_body.principal_axes`) or ``omega_body0``.
    """
    shape = body if isinstance(body, FreeBodyShape) else None
    J = _inertia(shape.inertia if shape is not None else body)
    w0 = _vec(omega_body0, "omega_body0")
    p0 = euler_parameters_momentum_up(J, w0)
    solution = free_body_solution(J, w0, p0)
    L_global = angular_momentum_global(J, w0, p0)
    for a in (J, w0, p0, L_global):
        a.setflags(write=False)
    return FreeBodyStart(J, w0, p0, solution, momentum_geometry(J, w0), L_global, polhode_class(solution),
                         shape.name if shape is not None else "")


# -- the polhode ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PolhodeClass:
    """What the polhode of one exact motion does (Landau & Lifshitz sec. 37).

    Attributes
    ----------
    kind : the solution's kind (``"rest"``, ``"steady"``, ``"symmetric"``, ``"asymmetric"``,
        ``"separatrix"``)
    ratio : ``2 E J2 / |L|^2`` (J2 the intermediate moment): 1 on the separatrix, below 1 when the
        polhode circles the major axis, above 1 when it circles the minor one (nan at rest)
    below : ``1 - ratio``, summed without cancellation (see :func:`polhode_class`)
    circles : ``"major"``, ``"minor"`` (the axis the polhode circles; for a symmetric body the
        unequal moment's axis), or ``""`` (rest, separatrix)
    closest_angle : rad, the polhode's closest approach to the intermediate axis (asymmetric
        motions; nan otherwise)
    flips : the body spins about its intermediate axis and turns over every ``flip_interval``
        (``closest_angle <= NEAR_SEPARATRIX_ANGLE``): the Dzhanibekov effect
    flip_interval : s, half the period of ``omega_body``
    """

    kind: str
    ratio: float
    below: float
    circles: str
    closest_angle: float
    flips: bool
    flip_interval: float

    @property
    def description(self) -> str:
        """One or two sentences on the polhode (plain text; Unicode superscripts)."""
        if self.kind == "rest":
            return "At rest: no polhode"
        below, ratio = self.below, self.ratio
        if abs(below) >= 5e-5:
            shown = f"2E J2/|L|² = {ratio:.4f}"
        elif below == 0.0:
            shown = "2E J2/|L|² = 1"
        else:  # would print as 1.0000: the distance from 1 is what matters
            shown = f"2E J2/|L|² = 1 {'−' if below > 0.0 else '+'} {abs(below):.1e}"
        if self.kind == "symmetric":
            return (f"{shown}. Two equal principal moments: no intermediate axis and no flip; the polhode "
                    f"circles the symmetry axis (the {self.circles} axis), a regular precession")
        if self.kind == "steady":
            return f"{shown}. The polhode is a point: steady rotation about a principal axis"
        if self.kind == "separatrix":
            return (f"{shown}, the separatrix: the intermediate axis turns over from along L to against it "
                    "(or back) once, starting and ending only as t → ±∞")
        if not self.flips:
            return f"{shown}: the polhode circles the {self.circles} axis"
        return (f"{shown}, near 1 (the separatrix): the body spins about its intermediate axis and flips over "
                f"every {self.flip_interval:.3g} s (half the ω period), the Dzhanibekov effect. Just "
                f"{'below' if below > 0.0 else 'above'} 1, the polhode passes "
                f"{math.degrees(self.closest_angle):.1f}° from the intermediate axis and circles the "
                f"{self.circles} axis")


def polhode_class(solution: FreeBodySolution) -> PolhodeClass:
    """Classify the polhode of ``solution`` (:func:`rigidlab.core.rigid_body.free_body_solution`).

    With principal moments ``J1 <= J2 <= J3`` and ``omega_k`` the principal components of
    ``omega_body``, ``1 - 2 E J2 / |L|^2 = sum_k J_k (J_k - J2) omega_k^2 / |L|^2`` (no cancellation
    near the separatrix). The polhode comes closest to the intermediate axis where it crosses the plane
    of that axis and the axis it circles; there ``(L . e2)^2 / |L|^2 = (r J3 - J2) / (J3 - J2)``
    (circling the major axis, ``r`` the ratio) or ``(J2 - r J1) / (J2 - J1)`` (the minor one).
    """
    g = momentum_geometry(solution.inertia, solution.omega_body0)
    J1, J2, J3 = (float(m) for m in g.moments)
    period = float(solution.period)
    if g.L_norm == 0.0:
        return PolhodeClass(solution.kind, math.nan, math.nan, "", math.nan, False, 0.5 * period)
    w_principal = g.axes.T @ solution.omega_body0
    below = float(np.sum(g.moments * (g.moments - J2) * w_principal**2)) / g.L_norm**2
    ratio = 1.0 - below
    closest = math.nan
    if solution.kind == "symmetric":
        circles = "major" if J2 - J1 <= J3 - J2 else "minor"
    elif solution.kind == "separatrix":
        circles = ""
    else:
        circles = "major" if below > 0.0 else "minor"
        if solution.kind == "asymmetric":
            c = (ratio * J3 - J2) / (J3 - J2) if below > 0.0 else (J2 - ratio * J1) / (J2 - J1)
            closest = math.acos(math.sqrt(min(max(c, 0.0), 1.0)))
    flips = bool(closest <= NEAR_SEPARATRIX_ANGLE)  # nan: False
    return PolhodeClass(solution.kind, ratio, below, circles, closest, flips, 0.5 * period)


# -- the exact motion over a window, and a numerical run against it -----------------------------------
@dataclass(frozen=True)
class GhostComparison:
    """A numerical run from a state, sampled with the exact motion (read-only arrays).

    Attributes
    ----------
    states : (n, 7) the run's states ``(p, omega_body)`` at the window's times (``p`` as integrated)
    p : (n, 4) its Euler parameters normalized (the rotation they represent)
    L : (n, 3) its angular momentum, global frame, from the normalized ``p`` (kg m^2/s)
    energy : (n,) its kinetic energy (J); ``L_norm`` (n,) its ``|L|`` from ``p`` as integrated
    angle_error : (n,) rad, angle of the rotation from the exact orientation to the run's (Eq. 8.82)
    omega_error : (n,) ``|omega_body - omega_body exact|`` (rad/s)
    energy_drift, L_drift : (n,) ``|E / E0 - 1|``, ``| |L| / |L0| - 1 |`` (0 at rest)
    p_norm_error : (n,) ``| |p| - 1 |``
    final_state : (7,) the state at the window's end (the next window starts there)
    """

    states: np.ndarray
    p: np.ndarray
    L: np.ndarray
    energy: np.ndarray
    L_norm: np.ndarray
    angle_error: np.ndarray
    omega_error: np.ndarray
    energy_drift: np.ndarray
    L_drift: np.ndarray
    p_norm_error: np.ndarray
    final_state: np.ndarray

    def errors(self, j: int) -> dict[str, float]:
        """Sample ``j``'s errors: ``angle`` (rad), ``omega`` (rad/s), ``energy``, ``L`` (relative drifts),
        ``p_norm``."""
        return {"angle": float(self.angle_error[j]), "omega": float(self.omega_error[j]),
                "energy": float(self.energy_drift[j]), "L": float(self.L_drift[j]),
                "p_norm": float(self.p_norm_error[j])}


@dataclass(frozen=True)
class FreeBodyWindow:
    """The exact motion at times ``t`` and optionally a numerical run compared with it (read-only arrays).

    Attributes
    ----------
    t : (n,) s
    p : (n, 4) exact Euler parameters; ``omega_body`` (n, 3) body frame; ``omega`` (n, 3) global frame
    L_body : (n, 3) exact angular momentum, body frame (on the polhode) (kg m^2/s)
    energy : (n,) J and ``L_norm`` (n,) kg m^2/s of the exact states (constant to round-off)
    ghost : :class:`GhostComparison` or None
    """

    t: np.ndarray
    p: np.ndarray
    omega_body: np.ndarray
    omega: np.ndarray
    L_body: np.ndarray
    energy: np.ndarray
    L_norm: np.ndarray
    ghost: GhostComparison | None = None

    def columns(self, *, every: int = 1) -> np.ndarray:
        """Every ``every``-th sample as the columns named by :data:`WINDOW_COLUMNS` (n', 9) and, with a run,
        :data:`GHOST_COLUMNS` after them (n', 19)."""
        rows = slice(None, None, int(every))
        out = [self.p[rows], self.omega_body[rows], self.energy[rows, None], self.L_norm[rows, None]]
        if (g := self.ghost) is not None:
            out += [g.states[rows], g.energy[rows, None], g.L_norm[rows, None], g.angle_error[rows, None]]
        return np.concatenate(out, axis=1)


def _drift(x: np.ndarray, x0: float) -> np.ndarray:
    return np.abs(x / x0 - 1.0) if x0 > 0.0 else np.zeros(x.shape)


def free_body_window(solution: FreeBodySolution, t0: float, t1: float, *, sample_dt: float,
                     method: str | None = None, state0: Any = None, dt: float | None = None,
                     rtol: float = 1e-8) -> FreeBodyWindow:
    """The exact motion of ``solution`` over ``[t0, t1]`` and, with ``method``, a numerical run compared with it.

    Without ``method``: the exact motion at ``round((t1 - t0) / sample_dt) + 1`` equally spaced times.
    With ``method`` (one of :data:`rigidlab.core.integrators.FIXED_STEP_METHODS` or ``ADAPTIVE_METHODS``):
    :func:`rigidlab.core.integrators.integrate` on :class:`rigidlab.core.rigid_body.FreeBodyModel` from ``state0`` (7,)
    at ``t0``, sampled at the same times (a fixed step ``dt`` finer than ``sample_dt`` is shortened to
    a whole number of steps per sample; a coarser one samples every step; adaptive methods use
    ``rtol`` and ``atol = rtol / 100`` with the samples as ``t_eval``), and the exact motion at the
    run's times, with the errors of :class:`GhostComparison`.

    Raises
    ------
    ValueError
        For an empty window, a non-positive ``sample_dt`` or ``dt``, a missing ``state0``, an unknown
        method; :class:`rigidlab.core.integrators.IntegrationError` when the run fails (e.g. an implicit step
        that does not converge).
    """
    a, b, h = real_number(t0, "t0"), real_number(t1, "t1"), real_number(sample_dt, "sample_dt")
    if not (math.isfinite(a) and math.isfinite(b) and b > a):
        raise ValueError(f"t0, t1: expected finite times with t1 > t0, got {t0!r}, {t1!r}")
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"sample_dt: expected a positive finite step, got {sample_dt!r}")
    n_samples = max(1, round((b - a) / h))
    model = FreeBodyModel(solution.inertia)
    run = None
    if method is not None:
        if state0 is None:
            raise ValueError("state0: expected the run's initial state (7,), got None")
        y0 = _vec(state0, "state0", 7)
        if method in FIXED_STEP_METHODS:
            step = real_number(dt, "dt") if dt is not None else math.nan
            if not (math.isfinite(step) and step > 0.0):
                raise ValueError(f"dt: expected a positive finite step, got {dt!r}")
            if step <= (b - a) / n_samples:  # several steps per sample
                sub = max(1, round((b - a) / n_samples / step))
                run = integrate(model, y0, (a, b), method=method, dt=(b - a) / (n_samples * sub), save_every=sub)
            else:  # coarse steps: every step is a sample
                run = integrate(model, y0, (a, b), method=method, dt=(b - a) / math.ceil((b - a) / step - 1e-9))
        elif method in ADAPTIVE_METHODS:
            run = integrate(model, y0, (a, b), method=method, rtol=rtol, atol=rtol * 1e-2,
                            t_eval=np.linspace(a, b, n_samples + 1))
        else:
            raise ValueError(f"method: expected one of {[*FIXED_STEP_METHODS, *ADAPTIVE_METHODS]}, "
                             f"got {method!r}")
    t = np.array(run.t) if run is not None else np.linspace(a, b, n_samples + 1)
    exact = solution.at(t)
    p, w = np.array(exact.p), np.array(exact.omega_body)
    inv = model.invariants(np.concatenate([p, w], axis=1))
    arrays = [t, p, w, rotate_vector(p, w), w @ model.inertia.T, inv["energy"],
              np.linalg.norm(inv["angular_momentum_global"], axis=1)]
    ghost = None
    if run is not None:
        states = np.array(run.states)
        g_inv = model.invariants(states)
        unit = normalize_euler_parameters(states[:, :4])
        g_L_norm = np.linalg.norm(g_inv["angular_momentum_global"], axis=1)
        geometry = momentum_geometry(solution.inertia, solution.omega_body0)
        fields = [states, unit, model.angular_momentum_global(states[:, 4:], unit), g_inv["energy"], g_L_norm,
                  rotation_angle_between(p, states[:, :4]), np.linalg.norm(w - states[:, 4:], axis=1),
                  _drift(g_inv["energy"], geometry.energy), _drift(g_L_norm, geometry.L_norm),
                  np.abs(g_inv["p_norm"] - 1.0), states[-1].copy()]
        for x in fields:
            x.setflags(write=False)
        ghost = GhostComparison(*fields)
    for x in arrays:
        x.setflags(write=False)
    return FreeBodyWindow(*arrays, ghost=ghost)
