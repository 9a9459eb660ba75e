r"""Stability and eigenvalue analysis of constrained multibody systems (Eqs. 8.110-8.131).

Three steps, each a function of data (MuJoCo's model/data split: nothing
here changes a System):

* :func:`linearize` (Eqs. 8.110-8.112): the equations of motion of a
  :class:`rigidlab.core.multibody.System` linearized about its current state (an
  equilibrium or a steady motion) and embedded in the degrees of freedom
  through an orthonormal basis of the null space of the constraint
  Jacobian: ``M u_ddot + (C + G) u_dot + K u = 0``. ``K`` holds the
  stiffness of the applied forces *and* the geometric stiffness of the
  constraint forces (the derivative of ``C_q^T lambda``).
* :meth:`LinearModel.modes` (Eqs. 8.113-8.131): the undamped generalized
  symmetric eigenproblem ``K phi = omega^2 M phi`` when there is no
  velocity coupling, else the state-space problem ``A x = s x``; real mode
  shapes from conjugate pairs, ``omega_n = abs(s)`` and ``xi = -Re(s) /
  abs(s)``, stability from the real parts.
* :func:`sweep`: the modes over a parameter (Campbell diagrams, root
  loci) on any :class:`concurrent.futures.Executor`, modes tracked by shape
  correlation, stability boundaries by root finding.

Conventions: SI units, global +Z up; in the tangent coordinates of a
linearization a body's perturbation is ``(dR, dtheta)``, a translation of
its centre of mass and a small rotation, both global (``A = exp(skew(dtheta))
A0``); :meth:`Modes.body_shapes` returns them in the layout of
:meth:`rigidlab.core.multibody.State.displaced` (rotations in the body frame). The
formulation is explained in ``docs/modal.md``.

Example::

    from rigidlab.core.models import pendulum_chain
    from rigidlab.core.modal import linearize
    modes = linearize(pendulum_chain(3, kind="point")).modes()
    modes.frequency_hz[::2]        # one entry per conjugate pair
"""

from __future__ import annotations

import concurrent.futures
import csv
import io
import json
import math
import os
import pickle
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse
from scipy.optimize import brentq, linear_sum_assignment

from rigidlab.core._errors import RigidModeWarning
from rigidlab.core._validation import float_array, real_number, short_repr

__all__ = [
    "RIGID_TOL",
    "RigidModeWarning",
    "STABILITY_TOL",
    "Embedding",
    "LinearModel",
    "ModeMotion",
    "Modes",
    "SweepResult",
    "linearize",
    "sweep",
]

#: Relative tolerance of the real parts: a mode with ``Re(s) <= STABILITY_TOL *
#: scale`` is stable and one with ``abs(Re(s)) <= STABILITY_TOL * scale`` is
#: critical (undamped), ``scale`` the largest ``abs(s)`` of the model. Within
#: a cluster of roots closer than ``2 RIGID_TOL * scale`` (a multiple root
#: split by round-off) the tolerance is ``RIGID_TOL * scale``.
STABILITY_TOL = 1e-8
#: Relative tolerance of a rigid-body (zero) mode: ``abs(s) <= RIGID_TOL *
#: scale`` (a double zero eigenvalue moves by the square root of the
#: round-off in ``K``, so this is looser than ``STABILITY_TOL``).
RIGID_TOL = 1e-5
#: Relative asymmetry of ``K`` up to which the undamped problem is solved as
#: the symmetric ``K phi = omega^2 M phi`` (Eqs. 8.113-8.116).
SYMMETRY_TOL = 1e-9
#: Relative size (to the largest entry) up to which a singular value counts as
#: zero when the structural zeros of a state-space problem are split off
#: (motions no force depends on, see ``LinearModel.modes``); the others must
#: exceed ``STRUCTURAL_GAP``, else nothing is split off.
STRUCTURAL_TOL = 1e-12
STRUCTURAL_GAP = 1e-6
#: Finite-difference step of the positions: ``STEP * l`` (m) for a body with
#: length scale ``l`` and ``STEP`` rad for rotations; Richardson-extrapolated.
STEP = 3e-4


