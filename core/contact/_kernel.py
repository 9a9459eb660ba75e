"""Batched contact kinematics: surface parameters, the five constraints, their reduction to one row.

Notation (one contact; ``i``, ``j`` its bodies; global vectors)::

    r_k = R_k + A_k u_k(s_k)                       contact points (Eq. 8.84)
    t_k = A_k du_k/ds_k, n_k = A_k nu_k(s_k)       tangents, normal field (Eqs. 8.85-8.86)
    C = [P^T (r_i - r_j); n_a . t_b1; n_a . t_b2]  the five constraints (Eqs. 8.90, 8.93-8.94)

``P`` is the identity for surfaces (three point rows) and body i's ``x, y``
axes for planar curves (two in-plane point rows, one normal row). The
normal rows pair the normal field of one surface ``a`` with the tangents of
the other ``b``: ``a = i, b = j`` unless ``surface_j`` has no tangents (a
rim), then ``a = j, b = i``.

Surface parameters as functions of the configuration. For a given
configuration ``q`` the parameters ``s(q)`` solve the four *extremal*
conditions ``E(q, s) = [d . t_b1, d . t_b2, n_a . t_b1, n_a . t_b2] = 0``
(``d = r_i - r_j``): ``d`` and ``n_a`` are both normal to the tangent
plane of ``b``, so the two points face each other along the common normal
(closest points when apart, deepest points when overlapping). On the
constraint manifold these are four of the five constraints, so ``s(q)`` is
the chapter's solution for the non-generalized coordinates; off it the
fifth, the gap ``g = n_i . (r_j - r_i)`` (``n_i`` the unit outward normal
of surface i), is the residual. ``s(q)`` is found by Newton's method, to
round-off, from the solution a run tracked along its accepted steps (or
continued from it in sub-steps, or, when that fails, a global search).

Augmented equations. With ``C_q`` (5 x 6n, Newton-Euler velocities) and
``C_s`` (5 x 4, Eq. 8.97) the chapter's augmented equations (Eqs.
8.95-8.104) are::

    [M    0    C_q^T] [a    ]   [Q    ]
    [0    0    C_s^T] [s_dd ] = [0    ]       (no inertia for s)
    [C_q  C_s  0    ] [lam  ]   [gamma]

``C_s^T lam = 0`` (Eq. 8.105) and rank ``C_s = 4`` (Eq. 8.109) leave the
one-dimensional solution ``lam = N nu`` with ``N`` the left null vector of
``C_s`` (Eqs. 8.106-8.107); premultiplying the last block row by ``N^T``
removes ``s_dd``. What remains is one ordinary constraint row per contact,
``N^T C_q a = N^T gamma``, with the multiplier ``nu``. ``N`` is scaled so
that its point part is the unit normal (``P N_p . n_i = 1``): ``nu`` is
then the normal force (N, positive while pressing) and the row's value
``N^T C = -g`` the penetration.
"""

from __future__ import annotations

import bisect
import math
from typing import Any

import numpy as np

from . import _compiled, _scalar
from ._errors import (  # noqa: F401 - (the kernel's names: tests and callers read them here)
    _CHART_LIMIT,
    _MAX_ITER,
    _STEP_TOL,
    COMPLIANT,
    CONSTRAINT,
    CONTACT_RANK_TOL,
    ContactError,
    _lost,
)
from ._geometry import (  # noqa: F401
    _at,
    _column_scales,
    _cross,
    _det_sign,
    _dot,
    _extremal,
    _Frames,
    _Geo,
    _globalize,
    _Group,
    _Kin,
    _pick,
    _rechart,
    _stack_geometry,
    contact_rows,
    frames_of,
    solve_parameters,
)
from ._search import find_contact

__all__ = ["CONTACT_RANK_TOL", "ContactError", "ContactKernel"]

#: Contacts whose two surfaces are built in (plane, sphere, ellipsoid, torus, a circle or a line of a planar
#: curve) evaluate on the float path through the compiled kernel (``_compiled.contact_packed``); False: on Python
#: floats as contacts of user surfaces do (the kernel's oracle in the tests).
COMPILED = True

#: Systems with at most this many contacts evaluate them on Python floats (``_scalar``). The batched path
#: forms each contact's surface geometry by its own numpy calls on one-row arrays (the surfaces differ), so it
#: costs more per contact at any count: 11 balls on inclines took 21 s batched, 5 s on floats (it was 8).
SCALAR_MAX = 1000


class _Static:
    """Constant data of one contact for the float path."""

    def __init__(self, contact: Any, n: int):
        self.contact = contact
        self.surf_i, self.surf_j = contact.surface_i, contact.surface_j
        self.p = contact.n_parameters
        self.swap = bool(contact.surface_j.degenerate_tangents)
        self.rim_i = bool(contact.surface_i.degenerate_tangents)
        self.rim_j = bool(contact.surface_j.degenerate_tangents)
        # an unbounded plane: Newton's steps along it are not limited (it is linear in its parameters), and a
        # contact point that moved far along it has not jumped
        self.flat_i = bool(contact.surface_i.unbounded)
        self.flat_j = bool(contact.surface_j.unbounded)
        L = min(contact.surface_i.length_scale, contact.surface_j.length_scale)
        self.L = float(L) if math.isfinite(L) else 1.0
        self.rolling = bool(contact.rolling)
        self.charted = bool(contact.surface_i.charted or contact.surface_j.charted)
        self.bi = n if contact.body_i.index < 0 else contact.body_i.index
        self.bj = n if contact.body_j.index < 0 else contact.body_j.index
        # built-in surfaces on both sides: the compiled kernel's description of the contact (else None: the
        # float path, for surfaces of user callables)

        self.packed = _compiled.description(contact)
        # the sides whose derivatives Python hands to the kernel (planar curves of user callables)
        self.curves = [] if self.packed is None else [
            (side, surf) for side, surf in ((0, self.surf_i), (1, self.surf_j)) if self.packed[10 + 16 * side] == 5.0]


class _Entry:
    """One tracked solution: time, chart parameters, charts, body-frame points, sign of det E_s, state."""

    __slots__ = ("t", "s", "charts", "points", "sign", "y")

    def __init__(self, t, s, charts, points, sign, y):
        self.t, self.s, self.charts, self.points, self.sign, self.y = t, s, charts, points, sign, y


