"""Compiled kernels of the multibody engine (numba, ``cache=True``).

Small functions over the flat arrays of :class:`rigidlab.core.multibody._compiled.Compiled`
(no objects, no allocation in the inner loops). Three groups:

* **Rows** (:func:`body_vectors`, :func:`rows_eval`): every row of the engine's
  row table has the form ``Phi = a . (y_b1 - y_b2)`` (see ``rigidlab.core.multibody._engine``),
  with ``a`` a direction fixed in a body and ``y_b1``, ``y_b2`` points (``h = 1``)
  or directions (``h = 0``) fixed in bodies. The distinct body vectors of the
  table (a revolute joint's five rows share two points and three axes) are
  evaluated once: ``g = A u``, ``r = h R + g``, ``r_dot = h R_dot + omega x g``
  and ``r_q = omega x (omega x g)`` with ``omega = A omega_body`` (Eqs. 8.48,
  8.19). Each row then takes its value, its Jacobian with respect to the
  Newton-Euler velocities ``v = (R_dot, omega_body)`` of the (at most three)
  bodies it touches, its rate and ``gamma`` (the acceleration terms of Eq.
  8.109's right-hand side) from three table entries in O(1):

  * ``d/dt (A u) = omega x (A u)``, so the angular part of the Jacobian of
    ``a . b`` is ``A_a^T (g_a x b)`` for ``a`` and ``+-A^T (g x a)`` for the
    points of ``b`` (one ``A^T`` per body the row touches); the translational
    part is ``+-h a``;
  * ``gamma = -(a_q . b + 2 a_dot . b_dot + a . b_q)``.

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
  or r x r (rows, negative definite) block, so the work is O(N). Blocks are
  stored as full 6 x 6 blocks (a group padded with unit pivots), so that
  every loop has a fixed trip count. A leaf body's pivot is its own mass
  block, factored once when the System is compiled. Rows that close loops
  are handled with a small Schur complement.

Every kernel is compiled with ``nogil=True``: it touches no Python object, so
a simulation running in a background job does not hold the thread that
streams the scene (a compiled DOP853 run of a whole chunk would otherwise
block it for as long as the chunk takes). An integer constant handed to a
compiled callee is made ``np.int64`` or an expression (``WH + 4 * W_Q``):
numba compiles one copy of a callee per literal constant it is called with
(once 43 copies of one view helper), each with all of its callees. Helpers
are not inlined by numba (``inline="always"`` types the inlined code again
at every call site); the compiler inlines them when it links.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
# The evaluation and the solve may fuse a product and a sum into one rounding (FMA: round-off of the same
# size, half the instructions); the step loop does not, so that its stages and error norms round as the
# interpreted loop's (numpy) do.
_JIT_FMA = {**_JIT, "fastmath": {"contract"}}

# ---------------------------------------------------------------- small algebra


@njit(**_JIT)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(**_JIT)
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


@njit(**_JIT)
def _half_g_bar_t(e0, e1, e2, e3, w0, w1, w2):
    """``G_bar(p)^T w / 2`` (Eq. 8.54) of the Euler parameters ``(e0, e1, e2, e3)`` and a body-frame ``w``."""
    return (0.5 * (-e1 * w0 - e2 * w1 - e3 * w2), 0.5 * (e0 * w0 - e3 * w1 + e2 * w2),
            0.5 * (e3 * w0 + e0 * w1 - e1 * w2), 0.5 * (-e2 * w0 + e1 * w1 + e0 * w2))


@njit(**_JIT)
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


@njit(**_JIT)
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


@njit(**_JIT_FMA)
def body_vectors(y, n, A, level, vec_b, vec_u, vec_h, omega, V):
    """The table's distinct body vectors ``(b, u, h)`` into ``V`` (nv, 12): ``g = A u``, ``r = h R + g``,
    (level 2) ``r_dot = h R_dot + omega x g`` and ``r_q = omega x (omega x g)``, ``omega = A omega_body``
    the global angular velocity (``omega`` (n, 3), filled here). Ground vectors (``b = -1``) are fixed."""
    if level >= 2:
        for b in range(n):
            w0 = y[10 * n + 3 * b]
            w1 = y[10 * n + 3 * b + 1]
            w2 = y[10 * n + 3 * b + 2]
            for i in range(3):
                omega[b, i] = A[b, i, 0] * w0 + A[b, i, 1] * w1 + A[b, i, 2] * w2
    for k in range(vec_b.shape[0]):
        b = vec_b[k]
        u0 = vec_u[k, 0]
        u1 = vec_u[k, 1]
        u2 = vec_u[k, 2]
        if b < 0:
            V[k, 0] = u0
            V[k, 1] = u1
            V[k, 2] = u2
            V[k, 3] = u0
            V[k, 4] = u1
            V[k, 5] = u2
            for i in range(6, 12):
                V[k, i] = 0.0
            continue
        h = vec_h[k]
        g0 = A[b, 0, 0] * u0 + A[b, 0, 1] * u1 + A[b, 0, 2] * u2
        g1 = A[b, 1, 0] * u0 + A[b, 1, 1] * u1 + A[b, 1, 2] * u2
        g2 = A[b, 2, 0] * u0 + A[b, 2, 1] * u1 + A[b, 2, 2] * u2
        V[k, 0] = g0
        V[k, 1] = g1
        V[k, 2] = g2
        V[k, 3] = g0 + h * y[3 * b]
        V[k, 4] = g1 + h * y[3 * b + 1]
        V[k, 5] = g2 + h * y[3 * b + 2]
        if level >= 2:
            w0 = omega[b, 0]
            w1 = omega[b, 1]
            w2 = omega[b, 2]
            c0, c1, c2 = _cross(w0, w1, w2, g0, g1, g2)
            q0, q1, q2 = _cross(w0, w1, w2, c0, c1, c2)
            V[k, 6] = c0 + h * y[7 * n + 3 * b]
            V[k, 7] = c1 + h * y[7 * n + 3 * b + 1]
            V[k, 8] = c2 + h * y[7 * n + 3 * b + 2]
            V[k, 9] = q0
            V[k, 10] = q1
            V[k, 11] = q2


@njit(**_JIT_FMA)
def rows_eval(A, level, V, vec_h, row_v, row_slot, tab_slots, Phi, J, gam, rate):
    """Value, Jacobian (level >= 1), gamma and rate (level 2) of every table row from the body vectors ``V``.

    ``row_v`` (m, 3): the vectors ``a``, ``y_b1``, ``y_b2`` of each row;
    ``row_slot`` (m, 3): their slots (-1: ground). ``J`` (m, 3, 6): per row,
    per slot (the distinct moving bodies the row touches, ``tab_slots``),
    the derivative with respect to the body's ``(R_dot, omega_body)``.
    ``gam = -(a_q . b + 2 a_dot . b_dot + a . b_q)`` and ``rate = a_dot . b +
    a . b_dot`` (Eq. 8.109's ``gamma`` and ``C_dot``).
    """
    m = Phi.shape[0]
    for r in range(m):
        ia = row_v[r, 0]
        i1 = row_v[r, 1]
        i2 = row_v[r, 2]
        a0 = V[ia, 3]
        a1 = V[ia, 4]
        a2 = V[ia, 5]
        b0 = V[i1, 3] - V[i2, 3]
        b1 = V[i1, 4] - V[i2, 4]
        b2 = V[i1, 5] - V[i2, 5]
        Phi[r] = a0 * b0 + a1 * b1 + a2 * b2
        if level >= 1:
            Jr = J[r]
            for s in range(3):
                for k in range(6):
                    Jr[s, k] = 0.0
            s = row_slot[r, 0]
            if s >= 0:  # g_a x b
                c0, c1, c2 = _cross(V[ia, 0], V[ia, 1], V[ia, 2], b0, b1, b2)
                Jr[s, 3] += c0
                Jr[s, 4] += c1
                Jr[s, 5] += c2
            s = row_slot[r, 1]
            if s >= 0:  # + h a, + g_1 x a
                h = vec_h[i1]
                Jr[s, 0] += h * a0
                Jr[s, 1] += h * a1
                Jr[s, 2] += h * a2
                c0, c1, c2 = _cross(V[i1, 0], V[i1, 1], V[i1, 2], a0, a1, a2)
                Jr[s, 3] += c0
                Jr[s, 4] += c1
                Jr[s, 5] += c2
            s = row_slot[r, 2]
            if s >= 0:  # - h a, - g_2 x a
                h = vec_h[i2]
                Jr[s, 0] -= h * a0
                Jr[s, 1] -= h * a1
                Jr[s, 2] -= h * a2
                c0, c1, c2 = _cross(V[i2, 0], V[i2, 1], V[i2, 2], a0, a1, a2)
                Jr[s, 3] -= c0
                Jr[s, 4] -= c1
                Jr[s, 5] -= c2
            for s in range(3):  # the global angular parts into body axes: A^T (...)
                b = tab_slots[r, s]
                if b < 0:
                    break
                t0 = Jr[s, 3]
                t1 = Jr[s, 4]
                t2 = Jr[s, 5]
                for i in range(3):
                    Jr[s, 3 + i] = A[b, 0, i] * t0 + A[b, 1, i] * t1 + A[b, 2, i] * t2
        if level >= 2:
            bd0 = V[i1, 6] - V[i2, 6]
            bd1 = V[i1, 7] - V[i2, 7]
            bd2 = V[i1, 8] - V[i2, 8]
            bq0 = V[i1, 9] - V[i2, 9]
            bq1 = V[i1, 10] - V[i2, 10]
            bq2 = V[i1, 11] - V[i2, 11]
            gam[r] = -((V[ia, 9] * b0 + V[ia, 10] * b1 + V[ia, 11] * b2)
                       + 2.0 * (V[ia, 6] * bd0 + V[ia, 7] * bd1 + V[ia, 8] * bd2)
                       + (a0 * bq0 + a1 * bq1 + a2 * bq2))
            rate[r] = (V[ia, 6] * b0 + V[ia, 7] * b1 + V[ia, 8] * b2) + (a0 * bd0 + a1 * bd1 + a2 * bd2)


@njit(**_JIT_FMA)
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


@njit(**_JIT_FMA)
def applied_forces(y, n, A, mass, inertia, gravity, has_gyro,
                   sp_bi, sp_ui, sp_bj, sp_uj, sp_k, sp_c, sp_L0,
                   rs_p1, rs_p2, rs_k, rs_c, rs_0, rs_bi, rs_hi, rs_bj, rs_hj, Phi, rate,
                   uf_b, uf_u, uf_has_u, uf_F, ut_b, ut_T, Q, Tg, pi, pj):
    """Generalized applied and quadratic-velocity forces ``Q_e + Q_v`` (6n,), Newton-Euler form.

    Translational part: global forces; rotational part: body-frame torques
    about the centre of mass including ``-omega_body x (I omega_body)``.
    ``Tg`` (n, 3), ``pi`` and ``pj`` (9,) are work arrays. Returns the index
    of a spring whose points coincide with a positive free length (its force
    direction is undefined), or -1.
    """
    for b in range(n):
        for i in range(3):
            Q[3 * b + i] = mass[b] * gravity[i]
            Q[3 * n + 3 * b + i] = 0.0
            Tg[b, i] = 0.0  # global torques, turned into body axes at the end
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
#
# Every block of the factorization is stored as a full 6 x 6 block (36
# contiguous floats, row-major) in flat arrays: a group of r < 6 rows is
# padded with unit pivots and zero couplings, so that every loop below has a
# fixed trip count of 6 (the compiler unrolls and vectorizes them; loops of
# 1-6 iterations set at run time cost several times the arithmetic).


@njit(**_JIT)
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


@njit(**_JIT)
def _forward(L, s, x):
    """x <- L^-1 x (leading s entries), L lower triangular (reciprocal diagonal, see _chol)."""
    for i in range(s):
        v = x[i]
        for k in range(i):
            v -= L[i, k] * x[k]
        x[i] = v * L[i, i]


@njit(**_JIT)
def _backward(L, s, x):
    """x <- L^-T x (leading s entries)."""
    for i in range(s - 1, -1, -1):
        v = x[i]
        for k in range(i + 1, s):
            v -= L[k, i] * x[k]
        x[i] = v * L[i, i]


@njit(**_JIT)
def _chol6(P, p, L, q):
    """:func:`_chol` of the 6 x 6 block ``P[p:p + 36]`` into the lower triangle of ``L[q:q + 36]``."""
    for j in range(6):
        d = P[p + 7 * j]
        for k in range(j):
            d -= L[q + 6 * j + k] * L[q + 6 * j + k]
        if not d > 0.0:
            return False
        d = 1.0 / np.sqrt(d)
        L[q + 7 * j] = d
        for i in range(j + 1, 6):
            x = P[p + 6 * i + j]
            for k in range(j):
                x -= L[q + 6 * i + k] * L[q + 6 * j + k]
            L[q + 6 * i + j] = x * d
    return True


@njit(**_JIT)
def _forward6(L, q, x, o):
    """``x[o:o + 6] <- L^-1 x[o:o + 6]`` (L the block at ``q``, as :func:`_chol6` leaves it)."""
    for i in range(6):
        v = x[o + i]
        for k in range(i):
            v -= L[q + 6 * i + k] * x[o + k]
        x[o + i] = v * L[q + 7 * i]


@njit(**_JIT)
def _backward6(L, q, x, o):
    """``x[o:o + 6] <- L^-T x[o:o + 6]``."""
    for i in range(5, -1, -1):
        v = x[o + i]
        for k in range(i + 1, 6):
            v -= L[q + 6 * k + i] * x[o + k]
        x[o + i] = v * L[q + 7 * i]


@njit(**_JIT_FMA)
def tree_factor(order_parent, node_kind, node_ref, leaf, parent_slot, group_rows, Mblocks, Lbody, Jc, Xp, Lfac,
                sign, work):
    """Block LDL^T of ``H = [[W, D^T], [D, 0]]`` over the tree, children before parents (Baraff 1996).

    Nodes are in elimination order ``0 .. N-1``; ``order_parent[i]`` is the
    parent node (> i) or -1. A body node (``node_kind`` 0, ``node_ref`` the
    body) has the diagonal block ``Mblocks[body]`` (6 x 6); a leaf body
    (``leaf[i]``, no child group) keeps it as its pivot, whose Cholesky factor
    ``Lbody[body]`` is made when the System is compiled; a group node (kind
    1, ``node_ref`` the group) has the zero block of its rows
    ``group_rows[g, :size]`` (-1 pads). ``parent_slot[i]`` is the slot, in
    the group's rows of ``Jc``, of the body of the link from ``i`` to its
    parent.

    The pivot of node i is ``D_i = H_ii - sum_children H_ic D_c^-1 H_ci``:
    positive definite for a body, negative definite for a group (its rows
    independent over its child body). Stored (6 x 6 blocks, flat, row-major):
    ``sign_i`` and the Cholesky factor ``L_i`` of ``sign_i D_i``
    (``Lfac[36 i:]``), and ``X_i = L_i^-1 H[i, parent]`` (``Xp[36 i:]``), so
    that the parent's update is ``D_p -= sign_i X_i^T X_i``. Returns -1, or
    the node whose pivot is not definite.
    """
    N = order_parent.shape[0]
    for i in range(N):
        o = 36 * i
        kind = node_kind[i]
        if leaf[i]:
            continue
        if kind == 1:  # zero block of the rows, unit pivots on the padding (negated below)
            g = node_ref[i]
            for a in range(36):
                work[o + a] = 0.0
            for a in range(6):
                if group_rows[g, a] < 0:
                    work[o + 7 * a] = -1.0
        elif kind == 0:
            mb = 36 * node_ref[i]
            for a in range(36):
                work[o + a] = Mblocks[mb + a]
    for i in range(N):
        o = 36 * i
        kind = node_kind[i]
        if leaf[i]:
            L = Lbody
            q = 36 * node_ref[i]
            sg = 1.0
        else:
            L = Lfac
            q = o
            sg = 1.0 if kind == 0 else -1.0
            if sg < 0.0:
                for a in range(36):
                    work[o + a] = -work[o + a]
            if not _chol6(work, o, Lfac, o):
                return i
        sign[i] = sg
        p = order_parent[i]
        if p < 0:
            continue
        sl = parent_slot[i]
        for a in range(36):
            Xp[o + a] = 0.0
        if kind == 1:  # group -> its parent body: D_gb (r x 6)
            g = node_ref[i]
            for a in range(6):
                r = group_rows[g, a]
                if r >= 0:
                    for c in range(6):
                        Xp[o + 6 * a + c] = Jc[r, sl, c]
        else:  # body -> its parent group: D_gb^T (6 x r)
            g = node_ref[p]
            for c in range(6):
                r = group_rows[g, c]
                if r >= 0:
                    for a in range(6):
                        Xp[o + 6 * a + c] = Jc[r, sl, a]
        for a in range(6):  # X <- L^-1 X, row by row (the six columns at once)
            for k in range(a):
                lak = L[q + 6 * a + k]
                for c in range(6):
                    Xp[o + 6 * a + c] -= lak * Xp[o + 6 * k + c]
            d = L[q + 7 * a]
            for c in range(6):
                Xp[o + 6 * a + c] *= d
        op = 36 * p
        for c in range(6):  # D_p -= sign X^T X
            for d in range(c + 1):
                v = 0.0
                for a in range(6):
                    v += Xp[o + 6 * a + d] * Xp[o + 6 * a + c]
                v *= sg
                work[op + 6 * d + c] -= v
                if d != c:
                    work[op + 6 * c + d] -= v
    return -1


@njit(**_JIT_FMA)
def tree_solve(order_parent, node_ref, leaf, Lbody, Xp, Lfac, sign, x):
    """Solve ``H z = x`` in place, ``x`` (6 N,) by node (zero on a group's padding), with the factor of
    :func:`tree_factor`."""
    N = order_parent.shape[0]
    # forward: x_i <- L_i^-1 x_i, then x_p -= sign_i X_i^T x_i (children first)
    for i in range(N):
        o = 6 * i
        if leaf[i]:
            _forward6(Lbody, 36 * node_ref[i], x, o)
        else:
            _forward6(Lfac, 36 * i, x, o)
        p = order_parent[i]
        if p < 0:
            continue
        sg = sign[i]
        for d in range(6):
            v = 0.0
            for a in range(6):
                v += Xp[36 * i + 6 * a + d] * x[o + a]
            x[6 * p + d] -= sg * v
    # backward (parents first): z_i = sign_i L_i^-T (x_i - X_i z_p)
    for i in range(N - 1, -1, -1):
        o = 6 * i
        p = order_parent[i]
        if p >= 0:
            for a in range(6):
                v = 0.0
                for d in range(6):
                    v += Xp[36 * i + 6 * a + d] * x[6 * p + d]
                x[o + a] -= v
        if leaf[i]:
            _backward6(Lbody, 36 * node_ref[i], x, o)
        else:
            _backward6(Lfac, 36 * i, x, o)
        if sign[i] < 0.0:
            for a in range(6):
                x[o + a] = -x[o + a]


@njit(**_JIT_FMA)
def augmented_solve(n, order_parent, node_kind, node_ref, leaf, body_node, group_rows, parent_slot, sec_rows,
                    jc_body, Wblocks, Lbody, Jc, rhs_v, rhs_c, x_v, lam, Xp, Lfac, sign, work, X, Z, S, rs, Ls):
    """Solve ``[[W, D^T], [D, 0]] [x; lam] = [rhs_v; rhs_c]`` (Eq. 8.109 with ``W = M``) in O(N + k^2 N).

    The rows of the tree's groups are eliminated by :func:`tree_factor`;
    the ``k`` secondary rows ``sec_rows`` (loop closures) by the Schur
    complement ``S = E H^-1 E^T`` (k x k, positive definite for independent
    rows), ``S mu = E H^-1 b - c``. ``lam`` gets the multipliers of the
    tree's and the secondary rows (others are left as they are). ``X`` (6 N,)
    and ``Z`` (k, 6 N) are work arrays. Returns 0, 1 (a pivot of the tree is
    not definite) or 2 (S is not).
    """
    if tree_factor(order_parent, node_kind, node_ref, leaf, parent_slot, group_rows, Wblocks, Lbody, Jc, Xp, Lfac,
                   sign, work) >= 0:
        return 1
    N = order_parent.shape[0]
    for i in range(N):
        o = 6 * i
        if node_kind[i] != 1:
            b = node_ref[i]
            for k in range(3):
                X[o + k] = rhs_v[3 * b + k]
                X[o + 3 + k] = rhs_v[3 * n + 3 * b + k]
        else:
            g = node_ref[i]
            for k in range(6):
                r = group_rows[g, k]
                X[o + k] = rhs_c[r] if r >= 0 else 0.0
    tree_solve(order_parent, node_ref, leaf, Lbody, Xp, Lfac, sign, X)
    ns = sec_rows.shape[0]
    if ns:
        for j in range(ns):
            Zj = Z[j]
            for k in range(6 * N):
                Zj[k] = 0.0
            r = sec_rows[j]
            for s in range(3):
                b = jc_body[r, s]
                if b >= 0:
                    for k in range(6):
                        Zj[6 * body_node[b] + k] += Jc[r, s, k]
            tree_solve(order_parent, node_ref, leaf, Lbody, Xp, Lfac, sign, Zj)
        for l in range(ns):
            rs[l] = 0.0
            for j in range(ns):
                S[l, j] = 0.0
        for l in range(ns):
            r = sec_rows[l]
            for s in range(3):
                b = jc_body[r, s]
                if b >= 0:
                    o = 6 * body_node[b]
                    for k in range(6):
                        rs[l] += Jc[r, s, k] * X[o + k]
                        for j in range(ns):
                            S[l, j] += Jc[r, s, k] * Z[j, o + k]
            rs[l] -= rhs_c[r]
        for l in range(ns):  # symmetrize the round-off
            for j in range(l):
                v = 0.5 * (S[l, j] + S[j, l])
                S[l, j] = v
                S[j, l] = v
        if not _chol(S, ns, Ls):
            return 2
        _forward(Ls, ns, rs)
        _backward(Ls, ns, rs)
        for j in range(ns):
            mu = rs[j]
            lam[sec_rows[j]] = mu
            for k in range(6 * N):
                X[k] -= mu * Z[j, k]
    for i in range(N):
        o = 6 * i
        if node_kind[i] != 1:
            b = node_ref[i]
            for k in range(3):
                x_v[3 * b + k] = X[o + k]
                x_v[3 * n + 3 * b + k] = X[o + 3 + k]
        else:
            g = node_ref[i]
            for k in range(6):
                r = group_rows[g, k]
                if r >= 0:
                    lam[r] = X[o + k]
    return 0


@njit(**_JIT_FMA)
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


@njit(**_JIT)
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

I_FIELDS = ("vec_b", "row_v", "row_slot", "tab_slots", "aux_motor", "jc_body", "sp_bi", "sp_bj", "rs_p1", "rs_p2",
            "rs_bi", "rs_bj", "uf_b", "uf_has_u", "ut_b")
F_FIELDS = ("vec_u", "vec_h", "mass", "inertia", "gravity", "Mblocks", "Wblocks", "Lm", "Lw", "sp_ui", "sp_uj",
            "sp_k", "sp_c", "sp_L0", "rs_k", "rs_c", "rs_0", "rs_hi", "rs_hj", "uf_u")
T_FIELDS = ("order_size", "order_parent", "node_kind", "node_ref", "leaf", "body_node", "group_rows", "parent_slot",
            "sec_rows")
W_FIELDS = ("A", "omega", "V", "Phi", "J", "gam", "rate", "C", "Jc", "Ct", "gamma", "Q", "Tg", "pi", "pj", "motor_f",
            "uf_F", "ut_T", "Xp", "Lfac", "sign", "work", "X", "Z", "S", "rs", "Ls", "cv", "dq", "lam", "rhs_c",
            "zero6", "res")
(I_VEC_B, I_ROW_V, I_ROW_SLOT, I_TAB_SLOTS, I_AUX_MOTOR, I_JC_BODY, I_SP_BI, I_SP_BJ, I_RS_P1, I_RS_P2, I_RS_BI,
 I_RS_BJ, I_UF_B, I_UF_HAS_U, I_UT_B) = range(15)
(F_VEC_U, F_VEC_H, F_MASS, F_INERTIA, F_GRAVITY, F_MBLOCKS, F_WBLOCKS, F_LM, F_LW, F_SP_UI, F_SP_UJ, F_SP_K, F_SP_C,
 F_SP_L0, F_RS_K, F_RS_C, F_RS_0, F_RS_HI, F_RS_HJ, F_UF_U) = range(20)
(T_ORDER_SIZE, T_ORDER_PARENT, T_NODE_KIND, T_NODE_REF, T_LEAF, T_BODY_NODE, T_GROUP_ROWS, T_PARENT_SLOT,
 T_SEC_ROWS) = range(9)
(W_A, W_OMEGA, W_V, W_PHI, W_J, W_GAM, W_RATE, W_C, W_JC, W_CT, W_GAMMA, W_Q, W_TG, W_PI, W_PJ, W_MOTOR_F, W_UF_F,
 W_UT_T, W_XP, W_LFAC, W_SIGN, W_WORK, W_X, W_Z, W_S, W_RS, W_LS, W_CV, W_DQ, W_LAM, W_RHS_C, W_ZERO6,
 W_RES) = range(33)
N_SCALARS = 8  # I[0:6] = n, m_tab, m, m_joint, m_dir, has_gyro; I[6:8] spare
IH = N_SCALARS
FH = IH + 4 * len(I_FIELDS)
TH = 0
WH = 4 * len(T_FIELDS)


def _view_codegen(ndim):
    def codegen(context, builder, sig, args):
        aty = sig.args[0]
        rty = sig.return_type
        src = context.make_array(aty)(context, builder, args[0])
        out = context.make_array(rty)(context, builder)
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(aty.dtype)))
        dims = list(args[2 : 2 + ndim])
        strides = [itemsize]
        for d in dims[:0:-1]:
            strides.insert(0, builder.mul(strides[0], d))
        context.populate_array(out, data=builder.gep(src.data, [args[1]]), shape=cgutils.pack_array(builder, dims),
                               strides=cgutils.pack_array(builder, strides), itemsize=itemsize, meminfo=src.meminfo,
                               parent=src.parent)
        return impl_ret_borrowed(context, builder, rty, out._getvalue())

    return codegen


@intrinsic
def _view2(typingctx, arr, offset, d0, d1):
    """``arr[offset:offset + d0 d1].reshape(d0, d1)`` of a contiguous 1-d ``arr``, without numba's reshape
    (a call into its runtime that costs tens of ns per view)."""
    return types.Array(arr.dtype, 2, "C")(arr, offset, d0, d1), _view_codegen(2)


@intrinsic
def _view3(typingctx, arr, offset, d0, d1, d2):
    """As :func:`_view2`, 3-d."""
    return types.Array(arr.dtype, 3, "C")(arr, offset, d0, d1, d2), _view_codegen(3)


@njit(**_JIT)
def _v1(P, H, at):
    """The 1-d field whose header entry is at ``H[at:at + 4]`` (a view of ``P``)."""
    o = H[at]
    return P[o : o + H[at + 1]]


@njit(**_JIT)
def _vflat(P, H, at):
    """The field of header ``at``, flat."""
    o = H[at]
    return P[o : o + H[at + 1] * H[at + 2] * H[at + 3]]


@njit(**_JIT)
def _v2(P, H, at):
    """The 2-d field of header ``at``."""
    return _view2(P, H[at], H[at + 1], H[at + 2])


@njit(**_JIT)
def _v3(P, H, at):
    """The 3-d field of header ``at``."""
    return _view3(P, H[at], H[at + 1], H[at + 2], H[at + 3])


@njit(**_JIT)
def evaluate_packed(I, F, TI, W, y, level):
    """Frames, body vectors, table rows and constraint rows (joints and motors) at ``y`` into ``W`` (motor
    values read from ``W``'s ``motor_f``, filled by the caller)."""
    n = I[0]
    A = _v3(W, TI, WH + 4 * W_A)
    frames(y, n, A)
    V = _v2(W, TI, WH + 4 * W_V)
    vec_h = _v1(F, I, FH + 4 * F_VEC_H)
    body_vectors(y, n, A, level, _v1(I, I, IH + 4 * I_VEC_B), _v2(F, I, FH + 4 * F_VEC_U), vec_h, _v2(W, TI, WH + 4 * W_OMEGA), V)
    Phi = _v1(W, TI, WH + 4 * W_PHI)
    J = _v3(W, TI, WH + 4 * W_J)
    gam = _v1(W, TI, WH + 4 * W_GAM)
    rate = _v1(W, TI, WH + 4 * W_RATE)
    rows_eval(A, level, V, vec_h, _v2(I, I, IH + 4 * I_ROW_V), _v2(I, I, IH + 4 * I_ROW_SLOT), _v2(I, I, IH + 4 * I_TAB_SLOTS),
              Phi, J, gam, rate)
    constraint_rows(level, I[3], I[4], Phi, J, gam, rate, _v2(W, TI, WH + 4 * W_MOTOR_F), _v2(I, I, IH + 4 * I_AUX_MOTOR),
                    _v1(W, TI, WH + 4 * W_C), _v3(W, TI, WH + 4 * W_JC), _v1(W, TI, WH + 4 * W_CT), _v1(W, TI, WH + 4 * W_GAMMA))


@njit(**_JIT)
def applied_packed(I, F, TI, W, y):
    """``Q_e + Q_v`` into ``W``'s ``Q`` (after a level-2 :func:`evaluate_packed`); a coincident spring or -1."""
    n = I[0]
    return applied_forces(y, n, _v3(W, TI, WH + 4 * W_A), _v1(F, I, FH + 4 * F_MASS), _v3(F, I, FH + 4 * F_INERTIA),
                          _v1(F, I, FH + 4 * F_GRAVITY), I[5] != 0, _v1(I, I, IH + 4 * I_SP_BI), _v2(F, I, FH + 4 * F_SP_UI),
                          _v1(I, I, IH + 4 * I_SP_BJ), _v2(F, I, FH + 4 * F_SP_UJ), _v1(F, I, FH + 4 * F_SP_K),
                          _v1(F, I, FH + 4 * F_SP_C), _v1(F, I, FH + 4 * F_SP_L0), _v1(I, I, IH + 4 * I_RS_P1),
                          _v1(I, I, IH + 4 * I_RS_P2), _v1(F, I, FH + 4 * F_RS_K), _v1(F, I, FH + 4 * F_RS_C),
                          _v1(F, I, FH + 4 * F_RS_0), _v1(I, I, IH + 4 * I_RS_BI), _v2(F, I, FH + 4 * F_RS_HI),
                          _v1(I, I, IH + 4 * I_RS_BJ), _v2(F, I, FH + 4 * F_RS_HJ), _v1(W, TI, WH + 4 * W_PHI),
                          _v1(W, TI, WH + 4 * W_RATE), _v1(I, I, IH + 4 * I_UF_B), _v2(F, I, FH + 4 * F_UF_U),
                          _v1(I, I, IH + 4 * I_UF_HAS_U), _v2(W, TI, WH + 4 * W_UF_F), _v1(I, I, IH + 4 * I_UT_B),
                          _v2(W, TI, WH + 4 * W_UT_T), _v1(W, TI, WH + 4 * W_Q), _v2(W, TI, WH + 4 * W_TG),
                          _v1(W, TI, WH + 4 * W_PI), _v1(W, TI, WH + 4 * W_PJ))


@njit(**_JIT)
def solve_packed(I, F, TI, W, metric, rhs_v, rhs_c, x_v):
    """:func:`augmented_solve` with the mass blocks (``metric`` 0) or the projection metric (1); the
    multipliers into ``W``'s ``lam``."""
    n = I[0]
    if metric == 0:
        blocks = _vflat(F, I, FH + 4 * F_MBLOCKS)
        Lb = _vflat(F, I, FH + 4 * F_LM)
    else:
        blocks = _vflat(F, I, FH + 4 * F_WBLOCKS)
        Lb = _vflat(F, I, FH + 4 * F_LW)
    return augmented_solve(n, _v1(TI, TI, TH + 4 * T_ORDER_PARENT), _v1(TI, TI, TH + 4 * T_NODE_KIND),
                           _v1(TI, TI, TH + 4 * T_NODE_REF), _v1(TI, TI, TH + 4 * T_LEAF), _v1(TI, TI, TH + 4 * T_BODY_NODE), _v2(TI, TI, TH + 4 * T_GROUP_ROWS),
                           _v1(TI, TI, TH + 4 * T_PARENT_SLOT), _v1(TI, TI, TH + 4 * T_SEC_ROWS), _v2(I, I, IH + 4 * I_JC_BODY),
                           blocks, Lb, _v3(W, TI, WH + 4 * W_JC), rhs_v, rhs_c, x_v, _v1(W, TI, WH + 4 * W_LAM),
                           _vflat(W, TI, WH + 4 * W_XP), _vflat(W, TI, WH + 4 * W_LFAC), _v1(W, TI, WH + 4 * W_SIGN),
                           _vflat(W, TI, WH + 4 * W_WORK), _vflat(W, TI, WH + 4 * W_X), _v2(W, TI, WH + 4 * W_Z),
                           _v2(W, TI, WH + 4 * W_S), _v1(W, TI, WH + 4 * W_RS), _v2(W, TI, WH + 4 * W_LS))


@njit(**_JIT)
def call_packed(I, F, TI, W, y, op, arg, rhs_v, rhs_c, x_v):
    """The evaluations the Python side asks for outside a right-hand side, in one compiled entry: ``op`` 0
    :func:`evaluate_packed` at level ``arg``, 1 :func:`applied_packed`, 2 :func:`solve_packed` with metric
    ``arg`` (``rhs_v``, ``rhs_c``, ``x_v``). Returns the callee's status (0 for an evaluation)."""
    if op == 0:
        evaluate_packed(I, F, TI, W, y, arg)
        return 0
    if op == 1:
        return applied_packed(I, F, TI, W, y)
    return solve_packed(I, F, TI, W, arg, rhs_v, rhs_c, x_v)


@njit(**_JIT)
def rhs_packed(I, F, TI, W, y, ydot, alpha):
    """``y_dot = [R_dot, p_dot, a]`` (Eqs. 8.51-8.54, 8.109) in one call; the user's loads and the motor
    values are in ``W`` already. Returns 0, 1 or 2 (see :func:`augmented_solve`) or ``3 + k`` for spring
    ``k`` whose points coincide."""
    n = I[0]
    evaluate_packed(I, F, TI, W, y, np.int64(2))  # (np.int64: one compiled callee for every level)
    bad = applied_packed(I, F, TI, W, y)
    if bad >= 0:
        return 3 + bad
    gamma = _v1(W, TI, WH + 4 * W_GAMMA)
    if alpha != 0.0:  # Baumgarte: gamma - 2 alpha C_dot - alpha^2 C
        cv = _v1(W, TI, WH + 4 * W_CV)
        C = _v1(W, TI, WH + 4 * W_C)
        jacobian_apply(n, _v3(W, TI, WH + 4 * W_JC), _v2(I, I, IH + 4 * I_JC_BODY), y[7 * n :], _v1(W, TI, WH + 4 * W_CT), cv)
        for r in range(gamma.shape[0]):
            gamma[r] = gamma[r] - 2.0 * alpha * cv[r] - alpha * alpha * C[r]
    lam = _v1(W, TI, WH + 4 * W_LAM)
    for r in range(lam.shape[0]):
        lam[r] = 0.0
    st = solve_packed(I, F, TI, W, np.int64(0), _v1(W, TI, WH + 4 * W_Q), gamma, ydot[7 * n :])
    if st:
        return st
    for k in range(3 * n):
        ydot[k] = y[7 * n + k]
    parameter_rates(y, n, ydot, 3 * n)
    return 0


@njit(**_JIT)
def _max_abs_kept(x, TI):
    """max |x_r| over the rows the tree solves (its groups' and the secondary rows)."""
    group_rows = _v2(TI, TI, TH + 4 * T_GROUP_ROWS)
    node_kind = _v1(TI, TI, TH + 4 * T_NODE_KIND)
    node_ref = _v1(TI, TI, TH + 4 * T_NODE_REF)
    order_size = _v1(TI, TI, TH + 4 * T_ORDER_SIZE)
    sec = _v1(TI, TI, TH + 4 * T_SEC_ROWS)
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


@njit(**_JIT)
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
    C = _v1(W, TI, WH + 4 * W_C)
    Jc = _v3(W, TI, WH + 4 * W_JC)
    Ct = _v1(W, TI, WH + 4 * W_CT)
    jc_body = _v2(I, I, IH + 4 * I_JC_BODY)
    dq = _v1(W, TI, WH + 4 * W_DQ)
    zero6 = _v1(W, TI, WH + 4 * W_ZERO6)
    cv = _v1(W, TI, WH + 4 * W_CV)
    one = np.int64(1)  # (np.int64: see the module's docstring)
    prev = np.inf
    res = 0.0
    for it in range(10):
        evaluate_packed(I, F, TI, W, y, one)
        res = _max_abs_kept(C, TI)
        if res <= tol or (it > 0 and res <= 1e-8 and res > 0.25 * prev):
            break
        if not np.isfinite(res):
            return 5, res, 0.0
        if it == 9:
            return 4, res, 0.0
        st = solve_packed(I, F, TI, W, one, zero6, C, dq)
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
        st = solve_packed(I, F, TI, W, one, zero6, cv, dq)
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
# The loop of ``rigidlab.core.integrators._run_adaptive_projected`` with scipy's DOP853
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


@njit(**_JIT)
def _rms(x, scale):
    s = 0.0
    for i in range(x.shape[0]):
        v = x[i] / scale[i]
        s += v * v
    return np.sqrt(s) / np.sqrt(x.shape[0])


@njit(**_JIT)
def _stage_sum(K, a, s, h, y, out):
    """``out = y + (K[:s].T @ a[:s]) * h``."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += K[j, i] * a[j]
        out[i] = y[i] + acc * h


@njit(**_JIT)
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
