"""Dynamics: the index-1 equations, their stabilization, integration and the trajectory.

The accelerations come from the augmented equations (Newton-Euler form)

    [[M, D^T], [D, 0]] [a; lambda] = [Q_e + Q_v; gamma]

solved by the Schur complement ``D M^-1 D^T`` (Cholesky) when ``M`` is
regular, and as one LU-factorized system when a body has no rotational
inertia. After every step the state is projected back onto the position
constraints (Newton, least change in the mass metric) and the velocity
constraints (mass-weighted); Baumgarte's feedback is the compared option.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from scipy.linalg import lapack
from scipy.optimize import brentq

from rigidlab.core._constants import DEFAULT_ATOL, DEFAULT_RTOL
from rigidlab.core._errors import ArgumentError
from rigidlab.core._validation import output_times, positive_integer, real_number, short_repr
from rigidlab.core import integrators
from rigidlab.core.integrators import (
    MAX_STEPS,
    STALLED_STEP,
    DriftReport,
    IntegrationError,
    RunFailure,
    Trajectory,
    _budget_error,
    _BudgetExceeded,
    attach_partial,
    integrate,
)

from ._analysis import (
    AssemblyError,
    analyze_rank,
    check_constrained_mass,
    constraints_at,
    flipped_motors,
    metric_inv_sqrt,
    row_label,
)
from ._elements import Body, Joint, Motor
from . import _kernel
from ._engine import (
    SingularSystemError,
    _call_load,
    _Engine,
    _FactorizationFailed,
    cross,
    einsum,
    matrices,
    parameter_rates,
)
from ._state import RUN_CONTACT_MODELS, RunState, State, _make_state, _run_state

__all__ = [
    "ADAPTIVE_METHODS",
    "FIXED_STEP_METHODS",
    "KINEMATIC_METHOD",
    "SEPARATION_ACTIONS",
    "STABILIZATIONS",
    "MultibodyTrajectory",
]

#: scipy's adaptive Runge-Kutta methods, stepped one accepted step at a time.
ADAPTIVE_METHODS = ("DOP853", "RK45")
#: Kinematic analysis instead of integration, for a System whose constraints
#: fix every coordinate (zero degrees of freedom, e.g. a driven mechanism or a
#: cam turned by a motor with its follower on the cam).
KINEMATIC_METHOD = "kinematic"
#: Integrator of a kinematic run after a separation gave it a degree of freedom.
KINEMATIC_CONTINUATION = "DOP853"
#: The project's fixed-step methods, run through :func:`rigidlab.core.integrators.integrate`.
FIXED_STEP_METHODS = ("rk4", "midpoint")
#: Constraint stabilization options of :func:`simulate`.
STABILIZATIONS = ("projection", "baumgarte", "none")
#: What :func:`simulate` does when the normal force of a constraint-model
#: contact crosses zero (the contact would have to pull).
SEPARATION_ACTIONS = ("stop", "compliant", "bilateral")
#: A normal force below ``-SEPARATION_TOL`` times the force scale of the run
#: (the largest of the applied forces, the normal forces and the bodies'
#: centripetal forces ``m |omega|^2 r_g`` at the start) is a separation;
#: round-off around a zero normal force is not.
SEPARATION_TOL = 1e-9


# ------------------------------------------------------------------ model
_NO_SELECTION = object()  # (see _Dynamics._kc_refused)


class _Dynamics:
    """The first-order model ``y' = f(t, y)`` of a compiled System, for core.integrators."""

    def __init__(self, system: Any, eng: _Engine, *, stabilization: str, baumgarte: float, position_tol: float):
        self.system = system
        self.eng = eng
        self.state_size = eng.y_size
        self.alpha = baumgarte if stabilization == "baumgarte" else 0.0
        self.position_tol = position_tol
        if stabilization != "projection":
            self.project = None
        n = eng.n
        self._n = n
        self._n3, self._n7, self._n10 = 3 * n, 7 * n, 10 * n
        self.output_times: frozenset = frozenset()
        self.residuals: dict[float, tuple[np.ndarray, float, float]] = {}
        # per output time (contacts only): (state, mode, lambda, D, contact evaluation, charts) of the
        # level-2 evaluation after the output's projection, shared by the multipliers and the energy
        self.outputs: dict[float, tuple] = {}
        # With a regular, diagonal M the projection metric is M, so D M^-1 D^T of
        # the last right-hand side (its Cholesky factor) serves the projection.
        self._reuse = (stabilization == "projection" and eng.mass_regular and eng.minv_sqrt is not None
                       and eng.winv_diag is not None and not self.alpha and not eng.nonholonomic_rows.size)
        self._last: tuple | None = None
        # separation events of constraint-model contacts (see stop_time)
        self.on_separation = "stop"
        self.separation_tol = 0.0
        self.events: list[tuple[float, int, np.ndarray, str]] = []
        self._lam_last: tuple | None = None  # (t, lambda) of the last right-hand side
        self._acc_key: tuple | None = None  # (t, y, modes) of the kept accelerations (see accelerations)
        self._acc_last: tuple | None = None
        self._acc_eval: Any = None
        self.applied_last: np.ndarray | None = None
        self._nu_prev: tuple | None = None  # (t, normal forces) at the end of the last step
        # the outputs are the ends of the steps (a kinematic analysis): their contact rates s_dot are the warm
        # start's prediction for the next step (see _record_output)
        self.outputs_end_steps = False
        # a compliant contact's touch or lift (its gap crossing zero) ends an adaptive run's step there, when
        # the run sets locate_touches (see stop_time); touched: the last stop was one
        self.locate_touches = False
        self.touched = False
        self._gap_prev: tuple | None = None  # (t, gaps) at the end of the last step
        self._stage_evals: dict = {}  # t -> contact evaluation of the right-hand sides since the last step
        self._separations = any(c.model == "constraint" for c in eng.contacts)
        # the compiled kernels (None: the numpy evaluation): see _compiled and _kernel
        self.kc = eng.compiled
        self._has_loads = self.kc is not None and bool(self.kc.user_forces or self.kc.user_torques)
        # the row selection (eng.keep, by identity) whose tree met a pivot that is not definite: the numpy path
        # takes over until the rank analysis picks other rows
        self._kc_refused: Any = _NO_SELECTION

    def failure(self, t: float, y: np.ndarray, exc: BaseException | None) -> BaseException | None:
        """The error of a run that failed after its last accepted state ``(t, y)``, or (``exc`` None) whose
        steps have shrunk to nothing there (``rigidlab.core.integrators`` asks): a dead point's
        :class:`SingularSystemError` when the state is one (see :func:`dead_point_error`), else ``exc``."""
        return dead_point_error(self.eng, t, y, exc)

    def stage_rejected(self) -> None:
        """A step's trial stage could not be evaluated (see ``rigidlab.core.integrators``): the retried step's
        contacts start again from the accepted states, not from the failed stages' parameters."""
        if self.eng.contact_kernel is not None:
            self.eng.contact_kernel.forget_trials(self.eng.contact_state)
        self._acc_key = None
        self._last = None

    def _state(self, t: float, y: np.ndarray) -> State:
        return _make_state(self.system, t, y)

    def _solve(self, t, y, D, Q, gamma):
        eng = self.eng
        try:
            return eng.solve(t, D, Q, gamma)
        except _FactorizationFailed:
            _recheck_rank(eng, t, y)
            try:
                return eng.solve(t, D, Q, gamma)
            except _FactorizationFailed:
                raise SingularSystemError(
                    f"the constrained equations became singular at t={t:.6g} although the constraint rows "
                    "are independent: the constrained mass matrix is singular there", t=t) from None

    def accelerations(self, t: float, y: np.ndarray, *, commit: bool = True):
        """``(a (6n,), lambda (m,), C, D, C_t)`` at ``(t, y)``.

        The last result is kept with its applied forces (``self.applied_last``)
        and returned again for the same ``t``, ``y`` and contact modes (an
        output's evaluation serves the separation test's force scale and the
        kinematic steps' rates).
        """
        eng = self.eng
        key = (t, y.tobytes(), eng.contact_state["mode"].tobytes() if eng.contacts else b"")
        if self._acc_key == key:
            eng.contact_eval = self._acc_eval  # as the evaluation would leave it (callers read it)
            return self._acc_last
        At, Y, Phi, gam = eng.table(t, y, level=2, commit=commit)
        C, D, Ct, gamma = eng.constraint_rows(t, Y, Phi, gam, level=2)
        if self.alpha:
            al = self.alpha
            gamma = gamma - 2.0 * al * (D @ y[self._n7 :] + Ct) - al * al * C
        Q = eng.applied(t, y, At, Y, Phi, self._state)
        if eng.m:
            a, lam = self._solve(t, y, D, Q, gamma)
        else:
            a, lam = eng.solve(t, np.zeros((0, 6 * eng.n)), Q, np.zeros(0))
        self._acc_key, self._acc_last, self.applied_last = key, (a, lam, np.array(C), np.array(D), np.array(Ct)), Q
        self._acc_eval = eng.contact_eval
        return self._acc_last

    def _loads(self, t: float, y: np.ndarray, F: np.ndarray, T: np.ndarray) -> None:
        """The user's forces and torques at ``(t, y)`` into ``F`` (k, 3) and ``T`` (l, 3), global (Python callables)."""
        state = self._state(t, y)
        kc = self.kc
        for k, (item, _, _) in enumerate(kc.user_forces):
            F[k] = _call_load(item, t, state, "force")
        for k, (item, _) in enumerate(kc.user_torques):
            T[k] = _call_load(item, t, state, "torque")

    def _spring_error(self, k: int, t: float) -> SingularSystemError:
        return SingularSystemError(
            f"spring_damper '{self.eng.springs[k].name}': its two points coincide at t={t:.6g}, "
            "the direction of its force is undefined (free_length > 0)", t=t)

    def _compiled_at(self, t: float) -> bool:
        """Whether the compiled kernels take this evaluation (not for a row selection they refused); if so,
        their work arrays are this selection's and the motors' values at ``t`` are written."""
        if self._kc_refused is self.eng.keep:
            return False
        kc = self.kc
        kc.select(self.eng.keep)
        if kc.motors:
            kc.motor_values(t)
        return True

    def _rhs_compiled(self, t: float, y: np.ndarray) -> np.ndarray | None:
        """The right-hand side on the compiled kernels: rows, forces and Baraff's O(N) solve of Eq. 8.109.

        One call into ``_kernel.rhs_packed`` after the Python callables (motor
        laws, user loads) have written their values. None when the tree's
        factorization meets a pivot that is not definite (the caller then
        takes the numpy path, which checks the rank).
        """
        if not self._compiled_at(t):
            return None
        kc = self.kc
        if self._has_loads:
            self._loads(t, y, kc.uf_F, kc.ut_T)
        ydot = np.empty(self.state_size)
        st = _kernel.rhs_packed(kc.I, kc.F, kc.TI, kc.W, y, ydot, self.alpha)
        if st:
            if st >= 3:
                raise self._spring_error(st - 3, t)
            self._kc_refused = self.eng.keep
            return None
        return ydot

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """``y_dot = [R_dot, p_dot = G_bar^T omega_body / 2, a]`` (Eqs. 8.51-8.54)."""
        if self.kc is not None:
            ydot = self._rhs_compiled(t, y)
            if ydot is not None:
                return ydot
        eng = self.eng
        n, n3, n7, n10 = self._n, self._n3, self._n7, self._n10
        At, Y, Phi, gam = eng.table(t, y, level=2, commit=False)  # a stage: not a warm start of the contacts
        C, D, Ct, gamma = eng.constraint_rows(t, Y, Phi, gam, level=2)
        if self.alpha:
            al = self.alpha
            gamma = gamma - 2.0 * al * (D @ y[n7:] + Ct) - al * al * C
        Q = eng.applied(t, y, At, Y, Phi, self._state)
        if self.locate_touches:
            self._stage_evals[t] = eng.contact_eval  # (the stage at the step's end: its gaps serve the touch check)
        if eng.m:
            eng.last_factor = None
            a, lam = self._solve(t, y, D, Q, gamma)
            self._lam_last = (t, lam)
            if self._reuse:
                # the projection after a step starts where the step's last evaluation is (FSAL):
                # keep its work (valid while no other evaluation overwrote the buffers)
                self._last = (y, t, C, D, Ct, eng.last_factor, eng.generation)
        else:
            a = eng.solve(t, np.zeros((0, 6 * n)), Q, np.zeros(0))[0]
        return np.concatenate([y[n7:n10], parameter_rates(y[n3:n7].reshape(n, 4), y[n10:].reshape(n, 3)).ravel(), a])

    def normal_forces(self, t: float, y: np.ndarray, lam: np.ndarray | None = None) -> np.ndarray:
        """(k,) normal forces of the contacts in the constraint model at ``(t, y)`` (nan for the others)."""
        eng = self.eng
        if lam is None:
            lam = self.accelerations(t, y, commit=False)[1]
        mode = eng.contact_state["mode"]
        out = np.full(len(eng.contacts), np.nan)
        for c in eng.contacts:
            r = eng.contact_row[c.index]
            if r >= 0 and mode[c.index] == 0:
                out[c.index] = lam[r]
        return out

    def stop_time(self, t0: float, y0: np.ndarray, t1: float, y1: np.ndarray, dense) -> float | None:
        """The integrators' event check: the earliest zero crossing of a normal force, or of a compliant
        contact's gap, in ``[t0, t1]``.

        A constraint-model contact whose normal force is below
        ``-separation_tol`` at the end of the step has crossed zero in it;
        the crossing is located by Brent's method on the normal force along
        the step's (projected) dense output and recorded in ``events``. With
        ``on_separation="bilateral"`` the run goes on (None is returned);
        otherwise it stops at the earliest crossing.

        With ``locate_touches`` (an adaptive run), a compliant contact whose
        gap changed sign in the step (a touch or a lift, see
        :meth:`_touch_time`) ends the run there too, unless a separation
        comes first; ``touched`` tells the caller to go on from that instant
        with a new run.
        """
        touch = self._touch_time(t0, y0, t1, y1, dense) if self.locate_touches else None
        if touch is not None:
            t1, y1 = touch, dense(touch)
        te = self._separation_time(t0, y0, t1, y1, dense) if self._separations else None
        if te is not None or touch is None:
            if touch is not None:
                self._gap_prev = None
            return te
        self.touched = True
        return touch

    def _gaps(self, t: float, y: np.ndarray) -> np.ndarray:
        """(k,) gaps of the contacts in the compliant model at ``(t, y)`` (nan for the others)."""
        eng = self.eng
        n = eng.n
        res = eng.contact_kernel.evaluate(y, matrices(y[3 * n : 7 * n].reshape(n, 4)), 0, eng.contact_state, t=t,
                                          commit=False)
        return np.where(eng.contact_state["mode"] != 0, res["gap"], np.nan)

    def _touch_time(self, t0: float, y0: np.ndarray, t1: float, y1: np.ndarray, dense) -> float | None:
        """The earliest instant in ``(t0, t1]`` at which a compliant contact's gap crosses zero, or None.

        The Hunt-Crossley force ``k d^e`` is not smooth where the press
        ``d`` starts or ends (its second derivative is unbounded for ``e <
        2``): a step of an order-8 method across that instant
        carries an error its estimate misses, and how large it is depends on
        where the step falls. Located by Brent's method on the gap along the
        step's dense output, the instant becomes the end of one step and the
        start of the next. A ball dropped on a sphere 41 times from heights
        within 1 um: energy errors of 1.4e-7 to 1.5e-7 at rtol 1e-8, against
        1.7e-7 to 1.1e-5 with steps across the touches.

        A gap within 1e-12 of the contact's length scale of zero at ``t0``
        (the start of a run at a touch or a separation) is not a crossing.
        """
        eng = self.eng
        stage = self._stage_evals.get(t1)
        self._stage_evals.clear()
        if not eng.contact_state["mode"].any():
            self._gap_prev = None
            return None
        prev = self._gap_prev
        g0 = prev[1] if prev is not None and prev[0] == t0 else self._gaps(t0, y0)
        if stage is not None:  # the step's stage at its end (before the projection, a round-off away)
            g1 = np.where(eng.contact_state["mode"] != 0, stage["gap"], np.nan)
        else:
            g1 = self._gaps(t1, y1)
        self._gap_prev = (t1, g1)
        at_zero = np.abs(g0) <= 1e-12 * eng.contact_kernel._L
        crossed = np.flatnonzero(((g0 > 0.0) != (g1 > 0.0)) & np.isfinite(g0) & np.isfinite(g1) & ~at_zero)
        found = []
        for c in crossed.tolist():
            def f(tt, c=c):
                return float(self._gaps(tt, dense(tt))[c])

            try:
                te = brentq(f, t0, t1, xtol=1e-15 * max(1.0, abs(t1)), rtol=4.0 * np.finfo(float).eps, maxiter=200)
            except ValueError:  # no sign change along the dense output
                continue
            if te > t0:
                found.append((te, c))
        if not found:
            return None
        te, c = min(found)
        g_te = self._gaps(te, dense(te))
        g_te[c] = g1[c]  # the next step starts on the side the gap crossed to
        self._gap_prev = (te, g_te)
        return te

    def _separation_time(self, t0: float, y0: np.ndarray, t1: float, y1: np.ndarray, dense) -> float | None:
        """The separation part of :meth:`stop_time` (constraint-model contacts)."""
        tol = self.separation_tol
        cached = self._lam_last
        if cached is not None and cached[0] == t1:
            nu1 = self.normal_forces(t1, y1, cached[1])  # the step's last stage (before the projection)
            if not np.any(nu1 < 0.0):
                self._nu_prev = (t1, nu1)
                return None
        nu1 = self.normal_forces(t1, y1)
        crossing = np.flatnonzero(nu1 < -tol)
        prev = self._nu_prev
        nu0 = prev[1] if prev is not None and prev[0] == t0 else self.normal_forces(t0, y0)
        self._nu_prev = (t1, nu1)
        new = [int(c) for c in crossing if not nu0[c] < -tol]
        if not new:
            return None
        found = []
        for c in new:
            if not nu0[c] > 0.0:
                te = t0
            else:
                def f(tt, c=c):
                    return float(self.normal_forces(tt, dense(tt))[c])

                try:
                    te = brentq(f, t0, t1, xtol=1e-15 * max(1.0, abs(t1)), rtol=4.0 * np.finfo(float).eps, maxiter=200)
                except ValueError:  # no sign change along the dense output: the start is the crossing
                    te = t0
            found.append((te, c))
        found.sort()
        if self.on_separation == "bilateral":
            for te, c in found:
                self.events.append((te, c, dense(te), "bilateral"))
            return None
        te, c = found[0]
        self.events.append((te, c, dense(te), "stopped" if self.on_separation == "stop" else "compliant"))
        return te

    def _metric_factor(self, Dk: np.ndarray, t: float):
        eng = self.eng
        WD = Dk * eng.winv_diag if eng.winv_diag is not None else eng.winv_apply(Dk.T).T
        c, info = lapack.dpotrf(WD @ Dk.T, lower=0, overwrite_a=1, clean=0)
        if info != 0:
            raise _FactorizationFailed(t)
        return WD, c

    def _project_compiled(self, t: float, y_in: np.ndarray) -> np.ndarray | None:
        """:meth:`project` on the compiled kernels (``_kernel.project_packed``): each Newton step and each
        velocity correction is one O(N) solve of ``[[W, D^T], [D, 0]]`` (Eq. 8.109's matrix with the metric
        W). None when a pivot is not definite (the caller then takes the numpy path, which checks the rank)."""
        if not self._compiled_at(t):
            return None
        kc = self.kc
        y = np.array(y_in, dtype=float)
        st, res, rv = _kernel.project_packed(kc.I, kc.F, kc.TI, kc.W, y, self.position_tol)
        if st in (4, 5):
            raise IntegrationError(
                f"projection onto the constraints did not converge at t={t:.6g} (residual {res:.3e}); "
                "tighten the tolerances or reduce the step", t=t)
        if st:
            self._kc_refused = self.eng.keep
            return None
        if t in self.output_times:
            self.residuals[t] = (y.copy(), res, rv)
        return y

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        """Newton projection of positions onto ``C(q, t) = 0``, then of velocities onto ``D v + C_t = 0``.

        Both corrections are least-change in the metric ``W`` (the mass
        matrix): ``dq = -W^-1 D^T (D W^-1 D^T)^-1 C`` applied as ``R +=
        dR`` and ``p <- (p + G_bar^T dpi_body / 2) / |.|`` (a first-order
        retraction; Newton stays quadratic) until ``max |C| <=
        position_tol``; then ``v -= W^-1 D^T (D W^-1 D^T)^-1 (D v + C_t)``,
        repeated while the residual is above round-off.
        """
        if self.kc is not None and self.kc.m:
            out = self._project_compiled(t, y)
            if out is not None:
                return out
        eng = self.eng
        n, n3, n7 = self._n, self._n3, self._n7
        y_in = y
        y = np.array(y, dtype=float)
        P = y[n3:n7].reshape(n, 4)
        P /= np.sqrt(einsum("ij,ij->i", P, P))[:, None]
        if eng.m == 0:
            return y
        tol = self.position_tol
        factor = None
        prev = math.inf
        last = self._last
        self._last = None
        kp, kv = _position_rows(eng)
        for it in range(10):
            if (it == 0 and last is not None and last[0] is y_in and last[1] == t and last[5] is not None
                    and last[6] == eng.generation):
                _, _, C, D, Ct, c, _ = last
                factor = (D[kp] if kp is not None else D) * eng.winv_diag, c
            else:
                C, D, Ct, _ = constraints_at(eng, t, y, 1)
                if factor is not None:  # from the previous iterate: O(dq) off, enough for Newton's next step
                    Dk = D if kp is None else D[kp]
                    factor = (Dk * eng.winv_diag if eng.winv_diag is not None else eng.winv_apply(Dk.T).T, factor[1])
            res = float(np.abs(C).max()) if C.size else 0.0
            if res <= tol or (it and res <= 1e-8 and res > 0.25 * prev):
                if it == 0 and factor is not None and eng.contact_kernel is not None:
                    # the step's last stage is accepted as it is: its contact parameters are the step's
                    eng.contact_kernel.commit_cached(eng.contact_state, t, strict=eng.contact_strict)
                break  # converged, or at the round-off floor
            if it == 9 or not math.isfinite(res):
                raise IntegrationError(
                    f"projection onto the constraints did not converge at t={t:.6g} (residual {res:.3e}); "
                    "tighten the tolerances or reduce the step", t=t)
            Dk = D if kp is None else D[kp]
            if Dk.shape[0] == 0:
                break
            if factor is None or it:
                try:
                    factor = self._metric_factor(Dk, t)
                except _FactorizationFailed:
                    _recheck_rank(eng, t, y)
                    kp, kv = _position_rows(eng)
                    continue
            WD, c = factor
            mu, _ = lapack.dpotrs(c, C if kp is None else C[kp], lower=0)
            dq = WD.T @ mu
            # first-order retraction R -= dR, p <- (p - G_bar^T dpi / 2) / |.|: Newton stays quadratic
            y[:n3] -= dq[:n3]
            P = y[n3:n7].reshape(n, 4)
            P -= parameter_rates(P, dq[n3:].reshape(n, 3))
            P /= np.sqrt(einsum("ij,ij->i", P, P))[:, None]
            prev = res
        Dk = D if kv is None else D[kv]
        Ctk = Ct if kv is None else Ct[kv]
        if Dk.shape[0] == 0:  # every row is switched off (contacts that left the constraint model)
            return y
        if factor is None or kv is not kp:  # rolling rows: the velocity projection has more rows
            factor = self._metric_factor(Dk, t)
        WD, c = factor
        v = y[n7:]
        floor = 4e-16 * (1.0 + float(np.abs(v).max())) * max(1.0, float(np.abs(Dk).max()))
        for _ in range(4):  # the factor may be from before the last Newton step: repeat until round-off
            r = Dk @ v + Ctk
            if float(np.abs(r).max()) <= floor:
                break
            mu, _ = lapack.dpotrs(c, r, lower=0)
            v = v - WD.T @ mu
        y[n7:] = v
        if t in self.output_times:
            rv = float(np.abs(D @ v + Ct).max())
            self.residuals[t] = (y.copy(), res, rv)
            if eng.contact_kernel is not None:
                self._record_output(t, y)
        return y

    def _record_output(self, t: float, y: np.ndarray) -> None:
        """The level-2 evaluation at a projected output state, kept for the multipliers and the energy.

        Only the velocities changed since the projection's last iterate, so
        the contacts' surface parameters are those of that iterate (the
        kernel reuses them, see ``ContactKernel.evaluate``). An output
        inside an integrator's step leaves the warm-start prediction of the
        run's next step as it was; an output that ends a step
        (``outputs_end_steps``, a kinematic analysis) makes its surface
        parameter rates ``s_dot`` the prediction: without it, every kinematic
        step's contact Newton would start from the last parameters unmoved
        (98 degrees of cam away at one step per 60 Hz frame), fail, and be
        continued in sub-steps.
        """
        eng = self.eng
        st = eng.contact_state
        rate = None if self.outputs_end_steps else dict(st.get("rate", {}))
        _, lam, _, D, _ = self.accelerations(t, y, commit=False)
        if rate is not None:
            st["rate"] = rate
        last = st.get("last", {})
        charts = [list(last[c.index][1]) if c.index in last else None for c in eng.contacts]
        self.outputs[t] = (y.copy(), st["mode"].copy(), lam, np.array(D), eng.contact_eval, charts)

    def output_hit(self, t: float, y: np.ndarray, mode: np.ndarray | None):
        """The kept evaluation of output ``(t, y)`` in contact modes ``mode`` (see :meth:`_record_output`), or None."""
        hit = self.outputs.get(t)
        if hit is None or not np.array_equal(hit[0], y) or (mode is not None and not np.array_equal(hit[1], mode)):
            return None
        return hit


