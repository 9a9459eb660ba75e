"""The state ``(t, q, v)`` of a System's bodies, the state a run ends in, and the tangent-space moves on them.

:class:`State` is a read-only snapshot owned by one System (its accessors take
body handles); :class:`RunState` is the state a run ended in (positions,
velocities, time, the contacts' surface parameters and models), free of the
System, small and picklable, so a run can continue from it in another process:
``system.simulate(t, initial=traj.final_state)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigidlab.core._validation import float_array, short_repr

from ._elements import Body
from ._engine import matrices

__all__ = ["RunState", "State"]


def _vector(x: Any, name: str, size: int = 3) -> np.ndarray:
    a = float_array(x, name, expected=f"a ({size},) vector of real numbers", copy=True)
    if a.shape != (size,):
        raise ValueError(f"{name}: expected shape ({size},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values, got {a.tolist()}")
    return a


# ------------------------------------------------------------------ state
@dataclass(frozen=True, eq=False)
class State:
    """The state ``(t, q, v)`` of a System's bodies (a read-only snapshot).

    Layout for ``n`` bodies (ground excluded), in the order they were added::

        q = [R (3n) | p (4n)]            centres of mass (global, m); Euler
                                         parameters (scalar first, unit)
        v = [R_dot (3n) | omega_body (3n)]  global velocities (m/s); body-frame
                                         angular velocities (rad/s)

    The accessors take a body handle and return copies.

    Attributes
    ----------
    t : float
        Time (s).
    q : (7n,) ndarray
    v : (6n,) ndarray
    """

    t: float
    q: np.ndarray = field(repr=False)  # (7n,)
    v: np.ndarray = field(repr=False)  # (6n,)
    _owner: Any = field(repr=False, compare=False)
    # surface parameters and charts of the contacts at this state, per contact (s, chart_i, chart_j), when
    # known (a trajectory's state): set_state makes them the warm start of the next run's contact Newton
    _contacts: Any = field(default=None, repr=False, compare=False)

    @property
    def n_bodies(self) -> int:
        """Number of bodies (ground excluded) the state describes."""
        return self.v.shape[0] // 6

    def _index(self, body: Any) -> int:
        if not isinstance(body, Body):
            raise ValueError(f"body: expected a Body, got {short_repr(body)}")
        if body._owner is not self._owner:
            raise ValueError(f"body: {body.name!r} belongs to another System than this state")
        if body.index >= self.n_bodies:
            raise ValueError(
                f"body: {body.name!r} was added after this state was taken; the state does not know it"
            )
        return body.index

    def position(self, body: Body) -> np.ndarray:
        """(3,) centre of mass R of ``body``, global (m); the origin for the ground."""
        i = self._index(body)
        return np.zeros(3) if i < 0 else self.q[3 * i : 3 * i + 3].copy()

    def orientation(self, body: Body) -> np.ndarray:
        """(4,) Euler parameters of ``body`` (scalar first, unit); ``(1, 0, 0, 0)`` for the ground."""
        i = self._index(body)
        if i < 0:
            return np.array([1.0, 0.0, 0.0, 0.0])
        n = self.n_bodies
        p = self.q[3 * n + 4 * i : 3 * n + 4 * i + 4]
        return p / np.linalg.norm(p)

    def velocity(self, body: Body) -> np.ndarray:
        """(3,) velocity of the centre of mass, global (m/s)."""
        i = self._index(body)
        return np.zeros(3) if i < 0 else self.v[3 * i : 3 * i + 3].copy()

    def omega_body(self, body: Body) -> np.ndarray:
        """(3,) angular velocity in the body frame (the chapter's omega-bar, rad/s)."""
        i = self._index(body)
        n = self.n_bodies
        return np.zeros(3) if i < 0 else self.v[3 * n + 3 * i : 3 * n + 3 * i + 3].copy()

    def omega(self, body: Body) -> np.ndarray:
        """(3,) angular velocity in the global frame (rad/s): ``A(p) omega_body``."""
        i = self._index(body)
        if i < 0:
            return np.zeros(3)
        return matrices(self.orientation(body)[None])[0] @ self.omega_body(body)

    def rotation_matrix(self, body: Body) -> np.ndarray:
        """(3, 3) rotation matrix A of ``body`` (body to global, Eq. 8.48)."""
        return matrices(self.orientation(body)[None])[0]

    def point(self, body: Body, u_body: Any) -> np.ndarray:
        """(3,) global position ``R + A u_body`` of a point given in the body frame."""
        u = _vector(u_body, "u_body")
        return self.position(body) + self.rotation_matrix(body) @ u

    def displaced(self, dq: Any = None, dv: Any = None) -> State:
        """A new state moved by tangent-space increments.

        Parameters
        ----------
        dq : (6n,) or None
            ``[dR (3n) | dpi_body (3n)]``: translations (global, m) and small
            rotations (body frame, rad); the Euler parameters become
            ``p * exp(dpi_body / 2)`` (quaternion product, exact).
        dv : (6n,) or None
            Added to ``v``.

        Returns
        -------
        State
            Same time, same System.
        """
        n = self.n_bodies
        y = np.concatenate([self.q, self.v])
        if dq is not None:
            d = float_array(dq, "dq", copy=True)
            if d.shape != (6 * n,) or not np.all(np.isfinite(d)):
                raise ValueError(f"dq: expected finite increments of shape ({6 * n},), got {short_repr(dq)}")
            y = retract(y, n, d)
        if dv is not None:
            d = float_array(dv, "dv", copy=True)
            if d.shape != (6 * n,) or not np.all(np.isfinite(d)):
                raise ValueError(f"dv: expected finite increments of shape ({6 * n},), got {short_repr(dv)}")
            y[7 * n :] += d
        return _make_state(self._owner, self.t, y)


def _make_state(owner: Any, t: float, y: np.ndarray) -> State:
    n = y.shape[0] // 13
    q = np.array(y[: 7 * n])
    v = np.array(y[7 * n :])
    q.setflags(write=False)
    v.setflags(write=False)
    return State(float(t), q, v, owner)


def exp_parameters(phi: np.ndarray) -> np.ndarray:
    """Euler parameters (k, 4) of rotation vectors phi (k, 3): ``(cos(|phi|/2), sin(|phi|/2) phi/|phi|)``."""
    ang = np.sqrt(np.einsum("ki,ki->k", phi, phi))
    half = 0.5 * ang
    # sin(x/2)/x, accurate near 0
    with np.errstate(invalid="ignore", divide="ignore"):
        sinc = np.where(ang > 1e-4, np.sin(half) / np.where(ang > 0, ang, 1.0), 0.5 - ang * ang / 48.0)
    return np.concatenate([np.cos(half)[:, None], sinc[:, None] * phi], axis=1)


def quaternion_products(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products (k, 4) of (k, 4) arrays, scalar first (Eqs. 8.69-8.72)."""
    w1, x1, y1, z1 = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    w2, x2, y2, z2 = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=1,
    )


def retract(y: np.ndarray, n: int, dq: np.ndarray) -> np.ndarray:
    """``y`` (13n,) moved by tangent increments dq = [dR (3n) | dpi_body (3n)] (new array, unit p)."""
    out = np.array(y, dtype=float)
    out[: 3 * n] += dq[: 3 * n]
    P = out[3 * n : 7 * n].reshape(n, 4)
    P = quaternion_products(P, exp_parameters(dq[3 * n : 6 * n].reshape(n, 3)))
    P /= np.linalg.norm(P, axis=1)[:, None]
    out[3 * n : 7 * n] = P.ravel()
    return out


#: Contact models a :class:`RunState` names per contact (``ContactKernel``'s mode codes 0 and 1).
RUN_CONTACT_MODELS = ("constraint", "compliant")


def _frozen(a: Any) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class RunState:
    """The state a run ended in, to continue from: ``system.simulate(t, initial=traj.final_state)``.

    Small, frozen and picklable (no reference to the System: it crosses
    process boundaries), as MuJoCo's rollout takes its initial state. A run
    started from it is the continuation of the run that produced it: the
    same positions and velocities, the contacts' Newton starting from the
    surface parameters they had (their warm start) and every contact in the
    model it had then (a constraint-model contact that separated with
    ``on_separation="compliant"`` stays compliant).

    Layout for ``n`` bodies, as :class:`State`::

        q = [R (3n) | p (4n)]               global centres of mass (m); Euler
                                            parameters (scalar first, unit)
        v = [R_dot (3n) | omega_body (3n)]  global velocities (m/s); body-frame
                                            angular velocities (rad/s)

    Attributes
    ----------
    t : float
        Time (s); a run from this state starts here.
    q : (7n,) read-only ndarray
    v : (6n,) read-only ndarray
    contact_parameters : tuple of (p,) read-only ndarrays, or None
        Per contact (in the order of ``system.contacts``), the surface
        parameters of its contact point (both surfaces' chart parameters,
        Eqs. 8.90-8.109); None when not known (no contacts, or a state
        made by hand: the run then searches the contact points afresh).
    contact_charts : tuple of (chart_i, chart_j), or None
        Per contact, the charts those parameters are in (None or a (3, 3)
        rotation of a charted surface's parametrization).
    contact_models : tuple of str
        Per contact, ``"constraint"`` or ``"compliant"``: the model the
        contact was in at ``t``.
    """

    t: float
    q: np.ndarray = field(repr=False)  # (7n,)
    v: np.ndarray = field(repr=False)  # (6n,)
    contact_parameters: tuple | None = field(default=None, repr=False)  # k x (p,)
    contact_charts: tuple | None = field(default=None, repr=False)  # k x (chart_i, chart_j)
    contact_models: tuple = ()  # k x str

    def __post_init__(self) -> None:
        object.__setattr__(self, "t", float(self.t))
        object.__setattr__(self, "q", _frozen(self.q))
        object.__setattr__(self, "v", _frozen(self.v))
        if self.contact_parameters is not None:
            object.__setattr__(self, "contact_parameters", tuple(_frozen(s) for s in self.contact_parameters))
        if self.contact_charts is not None:
            object.__setattr__(self, "contact_charts", tuple(
                tuple(None if ch is None else _frozen(ch) for ch in pair) for pair in self.contact_charts))
        object.__setattr__(self, "contact_models", tuple(str(m) for m in self.contact_models))

    def __reduce__(self):
        return (RunState, (self.t, self.q, self.v, self.contact_parameters, self.contact_charts,
                           self.contact_models))

    @property
    def n_bodies(self) -> int:
        """Number of bodies (ground excluded) the state describes."""
        return self.v.shape[0] // 6


def _run_state(t: float, y: np.ndarray, contacts: Any = None, modes: Any = None) -> RunState:
    """A :class:`RunState` at ``t`` of ``y`` (13n,); ``contacts``: per contact ``(s, chart_i, chart_j)`` or
    None; ``modes``: (k,) mode codes (0 constraint, 1 compliant) or None."""
    n = y.shape[0] // 13
    params = charts = None
    if contacts is not None:
        params = tuple(s for s, _, _ in contacts)
        charts = tuple((ci, cj) for _, ci, cj in contacts)
    models = () if modes is None else tuple(RUN_CONTACT_MODELS[int(m)] for m in modes)
    return RunState(float(t), y[: 7 * n], y[7 * n :], params, charts, models)
