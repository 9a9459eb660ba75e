"""Compiled model of a System: batched constraint, force and solve kernels.

An :class:`_Engine` is built from a System's items when the System first
needs it after a change (a constant snapshot of the model; the state is
passed in as arrays). It holds constant selection matrices, index arrays
and work arrays so that one evaluation of the equations of motion is a
fixed sequence of about forty numpy calls, whatever the number of joints:
no Python loop runs per joint or per body.

State layout (``n`` bodies, ground excluded)::

    y = [R (3n) | p (4n) | R_dot (3n) | omega_body (3n)]      (13n,)
    q = y[:7n]     v = y[7n:]  (Newton-Euler velocities, 6n)

``R`` is the centre of mass (global), ``p`` the Euler parameters (scalar
first), ``R_dot`` global, ``omega_body`` the chapter's omega-bar.

Constraint rows
---------------
Every constraint equation (and every auxiliary product used by motors and
torsion springs) is one *row* of a single table, of the form

    Phi_r = a . (y_b1 - y_b2)

with ``a`` a direction fixed in a body (``A_k a_body``), ``y_b1`` a point or
direction fixed in a second body and ``y_b2`` a point of a third body or
zero. The chapter's building blocks are special cases:

* point coincidence ``r_j - r_i = 0``: three rows with ``a`` the ground's
  x, y, z axes, ``y_b1`` the point on j, ``y_b2`` the point on i;
* perpendicularity of two body vectors (dot-1) ``a_i . b_j = 0``:
  ``y_b2 = 0``;
* a point on a line (dot-2) ``a_i . (r_j - r_i) = 0``.

Kernel
------
Per body ``b`` the matrix ``B_b`` (4 x 9) holds, in rows 0-2, the columns of
``[A | A W~ | A W~^2]`` (``W~`` the skew matrix of omega_body) and in row 3
``[R | R_dot | 0]``. A body vector with homogeneous coordinates
``(u, h)`` (``h = 1`` for a point, 0 for a direction) then has position,
velocity and quadratic acceleration ``(u, h) . B_b`` (``r = h R + A u``,
``r_dot = h R_dot + omega x A u``, ``omega x (omega x A u)``). Every vector
a row needs -- ``a``, ``b = y_b1 - y_b2`` and the partners of the cross
products of the Jacobian -- is one row of a constant selection matrix
``U``; all of them come out of one GEMM ``U @ B``. The row values, the
acceleration terms ``gamma`` and the rates are bilinear in ``a`` and ``b``:
one outer product and one GEMM with a constant (81, 3) map. The Jacobian
entries are cross products (``d/dt a = omega x a``) taken in the global
frame, scattered by fixed flat indices and turned into body-frame columns
by one GEMM with ``diag(A_k)``.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np
from scipy.linalg import lapack

try:  # numpy's C einsum: the same contraction without the Python wrapper's argument parsing (~0.7 us a call)
    from numpy._core.multiarray import c_einsum as einsum
except ImportError:  # numpy < 2
    from numpy.core.multiarray import c_einsum as einsum

from rigidlab.core.integrators import RunFailure

from ._compiled import compile_engine

# ---------------------------------------------------------------- constants


def _matrix_map() -> np.ndarray:
    """(16, 9) map from p p^T (flattened) to |p|^2 A(p / |p|) (flattened, row-major).

    ``A = (theta0^2 - |theta|^2) I + 2 theta theta^T + 2 theta0 skew(theta)``
    (Eq. 8.48) is a quadratic form in p.
    """
    T = np.zeros((4, 4, 3, 3))
    for a in range(4):
        for b in range(4):
            p1 = np.zeros(4)
            p1[a] = 1.0
            p2 = np.zeros(4)
            p2[b] = 1.0
            w1, v1 = p1[0], p1[1:]
            w2, v2 = p2[0], p2[1:]
            sk = np.array([[0.0, -v2[2], v2[1]], [v2[2], 0.0, -v2[0]], [-v2[1], v2[0], 0.0]])
            T[a, b] = (w1 * w2 - v1 @ v2) * np.eye(3) + 2.0 * np.outer(v1, v2) + 2.0 * w1 * sk
    return T.reshape(16, 9)


def _rate_map() -> np.ndarray:
    """(12, 4) map from p (x) omega_body (flattened) to p_dot = G_bar(p)^T omega_body / 2 (Eq. 8.54)."""
    T = np.zeros((4, 3, 4))
    for a in range(4):
        for b in range(3):
            p = np.zeros(4)
            p[a] = 1.0
            w, v = p[0], p[1:]
            G_bar = np.empty((3, 4))
            G_bar[:, 0] = -v
            G_bar[:, 1:] = w * np.eye(3) - np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
            e = np.zeros(3)
            e[b] = 1.0
            T[a, b] = 0.5 * G_bar.T @ e
    return T.reshape(12, 4)


def _cross_map() -> np.ndarray:
    """(9, 3) map from a (x) b (flattened) to a x b."""
    E = np.zeros((3, 3, 3))
    E[1, 2, 0], E[2, 1, 0] = 1.0, -1.0
    E[2, 0, 1], E[0, 2, 1] = 1.0, -1.0
    E[0, 1, 2], E[1, 0, 2] = 1.0, -1.0
    return E.reshape(9, 3)


def _skew_map() -> np.ndarray:
    """(3, 9) map from w to skew(w) (flattened, row-major)."""
    T = np.zeros((3, 3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        T[k] = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
    return T.reshape(3, 9)


def _bilinear_map() -> np.ndarray:
    """(81, 3) map from a9 (x) b9 to (Phi, gamma, Phi_dot).

    With ``a9 = [a, a_dot, a_q]`` and ``b9 = [b, b_dot, b_q]`` (``_q`` the
    quadratic-velocity parts of the accelerations): ``Phi = a . b``,
    ``gamma = -(a_q . b + 2 a_dot . b_dot + a . b_q)`` (so that
    ``D a_acc = gamma`` is the second derivative of ``Phi = 0``) and
    ``Phi_dot = a_dot . b + a . b_dot``.
    """
    W = np.zeros((9, 9, 3))
    for i in range(3):
        W[i, i, 0] = 1.0
        W[6 + i, i, 1] = -1.0
        W[3 + i, 3 + i, 1] = -2.0
        W[i, 6 + i, 1] = -1.0
        W[3 + i, i, 2] = 1.0
        W[i, 3 + i, 2] = 1.0
    return W.reshape(81, 3)


_A_MAP = _matrix_map()
# (16, 10): A^T (row-major) of p p^T and, in the last column, |p|^2
_AT_MAP = np.concatenate([_A_MAP.reshape(16, 3, 3).transpose(0, 2, 1).reshape(16, 9), np.eye(4).reshape(16, 1)], axis=1)
_RATE_MAP = _rate_map()
_CROSS_MAP = _cross_map()
_SKEW_MAP = _skew_map()
_BILINEAR_MAP = _bilinear_map()
# b9 @ _GAMMA_MAP pairs b's (position, velocity, quadratic) with a's (quadratic, velocity, position):
# gamma = a9 . (b9 @ _GAMMA_MAP) = -(a_q . b + 2 a_dot . b_dot + a . b_q)
_GAMMA_MAP = _BILINEAR_MAP[:, 1].reshape(9, 9).T.copy()
# d/dt Phi = a9[:, 0:6] . (b9 @ _RATE9_MAP)
_RATE9_MAP = _BILINEAR_MAP[:, 2].reshape(9, 9)[0:6].T.copy()


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (k, 3) arrays by one bilinear map (2 numpy calls)."""
    k = a.shape[0]
    return (a[:, :, None] * b[:, None, :]).reshape(k, 9) @ _CROSS_MAP


