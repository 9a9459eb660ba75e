"""Newton-Euler equations of a rigid body in Euler or Rodriguez parameters.

State layouts (flat float64 vectors, as :mod:`rigidlab.core.integrators` expects):

===================== ===== ===================================================
model                 size  state
===================== ===== ===================================================
EulerParameterModel   13    ``r`` (3, global), ``p`` (4, Euler parameters
                            theta0..theta3, scalar first), ``v`` (3, global),
                            ``omega_body`` (3, body frame)
RodriguezModel        12    ``r``, ``gamma`` (3, Rodriguez parameters
                            ``axis tan(angle / 2)``), ``v``, ``omega_body``
FreeBodyModel         7     ``p`` (4), ``omega_body`` (3): torque-free rotation
===================== ===== ===================================================

Equations (``A(p)`` maps body to global, ``r_global = r + A @ u_body``):

- translation ``m r_ddot = F(t, state)`` with ``F`` in the global frame;
- rotation (Euler's equations in the body frame)
  ``I omega_body_dot = n_body(t, state) - omega_body x (I omega_body)``;
- orientation ``p_dot = G_bar(p).T @ omega_body / 2`` (Eqs. 8.53-8.54,
  problem 6) or ``gamma_dot = (omega_body + gamma x omega_body
  + gamma (gamma . omega_body)) / 2`` (Eqs. 8.61-8.64, problem 8).

``free_body_exact`` gives the exact torque-free motion for any inertia
(Jacobi elliptic functions and Carlson's elliptic integrals; Landau &
Lifshitz, Mechanics, sec. 37; van Zon & Schofield, J. Comput. Phys. 225,
2007; Celledoni, Fasso, Safstrom & Zanna, SIAM J. Sci. Comput. 30, 2008).
:class:`FreeBodyModel` also provides the exact flows of a splitting of the
free-body Hamiltonian for :func:`rigidlab.core.integrators.splitting_step`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from scipy.special import ellipj, ellipkm1, elliprf, elliprj

from rigidlab.core._elliptic import agm_sn_cn
from rigidlab.core._validation import check_degrees, degrees_out, float_array, real_number, short_repr
from rigidlab.core.rotations import (
    UNIT_NORM_TOL,
    euler_parameters_from_matrix,
    quaternion_conjugate,
    quaternion_product,
)

__all__ = [
    "FREE_BODY_MAX_PHASE",
    "INERTIA_TRIANGLE_TOL",
    "EulerParameterModel",
    "FreeBodyModel",
    "FreeBodyMotion",
    "FreeBodySolution",
    "RigidBody",
    "RodriguezModel",
    "RodriguezSingularityError",
    "angular_momentum_body",
    "angular_momentum_global",
    "euler_parameter_norm_error",
    "euler_parameter_state",
    "free_body_exact",
    "free_body_solution",
    "free_body_state",
    "kinetic_energy",
    "MomentumGeometry",
    "momentum_geometry",
    "principal_axes",
    "rodriguez_state",
    "rotation_angle_between",
    "rotational_kinetic_energy",
]

Vector = Callable[[float, np.ndarray], np.ndarray]


class RodriguezSingularityError(ValueError):
    """Rodriguez parameters reached the singular rotation angle pi."""

    def __init__(self, message: str, *, t: float | None = None):
        super().__init__(message)
        self.t = t


#: Relative tolerance of the triangle inequality of principal moments of
#: inertia: an inertia is accepted when ``J3 - (J1 + J2) <= INERTIA_TRIANGLE_TOL
#: * J3`` for its ascending moments ``J1 <= J2 <= J3`` (equality is a flat
#: body, e.g. a plate; a larger J3 belongs to no mass distribution).
INERTIA_TRIANGLE_TOL = 1e-12

#: Largest phase (rad) through which :meth:`FreeBodySolution.at` evaluates
#: the exact motion: ``|t|`` times the largest angular rate of the motion,
#: ``|L| / J_min`` (a bound on ``|omega|``, on the precession rate and on
#: the rate of the elliptic argument). The phases are float64 numbers, so
#: they carry an absolute error of about ``eps * phase``: at 1e14 rad one
#: unit in the last place is 0.016 rad (about a degree). Beyond it the
#: orientation at ``t`` is not defined by float64 arithmetic, and times
#: that far are refused instead of returning an unrelated attitude.
FREE_BODY_MAX_PHASE = 1e14

# |I omega| sqrt(J_max / J_min) above which the squares in the constants of
# the exact motion (|L|^2, 2 E J) overflow float64.
_MAX_MOMENTUM_SCALE = 1e150


# ------------------------------------------------------------- validation
def _inertia(inertia: Any, name: str = "inertia") -> np.ndarray:
    """Return a symmetric positive-definite (3, 3) tensor from (3,) or (3, 3).

    Its principal moments must satisfy the triangle inequality
    ``J1 + J2 >= J3`` (within :data:`INERTIA_TRIANGLE_TOL`).
    """
    a = float_array(inertia, name, expected="principal moments (3,) or a tensor (3, 3) of real numbers")
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected principal moments (3,) or a tensor (3, 3), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    scale = float(np.max(np.abs(a)))
    if np.max(np.abs(a - a.T)) > 1e-12 * scale:
        raise ValueError(f"{name}: expected a symmetric tensor, got {a.tolist()}")
    a = 0.5 * (a + a.T)
    w = np.linalg.eigvalsh(a)
    if not w[0] > 0:
        raise ValueError(f"{name}: expected positive-definite (all principal moments > 0), got moments {w.tolist()}")
    if w[2] - (w[0] + w[1]) > INERTIA_TRIANGLE_TOL * w[2]:
        raise ValueError(
            f"{name}: expected principal moments that satisfy the triangle inequality J1 + J2 >= J3 "
            f"(within {INERTIA_TRIANGLE_TOL:g} of J3; no mass distribution has one moment larger than "
            f"the sum of the other two), got moments {w.tolist()}"
        )
    return a


def _vec(x: Any, name: str, size: int = 3) -> np.ndarray:
    a = float_array(x, name, expected=f"a ({size},) vector of real numbers")
    if a.shape != (size,):
        raise ValueError(f"{name}: expected shape ({size},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    return a


def _unit_p_batch(p: Any, name: str = "p") -> np.ndarray:
    """Euler parameters (..., 4), unit within ``UNIT_NORM_TOL``, normalized."""
    a = float_array(p, name, expected="(..., 4) Euler parameters of real numbers")
    if a.ndim == 0 or a.shape[-1] != 4:
        raise ValueError(f"{name}: expected shape (..., 4) (theta0, theta1, theta2, theta3), got {a.shape}")
    n = np.sqrt(np.einsum("...i,...i->...", a, a))
    bad = ~(np.abs(n - 1.0) <= UNIT_NORM_TOL)  # NaN and infinity fail too
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f" at index {index}" if index else ""
        with np.errstate(over="ignore"):  # the true norm, inf only past float64
            norm = float(np.hypot(np.hypot(a[index][0], a[index][1]), np.hypot(a[index][2], a[index][3])))
        raise ValueError(
            f"{name}: expected unit Euler parameters (| |{name}| - 1 | <= {UNIT_NORM_TOL:g}), got norm "
            f"{norm!r}{where}; renormalize with core.rotations.normalize_euler_parameters"
        )
    return a / n[..., None]


def _unit_p(p: Any, name: str = "p0") -> np.ndarray:
    """One orientation as Euler parameters (4,), unit within ``UNIT_NORM_TOL``, normalized.

    The rule of every entry that takes an orientation as Euler parameters
    (:func:`free_body_exact`, the state packers, :func:`angular_momentum_global`,
    and :mod:`rigidlab.core.rotations`): a norm 0, 2 or NaN is refused, naming ``name``
    and the norm.
    """
    return _unit_p_batch(_vec(p, name, 4), name)


def _p_from_rotation(A: np.ndarray) -> np.ndarray:
    """Euler parameters (4,) of one rotation matrix (3, 3) (Eq. 8.50)."""
    return euler_parameters_from_matrix(A[None])[0]


def principal_axes(inertia: Any) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and axes of an inertia tensor.

    Parameters
    ----------
    inertia : (3,) principal moments or (3, 3) symmetric positive-definite
        tensor in the body frame, kg m^2.

    Returns
    -------
    moments : (3,) ascending principal moments.
    Q_body_principal : (3, 3) rotation (det +1) whose columns are the
        principal axes in body coordinates: ``inertia = Q diag(moments) Q.T``.
    """
    a = _inertia(inertia)
    moments, Q = np.linalg.eigh(a)
    if np.linalg.det(Q) < 0:
        Q[:, 2] = -Q[:, 2]
    return moments, Q


# ------------------------------------------------------------- invariants
def _vectors(x: Any, name: str) -> np.ndarray:
    """Real vectors (..., 3), e.g. angular velocities (entries may be inf or NaN)."""
    a = float_array(x, name, expected="(..., 3) vectors of real numbers")
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"{name}: expected shape (..., 3), got {a.shape}")
    return a


def rotational_kinetic_energy(inertia: Any, omega_body: Any) -> np.ndarray:
    """``T = omega_body . (I omega_body) / 2``; omega_body (..., 3) body frame -> (...)."""
    J = _inertia(inertia)
    w = _vectors(omega_body, "omega_body")
    return 0.5 * np.einsum("...i,ij,...j->...", w, J, w)


