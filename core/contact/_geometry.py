"""Batched contact geometry: the extremal conditions, Newton on the surface parameters and the contact rows.

The vectorized functions of ``rigidlab.core.contact._kernel`` (see its docstring for
the notation and Eqs. 8.84-8.109), over groups of contacts with the same
number of parameters; the kernel and the global search
(``rigidlab.core.contact._search``) call them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._errors import _CHART_LIMIT, _MAX_ITER, _STEP_TOL, CONTACT_RANK_TOL, ContactError, _lost
from ._scalar import _det4



def _det_sign(M: list) -> float:
    """Sign of the determinant of the small matrix E_s (2 x 2 or 4 x 4), as a float."""
    if len(M) == 2:
        d = M[0][0] * M[1][1] - M[0][1] * M[1][0]
    else:
        d = _det4(M)
    return 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack(
        [a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
         a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
         a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


class _Group:
    """Contacts with the same number of parameters per body (2: surfaces, 1: curves)."""

    def __init__(self, contacts: list, p: int, ground: int):
        self.contacts = contacts
        self.p = p
        self.k = len(contacts)
        self.pos = np.array([c.index for c in contacts], dtype=np.intp)
        self.bi = np.array([ground if c.body_i.index < 0 else c.body_i.index for c in contacts], dtype=np.intp)
        self.bj = np.array([ground if c.body_j.index < 0 else c.body_j.index for c in contacts], dtype=np.intp)
        self.swap = np.array([bool(c.surface_j.degenerate_tangents) for c in contacts], dtype=bool)
        self.rim_i = np.array([bool(c.surface_i.degenerate_tangents) for c in contacts], dtype=bool)
        self.rim_j = self.swap
        self.flat = np.array([[bool(c.surface_i.unbounded)] * p + [bool(c.surface_j.unbounded)] * p
                              for c in contacts], dtype=bool).reshape(len(contacts), 2 * p)
        self.surf_i = [c.surface_i for c in contacts]
        self.surf_j = [c.surface_j for c in contacts]
        L = np.array([min(c.surface_i.length_scale, c.surface_j.length_scale) for c in contacts], dtype=float)
        self.L = np.where(np.isfinite(L), L, 1.0)


class _Frames:
    """Body data of the contacts of a group: rotation matrices, positions, velocities (global)."""

    __slots__ = ("A_i", "A_j", "R_i", "R_j", "V_i", "V_j", "W_i", "W_j")


def frames_of(group: _Group, A_ext: np.ndarray, R_ext: np.ndarray, V_ext: np.ndarray | None,
              W_ext: np.ndarray | None) -> _Frames:
    f = _Frames()
    f.A_i, f.A_j = A_ext[group.bi], A_ext[group.bj]
    f.R_i, f.R_j = R_ext[group.bi], R_ext[group.bj]
    if V_ext is not None:
        f.V_i, f.V_j = V_ext[group.bi], V_ext[group.bj]
        f.W_i, f.W_j = W_ext[group.bi], W_ext[group.bj]
    return f


def _stack_geometry(surfaces: list, s: np.ndarray, charts: list, order: int):
    """Per-contact geometry stacked over contacts: 7 entries (u, U1, U2, U3, nu, N1, N2)."""
    parts = [surf._geometry(s[c], order, charts[c]) for c, surf in enumerate(surfaces)]
    return [None if parts[0][e] is None else np.stack([np.asarray(pt[e], dtype=float) for pt in parts])
            for e in range(7)]


class _Geo:
    """Global geometry of one side of the contacts of a group."""

    __slots__ = ("rho", "T", "T2", "T3", "n", "n1", "n2", "nu_norm", "U1_norm")


def _globalize(g, A: np.ndarray) -> _Geo:
    out = _Geo()
    out.rho = np.einsum("kab,kb->ka", A, g[0])
    out.T = np.einsum("kab,kbl->kal", A, g[1])
    out.T2 = None if g[2] is None else np.einsum("kab,kblm->kalm", A, g[2])
    out.T3 = None if g[3] is None else np.einsum("kab,kblmo->kalmo", A, g[3])
    out.n = np.einsum("kab,kb->ka", A, g[4])
    out.n1 = None if g[5] is None else np.einsum("kab,kbl->kal", A, g[5])
    out.n2 = None if g[6] is None else np.einsum("kab,kblm->kalm", A, g[6])
    return out


def _pick(swap: np.ndarray, x_i: np.ndarray, x_j: np.ndarray) -> np.ndarray:
    if not swap.any():
        return x_i
    if swap.all():
        return x_j
    return np.where(swap.reshape((-1,) + (1,) * (x_i.ndim - 1)), x_j, x_i)


class _Kin:
    """Everything computed for a group at one configuration (and velocity)."""


def _extremal(group: _Group, fr: _Frames, gi: _Geo, gj: _Geo):
    """``E`` (k, 2p) and ``E_s`` (k, 2p, 2p) of the extremal conditions; also d, n_a, t_b, T2_b."""
    p = group.p
    swap = group.swap
    d = (fr.R_i + gi.rho) - (fr.R_j + gj.rho)
    n_a = _pick(swap, gi.n, gj.n)
    n1_a = _pick(swap, gi.n1, gj.n1)
    tb = _pick(swap, gj.T, gi.T)
    T2b = _pick(swap, gj.T2, gi.T2)
    E = np.concatenate([np.einsum("kx,kxm->km", d, tb), np.einsum("kx,kxm->km", n_a, tb)], axis=1)
    Es = np.empty((group.k, 2 * p, 2 * p))
    dT2 = np.einsum("kx,kxml->kml", d, T2b)
    ti = np.einsum("kxm,kxl->kml", tb, gi.T)
    tj = np.einsum("kxm,kxl->kml", tb, gj.T)
    sw = swap[:, None, None]
    Es[:, :p, :p] = ti + np.where(sw, dT2, 0.0)
    Es[:, :p, p:] = -tj + np.where(sw, 0.0, dT2)
    colA = np.einsum("kxm,kxl->kml", tb, n1_a)
    colB = np.einsum("kx,kxml->kml", n_a, T2b)
    Es[:, p:, :p] = np.where(sw, colB, colA)
    Es[:, p:, p:] = np.where(sw, colA, colB)
    return E, Es, d, n_a, tb


def _column_scales(group: _Group, gi: _Geo, gj: _Geo) -> np.ndarray:
    """(k, 2p) arc length per unit of each parameter (a rim's psi: L times the normal's turn)."""
    out = []
    for g in (gi, gj):
        t = np.linalg.norm(g.T, axis=1)
        nn = np.linalg.norm(g.n, axis=1)[:, None]
        rot = np.linalg.norm(g.n1, axis=1) / np.where(nn > 0, nn, 1.0) * group.L[:, None]
        out.append(np.maximum(t, rot))
    return np.concatenate(out, axis=1)


def solve_parameters(group: _Group, fr: _Frames, s: np.ndarray, charts: list, order: int, *,
                     t: float | None = None, max_iter: int = _MAX_ITER, damped: bool = False,
                     outward: bool = False):
    """Newton on the extremal conditions from ``s`` (k, 2p); returns ``(s, gi, gj, raw_i, raw_j, E, Es)``.

    ``order`` is the surface derivative order of the returned geometry
    (2 or 3). Charts of spheres and ellipsoids are re-centred (in place in
    ``charts``) when the point leaves the central region of its chart.
    ``outward`` (a search afresh): also refuse a rim point whose normal
    field ``cos(psi) e_r + sin(psi) e_y`` points into the disk (``cos psi
    <= 0``): the rim's far side, which faces the other surface with a
    flipped normal and would otherwise pass as the largest gap. A followed
    contact is not refused there: its ``psi`` crosses ``pi / 2`` only as
    the disk passes through lying flat, which the sign of ``det E_s``
    reports (Eq. 8.109).

    Raises
    ------
    ContactError
        When Newton does not converge or ``E_s`` is singular.
    """
    p = group.p
    s = np.array(s, dtype=float)
    for it in range(max_iter):
        _rechart(group, s, charts)  # before the geometry: the returned s and geometry share one chart
        ci = [ch[0] for ch in charts]
        cj = [ch[1] for ch in charts]
        raw_i = _stack_geometry(group.surf_i, s[:, :p], ci, order)
        raw_j = _stack_geometry(group.surf_j, s[:, p:], cj, order)
        gi, gj = _globalize(raw_i, fr.A_i), _globalize(raw_j, fr.A_j)
        E, Es, _, _, _ = _extremal(group, fr, gi, gj)
        try:
            ds = -np.linalg.solve(Es, E[..., None])[..., 0]
        except np.linalg.LinAlgError:
            ds = np.full_like(s, np.nan)
        scale = _column_scales(group, gi, gj)
        steps = np.abs(ds) * scale
        step = np.max(steps, axis=1) / group.L
        curved = np.max(np.where(group.flat, 0.0, steps), axis=1) / group.L  # (planes' parameters move freely)
        if not np.all(np.isfinite(step)):
            bad = int(np.argmax(~np.isfinite(step)))
            raise _at(ContactError(_lost(group.contacts[bad], t, "the extremal conditions are singular (E_s, rank "
                                         "of C_s < 2p, Eq. 8.109): a line or surface contact, or a singular "
                                         "point of a parametrization"), t=t), s, charts)
        lim = 0.25 if damped else 0.5
        big = curved > lim
        if big.any():
            ds = np.where(big[:, None] & ~group.flat, ds * (lim / np.where(big, curved, 1.0))[:, None], ds)
        done = step <= _STEP_TOL
        if done.all():
            s = s + ds
            facing = np.einsum("ki,ki->k", gi.n, gj.n) < 0.0
            if outward and p == 2:
                facing &= ~(group.rim_i & ~(np.cos(s[:, 1]) > 0.0)) & ~(group.rim_j & ~(np.cos(s[:, 3]) > 0.0))
            if not facing.all():
                bad = int(np.argmin(facing))
                raise ContactError(_lost(group.contacts[bad], t, "Newton reached a pair of points whose normals are "
                                         "not opposed (the far sides of the surfaces, or a rim's normal pointing "
                                         "into the disk)"), t=t)
            return s, gi, gj, raw_i, raw_j, E, Es
        s = s + ds
    worst = int(np.argmax(step))
    raise _at(ContactError(_lost(group.contacts[worst], t, f"Newton on the contact point did not converge in "
                                                          f"{max_iter} iterations (last step {step[worst]:.2e} of "
                                                          "the length scale): the contact point jumped"), t=t),
              s, charts)


def _at(exc: ContactError, s: np.ndarray, charts: list) -> ContactError:
    """``exc`` with Newton's last iterate attached (``exc.iterate = (s, charts)``; see ``_search.find_contact``)."""
    exc.iterate = (np.array(s), [list(ch) for ch in charts])
    return exc


