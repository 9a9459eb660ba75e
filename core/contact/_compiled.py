"""Compiled contact kinematics of the built-in surfaces (numba, ``cache=True``): one contact per call.

The same arithmetic as the float path (``_scalar``: ``newton_one``,
``geometry_one``, ``evaluate_one`` and the surfaces' ``_derivs_float``), in
the same order, on the closed forms of :class:`~rigidlab.core.contact.Plane`,
:class:`~rigidlab.core.contact.Sphere`, :class:`~rigidlab.core.contact.Ellipsoid`,
:class:`~rigidlab.core.contact.Torus` and the built-in planar curves
(:meth:`~rigidlab.core.contact.PlanarCurve.circle`,
:meth:`~rigidlab.core.contact.PlanarCurve.line`). A planar curve of user callables
(a cam profile) takes the kernel too: Python evaluates its derivatives at
each Newton iterate and hands them in (status ``DERIVATIVES``, arrays ``X``
and ``xs``). A contact with a :class:`~rigidlab.core.contact.ParametricSurface` keeps
the float path.

One entry point, :func:`contact_packed`, does for one contact what the float
path does: Newton's method on the extremal conditions ``E(q, s) = 0`` for
the surface parameters (Eqs. 8.90-8.94 with ``d = r_i - r_j``; ``E_s`` from
the second derivatives of Eqs. 8.87-8.88), then the reduced contact row
``N^T C`` with ``N`` the left null vector of ``C_s`` (Eqs. 8.97, 8.105-8.107),
its Jacobian (scattered into the Newton-Euler row of the System), the rank
indicator of Eq. 8.109, ``s_dot`` from ``E_s s_dot = -E_q v`` and the
acceleration terms ``gamma`` (Eqs. 8.98-8.104, third derivatives of ``u``).

Data (all float64 unless said):

* ``desc`` (42,): ``p, swap, rim_i, rim_j, flat_i, flat_j, L, rolling,
  charted_i, charted_j`` then the two surfaces' descriptions (16 each, from
  :func:`describe`): a kind code and the closed form's constants.
* ``y`` (13n,) the System's state; ``A`` (n, 3, 3) its rotation matrices
  (the ground, body index ``n``, is the identity at the origin).
* ``charts`` (2, 3, 3): the chart rotations ``Q`` of a sphere's or an
  ellipsoid's parameters (the identity for the body's own parameters).
* ``s`` (2p,) the parameters: the start in, the solution out.
* ``ctl`` (int64, 16): ``mode, order, max_iter, it, cur, damped, outward,
  level, rank, gamma, n, b_i, b_j, status``; ``it`` and ``cur`` are read
  and written (a Newton run handed back for a new chart resumes there).
* ``G`` (2, 22, 3) the global geometry of both sides (rows :data:`RHO`,
  :data:`T`, :data:`T2`, :data:`T3`, :data:`NN`, :data:`N1`, :data:`N2`) and
  ``Es`` (4, 4): written by Newton (mode 0) and by a geometry at fixed
  ``s`` (mode 1), read by the rows (mode 2: from the given ones).
* ``out`` (48,): the results at the offsets named ``O_*``; ``D_row`` (6n,)
  and ``Dr_rows`` (2, 6n): the contact's and the rolling rows (their blocks
  of the contact's bodies are written).
* ``X`` (2, 2, 4, 3) and ``xs`` (2, 2): per side, a user curve's derivatives
  ``c^(k)`` and its normal field's (``c^(k+1) x e_z``), lifted to 3-vectors,
  and the parameter and order they are of.

Every kernel runs without the GIL (``nogil=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# statuses
OK, SINGULAR, NOT_FINITE, NOT_FACING, NO_CONVERGENCE, RECHART, SINGULAR_RATE, DERIVATIVES = 0, 1, 2, 3, 4, 5, 6, 7
# surface kinds (CURVE: a planar curve of user callables, whose derivatives Python hands in)
PLANE, QUADRIC, TORUS, CIRCLE, LINE, CURVE = 0, 1, 2, 3, 4, 5
# rows of G
RHO, T, T2, T3, NN, N1, N2 = 0, 1, 3, 7, 15, 16, 18
# ctl
C_MODE, C_ORDER, C_MAXIT, C_IT, C_CUR, C_DAMPED, C_OUTWARD, C_LEVEL, C_RANK, C_GAMMA, C_N, C_BI, C_BJ, C_STATUS = \
    range(14)
# out
O_VALUE, O_GAP, O_NORMAL, O_PI, O_PJ, O_RANK, O_N, O_SDOT, O_RATE, O_GAMMA, O_GAMMA_C, O_GAMMA_R, O_SIGN, \
    O_UI, O_UJ, O_STEP = 0, 1, 2, 5, 8, 11, 12, 17, 21, 22, 23, 28, 30, 31, 34, 37
OUT_SIZE = 48
DESC_SIZE = 42

_STEP_TOL = 1e-11  # (= _errors._STEP_TOL)
_CHART_LIMIT = 1.0  # (= _errors._CHART_LIMIT)


def describe(surface):
    """(16,) description of a surface for the kernel (a planar curve of user callables: the kind ``CURVE``,
    its derivatives handed in), or None (a :class:`~rigidlab.core.contact.ParametricSurface`: the float path)."""
    from ._curves import PlanarCurve
    from ._surfaces import Ellipsoid, Plane, Sphere, Torus

    d = np.zeros(16)
    kind = type(surface)
    if kind is Plane:
        d[0] = PLANE
        d[1:4] = surface.origin
        d[4:7] = surface.axes[:, 0]
        d[7:10] = surface.axes[:, 1]
    elif kind is Sphere or kind is Ellipsoid:
        d[0] = QUADRIC
        d[1:4] = surface._centre_float
        d[4:7] = surface._S_float
    elif kind is Torus:
        d[0] = TORUS
        d[1:4] = surface.centre
        d[4] = surface.major_radius
        d[5] = surface.minor_radius
    elif kind is PlanarCurve and getattr(surface, "_builtin", None) is not None:
        b = surface._builtin
        d[0] = CIRCLE if b[0] == "circle" else LINE
        d[1 : 1 + len(b) - 1] = b[1:]
    elif isinstance(surface, PlanarCurve):  # its point and derivatives from Python, per Newton iterate
        d[0] = CURVE
    else:
        return None
    return d


def description(contact):
    """(42,) description of a contact for the kernel, or None when a side is a ParametricSurface."""
    di, dj = describe(contact.surface_i), describe(contact.surface_j)
    if di is None or dj is None:
        return None
    si, sj = contact.surface_i, contact.surface_j
    L = min(si.length_scale, sj.length_scale)
    head = [contact.n_parameters, bool(sj.degenerate_tangents), bool(si.degenerate_tangents),
            bool(sj.degenerate_tangents), bool(si.unbounded), bool(sj.unbounded),
            float(L) if math.isfinite(L) else 1.0, bool(contact.rolling), bool(si.charted), bool(sj.charted)]
    out = np.zeros(DESC_SIZE)
    out[:10] = head
    out[10:26] = di
    out[26:42] = dj
    return out


# ---------------------------------------------------------------- small algebra on 3-tuples
@njit(cache=True, nogil=True, error_model="numpy")
def _v(G, side, row):
    return (G[side, row, 0], G[side, row, 1], G[side, row, 2])


@njit(cache=True, nogil=True, error_model="numpy")
def _put(G, side, row, a):
    G[side, row, 0] = a[0]
    G[side, row, 1] = a[1]
    G[side, row, 2] = a[2]


@njit(cache=True, nogil=True, error_model="numpy")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, nogil=True, error_model="numpy")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, nogil=True, error_model="numpy")
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _mul(k, a):
    return (k * a[0], k * a[1], k * a[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _axpy(k, a, b):  # k a + b
    return (k * a[0] + b[0], k * a[1] + b[1], k * a[2] + b[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _neg(a):
    return (-a[0], -a[1], -a[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _rot(A, v):  # A v, A (3, 3)
    return (A[0, 0] * v[0] + A[0, 1] * v[1] + A[0, 2] * v[2], A[1, 0] * v[0] + A[1, 1] * v[1] + A[1, 2] * v[2],
            A[2, 0] * v[0] + A[2, 1] * v[1] + A[2, 2] * v[2])


@njit(cache=True, nogil=True, error_model="numpy")
def _rotT(A, v):  # A^T v
    return (A[0, 0] * v[0] + A[1, 0] * v[1] + A[2, 0] * v[2], A[0, 1] * v[0] + A[1, 1] * v[1] + A[2, 1] * v[2],
            A[0, 2] * v[0] + A[1, 2] * v[1] + A[2, 2] * v[2])


# ---------------------------------------------------------------- surfaces (Eqs. 8.84-8.89)
@njit(cache=True, nogil=True, error_model="numpy")
def _trig(x, k):
    """``cos(x + k pi/2)``, ``sin(x + k pi/2)`` as ``_surfaces._trig_cycle``."""
    c, s = math.cos(x), math.sin(x)
    if k == 0:
        return c, s
    if k == 1:
        return -s, c
    if k == 2:
        return -c, -s
    return s, -c


@njit(cache=True, nogil=True, error_model="numpy")
def _derivs(sd, x0, x1, Q, order, Db, Dn, X):
    """Body-frame derivatives ``Db[a, b] = d^(a+b) u / ds1^a ds2^b`` (curves: ``Db[k, 0]``) up to ``order``;
    the normal field's ``Dn`` up to ``order - 1`` where the surface gives it. Returns whether it does.
    ``X`` (2, 4, 3): a user curve's derivatives and its normal field's, handed in by Python."""
    kind = int(sd[0])
    if kind == 5:
        for k in range(order + 1):
            for c in range(3):
                Db[k, 0, c] = X[0, k, c]
                if k < order:
                    Dn[k, 0, c] = X[1, k, c]
        return True
    if kind == 0:  # plane: u = o + s1 e1 + s2 e2; nu = e1 x e2 from the rotated tangents
        for a in range(order + 1):
            for b in range(order + 1 - a):
                for k in range(3):
                    Db[a, b, k] = 0.0
        for k in range(3):
            Db[0, 0, k] = sd[1 + k] + x0 * sd[4 + k] + x1 * sd[7 + k]
            if order >= 1:
                Db[1, 0, k] = sd[4 + k]
                Db[0, 1, k] = sd[7 + k]
        return False
    if kind == 1:  # sphere, ellipsoid: u = c + S Q e0(s)
        m00, m01, m02 = sd[4] * Q[0, 0], sd[4] * Q[0, 1], sd[4] * Q[0, 2]
        m10, m11, m12 = sd[5] * Q[1, 0], sd[5] * Q[1, 1], sd[5] * Q[1, 2]
        m20, m21, m22 = sd[6] * Q[2, 0], sd[6] * Q[2, 1], sd[6] * Q[2, 2]
        for a in range(order + 1):
            c1, s1 = _trig(x0, a)
            for b in range(order + 1 - a):
                c2, s2 = _trig(x1, b)
                x = c2 * c1
                y = c2 * s1
                z = s2 if a == 0 else 0.0
                Db[a, b, 0] = m00 * x + m01 * y + m02 * z
                Db[a, b, 1] = m10 * x + m11 * y + m12 * z
                Db[a, b, 2] = m20 * x + m21 * y + m22 * z
        for k in range(3):
            Db[0, 0, k] = Db[0, 0, k] + sd[1 + k]
        return False
    if kind == 2:  # torus: u = c + (R + r cos psi) e_r(phi) + r sin psi e_y; nu = cos psi e_r + sin psi e_y
        R, r = sd[4], sd[5]
        for a in range(order + 1):
            cp, sp = _trig(x0, a)
            for b in range(order + 1 - a):
                cq, sq = _trig(x1, b)
                rad = (R if b == 0 else 0.0) + r * cq
                ex, ez = cp, -sp
                Db[a, b, 0] = rad * ex
                Db[a, b, 1] = r * sq if a == 0 else 0.0
                Db[a, b, 2] = rad * ez
                if a + b < order:
                    Dn[a, b, 0] = cq * ex
                    Dn[a, b, 1] = sq if a == 0 else 0.0
                    Dn[a, b, 2] = cq * ez
        for k in range(3):
            Db[0, 0, k] = Db[0, 0, k] + sd[1 + k]
        return True
    if kind == 3:  # circle c(phi) = c0 + rho (cos phi, sin phi); nu = c' x e_z
        rho = sd[3]
        for k in range(order + 1):
            c, s = _trig(x0, k)
            if k == 0:
                vx, vy = sd[1] + rho * c, sd[2] + rho * s
            else:
                vx, vy = rho * c, rho * s
            Db[k, 0, 0], Db[k, 0, 1], Db[k, 0, 2] = vx, vy, 0.0
            if k >= 1:
                Dn[k - 1, 0, 0], Dn[k - 1, 0, 1], Dn[k - 1, 0, 2] = vy, -vx, 0.0
        return True
    # line c(s) = p0 + s d
    for k in range(order + 1):
        if k == 0:
            vx, vy = sd[1] + x0 * sd[3], sd[2] + x0 * sd[4]
        elif k == 1:
            vx, vy = sd[3], sd[4]
        else:
            vx, vy = 0.0, 0.0
        Db[k, 0, 0], Db[k, 0, 1], Db[k, 0, 2] = vx, vy, 0.0
        if k >= 1:
            Dn[k - 1, 0, 0], Dn[k - 1, 0, 1], Dn[k - 1, 0, 2] = vy, -vx, 0.0
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _k1(p, l):
    """(a, b) orders of the first derivative along parameter l."""
    if p == 1:
        return 1, 0
    return (1, 0) if l == 0 else (0, 1)


@njit(cache=True, nogil=True, error_model="numpy")
def _k2(p, l, m):
    if p == 1:
        return 2, 0
    a = (l == 0) + (m == 0)
    return a, 2 - a


@njit(cache=True, nogil=True, error_model="numpy")
def _k3(p, l, m, o):
    if p == 1:
        return 3, 0
    a = (l == 0) + (m == 0) + (o == 0)
    return a, 3 - a


@njit(cache=True, nogil=True, error_model="numpy")
def _dv(D, ab):
    return (D[ab[0], ab[1], 0], D[ab[0], ab[1], 1], D[ab[0], ab[1], 2])


@njit(cache=True, nogil=True, error_model="numpy")
def _glob(sd, x0, x1, Q, A, p, order, G, side, Db, Dn, X):
    """Global geometry of one side into ``G[side]`` (as ``_scalar._glob``): ``rho``, tangents and their
    derivatives up to ``order``, the normal field and its derivatives up to ``order - 1`` (Eqs. 8.84-8.89)."""
    has_dn = _derivs(sd, x0, x1, Q, order, Db, Dn, X)
    _put(G, side, RHO, _rot(A, _dv(Db, (0, 0))))
    for l in range(p):
        _put(G, side, T + l, _rot(A, _dv(Db, _k1(p, l))))
        if order >= 2:
            for m in range(p):
                _put(G, side, T2 + 2 * l + m, _rot(A, _dv(Db, _k2(p, l, m))))
                if order >= 3:
                    for o in range(p):
                        _put(G, side, T3 + 4 * l + 2 * m + o, _rot(A, _dv(Db, _k3(p, l, m, o))))
    if has_dn:
        _put(G, side, NN, _rot(A, _dv(Dn, (0, 0))))
        if order >= 2:
            for l in range(p):
                _put(G, side, N1 + l, _rot(A, _dv(Dn, _k1(p, l))))
                if order >= 3:
                    for m in range(p):
                        _put(G, side, N2 + 2 * l + m, _rot(A, _dv(Dn, _k2(p, l, m))))
        return
    # nu = t1 x t2 (Eq. 8.86) of the rotated tangents, and its derivatives by the product rule
    t0, t1 = _v(G, side, T), _v(G, side, T + 1)
    _put(G, side, NN, _cross(t0, t1))
    if order >= 2:
        for l in range(2):
            _put(G, side, N1 + l, _add(_cross(_v(G, side, T2 + l), t1), _cross(t0, _v(G, side, T2 + 2 + l))))
    if order >= 3:
        for l in range(2):
            for m in range(l, 2):
                v = _add(_add(_cross(_v(G, side, T3 + 2 * l + m), t1),
                              _cross(_v(G, side, T2 + l), _v(G, side, T2 + 2 + m))),
                         _add(_cross(_v(G, side, T2 + m), _v(G, side, T2 + 2 + l)),
                              _cross(t0, _v(G, side, T3 + 4 + 2 * l + m))))
                _put(G, side, N2 + 2 * l + m, v)
                _put(G, side, N2 + 2 * m + l, v)


# ---------------------------------------------------------------- extremal conditions and Newton
@njit(cache=True, nogil=True, error_model="numpy")
def _extremal(p, swap, Ri, Rj, G, E, Es):
    """``E`` (2p,) and ``E_s`` (2p, 2p) of the extremal conditions (as ``_scalar._extremal``)."""
    a, b = (1, 0) if swap else (0, 1)
    d = _sub(_add(Ri, _v(G, 0, RHO)), _add(Rj, _v(G, 1, RHO)))
    n_a = _v(G, a, NN)
    for m in range(p):
        tbm = _v(G, b, T + m)
        E[m] = _dot(d, tbm)
        E[p + m] = _dot(n_a, tbm)
        for l in range(p):
            v = _dot(tbm, _v(G, 0, T + l))
            if swap:
                v += _dot(d, _v(G, b, T2 + 2 * m + l))
            Es[m, l] = v
        for l in range(p):
            v = -_dot(tbm, _v(G, 1, T + l))
            if not swap:
                v += _dot(d, _v(G, b, T2 + 2 * m + l))
            Es[m, p + l] = v
        for l in range(p):
            colA = _dot(tbm, _v(G, a, N1 + l))
            colB = _dot(n_a, _v(G, b, T2 + 2 * m + l))
            if swap:
                Es[p + m, l] = colB
                Es[p + m, p + l] = colA
            else:
                Es[p + m, l] = colA
                Es[p + m, p + l] = colB
    return d


@njit(cache=True, nogil=True, error_model="numpy")
def _solve(M, b, n, x):
    """``M x = b`` (n = 2: Cramer's rule; else Gaussian elimination with partial pivoting, as
    ``_scalar._solve``); False if singular."""
    if n == 2:
        a, c, d, e = M[0, 0], M[0, 1], M[1, 0], M[1, 1]
        det = a * e - c * d
        if not (abs(det) > 0.0 and math.isfinite(det)):
            return False
        x[0] = (b[0] * e - c * b[1]) / det
        x[1] = (a * b[1] - d * b[0]) / det
        return True
    W = np.empty((n, n + 1))
    for i in range(n):
        for j in range(n):
            W[i, j] = M[i, j]
        W[i, n] = b[i]
    for col in range(n):
        piv = col
        big = abs(W[col, col])
        for r in range(col + 1, n):
            v = abs(W[r, col])
            if v > big:
                piv, big = r, v
        if not (big > 0.0 and math.isfinite(big)):
            return False
        if piv != col:
            for q in range(n + 1):
                W[col, q], W[piv, q] = W[piv, q], W[col, q]
        inv = 1.0 / W[col, col]
        for r in range(col + 1, n):
            f = W[r, col] * inv
            if f != 0.0:
                for q in range(col, n + 1):
                    W[r, q] -= f * W[col, q]
    for r in range(n - 1, -1, -1):
        acc = W[r, n]
        for q in range(r + 1, n):
            acc -= W[r, q] * x[q]
        x[r] = acc / W[r, r]
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _det4(M):
    """Determinant of a 4 x 4 matrix (Laplace expansion by the first two rows, as ``_scalar._det4``)."""
    s0 = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    s1 = M[0, 0] * M[1, 2] - M[0, 2] * M[1, 0]
    s2 = M[0, 0] * M[1, 3] - M[0, 3] * M[1, 0]
    s3 = M[0, 1] * M[1, 2] - M[0, 2] * M[1, 1]
    s4 = M[0, 1] * M[1, 3] - M[0, 3] * M[1, 1]
    s5 = M[0, 2] * M[1, 3] - M[0, 3] * M[1, 2]
    c5 = M[2, 2] * M[3, 3] - M[2, 3] * M[3, 2]
    c4 = M[2, 1] * M[3, 3] - M[2, 3] * M[3, 1]
    c3 = M[2, 1] * M[3, 2] - M[2, 2] * M[3, 1]
    c2 = M[2, 0] * M[3, 3] - M[2, 3] * M[3, 0]
    c1 = M[2, 0] * M[3, 2] - M[2, 2] * M[3, 0]
    c0 = M[2, 0] * M[3, 1] - M[2, 1] * M[3, 0]
    return s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0


@njit(cache=True, nogil=True, error_model="numpy")
def _body(y, A, n, b, level):
    """Rotation matrix, position, velocity and global omega of body b (the ground: b == n)."""
    if b >= n:
        I = np.eye(3)
        z = (0.0, 0.0, 0.0)
        return I, z, z, z
    Ab = A[b]
    R = (y[3 * b], y[3 * b + 1], y[3 * b + 2])
    if level >= 2:
        V = (y[7 * n + 3 * b], y[7 * n + 3 * b + 1], y[7 * n + 3 * b + 2])
        W = _rot(Ab, (y[10 * n + 3 * b], y[10 * n + 3 * b + 1], y[10 * n + 3 * b + 2]))
    else:
        V = (0.0, 0.0, 0.0)
        W = (0.0, 0.0, 0.0)
    return Ab, R, V, W


@njit(cache=True, nogil=True, error_model="numpy")
def _handed_in(desc, p, s, order, xs, ctl, it, cur):
    """False (status DERIVATIVES) when a user curve's derivatives are not those at ``s`` up to ``order``."""
    for side in range(2):
        if desc[10 + 16 * side] == 5.0 and not (xs[side, 0] == s[side * p] and xs[side, 1] >= order):
            ctl[C_IT] = it
            ctl[C_CUR] = cur
            ctl[C_STATUS] = DERIVATIVES
            return False
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _newton(desc, Ai, Aj, Ri, Rj, charts, s, ctl, G, Es, out, X, xs):
    """Newton on the extremal conditions (as ``_scalar.newton_one``); the status into ``ctl``."""
    p = int(desc[0])
    swap = desc[1] != 0.0
    rim = (desc[2] != 0.0, desc[3] != 0.0)
    flat = (desc[4] != 0.0, desc[5] != 0.0)
    L = desc[6]
    charted = (desc[8] != 0.0, desc[9] != 0.0)
    sdi, sdj = desc[10:26], desc[26:42]
    order = ctl[C_ORDER]
    cur = ctl[C_CUR]
    damped = ctl[C_DAMPED] != 0
    outward = ctl[C_OUTWARD] != 0
    E = np.empty(4)
    ds = np.empty(4)
    Db = np.zeros((4, 4, 3))
    Dn = np.zeros((4, 4, 3))
    step = math.inf
    out[O_STEP] = step
    for it in range(ctl[C_IT], ctl[C_MAXIT]):
        if charted[0] or charted[1]:  # a point beyond the chart's central region: Python re-centres it
            for side in range(2):
                if charted[side] and max(abs(s[side * p]), abs(s[side * p + 1])) > _CHART_LIMIT:
                    ctl[C_IT] = it
                    ctl[C_CUR] = cur
                    ctl[C_STATUS] = RECHART
                    return
        if not _handed_in(desc, p, s, cur, xs, ctl, it, cur):
            return
        _glob(sdi, s[0], s[1] if p == 2 else 0.0, charts[0], Ai, p, cur, G, 0, Db, Dn, X[0])
        _glob(sdj, s[p], s[p + 1] if p == 2 else 0.0, charts[1], Aj, p, cur, G, 1, Db, Dn, X[1])
        _extremal(p, swap, Ri, Rj, G, E, Es)
        if not _solve(Es, E, 2 * p, ds):
            ctl[C_STATUS] = SINGULAR
            return
        step = 0.0
        curved = 0.0
        for side in range(2):
            off = side * p
            for l in range(p):
                sc = _norm(_v(G, side, T + l))
                if rim[side]:
                    x = L * _norm(_v(G, side, N1 + l)) / _norm(_v(G, side, NN))
                    if x > sc:
                        sc = x
                x = abs(ds[off + l]) * sc
                if x > step:
                    step = x
                if not flat[side] and x > curved:
                    curved = x
        step /= L
        curved /= L
        out[O_STEP] = step
        if not math.isfinite(step):
            ctl[C_STATUS] = NOT_FINITE
            return
        lim = 0.25 if damped else 0.5
        f = lim / curved if curved > lim else 1.0
        fi = 1.0 if flat[0] else f
        fj = 1.0 if flat[1] else f
        for q in range(p):
            s[q] -= fi * ds[q]
        for q in range(p, 2 * p):
            s[q] -= fj * ds[q]
        if step <= _STEP_TOL:
            if cur < order:  # one more evaluation, with the third derivatives
                cur = order
                continue
            facing = _dot(_v(G, 0, NN), _v(G, 1, NN)) < 0.0
            if outward and ((rim[0] and not math.cos(s[1]) > 0.0) or (rim[1] and not math.cos(s[p + 1]) > 0.0)):
                facing = False
            ctl[C_IT] = it + 1
            ctl[C_CUR] = cur
            ctl[C_STATUS] = OK if facing else NOT_FACING
            return
        if step <= 1e-5:
            cur = order
    ctl[C_STATUS] = NO_CONVERGENCE


