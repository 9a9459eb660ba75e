"""Linkage models: a slider-crank driven by a motor and a spatial double pendulum."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigidlab.core._validation import default_angle, radians, real_number
from rigidlab.core.multibody import Body, Joint, Motor, System

from ._pendulum import ROD_RADIUS_RATIO

__all__ = ["SliderCrank", "SpatialDoublePendulum", "slider_crank", "spatial_double_pendulum"]


def _positive(x: Any, name: str, unit: str) -> float:
    v = real_number(x, name, expected=f"a finite number > 0 ({unit})")
    if not v > 0:
        raise ValueError(f"{name}: expected a finite number > 0 ({unit}), got {v!r}")
    return v


def _rod_inertia(mass: float, length: float) -> tuple[float, float, float]:
    """Slender rod along its body z axis: transverse m L^2 / 12, axial m r^2 / 2 (r = ROD_RADIUS_RATIO L)."""
    r = ROD_RADIUS_RATIO * length
    return (mass * length**2 / 12.0, mass * length**2 / 12.0, 0.5 * mass * r * r)


def _z_to(direction: np.ndarray) -> tuple[float, float, float, float]:
    """Euler parameters of the shortest rotation taking the body z axis to ``direction`` (unit)."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ direction)
    if c < -1.0 + 1e-12:
        return (0.0, 1.0, 0.0, 0.0)
    axis = np.cross(z, direction)
    w = math.sqrt(0.5 * (1.0 + c))
    v = axis / (2.0 * w)
    return (w, float(v[0]), float(v[1]), float(v[2]))


# ------------------------------------------------------------------ slider-crank
@dataclass(frozen=True)
class SliderCrank:
    """A slider-crank mechanism in the x-z plane and the handles a scene needs.

    The crank turns about the global -y axis through the origin, so its
    angle ``phi`` runs from +x towards +z; the slider moves along the x axis.
    Joints: crank-ground revolute, crank-rod spherical, rod-slider universal
    (cross arms along y on the slider and normal to the rod in the plane on
    the rod), slider-ground prismatic: 5 + 3 + 4 + 5 = 17 independent
    equations for three bodies, one degree of freedom, which the motor
    drives (no redundant constraints, so every reaction is unique).

    Attributes
    ----------
    system : System
    crank, rod, slider : Body
    crank_joint, crank_rod_joint, rod_slider_joint, slider_joint : Joint
    motor : Motor
        Drives the crank joint: ``phi(t) = phi0 + speed t``.
    crank_length, rod_length : float
        r and l (m).
    phi0 : float
        Crank angle at t = 0 (rad).
    speed : float
        Crank speed (rad/s).
    """

    system: System
    crank: Body
    rod: Body
    slider: Body
    crank_joint: Joint
    crank_rod_joint: Joint
    rod_slider_joint: Joint
    slider_joint: Joint
    motor: Motor
    crank_length: float
    rod_length: float
    phi0: float
    speed: float

    def slider_position(self, phi: Any, *, degrees: bool = False) -> np.ndarray:
        """Closed form x of the slider pin: ``r cos phi + sqrt(l^2 - r^2 sin^2 phi)`` (m), any shape
        (``degrees=True``: ``phi`` in degrees)."""
        phi = np.asarray(radians(phi, "phi", degrees), dtype=float)
        r, l = self.crank_length, self.rod_length
        return r * np.cos(phi) + np.sqrt(l * l - (r * np.sin(phi)) ** 2)

    def slider_velocity(self, phi: Any, phi_dot: Any, *, degrees: bool = False) -> np.ndarray:
        """Closed form x_dot: ``-r phi_dot sin phi (1 + r cos phi / sqrt(l^2 - r^2 sin^2 phi))`` (m/s)
        (``degrees=True``: ``phi`` in degrees, ``phi_dot`` in deg/s)."""
        phi = np.asarray(radians(phi, "phi", degrees), dtype=float)
        phi_dot = radians(phi_dot, "phi_dot", degrees)
        r, l = self.crank_length, self.rod_length
        root = np.sqrt(l * l - (r * np.sin(phi)) ** 2)
        return -r * np.asarray(phi_dot) * np.sin(phi) * (1.0 + r * np.cos(phi) / root)


