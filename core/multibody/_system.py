"""The System: bodies, joints, drivers and forces added by kind, and the current state.

A :class:`System` is the *model* (constant items added with ``add_*``) plus
one *current state* ``(t, q, v)``: the configuration and velocities that
``add_joint`` and friends read their global points in, that
:meth:`System.assemble` and :meth:`System.equilibrium` update and that
:meth:`System.simulate` starts from. Results of analyses are separate frozen
objects (:class:`~rigidlab.core.multibody.MultibodyTrajectory`,
:class:`~rigidlab.core.multibody.AssemblyReport`, ...); a simulation never changes
the System. This is MuJoCo's model/data split with the data's one
persistent state kept on the System.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigidlab.core._validation import (RADIANS_PER_DEGREE, check_degrees, float_array, output_times, positive_integer,
                                       radians, real_number, short_repr)
from rigidlab.core.integrators import ADAPTIVE_METHODS, MAX_STEPS, MIN_RTOL
from rigidlab.core.rotations import UNIT_NORM_TOL

from ._drivers import ScaledLaw, driver_function
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
from ._engine import _Engine, matrices
from ._analysis import assemble, equilibrium
from ._evaluation import evaluate
from ._simulate import KINEMATIC_METHOD, simulate
from ._state import RunState, State, _make_state, exp_parameters, quaternion_products, retract  # noqa: F401

__all__ = ["INERTIA_TRIANGLE_TOL", "MAX_BAUMGARTE", "PERPENDICULAR_TOL", "RunState", "State", "System"]

#: Relative tolerance of the triangle inequality of principal moments:
#: ``J3 - (J1 + J2) <= INERTIA_TRIANGLE_TOL * J3`` (as in core.rigid_body).
INERTIA_TRIANGLE_TOL = 1e-12

#: Largest ``|cos|`` of the angle between the two cross arms of a universal
#: joint (they must be perpendicular).
PERPENDICULAR_TOL = 1e-6

#: Largest rate ``alpha`` (rad/s) of Baumgarte's feedback ``gamma - 2 alpha
#: (D v + C_t) - alpha^2 C`` (``System.simulate(stabilization="baumgarte")``).
#: Its time constant ``1/alpha`` is then 10 microseconds: DOP853 takes about
#: ``10 alpha`` right-hand sides per second of motion to follow it (1e6 and a
#: minute of CPU for 1 s of a double pendulum), and ``alpha^2`` turns the
#: round-off of the constraints (1e-16 of the model's size) into accelerations
#: of 1e-6 of that size per s^2. A larger rate only adds cost and noise
#: (``"projection"`` holds the constraints to round-off): at 1e6 the double
#: pendulum's run diverged within 5 ms, and 1e300 made ``alpha^2`` overflow.
MAX_BAUMGARTE = 1e5


# ------------------------------------------------------------- validation
def _vector(x: Any, name: str, size: int = 3) -> np.ndarray:
    a = float_array(x, name, expected=f"a ({size},) vector of real numbers", copy=True)
    if a.shape != (size,):
        raise ValueError(f"{name}: expected shape ({size},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    return a


def _unit_axis(x: Any, name: str) -> np.ndarray:
    a = _vector(x, name)
    big = float(np.max(np.abs(a)))
    if big == 0.0:
        raise ValueError(f"{name}: expected a nonzero axis, got {a.tolist()}")
    a = a / big  # scaled first: tiny and huge axes keep their direction
    return a / float(np.linalg.norm(a))


def _check_inertia(inertia: Any) -> np.ndarray:
    a = float_array(inertia, "inertia", expected="principal moments (3,) or a (3, 3) tensor of real numbers", copy=True)
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3):
        raise ValueError(f"inertia: expected principal moments (3,) or a tensor (3, 3), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"inertia: expected finite values, got {a.tolist()}")
    scale = float(np.max(np.abs(a)))
    if np.max(np.abs(a - a.T)) > 1e-12 * scale:
        raise ValueError(f"inertia: expected a symmetric tensor, got {a.tolist()}")
    a = 0.5 * (a + a.T)
    w = np.linalg.eigvalsh(a)
    if w[0] < -1e-12 * scale:
        raise ValueError(
            f"inertia: expected principal moments >= 0 (zero: a point mass), got moments {w.tolist()}"
        )
    if w[2] - (w[0] + w[1]) > INERTIA_TRIANGLE_TOL * w[2]:
        raise ValueError(
            "inertia: expected principal moments that satisfy the triangle inequality J1 + J2 >= J3 "
            f"(no mass distribution has one moment larger than the sum of the other two), got moments {w.tolist()}"
        )
    if w[0] < 0.0:
        # within round-off of zero: snap the tiny negative moment to zero
        vals, vecs = np.linalg.eigh(a)
        a = (vecs * np.maximum(vals, 0.0)) @ vecs.T
        a = 0.5 * (a + a.T)
    return a


def _positive(x: Any, name: str, *, allow_zero: bool, unit: str = "") -> float:
    bound = (">= 0" if allow_zero else "> 0") + (f" ({unit})" if unit else "")
    v = real_number(x, name, expected=f"a finite number {bound}")
    if v < 0.0 or (v == 0.0 and not allow_zero):
        raise ValueError(f"{name}: expected a finite number {bound}, got {v!r}")
    return v


def _unit_parameters(p: Any) -> np.ndarray:
    a = _vector(p, "orientation", 4)
    norm = float(np.linalg.norm(a))
    if abs(norm - 1.0) > UNIT_NORM_TOL:
        raise ValueError(
            f"orientation: expected unit Euler parameters (theta0, theta1, theta2, theta3), scalar first "
            f"(| |p| - 1 | <= {UNIT_NORM_TOL:g}), got norm {norm!r}; renormalize with "
            "rigidlab.core.rotations.normalize_euler_parameters"
        )
    return a / norm


def _check_name(name: Any, taken: set[str], what: str) -> str:
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty string, got {short_repr(name)}")
    if name in taken:
        raise ValueError(f"name: {'an' if what[0] in 'aeiou' else 'a'} {what} named {name!r} already exists in "
                         "this System")
    return name


def _perpendicular(h: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to the unit vector h (deterministic)."""
    e = np.zeros(3)
    e[int(np.argmin(np.abs(h)))] = 1.0
    f = e - (e @ h) * h
    return f / np.linalg.norm(f)


def _cylinder_moments(m: float, r: float, length: float) -> np.ndarray:
    """Principal moments (J_x, J_y, J_z) of a uniform solid cylinder, axis z, about its centre of mass."""
    side = m * (3.0 * r * r + length * length) / 12.0
    return np.array([side, side, 0.5 * m * r * r])


