"""Models for mode shapes and stability: a rod on a spherical joint, a disk rotor on a flexible
shaft, the heavy top in steady precession or sleeping, a damped two-mass oscillator.

Each builder returns an assembled System in an equilibrium or a steady
motion, ready for :func:`rigidlab.core.modal.linearize` (a steady precession needs
``frame_omega=model.frame_omega``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigidlab.core._validation import float_array, radians, real_number
from rigidlab.core.gyroscope import RotorParams, steady_precession_rates
from rigidlab.core.multibody import Body, Joint, SpringDamper, System

from ._pendulum import ROD_RADIUS_RATIO
from ._top import heavy_top

__all__ = [
    "DiskRotor",
    "SphericalPendulum",
    "SteadyTop",
    "TwoMassOscillator",
    "disk_rotor",
    "spherical_pendulum",
    "steady_top",
    "two_mass_oscillator",
]


def _positive(x: Any, name: str, unit: str, *, allow_zero: bool = False) -> float:
    bound = ">= 0" if allow_zero else "> 0"
    v = real_number(x, name, expected=f"a finite number {bound} ({unit})")
    if v < 0 or (v == 0 and not allow_zero):
        raise ValueError(f"{name}: expected a finite number {bound} ({unit}), got {v!r}")
    return v


# ------------------------------------------------------------------ spherical pendulum
@dataclass(frozen=True)
class SphericalPendulum:
    """A uniform rod hanging from a spherical joint at the origin, at rest.

    Attributes
    ----------
    system : System
    rod : Body
        Slender rod along its body z axis (transverse moments ``m L^2 / 12``,
        axial ``m r^2 / 2``, ``r = ROD_RADIUS_RATIO L``), centre of mass at
        ``(0, 0, -L / 2)``.
    joint : Joint
        Spherical joint between the ground and the rod's upper end.
    length : float
        L (m).
    """

    system: System
    rod: Body
    joint: Joint
    length: float


def spherical_pendulum(length: float = 1.0, mass: float = 1.0, *, gravity: float = 9.81) -> SphericalPendulum:
    """A rod on a spherical joint, hanging at rest (two swinging modes and a free spin about its axis).

    Linearized: two swinging modes with ``omega^2 = 3 g / (2 L)`` (a
    uniform rod about its end) and a rigid-body spin about the rod's axis.

    Parameters
    ----------
    length : float
        L (m), > 0.
    mass : float
        m (kg), > 0.
    gravity : float, keyword-only
        g (m/s^2) along -z, >= 0.

    Returns
    -------
    SphericalPendulum
    """
    L = _positive(length, "length", "m")
    m = _positive(mass, "mass", "kg")
    g = _positive(gravity, "gravity", "m/s^2", allow_zero=True)
    r = ROD_RADIUS_RATIO * L
    system = System(gravity=(0.0, 0.0, -g))
    rod = system.add_body("rod", mass=m, inertia=(m * L * L / 12.0, m * L * L / 12.0, 0.5 * m * r * r),
                          position=(0.0, 0.0, -0.5 * L))
    joint = system.add_joint("spherical", system.ground, rod, point=(0.0, 0.0, 0.0), name="pivot")
    system.assemble()
    return SphericalPendulum(system, rod, joint, L)


# ------------------------------------------------------------------ disk rotor
@dataclass(frozen=True)
class DiskRotor:
    """A thin disk on a flexible shaft spinning about the global x axis (see :func:`disk_rotor`).

    Attributes
    ----------
    system : System
    disk : Body
        Body x axis is the shaft (spin) axis.
    bearings : tuple of two SpringDamper
        Zero-length spring-dampers joining the shaft points at ``x = -a`` and
        ``x = +a`` of the disk to the ground: the shaft's elasticity.
    speed : float
        Spin Omega (rad/s) about +x.
    polar_moment, transverse_moment : float
        ``I_p = m r^2 / 2`` and ``I_t = m r^2 / 4`` (kg m^2).
    tilt_stiffness : float
        ``k_t = 2 k a^2`` (N m/rad).
    translational_stiffness : float
        ``2 k`` (N/m), the same in every direction.
    """

    system: System
    disk: Body
    bearings: tuple[SpringDamper, SpringDamper]
    speed: float
    polar_moment: float
    transverse_moment: float
    tilt_stiffness: float
    translational_stiffness: float


def disk_rotor(speed: float = 0.0, *, mass: float = 1.0, radius: float = 0.15, half_span: float = 0.25,
               stiffness: float = 2.0e4, damping: float = 0.0, gravity: float = 9.81) -> DiskRotor:
    r"""A thin disk on a flexible shaft, spinning at a set speed: forward and backward whirl.

    The shaft is modelled by two zero-length spring-dampers (stiffness ``k``,
    damping ``c``) joining the points of the spin axis at ``x = +-a`` to the
    ground, so the disk has translational stiffness ``2 k`` in every
    direction and tilt stiffness ``k_t = 2 k a^2``; it hangs at its static
    sag ``m g / (2 k)`` and spins freely about +x. The tilt modes whirl at
    (undamped)

    .. math:: \omega_{f,b} = \frac{\pm I_p \Omega + \sqrt{I_p^2 \Omega^2 + 4 I_t k_t}}{2 I_t}

    (forward +, backward -), the translations at ``sqrt(2 k / m)`` and the
    spin is a rigid-body mode.

    Parameters
    ----------
    speed : float
        Omega (rad/s), any sign.
    mass, radius : float, keyword-only
        m (kg) and r (m) of the disk, > 0.
    half_span : float, keyword-only
        a (m), > 0.
    stiffness, damping : float, keyword-only
        k (N/m, > 0) and c (N s/m, >= 0) of each spring-damper.
    gravity : float, keyword-only
        g (m/s^2) along -z, >= 0.

    Returns
    -------
    DiskRotor
    """
    W = real_number(speed, "speed", expected="a finite spin speed (rad/s)")
    m = _positive(mass, "mass", "kg")
    r = _positive(radius, "radius", "m")
    a = _positive(half_span, "half_span", "m")
    k = _positive(stiffness, "stiffness", "N/m")
    c = _positive(damping, "damping", "N s/m", allow_zero=True)
    g = _positive(gravity, "gravity", "m/s^2", allow_zero=True)
    Ip, It = 0.5 * m * r * r, 0.25 * m * r * r
    sag = m * g / (2.0 * k)
    system = System(gravity=(0.0, 0.0, -g))
    disk = system.add_body("disk", mass=m, inertia=(Ip, It, It), position=(0.0, 0.0, -sag),
                           omega_body=(W, 0.0, 0.0))
    bearings = tuple(
        system.add_spring_damper(system.ground, (x, 0.0, 0.0), disk, (x, 0.0, -sag), stiffness=k, damping=c,
                                 free_length=0.0, name=name)
        for x, name in ((-a, "bearing_left"), (a, "bearing_right"))
    )
    system.assemble()
    return DiskRotor(system, disk, bearings, W, Ip, It, 2.0 * k * a * a, 2.0 * k)


# ------------------------------------------------------------------ steady top
@dataclass(frozen=True)
class SteadyTop:
    """The heavy top in steady precession (or sleeping), see :func:`steady_top`.

    Attributes
    ----------
    system : System
    body : Body
    joint : Joint
    params : RotorParams
    length : float
        l (m) from O to the centre of mass.
    theta : float
        Nutation angle (rad).
    spin : float
        ``omega3 = psi_dot + phi_dot cos theta`` (rad/s).
    phi_dot, psi_dot : float
        Precession and spin rates (rad/s).
    frame_omega : (3,) ndarray
        ``(0, 0, phi_dot)``: pass it to :func:`rigidlab.core.modal.linearize`.
    """

    system: System
    body: Body
    joint: Joint
    params: RotorParams
    length: float
    theta: float
    spin: float
    phi_dot: float
    psi_dot: float
    frame_omega: np.ndarray


def steady_top(params: RotorParams, *, spin: float, theta: float = 0.0, precession: str = "slow",
               mass: float = 1.0, gravity: float = 9.81,
               degrees: bool = False) -> SteadyTop:
    """The heavy top of :func:`rigidlab.core.models.heavy_top` in steady precession, or sleeping at ``theta = 0``.

    At ``theta = 0`` the top spins upright at ``spin`` (stable above
    :func:`rigidlab.core.gyroscope.sleeping_top_critical_spin`); otherwise it
    precesses at the slow or fast rate of
    :func:`rigidlab.core.gyroscope.steady_precession_rates` (Eq. 8.23), a motion that
    is steady seen from the frame turning with the precession,
    ``frame_omega = (0, 0, phi_dot)``.

    Parameters
    ----------
    params : RotorParams
    spin : float, keyword-only
        ``omega3`` (rad/s).
    theta : float, keyword-only
        Nutation angle (rad) in ``[0, pi)``.
    precession : str, keyword-only
        ``"slow"`` or ``"fast"`` (ignored at ``theta = 0``).
    mass, gravity : float, keyword-only
        As :func:`rigidlab.core.models.heavy_top`.
    degrees : bool, keyword-only
        True: ``theta`` in degrees and ``spin`` in deg/s.

    Returns
    -------
    SteadyTop

    Raises
    ------
    ValueError
        For bad arguments, or where no steady precession exists.
    """
    theta = radians(theta, "theta", degrees)
    spin = radians(spin, "spin", degrees)
    w3 = real_number(spin, "spin", expected="a finite spin omega3 (rad/s)")
    th = real_number(theta, "theta", expected="a nutation angle in [0, pi) (rad)")
    if not 0.0 <= th < math.pi:
        raise ValueError(f"theta: expected a nutation angle in [0, pi) (rad), got {th!r}")
    if precession not in ("slow", "fast"):
        raise ValueError(f"precession: expected 'slow' or 'fast', got {precession!r}")
    if th == 0.0:
        phi_dot, psi_dot = 0.0, w3
    else:
        rates = steady_precession_rates(params, th, w3)
        phi_dot = float(rates.slow if precession == "slow" else rates.fast)
        if not math.isfinite(phi_dot):
            raise ValueError(f"precession: no {precession} steady precession at theta={th!r}")
        psi_dot = w3 - phi_dot * math.cos(th)
    top = heavy_top(params, (0.0, th, 0.0, phi_dot, 0.0, psi_dot), mass=mass, gravity=gravity)
    W = np.array([0.0, 0.0, phi_dot])
    W.setflags(write=False)
    return SteadyTop(top.system, top.body, top.joint, top.params, top.length, th, w3, phi_dot, psi_dot, W)


# ------------------------------------------------------------------ two masses
@dataclass(frozen=True)
class TwoMassOscillator:
    """Two blocks sliding along x, a damped two-degree-of-freedom system (see :func:`two_mass_oscillator`).

    Attributes
    ----------
    system : System
    blocks : tuple of two Body
    guides : tuple of two Joint
        Prismatic joints (ground, block) along x.
    springs : tuple of two SpringDamper
        Ground-block 1 and block 1-block 2.
    masses, stiffness, damping : (2,) ndarray
        ``(m1, m2)`` kg, ``(k1, k2)`` N/m, ``(c1, c2)`` N s/m.
    """

    system: System
    blocks: tuple[Body, Body]
    guides: tuple[Joint, Joint]
    springs: tuple[SpringDamper, SpringDamper]
    masses: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray


def two_mass_oscillator(*, masses: Any = (1.0, 1.0), stiffness: Any = (2000.0, 1000.0),
                        damping: Any = (4.0, 0.5), gravity: float = 9.81) -> TwoMassOscillator:
    """Two blocks on prismatic guides along x, ground-spring-block-spring-block, at rest.

    ``M = diag(m1, m2)``, ``K = [[k1 + k2, -k2], [-k2, k2]]``, ``C =
    [[c1 + c2, -c2], [-c2, c2]]``. The default damping is not proportional
    (``C`` is no combination of ``M`` and ``K``), so its modes are complex.

    Parameters
    ----------
    masses : (2,) keyword-only
        kg, > 0.
    stiffness : (2,) keyword-only
        ``(k1, k2)`` N/m, > 0.
    damping : (2,) keyword-only
        ``(c1, c2)`` N s/m, >= 0.
    gravity : float, keyword-only
        g (m/s^2) along -z, carried by the guides.

    Returns
    -------
    TwoMassOscillator
    """
    arrays = []
    for name, value, unit, zero in (("masses", masses, "kg", False), ("stiffness", stiffness, "N/m", False),
                                    ("damping", damping, "N s/m", True)):
        a = float_array(value, name, expected=f"two numbers ({unit})", copy=True)
        if a.shape != (2,) or not np.all(np.isfinite(a)) or np.any(a < 0) or (not zero and np.any(a == 0)):
            bound = ">= 0" if zero else "> 0"
            raise ValueError(f"{name}: expected two finite numbers {bound} ({unit}), got {value!r}")
        a.setflags(write=False)
        arrays.append(a)
    m, k, c = arrays
    g = _positive(gravity, "gravity", "m/s^2", allow_zero=True)
    side = 0.1
    system = System(gravity=(0.0, 0.0, -g))
    x = (0.5, 1.0)
    blocks = tuple(
        system.add_body(f"block{i + 1}", mass=m[i], inertia=(m[i] * side**2 / 6.0,) * 3, position=(x[i], 0.0, 0.0))
        for i in range(2)
    )
    guides = tuple(
        system.add_joint("prismatic", system.ground, blocks[i], point=(x[i], 0.0, 0.0), axis=(1.0, 0.0, 0.0),
                         name=f"guide{i + 1}")
        for i in range(2)
    )
    springs = (
        system.add_spring_damper(system.ground, (0.0, 0.0, 0.0), blocks[0], (x[0], 0.0, 0.0), stiffness=k[0],
                                 damping=c[0], name="spring1"),
        system.add_spring_damper(blocks[0], (x[0], 0.0, 0.0), blocks[1], (x[1], 0.0, 0.0), stiffness=k[1],
                                 damping=c[1], name="spring2"),
    )
    system.assemble()
    return TwoMassOscillator(system, blocks, guides, springs, m, k, c)