def matrices(p: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of Euler parameters (n, 4), normalized first (Eq. 8.48)."""
    n = p.shape[0]
    s = einsum("ij,ij->i", p, p)
    return (((p[:, :, None] * p[:, None, :]).reshape(n, 16) @ _A_MAP) / s[:, None]).reshape(n, 3, 3)


def parameter_rates(p: np.ndarray, omega_body: np.ndarray) -> np.ndarray:
    """p_dot = G_bar(p).T omega_body / 2 for (n, 4), (n, 3) (Eq. 8.54)."""
    n = p.shape[0]
    return (p[:, :, None] * omega_body[:, None, :]).reshape(n, 12) @ _RATE_MAP


class SingularSystemError(RunFailure, ValueError):
    """The constrained equations have no unique solution (see the message); raised during a run, it carries
    the outputs before it (``trajectory``, see ``rigidlab.core.integrators.RunFailure``)."""

    def __init__(self, message: str, *, t: float | None = None):
        super().__init__(message)
        self.t = t


# ------------------------------------------------------------------ rows
class _Rows:
    """Builder of the row table (compile time only)."""

    def __init__(self, ground: int):
        self.g = ground
        self.a: list[tuple[int, np.ndarray]] = []
        self.b1: list[tuple[int, np.ndarray, float]] = []
        self.b2: list[tuple[int, np.ndarray, float]] = []
        self.kind: list[str] = []  # "pc", "dot1", "dot2"

    def add(self, kind, a, b1, b2):
        self.a.append(a)
        self.b1.append(b1)
        self.b2.append(b2)
        self.kind.append(kind)
        return len(self.a) - 1

    def point(self, i, u_i, j, u_j):
        rows = []
        for k in range(3):
            e = np.zeros(3)
            e[k] = 1.0
            rows.append(self.add("pc", (self.g, e), (j, u_j, 1.0), (i, u_i, 1.0)))
        return rows

    def dot1(self, i, x_i, j, y_j):
        return [self.add("dot1", (i, x_i), (j, y_j, 0.0), (self.g, np.zeros(3), 0.0))]

    def dot2(self, i, x_i, u_i, j, u_j):
        return [self.add("dot2", (i, x_i), (j, u_j, 1.0), (i, u_i, 1.0))]


def _ext(body: Any, ground: int) -> int:
    return ground if body.index < 0 else body.index


class _Engine:
    """Constant, compiled description of a System with its work arrays."""

    def __init__(self, bodies, joints, motors, springs, rot_springs, forces, torques, gravity, contacts=(),
                 contact_starts=()):
        n = len(bodies)
        self.n = n
        self.bodies = tuple(bodies)
        self.joints = tuple(joints)
        self.motors = tuple(motors)
        self.springs = tuple(springs)
        self.rot_springs = tuple(rot_springs)
        self.forces = tuple(forces)
        self.torques = tuple(torques)
        self.gravity = np.array(gravity, dtype=float)
        self._mass_properties(bodies, joints)
        self._row_table(joints, motors, rot_springs, springs)
        self._contact_rows(contacts, contact_starts)
        self._work_arrays()
        self._force_tables(springs, rot_springs, forces, torques)
        self.keep: np.ndarray | None = None  # independent rows (None: all)
        self.last_factor = None
        self.generation = 0
        self._jacobian_of: tuple | None = None  # (positions, generation) of the Jacobian in the buffers
        self.rank = self.m
        self.analyzed = False  # rank analysis done (by assemble, equilibrium or simulate)
        self.K_aug = None
        if not self.mass_regular:
            self.K_aug = np.zeros((6 * n + self.m, 6 * n + self.m))
            self.K_aug[: 6 * n, : 6 * n] = self.M
        self.y_size = 13 * n
        self._zero_m = np.zeros(self.m_motor)
        self._zero_m.setflags(write=False)
        # the flat description for the compiled kernels (None: contacts or a singular inertia, numpy only)
        self.compiled = compile_engine(self)

    # ------------------------------------------------------------ compile
    def _mass_properties(self, bodies, joints) -> None:
        n = self.n
        self.mass = np.array([b.mass for b in bodies], dtype=float)
        self.inertia = np.array([b.inertia for b in bodies], dtype=float).reshape(n, 3, 3)
        diag = np.einsum("nii->ni", self.inertia)
        off = self.inertia - np.einsum("ni,ij->nij", diag, np.eye(3))
        self.inertia_diagonal = bool(not np.any(off))
        regular = np.array(
            [np.linalg.eigvalsh(J)[0] > 1e-14 * max(np.abs(J).max(), 1e-300) for J in self.inertia], dtype=bool
        ).reshape(n)
        self.singular_bodies = tuple(b for b, ok in zip(bodies, regular) if not ok)
        self.mass_regular = bool(regular.all())
        # the dense M (6n, 6n), U, Dt, Dw and blockA are made when first read (see __getattr__): the compiled
        # kernels never need them, and 3000 bodies would take gigabytes
        self._shared: dict[str, Any] = {}
        self.minv = self.minv_sqrt = self.minv_blocks = None
        if self.mass_regular:
            if self.inertia_diagonal:
                self.minv = np.concatenate([np.repeat(1.0 / self.mass, 3), (1.0 / diag).ravel()])
                self.minv_sqrt = np.sqrt(self.minv)
            else:
                blocks = np.zeros((2 * n, 3, 3))
                blocks[:n] = np.eye(3) / self.mass[:, None, None]
                blocks[n:] = np.linalg.inv(self.inertia)
                self.minv_blocks = blocks
        # Metric of the position and velocity projections: M where it is
        # regular; a body with zero rotational inertia gets m l^2 I with l
        # the largest distance from its centre of mass to one of its joint
        # points (1 m if it has none), so every correction has a least size.
        arm = np.zeros(n)
        for jt in joints:
            for side, body in (("u_i", jt.body_i), ("u_j", jt.body_j)):
                if body.index >= 0:
                    arm[body.index] = max(arm[body.index], float(np.linalg.norm(jt._local[side])))
        arm = np.where(arm > 0.0, arm, 1.0)
        w_rot = np.array(self.inertia)
        for k in range(n):
            if not regular[k]:
                w_rot[k] = w_rot[k] + self.mass[k] * arm[k] ** 2 * np.eye(3)
        wblocks = np.zeros((2 * n, 3, 3))
        if n:
            wblocks[:n] = np.eye(3) / self.mass[:, None, None]
            wblocks[n:] = np.linalg.inv(w_rot)
        self.winv_blocks = wblocks
        self.metric_diagonal = bool(self.inertia_diagonal)
        self.winv_diag = np.einsum("bii->bi", wblocks).ravel() if self.metric_diagonal else None
        self.idiag = diag.copy()
        self.has_gyro = bool(np.any(self.inertia))
        # body-wise bilinear map of the gyroscopic term: w x (I w) = (w (x) w) . G_b
        G = np.zeros((n, 3, 3, 3))
        for k in range(n):
            for i in range(3):
                for j in range(3):
                    e_i, e_j = np.eye(3)[i], np.eye(3)[j]
                    G[k, i, j] = np.cross(e_i, self.inertia[k] @ e_j)
        self.gyro_map = G.reshape(n, 9, 3)

    def _row_table(self, joints, motors, rot_springs, springs) -> None:
        n = self.n
        g = n
        rows = _Rows(g)
        self.row_labels: list[tuple[Any, str]] = []  # per constraint row: (item, label)
        joint_rows: list[list[int]] = []
        for jt in joints:
            i, j = _ext(jt.body_i, g), _ext(jt.body_j, g)
            L = jt._local
            idx: list[int] = []
            labels: list[str] = []
            if jt.kind in ("spherical", "revolute", "fixed", "universal"):
                idx += rows.point(i, L["u_i"], j, L["u_j"])
                labels += ["point x", "point y", "point z"]
            if jt.kind in ("revolute", "cylindrical", "prismatic", "fixed"):
                idx += rows.dot1(i, L["f_i"], j, L["h_j"])
                idx += rows.dot1(i, L["g_i"], j, L["h_j"])
                labels += ["axis f_i.h_j", "axis g_i.h_j"]
            if jt.kind in ("cylindrical", "prismatic"):
                idx += rows.dot2(i, L["f_i"], L["u_i"], j, L["u_j"])
                idx += rows.dot2(i, L["g_i"], L["u_i"], j, L["u_j"])
                labels += ["line f_i.d", "line g_i.d"]
            if jt.kind in ("prismatic", "fixed"):
                idx += rows.dot1(i, L["f_i"], j, L["g_j"])
                labels += ["twist f_i.g_j"]
            if jt.kind == "universal":
                idx += rows.dot1(i, L["a_i"], j, L["b_j"])
                labels += ["cross a_i.b_j"]
            joint_rows.append(idx)
            self.row_labels += [(jt, lab) for lab in labels]
        self.joint_rows = [np.array(r, dtype=np.intp) for r in joint_rows]
        self._rows = rows  # the table's description (kept for the compiled kernels, see _compiled)
        m_joint = sum(len(r) for r in joint_rows)
        disp = [mt for mt in motors if mt.coordinate == "displacement"]
        ang = [mt for mt in motors if mt.coordinate == "angle"]
        self.disp_motors = tuple(disp)
        self.angle_motors = tuple(ang)
        for mt in disp:
            jt = mt.joint
            L = jt._local
            rows.dot2(_ext(jt.body_i, g), L["h_i"], L["u_i"], _ext(jt.body_j, g), L["u_j"])
            self.row_labels.append((mt, "displacement"))
        m_dir = m_joint + len(disp)

        def pair(jt):
            L = jt._local
            i, j = _ext(jt.body_i, g), _ext(jt.body_j, g)
            # P1 = g_i . f_j = sin(theta), P2 = f_i . f_j = cos(theta)
            return rows.dot1(i, L["g_i"], j, L["f_j"])[0], rows.dot1(i, L["f_i"], j, L["f_j"])[0]

        aux_motor = [pair(mt.joint) for mt in ang]
        self.row_labels += [(mt, "angle") for mt in ang]
        aux_rs = [pair(rs.joint) for rs in rot_springs]
        self.m_joint = m_joint
        self.m_dir = m_dir
        self.m = m_dir + len(ang)
        m_tab = len(rows.a)
        self.m_tab = m_tab
        self.aux_motor = np.array(aux_motor, dtype=np.intp).reshape(-1, 2)
        self._aux_motor12 = np.concatenate([self.aux_motor[:, 0], self.aux_motor[:, 1]])  # P1 rows, then P2
        self._aux_motor_pair = tuple(int(i) for i in self.aux_motor[0]) if len(ang) == 1 else None
        self._aux_motor_rows = None if len(ang) != 1 else np.array(
            [*self._aux_motor_pair, *(m_tab + i for i in self._aux_motor_pair)], dtype=np.intp)
        self.aux_rs = np.array(aux_rs, dtype=np.intp).reshape(-1, 2)
        self.motor_rows = {}
        for k, mt in enumerate(disp):
            self.motor_rows[mt] = m_joint + k
        for k, mt in enumerate(ang):
            self.motor_rows[mt] = m_dir + k
        kinds = np.array(rows.kind)
        self.rows_dot2 = np.flatnonzero(kinds == "dot2")
        self.rows_pc = np.flatnonzero(kinds == "pc")

        # Selection matrix U (n_sel, 4 (n + 1)): rows are linear combinations
        # of the body matrices B_b; U @ B gives, in this order,
        #   [a (m_tab) | b = y_b1 - y_b2 (m_tab) | X of dot-2 rows | unique arms |
        #    spring points i, j | spring arms i, j]
        # with X = b + arm_b2 (a and y_b2 on the same body). The cross products
        # of the Jacobian, a x X (slot a), a x -arm_b1 (slot b1), a x arm_b2
        # (slot b2), are taken only for slots whose body moves (the ground's
        # and the zero vector's would be discarded); their partners are
        # gathered from U @ B with a sign (the arm of a direction b1 is b).
        sel: list[dict[int, np.ndarray]] = []

        def vec(body, u, h):
            return {body: np.append(np.asarray(u, dtype=float), h)}

        def add(dst, src, scale=1.0):
            for b, v in src.items():
                dst[b] = dst.get(b, np.zeros(4)) + scale * v
            return dst

        sigma = [k == "dot2" for k in rows.kind]
        sel += [vec(a[0], a[1], 0.0) for a in rows.a]
        sel += [add(vec(b1[0], b1[1], b1[2]), vec(b2[0], b2[1], b2[2]), -1.0) for b1, b2 in zip(rows.b1, rows.b2)]
        x_row = {}
        for r in self.rows_dot2:
            x_row[r] = len(sel)
            sel.append(add(dict(sel[m_tab + r]), vec(rows.b2[r][0], rows.b2[r][1], 0.0)))
        arm_row: dict[tuple, int] = {}

        def arm(body, u):
            key = (int(body), tuple(np.round(np.asarray(u, dtype=float), 15)))
            if key not in arm_row:
                arm_row[key] = len(sel)
                sel.append(vec(body, u, 0.0))
            return arm_row[key]

        cross_a, cross_u, cross_sign, cross_row, cross_body = [], [], [], [], []
        for r in range(m_tab):
            ba_, bb1_, bb2_ = rows.a[r][0], rows.b1[r][0], rows.b2[r][0]
            if ba_ != g:  # slot a: a x X
                cross_a.append(r)
                cross_u.append(x_row.get(r, m_tab + r))
                cross_sign.append(1.0)
                cross_row.append(r)
                cross_body.append(ba_)
            if bb1_ != g:  # slot b1: a x (-arm_b1); a direction's arm is b itself (y_b2 = 0)
                cross_a.append(r)
                cross_u.append(arm(bb1_, rows.b1[r][1]) if rows.b1[r][2] else m_tab + r)
                cross_sign.append(-1.0)
                cross_row.append(r)
                cross_body.append(bb1_)
            if bb2_ != g and not sigma[r] and rows.b2[r][2]:  # slot b2: a x arm_b2 (a point of a third body)
                cross_a.append(r)
                cross_u.append(arm(bb2_, rows.b2[r][1]))
                cross_sign.append(1.0)
                cross_row.append(r)
                cross_body.append(bb2_)
        self.cross_a = np.array(cross_a, dtype=np.intp)
        self.cross_u = np.array(cross_u, dtype=np.intp)
        self.cross_sign = np.array(cross_sign, dtype=float).reshape(-1, 1)
        self._cross_au = np.concatenate([self.cross_a, self.cross_u])  # one gather for both partners
        self.sel_springs = len(sel)
        for side in ("u_i", "u_j"):
            sel += [vec(_ext(getattr(sp, "body_" + side[-1]), g), sp._local[side], 1.0) for sp in springs]
        for side in ("u_i", "u_j"):
            sel += [vec(_ext(getattr(sp, "body_" + side[-1]), g), sp._local[side], 0.0) for sp in springs]
        self._sel = sel

        # Jacobian scatter: the global-omega entries of the live slots go to
        # the omega columns of their bodies in Dw; R_dot entries of dot-2 rows
        # (+-a) go straight to Dt; the point rows' constant R_dot entries
        # (+-e_k) are filled once.
        def col_R(b):
            return 3 * b if b < n else 6 * n

        bb1 = np.array([b[0] for b in rows.b1], dtype=np.intp)
        bb2 = np.array([b[0] for b in rows.b2], dtype=np.intp)
        k3 = np.arange(3)
        nw, nt = 3 * n + 3, 6 * n + 6

        def flat(rr, cols, width):
            return (rr[:, None] * width + cols[:, None] + k3[None, :]).ravel()

        self.flat_w = flat(np.array(cross_row, dtype=np.intp), 3 * np.array(cross_body, dtype=np.intp), nw)
        r2 = self.rows_dot2
        self.flat_R = (np.concatenate([
            flat(r2, np.array([col_R(b) for b in bb1[r2]], dtype=np.intp), nt),
            flat(r2, np.array([col_R(b) for b in bb2[r2]], dtype=np.intp), nt),
        ]) if r2.size else np.zeros(0, np.intp))
        self.R_rows = np.concatenate([r2, r2])
        self.R_sign = np.concatenate([np.ones(r2.size), -np.ones(r2.size)]).reshape(-1, 1)
        self._pc_entries = [(int(rr), col_R(rows.b1[rr][0]), col_R(rows.b2[rr][0]), np.asarray(rows.a[rr][1]))
                            for rr in self.rows_pc]

    # ------------------------------------------------------------ dense tables, made when first read
    _SHARED = ("U", "M", "minv_dense")
    _WORK = ("Dt_full", "Dw", "Dt", "blockA")

    def __getattr__(self, name: str) -> Any:
        if name in _Engine._SHARED:  # constants, shared with the workspaces
            shared = self.__dict__.get("_shared")
            if shared is None:
                raise AttributeError(name)
            if name not in shared:
                shared[name] = getattr(self, "_make_" + name)()
            self.__dict__[name] = shared[name]
            return shared[name]
        if name in _Engine._WORK and "_pc_entries" in self.__dict__:  # this workspace's own work arrays
            self._make_work()
            return self.__dict__[name]
        raise AttributeError(name)

    def _make_U(self) -> np.ndarray:
        n = self.n
        U = np.zeros((len(self._sel), 4 * (n + 1)))
        for r, entry in enumerate(self._sel):
            for b, v in entry.items():
                U[r, 4 * b : 4 * b + 4] += v
        return U

    def _make_M(self) -> np.ndarray:
        """M (6n, 6n) in velocity order [R_dot (3n), omega_body (3n)]."""
        n = self.n
        M = np.zeros((6 * n, 6 * n))
        for k in range(n):
            M[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = self.mass[k] * np.eye(3)
            M[3 * n + 3 * k : 3 * n + 3 * k + 3, 3 * n + 3 * k : 3 * n + 3 * k + 3] = self.inertia[k]
        return M

    def _make_minv_dense(self) -> np.ndarray | None:
        if self.minv_blocks is None:
            return None
        n = self.n
        dense = np.zeros((6 * n, 6 * n))
        for b in range(2 * n):
            dense[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = self.minv_blocks[b]
        return dense

    def _make_work(self) -> None:
        """The numpy evaluation's Jacobian buffers (the point rows' constant R_dot entries +-e_k filled)."""
        n, m_tab = self.n, self.m_tab
        Dt_full = np.zeros((m_tab, 6 * n + 6))
        for rr, cj, ci, e in self._pc_entries:
            Dt_full[rr, cj : cj + 3] += e
            Dt_full[rr, ci : ci + 3] -= e
        self.Dt_full = Dt_full
        self.Dw = np.zeros((m_tab, 3 * n + 3))
        self.Dt = Dt_full[:, : 6 * n]  # (view)
        self.blockA = np.zeros((3 * n, 3 * n)) if self.dense else None
        self._jacobian_of = None

    def _contact_rows(self, contacts, starts) -> None:
        """Rows of the contacts after the joint and motor rows (see ``rigidlab.core.contact._kernel``).

        Holonomic rows first (one reduced row per constraint-model contact,
        Eqs. 8.105-8.107), then the velocity-only rows of rolling contacts
        (``nonholonomic_rows``: no position value, excluded from the
        position projection and assembly).
        """
        self.contacts = tuple(contacts)
        self.m_motor = self.m  # rows of joints and motors
        self.contact_kernel = None
        self.contact_state = None
        self.contact_row = np.full(len(self.contacts), -1, dtype=np.intp)
        self.rolling_rows = [np.zeros(0, dtype=np.intp) for _ in self.contacts]
        m = self.m
        for c in self.contacts:
            if c.model == "constraint":
                self.contact_row[c.index] = m
                self.row_labels.append((c, "normal"))
                m += 1
        self.m_holo = m
        for c in self.contacts:
            if c.model == "constraint" and c.rolling:
                p = c.n_parameters
                self.rolling_rows[c.index] = np.arange(m, m + p, dtype=np.intp)
                self.row_labels += [(c, f"rolling t{q + 1}") for q in range(p)]
                m += p
        self.nonholonomic_rows = np.arange(self.m_holo, m, dtype=np.intp)
        self.m = m
        # per constraint-model contact: (index, normal row, rolling rows or None)
        self._contact_rows = tuple(
            (c.index, int(self.contact_row[c.index]),
             self.rolling_rows[c.index] if self.rolling_rows[c.index].size else None)
            for c in self.contacts if self.contact_row[c.index] >= 0)
        if self.contacts:
            from rigidlab.core.contact._kernel import ContactKernel

            self.contact_kernel = ContactKernel(self.contacts, self.n)
            self.contact_state = self.contact_kernel.initial_state(list(starts))
        self.contact_eval = None
        self.contact_strict = False  # a run's accepted states: a jump of a contact point is an error

    def contact_modes_changed(self) -> None:
        """Forget the rank analysis after a contact changed model (rows switched on or off)."""
        self.analyzed = False
        self.keep = None

    def _work_arrays(self) -> None:
        n = self.n
        # B ((n + 1) * 4, 9): see the module docstring; the ground's rows are [e_k | 0 | 0], [0 | 0 | 0]
        self.B = np.zeros((4 * (n + 1), 9))
        B3 = self.B.reshape(n + 1, 4, 9)
        B3[n, 0:3, 0:3] = np.eye(3)
        self._B3 = B3
        # small systems: the body-frame conversion as one GEMM with diag(A_k) (blockA, made with Dt)
        self.dense = n <= 32
        if self.dense:  # blockA[3b + j, 3b + k] = A_b[j, k] = At[b, k, j]
            bi_, k_, j_ = np.meshgrid(np.arange(n), np.arange(3), np.arange(3), indexing="ij")
            self.blockA_idx = ((3 * bi_ + j_) * 3 * n + 3 * bi_ + k_).ravel()
        self.Q0 = np.zeros(6 * n)
        if n:
            self.Q0[: 3 * n] = (self.mass[:, None] * self.gravity[None, :]).ravel()

    def _force_tables(self, springs, rot_springs, forces, torques) -> None:
        n = self.n
        g = n
        self.n_sp = len(springs)
        if self.n_sp:
            ns = self.n_sp
            self.sp_k = np.array([s.stiffness for s in springs])
            self.sp_c = np.array([s.damping for s in springs])
            self.sp_L0 = np.array([s.free_length for s in springs])
            self._sp_tiny = 1e-12 * np.maximum(self.sp_L0, 1e-300)  # a length below it: coincident points
            self._sp_pos = self.sp_L0 > 0
            self._sp_lin = (self.sp_L0 == 0.0)[:, None]  # zero free length: the linear force -k d - c d_dot
            self._sp_mixed = bool(self._sp_lin.any())
            inc = np.zeros((n + 1, 2 * ns))
            for k, sp in enumerate(springs):
                inc[_ext(sp.body_i, g), k] -= 1.0
                inc[_ext(sp.body_j, g), ns + k] += 1.0
            self.sp_inc = inc[:n]
        self.n_rs = len(rot_springs)
        if self.n_rs:
            self.rs_k = np.array([s.stiffness for s in rot_springs])
            self.rs_c = np.array([s.damping for s in rot_springs])
            self.rs_0 = np.array([s.angle0 for s in rot_springs])
            H = np.zeros((3 * n + 3, self.n_rs))  # body-frame torques per unit spring torque
            for k, rs in enumerate(rot_springs):
                jt = rs.joint
                bi, bj = _ext(jt.body_i, g), _ext(jt.body_j, g)
                H[3 * bj : 3 * bj + 3, k] += jt._local["h_j"]
                H[3 * bi : 3 * bi + 3, k] -= jt._local["h_i"]
            self.rs_H = H[: 3 * n]
        self.user_forces = tuple((f, f.body.index, f._u) for f in forces)
        self.user_torques = tuple((tq, tq.body.index) for tq in torques)

    def adopt(self, work: _Engine) -> None:
        """Take the row selection found by a workspace's rank analysis."""
        self.keep = None if work.keep is None else work.keep.copy()
        self.rank = work.rank
        self.analyzed = work.analyzed
        if self.contact_kernel is not None:  # warm start of the surface parameters
            state = self.contact_kernel.copy_state(work.contact_state)
            state["mode"] = np.array(self.contact_state["mode"])
            self.contact_state = state

    def workspace(self) -> _Engine:
        """A copy sharing the constant tables but with its own work arrays and row selection.

        Every simulation (and every lazy evaluation of a trajectory) runs on
        its own workspace, so two of them may run in different threads.
        """
        w = copy.copy(self)
        n = self.n
        w.B = self.B.copy()
        w._B3 = w.B.reshape(n + 1, 4, 9)
        for name in _Engine._WORK:  # (made again when the workspace first reads them)
            w.__dict__.pop(name, None)
        w._jacobian_of = None  # (its buffers hold no Jacobian yet)
        w.K_aug = None if self.K_aug is None else self.K_aug.copy()
        w.keep = None if self.keep is None else self.keep.copy()
        w.compiled = None if self.compiled is None else self.compiled.workspace()
        if self.contact_kernel is not None:
            w.contact_state = self.contact_kernel.copy_state(self.contact_state)
            w.contact_eval = None
        return w

    # ------------------------------------------------------------ kinematics
    def frames(self, y: np.ndarray, *, velocities: bool) -> np.ndarray:
        """Transposed rotation matrices ``A^T`` (n, 3, 3) of ``y`` (a view into ``B``, which it fills).

        ``A = A(p / |p|)`` (Eq. 8.48); with ``velocities`` also the blocks
        ``(A W~)^T = -W~ A^T`` and ``(A W~^2)^T = W~^2 A^T`` and ``R_dot``.
        """
        n = self.n
        p = y[3 * n : 7 * n].reshape(n, 4)
        O = (p[:, :, None] * p[:, None, :]).reshape(n, 16) @ _AT_MAP
        B3 = self._B3
        At = B3[:n, 0:3, 0:3]
        np.divide(O[:, :9].reshape(n, 3, 3), O[:, 9, None, None], out=At)
        B3[:n, 3, 0:3] = y[: 3 * n].reshape(n, 3)
        if velocities:
            Om = (y[10 * n :].reshape(n, 3) @ _SKEW_MAP).reshape(n, 3, 3)
            X = np.matmul(Om, At)  # W~ A^T = -(A W~)^T
            np.negative(X, out=B3[:n, 0:3, 3:6])
            np.matmul(Om, X, out=B3[:n, 0:3, 6:9])  # W~^2 A^T = (A W~^2)^T
            B3[:n, 3, 3:6] = y[7 * n : 10 * n].reshape(n, 3)
        return At

    def selected(self) -> np.ndarray:
        """(n_sel, 9) ``U @ B``: position, velocity and quadratic acceleration of every selected vector."""
        return self.U @ self.B

    def table(self, t: float, y: np.ndarray, *, level: int, commit: bool = True):
        """Evaluate the row table at state ``y``.

        level 0: values; 1: values and Jacobian; 2: also the acceleration
        terms. Returns ``(At, Y, Phi, gam)``: transposed rotation matrices,
        the selected vectors ``U @ B`` (see :meth:`rates`) and per table row
        the value and ``gamma`` (None below level 2). The Jacobian is left
        in ``self.Dt`` (body velocities) when ``level >= 1``. The contacts
        are evaluated too (``self.contact_eval``); ``commit`` makes their
        surface parameters the warm start of later evaluations (see
        ``rigidlab.core.contact._kernel.ContactKernel.evaluate``).
        """
        # the Jacobian depends on the positions only: at the positions of the last table that formed it, with
        # no other writer since (the generation), the buffers already hold it (the accelerations after a
        # projection's last iterate)
        qkey = y[: 7 * self.n].tobytes() if level >= 1 else None
        jac_held = qkey is not None and self._jacobian_of == (qkey, self.generation)
        self.generation += 1  # the Jacobian buffers are overwritten
        At = self.frames(y, velocities=level >= 2)
        m = self.m_tab
        Y = self.U @ (self.B if level >= 2 else self.B[:, 0:3])
        a9 = Y[:m]
        b9 = Y[m : 2 * m]
        Phi = einsum("ri,ri->r", a9[:, 0:3], b9[:, 0:3])
        gam = einsum("ri,ri->r", a9, b9 @ _GAMMA_MAP) if level >= 2 else None
        if level >= 1:
            self._jacobian_of = (qkey, self.generation)
        if level >= 1 and m and not jac_held:
            k = self.cross_a.size
            Yau = Y[self._cross_au, 0:3]
            c = cross(Yau[:k], Yau[k:] * self.cross_sign)
            self.Dw.flat[self.flat_w] = c.ravel()
            if self.rows_dot2.size:
                self.Dt_full.flat[self.flat_R] = (Y[self.R_rows, 0:3] * self.R_sign).ravel()
            n = self.n
            if self.dense:
                np.put(self.blockA, self.blockA_idx, At)
                np.matmul(self.Dw[:, : 3 * n], self.blockA, out=self.Dt_full[:, 3 * n : 6 * n])
            else:
                einsum("rbi,bki->rbk", self.Dw[:, : 3 * n].reshape(m, n, 3), At,
                          out=self.Dt_full[:, 3 * n : 6 * n].reshape(m, n, 3))
        if self.contact_kernel is not None:
            self.contact_eval = self.contact_kernel.evaluate(
                y, np.swapaxes(At, 1, 2), level, self.contact_state, t=t, commit=commit, strict=self.contact_strict)
        return At, Y, Phi, gam

    def rates(self, Y: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``d/dt Phi`` (k,) of the table rows ``rows`` from level-2 selected vectors ``Y``."""
        m = self.m_tab
        return einsum("ri,ri->r", Y[rows, 0:6], Y[m + rows] @ _RATE9_MAP)

    def constraint_rows(self, t: float, Y, Phi, gam, *, level: int):
        """Constraint vector (m,), its Jacobian D (m, 6n) or None, C_t (m,) and gamma (m,) or None.

        Joint and motor rows (:meth:`_joint_motor_rows`), then the contact
        rows evaluated by the last :meth:`table` call: the reduced row of
        each constraint-model contact (value ``-g``) and its rolling rows
        (value 0); rows of a contact that is not in the constraint model are
        zero (found redundant by the rank analysis, so their multipliers are
        zero).
        """
        if self.contact_kernel is None:
            return self._joint_motor_rows(t, Y, Phi, gam, level=level)
        mm = self.m_motor
        m = self.m
        if self.motors:  # new arrays of all m rows, the joints' and motors' filled
            C, D, Ct, gamma = self._joint_motor_rows(t, Y, Phi, gam, level=level, rows=m)
        else:  # (the joints' rows are views of the table's: copied into new arrays)
            C = np.zeros(m)
            Ct = np.zeros(m)
            D = np.zeros((m, 6 * self.n)) if level >= 1 else None
            gamma = np.zeros(m) if level >= 2 else None
            if mm:
                C0, D0, _, g0 = self._joint_motor_rows(t, Y, Phi, gam, level=level)
                C[:mm] = C0
                if D is not None:
                    D[:mm] = D0
                if gamma is not None:
                    gamma[:mm] = g0
        res = self.contact_eval
        mode = self.contact_state["mode"].tolist()
        value = res["value"]
        if D is not None:
            res_D, res_Dr = res["D"], res["Dr"]
        if gamma is not None:
            res_gamma, res_gamma_r = res["gamma"], res["gamma_r"]
        for q, r, rr in self._contact_rows:
            if mode[q] != 0:
                continue
            C[r] = value[q]
            if D is not None:
                D[r] = res_D[q]
                if rr is not None:
                    D[rr] = res_Dr[q, : rr.size]
            if gamma is not None:
                gamma[r] = res_gamma[q]
                if rr is not None:
                    gamma[rr] = res_gamma_r[q, : rr.size]
        return C, D, Ct, gamma

    def _joint_motor_rows(self, t: float, Y, Phi, gam, *, level: int, rows: int | None = None):
        """Rows of the joints and motors: constraint vector, Jacobian, C_t and gamma.

        Adds the motors: ``C = sin(theta - f) = P1 cos f - P2 sin f`` for an
        angle, ``C = s - f`` for a displacement, with ``C_t`` and the
        acceleration terms from ``f, f_dot, f_ddot``. Without motors the
        arrays are views of the table's (do not modify them). With motors,
        ``rows`` (at least ``m_motor``) sizes the new arrays, the rows past
        the motors' zero: :meth:`constraint_rows` fills the contacts' rows
        in them.
        """
        m_dir, m = self.m_dir, self.m_motor
        if not self.motors:
            D = (self.Dt if self.m_tab == m else self.Dt[:m]) if level >= 1 else None
            gamma = (gam if self.m_tab == m else gam[:m]) if level >= 2 else None
            return (Phi if self.m_tab == m else Phi[:m]), D, self._zero_m, gamma
        size = m if rows is None else rows
        C = np.zeros(size)
        C[:m_dir] = Phi[:m_dir]
        Ct = np.zeros(size)
        D = None
        gamma = None
        if level >= 2:
            gamma = np.zeros(size)
            gamma[:m_dir] = gam[:m_dir]
        if self.disp_motors:
            fv = np.array([mt.values(t) for mt in self.disp_motors]).reshape(-1, 3)
            rr = slice(self.m_joint, m_dir)
            C[rr] -= fv[:, 0]
            Ct[rr] = -fv[:, 1]
            if gamma is not None:
                gamma[rr] += fv[:, 2]
        if len(self.angle_motors) == 1:  # one motor (the common case): the same operations on floats
            f, fd, fdd = self.angle_motors[0].values(t)  # (floats: the driver functions check and convert)
            cf, sf = math.cos(f), math.sin(f)
            i1, i2 = self._aux_motor_pair
            P1, P2 = Phi[i1].item(), Phi[i2].item()
            c = P1 * cf - P2 * sf
            C[m_dir] = c
            cosd = P2 * cf + P1 * sf  # cos(theta - f)
            Ct[m_dir] = -fd * cosd
            if level >= 1:
                D = np.zeros((size, 6 * self.n))
                D[:m_dir] = self.Dt[:m_dir]
                np.subtract(cf * self.Dt[i1], sf * self.Dt[i2], out=D[m_dir])
            if gamma is not None:
                Yp = Y[self._aux_motor_rows]  # the rows' a and b vectors: (P1 a, P2 a, P1 b, P2 b)
                dP1, dP2 = (Yp[:2, 0:6] * (Yp[2:] @ _RATE9_MAP)).sum(axis=1).tolist()
                gamma[m_dir] = ((cf * gam[i1].item() - sf * gam[i2].item()) + 2.0 * fd * (sf * dP1 + cf * dP2)
                                + fdd * cosd + fd * fd * c)
        elif self.angle_motors:
            fv = np.array([mt.values(t) for mt in self.angle_motors]).reshape(-1, 3)
            f, fd, fdd = fv[:, 0], fv[:, 1], fv[:, 2]
            cf, sf = np.cos(f), np.sin(f)
            k = len(self.angle_motors)
            p12 = self._aux_motor12
            P12 = Phi[p12]
            P1, P2 = P12[:k], P12[k:]
            C[m_dir:m] = P1 * cf - P2 * sf
            cosd = P2 * cf + P1 * sf  # cos(theta - f)
            Ct[m_dir:m] = -fd * cosd
            if level >= 1:
                D = np.zeros((size, 6 * self.n))
                D[:m_dir] = self.Dt[:m_dir]
                D12 = self.Dt[p12]
                D[m_dir:m] = cf[:, None] * D12[:k] - sf[:, None] * D12[k:]
            if gamma is not None:
                dP12 = self.rates(Y, p12)
                dP1, dP2 = dP12[:k], dP12[k:]
                g12 = gam[p12]
                # C_dd = D a - (cf g1 - sf g2) - 2 fd (sf dP1 + cf dP2) - fdd cosd - fd^2 C = 0
                gamma[m_dir:m] = ((cf * g12[:k] - sf * g12[k:]) + 2.0 * fd * (sf * dP1 + cf * dP2)
                                  + fdd * cosd + fd * fd * C[m_dir:m])
        elif level >= 1:
            D = self.Dt[:m_dir] if size == m else np.zeros((size, 6 * self.n))
            if size != m:
                D[:m_dir] = self.Dt[:m_dir]
        if not math.isfinite(C.sum()) and not np.all(np.isfinite(C)):
            raise ValueError(f"motor: a driving function returned a non-finite value at t={t:.6g}")
        return C, D, Ct, gamma

    def angle_motor_errors(self, t: float, Phi: np.ndarray):
        """``(s, c, ds_rows, dc_rows)`` of the angle motors: ``s = sin(theta - f)``, ``c = cos(theta - f)``.

        ``ds_rows`` is the motor rows' Jacobian (computed from the table's
        ``Dt``) and ``dc_rows`` that of ``c``; needs a level-1 table.
        """
        fv = np.array([mt.values(t) for mt in self.angle_motors]).reshape(-1, 3)
        cf, sf = np.cos(fv[:, 0]), np.sin(fv[:, 0])
        p1, p2 = self.aux_motor[:, 0], self.aux_motor[:, 1]
        P1, P2 = Phi[p1], Phi[p2]
        s = P1 * cf - P2 * sf
        c = P2 * cf + P1 * sf
        ds = cf[:, None] * self.Dt[p1] - sf[:, None] * self.Dt[p2]
        dc = cf[:, None] * self.Dt[p2] + sf[:, None] * self.Dt[p1]
        return s, c, ds, dc

    # ------------------------------------------------------------ forces
    def applied(self, t: float, y: np.ndarray, At: np.ndarray, Y: np.ndarray, Phi, state_factory) -> np.ndarray:
        """Generalized applied and quadratic-velocity forces Q_e + Q_v (6n,), Newton-Euler form.

        Translational part: global forces (N); rotational part: body-frame
        torques about the centre of mass (N m) including the gyroscopic
        ``-omega_body x (I omega_body)``. Needs the level-2 table.
        """
        n = self.n
        Q = self.Q0.copy()
        Tb = Q[3 * n :].reshape(n, 3)
        if self.has_gyro:
            W = y[10 * n :].reshape(n, 3)
            Tb -= einsum("ni,nij->nj", (W[:, :, None] * W[:, None, :]).reshape(n, 9), self.gyro_map)
        Tg = None
        F = Q[: 3 * n].reshape(n, 3)
        if self.n_sp:
            Fu, arms = self._spring_forces(t, Y)
            F += self.sp_inc @ Fu
            Tg = self.sp_inc @ cross(arms, Fu)
        if self.n_rs:
            theta, theta_dot = self.rot_spring_angles(Phi, Y)
            tau = -self.rs_k * (theta - self.rs_0) - self.rs_c * theta_dot
            Q[3 * n :] += self.rs_H @ tau
        if self.user_forces or self.user_torques:
            state = state_factory(t, y)
            if Tg is None:
                Tg = np.zeros((n, 3))
            for item, b, u in self.user_forces:
                Fv = _call_load(item, t, state, "force")
                F[b] += Fv
                if u is not None:
                    arm = u @ At[b]
                    Tg[b] += np.array([arm[1] * Fv[2] - arm[2] * Fv[1], arm[2] * Fv[0] - arm[0] * Fv[2],
                                       arm[0] * Fv[1] - arm[1] * Fv[0]])
            for item, b in self.user_torques:
                Tg[b] += _call_load(item, t, state, "torque")
        if Tg is not None:
            Tb += einsum("nij,nj->ni", At, Tg)
        if self.contact_kernel is not None and self.contact_state["mode"].any():
            _, Qc = self.contact_kernel.compliant_forces(self.contact_eval, self.contact_state["mode"])
            Q += Qc
        return Q

    def _spring_forces(self, t: float, Y: np.ndarray):
        """Forces on the j points (n_sp, 3) repeated for both ends (2 n_sp, 3), and the arms of all ends."""
        ns = self.n_sp
        s0 = self.sel_springs
        d6 = Y[s0 + ns : s0 + 2 * ns, 0:6] - Y[s0 : s0 + ns, 0:6]
        d = d6[:, 0:3]
        dd = d6[:, 3:6]
        L = np.sqrt(einsum("ki,ki->k", d, d))
        zero = L <= self._sp_tiny
        if zero.any() and np.any(zero & self._sp_pos):
            k = int(np.argmax(zero & self._sp_pos))
            raise SingularSystemError(
                f"spring_damper '{self.springs[k].name}': its two points coincide at t={t:.6g}, "
                "the direction of its force is undefined (free_length > 0)", t=t)
        Ls = np.where(zero, 1.0, L) if zero.any() else L
        e = d / Ls[:, None]
        Ldot = einsum("ki,ki->k", e, dd)
        mag = self.sp_k * (L - self.sp_L0) + self.sp_c * Ldot
        Fj = -mag[:, None] * e
        if self._sp_mixed:
            Fj = np.where(self._sp_lin, -self.sp_k[:, None] * d - self.sp_c[:, None] * dd, Fj)
        return np.concatenate([Fj, Fj]), Y[s0 + 2 * ns : s0 + 4 * ns, 0:3]

    def spring_lengths(self, Y: np.ndarray) -> np.ndarray:
        """Current lengths (n_sp,) of the spring-dampers."""
        ns = self.n_sp
        s0 = self.sel_springs
        d = Y[s0 + ns : s0 + 2 * ns, 0:3] - Y[s0 : s0 + ns, 0:3]
        return np.sqrt(einsum("ki,ki->k", d, d))

    def rot_spring_angles(self, Phi: np.ndarray, Y: np.ndarray | None):
        """Joint angles (k,) of the torsion springs in (angle0 - pi, angle0 + pi] and their rates.

        ``theta = atan2(g_i . f_j, f_i . f_j)``; ``theta_dot = (dP1 P2 - dP2 P1) / (P1^2 + P2^2)``.
        """
        p1, p2 = self.aux_rs[:, 0], self.aux_rs[:, 1]
        P1, P2 = Phi[p1], Phi[p2]
        c0, s0 = np.cos(self.rs_0), np.sin(self.rs_0)
        theta = self.rs_0 + np.arctan2(P1 * c0 - P2 * s0, P2 * c0 + P1 * s0)
        if Y is None:
            return theta, None
        return theta, (self.rates(Y, p1) * P2 - self.rates(Y, p2) * P1) / (P1 * P1 + P2 * P2)

    # ------------------------------------------------------------ solve
    def solve(self, t: float, D: np.ndarray, Q: np.ndarray, gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations a (6n,) and multipliers (m,) of ``[[M, D^T], [D, 0]] [a; lam] = [Q; gamma]``.

        Rows outside ``self.keep`` (redundant) get zero multipliers. With a
        regular M: Schur complement ``D M^-1 D^T`` by Cholesky (LAPACK
        ``dposv``); otherwise the augmented matrix by LU (``dgesv``).
        """
        keep = self.keep
        if keep is not None:
            D = D[keep]
            gamma = gamma[keep]
        if self.mass_regular:
            if D.shape[0] == 0:
                return self._minv_apply(Q), np.zeros(self.m)
            if self.minv_sqrt is not None:
                Ds = D * self.minv_sqrt
                S = Ds @ Ds.T
                rhs = D @ (self.minv * Q) - gamma
                c, lam, info = lapack.dposv(S, rhs, lower=0, overwrite_a=1, overwrite_b=1)
                if info != 0:
                    raise _FactorizationFailed(t)
                self.last_factor = c  # Cholesky factor of D M^-1 D^T (upper), reused by projections
                a = self.minv * (Q - D.T @ lam)
            else:
                DM = D @ self.minv_dense
                S = DM @ D.T
                rhs = DM @ Q - gamma
                _, lam, info = lapack.dposv(S, rhs, lower=0, overwrite_a=1, overwrite_b=1)
                if info != 0:
                    raise _FactorizationFailed(t)
                a = self.minv_dense @ (Q - D.T @ lam)
        else:
            n6 = 6 * self.n
            r = D.shape[0]
            K = self.K_aug
            if K is None or K.shape[0] != n6 + r:
                K = np.zeros((n6 + r, n6 + r))
                K[:n6, :n6] = self.M
                self.K_aug = K
            K[n6:, :n6] = D
            K[:n6, n6:] = D.T
            rhs = np.concatenate([Q, gamma])
            _, _, sol, info = lapack.dgesv(K, rhs, overwrite_a=0, overwrite_b=1)
            if info != 0 or not np.all(np.isfinite(sol)):
                raise _FactorizationFailed(t)
            a = sol[:n6]
            lam = sol[n6:]
        if keep is None:
            return a, lam
        lam_full = np.zeros(self.m)
        lam_full[keep] = lam
        return a, lam_full

    def _minv_apply(self, Q: np.ndarray) -> np.ndarray:
        if self.minv is not None:
            return self.minv * Q
        return self.minv_dense @ Q

    def winv_apply(self, x: np.ndarray) -> np.ndarray:
        """W^-1 x with the projection metric W, for x (6n,) or (6n, k)."""
        n = self.n
        if x.ndim == 1:
            return einsum("bij,bj->bi", self.winv_blocks, x.reshape(2 * n, 3)).ravel()
        k = x.shape[1]
        return einsum("bij,bjk->bik", self.winv_blocks, x.reshape(2 * n, 3, k)).reshape(6 * n, k)


class _FactorizationFailed(Exception):
    """Internal: the constrained system could not be factorized at time t."""

    def __init__(self, t: float):
        super().__init__(t)
        self.t = t


def _call_load(item: Any, t: float, state: Any, what: str) -> np.ndarray:
    try:
        value = item._func(t, state)
    except Exception as exc:  # noqa: BLE001 - reported with the item's name
        raise ValueError(f"{what} '{item.name}': its function raised {type(exc).__name__}: {exc}") from exc
    arr = np.asarray(value)
    if arr.dtype.kind == "c":
        raise ValueError(f"{what} '{item.name}': expected real numbers, got complex {value!r}")
    if arr.dtype.kind == "b" or (arr.dtype.kind == "O" and any(isinstance(x, (bool, np.bool_)) for x in arr.ravel())):
        raise ValueError(f"{what} '{item.name}': expected a (3,) vector of real numbers, got {value!r}")
    try:
        arr = arr.astype(float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} '{item.name}': expected a (3,) vector of real numbers, got {value!r}") from None
    if arr.shape != (3,):
        raise ValueError(f"{what} '{item.name}': expected a (3,) vector, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} '{item.name}': expected finite values at t={t:.6g}, got {arr.tolist()}")
    return arr
