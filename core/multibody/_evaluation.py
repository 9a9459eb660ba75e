"""All terms of the equations of motion at one state, in both forms of the chapter.

Newton-Euler form (what :meth:`System.simulate` integrates), velocities
``v = [R_dot, omega_body]`` (6n):

    M a + D^T lambda = Q_e + Q_v,   D a = gamma,
    M = diag(m I, I_body),  Q_v = [0, -omega_body x (I_body omega_body)]

Euler-parameter form, coordinates ``q = [R, p]`` (7n) with ``omega_body =
2 G_bar(p) p_dot`` (Eqs. 8.51-8.54) and the normalization constraints
``p^T p = 1``:

    M_q q_dd + C_q^T lambda + 2 p lambda_p = Q_q,   C_q q_dd = gamma,   2 p^T p_dd = -2 p_dot^T p_dot
    M_q = diag(m I, 4 G_bar^T I_body G_bar),
    Q_q = [F, 2 G_bar^T n_body + 8 G_bar_dot^T I_body G_bar_dot p]

with ``C_q = D L``, ``L = diag(I, 2 G_bar)`` the map ``v = L q_dot``; the two
forms give the same motion (``a = L q_dd``, Eq. 8.57 for the angular part)
and the same joint multipliers. ``C`` depends on ``p`` through ``A(p /
|p|)``, so ``C_q p = 0`` and ``gamma`` is shared by both forms.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigidlab.core._validation import real_number

from ._analysis import analyze_rank, check_constrained_mass

__all__ = ["Evaluation"]


def _G_bar(p: np.ndarray) -> np.ndarray:
    """(n, 3, 4) G_bar of (n, 4) parameters (Eqs. 8.51-8.54)."""
    w, x, y, z = p[:, 0], p[:, 1], p[:, 2], p[:, 3]
    out = np.zeros((p.shape[0], 3, 4))
    out[:, :, 0] = -p[:, 1:]
    out[:, 0, 1], out[:, 1, 2], out[:, 2, 3] = w, w, w
    out[:, 0, 2], out[:, 0, 3] = z, -y
    out[:, 1, 1], out[:, 1, 3] = -z, x
    out[:, 2, 1], out[:, 2, 2] = y, -x
    return out


@dataclass(frozen=True)
class Evaluation:
    """The equations of motion of a System at one state (read-only arrays).

    ``n`` bodies, ``m`` constraint rows (joints, then motors).

    Attributes
    ----------
    t : float
    C : (m,) constraint values ``C(q, t)``.
    D : (m, 6n) Jacobian in the Newton-Euler velocities ``[R_dot, omega_body]``.
    C_q : (m, 7n) Jacobian in ``q = [R, p]`` (``C_q = D L``).
    C_t : (m,) partial time derivative (motors).
    gamma : (m,) acceleration right side (the chapter's Q_d): ``D a = gamma``.
    M : (6n, 6n) Newton-Euler mass matrix ``diag(m I, I_body)``.
    Q : (6n,) applied plus quadratic-velocity forces (global forces, body
        torques about the centres of mass).
    accelerations : (6n,) ``a = [R_ddot, omega_body_dot]``.
    multipliers : (m,) Lagrange multipliers (zero for redundant rows).
    independent : (r,) indices of the rows used (the others are redundant).
    M_q : (7n, 7n) Euler-parameter form mass matrix ``diag(m I, 4 G_bar^T I G_bar)``.
    Q_q : (7n,) Euler-parameter form applied plus quadratic-velocity forces.
    q_dot : (7n,) ``[R_dot, p_dot]``.
    """

    t: float
    C: np.ndarray = field(repr=False)
    D: np.ndarray = field(repr=False)
    C_q: np.ndarray = field(repr=False)
    C_t: np.ndarray = field(repr=False)
    gamma: np.ndarray = field(repr=False)
    M: np.ndarray = field(repr=False)
    Q: np.ndarray = field(repr=False)
    accelerations: np.ndarray = field(repr=False)
    multipliers: np.ndarray = field(repr=False)
    independent: np.ndarray = field(repr=False)
    M_q: np.ndarray = field(repr=False)
    Q_q: np.ndarray = field(repr=False)
    q_dot: np.ndarray = field(repr=False)

    def q_ddot(self) -> np.ndarray:
        """(7n,) ``[R_ddot, p_ddot]`` from the Newton-Euler accelerations (Eq. 8.57).

        ``p_ddot = G_bar^T omega_body_dot / 2 - |omega_body|^2 p / 4``.
        """
        n = self.M.shape[0] // 6
        a = self.accelerations
        p = self._p()
        w = self._w()
        Gb = _G_bar(p)
        pdd = 0.5 * np.einsum("nji,nj->ni", Gb, a[3 * n :].reshape(n, 3)) - 0.25 * np.einsum(
            "ni,ni->n", w, w)[:, None] * p
        return np.concatenate([a[: 3 * n], pdd.ravel()])

    def _p(self) -> np.ndarray:
        n = self.M.shape[0] // 6
        return self._q[3 * n :].reshape(n, 4)

    def _w(self) -> np.ndarray:
        n = self.M.shape[0] // 6
        return self._v[3 * n :].reshape(n, 3)

    _q: np.ndarray = field(repr=False, default=None)
    _v: np.ndarray = field(repr=False, default=None)

    def solve_euler_parameter_form(self) -> tuple[np.ndarray, np.ndarray]:
        """Solve the Euler-parameter form with the normalization constraints.

        ``[[M_q, C_q^T, P^T], [C_q, 0, 0], [P, 0, 0]] [q_dd; lambda; lambda_p]
        = [Q_q; gamma; -2 p_dot.p_dot]`` with ``P = diag(2 p^T)``, using the
        independent rows only.

        Returns
        -------
        q_ddot : (7n,)
        multipliers : (m,) (zero for redundant rows)
        """
        n = self.M.shape[0] // 6
        keep = self.independent
        Cq = self.C_q[keep]
        r = Cq.shape[0]
        p = self._p()
        pd = self.q_dot[3 * n :].reshape(n, 4)
        Pn = np.zeros((n, 7 * n))
        for k in range(n):
            Pn[k, 3 * n + 4 * k : 3 * n + 4 * k + 4] = 2.0 * p[k]
        size = 7 * n + r + n
        K = np.zeros((size, size))
        K[: 7 * n, : 7 * n] = self.M_q
        K[: 7 * n, 7 * n : 7 * n + r] = Cq.T
        K[7 * n : 7 * n + r, : 7 * n] = Cq
        K[: 7 * n, 7 * n + r :] = Pn.T
        K[7 * n + r :, : 7 * n] = Pn
        rhs = np.concatenate([self.Q_q, self.gamma[keep], -2.0 * np.einsum("ni,ni->n", pd, pd)])
        sol = np.linalg.solve(K, rhs)
        lam = np.zeros(self.C.shape[0])
        lam[keep] = sol[7 * n : 7 * n + r]
        return sol[: 7 * n], lam


def evaluate(system: Any, *, t: Any = None) -> Evaluation:
    """See :meth:`System.evaluate`."""
    from ._simulate import _Dynamics

    t = system._t if t is None else real_number(t, "t", expected="a finite time (s)")
    shared = system._engine()
    eng = shared.workspace()
    n = eng.n
    y = np.array(system._y)
    if not eng.analyzed:
        analyze_rank(eng, t, y)
        shared.adopt(eng)
    check_constrained_mass(eng, t, y)
    model = _Dynamics(system, eng, stabilization="none", baumgarte=1.0, position_tol=1e-12)
    a, lam, C, D, Ct = model.accelerations(t, y)
    At, Y, Phi, gam = eng.table(t, y, level=2)
    _, D2, _, gamma = eng.constraint_rows(t, Y, Phi, gam, level=2)
    D = np.array(D2)
    gamma = np.array(gamma)
    Q = eng.applied(t, y, At, Y, Phi, model._state)
    P = y[3 * n : 7 * n].reshape(n, 4)
    W = y[10 * n :].reshape(n, 3)
    Gb = _G_bar(P)
    L = np.zeros((6 * n, 7 * n))
    L[: 3 * n, : 3 * n] = np.eye(3 * n)
    for k in range(n):
        L[3 * n + 3 * k : 3 * n + 3 * k + 3, 3 * n + 4 * k : 3 * n + 4 * k + 4] = 2.0 * Gb[k]
    Cq = D @ L
    # Euler-parameter form
    pd = np.einsum("nji,nj->ni", Gb, W) * 0.5
    Gbd = _G_bar(pd)
    Mq = np.zeros((7 * n, 7 * n))
    Qq = np.zeros(7 * n)
    Qq[: 3 * n] = Q[: 3 * n]
    for k in range(n):
        Mq[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = eng.mass[k] * np.eye(3)
        J = eng.inertia[k]
        Mq[3 * n + 4 * k : 3 * n + 4 * k + 4, 3 * n + 4 * k : 3 * n + 4 * k + 4] = 4.0 * Gb[k].T @ J @ Gb[k]
        n_body = Q[3 * n + 3 * k : 3 * n + 3 * k + 3] + np.cross(W[k], J @ W[k])  # applied torque only
        Qq[3 * n + 4 * k : 3 * n + 4 * k + 4] = 2.0 * Gb[k].T @ n_body + 8.0 * Gbd[k].T @ J @ Gbd[k] @ P[k]
    keep = np.arange(eng.m) if eng.keep is None else eng.keep
    q_dot = np.concatenate([y[7 * n : 10 * n], pd.ravel()])
    arrays = dict(C=C, D=D, C_q=Cq, C_t=Ct, gamma=gamma, M=eng.M.copy(), Q=Q, accelerations=a, multipliers=lam,
                  independent=np.array(keep), M_q=Mq, Q_q=Qq, q_dot=q_dot, _q=y[: 7 * n].copy(), _v=y[7 * n :].copy())
    arrays = {k: np.array(v) for k, v in arrays.items()}
    for v in arrays.values():
        v.setflags(write=False)
    return Evaluation(t=float(t), **arrays)
