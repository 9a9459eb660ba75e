"""Compiled null-space basis of a spanning tree's joints (see ``_linearization.tree_null_space``).

One function over flat arrays, as the kernels of ``_kernel``: per tree
joint the rows over its child body are factorized (Householder QR of
``D_gc^T``, 6 x s), then every body's motion in the tangent coordinates
``z_b = (dR_b, dtheta_b)`` is its parent's carried through the joint plus
the joint's free directions, parents first.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def _joint_rows(Jc, jc_body, A, rows, s, slot, out):
    """``out[j] = `` row ``rows[j]``'s derivative by the body in ``slot``, rotation turned to global small
    rotations (``J_w A^T``), for ``j < s``; zero rows after (and all rows for slot -1: the ground)."""
    for j in range(6):
        for k in range(6):
            out[j, k] = 0.0
    if slot < 0:
        return
    for j in range(s):
        r = rows[j]
        b = jc_body[r, slot]
        for k in range(3):
            out[j, k] = Jc[r, slot, k]
        for i in range(3):
            out[j, 3 + i] = A[b, i, 0] * Jc[r, slot, 3] + A[b, i, 1] * Jc[r, slot, 4] + A[b, i, 2] * Jc[r, slot, 5]


@njit(cache=True, nogil=True, error_model="numpy")
def tree_basis(Jc, jc_body, A, group_rows, group_slot_of, bodies, joint, up, start, free, rank_tol, B3):
    """Fill ``B3`` (n, 6, f), zero on entry, with the tree's basis: ``B_c = T_g B_p + [0 | N_g | 0]``.

    ``Jc`` (m, 3, 6), ``jc_body`` (m, 3): the constraint rows per slot in
    ``(R_dot, omega_body)`` (``_compiled``); ``A`` (n, 3, 3) the bodies'
    rotation matrices; ``group_rows`` (G, 6) the rows of each tree joint
    (padded with -1), ``group_slot_of`` (G, 2) the slot of its child and of
    its parent body (-1: the ground). Bodies in ``bodies`` are taken in that
    order (every parent before its children); per entry ``k``: its tree
    joint ``joint[k]`` (-1: a root, whose six free directions are the unit
    vectors), its parent body ``up[k]`` (-1: the ground or none), its first
    free column ``start[k]`` and its number of free directions ``free[k]``.

    Per joint, ``D_gc^T = Q R`` (Householder): the last ``6 - s`` columns of
    ``Q`` are the free directions and ``T_g = -D_gc^+ D_gp = -Q_1 R^-T
    D_gp``. Returns 0, or 1 when a joint's rows are not of full rank over its
    child body (a pivot ``|R_jj|`` at or below ``rank_tol`` times the
    largest).
    """
    G = group_rows.shape[0]
    Ts = np.zeros((G, 6, 6))
    Qs = np.zeros((G, 6, 6))
    Dc = np.empty((6, 6))
    Dp = np.empty((6, 6))
    M = np.empty((6, 6))
    v = np.empty(6)
    Y = np.empty((6, 6))
    for g in range(G):
        s = 0
        while s < 6 and group_rows[g, s] >= 0:
            s += 1
        if s == 0:
            continue
        _joint_rows(Jc, jc_body, A, group_rows[g], s, group_slot_of[g, 0], Dc)
        _joint_rows(Jc, jc_body, A, group_rows[g], s, group_slot_of[g, 1], Dp)
        for i in range(6):  # M = D_gc^T (6 x s), Q = I
            for j in range(6):
                M[i, j] = Dc[j, i]
                Qs[g, i, j] = 1.0 if i == j else 0.0
        big = 0.0
        small = np.inf
        for j in range(s):  # Householder on column j: M[j:, j] -> (alpha, 0, ...)
            norm = 0.0
            for i in range(j, 6):
                norm += M[i, j] * M[i, j]
            norm = np.sqrt(norm)
            alpha = -norm if M[j, j] >= 0.0 else norm
            for i in range(6):
                v[i] = M[i, j] if i >= j else 0.0
            v[j] -= alpha
            vv = 0.0
            for i in range(j, 6):
                vv += v[i] * v[i]
            if vv > 0.0:
                for c in range(j, s):  # M <- H M
                    d = 0.0
                    for i in range(j, 6):
                        d += v[i] * M[i, c]
                    d *= 2.0 / vv
                    for i in range(j, 6):
                        M[i, c] -= d * v[i]
                for r in range(6):  # Q <- Q H
                    d = 0.0
                    for i in range(j, 6):
                        d += Qs[g, r, i] * v[i]
                    d *= 2.0 / vv
                    for i in range(j, 6):
                        Qs[g, r, i] -= d * v[i]
            a = abs(M[j, j])
            big = max(big, a)
            small = min(small, a)
        if not small > rank_tol * big:
            return 1
        # Y = R^-T D_gp (s x 6): R^T (lower triangular) Y = D_gp, forward substitution
        for c in range(6):
            for j in range(s):
                d = Dp[j, c]
                for i in range(j):
                    d -= M[i, j] * Y[i, c]
                Y[j, c] = d / M[j, j]
        for r in range(6):  # T = -Q_1 Y
            for c in range(6):
                d = 0.0
                for j in range(s):
                    d += Qs[g, r, j] * Y[j, c]
                Ts[g, r, c] = -d
    for k in range(bodies.shape[0]):
        c = bodies[k]
        g = joint[k]
        p = up[k]
        c0 = start[k]
        if p >= 0:  # (only the columns before c0 can be nonzero on the parent)
            for i in range(6):
                for col in range(c0):
                    d = 0.0
                    for j in range(6):
                        d += Ts[g, i, j] * B3[p, j, col]
                    B3[c, i, col] = d
        nf = free[k]
        for a in range(nf):
            for i in range(6):
                B3[c, i, c0 + a] = (1.0 if i == a else 0.0) if g < 0 else Qs[g, i, 6 - nf + a]
    return 0