@njit(cache=True, nogil=True, error_model="numpy")
def _rows(desc, Ai, Aj, Ri, Rj, Vi, Vj, Wi, Wj, G, Es, level, want_rank, want_gamma, out, n, bi, bj, D_row,
          Dr_rows):
    """Reduced row, rolling rows and their terms (as ``_scalar.evaluate_one``); False: E_s singular."""
    p = int(desc[0])
    swap = desc[1] != 0.0
    L = desc[6]
    rolling = desc[7] != 0.0
    a, b = (1, 0) if swap else (0, 1)
    rho_i, rho_j = _v(G, 0, RHO), _v(G, 1, RHO)
    d = _sub(_add(Ri, rho_i), _add(Rj, rho_j))
    n_a = _v(G, a, NN)
    n_i = _v(G, 0, NN)
    nn = _norm(n_i)
    nhat = _mul(1.0 / nn, n_i)
    P = np.zeros((3, 3))  # rows: the point rows' directions
    if p == 2:
        rp = 3
        P[0, 0] = P[1, 1] = P[2, 2] = 1.0
    else:
        rp = 2
        for k in range(3):
            P[0, k] = Ai[k, 0]
            P[1, k] = Ai[k, 1]
    r = rp + p
    c = np.empty(5)
    Cs = np.empty((5, 4))
    for q in range(rp):
        e = (P[q, 0], P[q, 1], P[q, 2])
        c[q] = _dot(e, d)
        for l in range(p):
            Cs[q, l] = _dot(e, _v(G, 0, T + l))
            Cs[q, p + l] = -_dot(e, _v(G, 1, T + l))
    for m in range(p):
        c[rp + m] = _dot(n_a, _v(G, b, T + m))
        for l in range(2 * p):
            Cs[rp + m, l] = Es[p + m, l]
    Nraw = np.empty(5)
    if p == 1:
        v = _cross((Cs[0, 0], Cs[1, 0], Cs[2, 0]), (Cs[0, 1], Cs[1, 1], Cs[2, 1]))
        Nraw[0], Nraw[1], Nraw[2] = v[0], v[1], v[2]
    else:
        minor = np.empty((4, 4))
        for q in range(5):
            x = 0
            for row in range(5):
                if row != q:
                    for col in range(4):
                        minor[x, col] = Cs[row, col]
                    x += 1
            Nraw[q] = (-1.0 if q % 2 else 1.0) * _det4(minor)
    if want_rank:  # rank indicator (Eq. 8.109)
        rs = np.empty(5)
        for q in range(rp):
            rs[q] = 1.0 / L
        for m in range(p):
            rs[rp + m] = 1.0 / (_norm(n_a) * _norm(_v(G, b, T + m)))
        prod_cs = 1.0
        for col in range(2 * p):
            acc = 0.0
            for x in range(r):
                u = Cs[x, col] * rs[x]
                acc += u * u
            v_ = math.sqrt(acc)
            prod_cs = prod_cs / v_ if v_ > 0 else 0.0
        prod_rs = 1.0
        for x in range(r):
            prod_rs *= rs[x]
        acc = 0.0
        for x in range(r):
            u = Nraw[x] * prod_rs / rs[x]
            acc += u * u
        out[O_RANK] = math.sqrt(acc) * prod_cs
    else:
        out[O_RANK] = math.nan
    w_raw = (0.0, 0.0, 0.0)
    for q in range(rp):
        w_raw = _axpy(Nraw[q], (P[q, 0], P[q, 1], P[q, 2]), w_raw)
    scale = _dot(w_raw, nhat)
    N = np.empty(5)
    value = 0.0
    for x in range(r):
        N[x] = Nraw[x] / scale if scale != 0.0 else math.nan
        out[O_N + x] = N[x]
        value += N[x] * c[x]
    w = _mul(1.0 / scale, w_raw) if scale != 0.0 else (math.nan, math.nan, math.nan)
    out[O_VALUE] = value
    out[O_GAP] = -_dot(nhat, d)
    pi_, pj_ = _add(Ri, rho_i), _add(Rj, rho_j)
    ui, uj = _rotT(Ai, rho_i), _rotT(Aj, rho_j)
    for k in range(3):
        out[O_NORMAL + k] = nhat[k]
        out[O_PI + k] = pi_[k]
        out[O_PJ + k] = pj_[k]
        out[O_UI + k] = ui[k]
        out[O_UJ + k] = uj[k]
    if level < 1:
        return True
    tN = (0.0, 0.0, 0.0)
    for m in range(p):
        tN = _axpy(N[rp + m], _v(G, b, T + m), tN)
    mm = _cross(n_a, tN)
    Wi_c = _cross(rho_i, w)
    if p == 1:
        Wi_c = _add(Wi_c, _cross(w, d))
    Wj_c = _neg(_cross(rho_j, w))
    if swap:
        Wi_c, Wj_c = _sub(Wi_c, mm), _add(Wj_c, mm)
    else:
        Wi_c, Wj_c = _add(Wi_c, mm), _sub(Wj_c, mm)
    _scatter(D_row, n, bi, bj, Ai, Aj, w, Wi_c, _neg(w), Wj_c)
    if rolling:  # unit tangents: the rows' residuals are slip speeds (m/s)
        for m in range(p):
            tbm = _v(G, b, T + m)
            u = _mul(1.0 / _norm(tbm), tbm)
            _scatter(Dr_rows[m], n, bi, bj, Ai, Aj, u, _cross(rho_i, u), _neg(u), _neg(_cross(rho_j, u)))
    if level < 2:
        return True
    vrel = _sub(_add(Vi, _cross(Wi, rho_i)), _add(Vj, _cross(Wj, rho_j)))
    W_a, W_b = (Wj, Wi) if swap else (Wi, Wj)
    Wn = _cross(W_a, n_a)
    Eq = np.empty(4)
    wtb = np.empty((2, 3))
    for m in range(p):
        tbm = _v(G, b, T + m)
        x = _cross(W_b, tbm)
        wtb[m, 0], wtb[m, 1], wtb[m, 2] = x[0], x[1], x[2]
        Eq[m] = _dot(vrel, tbm) + _dot(d, x)
        Eq[p + m] = _dot(Wn, tbm) + _dot(n_a, x)
    sd = np.empty(4)
    if not _solve(Es, Eq, 2 * p, sd):
        return False
    for x in range(2 * p):
        sd[x] = -sd[x]
        out[O_SDOT + x] = sd[x]
    out[O_RATE] = _dot(w, Vi) + _dot(Wi_c, Wi) + _dot(_neg(w), Vj) + _dot(Wj_c, Wj)
    if not want_gamma:
        return True
    oa, ob = (p, 0) if swap else (0, p)  # offsets of sd_a, sd_b
    Td_i = (0.0, 0.0, 0.0)
    Td_j = (0.0, 0.0, 0.0)
    for l in range(p):
        Td_i = _axpy(sd[l], _v(G, 0, T + l), Td_i)
        Td_j = _axpy(sd[p + l], _v(G, 1, T + l), Td_j)
    ddot = _sub(_add(vrel, Td_i), Td_j)
    qi = (0.0, 0.0, 0.0)
    qj = (0.0, 0.0, 0.0)
    for l in range(p):
        for m in range(p):
            qi = _axpy(sd[l] * sd[m], _v(G, 0, T2 + 2 * l + m), qi)
            qj = _axpy(sd[p + l] * sd[p + m], _v(G, 1, T2 + 2 * l + m), qj)
    rq_i = _add(_add(_cross(Wi, _cross(Wi, rho_i)), _mul(2.0, _cross(Wi, Td_i))), qi)
    rq_j = _add(_add(_cross(Wj, _cross(Wj, rho_j)), _mul(2.0, _cross(Wj, Td_j))), qj)
    dq = _sub(rq_i, rq_j)
    gam = np.empty(5)
    for q in range(rp):
        e = (P[q, 0], P[q, 1], P[q, 2])
        h = _dot(e, dq)
        if p == 1:
            wP = _cross(Wi, e)
            h += 2.0 * _dot(wP, ddot) + _dot(_cross(Wi, wP), d)
        gam[q] = h
    n1s = (0.0, 0.0, 0.0)
    for l in range(p):
        n1s = _axpy(sd[oa + l], _v(G, a, N1 + l), n1s)
    ndot = _add(Wn, n1s)
    qn = (0.0, 0.0, 0.0)
    for l in range(p):
        for m in range(p):
            qn = _axpy(sd[oa + l] * sd[oa + m], _v(G, a, N2 + 2 * l + m), qn)
    nq = _add(_add(_cross(W_a, Wn), _mul(2.0, _cross(W_a, n1s))), qn)
    tdot = np.empty((2, 3))
    for m in range(p):
        T2s = (0.0, 0.0, 0.0)
        for l in range(p):
            T2s = _axpy(sd[ob + l], _v(G, b, T2 + 2 * m + l), T2s)
        wtbm = (wtb[m, 0], wtb[m, 1], wtb[m, 2])
        td = _add(wtbm, T2s)
        tdot[m, 0], tdot[m, 1], tdot[m, 2] = td[0], td[1], td[2]
        qt = (0.0, 0.0, 0.0)
        for l in range(p):
            for o in range(p):
                qt = _axpy(sd[ob + l] * sd[ob + o], _v(G, b, T3 + 4 * m + 2 * l + o), qt)
        tq = _add(_add(_cross(W_b, wtbm), _mul(2.0, _cross(W_b, T2s))), qt)
        gam[rp + m] = _dot(nq, _v(G, b, T + m)) + 2.0 * _dot(ndot, td) + _dot(n_a, tq)
    g = 0.0
    for x in range(r):
        gam[x] = -gam[x]
        out[O_GAMMA_C + x] = gam[x]
        g += N[x] * gam[x]
    out[O_GAMMA] = g
    if rolling:
        wi = _cross(Wi, _add(_cross(Wi, rho_i), Td_i))
        wj = _cross(Wj, _add(_cross(Wj, rho_j), Td_j))
        dw = _sub(wi, wj)
        # of the unit-tangent rows: d/dt (t / |t|) = (t_dot - t (t . t_dot) / |t|^2) / |t|
        for m in range(p):
            tbm = _v(G, b, T + m)
            tdm = (tdot[m, 0], tdot[m, 1], tdot[m, 2])
            tl2 = _dot(tbm, tbm)
            out[O_GAMMA_R + m] = ((-(_dot(tdm, vrel) + _dot(tbm, dw)) + _dot(tbm, tdm) * _dot(tbm, vrel) / tl2)
                                  / math.sqrt(tl2))
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _scatter(row, n, bi, bj, Ai, Aj, J0, J1, J2, J3):
    """A row's coefficients (global omegas) into a Newton-Euler row (body-frame omegas: ``A^T c``)."""
    if bi < n:  # (written, not added: a call again after another branch was refused writes the same blocks)
        x = _rotT(Ai, J1)
        for k in range(3):
            row[3 * bi + k] = J0[k]
            row[3 * n + 3 * bi + k] = x[k]
    if bj < n:
        x = _rotT(Aj, J3)
        for k in range(3):
            row[3 * bj + k] = J2[k]
            row[3 * n + 3 * bj + k] = x[k]