# ------------------------------------------------------------------ validation
def _matrix(x: Any, name: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    a = float_array(x, name, expected="a 2-d array of real numbers", copy=True)
    if a.ndim != 2 or (shape is not None and a.shape != shape):
        want = f"shape {shape}" if shape is not None else "a 2-d array"
        raise ValueError(f"{name}: expected {want}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite values")
    a.setflags(write=False)
    return a


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


# ------------------------------------------------------------------ embedding

@dataclass(frozen=True)
class Embedding:
    """How the degrees of freedom of a :func:`linearize` model map to the bodies.

    ``n`` bodies; tangent coordinates ``z = [dR (3n) | dtheta (3n)]``
    (translations of the centres of mass and small rotations, both global at
    time ``t``, measured in the observer frame turning at ``frame_omega``).

    Attributes
    ----------
    basis : (6n, f) ndarray
        Orthonormal basis of the position perturbations the constraints
        allow: ``z = basis @ u`` (Eq. 8.111).
    velocity_basis : (6n, f_v) ndarray
        The same for the velocities (equal to ``basis`` without rolling
        constraints): ``z_dot = velocity_basis @ s``.
    t : float
        Time of the reference state (s).
    q0 : (7n,) ndarray
        Reference configuration ``[R, p]`` (m; Euler parameters, scalar first).
    v0 : (6n,) ndarray
        Reference velocities ``[R_dot, omega_body]`` (m/s; rad/s, body frame).
    frame_omega : (3,) ndarray
        Angular velocity of the observer frame (global, rad/s).
    body_names : tuple of str
    n_rows : int
        Constraint rows of the System (a check that ``body_shapes`` gets the
        same System).
    """

    basis: np.ndarray = field(repr=False)  # (6n, f)
    velocity_basis: np.ndarray = field(repr=False)  # (6n, f_v)
    t: float
    q0: np.ndarray = field(repr=False)  # (7n,)
    v0: np.ndarray = field(repr=False)  # (6n,)
    frame_omega: np.ndarray  # (3,)
    body_names: tuple[str, ...]
    n_rows: int

    @property
    def n_bodies(self) -> int:
        """Number of bodies."""
        return len(self.body_names)

    def check(self, system: Any) -> None:
        """Raise ValueError unless ``system`` has the bodies and rows this embedding was made for."""
        from rigidlab.core.multibody import System

        if not isinstance(system, System):
            raise ValueError(f"system: expected a rigidlab.core.multibody.System, got {short_repr(system)}")
        names = tuple(b.name for b in system.bodies)
        rows = system._engine().m
        if names != self.body_names or rows != self.n_rows:
            raise ValueError(
                f"system: expected the System that was linearized ({self.n_bodies} bodies, {self.n_rows} constraint "
                f"rows), got one with {len(names)} bodies and {rows} rows"
            )

    def body_coordinates(self, z: np.ndarray) -> np.ndarray:
        """Tangent vectors ``z`` (..., 6n) in the layout of ``State.displaced``: ``[dR (3n) | dpi_body (3n)]``."""
        n = self.n_bodies
        from rigidlab.core.multibody._engine import matrices

        A = matrices(self.q0[3 * n :].reshape(n, 4))
        out = np.array(z, copy=True)
        th = out[..., 3 * n :].reshape(out.shape[:-1] + (n, 3))
        out[..., 3 * n :] = np.einsum("bji,...bj->...bi", A, th).reshape(out.shape[:-1] + (3 * n,))
        return out


# ------------------------------------------------------------------ linear model
class LinearModel:
    r"""A linear(ized) mechanical system ``M u_ddot + (C + G) u_dot + K u = 0`` (Eq. 8.112).

    Parameters
    ----------
    M : (f_v, f_v) array_like
        Mass matrix, symmetric positive definite.
    K : (f_v, f) array_like
        Stiffness (square unless ``velocity_map`` is given); not
        symmetrized (a skew part is a circulatory force).
    C : (f_v, f_v) array_like or None
        Damping (symmetric for viscous damping; any matrix is accepted).
    G : (f_v, f_v) array_like or None
        Gyroscopic matrix, skew-symmetric (relative tolerance 1e-9).
    velocity_map : (f, f_v) array_like or None, keyword-only
        Rolling (nonholonomic) systems only: ``u_dot = velocity_map @ s``
        with ``s`` the ``f_v < f`` independent velocities; then the
        equations are ``M s_dot + (C + G) s + K u = 0``. Default: the
        identity (``s = u_dot``).
    position_rate_map : (f, f) array_like or None, keyword-only
        Rolling systems in steady motion only: ``u_dot = velocity_map @ s
        + position_rate_map @ u`` (a turned wheel rolling at speed moves
        sideways: the rolling constraints of the perturbed motion depend on
        the positions too). Needs ``velocity_map``. Default: zero.
    embedding : Embedding or None, keyword-only
        Set by :func:`linearize`: how ``u`` maps to the bodies.
    derivative_error : float, keyword-only
        Estimated relative error of the finite-difference derivatives
        (set by :func:`linearize`; 0 for exact matrices).

    Raises
    ------
    ValueError
        Naming the matrix: wrong shape, not finite, ``M`` not symmetric
        positive definite, ``G`` not skew-symmetric, complex entries.
    """

    def __init__(self, M: Any, K: Any, C: Any = None, G: Any = None, *, velocity_map: Any = None,
                 position_rate_map: Any = None, embedding: Embedding | None = None, derivative_error: float = 0.0):
        M = _matrix(M, "M")
        if M.shape[0] != M.shape[1] or M.shape[0] == 0:
            raise ValueError(f"M: expected a non-empty square matrix, got shape {M.shape}")
        fv = M.shape[0]
        scale = max(float(np.max(np.abs(M))), 1e-300)
        if np.max(np.abs(M - M.T)) > 1e-9 * scale:
            raise ValueError("M: expected a symmetric matrix")
        try:
            np.linalg.cholesky(0.5 * (M + M.T))
        except np.linalg.LinAlgError:
            raise ValueError("M: expected a positive definite mass matrix") from None
        if velocity_map is None:
            T = None
            f = fv
        else:
            T = _matrix(velocity_map, "velocity_map")
            if T.shape[1] != fv or T.shape[0] < fv:
                raise ValueError(f"velocity_map: expected shape (f, {fv}) with f >= {fv}, got {T.shape}")
            f = T.shape[0]
        K = _matrix(K, "K", (fv, f))
        Y = None
        if position_rate_map is not None:
            if T is None:
                raise ValueError("position_rate_map: needs a velocity_map (rolling systems only)")
            Y = _matrix(position_rate_map, "position_rate_map", (f, f))
        C = None if C is None else _matrix(C, "C", (fv, fv))
        G = None if G is None else _matrix(G, "G", (fv, fv))
        if G is not None:
            gs = max(float(np.max(np.abs(G))), 1e-300)
            if np.max(np.abs(G + G.T)) > 1e-9 * gs:
                raise ValueError("G: expected a skew-symmetric gyroscopic matrix (G^T = -G)")
        if embedding is not None and not isinstance(embedding, Embedding):
            raise ValueError(f"embedding: expected an Embedding or None, got {short_repr(embedding)}")
        self.M, self.K, self.C, self.G = M, K, C, G
        self.velocity_map = T
        self.position_rate_map = Y
        self.embedding = embedding
        err = real_number(derivative_error, "derivative_error", expected="a finite relative error >= 0")
        if not err >= 0.0:
            raise ValueError(f"derivative_error: expected a finite relative error >= 0, got {err!r}")
        self.derivative_error = err

    def __repr__(self) -> str:
        parts = [f"{self.n_dof} degrees of freedom"]
        if self.velocity_map is not None:
            parts.append(f"{self.M.shape[0]} independent velocities")
        parts.append("damped" if self.C is not None and np.any(self.C) else "undamped")
        if self.G is not None and np.any(self.G):
            parts.append("gyroscopic")
        return f"LinearModel({', '.join(parts)})"

    def __getstate__(self) -> dict:
        return dict(self.__dict__)

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    @property
    def n_dof(self) -> int:
        """Number of position coordinates ``f``."""
        return self.K.shape[1]

    @property
    def velocity_matrix(self) -> np.ndarray:
        """(f_v, f_v) ``C + G``: damping and gyroscopic coupling together (never symmetrized)."""
        out = np.zeros_like(self.M)
        if self.C is not None:
            out = out + self.C
        if self.G is not None:
            out = out + self.G
        return out

    def state_matrix(self) -> np.ndarray:
        r"""The first-order system matrix (Eqs. 8.117-8.120).

        ``x = [u, u_dot]`` (or ``[u, s]``):

        .. math:: \dot x = \begin{bmatrix} Y & T \\ -M^{-1} K & -M^{-1}(C + G) \end{bmatrix} x

        (``T`` the velocity map, the identity without rolling rows; ``Y``
        the position rate map, zero unless a rolling system moves).

        Returns
        -------
        (f + f_v, f + f_v) ndarray
        """
        f, fv = self.n_dof, self.M.shape[0]
        T = np.eye(f) if self.velocity_map is None else self.velocity_map
        cho = scipy.linalg.cho_factor(0.5 * (self.M + self.M.T))
        A = np.zeros((f + fv, f + fv))
        A[:f, f:] = T
        if self.position_rate_map is not None:
            A[:f, :f] = self.position_rate_map
        A[f:, :f] = -scipy.linalg.cho_solve(cho, self.K)
        A[f:, f:] = -scipy.linalg.cho_solve(cho, self.velocity_matrix)
        return A

    def _undamped_symmetric(self) -> bool:
        if self.velocity_map is not None:
            return False
        if (self.C is not None and np.any(self.C)) or (self.G is not None and np.any(self.G)):
            return False
        ks = max(float(np.max(np.abs(self.K))), 1e-300)
        return bool(np.max(np.abs(self.K - self.K.T)) <= SYMMETRY_TOL * ks)

    def modes(self) -> Modes:
        """Eigenvalues, natural frequencies, damping ratios and mode shapes (Eqs. 8.113-8.131).

        Without damping, gyroscopic coupling or a skew part of ``K``: the
        generalized symmetric problem ``K phi = omega^2 M phi``
        (``scipy.linalg.eigh``, Eqs. 8.113-8.116), ``s = +-i omega`` (``+-
        sqrt(-omega^2)`` for a negative stiffness). Otherwise the state-space
        problem of :meth:`state_matrix` (``scipy.linalg.eig``, Eqs.
        8.117-8.124).

        Returns
        -------
        Modes
        """
        f = self.n_dof
        if self._undamped_symmetric():
            Ks = 0.5 * (self.K + self.K.T)
            lam, phi = scipy.linalg.eigh(Ks, 0.5 * (self.M + self.M.T))
            big = max(float(np.max(np.abs(lam))), 1e-300)
            root = np.sqrt(np.abs(lam))
            s = np.zeros((f, 2), dtype=complex)  # per eigenvalue omega^2: the pair of roots
            up, down = lam > RIGID_TOL**2 * big, lam < -(RIGID_TOL**2) * big
            s[up, 0], s[up, 1] = 1j * root[up], -1j * root[up]
            s[down, 0], s[down, 1] = -root[down], root[down]
            s = s.ravel()
            X = np.repeat(phi.T.astype(complex), 2, axis=0)
            method = "symmetric"
        else:
            A = self.state_matrix()
            Q = _structural_subspace(A, f)
            if Q.shape[1] == 0:
                s, V = scipy.linalg.eig(A)
                X = V[:f].T.copy()
                return _modes(s, X, method="state-space", embedding=self.embedding)
            s, V, structural = _deflated_eig(A, Q)
            return _modes(s, V[:f].T.copy(), method="state-space", embedding=self.embedding, structural=structural)
        return _modes(s, X, method=method, embedding=self.embedding)


def _null_columns(X: np.ndarray, scale: float) -> np.ndarray | None:
    """Orthonormal basis (cols, k) of the vectors that ``X`` maps below ``STRUCTURAL_TOL * scale`` (SVD);
    None when a singular value lies between that and ``STRUCTURAL_GAP * scale`` (no clear rank)."""
    if X.shape[0] == 0:
        return np.eye(X.shape[1])
    _, sv, Vt = scipy.linalg.svd(X)
    if np.any((sv > STRUCTURAL_TOL * scale) & (sv <= STRUCTURAL_GAP * scale)):
        return None
    rank = int(np.sum(sv > STRUCTURAL_TOL * scale))
    return Vt[rank:].T.copy()


def _structural_subspace(A: np.ndarray, f: int) -> np.ndarray:
    """Orthonormal basis (f + f_v, d) of the motions that never meet a force: the largest invariant subspace
    of the state matrix ``A`` on which the accelerations (rows ``f:``) vanish.

    Ignorable coordinates (a position on which no force depends, a free spin,
    the heading and place of a rolling body) and the velocities that only
    move them span it; their eigenvalues are structural zeros. Iterated
    as ``S_0 = ker A[f:]``, ``S_k+1 = {x in S_k: A x in S_k}``; null spaces by
    SVD, a singular value counting as zero up to ``STRUCTURAL_TOL`` times the
    largest entry. When one lies between that and ``STRUCTURAL_GAP`` (a
    mode so slow that it cannot be told from a structural one) the result
    is empty: nothing is split off.
    """
    n = A.shape[0]
    empty = np.zeros((n, 0))
    scale = max(float(np.max(np.abs(A))), 1e-300)
    H = A[f:]
    Q = _null_columns(H, max(float(np.max(np.abs(H))), 1e-300))
    while Q is not None and Q.shape[1]:
        AQ = A @ Q
        c = _null_columns(AQ - Q @ (Q.T @ AQ), scale)
        if c is None or c.shape[1] == Q.shape[1]:
            Q = None if c is None else Q
            break
        Q, _ = scipy.linalg.qr(Q @ c, mode="economic")
    return empty if Q is None or Q.shape[1] in (0, n) else Q


def _deflated_eig(A: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors of ``A`` with the invariant subspace ``Q`` split off.

    In the orthonormal basis ``[Q, P]`` the matrix is block triangular,
    ``[[A11, A12], [0, A22]]``: the eigenvalues of ``A22`` (the dynamics
    the forces see) are computed apart from the structural ones of
    ``A11``, so that a cluster of structural zeros (a defective eigenvalue,
    sensitive to round-off) cannot spoil a small eigenvalue next to it.
    An eigenvector of ``A22`` is completed by its part in ``Q``,
    ``(s I - A11) z = A12 y``. Returns ``(s, V, structural)``.
    """
    n, d = Q.shape
    full, _ = scipy.linalg.qr(Q, mode="full")
    P = full[:, d:]
    A11 = Q.T @ A @ Q
    A12 = Q.T @ A @ P
    A22 = P.T @ A @ P
    s1, Y1 = scipy.linalg.eig(A11)
    s2, Y2 = scipy.linalg.eig(A22)
    V2 = np.empty((n, s2.size), dtype=complex)
    for k in range(s2.size):
        y = Y2[:, k]
        z = np.linalg.lstsq(s2[k] * np.eye(d) - A11, A12 @ y, rcond=None)[0]
        V2[:, k] = P @ y + Q @ z
    s = np.concatenate([s1, s2])
    V = np.concatenate([Q @ Y1, V2], axis=1)
    structural = np.concatenate([np.ones(d, dtype=bool), np.zeros(s2.size, dtype=bool)])
    return s, V, structural


# ------------------------------------------------------------------ modes
@dataclass(frozen=True)
class ModeMotion:
    """A mode shape animated on a System (see :meth:`Modes.animate`).

    Attributes
    ----------
    t : (n_times,) ndarray
        Times (s).
    positions : (n_times, n_bodies, 3) ndarray
        Centres of mass, global (m).
    orientations : (n_times, n_bodies, 4) ndarray
        Euler parameters (theta0, theta1, theta2, theta3), scalar first (viser's wxyz).
    residual_position : (n_times,) ndarray
        ``max abs(C)`` after the projection onto the constraints.
    """

    t: np.ndarray  # (n_times,)
    positions: np.ndarray  # (n_times, n_bodies, 3)
    orientations: np.ndarray  # (n_times, n_bodies, 4)
    residual_position: np.ndarray  # (n_times,)


@dataclass(frozen=True)
class Modes:
    """The eigen solution of a :class:`LinearModel` (``k`` eigenvalues, ``f`` coordinates).

    Attributes
    ----------
    eigenvalues : (k,) complex ndarray
        ``s`` sorted by ``abs(Im s)``, then ``Re s``; a conjugate pair is
        adjacent, ``Im s > 0`` first (Eqs. 8.116, 8.121).
    complex_shapes : (k, f) complex ndarray
        Position part of the eigenvectors, turned so that their real part is
        the real mode shape (below) and scaled with it; a motion of the
        linear model is ``u(t) = a Re(complex_shapes[j] e^(s_j t))``.
    shapes : (k, f) ndarray
        Real mode shapes (Eqs. 8.125-8.129): ``Re(e^(i alpha) phi)`` with the
        phase ``alpha`` that makes it largest; largest component +1. Both
        members of a conjugate pair have the same real shape. Exact normal
        modes for undamped and proportionally damped models.
    omega_n : (k,) ndarray
        Natural frequency ``abs(s)`` (rad/s, Eq. 8.130).
    damping_ratio : (k,) ndarray
        ``xi = -Re(s) / abs(s)`` (Eq. 8.131); NaN for rigid-body modes.
    frequency_hz : (k,) ndarray
        Damped frequency of oscillation ``abs(Im s) / (2 pi)`` (Hz).
    stable : (k,) bool ndarray
        ``Re(s) <= STABILITY_TOL * scale`` (rigid-body modes count as stable).
    critical : (k,) bool ndarray
        ``abs(Re(s)) <= STABILITY_TOL * scale`` and not rigid: undamped
        oscillations, on the stability boundary.
    rigid : (k,) bool ndarray
        ``abs(s) <= RIGID_TOL * scale``: rigid-body (zero) modes.
    scale : float
        Largest ``abs(s)`` (1/s), the reference of the tolerances.
    method : str
        ``"symmetric"`` (Eqs. 8.113-8.116) or ``"state-space"`` (8.117-8.124).
    embedding : Embedding or None
        From :func:`linearize`; None for a model built from matrices.
    """

    eigenvalues: np.ndarray = field(repr=False)
    complex_shapes: np.ndarray = field(repr=False)
    shapes: np.ndarray = field(repr=False)
    omega_n: np.ndarray = field(repr=False)
    damping_ratio: np.ndarray = field(repr=False)
    frequency_hz: np.ndarray = field(repr=False)
    stable: np.ndarray = field(repr=False)
    critical: np.ndarray = field(repr=False)
    rigid: np.ndarray = field(repr=False)
    scale: float
    method: str
    embedding: Embedding | None = field(default=None, repr=False)

    @property
    def is_stable(self) -> bool:
        """True when no mode has ``Re(s) > STABILITY_TOL * scale``."""
        return bool(np.all(self.stable))

    @property
    def flexible(self) -> Modes:
        """The vibration modes, each once, without the rigid-body modes, by ascending natural frequency.

        One entry per mode: the ``Im s > 0`` member of each conjugate pair
        (Eq. 8.121), each real non-zero eigenvalue of the state-space
        problem (an overdamped or divergent motion), and, from the symmetric
        problem (Eqs. 8.113-8.116), the ``Re s > 0`` root of a negative
        stiffness (its ``-Re s`` twin has the same shape). Rigid-body (zero)
        modes (:attr:`rigid`) are left out. Sorted by :attr:`omega_n`
        (stable: equal ones keep their order), so ``modes.flexible.frequency_hz``
        is the table of a modal analysis and ``modes.flexible.animate(system,
        0, ...)`` shows the lowest one.

        Returns
        -------
        Modes
            A Modes holding those rows (same ``scale``, ``method`` and
            ``embedding``; empty arrays when every mode is rigid).
        """
        ev = self.eigenvalues
        tiny = STABILITY_TOL * self.scale
        keep = ~self.rigid & (ev.imag >= -tiny)
        if self.method == "symmetric":
            keep &= (np.abs(ev.imag) > tiny) | (ev.real > 0.0)
        else:
            keep &= (ev.imag > tiny) | (np.abs(ev.imag) <= tiny)
        idx = np.flatnonzero(keep)
        idx = idx[np.argsort(self.omega_n[idx], kind="stable")]
        return Modes(_ro(ev[idx]), _ro(self.complex_shapes[idx]), _ro(self.shapes[idx]), _ro(self.omega_n[idx]),
                     _ro(self.damping_ratio[idx]), _ro(self.frequency_hz[idx]), _ro(self.stable[idx]),
                     _ro(self.critical[idx]), _ro(self.rigid[idx]), self.scale, self.method, self.embedding)

    def _embedding(self, system: Any) -> Embedding:
        if self.embedding is None:
            raise ValueError("system: these modes come from a LinearModel built from matrices; body shapes need "
                             "a model from rigidlab.core.modal.linearize(system)")
        self.embedding.check(system)
        return self.embedding

    def _index(self, index: Any) -> int:
        k = self.eigenvalues.shape[0]
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not -k <= int(index) < k:
            raise ValueError(f"index: expected an integer mode index in [0, {k}), got {short_repr(index)}")
        return int(index) % k

    def body_shapes(self, system: Any) -> np.ndarray:
        """Real mode shapes of the bodies, in the layout of ``State.displaced(dq=...)``.

        Parameters
        ----------
        system : System
            The System that was linearized.

        Returns
        -------
        (k, 6n) ndarray
            ``[dR (3n) global, m | dpi_body (3n) body frame, rad]`` per mode,
            scaled so that the largest entry is +1: ``system.state.displaced(dq=a
            * shapes[j])`` displaces the largest coordinate by ``a`` (m or rad).
        """
        emb = self._embedding(system)
        z = self.shapes @ emb.basis.T
        z = emb.body_coordinates(z)
        return _unit_largest(z)

    def animate(self, system: Any, index: Any, t: Any, *, amplitude: float) -> ModeMotion:
        """Mode ``index`` animated about the reference: ``q0 + a Re(S e^(s t))``, on the constraints.

        Each body is moved from its reference motion (at rest for an
        equilibrium; the steady motion otherwise) by ``a Re(S_b e^(s t))``
        (the complex body shape, largest real entry 1 as in
        :meth:`body_shapes`) and the configuration is projected back onto
        ``C(q, t) = 0`` by Newton's method (least change in the mass
        metric), so that the joints stay closed at large amplitude.

        Parameters
        ----------
        system : System
            The System that was linearized.
        index : int
            Mode index into :attr:`eigenvalues`.
        t : (n_times,) array_like
            Times after the reference time (s).
        amplitude : float, keyword-only
            ``a``: the largest translation (m) or rotation (rad) of the shape at t = 0.

        Returns
        -------
        ModeMotion

        Raises
        ------
        ValueError
            For another System, a bad index, times or amplitude;
            ``AssemblyError`` when the amplitude is so large that the
            constraints cannot be met.

        Warns
        -----
        RigidModeWarning
            For a rigid-body mode (:attr:`rigid`): it does not oscillate.
        """
        from rigidlab.core.multibody._analysis import AssemblyError
        from rigidlab.core.multibody._engine import matrices
        from rigidlab.core.multibody._linearization import project_positions
        from rigidlab.core.multibody._system import exp_parameters, quaternion_products

        emb = self._embedding(system)
        j = self._index(index)
        a = real_number(amplitude, "amplitude", expected="a finite amplitude (m or rad)")
        if self.rigid[j]:
            warnings.warn(f"animate: mode {j} is a rigid-body mode (s = {complex(self.eigenvalues[j]):.3g}): the "
                          "mechanism moves along it as a rigid body and does not oscillate (Modes.flexible leaves "
                          "such modes out)", RigidModeWarning, stacklevel=2)
        times = float_array(t, "t", expected="times (s)")
        if times.ndim > 1:
            raise ValueError(f"t: expected a time or a 1-D array of times (s), got shape {times.shape}")
        times = times.reshape(-1)
        if not np.all(np.isfinite(times)):
            raise ValueError("t: expected finite times (s)")
        n = emb.n_bodies
        zc = emb.basis @ self.complex_shapes[j]
        zr = np.real(zc)
        norm = _largest_entry(emb.body_coordinates(zr))
        zc = zc / norm
        s = complex(self.eigenvalues[j])
        W = emb.frame_omega
        R0 = emb.q0[: 3 * n].reshape(n, 3)
        P0 = emb.q0[3 * n :].reshape(n, 4)
        A0 = matrices(P0)
        v_obs = emb.v0[: 3 * n].reshape(n, 3) - np.cross(W[None, :], R0)
        w_obs = np.einsum("nij,nj->ni", A0, emb.v0[3 * n :].reshape(n, 3)) - W[None, :]
        positions = np.empty((times.size, n, 3))
        orientations = np.empty((times.size, n, 4))
        residual = np.empty(times.size)
        v_zero = np.zeros(6 * n)
        for i, ti in enumerate(times):
            with np.errstate(over="ignore", invalid="ignore"):
                z = a * np.real(zc * np.exp(s * ti))
            if not np.all(np.isfinite(z)):
                raise ValueError(
                    f"amplitude, t: the mode's displacement a Re(S e^(s t)) is not finite at t={ti:g} (a = {a:g}, "
                    f"s = {s.real:.6g}{s.imag:+.6g}j); give a smaller amplitude or earlier times")
            with np.errstate(over="ignore", invalid="ignore"):  # (a huge displacement: refused below)
                rot = exp_parameters((W * ti)[None, :])
                Rot = matrices(rot)[0]
                R = (R0 + v_obs * ti + z[: 3 * n].reshape(n, 3)) @ Rot.T
                P = quaternion_products(exp_parameters(w_obs * ti), P0)
                P = quaternion_products(exp_parameters(z[3 * n :].reshape(n, 3)), P)
                P = quaternion_products(np.repeat(rot, n, axis=0), P)
            y = np.concatenate([R.ravel(), P.ravel(), v_zero])
            y, res = project_positions(system, emb.t + ti, y)
            if not (np.all(np.isfinite(y)) and math.isfinite(res)):
                raise AssemblyError(
                    f"animate: the configuration at t={ti:g} could not be projected onto the constraints (a = {a:g}: "
                    "the displacement is too large); give a smaller amplitude or earlier times")
            positions[i] = y[: 3 * n].reshape(n, 3)
            Pn = y[3 * n : 7 * n].reshape(n, 4)
            orientations[i] = Pn / np.linalg.norm(Pn, axis=1)[:, None]
            residual[i] = res
        return ModeMotion(_ro(times), _ro(positions), _ro(orientations), _ro(residual))

    # ---------------------------------------------------------- export
    def to_records(self) -> list[dict]:
        """One dict per mode: eigenvalue, omega_n, frequency, damping ratio, flags and real shape."""
        out = []
        for k in range(self.eigenvalues.shape[0]):
            s = complex(self.eigenvalues[k])
            out.append({
                "index": k,
                "eigenvalue_real": s.real,
                "eigenvalue_imag": s.imag,
                "omega_n_rad_s": float(self.omega_n[k]),
                "frequency_hz": float(self.frequency_hz[k]),
                "damping_ratio": _json_float(self.damping_ratio[k]),
                "stable": bool(self.stable[k]),
                "critical": bool(self.critical[k]),
                "rigid": bool(self.rigid[k]),
                "shape": [float(x) for x in self.shapes[k]],
                "complex_shape": [[float(x.real), float(x.imag)] for x in self.complex_shapes[k]],
            })
        return out

    def to_json(self) -> str:
        """The modes as a JSON document (``{"method", "scale", "modes": [...]}``, NaN written as null)."""
        doc = {"method": self.method, "scale": self.scale, "modes": self.to_records()}
        if self.embedding is not None:
            doc["bodies"] = list(self.embedding.body_names)
        return json.dumps(doc, allow_nan=False)

    def to_csv(self) -> str:
        """The modes as CSV text: one row per mode, the real shape in columns ``shape_0 ... shape_{f-1}``."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        f = self.shapes.shape[1]
        w.writerow(["index", "eigenvalue_real", "eigenvalue_imag", "omega_n_rad_s", "frequency_hz", "damping_ratio",
                    "stable", "critical", "rigid"] + [f"shape_{i}" for i in range(f)])
        for r in self.to_records():
            w.writerow([r["index"], repr(r["eigenvalue_real"]), repr(r["eigenvalue_imag"]), repr(r["omega_n_rad_s"]),
                        repr(r["frequency_hz"]), "" if r["damping_ratio"] is None else repr(r["damping_ratio"]),
                        int(r["stable"]), int(r["critical"]), int(r["rigid"])] + [repr(x) for x in r["shape"]])
        return buf.getvalue()


def _json_float(x: float) -> float | None:
    x = float(x)
    return None if math.isnan(x) else x


def _largest_entry(z: np.ndarray) -> float:
    k = int(np.argmax(np.abs(z)))
    v = float(z.flat[k])
    return v if v != 0.0 else 1.0


def _unit_largest(Z: np.ndarray) -> np.ndarray:
    out = np.array(Z, dtype=float, copy=True)
    for k in range(out.shape[0]):
        out[k] /= _largest_entry(out[k])
    return out


def _real_shapes(V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(complex shapes, real shapes)`` of the rows of ``V`` (k, f): each turned by the phase that makes its
    real part largest (Eqs. 8.125-8.129), largest real entry +1."""
    if not np.any(V.imag):  # real shapes (the symmetric problem): no phase to turn (alpha = 0)
        W = V
    else:
        ss = np.sum(V * V, axis=1)
        alpha = np.where(np.abs(ss) > 0, -0.5 * np.arctan2(ss.imag, ss.real), 0.0)
        W = V * (np.cos(alpha) + 1j * np.sin(alpha))[:, None]
    flat = ~np.any(W.real, axis=1)
    if np.any(flat):
        W[flat] = W[flat] * -1j
    R = W.real
    c = R[np.arange(R.shape[0]), np.argmax(np.abs(R), axis=1)] if R.shape[1] else np.ones(R.shape[0])
    c = np.where(c != 0.0, c, 1.0)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):  # (a shape out of range: refused by _modes)
        return W / c, R / c


def _modes(s: np.ndarray, X: np.ndarray, *, method: str, embedding: Embedding | None,
           structural: np.ndarray | None = None) -> Modes:
    """Sort eigenvalues (pairs adjacent, +Im first), normalize shapes and flag modes.

    ``structural`` (k,) bool: the eigenvalues split off by
    :func:`_deflated_eig`; when given, only those can be rigid (a small
    eigenvalue of the rest is a slow mode, not a rigid-body one).
    """
    k = s.shape[0]
    scale = float(np.max(np.abs(s))) if k else 0.0
    scale = scale if scale > 0 else 1.0
    tiny = STABILITY_TOL * scale
    # groups: a conjugate pair (Im > tiny) or a single real eigenvalue
    upper = np.flatnonzero(s.imag > tiny)
    lower = np.flatnonzero(s.imag < -tiny)
    first = second = np.zeros(0, dtype=np.intp)
    if upper.size and lower.size:
        cost = np.abs(s[upper][:, None] - np.conj(s[lower])[None, :])
        ri, ci = linear_sum_assignment(cost)
        ok = cost[ri, ci] <= 1e-6 * scale
        first, second = upper[ri[ok]], lower[ci[ok]]
    single = np.ones(k, dtype=bool)
    single[first] = single[second] = False
    # the groups, pairs (in the assignment's order) then single roots, sorted stably by (|Im s| of a pair, else
    # 0; Re s)
    pair = np.concatenate([np.ones(first.size, dtype=bool), np.zeros(int(single.sum()), dtype=bool)])
    first = np.concatenate([first, np.flatnonzero(single)])
    second = np.concatenate([second, -np.ones(first.size - second.size, dtype=np.intp)])
    rank = np.lexsort((s[first].real, np.where(pair, np.abs(s[first].imag), 0.0)))
    first, second, pair = first[rank], second[rank], pair[rank]
    order = np.stack([first, second], axis=1).ravel()
    order = order[order >= 0]
    assert order.size == k
    pos = np.concatenate([[0], np.cumsum(np.where(pair, 2, 1))[:-1]]).astype(np.intp)
    s1 = s[first]
    V = X[first]
    flip = pair & (s1.imag < 0)  # (a pair's upper root is its first member: never taken)
    V[flip] = np.conj(V[flip])
    W, R = _real_shapes(V)
    ev = np.empty(k, dtype=complex)
    cs = np.empty_like(X, dtype=complex)
    rs = np.empty(X.shape, dtype=float)
    # a pair: s = (Re, |Im|) and its conjugate; a single root: real when |Im| <= tiny
    ev[pos] = np.where(pair, s1.real + 1j * np.abs(s1.imag), np.where(np.abs(s1.imag) <= tiny, s1.real + 0j, s1))
    cs[pos], rs[pos] = W, R
    p2 = pos[pair] + 1
    ev[p2] = np.conj(ev[pos[pair]])
    cs[p2], rs[p2] = np.conj(W[pair]), R[pair]
    mag = np.abs(ev)
    rigid = mag <= RIGID_TOL * scale
    if structural is not None:
        rigid &= np.asarray(structural, dtype=bool)[order]
    if not (np.all(np.isfinite(ev)) and np.all(np.isfinite(cs))):
        raise ValueError("M, K, C, G: the eigenvalue problem left the floating-point range (eigenvalues or "
                         "shapes not finite); give the matrices in units of similar size")
    with np.errstate(invalid="ignore", divide="ignore"):
        xi = np.where(rigid, np.nan, -ev.real / np.where(mag > 0, mag, 1.0)) + 0.0  # (+ 0.0: no -0.0)
    # a multiple root (the translations of a free body seen from a turning frame: +-i Omega twice) is split
    # by round-off into roots up to about sqrt(eps) apart, with real parts of that size: within such a
    # cluster a real part up to RIGID_TOL * scale is not resolved and counts as zero
    re = np.where(np.abs(ev.real) <= tiny, 0.0, ev.real)
    loose = (np.abs(ev.real) > tiny) & (np.abs(ev.real) <= RIGID_TOL * scale)
    for i in np.flatnonzero(loose):
        others = np.delete(np.arange(k), i)
        if others.size and float(np.min(np.abs(ev[others] - ev[i]))) <= 2.0 * RIGID_TOL * scale:
            re[i] = 0.0
    stable = (re <= 0.0) | rigid
    critical = (re == 0.0) & ~rigid
    return Modes(_ro(ev), _ro(cs), _ro(rs), _ro(mag), _ro(xi), _ro(np.abs(ev.imag) / (2.0 * math.pi)),
                 _ro(stable), _ro(critical), _ro(rigid), scale, method, embedding)


# ------------------------------------------------------------------ linearize
def linearize(system: Any, *, frame_omega: Any = None, steady_tol: float = 1e-6) -> LinearModel:
    r"""Linearize a System about its current state (Eqs. 8.110-8.112).

    The current state must be an equilibrium (velocities zero, e.g. after
    :meth:`System.equilibrium`) or a steady motion: seen from an observer
    frame that turns at ``frame_omega`` (constant, global), the velocities
    of every centre of mass and every angular velocity are constant (a rotor
    spinning about its axis of symmetry with ``frame_omega = 0``, a top in
    steady precession with ``frame_omega`` its precession). The linear model
    is then time invariant when every body's inertia and every force look
    the same from that frame at all times (symmetric rotors); otherwise it
    is the model frozen at the current time.

    Tangent coordinates ``z = [dR, dtheta]`` (global translation and small
    rotation of each body) are embedded as ``z = N u`` with ``N`` an
    orthonormal basis of the null space of the constraint Jacobian of the
    independent rows (Eq. 8.111; rolling rows restrict only the velocities,
    ``z_dot = N_v s``). With the multipliers ``lambda0`` of the reference,
    the dynamic residual of the bodies ``F = M a - Q + D^T lambda0`` gives

    .. math::

        M = N_v^T \frac{\partial F}{\partial \ddot z} N_v, \quad
        C + G = N_v^T \frac{\partial F}{\partial \dot z} N_v, \quad
        K = N_v^T \frac{\partial F}{\partial z} N

    (Eq. 8.112; ``dF/dz_ddot`` exact, the others by central differences,
    Richardson-extrapolated, over groups of bodies that share no row). ``K``
    contains the stiffness of the applied forces and the geometric stiffness
    ``d(C_q^T lambda)/dq`` of the constraint forces; the change of the
    multipliers is orthogonal to ``N`` and drops out. The velocity matrix is
    split into its symmetric part ``C`` (damping) and skew part ``G``
    (gyroscopic); neither is dropped.

    Parameters
    ----------
    system : System
        Assembled; its current state is the reference (not changed).
    frame_omega : (3,) array_like or None, keyword-only
        Angular velocity of the observer frame (global, rad/s); default zero.
    steady_tol : float, keyword-only
        Largest accepted acceleration of the reference as seen from the
        observer frame, relative to the accelerations of the problem
        (gravity, centripetal, springs over the bodies' lengths).

    Returns
    -------
    LinearModel
        With :attr:`LinearModel.embedding` set.

    Raises
    ------
    ValueError
        For a state that is neither an equilibrium nor a steady motion
        (the message gives the largest acceleration and the body), a System
        without degrees of freedom, bad arguments.
    AssemblyError
        For a state that violates the constraints (as ``simulate``).
    SingularSystemError
        When the constrained mass matrix is singular.

    Warns
    -----
    RuntimeWarning
        When a body turns relative to the observer frame and does not look
        the same from it at all times (see :func:`_warn_if_time_varying`):
        the model is then frozen at the reference time; and when the
        estimated error of the differenced derivatives exceeds 1e-3.
    """
    return _linearize(system, frame_omega=frame_omega, steady_tol=steady_tol, constraint_stiffness="analytic")


def _linearize(system: Any, *, frame_omega: Any, steady_tol: Any, constraint_stiffness: str) -> LinearModel:
    """:func:`linearize`; ``constraint_stiffness="differences"`` takes the geometric stiffness by differences too."""
    from rigidlab.core.multibody import System
    from rigidlab.core.multibody import _linearization as lin
    from rigidlab.core.multibody._simulate import check_assembled
    from rigidlab.core.multibody._state import _make_state

    if not isinstance(system, System):
        raise ValueError(f"system: expected a rigidlab.core.multibody.System, got {short_repr(system)}")
    n = len(system.bodies)
    if n == 0:
        raise ValueError("system: expected at least one body, got none")
    W = np.zeros(3) if frame_omega is None else float_array(frame_omega, "frame_omega", copy=True)
    if W.shape != (3,) or not np.all(np.isfinite(W)):
        raise ValueError(f"frame_omega: expected a finite (3,) angular velocity (rad/s), got {short_repr(frame_omega)}")
    tol = real_number(steady_tol, "steady_tol", expected="a finite tolerance > 0")
    if not tol > 0:
        raise ValueError(f"steady_tol: expected a finite tolerance > 0, got {tol!r}")
    t = system._t
    eng, ref = lin.reference(system, t, W)
    if eng.m:  # (a state off the constraints would be linearized about a configuration the System cannot take)
        check_assembled(eng, t, ref.y, "linearize")
    ell = lin.body_length_scales(eng)
    _check_steady(eng, ref, system, ell, tol)
    ell = _step_lengths(eng, ref, ell)
    _warn_if_time_varying(eng, ref, system)

    # embedding: null spaces of the position rows and of all rows (Eq. 8.111)
    velocity_only = np.isin(ref.keep, lin.nonholonomic_rows(eng))
    B = None if np.any(velocity_only) else lin.tree_null_space(eng, ref)
    if B is not None:  # the spanning tree's motions, orthonormalized
        N_v = N = _orthonormal_columns(B)
    else:
        Dk = ref.D[ref.keep]
        Dz = np.empty_like(Dk)
        Dz[:, : 3 * n] = Dk[:, : 3 * n]
        # rotation columns: body-frame small rotations dpi = A^T dtheta
        Dz[:, 3 * n :] = np.matmul(Dk[:, 3 * n :].reshape(-1, n, 1, 3),
                                   np.transpose(ref.A, (0, 2, 1))[None]).reshape(-1, 3 * n)
        N_v = _null_space(Dz)
        N = _null_space(Dz[~velocity_only]) if np.any(velocity_only) else N_v
    if N_v.shape[1] == 0:
        raise ValueError("system: the constraints leave no degree of freedom to linearize")

    def state_factory(tt: float, yy: np.ndarray):
        return _make_state(system, tt, yy)

    M_blocks = lin.mass_blocks(eng, ref)
    moving = bool(np.any(ref.y[7 * n :])) or bool(np.any(W))
    users = bool(eng.user_forces or eng.user_torques)
    if constraint_stiffness == "analytic":
        K_full = lin.constraint_stiffness_sparse(eng, ref)  # (block-sparse: the bodies that share a row)
        with_rows = False
        needs_position = (moving or users or bool(eng.springs) or bool(eng.rot_springs)
                          or lin.has_extra_rows(eng))
    else:
        K_full = np.zeros((6 * n, 6 * n))
        with_rows = True
        needs_position = True
    err_k = 0.0
    if needs_position:
        coupling = lin.body_coupling(eng, table_rows=with_rows)
        groups = lin.distance2_colors(coupling)
        K_diff, err_k = _jacobian(eng, ref, coupling, groups, ell, state_factory, "z", richardson=True,
                                  table_rows=with_rows)
        K_full = K_full.toarray() + K_diff if scipy.sparse.issparse(K_full) else K_full + K_diff
    needs_velocity = (moving or users or any(sp.damping > 0 for sp in eng.springs)
                      or any(rs.damping > 0 for rs in eng.rot_springs))
    if needs_velocity:
        coupling_v = lin.body_coupling(eng, table_rows=False)
        groups_v = lin.distance2_colors(coupling_v)
        rate = max(1.0, float(np.max(np.abs(ref.omega))), float(np.linalg.norm(W)))
        V_full, err_c = _jacobian(eng, ref, coupling_v, groups_v, ell * rate, state_factory, "zd",
                                  richardson=users, rot_step=rate, table_rows=False)
    else:
        V_full, err_c = None, 0.0
    M = N_v.T @ _blocks_apply(M_blocks, N_v, n)
    M = 0.5 * (M + M.T)
    K = N_v.T @ (K_full @ N)
    T = None if N_v.shape[1] == N.shape[1] else N.T @ N_v
    Y = None
    err_e = 0.0
    if np.any(velocity_only) and moving:
        # rolling rows of a moving reference: D_r z_dot + E z = 0 with E = d(D_r v)/dz at z_dot = 0, so
        # z_dot = N_v s + Z u and z_ddot = N_v s_dot + Z u_dot (u_dot = T s + Y u, Y = N^T Z)
        E, err_e = _rolling_rate_jacobian(eng, ref, ell, ref.keep[velocity_only])
        rhs = np.zeros((Dz.shape[0], N.shape[1]))
        rhs[velocity_only] = -(E @ N)
        Z = scipy.linalg.lstsq(Dz, rhs)[0]
        T = N.T @ N_v
        Y = N.T @ Z
        MZ = _blocks_apply(M_blocks, Z, n)
        K = K + N_v.T @ MZ @ Y
        if V_full is not None:
            K = K + N_v.T @ V_full @ Z
        else:
            V_full = np.zeros((6 * n, 6 * n))
        V_extra = N_v.T @ MZ @ T
    else:
        V_extra = None
    C = G = None
    if V_full is not None:
        V = N_v.T @ V_full @ N_v
        if V_extra is not None:
            V = V + V_extra
        C = 0.5 * (V + V.T)
        G = 0.5 * (V - V.T)
        vs = max(float(np.max(np.abs(V))), 1e-300)
        cs = max(float(np.max(np.abs(M))), float(np.max(np.abs(K))), 1e-300)
        if vs <= 1e-13 * cs:
            C = G = None
    rate = max(1.0, float(np.max(np.abs(ref.omega))), float(np.linalg.norm(W)))
    m_scale = float(np.max(np.abs(M_blocks)))
    k_scale = float(np.max(np.abs(K_full.data), initial=0.0)) if scipy.sparse.issparse(K_full) else float(
        np.max(np.abs(K_full)))
    err = max(err_k / max(k_scale, m_scale * rate**2, 1e-300),
              err_c / max(float(np.max(np.abs(V_full))) if V_full is not None else 0.0, m_scale * rate, 1e-300),
              err_e / rate)
    if err > 1e-3:
        warnings.warn(f"linearize: the finite-difference derivatives may be inaccurate (estimated relative error "
                      f"{err:.1e}); the reference may sit near a singular configuration", RuntimeWarning, stacklevel=2)
    emb = Embedding(_ro(N), _ro(N_v), float(t), _ro(ref.y[: 7 * n]), _ro(ref.y[7 * n :]), _ro(W),
                    tuple(b.name for b in system.bodies), int(eng.m))
    return LinearModel(M, K, C, G, velocity_map=T, position_rate_map=Y, embedding=emb, derivative_error=err)


def _rolling_rate_jacobian(eng: Any, ref: Any, ell: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, float]:
    """``(E, error)``: ``E = d(D_r v)/dz`` (len(rows), 6n) of the rolling rows at ``z_dot = 0``, by differences.

    The perturbed state keeps the reference velocities carried with the
    bodies (``lin.perturbed_state``); a rolling row's velocity ``D_r v``
    then changes to first order with the positions when the reference
    moves (a wheel turned by ``dtheta`` while rolling at speed ``v``
    slides sideways at ``v dtheta``). Central differences with the steps of
    :func:`_jacobian`, Richardson-extrapolated; only the bodies that appear
    in the rows are perturbed, those that share no row together (the two
    wheels of a bicycle in one pair of evaluations). ``error`` is the absolute error estimate of
    the plain difference.
    """
    from rigidlab.core.multibody import _linearization as lin

    n = eng.n
    size = 6 * n
    zeros = np.zeros(size)

    def g(z: np.ndarray) -> np.ndarray:
        y, _, _ = lin.perturbed_state(eng, ref, z, zeros, zeros)
        _, Y, Phi, gam = eng.table(ref.t, y, level=1)
        _, D, _, _ = eng.constraint_rows(ref.t, Y, Phi, gam, level=1)
        return np.asarray(D)[rows] @ y[7 * n :]

    Dr = ref.D[rows]
    bodies = [b for b in range(n) if np.any(Dr[:, 3 * b : 3 * b + 3]) or np.any(Dr[:, 3 * (n + b) : 3 * (n + b) + 3])]
    # bodies that share no row are perturbed together (a wheel's rolling rows see only that wheel)
    in_row = [{b for b in bodies if np.any(Dr[r, 3 * b : 3 * b + 3]) or np.any(Dr[r, 3 * (n + b) : 3 * (n + b) + 3])}
              for r in range(rows.size)]
    colors: list[list[int]] = []
    for b in bodies:
        for group in colors:
            if not any(b in members and members & set(group) for members in in_row):
                group.append(b)
                break
        else:
            colors.append([b])
    E = np.zeros((rows.size, size))
    E2 = np.zeros((rows.size, size))
    for group in colors:
        for c in range(6):
            cols = [3 * b + c if c < 3 else 3 * n + 3 * b + c - 3 for b in group]
            d = np.zeros(size)
            for b, col in zip(group, cols):
                d[col] = STEP * (ell[b] if c < 3 else 1.0)
            g1 = g(d) - g(-d)
            g2 = g(2.0 * d) - g(-2.0 * d)
            for b, col in zip(group, cols):
                # the rows of body b see only b's step (no row holds two bodies of one group)
                mask = np.array([b in members for members in in_row])
                E[mask, col] = g1[mask] / (2.0 * d[col])
                E2[mask, col] = g2[mask] / (4.0 * d[col])
    return (4.0 * E - E2) / 3.0, float(np.max(np.abs(E - E2), initial=0.0)) / 3.0


def _blocks_apply(blocks: np.ndarray, X: np.ndarray, n: int) -> np.ndarray:
    """``M @ X`` for M (6n, 6n) block diagonal with the 3 x 3 ``blocks`` (2n, 3, 3)."""
    return np.matmul(blocks, X.reshape(2 * n, 3, -1)).reshape(6 * n, -1)


def _null_space(D: np.ndarray) -> np.ndarray:
    """Orthonormal basis (6n, 6n - r) of the null space of the full-row-rank D (r, 6n) (QR of D^T)."""
    size = D.shape[1]
    r = D.shape[0]
    if r == 0:
        return np.eye(size)
    Q, _ = scipy.linalg.qr(D.T, mode="full")
    return np.ascontiguousarray(Q[:, r:])


#: Largest condition number of the (column-scaled) tree basis for Cholesky QR (:func:`_orthonormal_columns`).
_CHOLESKY_QR_COND = 1e6
#: Orthogonality error ``max |X^T X - I|`` accepted after one Cholesky QR pass (the error of Householder QR).
_ORTHONORMAL_TOL = 2e-15


def _orthonormal_columns(B: np.ndarray) -> np.ndarray:
    """Orthonormal basis (6n, f) of the span of the f independent columns of ``B``.

    Cholesky QR (``G = X^T X = R^T R``, ``X <- X R^-1``), repeated once
    when the result's orthogonality error ``max |X^T X - I|`` exceeds
    ``_ORTHONORMAL_TOL`` (CholeskyQR2, Fukaya et al. 2014): a pass leaves an
    error of about ``eps cond(X)^2``, so the second pass brings any ``cond(B)``
    below about ``eps^-1/2`` to round-off. The columns are scaled to unit
    length first; a condition number above ``_CHOLESKY_QR_COND`` (estimated
    from ``R``) takes Householder QR instead.
    """
    f = B.shape[1]
    if f == 0:
        return np.zeros(B.shape)
    norms = np.sqrt(np.sum(B * B, axis=0))
    if np.all(norms > 0.0):
        X = B / norms
        G = X.T @ X
        R, info = scipy.linalg.lapack.dpotrf(G)
        if info == 0:
            rcond, info = scipy.linalg.lapack.dtrcon(R)
        if info == 0 and rcond * _CHOLESKY_QR_COND > 1.0:
            X = scipy.linalg.blas.dtrsm(1.0, R, X, side=1)  # X R^-1
            G = X.T @ X
            if np.max(np.abs(G - np.eye(f))) <= _ORTHONORMAL_TOL:
                return np.ascontiguousarray(X)
            R, info = scipy.linalg.lapack.dpotrf(G)
            if info == 0:
                return np.ascontiguousarray(scipy.linalg.blas.dtrsm(1.0, R, X, side=1))
    Q, _ = scipy.linalg.qr(B, mode="economic")
    return np.ascontiguousarray(Q)


#: Relative tolerance of :func:`_warn_if_time_varying` (a symmetric inertia, a point on an axis, parallel axes).
_SYMMETRY_REL = 1e-8


def _warn_if_time_varying(eng: Any, ref: Any, system: Any) -> None:
    """Warn when a body turns relative to the observer frame and what turns with it does not look the same at
    all times: the linear model then changes with time and the one returned is frozen at the reference time.

    A body turning about an axis (through its centre of mass, which the steady check holds still in the
    frame) looks the same when its inertia is symmetric about that axis, every joint and spring point of it
    lies on the axis, and its joints are spherical or revolute about that axis. Contacts are not checked.
    """
    n = eng.n
    W = ref.frame_omega
    # (a first pass over all bodies with half the threshold; the test itself is the loop's)
    rates = np.sqrt(np.sum((ref.omega - W[None, :]) ** 2, axis=1))
    sizes = np.maximum(np.maximum(1.0, float(np.linalg.norm(W))), np.sqrt(np.sum(ref.omega**2, axis=1)))
    for b in np.flatnonzero(rates > 0.5 * _SYMMETRY_REL * sizes).tolist():
        w_rel = ref.omega[b] - W
        rate = float(np.linalg.norm(w_rel))
        if not rate > _SYMMETRY_REL * max(1.0, float(np.linalg.norm(W)), float(np.linalg.norm(ref.omega[b]))):
            continue
        a = ref.A[b].T @ (w_rel / rate)  # the axis in the body frame
        J = eng.inertia[b]
        P = np.eye(3) - np.outer(a, a)
        T = P @ J @ P
        size = max(float(np.trace(J)), 1e-300)
        reason = None
        if (float(np.linalg.norm(P @ J @ a)) > _SYMMETRY_REL * size
                or float(np.linalg.norm(T - 0.5 * np.trace(T) * P)) > _SYMMETRY_REL * size):
            reason = "its inertia is not symmetric about that axis"
        for item, kind in [(jt, "joint") for jt in eng.joints] + [(sp, "spring_damper") for sp in eng.springs]:
            if reason is not None:
                break
            for side, body in (("i", item.body_i), ("j", item.body_j)):
                if body.index != b:
                    continue
                u = np.asarray(item._local[f"u_{side}"], dtype=float)
                if float(np.linalg.norm(np.cross(u, a))) > _SYMMETRY_REL * max(float(np.linalg.norm(u)), 1.0):
                    reason = f"{kind} {item.name!r} is attached off that axis"
                elif kind == "joint" and item.kind not in ("spherical", "revolute"):
                    reason = f"joint {item.name!r} ({item.kind}) turns with it"
                elif kind == "joint" and item.kind == "revolute" and float(np.linalg.norm(
                        np.cross(np.asarray(item._local[f"h_{side}"], dtype=float), a))) > _SYMMETRY_REL:
                    reason = f"the axis of joint {item.name!r} is not that axis"
        if reason is not None:
            warnings.warn(
                f"linearize: body {system.bodies[b].name!r} turns at {rate:.4g} rad/s relative to the frame turning at "
                f"frame_omega={W.tolist()}, and {reason}: the linear model changes with time, and the one returned "
                "is frozen at the reference time (pass frame_omega equal to the body's angular velocity if "
                "everything turns with it)", RuntimeWarning, stacklevel=4)
            return


def _step_lengths(eng: Any, ref: Any, ell: np.ndarray) -> np.ndarray:
    """(n,) length scales of the translation steps: ``ell``, but per body no longer than a spring attached to it
    (its length at the reference): a step comparable to a spring's length turns the spring's force (a 0.5 mm
    spring stepped by 0.3 mm was 13 % too stiff)."""
    n = eng.n
    out = np.array(ell, dtype=float)
    R = ref.y[: 3 * n].reshape(n, 3)
    for sp in eng.springs:
        ends = [np.asarray(sp._local[side], dtype=float) if body.index < 0
                else R[body.index] + ref.A[body.index] @ np.asarray(sp._local[side], dtype=float)
                for side, body in (("u_i", sp.body_i), ("u_j", sp.body_j))]
        length = float(np.linalg.norm(ends[1] - ends[0]))
        for body in (sp.body_i, sp.body_j):
            if body.index >= 0 and length > 0.0:
                out[body.index] = min(out[body.index], length)
    return out


def _frame_cross(W: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(n, 3) ``W x v`` per row of ``v`` (the formula of ``np.cross``, without its overhead)."""
    out = np.empty_like(v)
    out[:, 0] = W[1] * v[:, 2] - W[2] * v[:, 1]
    out[:, 1] = W[2] * v[:, 0] - W[0] * v[:, 2]
    out[:, 2] = W[0] * v[:, 1] - W[1] * v[:, 0]
    return out


def _check_steady(eng: Any, ref: Any, system: Any, ell: np.ndarray, tol: float) -> None:
    n = eng.n
    W = ref.frame_omega
    Rd = ref.y[7 * n : 10 * n].reshape(n, 3)
    W_Rd = _frame_cross(W, Rd)
    acc_R = ref.R_ddot - W_Rd
    acc_w = ref.alpha - _frame_cross(W, ref.omega)
    w2 = float(np.max(np.sum(ref.omega**2, axis=1)))
    # the springs' accelerations over the bodies' lengths (k ell / m): the scale of a reference held by springs
    # alone, without gravity or motion, whose forces balance to round-off
    springs = max((sp.stiffness for sp in eng.springs), default=0.0) * float(np.max(ell)) / float(np.min(eng.mass))
    scale_R = max(float(np.linalg.norm(system.gravity)), float(np.max(np.abs(W_Rd))),
                  w2 * float(np.max(ell)), float(W @ W) * float(np.max(ell)), springs, 1e-12)
    scale_w = max(scale_R / float(np.min(ell)), w2, float(W @ W), 1e-12)
    eR = np.linalg.norm(acc_R, axis=1) / scale_R
    ew = np.linalg.norm(acc_w, axis=1) / scale_w
    if max(float(eR.max()), float(ew.max())) > tol:
        b = int(np.argmax(np.maximum(eR, ew)))
        raise ValueError(
            f"system: the current state is neither an equilibrium nor a steady motion seen from the frame turning at "
            f"frame_omega={W.tolist()}: body {system.bodies[b].name!r} accelerates by "
            f"{float(np.linalg.norm(acc_R[b])):.3e} m/s^2 and {float(np.linalg.norm(acc_w[b])):.3e} rad/s^2 "
            "(call system.equilibrium() first, or pass the frame in which the motion is steady)"
        )


def _jacobian(eng, ref, coupling, groups, ell, state_factory, which, *, richardson, rot_step=1.0, table_rows=True):
    """(6n, 6n) dF/dz or dF/dz_dot by central differences over distance-2 colour groups.

    Steps: ``STEP * ell_b`` (translations) and ``STEP * rot_step`` (rotations);
    with ``richardson`` the steps h and 2h are combined, ``(4 J_h - J_2h) /
    3``, and ``abs(J_h - J_2h)`` estimates the error. Returns ``(J,
    absolute error estimate of the plain central difference at step h)``.
    """
    from rigidlab.core.multibody import _linearization as lin

    n = eng.n
    size = 6 * n
    zeros = np.zeros(size)
    J = np.zeros((size, size))
    J2 = np.zeros((size, size)) if richardson else None
    # the unique perturbed body that each body's residual sees, per group
    owner = []
    for g in groups:
        gset = set(g)
        owner.append([next(iter(coupling[b] & gset), -1) for b in range(n)])

    def F(d: np.ndarray) -> np.ndarray:
        if which == "z":
            return lin.residual(eng, ref, d, zeros, zeros, state_factory, table_rows=table_rows)
        return lin.residual(eng, ref, zeros, d, zeros, state_factory, table_rows=table_rows)

    body_rows = np.concatenate([3 * np.arange(n)[:, None] + np.arange(3)[None, :],
                                3 * n + 3 * np.arange(n)[:, None] + np.arange(3)[None, :]], axis=1)  # (n, 6)
    for gi, g in enumerate(groups):
        own = np.array(owner[gi])
        seen = np.flatnonzero(own >= 0)
        cb = own[seen]
        rows = body_rows[seen]  # (k, 6)
        ga = np.array(g)
        for c in range(6):
            h = np.zeros(n)
            h[ga] = STEP * (ell[ga] if c < 3 else rot_step)
            d = np.zeros(size)
            d[body_rows[ga, c]] = h[ga]
            cols = np.repeat(body_rows[cb, c][:, None], 6, axis=1)
            scale = h[cb][:, None]
            J[rows, cols] = ((F(d) - F(-d)) / 2.0)[rows] / scale
            if richardson:
                J2[rows, cols] = ((F(2.0 * d) - F(-2.0 * d)) / 4.0)[rows] / scale
    if not richardson:
        return J, 0.0
    return (4.0 * J - J2) / 3.0, float(np.max(np.abs(J - J2))) / 3.0


# ------------------------------------------------------------------ sweep
@dataclass(frozen=True)
class SweepResult:
    """Modes over a parameter, tracked from value to value by shape correlation.

    Attributes
    ----------
    values : (n_values,) ndarray
        Parameter values, increasing.
    eigenvalues : (n_values, k) complex ndarray
        Column ``j`` follows one mode across the values (matched by the
        correlation of its shape with the previous value's, then by
        eigenvalue distance), not the sort order of :class:`Modes`.
    shapes : (n_values, k, f) complex ndarray
        The complex shapes, tracked the same way.
    stable, rigid : (n_values, k) bool ndarray
        As :class:`Modes`, tracked.
    build : callable
        ``build(value) -> LinearModel``, kept for :meth:`boundaries`.
    """

    values: np.ndarray = field(repr=False)
    eigenvalues: np.ndarray = field(repr=False)
    shapes: np.ndarray = field(repr=False)
    stable: np.ndarray = field(repr=False)
    rigid: np.ndarray = field(repr=False)
    build: Callable = field(repr=False)

    @property
    def omega_n(self) -> np.ndarray:
        """(n_values, k) natural frequencies ``abs(s)`` (rad/s, Eq. 8.130)."""
        return np.abs(self.eigenvalues)

    @property
    def damping_ratio(self) -> np.ndarray:
        """(n_values, k) ``-Re(s) / abs(s)`` (Eq. 8.131); NaN for rigid-body modes."""
        mag = np.abs(self.eigenvalues)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.rigid, np.nan, -self.eigenvalues.real / np.where(mag > 0, mag, 1.0))

    @property
    def frequency_hz(self) -> np.ndarray:
        """(n_values, k) damped frequencies ``abs(Im s) / (2 pi)`` (Hz): a Campbell diagram."""
        return np.abs(self.eigenvalues.imag) / (2.0 * math.pi)

    def boundaries(self, *, xtol: float | None = None) -> np.ndarray:
        """Parameter values where the model loses (or regains) stability, by root finding between grid values.

        Between neighbouring values where one side is unstable (a non-rigid
        mode with ``Re(s) > STABILITY_TOL * scale``) and the other is not,
        ``build`` is called again in this process and Brent's method finds,
        to ``xtol`` (default ``1e-10 (1 + max abs(values))``) and whatever
        the spacing of the grid:

        * the crossing of ``max Re(s) = STABILITY_TOL * scale`` (``scale``
          the largest ``abs(s)``): on an undamped stable side the real parts
          are zero (round-off of either sign), and instability begins where
          two imaginary roots collide, with each other (flutter: ``+-a + i
          b``) or at zero (divergence: ``+-sigma``). Past the collision the
          real part grows as ``c sqrt(v - v*)``, so this crossing lies
          ``(STABILITY_TOL scale / c)^2`` from the collision ``v*`` (about
          1e-16 relative for the heavy top);
        * when the stable side is asymptotically stable (every real part
          below ``-STABILITY_TOL * scale``) and ``max Re(s)`` passes
          through the band ``abs(Re s) <= STABILITY_TOL * scale`` linearly
          (a damped mode crossing the imaginary axis), the crossing of
          ``max Re(s) = 0`` itself inside that band.

        A divergence through a root classified rigid (``abs(s) <= RIGID_TOL
        * scale``) is found where the root leaves that class: for an
        undamped model ``s^2`` is linear in the stiffness, so this lies
        ``RIGID_TOL^2`` times the largest stiffness eigenvalue from the
        collision; a damped real root ``s ~ v - v*`` is found ``RIGID_TOL *
        scale / (ds/dv)`` from it.

        Returns
        -------
        (n_boundaries,) ndarray
            Increasing.
        """
        v = self.values
        xt = 1e-10 * (1.0 + float(np.max(np.abs(v)))) if xtol is None else real_number(xtol, "xtol")
        if not xt > 0:
            raise ValueError(f"xtol: expected a tolerance > 0, got {xt!r}")
        h = np.array([_margin(self.eigenvalues[i], self.rigid[i]) for i in range(v.size)])
        out = []
        for i in range(v.size - 1):
            if (h[i] > 0) != (h[i + 1] > 0):
                out.append(_crossing(self.build, float(v[i]), float(v[i + 1]), stable_first=not h[i] > 0,
                                     xtol=xt))
        return np.array(out)

    def to_csv(self) -> str:
        """CSV text: ``value`` then per tracked mode ``re_j, im_j`` (one row per value)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        k = self.eigenvalues.shape[1]
        w.writerow(["value"] + [f"{p}_{j}" for j in range(k) for p in ("re", "im")])
        for i, val in enumerate(self.values):
            w.writerow([repr(float(val))] + [repr(float(x)) for s in self.eigenvalues[i] for x in (s.real, s.imag)])
        return buf.getvalue()

    def to_json(self) -> str:
        """JSON: ``{"values": [...], "eigenvalues": [[[re, im], ...], ...]}`` (tracked columns)."""
        ev = [[[float(s.real), float(s.imag)] for s in row] for row in self.eigenvalues]
        return json.dumps({"values": [float(x) for x in self.values], "eigenvalues": ev}, allow_nan=False)


def _margin(ev: np.ndarray, rigid: np.ndarray, *, offset: bool = True) -> float:
    """``max Re(s)`` of the non-rigid modes, less ``STABILITY_TOL * scale`` with ``offset``."""
    scale = float(np.max(np.abs(ev))) if ev.size else 1.0
    scale = scale if scale > 0 else 1.0
    tol = STABILITY_TOL * scale if offset else 0.0
    live = ev[~rigid]
    if live.size == 0:
        return -STABILITY_TOL * scale
    return float(np.max(live.real)) - tol


def _margin_of(model: Any, *, offset: bool = True) -> float:
    if not isinstance(model, LinearModel):
        raise ValueError(f"build: expected build(value) to return a LinearModel, got {short_repr(model)}")
    m = model.modes()
    return _margin(m.eigenvalues, m.rigid, offset=offset)


def _crossing(build: Callable, a: float, b: float, *, stable_first: bool, xtol: float) -> float:
    """The stability boundary between ``a`` (stable when ``stable_first``) and ``b`` (see ``boundaries``)."""
    cache: dict[float, tuple[float, float]] = {}

    def margin(x: float) -> tuple[float, float]:
        """``(max Re(s) of the non-rigid modes, STABILITY_TOL * scale)`` at ``x``."""
        if x not in cache:
            model = build(x)
            if not isinstance(model, LinearModel):
                raise ValueError(f"build: expected build(value) to return a LinearModel, got {short_repr(model)}")
            m = model.modes()
            tol = STABILITY_TOL * m.scale
            cache[x] = (_margin(m.eigenvalues, m.rigid, offset=False), tol)
        return cache[x]

    def band(sign: float) -> Callable[[float], float]:
        return lambda x: margin(x)[0] - sign * margin(x)[1]

    stable = a if stable_first else b
    # where the unstable side begins: robust against real parts that are round-off on the stable side
    upper = brentq(band(1.0), a, b, xtol=xtol, maxiter=200)
    re, tol = margin(stable)
    if not re < -tol:
        return upper  # a critical (undamped) stable side: instability begins at a collision of imaginary roots
    # an asymptotically stable side: where max Re(s) enters the band |Re s| <= tol, then whether it crosses the
    # band linearly (a damped mode crossing the axis) or lingers in it (an undamped stretch before a collision)
    if not band(-1.0)(upper) > 0:
        return upper
    lower = brentq(band(-1.0), stable, upper, xtol=xtol, maxiter=200)
    width = upper - lower
    if not abs(width) > 4.0 * xtol:
        return 0.5 * (lower + upper)
    for frac, expect in ((0.25, -0.5), (0.75, 0.5)):
        re_q, tol_q = margin(lower + frac * width)
        if not abs(re_q - expect * tol_q) <= 0.25 * tol_q:
            return upper
    return brentq(lambda x: margin(x)[0], lower, upper, xtol=xtol, maxiter=200)


def _solve(build: Callable, value: float) -> Modes:
    """Worker task: ``build(value).modes()`` without the embedding (small to send back)."""
    model = build(value)
    if not isinstance(model, LinearModel):
        raise ValueError(f"build: expected build(value) to return a LinearModel, got {short_repr(model)}")
    return replace(model.modes(), embedding=None)


def _track(previous: Modes, current: Modes) -> np.ndarray:
    """Permutation of ``current``'s modes that follows ``previous``'s (shape correlation, then eigenvalues)."""
    P, Q = previous.complex_shapes, current.complex_shapes
    if P.shape != Q.shape:
        raise ValueError(f"build: the models have different sizes across the sweep ({P.shape} and {Q.shape})")
    num = np.abs(np.conj(P) @ Q.T) ** 2
    den = np.outer(np.sum(np.abs(P) ** 2, axis=1), np.sum(np.abs(Q) ** 2, axis=1))
    mac = num / np.where(den > 0, den, 1.0)
    scale = max(previous.scale, current.scale, 1e-300)
    dist = np.abs(previous.eigenvalues[:, None] - current.eigenvalues[None, :]) / scale
    _, cols = linear_sum_assignment((1.0 - mac) + dist)
    return cols


def sweep(build: Callable, values: Any, *, executor: concurrent.futures.Executor | None = None,
          progress: Callable[[int, int], Any] | None = None) -> SweepResult:
    """Modes of ``build(value)`` for every value, computed on an executor and tracked.

    Parameters
    ----------
    build : callable
        ``build(value) -> LinearModel``; it runs in the executor's workers,
        so with a process pool it must be picklable (a module-level function
        or a ``functools.partial`` of one).
    values : (n_values,) array_like
        Strictly increasing finite parameter values.
    executor : concurrent.futures.Executor or None, keyword-only
        Any executor (a process or thread pool, ``dask.distributed``'s
        ``Client.get_executor()``). Default: a local process pool with one
        worker per CPU, shut down at the end.
    progress : callable or None, keyword-only
        ``progress(done, total)`` after every finished value, in the calling
        thread. An exception it raises stops the sweep (pending values are
        cancelled) and propagates: a scene cancels a sweep that way.

    Returns
    -------
    SweepResult

    Raises
    ------
    ValueError
        For bad values, a ``build`` that cannot be pickled for the default
        pool, or one that does not return a LinearModel.
    """
    if not callable(build):
        raise ValueError(f"build: expected a callable build(value) -> LinearModel, got {short_repr(build)}")
    v = float_array(values, "values", expected="parameter values").reshape(-1) if np.ndim(values) <= 1 else None
    if v is None or v.size == 0 or not np.all(np.isfinite(v)) or np.any(np.diff(v) <= 0):
        raise ValueError(f"values: expected a non-empty 1-d array of finite, strictly increasing values, got "
                         f"{short_repr(values)}")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress: expected a callable progress(done, total) or None, got {short_repr(progress)}")
    own = executor is None
    if own:
        try:
            pickle.dumps(build)
        except Exception as exc:  # noqa: BLE001 - any pickling failure
            raise ValueError(f"build: the default process pool needs a picklable build (a module-level function or "
                             f"functools.partial), got {short_repr(build)} ({exc}); or pass an executor") from None
        executor = concurrent.futures.ProcessPoolExecutor(max_workers=os.cpu_count() or 1)
    elif not isinstance(executor, concurrent.futures.Executor):
        raise ValueError(f"executor: expected a concurrent.futures.Executor or None, got {short_repr(executor)}")
    total = v.size
    results: list[Modes | None] = [None] * total
    futures: dict = {}
    try:
        futures = {executor.submit(_solve, build, float(x)): i for i, x in enumerate(v)}
        done = 0
        for fut in concurrent.futures.as_completed(futures):
            results[futures[fut]] = fut.result()
            done += 1
            if progress is not None:
                progress(done, total)
    finally:
        for fut in futures:
            fut.cancel()
        if own:
            executor.shutdown(wait=True, cancel_futures=True)
    k = results[0].eigenvalues.shape[0]
    f = results[0].complex_shapes.shape[1]
    ev = np.empty((total, k), dtype=complex)
    shapes = np.empty((total, k, f), dtype=complex)
    stable = np.empty((total, k), dtype=bool)
    rigid = np.empty((total, k), dtype=bool)
    prev = None
    for i, m in enumerate(results):
        if prev is None:
            perm = np.arange(k)
        else:
            perm = _track(prev, m)
        tracked = Modes(m.eigenvalues[perm], m.complex_shapes[perm], m.shapes[perm], m.omega_n[perm],
                        m.damping_ratio[perm], m.frequency_hz[perm], m.stable[perm], m.critical[perm], m.rigid[perm],
                        m.scale, m.method)
        ev[i], shapes[i], stable[i], rigid[i] = tracked.eigenvalues, tracked.complex_shapes, tracked.stable, tracked.rigid
        prev = tracked
    return SweepResult(_ro(v), _ro(ev), _ro(shapes), _ro(stable), _ro(rigid), build)
