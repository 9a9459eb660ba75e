r"""The Whipple bicycle: four rigid bodies, three revolute joints and two rolling knife-edge wheels.

The benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab (Proc. R.
Soc. A 463, 2007) built from the general engine: a rear wheel, a rear frame
with the rider, a front fork with the handlebar and a front wheel
(:meth:`rigidlab.core.multibody.System.add_body`), the hubs and the steer axis as
revolute joints, and each wheel's rim a :class:`rigidlab.core.contact.Torus` of minor
radius zero rolling without slip on the ground :class:`rigidlab.core.contact.Plane`
(``System.add_contact(..., rolling=True)``). No bicycle-specific equation
enters the model; the paper's linearized equations in lean and steer,

.. math:: M \ddot q + v C_1 \dot q + (g K_0 + v^2 K_2) q = 0, \qquad q = (\phi, \delta),

are built from the same parameters by its Appendix A formulas in
:func:`whipple_bicycle_reference`, as an independent check of
:func:`rigidlab.core.modal.linearize`.

Conventions. The parameters (:class:`WhippleParameters`, Table 1 of the
paper) are in the paper's frame: origin at the rear contact point, ``x``
forward, ``y`` to the right, ``z`` down. The System uses the engine's
frame, global ``+z`` up: ``x`` forward, ``y`` to the left, so a vector
``(x, y, z)`` of the paper is ``(x, -y, -z)`` here, and an inertia tensor
``I`` is ``T I T`` with ``T = diag(1, -1, -1)`` (the products ``I_xz``
change sign). The angles of :func:`whipple_angles` and
:func:`whipple_modes` are the paper's: lean ``phi`` positive to the right
(a rotation about the forward axis, the same in both frames), steer
``delta`` positive to the right (about the steer axis pointing down), yaw
``psi`` positive to the right (about the paper's downward ``z``: the
negative of the engine's heading) and the rear frame's pitch about the
paper's ``y`` (right) axis.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import warnings
from dataclasses import KW_ONLY, InitVar, dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
from scipy.optimize import brentq

from rigidlab.core._constants import RIDE_ATOL, RIDE_RTOL
from rigidlab.core._errors import ArgumentError
from rigidlab.core._validation import default_angle, float_array, radians, real_number, short_repr

__all__ = [
    "MEIJAARD_2007",
    "MEIJAARD_2007_EIGENVALUES",
    "MEIJAARD_2007_SPEEDS",
    "WHIPPLE_FALL_LEAN",
    "WHIPPLE_MODE_NAMES",
    "WHIPPLE_PARAMETER_SETS",
    "WhippleAngles",
    "WhippleMode",
    "WhippleParameters",
    "WhippleReference",
    "WhippleRide",
    "WhippleSpeedModel",
    "whipple_angles",
    "whipple_bicycle",
    "whipple_bicycle_reference",
    "whipple_linear_response",
    "whipple_mode_names",
    "whipple_modes",
    "whipple_push",
    "whipple_ride",
    "whipple_speed_model",
]

#: Names of the modes of the upright bicycle, in the order :func:`whipple_modes` returns them.
WHIPPLE_MODE_NAMES = ("weave", "capsize", "castering")
#: Lean (rad) at which :func:`whipple_ride` calls the bicycle fallen and stops.
WHIPPLE_FALL_LEAN = math.radians(60.0)
#: Body, joint and contact names of :func:`whipple_bicycle`, in the System's order.
_BODIES = ("rear_wheel", "frame", "fork", "front_wheel")
_JOINTS = ("rear_hub", "steer", "front_hub")
_CONTACTS = ("rear_contact", "front_contact")
_FRAME, _FORK = 1, 2
_T = np.diag([1.0, -1.0, -1.0])  # the paper's vectors to the engine's (z down -> z up, y right -> y left)


# ------------------------------------------------------------------ parameters
@dataclass(frozen=True)
class WhippleParameters:
    """The parameters of a Whipple bicycle (Table 1 of Meijaard et al. 2007), in the paper's frame.

    Frame of the paper: origin at the rear contact point, ``x`` forward,
    ``y`` to the right, ``z`` down; positions of the centres of mass are
    ``(x, z)`` with ``z < 0`` above the ground; inertia tensors are about
    the centres of mass, in that frame (a wheel's about its centre, ``xx``
    about a diameter and ``yy`` about its axle). SI units.

    Attributes
    ----------
    wheelbase : float
        ``w`` (m), > 0.
    trail : float
        ``c`` (m): the front contact point is this far behind the point
        where the steer axis meets the ground.
    steer_axis_tilt : float
        ``lambda`` (rad) from the vertical, in ``(-pi/2, pi/2)``.
    gravity : float
        ``g`` (m/s^2), >= 0.
    rear_radius, rear_mass : float
        ``r_R`` (m), ``m_R`` (kg).
    rear_inertia : (2,) tuple
        ``(I_Rxx, I_Ryy)`` (kg m^2); ``I_Rzz = I_Rxx``.
    frame_position : (2,) tuple
        ``(x_B, z_B)`` (m): rear frame and rider.
    frame_mass : float
        ``m_B`` (kg).
    frame_inertia : (4,) tuple
        ``(I_Bxx, I_Byy, I_Bzz, I_Bxz)`` (kg m^2).
    fork_position : (2,) tuple
        ``(x_H, z_H)`` (m): front fork and handlebar.
    fork_mass : float
        ``m_H`` (kg).
    fork_inertia : (4,) tuple
        ``(I_Hxx, I_Hyy, I_Hzz, I_Hxz)`` (kg m^2).
    front_radius, front_mass : float
        ``r_F`` (m), ``m_F`` (kg).
    front_inertia : (2,) tuple
        ``(I_Fxx, I_Fyy)`` (kg m^2); ``I_Fzz = I_Fxx``.
    degrees : bool, keyword-only
        True: ``steer_axis_tilt`` given in degrees (stored in radians).

    Raises
    ------
    ValueError
        Naming the field: a length, radius or mass that is not > 0, a tilt
        outside ``(-pi/2, pi/2)``, a tuple of the wrong length, an inertia
        tensor that is not positive definite or breaks the triangle
        inequality, a wheel whose axle moment exceeds twice its diametral
        one.
    """

    wheelbase: float
    trail: float
    steer_axis_tilt: float
    gravity: float
    rear_radius: float
    rear_mass: float
    rear_inertia: tuple[float, float]
    frame_position: tuple[float, float]
    frame_mass: float
    frame_inertia: tuple[float, float, float, float]
    fork_position: tuple[float, float]
    fork_mass: float
    fork_inertia: tuple[float, float, float, float]
    front_radius: float
    front_mass: float
    front_inertia: tuple[float, float]
    _: KW_ONLY
    degrees: InitVar[bool] = False

    def __post_init__(self, degrees: bool) -> None:
        object.__setattr__(self, "steer_axis_tilt", radians(self.steer_axis_tilt, "steer_axis_tilt", degrees))
        for name in ("wheelbase", "rear_radius", "rear_mass", "frame_mass", "fork_mass", "front_radius",
                     "front_mass"):
            v = real_number(getattr(self, name), name, expected="a finite number > 0")
            if not v > 0:
                raise ValueError(f"{name}: expected a finite number > 0, got {v!r}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "trail", real_number(self.trail, "trail", expected="a finite trail (m)"))
        tilt = real_number(self.steer_axis_tilt, "steer_axis_tilt", expected="a finite angle (rad)")
        if not abs(tilt) < 0.5 * math.pi:
            raise ValueError(f"steer_axis_tilt: expected an angle from the vertical in (-pi/2, pi/2) rad, got {tilt!r}")
        object.__setattr__(self, "steer_axis_tilt", tilt)
        g = real_number(self.gravity, "gravity", expected="a finite g >= 0 (m/s^2)")
        if g < 0:
            raise ValueError(f"gravity: expected a finite g >= 0 (m/s^2), got {g!r}")
        object.__setattr__(self, "gravity", g)
        for name, size in (("rear_inertia", 2), ("frame_position", 2), ("frame_inertia", 4), ("fork_position", 2),
                           ("fork_inertia", 4), ("front_inertia", 2)):
            a = float_array(getattr(self, name), name, expected=f"{size} real numbers")
            if a.shape != (size,) or not np.all(np.isfinite(a)):
                raise ValueError(f"{name}: expected {size} finite numbers, got {short_repr(getattr(self, name))}")
            object.__setattr__(self, name, tuple(float(x) for x in a))
        for name in ("rear_inertia", "front_inertia"):
            ixx, iyy = getattr(self, name)
            if not (ixx > 0 and 0 < iyy <= 2 * ixx):
                raise ValueError(f"{name}: expected 0 < I_yy <= 2 I_xx (a wheel), got {getattr(self, name)}")
        for name in ("frame_inertia", "fork_inertia"):
            J = _tensor(getattr(self, name))
            ev = np.linalg.eigvalsh(J)
            if not ev[0] > 0 or ev[0] + ev[1] < ev[2] * (1.0 - 1e-12):
                raise ValueError(f"{name}: expected a positive definite inertia tensor whose principal moments "
                                 f"satisfy the triangle inequality, got {getattr(self, name)} (moments {ev})")

    @property
    def steer_axis(self) -> np.ndarray:
        """(3,) unit vector along the steer axis pointing down, engine frame (positive steer turns right)."""
        lam = self.steer_axis_tilt
        return np.array([math.sin(lam), 0.0, -math.cos(lam)])


def _tensor(values: tuple[float, float, float, float]) -> np.ndarray:
    """(3, 3) inertia tensor of ``(I_xx, I_yy, I_zz, I_xz)`` (paper's frame)."""
    ixx, iyy, izz, ixz = values
    return np.array([[ixx, 0.0, ixz], [0.0, iyy, 0.0], [ixz, 0.0, izz]])


#: Table 1 of Meijaard, Papadopoulos, Ruina and Schwab, Proc. R. Soc. A 463 (2007): the benchmark bicycle.
MEIJAARD_2007 = WhippleParameters(
    wheelbase=1.02, trail=0.08, steer_axis_tilt=math.pi / 10.0, gravity=9.81,
    rear_radius=0.3, rear_mass=2.0, rear_inertia=(0.0603, 0.12),
    frame_position=(0.3, -0.9), frame_mass=85.0, frame_inertia=(9.2, 11.0, 2.8, 2.4),
    fork_position=(0.9, -0.7), fork_mass=4.0, fork_inertia=(0.05892, 0.06, 0.00708, -0.00756),
    front_radius=0.35, front_mass=3.0, front_inertia=(0.1405, 0.28),
)

#: Named parameter sets accepted by ``parameters=`` (a :class:`WhippleParameters` is accepted too).
WHIPPLE_PARAMETER_SETS = {"meijaard2007": MEIJAARD_2007}

#: Forward speeds (m/s) of Table 2 of the paper (eigenvalues of the benchmark at 0, 1, ..., 10 m/s).
MEIJAARD_2007_SPEEDS = tuple(float(v) for v in range(11))

#: The published eigenvalues of the benchmark (Table 2, 14 decimals) at :data:`MEIJAARD_2007_SPEEDS`,
#: with the weave speed, the capsize speed and the speed where the weave pair turns complex:
#: ``{"eigenvalues": {v: (4 complex)}, "weave_speed", "capsize_speed", "weave_onset_speed"}``.
MEIJAARD_2007_EIGENVALUES = {
    "eigenvalues": {
        0.0: (-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393),
        1.0: (-7.11008014637442, -3.13423125066578, 3.52696170990070 - 0.80774027519930j,
              3.52696170990070 + 0.80774027519930j),
        2.0: (-8.67387984831735, -3.07158645641514, 2.68234517512745 - 1.68066296590675j,
              2.68234517512745 + 1.68066296590675j),
        3.0: (-10.35101467245920, -2.63366137253667, 1.70675605663975 - 2.31582447384325j,
              1.70675605663975 + 2.31582447384325j),
        4.0: (-12.15861426576450, -1.42944427361326, 0.41325331521125 - 3.07910818603206j,
              0.41325331521125 + 3.07910818603206j),
        5.0: (-14.07838969279820, -0.77534188219585 - 4.46486771378823j, -0.77534188219585 + 4.46486771378823j,
              -0.32286642900409),
        6.0: (-16.08537123098030, -1.52644486584142 - 5.87673060598709j, -1.52644486584142 + 5.87673060598709j,
              -0.00406690076970),
        7.0: (-18.15788466125262, -2.13875644258362 - 7.19525913329805j, -2.13875644258362 + 7.19525913329805j,
              0.10268170574766),
        8.0: (-20.27940894394569, -2.69348683581097 - 8.46037971396931j, -2.69348683581097 + 8.46037971396931j,
              0.14327879765713),
        9.0: (-22.43788559040858, -3.21675402252485 - 9.69377351531791j, -3.21675402252485 + 9.69377351531791j,
              0.15790184030917),
        10.0: (-24.62459635017404, -3.72016840437287 - 10.90681139476287j, -3.72016840437287 + 10.90681139476287j,
               0.16105338653172),
    },
    "weave_speed": 4.29238253634111,
    "capsize_speed": 6.02426201538837,
    "weave_onset_speed": 0.68428307889246,
}


def _parameters(parameters: Any) -> WhippleParameters:
    if isinstance(parameters, WhippleParameters):
        return parameters
    if isinstance(parameters, str) and parameters in WHIPPLE_PARAMETER_SETS:
        return WHIPPLE_PARAMETER_SETS[parameters]
    raise ValueError(f"parameters: expected a WhippleParameters or one of {sorted(WHIPPLE_PARAMETER_SETS)}, "
                     f"got {short_repr(parameters)}")


# ------------------------------------------------------------------ the System
def whipple_bicycle(speed: float = 5.0, parameters: Any = "meijaard2007"):
    """The Whipple bicycle upright and running straight ahead at ``speed``, as an assembled System.

    Four bodies, added in this order (their names): ``"rear_wheel"``,
    ``"frame"`` (rear frame with the rider), ``"fork"`` (front fork and
    handlebar), ``"front_wheel"``; three revolute joints: ``"rear_hub"``
    (frame, rear wheel; axis +y), ``"steer"`` (frame, fork; axis along the
    steer axis pointing down, so a positive joint angle steers right) and
    ``"front_hub"`` (fork, front wheel); two contacts in the constraint
    model, rolling without slip: ``"rear_contact"`` and ``"front_contact"``,
    each between the ground's :class:`~rigidlab.core.contact.Plane` and the wheel's
    rim, a :class:`~rigidlab.core.contact.Torus` of minor radius 0 about the wheel's
    body y axis. Gravity ``g`` acts along -z.

    Reference configuration (engine frame, z up): rear contact point at the
    origin, heading +x, upright; the steer axis meets the ground at ``x = w
    + c``; the steer joint sits where the perpendicular from the front hub
    meets the steer axis. Every body moves at ``(speed, 0, 0)`` and the
    wheels turn at ``speed / r`` about +y: a steady motion, ready for
    :func:`rigidlab.core.modal.linearize`.

    Parameters
    ----------
    speed : float
        Forward speed ``v`` (m/s); negative rolls backwards.
    parameters : str or WhippleParameters
        A name of :data:`WHIPPLE_PARAMETER_SETS` (``"meijaard2007"``, Table
        1 of the paper) or a parameter set.

    Returns
    -------
    System
        ``system.bodies``, ``system.joints`` and ``system.contacts`` in the
        order above.

    Raises
    ------
    ValueError
        For a non-finite speed or unknown parameters.

    Notes
    -----
    The configuration does not depend on the speed, and the velocities of
    the steady run are proportional to it: the System is built and
    assembled (the two contact points found, Eqs. 8.84-8.94) once per
    parameter set, at 1 m/s, and each call returns a copy of it with the
    velocities scaled by ``speed`` (the copies share nothing).
    """
    v = real_number(speed, "speed", expected="a finite forward speed (m/s)")
    system = copy.deepcopy(_upright(_parameters(parameters)))
    state = system.state
    system.set_state(dataclasses.replace(state, v=v * state.v))
    return system


@functools.lru_cache(maxsize=8)
def _upright(p: WhippleParameters):
    """The assembled System of :func:`whipple_bicycle` at 1 m/s (one per parameter set; never handed out)."""
    from rigidlab.core.contact import Plane, Torus
    from rigidlab.core.multibody import System

    w, c, rR, rF = p.wheelbase, p.trail, p.rear_radius, p.front_radius
    v = 1.0
    forward = (v, 0.0, 0.0)
    system = System(gravity=(0.0, 0.0, -p.gravity))
    rear = system.add_body(_BODIES[0], mass=p.rear_mass, inertia=(p.rear_inertia[0], p.rear_inertia[1],
                                                                  p.rear_inertia[0]),
                           position=(0.0, 0.0, rR), velocity=forward, omega=(0.0, v / rR, 0.0))
    frame = system.add_body(_BODIES[1], mass=p.frame_mass, inertia=_T @ _tensor(p.frame_inertia) @ _T,
                            position=(p.frame_position[0], 0.0, -p.frame_position[1]), velocity=forward)
    fork = system.add_body(_BODIES[2], mass=p.fork_mass, inertia=_T @ _tensor(p.fork_inertia) @ _T,
                           position=(p.fork_position[0], 0.0, -p.fork_position[1]), velocity=forward)
    front = system.add_body(_BODIES[3], mass=p.front_mass, inertia=(p.front_inertia[0], p.front_inertia[1],
                                                                    p.front_inertia[0]),
                            position=(w, 0.0, rF), velocity=forward, omega=(0.0, v / rF, 0.0))
    axis = p.steer_axis
    hub = np.array([w, 0.0, rF])
    ground_point = np.array([w + c, 0.0, 0.0])
    head = ground_point + ((hub - ground_point) @ axis) * axis  # foot of the perpendicular from the front hub
    system.add_joint("revolute", frame, rear, point=(0.0, 0.0, rR), axis=(0.0, 1.0, 0.0), name=_JOINTS[0])
    system.add_joint("revolute", frame, fork, point=head, axis=axis, name=_JOINTS[1])
    system.add_joint("revolute", fork, front, point=hub, axis=(0.0, 1.0, 0.0), name=_JOINTS[2])
    system.add_contact(system.ground, Plane(), rear, Torus(rR, 0.0), rolling=True, name=_CONTACTS[0])
    system.add_contact(system.ground, Plane(), front, Torus(rF, 0.0), rolling=True, name=_CONTACTS[1])
    system.assemble()
    return system


# ------------------------------------------------------------------ the paper's linear equations
@dataclass(frozen=True)
class WhippleReference:
    r"""The paper's linearized equations ``M q'' + v C1 q' + (g K0 + v^2 K2) q = 0``, ``q = (phi, delta)``.

    Built by :func:`whipple_bicycle_reference` from the parameters with the
    formulas of Appendix A of Meijaard et al. (2007); lean ``phi`` and steer
    ``delta`` in the paper's signs (both positive to the right).

    Attributes
    ----------
    M, C1, K0, K2 : (2, 2) ndarray
    gravity : float
        ``g`` (m/s^2).
    """

    M: np.ndarray = field(repr=False)  # (2, 2)
    C1: np.ndarray = field(repr=False)  # (2, 2)
    K0: np.ndarray = field(repr=False)  # (2, 2)
    K2: np.ndarray = field(repr=False)  # (2, 2)
    gravity: float

    def state_matrix(self, speed: float) -> np.ndarray:
        """(4, 4) ``A`` of ``x' = A x``, ``x = (phi, delta, phi', delta')``, at forward speed ``speed`` (m/s)."""
        v = real_number(speed, "speed", expected="a finite forward speed (m/s)")
        A = np.zeros((4, 4))
        A[:2, 2:] = np.eye(2)
        A[2:, :2] = -np.linalg.solve(self.M, self.gravity * self.K0 + v * v * self.K2)
        A[2:, 2:] = -np.linalg.solve(self.M, v * self.C1)
        return A

    def eigenvalues(self, speed: float) -> np.ndarray:
        """(4,) complex eigenvalues at ``speed``, sorted by real part, then imaginary part."""
        ev = scipy.linalg.eigvals(self.state_matrix(speed))
        return ev[np.lexsort((ev.imag, ev.real))]

    def stability_boundaries(self, speeds: Any = (0.0, 10.0)) -> np.ndarray:
        """Speeds in ``[speeds[0], speeds[1]]`` where the largest real part crosses zero (Brent, 1e-14 m/s).

        For the benchmark: the weave speed and the capsize speed.
        """
        lo, hi = (float(x) for x in speeds)
        grid = np.linspace(lo, hi, 201)
        h = np.array([float(np.max(self.eigenvalues(x).real)) for x in grid])
        out = []
        for i in range(grid.size - 1):
            if (h[i] > 0) != (h[i + 1] > 0):
                out.append(brentq(lambda x: float(np.max(self.eigenvalues(x).real)), grid[i], grid[i + 1],
                                  xtol=1e-14, rtol=4 * np.finfo(float).eps, maxiter=200))
        return np.array(out)


def whipple_bicycle_reference(parameters: Any = "meijaard2007") -> WhippleReference:
    """The paper's ``M``, ``C1``, ``K0``, ``K2`` from the parameters (Meijaard et al. 2007, Appendix A).

    Total mass and centre of mass, the front assembly ``A`` (fork and front
    wheel), its distance ``u_A`` from the steer axis and its moments about
    it, the ratio ``mu = (c / w) cos(lambda)``, the gyrostatic coefficients
    ``S_R = I_Ryy / r_R``, ``S_F = I_Fyy / r_F`` and the static moment
    ``S_A``, as printed in the appendix. For the benchmark this gives the
    paper's Table 2 matrices, e.g. ``M = [[80.81722, 2.31941332208709],
    [2.31941332208709, 0.29784188199686]]``.

    Parameters
    ----------
    parameters : str or WhippleParameters

    Returns
    -------
    WhippleReference
    """
    p = _parameters(parameters)
    w, c, lam, g = p.wheelbase, p.trail, p.steer_axis_tilt, p.gravity
    rR, mR, (IRxx, IRyy) = p.rear_radius, p.rear_mass, p.rear_inertia
    (xB, zB), mB, (IBxx, _, IBzz, IBxz) = p.frame_position, p.frame_mass, p.frame_inertia
    (xH, zH), mH, (IHxx, _, IHzz, IHxz) = p.fork_position, p.fork_mass, p.fork_inertia
    rF, mF, (IFxx, IFyy) = p.front_radius, p.front_mass, p.front_inertia
    mT = mR + mB + mH + mF
    xT = (xB * mB + xH * mH + w * mF) / mT
    zT = (-rR * mR + zB * mB + zH * mH - rF * mF) / mT
    ITxx = IRxx + IBxx + IHxx + IFxx + mR * rR**2 + mB * zB**2 + mH * zH**2 + mF * rF**2
    ITxz = IBxz + IHxz - mB * xB * zB - mH * xH * zH + mF * w * rF
    ITzz = IRxx + IBzz + IHzz + IFxx + mB * xB**2 + mH * xH**2 + mF * w**2  # I_Rzz = I_Rxx, I_Fzz = I_Fxx
    mA = mH + mF
    xA = (xH * mH + w * mF) / mA
    zA = (zH * mH - rF * mF) / mA
    IAxx = IHxx + IFxx + mH * (zH - zA) ** 2 + mF * (rF + zA) ** 2
    IAxz = IHxz - mH * (xH - xA) * (zH - zA) + mF * (w - xA) * (rF + zA)
    IAzz = IHzz + IFxx + mH * (xH - xA) ** 2 + mF * (w - xA) ** 2
    sl, cl = math.sin(lam), math.cos(lam)
    uA = (xA - w - c) * cl - zA * sl
    IAll = mA * uA**2 + IAxx * sl**2 + 2.0 * IAxz * sl * cl + IAzz * cl**2
    IAlx = -mA * uA * zA + IAxx * sl + IAxz * cl
    IAlz = mA * uA * xA + IAxz * sl + IAzz * cl
    mu = c / w * cl
    SR = IRyy / rR
    SF = IFyy / rF
    ST = SR + SF
    SA = mA * uA + mu * mT * xT
    M = np.array([[ITxx, IAlx + mu * ITxz], [IAlx + mu * ITxz, IAll + 2.0 * mu * IAlz + mu**2 * ITzz]])
    K0 = np.array([[mT * zT, -SA], [-SA, -SA * sl]])
    K2 = np.array([[0.0, (ST - mT * zT) / w * cl], [0.0, (SA + SF * sl) / w * cl]])
    C1 = np.array([[0.0, mu * ST + SF * cl + ITxz / w * cl - mu * mT * zT],
                   [-(mu * ST + SF * cl), IAlz / w * cl + mu * (SA + ITzz / w * cl)]])
    for a in (M, C1, K0, K2):
        a.setflags(write=False)
    return WhippleReference(M, C1, K0, K2, g)


# ------------------------------------------------------------------ angles of the System
@dataclass(frozen=True)
class WhippleAngles:
    """Lean, steer, yaw and pitch of the rear frame, in the paper's signs (rad; read-only arrays).

    Attributes
    ----------
    lean : (...,) ``phi``, positive leaning right.
    steer : (...,) ``delta``, positive steering right (about the steer axis, pointing down).
    yaw : (...,) ``psi``, positive turning right (the negative of the engine's heading about +z).
    pitch : (...,) ``theta_B``, rotation of the rear frame about the paper's ``y`` (right) axis.
    """

    lean: np.ndarray
    steer: np.ndarray
    yaw: np.ndarray
    pitch: np.ndarray


def whipple_angles(q: Any, parameters: Any = "meijaard2007") -> WhippleAngles:
    """The paper's angles of a :func:`whipple_bicycle` System at positions ``q``.

    The rear frame's rotation matrix is ``A = Rz(h) Rx(phi) Ry(b)`` (intrinsic
    ``"ZXY"``: heading ``h`` about the engine's +z, lean about the forward
    axis, pitch ``b`` about the engine's +y); the paper's yaw is ``-h`` and
    its pitch ``-b``. The steer angle is the rotation of the fork relative to
    the frame about the steer axis (pointing down):
    ``atan2(a . (e x A_rel e), e . A_rel e)`` with ``A_rel = A_frame^T
    A_fork``, ``a`` the axis and ``e`` the frame's y axis.

    Parameters
    ----------
    q : (..., 28) array_like
        Positions ``[R (12) | p (16)]`` of the System's four bodies
        (``State.q``, ``MultibodyTrajectory.q``).
    parameters : str or WhippleParameters
        Those of the System (for the steer axis).

    Returns
    -------
    WhippleAngles
    """
    from rigidlab.core.multibody._engine import matrices
    from rigidlab.core.rotations import euler_angles_from_matrix

    p = _parameters(parameters)
    q = float_array(q, "q", expected="positions (..., 28) of the bicycle's four bodies")
    if q.shape[-1:] != (28,) or not np.all(np.isfinite(q)):
        raise ValueError(f"q: expected finite positions (..., 28) of the bicycle's four bodies, got shape {q.shape}")
    lead = q.shape[:-1]
    P = q[..., 12:].reshape(-1, 4, 4)
    P = P / np.linalg.norm(P, axis=-1, keepdims=True)
    A_frame = matrices(P[:, _FRAME])
    A_fork = matrices(P[:, _FORK])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a frame pitched by 90 degrees (never a bicycle on its wheels)
        zxy = np.asarray(euler_angles_from_matrix(A_frame, "ZXY")).reshape(-1, 3)
    rel = np.einsum("kji,kjl->kil", A_frame, A_fork)
    a = p.steer_axis
    e = np.array([0.0, 1.0, 0.0])
    f = rel @ e
    steer = np.arctan2(np.cross(e, f) @ a, f @ e)
    out = [x.reshape(lead) for x in (zxy[:, 1], steer, -zxy[:, 0], -zxy[:, 2])]
    for x in out:
        x.setflags(write=False)
    return WhippleAngles(*out)


# ------------------------------------------------------------------ modes
@dataclass(frozen=True)
class WhippleMode:
    """One eigenvalue of the linearized bicycle, named.

    Attributes
    ----------
    name : str
        ``"weave"`` (the oscillating pair, or below ``weave_onset_speed``
        the two positive real roots that merge into it), ``"capsize"`` (the
        slow real mode, mostly lean) or ``"castering"`` (the fast, strongly
        damped real mode, mostly steer).
    eigenvalue : complex
        ``s`` (1/s).
    lean, steer : complex
        The mode shape in the paper's ``(phi, delta)``, scaled so that the
        larger of the two is 1 (turned to be real).
    stable : bool
        ``Re(s) <= 0``.
    """

    name: str
    eigenvalue: complex
    lean: complex
    steer: complex
    stable: bool


def whipple_modes(model: Any, parameters: Any = "meijaard2007") -> tuple[WhippleMode, ...]:
    """The four non-rigid modes of a linearized :func:`whipple_bicycle`, named and in lean and steer.

    ``model`` is ``rigidlab.core.modal.linearize(system)`` of the System; its
    embedding maps each mode shape to the bodies' small rotations
    ``dtheta`` (global), from which lean ``= dtheta_frame . x`` and steer ``=
    (dtheta_fork - dtheta_frame) . a`` (``a`` the steer axis pointing
    down). Names follow the paper: a complex pair is the weave; of the real
    modes the most negative one is castering, the next capsize, and when
    four are real (below the weave onset speed, 0.684 m/s for the
    benchmark) the two largest are the weave's.

    Returns
    -------
    tuple of WhippleMode
        Weave (``Im s >= 0`` first), capsize, castering.

    Raises
    ------
    ValueError
        For a model that is not a linearized System of four bodies, or one
        that does not have four non-rigid modes.
    """
    from rigidlab.core.modal import LinearModel

    p = _parameters(parameters)
    if not isinstance(model, LinearModel) or model.embedding is None or model.embedding.n_bodies != 4:
        raise ValueError(f"model: expected core.modal.linearize(whipple_bicycle(...)), got {short_repr(model)}")
    modes = model.modes()
    keep = np.flatnonzero(~modes.rigid)
    if keep.size != 4:
        raise ValueError(f"model: expected 4 non-rigid modes (weave pair, capsize, castering), got {keep.size}")
    s = modes.eigenvalues[keep]
    z = modes.complex_shapes[keep] @ model.embedding.basis.T  # (4, 24) complex, global small rotations
    n = 4
    th_frame = z[:, 3 * n + 3 * _FRAME : 3 * n + 3 * _FRAME + 3]
    th_fork = z[:, 3 * n + 3 * _FORK : 3 * n + 3 * _FORK + 3]
    lean = th_frame[:, 0]
    steer = (th_fork - th_frame) @ p.steer_axis
    try:
        names = whipple_mode_names(s)
    except ValueError as exc:
        raise ValueError(f"model: {exc}") from None
    out = []
    for k in range(4):
        big = lean[k] if abs(lean[k]) >= abs(steer[k]) else steer[k]
        big = big if big != 0 else 1.0
        out.append(WhippleMode(str(names[k]), complex(s[k]), complex(lean[k] / big), complex(steer[k] / big),
                               bool(s[k].real <= 0.0)))
    order = {name: i for i, name in enumerate(WHIPPLE_MODE_NAMES)}
    out.sort(key=lambda m: (order[m.name], -m.eigenvalue.imag, -m.eigenvalue.real))
    return tuple(out)


def whipple_mode_names(eigenvalues: Any) -> tuple[str, ...]:
    """Names of the four eigenvalues of an upright bicycle, in their order (see :func:`whipple_modes`).

    A complex pair is the weave; of the real ones the most negative is
    castering, the next capsize, and when all four are real (below the
    weave onset speed) the two largest are the weave's.

    Parameters
    ----------
    eigenvalues : (4,) array_like of complex

    Raises
    ------
    ValueError
        Unless there are four eigenvalues, two or four of them real.
    """
    s = np.asarray(eigenvalues, dtype=complex).reshape(-1)
    if s.size != 4:
        raise ValueError(f"expected the 4 eigenvalues of the bicycle, got {s.size}")
    scale = max(float(np.max(np.abs(s))), 1e-300)
    oscillating = np.abs(s.imag) > 1e-8 * scale
    names = np.empty(4, dtype=object)
    names[oscillating] = "weave"
    real = np.flatnonzero(~oscillating)
    real = real[np.argsort(s[real].real)]
    if real.size == 4:
        names[real] = ("castering", "capsize", "weave", "weave")
    elif real.size == 2:
        names[real] = ("castering", "capsize")
    else:
        raise ValueError(f"expected 2 or 4 real modes besides the weave pair, got {real.size}")
    return tuple(str(x) for x in names)


# ------------------------------------------------------------------ the linear model at every speed
@dataclass(frozen=True)
class WhippleSpeedModel:
    r"""The linearized :func:`whipple_bicycle` at every forward speed, from two linearizations of the System.

    The upright straight run has the same configuration at every speed
    ``v``, its velocities are proportional to ``v``, nothing accelerates,
    and its multipliers (the weight on the wheels) do not depend on ``v``.
    The dynamic residual of the perturbed motion (Eqs. 8.110-8.112) is then
    a polynomial in the reference velocities: the gyroscopic torques
    ``omega x I omega`` and the inertial terms the reference velocities
    carry are quadratic in ``v``, the coupling of the perturbation rates
    with them linear, and so is ``E = d(D_r v)/dz`` of the rolling rows.
    In the embedding of :func:`rigidlab.core.modal.linearize`, the same at every
    speed (it depends on the configuration only), the linear model is

    .. math::

        M \dot s + v (C_1 + G_1) s + (K_0 + v^2 K_2) u = 0, \qquad
        \dot u = T s + v Y_1 u,

    the form of the paper's linearized equations (``M q'' + v C1 q' + (g K0
    + v^2 K2) q = 0``, :class:`WhippleReference`) in the engine's
    coordinates. :func:`whipple_speed_model` linearizes the
    System at rest and at ``reference_speed`` and keeps the coefficients;
    :meth:`linear_model` assembles the model of any speed from them,
    equal to ``linearize(whipple_bicycle(v))`` to round-off (the
    differenced derivatives are linear in the residual, so the same
    differences enter both).

    Attributes
    ----------
    M : (f_v, f_v) ndarray
        Mass matrix (kg, kg m, kg m^2 in the basis).
    K0, K2 : (f_v, f) ndarray
        Stiffness at rest and its part per (m/s)^2.
    C1, G1 : (f_v, f_v) ndarray
        Damping and gyroscopic matrices per m/s.
    velocity_map : (f, f_v) ndarray
        ``T``: position rates of the independent velocities.
    position_rate_map : (f, f) ndarray
        ``Y_1``: position rates of the positions per m/s (rolling at speed).
    embedding : core.modal.Embedding
        Of the System at 1 m/s (``v0`` the velocities at 1 m/s).
    derivative_error : float
        The larger estimated relative error of the two linearizations.
    reference_speed : float
        The second speed linearized (m/s).
    """

    M: np.ndarray = field(repr=False)
    K0: np.ndarray = field(repr=False)
    K2: np.ndarray = field(repr=False)
    C1: np.ndarray = field(repr=False)
    G1: np.ndarray = field(repr=False)
    velocity_map: np.ndarray = field(repr=False)
    position_rate_map: np.ndarray = field(repr=False)
    embedding: Any = field(repr=False)
    derivative_error: float
    reference_speed: float

    def linear_model(self, speed: float):
        """``LinearModel`` of the bicycle at forward speed ``speed`` (m/s), as ``linearize(whipple_bicycle(speed))``.

        Raises
        ------
        ValueError
            For a non-finite speed.
        """
        from rigidlab.core.modal import LinearModel

        v = real_number(speed, "speed", expected="a finite forward speed (m/s)")
        emb = dataclasses.replace(self.embedding, v0=_read_only(v * self.embedding.v0))
        moving = v != 0.0
        return LinearModel(self.M, self.K0 + (v * v) * self.K2, v * self.C1 if moving else None,
                           v * self.G1 if moving else None, velocity_map=self.velocity_map,
                           position_rate_map=v * self.position_rate_map if moving else None, embedding=emb,
                           derivative_error=self.derivative_error)


def whipple_speed_model(parameters: Any = "meijaard2007", *, reference_speed: float = 10.0) -> WhippleSpeedModel:
    """The coefficients of the linearized bicycle in the speed (see :class:`WhippleSpeedModel`); cached.

    Two calls of :func:`rigidlab.core.modal.linearize`, on :func:`whipple_bicycle`
    at rest and at ``reference_speed``; the result is kept per parameter
    set and reference speed (eight of them), so a sweep over the speed, a
    root search for the weave and capsize speeds or a scene's modes cost
    one eigenvalue problem a speed.

    Parameters
    ----------
    parameters : str or WhippleParameters
    reference_speed : float, keyword-only
        The second speed linearized (m/s, finite and > 0); 10 m/s, the top of
        the paper's table.

    Returns
    -------
    WhippleSpeedModel
        Shared between calls: read-only arrays.

    Raises
    ------
    ValueError
        For unknown parameters or a reference speed that is not finite and > 0.
    """
    p = _parameters(parameters)
    vr = real_number(reference_speed, "reference_speed", expected="a finite speed > 0 (m/s)")
    if not vr > 0.0:
        raise ValueError(f"reference_speed: expected a finite speed > 0 (m/s), got {vr!r}")
    return _speed_model(p, vr)


@functools.lru_cache(maxsize=8)
def _speed_model(p: WhippleParameters, vr: float) -> WhippleSpeedModel:
    from rigidlab.core.modal import linearize

    rest = linearize(whipple_bicycle(0.0, p))
    ride = linearize(whipple_bicycle(vr, p))
    for name in ("basis", "velocity_basis", "q0"):
        if not np.array_equal(getattr(rest.embedding, name), getattr(ride.embedding, name)):  # one configuration
            raise RuntimeError(f"the bicycle's embedding ({name}) differs between 0 and {vr} m/s")
    if not (np.array_equal(rest.M, ride.M) and np.array_equal(rest.velocity_map, ride.velocity_map)):
        raise RuntimeError(f"the bicycle's mass matrix or velocity map differs between 0 and {vr} m/s")
    zero = np.zeros_like(ride.M)
    C = ride.C if ride.C is not None else zero
    G = ride.G if ride.G is not None else zero
    Y = ride.position_rate_map if ride.position_rate_map is not None else np.zeros((ride.n_dof, ride.n_dof))
    emb = dataclasses.replace(ride.embedding, v0=_read_only(ride.embedding.v0 / vr))
    arrays = [_read_only(a) for a in (rest.M, rest.K, (ride.K - rest.K) / (vr * vr), C / vr, G / vr,
                                      rest.velocity_map, Y / vr)]
    return WhippleSpeedModel(*arrays, emb, max(rest.derivative_error, ride.derivative_error), vr)


def _read_only(a: np.ndarray) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.setflags(write=False)
    return out


# ------------------------------------------------------------------ a push and the response
def whipple_push(system: Any, impulse: float):
    """The state just after a lateral impulse on the rear frame's centre of mass (a push from the side).

    The velocities jump by the constrained impulse response, Gauss's
    principle for impulses: ``dv = M^-1 J^T P`` projected onto the
    constraints in the mass metric, ``dv -= M^-1 D^T (D M^-1 D^T)^-1 D dv``
    (all rows of ``D``, the rolling ones too); the positions do not change.

    Parameters
    ----------
    system : System
        A :func:`whipple_bicycle` (its current state is pushed; not changed).
    impulse : float
        ``P`` (N s) along the paper's ``y``: positive pushes to the right.

    Returns
    -------
    State
        Put it in with ``system.set_state(state)``.
    """
    P = real_number(impulse, "impulse", expected="a finite impulse (N s)")
    names = tuple(b.name for b in system.bodies)
    if names != _BODIES:
        raise ValueError(f"system: expected a whipple_bicycle System (bodies {_BODIES}), got bodies {names}")
    ev = system.evaluate()
    M = np.asarray(ev.M)
    D = np.asarray(ev.D)[np.asarray(ev.independent)]
    n = len(names)
    J = np.zeros(6 * n)
    J[3 * _FRAME : 3 * _FRAME + 3] = (0.0, -P, 0.0)  # the paper's +y is the engine's -y
    Mi = np.linalg.inv(M)  # diag(m I, I_body): 3 x 3 blocks
    dv = Mi @ J
    MiDt = Mi @ D.T
    dv -= MiDt @ np.linalg.solve(D @ MiDt, D @ dv)
    return system.state.displaced(dv=dv)


def whipple_linear_response(model: Any, velocity_change: Any, t: Any, parameters: Any = "meijaard2007"):
    """Lean and steer of the linear model after a velocity jump at ``t = 0`` from the reference.

    The jump ``dv`` (Newton-Euler velocities ``[R_dot, omega_body]`` of the
    System, e.g. ``whipple_push(system, P).v - system.state.v``) becomes the
    tangent velocity ``z_d = [dR_dot, A dOmega_body]`` and the linear state
    ``x0 = [0, N_v^T z_d]``; then ``x(t) = expm(A t) x0`` with ``A`` the
    model's state matrix and ``z = N u`` gives lean and steer as in
    :func:`whipple_modes`.

    Returns
    -------
    (lean, steer) : two (n_times,) ndarrays (rad, the paper's signs)
    """
    p = _parameters(parameters)
    emb = model.embedding
    n = emb.n_bodies
    dv = float_array(velocity_change, "velocity_change").reshape(-1)
    times = float_array(t, "t").reshape(-1)
    from rigidlab.core.multibody._engine import matrices

    A_bodies = matrices(emb.q0[3 * n :].reshape(n, 4))
    zd = np.concatenate([dv[: 3 * n], np.einsum("nij,nj->ni", A_bodies, dv[3 * n :].reshape(n, 3)).ravel()])
    f = emb.basis.shape[1]
    x0 = np.concatenate([np.zeros(f), emb.velocity_basis.T @ zd])
    A = model.state_matrix()
    X = np.array([scipy.linalg.expm(A * ti) @ x0 for ti in times])
    z = X[:, :f] @ emb.basis.T
    th_frame = z[:, 3 * n + 3 * _FRAME : 3 * n + 3 * _FRAME + 3]
    th_fork = z[:, 3 * n + 3 * _FORK : 3 * n + 3 * _FORK + 3]
    return th_frame[:, 0], (th_fork - th_frame) @ p.steer_axis


# ------------------------------------------------------------------ a ride
@dataclass(frozen=True)
class WhippleRide:
    """A nonlinear run of :func:`whipple_bicycle` (:func:`whipple_ride`); read-only arrays.

    Attributes
    ----------
    t : (n,) s.
    q : (n, 28) positions ``[R | p]`` of the four bodies.
    v : (n, 24) velocities ``[R_dot | omega_body]``.
    lean, steer, yaw : (n,) rad, the paper's signs (:func:`whipple_angles`).
    rear_contact, front_contact : (n, 3) contact points on the ground (m, engine frame).
    fallen : bool
        The lean passed ``lean_limit``, a wheel left the ground or its
        contact was lost: the run ends there.
    end : str
        Why the run ended before ``t[-1]`` asked for ("" if it did not).
    final_state : RunState
        The state at ``t[-1]`` (positions, velocities, the wheels' contact
        parameters; it pickles): ``whipple_ride(system, t2,
        initial=ride.final_state)`` continues the ride, on this System or a
        new ``whipple_bicycle`` of the same speed and parameters.
    """

    t: np.ndarray
    q: np.ndarray = field(repr=False)
    v: np.ndarray = field(repr=False)
    lean: np.ndarray = field(repr=False)
    steer: np.ndarray = field(repr=False)
    yaw: np.ndarray = field(repr=False)
    rear_contact: np.ndarray = field(repr=False)
    front_contact: np.ndarray = field(repr=False)
    fallen: bool
    end: str
    final_state: Any = field(default=None, repr=False)

    @property
    def poses(self) -> np.ndarray:
        """(n, 4, 7) per body (the System's order) its centre of mass ``R`` (m) and Euler parameters
        (scalar first), as sampled: consecutive samples' parameters are continuous (no sign flip)."""
        n = self.t.size
        return np.concatenate([self.q[:, :12].reshape(n, 4, 3), self.q[:, 12:].reshape(n, 4, 4)], axis=2)

    @property
    def contact_points(self) -> np.ndarray:
        """(n, 2, 3) rear and front contact points (m); where a contact is not known (a ride that could
        not start), the ground point below the wheel's centre."""
        points = np.stack([self.rear_contact, self.front_contact], axis=1)
        below = self.poses[:, [0, 3], :3] * np.array([1.0, 1.0, 0.0])
        return np.where(np.isfinite(points), points, below)

    @property
    def rear_speed(self) -> np.ndarray:
        """(n,) speed of the rear wheel's centre (m/s)."""
        return np.linalg.norm(self.v[:, 0:3], axis=1)


def whipple_ride(system: Any, t: Any, *, parameters: Any = "meijaard2007",
                 lean_limit: float = default_angle(WHIPPLE_FALL_LEAN),
                 rtol: float = RIDE_RTOL, atol: float = RIDE_ATOL, piece: float = 0.25,
                 initial: Any = None,
                 degrees: bool = False) -> WhippleRide:
    """Ride a :func:`whipple_bicycle` from its current state (or ``initial``) over the output times ``t`` (DOP853).

    The System's :meth:`~rigidlab.core.multibody.System.simulate` runs in pieces of
    ``piece`` seconds, each continuing from the last one's final state; the
    ride ends after the first sample whose lean passes ``lean_limit``, at a
    separation (a wheel's normal force reaching zero), or when the contact
    cannot be followed any more (a wheel lying flat), with ``fallen`` set
    and the reason in ``end``. The System's current state is left as it
    was; a ride without ``initial`` moves its contacts' warm start to the
    ride's end (for callers that keep the System between rides; continuing
    from ``ride.final_state`` needs no kept System).

    Parameters
    ----------
    system : System
        From :func:`whipple_bicycle`, in the state to start from (e.g. after
        ``system.set_state(whipple_push(system, P))``).
    t : (n,) array_like
        Increasing output times (s), from the state's time.
    lean_limit : float, keyword-only
        ``|lean|`` (rad) at which the bicycle counts as fallen.
    rtol, atol : float, keyword-only
        DOP853's tolerances.
    piece : float, keyword-only
        Simulated seconds per call of ``simulate`` (the lean is checked
        after each).
    initial : RunState or None, keyword-only
        Start from this state (``ride.final_state`` of an earlier ride, on
        this System or another ``whipple_bicycle`` of the same speed and
        parameters) instead of the System's current one: the ride continues
        that ride, the wheels' contact Newton from the parameters it ended
        with. ``t[0] >= initial.t``.
    degrees : bool, keyword-only
        True: ``lean_limit`` is in degrees (the result holds radians).

    Returns
    -------
    WhippleRide
    """
    lean_limit = radians(lean_limit, "lean_limit", degrees)
    from rigidlab.core.contact import ContactError
    from rigidlab.core.integrators import IntegrationError
    from rigidlab.core.multibody import AssemblyError, RunState, SingularSystemError

    p = _parameters(parameters)
    times = float_array(t, "t", expected="output times (s)").reshape(-1)
    if times.size < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise ValueError(f"t: expected at least two finite, increasing times (s), got {short_repr(t)}")
    limit = real_number(lean_limit, "lean_limit", expected="a lean (rad) > 0")
    if initial is not None and not isinstance(initial, RunState):
        raise ArgumentError("initial", f"initial: expected a RunState (ride.final_state), got {short_repr(initial)}")
    rear_c, front_c = system.contacts
    parts: list[dict] = []
    end = ""
    fallen = False
    i = 0
    at = initial  # the state the next piece starts from (None: the System's current state)
    last = None  # the ride's last State (with its contacts' surface parameters)
    while i < times.size - 1:
        j = int(np.searchsorted(times, times[i] + piece, side="right"))
        j = min(max(j, i + 2), times.size)
        try:
            traj = system.simulate(times[i:j], rtol=rtol, atol=atol, initial=at)
        except (ContactError, SingularSystemError, IntegrationError, AssemblyError) as exc:
            end = f"the run stopped near t = {times[i]:.3f} s: {exc}"
            fallen = True
            break
        q = np.asarray(traj.q)
        ang = whipple_angles(q, p)
        part = {"t": np.asarray(traj.t), "q": q, "v": np.asarray(traj.v), "lean": ang.lean, "steer": ang.steer,
                "yaw": ang.yaw, "rear": traj.contact(rear_c).point, "front": traj.contact(front_c).point}
        over = np.flatnonzero(np.abs(ang.lean) > limit)
        if over.size:
            part = {k: a[: over[0] + 1] for k, a in part.items()}
            end = f"the bicycle fell: its lean passed {math.degrees(limit):.0f} deg at t = {part['t'][-1]:.3f} s"
            fallen = True
        elif traj.status == "separated":
            sep = traj.separations[-1]
            end = f"the {sep.contact.name.split('_')[0]} wheel left the ground at t = {sep.t:.3f} s"
            fallen = True
        keep = over[0] + 1 if over.size else traj.t.size
        parts.append(part if not parts else {k: a[1:] for k, a in part.items()})
        at = traj.run_state(int(keep) - 1)
        last = traj.state(int(keep) - 1)
        if fallen:
            break
        i = j - 1
    if not parts:
        st = system.state if initial is None else initial
        ang = whipple_angles(st.q, p)
        one = {"t": np.array([st.t]), "q": st.q[None], "v": st.v[None], "lean": ang.lean.reshape(1),
               "steer": ang.steer.reshape(1), "yaw": ang.yaw.reshape(1), "rear": np.full((1, 3), np.nan),
               "front": np.full((1, 3), np.nan)}
        parts = [one]
    out = {k: np.concatenate([pt[k] for pt in parts]) for k in parts[0]}
    for a in out.values():
        a.setflags(write=False)
    if initial is None and last is not None:
        # a ride from the System's current state leaves the contacts' warm start at the ride's end (the state
        # itself as it was), as before RunState: a caller that keeps the System between rides continues there
        start = system.state
        system.set_state(last)
        system.set_state(start)
    if at is None:  # (the ride could not start: its start)
        at = initial if initial is not None else _run_state_of(system)
    return WhippleRide(out["t"], out["q"], out["v"], out["lean"], out["steer"], out["yaw"], out["rear"], out["front"],
                       fallen, end, at)


def _run_state_of(system: Any):
    """The System's current state as a :class:`~rigidlab.core.multibody.RunState` (no contact warm start)."""
    from rigidlab.core.multibody import RunState

    st = system.state
    return RunState(st.t, st.q, st.v)


# ------------------------------------------------------------------ a ride in stretches, and the modes over speed
def whipple_ride_from(speed: float, t: Any, *, initial: Any = None, impulse: float = 0.0,
                      parameters: Any = "meijaard2007", lean_limit: float = default_angle(WHIPPLE_FALL_LEAN),
                      rtol: float = RIDE_RTOL, atol: float = RIDE_ATOL,
                      degrees: bool = False) -> WhippleRide:
    """A stretch of a ride of a new :func:`whipple_bicycle` at ``speed``: from upright, or from ``initial``,
    pushed by ``impulse`` at the start.

    A viewer computes a ride stretch by stretch, each from the last one's
    ``final_state`` (``initial=ride.final_state``: the continuation, contact
    warm starts included), and a push from any sample shown
    (``initial=RunState(t[j], q[j], v[j])``, ``impulse=P``: the velocities
    jump by :func:`whipple_push`). The System is a fresh copy of the cached
    build each time (nothing is kept between calls).

    Parameters
    ----------
    speed : float
        Forward speed of the bicycle built (m/s).
    t : (n,) array_like
        Increasing output times (s), ``t[0]`` = the start's time (0 for upright, else ``initial.t``).
    initial : RunState or None, keyword-only
        The state to start from (None: upright and straight at ``speed``, ``t = 0``). A state without
        contact parameters (made from a sample) is put into the System, whose contacts then start from
        the upright run's points.
    impulse : float, keyword-only
        Lateral push at the start (N s, positive to the right; :func:`whipple_push`).
    parameters, lean_limit, rtol, atol :
        As :func:`whipple_ride`.
    degrees : bool, keyword-only
        True: ``lean_limit`` is in degrees (the result holds radians).

    Returns
    -------
    WhippleRide
        Its ``end`` text gives times on the same clock as ``t``.
    """
    lean_limit = radians(lean_limit, "lean_limit", degrees)
    from rigidlab.core.multibody import RunState

    P = real_number(impulse, "impulse", expected="a finite impulse (N s)")
    if initial is not None and not isinstance(initial, RunState):
        raise ArgumentError("initial", f"initial: expected a RunState or None, got {short_repr(initial)}")
    system = whipple_bicycle(speed, parameters)
    if initial is not None and (P != 0.0 or initial.contact_parameters is None):
        system.set_state(dataclasses.replace(system.state, t=initial.t, q=np.asarray(initial.q),
                                             v=np.asarray(initial.v)))
        initial = None
    if P != 0.0:
        system.set_state(whipple_push(system, P))
    return whipple_ride(system, t, parameters=parameters, lean_limit=lean_limit, rtol=rtol, atol=atol,
                        initial=initial)


def whipple_modes_at(speed: float, parameters: Any = "meijaard2007") -> tuple[WhippleMode, ...]:
    """:func:`whipple_modes` of the bicycle linearized at ``speed`` (m/s), from :func:`whipple_speed_model`
    (two linearizations per parameter set and process, then one eigenvalue problem a speed; Eqs. 8.110-8.124)."""
    return whipple_modes(whipple_speed_model(parameters).linear_model(speed), parameters)


@dataclass(frozen=True)
class WhippleSweep:
    """The bicycle's four modes against speed, from the engine and from the paper's equations (read-only).

    Columns follow :func:`whipple_modes`: weave (the pair: ``+Im`` first, or
    the two largest real roots below the weave onset), weave, capsize,
    castering.

    Attributes
    ----------
    speeds : (n,) m/s, increasing.
    eigenvalues : (n, 4) complex, the linearized System (:func:`whipple_modes_at`).
    reference : (n, 4) complex, the paper's equations (:func:`whipple_bicycle_reference`).
    stable_speeds : (v_w, v_c) m/s, where the engine's largest real part turns negative and positive
        again (Brent on :func:`whipple_modes_at`, 1e-9 m/s); NaN if not crossed in ``speeds``.
    reference_stable_speeds : (v_w, v_c) m/s, the same from the paper's equations (1e-14 m/s).
    """

    speeds: np.ndarray
    eigenvalues: np.ndarray = field(repr=False)
    reference: np.ndarray = field(repr=False)
    stable_speeds: tuple[float, float]
    reference_stable_speeds: tuple[float, float]

    def curves(self, *, engine: bool = False) -> dict[str, np.ndarray]:
        """(n,) series of the paper's figure: ``"weave"`` and ``"weave_2"`` (real parts; equal when
        oscillating), ``"weave_frequency"`` (``Im s`` > 0, NaN while real), ``"capsize"``, ``"castering"``
        (real parts, 1/s); of the paper's equations, or of the engine with ``engine=True``."""
        s = self.eigenvalues if engine else self.reference
        return {"weave": s[:, 0].real, "weave_2": s[:, 1].real,
                "weave_frequency": np.where(s[:, 0].imag > 0, s[:, 0].imag, np.nan),
                "capsize": s[:, 2].real, "castering": s[:, 3].real}


def _ordered(s: Any) -> np.ndarray:
    """Four eigenvalues in :func:`whipple_modes`' order (weave +Im, weave, capsize, castering)."""
    order = {name: i for i, name in enumerate(WHIPPLE_MODE_NAMES)}
    pairs = sorted(zip(whipple_mode_names(s), np.asarray(s, dtype=complex)),
                   key=lambda m: (order[m[0]], -m[1].imag, -m[1].real))
    return np.array([x for _, x in pairs])


def _crossings(speeds: np.ndarray, largest: np.ndarray, f: Any, xtol: float) -> tuple[float, float]:
    """(first speed where ``f`` turns <= 0, the next where it turns > 0) by Brent between grid speeds."""
    out = [math.nan, math.nan]
    for i in range(speeds.size - 1):
        a, b = largest[i], largest[i + 1]
        if (a > 0) != (b > 0):
            root = brentq(f, speeds[i], speeds[i + 1], xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=200)
            if a > 0 and math.isnan(out[0]):
                out[0] = float(root)
            elif a <= 0 and not math.isnan(out[0]) and math.isnan(out[1]):
                out[1] = float(root)
    return out[0], out[1]


def whipple_sweep(speeds: Any = np.linspace(0.0, 10.0, 101), parameters: Any = "meijaard2007") -> WhippleSweep:
    """Eigenvalues against speed, the paper's figure: the linearized System and the paper's equations.

    Each speed costs one eigenvalue problem of :func:`whipple_speed_model`
    and one of the paper's ``A`` (about 5 ms together); the self-stable
    band, where every real part is negative, by Brent's method on each.

    Parameters
    ----------
    speeds : (n,) array_like
        At least two increasing forward speeds (m/s).
    parameters : str or WhippleParameters

    Returns
    -------
    WhippleSweep
    """
    v = float_array(speeds, "speeds", expected="increasing speeds (m/s)").reshape(-1)
    if v.size < 2 or not np.all(np.isfinite(v)) or np.any(np.diff(v) <= 0):
        raise ArgumentError("speeds", f"speeds: expected at least two finite, increasing speeds (m/s), "
                                      f"got {short_repr(speeds)}")
    ref = whipple_bicycle_reference(parameters)
    engine = np.array([[m.eigenvalue for m in whipple_modes_at(x, parameters)] for x in v])
    paper = np.array([_ordered(ref.eigenvalues(x)) for x in v])

    def top(x: float) -> float:
        return max(m.eigenvalue.real for m in whipple_modes_at(x, parameters))

    def top_ref(x: float) -> float:
        return float(np.max(ref.eigenvalues(x).real))

    band = _crossings(v, engine.real.max(axis=1), top, 1e-9)
    band_ref = _crossings(v, paper.real.max(axis=1), top_ref, 1e-14)
    return WhippleSweep(_read_only(v), _read_only_c(engine), _read_only_c(paper), band, band_ref)


def _read_only_c(a: np.ndarray) -> np.ndarray:
    out = np.array(a, dtype=complex)
    out.setflags(write=False)
    return out
