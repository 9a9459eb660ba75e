"""Compiled kernels of the multibody engine (numba, ``cache=True``).

Small functions over the flat arrays of :class:`core.multibody._compiled.Compiled`
(no objects, no allocation in the inner loops). Three groups:

* **Rows** (:func:`rows_eval`): every row of the engine's row table has the form
  ``Phi = a . (y_b1 - y_b2)`` (see ``core.multibody._engine``), with ``a`` a
  direction fixed in a body and ``y_b1``, ``y_b2`` points (``h = 1``) or
  directions (``h = 0``) fixed in bodies. Its value, its Jacobian with respect
  to the Newton-Euler velocities ``v = (R_dot, omega_body)`` of the (at most
  three) bodies it touches, its rate and ``gamma`` (the acceleration terms of
  Eq. 8.109's right-hand side) come from the body frames in O(1) per row:

  * ``d/dt (A u) = A (omega_body x u)``, so the body-frame angular part of the
    Jacobian of ``a . b`` is ``u_a x (A_a^T b)`` for ``a`` and ``+-u x (A^T a)``
    for the points of ``b``; the translational part is ``+-h a``;
  * ``gamma = -(a_q . b + 2 a_dot . b_dot + a . b_q)`` with ``_q`` the
    quadratic-velocity parts ``A (omega_body x (omega_body x u))``.

* **Forces** (:func:`applied_forces`): gravity, the gyroscopic torque
  ``-omega_body x (I omega_body)`` (Eq. 8.19 in body axes), spring-dampers,
  torsion springs and the user loads handed in as arrays.

* **Solve** (:func:`tree_factor`, :func:`tree_solve`): the augmented matrix
  ``H = [[M, D^T], [D, 0]]`` of Eq. 8.109 has the sparsity of the graph whose
  nodes are the bodies and the groups of constraint rows (the rows of one joint
  and its motors) and whose edges are the Jacobian blocks ``D_gb``. For a tree
  (forest) of that graph, the block LDL^T factorization in an order that
  eliminates every node before its parent makes no fill-in (Baraff, "Linear-time
  dynamics using Lagrange multipliers", SIGGRAPH 1996): each node's pivot is
  ``H_ii - sum_children H_ic D_c^-1 H_ci``, a 6 x 6 (body, positive definite)
  or r x r (rows, negative definite) block, so the work is O(N). Rows that
  close loops are handled by the caller with a small Schur complement.

Every kernel is compiled with ``nogil=True``: it touches no Python object, so
a simulation running in a background job does not hold the thread that
streams the scene (a compiled DOP853 run of a whole chunk would otherwise
block it for as long as the chunk takes).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# ---------------------------------------------------------------- small algebra


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, nogil=True, error_model="numpy")
def frames(y, n, A):
    """Rotation matrices ``A(p / |p|)`` (Eq. 8.48) of the Euler parameters in ``y[3n:7n]`` into ``A`` (n, 3, 3)."""
    for b in range(n):
        e0 = y[3 * n + 4 * b]
        e1 = y[3 * n + 4 * b + 1]
        e2 = y[3 * n + 4 * b + 2]
        e3 = y[3 * n + 4 * b + 3]
        s = 1.0 / (e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
        A[b, 0, 0] = (e0 * e0 + e1 * e1 - e2 * e2 - e3 * e3) * s
        A[b, 1, 1] = (e0 * e0 - e1 * e1 + e2 * e2 - e3 * e3) * s
        A[b, 2, 2] = (e0 * e0 - e1 * e1 - e2 * e2 + e3 * e3) * s
        A[b, 0, 1] = 2.0 * (e1 * e2 - e0 * e3) * s
        A[b, 1, 0] = 2.0 * (e1 * e2 + e0 * e3) * s
        A[b, 0, 2] = 2.0 * (e1 * e3 + e0 * e2) * s
        A[b, 2, 0] = 2.0 * (e1 * e3 - e0 * e2) * s
        A[b, 1, 2] = 2.0 * (e2 * e3 - e0 * e1) * s
        A[b, 2, 1] = 2.0 * (e2 * e3 + e0 * e1) * s


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _half_g_bar_t(e0, e1, e2, e3, w0, w1, w2):
    """``G_bar(p)^T w / 2`` (Eq. 8.54) of the Euler parameters ``(e0, e1, e2, e3)`` and a body-frame ``w``."""
    return (0.5 * (-e1 * w0 - e2 * w1 - e3 * w2), 0.5 * (e0 * w0 - e3 * w1 + e2 * w2),
            0.5 * (e3 * w0 + e0 * w1 - e1 * w2), 0.5 * (-e2 * w0 + e1 * w1 + e0 * w2))


@njit(cache=True, nogil=True, error_model="numpy")
def parameter_rates(y, n, out, offset):
    """``p_dot = G_bar(p)^T omega_body / 2`` (Eq. 8.54) of every body into ``out[offset:offset + 4n]``."""
    for b in range(n):
        e0 = y[3 * n + 4 * b]
        e1 = y[3 * n + 4 * b + 1]
        e2 = y[3 * n + 4 * b + 2]
        e3 = y[3 * n + 4 * b + 3]
        w0 = y[10 * n + 3 * b]
        w1 = y[10 * n + 3 * b + 1]
        w2 = y[10 * n + 3 * b + 2]
        k = offset + 4 * b
        out[k], out[k + 1], out[k + 2], out[k + 3] = _half_g_bar_t(e0, e1, e2, e3, w0, w1, w2)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _body_vector(A, y, n, b, u0, u1, u2, h, level, out):
    """Position, velocity and quadratic acceleration of the body vector ``(u, h)`` of body ``b`` (-1: ground).

    ``out`` (9,): ``r = h R + A u``, ``r_dot = h R_dot + A (w x u)``, ``r_q = A (w x (w x u))``.
    """
    if b < 0:
        out[0] = u0
        out[1] = u1
        out[2] = u2
        for k in range(3, 9):
            out[k] = 0.0
        return
    for i in range(3):
        out[i] = A[b, i, 0] * u0 + A[b, i, 1] * u1 + A[b, i, 2] * u2 + h * y[3 * b + i]
    if level < 2:
        return
    w0 = y[10 * n + 3 * b]
    w1 = y[10 * n + 3 * b + 1]
    w2 = y[10 * n + 3 * b + 2]
    c0, c1, c2 = _cross(w0, w1, w2, u0, u1, u2)
    q0, q1, q2 = _cross(w0, w1, w2, c0, c1, c2)
    for i in range(3):
        out[3 + i] = A[b, i, 0] * c0 + A[b, i, 1] * c1 + A[b, i, 2] * c2 + h * y[7 * n + 3 * b + i]
        out[6 + i] = A[b, i, 0] * q0 + A[b, i, 1] * q1 + A[b, i, 2] * q2


@njit(cache=True, nogil=True, error_model="numpy")
def rows_eval(y, n, A, level, ra_b, ra_u, r1_b, r1_u, r1_h, r2_b, r2_u, r2_h, slot_a, slot_1, slot_2,
              Phi, J, gam, rate):
    """Value, Jacobian (level >= 1), gamma and rate (level 2) of every table row.

    ``J`` (m, 3, 6): per row, per slot (the distinct moving bodies the row
    touches, see ``slot_*``), the derivative with respect to the body's
    ``(R_dot, omega_body)``. ``gam = -(a_q . b + 2 a_dot . b_dot + a . b_q)``
    and ``rate = a_dot . b + a . b_dot`` (Eq. 8.109's ``gamma`` and ``C_dot``).
    """
    m = Phi.shape[0]
    va = np.empty(9)
    v1 = np.empty(9)
    v2 = np.empty(9)
    for r in range(m):
        ka = ra_b[r]
        k1 = r1_b[r]
        k2 = r2_b[r]
        _body_vector(A, y, n, ka, ra_u[r, 0], ra_u[r, 1], ra_u[r, 2], 0.0, level, va)
        _body_vector(A, y, n, k1, r1_u[r, 0], r1_u[r, 1], r1_u[r, 2], r1_h[r], level, v1)
        _body_vector(A, y, n, k2, r2_u[r, 0], r2_u[r, 1], r2_u[r, 2], r2_h[r], level, v2)
        b0 = v1[0] - v2[0]
        b1 = v1[1] - v2[1]
        b2 = v1[2] - v2[2]
        a0 = va[0]
        a1 = va[1]
        a2 = va[2]
        Phi[r] = a0 * b0 + a1 * b1 + a2 * b2
        if level >= 1:
            for s in range(3):
                for k in range(6):
                    J[r, s, k] = 0.0
            if ka >= 0:  # u_a x (A_a^T b)
                s = slot_a[r]
                t0 = A[ka, 0, 0] * b0 + A[ka, 1, 0] * b1 + A[ka, 2, 0] * b2
                t1 = A[ka, 0, 1] * b0 + A[ka, 1, 1] * b1 + A[ka, 2, 1] * b2
                t2 = A[ka, 0, 2] * b0 + A[ka, 1, 2] * b1 + A[ka, 2, 2] * b2
                c0, c1, c2 = _cross(ra_u[r, 0], ra_u[r, 1], ra_u[r, 2], t0, t1, t2)
                J[r, s, 3] += c0
                J[r, s, 4] += c1
                J[r, s, 5] += c2
            if k1 >= 0:  # + h a, + u_1 x (A_1^T a)
                s = slot_1[r]
                h = r1_h[r]
                J[r, s, 0] += h * a0
                J[r, s, 1] += h * a1
                J[r, s, 2] += h * a2
                t0 = A[k1, 0, 0] * a0 + A[k1, 1, 0] * a1 + A[k1, 2, 0] * a2
                t1 = A[k1, 0, 1] * a0 + A[k1, 1, 1] * a1 + A[k1, 2, 1] * a2
                t2 = A[k1, 0, 2] * a0 + A[k1, 1, 2] * a1 + A[k1, 2, 2] * a2
                c0, c1, c2 = _cross(r1_u[r, 0], r1_u[r, 1], r1_u[r, 2], t0, t1, t2)
                J[r, s, 3] += c0
                J[r, s, 4] += c1
                J[r, s, 5] += c2
            if k2 >= 0:  # - h a, - u_2 x (A_2^T a)
                s = slot_2[r]
                h = r2_h[r]
                J[r, s, 0] -= h * a0
                J[r, s, 1] -= h * a1
                J[r, s, 2] -= h * a2
                t0 = A[k2, 0, 0] * a0 + A[k2, 1, 0] * a1 + A[k2, 2, 0] * a2
                t1 = A[k2, 0, 1] * a0 + A[k2, 1, 1] * a1 + A[k2, 2, 1] * a2
                t2 = A[k2, 0, 2] * a0 + A[k2, 1, 2] * a1 + A[k2, 2, 2] * a2
                c0, c1, c2 = _cross(r2_u[r, 0], r2_u[r, 1], r2_u[r, 2], t0, t1, t2)
                J[r, s, 3] -= c0
                J[r, s, 4] -= c1
                J[r, s, 5] -= c2
        if level >= 2:
            bd0 = v1[3] - v2[3]
            bd1 = v1[4] - v2[4]
            bd2 = v1[5] - v2[5]
            bq0 = v1[6] - v2[6]
            bq1 = v1[7] - v2[7]
            bq2 = v1[8] - v2[8]
            gam[r] = -((va[6] * b0 + va[7] * b1 + va[8] * b2) + 2.0 * (va[3] * bd0 + va[4] * bd1 + va[5] * bd2)
                       + (a0 * bq0 + a1 * bq1 + a2 * bq2))
            rate[r] = (va[3] * b0 + va[4] * b1 + va[5] * b2) + (a0 * bd0 + a1 * bd1 + a2 * bd2)


@njit(cache=True, nogil=True, error_model="numpy")
def constraint_rows(level, m_joint, m_dir, Phi, J, gam, rate, motor_f, aux_motor,
                    C, Jc, Ct, gamma):
    """Constraint rows of the joints and motors (``m_dir + k_angle`` rows) from the table rows.

    Rows ``< m_dir`` are the table's (a displacement motor's row minus its
    driving function, ``C_t = -f_dot``, ``gamma += f_ddot``); angle motor ``k``
    is ``sin(theta - f) = P1 cos f - P2 sin f`` of its pair of table rows
    ``P1 = g_i . f_j = sin(theta)``, ``P2 = f_i . f_j = cos(theta)``.
    ``motor_f`` (k_disp + k_angle, 3): ``(f, f_dot, f_ddot)`` of the
    displacement motors, then of the angle motors.
    """
    for r in range(m_dir):
        C[r] = Phi[r]
        Ct[r] = 0.0
        if level >= 1:
            for s in range(3):
                for k in range(6):
                    Jc[r, s, k] = J[r, s, k]
        if level >= 2:
            gamma[r] = gam[r]
    for q in range(m_dir - m_joint):
        r = m_joint + q
        C[r] -= motor_f[q, 0]
        Ct[r] = -motor_f[q, 1]
        if level >= 2:
            gamma[r] += motor_f[q, 2]
    k_disp = m_dir - m_joint
    for q in range(aux_motor.shape[0]):
        f = motor_f[k_disp + q, 0]
        fd = motor_f[k_disp + q, 1]
        fdd = motor_f[k_disp + q, 2]
        cf = np.cos(f)
        sf = np.sin(f)
        i1 = aux_motor[q, 0]
        i2 = aux_motor[q, 1]
        P1 = Phi[i1]
        P2 = Phi[i2]
        r = m_dir + q
        c = P1 * cf - P2 * sf
        cosd = P2 * cf + P1 * sf
        C[r] = c
        Ct[r] = -fd * cosd
        if level >= 1:
            for s in range(3):
                for k in range(6):
                    Jc[r, s, k] = cf * J[i1, s, k] - sf * J[i2, s, k]
        if level >= 2:
            gamma[r] = ((cf * gam[i1] - sf * gam[i2]) + 2.0 * fd * (sf * rate[i1] + cf * rate[i2])
                        + fdd * cosd + fd * fd * c)


@njit(cache=True, nogil=True, error_model="numpy")
def applied_forces(y, n, A, mass, inertia, gravity, has_gyro,
                   sp_bi, sp_ui, sp_bj, sp_uj, sp_k, sp_c, sp_L0,
                   rs_p1, rs_p2, rs_k, rs_c, rs_0, rs_bi, rs_hi, rs_bj, rs_hj, Phi, rate,
                   uf_b, uf_u, uf_has_u, uf_F, ut_b, ut_T, Q):
    """Generalized applied and quadratic-velocity forces ``Q_e + Q_v`` (6n,), Newton-Euler form.

    Translational part: global forces; rotational part: body-frame torques
    about the centre of mass including ``-omega_body x (I omega_body)``.
    Returns the index of a spring whose points coincide with a positive
    free length (its force direction is undefined), or -1.
    """
    Tg = np.zeros((n, 3))  # global torques, turned into body axes at the end
    for b in range(n):
        for i in range(3):
            Q[3 * b + i] = mass[b] * gravity[i]
            Q[3 * n + 3 * b + i] = 0.0
        if has_gyro:
            w0 = y[10 * n + 3 * b]
            w1 = y[10 * n + 3 * b + 1]
            w2 = y[10 * n + 3 * b + 2]
            I = inertia[b]
            L0 = I[0, 0] * w0 + I[0, 1] * w1 + I[0, 2] * w2
            L1 = I[1, 0] * w0 + I[1, 1] * w1 + I[1, 2] * w2
            L2 = I[2, 0] * w0 + I[2, 1] * w1 + I[2, 2] * w2
            c0, c1, c2 = _cross(w0, w1, w2, L0, L1, L2)
            Q[3 * n + 3 * b] -= c0
            Q[3 * n + 3 * b + 1] -= c1
            Q[3 * n + 3 * b + 2] -= c2
    bad = -1
    pi = np.empty(9)
    pj = np.empty(9)
    for k in range(sp_k.shape[0]):
        bi = sp_bi[k]
        bj = sp_bj[k]
        _body_vector(A, y, n, bi, sp_ui[k, 0], sp_ui[k, 1], sp_ui[k, 2], 1.0, 2, pi)
        _body_vector(A, y, n, bj, sp_uj[k, 0], sp_uj[k, 1], sp_uj[k, 2], 1.0, 2, pj)
        if bi < 0:  # a ground point does not move
            for i in range(3, 9):
                pi[i] = 0.0
        if bj < 0:
            for i in range(3, 9):
                pj[i] = 0.0
        d0 = pj[0] - pi[0]
        d1 = pj[1] - pi[1]
        d2 = pj[2] - pi[2]
        dd0 = pj[3] - pi[3]
        dd1 = pj[4] - pi[4]
        dd2 = pj[5] - pi[5]
        L = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if sp_L0[k] == 0.0:  # zero free length: the linear force -k d - c d_dot
            F0 = -sp_k[k] * d0 - sp_c[k] * dd0
            F1 = -sp_k[k] * d1 - sp_c[k] * dd1
            F2 = -sp_k[k] * d2 - sp_c[k] * dd2
        else:
            if L <= 1e-12 * sp_L0[k]:
                if bad < 0:
                    bad = k
                continue
            e0 = d0 / L
            e1 = d1 / L
            e2 = d2 / L
            Ld = e0 * dd0 + e1 * dd1 + e2 * dd2
            mag = sp_k[k] * (L - sp_L0[k]) + sp_c[k] * Ld
            F0 = -mag * e0
            F1 = -mag * e1
            F2 = -mag * e2
        # F on the j point, -F on the i point; torques about the centres of mass (global arms A u)
        if bj >= 0:
            Q[3 * bj] += F0
            Q[3 * bj + 1] += F1
            Q[3 * bj + 2] += F2
            ar0 = pj[0] - y[3 * bj]
            ar1 = pj[1] - y[3 * bj + 1]
            ar2 = pj[2] - y[3 * bj + 2]
            c0, c1, c2 = _cross(ar0, ar1, ar2, F0, F1, F2)
            Tg[bj, 0] += c0
            Tg[bj, 1] += c1
            Tg[bj, 2] += c2
        if bi >= 0:
            Q[3 * bi] -= F0
            Q[3 * bi + 1] -= F1
            Q[3 * bi + 2] -= F2
            ar0 = pi[0] - y[3 * bi]
            ar1 = pi[1] - y[3 * bi + 1]
            ar2 = pi[2] - y[3 * bi + 2]
            c0, c1, c2 = _cross(ar0, ar1, ar2, F0, F1, F2)
            Tg[bi, 0] -= c0
            Tg[bi, 1] -= c1
            Tg[bi, 2] -= c2
    for k in range(rs_k.shape[0]):  # torsion springs: theta = atan2(g_i . f_j, f_i . f_j) about angle0
        P1 = Phi[rs_p1[k]]
        P2 = Phi[rs_p2[k]]
        c0 = np.cos(rs_0[k])
        s0 = np.sin(rs_0[k])
        theta = rs_0[k] + np.arctan2(P1 * c0 - P2 * s0, P2 * c0 + P1 * s0)
        theta_dot = (rate[rs_p1[k]] * P2 - rate[rs_p2[k]] * P1) / (P1 * P1 + P2 * P2)
        tau = -rs_k[k] * (theta - rs_0[k]) - rs_c[k] * theta_dot
        bj = rs_bj[k]
        bi = rs_bi[k]
        if bj >= 0:
            for i in range(3):
                Q[3 * n + 3 * bj + i] += tau * rs_hj[k, i]
        if bi >= 0:
            for i in range(3):
                Q[3 * n + 3 * bi + i] -= tau * rs_hi[k, i]
    for k in range(uf_b.shape[0]):  # user forces (global), at a body point or the centre of mass
        b = uf_b[k]
        for i in range(3):
            Q[3 * b + i] += uf_F[k, i]
        if uf_has_u[k]:
            u0 = uf_u[k, 0]
            u1 = uf_u[k, 1]
            u2 = uf_u[k, 2]
            ar0 = A[b, 0, 0] * u0 + A[b, 0, 1] * u1 + A[b, 0, 2] * u2
            ar1 = A[b, 1, 0] * u0 + A[b, 1, 1] * u1 + A[b, 1, 2] * u2
            ar2 = A[b, 2, 0] * u0 + A[b, 2, 1] * u1 + A[b, 2, 2] * u2
            c0, c1, c2 = _cross(ar0, ar1, ar2, uf_F[k, 0], uf_F[k, 1], uf_F[k, 2])
            Tg[b, 0] += c0
            Tg[b, 1] += c1
            Tg[b, 2] += c2
    for k in range(ut_b.shape[0]):  # user torques (global)
        b = ut_b[k]
        for i in range(3):
            Tg[b, i] += ut_T[k, i]
    for b in range(n):
        for i in range(3):
            Q[3 * n + 3 * b + i] += A[b, 0, i] * Tg[b, 0] + A[b, 1, i] * Tg[b, 1] + A[b, 2, i] * Tg[b, 2]
    return bad


# ---------------------------------------------------------------- tree solve (Baraff 1996)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _chol(P, s, L):
    """Cholesky ``P = L L^T`` of the leading s x s block of ``P`` into ``L``, the diagonal stored as its
    reciprocals (the solves multiply); False if not positive definite."""
    for j in range(s):
        d = P[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        d = 1.0 / np.sqrt(d)
        L[j, j] = d  # (the diagonal holds the reciprocals)
        for i in range(j + 1, s):
            x = P[i, j]
            for k in range(j):
                x -= L[i, k] * L[j, k]
            L[i, j] = x * d
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _forward(L, s, x):
    """x <- L^-1 x (leading s entries), L lower triangular (reciprocal diagonal, see _chol)."""
    for i in range(s):
        v = x[i]
        for k in range(i):
            v -= L[i, k] * x[k]
        x[i] = v * L[i, i]


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _backward(L, s, x):
    """x <- L^-T x (leading s entries)."""
    for i in range(s - 1, -1, -1):
        v = x[i]
        for k in range(i + 1, s):
            v -= L[k, i] * x[k]
        x[i] = v * L[i, i]


@njit(cache=True, nogil=True, error_model="numpy")
def tree_factor(order_size, order_parent, node_kind, node_ref, Mblocks, Jc, group_rows, group_slot_of,
                Xp, Lfac, sign, work):
    """Block LDL^T of ``H = [[W, D^T], [D, 0]]`` over the tree, children before parents (Baraff 1996).

    Nodes are in elimination order ``0 .. N-1``; ``order_parent[i]`` is the
    parent node (> i) or -1. A body node (``node_kind`` 0, ``node_ref`` the
    body) has the diagonal block ``Mblocks[body]`` (6 x 6); a group node
    (kind 1, ``node_ref`` the group) the zero block of its rows
    ``group_rows[g, :size]``. ``group_slot_of[g, 0/1]`` is the slot of the
    group's rows (in ``Jc``) that holds the group's child / parent body.

    The pivot of node i is ``D_i = H_ii - sum_children H_ic D_c^-1 H_ci``:
    positive definite for a body, negative definite for a group (its rows
    independent over its child body). Stored: ``sign_i`` and the Cholesky
    factor ``L_i`` of ``sign_i D_i`` (``Lfac[i]``), and ``X_i = L_i^-1
    H[i, parent]`` (``Xp[i]``), so that the parent's update is ``D_p -=
    sign_i X_i^T X_i``. Returns -1, or the node whose pivot is not definite.
    """
    N = order_size.shape[0]
    for i in range(N):
        D = work[i]
        if node_kind[i] == 0:
            body = node_ref[i]
            for a in range(6):
                for b in range(6):
                    D[a, b] = Mblocks[body, a, b]
        else:
            for a in range(6):
                for b in range(6):
                    D[a, b] = 0.0
    for i in range(N):
        s = order_size[i]
        D = work[i]
        L = Lfac[i]
        sg = 1.0 if node_kind[i] == 0 else -1.0
        sign[i] = sg
        if sg < 0.0:
            for a in range(s):
                for b in range(s):
                    D[a, b] = -D[a, b]
        if not _chol(D, s, L):
            return i
        p = order_parent[i]
        if p < 0:
            continue
        sp_ = order_size[p]
        X = Xp[i]
        # H[i, p]: body i -> group p: D_gb^T (6 x r); group i -> body p: D_gb (r x 6)
        if node_kind[i] == 0:
            g = node_ref[p]
            sl = group_slot_of[g, 0]
            for k in range(sp_):
                r = group_rows[g, k]
                for a in range(6):
                    X[a, k] = Jc[r, sl, a]
        else:
            g = node_ref[i]
            sl = group_slot_of[g, 1]
            for k in range(s):
                r = group_rows[g, k]
                for a in range(6):
                    X[k, a] = Jc[r, sl, a]
        for c in range(sp_):  # X <- L^-1 X, column by column
            for a in range(s):
                v = X[a, c]
                for k in range(a):
                    v -= L[a, k] * X[k, c]
                X[a, c] = v * L[a, a]
        Dp = work[p]
        for c in range(sp_):
            for d in range(c + 1):
                v = 0.0
                for a in range(s):
                    v += X[a, d] * X[a, c]
                v *= sg
                Dp[d, c] -= v
                if d != c:
                    Dp[c, d] -= v
    return -1


@njit(cache=True, nogil=True, error_model="numpy")
def tree_solve(order_size, order_parent, Xp, Lfac, sign, x):
    """Solve ``H z = x`` in place, ``x`` (N, 6) by node (leading size entries), with the factor of :func:`tree_factor`."""
    N = order_size.shape[0]
    # forward: x_i <- L_i^-1 x_i, then x_p -= sign_i X_i^T x_i (children first)
    for i in range(N):
        s = order_size[i]
        xi = x[i]
        _forward(Lfac[i], s, xi)
        p = order_parent[i]
        if p < 0:
            continue
        X = Xp[i]
        sg = sign[i]
        for d in range(order_size[p]):
            v = 0.0
            for a in range(s):
                v += X[a, d] * xi[a]
            x[p, d] -= sg * v
    # backward (parents first): z_i = sign_i L_i^-T (x_i - X_i z_p)
    for i in range(N - 1, -1, -1):
        s = order_size[i]
        xi = x[i]
        p = order_parent[i]
        if p >= 0:
            X = Xp[i]
            zp = x[p]
            for a in range(s):
                v = 0.0
                for d in range(order_size[p]):
                    v += X[a, d] * zp[d]
                xi[a] -= v
        _backward(Lfac[i], s, xi)
        if sign[i] < 0.0:
            for a in range(s):
                xi[a] = -xi[a]


@njit(cache=True, nogil=True, error_model="numpy")
def augmented_solve(n, order_size, order_parent, node_kind, node_ref, body_node, group_rows, group_slot_of,
                    sec_rows, jc_body, Wblocks, Jc, rhs_v, rhs_c, x_v, lam, Hp, Lfac, sign, work, X, Z):
    """Solve ``[[W, D^T], [D, 0]] [x; lam] = [rhs_v; rhs_c]`` (Eq. 8.109 with ``W = M``) in O(N + k^2 N).

    The rows of the tree's groups are eliminated by :func:`tree_factor`;
    the ``k`` secondary rows ``sec_rows`` (loop closures) by the Schur
    complement ``S = E H^-1 E^T`` (k x k, positive definite for independent
    rows), ``S mu = E H^-1 b - c``. ``lam`` gets the multipliers of the
    tree's and the secondary rows (others are left as they are). Returns 0,
    1 (a pivot of the tree is not definite) or 2 (S is not).
    """
    if tree_factor(order_size, order_parent, node_kind, node_ref, Wblocks, Jc, group_rows, group_slot_of,
                   Hp, Lfac, sign, work) >= 0:
        return 1
    N = order_size.shape[0]
    for i in range(N):
        if node_kind[i] == 0:
            b = node_ref[i]
            for k in range(3):
                X[i, k] = rhs_v[3 * b + k]
                X[i, 3 + k] = rhs_v[3 * n + 3 * b + k]
        else:
            g = node_ref[i]
            for k in range(order_size[i]):
                X[i, k] = rhs_c[group_rows[g, k]]
    tree_solve(order_size, order_parent, Hp, Lfac, sign, X)
    ns = sec_rows.shape[0]
    if ns:
        for j in range(ns):
            Zj = Z[j]
            for i in range(N):
                for k in range(6):
                    Zj[i, k] = 0.0
            r = sec_rows[j]
            for s in range(3):
                b = jc_body[r, s]
                if b >= 0:
                    for k in range(6):
                        Zj[body_node[b], k] += Jc[r, s, k]
            tree_solve(order_size, order_parent, Hp, Lfac, sign, Zj)
        S = np.zeros((ns, ns))
        rs = np.zeros(ns)
        for l in range(ns):
            r = sec_rows[l]
            for s in range(3):
                b = jc_body[r, s]
                if b >= 0:
                    i = body_node[b]
                    for k in range(6):
                        rs[l] += Jc[r, s, k] * X[i, k]
                        for j in range(ns):
                            S[l, j] += Jc[r, s, k] * Z[j, i, k]
            rs[l] -= rhs_c[r]
        for l in range(ns):  # symmetrize the round-off
            for j in range(l):
                v = 0.5 * (S[l, j] + S[j, l])
                S[l, j] = v
                S[j, l] = v
        Ls = np.zeros((ns, ns))
        if not _chol(S, ns, Ls):
            return 2
        _forward(Ls, ns, rs)
        _backward(Ls, ns, rs)
        for j in range(ns):
            mu = rs[j]
            lam[sec_rows[j]] = mu
            for i in range(N):
                for k in range(order_size[i]):
                    X[i, k] -= mu * Z[j, i, k]
    for i in range(N):
        if node_kind[i] == 0:
            b = node_ref[i]
            for k in range(3):
                x_v[3 * b + k] = X[i, k]
                x_v[3 * n + 3 * b + k] = X[i, 3 + k]
        else:
            g = node_ref[i]
            for k in range(order_size[i]):
                lam[group_rows[g, k]] = X[i, k]
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def jacobian_apply(n, Jc, jc_body, v, Ct, out):
    """``out = D v + C_t`` (m,) from the constraint rows' slots: the constraint velocities (Eq. 8.109's ``C_dot``)."""
    for r in range(Jc.shape[0]):
        acc = Ct[r]
        for s in range(3):
            b = jc_body[r, s]
            if b >= 0:
                for k in range(3):
                    acc += Jc[r, s, k] * v[3 * b + k] + Jc[r, s, 3 + k] * v[3 * n + 3 * b + k]
        out[r] = acc


@njit(cache=True, nogil=True, error_model="numpy")
def retract(y, n, dq):
    """``R -= dR``, ``p <- (p - G_bar^T dpi_body / 2) / |.|`` (first-order retraction of a projection step)."""
    for b in range(n):
        for k in range(3):
            y[3 * b + k] -= dq[3 * b + k]
        e0 = y[3 * n + 4 * b]
        e1 = y[3 * n + 4 * b + 1]
        e2 = y[3 * n + 4 * b + 2]
        e3 = y[3 * n + 4 * b + 3]
        w0 = dq[3 * n + 3 * b]
        w1 = dq[3 * n + 3 * b + 1]
        w2 = dq[3 * n + 3 * b + 2]
        d0, d1, d2, d3 = _half_g_bar_t(e0, e1, e2, e3, w0, w1, w2)
        f0 = e0 - d0
        f1 = e1 - d1
        f2 = e2 - d2
        f3 = e3 - d3
        s = 1.0 / np.sqrt(f0 * f0 + f1 * f1 + f2 * f2 + f3 * f3)
        y[3 * n + 4 * b] = f0 * s
        y[3 * n + 4 * b + 1] = f1 * s
        y[3 * n + 4 * b + 2] = f2 * s
        y[3 * n + 4 * b + 3] = f3 * s


# ---------------------------------------------------------------- packed model (one call per right-hand side)
#
# A compiled System is four flat arrays, as MuJoCo's mjModel / mjData: ``I``
# (int64: sizes, then the headers of the int and float fields, then the int
# data), ``F`` (float64 data), per selection of rows ``TI`` (int64: the
# headers of the tree's and the work array's fields, then the tree's data)
# and the work array ``W`` (float64). A header entry is ``(offset, d0, d1,
# d2)``. One call into the kernel then takes a handful of arguments whatever
# the model (numba's dispatch costs about 0.2-0.4 us per argument).

I_FIELDS = ("ra_b", "r1_b", "r2_b", "slot_a", "slot_1", "slot_2", "aux_motor", "jc_body", "sp_bi", "sp_bj",
            "rs_p1", "rs_p2", "rs_bi", "rs_bj", "uf_b", "uf_has_u", "ut_b")
F_FIELDS = ("ra_u", "r1_u", "r1_h", "r2_u", "r2_h", "mass", "inertia", "gravity", "Mblocks", "Wblocks", "sp_ui",
            "sp_uj", "sp_k", "sp_c", "sp_L0", "rs_k", "rs_c", "rs_0", "rs_hi", "rs_hj", "uf_u")
T_FIELDS = ("order_size", "order_parent", "node_kind", "node_ref", "body_node", "group_rows", "group_slot_of",
            "sec_rows")
W_FIELDS = ("A", "Phi", "J", "gam", "rate", "C", "Jc", "Ct", "gamma", "Q", "motor_f", "uf_F", "ut_T", "Xp", "Lfac",
            "sign", "work", "X", "Z", "cv", "dq", "lam", "rhs_c", "zero6", "res")
N_SCALARS = 8  # I[0:6] = n, m_tab, m, m_joint, m_dir, has_gyro; I[6:8] spare
IH = N_SCALARS
FH = IH + 4 * len(I_FIELDS)
TH = 0
WH = 4 * len(T_FIELDS)


@njit(cache=True, nogil=True, error_model="numpy")
def _v1(P, H, base, k):
    o = H[base + 4 * k]
    return P[o : o + H[base + 4 * k + 1]]


@njit(cache=True, nogil=True, error_model="numpy")
def _v2(P, H, base, k):
    o = H[base + 4 * k]
    d0 = H[base + 4 * k + 1]
    d1 = H[base + 4 * k + 2]
    return P[o : o + d0 * d1].reshape((d0, d1))


@njit(cache=True, nogil=True, error_model="numpy")
def _v3(P, H, base, k):
    o = H[base + 4 * k]
    d0 = H[base + 4 * k + 1]
    d1 = H[base + 4 * k + 2]
    d2 = H[base + 4 * k + 3]
    return P[o : o + d0 * d1 * d2].reshape((d0, d1, d2))


@njit(cache=True, nogil=True, error_model="numpy")
def evaluate_packed(I, F, TI, W, y, level):
    """Frames, table rows and constraint rows (joints and motors) at ``y`` into ``W`` (motor values read
    from ``W``'s ``motor_f``, filled by the caller)."""
    n = I[0]
    A = _v3(W, TI, WH, 0)
    frames(y, n, A)
    Phi = _v1(W, TI, WH, 1)
    J = _v3(W, TI, WH, 2)
    gam = _v1(W, TI, WH, 3)
    rate = _v1(W, TI, WH, 4)
    rows_eval(y, n, A, level, _v1(I, I, IH, 0), _v2(F, I, FH, 0), _v1(I, I, IH, 1), _v2(F, I, FH, 1),
              _v1(F, I, FH, 2), _v1(I, I, IH, 2), _v2(F, I, FH, 3), _v1(F, I, FH, 4), _v1(I, I, IH, 3),
              _v1(I, I, IH, 4), _v1(I, I, IH, 5), Phi, J, gam, rate)
    constraint_rows(level, I[3], I[4], Phi, J, gam, rate, _v2(W, TI, WH, 10), _v2(I, I, IH, 6),
                    _v1(W, TI, WH, 5), _v3(W, TI, WH, 6), _v1(W, TI, WH, 7), _v1(W, TI, WH, 8))


@njit(cache=True, nogil=True, error_model="numpy")
def applied_packed(I, F, TI, W, y):
    """``Q_e + Q_v`` into ``W``'s ``Q`` (after a level-2 :func:`evaluate_packed`); a coincident spring or -1."""
    n = I[0]
    return applied_forces(y, n, _v3(W, TI, WH, 0), _v1(F, I, FH, 5), _v3(F, I, FH, 6), _v1(F, I, FH, 7),
                          I[5] != 0, _v1(I, I, IH, 8), _v2(F, I, FH, 10), _v1(I, I, IH, 9), _v2(F, I, FH, 11),
                          _v1(F, I, FH, 12), _v1(F, I, FH, 13), _v1(F, I, FH, 14), _v1(I, I, IH, 10),
                          _v1(I, I, IH, 11), _v1(F, I, FH, 15), _v1(F, I, FH, 16), _v1(F, I, FH, 17),
                          _v1(I, I, IH, 12), _v2(F, I, FH, 18), _v1(I, I, IH, 13), _v2(F, I, FH, 19),
                          _v1(W, TI, WH, 1), _v1(W, TI, WH, 4), _v1(I, I, IH, 14), _v2(F, I, FH, 20),
                          _v1(I, I, IH, 15), _v2(W, TI, WH, 11), _v1(I, I, IH, 16), _v2(W, TI, WH, 12),
                          _v1(W, TI, WH, 9))


@njit(cache=True, nogil=True, error_model="numpy")
def solve_packed(I, F, TI, W, metric, rhs_v, rhs_c, x_v):
    """:func:`augmented_solve` with the mass blocks (``metric`` 0) or the projection metric (1); the
    multipliers into ``W``'s ``lam``."""
    n = I[0]
    blocks = _v3(F, I, FH, 8) if metric == 0 else _v3(F, I, FH, 9)
    return augmented_solve(n, _v1(TI, TI, TH, 0), _v1(TI, TI, TH, 1), _v1(TI, TI, TH, 2), _v1(TI, TI, TH, 3),
                           _v1(TI, TI, TH, 4), _v2(TI, TI, TH, 5), _v2(TI, TI, TH, 6), _v1(TI, TI, TH, 7),
                           _v2(I, I, IH, 7), blocks, _v3(W, TI, WH, 6), rhs_v, rhs_c, x_v, _v1(W, TI, WH, 21),
                           _v3(W, TI, WH, 13), _v3(W, TI, WH, 14), _v1(W, TI, WH, 15), _v3(W, TI, WH, 16),
                           _v2(W, TI, WH, 17), _v3(W, TI, WH, 18))


@njit(cache=True, nogil=True, error_model="numpy")
def rhs_packed(I, F, TI, W, y, ydot, alpha):
    """``y_dot = [R_dot, p_dot, a]`` (Eqs. 8.51-8.54, 8.109) in one call; the user's loads and the motor
    values are in ``W`` already. Returns 0, 1 or 2 (see :func:`augmented_solve`) or ``3 + k`` for spring
    ``k`` whose points coincide."""
    n = I[0]
    evaluate_packed(I, F, TI, W, y, 2)
    bad = applied_packed(I, F, TI, W, y)
    if bad >= 0:
        return 3 + bad
    gamma = _v1(W, TI, WH, 8)
    if alpha != 0.0:  # Baumgarte: gamma - 2 alpha C_dot - alpha^2 C
        cv = _v1(W, TI, WH, 19)
        C = _v1(W, TI, WH, 5)
        jacobian_apply(n, _v3(W, TI, WH, 6), _v2(I, I, IH, 7), y[7 * n :], _v1(W, TI, WH, 7), cv)
        for r in range(gamma.shape[0]):
            gamma[r] = gamma[r] - 2.0 * alpha * cv[r] - alpha * alpha * C[r]
    lam = _v1(W, TI, WH, 21)
    for r in range(lam.shape[0]):
        lam[r] = 0.0
    st = solve_packed(I, F, TI, W, 0, _v1(W, TI, WH, 9), gamma, ydot[7 * n :])
    if st:
        return st
    for k in range(3 * n):
        ydot[k] = y[7 * n + k]
    parameter_rates(y, n, ydot, 3 * n)
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def _max_abs_kept(x, TI):
    """max |x_r| over the rows the tree solves (its groups' and the secondary rows)."""
    group_rows = _v2(TI, TI, TH, 5)
    node_kind = _v1(TI, TI, TH, 2)
    node_ref = _v1(TI, TI, TH, 3)
    order_size = _v1(TI, TI, TH, 0)
    sec = _v1(TI, TI, TH, 7)
    res = 0.0
    for i in range(node_kind.shape[0]):
        if node_kind[i] == 1:
            g = node_ref[i]
            for k in range(order_size[i]):
                v = abs(x[group_rows[g, k]])
                if not v <= res:
                    res = v
    for j in range(sec.shape[0]):
        v = abs(x[sec[j]])
        if not v <= res:
            res = v
    return res


@njit(cache=True, nogil=True, error_model="numpy")
def project_packed(I, F, TI, W, y, tol):
    """Newton projection of positions onto ``C = 0``, then of velocities onto ``D v + C_t = 0`` (in place).

    Both least-change in the metric W: each Newton step solves
    ``[[W, D^T], [D, 0]] [dq; -mu] = [0; C]`` and retracts ``R -= dR``,
    ``p <- (p - G_bar^T dpi / 2) / |.|``, until ``max |C| <= tol`` (or at the
    round-off floor); the velocities take up to four corrections, until the
    residual is below round-off. Returns ``(status, position residual,
    velocity residual)``: status 0, 1 or 2 (a pivot, see
    :func:`augmented_solve`), 4 (not converged: the residual is returned)
    or 5 (not finite). The motor values at the projection's time are in
    ``W`` already.
    """
    n = I[0]
    # normalize the Euler parameters first
    for b in range(n):
        s = 0.0
        for k in range(4):
            s += y[3 * n + 4 * b + k] ** 2
        s = 1.0 / np.sqrt(s)
        for k in range(4):
            y[3 * n + 4 * b + k] *= s
    C = _v1(W, TI, WH, 5)
    Jc = _v3(W, TI, WH, 6)
    Ct = _v1(W, TI, WH, 7)
    jc_body = _v2(I, I, IH, 7)
    dq = _v1(W, TI, WH, 20)
    zero6 = _v1(W, TI, WH, 23)
    cv = _v1(W, TI, WH, 19)
    prev = np.inf
    res = 0.0
    for it in range(10):
        evaluate_packed(I, F, TI, W, y, 1)
        res = _max_abs_kept(C, TI)
        if res <= tol or (it > 0 and res <= 1e-8 and res > 0.25 * prev):
            break
        if not np.isfinite(res):
            return 5, res, 0.0
        if it == 9:
            return 4, res, 0.0
        st = solve_packed(I, F, TI, W, 1, zero6, C, dq)
        if st:
            return st, res, 0.0
        retract(y, n, dq)
        prev = res
    v = y[7 * n :]
    vmax = 0.0
    for k in range(v.shape[0]):
        vmax = max(vmax, abs(v[k]))
    jmax = 0.0
    for r in range(Jc.shape[0]):
        for s in range(3):
            for k in range(6):
                jmax = max(jmax, abs(Jc[r, s, k]))
    floor = 4e-16 * (1.0 + vmax) * max(1.0, jmax)
    rv = 0.0
    for _ in range(4):
        jacobian_apply(n, Jc, jc_body, v, Ct, cv)
        rv = _max_abs_kept(cv, TI)
        if rv <= floor:
            break
        st = solve_packed(I, F, TI, W, 1, zero6, cv, dq)
        if st:
            return st, res, rv
        for k in range(v.shape[0]):
            v[k] -= dq[k]
    jacobian_apply(n, Jc, jc_body, v, Ct, cv)
    rv = 0.0
    for r in range(cv.shape[0]):
        rv = max(rv, abs(cv[r]))
    return 0, res, rv


# ---------------------------------------------------------------- the step loop (DOP853 with projection)
#
# The loop of ``core.integrators._run_adaptive_projected`` with scipy's DOP853
# (``scipy.integrate._ivp.rk``: the same coefficients, passed in from scipy,
# the same initial step, error norm, step control and dense output), the
# projection after every accepted step and the outputs, all compiled: one
# call runs a whole span. Anything unusual (a pivot that is not definite, a
# projection that does not converge, a non-finite value, a step that shrank
# to nothing) returns LOOP_FALLBACK, and the caller runs the span again on
# the interpreted path, which diagnoses it; a used-up budget returns
# LOOP_BUDGET with the outputs so far.
LOOP_DONE = 0
LOOP_FALLBACK = 1
LOOP_BUDGET = 2
_SAFETY = 0.9
_MIN_FACTOR = 0.2
_MAX_FACTOR = 10.0
_STALE_DERIVATIVE_TOL = 1e-3


@njit(cache=True, nogil=True, error_model="numpy")
def _rms(x, scale):
    s = 0.0
    for i in range(x.shape[0]):
        v = x[i] / scale[i]
        s += v * v
    return np.sqrt(s) / np.sqrt(x.shape[0])


@njit(cache=True, nogil=True, error_model="numpy")
def _stage_sum(K, a, s, h, y, out):
    """``out = y + (K[:s].T @ a[:s]) * h``."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += K[j, i] * a[j]
        out[i] = y[i] + acc * h


@njit(cache=True, nogil=True, error_model="numpy")
def dop853_projected(I, F, TI, W, y, f, carry, t1, t_out, k_out, rtol, atol, position_tol, n_rhs, max_rhs, stalled,
                     A, B, E3, E5, D, out_y, out_res):
    """Run DOP853 with projection from ``(carry[0], y)`` towards ``t1``; the states at ``t_out[k_out:]``
    (ascending, after the start) into ``out_y`` and their position and velocity residuals into ``out_res``.

    ``carry = (t, h_abs, t_prev)``: the run's time, next step size (0: a new run, which evaluates ``f`` and
    picks the first step as scipy does) and the end of the step before; with ``y`` and ``f`` (the state and
    its derivative) they are updated in place, so a run stopped at its budget (``n_rhs + 16 > max_rhs``
    before a step) goes on from there when called again. Returns ``(status, k_out, accepted steps,
    n_rhs)``.
    """
    ny = y.shape[0]
    n_stages = 12
    K = np.zeros((16, ny))
    ytmp = np.empty(ny)
    y_new = np.empty(ny)
    scale = np.empty(ny)
    Fd = np.empty((7, ny))
    n_steps = 0
    n_out = t_out.shape[0]
    t = carry[0]
    h_abs = carry[1]
    t_prev = carry[2]
    if h_abs <= 0.0:
        if n_rhs + 2 > max_rhs:
            return LOOP_BUDGET, k_out, n_steps, n_rhs
        if rhs_packed(I, F, TI, W, y, f, 0.0) != 0:
            return LOOP_FALLBACK, k_out, n_steps, n_rhs
        n_rhs += 1
        for i in range(ny):
            if not np.isfinite(f[i]):
                return LOOP_FALLBACK, k_out, n_steps, n_rhs
        # initial step (scipy.integrate._ivp.common.select_initial_step, error estimator order 7)
        interval = abs(t1 - t)
        for i in range(ny):
            scale[i] = atol + abs(y[i]) * rtol
        d0 = _rms(y, scale)
        d1 = _rms(f, scale)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, interval)
        for i in range(ny):
            ytmp[i] = y[i] + h0 * f[i]
        if rhs_packed(I, F, TI, W, ytmp, K[1], 0.0) != 0:
            return LOOP_FALLBACK, k_out, n_steps, n_rhs
        n_rhs += 1
        for i in range(ny):
            ytmp[i] = K[1, i] - f[i]
        d2 = _rms(ytmp, scale) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
        h_abs = min(100.0 * h0, h1, interval)
        carry[1] = h_abs
    while t < t1:
        if n_rhs + 16 > max_rhs:  # (a step takes at most 16 right-hand sides)
            return LOOP_BUDGET, k_out, n_steps, n_rhs
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        rejected = False
        while True:
            if h_abs < min_step:
                return LOOP_FALLBACK, k_out, n_steps, n_rhs
            t_new = t + h_abs
            if t_new - t1 > 0.0:
                t_new = t1
            h = t_new - t
            h_abs = abs(h)
            for i in range(ny):
                K[0, i] = f[i]
            for s in range(1, n_stages):
                _stage_sum(K, A[s], s, h, y, ytmp)
                if rhs_packed(I, F, TI, W, ytmp, K[s], 0.0) != 0:
                    return LOOP_FALLBACK, k_out, n_steps, n_rhs
                n_rhs += 1
            for i in range(ny):
                acc = 0.0
                for j in range(n_stages):
                    acc += K[j, i] * B[j]
                y_new[i] = y[i] + h * acc
            if rhs_packed(I, F, TI, W, y_new, K[n_stages], 0.0) != 0:
                return LOOP_FALLBACK, k_out, n_steps, n_rhs
            n_rhs += 1
            # error norm (DOP853._estimate_error_norm)
            e5 = 0.0
            e3 = 0.0
            for i in range(ny):
                sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                a5 = 0.0
                a3 = 0.0
                for j in range(n_stages + 1):
                    a5 += K[j, i] * E5[j]
                    a3 += K[j, i] * E3[j]
                a5 /= sc
                a3 /= sc
                e5 += a5 * a5
                e3 += a3 * a3
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = h_abs * e5 / np.sqrt((e5 + 0.01 * e3) * ny)
            if not np.isfinite(err):  # a stage that is not finite: diagnosed on the interpreted path
                return LOOP_FALLBACK, k_out, n_steps, n_rhs
            if err < 1.0:
                if err == 0.0:
                    factor = _MAX_FACTOR
                else:
                    factor = min(_MAX_FACTOR, _SAFETY * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            h_abs *= max(_MIN_FACTOR, _SAFETY * err ** (-1.0 / 8.0))
            rejected = True
            if n_rhs + 16 > max_rhs:
                carry[1] = h_abs
                return LOOP_BUDGET, k_out, n_steps, n_rhs
        n_steps += 1
        # dense output of the unprojected step, when an output falls inside it
        if k_out < n_out and t_out[k_out] < t_new:
            for s in range(n_stages + 1, 16):
                _stage_sum(K, A[s], s, h, y, ytmp)
                if rhs_packed(I, F, TI, W, ytmp, K[s], 0.0) != 0:
                    return LOOP_FALLBACK, k_out, n_steps, n_rhs
                n_rhs += 1
            for i in range(ny):
                dy = y_new[i] - y[i]
                Fd[0, i] = dy
                Fd[1, i] = h * K[0, i] - dy
                Fd[2, i] = 2.0 * dy - h * (K[n_stages, i] + K[0, i])
                for r in range(4):
                    acc = 0.0
                    for j in range(16):
                        acc += D[r, j] * K[j, i]
                    Fd[3 + r, i] = h * acc
        # projection of the step's end
        y_raw = y_new.copy()
        st, res, rv = project_packed(I, F, TI, W, y_new, position_tol)
        if st != 0:
            return LOOP_FALLBACK, k_out, n_steps, n_rhs
        for i in range(ny):
            if not np.isfinite(y_new[i]):
                return LOOP_FALLBACK, k_out, n_steps, n_rhs
        if t_new - t_prev < stalled:  # (the interpreted path asks whether it is a dead point)
            return LOOP_FALLBACK, k_out, n_steps, n_rhs
        k0 = k_out
        while k_out < n_out and t_out[k_out] <= t_new:
            te = t_out[k_out]
            if te == t_new:
                for i in range(ny):
                    out_y[k_out, i] = y_new[i]
                out_res[k_out, 0] = res
                out_res[k_out, 1] = rv
            else:
                x = (te - t) / h
                for i in range(ny):
                    v = 0.0
                    for r in range(6, -1, -1):
                        v += Fd[r, i]
                        if (6 - r) % 2 == 0:
                            v *= x
                        else:
                            v *= 1.0 - x
                    ytmp[i] = v + y[i]
                st, r0, r1 = project_packed(I, F, TI, W, ytmp, position_tol)
                if st != 0:
                    return LOOP_FALLBACK, k0, n_steps, n_rhs
                for i in range(ny):
                    out_y[k_out, i] = ytmp[i]
                out_res[k_out, 0] = r0
                out_res[k_out, 1] = r1
            k_out += 1
        change = 0.0
        for i in range(ny):
            c = abs(y_new[i] - y_raw[i]) / (atol + rtol * max(abs(y_raw[i]), abs(y_new[i])))
            if c > change:
                change = c
        for i in range(ny):
            f[i] = K[n_stages, i]
        if change > _STALE_DERIVATIVE_TOL:
            if rhs_packed(I, F, TI, W, y_new, f, 0.0) != 0:
                return LOOP_FALLBACK, k0, n_steps, n_rhs
            n_rhs += 1
        for i in range(ny):
            y[i] = y_new[i]
        t = t_new
        t_prev = t_new
        carry[0] = t
        carry[1] = h_abs
        carry[2] = t_prev
    return LOOP_DONE, k_out, n_steps, n_rhs
