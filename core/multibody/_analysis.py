"""Assembly (Newton onto the constraints), redundancy analysis and static equilibrium.

Corrections are least-change in the *projection metric* ``W`` (the mass
matrix, with ``m l^2 I`` standing in for a zero rotational inertia): the
Newton step ``dq = -W^-1 D^T (D W^-1 D^T)^+ C`` is the smallest change of
configuration, measured by kinetic energy, that removes the linearized
residual (a minimum-norm least-squares solution, so redundant rows do not
make it singular).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from rigidlab.core._validation import positive_integer, real_number

from ._engine import _Engine
from ._state import _make_state, retract

__all__ = ["RANK_TOL", "AssemblyError", "AssemblyReport", "EquilibriumReport"]

#: Rank tolerance of the constraint Jacobian: a row whose component
#: orthogonal to the rows before it (in the metric ``W``, rows scaled to unit
#: length) is below RANK_TOL is redundant.
RANK_TOL = 1e-8


class AssemblyError(ValueError):
    """The constraints cannot be satisfied (or statics not found) from the given configuration."""


@dataclass(frozen=True)
class AssemblyReport:
    """What :meth:`System.assemble` did.

    Attributes
    ----------
    iterations : int
        Newton iterations on the positions.
    displacement : mapping body name -> float
        Distance each centre of mass moved (m).
    rotation : mapping body name -> float
        Angle each body turned (rad).
    velocity_change : mapping body name -> float
        Norm of the change of ``(R_dot, omega_body)`` of each body by the
        velocity projection (m/s and rad/s taken together).
    moved : tuple of str
        Bodies whose position or orientation changed by more than 1e-12
        (m or rad).
    residual_position, residual_velocity : float
        ``max |C|`` and ``max |D v + C_t|`` after assembly.
    n_constraints : int
        Constraint equations (joint rows and motors).
    rank : int
        Independent equations.
    redundant : tuple of str
        The redundant rows, as ``"<joint> (<kind>): <row>"``; their
        multipliers are zero in the dynamics (see docs/multibody.md).
    degrees_of_freedom : int
        ``6 n - rank``.
    """

    iterations: int
    displacement: Mapping[str, float] = field(repr=False)
    rotation: Mapping[str, float] = field(repr=False)
    velocity_change: Mapping[str, float] = field(repr=False)
    moved: tuple[str, ...]
    residual_position: float
    residual_velocity: float
    n_constraints: int
    rank: int
    redundant: tuple[str, ...]
    degrees_of_freedom: int

    def __str__(self) -> str:
        lines = [
            f"assembled in {self.iterations} iterations: residual {self.residual_position:.2e} (positions), "
            f"{self.residual_velocity:.2e} (velocities)",
            f"{self.n_constraints} constraint equations, rank {self.rank}, "
            f"{self.degrees_of_freedom} degrees of freedom",
        ]
        if self.redundant:
            lines.append("redundant: " + "; ".join(self.redundant))
        for name in self.moved:
            lines.append(f"  moved {name}: {self.displacement[name]:.3e} m, {self.rotation[name]:.3e} rad")
        return "\n".join(lines)


@dataclass(frozen=True)
class EquilibriumReport:
    """What :meth:`System.equilibrium` did.

    Attributes
    ----------
    iterations : int
    displacement, rotation : mapping body name -> float
        How far each body moved (m) and turned (rad) from the start.
    moved : tuple of str
    residual_force : float
        ``max |Q - D^T lambda|`` at the result (N and N m).
    residual_position : float
        ``max |C|``.
    multipliers : (m,) ndarray
        Lagrange multipliers of the constraint rows (zero for redundant
        rows); the joint reactions are ``-D^T lambda``.
    """

    iterations: int
    displacement: Mapping[str, float] = field(repr=False)
    rotation: Mapping[str, float] = field(repr=False)
    moved: tuple[str, ...]
    residual_force: float
    residual_position: float
    multipliers: np.ndarray = field(repr=False)


# ------------------------------------------------------------- helpers
def constraints_at(eng: _Engine, t: float, y: np.ndarray, level: int):
    """``(C, D, C_t, gamma)`` of all constraint rows at ``y`` (D, gamma None below their level)."""
    At, Y, Phi, gam = eng.table(t, y, level=level)
    return eng.constraint_rows(t, Y, Phi, gam, level=level)


def assembly_rows(eng: _Engine, t: float, y: np.ndarray):
    """``(C, D)`` of the position constraints for Newton in assembly (rolling rows left out).

    The angle motors' rows are the wrapped angle error.

    The driving constraint ``sin(theta - f) = 0`` also holds at ``theta = f +
    pi``, and Newton on the sine from more than a quarter turn away goes
    there; ``atan2(sin, cos)`` of the error has the one root ``theta = f``
    in ``(-pi, pi]`` and the Jacobian ``(c ds - s dc) / (s^2 + c^2)``.
    """
    At, Y, Phi, gam = eng.table(t, y, level=1)
    C, D, _, _ = eng.constraint_rows(t, Y, Phi, gam, level=1)
    if eng.m_holo < eng.m:  # rolling rows constrain velocities only
        C, D = C[: eng.m_holo], D[: eng.m_holo]
    if not eng.angle_motors:
        return C, D
    C = np.array(C)
    D = np.array(D)
    s, c, ds, dc = eng.angle_motor_errors(t, Phi)
    r = slice(eng.m_dir, eng.m_motor)
    C[r] = np.arctan2(s, c)
    D[r] = (c[:, None] * ds - s[:, None] * dc) / (s * s + c * c)[:, None]
    return C, D


def flipped_motors(eng: _Engine, t: float, y: np.ndarray) -> list:
    """Angle motors whose joint is nearer ``f(t) + pi`` than ``f(t)`` (``cos(theta - f) < 0``)."""
    if not eng.angle_motors:
        return []
    At, Y, Phi, gam = eng.table(t, y, level=1)
    _, c, _, _ = eng.angle_motor_errors(t, Phi)
    return [mt for mt, ck in zip(eng.angle_motors, c) if ck < 0.0]


def metric_inv_sqrt(eng: _Engine) -> np.ndarray:
    """Dense (6n, 6n) ``W^-1/2`` of the projection metric."""
    n = eng.n
    out = np.zeros((6 * n, 6 * n))
    for b in range(2 * n):
        w, V = np.linalg.eigh(eng.winv_blocks[b])
        out[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = (V * np.sqrt(np.maximum(w, 0.0))) @ V.T
    return out


def row_label(eng: _Engine, r: int) -> str:
    item, label = eng.row_labels[r]
    kind = getattr(item, "kind", None) or f"motor {item.coordinate}"
    return f"{item.name} ({kind}): {label}"


def independent_rows(eng: _Engine, D: np.ndarray) -> np.ndarray:
    """Indices of the rows of D kept in order (Gram-Schmidt in the metric W, tolerance RANK_TOL)."""
    m = D.shape[0]
    if m == 0:
        return np.zeros(0, dtype=np.intp)
    Dw = D @ metric_inv_sqrt(eng)
    norms = np.linalg.norm(Dw, axis=1)
    keep: list[int] = []
    basis = np.zeros((0, Dw.shape[1]))
    for r in range(m):
        if norms[r] == 0.0:
            continue
        v = Dw[r] / norms[r]
        for _ in range(2):  # twice is enough (Kahan)
            v = v - basis.T @ (basis @ v)
        nv = float(np.linalg.norm(v))
        if nv > RANK_TOL:
            keep.append(r)
            basis = np.vstack([basis, v / nv])
    return np.array(keep, dtype=np.intp)


def analyze_rank(eng: _Engine, t: float, y: np.ndarray) -> np.ndarray:
    """Set ``eng.keep`` / ``eng.rank`` from the Jacobian at ``y``; return the kept rows."""
    if eng.m == 0:
        eng.keep, eng.rank = None, 0
        return np.zeros(0, dtype=np.intp)
    _, D, _, _ = constraints_at(eng, t, y, 1)
    keep = independent_rows(eng, np.array(D))
    eng.rank = int(keep.size)
    eng.keep = None if keep.size == eng.m else keep
    eng.K_aug = None
    if not eng.mass_regular:
        r = keep.size
        K = np.zeros((6 * eng.n + r, 6 * eng.n + r))
        K[: 6 * eng.n, : 6 * eng.n] = eng.M
        eng.K_aug = K
    eng.analyzed = True
    return keep


def check_constrained_mass(eng: _Engine, t: float, y: np.ndarray) -> None:
    """Raise when M is singular on the motions the joints allow (a point mass whose rotation is free)."""
    if eng.mass_regular:
        return
    from ._engine import SingularSystemError

    _, D, _, _ = constraints_at(eng, t, y, 1)
    D = np.array(D)
    if eng.keep is not None:
        D = D[eng.keep]
    n6 = 6 * eng.n
    if D.shape[0]:
        _, s, Vt = np.linalg.svd(D)
        rank = int(np.sum(s > RANK_TOL * s[0]))
        N = Vt[rank:].T
    else:
        N = np.eye(n6)
    if N.shape[1] == 0:
        return
    Mr = N.T @ eng.M @ N
    w, V = np.linalg.eigh(0.5 * (Mr + Mr.T))
    scale = max(float(np.max(np.abs(eng.M))), 1e-300)
    if w[0] <= 1e-12 * scale:
        motion = N @ V[:, 0]
        n = eng.n
        rot = np.abs(motion[3 * n :]).reshape(n, 3).max(axis=1)
        names = [eng.bodies[k].name for k in range(n) if rot[k] > 1e-6 and not np.any(eng.inertia[k])]
        names = names or [b.name for b in eng.singular_bodies]
        raise SingularSystemError(
            "the constrained mass matrix is singular: the joints leave a motion without inertia "
            f"(a rotation of zero-inertia bodies {names}); fix their rotation with joints or give them inertia",
            t=t,
        )


def _moves(eng: _Engine, y0: np.ndarray, y: np.ndarray) -> tuple[dict, dict, tuple]:
    n = eng.n
    disp, rot = {}, {}
    moved = []
    R0, R1 = y0[: 3 * n].reshape(n, 3), y[: 3 * n].reshape(n, 3)
    P0, P1 = y0[3 * n : 7 * n].reshape(n, 4), y[3 * n : 7 * n].reshape(n, 4)
    for k, b in enumerate(eng.bodies):
        d = float(np.linalg.norm(R1[k] - R0[k]))
        c = abs(float(P0[k] @ P1[k]) / (np.linalg.norm(P0[k]) * np.linalg.norm(P1[k])))
        a = 2.0 * float(np.arccos(min(1.0, c)))
        if a < 1e-7:  # arccos loses accuracy near 1; use the vector part
            w0, v0 = P0[k][0], P0[k][1:]
            w1, v1 = P1[k][0], P1[k][1:]
            rel = w0 * v1 - w1 * v0 - np.cross(v0, v1)
            a = 2.0 * float(np.linalg.norm(rel))
        disp[b.name] = d
        rot[b.name] = a
        if d > 1e-12 or a > 1e-12:
            moved.append(b.name)
    return disp, rot, tuple(moved)


def _args(system: Any, t: Any, tol: Any, max_iterations: Any) -> tuple[float, float, int]:
    t = system._t if t is None else real_number(t, "t", expected="a finite time (s)")
    tol = real_number(tol, "tol", expected="a finite tolerance > 0")
    if not tol > 0.0:
        raise ValueError(f"tol: expected a finite tolerance > 0, got {tol!r}")
    return t, tol, positive_integer(max_iterations, "max_iterations")


def _newton_positions(eng: _Engine, t: float, y: np.ndarray, tol: float, max_iterations: int, what: str):
    """Newton with minimum-norm steps and halving; returns (y, iterations, residual)."""
    n = eng.n
    Wmh = metric_inv_sqrt(eng)
    it = 0
    C, D = assembly_rows(eng, t, y)
    res = float(np.max(np.abs(C))) if C.size else 0.0
    while res > tol:
        if it >= max_iterations:
            _fail(eng, C, it, f"{what}: the constraints could not be satisfied in {max_iterations} iterations")
        Dw = np.array(D) @ Wmh
        sol = np.linalg.lstsq(Dw, C, rcond=1e-12)[0]
        step = -(Wmh @ sol)
        lam = 1.0
        while True:
            y_try = retract(y, n, lam * step)
            C_try, D_try = assembly_rows(eng, t, y_try)
            res_try = float(np.max(np.abs(C_try)))
            if res_try < res or lam < 1e-4:
                break
            lam *= 0.5
        it += 1
        if not res_try < res:
            _fail(eng, C, it, f"{what}: Newton stalled at residual {res:.3e}; the joints cannot all hold at once "
                              "from this configuration (incompatible joints or a configuration too far from an "
                              "assembled one)")
        y, C, D, res = y_try, C_try, D_try, res_try
    return y, it, res


def _fail(eng: _Engine, C: np.ndarray, it: int, message: str) -> None:
    r = int(np.argmax(np.abs(C)))
    raise AssemblyError(f"{message}; largest residual {abs(float(C[r])):.3e} in {row_label(eng, r)}")


# ------------------------------------------------------------- assemble
def assemble(system: Any, *, t: Any = None, tol: Any = 1e-12, max_iterations: Any = 50) -> AssemblyReport:
    """See :meth:`System.assemble`."""
    t, tol, max_iterations = _args(system, t, tol, max_iterations)
    shared = system._engine()
    eng = shared.workspace()
    n = eng.n
    y0 = np.array(system._y)
    y = y0.copy()
    it, res = 0, 0.0
    if eng.m:
        y, it, res = _newton_positions(eng, t, y, tol, max_iterations, "assemble")
        keep = analyze_rank(eng, t, y)
        C, D, Ct, _ = constraints_at(eng, t, y, 1)
        D = np.array(D)
        Wmh = metric_inv_sqrt(eng)
        v = y[7 * n :]
        r = D @ v + Ct
        dv = -(Wmh @ np.linalg.lstsq(D @ Wmh, r, rcond=1e-12)[0])
        y[7 * n :] = v + dv
        rv = D @ y[7 * n :] + Ct
        res_v = float(np.max(np.abs(rv)))
        if res_v > 1e-8 * (1.0 + float(np.max(np.abs(y[7 * n :])))):  # (simulate's limit: it would refuse the state)
            r = int(np.argmax(np.abs(rv)))
            raise AssemblyError(
                f"assemble: the velocity constraints contradict each other at t={t:g} (velocity residual "
                f"{res_v:.3e} after the least-squares velocities; largest in {row_label(eng, r)}): rows that are "
                "redundant in the positions prescribe different velocities, e.g. a motor driving a coordinate "
                "that other joints or motors already fix")
        rank = int(keep.size)
    else:
        eng.keep, eng.rank = None, 0
        res_v, rank = 0.0, 0
        eng.analyzed = True
    check_constrained_mass(eng, t, y)
    shared.adopt(eng)
    disp, rot, moved = _moves(eng, y0, y)
    dvel = {b.name: float(np.linalg.norm(np.concatenate([
        y[7 * n + 3 * k : 7 * n + 3 * k + 3] - y0[7 * n + 3 * k : 7 * n + 3 * k + 3],
        y[10 * n + 3 * k : 10 * n + 3 * k + 3] - y0[10 * n + 3 * k : 10 * n + 3 * k + 3]]))) for k, b in enumerate(eng.bodies)}
    system._y = y
    system._t = t
    system._sync_contacts(eng)
    redundant = tuple(row_label(eng, r) for r in range(eng.m) if eng.keep is not None and r not in set(eng.keep.tolist()))
    return AssemblyReport(
        iterations=it,
        displacement=MappingProxyType(disp),
        rotation=MappingProxyType(rot),
        velocity_change=MappingProxyType(dvel),
        moved=moved,
        residual_position=res,
        residual_velocity=res_v,
        n_constraints=eng.m,
        rank=rank,
        redundant=redundant,
        degrees_of_freedom=6 * n - rank,
    )


# ------------------------------------------------------------- statics
def _static_residual(eng: _Engine, system: Any, t: float, y: np.ndarray, lam: np.ndarray, keep: np.ndarray):

    At, Y, Phi, gam = eng.table(t, y, level=2)
    C, D, _, _ = eng.constraint_rows(t, Y, Phi, gam, level=1)
    Q = eng.applied(t, y, At, Y, Phi, lambda tt, yy: _make_state(system, tt, yy))
    Dk = np.array(D)[keep]
    return np.concatenate([Q - Dk.T @ lam, C[keep]]), Q, Dk, C


def equilibrium(system: Any, *, t: Any = None, tol: Any = 1e-10, max_iterations: Any = 50) -> EquilibriumReport:
    """See :meth:`System.equilibrium`."""
    t, tol, max_iterations = _args(system, t, tol, max_iterations)
    if not system.bodies:
        raise ValueError("system: has no bodies to hold in equilibrium (add_body first)")
    shared = system._engine()
    eng = shared.workspace()
    n = eng.n
    n6 = 6 * n
    y0 = np.array(system._y)
    y = y0.copy()
    y[7 * n :] = 0.0
    if eng.m:
        y, _, _ = _newton_positions(eng, t, y, 1e-12, max_iterations, "equilibrium")
        keep = analyze_rank(eng, t, y)
    else:
        keep = np.zeros(0, dtype=np.intp)
        eng.keep, eng.rank, eng.analyzed = None, 0, True
    r = keep.size
    F, Q, Dk, C = _static_residual(eng, system, t, y, np.zeros(r), keep)
    lam = np.linalg.lstsq(Dk.T, Q, rcond=1e-12)[0] if r else np.zeros(0)
    F, Q, Dk, C = _static_residual(eng, system, t, y, lam, keep)
    fscale = max(float(np.max(np.abs(Q))) if Q.size else 0.0, 1e-300)
    Wmh = metric_inv_sqrt(eng)
    length = max(1.0, float(np.max(np.abs(y[: 3 * n]))) if n else 1.0)

    def merit(F: np.ndarray) -> float:
        return float(np.max(np.abs(F[:n6]))) / fscale + (float(np.max(np.abs(F[n6:]))) * 1e-3 if r else 0.0)

    it = 0
    while not (np.max(np.abs(F[:n6])) <= tol * fscale and (r == 0 or np.max(np.abs(F[n6:])) <= 1e-12)):
        if it >= max_iterations:
            raise AssemblyError(
                f"equilibrium: no static equilibrium found in {max_iterations} iterations (force residual "
                f"{float(np.max(np.abs(F[:n6]))):.3e} N or N m); the system may have none near this configuration"
            )
        # Jacobian: tangent columns by central differences (scaled by W^-1/2), multiplier columns exact
        J = np.zeros((n6 + r, n6 + r))
        for k in range(n6):
            h = 1e-6 * (length if k < 3 * n else 1.0)
            dq = Wmh[:, k] * (h / max(float(np.max(np.abs(Wmh[:, k]))), 1e-300))
            Fp = _static_residual(eng, system, t, retract(y, n, dq), lam, keep)[0]
            Fm = _static_residual(eng, system, t, retract(y, n, -dq), lam, keep)[0]
            J[:, k] = (Fp - Fm) / 2.0
            J[:, k] /= h / max(float(np.max(np.abs(Wmh[:, k]))), 1e-300)
        J[:n6, n6:] = -Dk.T
        # columns k correspond to dq = Wmh e_k: x = (z, lam) with dq = Wmh z
        sol = np.linalg.lstsq(J, -F, rcond=1e-13)[0]
        dz, dlam = sol[:n6], sol[n6:]
        step = 1.0
        m0 = merit(F)
        while True:
            y_try = retract(y, n, step * (Wmh @ dz))
            lam_try = lam + step * dlam
            F_try, Q_try, Dk_try, C_try = _static_residual(eng, system, t, y_try, lam_try, keep)
            if merit(F_try) < m0 or step < 1e-4:
                break
            step *= 0.5
        it += 1
        if not merit(F_try) < m0:
            raise AssemblyError(
                f"equilibrium: Newton stalled at force residual {float(np.max(np.abs(F[:n6]))):.3e}; "
                "no equilibrium found near this configuration"
            )
        y, lam, F, Q, Dk, C = y_try, lam_try, F_try, Q_try, Dk_try, C_try
    shared.adopt(eng)
    disp, rot, moved = _moves(eng, y0, y)
    system._y = y
    system._t = t
    system._sync_contacts(eng)
    lam_full = np.zeros(eng.m)
    lam_full[keep] = lam
    lam_full.setflags(write=False)
    return EquilibriumReport(
        iterations=it,
        displacement=MappingProxyType(disp),
        rotation=MappingProxyType(rot),
        moved=moved,
        residual_force=float(np.max(np.abs(F[:n6]))) if n6 else 0.0,
        residual_position=float(np.max(np.abs(C))) if C.size else 0.0,
        multipliers=lam_full,
    )