def slider_crank(
    *,
    crank_length: float = 0.1,
    rod_length: float = 0.3,
    crank_mass: float = 0.5,
    rod_mass: float = 1.0,
    slider_mass: float = 2.0,
    speed: float = default_angle(2.0 * math.pi),
    phi0: float = 0.0,
    gravity: float = 9.81,
    degrees: bool = False,
) -> SliderCrank:
    """A motor-driven slider-crank (crank, connecting rod, slider) at its initial angle, assembled.

    Parameters (keyword-only)
    -------------------------
    crank_length, rod_length : float
        r < l (m).
    crank_mass, rod_mass, slider_mass : float
        kg, > 0. Crank and rod are slender rods; the slider a cube of side
        ``r / 2``.
    speed : float
        Crank speed (rad/s); any real number (0 holds the crank still).
    phi0 : float
        Crank angle at t = 0 (rad), from +x towards +z.
    gravity : float
        g (m/s^2) along -z, >= 0.
    degrees : bool
        True: ``phi0`` in degrees and ``speed`` in deg/s.

    Returns
    -------
    SliderCrank
    """
    phi0 = radians(phi0, "phi0", degrees)
    speed = radians(speed, "speed", degrees)
    r = _positive(crank_length, "crank_length", "m")
    l = _positive(rod_length, "rod_length", "m")
    if not l > r:
        raise ValueError(f"rod_length: expected longer than crank_length={r!r} (a full turn), got {l!r}")
    mc = _positive(crank_mass, "crank_mass", "kg")
    mr = _positive(rod_mass, "rod_mass", "kg")
    ms = _positive(slider_mass, "slider_mass", "kg")
    w = real_number(speed, "speed", expected="a finite crank speed (rad/s)")
    phi0 = real_number(phi0, "phi0")
    g = real_number(gravity, "gravity", expected="a finite g >= 0 (m/s^2)")
    if g < 0:
        raise ValueError(f"gravity: expected a finite g >= 0 (m/s^2), got {g!r}")
    system = System(gravity=(0.0, 0.0, -g))
    u = np.array([math.cos(phi0), 0.0, math.sin(phi0)])
    pin = r * u
    xs = float(r * math.cos(phi0) + math.sqrt(l * l - (r * math.sin(phi0)) ** 2))
    slider_pin = np.array([xs, 0.0, 0.0])
    e_rod = (slider_pin - pin) / l
    crank = system.add_body("crank", mass=mc, inertia=_rod_inertia(mc, r), position=0.5 * pin, orientation=_z_to(u))
    rod = system.add_body("rod", mass=mr, inertia=_rod_inertia(mr, l), position=0.5 * (pin + slider_pin),
                          orientation=_z_to(e_rod))
    side = 0.5 * r
    slider = system.add_body("slider", mass=ms, inertia=(ms * side**2 / 6.0,) * 3, position=slider_pin)
    y_axis = np.array([0.0, 1.0, 0.0])
    crank_joint = system.add_joint("revolute", system.ground, crank, point=(0.0, 0.0, 0.0), axis=-y_axis,
                                   name="crank_joint")
    crank_rod = system.add_joint("spherical", crank, rod, point=pin, name="crank_rod_joint")
    rod_slider = system.add_joint("universal", slider, rod, point=slider_pin, axis=y_axis,
                                  axis_j=np.cross(y_axis, e_rod), name="rod_slider_joint")
    slider_joint = system.add_joint("prismatic", system.ground, slider, point=slider_pin, axis=(1.0, 0.0, 0.0),
                                    name="slider_joint")
    motor = system.add_motor(crank_joint, angle=(lambda t: w * t, lambda t: w, lambda t: 0.0), name="crank_motor")
    # with the motor the mechanism has no free coordinate: the assembly's
    # velocity projection finds the unique velocities (crank at w)
    system.assemble()
    return SliderCrank(system, crank, rod, slider, crank_joint, crank_rod, rod_slider, slider_joint, motor, r, l,
                       phi0, w)