class _Track:
    """The surface parameters a run tracked for one contact, in time order (see ContactKernel.evaluate)."""

    __slots__ = ("times", "entries")

    def __init__(self):
        self.times: list[float] = []
        self.entries: list[_Entry] = []

    def add(self, t: float, s, charts, points, sign, y) -> None:
        k = bisect.bisect_right(self.times, t)
        self.times.insert(k, t)
        self.entries.insert(k, _Entry(t, s, charts, points, sign, y))

    def nearest(self, t: float) -> _Entry:
        k = bisect.bisect_left(self.times, t)
        if k >= len(self.times) or (k > 0 and t - self.times[k - 1] <= self.times[k] - t):
            k -= 1
        return self.entries[k]

    def start(self, t: float):
        """Parameters and charts at ``t``: the entry at ``t``, or linear in time between its neighbours."""
        k = bisect.bisect_right(self.times, t)
        if k == 0:
            e = self.entries[0]
            return np.array(e.s), list(e.charts)
        a = self.entries[k - 1]
        if a.t == t or k == len(self.entries):
            return np.array(a.s), list(a.charts)
        b = self.entries[k]
        if a.charts[0] is b.charts[0] and a.charts[1] is b.charts[1] and b.t > a.t:
            w = (t - a.t) / (b.t - a.t)
            return a.s + w * (b.s - a.s), list(a.charts)
        e = a if t - a.t <= b.t - t else b
        return np.array(e.s), list(e.charts)