@njit(cache=True, nogil=True, error_model="numpy")
def contact_packed(desc, y, A, charts, s, ctl, G, Es, out, D_row, Dr_rows, X, xs):
    """One contact: Newton (mode 0), the geometry at ``s`` (mode 1) or neither (mode 2), then the rows.

    ``ctl[C_LEVEL] < 0``: no rows. The status (``OK``, a Newton failure,
    ``RECHART`` or ``SINGULAR_RATE``) is left in ``ctl[C_STATUS]``; see the
    module docstring for the arrays.
    """
    mode = ctl[C_MODE]
    level = ctl[C_LEVEL]
    n, bi, bj = ctl[C_N], ctl[C_BI], ctl[C_BJ]
    p = int(desc[0])
    Ai, Ri, Vi, Wi = _body(y, A, n, bi, level)
    Aj, Rj, Vj, Wj = _body(y, A, n, bj, level)
    ctl[C_STATUS] = OK
    if mode == 0:
        _newton(desc, Ai, Aj, Ri, Rj, charts, s, ctl, G, Es, out, X, xs)
        if ctl[C_STATUS] != OK:
            return
    elif mode == 1:
        Db = np.zeros((4, 4, 3))
        Dn = np.zeros((4, 4, 3))
        order = ctl[C_ORDER]
        if not _handed_in(desc, p, s, order, xs, ctl, 0, order):
            return
        _glob(desc[10:26], s[0], s[1] if p == 2 else 0.0, charts[0], Ai, p, order, G, 0, Db, Dn, X[0])
        _glob(desc[26:42], s[p], s[p + 1] if p == 2 else 0.0, charts[1], Aj, p, order, G, 1, Db, Dn, X[1])
        E = np.empty(4)
        _extremal(p, desc[1] != 0.0, Ri, Rj, G, E, Es)
    if p == 1:
        d = Es[0, 0] * Es[1, 1] - Es[0, 1] * Es[1, 0]
    else:
        d = _det4(Es)
    out[O_SIGN] = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
    if level < 0:
        return
    if not _rows(desc, Ai, Aj, Ri, Rj, Vi, Vj, Wi, Wj, G, Es, level, ctl[C_RANK] != 0, ctl[C_GAMMA] != 0, out,
                 n, bi, bj, D_row, Dr_rows):
        ctl[C_STATUS] = SINGULAR_RATE