def angular_momentum_body(inertia: Any, omega_body: Any) -> np.ndarray:
    """Angular momentum about the center of mass in the body frame, ``I omega_body``: (..., 3)."""
    return np.einsum("ij,...j->...i", _inertia(inertia), _vectors(omega_body, "omega_body"))


def angular_momentum_global(inertia: Any, omega_body: Any, p: Any) -> np.ndarray:
    """Angular momentum in the global frame, ``A(p) I omega_body`` (Eq. 8.48 for A): (..., 3).

    Parameters
    ----------
    inertia : (3,) principal moments or (3, 3) inertia tensor in the body
        frame, kg m^2 (validated on every call; a :class:`FreeBodyModel`
        validates it once, see :meth:`FreeBodyModel.angular_momentum_global`).
    omega_body : (..., 3) angular velocity in the body frame, rad/s.
    p : (..., 4) unit Euler parameters (theta0..theta3, scalar first), body
        to global, unit within :data:`rigidlab.core.rotations.UNIT_NORM_TOL` and
        normalized before use. Batch shapes broadcast.

    Returns
    -------
    (..., 3) angular momentum about the center of mass, global frame.

    Raises
    ------
    ValueError
        For a bad inertia, non-unit ``p`` (renormalize drifting parameters
        with :func:`rigidlab.core.rotations.normalize_euler_parameters`) or complex
        input.
    """
    return _angular_momentum_global(_inertia(inertia), omega_body, p)


