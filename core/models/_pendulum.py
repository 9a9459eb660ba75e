"""Pendulum chains: n links on revolute joints about parallel horizontal axes, and their reduced equations."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigidlab.core._validation import output_times, positive_integer, radians, real_number
from rigidlab.core.integrators import integrate
from rigidlab.core.multibody import System

__all__ = ["MAX_LINKS", "ROD_RADIUS_RATIO", "ReducedChainMotion", "pendulum_chain", "pendulum_chain_reduced"]

#: Most links of a chain (:func:`pendulum_chain`, :func:`pendulum_chain_reduced`). The assembly of a System
#: analyses the rank of its constraint rows densely, a cost cubic in the number of links: 100 links take 0.5 s,
#: 200 take 15 s and 300 about a minute on the development machine (2 cores), so a chain of 10**6 would never
#: finish; the reduced equations solve an n x n system per right-hand side. Longer chains are refused.
MAX_LINKS = 300

#: Radius of a rod link over its length: it gives the rod its axial moment
#: ``m r^2 / 2``, which revolute joints about parallel axes never excite
#: (the transverse moments stay the slender-rod ``m L^2 / 12``), and keeps
#: the mass matrix regular.
ROD_RADIUS_RATIO = 0.01


def _chain_arguments(n: Any, length: Any, mass: Any, kind: Any, tilt: Any, gravity: Any):
    """Validated ``(n, L, m, tilt, g)`` of a pendulum chain."""
    n = positive_integer(n, "n")
    if n > MAX_LINKS:
        raise ValueError(f"n: expected a number of links from 1 to core.models._pendulum.MAX_LINKS = {MAX_LINKS} (the "
                         f"assembly's cost grows as n^3: 300 links take about a minute), got {n}")
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
    return n, L, m, tilt, g


def pendulum_chain(
    n: int,
    length: float = 1.0,
    mass: float = 1.0,
    kind: str = "rod",
    *,
    tilt: float = 0.0,
    gravity: float = 9.81,
    degrees: bool = False,
) -> System:
    """A chain of ``n`` pendulum links hanging from the origin, at rest.

    Link ``k`` hangs from the end of link ``k - 1`` (link 0 from the
    ground at the origin) on a revolute joint about the global x axis; the
    chain lies in the y-z plane and hangs along -z (global +z is up).

    Parameters
    ----------
    n : int
        Number of links, 1 to :data:`MAX_LINKS` (300: building the chain
        takes about a minute there, its cost growing as ``n^3``).
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
    degrees : bool, keyword-only
        True: ``tilt`` is in degrees.

    Returns
    -------
    System
        Assembled; ``system.bodies[k]`` and ``system.joints[k]`` are link
        ``k`` and the joint above it (named ``"link<k>"``, ``"joint<k>"``).
    """
    tilt = radians(tilt, "tilt", degrees)
    n, L, m, tilt, g = _chain_arguments(n, length, mass, kind, tilt, gravity)
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


@dataclass(frozen=True)
class ReducedChainMotion:
    """Motion of a planar pendulum chain in its joint angles (see :func:`pendulum_chain_reduced`).

    Attributes
    ----------
    t : (n_times,) ndarray
        Output times (s).
    angles : (n_times, n) ndarray
        Absolute angle ``phi_k`` of link ``k`` from the downward vertical,
        positive about +x (rad): the link points along ``(0, sin phi_k,
        -cos phi_k)``.
    rates : (n_times, n) ndarray
        ``phi_k_dot`` (rad/s), the links' angular velocity about +x.
    centres : (n_times, n, 3) ndarray
        Centres of mass of the links, global (m): the positions of
        ``system.bodies[k]`` of :func:`pendulum_chain`.
    """

    t: np.ndarray  # (n_times,)
    angles: np.ndarray  # (n_times, n)
    rates: np.ndarray  # (n_times, n)
    centres: np.ndarray  # (n_times, n, 3)


@dataclass(frozen=True)
class _ReducedChain:
    """The reduced equations as a model of :func:`rigidlab.core.integrators.integrate`."""

    state_size: int
    rhs: Any


def pendulum_chain_reduced(
    n: int,
    t: Any,
    length: float = 1.0,
    mass: float = 1.0,
    kind: str = "rod",
    *,
    tilt: float = 0.0,
    gravity: float = 9.81,
    rtol: float = 1e-13,
    atol: float = 1e-13,
    degrees: bool = False,
) -> ReducedChainMotion:
    """The chain of :func:`pendulum_chain` from its reduced Lagrange equations in the joint angles.

    An independent formulation of the same model (minimal coordinates, no
    constraints), integrated by scipy's DOP853 from the straight chain
    tilted by ``tilt`` and at rest at ``t[0]``: the reference that tests
    and benchmarks compare :meth:`rigidlab.core.multibody.System.simulate` with.

    With ``a_ik = L`` for ``i < k``, ``c L`` for ``i = k`` (``c = 1/2`` for
    rods, 1 for point masses) and 0 otherwise, the centre of link ``k`` is
    ``sum_i a_ik e(phi_i)``, ``e = (0, sin, -cos)``; with ``B = m a a^T``
    and ``J`` the transverse moment about the centre (``m L^2 / 12`` for
    rods, 0 for point masses) the equations are

    .. math::

        \\sum_j [B_{ij} \\cos(\\phi_i - \\phi_j) + J \\delta_{ij}] \\ddot\\phi_j
        = -\\sum_j B_{ij} \\sin(\\phi_i - \\phi_j) \\dot\\phi_j^2
        - m g \\Big(\\sum_k a_{ik}\\Big) \\sin \\phi_i

    (the axial moment of the rods never enters: the axes are parallel).

    Parameters
    ----------
    n, length, mass, kind, tilt, gravity
        As :func:`pendulum_chain` (n links, m, kg, ``"rod"`` or
        ``"point"``, rad, m/s^2).
    t : (n_times,) array_like
        Non-decreasing output times (s), at least one; the chain is
        released at ``t[0]``.
    rtol, atol : float, keyword-only
        DOP853's tolerances on the angles (rad) and rates (rad/s), > 0;
        ``rtol >= core.integrators.MIN_RTOL`` (2.2e-14).
    degrees : bool, keyword-only
        True: ``tilt`` is in degrees (the result holds radians).

    Returns
    -------
    ReducedChainMotion

    Raises
    ------
    ValueError
        For bad arguments (``n`` above :data:`MAX_LINKS`, ``rtol`` below
        ``rigidlab.core.integrators.MIN_RTOL``).
    core.integrators.IntegrationError
        When DOP853 fails or needs more than ``rigidlab.core.integrators.MAX_STEPS``
        right-hand sides (a run too long for its tolerances stops after
        ``rigidlab.core.integrators.PACE_CHECK_CALLS``, see
        :func:`rigidlab.core.integrators.integrate`).
    """
    tilt = radians(tilt, "tilt", degrees)
    n, L, m, tilt, g = _chain_arguments(n, length, mass, kind, tilt, gravity)
    times = output_times(t)
    tolerances = []
    for name, value in (("rtol", rtol), ("atol", atol)):
        v = real_number(value, name, expected="a finite tolerance > 0")
        if not v > 0:
            raise ValueError(f"{name}: expected a finite tolerance > 0, got {v!r}")
        tolerances.append(v)
    offset = 0.5 if kind == "rod" else 1.0
    J = m * L * L / 12.0 if kind == "rod" else 0.0
    i, k = np.indices((n, n))
    a = np.where(i < k, L, 0.0) + np.where(i == k, offset * L, 0.0)
    B = m * a @ a.T
    weight = m * g * a.sum(axis=1)
    eye_J = J * np.eye(n)

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        phi, rate = y[:n], y[n:]
        d = phi[:, None] - phi[None, :]
        M = B * np.cos(d) + eye_J
        return np.concatenate([rate, np.linalg.solve(M, -(B * np.sin(d)) @ (rate * rate) - weight * np.sin(phi))])

    y0 = np.concatenate([np.full(n, tilt), np.zeros(n)])
    if times[-1] > times[0]:
        model = _ReducedChain(2 * n, rhs)
        y = np.array(integrate(model, y0, (float(times[0]), float(times[-1])), method="DOP853", rtol=tolerances[0],
                               atol=tolerances[1], t_eval=times).states)
    else:
        y = np.tile(y0, (times.size, 1))
    angles, rates = y[:, :n].copy(), y[:, n:].copy()
    e = np.stack([np.zeros_like(angles), np.sin(angles), -np.cos(angles)], axis=-1)
    centres = np.einsum("ik,tid->tkd", a, e)
    return ReducedChainMotion(times.copy(), angles, rates, centres)