def _rechart(group: _Group, s: np.ndarray, charts: list) -> None:
    p = group.p
    for c in range(group.k):
        for side, surf, off in ((0, group.surf_i[c], 0), (1, group.surf_j[c], p)):
            if surf.charted and np.max(np.abs(s[c, off : off + p])) > _CHART_LIMIT:
                chart, s_new = surf._new_chart(s[c, off : off + p], charts[c][side])
                charts[c][side] = chart
                s[c, off : off + p] = s_new


# ------------------------------------------------------------------ rows
def contact_rows(group: _Group, fr: _Frames, gi: _Geo, gj: _Geo, level: int, rolling: np.ndarray, Es: np.ndarray):
    """Reduced contact row and, with rolling, the rolling rows of every contact of a group.

    Returns a :class:`_Kin` with (k = contacts of the group):

    * ``value`` (k,) ``N^T C`` (the penetration ``-g``); ``gap`` (k,);
      ``normal`` (k, 3) unit outward normal of surface i; ``point_i``,
      ``point_j`` (k, 3);
    * ``N`` (k, r) the chapter's multipliers per unit normal force;
      ``rank`` (k,) the scaled volume of the columns of C_s;
    * level >= 1: ``J`` (k, 12) the row's coefficients of ``[R_dot_i,
      omega_i, R_dot_j, omega_j]`` (global omegas); ``Jr`` (k, p, 12) the
      rolling rows';
    * level >= 2: ``gamma`` (k,), ``gamma_r`` (k, p), ``sdot`` (k, 2p),
      ``rate`` (k,) ``d(N^T C)/dt`` (the penetration rate).
    """
    p = group.p
    k = group.k
    swap = group.swap
    out = _Kin()
    E, Es2, d, n_a, tb = _extremal(group, fr, gi, gj)
    del E, Es2
    n_i = gi.n
    nn = np.linalg.norm(n_i, axis=1)
    nhat = n_i / nn[:, None]
    # point-row directions P (k, 3, rp)
    if p == 2:
        P = np.broadcast_to(np.eye(3), (k, 3, 3))
    else:
        P = fr.A_i[:, :, :2]
    rp = P.shape[2]
    r = rp + p
    c = np.concatenate([np.einsum("kxq,kx->kq", P, d), np.einsum("kx,kxm->km", n_a, tb)], axis=1)
    Cs = np.empty((k, r, 2 * p))
    Cs[:, :rp, :p] = np.einsum("kxq,kxl->kql", P, gi.T)
    Cs[:, :rp, p:] = -np.einsum("kxq,kxl->kql", P, gj.T)
    Cs[:, rp:, :] = Es[:, p:, :]
    # left null vector by signed minors (generalized cross product)
    if p == 1:
        Nraw = _cross(Cs[:, :, 0], Cs[:, :, 1])
    else:
        Nraw = np.empty((k, 5))
        rows = np.arange(5)
        for q in range(5):
            Nraw[:, q] = (-1.0) ** q * np.linalg.det(Cs[:, rows != q, :])
    # rank indicator (Eq. 8.109): the same minors of C_s with rows and columns scaled
    L = group.L
    rs = np.empty((k, r))
    rs[:, :rp] = 1.0 / L[:, None]
    # point rows (a length per parameter) over L, normal rows (n_a . t_b over |n_a| |t_b|, a number per
    # parameter) as they are: the entries of a column then compare like L curvatures, whatever the units
    rs[:, rp:] = 1.0 / (np.linalg.norm(n_a, axis=1)[:, None] * np.linalg.norm(tb, axis=1))
    cn = np.linalg.norm(Cs * rs[:, :, None], axis=1)
    cs = 1.0 / np.where(cn > 0, cn, np.inf)
    prod_r = np.prod(rs, axis=1)[:, None] / rs
    out.rank = np.linalg.norm(Nraw * prod_r, axis=1) * np.prod(cs, axis=1)
    w_raw = np.einsum("kxq,kq->kx", P, Nraw[:, :rp])
    scale = _dot(w_raw, nhat)
    scale = np.where(scale != 0.0, scale, np.nan)
    N = Nraw / scale[:, None]
    out.N = N
    w = np.einsum("kxq,kq->kx", P, N[:, :rp])  # = nhat on the manifold
    out.value = _dot(N, c)
    out.gap = -_dot(nhat, d)
    out.normal = nhat
    out.point_i = fr.R_i + gi.rho
    out.point_j = fr.R_j + gj.rho
    out.c = c
    out.Cs = Cs
    if level < 1:
        return out
    # Jacobian of N^T C: point part w . (v_i^P - v_j^P) (+ rotation of P for curves), normal part
    m = _cross(n_a, np.einsum("kxm,km->kx", tb, N[:, rp:]))  # n_a x (t_b N_n)
    J = np.zeros((k, 12))
    J[:, 0:3] = w
    J[:, 3:6] = _cross(gi.rho, w)
    if p == 1:
        J[:, 3:6] += _cross(w, d)
    J[:, 6:9] = -w
    J[:, 9:12] = -_cross(gj.rho, w)
    sw = swap[:, None]
    J[:, 3:6] += np.where(sw, -m, m)
    J[:, 9:12] += np.where(sw, m, -m)
    out.J = J
    if rolling.any():  # unit tangents: the rows' residuals are slip speeds (m/s) whatever the parametrization
        Jr = np.zeros((k, p, 12))
        tbT = np.moveaxis(tb, 1, 2)  # (k, p, 3)
        units = tbT / np.linalg.norm(tbT, axis=2)[:, :, None]
        Jr[:, :, 0:3] = units
        Jr[:, :, 3:6] = _cross(gi.rho[:, None, :], units)
        Jr[:, :, 6:9] = -units
        Jr[:, :, 9:12] = -_cross(gj.rho[:, None, :], units)
        out.Jr = Jr
    else:
        out.Jr = None
    if level < 2:
        return out
    # s_dot from the extremal conditions: E_s s_dot = -E_q v
    vrel = (fr.V_i + _cross(fr.W_i, gi.rho)) - (fr.V_j + _cross(fr.W_j, gj.rho))  # material points
    W_a = _pick(swap, fr.W_i, fr.W_j)
    W_b = _pick(swap, fr.W_j, fr.W_i)
    tbT = np.moveaxis(tb, 1, 2)
    wtb = _cross(W_b[:, None, :], tbT)  # (k, p, 3) omega_b x t_bk
    Eq_t = np.einsum("kx,kmx->km", vrel, tbT) + np.einsum("kx,kmx->km", d, wtb)
    Eq_n = np.einsum("kx,kmx->km", _cross(W_a, n_a), tbT) + np.einsum("kx,kmx->km", n_a, wtb)
    Eqv = np.concatenate([Eq_t, Eq_n], axis=1)
    sdot = -np.linalg.solve(Es, Eqv[..., None])[..., 0]
    out.sdot = sdot
    sd_i, sd_j = sdot[:, :p], sdot[:, p:]
    sd_a = _pick(swap, sd_i, sd_j)
    sd_b = _pick(swap, sd_j, sd_i)
    Td_i = np.einsum("kxl,kl->kx", gi.T, sd_i)
    Td_j = np.einsum("kxl,kl->kx", gj.T, sd_j)
    ddot = vrel + Td_i - Td_j
    rq_i = _cross(fr.W_i, _cross(fr.W_i, gi.rho)) + 2.0 * _cross(fr.W_i, Td_i) + np.einsum(
        "kxlm,kl,km->kx", gi.T2, sd_i, sd_i)
    rq_j = _cross(fr.W_j, _cross(fr.W_j, gj.rho)) + 2.0 * _cross(fr.W_j, Td_j) + np.einsum(
        "kxlm,kl,km->kx", gj.T2, sd_j, sd_j)
    hp = np.einsum("kxq,kx->kq", P, rq_i - rq_j)
    if p == 1:
        PT = np.moveaxis(P, 1, 2)  # (k, 2, 3)
        wP = _cross(fr.W_i[:, None, :], PT)
        wwP = _cross(fr.W_i[:, None, :], wP)
        hp = hp + 2.0 * np.einsum("kqx,kx->kq", wP, ddot) + np.einsum("kqx,kx->kq", wwP, d)
    n1_a = _pick(swap, gi.n1, gj.n1)
    n2_a = _pick(swap, gi.n2, gj.n2)
    T2b = _pick(swap, gj.T2, gi.T2)
    T3b = _pick(swap, gj.T3, gi.T3)
    n1s = np.einsum("kxl,kl->kx", n1_a, sd_a)
    ndot = _cross(W_a, n_a) + n1s
    nq = _cross(W_a, _cross(W_a, n_a)) + 2.0 * _cross(W_a, n1s) + np.einsum("kxlm,kl,km->kx", n2_a, sd_a, sd_a)
    T2s = np.einsum("kxml,kl->kmx", T2b, sd_b)  # (k, p, 3): d t_bm / ds_b . sdot_b
    tdot = wtb + T2s
    tq = (_cross(W_b[:, None, :], wtb) + 2.0 * _cross(W_b[:, None, :], T2s)
          + np.einsum("kxmlo,kl,ko->kmx", T3b, sd_b, sd_b))
    hn = np.einsum("kx,kmx->km", nq, tbT) + 2.0 * np.einsum("kx,kmx->km", ndot, tdot) + np.einsum(
        "kx,kmx->km", n_a, tq)
    gamma_c = -np.concatenate([hp, hn], axis=1)
    out.gamma_c = gamma_c
    out.gamma = _dot(N, gamma_c)
    vel = np.concatenate([fr.V_i, fr.W_i, fr.V_j, fr.W_j], axis=1)
    out.rate = _dot(J, vel)
    if out.Jr is not None:
        wi = _cross(fr.W_i, _cross(fr.W_i, gi.rho) + Td_i)
        wj = _cross(fr.W_j, _cross(fr.W_j, gj.rho) + Td_j)
        hr = np.einsum("kmx,kx->km", tdot, vrel) + np.einsum("kmx,kx->km", tbT, wi - wj)
        # of the unit-tangent rows: d/dt (t / |t|) = (t_dot - t (t . t_dot) / |t|^2) / |t|
        tl2 = np.einsum("kmx,kmx->km", tbT, tbT)
        along = np.einsum("kmx,kmx->km", tbT, tdot) * np.einsum("kmx,kx->km", tbT, vrel) / tl2
        out.gamma_r = (along - hr) / np.sqrt(tl2)
    else:
        out.gamma_r = None
    return out