def _parameters_z_to(h: np.ndarray) -> np.ndarray:
    """Euler parameters (scalar first) of the shortest rotation taking global z to the unit vector ``h``
    (half a turn about global x when ``h`` is -z): ``theta0 = cos(phi/2)``, ``theta = sin(phi/2) n`` (Eq. 8.46)."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(h @ z)
    if c < -1.0 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    # q = (1 + c, z x h) normalized: the half-angle form of the axis-angle parameters
    q = np.concatenate([[1.0 + c], np.cross(z, h)])
    return q / np.linalg.norm(q)


def _check_run_limits(t: Any, method: Any, rtol: Any, stabilization: Any, baumgarte: Any, max_steps: Any,
                      adaptive: tuple[str, ...]) -> None:
    """Refuse the options of ``System.simulate`` that would make a run overflow or never end: ``baumgarte``
    above :data:`MAX_BAUMGARTE`, or with ``alpha (t[-1] - t[0])`` above ``max_steps`` for an adaptive run with
    Baumgarte's stabilization; ``rtol`` below ``rigidlab.core.integrators.MIN_RTOL`` (the other checks are
    ``rigidlab.core.multibody._simulate.simulate``'s)."""
    alpha = real_number(baumgarte, "baumgarte", expected="a finite rate > 0 (rad/s)")
    if not 0.0 < alpha <= MAX_BAUMGARTE:
        raise ValueError(f"baumgarte: expected a finite rate > 0 and <= core.multibody._system.MAX_BAUMGARTE = "
                         f"{MAX_BAUMGARTE:g} rad/s (a feedback time under 10 microseconds only adds cost and noise; "
                         f"stabilization='projection' holds the constraints to round-off), got {alpha!r}")
    is_adaptive = isinstance(method, str) and method in adaptive
    if is_adaptive and isinstance(rtol, (int, float, np.integer, np.floating)) and not isinstance(rtol, bool):
        if 0.0 < float(rtol) < MIN_RTOL:
            raise ValueError(f"rtol: expected a relative tolerance >= core.integrators.MIN_RTOL = {MIN_RTOL:.3g} "
                             f"(100 machine epsilons: a smaller one asks for digits that round-off does not keep), "
                             f"got {rtol!r}")
    if is_adaptive and stabilization == "baumgarte" and method != "kinematic":
        times = output_times(t)
        budget = positive_integer(max_steps, "max_steps")
        span = float(times[-1] - times[0])
        if alpha * span > budget:
            raise ValueError(
                f"baumgarte: an adaptive run follows the feedback's time 1/alpha with at least one right-hand side "
                f"each: alpha={alpha:g} rad/s over t[-1] - t[0] = {span:g} s needs at least {alpha * span:.3g}, "
                f"more than max_steps={budget}; use a smaller baumgarte or a shorter time span, "
                "stabilization='projection', or pass a larger max_steps")


