"""Planar four-bar linkage: three uniform rods on four revolute joints, a spring and gravity.

Serve it with ``rigidlab serve --model examples/four_bar.py``. The linkage
moves in the x-z plane (joint axes along global y): a crank from the ground
pivot A = (0, 0, 0), a coupler, and a rocker to the ground pivot
D = (ground, 0, 0). A spring pulls the coupler's middle towards a point on
the ground above the linkage. The System is built at rest with the crank at
``crank_deg`` (the simulation releases it from there); the mode-shapes panel
linearizes it about the nearest static equilibrium (the single mode of a
one-degree-of-freedom loop).
"""

import math

import numpy as np

from rigidlab.core.multibody import System

PARAMETERS = {
    "crank_deg": (60.0, 20.0, 160.0, "deg", "Crank angle at release"),
    "spring_k": (200.0, 0.0, 1000.0, "N/m", "Spring stiffness"),
    "coupler_mass": (2.0, 0.2, 10.0, "kg", "Coupler mass"),
}

CRANK, COUPLER, ROCKER, GROUND = 0.4, 1.0, 0.8, 0.9  # link lengths (m)


def _circles(p0, r0, p1, r1):
    """The intersection of two circles in the x-z plane above the line p0-p1 (the linkage's assembly)."""
    d = float(np.linalg.norm(p1 - p0))
    if not abs(r0 - r1) < d < r0 + r1:
        raise ValueError(f"crank_deg: the linkage cannot be assembled at this crank angle (distance {d:.3g} m)")
    a = (r0 * r0 - r1 * r1 + d * d) / (2.0 * d)
    h = math.sqrt(max(r0 * r0 - a * a, 0.0))
    e = (p1 - p0) / d
    normal = np.array([-e[2], 0.0, e[0]])  # e turned by +90 deg in the x-z plane
    return p0 + a * e + h * normal


def build(crank_deg=60.0, spring_k=200.0, coupler_mass=2.0):
    """The four-bar at rest with the crank at ``crank_deg`` from the ground line (deg)."""
    system = System(gravity=(0.0, 0.0, -9.81))
    theta = math.radians(crank_deg)
    A = np.zeros(3)
    D = np.array([GROUND, 0.0, 0.0])
    B = A + CRANK * np.array([math.cos(theta), 0.0, math.sin(theta)])
    C = _circles(B, COUPLER, D, ROCKER)
    crank = system.add_rod("crank", A, B, mass=1.0, radius=0.02)
    coupler = system.add_rod("coupler", B, C, mass=coupler_mass, radius=0.02)
    rocker = system.add_rod("rocker", D, C, mass=1.5, radius=0.02)
    y = (0.0, 1.0, 0.0)
    system.add_joint("revolute", system.ground, crank, point=A, axis=y, name="A")
    system.add_joint("revolute", crank, coupler, point=B, axis=y, name="B")
    system.add_joint("revolute", coupler, rocker, point=C, axis=y, name="C")
    system.add_joint("revolute", system.ground, rocker, point=D, axis=y, name="D")
    middle = 0.5 * (B + C)
    if spring_k > 0.0:
        system.add_spring_damper(system.ground, (0.45, 0.0, 1.4), coupler, middle, stiffness=spring_k,
                                 damping=0.5, free_length=0.5, name="spring")
    return system