def _angular_momentum_global(J: np.ndarray, omega_body: Any, p: Any) -> np.ndarray:
    """:func:`angular_momentum_global` for a validated inertia tensor ``J``."""
    w = _vectors(omega_body, "omega_body")
    a = float_array(p, "p", expected="(..., 4) Euler parameters of real numbers")
    if w.shape == (3,) and a.shape == (4,):
        # one body: Python floats, a few microseconds instead of ~50
        e0, e1, e2, e3 = a.tolist()
        n = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
        if abs(n - 1.0) <= UNIT_NORM_TOL:  # else the batched path raises
            e0, e1, e2, e3 = e0 / n, e1 / n, e2 / n, e3 / n
            w0, w1, w2 = w.tolist()
            (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = J.tolist()
            l0 = j00 * w0 + j01 * w1 + j02 * w2
            l1 = j10 * w0 + j11 * w1 + j12 * w2
            l2 = j20 * w0 + j21 * w1 + j22 * w2
            ee, xx, yy, zz = e0 * e0, e1 * e1, e2 * e2, e3 * e3
            return np.array((
                (ee + xx - yy - zz) * l0 + 2.0 * (e1 * e2 - e3 * e0) * l1 + 2.0 * (e1 * e3 + e2 * e0) * l2,
                2.0 * (e1 * e2 + e3 * e0) * l0 + (ee - xx + yy - zz) * l1 + 2.0 * (e2 * e3 - e1 * e0) * l2,
                2.0 * (e1 * e3 - e2 * e0) * l0 + 2.0 * (e2 * e3 + e1 * e0) * l1 + (ee - xx - yy + zz) * l2,
            ))
    p = _unit_p_batch(a, "p")
    return np.einsum("...ij,...j->...i", _matrix_unnormalized(p), np.einsum("ij,...j->...i", J, w))


def euler_parameter_norm_error(p: Any) -> np.ndarray:
    """``|p| - 1`` for Euler parameters p (..., 4) -> (...)."""
    return np.linalg.norm(float_array(p, "p", expected="(..., 4) Euler parameters of real numbers"), axis=-1) - 1.0


def kinetic_energy(mass: float, inertia: Any, v: Any, omega_body: Any) -> np.ndarray:
    """Total kinetic energy ``m |v|^2 / 2 + omega_body . I omega_body / 2``: (...)."""
    mass = real_number(mass, "mass", expected="a finite mass > 0")
    if not mass > 0:
        raise ValueError(f"mass: expected a finite mass > 0, got {mass!r}")
    v = _vectors(v, "v")
    return 0.5 * mass * np.einsum("...i,...i->...", v, v) + rotational_kinetic_energy(inertia, omega_body)


def _matrix_unnormalized(p: np.ndarray) -> np.ndarray:
    """A(p) of Eq. 8.48 evaluated as written (no normalization), batched."""
    w, x, y, z = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    A = np.empty(p.shape[:-1] + (3, 3))
    A[..., 0, 0] = w * w + x * x - y * y - z * z
    A[..., 0, 1] = 2.0 * (x * y - z * w)
    A[..., 0, 2] = 2.0 * (x * z + y * w)
    A[..., 1, 0] = 2.0 * (x * y + z * w)
    A[..., 1, 1] = w * w - x * x + y * y - z * z
    A[..., 1, 2] = 2.0 * (y * z - x * w)
    A[..., 2, 0] = 2.0 * (x * z - y * w)
    A[..., 2, 1] = 2.0 * (y * z + x * w)
    A[..., 2, 2] = w * w - x * x - y * y + z * z
    return A


def _G_bar(p: np.ndarray) -> np.ndarray:
    """G_bar(p) = [-theta, -skew(theta) + theta0 I] (Eq. 8.53), (..., 3, 4), no validation."""
    w, x, y, z = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    G = np.empty(p.shape[:-1] + (3, 4))
    G[..., 0, :] = np.stack([-x, w, z, -y], axis=-1)
    G[..., 1, :] = np.stack([-y, -z, w, x], axis=-1)
    G[..., 2, :] = np.stack([-z, y, -x, w], axis=-1)
    return G


def rotation_angle_between(p: Any, q: Any, *, degrees: bool = False) -> np.ndarray:
    """Angle (rad, in [0, pi]) of the rotation taking ``A(p)`` to ``A(q)``.

    ``p``, ``q`` (..., 4) Euler parameters (scalar first; sign-insensitive,
    not renormalized). Uses ``2 atan2(|v|, |w|)`` of ``conj(p) q`` (Eq. 8.82),
    accurate for small angles too. Returns (...); ``degrees=True`` returns degrees.
    """
    check_degrees(degrees)
    p = float_array(p, "p", expected="(..., 4) Euler parameters of real numbers")
    q = float_array(q, "q", expected="(..., 4) Euler parameters of real numbers")
    pc = p * np.array([1.0, -1.0, -1.0, -1.0])
    r = _qmul_arr(pc, q)
    return degrees_out(2.0 * np.arctan2(np.linalg.norm(r[..., 1:], axis=-1), np.abs(r[..., 0])), degrees)


@dataclass(frozen=True)
class MomentumGeometry:
    """The momentum sphere and the energy ellipsoid of a free body (body frame).

    ``L_body`` moves on the sphere ``|L| = L_norm`` and on the ellipsoid
    ``L . I^-1 L = 2 energy``; their intersection is the polhode
    (Landau & Lifshitz sec. 37). The ellipsoid's semi-axes are
    ``sqrt(2 energy J_k)`` along the principal axes (columns of ``axes``).
    """

    L_norm: float
    energy: float
    semi_axes: np.ndarray  # (3,) ascending with the principal moments
    axes: np.ndarray  # (3, 3) principal axes (columns) in body coordinates
    moments: np.ndarray  # (3,) principal moments, ascending


def momentum_geometry(inertia: Any, omega_body: Any) -> MomentumGeometry:
    """Sphere radius and energy-ellipsoid axes for ``omega_body`` (3,) (body frame)."""
    J = _inertia(inertia)
    w = _vec(omega_body, "omega_body")
    moments, Q = principal_axes(J)
    L = J @ w
    E = 0.5 * float(w @ L)
    semi = np.sqrt(2.0 * E * moments)
    for a in (semi, Q, moments):
        a.setflags(write=False)
    return MomentumGeometry(float(np.linalg.norm(L)), E, semi, Q, moments)


# ------------------------------------------------------------- the body
@dataclass(frozen=True)
class RigidBody:
    """Mass properties and applied loads of one rigid body.

    Attributes
    ----------
    mass : float, kg (> 0).
    inertia : (3, 3) inertia tensor about the center of mass in the body
        frame, kg m^2 (a (3,) input is taken as principal moments).
    force : applied force at the center of mass in the global frame, N:
        ``None`` (no force), a constant (3,) vector, or a callable
        ``(t, state) -> (3,)``.
    torque_body : applied moment about the center of mass in the body frame
        (n-bar), N m: ``None``, a constant (3,) vector, or a callable
        ``(t, state) -> (3,)``.

    ``state`` passed to the loads is the model's flat state vector. A
    constant is stored as a read-only float64 (3,) array. A callable's value
    is checked at every evaluation: anything but a (3,) vector of finite
    real numbers raises a ``ValueError`` naming ``force`` or
    ``torque_body``, the time and what it returned (a non-finite value is
    blamed on the callable only when the state it was given is finite;
    otherwise the integrator reports the divergence).

    Raises
    ------
    ValueError
        For a bad mass or inertia, and for a ``force`` or ``torque_body``
        that is neither None, a finite (3,) vector nor a callable.
    """

    mass: float
    inertia: np.ndarray = field(repr=False)
    force: Vector | np.ndarray | None = None
    torque_body: Vector | np.ndarray | None = None

    def __post_init__(self) -> None:
        mass = real_number(self.mass, "mass", expected="a finite number > 0")
        if not mass > 0:
            raise ValueError(f"mass: expected a finite number > 0, got {self.mass!r}")
        object.__setattr__(self, "mass", mass)
        J = _inertia(self.inertia)
        J.setflags(write=False)
        object.__setattr__(self, "inertia", J)
        object.__setattr__(self, "_inertia_inv", np.linalg.inv(J))
        for name, unit, frame in (("force", "N", "global"), ("torque_body", "N m", "body")):
            object.__setattr__(self, name, _load_spec(getattr(self, name), name, unit, frame))


def _load_spec(value: Any, name: str, unit: str, frame: str) -> Vector | np.ndarray | None:
    """A load of :class:`RigidBody` as given: None, a callable, or a read-only constant (3,) array."""
    if value is None or callable(value):
        return value
    expected = f"None, a constant (3,) vector ({unit}, {frame} frame) or a callable (t, state) -> (3,)"
    a = float_array(value, name, expected=expected, copy=True)
    if a.shape != (3,):
        raise ValueError(f"{name}: expected {expected}, got {short_repr(value)} (shape {a.shape})")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    a.setflags(write=False)
    return a


def euler_parameter_state(r: Any, p: Any, v: Any, omega_body: Any) -> np.ndarray:
    """Pack the (13,) state of :class:`EulerParameterModel`; ``p`` unit within
    :data:`rigidlab.core.rotations.UNIT_NORM_TOL`, normalized."""
    return np.concatenate([_vec(r, "r"), _unit_p(p, "p"), _vec(v, "v"), _vec(omega_body, "omega_body")])


def rodriguez_state(r: Any, gamma: Any, v: Any, omega_body: Any) -> np.ndarray:
    """Pack the (12,) state of :class:`RodriguezModel`."""
    return np.concatenate([_vec(r, "r"), _vec(gamma, "gamma"), _vec(v, "v"), _vec(omega_body, "omega_body")])


_NO_LOAD = np.zeros(3)
_NO_LOAD.setflags(write=False)


def _load_value(load: Vector | np.ndarray | None, name: str, t: float, y: np.ndarray) -> np.ndarray:
    """The value (3,) of one load of a :class:`RigidBody` at ``(t, y)``.

    A callable's return value must be a (3,) vector of finite real numbers;
    otherwise a ValueError names the load, the time and what it returned
    (numpy would report a failed broadcast deep in the integrator, and a
    NaN would surface as a divergence blamed on the step size).
    """
    if load is None:
        return _NO_LOAD
    if not callable(load):
        return load  # a constant, validated by RigidBody
    value = load(t, y)
    out = float_array(value, name, expected=f"the callable to return a (3,) vector of real numbers at t={t:.6g}")
    if out.shape != (3,):
        raise ValueError(
            f"{name}: expected the callable to return shape (3,), got shape {out.shape} at t={t:.6g}: "
            f"{short_repr(value)}"
        )
    if not (math.isfinite(out[0]) and math.isfinite(out[1]) and math.isfinite(out[2])) and np.all(np.isfinite(y)):
        raise ValueError(
            f"{name}: expected the callable to return finite values, got {out.tolist()} at t={t:.6g} "
            "for a finite state"
        )
    return out


def _loads(body: RigidBody, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return _load_value(body.force, "force", t, y), _load_value(body.torque_body, "torque_body", t, y)


def _euler_equations(body: RigidBody, omega_body: np.ndarray, n_body: np.ndarray) -> np.ndarray:
    """omega_body_dot = I^-1 (n_body - omega_body x I omega_body) (Euler's equations)."""
    L = body.inertia @ omega_body
    return body._inertia_inv @ (n_body - np.cross(omega_body, L))  # type: ignore[attr-defined]


@dataclass(frozen=True)
class EulerParameterModel:
    """Newton-Euler equations with orientation in Euler parameters (problem 6).

    State (13,): ``r`` (0:3, global), ``p`` (3:7, theta0..theta3 scalar
    first), ``v`` (7:10, global), ``omega_body`` (10:13, body frame).

    .. math::

        \\dot r = v, \\quad \\dot p = \\tfrac12 \\bar G(p)^T \\bar\\omega,
        \\quad m \\dot v = F, \\quad
        \\bar I \\dot{\\bar\\omega} = \\bar n - \\bar\\omega \\times \\bar I \\bar\\omega

    with ``G_bar`` of Eq. 8.53 (``omega_body = 2 G_bar p_dot``, Eq. 8.54;
    ``G_bar G_bar.T = I`` and ``G_bar p = 0``, Eqs. 8.55-8.56).
    """

    body: RigidBody
    state_size: int = 13
    #: Where the Euler parameters sit in the state (checked by
    #: :func:`rigidlab.core.integrators.integrate` in ``state0``).
    euler_parameter_slice: ClassVar[slice] = slice(3, 7)

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """State derivative (13,) at time ``t``."""
        y = float_array(y, "y")
        p, v, w = y[3:7], y[7:10], y[10:13]
        F, n = _loads(self.body, t, y)
        out = np.empty(13)
        out[0:3] = v
        out[3:7] = 0.5 * _G_bar(p).T @ w
        out[7:10] = F / self.body.mass
        out[10:13] = _euler_equations(self.body, w, n)
        return out

    @property
    def conserves_invariants(self) -> bool:
        """True without applied loads (then every invariant is conserved)."""
        return self.body.force is None and self.body.torque_body is None

    def invariants(self, states: np.ndarray) -> dict[str, np.ndarray]:
        """Kinetic energy, linear and angular momentum (global), ``|L|`` (body) and ``|p|``.

        ``states`` (..., 13). Without loads, all are conserved.
        """
        s = float_array(states, "states")
        p, v, w = s[..., 3:7], s[..., 7:10], s[..., 10:13]
        J = self.body.inertia
        L_body = angular_momentum_body(J, w)
        return {
            "kinetic_energy": kinetic_energy(self.body.mass, J, v, w),
            "linear_momentum": self.body.mass * v,
            "angular_momentum_global": np.einsum("...ij,...j->...i", _matrix_unnormalized(p), L_body),
            "angular_momentum_body_norm": np.linalg.norm(L_body, axis=-1),
            "p_norm": np.linalg.norm(p, axis=-1),
        }


@dataclass(frozen=True)
class RodriguezModel:
    """Newton-Euler equations with orientation in Rodriguez parameters (problem 8).

    State (12,): ``r`` (0:3), ``gamma`` (3:6) = axis tan(angle / 2)
    (Eq. 8.58), ``v`` (6:9), ``omega_body`` (9:12, body frame).

    ``gamma_dot = (omega_body + gamma x omega_body + gamma (gamma . omega_body)) / 2``
    (Eqs. 8.61-8.64). The parameters are infinite at rotation angle pi; the
    right-hand side raises :class:`RodriguezSingularityError` once
    ``|gamma| > gamma_max`` (angle within ``2 / gamma_max`` rad of pi).
    Re-parameterize (e.g. integrate in Euler parameters) for such motions.
    """

    body: RigidBody
    gamma_max: float = 1e3
    state_size: int = 12

    def __post_init__(self) -> None:
        gamma_max = real_number(self.gamma_max, "gamma_max", expected="a finite number > 0")
        if not gamma_max > 0:
            raise ValueError(f"gamma_max: expected a finite number > 0, got {self.gamma_max!r}")

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """State derivative (12,) at time ``t``."""
        y = float_array(y, "y")
        g, v, w = y[3:6], y[6:9], y[9:12]
        gn = float(np.linalg.norm(g))
        if not gn <= self.gamma_max:
            angle = 2.0 * math.atan(gn) if math.isfinite(gn) else math.pi
            raise RodriguezSingularityError(
                f"Rodriguez parameters near the singular angle pi at t={t:.6g}: |gamma| = {gn:.3e} > "
                f"gamma_max={self.gamma_max:g} (rotation angle {angle:.9f} rad); use Euler parameters",
                t=t,
            )
        F, n = _loads(self.body, t, y)
        out = np.empty(12)
        out[0:3] = v
        out[3:6] = 0.5 * (w + np.cross(g, w) + g * float(g @ w))
        out[6:9] = F / self.body.mass
        out[9:12] = _euler_equations(self.body, w, n)
        return out

    @staticmethod
    def euler_parameters(states: np.ndarray) -> np.ndarray:
        """Euler parameters (..., 4) of the states' Rodriguez parameters (Eq. 8.59)."""
        g = float_array(states, "states")[..., 3:6]
        p = np.concatenate([np.ones(g.shape[:-1] + (1,)), g], axis=-1)
        return p / np.linalg.norm(p, axis=-1, keepdims=True)

    @property
    def conserves_invariants(self) -> bool:
        """True without applied loads (then every invariant is conserved)."""
        return self.body.force is None and self.body.torque_body is None

    def invariants(self, states: np.ndarray) -> dict[str, np.ndarray]:
        """Kinetic energy and angular momentum (global, and ``|L|`` in the body frame)."""
        s = float_array(states, "states")
        v, w = s[..., 6:9], s[..., 9:12]
        J = self.body.inertia
        L_body = angular_momentum_body(J, w)
        return {
            "kinetic_energy": kinetic_energy(self.body.mass, J, v, w),
            "linear_momentum": self.body.mass * v,
            "angular_momentum_global": np.einsum(
                "...ij,...j->...i", _matrix_unnormalized(self.euler_parameters(s)), L_body
            ),
            "angular_momentum_body_norm": np.linalg.norm(L_body, axis=-1),
        }


# ------------------------------------------------------------- free body
def free_body_state(p: Any, omega_body: Any) -> np.ndarray:
    """Pack the (7,) state ``(p, omega_body)`` of :class:`FreeBodyModel`; ``p`` unit
    within :data:`rigidlab.core.rotations.UNIT_NORM_TOL`, normalized."""
    return np.concatenate([_unit_p(p, "p"), _vec(omega_body, "omega_body")])


def _qmul(a: tuple, b: tuple) -> tuple:
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


class FreeBodyModel:
    """Torque-free rotation of a rigid body, state (7,) = ``p`` (4), ``omega_body`` (3).

    ``p_dot = G_bar(p).T omega_body / 2`` (Eq. 8.54) and Euler's equations
    ``I omega_body_dot = (I omega_body) x omega_body``.

    Splitting (for ``rigidlab.core.integrators`` methods ``splitting*``): in the
    principal frame (moments ``J0 <= J1 <= J2``) the kinetic energy is

    .. math::

        T = \\frac{|L|^2}{2 J_1} + c_0 L_0^2 + c_2 L_2^2, \\qquad
        c_k = \\frac{1}{2 J_k} - \\frac{1}{2 J_1}.

    ``|L|^2`` is a Casimir: its flow (a rotation of the body about the fixed
    ``L``) commutes with the other two, so the only splitting error comes
    from the two planar rotations generated by ``c_0 L_0^2`` and
    ``c_2 L_2^2``; taking the intermediate moment as reference minimises
    ``|c_0 c_2|``. Every flow is an exact rotation of ``(p, L_body)``:
    ``|p|`` stays 1 to round-off and ``|L|`` is conserved exactly.
    The internal split state is ``(p_principal (4), L_principal (3), tau)``
    as a tuple of floats; the Casimir flow, which commutes with everything,
    is run once for the accumulated time ``tau`` when converting back.

    Rounding makes ``|p|`` perform a random walk of about ``sqrt(n) eps``
    over n rotations. With ``compensated=True`` the split state carries
    ``p`` as an unevaluated sum ``p_hi + p_lo`` (four more floats) and each
    planar rotation is applied as a Cayley update ``p += delta`` (exactly
    norm-preserving in exact arithmetic, ``t = tan(angle / 4)``) added with
    an error-free two-sum, so the rounding per rotation is of the order of
    ``eps |delta|`` instead of ``eps |p|``: ``|p| - 1`` stays near 1e-15
    over 1e6 steps, at about 3x the cost. No renormalization either way.
    """

    state_size = 7
    #: Where the Euler parameters sit in the state (checked by
    #: :func:`rigidlab.core.integrators.integrate` in ``state0``).
    euler_parameter_slice = slice(0, 4)

    def __init__(self, inertia: Any, *, compensated: bool = False):
        self.inertia = _inertia(inertia)
        self.inertia.setflags(write=False)
        self._inv = np.linalg.inv(self.inertia)
        J, Q = principal_axes(self.inertia)
        self.moments = J
        self._Q = Q
        self._q_Q = tuple(_p_from_rotation(Q).tolist())
        self._q_Q_conj = (self._q_Q[0], -self._q_Q[1], -self._q_Q[2], -self._q_Q[3])
        self._c0 = 0.5 / J[0] - 0.5 / J[1]
        self._c2 = 0.5 / J[2] - 0.5 / J[1]
        self._J = tuple(J.tolist())
        self.compensated = bool(compensated)
        if self.compensated:
            self.split_flows = (self._flow_axis0_compensated, self._flow_axis2_compensated)
            self.split_run = self._split_run_compensated
        else:
            self.split_flows = (self._flow_axis0, self._flow_axis2_and_casimir)

    def __repr__(self) -> str:
        return f"FreeBodyModel(moments={self.moments.tolist()})"

    # -- equations
    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """State derivative (7,)."""
        p0, p1, p2, p3, w1, w2, w3 = float_array(y, "y").tolist()
        I = self.inertia
        L = I @ np.array((w1, w2, w3))
        l1, l2, l3 = L.tolist()
        # torque-free Euler equations: I w_dot = L x w
        wd = self._inv @ np.array((l2 * w3 - l3 * w2, l3 * w1 - l1 * w3, l1 * w2 - l2 * w1))
        return np.array(
            (
                0.5 * (-p1 * w1 - p2 * w2 - p3 * w3),
                0.5 * (p0 * w1 + p2 * w3 - p3 * w2),
                0.5 * (p0 * w2 + p3 * w1 - p1 * w3),
                0.5 * (p0 * w3 + p1 * w2 - p2 * w1),
                *wd.tolist(),
            )
        )

    def invariants(self, states: np.ndarray) -> dict[str, np.ndarray]:
        """``energy`` (...), ``angular_momentum_global`` (..., 3), ``p_norm`` (...)."""
        s = float_array(states, "states")
        p, w = s[..., :4], s[..., 4:]
        # p as given (not renormalized): a drift of |p| shows up in L too
        L_global = np.einsum("...ij,...j->...i", _matrix_unnormalized(p), np.einsum("ij,...j->...i", self.inertia, w))
        return {
            "energy": 0.5 * np.einsum("...i,ij,...j->...", w, self.inertia, w),
            "angular_momentum_global": L_global,
            "p_norm": np.linalg.norm(p, axis=-1),
        }

    def angular_momentum_global(self, omega_body: Any, p: Any) -> np.ndarray:
        """Angular momentum in the global frame, ``A(p) I omega_body`` (Eq. 8.48 for A).

        :func:`angular_momentum_global` for this model's inertia, which was
        validated once when the model was built (the free function checks
        it, an eigenvalue problem, on every call).

        Parameters
        ----------
        omega_body : (..., 3) angular velocity in the body frame, rad/s.
        p : (..., 4) unit Euler parameters (theta0..theta3, scalar first),
            body to global, unit within :data:`rigidlab.core.rotations.UNIT_NORM_TOL`
            and normalized before use. Batch shapes broadcast.

        Returns
        -------
        (..., 3) angular momentum about the center of mass, global frame.

        Raises
        ------
        ValueError
            For non-unit ``p``, wrong shapes or complex input.
        """
        return _angular_momentum_global(self.inertia, omega_body, p)

    def exact(self, state0: np.ndarray, t: Any) -> np.ndarray:
        """Exact states (..., 7) at times ``t`` (...) from ``state0`` at t = 0."""
        s = _vec(state0, "state0", 7)
        m = free_body_exact(self.inertia, s[4:], s[:4], t)
        return np.concatenate([m.p, m.omega_body], axis=-1)

    # -- splitting
    def to_split_state(self, y: np.ndarray) -> tuple:
        """(p, omega_body) -> (p_principal (4), L_principal (3), tau) as an 8-tuple of floats.

        ``tau`` is the time the Casimir flow still has to run (0 here).
        """
        y = float_array(y, "y")
        p_pr = _qmul(tuple(y[:4].tolist()), self._q_Q)
        L_pr = (self._Q.T @ (self.inertia @ y[4:])).tolist()
        if self.compensated:
            return (*p_pr, *L_pr, 0.0, 0.0, 0.0, 0.0, 0.0)
        return (*p_pr, *L_pr, 0.0)

    def from_split_state(self, z: tuple) -> np.ndarray:
        """Inverse of :meth:`to_split_state`: a (7,) state vector.

        Runs the pending Casimir flow first: the rotation of the body about
        the (constant) body vector ``L`` by ``|L| tau / J1``. It commutes with
        the other flows, so running it once for the accumulated time is exact
        and spares its round-off at every step.
        """
        q0, q1, q2, q3, L0, L1, L2, tau = z[:8]
        if len(z) == 12:  # compensated: p = p_hi + p_lo
            q0, q1, q2, q3 = q0 + z[8], q1 + z[9], q2 + z[10], q3 + z[11]
        Ln = math.sqrt(L0 * L0 + L1 * L1 + L2 * L2)
        if Ln > 0.0 and tau != 0.0:
            half = 0.5 * Ln * tau / self._J[1]
            k = math.sin(half) / Ln
            q0, q1, q2, q3 = _qmul((q0, q1, q2, q3), (math.cos(half), k * L0, k * L1, k * L2))
        p = _qmul((q0, q1, q2, q3), self._q_Q_conj)
        J = self._J
        w_pr = np.array((L0 / J[0], L1 / J[1], L2 / J[2]))
        return np.array((*p, *(self._Q @ w_pr).tolist()))

    def split_run(self, z: tuple, h: float, gammas: tuple[float, ...], n_steps: int) -> tuple:
        """``n_steps`` composed Strang steps of size ``h`` in one tight loop.

        Equivalent to applying ``split_flows`` in the Strang pattern
        ``A(g h/2) B(g h) A(g h/2)`` for each stage weight ``g`` of
        ``gammas`` (which sum to 1), ``n_steps`` times; the consecutive half
        steps of ``A`` are merged (``A(s) A(t) = A(s + t)`` exactly, since
        ``L0`` is constant along ``A``), so each stage costs one planar
        rotation of each kind. Used by :func:`rigidlab.core.integrators.integrate`.
        """
        q0, q1, q2, q3, L0, L1, L2, tau = z
        if n_steps <= 0:
            return z
        c0, c2 = self._c0, self._c2
        cos, sin = math.cos, math.sin
        g = [float(x) * h for x in gammas]
        s = len(g)
        # B durations and the A durations that follow each B (wrapping into
        # the next step's first half stage), and the last step's final half.
        wrap = [(g[i], 0.5 * (g[i] + g[(i + 1) % s])) for i in range(s)]
        last = wrap[:-1] + [(g[-1], 0.5 * g[-1])]
        a_first = 0.5 * g[0]
        # A(a_first)
        ang = c0 * L0 * a_first
        ch, sh = cos(ang), sin(ang)
        c, sn = ch * ch - sh * sh, 2.0 * ch * sh
        q0, q1, q2, q3 = q0 * ch - q1 * sh, q0 * sh + q1 * ch, q2 * ch + q3 * sh, q3 * ch - q2 * sh
        L1, L2 = c * L1 + sn * L2, c * L2 - sn * L1
        for k in range(n_steps):
            for hb, ha in wrap if k < n_steps - 1 else last:
                # B(hb): rotation about principal axis 2
                ang = c2 * L2 * hb
                ch, sh = cos(ang), sin(ang)
                c, sn = ch * ch - sh * sh, 2.0 * ch * sh
                q0, q1, q2, q3 = q0 * ch - q3 * sh, q1 * ch + q2 * sh, q2 * ch - q1 * sh, q0 * sh + q3 * ch
                L0, L1 = c * L0 + sn * L1, c * L1 - sn * L0
                # A(ha): rotation about principal axis 0
                ang = c0 * L0 * ha
                ch, sh = cos(ang), sin(ang)
                c, sn = ch * ch - sh * sh, 2.0 * ch * sh
                q0, q1, q2, q3 = q0 * ch - q1 * sh, q0 * sh + q1 * ch, q2 * ch + q3 * sh, q3 * ch - q2 * sh
                L1, L2 = c * L1 + sn * L2, c * L2 - sn * L1
        return (q0, q1, q2, q3, L0, L1, L2, tau + n_steps * h * sum(gammas))

    # -- compensated variant ------------------------------------------------
    def _flow_axis0_compensated(self, z: tuple, h: float) -> tuple:
        """Compensated exact flow of ``c0 L0^2`` (split state of 12 floats)."""
        return _compensated_planar(z, self._c0 * z[4] * h, 0)

    def _flow_axis2_compensated(self, z: tuple, h: float) -> tuple:
        """Compensated exact flow of ``c2 L2^2``; the Casimir adds ``h`` to tau."""
        out = _compensated_planar(z, self._c2 * z[6] * h, 2)
        return (*out[:7], out[7] + h, *out[8:])

    def _split_run_compensated(self, z: tuple, h: float, gammas: tuple[float, ...], n_steps: int) -> tuple:
        """``n_steps`` composed Strang steps with compensated rotations (see :meth:`split_run`)."""
        if n_steps <= 0:
            return z
        g = [float(x) * h for x in gammas]
        s = len(g)
        wrap = [(g[i], 0.5 * (g[i] + g[(i + 1) % s])) for i in range(s)]
        last = wrap[:-1] + [(g[-1], 0.5 * g[-1])]
        c0, c2 = self._c0, self._c2
        z = _compensated_planar(z, c0 * z[4] * 0.5 * g[0], 0)
        for k in range(n_steps):
            for hb, ha in wrap if k < n_steps - 1 else last:
                z = _compensated_planar(z, c2 * z[6] * hb, 2)
                z = _compensated_planar(z, c0 * z[4] * ha, 0)
        return (*z[:7], z[7] + n_steps * h * sum(gammas), *z[8:])

    def _flow_axis0(self, z: tuple, h: float) -> tuple:
        """Exact flow of ``c0 L0^2``: rotation about principal axis 0 by ``2 c0 L0 h``."""
        q0, q1, q2, q3, L0, L1, L2, tau = z
        half = self._c0 * L0 * h
        ch, sh = math.cos(half), math.sin(half)
        c, s = ch * ch - sh * sh, 2.0 * ch * sh
        return (
            q0 * ch - q1 * sh,
            q0 * sh + q1 * ch,
            q2 * ch + q3 * sh,
            q3 * ch - q2 * sh,
            L0,
            c * L1 + s * L2,
            c * L2 - s * L1,
            tau,
        )

    def _flow_axis2_and_casimir(self, z: tuple, h: float) -> tuple:
        """Exact flow of ``c2 L2^2 + |L|^2 / (2 J1)`` (the two commute).

        The planar rotation about principal axis 2 by ``2 c2 L2 h`` is
        applied; the Casimir part only adds ``h`` to ``tau`` (see
        :meth:`from_split_state`).
        """
        q0, q1, q2, q3, L0, L1, L2, tau = z
        half = self._c2 * L2 * h
        ch, sh = math.cos(half), math.sin(half)
        c, s = ch * ch - sh * sh, 2.0 * ch * sh
        return (
            q0 * ch - q3 * sh,
            q1 * ch + q2 * sh,
            q2 * ch - q1 * sh,
            q0 * sh + q3 * ch,
            c * L0 + s * L1,
            c * L1 - s * L0,
            L2,
            tau + h,
        )


def _two_sum(a: float, b: float) -> tuple[float, float]:
    """s = fl(a + b) and the exact error e with a + b = s + e (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _compensated_planar(z: tuple, half: float, axis: int) -> tuple:
    """Rotation of the body about principal axis 0 or 2 by ``2 half`` on a
    compensated split state ``(q_hi (4), L (3), tau, q_lo (4))``.

    The quaternion pairs turn by ``+-half`` through the Cayley map with
    ``t = tan(half / 2)``: ``delta = 2t / (1 + t^2) * (-(t x + y), x - t y)``
    (norm-preserving in exact arithmetic), added to ``q_hi`` by two-sums
    whose errors go to ``q_lo``. ``L`` turns by ``-2 half`` about the axis.
    """
    q0, q1, q2, q3, L0, L1, L2, tau, e0, e1, e2, e3 = z
    t = math.tan(0.5 * half)
    d = 2.0 * t / (1.0 + t * t)
    ch = (1.0 - t * t) / (1.0 + t * t)
    c, sn = ch * ch - d * d, 2.0 * ch * d  # cos, sin of 2 half

    def pair(x: float, ex: float, y: float, ey: float, tt: float, dd: float) -> tuple[float, float, float, float]:
        X, Y = x + ex, y + ey
        x1, rx = _two_sum(x, -dd * (tt * X + Y))
        y1, ry = _two_sum(y, dd * (X - tt * Y))
        return x1, ex + rx, y1, ey + ry

    if axis == 0:
        # (q0, q1) by +half, (q2, q3) by -half; (L1, L2) by -2 half
        q0, e0, q1, e1 = pair(q0, e0, q1, e1, t, d)
        q2, e2, q3, e3 = pair(q2, e2, q3, e3, -t, -d)
        L1, L2 = c * L1 + sn * L2, c * L2 - sn * L1
    else:
        # (q0, q3) by +half, (q1, q2) by -half; (L0, L1) by -2 half
        q0, e0, q3, e3 = pair(q0, e0, q3, e3, t, d)
        q1, e1, q2, e2 = pair(q1, e1, q2, e2, -t, -d)
        L0, L1 = c * L0 + sn * L1, c * L1 - sn * L0
    return (q0, q1, q2, q3, L0, L1, L2, tau, e0, e1, e2, e3)


# ------------------------------------------------------------- exact solution
@dataclass(frozen=True)
class FreeBodyMotion:
    """Exact torque-free motion at given times.

    Attributes
    ----------
    t : (...) times, s.
    p : (..., 4) Euler parameters (theta0..theta3, scalar first) of the body,
        continuous in t and equal to ``p0`` at t = 0.
    omega_body : (..., 3) angular velocity in the body frame, rad/s.
    """

    t: np.ndarray  # (...)
    p: np.ndarray  # (..., 4)
    omega_body: np.ndarray  # (..., 3)


def _qmul_arr(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quaternion product of broadcastable (..., 4) arrays, no validation."""
    a0, a1, a2, a3 = np.moveaxis(a, -1, 0)
    b0, b1, b2, b3 = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
        ],
        axis=-1,
    )


