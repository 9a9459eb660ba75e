"""Rotor in a cardan suspension: Lagrange equations in Euler angles.

A symmetric rotor turns about a fixed point O (the centre of the cardan
suspension). Its orientation is given by the intrinsic ``"ZXZ"`` Euler angles
``(phi, theta, psi)`` -- precession about the base axis Z1 (outer gimbal),
nutation about the line of nodes X2 (inner gimbal) and spin about the rotor
axis Z3 -- so that ``A_global_rotor = Rz(phi) @ Rx(theta) @ Rz(psi)`` and the
rotor axis is ``e3 = A[:, 2] = (sin phi sin theta, -cos phi sin theta,
cos theta)``. Global +Z1 is up; gravity (when ``mgl > 0``) points along -Z1
and the centre of mass lies on the rotor axis at distance ``l`` from O.

The state of the rotor is the ``(..., 6)`` array ``(phi, theta, psi,
phi_dot, theta_dot, psi_dot)`` in radians and rad/s. Moments of inertia are
about O: ``I`` transverse (``ixx = iyy``), ``I3`` axial.

Equations (textbook chapter 8, gyroscope section):

* kinetic energy (Eq. 8.14)
  ``T = 1/2 I (theta_dot^2 + phi_dot^2 sin^2 theta) + 1/2 I3 omega3^2``,
  ``omega3 = psi_dot + phi_dot cos theta`` (the spin, the body-frame
  component of omega along the rotor axis); potential ``V = mgl cos theta``;
* Lagrange equations (Eq. 8.16) with generalized torques
  ``(M_phi, M_theta, M_psi)`` -- see :func:`equations_of_motion`;
* the momenta of the two ignorable coordinates (Eqs. 8.19-8.20)
  ``d1 = I3 omega3`` and ``d2 = I phi_dot sin^2 theta + d1 cos theta``;
* the reduced one-degree-of-freedom nutation equation (Eq. 8.21): with
  ``u = cos theta``, ``u_dot^2 = f(u) = (1 - u^2)(alpha - beta u) - (b - a u)^2``
  where ``a = d1 / I``, ``b = d2 / I``, ``beta = 2 mgl / I`` and
  ``alpha = (2 E - d1^2 / I3) / I`` (Goldstein, Classical Mechanics,
  sec. 5.7);
* the torque needed for steady precession (Eq. 8.23) and its theta = pi/2
  form ``M_theta = I3 phi_dot psi_dot - mgl``.

The exact heavy-top motion (:func:`simulate`) is
``u(t) = u1 + (u2 - u1) sn^2(lambda (t - t1), k)`` between the turning
points ``u1 <= u2`` of the cubic ``f``; ``phi`` and ``psi`` follow from
incomplete elliptic integrals of the third kind (Carlson's ``R_J``), made
quasi-periodic by whole nutation periods so that they stay accurate for any
``t``. The torque-free balanced rotor (``mgl = 0``) is the ``k = 0`` case of
the same formulas (regular precession about the angular momentum).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import KW_ONLY, InitVar, dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import elliprf, elliprj

from rigidlab.core._elliptic import complete_k, jacobi
from rigidlab.core._validation import degrees_out, float_array, output_times, positive_integer, radians, short_repr
from rigidlab.core.integrators import MAX_STEPS

__all__ = [
    "GYROSCOPE_MAX_ANGLE",
    "GyroscopeTrajectory",
    "Invariants",
    "MotionSamples",
    "MotionSummary",
    "NutationResult",
    "RotorParams",
    "RotorSetup",
    "RotorVectors",
    "SteadyPrecessionRates",
    "TopMotion",
    "equations_of_motion",
    "invariants",
    "motion_summary",
    "nutation",
    "rotor_vectors",
    "sample_motion",
    "simulate",
    "sleeping_top_critical_spin",
    "steady_precession_rates",
    "steady_precession_torque",
    "top_motion",
]

# |sin theta| below which the numerical path leaves the Euler-angle equations
# (singular at theta = 0, pi) for the Euler-parameter form, and above which it
# returns (hysteresis keeps the switches few).
_SIN_ENTER_PARAMETERS = 0.05
_SIN_LEAVE_PARAMETERS = 0.1

#: Largest magnitude (rad) of the angles ``phi``, ``theta``, ``psi`` of a
#: state, and of the angles of a motion at its sample times: the bound of
#: :data:`rigidlab.core.rigid_body.FREE_BODY_MAX_PHASE` for the same reason. A float64
#: angle carries an absolute error of about ``eps`` times its size: at 1e14
#: rad one unit in the last place is 0.016 rad (about a degree), and at 1e300
#: sin and cos are those of an angle known to no digit. States beyond it are
#: refused (naming the state and the angle), and so are sample times at
#: which the motion's angles would pass it (naming ``t``).
GYROSCOPE_MAX_ANGLE = 1e14

_ANGLE_NAMES = ("phi", "theta", "psi")


# ----------------------------------------------------------------- parameters
@dataclass(frozen=True)
class RotorParams:
    """Inertia and gravity moment of a symmetric rotor about its fixed point.

    Parameters
    ----------
    I : float
        Transverse moment of inertia about the fixed point O,
        ``ixx = iyy`` (kg m^2), > 0.
    I3 : float
        Axial moment of inertia about the rotor axis Z3 (kg m^2), > 0 and
        ``<= 2 I`` (triangle inequality of principal moments).
    mgl : float, default 0.0
        Weight times the distance from O to the centre of mass along the
        rotor axis (N m), >= 0. ``0`` is the balanced rotor of the chapter;
        ``> 0`` is the heavy (Lagrange) top with gravity along -Z1,
        potential ``V = mgl cos theta``.

    Raises
    ------
    ValueError
        When a value is not a finite number or breaks the bounds above.
    """

    I: float  # () transverse moment about O
    I3: float  # () axial moment
    mgl: float = 0.0  # () gravity moment, potential mgl cos(theta)

    def __post_init__(self) -> None:
        for name in ("I", "I3", "mgl"):
            value = getattr(self, name)
            if isinstance(value, (complex, np.complexfloating)):
                raise ValueError(f"{name}: expected real numbers, got complex {value!r}")
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise ValueError(f"{name}: expected a real number, got {value!r}")
            if not math.isfinite(float(value)):
                raise ValueError(f"{name}: expected a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.I <= 0.0:
            raise ValueError(f"I: expected a transverse moment of inertia > 0, got {self.I!r}")
        if self.I3 <= 0.0:
            raise ValueError(f"I3: expected an axial moment of inertia > 0, got {self.I3!r}")
        if self.I3 > 2.0 * self.I * (1.0 + 1e-12):
            raise ValueError(
                f"I3: expected I3 <= 2*I (triangle inequality of principal moments), "
                f"got I3={self.I3!r} with I={self.I!r}"
            )
        if self.mgl < 0.0:
            raise ValueError(
                f"mgl: expected >= 0 (centre of mass above the fixed point, gravity along -Z1), got {self.mgl!r}"
            )


@dataclass(frozen=True)
class Invariants:
    """First integrals of the torque-free (gravity only) rotor (Eqs. 8.19-8.20).

    Attributes
    ----------
    d1 : (...) ``I3 (psi_dot + phi_dot cos theta)``, momentum conjugate to psi
        (angular momentum about the rotor axis), kg m^2/s.
    d2 : (...) ``I phi_dot sin^2 theta + d1 cos theta``, momentum conjugate
        to phi (angular momentum about Z1), kg m^2/s.
    energy : (...) ``T + V`` with T of Eq. 8.14 and ``V = mgl cos theta`` (J).
    """

    d1: np.ndarray  # (...)
    d2: np.ndarray  # (...)
    energy: np.ndarray  # (...)


@dataclass(frozen=True)
class SteadyPrecessionRates:
    """Precession rates that keep theta constant under gravity alone.

    Attributes
    ----------
    slow : (...) the slow rate (the root of Eq. 8.23 with M_theta = 0 that
        tends to ``mgl / (I3 spin)`` for a fast top), rad/s.
    fast : (...) the fast rate (tends to ``I3 spin / (I cos theta)``),
        rad/s; at ``theta = pi/2``, where it does not exist, its limit
        ``sign(spin cos theta) inf`` from theta's side of the horizontal
        (0 without spin).
    """

    slow: np.ndarray  # (...)
    fast: np.ndarray  # (...)


@dataclass(frozen=True)
class NutationResult:
    """Nutation of the Lagrange (heavy symmetric) top, Goldstein sec. 5.7.

    Attributes
    ----------
    theta_min, theta_max : (...) bounds of theta in [0, pi] (rad), from the
        roots ``u2 = cos theta_min`` and ``u1 = cos theta_max`` of the cubic
        ``f(u)`` of Eq. 8.21.
    period : (...) nutation period ``2 K(k) / lambda`` (s); ``inf`` when
        theta stays constant (steady precession, sleeping top).
    mean_precession_rate : (...) average of ``phi_dot`` over one nutation
        period (rad/s), from complete elliptic integrals of the third kind.
    mean_spin_rate : (...) average of ``psi_dot`` over one period (rad/s).
    modulus_squared : (...) the parameter ``m = k^2`` of the Jacobi functions.
    """

    theta_min: np.ndarray  # (...)
    theta_max: np.ndarray  # (...)
    period: np.ndarray  # (...)
    mean_precession_rate: np.ndarray  # (...)
    mean_spin_rate: np.ndarray  # (...)
    modulus_squared: np.ndarray  # (...)


@dataclass(frozen=True)
class GyroscopeTrajectory:
    """Motion of the rotor sampled at given times (read-only arrays).

    Attributes
    ----------
    t : (n,) times (s).
    angles : (n, 3) ZXZ Euler angles ``(phi, theta, psi)`` (rad), continuous
        in time (not wrapped), theta in [0, pi].
    rates : (n, 3) ``(phi_dot, theta_dot, psi_dot)`` (rad/s).
    method : which path computed it: ``"closed_form"`` (elliptic functions,
        Eq. 8.21; includes the torque-free rotor as ``k = 0``),
        ``"steady"`` (theta constant), or ``"numerical"`` (DOP853 on
        Eq. 8.16, switching to Euler parameters near theta = 0, pi).
    """

    t: np.ndarray  # (n,)
    angles: np.ndarray  # (n, 3)
    rates: np.ndarray  # (n, 3)
    method: str


# ----------------------------------------------------------------- validation
def _check_params(params: Any) -> RotorParams:
    if not isinstance(params, RotorParams):
        raise ValueError(f"params: expected a RotorParams, got {type(params).__name__}")
    return params


def _check_state(state: Any, name: str = "state") -> np.ndarray:
    s = float_array(state, name, expected="a (..., 6) array of numbers")
    if s.ndim == 0 or s.shape[-1] != 6:
        raise ValueError(
            f"{name}: expected shape (..., 6) = (phi, theta, psi, phi_dot, theta_dot, psi_dot), got {s.shape}"
        )
    if not np.all(np.isfinite(s)):
        raise ValueError(f"{name}: expected finite values, got {s}")
    big = np.abs(s[..., :3]) > GYROSCOPE_MAX_ANGLE
    if big.any():
        index = tuple(int(i) for i in np.argwhere(big)[0])
        angle = _ANGLE_NAMES[index[-1]]
        where = f" at index {index[:-1]}" if index[:-1] else ""
        raise ValueError(
            f"{name}: expected angles |phi|, |theta|, |psi| <= GYROSCOPE_MAX_ANGLE = {GYROSCOPE_MAX_ANGLE:g} rad, "
            f"got {angle} = {float(s[index])!r}{where}: a float64 angle that large is known only to about "
            "eps times its size (a degree at 1e14 rad), so its sine and cosine mean nothing; reduce it modulo "
            "2 pi (phi, psi) or map theta into [0, pi]"
        )
    return s


def _check_array(value: Any, name: str) -> np.ndarray:
    a = float_array(value, name, expected="a number or array of numbers")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a}")
    return a


# ------------------------------------------------------- equations of motion
def equations_of_motion(params: RotorParams, state: Any, torques: Any = (0.0, 0.0, 0.0), *,
                        degrees: bool = False) -> np.ndarray:
    r"""Angle accelerations of the rotor from the Lagrange equations (Eq. 8.16).

    With ``s = sin theta``, ``c = cos theta`` and the spin
    ``omega3 = psi_dot + phi_dot c``, the Lagrangian ``T - V`` (Eq. 8.14,
    ``V = mgl c``) gives

    .. math::

        I \ddot\theta &= I \dot\phi^2 s c - I_3 \omega_3 \dot\phi s + mgl\, s + M_\theta \\
        I s^2 \ddot\phi &= M_\phi - M_\psi c + \dot\theta s (I_3 \omega_3 - 2 I \dot\phi c) \\
        \ddot\psi &= M_\psi / I_3 - \ddot\phi c + \dot\phi \dot\theta s

    (the phi and psi equations are ``d/dt (d2) = M_phi`` and
    ``d/dt (d1) = M_psi``).

    Parameters
    ----------
    params : RotorParams
    state : (..., 6) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)``.
    torques : (..., 3) generalized torques ``(M_phi, M_theta, M_psi)`` (N m),
        the virtual-work partners of the three angles (motor torques about
        Z1, X2 and Z3 of massless gimbals); broadcast against ``state``.
    degrees : bool, keyword-only
        True: ``state`` in degrees and deg/s, the result in deg/s^2.

    Returns
    -------
    (..., 3) ``(phi_ddot, theta_ddot, psi_ddot)`` in rad/s^2.

    Raises
    ------
    ValueError
        For bad shapes or non-finite input, and at ``sin theta = 0`` where
        the Euler-angle equations are singular (use :func:`simulate`, which
        switches to Euler parameters there).
    """
    state = radians(state, "state", degrees)
    params = _check_params(params)
    s_ = _check_state(state)
    m = _check_array(torques, "torques")
    if m.ndim == 0 or m.shape[-1] != 3:
        raise ValueError(f"torques: expected shape (..., 3) = (M_phi, M_theta, M_psi), got {m.shape}")
    theta = s_[..., 1]
    phid, thetad, psid = s_[..., 3], s_[..., 4], s_[..., 5]
    sn, cs = np.sin(theta), np.cos(theta)
    if np.any(np.abs(sn) < 1e-12):
        raise ValueError(
            f"state: the Euler-angle equations (Eq. 8.16) are singular at sin(theta) = 0, got theta={theta}"
        )
    I, I3, mgl = params.I, params.I3, params.mgl
    m_phi, m_theta, m_psi = m[..., 0], m[..., 1], m[..., 2]
    omega3 = psid + phid * cs
    theta_dd = (I * phid**2 * sn * cs - I3 * omega3 * phid * sn + mgl * sn + m_theta) / I
    phi_dd = (m_phi - m_psi * cs + thetad * sn * (I3 * omega3 - 2.0 * I * phid * cs)) / (I * sn**2)
    psi_dd = m_psi / I3 - phi_dd * cs + phid * thetad * sn
    return degrees_out(np.stack(np.broadcast_arrays(phi_dd, theta_dd, psi_dd), axis=-1), degrees)


def invariants(params: RotorParams, state: Any, *, degrees: bool = False) -> Invariants:
    """Momenta d1, d2 of the ignorable angles (Eqs. 8.19-8.20) and the energy.

    ``d1 = I3 (psi_dot + phi_dot cos theta)``,
    ``d2 = I phi_dot sin^2 theta + d1 cos theta`` and
    ``E = 1/2 I (theta_dot^2 + phi_dot^2 sin^2 theta) + d1^2 / (2 I3) + mgl cos theta``
    (Eq. 8.14 plus the potential). All three are constant when the applied
    generalized torques vanish (gravity allowed).

    Parameters
    ----------
    params : RotorParams
    state : (..., 6) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)``.
    degrees : bool, keyword-only
        True: the angles of ``state`` in degrees, its rates in deg/s (the result holds radians).

    Returns
    -------
    Invariants
        ``d1``, ``d2``, ``energy``, each of shape ``(...)``.
    """
    state = radians(state, "state", degrees)
    params = _check_params(params)
    s_ = _check_state(state)
    theta, phid, thetad, psid = s_[..., 1], s_[..., 3], s_[..., 4], s_[..., 5]
    sn, cs = np.sin(theta), np.cos(theta)
    d1 = params.I3 * (psid + phid * cs)
    d2 = params.I * phid * sn**2 + d1 * cs
    energy = 0.5 * params.I * (thetad**2 + (phid * sn) ** 2) + 0.5 * d1**2 / params.I3 + params.mgl * cs
    return Invariants(d1=d1, d2=d2, energy=energy)


@dataclass(frozen=True)
class RotorVectors:
    """Vectors of the rotor in the global frame (for drawing and checks).

    Attributes
    ----------
    rotor_axis : (..., 3) unit vector e3 along the rotor axis Z3.
    omega : (..., 3) angular velocity ``phi_dot Z1 + theta_dot X2 + psi_dot e3``
        in the global frame (Eq. 8.8), rad/s.
    angular_momentum : (..., 3) about the fixed point, global frame:
        ``I omega + (I3 - I) omega3 e3`` (kg m^2/s).
    torque : (..., 3) total torque about the fixed point, global frame:
        gravity ``mgl Z1 x e3`` plus the vector ``M`` of the applied
        generalized torques, ``G^T M = (M_phi, M_theta, M_psi)`` (N m).
    """

    rotor_axis: np.ndarray  # (..., 3)
    omega: np.ndarray  # (..., 3)
    angular_momentum: np.ndarray  # (..., 3)
    torque: np.ndarray  # (..., 3)


def rotor_vectors(params: RotorParams, state: Any, torques: Any = (0.0, 0.0, 0.0), *,
                  degrees: bool = False) -> RotorVectors:
    r"""Rotor axis, angular velocity, angular momentum and torque (global frame).

    With ``G = [Z1, X2, e3]`` the ZXZ velocity matrix (Eq. 8.8),
    ``omega = G (phi_dot, theta_dot, psi_dot)``. The generalized torques are
    the projections ``G^T M`` of a torque vector
    ``M = alpha Z1 + M_theta X2 + gamma e3`` with
    ``alpha = (M_phi - M_psi cos theta) / sin^2 theta`` and
    ``gamma = (M_psi - M_phi cos theta) / sin^2 theta``; at
    ``sin theta = 0`` (where Z1 = +-e3 and only ``M_phi = +-M_psi`` is
    consistent) ``M = M_theta X2 + M_psi e3`` is used.

    Parameters
    ----------
    params : RotorParams
    state : (..., 6) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)``.
    torques : (..., 3) ``(M_phi, M_theta, M_psi)`` (N m).
    degrees : bool, keyword-only
        True: the angles of ``state`` in degrees, its rates in deg/s (the result holds radians).

    Returns
    -------
    RotorVectors
        Each field (..., 3), global frame.
    """
    state = radians(state, "state", degrees)
    params = _check_params(params)
    s_ = _check_state(state)
    m = _check_array(torques, "torques")
    if m.ndim == 0 or m.shape[-1] != 3:
        raise ValueError(f"torques: expected shape (..., 3) = (M_phi, M_theta, M_psi), got {m.shape}")
    phi, theta = s_[..., 0], s_[..., 1]
    phid, thetad, psid = s_[..., 3], s_[..., 4], s_[..., 5]
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    zero = np.zeros_like(phi)
    z1 = np.stack([zero, zero, zero + 1.0], -1)
    x2 = np.stack([cp, sp, zero], -1)
    e3 = np.stack([sp * st, -cp * st, ct], -1)
    omega = phid[..., None] * z1 + thetad[..., None] * x2 + psid[..., None] * e3
    omega3 = psid + phid * ct
    L = params.I * omega + ((params.I3 - params.I) * omega3)[..., None] * e3
    m_phi, m_theta, m_psi = m[..., 0], m[..., 1], m[..., 2]
    s2 = st**2
    regular = s2 > 1e-12
    safe = np.where(regular, s2, 1.0)
    alpha = np.where(regular, (m_phi - m_psi * ct) / safe, 0.0)
    gamma = np.where(regular, (m_psi - m_phi * ct) / safe, m_psi)
    gravity = params.mgl * np.cross(z1, e3)
    torque = gravity + alpha[..., None] * z1 + np.asarray(m_theta)[..., None] * x2 + gamma[..., None] * e3
    return RotorVectors(rotor_axis=e3, omega=omega, angular_momentum=L, torque=torque)


# ---------------------------------------------------------- steady precession
def steady_precession_torque(params: RotorParams, theta: Any, phi_dot: Any, psi_dot: Any, *,
                             degrees: bool = False) -> np.ndarray:
    r"""Generalized torque M_theta that holds theta constant (Eq. 8.23).

    Setting ``theta_dot = theta_ddot = 0`` and constant ``phi_dot``,
    ``psi_dot`` in the theta equation of Eq. 8.16:

    .. math::

        M_\theta = \dot\phi \sin\theta \left(I_3 \dot\psi + (I_3 - I) \dot\phi \cos\theta\right)
                   - mgl \sin\theta ,

    which at ``theta = pi/2`` is ``M_theta = I3 phi_dot psi_dot - mgl``
    (the gyroscopic moment of the chapter). ``M_phi = M_psi = 0``.

    Parameters
    ----------
    params : RotorParams
    theta, phi_dot, psi_dot : (...) nutation angle (rad), precession and
        spin rates (rad/s); broadcast together.
    degrees : bool, keyword-only
        True: ``theta`` in degrees, ``phi_dot`` and ``psi_dot`` in deg/s.

    Returns
    -------
    (...) M_theta in N m (about the line of nodes X2).
    """
    theta = radians(theta, "theta", degrees)
    phi_dot = radians(phi_dot, "phi_dot", degrees)
    psi_dot = radians(psi_dot, "psi_dot", degrees)
    params = _check_params(params)
    th = _check_array(theta, "theta")
    pd = _check_array(phi_dot, "phi_dot")
    sd = _check_array(psi_dot, "psi_dot")
    sn, cs = np.sin(th), np.cos(th)
    return pd * sn * (params.I3 * sd + (params.I3 - params.I) * pd * cs) - params.mgl * sn


def steady_precession_rates(params: RotorParams, theta: Any, spin: Any, *,
                            degrees: bool = False) -> SteadyPrecessionRates:
    r"""Slow and fast steady precession rates of the heavy top (Eq. 8.23, M = 0).

    With ``M_theta = 0`` and ``sin theta != 0`` the steady condition is the
    quadratic ``I cos(theta) phi_dot^2 - I3 spin phi_dot + mgl = 0`` in
    ``phi_dot``, with ``spin = omega3 = psi_dot + phi_dot cos theta``:

    .. math::

        \dot\phi_{slow,fast} = \frac{I_3\omega_3 \mp \sqrt{I_3^2\omega_3^2 - 4 I\, mgl \cos\theta}}{2 I \cos\theta}

    (evaluated without cancellation). At ``cos theta = 0`` (``|cos theta| <
    1e-15``: ``np.pi / 2`` and its neighbours) the quadratic is linear: only
    the slow rate ``mgl / (I3 spin)`` exists, the steady precession of the
    chapter's horizontal gyroscope (``M_theta = I3 phi_dot psi_dot - mgl =
    0``). The fast root ``~ I3 spin / (I cos theta)`` has gone to infinity;
    ``fast`` is its limit from the side of the horizontal that ``theta``
    lies on, ``sign(spin cos theta) inf`` (``+inf`` for ``np.pi / 2``,
    6e-17 rad above the horizontal, and a positive spin), and ``0`` without
    spin (``mgl = 0``, where the fast root is 0 at every theta). The spin
    rate that goes with a precession rate is ``psi_dot = spin - phi_dot cos
    theta``.

    Parameters
    ----------
    params : RotorParams
    theta : (...) nutation angle (rad), with ``sin theta != 0``.
    spin : (...) ``omega3 = psi_dot + phi_dot cos theta`` (rad/s).
    degrees : bool, keyword-only
        True: ``theta`` in degrees and ``spin`` in deg/s (the result holds rad/s).

    Returns
    -------
    SteadyPrecessionRates
        ``slow`` and ``fast``, shape ``(...)``.

    Raises
    ------
    ValueError
        Where no steady precession exists: discriminant
        ``I3^2 spin^2 - 4 I mgl cos(theta) < 0`` (spin too slow for a top
        above the horizontal), or ``spin = 0`` at ``theta = pi/2`` with
        ``mgl > 0``, or ``sin theta = 0``.
    """
    theta = radians(theta, "theta", degrees)
    spin = radians(spin, "spin", degrees)
    params = _check_params(params)
    th = _check_array(theta, "theta")
    w3 = _check_array(spin, "spin")
    th, w3 = np.broadcast_arrays(th, w3)
    I, I3, mgl = params.I, params.I3, params.mgl
    sn, cs = np.sin(th), np.cos(th)
    if np.any(np.abs(sn) < 1e-12):
        raise ValueError(f"theta: steady precession needs sin(theta) != 0, got theta={th}")
    horizontal = np.abs(cs) < 1e-15
    side = np.where(cs < 0.0, -1.0, 1.0)  # below (-) or above (+) the horizontal
    cs = np.where(horizontal, 0.0, cs)
    h = I3 * w3
    disc = h**2 - 4.0 * I * mgl * cs
    if np.any(disc < 0.0):
        raise ValueError(
            "spin: no steady precession exists where I3^2 spin^2 < 4 I mgl cos(theta) "
            f"(spin too slow), got spin={w3}, theta={th}"
        )
    if mgl > 0.0 and np.any((cs == 0.0) & (h == 0.0)):
        raise ValueError(f"spin: no steady precession at theta = pi/2 without spin when mgl > 0, got spin={w3}")
    root = np.sqrt(disc)
    big = h + np.where(h >= 0.0, root, -root)  # |big| = |h| + root, no cancellation
    with np.errstate(divide="ignore", invalid="ignore"):
        slow = np.where(big != 0.0, 2.0 * mgl / np.where(big != 0.0, big, 1.0), 0.0)
        # at the horizontal the fast root I3 spin / (I cos theta) has left for
        # infinity on the side of theta's cosine: its limit is signed, and 0
        # without spin (then mgl = 0 and the fast root is 0 at every theta)
        limit = np.where(h == 0.0, 0.0, np.sign(h) * side * np.inf)
        fast = np.where(cs != 0.0, big / (2.0 * I * np.where(cs != 0.0, cs, 1.0)), limit)
    return SteadyPrecessionRates(slow=slow, fast=fast)


def sleeping_top_critical_spin(params: RotorParams) -> float:
    r"""Spin above which the upright (theta = 0) heavy top is stable.

    The sleeping top ``u = cos theta = 1`` is a double root of ``f(u)``
    (Eq. 8.21); it stays a stable turning point while
    ``a^2 >= 2 beta``, i.e. (Goldstein sec. 5.7)

    .. math:: \omega_{3,crit} = \frac{2\sqrt{mgl\, I}}{I_3}.

    Returns
    -------
    float
        The critical spin (rad/s); 0 for the balanced rotor.
    """
    params = _check_params(params)
    return 2.0 * math.sqrt(params.mgl * params.I) / params.I3


# ------------------------------------------------------ heavy-top closed form
def _normalize_state(s: np.ndarray) -> np.ndarray:
    """Map theta into [0, pi] with the equivalent ZXZ angles.

    ``(phi + pi, 2 pi - theta, psi + pi)`` with rates
    ``(phi_dot, -theta_dot, psi_dot)`` is the same orientation and angular
    velocity. A state exactly at theta = 0 (pi) moving to negative theta
    (above pi) is reflected as well.
    """
    s = np.array(s, dtype=float, copy=True)
    th = np.mod(s[..., 1], 2.0 * np.pi)
    flip = (th > np.pi) | ((th == 0.0) & (s[..., 4] < 0.0)) | ((th == np.pi) & (s[..., 4] > 0.0))
    th = np.where(flip, np.mod(2.0 * np.pi - th, 2.0 * np.pi), th)
    s[..., 0] = np.where(flip, s[..., 0] + np.pi, s[..., 0])
    s[..., 2] = np.where(flip, s[..., 2] + np.pi, s[..., 2])
    s[..., 4] = np.where(flip, -s[..., 4], s[..., 4])
    s[..., 1] = th
    return s


def _cubic_root_bisect_float(c0, c1, c2, c3, lo, hi, positive_at_lo):
    """:func:`_cubic_root_bisect` for one state, on Python floats (the same
    operations in the same order, without the cost of numpy calls on 0-d
    arrays)."""

    def poly(x):
        return c0 + x * (c1 + x * (c2 + x * c3))

    for _ in range(80):
        mid = 0.5 * (lo + hi)
        val = poly(mid)
        if (val >= 0.0) if positive_at_lo else (val <= 0.0):
            lo = mid
        else:
            hi = mid
    x = 0.5 * (lo + hi)
    bottom, top = min(lo, hi) - 1e-300, max(lo, hi) + 1e-300
    for _ in range(3):
        d = c1 + x * (2.0 * c2 + 3.0 * c3 * x)
        step = poly(x) / d if d != 0.0 else 0.0
        xn = x - step
        if math.isfinite(xn) and bottom <= xn <= top and abs(poly(xn)) <= abs(poly(x)):
            x = xn
    return x


def _cubic_root_bisect(c0, c1, c2, c3, lo, hi, *, positive_at_lo: bool) -> np.ndarray:
    """Root of ``c0 + c1 x + c2 x^2 + c3 x^3`` in [lo, hi] by bisection + Newton.

    Vectorized. The polynomial is >= 0 at ``lo`` and <= 0 at ``hi`` when
    ``positive_at_lo`` (the reverse otherwise), with one sign change.
    """
    if all(np.ndim(a) == 0 for a in (c0, c1, c2, c3, lo, hi)):
        args = (float(c0), float(c1), float(c2), float(c3), float(lo), float(hi))
        if all(math.isfinite(a) for a in args):
            return np.float64(_cubic_root_bisect_float(*args, positive_at_lo))
    lo = np.array(lo, dtype=float, copy=True)
    hi = np.array(hi, dtype=float, copy=True)

    def poly(x):
        return c0 + x * (c1 + x * (c2 + x * c3))

    for _ in range(80):
        mid = 0.5 * (lo + hi)
        val = poly(mid)
        go_right = (val >= 0.0) if positive_at_lo else (val <= 0.0)
        lo = np.where(go_right, mid, lo)
        hi = np.where(go_right, hi, mid)
    x = 0.5 * (lo + hi)
    # Newton polish (keeps the result when a step would leave the bracket,
    # e.g. at a double root where the derivative vanishes).
    for _ in range(3):
        d = c1 + x * (2.0 * c2 + 3.0 * c3 * x)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(d != 0.0, poly(x) / np.where(d != 0.0, d, 1.0), 0.0)
        xn = x - step
        ok = np.isfinite(xn) & (xn >= np.minimum(lo, hi) - 1e-300) & (xn <= np.maximum(lo, hi) + 1e-300)
        ok &= np.abs(poly(xn)) <= np.abs(poly(x))
        x = np.where(ok, xn, x)
    return x


@dataclass(frozen=True)
class _TopConstants:
    """Constants of the exact heavy-top motion from one state (arrays (...))."""

    u0: np.ndarray
    one_minus_u1: np.ndarray  # 1 - u1
    one_plus_u2: np.ndarray  # 1 + u2
    eps_top: np.ndarray  # 1 - u2 (accurate near theta = 0)
    eps_bottom: np.ndarray  # 1 + u1 (accurate near theta = pi)
    delta: np.ndarray  # u2 - u1
    lam: np.ndarray  # lambda, rad/s (argument rate of sn)
    m: np.ndarray  # k^2
    mc: np.ndarray  # 1 - k^2, formed without cancellation
    K: np.ndarray  # complete K(m)
    v0: np.ndarray  # sn argument at t = 0
    A: np.ndarray  # (b - a) / 2 : phi_dot = A/(1-u) + B/(1+u)
    B: np.ndarray  # (b + a) / 2
    spin_base: np.ndarray  # d1/I3 - a : psi_dot = spin_base - A/(1-u) + B/(1+u)
    steady: np.ndarray  # bool: theta constant


def _top_constants(params: RotorParams, s: np.ndarray) -> _TopConstants:
    """Turning points and elliptic constants of Eq. 8.21 for states (..., 6).

    The cubic is expanded about ``u0`` (and, for roots near the poles, about
    ``u = +1`` and ``u = -1``) so that ``u2 - u1``, ``1 - u2`` and ``1 + u1``
    are computed without cancellation, even when theta passes within 1e-8 of
    a pole.
    """
    I, I3, mgl = params.I, params.I3, params.mgl
    theta, phid, thetad, psid = s[..., 1], s[..., 3], s[..., 4], s[..., 5]
    # theta = np.pi (the double nearest pi, 1.2e-16 below it) is the lower
    # pole itself, as theta = 0 is the upper one: sin theta = 1 + cos theta = 0
    # there, so that a rotor at rest in theta there is an equilibrium (or a
    # steady spin about the vertical), not a nutation of amplitude 1e-16.
    pole = theta == np.pi
    sn, u0 = np.where(pole, 0.0, np.sin(theta)), np.cos(theta)
    om_u0 = 2.0 * np.sin(0.5 * theta) ** 2  # 1 - u0
    op_u0 = np.where(pole, 0.0, 2.0 * np.cos(0.5 * theta) ** 2)  # 1 + u0
    beta = 2.0 * mgl / I
    d1 = I3 * (psid + phid * u0)
    a = d1 / I
    h = phid * sn**2  # b - a u0
    w = thetad**2 + (phid * sn) ** 2  # alpha - beta u0
    b_minus_a = h - a * om_u0
    b_plus_a = h + a * op_u0
    A = 0.5 * b_minus_a
    B = 0.5 * b_plus_a
    # f(u0 + x) = f0 + f1 x + f2 x^2 + beta x^3
    f0 = (sn * thetad) ** 2
    f1 = -(sn**2) * beta - 2.0 * u0 * w + 2.0 * a * h
    f2 = 2.0 * u0 * beta - w - a**2
    f3 = beta * np.ones_like(u0)
    x2 = _cubic_root_bisect(f0, f1, f2, f3, np.zeros_like(u0), om_u0, positive_at_lo=True)
    x1 = _cubic_root_bisect(f0, f1, f2, f3, -op_u0, np.zeros_like(u0), positive_at_lo=False)
    # theta stays constant: turning point that is a double root (steady
    # precession, sleeping top, equilibria).
    # |f1| at the level of its own round-off means a double root at u0
    f1_scale = np.abs(sn**2 * beta) + np.abs(2.0 * u0 * w) + np.abs(2.0 * a * h)
    steady = (f0 == 0.0) & (np.abs(f1) <= 16.0 * np.finfo(float).eps * f1_scale)
    x1 = np.where(steady, 0.0, x1)
    x2 = np.where(steady, 0.0, x2)
    delta = x2 - x1
    # Near the poles: roots of f(1 - y) = g0 + g1 y + g2 y^2 - beta y^3 and
    # f(-1 + z) = h0 + h1 z + h2 z^2 + beta z^3.
    alpha_minus_beta = w - beta * om_u0
    alpha_plus_beta = w + beta * op_u0
    g0 = -(b_minus_a**2)
    g1 = 2.0 * alpha_minus_beta - 2.0 * a * b_minus_a
    g2 = -(w + beta * u0) + 3.0 * beta - a**2
    eps_top_far = om_u0 - x2
    y2 = _cubic_root_bisect(g0, g1, g2, -f3, np.zeros_like(u0), om_u0, positive_at_lo=False)
    eps_top = np.where((eps_top_far < 0.25) & ~steady, y2, eps_top_far)
    h0 = -(b_plus_a**2)
    h1 = 2.0 * alpha_plus_beta + 2.0 * a * b_plus_a
    h2 = -(w + beta * u0) - 3.0 * beta - a**2
    eps_bot_far = op_u0 + x1
    z1 = _cubic_root_bisect(h0, h1, h2, f3, np.zeros_like(u0), op_u0, positive_at_lo=False)
    eps_bottom = np.where((eps_bot_far < 0.25) & ~steady, z1, eps_bot_far)
    eps_top = np.maximum(eps_top, 0.0)
    eps_bottom = np.maximum(eps_bottom, 0.0)
    # f(u) = beta (u-u1)(u-u2)(u-u3): gamma1 = beta (u3 - u1) = -f2 - beta (2 x1 + x2)
    gamma1 = np.maximum(-f2 - beta * (2.0 * x1 + x2), 0.0)
    lam = 0.5 * np.sqrt(gamma1)
    with np.errstate(divide="ignore", invalid="ignore"):
        g_pos = np.where(gamma1 > 0.0, gamma1, 1.0)
        m = np.where(gamma1 > 0.0, beta * delta / g_pos, 0.0)
        # 1 - m = beta (u3 - u2) / gamma1, formed without cancellation: m is
        # within 1e-16 of 1 for a top started within 1e-8 rad of the vertical
        # below its critical spin, where 1 - m ~ theta0^2 sets the period.
        # With y = 1 - u the roots of g are y1 = 1 - u1, y2 = 1 - u2 and
        # y3 = 1 - u3 <= 0, whose product is g0 / beta (g0 = 0 when u2 = 1:
        # then y1 y3 = -g1 / beta).
        y1 = eps_top + delta
        y1_pos = np.where(y1 > 0.0, y1, 1.0)
        y3 = np.where(eps_top > 0.0, g0 / (beta * y1_pos * np.where(eps_top > 0.0, eps_top, 1.0)),
                      -g1 / (beta * y1_pos))
        mc_top = np.where(gamma1 > 0.0, beta * (eps_top - y3) / g_pos, 1.0)
    near_top = (eps_top_far < 0.25) & (m > 0.5) & (beta > 0.0) & np.isfinite(mc_top)
    mc = np.where(near_top, mc_top, 1.0 - m)
    # a state exactly on the separatrix is steady (theta0 at a double root)
    mc = np.clip(mc, np.finfo(float).tiny, 1.0)
    m = np.clip(m, 0.0, 1.0)
    K = complete_k(mc)
    # phase: sn^2(v0) = r = (u0 - u1)/delta, increasing u on [0, K]
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(delta > 0.0, -x1 / np.where(delta > 0.0, delta, 1.0), 0.0)
        rc = np.where(delta > 0.0, x2 / np.where(delta > 0.0, delta, 1.0), 1.0)
    r = np.clip(r, 0.0, 1.0)
    rc = np.clip(rc, 0.0, 1.0)
    # 1 - m r = rc + mc r (r + rc = 1), no cancellation as m -> 1
    F = np.sqrt(r) * elliprf(rc, rc + mc * r, 1.0)
    u_dot0 = -sn * thetad
    v0 = np.where(u_dot0 < 0.0, 2.0 * K - F, F)
    spin_base = d1 / I3 - a
    steady = steady | (delta <= 0.0) | (lam <= 0.0)
    return _TopConstants(
        u0=u0,
        one_minus_u1=eps_top + delta,
        one_plus_u2=eps_bottom + delta,
        eps_top=eps_top,
        eps_bottom=eps_bottom,
        delta=delta,
        lam=lam,
        m=m,
        mc=mc,
        K=K,
        v0=v0,
        A=A,
        B=B,
        spin_base=spin_base,
        steady=steady,
    )


def _q_complete(one_minus_n, mc):
    """``Q(n) = int_0^K sn^2 / (1 - n sn^2) dv = R_J(0, 1-m, 1, 1-n) / 3`` (``mc = 1 - m``)."""
    return elliprj(0.0, mc, 1.0, one_minus_n) / 3.0


def _q_incomplete(v, n, one_minus_n, mc, K, qc):
    """``int_0^v sn^2/(1 - n sn^2) dv'`` for any real v (quasi-periodic).

    ``v = 2 K j + r`` with ``r`` in [-K, K); the principal part is
    ``s^3 R_J(c^2, d^2, 1, 1 - n s^2) / 3`` with ``1 - n s^2`` formed as
    ``c^2 + s^2 (1 - n)`` (no cancellation near the pole ``n -> 1``).
    """
    j = np.floor((v + K) / (2.0 * K))
    r = v - 2.0 * K * j
    sn_, cn_, dn_ = jacobi(r, mc, K)
    c2 = cn_**2
    p = c2 + sn_**2 * one_minus_n
    with np.errstate(divide="ignore", invalid="ignore"):
        part = np.where(sn_ != 0.0, sn_**3 * elliprj(c2, dn_**2, 1.0, p) / 3.0, 0.0)
    return 2.0 * j * qc + part


def nutation(params: RotorParams, state: Any, *, degrees: bool = False) -> NutationResult:
    r"""Nutation bounds, period and mean precession of the heavy top.

    From the cubic of Eq. 8.21 (Goldstein sec. 5.7),
    ``f(u) = (1-u^2)(alpha - beta u) - (b - a u)^2 = beta (u-u1)(u-u2)(u-u3)``
    with ``-1 <= u1 <= u0 <= u2 <= 1 < u3``:
    ``theta_max = arccos u1``, ``theta_min = arccos u2``,
    ``u(t) = u1 + (u2 - u1) sn^2(lambda t', k)``, ``k^2 = (u2-u1)/(u3-u1)``,
    ``lambda = sqrt(beta (u3 - u1)) / 2``, period ``2 K(k) / lambda``.
    The mean precession rate is the average of
    ``phi_dot = A/(1-u) + B/(1+u)`` (``A, B = (b -+ a)/2``) over one period,
    exact through complete elliptic integrals of the third kind
    (Carlson's ``R_J``). For ``mgl = 0`` (torque-free rotor) ``k = 0`` and
    the motion is regular precession (theta constant only when the rotor
    axis is along Z1 or the angular momentum is along Z1).

    Parameters
    ----------
    params : RotorParams
    state : (..., 6) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)``; no
        applied torques (gravity only).
    degrees : bool, keyword-only
        True: the angles of ``state`` in degrees, its rates in deg/s (the result holds radians).

    Returns
    -------
    NutationResult
        Each field of shape ``(...)``; ``period = inf`` and
        ``theta_min = theta_max`` when theta stays constant.
    """
    state = radians(state, "state", degrees)
    params = _check_params(params)
    s = _normalize_state(_check_state(state))
    c = _top_constants(params, s)
    theta_min = 2.0 * np.arctan2(np.sqrt(0.5 * c.eps_top), np.sqrt(0.5 * c.one_plus_u2))
    theta_max = 2.0 * np.arctan2(np.sqrt(0.5 * c.one_minus_u1), np.sqrt(0.5 * c.eps_bottom))
    theta0 = s[..., 1]
    theta_min = np.where(c.steady, theta0, theta_min)
    theta_max = np.where(c.steady, theta0, theta_max)
    with np.errstate(divide="ignore", invalid="ignore"):
        period = np.where(c.steady, np.inf, 2.0 * c.K / np.where(c.steady, 1.0, c.lam))
        j_plus, j_minus = _period_integrals(c)
        mean_phi = (c.A * j_plus + c.B * j_minus) / period
        mean_psi = c.spin_base + (-c.A * j_plus + c.B * j_minus) / period
    rates_steady = _constant_rates(c)
    mean_phi = np.where(c.steady, rates_steady[0], mean_phi)
    mean_psi = np.where(c.steady, rates_steady[1], mean_psi)
    return NutationResult(
        theta_min=theta_min,
        theta_max=theta_max,
        period=period,
        mean_precession_rate=mean_phi,
        mean_spin_rate=mean_psi,
        modulus_squared=c.m,
    )


def _safe_div(num, den):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(num == 0.0, 0.0, num / np.where(den == 0.0, 1.0, den))


def _char_plus(c: _TopConstants):
    """n+ = delta / (1 - u1) and 1 - n+ = (1 - u2)/(1 - u1) for 1/(1-u)."""
    n = _safe_div(c.delta, c.one_minus_u1)
    one_minus_n = np.where(c.one_minus_u1 > 0.0, _safe_div(c.eps_top, c.one_minus_u1), 1.0)
    return n, one_minus_n


def _char_minus(c: _TopConstants):
    """N = (m (1+u1) + delta)/(1+u2), 1 - N = (1-m)(1+u1)/(1+u2) for 1/(1+u)."""
    N = _safe_div(c.m * c.eps_bottom + c.delta, c.one_plus_u2)
    one_minus_N = np.where(c.one_plus_u2 > 0.0, c.mc * _safe_div(c.eps_bottom, c.one_plus_u2), 1.0)
    return N, one_minus_N


def _period_integrals(c: _TopConstants):
    """``int dt/(1-u)`` and ``int dt/(1+u)`` over one nutation period."""
    n, one_minus_n = _char_plus(c)
    N, one_minus_N = _char_minus(c)
    lam = np.where(c.lam > 0.0, c.lam, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        q_plus = np.where(c.A != 0.0, _q_complete(one_minus_n, c.mc), 0.0)
        q_minus = np.where(c.B != 0.0, _q_complete(one_minus_N, c.mc), 0.0)
    j_plus = _safe_div(2.0 * c.K + n * 2.0 * q_plus, lam * c.one_minus_u1)
    j_minus = _safe_div(2.0 * c.K + (N - c.m) * 2.0 * q_minus, lam * c.one_plus_u2)
    return j_plus, j_minus


def _constant_rates(c: _TopConstants):
    """phi_dot and psi_dot while u stays at u0 (steady precession)."""
    one_m_u = c.eps_top
    one_p_u = c.one_plus_u2
    phid = _safe_div(c.A, one_m_u) + _safe_div(c.B, one_p_u)
    psid = c.spin_base - _safe_div(c.A, one_m_u) + _safe_div(c.B, one_p_u)
    return phid, psid


@dataclass(frozen=True)
class TopMotion:
    """One exact torque-free motion of the rotor (gravity allowed); evaluate with :meth:`at`.

    Build with :func:`top_motion`. Holds the constants of the closed form
    (Eqs. 8.19-8.21): the turning points ``u1 <= u0 <= u2`` of the cubic
    ``f(u)`` of Eq. 8.21 (a bisection per root), the modulus, the rate
    ``lambda`` and the phase of Jacobi's ``sn``, and the complete elliptic
    integrals of the third kind of the precession and spin integrals.
    Computing them costs about a millisecond; :meth:`at` then costs only
    the evaluation at the requested times, so a caller that samples one
    motion chunk after chunk pays for the constants once.

    Attributes
    ----------
    params : RotorParams
    state0 : (6,) initial state ``(phi, theta, psi, phi_dot, theta_dot,
        psi_dot)`` with theta mapped into [0, pi] (see :func:`simulate`).
    method : ``"closed_form"`` (Jacobi elliptic functions; ``k = 0`` for
        the balanced rotor) or ``"steady"`` (theta constant).
    period : nutation period ``2 K(k) / lambda`` (s); ``inf`` when steady.
    """

    params: RotorParams
    state0: np.ndarray = field(repr=False)  # (6,)
    method: str
    period: float
    _k: dict = field(repr=False, compare=False)

    def at(self, t: Any) -> GyroscopeTrajectory:
        """The motion sampled at times ``t``.

        Parameters
        ----------
        t : (n,) sample times (s), non-decreasing, >= 0.

        Returns
        -------
        GyroscopeTrajectory
            ``t`` (n,), ``angles`` (n, 3), ``rates`` (n, 3) and ``method``;
            exactly what ``simulate(params, state0, t)`` returns.

        Raises
        ------
        ValueError
            For bad times, or when the motion reaches a non-finite state.
        """
        tt = _check_times(t)
        angles, rates = self._evaluate(tt)
        if not (np.all(np.isfinite(angles)) and np.all(np.isfinite(rates))):
            raise ValueError("state0: the motion reached a non-finite state")
        _check_motion_angles(tt, angles)
        for a in (tt, angles, rates):
            a.setflags(write=False)
        return GyroscopeTrajectory(t=tt, angles=angles, rates=rates, method=self.method)

    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angles (n, 3) and rates (n, 3) of the exact motion at times t (n,)."""
        k = self._k
        phi0, theta0, psi0 = k["phi0"], k["theta0"], k["psi0"]
        n_t = t.shape[0]
        angles = np.empty((n_t, 3))
        rates = np.empty((n_t, 3))
        if self.method == "steady":
            phid, psid = k["phid"], k["psid"]
            angles[:, 0] = phi0 + phid * t
            angles[:, 1] = theta0
            angles[:, 2] = psi0 + psid * t
            rates[:, 0] = phid
            rates[:, 1] = 0.0
            rates[:, 2] = psid
            return angles, rates
        lam, m, mc, K, v0, delta = k["lam"], k["m"], k["mc"], k["K"], k["v0"], k["delta"]
        A, B = k["A"], k["B"]
        one_minus_u1, one_plus_u2 = k["one_minus_u1"], k["one_plus_u2"]
        eps_top, eps_bottom = k["eps_top"], k["eps_bottom"]
        v = v0 + lam * t
        j = np.floor((v + K) / (2.0 * K))
        r = v - 2.0 * K * j
        sn_, cn_, dn_ = jacobi(r, mc, K)
        s2 = sn_**2
        one_m_u = one_minus_u1 * cn_**2 + eps_top * s2
        one_p_u = eps_bottom + delta * s2
        theta = 2.0 * np.arctan2(np.sqrt(0.5 * one_m_u), np.sqrt(0.5 * one_p_u))
        # theta_dot = -u_dot / sin(theta), u_dot = 2 delta lambda sn cn dn
        sin_theta = np.sqrt(one_m_u * one_p_u)
        with np.errstate(divide="ignore", invalid="ignore"):
            thetad = np.where(sin_theta > 0.0, -2.0 * delta * lam * sn_ * cn_ * dn_ / np.where(sin_theta > 0, sin_theta, 1), 0.0)
        # exactly through a pole: the limit of cn / sqrt(1 - u) (or sn / sqrt(1 + u))
        at_top = (one_m_u == 0.0)
        at_bot = (one_p_u == 0.0)
        if np.any(at_top):
            thetad = np.where(at_top, -2.0 * delta * lam * sn_ * np.sign(cn_ + 0.0) * dn_
                              / math.sqrt(one_minus_u1 * one_plus_u2), thetad)
        if np.any(at_bot):
            thetad = np.where(at_bot, -2.0 * delta * lam * np.sign(sn_) * cn_ * dn_
                              / math.sqrt(delta * one_plus_u2), thetad)
        term_top = _safe_div(np.full_like(one_m_u, A), one_m_u)
        term_bot = _safe_div(np.full_like(one_p_u, B), one_p_u)
        phid = term_top + term_bot
        psid = k["spin_base"] - term_top + term_bot
        # phi, psi: int dt/(1-u) and int dt/(1+u) from v0 to v
        dv = lam * t
        if A != 0.0:
            n, one_minus_n, qc = k["n"], k["one_minus_n"], k["qc_plus"]
            q = _q_incomplete(v, n, one_minus_n, mc, K, qc) - k["q0_plus"]
            j_plus = (dv + n * q) / (lam * one_minus_u1)
        else:
            j_plus = np.zeros_like(t)
        if B != 0.0:
            # 1/(1+u) in terms of v'' = K - v: (1 - m s''^2) / ((1+u2)(1 - N s''^2))
            N, one_minus_N, qc = k["N"], k["one_minus_N"], k["qc_minus"]
            q = _q_incomplete(K - v, N, one_minus_N, mc, K, qc) - k["q0_minus"]
            j_minus = -(-(dv) + (N - m) * q) / (lam * one_plus_u2)
        else:
            j_minus = np.zeros_like(t)
        phi = phi0 + A * j_plus + B * j_minus
        psi = psi0 + k["spin_base"] * t - A * j_plus + B * j_minus
        # Passing exactly through a pole (A = 0 or B = 0 with the pole reached):
        # the Euler angles jump by pi there (theta is kept in [0, pi]).
        if A == 0.0 and eps_top == 0.0:
            passes = _count_crossings(v, v0, K)  # u = 1 at v = K (mod 2K)
            phi = phi + np.pi * passes
            psi = psi - np.pi * passes
        if B == 0.0 and eps_bottom == 0.0:
            passes = _count_crossings(v, v0, 0.0 * K, period=2.0 * K)  # u = -1 at v = 0 (mod 2K)
            phi = phi + np.pi * passes
            psi = psi + np.pi * passes
        angles[:, 0] = phi
        angles[:, 1] = theta
        angles[:, 2] = psi
        rates[:, 0] = phid
        rates[:, 1] = thetad
        rates[:, 2] = psid
        return angles, rates


def _check_motion_angles(t: np.ndarray, angles: np.ndarray) -> None:
    """Refuse sample times at which an angle of the motion exceeds :data:`GYROSCOPE_MAX_ANGLE` (naming ``t``)."""
    big = np.abs(angles) > GYROSCOPE_MAX_ANGLE
    if big.any():
        i, k = (int(j) for j in np.argwhere(big)[0])
        raise ValueError(
            f"t: expected times at which the angles stay within GYROSCOPE_MAX_ANGLE = {GYROSCOPE_MAX_ANGLE:g} rad, "
            f"got t[{i}] = {float(t[i])!r} s where {_ANGLE_NAMES[k]} = {float(angles[i, k]):.6g} rad: there one "
            "float64 rounding of the angle turns the rotor by more than a degree; ask for earlier times"
        )


def top_motion(params: RotorParams, state0: Any, *, degrees: bool = False) -> TopMotion:
    """Precompute the exact torque-free (gravity only) motion from ``state0`` at t = 0.

    The closed form of :func:`simulate` without applied torques, split into
    its per-motion constants (computed here once) and its evaluation at
    given times (:meth:`TopMotion.at`): ``top_motion(params, state0).at(t)``
    equals ``simulate(params, state0, t)`` for every ``t``.

    Parameters
    ----------
    params : RotorParams
    state0 : (6,) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)`` at
        t = 0. A theta outside [0, pi] is first mapped to the same
        orientation with ``(phi + pi, -theta, psi + pi)``.
    degrees : bool, keyword-only
        True: the angles of ``state0`` in degrees, its rates in deg/s (the result holds radians).

    Returns
    -------
    TopMotion
        ``.at(t)`` gives the :class:`GyroscopeTrajectory` at times ``t``.

    Raises
    ------
    ValueError
        For bad parameters or a bad state.
    """
    state0 = radians(state0, "state0", degrees)
    params = _check_params(params)
    s0 = _check_state(state0, "state0")
    if s0.shape != (6,):
        raise ValueError(f"state0: expected shape (6,), got {s0.shape}")
    s0 = _normalize_state(s0)
    s0.setflags(write=False)
    c = _top_constants(params, s0)
    k: dict[str, float] = {"phi0": float(s0[0]), "theta0": float(s0[1]), "psi0": float(s0[2])}
    if bool(c.steady):
        phid, psid = _constant_rates(c)
        k.update(phid=float(phid), psid=float(psid))
        return TopMotion(params, s0, "steady", math.inf, k)
    k.update(
        lam=float(c.lam), m=float(c.m), mc=float(c.mc), K=float(c.K), v0=float(c.v0), delta=float(c.delta),
        A=float(c.A), B=float(c.B), one_minus_u1=float(c.one_minus_u1), one_plus_u2=float(c.one_plus_u2),
        eps_top=float(c.eps_top), eps_bottom=float(c.eps_bottom), spin_base=float(c.spin_base),
    )
    mc, K, v0 = k["mc"], k["K"], k["v0"]
    if k["A"] != 0.0:
        n, one_minus_n = (float(x) for x in _char_plus(c))
        qc = float(_q_complete(one_minus_n, mc))
        q0 = float(_q_incomplete(np.float64(v0), n, one_minus_n, mc, K, qc))
        k.update(n=n, one_minus_n=one_minus_n, qc_plus=qc, q0_plus=q0)
    if k["B"] != 0.0:
        N, one_minus_N = (float(x) for x in _char_minus(c))
        qc = float(_q_complete(one_minus_N, mc))
        q0 = float(_q_incomplete(np.float64(K - v0), N, one_minus_N, mc, K, qc))
        k.update(N=N, one_minus_N=one_minus_N, qc_minus=qc, q0_minus=q0)
    return TopMotion(params, s0, "closed_form", 2.0 * K / k["lam"], k)


def _count_crossings(v, v0, at, period=None):
    """Number of points ``at + period j`` in (v0, v] (``period`` default 2K)."""
    period = 2.0 * at if period is None else period
    j0 = (v0 - at) / period
    if abs(j0 - round(j0)) < 1e-12:
        j0 = float(round(j0))
    return np.floor((v - at) / period + 1e-12) - math.floor(j0)


# ------------------------------------------------------------ numerical path
def _torque_function(torques: Any) -> Callable[[float, np.ndarray], np.ndarray] | None:
    """None for no applied torque, else ``f(t, state) -> (3,)``."""
    if torques is None:
        return None
    if callable(torques):
        def f(t, state, _f=torques):
            value = _f(t, state)
            out = float_array(value, "torques", expected="3 finite numbers from the callable")
            if out.shape != (3,) or not np.all(np.isfinite(out)):
                raise ValueError(f"torques: the callable must return 3 finite numbers, got {short_repr(value)}")
            return out
        return f
    m = _check_array(torques, "torques")
    if m.shape != (3,):
        raise ValueError(f"torques: expected (M_phi, M_theta, M_psi) of shape (3,) or a callable, got shape {m.shape}")
    if not np.any(m):
        return None
    return lambda t, state, _m=m: _m


class _StopNumerical(Exception):
    """Stops the numerical path from inside a right-hand side (internal)."""

    def __init__(self, reason: str, t: float):
        super().__init__(reason, t)
        self.reason = reason  # "non-finite", "pole" or "budget"
        self.t = float(t)


class _Budget:
    """Counts right-hand-side evaluations of one numerical run (internal)."""

    def __init__(self, limit: int):
        self.limit = limit
        self.calls = 0

    def spend(self, t: float) -> None:
        self.calls += 1
        if self.calls > self.limit:
            raise _StopNumerical("budget", t)


def _rhs_angles(params: RotorParams, torque: Callable, budget: _Budget) -> Callable:
    I, I3, mgl = params.I, params.I3, params.mgl

    def rhs(t, y):
        budget.spend(t)
        m_phi, m_theta, m_psi = torque(t, y)
        theta, phid, thetad, psid = y[1], y[3], y[4], y[5]
        if not math.isfinite(theta):
            raise _StopNumerical("non-finite", t)
        sn, cs = math.sin(theta), math.cos(theta)
        omega3 = psid + phid * cs
        theta_dd = (I * phid * phid * sn * cs - I3 * omega3 * phid * sn + mgl * sn + m_theta) / I
        phi_dd = (m_phi - m_psi * cs + thetad * sn * (I3 * omega3 - 2.0 * I * phid * cs)) / (I * sn * sn)
        psi_dd = m_psi / I3 - phi_dd * cs + phid * thetad * sn
        if not math.isfinite(phid + thetad + psid + phi_dd + theta_dd + psi_dd):
            raise _StopNumerical("non-finite", t)
        return np.array([phid, thetad, psid, phi_dd, theta_dd, psi_dd])

    return rhs


def _quaternion_from_zxz(phi, theta, psi):
    """Euler parameters (scalar first) of Rz(phi) Rx(theta) Rz(psi)."""
    ch, sh = math.cos(0.5 * theta), math.sin(0.5 * theta)
    sp, dp = 0.5 * (phi + psi), 0.5 * (phi - psi)
    return np.array([ch * math.cos(sp), sh * math.cos(dp), sh * math.sin(dp), ch * math.sin(sp)])


def _zxz_from_quaternion(p: np.ndarray, phi_ref: float, psi_ref: float):
    """ZXZ angles of Euler parameters p (n, 4), theta in [0, pi], continuous.

    ``theta = 2 atan2(|(p1, p2)|, |(p0, p3)|)``, ``phi + psi = 2 atan2(p3, p0)``,
    ``phi - psi = 2 atan2(p2, p1)``; accurate near theta = 0 and pi. The
    branches follow ``phi_ref``, ``psi_ref`` (the previous sample).
    """
    p = p / np.linalg.norm(p, axis=-1, keepdims=True)
    theta = 2.0 * np.arctan2(np.hypot(p[:, 1], p[:, 2]), np.hypot(p[:, 0], p[:, 3]))
    s_sum = 2.0 * np.arctan2(p[:, 3], p[:, 0])
    s_dif = 2.0 * np.arctan2(p[:, 2], p[:, 1])
    phi = 0.5 * (s_sum + s_dif)
    psi = 0.5 * (s_sum - s_dif)
    phi_prev, psi_prev = phi_ref, psi_ref
    out_phi = np.empty_like(phi)
    out_psi = np.empty_like(psi)
    two_pi = 2.0 * np.pi
    for i in range(phi.shape[0]):
        # phi and psi are each defined modulo 2 pi (with theta in [0, pi] the
        # sign of p does not matter); pick the branches nearest the previous
        # sample. Near a pole the true phi and psi jump by about pi: either
        # branch of such a jump is the same orientation.
        cand_phi = phi[i] + two_pi * np.round((phi_prev - phi[i]) / two_pi)
        cand_psi = psi[i] + two_pi * np.round((psi_prev - psi[i]) / two_pi)
        phi_prev, psi_prev = cand_phi, cand_psi
        out_phi[i], out_psi[i] = cand_phi, cand_psi
    return out_phi, theta, out_psi


def _rhs_parameters(params: RotorParams, torque: Callable, angle_ref: list, budget: _Budget) -> Callable:
    """Newton-Euler in Euler parameters: y = (p (4), omega_body (3)).

    ``p_dot = 1/2 G_bar^T omega_body`` (Eq. 8.54) and Euler's equations
    ``J omega_body_dot = M_body - omega_body x J omega_body`` with
    ``J = diag(I, I, I3)``; gravity torque ``mgl Z1 x e3``; generalized
    torques mapped to a torque vector ``M`` with ``G^T M = (M_phi, M_theta,
    M_psi)``, ``G = [Z1, X2, e3]``.
    """
    I, I3, mgl = params.I, params.I3, params.mgl
    J = np.array([I, I, I3])

    def rhs(t, y):
        budget.spend(t)
        p, w = y[:4], y[4:]
        e0, e1, e2, e3 = p
        s2 = 0.0
        # third row of A (Z1 in body coordinates)
        z1_b = np.array([2.0 * (e1 * e3 - e0 * e2), 2.0 * (e2 * e3 + e0 * e1), e0 * e0 - e1 * e1 - e2 * e2 + e3 * e3])
        m_body = mgl * np.array([z1_b[1], -z1_b[0], 0.0])  # z1_b x (0, 0, 1)
        if torque is not None:
            cth = z1_b[2]
            x2_b = np.array([z1_b[1], -z1_b[0], 0.0])
            s2 = x2_b[0] ** 2 + x2_b[1] ** 2
            if s2 > 0.0:
                phi, theta, psi = _zxz_from_quaternion(p[None, :], angle_ref[0], angle_ref[1])
                phid, thetad, psid = _rates_from_omega_body(theta[0], psi[0], w)
                state = np.array([phi[0], theta[0], psi[0], phid, thetad, psid])
                m_phi, m_theta, m_psi = torque(t, state)
                x2_b = x2_b / math.sqrt(s2)
                alpha = (m_phi - m_psi * cth) / s2
                gamma = (m_psi - m_phi * cth) / s2
                m_body = m_body + alpha * z1_b + m_theta * x2_b + gamma * np.array([0.0, 0.0, 1.0])
        Jw = J * w
        w_dot = (m_body - np.cross(w, Jw)) / J
        p_dot = 0.5 * np.array([
            -e1 * w[0] - e2 * w[1] - e3 * w[2],
            e0 * w[0] + e2 * w[2] - e3 * w[1],
            e0 * w[1] + e3 * w[0] - e1 * w[2],
            e0 * w[2] + e1 * w[1] - e2 * w[0],
        ])
        out = np.concatenate([p_dot, w_dot])
        if not math.isfinite(float(out @ out)):
            # unbounded torque vector next to a pole, or accelerations beyond float64
            raise _StopNumerical("pole" if 0.0 < s2 < 1e-12 else "non-finite", t)
        return out

    return rhs


def _raise_failed(sol, t_start: float, rhs: Callable, y_start: np.ndarray, params: RotorParams) -> None:
    """ValueError naming ``torques`` for a failed solve_ivp run of one segment.

    Reports the angular accelerations at the segment's start: when scipy
    cannot find a step (``Required step size is less than spacing between
    numbers``), they are what the steps cannot follow.
    """
    try:
        accel = float(np.max(np.abs(rhs(t_start, y_start)[-3:])))
    except _StopNumerical:
        accel = math.inf
    cause = ""
    if "spacing" in sol.message:
        cause = "; the applied torques are too large for this rotor, its motion changes faster than float64 time steps resolve"
    raise ValueError(
        f"torques: the numerical integration failed after t={t_start:.6g} s ({sol.message}); angular "
        f"accelerations {accel:.3g} rad/s^2 with I={params.I!r}, I3={params.I3!r}{cause}"
    )


def _omega_body_from_rates(theta, psi, phid, thetad, psid):
    """omega_body = G_bar (phi_dot, theta_dot, psi_dot) for ZXZ (Eq. 8.9)."""
    st, ct, sp, cp = math.sin(theta), math.cos(theta), math.sin(psi), math.cos(psi)
    return np.array([phid * st * sp + thetad * cp, phid * st * cp - thetad * sp, phid * ct + psid])


def _rates_from_omega_body(theta, psi, w):
    """Inverse of :func:`_omega_body_from_rates` (needs sin theta != 0)."""
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(psi), np.cos(psi)
    with np.errstate(divide="ignore", invalid="ignore"):
        phid = (w[..., 0] * sp + w[..., 1] * cp) / st
    thetad = w[..., 0] * cp - w[..., 1] * sp
    psid = w[..., 2] - phid * ct
    return phid, thetad, psid


def _numerical(params, s0, t, torque, rtol, atol, max_steps=MAX_STEPS):
    """DOP853 on Eq. 8.16, in Euler parameters while |sin theta| is small.

    At most ``max_steps`` right-hand-side evaluations; ValueError naming
    ``t`` beyond, and naming ``torques`` when the motion becomes non-finite.
    """
    try:
        return _numerical_run(params, s0, t, torque, rtol, atol, _Budget(max_steps))
    except _StopNumerical as stop:
        if stop.reason == "budget":
            raise ValueError(
                f"t: the numerical path (applied torques) used max_steps={max_steps} right-hand-side "
                f"evaluations and stopped at t={stop.t:.6g} s before t={float(t[-1]):.6g} s "
                f"(core.integrators.MAX_STEPS = {MAX_STEPS}); ask for a shorter time span, loosen rtol/atol "
                "or pass a larger max_steps"
            ) from None
        if stop.reason == "pole":
            raise ValueError(
                f"torques: the motion reached sin(theta) = 0 at t={stop.t:.6g} s, where constant generalized "
                "torques M_phi != +-M_psi need an unbounded torque on the rotor (massless gimbals in gimbal lock)"
            ) from None
        raise ValueError(
            f"torques: the motion became non-finite at t={stop.t:.6g} s: the applied torques are too large "
            f"for this rotor (I={params.I!r}, I3={params.I3!r}); the angle accelerations overflow float64"
        ) from None


def _numerical_run(params, s0, t, torque, rtol, atol, budget):
    n_t = t.shape[0]
    angles = np.empty((n_t, 3))
    rates = np.empty((n_t, 3))
    t_cur = 0.0
    y_angles = s0.copy()
    filled = 0
    # samples at t == 0
    while filled < n_t and t[filled] <= 0.0:
        angles[filled] = s0[:3]
        rates[filled] = s0[3:]
        filled += 1
    t_end = float(t[-1])
    in_params = abs(math.sin(s0[1])) < _SIN_ENTER_PARAMETERS
    y_par = None
    ref = [float(s0[0]), float(s0[2])]
    guard = 0
    while filled < n_t:
        guard += 1
        if guard > 100000:
            raise ValueError("torques: the motion crosses the Euler-angle singularity too often to follow")
        t_eval = t[filled:]
        if t_cur >= t_end:
            angles[filled:] = angles[filled - 1]
            rates[filled:] = rates[filled - 1]
            break
        if not in_params:
            def ev(tt, y):
                return abs(math.sin(y[1])) - _SIN_ENTER_PARAMETERS
            ev.terminal = True
            ev.direction = -1
            rhs = _rhs_angles(params, torque, budget)
            sol = solve_ivp(rhs, (t_cur, t_end), y_angles, method="DOP853",
                            rtol=rtol, atol=atol, t_eval=t_eval, events=ev)
            if sol.status < 0:
                _raise_failed(sol, t_cur, rhs, y_angles, params)
            # sol.t is a list, not an array, when an event comes before the first t_eval sample
            k = np.asarray(sol.t).shape[0]
            if k:
                angles[filled:filled + k] = sol.y[:3].T
                rates[filled:filled + k] = sol.y[3:].T
            filled += k
            if sol.status == 1:
                y_e = sol.y_events[0][0]
                t_cur = float(sol.t_events[0][0])
                p = _quaternion_from_zxz(y_e[0], y_e[1], y_e[2])
                w = _omega_body_from_rates(y_e[1], y_e[2], y_e[3], y_e[4], y_e[5])
                y_par = np.concatenate([p, w])
                ref = [float(y_e[0]), float(y_e[2])]
                in_params = True
            else:
                break
        else:
            if y_par is None:
                p = _quaternion_from_zxz(s0[0], s0[1], s0[2])
                w = _omega_body_from_rates(s0[1], s0[2], s0[3], s0[4], s0[5])
                y_par = np.concatenate([p, w])

            def ev(tt, y):
                e = y[:4] / np.linalg.norm(y[:4])
                sin_t = 2.0 * math.hypot(e[1], e[2]) * math.hypot(e[0], e[3])
                return sin_t - _SIN_LEAVE_PARAMETERS
            ev.terminal = True
            ev.direction = 1
            rhs = _rhs_parameters(params, torque, ref, budget)
            sol = solve_ivp(rhs, (t_cur, t_end), y_par, method="DOP853",
                            rtol=rtol, atol=atol, t_eval=t_eval, events=ev)
            if sol.status < 0:
                _raise_failed(sol, t_cur, rhs, y_par, params)
            k = np.asarray(sol.t).shape[0]
            if k:
                p = sol.y[:4].T
                phi, theta, psi = _zxz_from_quaternion(p, ref[0], ref[1])
                w = sol.y[4:].T
                phid, thetad, psid = _rates_from_omega_body(theta, psi, w)
                angles[filled:filled + k] = np.stack([phi, theta, psi], axis=-1)
                rates[filled:filled + k] = np.stack([phid, thetad, psid], axis=-1)
                ref = [float(phi[-1]), float(psi[-1])]
                filled += k
            if sol.status == 1:
                y_e = sol.y_events[0][0]
                t_cur = float(sol.t_events[0][0])
                phi, theta, psi = _zxz_from_quaternion(y_e[None, :4], ref[0], ref[1])
                phid, thetad, psid = _rates_from_omega_body(theta[0], psi[0], y_e[4:])
                y_angles = np.array([phi[0], theta[0], psi[0], phid, thetad, psid])
                in_params = False
            else:
                break
    if filled < n_t:
        raise ValueError(f"torques: integration stopped early at t={t[filled - 1] if filled else 0.0}")
    return angles, rates


def _check_numerical_work(params: RotorParams, s0: np.ndarray, t_end: float, torque: Callable, max_steps: int) -> None:
    """Refuse up front a numerical run that certainly needs more than ``max_steps`` evaluations.

    The angle through which the rotor turns by ``t_end`` is estimated as
    ``|omega0| t + (|M| + mgl) t^2 / (2 I_min)`` with ``|M|`` the largest
    generalized torque at t = 0 and ``I_min = min(I, I3)``. DOP853 at the
    default tolerances spends 15 to 100 right-hand-side evaluations per
    radian; a run whose estimate exceeds ``max_steps`` radians (one
    evaluation per radian) is refused before it starts. The count during
    the run (:func:`_numerical`) remains the limit for the rest.
    """
    omega0 = float(np.linalg.norm(rotor_vectors(params, s0).omega))
    m0 = float(np.max(np.abs(torque(0.0, s0))))
    spin_part = omega0 * t_end
    torque_part = (m0 + params.mgl) / min(params.I, params.I3) * 0.5 * t_end * t_end
    estimate = spin_part + torque_part
    if not estimate <= max_steps:
        # the torques are to blame when they, not the spin or gravity, dominate
        name = "torques" if m0 >= params.mgl and torque_part > spin_part else "t"
        raise ValueError(
            f"{name}: the numerical path (applied torques) would turn the rotor through about {estimate:.3g} rad "
            f"by t={t_end:.6g} s (|omega0| t + (|M| + mgl) t^2 / (2 min(I, I3)), |omega0| = {omega0:.3g} rad/s, "
            f"|M| = {m0:.3g} N m), which takes more than max_steps={max_steps} right-hand-side evaluations "
            f"(at least one per radian; core.integrators.MAX_STEPS = {MAX_STEPS}); ask for a shorter time span "
            "or smaller torques, or pass a larger max_steps"
        )


def _check_times(t: Any) -> np.ndarray:
    """Sample times: :func:`rigidlab.core._validation.output_times` (a new non-empty 1-D float array, finite,
    non-decreasing), and >= 0."""
    tt = output_times(t)
    if tt[0] < 0.0:
        raise ValueError(f"t: expected times >= 0 (s), got t[0] = {float(tt[0])!r}")
    return tt


def simulate(
    params: RotorParams,
    state0: Any,
    t: Any,
    torques: Any = None,
    *,
    rtol: float = 1e-11,
    atol: float = 1e-12,
    max_steps: int = MAX_STEPS,
    degrees: bool = False,
) -> GyroscopeTrajectory:
    """Motion of the rotor from ``state0`` at time 0, sampled at times ``t``.

    Chooses the cheapest accurate path:

    * no applied torque (``torques`` None or zero; gravity allowed): the
      exact solution -- ``u = cos theta`` from Jacobi's ``sn`` (Eq. 8.21),
      ``phi``, ``psi`` from incomplete elliptic integrals of the third kind
      with d1, d2 (Eqs. 8.19-8.20) conserved exactly; ``mgl = 0`` gives
      regular precession (``k = 0``). Accurate for any t (arguments reduced
      by whole nutation periods) and when theta passes near or through 0 or
      pi (the pole distances ``1 -+ u`` are carried without cancellation).
      This is ``top_motion(params, state0).at(t)``; a caller that samples
      one motion repeatedly should keep the :class:`TopMotion` and call
      :meth:`TopMotion.at` (the constants cost about a millisecond);
    * applied torques: scipy DOP853 on Eq. 8.16, switching to the
      Euler-parameter Newton-Euler form (``p``, ``omega_body``) while
      ``|sin theta| < 0.05`` (back above 0.1) and converting back to angles
      for output.

    Parameters
    ----------
    params : RotorParams
    state0 : (6,) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)`` at t = 0.
        A theta outside [0, pi] is first mapped to the same orientation with
        ``(phi + pi, -theta, psi + pi)``.
    t : (n,) sample times, non-decreasing, >= 0.
    torques : None, (3,) constant ``(M_phi, M_theta, M_psi)``, or a callable
        ``torques(t, state) -> (3,)`` of time and the (6,) state.
    rtol, atol : keyword-only, tolerances of the numerical path.
    max_steps : keyword-only, largest number of right-hand-side evaluations
        of the numerical path (default ``rigidlab.core.integrators.MAX_STEPS``, ten
        million); a run that needs more stops with a ValueError naming
        ``t`` instead of running for hours. The closed form costs O(n)
        whatever the time span.
    degrees : bool, keyword-only
        True: the angles of ``state0`` in degrees, its rates in deg/s (the result holds radians).

    Returns
    -------
    GyroscopeTrajectory
        ``t`` (n,), ``angles`` (n, 3), ``rates`` (n, 3), ``method``.

    Raises
    ------
    ValueError
        For a bad state, times or torques (including complex input), a
        failed numerical run, torques so large that the motion becomes
        non-finite, or a numerical run that would need more than
        ``max_steps`` right-hand-side evaluations.
    """
    state0 = radians(state0, "state0", degrees)
    params = _check_params(params)
    s0 = _check_state(state0, "state0")
    if s0.shape != (6,):
        raise ValueError(f"state0: expected shape (6,), got {s0.shape}")
    tt = _check_times(t)
    for name, value in (("rtol", rtol), ("atol", atol)):
        if isinstance(value, (complex, np.complexfloating)):
            raise ValueError(f"{name}: expected real numbers, got complex {value!r}")
    if not (rtol > 0 and atol > 0):
        raise ValueError(f"rtol, atol: expected > 0, got rtol={rtol!r}, atol={atol!r}")
    max_steps = positive_integer(max_steps, "max_steps")
    torque = _torque_function(torques)
    if torque is None:
        return top_motion(params, s0).at(tt)
    s0 = _normalize_state(s0)
    _check_numerical_work(params, s0, float(tt[-1]), torque, max_steps)
    angles, rates = _numerical(params, s0, tt, torque, rtol, atol, max_steps)
    if not (np.all(np.isfinite(angles)) and np.all(np.isfinite(rates))):
        raise ValueError(
            "torques: the motion reached sin(theta) = 0, where constant generalized torques "
            "M_phi != +-M_psi need an unbounded torque on the rotor (massless gimbals in gimbal lock)"
        )
    _check_motion_angles(tt, angles)
    for a in (tt, angles, rates):
        a.setflags(write=False)
    return GyroscopeTrajectory(t=tt, angles=angles, rates=rates, method="numerical")


# ------------------------------------------------------ sampling one motion
@dataclass(frozen=True)
class RotorSetup:
    """One motion to sample: a rotor, its state at t = 0 and constant applied torques.

    Hashable (the scenes key their caches by it) and checked once, here.

    Parameters
    ----------
    params : RotorParams
    state0 : (6,) ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)`` at t = 0
        (rad, rad/s), stored as a tuple of floats.
    torques : (3,) constant generalized torques ``(M_phi, M_theta, M_psi)``
        (N m) of Eq. 8.16, stored as a tuple of floats.
    degrees : bool, keyword-only
        True: ``state0`` in degrees and deg/s (stored in radians).

    Raises
    ------
    ValueError
        Naming ``params``, ``state0`` or ``torques`` for a value
        :func:`simulate` would refuse.
    """

    params: RotorParams
    state0: tuple[float, ...]  # (6,)
    torques: tuple[float, ...] = (0.0, 0.0, 0.0)  # (3,)
    _: KW_ONLY
    degrees: InitVar[bool] = False

    def __post_init__(self, degrees: bool) -> None:
        _check_params(self.params)
        s0 = _check_state(radians(self.state0, "state0", degrees), "state0")
        if s0.shape != (6,):
            raise ValueError(f"state0: expected shape (6,), got {s0.shape}")
        m = _check_array(self.torques, "torques")
        if m.shape != (3,):
            raise ValueError(f"torques: expected shape (3,) = (M_phi, M_theta, M_psi), got {m.shape}")
        object.__setattr__(self, "state0", tuple(float(x) for x in s0))
        object.__setattr__(self, "torques", tuple(float(x) for x in m))

    @property
    def has_torque(self) -> bool:
        """Whether an applied torque acts (then the motion is integrated, not the closed form)."""
        return any(m != 0.0 for m in self.torques)


@dataclass(frozen=True)
class MotionSummary:
    """What one motion's constants predict (:func:`motion_summary`).

    Attributes
    ----------
    motion : the closed form's constants (:class:`TopMotion`), None when torques act.
    prediction : nutation bounds, period and mean rates (Eq. 8.21), None when torques act
        or the nutation cannot be predicted.
    invariants0 : (3,) ``d1, d2, E`` at t = 0 (Eqs. 8.14, 8.19-8.20).
    spin : ``omega3 = psi_dot + phi_dot cos theta`` at t = 0 (rad/s).
    critical_spin : the sleeping top's critical spin ``2 sqrt(mgl I) / I3`` (rad/s).
    """

    motion: TopMotion | None
    prediction: NutationResult | None
    invariants0: np.ndarray = field(repr=False)  # (3,)
    spin: float
    critical_spin: float

    @property
    def period(self) -> float:
        """The predicted nutation period (s): ``inf`` when theta stays put, NaN when not predicted."""
        return float(self.prediction.period) if self.prediction is not None else math.nan

    def describe(self) -> tuple[tuple[str, str], ...]:
        """The motion in words: ``(topic, text)`` pairs (spin; nutation, Eq. 8.21), numbers to 3 digits."""
        spin = (f"ω3 = dψ/dt + dφ/dt cos θ = {_digits(self.spin)} rad/s; "
                f"sleeping top critical spin {_digits(self.critical_spin)} rad/s")
        nu = self.prediction
        if nu is None:
            return ("Spin", spin), ("Nutation", "applied torques act, no closed-form prediction (DOP853 on Eq. 8.16).")
        lo, hi = math.degrees(float(nu.theta_min)), math.degrees(float(nu.theta_max))
        rate = _digits(float(nu.mean_precession_rate))
        if math.isinf(self.period):
            return ("Spin", spin), ("Nutation", f"(Eq. 8.21): none, θ stays at {lo:.2f}°; dφ/dt = {rate} rad/s")
        return ("Spin", spin), ("Nutation", f"(Eq. 8.21): θ from {lo:.2f}° to {hi:.2f}°, period "
                                            f"{_digits(self.period)} s; mean dφ/dt {rate} rad/s")


def _digits(x: float, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits, plain notation between 1e-3 and 1e5."""
    if x == 0.0 or not math.isfinite(x):
        return f"{x:g}"
    if 1e-3 <= abs(x) < 1e5:
        return f"{x:.{max(0, digits - 1 - math.floor(math.log10(abs(x))))}f}"
    return f"{x:.{digits - 1}e}"


@functools.lru_cache(maxsize=32)
def motion_summary(setup: RotorSetup) -> MotionSummary:
    """The constants of ``setup``'s motion, computed once per setup (cached; about a millisecond).

    Without applied torques: :func:`top_motion` (the closed form's constants,
    Eqs. 8.19-8.21) and :func:`nutation` (bounds, period, mean precession);
    always the invariants at t = 0 (:func:`invariants`), the spin and
    :func:`sleeping_top_critical_spin`.

    Parameters
    ----------
    setup : RotorSetup

    Returns
    -------
    MotionSummary
    """
    if not isinstance(setup, RotorSetup):
        raise ValueError(f"setup: expected a RotorSetup, got {type(setup).__name__}")
    p, s0 = setup.params, np.array(setup.state0)
    motion = prediction = None
    if not setup.has_torque:
        motion = top_motion(p, s0)
        try:
            prediction = nutation(p, s0)
        except ValueError:
            prediction = None
    inv = invariants(p, s0)
    invariants0 = np.array([float(inv.d1), float(inv.d2), float(inv.energy)])
    invariants0.setflags(write=False)
    spin = float(s0[5] + s0[3] * math.cos(s0[1]))
    return MotionSummary(motion, prediction, invariants0, spin, sleeping_top_critical_spin(p))


@dataclass(frozen=True)
class MotionSamples:
    """One stretch of a motion with what a view of it draws (read-only arrays; global frame).

    Attributes
    ----------
    t : (n,) sample times (s).
    angles : (n, 3) ZXZ angles ``(phi, theta, psi)`` (rad).
    rates : (n, 3) ``(phi_dot, theta_dot, psi_dot)`` (rad/s).
    vectors : :class:`RotorVectors` at the samples, each (n, 3): rotor axis, omega (Eq. 8.8), L, torque.
    invariants : (n, 3) ``d1, d2, E`` (Eqs. 8.14, 8.19-8.20).
    method : ``"closed_form"``, ``"steady"`` or ``"numerical"`` (as :class:`GyroscopeTrajectory`).
    """

    t: np.ndarray  # (n,)
    angles: np.ndarray  # (n, 3)
    rates: np.ndarray  # (n, 3)
    vectors: RotorVectors  # each (n, 3)
    invariants: np.ndarray  # (n, 3)
    method: str

    @property
    def final_state(self) -> np.ndarray:
        """(6,) the state at ``t[-1]``: ``start`` of the next stretch (:func:`sample_motion`)."""
        return np.concatenate([self.angles[-1], self.rates[-1]])


def sample_motion(setup: RotorSetup, t: Any, *, start: Any = None, rtol: float = 1e-9,
                  atol: float = 1e-10) -> MotionSamples:
    """``setup``'s motion at the times ``t``, with its vectors and invariants.

    Without applied torques the closed form (Eq. 8.21) at the absolute times
    ``t`` (the constants of :func:`motion_summary`, computed once per setup;
    ``start`` is not needed). With torques DOP853 on Eq. 8.16 from ``start``,
    the state at ``t[0]`` (the previous stretch's ``final_state``; None: the
    setup's ``state0``, then ``t[0]`` must be 0). The default tolerances are
    a view's (the drawn and plotted accuracy); :func:`simulate` has tighter ones.

    Parameters
    ----------
    setup : RotorSetup
    t : (n,) sample times (s), increasing, >= 0.
    start : (6,) state at ``t[0]``, or None.
    rtol, atol : keyword-only, tolerances of the numerical path.

    Returns
    -------
    MotionSamples

    Raises
    ------
    ValueError
        For bad times or start (naming them), a failed numerical run (as
        :func:`simulate`), or a motion that leaves the finite range (naming
        what left it and near which time).
    """
    summary = motion_summary(setup)
    tt = _check_times(t)
    if summary.motion is not None:
        traj = summary.motion.at(tt)
    else:
        if start is None and float(tt[0]) != 0.0:
            raise ValueError(f"start: expected the state at t[0] = {float(tt[0])!r} s of a torque-driven motion, "
                             "got None (only a stretch from t = 0 starts from state0)")
        s0 = np.array(setup.state0) if start is None else _check_state(start, "start")
        traj = simulate(setup.params, s0, tt - tt[0], torques=setup.torques, rtol=rtol, atol=atol)
    states = np.concatenate([traj.angles, traj.rates], axis=1)
    vectors = rotor_vectors(setup.params, states, setup.torques)
    inv = invariants(setup.params, states)
    columns = np.stack([inv.d1, inv.d2, inv.energy], axis=1)
    for name, a in (("angles", traj.angles), ("rates", traj.rates), ("invariants", columns),
                    ("vectors", np.stack([vectors.omega, vectors.angular_momentum, vectors.torque]))):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the motion left the finite range near t = {float(tt[0]):.3g} s")
    for a in (columns, vectors.rotor_axis, vectors.omega, vectors.angular_momentum, vectors.torque):
        a.setflags(write=False)
    return MotionSamples(tt, traj.angles, traj.rates, vectors, columns, traj.method)