def _position_rows(eng: _Engine):
    """Rows of the position projection and of the velocity projection (None: all rows).

    The rows of rolling contacts constrain velocities only: they take part
    in the velocity projection, not in the position projection.
    """
    kv = eng.keep
    if not eng.nonholonomic_rows.size:
        return kv, kv
    rows = np.arange(eng.m) if kv is None else kv
    return rows[rows < eng.m_holo], rows


def _recheck_rank(eng: _Engine, t: float, y: np.ndarray) -> None:
    """After a failed factorization: new independent rows, or a clear error if the rank dropped."""
    old_rank = eng.rank
    old_keep = eng.keep
    keep = analyze_rank(eng, t, y)
    if keep.size < old_rank:
        before = set(range(eng.m)) if old_keep is None else set(old_keep.tolist())
        lost = sorted(before - set(keep.tolist()))
        names = "; ".join(row_label(eng, r) for r in lost) or "?"
        raise SingularSystemError(
            f"the constraint Jacobian lost rank at t={t:.6g} (rank {keep.size} < {old_rank}): the mechanism "
            f"reached a singular configuration; dependent rows: {names}", t=t)


# ------------------------------------------------------------------ outputs
def _energy(eng: _Engine, states: np.ndarray, modes: np.ndarray | None = None,
            ts: np.ndarray | None = None, start: dict | None = None, track: dict | None = None,
            model: _Dynamics | None = None) -> np.ndarray:
    """Kinetic + gravitational + spring (+ compliant contact) energy (N,) of states (N, 13n).

    Batched over the outputs; a contact in the compliant model adds ``k
    delta^(e+1) / (e + 1)`` while the bodies overlap by ``delta`` (the
    contact followed along the run's ``track``; the gap from the evaluation
    kept at the output's projection when ``model`` has it).
    """
    n = eng.n
    N = states.shape[0]
    R = states[:, : 3 * n].reshape(N, n, 3)
    P = states[:, 3 * n : 7 * n].reshape(N, n, 4)
    Rd = states[:, 7 * n : 10 * n].reshape(N, n, 3)
    W = states[:, 10 * n :].reshape(N, n, 3)
    e = 0.5 * np.einsum("k,nki,nki->n", eng.mass, Rd, Rd) + 0.5 * np.einsum("nki,kij,nkj->n", W, eng.inertia, W)
    e -= np.einsum("k,nki,i->n", eng.mass, R, eng.gravity)
    if eng.n_sp or eng.n_rs:
        A = matrices(P.reshape(N * n, 4)).reshape(N, n, 3, 3)

        def point(body, u, h):
            if body.index < 0:
                return np.broadcast_to(u, (N, 3))
            return h * R[:, body.index] + A[:, body.index] @ u

        for k, sp in enumerate(eng.springs):
            d = point(sp.body_j, sp._local["u_j"], 1.0) - point(sp.body_i, sp._local["u_i"], 1.0)
            L = np.sqrt(np.einsum("ni,ni->n", d, d))
            e += 0.5 * eng.sp_k[k] * (L - eng.sp_L0[k]) ** 2
        for k, rs in enumerate(eng.rot_springs):
            jt = rs.joint
            L = jt._local
            f_i = point(jt.body_i, L["f_i"], 0.0)
            g_i = point(jt.body_i, L["g_i"], 0.0)
            f_j = point(jt.body_j, L["f_j"], 0.0)
            P1 = np.einsum("ni,ni->n", g_i, f_j)
            P2 = np.einsum("ni,ni->n", f_i, f_j)
            a0 = eng.rs_0[k]
            d = np.arctan2(P1 * math.cos(a0) - P2 * math.sin(a0), P2 * math.cos(a0) + P1 * math.sin(a0))
            e += 0.5 * eng.rs_k[k] * d**2
    if modes is not None and np.any(modes == 1):
        ker = eng.contact_kernel
        st = None
        for idx in np.flatnonzero(np.any(modes == 1, axis=1)):
            y = states[idx]
            hit = None if model is None or ts is None else model.output_hit(float(ts[idx]), y, modes[idx])
            if hit is not None:
                res = hit[4]
            else:
                if st is None:
                    st = ker.copy_state(start if start is not None else eng.contact_state, track=track)
                res = ker.evaluate(y, matrices(y[3 * n : 7 * n].reshape(n, 4)), 0, st,
                                   t=None if ts is None else float(ts[idx]))
            delta = np.maximum(-res["gap"], 0.0)
            on = (modes[idx] == 1) & (delta > 0.0)
            if on.any():
                ex = ker.exponent[on]
                e[idx] += float(np.sum(ker.stiffness[on] * delta[on] ** (ex + 1.0) / (ex + 1.0)))
    return e


