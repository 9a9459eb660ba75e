"""Four textbook linkages and their motion sampled for a viewer: joint points, reactions, closed-form checks.

:func:`linkage` builds one of the four constrained systems of the chapter
(a pendulum chain, a spatial double pendulum, a slider-crank driven by a
motor, a heavy top on a spherical joint) with the handles its motion is read
by; :func:`linkage_motion` runs it over given output times (from its initial
state or from the state a previous run ended in) and returns everything a
viewer draws and checks at those times: body poses, joint points, the
reaction each joint applies, the motor's torque, the energy, the constraint
residual and, where the textbook gives one, the closed form beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigidlab.core._validation import default_angle, radians
from rigidlab.core.gyroscope import RotorParams, top_motion
from rigidlab.core.multibody import JOINT_KINDS, Joint, Motor, System
from rigidlab.core.rigid_body import rotation_angle_between
from rigidlab.core.rotations import euler_parameters_from_euler_angles, rotate_vector

from ._linkages import SliderCrank, slider_crank, spatial_double_pendulum
from ._pendulum import pendulum_chain
from ._top import HeavyTop, heavy_top

__all__ = ["LINKAGE_KINDS", "Linkage", "LinkageInfo", "LinkageMotion", "linkage", "linkage_motion"]

#: The linkages :func:`linkage` builds.
LINKAGE_KINDS = ("chain", "double_pendulum", "slider_crank", "heavy_top")

# The textbook dimensions (SI): a chain of total length 2 m of 1 kg rods; rods of 1 m and 1 kg; a
# slider-crank with r = 0.5 m, l = 1.5 m; the gyroscope scene's "cuspidal" top (I = 1, I3 = 0.8 kg m^2,
# mgl = 2 N m, theta0 = 50 deg, dpsi/dt = 8 rad/s) as a 1 kg body.
_CHAIN_LENGTH = 2.0
_TOP_PARAMS = RotorParams(I=1.0, I3=0.8, mgl=2.0)
_TOP_STATE0 = (0.0, math.radians(50.0), 0.0, 0.0, 0.0, 8.0)


@dataclass(frozen=True)
class LinkageInfo:
    """What a viewer of a :class:`Linkage` needs to know of it (picklable: names, counts, geometry).

    Attributes
    ----------
    kind : one of :data:`LINKAGE_KINDS`
    body_names, joint_names : tuple of str
        The bodies in index order; the joints whose reactions :func:`linkage_motion` reports, top down.
    joint_bodies : (J,) int
        ``body_j`` index of each joint (-1: the ground).
    joint_points_body : (J, 3)
        Each joint's point in ``body_j``'s frame (global for the ground), m.
    links : tuple of (int, float)
        ``(body index, length)`` of the bodies that are slender rods along their body z axis, centred (m).
    slider, top : int
        Index of the slider-crank's slider and of the heavy top's body (-1: none).
    motor : bool
        Whether a motor drives the linkage (its energy is then not constant).
    n_equations, rank, degrees_of_freedom : int
        Constraint equations (motor rows included), their rank and the freedom left (0: driven).
    weight : float
        Total weight (N).
    """

    kind: str
    body_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    joint_bodies: np.ndarray
    joint_points_body: np.ndarray
    links: tuple[tuple[int, float], ...]
    slider: int
    top: int
    motor: bool
    n_equations: int
    rank: int
    degrees_of_freedom: int
    weight: float

    @property
    def n_bodies(self) -> int:
        return len(self.body_names)

    @property
    def conserved(self) -> bool:
        """Whether the energy is constant (no motor does work)."""
        return not self.motor

    def columns(self) -> tuple[str, ...]:
        """Names (with units) of the columns of :meth:`LinkageMotion.table`."""
        out = [f"{b} {c}" for b in self.body_names for c in ("x (m)", "y (m)", "z (m)", "p0", "p1", "p2", "p3")]
        out += ["E (J)", "max |C|"]
        if self.slider >= 0:
            out.append("slider x - closed form (m)")
        if self.top >= 0:
            out += ["closed-form p0", "closed-form p1", "closed-form p2", "closed-form p3", "attitude difference (rad)"]
        return tuple(out)

    def description(self) -> tuple[str, str]:
        """Two sentences: the bodies, coordinates and joints; the constraint equations, their rank, the
        normalizations ``p^T p = 1`` (Eq. 8.46) and the degrees of freedom left."""
        n = self.n_bodies
        joints = {"chain": f"{n} rods on revolute joints", "double_pendulum": "2 rods on spherical joints",
                  "slider_crank": "crank, rod, slider: revolute, spherical, universal, prismatic joints and a motor",
                  "heavy_top": "one body on a spherical joint"}[self.kind]
        return (f"{n} {'body' if n == 1 else 'bodies'}, {7 * n} coordinates (R, p); {joints}",
                f"{self.n_equations} constraint equations (rank {self.rank}) + {n} normalization"
                f"{'' if n == 1 else 's'} pᵀp = 1: {self.degrees_of_freedom} degrees of freedom"
                + (" (the motor drives the one left)" if self.motor else ""))


@dataclass(frozen=True)
class Linkage:
    """A linkage of :func:`linkage`: its System, the handles its motion is read by, and its :class:`LinkageInfo`.

    Attributes
    ----------
    system : System
        Assembled, at t = 0.
    joints : tuple of Joint
        The joints of ``info.joint_names``.
    motor : Motor or None
        The slider-crank's motor.
    slider_crank : SliderCrank or None
    top : HeavyTop or None
    top_state0 : (6,) or None
        The heavy top's ZXZ angles and rates at t = 0 (core.gyroscope's state).
    info : LinkageInfo
    """

    system: System
    joints: tuple[Joint, ...]
    motor: Motor | None
    slider_crank: SliderCrank | None
    top: HeavyTop | None
    top_state0: tuple[float, ...] | None
    info: LinkageInfo


def linkage(kind: str, *, n_links: int = 5, tilt: float = default_angle(math.radians(60.0)),
            speed: float = default_angle(2.0 * math.pi),
            gravity: float = 9.81,
            degrees: bool = False) -> Linkage:
    """One of the chapter's four linkages at t = 0, assembled.

    * ``"chain"``: :func:`pendulum_chain` of ``n_links`` uniform 1 kg rods of total length 2 m on revolute
      joints, released at rest turned ``tilt`` (rad) from hanging;
    * ``"double_pendulum"``: :func:`spatial_double_pendulum` of two 1 m, 1 kg rods on spherical joints;
    * ``"slider_crank"``: :func:`slider_crank` with r = 0.5 m, l = 1.5 m, the motor turning the crank at
      ``speed`` (rad/s; Eqs. 8.82-8.83);
    * ``"heavy_top"``: :func:`heavy_top` of core.gyroscope's top (I = 1, I3 = 0.8 kg m^2, mgl = 2 N m,
      theta0 = 50 deg, dpsi/dt = 8 rad/s) as a 1 kg body on a spherical joint.

    Parameters
    ----------
    kind : one of :data:`LINKAGE_KINDS`
    n_links, tilt : keyword-only, the chain's (see :func:`pendulum_chain`)
    speed : keyword-only, the slider-crank's crank speed (rad/s)
    gravity : keyword-only, g along -z (m/s^2)
    degrees : bool, keyword-only
        True: ``tilt`` in degrees and ``speed`` in deg/s.

    Raises
    ------
    ValueError
        For an unknown ``kind`` (and what the builders refuse).
    """
    tilt = radians(tilt, "tilt", degrees)
    speed = radians(speed, "speed", degrees)
    motor = crank = top = state0 = None
    links: list[tuple[int, float]] = []
    if kind == "chain":
        system = pendulum_chain(n_links, _CHAIN_LENGTH / n_links, 1.0, "rod", tilt=tilt, gravity=gravity)
        joints = tuple(system.joints)
        links = [(b.index, _CHAIN_LENGTH / len(system.bodies)) for b in system.bodies]
    elif kind == "double_pendulum":
        sdp = spatial_double_pendulum(1.0, 1.0, gravity=gravity)
        system, joints = sdp.system, tuple(sdp.joints)
        links = [(b.index, sdp.length) for b in sdp.links]
    elif kind == "slider_crank":
        crank = slider_crank(crank_length=0.5, rod_length=1.5, speed=speed, gravity=gravity)
        system, motor = crank.system, crank.motor
        joints = (crank.crank_joint, crank.crank_rod_joint, crank.rod_slider_joint, crank.slider_joint)
        links = [(crank.crank.index, crank.crank_length), (crank.rod.index, crank.rod_length)]
    elif kind == "heavy_top":
        state0 = _TOP_STATE0
        top = heavy_top(_TOP_PARAMS, state0, mass=1.0, gravity=gravity)
        system, joints = top.system, (top.joint,)
    else:
        raise ValueError(f"kind: expected one of {list(LINKAGE_KINDS)}, got {kind!r}")
    # Joint.point is global in the configuration the joint was added in, which the builders' assembly keeps:
    # u = A^T (point - R) in body_j (Eq. 8.48)
    state = system.state
    points = [np.asarray(j.point, dtype=float) if j.body_j.is_ground else
              state.rotation_matrix(j.body_j).T @ (np.asarray(j.point, dtype=float) - state.position(j.body_j))
              for j in joints]
    report = system.assemble()
    info = LinkageInfo(
        kind=kind, body_names=tuple(b.name for b in system.bodies), joint_names=tuple(j.name for j in joints),
        joint_bodies=np.array([-1 if j.body_j.is_ground else j.body_j.index for j in joints], dtype=np.intp),
        joint_points_body=np.array(points, dtype=float).reshape(-1, 3), links=tuple(links),
        slider=crank.slider.index if crank is not None else -1, top=top.body.index if top is not None else -1,
        motor=motor is not None, n_equations=int(sum(JOINT_KINDS[j.kind] for j in system.joints) + len(system.motors)),
        rank=int(report.rank), degrees_of_freedom=int(report.degrees_of_freedom),
        weight=float(sum(b.mass for b in system.bodies)) * float(np.linalg.norm(system.gravity)),
    )
    return Linkage(system, joints, motor, crank, top, state0, info)


@dataclass(frozen=True)
class LinkageMotion:
    """The motion of a :class:`Linkage` at the output times (read-only arrays).

    Attributes
    ----------
    t : (n,) s
    R : (n, nb, 3) centres of mass, global (m)
    p : (n, nb, 4) Euler parameters, scalar first, signs chosen so consecutive samples agree
    joint_points : (n, J, 3) the joints' points ``R + A(p) u`` (Eq. 8.48), global (m)
    joint_forces : (n, J, 3) force each joint applies to its ``body_j`` (N, global; from the multipliers)
    motor_torque : (n, 3) or None, the motor's torque on the crank (N m, global)
    energy : (n,) J
    residual : (n,) ``max |C(q, t)|``
    closed_form : (n,) or (n, 4) or None
        The textbook's closed form at ``t``: the slider's x (m), or the heavy top's Euler parameters
        (:func:`rigidlab.core.gyroscope.top_motion`, Eqs. 8.19-8.21, ZXZ angles turned into Euler parameters).
    closed_form_center : (n, 3) or None, the closed-form top's centre of mass (m; its fixed point at the origin)
    difference : (n,) or None
        Multibody minus closed form: the slider's x (m), or the rotation angle between the two tops'
        attitudes (rad, Eq. 8.82).
    n_steps, n_rhs : int, the integrator's steps and right-hand sides
    final_state : RunState, what :func:`linkage_motion` continues from (``initial=``; core's
        ``traj.final_state``)
    """

    t: np.ndarray
    R: np.ndarray
    p: np.ndarray
    joint_points: np.ndarray
    joint_forces: np.ndarray
    motor_torque: np.ndarray | None
    energy: np.ndarray
    residual: np.ndarray
    closed_form: np.ndarray | None
    closed_form_center: np.ndarray | None
    difference: np.ndarray | None
    n_steps: int
    n_rhs: int
    final_state: Any

    def table(self) -> np.ndarray:
        """(n, m) the samples by the columns of :meth:`LinkageInfo.columns`: per body R and p, E, max |C|,
        and the closed-form check (the slider's difference; the top's closed-form p and attitude difference)."""
        n = self.t.size
        parts = [np.concatenate([self.R, self.p], axis=2).reshape(n, -1), self.energy[:, None], self.residual[:, None]]
        if self.closed_form is not None and self.closed_form.ndim == 2:
            parts.append(self.closed_form)
        if self.difference is not None:
            parts.append(self.difference[:, None])
        return np.concatenate(parts, axis=1)


def _continuous(p: np.ndarray) -> np.ndarray:
    """Euler parameters (n, ..., 4) with signs flipped so consecutive samples agree (p and -p: one attitude)."""
    p = np.array(p)
    for i in range(1, p.shape[0]):
        flip = np.einsum("...i,...i->...", p[i], p[i - 1]) < 0.0
        p[i][flip] *= -1.0
    return p


def _ro(a: Any) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def linkage_motion(linkage: Linkage, t: Any, *, initial: Any = None, **options: Any) -> LinkageMotion:
    """The motion of ``linkage`` at the output times ``t``, from t = 0 or from ``initial``.

    Runs :meth:`System.simulate` (the augmented equations with Euler parameters, Eqs. 8.51-8.57, projected
    onto ``C = 0`` after every step) and reads at every output the joints' points, their reactions
    (``-D^T lambda`` of each joint's rows, on ``body_j``), the motor's torque, and the closed form beside it
    (slider-crank: the slider's x; heavy top: core.gyroscope's exact motion).

    Parameters
    ----------
    linkage : Linkage
        Its System is not changed.
    t : (n,) output times (s), increasing; from ``initial``'s time on when given.
    initial : keyword-only, a previous motion's ``final_state`` (None: the System's state at t = 0).
    **options : keyword-only, those of :meth:`System.simulate` (``method``, ``rtol``, ``atol``, ``dt``)

    Raises
    ------
    ValueError
        Naming the quantity when the motion leaves the finite range; what ``simulate`` raises
        (``ArgumentError`` naming ``initial`` or ``t`` for a state of another System or one after ``t[0]``,
        ``IntegrationError``, ...).
    """
    system, t = linkage.system, np.asarray(t, dtype=float)
    traj = system.simulate(t, initial=initial, **options)
    n, nb = t.size, len(system.bodies)
    R = traj.q[:, : 3 * nb].reshape(n, nb, 3)
    p = _continuous(traj.q[:, 3 * nb :].reshape(n, nb, 4))
    bodies, u = linkage.info.joint_bodies, linkage.info.joint_points_body
    points = np.broadcast_to(u, (n, *u.shape)).copy()
    points[:, bodies >= 0] = R[:, bodies[bodies >= 0]] + rotate_vector(p[:, bodies[bodies >= 0]], u[bodies >= 0])
    forces = np.stack([traj.reaction(j)[0] for j in linkage.joints], axis=1)
    torque = traj.reaction(linkage.motor)[1] if linkage.motor is not None else None
    closed = center = difference = None
    if linkage.slider_crank is not None:
        sc = linkage.slider_crank
        closed = sc.slider_position(sc.phi0 + sc.speed * t)
        difference = R[:, sc.slider.index, 0] - closed
    elif linkage.top is not None:
        exact = top_motion(linkage.top.params, np.array(linkage.top_state0)).at(t)
        closed = _continuous(euler_parameters_from_euler_angles(exact.angles, "ZXZ"))
        center = linkage.top.length * rotate_vector(closed, np.array([0.0, 0.0, 1.0]))
        difference = rotation_angle_between(p[:, linkage.top.body.index], closed)
    for name, a in (("positions", traj.q), ("energy", traj.energy), ("residual", traj.residual_position)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the motion left the finite range near t = {t[0]:.3g} s")
    return LinkageMotion(
        t=_ro(t), R=_ro(R), p=_ro(p), joint_points=_ro(points), joint_forces=_ro(forces),
        motor_torque=None if torque is None else _ro(torque), energy=_ro(traj.energy),
        residual=_ro(traj.residual_position), closed_form=None if closed is None else _ro(closed),
        closed_form_center=None if center is None else _ro(center),
        difference=None if difference is None else _ro(difference), n_steps=int(traj.n_steps),
        n_rhs=int(traj.n_rhs), final_state=traj.final_state,
    )