def _q_rotvec(theta: np.ndarray) -> np.ndarray:
    """Euler parameters of rotation vectors theta (..., 3)."""
    ang = np.linalg.norm(theta, axis=-1)
    half = 0.5 * ang
    k = np.where(ang > 0, np.sin(half) / np.where(ang > 0, ang, 1.0), 0.5)
    return np.concatenate([np.cos(half)[..., None], k[..., None] * theta], axis=-1)


def _q_axis(axis: int, angle: np.ndarray) -> np.ndarray:
    q = np.zeros(np.shape(angle) + (4,))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., 1 + axis] = np.sin(0.5 * angle)
    return q


def _ellipj_accurate(u: np.ndarray, m: float, mc: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sn, cn, dn for |u| <= K(m) using the complementary parameter mc = 1 - m.

    ``dn`` always comes from ``sqrt(cn^2 + mc sn^2)`` (no cancellation near
    ``u = K``, where dn is as small as ``sqrt(mc)``). scipy's ``ellipj`` switches to a first-order expansion in ``1 - m`` when
    ``m >= 1 - 1e-9``, which is inaccurate for ``u`` near K; there we run
    the arithmetic-geometric mean recursion (Abramowitz & Stegun 16.4)
    with ``b0 = sqrt(mc)`` instead.
    """
    if mc >= 1e-9:
        sn, cn, _, _ = ellipj(u, m)
        # dn^2 = 1 - m sn^2 = cn^2 + mc sn^2, without cancellation near u = K
        return sn, cn, np.sqrt(cn * cn + mc * sn * sn)
    sn, cn = agm_sn_cn(u, mc)
    # dn^2 = 1 - m sn^2 = cn^2 + mc sn^2, without cancellation near u = K
    return sn, cn, np.sqrt(cn * cn + mc * sn * sn)


def _carlson_pi(sn: np.ndarray, cn: np.ndarray, dn: np.ndarray, n: float) -> np.ndarray:
    """Pi(n; phi | m) for |phi| <= pi/2 from sin, cos and sqrt(1 - m sin^2) of phi (Carlson)."""
    c2, d2 = cn * cn, dn * dn
    return sn * elliprf(c2, d2, 1.0) + (n / 3.0) * sn**3 * elliprj(c2, d2, 1.0, 1.0 - n * sn * sn)


def _pi_reduced(
    r: np.ndarray, sn: np.ndarray, cn: np.ndarray, dn: np.ndarray, n: float, m: float, mc: float, K: float, Pi: float
) -> np.ndarray:
    """``int_0^r du / (1 - n sn^2 u)`` for |r| <= K (= Pi(n; am r | m)).

    Near |r| = K both Carlson terms grow like log(1 / mc) and cancel; there
    the integral is taken from the other end, ``u = K - v`` with
    ``sn(K - v) = cd(v)``, which gives
    ``Pi - (m/n' v + (1 - m/n') Pi(n'; am v)) / (1 - n)``,
    ``n' = (m - n) / (1 - n)``.
    """
    far = np.abs(r) > 0.5 * K
    near = ~far
    out = np.empty_like(r)
    out[near] = _carlson_pi(sn[near], cn[near], dn[near], n)
    if np.any(far):
        rf = r[far]
        v = K - np.abs(rf)
        if mc >= 1e-2:
            # sn(v) = cd(K - v), cn(v) = sqrt(mc) sd(K - v), dn(v) = sqrt(mc) / dn(K - v);
            # with dn >= sqrt(mc) >= 0.1 these lose at most a digit
            dnf = dn[far]
            snv, cnv, dnv = cn[far] / dnf, math.sqrt(mc) * np.abs(sn[far]) / dnf, math.sqrt(mc) / dnf
        else:
            snv, cnv, dnv = _ellipj_accurate(v, m, mc)
        n2 = (m - n) / (1.0 - n)
        tail = ((m / n2) * v + (1.0 - m / n2) * _carlson_pi(snv, np.maximum(cnv, 0.0), dnv, n2)) / (1.0 - n)
        out[far] = np.sign(rf) * (Pi - tail)
    return out


@dataclass(frozen=True)
class FreeBodySolution:
    """Constants of one exact torque-free motion; evaluate with :meth:`at`.

    Build with :func:`free_body_solution`. ``kind`` is one of ``"rest"``,
    ``"steady"`` (rotation about a principal axis, or a spherical body),
    ``"symmetric"`` (two equal moments: regular precession),
    ``"asymmetric"`` (Jacobi elliptic functions) or ``"separatrix"``
    (``|L|^2 = 2 E J_intermediate`` exactly: hyperbolic functions).
    ``period`` is the period of ``omega_body`` (``inf`` on the separatrix,
    0 when constant).
    """

    kind: str
    period: float
    inertia: np.ndarray = field(repr=False)
    p0: np.ndarray = field(repr=False)
    omega_body0: np.ndarray = field(repr=False)
    _c: dict = field(repr=False, compare=False)

    def at(self, t: Any) -> FreeBodyMotion:
        """Exact motion at times ``t`` (any shape, s): see :class:`FreeBodyMotion`.

        Raises
        ------
        ValueError
            For non-finite or complex ``t``, and for ``|t|`` beyond
            ``FREE_BODY_MAX_PHASE / (|L| / J_min)``: there the phases of the
            motion exceed :data:`FREE_BODY_MAX_PHASE` (1e14 rad) and their
            float64 rounding alone moves the body by more than a degree.
        """
        t = float_array(t, "t", expected="times of real numbers")
        if not np.all(np.isfinite(t)):
            raise ValueError(f"t: expected finite times, got {t.ravel()[~np.isfinite(t.ravel())][:3].tolist()}")
        rate = self._c["max_rate"]
        t_max = float(np.max(np.abs(t))) if t.size else 0.0
        if rate * t_max > FREE_BODY_MAX_PHASE:
            raise ValueError(
                f"t: expected |t| <= {FREE_BODY_MAX_PHASE / rate:.6g} s for this motion, got |t| = {t_max:.6g} s: "
                f"its phases (|L| |t| / J_min, {rate:.6g} rad/s) would exceed FREE_BODY_MAX_PHASE = "
                f"{FREE_BODY_MAX_PHASE:g} rad, where one float64 rounding of a phase turns the body by "
                "more than a degree"
            )
        shape = t.shape
        tt = t.ravel()
        if self.kind == "rest":
            p = np.broadcast_to(self.p0, tt.shape + (4,)).copy()
            w = np.zeros(tt.shape + (3,))
        elif self.kind == "steady":
            p = _qmul_arr(self.p0, _q_rotvec(tt[:, None] * self.omega_body0))
            w = np.broadcast_to(self.omega_body0, tt.shape + (3,)).copy()
        elif self.kind == "symmetric":
            p, w = self._symmetric(tt)
        else:
            p, w = self._elliptic(tt)
        return FreeBodyMotion(t, p.reshape(shape + (4,)), w.reshape(shape + (3,)))

    # -- two equal moments: regular precession
    def _symmetric(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = self._c
        s, Je, Js, L_pr = c["axis"], c["J_equal"], c["J_axis"], c["L_pr"]
        # T = |L|^2 / (2 Je) + (1/(2 Js) - 1/(2 Je)) L_s^2: two commuting exact flows.
        cas = _q_rotvec(t[:, None] * (L_pr / Je))
        phi = (1.0 / Js - 1.0 / Je) * L_pr[s] * t
        p_pr = _qmul_arr(_qmul_arr(c["p_pr0"], cas), _q_axis(s, phi))
        i, j = (s + 1) % 3, (s + 2) % 3
        cph, sph = np.cos(phi), np.sin(phi)
        L = np.empty(t.shape + (3,))
        L[:, s] = L_pr[s]
        L[:, i] = cph * L_pr[i] + sph * L_pr[j]
        L[:, j] = cph * L_pr[j] - sph * L_pr[i]
        w_pr = L / c["J_pr"]
        return _qmul_arr(p_pr, c["q_Q_conj"]), np.einsum("nk,jk->nj", w_pr, c["Q"])

    # -- asymmetric: Jacobi elliptic functions
    def _elliptic(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = self._c
        J1, J2, J3 = c["J"]
        u = c["lam"] * t + c["u0"]
        n = c["n"]
        if self.kind == "separatrix":
            sn = np.tanh(u)
            with np.errstate(over="ignore"):  # sech(u) underflows to 0 for |u| > 710
                cn = 1.0 / np.cosh(u)
            dn = cn
            a = -n
            sa = math.sqrt(a)
            integral = (u + sa * np.arctan(sa * sn)) / (1.0 + a)
            am_turns = np.zeros_like(u)
        else:
            K = c["K"]
            # u = 2 K j + r, |r| <= K; everything below uses this one (j, r)
            # pair, so sn, cn, dn and the signs of omega stay consistent
            # (sn^2 + cn^2 = 1, the energy exact) however large u is.
            j, r = _reduce(u, K)
            if c.get("table") is not None:
                sn, cn, dn, periodic = _table_functions(c["table"], r, K)
                cn = np.maximum(cn, 0.0)  # cn(r) >= 0 for |r| <= K
                integral = 2.0 * j * c["Pi"] + (c["Pi"] / K) * r + periodic
            else:
                sn, cn, dn, integral = _direct_functions(j, r, c)
            am_turns = j
        s1, s2, s3 = c["signs"]
        # omega with sn, cn, dn of the reduced argument r; cn(u) = (-1)^j cn(r),
        # sn(u) = (-1)^j sn(r), dn(u) = dn(r).
        w = np.stack([s1 * c["W"][0] * cn, s2 * c["W"][1] * sn, s3 * c["W"][2] * dn], axis=-1)
        L1, L2, L3 = J1 * w[:, 0], J2 * w[:, 1], J3 * w[:, 2]
        flip = 1.0 - 2.0 * np.mod(am_turns, 2.0)
        w[:, :2] *= flip[:, None]
        Lm = c["L"]
        # precession about L (Landau & Lifshitz 37.15 integrated in closed form)
        phi = (Lm / J3) * t + c["prec"] * (integral - c["I0"])
        theta = np.arctan2(np.hypot(L1, L2), L3)
        # psi = atan2(L1, L2) made continuous across half periods of am
        psi = np.arctan2(L1, L2) - s1 * s2 * math.pi * am_turns
        r_q = _zxz_quaternion(phi, theta, psi)
        # p = left (x) r (x) conj(q_can): one constant 4x4 matrix acting on r
        # (einsum, not matmul: a BLAS call would spin extra threads for a 4x4 product)
        return np.einsum("nk,jk->nj", r_q, c["sandwich"]), np.einsum("nk,jk->nj", w, c["QP"])


def _reduce(u: np.ndarray, K: float) -> tuple[np.ndarray, np.ndarray]:
    """``u = 2 K j + r`` with integer ``j`` and ``|r| <= K``, consistently.

    ``fmod`` gives the remainder of ``u + K`` by ``2 K`` exactly, and ``j``
    is read back from that remainder, so ``j`` and ``r`` agree even where
    ``u`` is so large that ``u - 2 K j`` would cancel to a few bits (there
    ``r`` carries the rounding of ``u + K``, an error of one unit in the
    last place of ``u``, the error ``u`` already has).
    """
    two_K = 2.0 * K
    s = u + K
    rem = np.fmod(s, two_K)
    rem = np.where(rem < 0.0, rem + two_K, rem)  # [0, 2K]
    j = np.round((s - rem) / two_K)
    return j, rem - K


def _direct_functions(j: np.ndarray, r: np.ndarray, c: dict) -> tuple[np.ndarray, ...]:
    """sn, cn, dn of the reduced argument ``r = u - 2 K j`` (|r| <= K) and
    ``I(u) = int_0^u du' / (1 - n sn^2 u')``, by ``ellipj`` and Carlson's integrals."""
    K, m, mc, n = c["K"], c["m"], c["mc"], c["n"]
    sn, cn, dn = _ellipj_accurate(r, m, mc)
    cn = np.maximum(cn, 0.0)
    integral = 2.0 * j * c["Pi"] + _pi_reduced(r, sn, cn, dn, n, m, mc, K, c["Pi"])
    return sn, cn, dn, integral


_TABLE_INTERVALS = 256  # pieces per period 4K
_TABLE_DEGREE = 9  # Chebyshev degree per piece


def _chebyshev_tables(c: dict) -> np.ndarray | None:
    """Piecewise Chebyshev tables of sn(u), cn(u), dn(u) and of the periodic
    part ``P(u) = I(u) - (Pi_c / K) u`` of the precession integral over one
    period 4K: (degree + 1, pieces, 4) coefficients.

    Built once per motion from the direct formulas at the Chebyshev points of
    each piece. The functions are analytic, so on pieces of width 4K/256 a
    degree-9 interpolant is exact to round-off; the degree-8 coefficients of
    every piece are checked against 1e-14 of the function's size, and None
    is returned (direct evaluation is used) when they are larger, which
    happens only close to the separatrix where K grows and the pulses
    sharpen.
    """
    K = c["K"]
    d = _TABLE_DEGREE
    h = 4.0 * K / _TABLE_INTERVALS
    k = np.arange(d + 1)
    nodes = np.cos(np.pi * (k + 0.5) / (d + 1))
    u = (-2.0 * K + h * (np.arange(_TABLE_INTERVALS) + 0.5))[:, None] + 0.5 * h * nodes[None, :]
    flat = u.ravel()
    j, r = _reduce(flat, K)
    sn, cn, dn, integral = _direct_functions(j, r, c)
    flip = 1.0 - 2.0 * np.mod(j, 2.0)
    f = np.stack([flip * sn, flip * cn, dn, integral - (c["Pi"] / K) * flat]).reshape(4, _TABLE_INTERVALS, d + 1)
    T = np.cos(np.outer(k, (k + 0.5) * np.pi / (d + 1)))  # T_k at the nodes
    coef = (2.0 / (d + 1)) * np.einsum("fpj,kj->kpf", f, T)  # (degree + 1, pieces, 4)
    coef[0] *= 0.5
    # converged when the degree d-1 coefficients are at round-off level
    # (the samples carry ~1e-16 relative noise, which sets the floor of the
    # last coefficients; the interpolation error is below the first omitted
    # coefficient, which decays geometrically past d - 1)
    scale = np.maximum(np.max(np.abs(f), axis=(1, 2)), 1e-300)
    tail = np.max(np.abs(coef[d - 1]), axis=0)
    if np.any(tail > 1e-14 * scale):
        return None
    return np.ascontiguousarray(coef)


def _table_functions(table: np.ndarray, u: np.ndarray, K: float) -> tuple[np.ndarray, ...]:
    """sn(u), cn(u), dn(u), P(u) from the piecewise Chebyshev tables (Clenshaw)."""
    n_pieces = table.shape[1]
    x = np.mod(u + 2.0 * K, 4.0 * K) * (n_pieces / (4.0 * K))
    idx = np.minimum(x.astype(np.intp), n_pieces - 1)
    s = (2.0 * (x - idx) - 1.0)[:, None]
    C = table[:, idx]  # (degree + 1, n, 4)
    two_s = 2.0 * s
    b1 = C[-1].copy()
    b2 = np.zeros_like(b1)
    for k in range(C.shape[0] - 2, 0, -1):
        b1, b2 = C[k] + two_s * b1 - b2, b1
    f = C[0] + s * b1 - b2
    return f[:, 0], f[:, 1], f[:, 2], f[:, 3]


def _sandwich_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The (4, 4) matrix M with ``M @ r = a (x) r (x) b`` for quaternions a, b (4,)."""
    eye = np.eye(4)
    return np.stack([_qmul_arr(_qmul_arr(a, e), b) for e in eye], axis=1)


def _zxz_quaternion(phi: np.ndarray, theta: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """Euler parameters of intrinsic ZXZ angles, Rz(phi) Rx(theta) Rz(psi)."""
    ch, sh = np.cos(0.5 * theta), np.sin(0.5 * theta)
    sp, dp = 0.5 * (phi + psi), 0.5 * (phi - psi)
    return np.stack([ch * np.cos(sp), sh * np.cos(dp), sh * np.sin(dp), ch * np.sin(sp)], axis=-1)


def free_body_solution(
    inertia: Any, omega_body0: Any, p0: Any, *, equal_tol: float = 1e-12, tables: bool = True
) -> FreeBodySolution:
    """Precompute the exact torque-free motion from ``(omega_body0, p0)`` at t = 0.

    Parameters
    ----------
    inertia : (3,) principal moments or (3, 3) symmetric positive-definite
        tensor in the body frame (diagonalized here; results are rotated
        back to the body frame).
    omega_body0 : (3,) initial angular velocity in the body frame, rad/s.
    p0 : (4,) initial unit Euler parameters (scalar first), body to global,
        unit within :data:`rigidlab.core.rotations.UNIT_NORM_TOL` (normalized).
    equal_tol : principal moments closer than ``equal_tol * max moment`` are
        treated as equal (closed-form regular precession).
    tables : tabulate sn, cn, dn and the periodic part of the precession
        integral once per motion (piecewise Chebyshev interpolants of the
        direct formulas, exact to round-off; ~1 ms) so that each time point
        costs a table look-up instead of ``ellipj`` and Carlson's integrals.
        ``False``, and motions close to the separatrix, evaluate the direct
        formulas at every time point.

    Returns
    -------
    FreeBodySolution
        ``.at(t)`` evaluates the motion; see :func:`free_body_exact`.
    """
    equal_tol = real_number(equal_tol, "equal_tol", expected="a finite tolerance >= 0")
    if equal_tol < 0.0:
        raise ValueError(f"equal_tol: expected a finite tolerance >= 0, got {equal_tol!r}")
    J_body = _inertia(inertia)
    w0 = _vec(omega_body0, "omega_body0").copy()  # frozen below: never the caller's array
    p0 = _unit_p(p0, "p0")
    J_body.setflags(write=False)
    w0.setflags(write=False)
    p0.setflags(write=False)
    Jsorted, Q = principal_axes(J_body)
    scale = float(Jsorted[2])
    eq01 = Jsorted[1] - Jsorted[0] <= equal_tol * scale
    eq12 = Jsorted[2] - Jsorted[1] <= equal_tol * scale
    w_pr = Q.T @ w0
    wn = math.hypot(*w0.tolist())  # hypot: no overflow of the squares
    with np.errstate(over="ignore"):
        L_norm = math.hypot(*(Jsorted * w_pr).tolist())
    if not L_norm * math.sqrt(scale / float(Jsorted[0])) <= _MAX_MOMENTUM_SCALE:
        raise ValueError(
            f"omega_body0: expected an angular velocity whose angular momentum squared fits float64 "
            f"(|I omega| sqrt(J_max / J_min) <= {_MAX_MOMENTUM_SCALE:g}), got |omega_body0| = {wn:.6g} rad/s "
            f"with |I omega| = {L_norm:.6g}"
        )
    # every angular rate of the motion is at most |L| / J_min (see FREE_BODY_MAX_PHASE)
    c: dict[str, Any] = {"max_rate": L_norm / float(Jsorted[0])}

    def done(kind: str, period: float) -> FreeBodySolution:
        return FreeBodySolution(kind, period, J_body, p0, w0, c)

    if wn == 0.0:
        return done("rest", 0.0)
    nonzero = np.count_nonzero(w_pr)
    if (eq01 and eq12) or nonzero <= 1:
        return done("steady", 0.0)
    q_Q = _p_from_rotation(Q)
    if eq01 or eq12:
        s = 2 if eq01 else 0
        Je = float(0.5 * (Jsorted[0] + Jsorted[1])) if eq01 else float(0.5 * (Jsorted[1] + Jsorted[2]))
        J_pr = np.array([Je, Je, Jsorted[2]]) if eq01 else np.array([Jsorted[0], Je, Je])
        L_pr = J_pr * w_pr
        c.update(
            axis=s, J_equal=Je, J_axis=float(J_pr[s]), J_pr=J_pr, L_pr=L_pr, Q=Q,
            p_pr0=quaternion_product(p0, q_Q), q_Q_conj=quaternion_conjugate(q_Q),
        )
        rate = abs((1.0 / J_pr[s] - 1.0 / Je) * L_pr[s])
        return done("symmetric", 2.0 * math.pi / rate if rate > 0 else 0.0)

    # Canonical labels (J1, J2, J3) with the polhode circling axis 3:
    # if |L|^2 < 2 E J2 relabel by the proper rotation (e3, -e2, e1).
    J = Jsorted
    D2 = float(np.sum(J * (J - J[1]) * w_pr**2))  # |L|^2 - 2 E J2 without cancellation
    if D2 >= 0.0:
        P = np.eye(3)
    else:
        P = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
    QP = Q @ P
    Jc = P.T @ np.diag(J) @ P
    J1, J2, J3 = float(Jc[0, 0]), float(Jc[1, 1]), float(Jc[2, 2])
    w1, w2, w3 = (P.T @ w_pr).tolist()
    D3 = J1 * (J3 - J1) * w1**2 + J2 * (J3 - J2) * w2**2  # 2 E J3 - |L|^2
    D1 = J2 * (J2 - J1) * w2**2 + J3 * (J3 - J1) * w3**2  # |L|^2 - 2 E J1
    W1 = math.sqrt(D3 / (J1 * (J3 - J1)))
    W2 = math.sqrt(D3 / (J2 * (J3 - J2)))
    W3 = math.sqrt(D1 / (J3 * (J3 - J1)))
    lam = math.sqrt((J3 - J2) * D1 / (J1 * J2 * J3))
    m = (J2 - J1) * D3 / ((J3 - J2) * D1)
    mc = (J3 - J1) * (J3 * (J3 - J2) * w3**2 - J1 * (J2 - J1) * w1**2) / ((J3 - J2) * D1)
    m, mc = min(max(m, 0.0), 1.0), min(max(mc, 0.0), 1.0)
    n = J3 * (J1 - J2) / (J1 * (J3 - J2))  # < 0
    sigma = 1.0 if J3 > J2 else -1.0
    s3 = 1.0 if w3 >= 0 else -1.0
    s2 = 1.0
    s1 = sigma * s3
    sn0, cn0 = s2 * w2 / W2, s1 * w1 / W1
    rho = math.hypot(sn0, cn0)
    sn0, cn0 = sn0 / rho, cn0 / rho
    Lm = math.sqrt((J1 * w1) ** 2 + (J2 * w2) ** 2 + (J3 * w3) ** 2)
    separatrix = mc == 0.0
    if separatrix:
        if cn0 == 0.0:  # exactly on the unstable axis: steady rotation
            return done("steady", 0.0)
        if cn0 < 0.0:  # the other branch of the separatrix
            s1, s2, sn0, cn0 = -s1, -s2, -sn0, -cn0
        u0 = math.asinh(sn0 / cn0)
        I0 = (u0 + math.sqrt(-n) * math.atan(math.sqrt(-n) * sn0)) / (1.0 - n)
        K = math.inf
        Pi = math.inf
    else:
        K = float(ellipkm1(mc))
        # F(phi0 | m) by Carlson's R_F with 1 - m sin^2 = cn^2 + mc sn^2 (accurate near m = 1)
        f = sn0 * float(elliprf(cn0 * cn0, cn0 * cn0 + mc * sn0 * sn0, 1.0))
        u0 = f if cn0 >= 0 else math.copysign(2.0 * K, sn0) - f
        Pi = float(elliprf(0.0, mc, 1.0) + (n / 3.0) * elliprj(0.0, mc, 1.0, 1.0 - n))
        j0 = math.floor((u0 + K) / (2.0 * K))
        r0 = u0 - 2.0 * K * j0
        r0a = np.array([r0])
        sn_r, cn_r, dn_r = _ellipj_accurate(r0a, m, mc)
        I0 = 2.0 * j0 * Pi + float(_pi_reduced(r0a, sn_r, np.maximum(cn_r, 0.0), dn_r, n, m, mc, K, Pi)[0])
    c.update(
        J=(J1, J2, J3), W=(W1, W2, W3), lam=lam, m=m, mc=mc, n=n, K=K, Pi=Pi, u0=u0, I0=I0,
        signs=(s1, s2, s3), L=Lm, prec=Lm * (J3 - J1) / (J1 * J3 * lam), QP=QP,
    )
    if not separatrix and tables:
        c["table"] = _chebyshev_tables(c)
    sol = FreeBodySolution("separatrix" if separatrix else "asymmetric",
                           math.inf if separatrix else 4.0 * K / lam, J_body, p0, w0, c)
    # Orientation: p(t) = p0 (x) q_can (x) conj(r(0)) (x) r(t) (x) conj(q_can),
    # with r(t) the canonical body -> invariable-frame rotation (z along L).
    q_can = _p_from_rotation(QP)
    c["q_can_conj"] = quaternion_conjugate(q_can)
    c["left"] = np.array([1.0, 0.0, 0.0, 0.0])
    c["sandwich"] = _sandwich_matrix(c["left"], c["q_can_conj"])
    r0q = _qmul_arr(sol.at(0.0).p.reshape(4), q_can)  # = r(0) with left = identity
    c["left"] = _qmul_arr(quaternion_product(p0, q_can), quaternion_conjugate(r0q))
    c["sandwich"] = _sandwich_matrix(c["left"], c["q_can_conj"])
    return sol


def free_body_exact(inertia: Any, omega_body0: Any, p0: Any, t: Any) -> FreeBodyMotion:
    """Exact torque-free motion of a rigid body with any inertia.

    Parameters
    ----------
    inertia : (3,) principal moments or (3, 3) symmetric positive-definite
        inertia tensor in the body frame, kg m^2.
    omega_body0 : (3,) angular velocity at t = 0 in the body frame, rad/s.
    p0 : (4,) unit Euler parameters at t = 0 (theta0..theta3, scalar first;
        ``A(p0)`` maps body to global), unit within
        :data:`rigidlab.core.rotations.UNIT_NORM_TOL` (1e-6) and normalized, as
        everywhere in the core.
    t : (...) times, s (any shape, any sign), with ``|t| |L| / J_min <=
        FREE_BODY_MAX_PHASE`` (1e14 rad).

    Returns
    -------
    FreeBodyMotion
        ``p`` (..., 4) and ``omega_body`` (..., 3) at ``t``.

    Raises
    ------
    ValueError
        For a bad inertia (including one that violates the triangle
        inequality), non-unit ``p0``, complex input, an angular velocity
        whose ``|L|^2`` overflows float64, and times beyond the phase bound
        :data:`FREE_BODY_MAX_PHASE`: every phase of the motion (elliptic
        argument ``lambda t``, precession, spin) is at most ``|L| |t| /
        J_min``, and a float64 phase is only known to about ``eps`` times
        its size, so past 1e14 rad (where that is a degree) the attitude at
        ``t`` is not defined by the arithmetic; the energy and ``|L|`` would
        still be right, the orientation would not.

    Notes
    -----
    In the principal frame with the polhode circling axis 3 (Landau &
    Lifshitz 37.10), ``omega = (s1 W1 cn u, s2 W2 sn u, s3 W3 dn u)`` with
    ``u = lambda t + u0`` (``ellipj``, reduced to ``|u| <= K`` by the
    half period ``2K``). The body's orientation is ``Rz(phi) Rx(theta)
    Rz(psi)`` in the frame whose z axis is L, with ``theta, psi`` read from
    ``L_body`` and the precession ``phi = |L| t / J3 + |L| (J3 - J1) /
    (J1 J3 lambda) Pi(n; am u | m)``, the incomplete elliptic integral of
    the third kind evaluated with Carlson's ``elliprf``/``elliprj``
    (van Zon & Schofield 2007). Two equal moments give regular precession in
    closed form; the separatrix uses tanh/sech; rotation about a principal
    axis is uniform. Cost is O(len(t)), vectorized.
    """
    return free_body_solution(inertia, omega_body0, p0).at(t)
