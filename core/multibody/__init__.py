"""Constrained multibody systems in absolute coordinates (R, Euler parameters).

One :class:`System` holds bodies, joints, drivers and forces, added by kind;
analyses are :meth:`System.assemble`, :meth:`System.equilibrium`,
:meth:`System.simulate` and :meth:`System.evaluate`. Conventions (stated
once in ``docs/conventions.md``): right-handed frames, global +Z up;
rotation matrices map body to global (``r = R + A(p) u_body``); Euler
parameters are scalar first ``(theta0, theta1, theta2, theta3)``;
``omega`` is global and ``omega_body`` (omega-bar) body-frame; SI units.
The formulation is explained step by step in ``docs/multibody.md``.

Example::

    from rigidlab.core.multibody import System
    system = System(gravity=(0.0, 0.0, -9.81))
    link = system.add_body("link", mass=1.0, inertia=(1 / 12, 1 / 12, 1e-4),
                           position=(0.0, 0.0, -0.5))
    hinge = system.add_joint("revolute", system.ground, link, point=(0, 0, 0), axis=(1, 0, 0))
    system.assemble()
    traj = system.simulate([0.0, 0.5, 1.0])
    force, torque = traj.reaction(hinge)
    more = system.simulate([1.0, 1.5], initial=traj.final_state)  # continues the run
"""

from ._analysis import RANK_TOL, AssemblyError, AssemblyReport, EquilibriumReport
from ._elements import (
    JOINT_KINDS,
    Body,
    Force,
    Joint,
    Motor,
    RotationalSpringDamper,
    SpringDamper,
    Torque,
)
from ._engine import SingularSystemError
from ._evaluation import Evaluation
from ._simulate import (
    ADAPTIVE_METHODS,
    FIXED_STEP_METHODS,
    KINEMATIC_METHOD,
    SEPARATION_ACTIONS,
    STABILIZATIONS,
    MultibodyTrajectory,
)
from ._state import RunState
from ._system import INERTIA_TRIANGLE_TOL, MAX_BAUMGARTE, PERPENDICULAR_TOL, State, System

__all__ = [
    "ADAPTIVE_METHODS",
    "FIXED_STEP_METHODS",
    "KINEMATIC_METHOD",
    "INERTIA_TRIANGLE_TOL",
    "MAX_BAUMGARTE",
    "JOINT_KINDS",
    "PERPENDICULAR_TOL",
    "RANK_TOL",
    "SEPARATION_ACTIONS",
    "STABILIZATIONS",
    "AssemblyError",
    "AssemblyReport",
    "Body",
    "EquilibriumReport",
    "Evaluation",
    "Force",
    "Joint",
    "Motor",
    "MultibodyTrajectory",
    "RotationalSpringDamper",
    "RunState",
    "SingularSystemError",
    "SpringDamper",
    "State",
    "System",
    "Torque",
]
