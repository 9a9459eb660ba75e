"""One contact on Python floats: the same kinematics as ``_kernel`` (see its docstring).

A contact's work is a few hundred products of 3-vectors; as numpy calls on
arrays of three numbers each one costs microseconds of call overhead, so a
System with few contacts evaluates them one at a time on floats (about ten
times faster); many contacts use the batched arrays of ``_kernel``. The
tests check that both give the same rows.
"""

from __future__ import annotations

import math
from typing import Any

from ._errors import _CHART_LIMIT, _MAX_ITER, _STEP_TOL, ContactError, _lost

__all__ = ["evaluate_one", "geometry_one", "newton_one"]


# ------------------------------------------------------------------ 3-vectors as tuples
def _rot(A, v):
    a0, a1, a2 = A
    return (a0[0] * v[0] + a0[1] * v[1] + a0[2] * v[2], a1[0] * v[0] + a1[1] * v[1] + a1[2] * v[2],
            a2[0] * v[0] + a2[1] * v[1] + a2[2] * v[2])


def _rotT(A, v):
    a0, a1, a2 = A
    return (a0[0] * v[0] + a1[0] * v[1] + a2[0] * v[2], a0[1] * v[0] + a1[1] * v[1] + a2[1] * v[2],
            a0[2] * v[0] + a1[2] * v[1] + a2[2] * v[2])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _mul(k, a):
    return (k * a[0], k * a[1], k * a[2])


def _axpy(k, a, b):  # k a + b
    return (k * a[0] + b[0], k * a[1] + b[1], k * a[2] + b[2])


def _norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def _neg(a):
    return (-a[0], -a[1], -a[2])


_ZERO = (0.0, 0.0, 0.0)


def _key(p, idx):
    """Multi-order key of a derivative index tuple."""
    if p == 1:
        return (len(idx),)
    a = idx.count(0)
    return (a, len(idx) - a)


_K1 = {p: [_key(p, (l,)) for l in range(p)] for p in (1, 2)}
_K2 = {p: [[_key(p, (l, m)) for m in range(p)] for l in range(p)] for p in (1, 2)}
_K3 = {p: [[[_key(p, (l, m, o)) for o in range(p)] for m in range(p)] for l in range(p)] for p in (1, 2)}


class _G:
    """Global geometry of one side at one point."""

    __slots__ = ("rho", "T", "T2", "T3", "n", "n1", "n2")


