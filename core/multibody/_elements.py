"""Handles of the items of a :class:`~rigidlab.core.multibody.System` (bodies, joints, drivers, forces).

Every ``System.add_*`` call returns one of these small frozen objects. They
describe the model (constant data fixed when the item was added: masses,
body-frame points and axes, stiffnesses, user callables); the changing
state lives in the System and in trajectories. A handle knows the System
that made it, so an item of another System is refused with a clear error.
Handles compare and hash by identity.

Body-frame data are computed once, when the item is added, from the global
points and axes given in the System's current configuration:
``u_body = A(p).T @ (r_global - R)`` for points and ``a_body = A(p).T @
a_global`` for directions (``A(p)`` maps body to global, Eq. 8.48).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "JOINT_KINDS",
    "Body",
    "Force",
    "Joint",
    "Motor",
    "RotationalSpringDamper",
    "SpringDamper",
    "Torque",
]

#: Joint kinds of :meth:`System.add_joint` and the number of constraint
#: equations (rows) each adds.
JOINT_KINDS = {
    "fixed": 6,
    "spherical": 3,
    "revolute": 5,
    "prismatic": 5,
    "cylindrical": 4,
    "universal": 4,
}


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Body:
    """A rigid body of a System (or the System's ground).

    Attributes
    ----------
    name : str
        Unique within the System; ``"ground"`` for ``system.ground``.
    index : int
        Position of the body in the System's state (``-1`` for the ground).
    mass : float
        kg, > 0 (``inf`` for the ground).
    inertia : (3, 3) ndarray
        Inertia tensor about the centre of mass in the body frame (kg m^2);
        symmetric, positive semi-definite (zero moments allowed: a point
        mass), principal moments satisfying ``J1 + J2 >= J3``.
    """

    name: str
    index: int
    mass: float
    inertia: np.ndarray = field(repr=False)  # (3, 3)
    _owner: Any = field(repr=False, compare=False)

    @property
    def is_ground(self) -> bool:
        """True for ``system.ground``."""
        return self.index < 0


@dataclass(frozen=True, eq=False)
class Joint:
    """A joint between two bodies (either may be the ground).

    Attributes
    ----------
    name : str
    kind : str
        One of :data:`JOINT_KINDS`.
    body_i, body_j : Body
        The reaction of :meth:`MultibodyTrajectory.reaction` acts on
        ``body_j``.
    point : (3,) ndarray
        Joint point, global, in the configuration at which the joint was
        added.
    axis : (3,) ndarray or None
        Unit joint axis, global, at creation (revolute, prismatic,
        cylindrical: the axis of rotation / sliding; universal: the cross
        arm fixed in ``body_i``).
    axis_j : (3,) ndarray or None
        Universal joints only: the cross arm fixed in ``body_j``,
        perpendicular to ``axis``.
    index : int
        Order of creation among the System's joints.
    """

    name: str
    kind: str
    body_i: Body
    body_j: Body
    point: np.ndarray = field(repr=False)  # (3,)
    axis: np.ndarray | None = field(repr=False)  # (3,) or None
    axis_j: np.ndarray | None = field(repr=False)  # (3,) or None
    index: int = field(repr=False)
    # body-frame data: u_i, u_j (points); f_i, g_i, h_i, f_j, g_j, h_j (frames)
    _local: dict = field(repr=False, compare=False)
    _owner: Any = field(repr=False, compare=False)


@dataclass(frozen=True, eq=False)
class Motor:
    """A driving constraint on a joint (Eq. 8.83 with a prescribed angle).

    Attributes
    ----------
    name : str
    joint : Joint
    coordinate : str
        ``"angle"`` (revolute, cylindrical: rotation of ``body_j`` relative
        to ``body_i`` about the joint axis, rad, zero in the configuration
        at which the joint was added) or ``"displacement"`` (prismatic,
        cylindrical: slide of ``body_j``'s joint point relative to
        ``body_i``'s along the axis, m, zero at creation).
    derivatives : str
        How ``f_dot`` and ``f_ddot`` are obtained: ``"given"`` (a tuple of
        three callables), ``"complex step"`` or ``"finite differences"``.
    index : int
    """

    name: str
    joint: Joint
    coordinate: str
    derivatives: str
    index: int
    _f: Callable[[float], tuple[float, float, float]] = field(repr=False, compare=False)
    _owner: Any = field(repr=False, compare=False)

    def values(self, t: float) -> tuple[float, float, float]:
        """``(f(t), f_dot(t), f_ddot(t))`` of the prescribed coordinate."""
        return self._f(float(t))


@dataclass(frozen=True, eq=False)
class SpringDamper:
    """A linear spring and damper between two body points.

    Force on ``body_j`` ``F = -(k (L - L0) + c L_dot) e`` with ``e`` the unit
    vector from point i to point j and ``L`` their distance; ``-F`` on
    ``body_i``.

    Attributes
    ----------
    name : str
    body_i, body_j : Body
    point_i, point_j : (3,) ndarray
        Global attachment points at creation.
    stiffness, damping, free_length : float
        N/m, N s/m, m.
    index : int
    """

    name: str
    body_i: Body
    body_j: Body
    point_i: np.ndarray = field(repr=False)
    point_j: np.ndarray = field(repr=False)
    stiffness: float
    damping: float
    free_length: float
    index: int = field(repr=False)
    _local: dict = field(repr=False, compare=False)
    _owner: Any = field(repr=False, compare=False)


@dataclass(frozen=True, eq=False)
class RotationalSpringDamper:
    """A torsion spring and damper acting in a revolute or cylindrical joint.

    Torque on ``body_j`` about the joint axis
    ``T = -k (theta - angle0) - c theta_dot`` (``-T`` on ``body_i``), with
    ``theta`` the joint angle of :class:`Motor` (``"angle"``), measured in
    ``(angle0 - pi, angle0 + pi]``.

    Attributes
    ----------
    name : str
    joint : Joint
    stiffness, damping, angle0 : float
        N m/rad, N m s/rad, rad.
    index : int
    """

    name: str
    joint: Joint
    stiffness: float
    damping: float
    angle0: float
    index: int = field(repr=False)
    _owner: Any = field(repr=False, compare=False)


@dataclass(frozen=True, eq=False)
class Force:
    """A user force ``f(t, state) -> (3,)`` (global, N) at a point of a body.

    Attributes
    ----------
    name : str
    body : Body
    point : (3,) ndarray or None
        Global point of application at creation; None: the centre of mass.
    index : int
    """

    name: str
    body: Body
    point: np.ndarray | None = field(repr=False)
    index: int = field(repr=False)
    _func: Callable = field(repr=False, compare=False)
    _u: np.ndarray | None = field(repr=False, compare=False)  # body-frame point
    _owner: Any = field(repr=False, compare=False)


@dataclass(frozen=True, eq=False)
class Torque:
    """A user torque ``f(t, state) -> (3,)`` (global, N m) on a body.

    Attributes
    ----------
    name : str
    body : Body
    index : int
    """

    name: str
    body: Body
    index: int = field(repr=False)
    _func: Callable = field(repr=False, compare=False)
    _owner: Any = field(repr=False, compare=False)