def _switch_to_compliant(eng: _Engine, c: int, t: float, y: np.ndarray) -> None:
    """Contact ``c`` leaves the constraint model (its rows switch off) for the compliant model."""
    mode = eng.contact_state["mode"].copy()
    mode[c] = 1
    set_contact_modes(eng, mode, t, y)


def _separation(system: Any, eng: _Engine, event: tuple):
    """A :class:`~rigidlab.core.contact.Separation` from an event ``(t, contact index, state, action)``."""
    from rigidlab.core.contact import Separation

    t, c, y, action = event
    res = eng.contact_kernel.evaluate(y, matrices(y[3 * eng.n : 7 * eng.n].reshape(eng.n, 4)), 0,
                                      eng.contact_kernel.copy_state(eng.contact_state,
                                                                    track=eng.contact_state.get("track")), t=t)
    point = _ro(res["point_i"][c])
    normal = _ro(res["normal"][c])
    return Separation(eng.contacts[c], float(t), point, normal, _make_state(system, t, y), action)


def _residuals(model: _Dynamics, ts: np.ndarray, states: np.ndarray,
               modes: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """max |C| and max |D v + C_t| per output; taken from the output projections where they ran."""
    eng = model.eng
    N = ts.size
    res_p = np.zeros(N)
    res_v = np.zeros(N)
    if eng.m == 0:
        return res_p, res_v
    n7 = 7 * eng.n
    for k in range(N):
        t, y = float(ts[k]), states[k]
        hit = model.residuals.get(t)
        if hit is not None and np.array_equal(hit[0], y):
            res_p[k], res_v[k] = hit[1], hit[2]
            continue
        if modes is not None:
            set_contact_modes(eng, modes[k], t, y)
        C, D, Ct, _ = constraints_at(eng, t, y, 1)
        res_p[k] = float(np.max(np.abs(C)))
        res_v[k] = float(np.max(np.abs(D @ y[n7:] + Ct)))
    return res_p, res_v


def _reaction_tables(eng: _Engine) -> dict:
    items = list(eng.joints) + list(eng.motors)
    k = len(items)
    inc = np.zeros((k, eng.m))
    body = np.zeros(k, dtype=np.intp)
    sign = np.ones(k)
    u = np.zeros((k, 3))
    fixed_point = np.zeros((k, 3))
    for idx, item in enumerate(items):
        jt = item if isinstance(item, Joint) else item.joint
        if isinstance(item, Joint):
            inc[idx, eng.joint_rows[idx]] = 1.0
            for mt in eng.motors:
                if mt.joint is jt:
                    inc[idx, eng.motor_rows[mt]] = 1.0
        else:
            inc[idx, eng.motor_rows[item]] = 1.0
        if jt.body_j.is_ground:
            body[idx] = jt.body_i.index
            sign[idx] = -1.0
            fixed_point[idx] = jt._local["u_j"]
        else:
            body[idx] = jt.body_j.index
            u[idx] = jt._local["u_j"]
    n = eng.n
    return {
        "items": {item: idx for idx, item in enumerate(items)},
        "inc": inc,
        "body": body,
        "sign": sign,
        "u": u,
        "fixed": fixed_point,
        "fcols": 3 * body[:, None] + np.arange(3)[None, :],
        "tcols": 3 * n + 3 * body[:, None] + np.arange(3)[None, :],
        "ground_j": sign < 0,
    }


def set_contact_modes(eng: _Engine, mode: np.ndarray | None, t: float, y: np.ndarray) -> None:
    """Put the workspace's contacts in the models ``mode`` (k,); redo the rank analysis on a change."""
    if mode is None or eng.contact_kernel is None:
        return
    current = eng.contact_state["mode"]
    if np.array_equal(current, mode):
        return
    current[:] = mode
    eng.contact_modes_changed()
    analyze_rank(eng, t, y)


def _restart_contacts(model: _Dynamics) -> None:
    """Follow the contacts from the start of the run again (a pass over the outputs).

    The pass replays the run's track: the surface parameters at an output
    start from those tracked along the steps of the run (see
    ``ContactKernel.evaluate``), not from the previous output, so the
    history does not depend on the output density.
    """
    eng = model.eng
    start = getattr(model, "contact_start", None)
    if start is None or eng.contact_kernel is None:
        return
    state = eng.contact_kernel.copy_state(start, track=getattr(model, "contact_track", None))
    state["mode"] = eng.contact_state["mode"]
    eng.contact_state = state


def _contact_record(eng: _Engine, lam: np.ndarray, res: dict, data: dict, idx: int,
                    charts: list | None = None) -> None:
    """Fill output ``idx`` of the per-contact arrays from a level-2 evaluation and the multipliers
    (``charts``: per contact those of the evaluation; default the committed ones)."""
    mode = eng.contact_state["mode"]
    F_comp, _ = eng.contact_kernel.compliant_forces(res, mode)
    for c in eng.contacts:
        q = c.index
        p = c.n_parameters
        on = eng.contact_row[q] >= 0 and mode[q] == 0
        nu = float(lam[eng.contact_row[q]]) if on else float(F_comp[q])
        normal = res["normal"][q]
        data["normal_force"][idx, q] = nu
        data["point"][idx, q] = res["point_i"][q]
        data["point_j"][idx, q] = res["point_j"][q]
        data["normal"][idx, q] = normal
        data["gap"][idx, q] = res["gap"][q]
        data["constraint"][idx, q] = on
        ch = charts[q] if charts is not None and charts[q] is not None else eng.contact_state["charts"][q]
        for side, surf, off in ((0, c.surface_i, 0), (1, c.surface_j, 2)):
            loc = res["s"][q, off : off + p]
            data["surface_parameters"][idx, q, off : off + p] = surf._chart_parameters(loc, ch[side])
        Ft = np.zeros(3)
        rr = eng.rolling_rows[q]
        if on and rr.size:
            for m, r in enumerate(rr):
                row = res["Dr"][q, m]
                if c.body_j.index >= 0:
                    b = c.body_j.index
                    Ft -= lam[r] * row[3 * b : 3 * b + 3]
                else:
                    b = c.body_i.index
                    Ft += lam[r] * row[3 * b : 3 * b + 3]
        data["tangential_force"][idx, q] = Ft
        data["force"][idx, q] = nu * normal + Ft
        data["multipliers"][idx, q] = res["N"][q] * nu if on else np.where(np.isnan(res["N"][q]), np.nan, 0.0)


def _multipliers_and_reactions(model: _Dynamics, ts: np.ndarray, states: np.ndarray, modes: np.ndarray | None = None):
    """Multipliers (N, m), reactions (N, k, 6) [force, torque about the joint point], items, contact data."""
    eng = model.eng
    n, m = eng.n, eng.m
    tabs = _reaction_tables(eng)
    k_items = len(tabs["items"])
    N = ts.size
    lam_out = np.zeros((N, m))
    F = np.zeros((N, k_items, 3))
    nb = np.zeros((N, k_items, 3))
    rows = np.arange(k_items)[:, None]
    kc = len(eng.contacts)
    data = {
        "normal_force": np.zeros((N, kc)), "point": np.zeros((N, kc, 3)), "point_j": np.zeros((N, kc, 3)),
        "normal": np.zeros((N, kc, 3)), "gap": np.zeros((N, kc)), "surface_parameters": np.full((N, kc, 4), np.nan),
        "tangential_force": np.zeros((N, kc, 3)), "force": np.zeros((N, kc, 3)),
        "multipliers": np.full((N, kc, 5), np.nan), "constraint": np.zeros((N, kc), dtype=bool),
    }
    _restart_contacts(model)
    for idx in range(N):
        if modes is not None:
            set_contact_modes(eng, modes[idx], float(ts[idx]), states[idx])
        hit = model.output_hit(float(ts[idx]), states[idx], None if modes is None else modes[idx]) if kc else None
        if hit is not None:  # kept from the output's projection
            _, _, lam, D, res, charts = hit
        else:
            _, lam, _, D, _ = model.accelerations(float(ts[idx]), states[idx])
            res, charts = eng.contact_eval, None
        lam_out[idx] = lam
        if kc:
            _contact_record(eng, lam, res, data, idx, charts)
        if k_items and m:
            G = -(tabs["inc"] * lam) @ D  # (k, 6n) generalized constraint forces per item
            F[idx] = G[rows, tabs["fcols"]]
            nb[idx] = G[rows, tabs["tcols"]]
    react = np.zeros((N, k_items, 6))
    if k_items and m:
        b = tabs["body"]
        P = states[:, 3 * n : 7 * n].reshape(N, n, 4)[:, b]
        Ab = matrices(P.reshape(-1, 4)).reshape(N, k_items, 3, 3)
        n_glob = np.einsum("nkij,nkj->nki", Ab, nb)
        R = states[:, : 3 * n].reshape(N, n, 3)[:, b]
        arm = np.einsum("nkij,kj->nki", Ab, tabs["u"])
        lever = np.where(tabs["ground_j"][None, :, None], tabs["fixed"][None] - R, arm)
        T = n_glob - cross(lever.reshape(-1, 3), F.reshape(-1, 3)).reshape(N, k_items, 3)
        s = tabs["sign"][None, :, None]
        react[:, :, 0:3] = s * F
        react[:, :, 3:6] = s * T
    return lam_out, react, tabs["items"], data


# ------------------------------------------------------------------ result
def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class MultibodyTrajectory:
    """Result of :meth:`System.simulate`: states and derived quantities at the output times.

    All arrays are read-only, ``(n_times, ...)``. The multipliers and
    reactions need one solve of the equations of motion per output time;
    they are computed on first use (:attr:`multipliers`,
    :meth:`reaction`) and kept.

    Attributes
    ----------
    t : (n,) output times (s).
    q : (n, 7 nb) ``[R (3 nb) | p (4 nb)]`` per time (see :class:`State`).
    v : (n, 6 nb) ``[R_dot (3 nb) | omega_body (3 nb)]`` per time.
    energy : (n,) kinetic + gravitational + spring potential energy (J);
        constant without dampers, motors and user loads.
    residual_position : (n,) ``max |C(q, t)|`` over all constraint rows
        (m for point rows, dimensionless for direction rows).
    residual_velocity : (n,) ``max |D v + C_t|`` (m/s for point rows, 1/s
        for direction rows).
    method : str
    stabilization : str
    n_steps : int
        Accepted steps.
    n_rhs : int
        Right-hand-side evaluations of the integrator (projections and
        output evaluations not counted).
    separations : tuple of :class:`~rigidlab.core.contact.Separation`
        Zero crossings of the normal forces of constraint-model contacts, in
        time order (see ``simulate(..., on_separation=...)``).
    status : str
        ``"completed"`` (reached the last output time), ``"separated"``
        (stopped at a separation; the outputs end before it) or ``"failed"``
        (the trajectory a failed run's exception carries: the outputs before
        the failure, see :func:`simulate`).
    """

    t: np.ndarray  # (n,)
    q: np.ndarray = field(repr=False)  # (n, 7 nb)
    v: np.ndarray = field(repr=False)  # (n, 6 nb)
    energy: np.ndarray = field(repr=False)  # (n,)
    residual_position: np.ndarray = field(repr=False)  # (n,)
    residual_velocity: np.ndarray = field(repr=False)  # (n,)
    method: str
    stabilization: str
    n_steps: int
    n_rhs: int
    _model: Any = field(repr=False, compare=False)
    _owner: Any = field(repr=False, compare=False)
    separations: tuple = ()
    status: str = "completed"
    _modes: Any = field(repr=False, compare=False, default=None)  # (n, k) contact models per output
    _cache: dict = field(repr=False, compare=False, default_factory=dict)
    _lock: Any = field(repr=False, compare=False, default_factory=threading.Lock)

    @property
    def n_bodies(self) -> int:
        """Number of bodies the trajectory describes."""
        return self.v.shape[1] // 6

    def _loads(self) -> tuple[np.ndarray, np.ndarray, Mapping[Any, int]]:
        with self._lock:
            if "lam" not in self._cache:
                states = np.concatenate([self.q, self.v], axis=1)
                lam, react, items, contacts = _multipliers_and_reactions(self._model, self.t, states, self._modes)
                self._cache["items"] = MappingProxyType(dict(items))
                self._cache["react"] = _ro(react)
                self._cache["lam"] = _ro(lam)
                self._cache["contacts"] = contacts
            return self._cache["lam"], self._cache["react"], self._cache["items"]

    @property
    def multipliers(self) -> np.ndarray:
        """(n, m) Lagrange multipliers of the constraint rows (zero for rows found redundant)."""
        return self._loads()[0]

    def _index(self, body: Any) -> int:
        if not isinstance(body, Body):
            raise ValueError(f"body: expected a Body, got {short_repr(body)}")
        if body._owner is not self._owner:
            raise ValueError(f"body: {body.name!r} belongs to another System than this trajectory")
        if body.index >= self.n_bodies:
            raise ValueError(
                f"body: {body.name!r} was added after this trajectory was computed; it is not in the trajectory"
            )
        return body.index

    def position(self, body: Body) -> np.ndarray:
        """(n, 3) centre of mass of ``body``, global (m)."""
        i = self._index(body)
        if i < 0:
            return np.zeros((self.t.size, 3))
        return self.q[:, 3 * i : 3 * i + 3].copy()

    def orientation(self, body: Body) -> np.ndarray:
        """(n, 4) Euler parameters of ``body``, scalar first (viser's wxyz)."""
        i = self._index(body)
        if i < 0:
            return np.tile([1.0, 0.0, 0.0, 0.0], (self.t.size, 1))
        nb = self.n_bodies
        return self.q[:, 3 * nb + 4 * i : 3 * nb + 4 * i + 4].copy()

    def velocity(self, body: Body) -> np.ndarray:
        """(n, 3) velocity of the centre of mass, global (m/s)."""
        i = self._index(body)
        if i < 0:
            return np.zeros((self.t.size, 3))
        return self.v[:, 3 * i : 3 * i + 3].copy()

    def omega_body(self, body: Body) -> np.ndarray:
        """(n, 3) angular velocity in the body frame (rad/s)."""
        i = self._index(body)
        if i < 0:
            return np.zeros((self.t.size, 3))
        nb = self.n_bodies
        return self.v[:, 3 * nb + 3 * i : 3 * nb + 3 * i + 3].copy()

    def omega(self, body: Body) -> np.ndarray:
        """(n, 3) angular velocity in the global frame (rad/s)."""
        i = self._index(body)
        if i < 0:
            return np.zeros((self.t.size, 3))
        A = matrices(self.orientation(body))
        return np.einsum("nij,nj->ni", A, self.omega_body(body))

    def reaction(self, item: Joint | Motor, *, frame: str = "global") -> tuple[np.ndarray, np.ndarray]:
        """Force and torque the joint (or motor) applies to its ``body_j`` at the joint point.

        From the multipliers: the generalized constraint forces ``-D^T
        lambda`` of the item's rows, on ``body_j``, as a force and a torque
        about the joint point fixed in ``body_j``. For a joint, its own rows
        plus those of the motors driving it (the whole load it transmits);
        for a motor, only the motor's row (the driving torque or force). The
        load on ``body_i`` is the opposite, about the same point. When
        ``body_j`` is the ground it is computed from ``body_i``'s share.

        Parameters
        ----------
        item : Joint or Motor
        frame : ``"global"`` (default) or ``"body"`` (``body_j``'s frame;
            the global frame when ``body_j`` is the ground), keyword-only.

        Returns
        -------
        force : (n, 3) N
        torque : (n, 3) N m
        """
        if not isinstance(item, (Joint, Motor)):
            raise ValueError(f"item: expected a Joint or Motor, got {short_repr(item)}")
        if item._owner is not self._owner:
            raise ValueError(f"item: {item.name!r} belongs to another System than this trajectory")
        if frame not in ("global", "body"):
            raise ValueError(f"frame: expected 'global' or 'body', got {short_repr(frame)}")
        _, react, items = self._loads()
        if item not in items:
            raise ValueError(f"item: {item.name!r} was added after this trajectory was computed")
        k = items[item]
        F = react[:, k, 0:3].copy()
        T = react[:, k, 3:6].copy()
        jt = item if isinstance(item, Joint) else item.joint
        if frame == "body" and not jt.body_j.is_ground:
            A = matrices(self.orientation(jt.body_j))
            F = np.einsum("nji,nj->ni", A, F)
            T = np.einsum("nji,nj->ni", A, T)
        return F, T

    def contact(self, contact: Any):
        """The contact's normal force, point, normal and surface parameters at the outputs.

        Computed on first use with the multipliers (one solve per output).

        Parameters
        ----------
        contact : Contact
            A contact of this System (from ``System.add_contact``).

        Returns
        -------
        ContactHistory
            ``normal_force`` (n,) N, positive while pressing (the
            independent multiplier, Eq. 8.107, or the compliant force);
            ``point``, ``point_j``, ``normal`` (n, 3) global; ``gap`` (n,);
            ``surface_parameters`` (n, 4) (curves: ``(s_i, nan, s_j,
            nan)``); ``tangential_force``, ``force`` (n, 3) on ``body_j``;
            ``multipliers`` (n, 5); ``constraint`` (n,) bool.
        """
        from rigidlab.core.contact import Contact, ContactHistory

        if not isinstance(contact, Contact):
            raise ValueError(f"contact: expected a Contact (from System.add_contact), got {short_repr(contact)}")
        if contact._owner is not self._owner:
            raise ValueError(f"contact: {contact.name!r} belongs to another System than this trajectory")
        eng = self._model.eng
        if contact.index >= len(eng.contacts) or eng.contacts[contact.index] is not contact:
            raise ValueError(f"contact: {contact.name!r} was added after this trajectory was computed")
        self._loads()
        data = self._cache["contacts"]
        k = contact.index
        fields = {name: _ro(data[name][:, k]) for name in (
            "normal_force", "point", "point_j", "normal", "gap", "surface_parameters", "tangential_force", "force",
            "multipliers", "constraint")}
        fields["constraint"] = np.array(data["constraint"][:, k], dtype=bool)
        fields["constraint"].setflags(write=False)
        return ContactHistory(t=self.t, **fields)

    def state(self, index: int) -> State:
        """The :class:`State` at output ``index`` (negative counts from the end)."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise ValueError(f"index: expected an integer, got {short_repr(index)}")
        n = self.t.size
        if not -n <= index < n:
            raise ValueError(f"index: expected -{n} <= index < {n}, got {index}")
        state = _make_state(self._owner, float(self.t[index]), np.concatenate([self.q[index], self.v[index]]))
        known = self._contacts_at(state.t)
        if known is not None:
            state = dataclasses.replace(state, _contacts=known)
        return state

    def _contacts_at(self, t: float) -> tuple | None:
        """Per contact ``(s, chart_i, chart_j)`` at time ``t`` of the run (from its track), or None."""
        track = getattr(self._model, "contact_track", None)
        contacts = self._model.eng.contacts
        if not (contacts and track is not None and all(c.index in track and track[c.index].times
                                                        for c in contacts)):
            return None
        known = []
        for c in contacts:
            s, charts = track[c.index].start(t)
            known.append((s, charts[0], charts[1]))
        return tuple(known)

    def run_state(self, index: int) -> RunState:
        """The :class:`RunState` at output ``index`` (negative counts from the end): positions, velocities,
        time, the contacts' surface parameters and models there; a run from it continues this one
        (``system.simulate(t, initial=traj.run_state(i))``, ``t[0] >= self.t[i]``)."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise ValueError(f"index: expected an integer, got {short_repr(index)}")
        n = self.t.size
        if not -n <= index < n:
            raise ValueError(f"index: expected -{n} <= index < {n}, got {index}")
        t = float(self.t[index])
        modes = None if self._modes is None else self._modes[index]
        return _run_state(t, np.concatenate([self.q[index], self.v[index]]), self._contacts_at(t), modes)

    @property
    def final_state(self) -> RunState:
        """The :class:`RunState` the run ended in (its last output): ``system.simulate(t,
        initial=traj.final_state)`` continues the run, ``t[0] >= traj.t[-1]`` (see :meth:`run_state`)."""
        key = "final_state"
        with self._lock:
            if key not in self._cache:
                self._cache[key] = self.run_state(-1)
            return self._cache[key]


# ------------------------------------------------------------------ simulate
#: Radians of the fastest body's turn from which an adaptive run warns that it will be long: it takes at
#: least one right-hand side per radian (about 1.2 for DOP853 on a spinning disk), each 0.1-1 ms.
LONG_RUN_RADIANS = 1e5


def _check_turns(system: Any, y0: np.ndarray, t0: float, t1: float, max_steps: int) -> None:
    """Refuse an adaptive run that cannot end within ``max_steps`` right-hand sides, and warn of one that
    takes minutes: the fastest body's angle ``|omega| (t1 - t0)`` at the start, at least one evaluation a
    radian (an explicit method resolves every turn)."""
    n = len(system.bodies)
    omega = np.linalg.norm(y0[10 * n :].reshape(n, 3), axis=1)
    b = int(np.argmax(omega))
    radians = float(omega[b]) * (t1 - t0)
    if not radians > LONG_RUN_RADIANS:
        return
    what = (f"body {system.bodies[b].name!r} turns at {float(omega[b]):.3g} rad/s, about {radians:.3g} rad by "
            f"t={t1:.6g}, and an adaptive run takes at least one right-hand-side evaluation a radian")
    if radians > max_steps:
        raise ValueError(f"t: {what}: more than max_steps={max_steps}; ask for a shorter time span or pass a "
                         "larger max_steps")
    warnings.warn(f"simulate: {what} (0.1-1 ms each): this run takes minutes; ask for a shorter time span to "
                  "see it sooner", RuntimeWarning, stacklevel=4)


def check_assembled(eng: _Engine, t: float, y: np.ndarray, what: str, *, limit: float = 1e-8) -> None:
    """Refuse a state ``y`` that violates the constraints at ``t`` (residuals above ``limit``, velocities
    relative to ``1 + max |v|``) or whose motor holds its joint half a turn from ``f(t)``.

    Raises
    ------
    AssemblyError
        Naming ``what`` (the caller), both residuals and the row of the largest one.
    """
    n = eng.n
    if _assembled_compiled(eng, t, y, limit):
        return
    C, D, Ct, _ = constraints_at(eng, t, y, 1)
    res_p = float(np.max(np.abs(C)))
    rv = np.array(D) @ y[7 * n :] + Ct
    res_v = float(np.max(np.abs(rv)))
    if res_p > limit or res_v > limit * (1.0 + float(np.max(np.abs(y[7 * n :])))):
        r = int(np.argmax(np.abs(C))) if res_p > limit else int(np.argmax(np.abs(rv)))
        raise AssemblyError(
            f"{what}: the current state violates the constraints at t={t:g} (position residual "
            f"{res_p:.3e}, velocity residual {res_v:.3e}; largest in {row_label(eng, r)}); "
            f"call system.assemble(t={t:g}) first{_normal_velocity_note(eng, r, res_p > limit, rv)}"
        )
    flipped = flipped_motors(eng, t, y)
    if flipped:
        raise AssemblyError(
            f"{what}: motor {flipped[0].name!r} holds its joint half a turn from its angle f(t) at "
            f"t={t:g} (sin(theta - f) = 0 with cos(theta - f) < 0); call system.assemble(t={t:g}) first"
        )


def _assembled_compiled(eng: _Engine, t: float, y: np.ndarray, limit: float) -> bool:
    """True when the compiled kernels hold every row and find ``y`` on the constraints at ``t`` (the check of
    :func:`check_assembled` without its motor test); False leaves the verdict (and its message) to the numpy
    evaluation."""
    kc = eng.compiled
    if kc is None or eng.m != kc.m or eng.nonholonomic_rows.size or eng.angle_motors:
        return False
    n = eng.n
    kc.select(eng.keep)
    kc.evaluate(t, y, 1)
    v = y[7 * n :]
    rv = np.empty(kc.m)
    _kernel.jacobian_apply(n, kc.Jc, kc.jc_body, v, kc.Ct, rv)
    res_p = float(np.max(np.abs(kc.C), initial=0.0))
    res_v = float(np.max(np.abs(rv), initial=0.0))
    return res_p <= limit and res_v <= limit * (1.0 + float(np.max(np.abs(v), initial=0.0)))


#: A run that fails (its steps cannot pass a time) at a state where the Jacobian of the independent position
#: rows, in the mass metric, has its smallest singular value below this fraction of its largest has reached a
#: dead point: the constraints lose rank there (a linkage at its limit position, driven further by a motor).
DEAD_POINT_TOL = 1e-3


def dead_point_ratio(eng: _Engine, t: float, y: np.ndarray) -> float:
    """Smallest over largest singular value of ``D_p W^-1/2`` at ``(t, y)`` (``D_p``: the independent position
    rows; 1 without rows), on a workspace copy (the run's contact warm starts are left as they are)."""
    w = eng.workspace()
    kp = _position_rows(w)[0]
    _, D, _, _ = constraints_at(w, t, y, 1)
    D = np.array(D) if kp is None else np.array(D)[kp]
    if D.shape[0] == 0:
        return 1.0
    sv = np.linalg.svd(D @ metric_inv_sqrt(w), compute_uv=False)
    return float(sv[-1] / sv[0]) if sv[0] > 0.0 else 0.0


def dead_point_error(eng: _Engine, t: float, y: np.ndarray, exc: BaseException | None) -> BaseException | None:
    """``exc`` (a run that could not go on past the last accepted state ``(t, y)``; None: a run whose steps
    have shrunk to nothing), or a :class:`SingularSystemError` when that state is a dead point (see
    :data:`DEAD_POINT_TOL`)."""
    try:
        ratio = dead_point_ratio(eng, t, y)
    except Exception:  # noqa: BLE001 - the diagnosis must not hide the failure
        return exc
    if not ratio <= DEAD_POINT_TOL:
        return exc
    own = "" if exc is None else f" The run's own error: {exc}"
    return SingularSystemError(
        f"the mechanism reached a dead point at t={t:.6g}: its constraint Jacobian is nearly singular there "
        f"(smallest singular value {ratio:.1e} of the largest, in the mass metric), so no step passes it; a "
        f"motor is driving a linkage beyond its limit position (change the motion or the dimensions).{own}", t=t)


def _normal_velocity_note(eng: _Engine, r: int, position: bool, rv: np.ndarray) -> str:
    """What ``assemble`` would do to a normal velocity of a constraint-model contact (row ``r``)."""
    item, label = eng.row_labels[r]
    if position or label != "normal" or getattr(item, "kind", None) != "contact":
        return ""
    way = "into each other" if rv[r] > 0.0 else "apart"  # (the row is the rate of penetration)
    return (f". The surfaces of contact {item.name!r} move {way} at {abs(float(rv[r])):.3g} m/s along its normal: "
            "assemble() removes that velocity, since a contact in the constraint model holds its surfaces "
            "together; for surfaces that may move apart or collide, add the contact with model='compliant'")


def _check_kinematic(eng: _Engine, t: float) -> None:
    """``method="kinematic"``: refuse a System whose constraints do not fix every coordinate at ``t``."""
    if eng.nonholonomic_rows.size:
        raise ValueError(
            "method: 'kinematic' solves positions from the constraints, but this System has rolling contacts "
            "(velocity constraints: its positions must be integrated); use 'DOP853'")
    free = 6 * eng.n - int(eng.rank if eng.rank is not None else eng.m)
    if free > 0:
        raise ValueError(
            f"method: 'kinematic' needs a System whose constraints fix every coordinate (0 degrees of freedom); "
            f"this one has {free} at t={t:g} (6 x {eng.n} body coordinates, {6 * eng.n - free} independent "
            "constraint rows); use 'DOP853', or add motors for the free coordinates")


#: Longest kinematic step, as a multiple of the last one: the extrapolated start
#: of Newton's method stays close (its error grows as the step to the fourth).
_KINEMATIC_GROWTH = 3.0
#: Halvings of a kinematic step whose projection failed before the run gives up.
_KINEMATIC_HALVINGS = 12
#: A kinematic step is accepted when Newton moved the extrapolated positions by at
#: most this fraction of the step's own motion (or by round-off): the solution is
#: then the one the motion continues to, not another assembly of the mechanism.
_KINEMATIC_TRUST = 0.5
_CONTACT_KEYS = ("s", "charts", "t_committed", "points", "signs", "last", "t_last", "rate")


def _contact_snapshot(eng: _Engine):
    """What a projection may change of the contacts' warm start and track (restored when a step is rejected)."""
    if eng.contact_kernel is None:
        return None
    st = eng.contact_state
    saved = {key: (list(st[key]) if isinstance(st[key], list) else dict(st[key])) for key in _CONTACT_KEYS
             if key in st}
    lengths = {q: len(tr.times) for q, tr in st.get("track", {}).items()}
    return saved, lengths


def _contact_restore(eng: _Engine, snap) -> None:
    if snap is None:
        return
    saved, lengths = snap
    st = eng.contact_state
    for key in _CONTACT_KEYS:
        if key in saved:
            st[key] = saved[key]
        else:
            st.pop(key, None)
    tracks = st.get("track", {})
    for q in list(tracks):
        keep = lengths.get(q, 0)
        if keep == 0:
            del tracks[q]
        else:
            del tracks[q].times[keep:]
            del tracks[q].entries[keep:]
    st.pop("cache", None)


def _trusted(n: int, y_a: np.ndarray, z: np.ndarray, y_new: np.ndarray, h: float, f_a: np.ndarray) -> bool:
    """The Newton correction ``y_new - z`` is small against the step's motion (see
    :data:`_KINEMATIC_TRUST`), for the positions and the Euler parameters separately.

    The motion is the larger of the displacement ``y_new - y_a`` and ``h``
    times the rates at the step's start: a coordinate that goes and comes
    back within the step (a follower over a turning point) has moved,
    although its displacement is small.
    """
    n3, n7 = 3 * n, 7 * n
    yn = y_new[:n7]
    d = np.abs(np.concatenate([yn - z[:n7], yn - y_a[:n7], h * f_a[:n7], yn])).tolist()
    corr_R, corr_p, disp_R, disp_p = max(d[:n3]), max(d[n3:n7]), max(d[n7 : n7 + n3]), max(d[n7 + n3 : 2 * n7])
    rate_R, rate_p, size_R = max(d[2 * n7 : 2 * n7 + n3]), max(d[2 * n7 + n3 : 3 * n7]), max(d[3 * n7 : 3 * n7 + n3])
    for corr, moved, floor in ((corr_R, max(disp_R, rate_R), 1e-9 * (1.0 + size_R)),
                               (corr_p, max(disp_p, rate_p), 1e-9)):
        if corr > floor and corr > _KINEMATIC_TRUST * moved:
            return False
    return True


def _kinematic_prediction(n: int, y: np.ndarray, t: float, hist: tuple, tq: float) -> np.ndarray:
    """Start of the projection at ``tq``: the positions of ``y`` (at ``t``) extrapolated.

    ``hist = (t_p, y_p, f_p, f)``: the solved point before (``t_p`` None at
    the first step) and the rates ``y_dot`` at both points, whose last
    ``6n`` entries are the accelerations ``R_ddot`` and ``omega_body_dot``.

    * Positions ``R``: the quintic Hermite polynomial through both points
      and their first and second derivatives (an error of order h^6 for a
      smooth motion), when ``tq`` is at most one interval ``t - t_p``
      beyond ``t``; further out (a step grown after halvings), and at the
      first step, Taylor's ``R + h v + h^2 a / 2``, whose error does not
      grow with the distance as an extrapolated polynomial's does.
    * Euler parameters: beyond ``t``, the rotation ``p exp(phi / 2)`` with
      the body rotation vector ``phi = h omega + h^2 omega_dot / 2``
      (Eqs. 8.69-8.72; exact at a constant angular velocity, as a motor
      turns a body); inside ``[t_p, t]`` (the dense output of the event
      search), the cubic Hermite polynomial, normalized.

    The velocities are left to the projection (which solves ``D v = -C_t``
    exactly when ``D`` is square). With a cam turning 98 degrees per step,
    these starts let Newton converge where the cubic Hermite extrapolation
    of every coordinate was rejected in one step of three (see
    :func:`_trusted`).
    """
    n3, n7 = 3 * n, 7 * n
    z = np.array(y, dtype=float)
    t_p, y_p, f_p, f = hist
    h = tq - t
    u = None if t_p is None else (tq - t_p) / (t - t_p)
    if u is not None and u <= 2.0 + 1e-9:  # (one interval ahead, with its round-off)
        H = t - t_p
        u2 = u * u
        u3 = u2 * u
        u4 = u3 * u
        u5 = u4 * u
        h0 = 1.0 - 10.0 * u3 + 15.0 * u4 - 6.0 * u5
        h1 = u - 6.0 * u3 + 8.0 * u4 - 3.0 * u5
        h2 = 0.5 * (u2 - 3.0 * u3 + 3.0 * u4 - u5)
        h3 = 0.5 * (u3 - 2.0 * u4 + u5)
        h4 = -4.0 * u3 + 7.0 * u4 - 3.0 * u5
        z[:n3] = (h0 * y_p[:n3] + (1.0 - h0) * y[:n3] + (H * h1) * f_p[:n3] + (H * h4) * f[:n3]
                  + (H * H * h2) * f_p[n7 : n7 + n3] + (H * H * h3) * f[n7 : n7 + n3])
    else:
        z[:n3] = y[:n3] + h * f[:n3] + 0.5 * h * h * f[n7 : n7 + n3]
    if u is not None and u <= 1.0 + 1e-9:
        H = t - t_p
        u2, u3 = u * u, u * u * u
        z[n3:n7] = ((2 * u3 - 3 * u2 + 1) * y_p[n3:n7] + (u3 - 2 * u2 + u) * H * f_p[n3:n7]
                    + (-2 * u3 + 3 * u2) * y[n3:n7] + (u3 - u2) * H * f[n3:n7])
        P = z[n3:n7].reshape(n, 4)
        P /= np.sqrt(einsum("ij,ij->i", P, P))[:, None]
    else:
        phi = (h * y[10 * n :] + 0.5 * h * h * f[n7 + n3 :]).tolist()
        P = y[n3:n7].tolist()
        out = []
        for b in range(n):  # p exp(phi / 2), body by body on floats (a mechanism has few bodies)
            x1, x2, x3 = phi[3 * b : 3 * b + 3]
            ang = math.sqrt(x1 * x1 + x2 * x2 + x3 * x3)
            c = math.cos(0.5 * ang)
            k = math.sin(0.5 * ang) / ang if ang > 1e-4 else 0.5 - ang * ang / 48.0  # sin(x/2)/x near 0
            q1, q2, q3 = k * x1, k * x2, k * x3
            w, a1, a2, a3 = P[4 * b : 4 * b + 4]
            out += (w * c - a1 * q1 - a2 * q2 - a3 * q3, w * q1 + a1 * c + a2 * q3 - a3 * q2,
                    w * q2 - a1 * q3 + a2 * c + a3 * q1, w * q3 + a1 * q2 - a2 * q1 + a3 * c)
        z[n3:n7] = out
    return z


def _kinematic_rates(model: _Dynamics, t: float, y: np.ndarray) -> np.ndarray:
    """``y_dot`` at a solved state (as ``model.rhs``), from the accelerations the output kept when there is one."""
    n = model.eng.n
    a, lam, _, _, _ = model.accelerations(t, y, commit=False)
    model._lam_last = (t, lam)
    n3, n7, n10 = 3 * n, 7 * n, 10 * n
    return np.concatenate([y[n7:n10], parameter_rates(y[n3:n7].reshape(n, 4), y[n10:].reshape(n, 3)).ravel(), a])


def _run_kinematic(model: _Dynamics, y0: np.ndarray, t0: float, t_eval: np.ndarray, max_steps: int) -> Trajectory:
    """Kinematic analysis of a System with zero degrees of freedom at the times ``t_eval``.

    Every step ends at the next output time (at most :data:`_KINEMATIC_GROWTH`
    times the last step): positions by Newton's method on ``C(q, t) = 0``
    from an extrapolated start, velocities from ``D v = -C_t``, accelerations
    and multipliers from the augmented equations (Eqs. 8.105-8.107): no
    integration error, only the Newton tolerance. A projection that fails,
    or whose correction is not small against the step's motion (Newton may
    then have found another assembly of the mechanism, see
    :data:`_KINEMATIC_TRUST`), halves the step; the contacts' warm start and
    track are put back as they were before it. The separation check runs at every
    step's end (``model.stop_time``); a crossing is located by Brent's method
    on the normal force of kinematic solutions inside the step. Returns what
    :func:`rigidlab.core.integrators.integrate` returns (``t[0] = t0``).
    """
    n = model.eng.n
    pending = [float(x) for x in t_eval if x > t0]
    t_rec = [t0] * int(np.count_nonzero(t_eval <= t0))
    y_rec = [np.array(y0)] * len(t_rec)
    f_a = _kinematic_rates(model, t0, y0)
    n_rhs, n_steps = 1, 0
    t_a, y_a, t_p, y_p, f_p = t0, np.array(y0), None, None, None
    h_last = math.inf
    stopped = None
    k = 0
    try:  # (a failure keeps the outputs solved before it)
        while k < len(pending):
            target = pending[k]
            if target <= t_a:
                t_rec.append(target)
                y_rec.append(np.array(y_a))
                k += 1
                continue
            h = min(target - t_a, _KINEMATIC_GROWTH * h_last)
            for halving in range(_KINEMATIC_HALVINGS + 1):
                t_new = target if h == target - t_a else t_a + h
                snap = _contact_snapshot(model.eng)
                try:
                    z = _kinematic_prediction(n, y_a, t_a, (t_p, y_p, f_p, f_a), t_new)
                    y_new = model.project(t_new, z)
                    if not np.isfinite(y_new).all():
                        raise IntegrationError(f"the kinematic solution at t={t_new:.6g} is not finite", t=t_new)
                    if not _trusted(n, y_a, z, y_new, t_new - t_a, f_a):
                        raise IntegrationError(
                            f"kinematic: the extrapolation to t={t_new:.6g} is too far from the solution to trust that "
                            "Newton found the configuration the motion continues to; give closer output times", t=t_new)
                    break
                except (IntegrationError, ValueError) as exc:
                    if halving == _KINEMATIC_HALVINGS:
                        err = model.failure(t_a, y_a, exc)
                        if err is exc:
                            raise
                        raise err from exc
                    _contact_restore(model.eng, snap)
                    h *= 0.5
            if n_rhs >= max_steps:
                raise IntegrationError(
                    f"kinematic: stopped at t={t_a:.6g} after max_steps={max_steps} evaluations of the accelerations; "
                    "pass a larger max_steps", t=t_a)
            f_new = _kinematic_rates(model, t_new, y_new)
            n_rhs += 1
            n_steps += 1
            if model.stop_time is not None:
                t_lo, y_lo, f_lo = t_a, y_a, f_a

                def dense(te, t_lo=t_lo, y_lo=y_lo, f_lo=f_lo, t_new=t_new, y_new=y_new, f_new=f_new):
                    if te == t_new:
                        return np.array(y_new)
                    return model.project(te, _kinematic_prediction(n, y_new, t_new, (t_lo, y_lo, f_lo, f_new), te))

                te = model.stop_time(t_a, y_a, t_new, np.array(y_new), dense)
                if te is not None:
                    te = float(te)
                    y_stop = dense(te)
                    while k < len(pending) and pending[k] <= te:
                        t_rec.append(pending[k])
                        y_rec.append(dense(pending[k]))
                        k += 1
                    stopped = (te, y_stop)
                    break
            t_p, y_p, f_p = t_a, y_a, f_a
            t_a, y_a, f_a = t_new, np.array(y_new), f_new
            h_last = h
            if t_new == target:
                t_rec.append(target)
                y_rec.append(np.array(y_new))
                k += 1
    except Exception as exc:
        attach_partial(exc, t_rec, y_rec)
        raise
    states = np.array(y_rec).reshape(len(y_rec), y0.size)
    return Trajectory(np.array(t_rec), states, KINEMATIC_METHOD, n_steps, n_rhs, DriftReport(),
                      None if stopped is None else stopped[0], None if stopped is None else stopped[1])


def simulate(
    system: Any,
    t: Any,
    *,
    method: str = "DOP853",
    rtol: float | None = None,
    atol: float | None = None,
    dt: float | None = None,
    stabilization: str = "projection",
    baumgarte: float = 20.0,
    position_tol: float = 1e-12,
    max_steps: int = MAX_STEPS,
    on_separation: str = "stop",
    initial: RunState | None = None,
) -> MultibodyTrajectory:
    """Integrate the constrained equations of motion from the System's current state (or ``initial``).

    The current state is taken as the state at ``t[0]``; it must satisfy
    the constraints (to 1e-8; call :meth:`System.assemble` first). The
    System is not changed. With ``initial`` (a :class:`RunState`, e.g.
    ``traj.final_state``) the run starts from it instead, at its time
    ``initial.t``, with the contacts' warm starts and models it holds: the
    continuation of the run that ended there.

    Parameters
    ----------
    system : System
    t : (n,) non-decreasing output times (s).
    method : str, keyword-only
        ``"DOP853"`` (default, order 8) or ``"RK45"`` (order 5): scipy's
        adaptive methods, stepped one accepted step at a time, outputs by
        dense output; ``"rk4"`` or ``"midpoint"``: fixed steps of at most
        ``dt`` through :func:`rigidlab.core.integrators.integrate`;
        ``"kinematic"``: for a System whose constraints fix every
        coordinate (zero degrees of freedom: a driven mechanism, a cam
        turned by a motor with its follower on it), no integration: at
        every output the positions are solved from ``C(q, t) = 0``
        (Newton to ``position_tol``), the velocities from ``D v = -C_t``
        and the accelerations and multipliers from the augmented equations
        (Eqs. 8.105-8.107), so the results carry only the Newton tolerance.
        Separations are checked at the outputs (give outputs as fine as the
        shortest contact loss to be seen) and located by Brent's method on
        solved states; a contact that continues in the compliant model
        gives the System a degree of freedom, and the run goes on with
        DOP853 at ``rtol``/``atol``. A System with degrees of freedom,
        rolling contacts or ``stabilization`` other than ``"projection"``
        is refused.
    rtol, atol : float, keyword-only
        Adaptive methods: scipy's tolerances (default
        ``rigidlab.core.integrators.DEFAULT_RTOL`` 1e-8 and ``DEFAULT_ATOL`` 1e-10);
        ``"kinematic"``: those of its DOP853 continuation.
    dt : float, keyword-only
        Fixed-step methods: the largest step (required).
    stabilization : str, keyword-only
        ``"projection"`` (default): Newton projection of positions and
        mass-weighted projection of velocities after every step and at
        every output; ``"baumgarte"``: feedback ``gamma - 2 alpha (D v +
        C_t) - alpha^2 C`` (critically damped), no projection;
        ``"none"``: the bare index-1 equations (the residuals drift).
    baumgarte : float, keyword-only
        ``alpha`` of Baumgarte's feedback (rad/s, > 0).
    position_tol : float, keyword-only
        Newton tolerance of the position projection, ``max |C|``.
    max_steps : int, keyword-only
        Limit on steps (fixed) or right-hand-side evaluations (adaptive);
        see :func:`_check_turns` for the adaptive runs' check before they
        start.
    on_separation : str, keyword-only
        When the normal force of a constraint-model contact crosses zero
        (it would have to pull): ``"stop"`` (default) ends the run at that
        instant (``status == "separated"``, outputs up to it);
        ``"compliant"`` continues with that contact in the compliant model
        (its ``stiffness``, ``damping``, ``exponent``), which handles the
        flight, re-contact and impact; ``"bilateral"`` keeps the constraint
        (the force goes negative). Each crossing is reported in
        ``separations`` (time by Brent's method on the dense output).
    initial : RunState or None, keyword-only
        The state to start from (see :func:`_initial_state`); the output
        times must not begin before ``initial.t`` (outputs at ``initial.t``
        give its state).

    Returns
    -------
    MultibodyTrajectory

    Raises
    ------
    ValueError
        For bad options or times; ``AssemblyError`` when the state does not
        satisfy the constraints; ``SingularSystemError`` when the
        constrained equations are singular; ``IntegrationError`` when the
        integrator fails. An error raised during the run (after the start's
        checks: ``IntegrationError``, ``ContactError``, ...) carries
        ``trajectory``: the outputs reached before it, ``status ==
        "failed"`` (None if they could not be evaluated), so a notebook
        keeps the motion up to the failure::

            try:
                traj = system.simulate(t)
            except IntegrationError as exc:  # or ContactError
                traj = exc.trajectory
    """
    tt = output_times(t)
    methods = ADAPTIVE_METHODS + FIXED_STEP_METHODS + (KINEMATIC_METHOD,)
    if not isinstance(method, str) or method not in methods:
        raise ValueError(f"method: expected one of {list(methods)}, got {short_repr(method)}")
    kinematic = method == KINEMATIC_METHOD
    adaptive = method in ADAPTIVE_METHODS or kinematic
    if adaptive:
        if dt is not None:
            what = ("method 'kinematic' solves at the output times (rtol/atol are its DOP853 continuation's)"
                    if kinematic else f"adaptive method '{method}' takes rtol/atol")
            raise ValueError(f"dt: {what}, not dt (got dt={dt!r})")
        rtol = DEFAULT_RTOL if rtol is None else real_number(rtol, "rtol", expected="a finite tolerance > 0")
        atol = DEFAULT_ATOL if atol is None else real_number(atol, "atol", expected="a finite tolerance > 0")
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"rtol, atol: expected > 0, got rtol={rtol!r}, atol={atol!r}")
    else:
        if rtol is not None or atol is not None:
            raise ValueError(f"rtol, atol: fixed-step method '{method}' takes dt, not tolerances")
        if dt is None:
            raise ValueError(f"dt: method '{method}' needs a finite step dt > 0, got None")
        dt = real_number(dt, "dt", expected="a finite step dt > 0")
        if not dt > 0:
            raise ValueError(f"dt: expected a finite step dt > 0, got {dt!r}")
    if not isinstance(stabilization, str) or stabilization not in STABILIZATIONS:
        raise ValueError(f"stabilization: expected one of {list(STABILIZATIONS)}, got {short_repr(stabilization)}")
    if kinematic and stabilization != "projection":
        raise ValueError(f"stabilization: method 'kinematic' solves the constraints at every output (it is the "
                         f"projection); expected 'projection', got {short_repr(stabilization)}")
    baumgarte = real_number(baumgarte, "baumgarte", expected="a finite rate > 0 (rad/s)")
    if not baumgarte > 0:
        raise ValueError(f"baumgarte: expected a finite rate > 0 (rad/s), got {baumgarte!r}")
    position_tol = real_number(position_tol, "position_tol", expected="a finite tolerance > 0")
    if not position_tol > 0:
        raise ValueError(f"position_tol: expected a finite tolerance > 0, got {position_tol!r}")
    max_steps = positive_integer(max_steps, "max_steps")
    if not isinstance(on_separation, str) or on_separation not in SEPARATION_ACTIONS:
        raise ValueError(f"on_separation: expected one of {list(SEPARATION_ACTIONS)}, got {short_repr(on_separation)}")

    shared = system._engine()
    eng = shared.workspace()  # this run's own work arrays: simulations may run in parallel threads
    n = eng.n
    if n == 0:
        raise ValueError("system: has no bodies to simulate (add_body first)")
    t0 = float(tt[0])
    y0 = np.array(system._y)
    own_modes = True  # the contacts are in the System's models (the rank analysis may be shared)
    if initial is not None:
        t0, y0, own_modes = _initial_state(system, eng, initial, tt)
    if eng.contact_kernel is not None:
        eng.contact_state["track"] = {}  # the run's tracked contact parameters (ContactKernel.evaluate)
    # a constraint-model contact already compliant (a run continued after a separation): the System is free to
    # leave the contact, and "kinematic" integrates from the start as it does after a separation
    resumed_compliant = bool(eng.contacts) and any(
        c.model == "constraint" and int(mode) != 0 for c, mode in zip(eng.contacts, eng.contact_state["mode"]))
    if eng.m:
        check_assembled(eng, t0, y0, "simulate", limit=max(1e-8, 1e3 * position_tol))
        if not eng.analyzed:
            analyze_rank(eng, t0, y0)
            if own_modes:
                shared.adopt(eng)
    else:
        eng.analyzed = True
    check_constrained_mass(eng, t0, y0)
    if kinematic and not resumed_compliant:
        _check_kinematic(eng, t0)
    model = _Dynamics(system, eng, stabilization=stabilization, baumgarte=baumgarte, position_tol=position_tol)
    model.outputs_end_steps = kinematic  # (from the initial projection on; see _run_kinematic)
    if model.project is not None:
        model.output_times = frozenset(float(x) for x in tt)
        y0 = model.project(t0, y0)
    # a contact may be in the compliant model during the run: from the start, or after a separation
    model.locate_touches = adaptive and bool(eng.contacts) and (
        on_separation == "compliant" or any(c.model != "constraint" for c in eng.contacts)
        or bool(eng.contact_state["mode"].any()))
    if not (model._separations or model.locate_touches):
        model.stop_time = None  # (the integrators skip the event check)

    kc = len(eng.contacts)
    if kc:
        model.contact_start = eng.contact_kernel.copy_state(eng.contact_state)
        model.on_separation = on_separation
        if on_separation == "compliant":
            for c in eng.contacts:
                if c.model == "constraint" and c.stiffness is None:
                    raise ValueError(
                        f"on_separation: 'compliant' continues contact {c.name!r} with the compliant model, which "
                        "needs its stiffness (add_contact(..., stiffness=k))")
    if adaptive and not kinematic:
        _check_turns(system, y0, t0, float(tt[-1]), max_steps)
    if not adaptive:
        gaps = np.diff(tt)
        with np.errstate(over="ignore", invalid="ignore"):  # (a dt so small that the count overflows: refused below)
            counts = np.where(gaps > 0, np.ceil(gaps / dt - 1e-9), 0).astype(np.int64)
        counts[(gaps > 0) & (counts < 1)] = 1
        if int(counts.sum()) > max_steps:
            raise ValueError(
                f"dt: the output times with dt={dt:g} need {int(counts.sum())} steps, more than "
                f"max_steps={max_steps}; use a larger dt or pass a larger max_steps"
            )
    n_steps = n_rhs = 0
    pending_event = None
    if model._separations:
        # force scale of the separation test; a contact that pulls already at t0 separates there
        _, lam0, _, _, _ = model.accelerations(t0, y0)  # (kept from the output at t0)
        Q0 = model.applied_last
        nu0 = model.normal_forces(t0, y0, lam0)
        finite = nu0[np.isfinite(nu0)]
        # the bodies' centripetal forces m |omega|^2 r_g (r_g: radius of gyration): with no applied force (no
        # gravity) a normal force that is zero in exact arithmetic is round-off of their size, not a separation
        r_g = np.sqrt(np.trace(eng.inertia, axis1=1, axis2=2) / (2.0 * np.maximum(eng.mass, 1e-300)))
        w2 = np.einsum("ij,ij->i", y0[10 * n :].reshape(n, 3), y0[10 * n :].reshape(n, 3))
        inertial = float(np.max(eng.mass * w2 * r_g)) if n else 0.0
        scale = max(float(np.max(np.abs(finite))) if finite.size else 0.0, float(np.max(np.abs(Q0[: 3 * n]))),
                    inertial, 1e-300)
        model.separation_tol = SEPARATION_TOL * scale
        model._nu_prev = (t0, nu0)
        pulling = np.flatnonzero(nu0 < -model.separation_tol)
        if pulling.size:
            action = {"stop": "stopped", "compliant": "compliant", "bilateral": "bilateral"}[on_separation]
            for c in pulling:
                model.events.append((t0, int(c), np.array(y0), action))
            if action == "stopped":
                pending_event = model.events[-len(pulling)]
            elif action == "compliant":  # every contact that pulls at the start leaves the constraint model
                for c in pulling[:-1]:
                    _switch_to_compliant(eng, int(c), t0, y0)
                pending_event = model.events[-1]
    out_t: list[float] = []
    out_y: list[np.ndarray] = []
    out_mode: list[np.ndarray] = []
    eng.contact_strict = True

    def record(times, ys) -> None:
        mode = eng.contact_state["mode"].copy() if kc else None
        for tq, yq in zip(times, ys):
            out_t.append(float(tq))
            out_y.append(np.array(yq))
            out_mode.append(mode)

    first = tt[tt <= t0]
    record(first, [y0] * first.size)
    idx = first.size
    t_cur, y_cur = t0, y0
    stopped = False
    continued = resumed_compliant  # (a compliant contact is free to leave: integrated from the start)
    if kinematic and continued:
        model.outputs_end_steps = False
    try:
        while True:
            if pending_event is not None:
                te, c, ye, action = pending_event
                pending_event = None
                if action == "stopped":
                    stopped = True
                    break
                _switch_to_compliant(eng, c, te, ye)
                model._nu_prev = None
                continued = True  # a compliant contact is free to leave: integrated from here on
                model.outputs_end_steps = False  # the integrator's outputs are inside its steps (see _record_output)
            if idx >= tt.size:
                break
            if kinematic and not continued:
                res = _run_kinematic(model, y_cur, t_cur, np.concatenate([[t_cur], tt[idx:]]), max_steps)
                record(res.t[1:], res.states[1:])
                idx += res.t.size - 1
            elif adaptive and (res := _run_compiled(model, method, y_cur, t_cur, tt[idx:], rtol, atol,
                                                    max_steps)) is not None:
                record(res.t, res.states)
                idx += res.t.size
            elif adaptive:
                res = integrate(model, y_cur, (t_cur, float(tt[-1])),
                                method=KINEMATIC_CONTINUATION if kinematic else method, rtol=rtol, atol=atol,
                                t_eval=np.concatenate([[t_cur], tt[idx:]]), max_steps=max_steps)
                record(res.t[1:], res.states[1:])
                idx += res.t.size - 1
            else:
                t_next = float(tt[idx])
                if t_next <= t_cur:
                    record([t_next], [y_cur])
                    idx += 1
                    continue
                count = max(1, math.ceil((t_next - t_cur) / dt - 1e-9))
                res = integrate(model, y_cur, (t_cur, t_next), method=method, dt=(t_next - t_cur) / count,
                                save_every=count, max_steps=max_steps)
                if res.stop_time is None:
                    record([t_next], res.states[-1:])
                    idx += 1
                    t_cur, y_cur = t_next, np.array(res.states[-1])
            n_steps += res.n_steps
            n_rhs += res.n_rhs
            if res.stop_time is not None:
                t_cur, y_cur = float(res.stop_time), np.array(res.stop_state)
                if model.touched:  # a compliant contact touched or lifted: a new run from that instant
                    model.touched = False
                    continue
                pending_event = model.events[-1]
                continue
            if adaptive:
                break
    except RunFailure as exc:
        # the outputs reached before the failure, as a trajectory of their own (status "failed")
        partial = getattr(exc, "partial", None)
        if partial is not None and len(partial[0]) > 1:
            record(partial[0][1:], partial[1][1:])
        try:
            exc.trajectory = _finish(system, eng, model, method, stabilization, out_t, out_y, out_mode, kc, n,
                                     n_steps, n_rhs, "failed")
        except Exception:  # noqa: BLE001 - the run's own error is the one to report
            exc.trajectory = None
        raise
    return _finish(system, eng, model, method, stabilization, out_t, out_y, out_mode, kc, n, n_steps, n_rhs,
                   "separated" if stopped else "completed")