#: The identity rotation (the ground's frame): geometry in it is not rotated.
IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def _glob(D: dict, Dn, A, p: int, order: int, normal_order: int = 2, third: bool = True) -> _G:
    """Global geometry of one side: ``rho``, tangents and their derivatives, the normal field.

    Only what the side's role needs is formed: the normal's derivatives up
    to ``normal_order`` (the side whose normal enters the constraints) and
    the third derivatives when ``third`` (the side whose tangents do).
    """
    g = _G()
    n_ord = min(order - 1, normal_order)
    keep3 = third or (Dn is None and n_ord >= 2)  # (nu = t1 x t2 needs the side's own third derivatives)
    if A is IDENTITY:
        G = D
    else:
        (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = A
        items = D.items() if keep3 else [kv for kv in D.items() if sum(kv[0]) < 3]
        G = {k: (a00 * v0 + a01 * v1 + a02 * v2, a10 * v0 + a11 * v1 + a12 * v2, a20 * v0 + a21 * v1 + a22 * v2)
             for k, (v0, v1, v2) in items}
    g.rho = G[(0,) * p]
    g.T = [G[k] for k in _K1[p]]
    g.T2 = [[G[k] for k in row] for row in _K2[p]] if order >= 2 else None
    g.T3 = [[[G[k] for k in r2] for r2 in r1] for r1 in _K3[p]] if order >= 3 and third else None
    if Dn is None:  # nu = t1 x t2 (Eq. 8.86), rotated tangents
        T, T2 = g.T, g.T2
        g.n = _cross(T[0], T[1])
        g.n1 = [_add(_cross(T2[0][l], T[1]), _cross(T[0], T2[1][l])) for l in range(2)] if n_ord >= 1 else None
        if n_ord >= 2:
            T3 = [[[G[k] for k in r2] for r2 in r1] for r1 in _K3[p]] if g.T3 is None else g.T3
            n2 = [[None, None], [None, None]]
            for l in range(2):
                for m in range(l, 2):
                    v = _add(_add(_cross(T3[0][l][m], T[1]), _cross(T2[0][l], T2[1][m])),
                             _add(_cross(T2[0][m], T2[1][l]), _cross(T[0], T3[1][l][m])))
                    n2[l][m] = n2[m][l] = v
            g.n2 = n2
        else:
            g.n2 = None
    elif A is IDENTITY:
        g.n = Dn[(0,) * p]
        g.n1 = [Dn[k] for k in _K1[p]] if n_ord >= 1 else None
        g.n2 = [[Dn[k] for k in row] for row in _K2[p]] if n_ord >= 2 else None
    else:
        g.n = _rot(A, Dn[(0,) * p])
        g.n1 = [_rot(A, Dn[k]) for k in _K1[p]] if n_ord >= 1 else None
        g.n2 = [[_rot(A, Dn[k]) for k in row] for row in _K2[p]] if n_ord >= 2 else None
    return g


def _solve(M: list, b: list):
    """Solution of the small dense system ``M x = b`` (2 x 2 by Cramer's rule, else Gaussian elimination
    with partial pivoting); None if singular."""
    n = len(b)
    if n == 2:
        (a, c), (d, e) = M
        det = a * e - c * d
        if not (abs(det) > 0.0 and math.isfinite(det)):
            return None
        return [(b[0] * e - c * b[1]) / det, (a * b[1] - d * b[0]) / det]
    a = [list(row) + [b[i]] for i, row in enumerate(M)]
    for col in range(n):
        piv = col
        big = abs(a[col][col])
        for r in range(col + 1, n):
            v = abs(a[r][col])
            if v > big:
                piv, big = r, v
        if not (big > 0.0 and math.isfinite(big)):
            return None
        if piv != col:
            a[col], a[piv] = a[piv], a[col]
        rowc = a[col]
        inv = 1.0 / rowc[col]
        for r in range(col + 1, n):
            rr = a[r]
            f = rr[col] * inv
            if f != 0.0:
                for q in range(col, n + 1):
                    rr[q] -= f * rowc[q]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        row = a[r]
        acc = row[n]
        for q in range(r + 1, n):
            acc -= row[q] * x[q]
        x[r] = acc / row[r]
    return x


def _det4(M):
    """Determinant of a 4 x 4 matrix (Laplace expansion by the first two rows)."""
    a, b, c, d = M
    s0 = a[0] * b[1] - a[1] * b[0]
    s1 = a[0] * b[2] - a[2] * b[0]
    s2 = a[0] * b[3] - a[3] * b[0]
    s3 = a[1] * b[2] - a[2] * b[1]
    s4 = a[1] * b[3] - a[3] * b[1]
    s5 = a[2] * b[3] - a[3] * b[2]
    c5 = c[2] * d[3] - c[3] * d[2]
    c4 = c[1] * d[3] - c[3] * d[1]
    c3 = c[1] * d[2] - c[2] * d[1]
    c2 = c[0] * d[3] - c[3] * d[0]
    c1 = c[0] * d[2] - c[2] * d[0]
    c0 = c[0] * d[1] - c[1] * d[0]
    return s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0


class Frames1:
    """Rotation matrices (tuples of rows), positions, velocities and global omegas of a contact's bodies."""

    __slots__ = ("Ai", "Aj", "Ri", "Rj", "Vi", "Vj", "Wi", "Wj")


def _extremal(cs, fr: Frames1, gi: _G, gj: _G):
    p = cs.p
    swap = cs.swap
    d = _sub(_add(fr.Ri, gi.rho), _add(fr.Rj, gj.rho))
    if swap:
        n_a, n1_a, tb, T2b = gj.n, gj.n1, gi.T, gi.T2
    else:
        n_a, n1_a, tb, T2b = gi.n, gi.n1, gj.T, gj.T2
    E = [_dot(d, tb[m]) for m in range(p)] + [_dot(n_a, tb[m]) for m in range(p)]
    Es = []
    for m in range(p):
        row = []
        for l in range(p):
            v = _dot(tb[m], gi.T[l])
            if swap:
                v += _dot(d, T2b[m][l])
            row.append(v)
        for l in range(p):
            v = -_dot(tb[m], gj.T[l])
            if not swap:
                v += _dot(d, T2b[m][l])
            row.append(v)
        Es.append(row)
    for m in range(p):
        colA = [_dot(tb[m], n1_a[l]) for l in range(p)]
        colB = [_dot(n_a, T2b[m][l]) for l in range(p)]
        Es.append(colB + colA if swap else colA + colB)
    return E, Es, d


def newton_one(cs, fr: Frames1, s: list, charts: list, order: int, *, t: float | None = None,
               max_iter: int = _MAX_ITER, damped: bool = False, outward: bool = False):
    """Newton on the extremal conditions of one contact; returns ``(s, gi, gj, E, Es)`` (see ``_kernel``).

    ``outward``: also refuse a rim point whose normal points into the disk
    (see ``_kernel.solve_parameters``).
    """
    p = cs.p
    s = list(s)
    L = cs.L
    step = math.inf
    # iterate on second derivatives; the third (for gamma) only once the step is small
    cur = min(order, 2)
    a_is_i = not cs.swap
    charted = getattr(cs, "charted", True)
    derivs_i, derivs_j = cs.surf_i._derivs_float, cs.surf_j._derivs_float
    for _ in range(max_iter):
        if charted:
            _rechart(cs, s, charts)  # before the geometry: the returned s, geometry and s_dot share one chart
        Di, Dni = derivs_i(tuple(s[:p]), cur, charts[0])
        Dj, Dnj = derivs_j(tuple(s[p:]), cur, charts[1])
        gi = _glob(Di, Dni, fr.Ai, p, cur, 2 if a_is_i else 0, not a_is_i)
        gj = _glob(Dj, Dnj, fr.Aj, p, cur, 0 if a_is_i else 2, a_is_i)
        E, Es, _ = _extremal(cs, fr, gi, gj)
        ds = _solve(Es, E)
        if ds is None:
            raise ContactError(_lost(cs.contact, t, "the extremal conditions are singular (E_s, rank of C_s < 2p, "
                                     "Eq. 8.109): a line or surface contact, or a singular point of a "
                                     "parametrization"), t=t)
        step = 0.0
        curved = 0.0  # the step on the curved sides: an unbounded plane's parameters move freely
        for side, g, off, flat in ((cs.rim_i, gi, 0, cs.flat_i), (cs.rim_j, gj, p, cs.flat_j)):
            for l in range(p):
                sc = _norm(g.T[l])
                if side:
                    sc = max(sc, L * _norm(g.n1[l]) / _norm(g.n))
                x = abs(ds[off + l]) * sc
                step = max(step, x)
                if not flat:
                    curved = max(curved, x)
        step /= L
        curved /= L
        if not math.isfinite(step):
            raise ContactError(_lost(cs.contact, t, "the contact geometry is not finite"), t=t)
        lim = 0.25 if damped else 0.5
        f = lim / curved if curved > lim else 1.0
        fi = 1.0 if cs.flat_i else f
        fj = 1.0 if cs.flat_j else f
        for q in range(p):
            s[q] -= fi * ds[q]
        for q in range(p, 2 * p):
            s[q] -= fj * ds[q]
        if step <= _STEP_TOL:
            if cur < order:  # one more evaluation, with the third derivatives
                cur = order
                continue
            if not _dot(gi.n, gj.n) < 0.0 or (outward and ((cs.rim_i and not math.cos(s[1]) > 0.0) or (
                    cs.rim_j and not math.cos(s[p + 1]) > 0.0))):
                raise ContactError(_lost(cs.contact, t, "Newton reached a pair of points whose normals are not "
                                         "opposed (the far sides of the surfaces, or a rim's normal pointing "
                                         "into the disk)"), t=t)
            return s, gi, gj, E, Es
        if step <= 1e-5:
            cur = order
    raise ContactError(_lost(cs.contact, t, f"Newton on the contact point did not converge in {max_iter} iterations "
                                            f"(last step {step:.2e} of the length scale): the contact point jumped"),
                       t=t)


def geometry_one(cs, fr: Frames1, s: list, charts: list, order: int):
    """``(gi, gj)``: the global geometry of both sides at converged parameters ``s`` (in ``charts``) up to
    ``order``, as the last iteration of :func:`newton_one` forms it (Eqs. 8.84-8.89)."""
    p = cs.p
    a_is_i = not cs.swap
    Di, Dni = cs.surf_i._derivs_float(tuple(s[:p]), order, charts[0])
    Dj, Dnj = cs.surf_j._derivs_float(tuple(s[p:]), order, charts[1])
    return (_glob(Di, Dni, fr.Ai, p, order, 2 if a_is_i else 0, not a_is_i),
            _glob(Dj, Dnj, fr.Aj, p, order, 0 if a_is_i else 2, a_is_i))


def _rechart(cs, s: list, charts: list) -> None:
    p = cs.p
    for side, surf, off in ((0, cs.surf_i, 0), (1, cs.surf_j, p)):
        if surf.charted and max(abs(s[off]), abs(s[off + 1])) > _CHART_LIMIT:
            import numpy as np

            chart, s_new = surf._new_chart(np.array(s[off : off + p]), charts[side])
            charts[side] = chart
            s[off : off + p] = [float(x) for x in s_new]


def evaluate_one(cs, fr: Frames1, gi: _G, gj: _G, Es: list, level: int, *, rank: bool = True,
                 gamma: bool = True) -> dict:
    """Reduced row, rolling rows and their terms for one contact (see ``_kernel.contact_rows``).

    ``rank``: also the scaled volume of the columns of C_s (Eq. 8.109); nan otherwise. ``gamma``
    (level 2): also the acceleration terms; without it level 2 adds only ``sdot`` and ``rate`` (a
    compliant contact's force needs no more, and ``gi``/``gj`` may then lack third derivatives).
    """
    p = cs.p
    swap = cs.swap
    out: dict[str, Any] = {}
    d = _sub(_add(fr.Ri, gi.rho), _add(fr.Rj, gj.rho))
    if swap:
        n_a, tb = gj.n, gi.T
    else:
        n_a, tb = gi.n, gj.T
    nn = _norm(gi.n)
    nhat = _mul(1.0 / nn, gi.n)
    if p == 2:
        P = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
    else:
        A = fr.Ai
        P = [(A[0][0], A[1][0], A[2][0]), (A[0][1], A[1][1], A[2][1])]
    rp = len(P)
    r = rp + p
    c = [_dot(e, d) for e in P] + [_dot(n_a, tb[m]) for m in range(p)]
    Cs = [[_dot(e, gi.T[l]) for l in range(p)] + [-_dot(e, gj.T[l]) for l in range(p)] for e in P]
    Cs += [list(row) for row in Es[p:]]
    if p == 1:
        c0 = (Cs[0][0], Cs[1][0], Cs[2][0])
        c1 = (Cs[0][1], Cs[1][1], Cs[2][1])
        Nraw = list(_cross(c0, c1))
    else:
        Nraw = []
        for q in range(5):
            minor = [Cs[x] for x in range(5) if x != q]
            Nraw.append((-1.0 if q % 2 else 1.0) * _det4(minor))
    if rank:  # rank indicator (Eq. 8.109)
        L = cs.L
        rs = [1.0 / L] * rp + [1.0 / (_norm(n_a) * _norm(tb[m])) for m in range(p)]
        prod_cs = 1.0
        for col in range(2 * p):
            v = math.sqrt(sum((Cs[x][col] * rs[x]) ** 2 for x in range(r)))
            prod_cs = prod_cs / v if v > 0 else 0.0
        prod_rs = 1.0
        for v in rs:
            prod_rs *= v
        out["rank"] = math.sqrt(sum((Nraw[x] * prod_rs / rs[x]) ** 2 for x in range(r))) * prod_cs
    else:
        out["rank"] = math.nan
    w_raw = _ZERO
    for q in range(rp):
        w_raw = _axpy(Nraw[q], P[q], w_raw)
    scale = _dot(w_raw, nhat)
    N = [x / scale for x in Nraw] if scale != 0.0 else [math.nan] * r
    out["N"] = N
    w = _mul(1.0 / scale, w_raw) if scale != 0.0 else (math.nan,) * 3
    out["value"] = sum(N[x] * c[x] for x in range(r))
    out["gap"] = -_dot(nhat, d)
    out["normal"] = nhat
    out["point_i"] = _add(fr.Ri, gi.rho)
    out["point_j"] = _add(fr.Rj, gj.rho)
    if level < 1:
        return out
    tN = _ZERO
    for m in range(p):
        tN = _axpy(N[rp + m], tb[m], tN)
    mm = _cross(n_a, tN)
    Wi_c = _cross(gi.rho, w)
    if p == 1:
        Wi_c = _add(Wi_c, _cross(w, d))
    Wj_c = _neg(_cross(gj.rho, w))
    if swap:
        Wi_c, Wj_c = _sub(Wi_c, mm), _add(Wj_c, mm)
    else:
        Wi_c, Wj_c = _add(Wi_c, mm), _sub(Wj_c, mm)
    out["J"] = (w, Wi_c, _neg(w), Wj_c)
    if cs.rolling:  # unit tangents: the rows' residuals are slip speeds (m/s) whatever the parametrization
        units = [_mul(1.0 / _norm(tb[m]), tb[m]) for m in range(p)]
        out["Jr"] = [(u, _cross(gi.rho, u), _neg(u), _neg(_cross(gj.rho, u))) for u in units]
    if level < 2:
        return out
    Vi, Vj, Wi, Wj = fr.Vi, fr.Vj, fr.Wi, fr.Wj
    vrel = _sub(_add(Vi, _cross(Wi, gi.rho)), _add(Vj, _cross(Wj, gj.rho)))
    if swap:
        W_a, W_b, n1_a, n2_a, T2b, T3b = Wj, Wi, gj.n1, gj.n2, gi.T2, gi.T3
    else:
        W_a, W_b, n1_a, n2_a, T2b, T3b = Wi, Wj, gi.n1, gi.n2, gj.T2, gj.T3
    wtb = [_cross(W_b, tb[m]) for m in range(p)]
    Wn = _cross(W_a, n_a)
    Eq = [_dot(vrel, tb[m]) + _dot(d, wtb[m]) for m in range(p)] + [_dot(Wn, tb[m]) + _dot(n_a, wtb[m])
                                                                    for m in range(p)]
    sd = _solve(Es, Eq)
    if sd is None:
        raise ContactError(_lost(cs.contact, None, "the extremal conditions are singular"))
    sd = [-x for x in sd]
    out["sdot"] = sd
    J = out["J"]
    out["rate"] = _dot(J[0], Vi) + _dot(J[1], Wi) + _dot(J[2], Vj) + _dot(J[3], Wj)
    if not gamma:
        return out
    sd_i, sd_j = sd[:p], sd[p:]
    sd_a, sd_b = (sd_j, sd_i) if swap else (sd_i, sd_j)
    Td_i = _ZERO
    Td_j = _ZERO
    for l in range(p):
        Td_i = _axpy(sd_i[l], gi.T[l], Td_i)
        Td_j = _axpy(sd_j[l], gj.T[l], Td_j)
    ddot = _sub(_add(vrel, Td_i), Td_j)

    def quad(T2, sv):
        acc = _ZERO
        for l in range(p):
            for m in range(p):
                acc = _axpy(sv[l] * sv[m], T2[l][m], acc)
        return acc

    rq_i = _add(_add(_cross(Wi, _cross(Wi, gi.rho)), _mul(2.0, _cross(Wi, Td_i))), quad(gi.T2, sd_i))
    rq_j = _add(_add(_cross(Wj, _cross(Wj, gj.rho)), _mul(2.0, _cross(Wj, Td_j))), quad(gj.T2, sd_j))
    dq = _sub(rq_i, rq_j)
    hp = [_dot(e, dq) for e in P]
    if p == 1:
        for q in range(rp):
            wP = _cross(Wi, P[q])
            hp[q] += 2.0 * _dot(wP, ddot) + _dot(_cross(Wi, wP), d)
    n1s = _ZERO
    for l in range(p):
        n1s = _axpy(sd_a[l], n1_a[l], n1s)
    ndot = _add(Wn, n1s)
    nq = _add(_add(_cross(W_a, Wn), _mul(2.0, _cross(W_a, n1s))), quad(n2_a, sd_a))
    hn = []
    tdot = []
    for m in range(p):
        T2s = _ZERO
        for l in range(p):
            T2s = _axpy(sd_b[l], T2b[m][l], T2s)
        td = _add(wtb[m], T2s)
        tdot.append(td)
        tq = _add(_add(_cross(W_b, wtb[m]), _mul(2.0, _cross(W_b, T2s))), quad(T3b[m], sd_b))
        hn.append(_dot(nq, tb[m]) + 2.0 * _dot(ndot, td) + _dot(n_a, tq))
    gamma_c = [-x for x in hp + hn]
    out["gamma_c"] = gamma_c
    out["gamma"] = sum(N[x] * gamma_c[x] for x in range(r))
    if cs.rolling:
        wi = _cross(Wi, _add(_cross(Wi, gi.rho), Td_i))
        wj = _cross(Wj, _add(_cross(Wj, gj.rho), Td_j))
        dw = _sub(wi, wj)
        # of the unit-tangent rows: d/dt (t / |t|) = (t_dot - t (t . t_dot) / |t|^2) / |t|
        gr = []
        for m in range(p):
            tl2 = _dot(tb[m], tb[m])
            gr.append((-(_dot(tdot[m], vrel) + _dot(tb[m], dw)) + _dot(tb[m], tdot[m]) * _dot(tb[m], vrel) / tl2)
                      / math.sqrt(tl2))
        out["gamma_r"] = gr
    return out
