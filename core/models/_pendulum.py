"""Pendulum chains: n links on revolute joints about parallel horizontal axes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from core._validation import positive_integer, real_number
from core.multibody import System

__all__ = ["ROD_RADIUS_RATIO", "pendulum_chain"]

#: Radius of a rod link over its length: it gives the rod its axial moment
#: ``m r^2 / 2``, which revolute joints about parallel axes never excite
#: (the transverse moments stay the slender-rod ``m L^2 / 12``), and keeps
#: the mass matrix regular.
ROD_RADIUS_RATIO = 0.01


def pendulum_chain(
    n: int,
    length: float = 1.0,
    mass: float = 1.0,
    kind: str = "rod",
    *,
    tilt: float = 0.0,
    gravity: float = 9.81,
) -> System:
    """A chain of ``n`` pendulum links hanging from the origin, at rest.

    Link ``k`` hangs from the end of link ``k - 1`` (link 0 from the
    ground at the origin) on a revolute joint about the global x axis; the
    chain lies in the y-z plane and hangs along -z (global +z is up).

    Parameters
    ----------
    n : int
        Number of links, >= 1.
    length : float
        Link length L (m), > 0.
    mass : float
        Link mass m (kg), > 0.
    kind : str
        ``"rod"``: uniform slender rods (centre of mass at mid-length,
        transverse moments ``m L^2 / 12``, axial ``m r^2 / 2`` with ``r =
        ROD_RADIUS_RATIO * L``); ``"point"``: a point mass at the lower end
        of each massless link (each body is the point mass, with zero
        rotational inertia, and carries its link: the joint above it is at
        distance L from its centre of mass), so the point-mass closed forms
        hold exactly.
    tilt : float, keyword-only
        The straight chain is turned by ``tilt`` (rad) about the x axis
        through the top joint; 0 is the hanging equilibrium. The state is
        at rest either way.
    gravity : float, keyword-only
        g (m/s^2) along -z, >= 0.

    Returns
    -------
    System
        Assembled; ``system.bodies[k]`` and ``system.joints[k]`` are link
        ``k`` and the joint above it (named ``"link<k>"``, ``"joint<k>"``).
    """
    n = positive_integer(n, "n")
    L = real_number(length, "length", expected="a finite length > 0 (m)")
    if not L > 0:
        raise ValueError(f"length: expected a finite length > 0 (m), got {L!r}")
    m = real_number(mass, "mass", expected="a finite mass > 0 (kg)")
    if not m > 0:
        raise ValueError(f"mass: expected a finite mass > 0 (kg), got {m!r}")
    if kind not in ("rod", "point"):
        raise ValueError(f"kind: expected 'rod' or 'point', got {kind!r}")
    tilt = real_number(tilt, "tilt")
    g = real_number(gravity, "gravity", expected="a finite g >= 0 (m/s^2)")
    if g < 0:
        raise ValueError(f"gravity: expected a finite g >= 0 (m/s^2), got {g!r}")
    system = System(gravity=(0.0, 0.0, -g))
    down = np.array([0.0, math.sin(tilt), -math.cos(tilt)])
    p = (math.cos(0.5 * tilt), math.sin(0.5 * tilt), 0.0, 0.0)
    if kind == "rod":
        r = ROD_RADIUS_RATIO * L
        inertia: Any = (m * L * L / 12.0, m * L * L / 12.0, 0.5 * m * r * r)
        offset = 0.5
    else:
        inertia = (0.0, 0.0, 0.0)
        offset = 1.0
    previous = system.ground
    for k in range(n):
        top = k * L * down
        body = system.add_body(f"link{k}", mass=m, inertia=inertia, position=top + offset * L * down, orientation=p)
        system.add_joint("revolute", previous, body, point=top, axis=(1.0, 0.0, 0.0), name=f"joint{k}")
        previous = body
    system.assemble()
    return system
