"""Hooks of the compiled model for linearization (used by :mod:`rigidlab.core.modal`).

Everything here works on the generic constraint rows of a System (the row
table of ``_engine``, with its motors) and on its force elements, never on
joint kinds, so that any row the table gains (contact, rolling) is
linearized the same way.

Perturbation coordinates (Eqs. 8.110-8.112)
-------------------------------------------
About a reference state ``(R0, p0, R0_dot, omega0)`` at time ``t``, every
body ``b`` gets tangent coordinates ``z_b = (rho_b, theta_b)``: a
translation of its centre of mass and a small rotation, both measured in an
observer frame that coincides with the global frame at ``t`` and turns at
the constant global angular velocity ``Omega`` (zero for equilibria)::

    R = R0(t) + Rot(t) rho,          A = exp(skew(Rot(t) theta)) A0(t)

At ``t`` (``Rot = I``) the velocities and accelerations of the bodies are,
to first order in ``(z, z_dot)``,

    R_dot   = R0_dot + rho_dot + Omega x rho
    omega   = omega0 + theta_dot + Omega x theta + theta x omega0          (global)
    R_ddot  = R0_ddot + rho_ddot + 2 Omega x rho_dot + Omega x (Omega x rho)
    alpha   = alpha0 + theta_ddot + 2 Omega x theta_dot + Omega x (Omega x theta)
              + (theta_dot + Omega x theta) x omega0 + theta x alpha0

The linearized equations come from the dynamic residual of every body with
the multipliers held at their reference values ``lambda0``::

    F(z, z_dot, z_ddot) = [M a - Q + D^T lambda0]   (torques turned to global by A(z))

``F = 0`` at the reference; ``dF/dz`` (stiffness: applied forces *and* the
geometric stiffness ``d(D^T lambda0)/dz`` of the constraint forces),
``dF/dz_dot`` (damping and gyroscopic coupling) and ``dF/dz_ddot`` (the mass
matrix, exact) are projected on the perturbations the constraints allow;
the change of the multipliers is orthogonal to those and drops out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse

from . import _tree_basis
from ._engine import _Engine, cross
from ._state import exp_parameters, quaternion_products

__all__ = [
    "Reference",
    "body_coupling",
    "body_length_scales",
    "constraint_force",
    "compiled_rows",
    "constraint_stiffness",
    "constraint_stiffness_sparse",
    "distance2_colors",
    "has_extra_rows",
    "jacobian_from_slots",
    "mass_blocks",
    "mass_matrix",
    "nonholonomic_rows",
    "project_positions",
    "reference",
    "residual",
    "row_multipliers",
    "selected_vectors",
    "table_row_count",
    "tree_null_space",
]


@dataclass(frozen=True)
class Reference:
    """The reference state of a linearization, arrays of the compiled model (n bodies).

    Attributes
    ----------
    t : float
    y : (13n,) state ``[R, p, R_dot, omega_body]``.
    A : (n, 3, 3) rotation matrices (body to global).
    omega : (n, 3) global angular velocities.
    R_ddot : (n, 3) centre-of-mass accelerations (global).
    alpha : (n, 3) global angular accelerations.
    multipliers : (m,) Lagrange multipliers (zero for redundant rows).
    D : (m, 6n) constraint Jacobian in ``[R_dot, omega_body]``.
    keep : (r,) independent rows.
    frame_omega : (3,) angular velocity of the observer frame (global).
    """

    t: float
    y: np.ndarray
    A: np.ndarray
    omega: np.ndarray
    R_ddot: np.ndarray
    alpha: np.ndarray
    multipliers: np.ndarray
    D: np.ndarray
    keep: np.ndarray
    frame_omega: np.ndarray


def reference(system: Any, t: float, frame_omega: np.ndarray) -> tuple[_Engine, Reference]:
    """A workspace of the System's compiled model and the reference at its current state.

    The constraint rows are analysed (independent rows) and the
    accelerations and multipliers solved at the current state.
    """
    from ._analysis import analyze_rank, check_constrained_mass
    from ._simulate import _Dynamics

    shared = system._engine()
    _slot_tables(shared)
    _row_tables(shared)
    if getattr(shared, "_linearization_U", None) is None:
        shared._linearization_U = scipy.sparse.csr_matrix(shared.U)
    if getattr(shared, "_linearization_ell", None) is None:
        shared._linearization_ell = body_length_scales(shared)
    if getattr(shared, "_linearization_trees", None) is None:
        shared._linearization_trees = {}  # (shared with the workspaces: see _tree_order)
    eng = shared.workspace()
    n = eng.n
    y = np.array(system._y, dtype=float)
    if not eng.analyzed:
        analyze_rank(eng, t, y)
        shared.adopt(eng)
    check_constrained_mass(eng, t, y)
    model = _Dynamics(system, eng, stabilization="none", baumgarte=1.0, position_tol=1e-12)
    compiled = _compiled_accelerations(model, t, y)
    if compiled is None:
        a, lam, _, D, _ = model.accelerations(t, y)
        D = np.array(D) if eng.m else np.zeros((0, 6 * n))
    else:
        a, lam, D = compiled
    keep = np.arange(eng.m) if eng.keep is None else np.array(eng.keep)
    At = np.array(eng.frames(y, velocities=False))
    A = np.transpose(At, (0, 2, 1)).copy()
    w_body = y[10 * n :].reshape(n, 3)
    omega = np.einsum("nij,nj->ni", A, w_body)
    alpha = np.einsum("nij,nj->ni", A, a[3 * n :].reshape(n, 3))
    ref = Reference(float(t), y, A, omega, a[: 3 * n].reshape(n, 3).copy(), alpha, np.array(lam), D, keep,
                    np.array(frame_omega, dtype=float))
    return eng, ref


def compiled_rows(eng: _Engine) -> bool:
    """True when the compiled kernels hold every constraint row of ``eng`` (no contacts, no rolling rows)."""
    return eng.compiled is not None and not has_extra_rows(eng) and not nonholonomic_rows(eng).size


def _compiled_accelerations(model: Any, t: float, y: np.ndarray):
    """``(a (6n,), lambda (m,), D (m, 6n))`` at ``(t, y)`` on the compiled kernels (Baraff's O(N) solve of
    Eq. 8.109), or None where they do not apply (then the numpy evaluation, which diagnoses what they
    refused: a pivot that is not definite, a singular system)."""
    eng = model.eng
    if not compiled_rows(eng):
        return None
    ydot = model._rhs_compiled(t, y)
    if ydot is None:
        return None
    kc = model.kc
    lam = np.array(kc.lam)  # (rows the tree does not solve, the redundant ones, stay 0)
    return ydot[7 * eng.n :].copy(), lam, jacobian_from_slots(eng.n, kc.Jc, kc.jc_body)


def jacobian_from_slots(n: int, Jc: np.ndarray, jc_body: np.ndarray) -> np.ndarray:
    """The dense constraint Jacobian D (m, 6n) in ``[R_dot, omega_body]`` from the rows' slots (``_compiled``):
    ``Jc`` (m, 3, 6) per row and slot the derivative by that body's ``(R_dot, omega_body)``, ``jc_body``
    (m, 3) the slots' bodies (-1: none). A row's slots are distinct bodies."""
    m = Jc.shape[0]
    D = np.zeros((m, 6 * n))
    r, s = np.nonzero(jc_body >= 0)
    at = (r * (6 * n) + 3 * jc_body[r, s])[:, None] + np.arange(3)[None, :]  # (flat index of the R_dot columns)
    flat = D.reshape(-1)
    flat[at] = Jc[r, s, :3]
    flat[at + 3 * n] = Jc[r, s, 3:]
    return D


#: Smallest singular value, relative to the largest, of a tree joint's rows over its child body for
#: :func:`tree_null_space` (below it the dense null space is taken).
TREE_RANK_TOL = 1e-9


def tree_null_space(eng: _Engine, ref: Reference) -> np.ndarray | None:
    """(6n, f) basis of the tangent motions ``z = [dR, dtheta]`` that the kept rows allow (Eq. 8.111), from
    the spanning tree of the compiled kernels; None where it does not apply.

    The kept rows of a System on the compiled kernels are grouped by joint
    over a spanning tree of the bodies (``_compiled.build_tree``, Baraff's
    elimination order). A tree joint ``g`` between parent ``p`` (or the
    ground) and child ``c`` has rows ``D_gp z_p + D_gc z_c = 0``, ``D_gc``
    (s x 6) of full row rank, so the child moves as ``z_c = T_g z_p + N_g
    w_g`` with ``T_g = -D_gc^+ D_gp`` and ``N_g`` (6 x (6 - s)) the joint's
    free directions (the null space of ``D_gc``, by QR of ``D_gc^T``). From the roots
    (a body without a parent joint is free: six columns) down the tree,
    every joint adds its free directions and carries its parent's columns:
    O(n f). The k secondary rows (loops) then restrict the tree's motions
    to the null space of the small ``E = D_sec B`` (k x f). The columns are
    not orthonormal (see ``rigidlab.core.modal``).

    None (the caller takes the dense null space) without the compiled
    kernels, with contacts or rolling rows, or when a tree joint's rows are
    not of full rank over its child body (``TREE_RANK_TOL``) or the loop
    rows not over the tree's motions.
    """
    if not compiled_rows(eng):
        return None
    n = eng.n
    kc = eng.compiled
    kc.select(eng.keep)
    kc.evaluate(ref.t, ref.y, 1)
    tr = kc.tree_now
    bodies, joint, up, start, free = _tree_order(eng, tr)
    f = int(start[-1] + free[-1]) if n else 0
    B3 = np.zeros((n, 6, f))  # per body its rows [dR | dtheta]
    if _tree_basis.tree_basis(kc.Jc, kc.jc_body, ref.A, tr.group_rows, tr.group_slot_of, bodies, joint, up, start,
                              free, TREE_RANK_TOL, B3):
        return None
    sec = tr.sec_rows
    if sec.size > f:
        return None
    if sec.size:
        jb = kc.jc_body[sec]
        bs = np.where(jb >= 0, jb, 0)
        Jz = np.array(kc.Jc[sec])  # (k, 3, 6): rotation columns turned to global small rotations, (A J_w)^T
        Jz[..., 3:] = np.einsum("lsji,lsi->lsj", ref.A[bs], Jz[..., 3:])
        E = np.einsum("lsk,lskf->lf", Jz * (jb >= 0)[..., None], B3[bs])
        _, Se, Ve = np.linalg.svd(E)
        if not Se[-1] > TREE_RANK_TOL * Se[0]:
            return None
        B3 = np.matmul(B3, Ve[sec.size :].T)
    return np.concatenate([B3[:, :3].reshape(3 * n, -1), B3[:, 3:].reshape(3 * n, -1)])


def _tree_order(eng: _Engine, tr: Any) -> tuple:
    """Per body, parents first (``_tree_basis.tree_basis``'s order): ``(bodies, joint, up, start, free)``, the
    body, its tree joint (-1: a root), its parent body (-1: none), its first free column and its number of
    free directions. Cached per tree on the System's engine (see :func:`reference`)."""
    cache = getattr(eng, "_linearization_trees", None)
    key = id(tr)
    if cache is not None and key in cache and cache[key][0] is tr:
        return cache[key][1]
    kind, parent, ref_of = tr.node_kind, tr.order_parent, tr.node_ref
    nodes = np.flatnonzero(kind == 0)[::-1]
    bodies = ref_of[nodes]
    pg = parent[nodes]
    child = pg >= 0
    joint = np.full(nodes.size, -1, dtype=np.int64)
    joint[child] = ref_of[pg[child]]
    pp = np.full(nodes.size, -1, dtype=np.int64)
    pp[child] = parent[pg[child]]
    up = np.full(nodes.size, -1, dtype=np.int64)
    up[pp >= 0] = ref_of[pp[pp >= 0]]
    size = np.concatenate([np.sum(tr.group_rows >= 0, axis=1), [0]])
    free = (6 - size[joint]).astype(np.int64)  # (a root: joint -1, six free columns)
    start = np.concatenate([[0], np.cumsum(free)[:-1]]).astype(np.int64)
    out = tuple(np.ascontiguousarray(a, dtype=np.int64) for a in (bodies, joint, up, start, free))
    if cache is not None:
        cache[key] = (tr, out)
    return out


def mass_blocks(eng: _Engine, ref: Reference) -> np.ndarray:
    """(2n, 3, 3) the diagonal blocks of :func:`mass_matrix`: ``m_b I`` (translations), then ``A I_body A^T``."""
    n = eng.n
    out = np.empty((2 * n, 3, 3))
    out[:n] = eng.mass[:, None, None] * np.eye(3)
    out[n:] = np.matmul(np.matmul(ref.A, eng.inertia), np.transpose(ref.A, (0, 2, 1)))
    return out


def mass_matrix(eng: _Engine, ref: Reference) -> np.ndarray:
    """(6n, 6n) ``dF/dz_ddot = diag(m I, A I_body A^T)`` (exact)."""
    n = eng.n
    M = np.zeros((6 * n, 6 * n))
    for k in range(n):
        M[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = eng.mass[k] * np.eye(3)
        A = ref.A[k]
        M[3 * n + 3 * k : 3 * n + 3 * k + 3, 3 * n + 3 * k : 3 * n + 3 * k + 3] = A @ eng.inertia[k] @ A.T
    return M


def perturbed_state(eng: _Engine, ref: Reference, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray):
    """``(y (13n,), a (6n,), A (n, 3, 3))``: state and accelerations of the perturbation ``(z, z_dot, z_ddot)``."""
    n = eng.n
    W = ref.frame_omega[None, :]
    rho, theta = z[: 3 * n].reshape(n, 3), z[3 * n :].reshape(n, 3)
    rho_d, theta_d = zd[: 3 * n].reshape(n, 3), zd[3 * n :].reshape(n, 3)
    rho_dd, theta_dd = zdd[: 3 * n].reshape(n, 3), zdd[3 * n :].reshape(n, 3)
    y0 = ref.y
    P = quaternion_products(exp_parameters(theta), y0[3 * n : 7 * n].reshape(n, 4))
    P /= np.linalg.norm(P, axis=1)[:, None]
    A = np.matmul(_rotations(theta), ref.A)
    R_dot = y0[7 * n : 10 * n].reshape(n, 3) + rho_d
    R_dd = ref.R_ddot + rho_dd
    omega_E = theta_d
    alpha = ref.alpha + theta_dd
    if np.any(W):  # observer frame turning: transport and Coriolis terms
        Wn = np.repeat(W, n, axis=0)
        w_theta = cross(Wn, theta)
        w_rho = cross(Wn, rho)
        R_dot = R_dot + w_rho
        omega_E = omega_E + w_theta
        R_dd = R_dd + 2.0 * cross(Wn, rho_d) + cross(Wn, w_rho)
        alpha = alpha + 2.0 * cross(Wn, theta_d) + cross(Wn, w_theta)
    omega = ref.omega + omega_E
    if np.any(ref.omega):
        omega = omega + cross(theta, ref.omega)
        alpha = alpha + cross(omega_E, ref.omega)
    if np.any(ref.alpha):
        alpha = alpha + cross(theta, ref.alpha)
    y = np.empty(13 * n)
    y[: 3 * n] = y0[: 3 * n] + rho.ravel()
    y[3 * n : 7 * n] = P.ravel()
    y[7 * n : 10 * n] = R_dot.ravel()
    At = A.transpose(0, 2, 1)
    y[10 * n :] = np.matmul(At, omega[:, :, None]).ravel()
    a = np.concatenate([R_dd.ravel(), np.matmul(At, alpha[:, :, None]).ravel()])
    return y, a, A


def residual(eng: _Engine, ref: Reference, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, state_factory, *,
             table_rows: bool = True) -> np.ndarray:
    """(6n,) dynamic residual ``F(z, z_dot, z_ddot)`` of every body (forces; torques global).

    ``F = M a - Q + D^T lambda0`` with the multipliers held at the
    reference, torques about the centres of mass turned from the body
    frame to the global frame by the perturbed ``A``. The rows of the row
    table are summed row by row (:func:`constraint_force`, no dense
    Jacobian); ``table_rows=False`` leaves them out (their derivative is
    :func:`constraint_stiffness`). Rows outside the table (contacts) are
    always included, from the engine's full evaluation.
    """
    n = eng.n
    y, a, A = perturbed_state(eng, ref, z, zd, zdd)
    t = ref.t
    extra = has_extra_rows(eng)
    if extra:
        At, Y, Phi, gam = eng.table(t, y, level=2)
    else:
        At, Y, Phi = selected_vectors(eng, y)
    Q = eng.applied(t, y, At, Y, Phi, state_factory)
    F = eng.M @ a - Q
    if table_rows and eng.m:
        F += constraint_force(eng, t, At, Y, ref.multipliers)
    if extra:
        mt = table_row_count(eng)
        _, D, _, _ = eng.constraint_rows(t, Y, Phi, gam, level=1)
        F += np.asarray(D)[mt:].T @ ref.multipliers[mt:]
    out = np.empty(6 * n)
    out[: 3 * n] = F[: 3 * n]
    out[3 * n :] = np.matmul(A, F[3 * n :].reshape(n, 3, 1)).ravel()
    return out


def selected_vectors(eng: _Engine, y: np.ndarray):
    """``(At, Y, Phi)`` of the row table at ``y`` with velocities, without the Jacobian (see ``_Engine.table``)."""
    eng.generation += 1  # the work arrays are overwritten
    At = eng.frames(y, velocities=True)
    U = getattr(eng, "_linearization_U", None)
    if U is None:
        U = eng._linearization_U = scipy.sparse.csr_matrix(eng.U)
    Y = U @ eng.B
    m = eng.m_tab
    Phi = np.einsum("ri,ri->r", Y[:m, 0:3], Y[m : 2 * m, 0:3])
    return At, Y, Phi


def _row_tables(eng: _Engine) -> dict:
    """Where the Jacobian entries of the row table go (read from the compiled scatter indices), cached on ``eng``."""
    cached = getattr(eng, "_linearization_rows", None)
    if cached is not None:
        return cached
    n = eng.n
    nw, nt = 3 * n + 3, 6 * n + 6
    fw = np.asarray(eng.flat_w)[::3]
    w_row, w_body = fw // nw, (fw % nw) // 3
    fr = np.asarray(eng.flat_R)[::3]
    r_row, r_col = fr // nt, fr % nt
    live_w = w_body < n
    live_r = r_col < 3 * n
    pc = np.asarray(eng.rows_pc)
    const = np.array(eng.Dt_full[pc, : 3 * n]) if pc.size else np.zeros((0, 3 * n))
    tables = dict(w_row=w_row[live_w], w_body=w_body[live_w], w_keep=np.flatnonzero(live_w),
                  r_row=r_row[live_r], r_col=r_col[live_r], r_keep=np.flatnonzero(live_r), pc=pc, pc_R=const)
    eng._linearization_rows = tables
    return tables


def table_row_count(eng: _Engine) -> int:
    """Constraint rows of the row table (joints and motors); rows after them (contacts) come from elsewhere."""
    return int(getattr(eng, "m_motor", eng.m))


def has_extra_rows(eng: _Engine) -> bool:
    """True when the model has constraint rows outside the row table (contacts)."""
    return eng.m > table_row_count(eng) or getattr(eng, "contact_kernel", None) is not None


def row_multipliers(eng: _Engine, t: float, lam: np.ndarray) -> np.ndarray:
    """(m_tab,) multipliers of the table rows: the constraint rows' own, and the angle motors' spread on their
    auxiliary rows (``C = P1 cos f - P2 sin f``)."""
    mu = np.zeros(eng.m_tab)
    mu[: eng.m_dir] = lam[: eng.m_dir]
    if eng.angle_motors:
        fv = np.array([mt.values(t) for mt in eng.angle_motors]).reshape(-1, 3)
        lm = lam[eng.m_dir : table_row_count(eng)]
        np.add.at(mu, eng.aux_motor[:, 0], np.cos(fv[:, 0]) * lm)
        np.add.at(mu, eng.aux_motor[:, 1], -np.sin(fv[:, 0]) * lm)
    return mu


def constraint_force(eng: _Engine, t: float, At: np.ndarray, Y: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """(6n,) ``D^T lambda`` in ``[R_dot, omega_body]`` from the row table, summed row by row.

    The same Jacobian entries as ``_Engine.table`` (cross products ``a x X``
    in the global frame, the dot-2 rows' ``+-a`` and the point rows'
    constant ``+-e``), weighted by the rows' multipliers and added per body
    instead of scattered into a dense ``D``.
    """
    n = eng.n
    tb = _row_tables(eng)
    mu = row_multipliers(eng, t, lam)
    out = np.zeros(6 * n)
    if tb["pc"].size:
        out[: 3 * n] += tb["pc_R"].T @ mu[tb["pc"]]
    if tb["r_row"].size:
        vals = (Y[eng.R_rows, 0:3] * eng.R_sign)[tb["r_keep"]] * mu[tb["r_row"], None]
        np.add.at(out, (tb["r_col"][:, None] + np.arange(3)[None, :]), vals)
    if tb["w_row"].size:
        c = cross(Y[eng.cross_a, 0:3], Y[eng.cross_u, 0:3] * eng.cross_sign)[tb["w_keep"]]
        g = np.zeros((n, 3))
        np.add.at(g, tb["w_body"], c * mu[tb["w_row"], None])
        out[3 * n :] = np.matmul(At, g[:, :, None]).ravel()
    return out


def _rotations(theta: np.ndarray) -> np.ndarray:
    """exp(skew(theta)) (n, 3, 3) of rotation vectors (n, 3) (Rodriguez formula)."""
    n = theta.shape[0]
    ang = np.sqrt(np.einsum("ni,ni->n", theta, theta))
    small = ang < 1e-4
    safe = np.where(small, 1.0, ang)
    a = np.where(small, 1.0 - ang**2 / 6.0, np.sin(ang) / safe)
    b = np.where(small, 0.5 - ang**2 / 24.0, (1.0 - np.cos(ang)) / safe**2)
    K = np.zeros((n, 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -theta[:, 2], theta[:, 1], -theta[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = theta[:, 2], -theta[:, 1], theta[:, 0]
    return np.eye(3)[None] + a[:, None, None] * K + b[:, None, None] * np.matmul(K, K)


def body_coupling(eng: _Engine, *, table_rows: bool = True) -> list[set[int]]:
    """Per body, the bodies whose coordinates its residual depends on (itself included).

    Two bodies are coupled when they appear in one constraint row of the
    table (joints and motors; only with ``table_rows``), one spring-damper,
    one torsion spring or one contact (its rows, or its compliant force,
    and its surface parameters depend on the poses and velocities of its
    two bodies only, Eqs. 8.84-8.86). User forces and torques may read any
    state: with any of them every body is coupled to every other.
    """
    n = eng.n
    full = set(range(n))
    if eng.user_forces or eng.user_torques:
        return [set(full) for _ in range(n)]
    groups: list[set[int]] = []
    for c in getattr(eng, "contacts", ()):
        groups.append({b.index for b in (c.body_i, c.body_j) if b.index >= 0})
    if table_rows and eng.m_tab:
        tb = _slot_tables(eng)
        rows: list[set[int]] = [set() for _ in range(eng.m_tab)]
        for r, b in zip(tb["t_row"].tolist(), tb["t_body"].tolist()):
            rows[r].add(b)
        for r, b in enumerate(tb["a_body"].tolist()):
            if b >= 0:
                rows[r].add(b)
        groups += rows
    for sp in eng.springs:
        groups.append({b.index for b in (sp.body_i, sp.body_j) if b.index >= 0})
    for rs in eng.rot_springs:
        groups.append({b.index for b in (rs.joint.body_i, rs.joint.body_j) if b.index >= 0})
    out = [{b} for b in range(n)]
    for g in groups:
        for b in g:
            out[b] |= g
    return out


def distance2_colors(coupling: list[set[int]]) -> list[list[int]]:
    """Groups of bodies that may be perturbed together (greedy distance-2 colouring).

    No body's residual depends on two bodies of one group, so one pair of
    evaluations per group and coordinate recovers all their Jacobian columns.
    """
    n = len(coupling)
    color = [-1] * n
    for b in range(n):
        near: set[int] = set()
        for c in coupling[b]:
            near |= coupling[c]
        used = {color[c] for c in near if color[c] >= 0}
        k = 0
        while k in used:
            k += 1
        color[b] = k
    groups: list[list[int]] = [[] for _ in range(max(color) + 1 if n else 0)]
    for b, k in enumerate(color):
        groups[k].append(b)
    return groups


def project_positions(system: Any, t: float, y: np.ndarray, *, tol: float = 1e-12, max_iterations: int = 50):
    """``(y, residual)``: the state ``y`` (13n,) moved onto ``C(q, t) = 0`` by Newton (least change, mass metric).

    The same iteration as :meth:`System.assemble` (minimum-norm corrections,
    step halving); the velocities are left as they are.

    Raises
    ------
    AssemblyError
        When Newton does not converge.
    """
    from ._analysis import _newton_positions

    eng = system._engine().workspace()
    if not eng.m:
        return np.array(y, dtype=float), 0.0
    y, _, res = _newton_positions(eng, float(t), np.array(y, dtype=float), tol, max_iterations, "animate")
    return y, float(res)


def body_length_scales(eng: _Engine) -> np.ndarray:
    """(n,) per body the largest distance from its centre of mass to a joint or spring point (m), 1 if none
    (cached on the engine: :func:`reference` keeps it on the System's)."""
    cached = getattr(eng, "_linearization_ell", None)
    if cached is not None:
        return cached.copy()
    n = eng.n
    arm = np.zeros(n)
    for jt in eng.joints:
        for side, body in (("u_i", jt.body_i), ("u_j", jt.body_j)):
            if body.index >= 0:
                arm[body.index] = max(arm[body.index], float(np.linalg.norm(jt._local[side])))
    for sp in eng.springs:
        for side, body in (("u_i", sp.body_i), ("u_j", sp.body_j)):
            if body.index >= 0:
                arm[body.index] = max(arm[body.index], float(np.linalg.norm(sp._local[side])))
    return np.where(arm > 0.0, arm, 1.0)


def nonholonomic_rows(eng: _Engine) -> np.ndarray:
    """Indices of the rows that constrain velocities only (rolling); ``eng.nonholonomic_rows`` if the model has it.

    Their velocity equations ``D_r v = 0`` restrict the perturbation
    velocities but not the positions.
    """
    return np.asarray(getattr(eng, "nonholonomic_rows", ()), dtype=np.intp).reshape(-1)


def _slot_tables(eng: _Engine) -> dict:
    """Per table row, the body of its direction ``a`` and the signed body terms ``(k, u_k, h_k)`` of ``b``.

    Read from the selection matrix ``U``: row ``r`` selects ``a = A_alpha
    a_body``, row ``m_tab + r`` selects ``b = sum_k (h_k R_k + A_k u_k)``
    (``y_b1 - y_b2`` with the signs folded into ``u_k, h_k``). Cached on
    ``eng``.
    """
    cached = getattr(eng, "_linearization_slots", None)
    if cached is not None:
        return cached
    n = eng.n
    m = eng.m_tab
    U = eng.U
    A_blocks = np.any(U[:m, : 4 * n].reshape(m, n, 4) != 0.0, axis=2)  # (m, n)
    a_body = np.where(A_blocks.any(axis=1), np.argmax(A_blocks, axis=1), -1).astype(np.intp)
    B = U[m : 2 * m, : 4 * n].reshape(m, n, 4)
    t_row, t_body = np.nonzero(np.any(B != 0.0, axis=2))
    tables = dict(a_body=a_body, t_row=t_row.astype(np.intp), t_body=t_body.astype(np.intp),
                  t_u=B[t_row, t_body, 0:3].copy(), t_h=B[t_row, t_body, 3].copy())
    eng._linearization_slots = tables
    return tables


def _skew(v: np.ndarray) -> np.ndarray:
    """(k, 3, 3) skew matrices of (k, 3) vectors."""
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return S


def constraint_stiffness(eng: _Engine, ref: Reference) -> np.ndarray:
    """(6n, 6n) ``d(D^T lambda0)/dz`` at the reference, analytic, from the row table (the geometric stiffness).

    Every table row is ``Phi = a . b`` with ``a = A_alpha a_body`` and ``b =
    sum_k (h_k R_k + A_k u_k)``; with ``s_k = A_k u_k`` its generalized force
    is ``h_k a`` on ``R_k``, ``a x b`` on the rotation of ``alpha`` and
    ``s_k x a`` on the rotation of ``k``. Differentiated along ``dR``,
    ``da = theta_alpha x a`` and ``ds_k = theta_k x s_k`` and weighted by the
    row's multiplier (the angle motors' spread on their auxiliary rows),
    the blocks are::

        (R_k, theta_a) = -h_k [a]x      (theta_a, R_k) = h_k [a]x
        (theta_a, theta_a) = [b]x [a]x
        (theta_a, theta_k) = -[a]x [s_k]x   (theta_k, theta_a) = -[s_k]x [a]x
        (theta_k, theta_k) = [a]x [s_k]x

    (``[v]x`` the skew matrix of ``v``); blocks of the ground are dropped.
    """
    return constraint_stiffness_sparse(eng, ref).toarray()


def constraint_stiffness_sparse(eng: _Engine, ref: Reference) -> scipy.sparse.csr_matrix:
    """:func:`constraint_stiffness` as a sparse (6n, 6n) matrix: 3 x 3 blocks of the bodies that share a row."""
    n = eng.n
    blocks: list[tuple] = []
    if not eng.m:
        return scipy.sparse.csr_matrix((6 * n, 6 * n))
    tb = _slot_tables(eng)
    mu = row_multipliers(eng, ref.t, ref.multipliers)
    At = np.array(eng.frames(ref.y, velocities=False))
    U = getattr(eng, "_linearization_U", None)
    Y = (eng.U if U is None else U) @ eng.B[:, 0:3]
    m = eng.m_tab
    a = Y[:m]
    b = Y[m : 2 * m]
    Sa = _skew(a) * mu[:, None, None]
    Sb = _skew(b)

    def add(part_i, bi, part_j, bj, values):  # part 0: R, 1: theta
        blocks.append((part_i * n + bi, part_j * n + bj, values))

    ra = np.flatnonzero((tb["a_body"] >= 0) & (mu != 0.0))
    if ra.size:
        alpha = tb["a_body"][ra]
        add(1, alpha, 1, alpha, np.matmul(Sb[ra], Sa[ra]))
    rows, body = tb["t_row"], tb["t_body"]
    if rows.size:
        live = mu[rows] != 0.0
        rows, body, u, h = rows[live], body[live], tb["t_u"][live], tb["t_h"][live]
        A = np.transpose(At, (0, 2, 1))
        s = np.matmul(A[body], u[:, :, None])[:, :, 0]
        Ss = _skew(s)
        Sak = Sa[rows]
        add(1, body, 1, body, np.matmul(Sak, Ss))
        alpha = tb["a_body"][rows]
        moving = alpha >= 0
        if np.any(moving):
            al, bo = alpha[moving], body[moving]
            Sam, Ssm, hm = Sak[moving], Ss[moving], h[moving]
            add(0, bo, 1, al, -hm[:, None, None] * Sam)
            add(1, al, 0, bo, hm[:, None, None] * Sam)
            add(1, al, 1, bo, -np.matmul(Sam, Ssm))
            add(1, bo, 1, al, -np.matmul(Ssm, Sam))
    if not blocks:
        return scipy.sparse.csr_matrix((6 * n, 6 * n))
    bi = np.concatenate([blk[0] for blk in blocks])
    bj = np.concatenate([blk[1] for blk in blocks])
    vals = np.concatenate([blk[2] for blk in blocks])  # (k, 3, 3)
    k3 = np.arange(3)
    rows = np.broadcast_to((3 * bi[:, None, None] + k3[None, :, None]), vals.shape).ravel()
    cols = np.broadcast_to((3 * bj[:, None, None] + k3[None, None, :]), vals.shape).ravel()
    return scipy.sparse.coo_matrix((vals.ravel(), (rows, cols)), shape=(6 * n, 6 * n)).tocsr()