class ContactKernel:
    """Compiled contacts of a System: groups by parameter count, rows, evaluation.

    Parameters
    ----------
    contacts : sequence of Contact
    n : int
        Number of moving bodies (the ground is index ``n`` in the extended arrays).
    """

    def __init__(self, contacts, n: int):
        self.contacts = tuple(contacts)
        self.n = n
        self.k = len(self.contacts)
        self.groups = []
        for p in (2, 1):
            cs = [c for c in self.contacts if c.n_parameters == p]
            if cs:
                self.groups.append(_Group(cs, p, n))
        self.p = np.array([c.n_parameters for c in self.contacts], dtype=np.intp)
        self.rolling = np.array([c.rolling for c in self.contacts], dtype=bool)
        self.constraint = np.array([c.model == "constraint" for c in self.contacts], dtype=bool)
        self.stiffness = np.array([c.stiffness if c.stiffness is not None else np.nan for c in self.contacts])
        self.damping = np.array([c.damping for c in self.contacts])
        self.exponent = np.array([c.exponent for c in self.contacts])
        self.static = [_Static(c, n) for c in self.contacts]
        self._L = np.array([cs.L for cs in self.static], dtype=float)  # (a compliant contact's deepest press)
        self._all_packed = all(cs.packed is not None for cs in self.static)

    # ------------------------------------------------------------ state
    def initial_state(self, starts: list) -> dict:
        """Warm-start data: parameters and charts per contact (from ``starts``: (s, chart_i, chart_j)), and modes."""
        s = [np.array(st[0], dtype=float) for st in starts]
        charts = [[st[1], st[2]] for st in starts]
        mode = np.where(self.constraint, CONSTRAINT, COMPLIANT).astype(np.int8)
        return {"s": s, "charts": charts, "mode": mode}

    @staticmethod
    def copy_state(state: dict, *, track: dict | None = None) -> dict:
        """A copy of the warm-start data (without the evaluation cache, the prediction rates and the track).

        ``track``: the contact track of a finished run (see :meth:`evaluate`);
        the copy then *replays* it: evaluations inside the run's time span
        start from the run's own solution and add nothing to the track.
        """
        out = {"s": [np.array(x) for x in state["s"]], "charts": [list(ch) for ch in state["charts"]],
               "mode": np.array(state["mode"])}
        if track is not None:
            out["track"] = track
            out["replay"] = True
        return out

    # ------------------------------------------------------------ evaluation
    def evaluate(self, y: np.ndarray, A: np.ndarray, level: int, state: dict, *, t: float | None = None,
                 batched: bool | None = None, commit: bool = True, strict: bool = False):
        """Kinematics of every contact at state ``y`` (13n,) with rotation matrices ``A`` (n, 3, 3).

        Returns a dict of arrays over all contacts (k): ``value``, ``gap``,
        ``normal``, ``point_i``, ``point_j``, ``N`` (k, 5, nan-padded),
        ``rank``, ``s`` (k, 4, nan-padded, chart parameters); level >= 1:
        ``D`` (k, 6n), ``Dr`` (k, 2, 6n) rolling rows; level >= 2:
        ``gamma`` (k,), ``gamma_r`` (k, 2), ``rate`` (k,), ``gamma_c`` (k,
        5). ``batched``: numpy arrays over the contacts (default when
        there are more than :data:`SCALAR_MAX` contacts) or one contact at
        a time on floats.

        Warm start: Newton starts from the *committed* parameters of
        ``state`` (moved by ``s_dot (t - t_committed)``) or else from the
        last evaluation. ``commit`` makes the result the new committed
        start: a run commits only at its accepted, projected states, so a
        stage of a rejected step never moves it. Commits are ordered in
        time: a committed evaluation earlier than the committed start (an
        output or an event inside the last step, projected from the dense
        output) does not move it.

        Track: when ``state`` has a ``"track"`` dict (a run's), every
        committed evaluation is kept in it per contact, with its time,
        parameters, charts and configuration, in time order. An evaluation
        at a time inside the track starts from the track (its entry at that
        time, or linear in time between the entries around it); a run's
        outputs and its history (:meth:`copy_state` with ``track``) thus
        follow the one solution that was tracked along the steps, whatever
        the output density.

        When Newton from the warm start fails (a long step, a trial stage
        far away), the solution is *continued* from the nearest tracked
        configuration to this one in sub-steps (positions linear, Euler
        parameters normalized linear), halved down to 1/1024 of the way;
        only when that fails too is the contact searched afresh. With
        ``strict`` (a run's accepted states) a point found afresh far from
        the tracked one nearest in time is a jump of the contact point and
        an error, and so is a change of sign of ``det E_s`` (Eq. 8.109).

        Raises
        ------
        ContactError
            When a contact point cannot be followed or C_s loses rank
            (Eq. 8.109).
        """
        if batched is None:
            batched = self.k > SCALAR_MAX
        cached = state.get("cache")
        modes = state["mode"].tobytes()  # (a compliant contact is evaluated without its gamma)
        ykey = y.tobytes()
        if cached is not None and cached[1] >= level and cached[2] == batched and cached[5] == modes and (
                cached[6] == ykey):
            if commit:
                self._commit_last(state, t, cached[3], y, A, strict)
            return cached[3]
        res = self._evaluate_batched(y, A, level, state, t) if batched else self._evaluate_floats(
            y, A, level, state, t)
        bad = res["rank"] <= CONTACT_RANK_TOL  # (nan: not computed at level 2)
        if bad.any():
            c = self.contacts[int(np.argmax(bad))]
            when = "" if t is None else f" at t={t:.6g}"
            raise ContactError(
                f"contact {c.name!r}: C_s lost rank{when} (Eq. 8.109; scaled volume {res['rank'][c.index]:.1e}): "
                "the surfaces touch along a line or over an area, where the contact point is not unique", t=t)
        state["cache"] = (np.array(y), level, batched, res, A, modes, ykey)
        if commit:
            self._commit_last(state, t, res, y, A, strict)
        return res

    @staticmethod
    def forget_trials(state: dict) -> None:
        """Drop the warm starts of uncommitted evaluations (a rejected step's stages): the next evaluation
        starts from the committed parameters and the track."""
        for key in ("last", "t_last", "geom", "cache"):
            state.pop(key, None)

    def commit_cached(self, state: dict, t: float, *, strict: bool = False) -> None:
        """Commit the last evaluation, as ``evaluate(..., commit=True)`` at its own state would.

        For a projection that accepts the state of the step's last stage
        without evaluating it again: that stage's contact parameters are
        then the step's, and the track must hold them.
        """
        cached = state.get("cache")
        if cached is not None:
            self._commit_last(state, t, cached[3], cached[0], cached[4], strict)

    def _start(self, state: dict, q: int, t: float | None):
        """Start parameters and a copy of the charts for contact ``q`` (see :meth:`evaluate`).

        Inside the track's time span: the tracked solution at ``t`` (linear
        in time between the entries around it when they share their
        charts). Beyond it: from the committed parameters or those of the
        last evaluation, whichever is nearer in time, moved by the last
        known ``s_dot`` over the time between (a wheel rolling at ``omega``
        turns its rim parameter by ``omega dt`` in a step, beyond the reach
        of Newton's method when a long step is not extrapolated).
        """
        track = state.get("track", {}).get(q)
        if track is not None and t is not None and track.times and t <= track.times[-1]:
            return track.start(t)
        s0 = state["s"][q]
        charts = state["charts"][q]
        pred = state.get("rate", {}).get(q)
        t_c = state.get("t_committed", {}).get(q)
        last = state.get("last", {}).get(q)
        t_last = state.get("t_last", {}).get(q)
        if last is not None and (t is None or t_c is None or (t_last is not None and abs(t - t_last) < abs(t - t_c))):
            s0, charts, t_c = last[0], last[1], t_last
        if t is None or t_c is None or t == t_c:
            return np.array(s0), list(charts)
        rate = None
        if pred is not None and pred[0] == t_c and pred[2] is charts[0] and pred[3] is charts[1]:
            rate = np.asarray(pred[1])  # s_dot at the start's own state (a trial stage's may be anything)
        elif track is not None and len(track.times) >= 2:
            a, b = track.entries[-2], track.entries[-1]
            if b.t == t_c and b.t > a.t and a.charts[0] is charts[0] and a.charts[1] is charts[1] and (
                    b.charts[0] is charts[0] and b.charts[1] is charts[1]):
                rate = (b.s - a.s) / (b.t - a.t)  # the secant of the last two tracked states
        if rate is None:
            return np.array(s0), list(charts)
        return np.asarray(s0) + rate * (t - t_c), list(charts)

    def _commit_last(self, state: dict, t, res: dict, y: np.ndarray, A: np.ndarray, strict: bool) -> None:
        """Make the last evaluation's parameters the committed warm start (checking for jumps when strict).

        The jump and rank-sign checks compare with the tracked solution
        nearest in time (else the committed one). An evaluation earlier
        than the committed start is kept in the track only.
        """
        last = state.get("last", {})
        tracks = state.get("track")
        replay = bool(state.get("replay"))
        body_points = res.get("body_points")  # (the float path's, per contact: the points in the bodies' frames)
        for c in self.contacts:
            q = c.index
            if q not in last:
                continue
            s, charts, restarted, sign = last[q]
            if body_points is not None:
                u = [np.array(x) for x in body_points[q]]
            else:
                u = []
                for body, key in ((c.body_i, "point_i"), (c.body_j, "point_j")):
                    b = body.index
                    x = res[key][q]
                    u.append(x if b < 0 else A[b].T @ (x - y[3 * b : 3 * b + 3]))
            tr = None if tracks is None else tracks.get(q)
            near = tr.nearest(t) if tr is not None and t is not None and tr.times else None
            if near is not None:
                t0, prev, old_sign = near.t, near.points, near.sign
            else:
                t0 = state.get("t_committed", {}).get(q)
                prev = state.setdefault("points", {}).get(q)
                old_sign = state.setdefault("signs", {}).get(q)
            if strict and restarted and prev is not None:
                st_q = self.static[q]
                L = st_q.L
                jump = max(0.0 if st_q.flat_i else float(np.linalg.norm(u[0] - prev[0])),
                           0.0 if st_q.flat_j else float(np.linalg.norm(u[1] - prev[1])))
                if jump > 0.25 * L:
                    when = "" if t is None else f" at t={t:.6g}"
                    since = "" if t0 is None or t is None else f" since t={t0:.6g}"
                    raise ContactError(
                        f"contact {c.name!r}: the contact point jumped by {jump:.3g} m on a body{when}{since}: it "
                        "could not be continued from the tracked one, and the nearest points of the surfaces are "
                        "elsewhere (a surface about to lie flat on the other, or a non-convex profile)", t=t)
            if strict and old_sign is not None and sign != old_sign:
                between = "" if t is None or t0 is None else f" between t={min(t0, t):.6g} and t={max(t0, t):.6g}"
                raise ContactError(
                    f"contact {c.name!r}: the contact passed a configuration where C_s loses rank (Eq. 8.109)"
                    f"{between}: the surfaces lay along each other there (e.g. a disk or a wheel lying flat), "
                    "and the contact point is no longer the nearest one", t=t)
            t_c = state.get("t_committed", {}).get(q)
            if t is None or t_c is None or t >= t_c:
                state["s"][q] = np.array(s)
                state["charts"][q] = list(charts)
                state.setdefault("t_committed", {})[q] = t
                state.setdefault("points", {})[q] = (u[0], u[1])
                state.setdefault("signs", {})[q] = sign
            if tracks is not None and not replay and t is not None:
                if tr is None:
                    tr = tracks[q] = _Track()
                tr.add(t, np.array(s), list(charts), (u[0], u[1]), sign, np.array(y))
            last[q] = (s, charts, False, sign)

    def _empty(self, level: int, *, floats: bool = False) -> dict:
        """Result arrays of an evaluation; ``floats``: without the (k,) and (k, 3) ones, which the float path
        builds from its lists (``value``, ``gap``, ``normal``, ``point_i``, ``point_j``, ``rank``)."""
        k, n = self.k, self.n
        res = {"N": _nan((k, 5)), "s": _nan((k, 4))}
        if not floats:
            res.update({"value": np.zeros(k), "gap": np.zeros(k), "normal": np.zeros((k, 3)),
                        "point_i": np.zeros((k, 3)), "point_j": np.zeros((k, 3)), "rank": np.zeros(k)})
        if level >= 1:
            res["D"] = np.zeros((k, 6 * n))
            res["Dr"] = np.zeros((k, 2, 6 * n))
        if level >= 2:
            res["gamma"] = np.zeros(k)
            res["gamma_r"] = np.zeros((k, 2))
            res["rate"] = np.zeros(k)
            res["gamma_c"] = _nan((k, 5))
        return res

    def _evaluate_floats(self, y, A, level, state, t):
        Frames1, evaluate_one, newton_one, ground_A = _scalar.Frames1, _scalar.evaluate_one, _scalar.newton_one, \
            _scalar.IDENTITY
        n = self.n
        if not self.static:
            return self._empty(level)
        res = self._empty(level, floats=True)
        compiled = COMPILED
        if compiled:
            A = np.ascontiguousarray(A, dtype=float)
            y = np.ascontiguousarray(y, dtype=float)
        # per body (ground last): rotation matrix, position and (level 2) velocity and global omega as tuples
        # (for the contacts of user surfaces; the kernel reads y and A)
        zero = (0.0, 0.0, 0.0)
        floats = not (compiled and self._all_packed)
        if floats:
            A_rows = [tuple(map(tuple, Am)) for Am in A.tolist()] + [ground_A]
            Rl = y[: 3 * n].tolist()
            R_b = [tuple(Rl[3 * b : 3 * b + 3]) for b in range(n)] + [zero]
        if floats and level >= 2:
            Vl = y[7 * n : 10 * n].tolist()
            Wl = y[10 * n :].tolist()  # omega_body; its global components A omega_body
            V_b = [tuple(Vl[3 * b : 3 * b + 3]) for b in range(n)] + [zero]
            W_b = [_scalar._rot(A_rows[b], Wl[3 * b : 3 * b + 3]) for b in range(n)] + [zero]
        order_all = 3 if level >= 2 else 2
        modes = state.get("mode")
        qkey = y[: 7 * n].tobytes()
        geom = state.setdefault("geom", {})  # per contact: the last solution and the configuration it is of
        last_all = state.setdefault("last", {})
        t_last_all = state.setdefault("t_last", {})
        rate_all = state.setdefault("rate", {}) if level >= 2 and t is not None else None
        res_N, res_s = res["N"], res["s"]
        if level >= 1:
            res_D, res_Dr = res["D"], res["Dr"]
        if level >= 2:
            res_gamma, res_rate, res_gamma_c, res_gamma_r = res["gamma"], res["rate"], res["gamma_c"], res["gamma_r"]
        vals, gaps, normals, pis, pjs, ranks = [], [], [], [], [], []
        body_points = [None] * self.k
        _rotT = _scalar._rotT
        for cs in self.static:
            if compiled and cs.packed is not None:  # built-in surfaces: the compiled kernel
                q = cs.contact.index
                light = level >= 2 and modes is not None and modes[q] == COMPLIANT
                s, charts, o, restarted = self._compiled_one(
                    cs, y, A, level, 2 if light else order_all, light, state, t, qkey, geom,
                    res_D[q] if level >= 1 else _NO_ROW, res_Dr[q] if level >= 1 else _NO_ROWS)
                C = _compiled
                p = cs.p
                r = 2 * p + 1
                last_all[q] = (np.array(s), charts, restarted, o[C.O_SIGN])
                t_last_all[q] = t
                body_points[q] = (o[C.O_UI : C.O_UI + 3], o[C.O_UJ : C.O_UJ + 3])
                if rate_all is not None:
                    sd = o[C.O_SDOT : C.O_SDOT + 2 * p]
                    rate_all[q] = (t, sd, charts[0], charts[1], max(abs(x) for x in sd))
                vals.append(o[C.O_VALUE])
                gaps.append(o[C.O_GAP])
                normals.append(o[C.O_NORMAL : C.O_NORMAL + 3])
                pis.append(o[C.O_PI : C.O_PI + 3])
                pjs.append(o[C.O_PJ : C.O_PJ + 3])
                ranks.append(o[C.O_RANK])
                res_N[q, :r] = o[C.O_N : C.O_N + r]
                res_s[q, 0:p] = s[:p]
                res_s[q, 2 : 2 + p] = s[p:]
                if level >= 2:
                    res_rate[q] = o[C.O_RATE]
                    if not light:
                        res_gamma[q] = o[C.O_GAMMA]
                        res_gamma_c[q, :r] = o[C.O_GAMMA_C : C.O_GAMMA_C + r]
                        if cs.rolling:
                            res_gamma_r[q, :p] = o[C.O_GAMMA_R : C.O_GAMMA_R + p]
                continue
            fr = Frames1()
            bi, bj = cs.bi, cs.bj
            fr.Ai, fr.Aj = A_rows[bi], A_rows[bj]
            fr.Ri, fr.Rj = R_b[bi], R_b[bj]
            if level >= 2:
                fr.Vi, fr.Vj = V_b[bi], V_b[bj]
                fr.Wi, fr.Wj = W_b[bi], W_b[bj]
            else:  # (the ground's velocities, as its frame; a moving body's are not known below level 2)
                if bi >= n:
                    fr.Vi = fr.Wi = zero
                if bj >= n:
                    fr.Vj = fr.Wj = zero
            q = cs.contact.index
            # a compliant contact's force needs the gap, the normal, the row and its rate, not gamma: its
            # surfaces' third derivatives are not formed
            light = level >= 2 and modes is not None and modes[q] == COMPLIANT
            order = 2 if light else order_all
            hit = geom.get(q)
            if hit is not None and hit[0] == qkey and len(hit) == 8:
                # the same configuration as an evaluation before (a projection's last iterate, then its
                # velocities projected): the surface parameters depend on q only, Newton has nothing to do
                _, s, charts, gi, gj, Es, done, restarted = hit
                if done < order:  # the third derivatives for gamma, at the converged parameters
                    gi, gj = _scalar.geometry_one(cs, fr, s, charts, order)
                    # and E_s of the same point: Newton's is of its last iterate, which may lie across a jump
                    # of the curvature (a cam law's breakpoint); s_dot from one side and gamma from the other
                    # mixed the two sides' forces (40 N between 25 and 78 N)
                    Es = _scalar._extremal(cs, fr, gi, gj)[1]
            else:
                s0, charts = self._start(state, q, t)
                restarted = False
                try:
                    s, gi, gj, _, Es = newton_one(cs, fr, s0.tolist(), charts, order, t=t)
                    known = self._tracked_sign(state, q, t)
                    if known is not None and _det_sign(Es) != known:  # another branch: continue the tracked one
                        raise ContactError("another branch of the extremal conditions", t=t)
                except ContactError:
                    found = self._continue_one(cs, state, y, t)
                    if found is not None:
                        s, charts = found
                        s, gi, gj, _, Es = newton_one(cs, fr, s, charts, order, t=t)
                    else:
                        s, gi, gj, Es, charts = self._restart_one(cs, fr, order, t)
                        restarted = True
            geom[q] = (qkey, s, charts, gi, gj, Es, order, restarted)
            last_all[q] = (np.array(s), charts, restarted, _det_sign(Es))
            t_last_all[q] = t
            out = evaluate_one(cs, fr, gi, gj, Es, level, rank=level < 2, gamma=not light)  # (rank: at projections)
            body_points[q] = (_rotT(fr.Ai, gi.rho), _rotT(fr.Aj, gj.rho))
            if rate_all is not None:
                sd = out["sdot"]
                speed = max(abs(x) for x in sd) if sd else 0.0
                rate_all[q] = (t, sd, charts[0], charts[1], speed)
            p = cs.p
            r = 2 * p + 1
            vals.append(out["value"])
            gaps.append(out["gap"])
            normals.append(out["normal"])
            pis.append(out["point_i"])
            pjs.append(out["point_j"])
            ranks.append(out["rank"])
            res_N[q, :r] = out["N"]
            res_s[q, 0:p] = s[:p]
            res_s[q, 2 : 2 + p] = s[p:]
            if level >= 1:
                self._scatter_one(res_D[q], cs, out["J"], fr)
                if cs.rolling:
                    for m in range(p):
                        self._scatter_one(res_Dr[q, m], cs, out["Jr"][m], fr)
            if level >= 2:
                res_rate[q] = out["rate"]
                if light:
                    continue
                res_gamma[q] = out["gamma"]
                res_gamma_c[q, :r] = out["gamma_c"]
                if cs.rolling:
                    res_gamma_r[q, :p] = out["gamma_r"]
        res["value"] = np.array(vals, dtype=float)
        res["gap"] = np.array(gaps, dtype=float)
        res["normal"] = np.array(normals, dtype=float)
        res["point_i"] = np.array(pis, dtype=float)
        res["point_j"] = np.array(pjs, dtype=float)
        res["rank"] = np.array(ranks, dtype=float)
        res["body_points"] = body_points
        return res

    def _compiled_one(self, cs, y, A, level, order, light, state, t, qkey, geom, D_row, Dr_rows):
        """One contact of built-in surfaces through the compiled kernel: ``(s, charts, out, restarted)``.

        The same steps as the float path's loop body (warm start, Newton,
        the tracked branch, continuation, search afresh; the cache of the
        last configuration) with Newton and the rows compiled
        (``_compiled.contact_packed``); ``out`` is the kernel's result list.
        """
        C = _compiled
        q = cs.contact.index
        ctl = np.zeros(16, dtype=np.int64)
        ctl[C.C_ORDER] = order
        ctl[C.C_LEVEL] = level
        ctl[C.C_RANK] = level < 2  # (rank: at projections)
        ctl[C.C_GAMMA] = not light
        ctl[C.C_N], ctl[C.C_BI], ctl[C.C_BJ] = self.n, cs.bi, cs.bj
        out = np.empty(C.OUT_SIZE)
        hit = geom.get(q)
        if hit is not None and hit[0] == qkey and len(hit) == 9:  # (the float path's entries have 8 items)
            # the same configuration as an evaluation before: no Newton (see the float path)
            _, s, charts, G, Es, done, restarted, _, _ = hit
            if done < order:  # the third derivatives for gamma, and E_s, at the converged parameters
                G, Es = np.empty((2, 22, 3)), np.empty((4, 4))
                ctl[C.C_MODE] = 1
            else:
                ctl[C.C_MODE] = 2
            _run(cs, y, A, charts, s, ctl, G, Es, out, D_row, Dr_rows)
        else:
            G, Es = np.empty((2, 22, 3)), np.empty((4, 4))
            s0, charts = self._start(state, q, t)
            restarted = False
            try:
                s = self._newton_compiled(cs, y, A, s0, charts, ctl, G, Es, out, D_row, Dr_rows, t)
                known = self._tracked_sign(state, q, t)
                if known is not None and out[C.O_SIGN] != known:  # another branch: continue the tracked one
                    raise ContactError("another branch of the extremal conditions", t=t)
            except ContactError:
                found = self._continue_one(cs, state, y, t)
                if found is None:
                    found = self._search_one(cs, y, A, t)
                    restarted = True
                s0, charts = found
                s = self._newton_compiled(cs, y, A, s0, charts, ctl, G, Es, out, D_row, Dr_rows, t)
            geom[q] = (qkey, s, charts, G, Es, order, restarted, None, "compiled")
        if ctl[C.C_STATUS] == C.SINGULAR_RATE:
            raise ContactError(_lost(cs.contact, None, "the extremal conditions are singular"))
        return s, charts, out.tolist(), restarted

    @staticmethod
    def _newton_compiled(cs, y, A, s0, charts: list, ctl, G, Es, out, D_row, Dr_rows, t):
        """Newton (``_scalar.newton_one``) and the rows in the compiled kernel; re-charts in place in ``charts``
        when the kernel hands the point back beyond its chart. Returns ``s``; raises ContactError."""
        C = _compiled
        s = np.array(s0, dtype=float)
        order = int(ctl[C.C_ORDER])
        ctl[C.C_MODE] = 0
        ctl[C.C_MAXIT] = _MAX_ITER
        ctl[C.C_IT] = 0
        ctl[C.C_CUR] = min(order, 2)
        status = _run(cs, y, A, charts, s, ctl, G, Es, out, D_row, Dr_rows)
        if status in (C.OK, C.SINGULAR_RATE):
            return s
        if status == C.SINGULAR:
            why = ("the extremal conditions are singular (E_s, rank of C_s < 2p, Eq. 8.109): a line or surface "
                   "contact, or a singular point of a parametrization")
        elif status == C.NOT_FINITE:
            why = "the contact geometry is not finite"
        elif status == C.NOT_FACING:
            why = ("Newton reached a pair of points whose normals are not opposed (the far sides of the surfaces, "
                   "or a rim's normal pointing into the disk)")
        else:
            why = (f"Newton on the contact point did not converge in {_MAX_ITER} iterations (last step "
                   f"{out[C.O_STEP]:.2e} of the length scale): the contact point jumped")
        raise ContactError(_lost(cs.contact, t, why), t=t)

    def _search_one(self, cs, y, A, t):
        """The warm start and the continuation failed: search the contact point afresh, ``(s, charts)``."""
        n = self.n
        frames = []
        for b in (cs.bi, cs.bj):
            frames += [np.array(y[3 * b : 3 * b + 3]), A[b]] if b < n else [np.zeros(3), np.eye(3)]
        try:
            info = find_contact(cs.contact.name, cs.surf_i, frames[0], frames[1], cs.surf_j, frames[2], frames[3])
        except ContactError as exc:
            raise ContactError(f"{exc}{'' if t is None else f' (t={t:.6g})'}", t=t) from None
        return list(info["s"]), [info["charts"][0], info["charts"][1]]

    def _pose_frames(self, cs, y: np.ndarray):
        """Rotation matrices and positions of the bodies of contact ``cs`` at state ``y`` (floats)."""
        n = self.n
        fr = _scalar.Frames1()
        for side, b in (("i", cs.bi), ("j", cs.bj)):
            if b < n:
                e0, e1, e2, e3 = (float(x) for x in y[3 * n + 4 * b : 3 * n + 4 * b + 4])
                h = 1.0 / math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
                e0, e1, e2, e3 = e0 * h, e1 * h, e2 * h, e3 * h
                A = ((1.0 - 2.0 * (e2 * e2 + e3 * e3), 2.0 * (e1 * e2 - e0 * e3), 2.0 * (e1 * e3 + e0 * e2)),
                     (2.0 * (e1 * e2 + e0 * e3), 1.0 - 2.0 * (e1 * e1 + e3 * e3), 2.0 * (e2 * e3 - e0 * e1)),
                     (2.0 * (e1 * e3 - e0 * e2), 2.0 * (e2 * e3 + e0 * e1), 1.0 - 2.0 * (e1 * e1 + e2 * e2)))
                setattr(fr, "A" + side, A)  # Eq. 8.48
                setattr(fr, "R" + side, tuple(float(x) for x in y[3 * b : 3 * b + 3]))
            else:
                setattr(fr, "A" + side, _scalar.IDENTITY)
                setattr(fr, "R" + side, (0.0, 0.0, 0.0))
        return fr

    @staticmethod
    def _tracked_sign(state: dict, q: int, t: float | None) -> float | None:
        """Sign of det E_s of the solution tracked nearest in time (else the committed one; None: unknown)."""
        tracks = state.get("track")
        tr = None if tracks is None or t is None else tracks.get(q)
        if tr is not None and tr.times:
            return tr.entries[-1].sign if t >= tr.times[-1] else tr.nearest(t).sign
        return state.get("signs", {}).get(q)

    def _continue_one(self, cs, state: dict, y: np.ndarray, t: float | None):
        """Continue contact ``cs``'s tracked solution to state ``y``: ``(s, charts)``, or None when it fails.

        From the tracked entry nearest in time, along configurations between
        its state and ``y`` (positions linear, Euler parameters linear then
        normalized), by Newton's method in sub-steps of at most a quarter of
        the way, halved on failure down to 1/1024; each sub-step starts from
        the last two solutions extrapolated.
        """
        tracks = state.get("track")
        tr = None if tracks is None or t is None else tracks.get(cs.contact.index)
        if tr is None or not tr.times:
            return None
        e = tr.nearest(t)
        n = self.n
        y0 = e.y
        y1 = np.array(y, dtype=float)
        P0 = y0[3 * n : 7 * n].reshape(n, 4)
        P1 = y1[3 * n : 7 * n].reshape(n, 4)
        flip = np.where(np.einsum("ij,ij->i", P0, P1) < 0.0, -1.0, 1.0)[:, None]  # the nearer of +-p
        s = list(e.s)
        charts = list(e.charts)
        sign = e.sign
        prev = None
        lam, dl = 0.0, 0.25
        while lam < 1.0:
            l1 = min(1.0, lam + dl)
            yl = (1.0 - l1) * y0 + l1 * y1
            yl[3 * n : 7 * n] = ((1.0 - l1) * P0 + l1 * flip * P1).ravel()
            fr = self._pose_frames(cs, yl)
            guess = s if prev is None else [a + (a - b) * (dl / prev[1]) for a, b in zip(s, prev[0])]
            trial = list(charts)
            try:
                s_new, _, _, _, Es = _scalar.newton_one(cs, fr, guess, trial, 2, t=t, max_iter=12)
                # another branch: a sub-step too long, unless it persists in the shortest (a fold, Eq. 8.109,
                # which the commit reports)
                if _det_sign(Es) != sign and dl >= 1.0 / 1024.0:
                    raise ContactError("another branch of the extremal conditions", t=t)
            except ContactError:
                dl *= 0.5
                if dl < 1.0 / 2048.0:
                    return None
                continue
            sign = _det_sign(Es)
            if trial[0] is not charts[0] or trial[1] is not charts[1]:
                prev = None  # re-charted: the last solution is in another chart
            else:
                prev = (s, l1 - lam)
            s, charts, lam = list(s_new), trial, l1
            dl = min(0.25, 2.0 * dl)
        return s, charts

    def _restart_one(self, cs, fr, order, t):
        """The warm start failed: search the contact point afresh (sampling and damped Newton)."""
        Ai, Aj = np.array(fr.Ai), np.array(fr.Aj)
        try:
            info = find_contact(cs.contact.name, cs.surf_i, np.array(fr.Ri), Ai, cs.surf_j, np.array(fr.Rj), Aj)
        except ContactError as exc:
            raise ContactError(f"{exc}{'' if t is None else f' (t={t:.6g})'}", t=t) from None
        charts = [info["charts"][0], info["charts"][1]]
        s, gi, gj, _, Es = _scalar.newton_one(cs, fr, list(info["s"]), charts, order, t=t)
        return s, gi, gj, Es, charts

    def _restart_group(self, g: _Group, fr: _Frames, t):
        s0, charts = [], []
        for q, c in enumerate(g.contacts):
            try:
                info = find_contact(c.name, c.surface_i, fr.R_i[q], fr.A_i[q], c.surface_j, fr.R_j[q], fr.A_j[q])
            except ContactError as exc:
                raise ContactError(f"{exc}{'' if t is None else f' (t={t:.6g})'}", t=t) from None
            s0.append(info["s"])
            charts.append([info["charts"][0], info["charts"][1]])
        return np.stack(s0), charts

    def _scatter_one(self, row: np.ndarray, cs, J, fr) -> None:
        _rotT = _scalar._rotT
        n = self.n
        bi, bj = cs.bi, cs.bj
        if bi < n and bj < n and bi != bj:  # two bodies: the four blocks are disjoint, one assignment each
            row[3 * bi : 3 * bi + 3] = J[0]
            row[3 * n + 3 * bi : 3 * n + 3 * bi + 3] = _rotT(fr.Ai, J[1])
            row[3 * bj : 3 * bj + 3] = J[2]
            row[3 * n + 3 * bj : 3 * n + 3 * bj + 3] = _rotT(fr.Aj, J[3])
            return
        if bi < n:
            b = bi
            row[3 * b : 3 * b + 3] += J[0]
            row[3 * n + 3 * b : 3 * n + 3 * b + 3] += _rotT(fr.Ai, J[1])
        if bj < n:
            b = bj
            row[3 * b : 3 * b + 3] += J[2]
            row[3 * n + 3 * b : 3 * n + 3 * b + 3] += _rotT(fr.Aj, J[3])

    def _evaluate_batched(self, y, A, level, state, t):
        n = self.n
        A_ext = np.empty((n + 1, 3, 3))
        A_ext[:n] = A
        A_ext[n] = np.eye(3)
        R_ext = np.zeros((n + 1, 3))
        R_ext[:n] = y[: 3 * n].reshape(n, 3)
        V_ext = W_ext = None
        if level >= 2:
            V_ext = np.zeros((n + 1, 3))
            V_ext[:n] = y[7 * n : 10 * n].reshape(n, 3)
            W_ext = np.zeros((n + 1, 3))
            W_ext[:n] = np.einsum("kab,kb->ka", A, y[10 * n :].reshape(n, 3))
        res = self._empty(level)
        order = 3 if level >= 2 else 2
        for g in self.groups:
            fr = frames_of(g, A_ext, R_ext, V_ext, W_ext)
            starts = [self._start(state, c, t) for c in g.pos]
            s0 = np.stack([st[0] for st in starts])
            charts = [st[1] for st in starts]
            restarted = False
            try:
                s, gi, gj, _, _, _, Es = solve_parameters(g, fr, s0, charts, order, t=t)
                known = [self._tracked_sign(state, c, t) for c in g.pos]
                got = np.sign(np.linalg.det(Es))
                if any(k is not None and k != x for k, x in zip(known, got)):  # another branch
                    raise ContactError("another branch of the extremal conditions", t=t)
            except ContactError:  # the warm start failed: continue the tracked solutions, else search afresh
                found = [self._continue_one(self.static[c], state, y, t) for c in g.pos]
                if all(f is not None for f in found):
                    s0 = np.array([f[0] for f in found], dtype=float)
                    charts = [f[1] for f in found]
                    s, gi, gj, _, _, _, Es = solve_parameters(g, fr, s0, charts, order, t=t)
                else:
                    s0, charts = self._restart_group(g, fr, t)
                    s, gi, gj, _, _, _, Es = solve_parameters(g, fr, s0, charts, order, t=t)
                    restarted = True
            signs = np.sign(np.linalg.det(Es))
            for q, c in enumerate(g.pos):
                state.setdefault("last", {})[c] = (np.array(s[q]), charts[q], restarted, float(signs[q]))
                state.setdefault("t_last", {})[c] = t
            kin = contact_rows(g, fr, gi, gj, level, self.rolling[g.pos], Es)
            pos = g.pos
            p = g.p
            r = 2 * p + 1
            res["value"][pos] = kin.value
            res["gap"][pos] = kin.gap
            res["normal"][pos] = kin.normal
            res["point_i"][pos] = kin.point_i
            res["point_j"][pos] = kin.point_j
            res["N"][pos, :r] = kin.N
            res["rank"][pos] = kin.rank
            res["s"][pos, 0:p] = s[:, :p]
            res["s"][pos, 2 : 2 + p] = s[:, p:]
            if level >= 1:
                Ai, Aj = fr.A_i, fr.A_j
                res["D"][pos] = self._scatter(g, kin.J, Ai, Aj)
                if kin.Jr is not None:
                    for m in range(p):
                        res["Dr"][pos, m] = self._scatter(g, kin.Jr[:, m], Ai, Aj)
            if level >= 2:
                res["gamma"][pos] = kin.gamma
                res["rate"][pos] = kin.rate
                res["gamma_c"][pos, :r] = kin.gamma_c
                if kin.gamma_r is not None:
                    res["gamma_r"][pos, :p] = kin.gamma_r
        return res

    def _scatter(self, g: _Group, J: np.ndarray, Ai: np.ndarray, Aj: np.ndarray) -> np.ndarray:
        """Rows (k, 6n) in Newton-Euler velocities from coefficients (k, 12) with global omegas."""
        n = self.n
        out = np.zeros((g.k, 6 * n))
        # omega_global = A omega_body: coefficient of omega_body is A^T c
        ci = np.einsum("kab,ka->kb", Ai, J[:, 3:6])
        cj = np.einsum("kab,ka->kb", Aj, J[:, 9:12])
        for q in range(g.k):
            b = int(g.bi[q])
            if b < n:
                out[q, 3 * b : 3 * b + 3] += J[q, 0:3]
                out[q, 3 * n + 3 * b : 3 * n + 3 * b + 3] += ci[q]
            b = int(g.bj[q])
            if b < n:
                out[q, 3 * b : 3 * b + 3] += J[q, 6:9]
                out[q, 3 * n + 3 * b : 3 * n + 3 * b + 3] += cj[q]
        return out

    def compliant_forces(self, res: dict, mode: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Hunt-Crossley normal forces (k,) and the generalized force (6n,) of the compliant contacts.

        ``F = k delta^e (1 + 3/2 c delta_dot)`` for a penetration ``delta =
        -g > 0`` (zero apart, never pulling); on ``body_j`` along the
        normal at its point, the opposite on ``body_i`` at its point:
        ``Q = -F D_row^T`` with ``D_row`` the row of the penetration.
        """
        k = self.k
        F = np.zeros(k)
        on = mode == COMPLIANT
        delta = -res["gap"]
        pen = on & (delta > 0.0)
        if pen.any():
            deep = pen & (delta > self._L)
            if deep.any():
                q = int(np.argmax(deep))
                raise ContactError(
                    f"contact {self.contacts[q].name!r}: pressed in by {delta[q]:.3g} m, more than the surfaces' "
                    f"length scale {self._L[q]:.3g} m: the Hunt-Crossley force law has no meaning there (a step "
                    "too long, which the integrator retries shorter, or a contact too soft for the impact: raise "
                    "its stiffness)")
            dl = np.where(pen, delta, 0.0)
            rate = res["rate"]
            val = self.stiffness * dl ** self.exponent * (1.0 + 1.5 * self.damping * rate)
            F = np.where(pen, np.maximum(val, 0.0), 0.0)
        Q = -(F @ res["D"]) if pen.any() else np.zeros(6 * self.n)
        return F, Q


_IDENTITY3 = np.eye(3)
_NO_ROW = np.zeros(0)  # (the rows of an evaluation below level 1)
_NO_ROWS = np.zeros((2, 0))


_NO_CURVE = (np.zeros((2, 2, 4, 3)), np.zeros((2, 2)))


def _run(cs, y, A, charts: list, s, ctl, G, Es, out, D_row, Dr_rows) -> int:
    """``_compiled.contact_packed`` until it is done: a point beyond its chart is re-charted (in place in
    ``s`` and ``charts``) and a user curve's derivatives at the kernel's iterate are handed in, then the kernel
    resumes. Returns the status."""
    C = _compiled
    desc = cs.packed
    curves = cs.curves
    X, xs = (np.zeros((2, 2, 4, 3)), np.full((2, 2), math.nan)) if curves else _NO_CURVE
    while True:
        C.contact_packed(desc, y, A, _chart_buffer(charts), s, ctl, G, Es, out, D_row, Dr_rows, X, xs)
        status = ctl[C.C_STATUS]
        if status == C.RECHART:
            _scalar._rechart(cs, s, charts)
        elif status == C.DERIVATIVES:  # (a planar curve of user callables: p = 1)
            order = int(ctl[C.C_CUR] if ctl[C.C_MODE] == 0 else ctl[C.C_ORDER])
            for side, surf in curves:
                x = float(s[side])
                D, Dn = surf._derivs_float((x,), order, charts[side])
                for k in range(order + 1):
                    X[side, 0, k] = D[(k,)]
                    if k < order:
                        X[side, 1, k] = Dn[(k,)]
                xs[side] = (x, order)
        else:
            return status


def _chart_buffer(charts: list) -> np.ndarray:
    """(2, 3, 3) the chart rotations of a contact's two sides for the compiled kernel (None: the identity)."""
    out = np.empty((2, 3, 3))
    out[0] = _IDENTITY3 if charts[0] is None else charts[0]
    out[1] = _IDENTITY3 if charts[1] is None else charts[1]
    return out


def _nan(shape: tuple) -> np.ndarray:
    """``np.full(shape, nan)`` without its Python-level overhead (small arrays, built per evaluation)."""
    a = np.empty(shape)
    a.fill(math.nan)
    return a

