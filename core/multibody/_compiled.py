"""The compiled description of a System: flat typed arrays for the kernels of ``_kernel``.

A :class:`Compiled` is made once from an :class:`~rigidlab.core.multibody._engine._Engine`
(itself made once per change of the System) and holds

* per table row (see ``_engine``): the body and body-frame vector of ``a``,
  ``y_b1`` and ``y_b2`` (ground ``-1``), and each row's *slots*: the distinct
  moving bodies it touches, in ascending order, so that the rows of one
  joint share their slots;
* per constraint row (joints, then displacement motors, then angle motors):
  its slots (``jc_body``);
* the mass blocks ``M_b = diag(m I, I_b)`` and the projection metric's
  blocks ``W_b``; spring-damper, torsion-spring and user-load tables;
* per selection of independent rows (``keep``, from the rank analysis) a
  :class:`Tree`: the elimination order of Baraff's factorization.

The user's callables (motor laws, ``add_force`` / ``add_torque``) stay
Python: they are evaluated once per right-hand side and handed to the
kernels as arrays. Systems with contacts, or with a body whose inertia is
singular, are not compiled (``compile_engine`` returns None) and run on
the engine's numpy evaluation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _kernel as K

_I64 = np.int64


@dataclass(frozen=True)
class Tree:
    """Elimination order of the augmented matrix over the body-joint graph (Baraff 1996).

    Nodes ``0 .. N-1`` in elimination order (every node before its
    parent). Bodies are 6 x 6 nodes; the kept constraint rows are grouped by
    the set of bodies they touch (one joint and its motors), a group being
    a node of its rows. Groups are taken into a spanning forest of the
    bodies and the ground in the order of their rows; a group that would
    close a loop (through other bodies or through the ground) is
    *secondary*: its rows are eliminated by a Schur complement. A body
    without child groups (a leaf: the last link of a chain, a free body)
    keeps its own mass block as its pivot, factored once at compile time.
    """

    order_size: np.ndarray  # (N,) block size of each node
    order_parent: np.ndarray  # (N,) parent node, -1 at a root
    node_kind: np.ndarray  # (N,) 0 body, 1 row group
    node_ref: np.ndarray  # (N,) body index or group index
    leaf: np.ndarray  # (N,) 1 for a body without child groups, else 0
    body_node: np.ndarray  # (n,) node of each body
    group_rows: np.ndarray  # (G, 6) constraint rows of each group (padded with -1)
    group_slot_of: np.ndarray  # (G, 2) slot of the group's child body and of its parent body (-1: ground root)
    parent_slot: np.ndarray  # (N,) slot, in the rows of the group of the link to the parent, of its body (-1: root)
    sec_rows: np.ndarray  # (k,) secondary rows (loop closures)


class Compiled:
    """Flat arrays of one engine and the work arrays of one thread (see :meth:`workspace`)."""

    def __init__(self, eng: Any):
        n = eng.n
        self.n = n
        rows = eng._rows
        g = n
        m_tab = len(rows.a)
        self.m_tab = m_tab
        self.m = eng.m_motor
        self.m_joint = eng.m_joint
        self.m_dir = eng.m_dir

        def body(b: int) -> int:
            return -1 if b == g else int(b)

        ra_b = np.array([body(a[0]) for a in rows.a], dtype=_I64)
        r1_b = np.array([body(b[0]) for b in rows.b1], dtype=_I64)
        r2_b = np.array([body(b[0]) for b in rows.b2], dtype=_I64)
        self.ra_b, self.r1_b, self.r2_b = ra_b, r1_b, r2_b
        self.ra_u = np.array([a[1] for a in rows.a], dtype=float).reshape(m_tab, 3)
        self.r1_u = np.array([b[1] for b in rows.b1], dtype=float).reshape(m_tab, 3)
        self.r2_u = np.array([b[1] for b in rows.b2], dtype=float).reshape(m_tab, 3)
        self.r1_h = np.array([b[2] for b in rows.b1], dtype=float)
        self.r2_h = np.array([b[2] for b in rows.b2], dtype=float)
        # slots: the distinct moving bodies of a row, ascending
        tab_slots = np.full((m_tab, 3), -1, dtype=_I64)
        slot = np.full((3, m_tab), 0, dtype=_I64)
        for r in range(m_tab):
            bodies = sorted({int(b) for b in (ra_b[r], r1_b[r], r2_b[r]) if b >= 0})
            tab_slots[r, : len(bodies)] = bodies
            for k, b in enumerate((ra_b[r], r1_b[r], r2_b[r])):
                slot[k, r] = bodies.index(int(b)) if b >= 0 else -1
        self.slot_a, self.slot_1, self.slot_2 = slot[0].copy(), slot[1].copy(), slot[2].copy()
        self.row_slot = np.ascontiguousarray(slot.T)
        self.tab_slots = tab_slots
        # the distinct body vectors (b, u, h) of the table, each evaluated once per call
        vec_index: dict[tuple, int] = {}
        row_v = np.zeros((m_tab, 3), dtype=_I64)
        for r in range(m_tab):
            for k, (b, u, h) in enumerate(((ra_b[r], self.ra_u[r], 0.0), (r1_b[r], self.r1_u[r], self.r1_h[r]),
                                           (r2_b[r], self.r2_u[r], self.r2_h[r]))):
                key = (int(b), *(float(x) for x in u), float(h))
                row_v[r, k] = vec_index.setdefault(key, len(vec_index))
        keys = list(vec_index)
        self.row_v = row_v
        self.vec_b = np.array([k[0] for k in keys], dtype=_I64)
        self.vec_u = np.array([k[1:4] for k in keys], dtype=float).reshape(-1, 3)
        self.vec_h = np.array([k[4] for k in keys], dtype=float)
        self.aux_motor = np.ascontiguousarray(eng.aux_motor, dtype=_I64).reshape(-1, 2)
        jc_body = np.full((self.m, 3), -1, dtype=_I64)
        jc_body[: self.m_dir] = tab_slots[: self.m_dir]
        for q, (i1, i2) in enumerate(self.aux_motor):
            if not np.array_equal(tab_slots[i1], tab_slots[i2]):  # (both rows join the joint's two bodies)
                raise AssertionError("an angle motor's rows touch different bodies")
            jc_body[self.m_dir + q] = tab_slots[i1]
        self.jc_body = jc_body
        # mass blocks and projection metric
        self.mass = np.ascontiguousarray(eng.mass, dtype=float)
        self.inertia = np.ascontiguousarray(eng.inertia, dtype=float)
        self.gravity = np.ascontiguousarray(eng.gravity, dtype=float)
        self.has_gyro = bool(eng.has_gyro)
        M = np.zeros((n, 6, 6))
        Wb = np.zeros((n, 6, 6))
        for b in range(n):
            M[b, :3, :3] = self.mass[b] * np.eye(3)
            M[b, 3:, 3:] = self.inertia[b]
            Wb[b, :3, :3] = self.mass[b] * np.eye(3)
            Wb[b, 3:, 3:] = np.linalg.inv(eng.winv_blocks[n + b])
        self.Mblocks = M
        self.Wblocks = Wb
        # their Cholesky factors (the diagonal as its reciprocals, as the kernels store theirs): a body that
        # touches at most two groups of rows is eliminated with its own block (see _kernel.tree_factor)
        self.Lm = _chol_reciprocal(M)
        self.Lw = _chol_reciprocal(Wb)
        # spring-dampers
        sp = eng.springs
        self.sp_bi = np.array([_index(s.body_i) for s in sp], dtype=_I64)
        self.sp_bj = np.array([_index(s.body_j) for s in sp], dtype=_I64)
        self.sp_ui = np.array([s._local["u_i"] for s in sp], dtype=float).reshape(-1, 3)
        self.sp_uj = np.array([s._local["u_j"] for s in sp], dtype=float).reshape(-1, 3)
        self.sp_k = np.array([s.stiffness for s in sp], dtype=float)
        self.sp_c = np.array([s.damping for s in sp], dtype=float)
        self.sp_L0 = np.array([s.free_length for s in sp], dtype=float)
        # torsion springs
        rs = eng.rot_springs
        aux_rs = np.asarray(eng.aux_rs, dtype=_I64).reshape(-1, 2)
        self.rs_p1 = np.ascontiguousarray(aux_rs[:, 0])
        self.rs_p2 = np.ascontiguousarray(aux_rs[:, 1])
        self.rs_k = np.array([s.stiffness for s in rs], dtype=float)
        self.rs_c = np.array([s.damping for s in rs], dtype=float)
        self.rs_0 = np.array([s.angle0 for s in rs], dtype=float)
        self.rs_bi = np.array([_index(s.joint.body_i) for s in rs], dtype=_I64)
        self.rs_bj = np.array([_index(s.joint.body_j) for s in rs], dtype=_I64)
        self.rs_hi = np.array([s.joint._local["h_i"] for s in rs], dtype=float).reshape(-1, 3)
        self.rs_hj = np.array([s.joint._local["h_j"] for s in rs], dtype=float).reshape(-1, 3)
        # user loads (their values come per right-hand side)
        self.user_forces = tuple(eng.user_forces)
        self.user_torques = tuple(eng.user_torques)
        self.uf_b = np.array([b for _, b, _ in self.user_forces], dtype=_I64)
        self.uf_u = np.array([np.zeros(3) if u is None else u for _, _, u in self.user_forces],
                             dtype=float).reshape(-1, 3)
        self.uf_has_u = np.array([u is not None for _, _, u in self.user_forces], dtype=_I64)
        self.ut_b = np.array([b for _, b in self.user_torques], dtype=_I64)
        self.motors = tuple(eng.disp_motors) + tuple(eng.angle_motors)
        self.I, self.F = self._pack_model()
        self._selections: dict[bytes, tuple] = {}  # keep -> (Tree, TI, W sizes)
        self._keep_obj: Any = 0  # the keep array of the current selection (identity), 0: none yet
        self._ws: dict[bytes, tuple] = {}  # keep -> (TI, W, views) of this workspace

    # ------------------------------------------------------------ packing
    def _pack_model(self) -> tuple[np.ndarray, np.ndarray]:
        ints = [getattr(self, f) for f in K.I_FIELDS]
        floats = [getattr(self, f) for f in K.F_FIELDS]
        head = np.zeros(K.N_SCALARS + 4 * (len(ints) + len(floats)), dtype=_I64)
        head[:6] = (self.n, self.m_tab, self.m, self.m_joint, self.m_dir, int(self.has_gyro))
        off = head.size
        for k, a in enumerate(ints):
            head[K.IH + 4 * k : K.IH + 4 * k + 4] = (off, *_dims(a))
            off += a.size
        off_f = 0
        for k, a in enumerate(floats):
            head[K.FH + 4 * k : K.FH + 4 * k + 4] = (off_f, *_dims(a))
            off_f += a.size
        I = np.concatenate([head] + [np.ascontiguousarray(a, dtype=_I64).ravel() for a in ints])
        F = np.concatenate([np.zeros(0)] + [np.ascontiguousarray(a, dtype=float).ravel() for a in floats])
        return I, F

    def tree(self, keep: np.ndarray | None) -> Tree:
        """The elimination order for the kept rows (all rows when ``keep`` is None); cached per selection."""
        return self._selection(keep)[0]

    def _selection(self, keep: np.ndarray | None) -> tuple:
        key = b"" if keep is None else np.asarray(keep, dtype=_I64).tobytes()
        sel = self._selections.get(key)
        if sel is None:
            rows = range(self.m) if keep is None else [int(r) for r in keep if r < self.m]
            tr = build_tree(self.n, self.jc_body, rows)
            n, m, mt = self.n, self.m, self.m_tab
            N, k = tr.order_size.size, tr.sec_rows.size
            shapes = {"A": (max(n, 1), 3, 3), "omega": (max(n, 1), 3), "V": (self.vec_b.size, 12),
                      "Phi": (mt,), "J": (mt, 3, 6), "gam": (mt,), "rate": (mt,),
                      "C": (m,), "Jc": (m, 3, 6), "Ct": (m,), "gamma": (m,), "Q": (6 * n,), "Tg": (max(n, 1), 3),
                      "pi": (9,), "pj": (9,), "motor_f": (len(self.motors), 3), "uf_F": (len(self.user_forces), 3),
                      "ut_T": (len(self.user_torques), 3), "Xp": (N, 6, 6), "Lfac": (N, 6, 6), "sign": (N,),
                      "work": (N, 6, 6), "X": (N, 6), "Z": (k, 6 * N), "S": (k, k), "rs": (k,), "Ls": (k, k),
                      "cv": (m,), "dq": (6 * n,), "lam": (m,), "rhs_c": (m,), "zero6": (6 * n,), "res": (4,)}
            tfields = [getattr(tr, f) for f in K.T_FIELDS]
            head = np.zeros(4 * (len(K.T_FIELDS) + len(K.W_FIELDS)), dtype=_I64)
            off = head.size
            for q, a in enumerate(tfields):
                head[K.TH + 4 * q : K.TH + 4 * q + 4] = (off, *_dims(a))
                off += a.size
            off_w = 0
            for q, f in enumerate(K.W_FIELDS):
                shp = shapes[f]
                size = int(np.prod(shp))
                head[K.WH + 4 * q : K.WH + 4 * q + 4] = (off_w, *(tuple(shp) + (1, 1, 1))[:3])
                off_w += size
            TI = np.concatenate([head] + [np.ascontiguousarray(a, dtype=_I64).ravel() for a in tfields])
            sel = (tr, TI, off_w, shapes)
            self._selections[key] = sel
        return sel

    def select(self, keep: np.ndarray | None) -> None:
        """Make the rows ``keep`` (None: all) the current selection: its tree and this workspace's work arrays."""
        if keep is self._keep_obj:
            return
        key = b"" if keep is None else np.asarray(keep, dtype=_I64).tobytes()
        ws = self._ws.get(key)
        if ws is None:
            tr, TI, size, shapes = self._selection(keep)
            W = np.zeros(size)
            views = {}
            off = 0
            for f in K.W_FIELDS:
                shp = shapes[f]
                k = int(np.prod(shp))
                views[f] = W[off : off + k].reshape(shp)
                off += k
            ws = (tr, TI, W, views)
            self._ws[key] = ws
        self._keep_obj = keep
        self.tree_now, self.TI, self.W, views = ws
        self.__dict__.update(views)

    def workspace(self) -> Compiled:
        """A copy sharing the constant arrays with work arrays of its own (one per thread or run)."""
        w = object.__new__(Compiled)
        w.__dict__.update(self.__dict__)
        w._ws = {}
        w._keep_obj = 0
        return w

    # ------------------------------------------------------------ evaluation
    def motor_values(self, t: float) -> None:
        """``(f, f_dot, f_ddot)`` of every motor at ``t`` into ``motor_f`` (displacement, then angle)."""
        mf = self.motor_f
        for k, mt in enumerate(self.motors):
            mf[k] = mt.values(t)
        if not math.isfinite(float(mf.sum())):
            raise ValueError(f"motor: a driving function returned a non-finite value at t={t:.6g}")

    def evaluate(self, t: float, y: np.ndarray, level: int) -> None:
        """Frames, table rows and constraint rows at ``(t, y)`` into the work arrays (after :meth:`select`)."""
        if self.motors:
            self.motor_values(t)
        K.call_packed(self.I, self.F, self.TI, self.W, y, 0, level, y, y, y)

    def applied(self, t: float, y: np.ndarray, loads) -> int:
        """``Q_e + Q_v`` into ``Q`` (needs :meth:`evaluate` at level 2); ``loads(t, y, F, T)`` fills the user loads."""
        if self.user_forces or self.user_torques:
            loads(t, y, self.uf_F, self.ut_T)
        return K.call_packed(self.I, self.F, self.TI, self.W, y, 1, 0, y, y, y)

    def solve(self, metric: int, rhs_v: np.ndarray, rhs_c: np.ndarray, x_v: np.ndarray) -> int:
        """``[[W, D^T], [D, 0]] [x; lam] = [rhs_v; rhs_c]`` with the current ``Jc``: W the mass blocks
        (``metric`` 0) or the projection metric (1); the multipliers in ``lam`` (see ``_kernel.augmented_solve``)."""
        return K.call_packed(self.I, self.F, self.TI, self.W, x_v, 2, metric, rhs_v, rhs_c, x_v)

    def dense_jacobian(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The constraint Jacobian D (m, 6n) of the last evaluation as a dense array (outside the hot path)."""
        n = self.n
        rr = np.arange(self.m) if rows is None else np.asarray(rows)
        D = np.zeros((rr.size, 6 * n))
        for q, r in enumerate(rr.tolist()):
            for s in range(3):
                b = int(self.jc_body[r, s])
                if b >= 0:
                    D[q, 3 * b : 3 * b + 3] += self.Jc[r, s, :3]
                    D[q, 3 * n + 3 * b : 3 * n + 3 * b + 3] += self.Jc[r, s, 3:]
        return D


def _dims(a: np.ndarray) -> tuple[int, int, int]:
    shp = tuple(int(d) for d in np.shape(a)) + (1, 1, 1)
    return shp[0], shp[1], shp[2]


def _chol_reciprocal(blocks: np.ndarray) -> np.ndarray:
    """Lower Cholesky factors of the 6 x 6 ``blocks`` with the diagonal replaced by its reciprocals."""
    L = np.linalg.cholesky(blocks) if blocks.size else np.zeros_like(blocks)
    for b in range(L.shape[0]):
        L[b][np.diag_indices(6)] = 1.0 / np.diag(L[b])
    return np.ascontiguousarray(L)


def _index(body: Any) -> int:
    """A body's index in the kernels' tables: ``-1`` for the ground."""
    return -1 if body.index < 0 else int(body.index)


def build_tree(n: int, jc_body: np.ndarray, rows) -> Tree:
    """Group the rows by the bodies they touch, pick a spanning forest and order it children first."""
    groups: dict[tuple, list[int]] = {}
    secondary: list[int] = []
    for r in rows:
        bodies = tuple(int(b) for b in jc_body[r] if b >= 0)
        if len(bodies) == 0 or len(bodies) > 2:
            secondary.append(r)
            continue
        groups.setdefault(bodies, []).append(r)
    parent = list(range(n + 1))  # union-find over the bodies and the ground (n)

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    tree_groups: list[tuple[tuple, list[int]]] = []
    for key, rr in groups.items():
        a, c = (key[0], n) if len(key) == 1 else key
        if len(rr) > 6 or find(a) == find(c):
            secondary += rr
            continue
        parent[find(a)] = find(c)
        tree_groups.append((key, rr))
    # bipartite forest: body nodes 0..n-1, group nodes n..n+G-1
    G = len(tree_groups)
    adj: list[list[int]] = [[] for _ in range(n + G)]
    ground_group = []
    for gi, (key, _) in enumerate(tree_groups):
        for b in key:
            adj[n + gi].append(b)
            adj[b].append(n + gi)
        if len(key) == 1:
            ground_group.append(n + gi)
    seen = [False] * (n + G)
    par = [-1] * (n + G)
    post: list[int] = []
    roots = ground_group + list(range(n)) + list(range(n, n + G))
    for root in roots:
        if seen[root]:
            continue
        seen[root] = True
        stack = [(root, 0)]
        while stack:
            v, k = stack[-1]
            if k < len(adj[v]):
                stack[-1] = (v, k + 1)
                w = adj[v][k]
                if not seen[w]:
                    seen[w] = True
                    par[w] = v
                    stack.append((w, 0))
            else:
                stack.pop()
                post.append(v)
    pos = {v: i for i, v in enumerate(post)}
    N = len(post)
    order_size = np.zeros(N, dtype=_I64)
    order_parent = np.full(N, -1, dtype=_I64)
    node_kind = np.zeros(N, dtype=_I64)
    node_ref = np.zeros(N, dtype=_I64)
    body_node = np.zeros(n, dtype=_I64)
    group_rows = np.full((max(G, 1), 6), -1, dtype=_I64)
    parent_slot = np.full(N, -1, dtype=_I64)
    leaf = np.zeros(N, dtype=_I64)
    group_slot_of = np.full((max(G, 1), 2), -1, dtype=_I64)

    def slot_of(group_node: int, body: int) -> int:
        rr = tree_groups[group_node - n][1]
        return [int(b) for b in jc_body[rr[0]] if b >= 0].index(body)

    for i, v in enumerate(post):
        pv = par[v]
        order_parent[i] = pos[pv] if pv >= 0 else -1
        if v < n:
            order_size[i] = 6
            leaf[i] = int(all(w == pv for w in adj[v]))  # no child group
            node_ref[i] = v
            body_node[v] = i
            if pv >= 0:
                parent_slot[i] = slot_of(pv, v)
        else:
            gi = v - n
            rr = tree_groups[gi][1]
            order_size[i] = len(rr)
            node_kind[i] = 1
            node_ref[i] = gi
            group_rows[gi, : len(rr)] = rr
            if pv >= 0:
                parent_slot[i] = slot_of(v, pv)
            child = [b for b in tree_groups[gi][0] if b != pv][0]
            group_slot_of[gi, 0] = slot_of(v, child)
            group_slot_of[gi, 1] = parent_slot[i]
    return Tree(order_size, order_parent, node_kind, node_ref, leaf, body_node, group_rows, group_slot_of,
                parent_slot, np.array(secondary, dtype=_I64))


def compile_engine(eng: Any) -> Compiled | None:
    """The compiled description of ``eng``, or None for what the kernels do not cover (contacts, a body
    with singular inertia)."""
    if eng.contacts or not eng.mass_regular or eng.n == 0:
        return None
    return Compiled(eng)