# ------------------------------------------------------------------ spatial double pendulum
@dataclass(frozen=True)
class SpatialDoublePendulum:
    """Two uniform rods on spherical joints, hanging from the origin.

    Attributes
    ----------
    system : System
    links : tuple of Body
    joints : tuple of Joint
    length : float
    """

    system: System
    links: tuple[Body, Body]
    joints: tuple[Joint, Joint]
    length: float


def spatial_double_pendulum(
    length: float = 1.0,
    mass: float = 1.0,
    *,
    tilt: tuple[float, float] = default_angle((0.7, 1.2)),
    azimuth: tuple[float, float] = default_angle((0.0, 1.0)),
    spin: float = default_angle(1.5),
    gravity: float = 9.81,
    degrees: bool = False,
) -> SpatialDoublePendulum:
    """A spatial double pendulum of two uniform rods on spherical joints, assembled.

    Link k hangs from the end of link k-1 (link 0 from the origin); its
    direction makes the angle ``tilt[k]`` with -z, turned by ``azimuth[k]``
    about +z from the x-z plane. The whole pendulum starts turning about the
    vertical axis at ``spin`` rad/s, so the motion is three-dimensional.

    Parameters
    ----------
    length, mass : float
        Of each rod (m, kg), > 0; slender rods with the axial moment of
        :data:`ROD_RADIUS_RATIO`.
    tilt, azimuth : (2,) keyword-only
        Initial directions (rad).
    spin : float, keyword-only
        Initial angular velocity about +z (rad/s).
    gravity : float, keyword-only
        g (m/s^2) along -z, >= 0.
    degrees : bool, keyword-only
        True: ``tilt`` and ``azimuth`` in degrees, ``spin`` in deg/s.

    Returns
    -------
    SpatialDoublePendulum
    """
    tilt = radians(tilt, "tilt", degrees)
    azimuth = radians(azimuth, "azimuth", degrees)
    spin = radians(spin, "spin", degrees)
    L = _positive(length, "length", "m")
    m = _positive(mass, "mass", "kg")
    tilts = [real_number(v, "tilt") for v in np.asarray(tilt, dtype=object).ravel()]
    azis = [real_number(v, "azimuth") for v in np.asarray(azimuth, dtype=object).ravel()]
    if len(tilts) != 2 or len(azis) != 2:
        raise ValueError("tilt, azimuth: expected two angles each (one per link)")
    w = real_number(spin, "spin", expected="a finite rate (rad/s)")
    g = real_number(gravity, "gravity", expected="a finite g >= 0 (m/s^2)")
    if g < 0:
        raise ValueError(f"gravity: expected a finite g >= 0 (m/s^2), got {g!r}")
    system = System(gravity=(0.0, 0.0, -g))
    omega = np.array([0.0, 0.0, w])
    top = np.zeros(3)
    previous: Body = system.ground
    links, joints = [], []
    for k in range(2):
        d = np.array([math.sin(tilts[k]) * math.cos(azis[k]), math.sin(tilts[k]) * math.sin(azis[k]), -math.cos(tilts[k])])
        centre = top + 0.5 * L * d
        body = system.add_body(f"link{k}", mass=m, inertia=_rod_inertia(m, L), position=centre, orientation=_z_to(d),
                               velocity=np.cross(omega, centre), omega=omega)
        joints.append(system.add_joint("spherical", previous, body, point=top, name=f"joint{k}"))
        links.append(body)
        previous = body
        top = top + L * d
    system.assemble()
    return SpatialDoublePendulum(system, (links[0], links[1]), (joints[0], joints[1]), L)