# ------------------------------------------------------------------ system
class System:
    """A constrained multibody system in absolute coordinates (R, Euler parameters).

    Items are added by kind: :meth:`add_body` (or, with the inertia of a
    uniform solid, :meth:`add_rod`, :meth:`add_box`, :meth:`add_cylinder`), :meth:`add_joint`,
    :meth:`add_motor`, :meth:`add_spring_damper`,
    :meth:`add_rotational_spring_damper`, :meth:`add_force`,
    :meth:`add_torque`. Global points and axes are read in the System's
    current configuration (the current state). Analyses:
    :meth:`assemble` (Newton onto the constraints), :meth:`equilibrium`
    (statics), :meth:`simulate` (dynamics; returns a
    :class:`~rigidlab.core.multibody.MultibodyTrajectory` and leaves the System
    unchanged), :meth:`evaluate` (all matrices of the equations of motion
    at the current state).

    Parameters
    ----------
    gravity : (3,) array_like, keyword-only
        Gravitational acceleration, global (m/s^2). Default ``(0, 0, -9.81)``
        (global +Z is up).
    """

    def __init__(self, *, gravity: Any = (0.0, 0.0, -9.81)):
        self.gravity = _vector(gravity, "gravity")
        self.gravity.setflags(write=False)
        self._bodies: list[Body] = []
        self._joints: list[Joint] = []
        self._motors: list[Motor] = []
        self._springs: list[SpringDamper] = []
        self._rot_springs: list[RotationalSpringDamper] = []
        self._forces: list[Force] = []
        self._torques: list[Torque] = []
        self._contacts: list = []
        self._contact_start: list = []
        self._names: dict[str, set[str]] = {"body": {"ground"}, "joint": set(), "item": set()}
        self._y = np.zeros(0)
        self._t = 0.0
        self._engine_cache: _Engine | None = None
        self.ground = Body("ground", -1, math.inf, np.zeros((3, 3)), self)

    # ------------------------------------------------------------- access
    @property
    def bodies(self) -> tuple[Body, ...]:
        """Bodies in the order they were added (ground excluded)."""
        return tuple(self._bodies)

    @property
    def joints(self) -> tuple[Joint, ...]:
        """Joints in the order they were added."""
        return tuple(self._joints)

    @property
    def motors(self) -> tuple[Motor, ...]:
        """Motors (driving constraints) in the order they were added."""
        return tuple(self._motors)

    @property
    def spring_dampers(self) -> tuple[SpringDamper, ...]:
        """Translational spring-dampers in the order they were added."""
        return tuple(self._springs)

    @property
    def rotational_spring_dampers(self) -> tuple[RotationalSpringDamper, ...]:
        """Torsion spring-dampers in the order they were added."""
        return tuple(self._rot_springs)

    @property
    def contacts(self) -> tuple:
        """Contacts in the order they were added."""
        return tuple(self._contacts)

    @property
    def state(self) -> State:
        """The current state (a read-only snapshot)."""
        return _make_state(self, self._t, self._y)

    def set_state(self, state: State) -> None:
        """Make ``state`` (of this System, with all its bodies) the current state.

        Raises
        ------
        ValueError
            For a state of another System or one taken before bodies were
            added, and naming the field (``state.t``, ``state.q``,
            ``state.v``) for one whose fields are not what a State of this
            System holds (a State is a frozen dataclass, but
            ``dataclasses.replace`` makes any): a time that is not a finite
            real number, ``q`` or ``v`` not real, finite, of shape ``(7n,)``
            and ``(6n,)``, or Euler parameters of norm 0.
        """
        if not isinstance(state, State):
            raise ValueError(f"state: expected a State, got {short_repr(state)}")
        if state._owner is not self:
            raise ValueError("state: belongs to another System")
        n = len(self._bodies)
        t = real_number(state.t, "state.t", expected="a finite time (s)")
        q = float_array(state.q, "state.q", expected=f"a ({7 * n},) vector of real numbers", copy=True)
        v = float_array(state.v, "state.v", expected=f"a ({6 * n},) vector of real numbers", copy=True)
        k = v.size // 6 if v.ndim == 1 and v.size % 6 == 0 else -1
        if 0 < k != n and q.shape == (7 * k,):  # a whole state of fewer (or more) bodies
            raise ValueError(
                f"state: describes {k} bodies, this System has {n} (bodies were added after it was taken)"
            )
        for name, a, size, layout in (("q", q, 7 * n, "R (3n) | Euler parameters (4n)"),
                                      ("v", v, 6 * n, "R_dot (3n) | omega_body (3n)")):
            if a.shape != (size,):
                raise ValueError(f"state.{name}: expected shape ({size},) for {n} bodies ([{layout}]), got "
                                 f"{a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"state.{name}: expected finite values, got {short_repr(a.tolist())}")
        y = np.concatenate([q, v])
        P = y[3 * n : 7 * n].reshape(n, 4)
        norms = np.linalg.norm(P, axis=1)
        if np.any(norms == 0.0):
            b = int(np.argmax(norms == 0.0))
            raise ValueError(f"state.q: expected Euler parameters of norm 1, got norm 0 for body "
                             f"{self._bodies[b].name!r} (q[{3 * n + 4 * b}:{3 * n + 4 * b + 4}])")
        y[3 * n : 7 * n] = (P / norms[:, None]).ravel()
        self._y = y
        self._t = t
        known = state._contacts
        if known is not None and len(known) == len(self._contacts):
            # the surface parameters at this state (the non-generalized coordinates of the contacts):
            # the next run's Newton starts from them instead of from an older configuration's
            self._contact_start = [(np.array(sq), ci, cj) for sq, ci, cj in known]
            eng = self._engine_cache
            if eng is not None and eng.contact_kernel is not None:
                start = eng.contact_kernel.initial_state(self._contact_start)
                start["mode"] = np.array(eng.contact_state["mode"])
                eng.contact_state = start

    def __repr__(self) -> str:
        return (
            f"System({len(self._bodies)} bodies, {len(self._joints)} joints, {len(self._motors)} motors, "
            f"{len(self._springs) + len(self._rot_springs)} spring-dampers, "
            f"{len(self._forces) + len(self._torques)} loads, {len(self._contacts)} contacts)"
        )

    # ------------------------------------------------------------- helpers
    def _changed(self) -> None:
        self._engine_cache = None

    def _engine(self) -> _Engine:
        if self._engine_cache is None:
            self._engine_cache = _Engine(
                self._bodies, self._joints, self._motors, self._springs, self._rot_springs,
                self._forces, self._torques, self.gravity, self._contacts, self._contact_start,
            )
        return self._engine_cache

    def _sync_contacts(self, eng: _Engine) -> None:
        """Keep the surface parameters found at the new current state (the next engine starts from them)."""
        if eng.contact_kernel is None:
            return
        st = eng.contact_state
        self._contact_start = [(np.array(st["s"][q]), st["charts"][q][0], st["charts"][q][1])
                               for q in range(len(self._contacts))]

    def _body(self, body: Any, name: str, *, allow_ground: bool = True) -> Body:
        if not isinstance(body, Body):
            raise ValueError(
                f"{name}: expected a Body of this System (from add_body, or system.ground), got {short_repr(body)}"
            )
        if body._owner is not self:
            raise ValueError(f"{name}: body {body.name!r} belongs to another System")
        if body.is_ground and not allow_ground:
            raise ValueError(f"{name}: expected a moving body, got the ground")
        return body

    def _joint(self, joint: Any, name: str = "joint") -> Joint:
        if not isinstance(joint, Joint):
            raise ValueError(f"{name}: expected a Joint of this System (from add_joint), got {short_repr(joint)}")
        if joint._owner is not self:
            raise ValueError(f"{name}: joint {joint.name!r} belongs to another System")
        return joint

    def _frame(self, body: Body) -> tuple[np.ndarray, np.ndarray]:
        """Current (R, A) of a body; the ground's are (0, I)."""
        if body.is_ground:
            return np.zeros(3), np.eye(3)
        n = len(self._bodies)
        i = body.index
        R = self._y[3 * i : 3 * i + 3]
        p = self._y[3 * n + 4 * i : 3 * n + 4 * i + 4]
        return R.copy(), matrices(p[None])[0]

    def _local_point(self, body: Body, point: np.ndarray) -> np.ndarray:
        R, A = self._frame(body)
        return A.T @ (point - R)

    def _local_dir(self, body: Body, d: np.ndarray) -> np.ndarray:
        _, A = self._frame(body)
        return A.T @ d

    def _item_name(self, name: Any, default: str, pool: str = "item") -> str:
        if name is None:
            k = 1
            while f"{default}{k}" in self._names[pool]:
                k += 1
            name = f"{default}{k}"
        name = _check_name(name, self._names[pool], "joint" if pool == "joint" else "item")
        self._names[pool].add(name)
        return name

    # ------------------------------------------------------------- bodies
    def add_body(
        self,
        name: str,
        *,
        mass: float,
        inertia: Any,
        position: Any = (0.0, 0.0, 0.0),
        orientation: Any = (1.0, 0.0, 0.0, 0.0),
        velocity: Any = (0.0, 0.0, 0.0),
        omega: Any = None,
        omega_body: Any = None,
    ) -> Body:
        """Add a rigid body; its initial state becomes part of the current state.

        Parameters
        ----------
        name : str
            Unique body name (not ``"ground"``).
        mass : float
            kg, finite and > 0.
        inertia : (3,) or (3, 3)
            Principal moments about the centre of mass (body axes), or the
            body-frame tensor about the centre of mass (kg m^2). Symmetric,
            moments >= 0 (zero rotational inertia is allowed: a point mass
            whose rotation the joints fix) that satisfy ``J1 + J2 >= J3``.
        position : (3,)
            Centre of mass R, global (m).
        orientation : (4,)
            Euler parameters (theta0, theta1, theta2, theta3), scalar first,
            unit within ``rigidlab.core.rotations.UNIT_NORM_TOL`` (1e-6); normalized.
        velocity : (3,)
            Velocity of the centre of mass, global (m/s).
        omega : (3,) or None
            Angular velocity, global frame (rad/s).
        omega_body : (3,) or None
            Angular velocity, body frame (omega-bar). At most one of
            ``omega`` and ``omega_body``; default zero.

        Returns
        -------
        Body
            The handle to pass to joints, forces and trajectories.

        Raises
        ------
        ValueError
            Naming the argument: a duplicate or empty name, a mass that is
            not > 0, an inertia that is negative, not symmetric or violates
            the triangle inequality, non-unit Euler parameters, non-finite
            or wrongly shaped vectors, both omegas given.
        """
        name = _check_name(name, self._names["body"], "body")
        m = real_number(mass, "mass", expected="a finite mass > 0 (kg)")
        if not m > 0.0:
            raise ValueError(f"mass: expected a finite mass > 0 (kg), got {m!r}")
        J = _check_inertia(inertia)
        R = _vector(position, "position")
        p = _unit_parameters(orientation)
        Rd = _vector(velocity, "velocity")
        if omega is not None and omega_body is not None:
            raise ValueError("omega, omega_body: expected at most one of them, got both")
        A = matrices(p[None])[0]
        if omega is not None:
            w_body = A.T @ _vector(omega, "omega")
        elif omega_body is not None:
            w_body = _vector(omega_body, "omega_body")
        else:
            w_body = np.zeros(3)
        J.setflags(write=False)
        n = len(self._bodies)
        body = Body(name, n, m, J, self)
        y = self._y
        blocks = [y[: 3 * n], R, y[3 * n : 7 * n], p, y[7 * n : 10 * n], Rd, y[10 * n :], w_body]
        self._y = np.concatenate(blocks)
        self._names["body"].add(name)
        self._bodies.append(body)
        self._changed()
        return body

    def add_rod(self, name: str, start: Any, end: Any, mass: float, radius: float = 0.01) -> Body:
        """Add a uniform solid rod (a circular cylinder) from ``start`` to ``end``, at rest.

        The body's centre of mass is the midpoint, its z axis points from
        ``start`` to ``end`` (the shortest rotation that takes global z there;
        a rod along -z is turned half a turn about global x) and its principal
        moments about the centre of mass are those of a solid cylinder of
        length ``L = norm(end - start)`` and radius ``r``:
        ``J_x = J_y = m (3 r^2 + L^2) / 12``, ``J_z = m r^2 / 2``. The
        orientation is returned as Euler parameters (Eq. 8.46).

        Parameters
        ----------
        name : str
            Unique body name.
        start, end : (3,) array_like
            End points of the rod's axis, global (m), different points.
        mass : float
            kg, > 0.
        radius : float
            m, >= 0 (0: a slender rod, ``J_x = J_y = m L^2 / 12``, ``J_z = 0``).

        Returns
        -------
        Body

        Raises
        ------
        ValueError
            Naming the argument: coincident end points, a mass that is not
            > 0, a negative radius (and whatever :meth:`add_body` refuses).
        """
        a = _vector(start, "start")
        b = _vector(end, "end")
        d = b - a
        length = float(np.linalg.norm(d))
        if not length > 0.0:
            raise ValueError(f"start, end: expected two different points, got {a.tolist()} twice")
        r = _positive(radius, "radius", allow_zero=True, unit="m")
        m = _positive(mass, "mass", allow_zero=False, unit="kg")
        J = _cylinder_moments(m, r, length)
        return self.add_body(name, mass=m, inertia=J, position=0.5 * (a + b), orientation=_parameters_z_to(d / length))

    def add_box(self, name: str, center: Any, size: Any, mass: float, orientation: Any = (1.0, 0.0, 0.0, 0.0)
                ) -> Body:
        """Add a uniform solid box (cuboid), at rest.

        Principal moments about the centre of mass, body axes along the
        edges: ``J_x = m (b^2 + c^2) / 12``, ``J_y = m (a^2 + c^2) / 12``,
        ``J_z = m (a^2 + b^2) / 12`` for edge lengths ``size = (a, b, c)``.

        Parameters
        ----------
        name : str
            Unique body name.
        center : (3,) array_like
            Centre of the box (its centre of mass), global (m).
        size : (3,) array_like
            Full edge lengths ``(a, b, c)`` along the body x, y, z axes (m), >= 0.
        mass : float
            kg, > 0.
        orientation : (4,) array_like
            Euler parameters (theta0, theta1, theta2, theta3) of the body
            frame, scalar first (Eq. 8.48: ``A`` maps body to global).

        Returns
        -------
        Body
        """
        c = _vector(center, "center")
        abc = _vector(size, "size")
        if np.any(abc < 0.0):
            raise ValueError(f"size: expected edge lengths >= 0 (m), got {abc.tolist()}")
        m = _positive(mass, "mass", allow_zero=False, unit="kg")
        a2, b2, c2 = abc**2
        J = m / 12.0 * np.array([b2 + c2, a2 + c2, a2 + b2])
        return self.add_body(name, mass=m, inertia=J, position=c, orientation=orientation)

    def add_cylinder(self, name: str, center: Any, axis: Any, radius: float, length: float, mass: float) -> Body:
        """Add a uniform solid circular cylinder, at rest.

        The body's z axis is ``axis`` (the shortest rotation from global z,
        as in :meth:`add_rod`); principal moments about the centre of mass
        ``J_x = J_y = m (3 r^2 + L^2) / 12``, ``J_z = m r^2 / 2``.

        Parameters
        ----------
        name : str
            Unique body name.
        center : (3,) array_like
            Centre of the cylinder (its centre of mass), global (m).
        axis : (3,) array_like
            Direction of the cylinder's axis, global (any nonzero length).
        radius, length : float
            m, >= 0.
        mass : float
            kg, > 0.

        Returns
        -------
        Body
        """
        c = _vector(center, "center")
        h = _unit_axis(axis, "axis")
        r = _positive(radius, "radius", allow_zero=True, unit="m")
        L = _positive(length, "length", allow_zero=True, unit="m")
        m = _positive(mass, "mass", allow_zero=False, unit="kg")
        return self.add_body(name, mass=m, inertia=_cylinder_moments(m, r, L), position=c,
                             orientation=_parameters_z_to(h))

    # ------------------------------------------------------------- joints
    def add_joint(
        self,
        kind: str,
        body_i: Body,
        body_j: Body,
        *,
        point: Any,
        axis: Any = None,
        axis_j: Any = None,
        name: str | None = None,
    ) -> Joint:
        """Add a joint between two bodies (either may be ``system.ground``).

        Parameters
        ----------
        kind : str
            ``"fixed"`` (6 equations), ``"spherical"`` (3), ``"revolute"``
            (5), ``"prismatic"`` (5), ``"cylindrical"`` (4) or
            ``"universal"`` (4).
        body_i, body_j : Body
            Two different bodies of this System.
        point : (3,)
            Joint point, global, in the current configuration (m). For
            prismatic and cylindrical joints a point on the sliding line.
        axis : (3,) or None
            Global axis in the current configuration (any nonzero length;
            normalized): the rotation axis (revolute, cylindrical), the
            sliding direction (prismatic, cylindrical), or for a universal
            joint the cross arm fixed in ``body_i``. Required by those four
            kinds, refused by ``"fixed"`` and ``"spherical"``.
        axis_j : (3,) or None
            Universal joints only (required): the cross arm fixed in
            ``body_j``, perpendicular to ``axis`` (``|cos| <=
            PERPENDICULAR_TOL``).
        name : str or None
            Unique joint name; default ``"<kind><k>"``.

        Returns
        -------
        Joint

        Raises
        ------
        ValueError
            For an unknown kind, a body that is not of this System, the same
            body twice, a zero or missing axis, an axis a kind does not
            take, or universal arms that are not perpendicular.
        """
        if not isinstance(kind, str) or kind not in JOINT_KINDS:
            raise ValueError(f"kind: expected one of {sorted(JOINT_KINDS)}, got {short_repr(kind)}")
        bi = self._body(body_i, "body_i")
        bj = self._body(body_j, "body_j")
        if bi is bj:
            raise ValueError(f"body_i, body_j: expected two different bodies, got {bi.name!r} twice")
        P = _vector(point, "point")
        needs_axis = kind in ("revolute", "prismatic", "cylindrical", "universal")
        if needs_axis and axis is None:
            raise ValueError(f"axis: a {kind} joint needs an axis, got None")
        if not needs_axis and axis is not None:
            raise ValueError(f"axis: a {kind} joint takes no axis, got {short_repr(axis)}")
        if kind != "universal" and axis_j is not None:
            raise ValueError(f"axis_j: only universal joints take axis_j, got it for a {kind} joint")
        h = _unit_axis(axis, "axis") if needs_axis else np.array([0.0, 0.0, 1.0])
        b = None
        if kind == "universal":
            if axis_j is None:
                raise ValueError("axis_j: a universal joint needs axis_j (the cross arm fixed in body_j), got None")
            b = _unit_axis(axis_j, "axis_j")
            if abs(float(h @ b)) > PERPENDICULAR_TOL:
                raise ValueError(
                    f"axis_j: expected perpendicular to axis (|cos| <= {PERPENDICULAR_TOL:g}), got cos {float(h @ b)!r}"
                )
        if kind == "fixed":
            f, g = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
        else:
            f = _perpendicular(h)
            g = np.cross(h, f)
        name = self._item_name(name, kind, "joint")
        local = {
            "u_i": self._local_point(bi, P),
            "u_j": self._local_point(bj, P),
            "f_i": self._local_dir(bi, f),
            "g_i": self._local_dir(bi, g),
            "h_i": self._local_dir(bi, h),
            "f_j": self._local_dir(bj, f),
            "g_j": self._local_dir(bj, g),
            "h_j": self._local_dir(bj, h),
        }
        if b is not None:
            local["a_i"] = self._local_dir(bi, h)
            local["b_j"] = self._local_dir(bj, b)
        for v in local.values():
            v.setflags(write=False)
        for arr in (P, h):
            arr.setflags(write=False)
        if b is not None:
            b.setflags(write=False)
        joint = Joint(name, kind, bi, bj, P, h if needs_axis else None, b, len(self._joints), local, self)
        self._joints.append(joint)
        self._changed()
        return joint

    def add_motor(
        self, joint: Joint, *, angle: Any = None, displacement: Any = None, name: str | None = None,
        degrees: bool = False
    ) -> Motor:
        """Drive a joint coordinate as a function of time (a driving constraint).

        The angle of a revolute or cylindrical joint is the rotation of
        ``body_j`` relative to ``body_i`` about the joint axis (right hand),
        zero in the configuration at which the joint was added; the
        constraint is ``sin(theta - f(t)) = (g_i . f_j) cos f - (f_i . f_j)
        sin f = 0`` (smooth, no angle wrapping; ``f_i, g_i`` span the plane
        normal to the axis on body i, ``f_j`` on body j). The displacement of a
        prismatic or cylindrical joint is ``h_i . (r_j - r_i) = f(t)``,
        zero at creation.

        Parameters
        ----------
        joint : Joint
        angle, displacement : callable or tuple, keyword-only
            Exactly one: ``f(t) -> float`` (rad or m) or a tuple
            ``(f, f_dot, f_ddot)`` of callables. With a single callable,
            ``f_dot`` and ``f_ddot`` come from complex steps when ``f``
            accepts complex input, else from finite differences (see
            docs/multibody.md for the rules and their accuracy).
        name : str or None
        degrees : bool, keyword-only
            True: the ``angle`` law (and its given rates) in degrees, deg/s, deg/s^2.

        Returns
        -------
        Motor

        Raises
        ------
        ValueError
            For a joint of another System, a coordinate the joint kind does
            not have, a coordinate already driven, both or neither of
            ``angle`` and ``displacement``, or a function that does not
            return a finite real number at the current time (a complex
            value included); the message names the motor. A law that
            returns a complex (or non-finite) value at a later time raises
            the same ValueError where that value is first taken.
        """
        check_degrees(degrees)
        jt = self._joint(joint)
        if (angle is None) == (displacement is None):
            raise ValueError("angle, displacement: expected exactly one of them")
        coord = "angle" if angle is not None else "displacement"
        allowed = {"revolute": ("angle",), "cylindrical": ("angle", "displacement"), "prismatic": ("displacement",)}
        if coord not in allowed.get(jt.kind, ()):
            raise ValueError(
                f"{coord}: a {jt.kind} joint has no driven {coord} (angle: revolute, cylindrical; "
                "displacement: prismatic, cylindrical)"
            )
        for mt in self._motors:
            if mt.joint is jt and mt.coordinate == coord:
                raise ValueError(f"joint: the {coord} of joint {jt.name!r} is already driven by motor {mt.name!r}")
        label = name
        if label is None:  # the name add_motor gives it (registered below, once the law is accepted)
            k = 1
            while f"motor{k}" in self._names["item"]:
                k += 1
            label = f"motor{k}"
        func, how = driver_function(angle if angle is not None else displacement, f"motor {label!r}, {coord}",
                                    self._t)
        if degrees and coord == "angle":
            func = ScaledLaw(func, RADIANS_PER_DEGREE)
        name = self._item_name(name, "motor")
        motor = Motor(name, jt, coord, how, len(self._motors), func, self)
        self._motors.append(motor)
        self._changed()
        return motor

    # ------------------------------------------------------------- forces
    def add_spring_damper(
        self,
        body_i: Body,
        point_i: Any,
        body_j: Body,
        point_j: Any,
        *,
        stiffness: float,
        damping: float = 0.0,
        free_length: float | None = None,
        name: str | None = None,
    ) -> SpringDamper:
        """Add a linear spring-damper between two body points (global, current configuration).

        Force on ``body_j``: ``-(k (L - L0) + c L_dot) e``, ``e`` the unit
        vector from point i to point j; the opposite on ``body_i``. With
        ``free_length = 0`` the force is ``-k d - c d_dot`` (``d = r_j -
        r_i``), defined also when the points meet.

        Parameters
        ----------
        body_i, body_j : Body
            Different bodies of this System (either may be the ground).
        point_i, point_j : (3,)
            Attachment points, global, current configuration (m).
        stiffness : float
            N/m, >= 0.
        damping : float
            N s/m, >= 0.
        free_length : float or None
            m, >= 0; default the current distance of the points.
        name : str or None

        Returns
        -------
        SpringDamper
        """
        bi = self._body(body_i, "body_i")
        bj = self._body(body_j, "body_j")
        if bi is bj:
            raise ValueError(f"body_i, body_j: expected two different bodies, got {bi.name!r} twice")
        Pi = _vector(point_i, "point_i")
        Pj = _vector(point_j, "point_j")
        k = _positive(stiffness, "stiffness", allow_zero=True, unit="N/m")
        c = 0.0 if damping is None else _positive(damping, "damping", allow_zero=True, unit="N s/m")
        L0 = float(np.linalg.norm(Pj - Pi)) if free_length is None else _positive(free_length, "free_length",
                                                                                   allow_zero=True, unit="m")
        name = self._item_name(name, "spring_damper")
        local = {"u_i": self._local_point(bi, Pi), "u_j": self._local_point(bj, Pj)}
        sp = SpringDamper(name, bi, bj, Pi, Pj, k, c, L0, len(self._springs), local, self)
        self._springs.append(sp)
        self._changed()
        return sp

    def add_rotational_spring_damper(
        self, joint: Joint, *, stiffness: float, damping: float = 0.0, angle0: float = 0.0, name: str | None = None,
        degrees: bool = False
    ) -> RotationalSpringDamper:
        """Add a torsion spring-damper in a revolute or cylindrical joint.

        Torque on ``body_j`` about the joint axis ``-k (theta - angle0) - c
        theta_dot`` (the opposite on ``body_i``), ``theta`` the joint angle
        of :meth:`add_motor`, taken in ``(angle0 - pi, angle0 + pi]``.

        Parameters
        ----------
        joint : Joint
            A revolute or cylindrical joint of this System.
        stiffness : float
            N m/rad, >= 0.
        damping : float
            N m s/rad, >= 0.
        angle0 : float
            Angle at which the spring is relaxed (rad).
        name : str or None
        degrees : bool, keyword-only
            True: ``angle0`` is in degrees (``stiffness`` stays N m/rad).

        Returns
        -------
        RotationalSpringDamper
        """
        angle0 = radians(angle0, "angle0", degrees)
        jt = self._joint(joint)
        if jt.kind not in ("revolute", "cylindrical"):
            raise ValueError(f"joint: a rotational spring-damper needs a revolute or cylindrical joint, got {jt.kind}")
        k = _positive(stiffness, "stiffness", allow_zero=True, unit="N m/rad")
        c = 0.0 if damping is None else _positive(damping, "damping", allow_zero=True, unit="N m s/rad")
        a0 = real_number(angle0, "angle0")
        name = self._item_name(name, "rotational_spring_damper")
        rs = RotationalSpringDamper(name, jt, k, c, a0, len(self._rot_springs), self)
        self._rot_springs.append(rs)
        self._changed()
        return rs

    def add_force(self, body: Body, f: Callable, *, point: Any = None, name: str | None = None) -> Force:
        """Add a force ``f(t, state) -> (3,)`` (global, N) at a point of ``body``.

        Parameters
        ----------
        body : Body
            A moving body of this System.
        f : callable
            ``f(t, state)`` with ``state`` a :class:`State`; returns the
            force in the global frame.
        point : (3,) or None
            Global point of application in the current configuration; it
            moves with the body. Default: the centre of mass.
        name : str or None

        Returns
        -------
        Force
        """
        b = self._body(body, "body", allow_ground=False)
        if not callable(f):
            raise ValueError(f"f: expected a callable f(t, state) -> (3,), got {short_repr(f)}")
        P = None if point is None else _vector(point, "point")
        u = None if P is None else self._local_point(b, P)
        name = self._item_name(name, "force")
        force = Force(name, b, P, len(self._forces), f, u, self)
        self._forces.append(force)
        self._changed()
        return force

    def add_torque(self, body: Body, f: Callable, *, name: str | None = None) -> Torque:
        """Add a torque ``f(t, state) -> (3,)`` (global frame, N m) on ``body``.

        Parameters
        ----------
        body : Body
            A moving body of this System.
        f : callable
            ``f(t, state)`` with ``state`` a :class:`State`.
        name : str or None

        Returns
        -------
        Torque
        """
        b = self._body(body, "body", allow_ground=False)
        if not callable(f):
            raise ValueError(f"f: expected a callable f(t, state) -> (3,), got {short_repr(f)}")
        name = self._item_name(name, "torque")
        torque = Torque(name, b, len(self._torques), f, self)
        self._torques.append(torque)
        self._changed()
        return torque


    # ------------------------------------------------------------- contacts
    def add_contact(
        self,
        body_i: Body,
        surface_i: Any,
        body_j: Body,
        surface_j: Any,
        *,
        model: str = "constraint",
        rolling: bool = False,
        stiffness: float | None = None,
        damping: float | None = None,
        exponent: float = 1.5,
        tolerance: float = 1e-6,
        name: str | None = None,
    ):
        """Add a contact between a surface of ``body_i`` and a surface of ``body_j`` (Eqs. 8.84-8.109).

        The contact point is found in the current configuration (sampled
        guess, then Newton on the surface parameters). With
        ``model="constraint"`` the five contact constraints (point
        coincidence, Eq. 8.90; the normal of one surface perpendicular to
        the tangents of the other, Eqs. 8.93-8.94) in the body coordinates
        and the four surface parameters are adjoined to the equations of
        motion; since the surface parameters have no inertia, ``C_s^T
        lambda = 0`` leaves one independent multiplier, the normal force
        (Eqs. 8.105-8.107). With ``model="compliant"`` a Hunt-Crossley force
        ``F = k delta^e (1 + 3/2 c delta_dot)`` acts along the common
        normal while the bodies overlap by ``delta``. See docs/contact.md.

        Parameters
        ----------
        body_i, body_j : Body
            Two different bodies of this System (either may be the ground).
        surface_i, surface_j : Surface
            In the frames of ``body_i`` and ``body_j``: two surfaces
            (:class:`~rigidlab.core.contact.Plane`, :class:`~rigidlab.core.contact.Sphere`,
            :class:`~rigidlab.core.contact.Ellipsoid`, :class:`~rigidlab.core.contact.Torus`,
            :class:`~rigidlab.core.contact.ParametricSurface`) or two
            :class:`~rigidlab.core.contact.PlanarCurve` in parallel body x-y planes.
        model : ``"constraint"`` or ``"compliant"``, keyword-only
        rolling : bool, keyword-only
            Rolling without slip: the contact points' relative velocity
            along the tangents is zero (two velocity constraints, one for
            curves; constraint model only).
        stiffness : float or None, keyword-only
            ``k`` (N/m^exponent, > 0): required by the compliant model; for
            the constraint model it enables ``simulate(...,
            on_separation="compliant")``.
        damping : float or None, keyword-only
            Hunt-Crossley ``c`` (s/m, >= 0; None: 0, elastic); the
            coefficient of restitution of a slow impact is about ``1 - c v``.
        exponent : float, keyword-only
            ``e`` >= 1 (1.5: Hertz contact of curved surfaces).
        tolerance : float, keyword-only
            Constraint model: the largest gap or penetration (m) accepted
            in the current configuration (``assemble`` then closes it).
        name : str or None

        Returns
        -------
        Contact

        Raises
        ------
        ValueError
            Naming the argument: bodies or surfaces of the wrong kind, a
            curve with a surface, bad model options (``stiffness: expected a
            finite stiffness > 0 ...``), two flat faces, bodies that do not
            touch or penetrate beyond ``tolerance``, a line contact (the
            rank of ``C_s``, Eq. 8.109), curves in planes that are not
            parallel.
        """
        from rigidlab.core.contact import CONTACT_MODELS, Contact, Surface
        from rigidlab.core.contact._search import check_rank, find_contact

        bi = self._body(body_i, "body_i")
        bj = self._body(body_j, "body_j")
        if bi is bj:
            raise ValueError(f"body_i, body_j: expected two different bodies, got {bi.name!r} twice")
        for surf, label in ((surface_i, "surface_i"), (surface_j, "surface_j")):
            if not isinstance(surf, Surface):
                raise ValueError(
                    f"{label}: expected a Plane, Sphere, Ellipsoid, Torus, ParametricSurface or PlanarCurve, "
                    f"got {short_repr(surf)}")
        if surface_i.n_parameters != surface_j.n_parameters:
            raise ValueError(
                "surface_i, surface_j: a planar curve touches only another planar curve (curve-on-curve contact "
                f"in a plane), got {surface_i!r} and {surface_j!r}")
        if not isinstance(model, str) or model not in CONTACT_MODELS:
            raise ValueError(f"model: expected one of {list(CONTACT_MODELS)}, got {short_repr(model)}")
        if not isinstance(rolling, (bool, np.bool_)):
            raise ValueError(f"rolling: expected True or False, got {short_repr(rolling)}")
        rolling = bool(rolling)
        if rolling and model != "constraint":
            raise ValueError("rolling: rolling without slip needs model='constraint' (a compliant contact has "
                             "no tangential force)")
        k = None
        if stiffness is not None:
            k = real_number(stiffness, "stiffness", expected="a finite stiffness > 0 (N/m^exponent)")
            if not k > 0.0:
                raise ValueError(f"stiffness: expected a finite stiffness > 0 (N/m^exponent), got {k!r}")
        elif model == "compliant":
            raise ValueError("stiffness: the compliant model needs a finite stiffness > 0 (N/m^exponent), got None")
        c = 0.0 if damping is None else _positive(damping, "damping", allow_zero=True, unit="s/m")
        e = real_number(exponent, "exponent", expected="a finite exponent >= 1")
        if not e >= 1.0:
            raise ValueError(f"exponent: expected a finite exponent >= 1, got {e!r}")
        tol = _positive(tolerance, "tolerance", allow_zero=False, unit="m")
        if surface_i.unbounded and surface_j.unbounded:
            what = "two lines" if surface_i.n_parameters == 1 else "two planes"
            raise ValueError(
                f"surface_i, surface_j: {what} (parallel flat faces) touch along a whole line or face, not at a "
                "point: C_s has no full rank (Eq. 8.109); give one of the bodies a curved surface")
        if surface_i.degenerate_tangents and surface_j.degenerate_tangents:
            raise ValueError(
                "surface_i, surface_j: two rims (tori with minor_radius 0) meet edge to edge, where neither "
                "surface has a tangent plane; give one of them a minor radius > 0")
        key_i, key_j = surface_i._shape_key(), surface_j._shape_key()
        for other in self._contacts:
            if (other.body_i, other.surface_i._shape_key(), other.body_j, other.surface_j._shape_key()) in (
                    (bi, key_i, bj, key_j), (bj, key_j, bi, key_i)):
                raise ValueError(
                    f"surface_i, surface_j: these surfaces of {bi.name!r} and {bj.name!r} already touch in contact "
                    f"{other.name!r}; a second contact would repeat its constraint (and carry no force)")
        name = self._item_name(name, "contact")
        Ri, Ai = self._frame(bi)
        Rj, Aj = self._frame(bj)
        if surface_i.n_parameters == 1:
            zc = float(np.linalg.norm(np.cross(Ai[:, 2], Aj[:, 2])))
            if zc > 1e-6:
                self._names["item"].discard(name)
                raise ValueError(
                    f"surface_i, surface_j: planar curves lie in their bodies' x-y planes, which must be parallel "
                    f"(the bodies' z axes are {zc:.2e} rad apart); keep the mechanism planar with joints")
        try:
            info = find_contact(name, surface_i, Ri, Ai, surface_j, Rj, Aj)
            check_rank(name, info)
        except ValueError:
            self._names["item"].discard(name)
            raise
        gap = info["gap"]
        L = min(surface_i.length_scale, surface_j.length_scale)
        where = f"(closest points {np.round(info['point_i'], 9).tolist()} and {np.round(info['point_j'], 9).tolist()})"
        if model == "constraint" and abs(gap) > tol:
            self._names["item"].discard(name)
            if gap > 0:
                raise ValueError(
                    f"body_i, body_j: {bi.name!r} and {bj.name!r} do not touch: gap {gap:.3e} m > tolerance "
                    f"{tol:g} m {where}; place them in contact, or use model='compliant'")
            raise ValueError(
                f"body_i, body_j: {bi.name!r} and {bj.name!r} penetrate by {-gap:.3e} m > tolerance {tol:g} m "
                f"{where}; place them in contact")
        if model == "compliant" and math.isfinite(L) and -gap > 0.5 * L:
            self._names["item"].discard(name)
            raise ValueError(
                f"body_i, body_j: {bi.name!r} and {bj.name!r} penetrate by {-gap:.3e} m, more than half the "
                f"length scale {L:g} m of the surfaces {where}; separate them")
        contact = Contact(name, bi, bj, surface_i, surface_j, model, rolling, k, c, e, tol, len(self._contacts),
                          gap, self)
        self._contacts.append(contact)
        self._contact_start.append((np.array(info["s"]), info["charts"][0], info["charts"][1]))
        self._changed()
        return contact

    # ------------------------------------------------------------- analyses
    def assemble(self, *, t: float | None = None, tol: float = 1e-12, max_iterations: int = 50):
        """Move the current state onto the constraints (positions, then velocities).

        Newton iterations with least-change (mass-weighted, minimum-norm)
        corrections in the tangent space bring the position constraints
        ``C(q, t) = 0`` to ``tol``; then the velocities are projected onto
        ``D v + C_t = 0`` with the least change of kinetic energy. The
        constraint rows are checked for redundancy at the result. A contact
        in the constraint model holds its surfaces together, so the velocity
        along its normal is removed, also when the bodies were moving apart
        (a contact with ``model="compliant"`` keeps it).

        Parameters
        ----------
        t : float or None
            Time of the driving constraints; default the state's time. The
            state's time becomes ``t``.
        tol : float
            Largest accepted ``|C|`` (m for point rows, dimensionless for
            direction rows).
        max_iterations : int

        Returns
        -------
        AssemblyReport
            Which bodies moved and by how much, iterations, residuals, rank
            and redundant rows.

        Raises
        ------
        AssemblyError
            (a ValueError) when the configuration cannot be assembled: no
            convergence, or joints that cannot all hold at once; the message
            names the joint with the largest residual.
        """
        return assemble(self, t=t, tol=tol, max_iterations=max_iterations)

    def equilibrium(self, *, t: float | None = None, tol: float = 1e-10, max_iterations: int = 50):
        """Find a static equilibrium near the current configuration; velocities become zero.

        Newton iterations on the tangent-space coordinates and the
        multipliers solve ``Q(q, 0, t) - D(q)^T lambda = 0``, ``C(q, t) = 0``
        (applied forces balanced by the joints). The result is the nearest
        equilibrium, stable or not.

        Parameters
        ----------
        t : float or None
            Time of the drivers and loads; default the state's time.
        tol : float
            Largest accepted force residual relative to the largest applied
            generalized force (and 1e-12 on the constraints).
        max_iterations : int

        Returns
        -------
        EquilibriumReport

        Raises
        ------
        AssemblyError
            When Newton does not converge.
        """
        return equilibrium(self, t=t, tol=tol, max_iterations=max_iterations)

    def simulate(
        self,
        t: Any,
        *,
        method: str = "DOP853",
        rtol: float | None = None,
        atol: float | None = None,
        dt: float | None = None,
        stabilization: str = "projection",
        baumgarte: float = 20.0,
        position_tol: float = 1e-12,
        max_steps: int | None = None,
        on_separation: str = "stop",
        initial: RunState | None = None,
    ):
        """Integrate the constrained equations of motion from the current state (or ``initial``).

        The augmented index-1 equations ``[[M, D^T], [D, 0]] [a; lambda] =
        [Q_e + Q_v; gamma]`` in Newton-Euler form (velocities ``R_dot`` and
        ``omega_body``, ``p_dot = G_bar^T omega_body / 2``, Eqs. 8.51-8.54)
        are integrated with the state projected back onto the constraints
        after every step. The current state is taken as the state at
        ``t[0]``; it must satisfy the constraints to 1e-8 (call
        :meth:`assemble` first). The System is not changed; continue a run
        with ``system.simulate(t2, initial=traj.final_state)`` (a
        :class:`RunState`: positions, velocities, time, the contacts'
        surface parameters and models), or make its end the current state
        with ``system.set_state(traj.state(-1))``.

        Parameters
        ----------
        t : (n,) array_like
            Non-decreasing output times (s).
        method : str, keyword-only
            ``"DOP853"`` (default, order 8) or ``"RK45"`` (order 5): scipy's
            adaptive methods stepped one accepted step at a time, outputs by
            dense output; ``"rk4"`` or ``"midpoint"``: fixed steps of at
            most ``dt`` through :func:`rigidlab.core.integrators.integrate`;
            ``"kinematic"``: a System without a degree of freedom (a driven
            mechanism, a cam on its motor with the follower held on it) is
            solved at every output from its constraints, positions,
            velocities, accelerations and multipliers (Eqs. 8.105-8.107),
            without integration error (see ``rigidlab.core.multibody._simulate.simulate``).
        rtol, atol : float, keyword-only
            Adaptive methods: scipy's tolerances (defaults
            ``rigidlab.core.integrators.DEFAULT_RTOL`` 1e-8, ``DEFAULT_ATOL`` 1e-10;
            ``rtol >= core.integrators.MIN_RTOL``, 2.2e-14);
            ``"kinematic"``: those of DOP853 after a compliant continuation.
        dt : float, keyword-only
            Fixed-step methods: the largest step (required).
        stabilization : str, keyword-only
            ``"projection"`` (default): Newton projection of positions and
            mass-weighted projection of velocities after every step and at
            every output; ``"baumgarte"``: the feedback ``gamma - 2 alpha
            (D v + C_t) - alpha^2 C``, no projection; ``"none"``: the bare
            index-1 equations (the residuals drift).
        baumgarte : float, keyword-only
            ``alpha`` of Baumgarte's feedback (rad/s), ``0 < alpha <=
            MAX_BAUMGARTE`` (1e5). An adaptive run follows the feedback's
            time ``1/alpha`` with at least one right-hand side each: with
            ``stabilization="baumgarte"``, one whose ``alpha (t[-1] -
            t[0])`` exceeds ``max_steps`` is refused before it starts.
        position_tol : float, keyword-only
            Newton tolerance of the position projection, ``max |C|``.
        max_steps : int, keyword-only
            Limit on steps (fixed) or right-hand-side evaluations
            (adaptive); default ``rigidlab.core.integrators.MAX_STEPS`` (1e7). An
            adaptive run takes at least one evaluation per radian of its
            fastest body's turn: one whose ``|omega| (t[-1] - t[0])`` at the
            start exceeds ``max_steps`` is refused before it starts, and one
            above ``rigidlab.core.multibody._simulate.LONG_RUN_RADIANS`` (1e5 rad,
            minutes of CPU) warns (RuntimeWarning). One whose pace after
            ``rigidlab.core.integrators.PACE_CHECK_CALLS`` (1e4) evaluations, or any
            doubling of them, needs more than ``PACE_MARGIN`` (2) times
            ``max_steps`` stops then with ``IntegrationError`` (a horizon of
            1e300 s ends within seconds).
        on_separation : str, keyword-only
            Contacts in the constraint model: when a normal force crosses
            zero, ``"stop"`` (default) ends the run there,
            ``"compliant"`` continues with that contact's compliant model
            and ``"bilateral"`` keeps the constraint (it pulls); every
            crossing is listed in ``traj.separations`` (docs/contact.md).
        initial : RunState or None, keyword-only
            Start from this state (``traj.final_state`` of an earlier run of
            this System, or ``traj.run_state(i)``) instead of the current
            one: at its time ``initial.t`` (``t[0] >= initial.t``; an output
            at ``initial.t`` is its state), with the contacts' warm starts
            and models it holds (a contact that separated into the compliant
            model stays compliant). The run is the continuation of the one
            that ended there: split at an output time, two runs agree with
            one long run to the integrator's tolerance (adaptive methods
            restart their step-size control at the split), to round-off for
            ``"kinematic"`` and for fixed steps that end on the split
            (docs/multibody.md, "Continuing a run").

        Returns
        -------
        MultibodyTrajectory

        Raises
        ------
        ValueError
            For bad options or times; ``AssemblyError`` when the state does
            not satisfy the constraints; ``SingularSystemError`` when the
            constrained equations are singular; ``IntegrationError`` when
            the integrator fails.
        """
        _check_run_limits(t, method, rtol, stabilization, baumgarte,
                          MAX_STEPS if max_steps is None else max_steps, ADAPTIVE_METHODS + (KINEMATIC_METHOD,))
        return simulate(
            self, t, method=method, rtol=rtol, atol=atol, dt=dt, stabilization=stabilization, baumgarte=baumgarte,
            position_tol=position_tol, max_steps=MAX_STEPS if max_steps is None else max_steps,
            on_separation=on_separation, initial=initial,
        )

    def evaluate(self, *, t: float | None = None):
        """All terms of the equations of motion at the current state.

        Parameters
        ----------
        t : float or None
            Time; default the state's time.

        Returns
        -------
        Evaluation
        """
        return evaluate(self, t=t)