def _initial_state(system: Any, eng: _Engine, initial: Any, tt: np.ndarray) -> tuple[float, np.ndarray, bool]:
    """The start ``(t0, y0, own_modes)`` of a run continued from the :class:`RunState` ``initial``.

    Puts the contacts of the run's workspace ``eng`` in the models
    ``initial`` names and their Newton's warm start at its surface
    parameters. ``own_modes``: the models are the System's own (False:
    the workspace's rank analysis is redone, and not handed to the
    System).

    Raises
    ------
    ArgumentError
        ``initial`` (not a RunState, another number of bodies or contacts,
        non-finite values) or ``t`` (output times before ``initial.t``).
    """
    if not isinstance(initial, RunState):
        raise ArgumentError("initial", f"initial: expected a RunState (traj.final_state), got "
                                          f"{short_repr(initial)}")
    n = eng.n
    q, v = np.asarray(initial.q, dtype=float), np.asarray(initial.v, dtype=float)
    if q.shape != (7 * n,) or v.shape != (6 * n,):
        raise ArgumentError("initial", f"initial: expected the state of {n} bodies (q ({7 * n},), v "
                                          f"({6 * n},)), got q {q.shape}, v {v.shape}")
    t0 = float(initial.t)
    if not (math.isfinite(t0) and np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise ArgumentError("initial", "initial: expected a finite time, q and v")
    # the outputs start at the state's time; a first output within round-off of it (k T computed two ways)
    # counts as that time
    if float(tt[0]) < t0 - 8.0 * np.finfo(float).eps * max(1.0, abs(t0)):
        raise ArgumentError("t", f"t: a run from initial starts at initial.t = {t0!r}; expected output "
                                    f"times >= it, got t[0] = {float(tt[0])!r}")
    y0 = np.concatenate([q, v])
    P = y0[3 * n : 7 * n].reshape(n, 4)
    norms = np.linalg.norm(P, axis=1)
    if np.any(norms == 0.0):
        raise ArgumentError("initial", "initial: expected Euler parameters of norm 1, got norm 0")
    y0[3 * n : 7 * n] = (P / norms[:, None]).ravel()
    k = len(eng.contacts)
    models = tuple(initial.contact_models)
    if models and len(models) != k:
        raise ArgumentError("initial", f"initial: describes {len(models)} contacts, the System has {k}")
    if any(m not in RUN_CONTACT_MODELS for m in models):
        raise ArgumentError("initial", f"initial.contact_models: expected {list(RUN_CONTACT_MODELS)} per "
                                          f"contact, got {short_repr(models)}")
    own_modes = True
    if k:
        ker = eng.contact_kernel
        params, charts = initial.contact_parameters, initial.contact_charts
        if params is not None:
            if charts is None or len(params) != k or len(charts) != k:
                raise ArgumentError("initial", f"initial: expected surface parameters and charts of {k} "
                                                  f"contacts")
            state = ker.initial_state([(np.array(s), ci, cj) for s, (ci, cj) in zip(params, charts)])
        else:
            state = ker.copy_state(eng.contact_state)
        mode = np.array(eng.contact_state["mode"])
        if models:
            wanted = np.array([RUN_CONTACT_MODELS.index(m) for m in models], dtype=mode.dtype)
            for c, code in zip(eng.contacts, wanted):
                if code == 0 and c.model != "constraint":
                    raise ArgumentError("initial", f"initial: contact {c.name!r} is compliant in this System "
                                                      "and has no constraint model to return to")
            own_modes = bool(np.array_equal(wanted, mode))
            mode = wanted
        state["mode"] = mode
        eng.contact_state = state
        if not own_modes:
            eng.contact_modes_changed()
    return t0, y0, own_modes


@dataclass(frozen=True)
class _CompiledRun:
    """What :func:`_run_compiled` hands back to :func:`simulate` (the fields it reads of a Trajectory)."""

    t: np.ndarray  # (k,) output times after the start
    states: np.ndarray  # (k, 13 n)
    n_steps: int
    n_rhs: int
    stop_time: None = None


def _run_compiled(model: _Dynamics, method: str, y0: np.ndarray, t0: float, t_out: np.ndarray, rtol: float,
                  atol: float, max_steps: int) -> _CompiledRun | None:
    """A DOP853 run with projection as one compiled call (``_kernel.dop853_projected``), or None where the
    interpreted loop is needed: another method or stabilization, contacts or events, Python callables
    (motor laws, user loads) in the right-hand side, or a run the compiled loop handed back (a pivot, a
    projection or a step it could not take: the interpreted loop diagnoses it).

    It takes the same steps as ``rigidlab.core.integrators`` with scipy's DOP853 (the same coefficients, initial
    step, error norm, step control and dense output), at a few microseconds per step instead of a few
    hundred of interpreter overhead.
    """
    kc = model.kc
    if (method != "DOP853" or kc is None or model._kc_refused is model.eng.keep or kc.motors or model._has_loads or model.project is None
            or model.alpha or getattr(model, "stop_time", None) is not None
            or rtol < 100 * np.finfo(float).eps or not t_out.size or not t_out[-1] > t0):
        return None
    kc.select(model.eng.keep)
    t_out = np.ascontiguousarray(t_out, dtype=float)
    first = int(np.count_nonzero(t_out <= t0))
    pending = t_out[first:]
    y = np.array(y0, dtype=float)
    f = np.empty_like(y)
    out_y = np.empty((pending.size, y.size))
    out_res = np.empty((pending.size, 2))
    t1 = float(t_out[-1])
    carry = np.array([float(t0), 0.0, float(t0)])
    co = _dop853_tables()
    k = n_steps = n_rhs = 0
    # the checks of core.integrators._CountingModel, at the same counts (read per run: tests scale them down):
    # the long-run warning and the pace check that stops a run which cannot end within max_steps
    counter = integrators._CountingModel(model, max_calls=max_steps, span=(float(t0), t1))
    warn_at = integrators.LONG_RUN_CALLS
    pace_at = integrators.PACE_CHECK_CALLS
    stopped = None
    while True:
        stop = min(max_steps, warn_at if n_rhs < warn_at else max_steps, pace_at)
        status, k, steps, n_rhs = _kernel.dop853_projected(
            kc.I, kc.F, kc.TI, kc.W, y, f, carry, t1, pending, k, float(rtol), float(atol), model.position_tol,
            n_rhs, int(stop), STALLED_STEP * abs(t1 - t0), *co, out_y, out_res)
        n_steps += steps
        if status != _kernel.LOOP_BUDGET or stop >= max_steps:
            break
        t_now = float(carry[0])
        try:
            if n_rhs + 16 > warn_at and stop == warn_at:
                counter._warn_long(t_now)
                warn_at = max_steps
            if n_rhs + 16 > pace_at:
                counter._check_pace(t_now, n_rhs)
                pace_at *= 2
        except IntegrationError as exc:  # (_BudgetExceeded of the pace check, or the long-run check's own)
            stopped = exc
            break
    times = np.concatenate([t_out[:first], pending[:k]])
    states = np.concatenate([np.repeat(np.asarray(y0, dtype=float)[None, :], first, axis=0), out_y[:k]])
    for q in range(k):
        model.residuals[float(pending[q])] = (out_y[q].copy(), float(out_res[q, 0]), float(out_res[q, 1]))
    if status == _kernel.LOOP_BUDGET:
        if stopped is None:
            stopped = _BudgetExceeded(float(carry[0]))
        exc = _budget_error(method, stopped, t1, max_steps) if isinstance(stopped, _BudgetExceeded) else stopped
        exc.partial = ([float(t0), *times.tolist()], [np.array(y0), *states])
        raise exc
    if status != _kernel.LOOP_DONE:
        return None
    return _CompiledRun(times, states, int(n_steps), int(n_rhs))


@functools.cache
def _dop853_tables() -> tuple:
    """scipy's DOP853 coefficients ``(A, B, E3, E5, D)`` as contiguous float arrays (read once; the nodes C
    are not needed: the compiled runs have no time-dependent force)."""
    from scipy.integrate._ivp import dop853_coefficients as dc

    return tuple(np.ascontiguousarray(a, dtype=float) for a in (dc.A, dc.B, dc.E3, dc.E5, dc.D))


def _finish(system, eng, model, method, stabilization, out_t, out_y, out_mode, kc, n, n_steps, n_rhs,
            status) -> MultibodyTrajectory:
    """The trajectory of the outputs recorded by :func:`simulate` (``status``: how the run ended)."""
    eng.contact_strict = False
    if kc:
        model.contact_track = eng.contact_state.get("track")
    tt_out = np.array(out_t, dtype=float)
    states = np.array(out_y).reshape(len(out_y), 13 * n)
    modes = np.array(out_mode) if kc else None
    separations = tuple(_separation(system, eng, ev) for ev in model.events)
    _restart_contacts(model)
    res_p, res_v = _residuals(model, tt_out, states, modes)
    model.residuals = {}
    return MultibodyTrajectory(
        t=_ro(tt_out),
        q=_ro(states[:, : 7 * n]),
        v=_ro(states[:, 7 * n :]),
        energy=_ro(_energy(eng, states, modes, tt_out, getattr(model, "contact_start", None),
                           getattr(model, "contact_track", None), model)),
        residual_position=_ro(res_p),
        residual_velocity=_ro(res_v),
        method=method,
        stabilization=stabilization,
        n_steps=int(n_steps),
        n_rhs=int(n_rhs),
        separations=separations,
        status=status,
        _modes=modes,
        _model=model,
        _owner=system,
    )
