"""A thin uniform disk on the ground: rolling without slip or sliding without friction.

Conventions: global +z is up and the ground is the plane z = 0. The disk's
symmetry axis is its body y axis; at the identity orientation the disk
stands upright in the global x-z plane and a positive spin about +y rolls
it along global +x. Its attitude is described by the intrinsic ``"ZXY"``
Euler angles ``(psi, theta, phi)``: heading ``psi`` about +z, lean
``theta`` about the rolling direction ``f1 = (cos psi, sin psi, 0)``
(positive lean tips the top of the disk towards ``-f2``, the symmetry axis
``f2`` rising), spin angle ``phi`` about the symmetry axis, so
``A = Rz(psi) Rx(theta) Ry(phi)``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import KW_ONLY, InitVar, dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from rigidlab.core._validation import check_degrees, default_angle, float_array, output_times, radians, real_number, short_repr
from rigidlab.core.rotations import (
    GimbalLockWarning,
    euler_angle_rates_from_omega,
    euler_angles_from_euler_parameters,
    euler_parameters_from_euler_angles,
    rotate_vector,
)

__all__ = [
    "FLAT_LEAN",
    "RollingDisk",
    "RollingDiskMotion",
    "RollingDiskRun",
    "rolling_disk",
    "rolling_disk_critical_spin",
    "rolling_disk_reference",
    "rolling_disk_run",
]

#: Lean (rad) at which :func:`rolling_disk_reference` stops: the disk has
#: fallen (the heading equation is singular at pi / 2, the disk flat).
FLAT_LEAN = 1.5


def _positive(x: Any, name: str, unit: str) -> float:
    v = real_number(x, name, expected=f"a finite number > 0 ({unit})")
    if not v > 0:
        raise ValueError(f"{name}: expected a finite number > 0 ({unit}), got {v!r}")
    return v


def _disk_arguments(radius: Any, mass: Any, lean: Any, spin: Any, rolling: Any, heading_rate: Any, gravity: Any):
    R = _positive(radius, "radius", "m")
    m = _positive(mass, "mass", "kg")
    lean = real_number(lean, "lean", expected="a finite lean angle (rad)")
    if not abs(lean) < FLAT_LEAN:
        raise ValueError(f"lean: expected |lean| < {FLAT_LEAN} rad (the disk standing on its rim), got {lean!r}")
    spin = real_number(spin, "spin", expected="a finite spin rate (rad/s)")
    if not isinstance(rolling, (bool, np.bool_)):
        raise ValueError(f"rolling: expected True (rolling without slip) or False (frictionless sliding), got {rolling!r}")
    heading_rate = real_number(heading_rate, "heading_rate", expected="a finite heading rate (rad/s)")
    g = real_number(gravity, "gravity", expected="a finite g >= 0 (m/s^2)")
    if g < 0:
        raise ValueError(f"gravity: expected a finite g >= 0 (m/s^2), got {g!r}")
    return R, m, lean, spin, bool(rolling), heading_rate, g


def _initial_state(R: float, lean: float, spin: float, heading_rate: float, lean_rate: float):
    """Centre, Euler parameters, centre velocity and omega (global) at heading 0 with the contact point at the origin."""
    s, c = math.sin(lean), math.cos(lean)
    f1 = np.array([1.0, 0.0, 0.0])
    f2 = np.array([0.0, c, s])
    f3 = np.array([0.0, -s, c])
    centre = R * f3
    velocity = R * spin * f1 - R * lean_rate * f2
    omega = lean_rate * f1 + spin * f2 + heading_rate * c * f3
    p = euler_parameters_from_euler_angles(np.array([0.0, lean, 0.0]), "ZXY")
    return centre, p, velocity, omega


def rolling_disk(
    radius: float = 0.1,
    mass: float = 1.0,
    lean: float = 0.0,
    spin: float = default_angle(20.0),
    rolling: bool = True,
    *,
    heading_rate: float = 0.0,
    lean_rate: float = 0.0,
    gravity: float = 9.81,
    degrees: bool = False,
):
    """A thin uniform disk standing on the ground, as a System with one contact, assembled.

    The disk (mass ``m``, moments ``m R^2 / 4`` about its diameters, body
    x and z, and ``m R^2 / 2`` about its symmetry axis, body y) touches the
    ground's plane (:class:`~rigidlab.core.contact.Plane`, the ground's ``z = 0``,
    normal +z) with its rim (:class:`~rigidlab.core.contact.Torus` of major radius
    ``R`` and minor radius 0, axis = body y), through
    ``system.add_contact(system.ground, Plane(), disk, Torus(R, 0),
    rolling=rolling)`` in the constraint model: the normal force is the
    contact's multiplier (Eq. 8.107). With ``rolling=True`` the contact
    point does not slip (nonholonomic velocity constraints); with
    ``rolling=False`` the rim slides without friction.

    Initial state (module conventions): heading 0, lean ``lean`` about +x
    (a positive lean lifts the symmetry axis towards +z and tips the top
    of the disk towards -y), spin angle 0, contact point at the origin;
    angular velocity ``lean_rate f1 + spin f2 + heading_rate cos(lean)
    f3`` and the centre's velocity of rolling without slip ``R spin f1 -
    R lean_rate f2`` (also when sliding). The identity orientation is the
    upright disk; a positive ``spin`` rolls it along +x.

    Parameters
    ----------
    radius, mass : float
        R (m) and m (kg), > 0.
    lean : float
        Initial lean (rad), ``abs(lean) < FLAT_LEAN``.
    spin : float
        Angular velocity about the symmetry axis (rad/s).
    rolling : bool
        True: rolling without slip; False: frictionless sliding.
    heading_rate, lean_rate : float, keyword-only
        Initial heading rate about +z and lean rate (rad/s).
    gravity : float, keyword-only
        g (m/s^2) along -z, >= 0.
    degrees : bool, keyword-only
        True: ``lean`` in degrees; ``spin``, ``heading_rate``, ``lean_rate`` in deg/s.

    Returns
    -------
    (System, Body, Contact)
        The system, the disk and the contact (``traj.contact(contact)``
        gives the normal force, the contact point and its track).

    See Also
    --------
    rolling_disk_reference : the same disk from its reduced equations.
    rolling_disk_critical_spin : the spin above which upright rolling is stable.
    """
    lean = radians(lean, "lean", degrees)
    spin = radians(spin, "spin", degrees)
    heading_rate = radians(heading_rate, "heading_rate", degrees)
    lean_rate = radians(lean_rate, "lean_rate", degrees)
    from rigidlab.core.contact import Plane, Torus
    from rigidlab.core.multibody import System

    R, m, lean, spin, rolling, heading_rate, g = _disk_arguments(radius, mass, lean, spin, rolling, heading_rate,
                                                                 gravity)
    lean_rate = real_number(lean_rate, "lean_rate", expected="a finite lean rate (rad/s)")
    centre, p, velocity, omega = _initial_state(R, lean, spin, heading_rate, lean_rate)
    system = System(gravity=(0.0, 0.0, -g))
    disk = system.add_body("disk", mass=m, inertia=(0.25 * m * R * R, 0.5 * m * R * R, 0.25 * m * R * R),
                           position=centre, orientation=p, velocity=velocity, omega=omega)
    contact = system.add_contact(system.ground, Plane(), disk, Torus(R, 0.0), rolling=rolling, name="rim")
    system.assemble()
    return system, disk, contact


def rolling_disk_critical_spin(radius: float = 0.1, *, rolling: bool = True, gravity: float = 9.81) -> float:
    """Spin (rad/s) above which the upright disk is stable: ``sqrt(g / (3 R))`` rolling, ``sqrt(g / R)`` sliding.

    Linearizing the reduced equations (see :func:`rolling_disk_reference`)
    about upright motion (``theta = 0``, ``psi_dot = 0``, spin ``Omega``)
    gives, with ``A = m R^2 / 4`` and ``C = m R^2 / 2`` the thin disk's
    moments about a diameter and the axis:

    * rolling: ``A psi_ddot = -C Omega theta_dot`` and ``(A + m R^2)
      theta_ddot = (C + m R^2) Omega psi_dot + m g R theta``, so
      ``theta_ddot = [m g R - C (C + m R^2) Omega^2 / A] theta / (A + m
      R^2)``: stable (a wobble of angular frequency ``sqrt((4 / 5) (3
      Omega^2 - g / R))``) when ``Omega^2 > m g R A / (C (C + m R^2)) = g /
      (3 R)``, i.e. when the rolling speed ``v = Omega R`` has ``v^2 > g R /
      3`` (Routh's classic result for the rolling disk; see e.g. O. M.
      O'Reilly, "The dynamics of rolling disks and sliding disks",
      Nonlinear Dynamics 10, 1996);
    * frictionless sliding: ``A theta_ddot = C Omega psi_dot + m g R
      theta``, ``A psi_ddot = -C Omega theta_dot``: stable when ``Omega^2 >
      m g R A / C^2 = g / R``.

    At the critical spin itself the linearization has a double zero
    eigenvalue (neutral, not asymptotically stable).

    Parameters
    ----------
    radius : float
        R (m), > 0.
    rolling : bool, keyword-only
        True: rolling without slip; False: sliding without friction.
    gravity : float, keyword-only
        g (m/s^2), >= 0.

    Returns
    -------
    float
        Omega_critical (rad/s); independent of the mass.
    """
    R, _, _, _, rolling, _, g = _disk_arguments(radius, 1.0, 0.0, 0.0, rolling, 0.0, gravity)
    return math.sqrt(g / (3.0 * R)) if rolling else math.sqrt(g / R)


@dataclass(frozen=True)
class RollingDiskMotion:
    """Motion of the thin disk from its reduced equations (see :func:`rolling_disk_reference`).

    Attributes
    ----------
    t : (n,) ndarray
        Times (s).
    lean, heading, spin_angle : (n,) ndarray
        ``theta``, ``psi``, ``phi`` (rad), the ``"ZXY"`` angles of the
        module conventions.
    lean_rate, heading_rate : (n,) ndarray
        ``theta_dot``, ``psi_dot`` (rad/s).
    spin : (n,) ndarray
        ``omega_2 = psi_dot sin theta + phi_dot`` (rad/s): the angular
        velocity component along the symmetry axis (body y).
    orientation : (n, 4) ndarray
        Euler parameters (theta0, theta1, theta2, theta3), scalar first,
        of ``A = Rz(psi) Rx(theta) Ry(phi)``.
    centre : (n, 3) ndarray
        Centre of mass, global (m).
    velocity : (n, 3) ndarray
        Velocity of the centre, global (m/s).
    omega : (n, 3) ndarray
        Angular velocity, global (rad/s).
    contact_point : (n, 3) ndarray
        Lowest point of the rim, global (m); on the ground (z = 0).
    normal_force : (n,) ndarray
        Vertical (normal) component of the ground's force on the disk,
        ``m (g + z_ddot)`` (N); the equations assume it stays > 0.
    energy : (n,) ndarray
        Kinetic plus gravitational energy (J), gravity's zero at z = 0.
    """

    t: np.ndarray  # (n,)
    lean: np.ndarray  # (n,)
    heading: np.ndarray  # (n,)
    spin_angle: np.ndarray  # (n,)
    lean_rate: np.ndarray  # (n,)
    heading_rate: np.ndarray  # (n,)
    spin: np.ndarray  # (n,)
    orientation: np.ndarray  # (n, 4)
    centre: np.ndarray  # (n, 3)
    velocity: np.ndarray  # (n, 3)
    omega: np.ndarray  # (n, 3)
    contact_point: np.ndarray  # (n, 3)
    normal_force: np.ndarray  # (n,)
    energy: np.ndarray  # (n,)


def rolling_disk_reference(
    t: Any,
    radius: float = 0.1,
    mass: float = 1.0,
    lean: float = 0.0,
    spin: float = default_angle(20.0),
    rolling: bool = True,
    *,
    heading_rate: float = 0.0,
    lean_rate: float = 0.0,
    gravity: float = 9.81,
    rtol: float = 1e-13,
    atol: float = 1e-13,
    degrees: bool = False,
) -> RollingDiskMotion:
    """The thin uniform disk from its reduced equations in lean, heading and spin (DOP853).

    An independent formulation of :func:`rolling_disk` (minimal
    coordinates, no constraints): the reference that tests and benchmarks
    compare the System's contact with. With ``A = m R^2 / 4``, ``C = m R^2
    / 2``, ``s = sin theta``, ``c = cos theta`` and ``omega_2 = psi_dot s +
    phi_dot`` (spin about the symmetry axis), the angular momentum about the
    centre in the lean frame ``(f1, f2, f3)`` (rolling direction, symmetry
    axis, centre above the contact point) is ``(A theta_dot, C omega_2, A
    psi_dot c)``, and the moment equations about the centre with the
    contact force ``F = m a + m g e_z`` acting at ``-R f3`` give

    * rolling without slip (``v = R omega_2 f1 - R theta_dot f2``):

      .. math::

          (A + m R^2) \\ddot\\theta &= -A \\dot\\psi^2 s c + (C + m R^2) \\dot\\psi c \\omega_2 + m g R s \\\\
          (C + m R^2) \\dot\\omega_2 &= -m R^2 \\dot\\psi \\dot\\theta c \\\\
          A c \\ddot\\psi &= 2 A \\dot\\psi \\dot\\theta s - C \\dot\\theta \\omega_2

    * sliding without friction (the horizontal velocity of the centre is
      constant, ``z = R c``):

      .. math::

          (A + m R^2 s^2) \\ddot\\theta &= -A \\dot\\psi^2 s c + C \\dot\\psi c \\omega_2 + m R s (g - R c \\dot\\theta^2) \\\\
          \\dot\\omega_2 &= 0, \\qquad A c \\ddot\\psi = 2 A \\dot\\psi \\dot\\theta s - C \\dot\\theta \\omega_2

    with ``phi_dot = omega_2 - psi_dot s``. These are the classic rolling
    (and sliding) coin equations written in this module's angles.

    Parameters
    ----------
    t : (n,) array_like
        Non-decreasing output times (s), at least one; the state below is
        the state at ``t[0]``.
    radius, mass : float
        R (m) and m (kg), > 0.
    lean : float
        Initial lean theta (rad), ``|lean| < FLAT_LEAN``.
    spin : float
        Initial omega_2 (rad/s); positive rolls towards +x at heading 0.
    rolling : bool
        True: rolling without slip; False: sliding without friction.
    heading_rate, lean_rate : float, keyword-only
        Initial psi_dot and theta_dot (rad/s).
    gravity : float, keyword-only
        g (m/s^2) along -z, >= 0.
    rtol, atol : float, keyword-only
        DOP853's tolerances, > 0.

    The disk starts with heading 0 and spin angle 0, its contact point at
    the origin and the centre's velocity that of rolling without slip
    (also when sliding, which then keeps its horizontal part).
    degrees : bool, keyword-only
        True: ``lean`` in degrees; ``spin``, ``heading_rate``, ``lean_rate`` in deg/s (the result holds radians).

    Returns
    -------
    RollingDiskMotion

    Raises
    ------
    ValueError
        For bad arguments.
    RuntimeError
        When the disk falls (``|lean|`` reaches ``FLAT_LEAN``) or DOP853
        fails.
    """
    lean = radians(lean, "lean", degrees)
    spin = radians(spin, "spin", degrees)
    heading_rate = radians(heading_rate, "heading_rate", degrees)
    lean_rate = radians(lean_rate, "lean_rate", degrees)
    R, m, lean, spin, rolling, heading_rate, g = _disk_arguments(radius, mass, lean, spin, rolling, heading_rate,
                                                                 gravity)
    lean_rate = real_number(lean_rate, "lean_rate", expected="a finite lean rate (rad/s)")
    times = output_times(t)
    tolerances = []
    for name, value in (("rtol", rtol), ("atol", atol)):
        tolerances.append(_positive(value, name, "tolerance"))
    A, C, mR2 = 0.25 * m * R * R, 0.5 * m * R * R, m * R * R

    def accelerations(th: float, thd: float, psd: float, w2: float) -> tuple[float, float, float]:
        s, c = math.sin(th), math.cos(th)
        if rolling:
            thdd = (-A * psd * psd * s * c + (C + mR2) * psd * c * w2 + m * g * R * s) / (A + mR2)
            w2d = -mR2 * psd * thd * c / (C + mR2)
        else:
            thdd = (-A * psd * psd * s * c + C * psd * c * w2 + m * R * s * (g - R * c * thd * thd)) / (A + mR2 * s * s)
            w2d = 0.0
        psdd = (2.0 * A * psd * thd * s - C * thd * w2) / (A * c)
        return thdd, psdd, w2d

    # centre velocity at t[0]: rolling without slip, v = R w2 f1 - R theta_dot f2 (heading 0)
    s0, c0 = math.sin(lean), math.cos(lean)
    v0 = np.array([R * spin, -R * lean_rate * c0, -R * lean_rate * s0])

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        th, ps, _ph, thd, psd, w2, _x, _y = y
        thdd, psdd, w2d = accelerations(th, thd, psd, w2)
        s, c = math.sin(th), math.cos(th)
        if rolling:
            cp, sp = math.cos(ps), math.sin(ps)
            xd = R * w2 * cp + R * thd * c * sp
            yd = R * w2 * sp - R * thd * c * cp
        else:
            xd, yd = v0[0], v0[1]
        return np.array([thd, psd, w2 - psd * s, thdd, psdd, w2d, xd, yd])

    def fallen(_t: float, y: np.ndarray) -> float:
        return FLAT_LEAN - abs(y[0])

    fallen.terminal = True  # type: ignore[attr-defined]
    y0 = np.array([lean, 0.0, 0.0, lean_rate, heading_rate, spin, 0.0, -R * s0])
    if times[-1] > times[0]:
        sol = solve_ivp(rhs, (times[0], times[-1]), y0, method="DOP853", rtol=tolerances[0], atol=tolerances[1],
                        t_eval=times, events=fallen)
        if sol.status == 1:
            raise RuntimeError(
                f"rolling_disk_reference: the disk fell (|lean| reached FLAT_LEAN = {FLAT_LEAN} rad) at "
                f"t = {sol.t_events[0][0]:.6g} s; ask for earlier times"
            )
        if not sol.success:
            raise RuntimeError(f"rolling_disk_reference: DOP853 failed: {sol.message}")
        y = sol.y.T
    else:
        y = np.tile(y0, (times.size, 1))
    th, ps, ph, thd, psd, w2 = (y[:, k].copy() for k in range(6))
    s, c = np.sin(th), np.cos(th)
    sp, cp = np.sin(ps), np.cos(ps)
    f1 = np.stack([cp, sp, np.zeros_like(cp)], axis=-1)
    f2 = np.stack([-sp * c, cp * c, s], axis=-1)
    f3 = np.stack([sp * s, -cp * s, c], axis=-1)
    centre = np.stack([y[:, 6], y[:, 7], R * c], axis=-1)
    if rolling:
        velocity = R * w2[:, None] * f1 - R * thd[:, None] * f2
    else:
        velocity = np.stack([np.full_like(th, v0[0]), np.full_like(th, v0[1]), -R * s * thd], axis=-1)
    omega = thd[:, None] * f1 + w2[:, None] * f2 + (psd * c)[:, None] * f3
    thdd = np.array([accelerations(*v)[0] for v in zip(th, thd, psd, w2)])
    normal = m * (g - R * (c * thd * thd + s * thdd))
    kinetic = 0.5 * m * np.einsum("ij,ij->i", velocity, velocity) + 0.5 * (A * thd**2 + C * w2**2 + A * (psd * c) ** 2)
    energy = kinetic + m * g * R * c
    orientation = euler_parameters_from_euler_angles(np.stack([ps, th, ph], axis=-1), "ZXY")
    return RollingDiskMotion(
        t=times.copy(), lean=th, heading=ps, spin_angle=ph, lean_rate=thd, heading_rate=psd, spin=w2,
        orientation=orientation, centre=centre, velocity=velocity, omega=omega, contact_point=centre - R * f3,
        normal_force=normal, energy=energy,
    )


@dataclass(frozen=True)
class RollingDiskRun:
    """A run of the :func:`rolling_disk` System (:func:`rolling_disk_run`); read-only arrays.

    Attributes
    ----------
    t : (n,) ndarray
        Output times (s), n >= 1; the run may end before the last time
        asked for (see ``end``).
    q : (n, 7) ndarray
        Centre (global, m) and Euler parameters (theta0, theta1, theta2,
        theta3), scalar first.
    v : (n, 6) ndarray
        Centre's velocity (global, m/s) and omega_body (body frame, rad/s).
    contact_point : (n, 3) ndarray
        The rim's point on the ground (global, m).
    contact_force : (n, 3) ndarray
        The ground's force on the disk at that point (global, N).
    normal_force : (n,) ndarray
        Its normal component, the contact's independent multiplier (N, Eq. 8.107).
    energy : (n,) ndarray
        Kinetic plus gravitational energy (J).
    residual_position, residual_velocity : (n,) ndarray
        max |C| (m) and max |dC/dt| (m/s) of the contact constraints (Eqs. 8.90-8.94).
    lean, lean_rate, heading_rate : (n,) ndarray
        theta (rad), theta_dot and psi_dot (rad/s) of the module's ``"ZXY"``
        angles (Eq. 8.8 inverted for the rates).
    spin : (n,) ndarray
        omega_2, the angular velocity along the symmetry axis (rad/s).
    speed : (n,) ndarray
        Speed of the centre (m/s).
    end : str
        Why the run ended at ``t[-1]`` before the last time asked for
        ("" when it did not): the disk left the ground (the normal force
        reached zero, Eq. 8.107), fell flat (its lean reached the limit,
        or the contact lost rank, Eq. 8.109), or the integrator stopped.
    final_state : core.multibody.RunState
        The state at ``t[-1]`` (positions, velocities, the contact's
        surface parameters and model): ``initial`` of a run that continues
        this one; picklable, free of the System.
    n_steps, n_rhs : int
        Integrator steps and right-hand-side evaluations.
    """

    t: np.ndarray
    q: np.ndarray = field(repr=False)
    v: np.ndarray = field(repr=False)
    contact_point: np.ndarray = field(repr=False)
    contact_force: np.ndarray = field(repr=False)
    normal_force: np.ndarray = field(repr=False)
    energy: np.ndarray = field(repr=False)
    residual_position: np.ndarray = field(repr=False)
    residual_velocity: np.ndarray = field(repr=False)
    lean: np.ndarray = field(repr=False)
    lean_rate: np.ndarray = field(repr=False)
    heading_rate: np.ndarray = field(repr=False)
    spin: np.ndarray = field(repr=False)
    speed: np.ndarray = field(repr=False)
    end: str
    final_state: Any = field(repr=False)
    n_steps: int = 0
    n_rhs: int = 0

    @property
    def final(self) -> bool:
        """The motion ended at ``t[-1]`` (a separation, a fall or a failed run)."""
        return bool(self.end)


def rolling_disk_run(system: Any, disk: Any, contact: Any, t: Any, *, initial: Any = None, rtol: float = 1e-6,
                     atol: float = 1e-8, lean_limit: float = default_angle(FLAT_LEAN), pieces: int = 20,
                     degrees: bool = False) -> RollingDiskRun:
    """Run the :func:`rolling_disk` System over the output times ``t`` (DOP853) until the disk cannot go on.

    The run stops where the disk leaves the ground (the normal force, the
    contact's multiplier, reaches zero: a constraint cannot pull, Eq. 8.107;
    ``on_separation="stop"``), ends at the last sample before its lean
    reaches ``lean_limit`` (the disk lies down), and, when the System's run
    fails (the contact constraints lose rank as the disk lies flat, Eq.
    8.109, or the integrator gives up), is run again in ``pieces`` pieces
    and ends after the last piece that worked. ``end`` says which.
    Positions and velocities are projected onto the constraints after every
    step (the residuals stay at round-off). The System is not changed.

    Parameters
    ----------
    system, disk, contact :
        As :func:`rolling_disk` returns them.
    t : (n,) array_like
        Increasing output times (s), at least two; from the System's state
        time, or from ``initial``'s.
    initial : RunState or None, keyword-only
        Continue the run that ended there (``RollingDiskRun.final_state`` or
        a trajectory's ``final_state``: time, positions, velocities, the
        contact's warm start) instead of starting from the System's state
        (``System.simulate(t, initial=...)``).
    rtol, atol : float, keyword-only
        DOP853's tolerances (atol in the state's units).
    lean_limit : float, keyword-only
        |lean| (rad) at which the disk counts as fallen, <= ``FLAT_LEAN``
        keeps it clear of the contact's loss of rank at pi / 2.
    pieces : int, keyword-only
        Pieces of a failed run's second try.
    degrees : bool, keyword-only
        True: ``lean_limit`` is in degrees (the result holds radians).

    Returns
    -------
    RollingDiskRun

    Raises
    ------
    ValueError
        For bad times, or when not even the first piece of a failed run
        works, or the motion leaves the finite range.
    """
    lean_limit = radians(lean_limit, "lean_limit", degrees)
    from rigidlab.core.contact import ContactError
    from rigidlab.core.integrators import IntegrationError
    from rigidlab.core.multibody import AssemblyError, SingularSystemError

    times = float_array(t, "t", expected="output times (s)").reshape(-1)
    if times.size < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise ValueError(f"t: expected at least two finite, increasing times (s), got {short_repr(t)}")
    limit = real_number(lean_limit, "lean_limit", expected="a lean (rad) in (0, pi / 2)")
    if not 0.0 < limit < 0.5 * math.pi:
        raise ValueError(f"lean_limit: expected a lean (rad) in (0, pi / 2), got {limit!r}")
    errors = (ContactError, SingularSystemError, IntegrationError, AssemblyError)
    options = {"method": "DOP853", "rtol": rtol, "atol": atol, "on_separation": "stop"}
    trajs, end = _disk_pieces(system, times, options, errors, pieces, initial)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "q", "v", "omega", "energy", "res_p", "res_v",
                                                           "point", "force", "normal")}
    for j, traj in enumerate(trajs):
        s = slice(1 if j else 0, None)
        history = traj.contact(contact)
        for key, a in (("t", traj.t), ("q", traj.q), ("v", traj.v), ("omega", traj.omega(disk)),
                       ("energy", traj.energy), ("res_p", traj.residual_position),
                       ("res_v", traj.residual_velocity), ("point", history.point), ("force", history.force),
                       ("normal", history.normal_force)):
            parts[key].append(np.asarray(a)[s])
    out = {k: np.concatenate(v) for k, v in parts.items()}
    P = out["q"][:, 3:7]
    with warnings.catch_warnings():  # past the limit the angles near their singularity; cut off below
        warnings.simplefilter("ignore", GimbalLockWarning)
        angles = euler_angles_from_euler_parameters(P / np.linalg.norm(P, axis=1)[:, None], "ZXY")
    flat = np.flatnonzero(np.abs(angles[:, 1]) >= limit)  # (psi, theta, phi): theta is the lean
    if flat.size:
        n = max(int(flat[0]), 1)
        end = f"the disk fell flat at t = {out['t'][n - 1]:.3f} s (its lean reached {math.degrees(limit):.0f}°)"
        out = {key: a[:n] for key, a in out.items()}
        angles = angles[:n]
    rates = euler_angle_rates_from_omega(angles, out["omega"], "ZXY", tol=1e-9)  # d(psi, theta, phi)/dt
    axis = rotate_vector(out["q"][:, 3:7], np.array([0.0, 1.0, 0.0]))
    fields = {"q": out["q"], "v": out["v"], "contact_point": out["point"], "contact_force": out["force"],
              "normal_force": out["normal"], "energy": out["energy"], "residual_position": out["res_p"],
              "residual_velocity": out["res_v"], "lean": angles[:, 1], "lean_rate": rates[:, 1],
              "heading_rate": rates[:, 0], "spin": np.einsum("ij,ij->i", out["omega"], axis),
              "speed": np.linalg.norm(out["v"][:, :3], axis=1)}
    for name, a in fields.items():
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the motion left the finite range near t = {times[0]:.3g} s")
        a.setflags(write=False)
    out["t"].setflags(write=False)
    t_end = float(out["t"][-1])
    last = next(tr for tr in reversed(trajs) if tr.t[0] <= t_end)
    final_state = last.run_state(int(np.searchsorted(last.t, t_end)))
    return RollingDiskRun(t=out["t"], **fields, end=end, final_state=final_state,
                          n_steps=sum(int(tr.n_steps) for tr in trajs), n_rhs=sum(int(tr.n_rhs) for tr in trajs))


def _disk_pieces(system: Any, times: np.ndarray, options: dict, errors: tuple, pieces: int,
                 initial: Any) -> tuple[list, str]:
    """The trajectories of a run over ``times`` and why it ended early ("" if not); see :func:`rolling_disk_run`."""

    def separated(traj: Any) -> str:
        return (f"the disk left the ground at t = {traj.separations[-1].t:.3f} s: the normal force reached zero "
                "and a contact constraint cannot pull (Eq. 8.107)")

    try:
        traj = system.simulate(times, initial=initial, **options)
    except errors as exc:
        failure: Exception = exc
    else:
        return [traj], separated(traj) if traj.status == "separated" else ""
    trajs: list[Any] = []
    step = max(1, (times.size - 1) // max(int(pieces), 1))
    i = 0
    while i < times.size - 1:
        try:
            traj = system.simulate(times[i: i + step + 1], initial=initial, **options)
        except errors:
            break
        trajs.append(traj)
        if traj.status == "separated":
            return trajs, separated(traj)
        initial = traj.final_state
        i += step
    if not trajs:
        raise ValueError(f"t: the run cannot start at t = {times[0]:.3f} s: {type(failure).__name__}: {failure}")
    if isinstance(failure, errors[0]) and "rank" in str(failure):
        return trajs, (f"the disk lay down flat near t = {times[i]:.3f} s: its contact constraints lose rank "
                       "there (Eq. 8.109)")
    return trajs, f"the run stopped near t = {times[i]:.3f} s: {type(failure).__name__}: {failure}"


@dataclass(frozen=True)
class RollingDisk:
    """The thin disk's parameters and initial state (frozen, picklable): :func:`rolling_disk` of them.

    Attributes
    ----------
    radius, mass : float
        R (m) and m (kg), > 0.
    lean : float
        Initial lean (rad), ``|lean| < FLAT_LEAN``.
    spin : float
        Initial omega_2 about the symmetry axis (rad/s).
    heading_rate : float
        Initial heading rate about +z (rad/s).
    rolling : bool
        Rolling without slip (True) or frictionless sliding.
    lean_rate, gravity : float
        Initial lean rate (rad/s); g (m/s^2) along -z, >= 0.
    degrees : bool, keyword-only
        True: ``lean`` given in degrees; ``spin``, ``heading_rate``, ``lean_rate`` in deg/s (stored in radians).

    Raises
    ------
    ValueError
        Naming the first argument :func:`rolling_disk` refuses.
    """

    radius: float = 0.1
    mass: float = 1.0
    lean: float = 0.0
    spin: float = default_angle(20.0)
    heading_rate: float = 0.0
    rolling: bool = True
    lean_rate: float = 0.0
    gravity: float = 9.81
    _: KW_ONLY
    degrees: InitVar[bool] = False

    def __post_init__(self, degrees: bool) -> None:
        if check_degrees(degrees):
            for name in ("lean", "spin", "heading_rate", "lean_rate"):
                object.__setattr__(self, name, radians(getattr(self, name), name, True))
        _disk_arguments(self.radius, self.mass, self.lean, self.spin, self.rolling, self.heading_rate, self.gravity)
        real_number(self.lean_rate, "lean_rate", expected="a finite lean rate (rad/s)")

    @property
    def critical_spin(self) -> float:
        """The spin above which the upright disk is stable (rad/s): :func:`rolling_disk_critical_spin`."""
        return rolling_disk_critical_spin(self.radius, rolling=self.rolling, gravity=self.gravity)

    def system(self) -> tuple[Any, Any, Any]:
        """``(System, Body, Contact)``: :func:`rolling_disk` of these parameters, assembled."""
        return rolling_disk(self.radius, self.mass, self.lean, self.spin, self.rolling, heading_rate=self.heading_rate,
                            lean_rate=self.lean_rate, gravity=self.gravity)

    def run(self, t: Any, *, initial: Any = None, **options: Any) -> RollingDiskRun:
        """:func:`rolling_disk_run` of a fresh :meth:`system` over ``t`` (from ``initial``; ``options``:
        rtol, atol, lean_limit, pieces)."""
        return rolling_disk_run(*self.system(), t, initial=initial, **options)
