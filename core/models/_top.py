"""The heavy symmetric top on a spherical joint, in the conventions of core.gyroscope."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rigidlab.core._validation import float_array, radians, real_number
from rigidlab.core.gyroscope import RotorParams
from rigidlab.core.multibody import Body, Joint, System
from rigidlab.core.rotations import euler_angle_G_bar, euler_parameters_from_euler_angles

__all__ = ["HeavyTop", "heavy_top"]


@dataclass(frozen=True)
class HeavyTop:
    """A heavy top: one body on a spherical joint at the origin.

    Attributes
    ----------
    system : System
    body : Body
        The rotor; its body z axis is the rotor axis Z3 of core.gyroscope and
        its orientation the ZXZ angles ``(phi, theta, psi)`` of that module.
    joint : Joint
        Spherical joint between the ground (``body_i``) and the rotor at the
        fixed point O.
    params : RotorParams
    length : float
        Distance l from O to the centre of mass along the rotor axis (m).
    """

    system: System
    body: Body
    joint: Joint
    params: RotorParams
    length: float


def heavy_top(params: RotorParams, state0: Any, *, mass: float = 1.0, gravity: float = 9.81,
              degrees: bool = False) -> HeavyTop:
    """A heavy top equivalent to ``rigidlab.core.gyroscope``'s rotor with ``params`` in ``state0``.

    The rotor's moments about O (``I`` transverse, ``I3`` axial) and
    ``mgl`` fix the body: mass ``m``, centre of mass at ``l = mgl / (m g)``
    on the rotor axis, moments about the centre of mass ``I - m l^2``
    (transverse) and ``I3``. Gravity is ``g`` along -z (core.gyroscope's
    -Z1).

    Parameters
    ----------
    params : RotorParams
    state0 : (6,)
        ``(phi, theta, psi, phi_dot, theta_dot, psi_dot)``, ZXZ angles and
        their rates (rad, rad/s), as in :func:`rigidlab.core.gyroscope.simulate`.
    mass : float, keyword-only
        m (kg), > 0.
    gravity : float, keyword-only
        g (m/s^2), > 0 (any value when ``mgl = 0``).
    degrees : bool, keyword-only
        True: the angles of ``state0`` in degrees, its rates in deg/s.

    Returns
    -------
    HeavyTop

    Raises
    ------
    ValueError
        For a bad ``params`` or ``state0``, or a mass so large that
        ``I - m l^2`` is no longer a valid moment about the centre of mass
        (it must be > 0 and >= I3 / 2).
    """
    state0 = radians(state0, "state0", degrees)
    if not isinstance(params, RotorParams):
        raise ValueError(f"params: expected a core.gyroscope.RotorParams, got {type(params).__name__}")
    s = float_array(state0, "state0", expected="(phi, theta, psi, phi_dot, theta_dot, psi_dot)")
    if s.shape != (6,) or not np.all(np.isfinite(s)):
        raise ValueError(f"state0: expected 6 finite numbers (phi, theta, psi, phi_dot, theta_dot, psi_dot), got {s!r}")
    m = real_number(mass, "mass", expected="a finite mass > 0 (kg)")
    if not m > 0:
        raise ValueError(f"mass: expected a finite mass > 0 (kg), got {m!r}")
    g = real_number(gravity, "gravity", expected="a finite g > 0 (m/s^2)")
    if params.mgl > 0 and not g > 0:
        raise ValueError(f"gravity: expected a finite g > 0 (m/s^2) for a heavy top, got {g!r}")
    length = params.mgl / (m * g) if params.mgl > 0 else 0.0
    transverse = params.I - m * length**2
    if not transverse > 0 or params.I3 > 2.0 * transverse * (1.0 + 1e-12):
        raise ValueError(
            f"mass: with m={m!r} the centre of mass lies l={length!r} m from O and the transverse moment about "
            f"it, I - m l^2 = {transverse!r}, must be > 0 and >= I3/2 = {params.I3 / 2!r}; use a larger mass"
        )
    angles, rates = s[:3], s[3:]
    p = euler_parameters_from_euler_angles(angles, "ZXZ")
    omega_body = euler_angle_G_bar(angles, "ZXZ") @ rates
    system = System(gravity=(0.0, 0.0, -g))
    A = np.array(_matrix(p))
    e3 = A[:, 2]
    body = system.add_body("top", mass=m, inertia=(transverse, transverse, params.I3), position=length * e3,
                           orientation=p, omega_body=omega_body,
                           velocity=np.cross(A @ omega_body, length * e3))
    joint = system.add_joint("spherical", system.ground, body, point=(0.0, 0.0, 0.0), name="pivot")
    system.assemble()
    return HeavyTop(system, body, joint, params, length)


def _matrix(p: np.ndarray) -> np.ndarray:
    from rigidlab.core.rotations import matrix_from_euler_parameters

    return matrix_from_euler_parameters(p)
