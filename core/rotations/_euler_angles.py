"""Euler angles for all 12 sequences, intrinsic and extrinsic (Eqs. 8.7-8.11).

A sequence is three axis letters. Upper case (``"ZXZ"``) is intrinsic: each
rotation is about an axis of the moving (body) frame, so
``A = R_Z(a) @ R_X(b) @ R_Z(c)`` for angles ``(a, b, c)``; ``"ZXZ"`` with
``(phi, theta, psi)`` is the chapter's precession, nutation, spin. Lower case (``"zxz"``) is extrinsic: each rotation is about an
axis of the fixed (global) frame, applied in the order given, so
``A = R_z(c) @ R_x(b) @ R_z(a)``. These are scipy's letters.
"""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np

from ._euler_parameters import _p_from_matrix, _p_from_matrix_single
from ._batch import blocks
from ._matrix import elementary_matrix
from ._quaternion import _product
from ._validation import (
    check_degrees,
    degrees_out,
    radians_in,
    _index_str,
    as_float_array,
    broadcast_batch,
    check_euler_parameters,
    check_matrix,
    check_vector,
    parse_seq,
)

#: Distance (rad) of the middle angle from its singular value below which
#: :func:`euler_angles_from_matrix` reports gimbal lock (the first and third
#: angles are then ill-conditioned; only their sum or difference is not).
GIMBAL_LOCK_TOL = 1e-7

# tan(distance / 2) of the middle angle from its singular value below which
# the rotation is the locked one to round-off: the third angle is set to zero
# there, which moves the matrix by at most about the distance (<= 2 eps).
_LOCKED_RATIO = float(np.finfo(np.float64).eps)

_LOCK_MESSAGE = (
    "the middle angle is within GIMBAL_LOCK_TOL = {tol:g} rad of its singular value, so only the sum "
    "or difference of the first and third angles is well conditioned; the returned angles reproduce "
    "the matrix to round-off, and the third angle is set to zero where the middle angle is singular "
    "to round-off."
)


class GimbalLockWarning(UserWarning):
    """The middle Euler angle is within :data:`GIMBAL_LOCK_TOL` of its singular
    value; see :func:`euler_angles_from_matrix` for the angles returned there."""


def _intrinsic_form(seq, angles):
    """Axes and angle columns of the equivalent intrinsic sequence.

    An extrinsic sequence ``"ijk"`` with angles ``(a, b, c)`` is the
    intrinsic sequence ``"KJI"`` with angles ``(c, b, a)``.
    """
    axes, intrinsic = parse_seq(seq)
    if intrinsic:
        return axes, (0, 1, 2), intrinsic
    return axes[::-1], (2, 1, 0), intrinsic


# Entries of the symbolic 3x3 products are 0.0, 1.0 or arrays; the helpers
# skip the multiplications and additions with structural zeros and ones so
# that the product costs exactly the flops of the closed form.
def _mul(x, y):
    if isinstance(x, float):
        if x == 0.0:
            return 0.0
        if x == 1.0:
            return y
    if isinstance(y, float):
        if y == 0.0:
            return 0.0
        if y == 1.0:
            return x
    return x * y


def _add(x, y):
    if isinstance(x, float) and x == 0.0:
        return y
    if isinstance(y, float) and y == 0.0:
        return x
    return x + y


def _elementary(axis, c, s, ns):
    R = [[0.0] * 3 for _ in range(3)]
    i1 = (axis + 1) % 3
    i2 = (axis + 2) % 3
    R[axis][axis] = 1.0
    R[i1][i1] = c
    R[i1][i2] = ns
    R[i2][i1] = s
    R[i2][i2] = c
    return R


def _matmul_sym(X, Y):
    out = [[0.0] * 3 for _ in range(3)]
    for r in range(3):
        for col in range(3):
            acc = 0.0
            for m in range(3):
                acc = _add(acc, _mul(X[r][m], Y[m][col]))
            out[r][col] = acc
    return out


def _matrix_from_angles(angles, seq):
    (i, j, k), cols, _ = _intrinsic_form(seq, angles)
    flat = angles.reshape(-1, 3)
    out = np.empty((flat.shape[0], 3, 3))
    for start, stop in blocks(flat.shape[0]):
        b = flat[start:stop]
        c = np.cos(b)
        s = np.sin(b)
        Rs = []
        for axis, col in zip((i, j, k), cols):
            sc = s[:, col]
            Rs.append(_elementary(axis, c[:, col], sc, -sc))
        M = _matmul_sym(_matmul_sym(Rs[0], Rs[1]), Rs[2])
        o = out[start:stop]
        for r in range(3):
            for col in range(3):
                o[:, r, col] = M[r][col]
    return out.reshape(angles.shape[:-1] + (3, 3))


@functools.cache
def _single_form(seq):
    """Index tables of the one-rotation kernels for a parsed ``seq``.

    Returns the intrinsic axes ``(i, j, k)``, the angle positions of their
    angles, and the neighbours ``(i1, i2)``, ``(j1, j2)``, ``(k1, k2)`` of
    each axis, ``n1 = (n + 1) % 3`` and ``n2 = (n + 2) % 3``.
    """
    (i, j, k), cols, _ = _intrinsic_form(seq, None)
    return (i, j, k), cols, tuple(((n + 1) % 3, (n + 2) % 3) for n in (i, j, k))


def _matrix_from_angles_single(angles, seq):
    """:func:`_matrix_from_angles` for one rotation: (3, 3), or None if an
    angle is not finite.

    ``(R_i(a) @ R_j(b)) @ R_k(c)`` with every entry of both products a sum
    of at most two non-zero terms, so computing it as two row operations of
    ``R_i(a)`` on ``R_j(b)`` and two column operations of ``R_k(c)`` gives
    the same floats as the batched symbolic product.
    """
    x0, x1, x2 = angles.tolist()
    if not math.isfinite(x0 + x1 + x2):  # NaN or infinity (or overflow)
        return None
    (i, j, k), (ca_, cb_, cc_), ((i1, i2), (j1, j2), (k1, k2)) = _single_form(seq)
    values = (x0, x1, x2)
    a, b, c = values[ca_], values[cb_], values[cc_]
    ca, sa = math.cos(a), math.sin(a)
    cb, sb = math.cos(b), math.sin(b)
    cc, sc = math.cos(c), math.sin(c)
    # R_j(b)
    M = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    M[j][j] = 1.0
    M[j1][j1] = cb
    M[j1][j2] = -sb
    M[j2][j1] = sb
    M[j2][j2] = cb
    # R_i(a) @ M: rows i1 and i2 turn.
    r1 = M[i1]
    r2 = M[i2]
    M[i1] = [ca * r1[0] - sa * r2[0], ca * r1[1] - sa * r2[1], ca * r1[2] - sa * r2[2]]
    M[i2] = [sa * r1[0] + ca * r2[0], sa * r1[1] + ca * r2[1], sa * r1[2] + ca * r2[2]]
    # M @ R_k(c): columns k1 and k2 turn.
    for row in M:
        m1 = row[k1]
        m2 = row[k2]
        row[k1] = m1 * cc + m2 * sc
        row[k2] = m2 * cc - m1 * sc
    return np.array(M)


def matrix_from_euler_angles(angles, seq="ZXZ", *, degrees=False):
    """Rotation matrix of Euler angles (precession-nutation-spin product for ``"ZXZ"``).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Angles in radians, in the order of ``seq``. For ``"ZXZ"``:
        precession phi, nutation theta, spin psi.
    seq : str
        One of the 12 sequences; upper case intrinsic (moving axes),
        lower case extrinsic (fixed axes), as in scipy.
    degrees : bool, keyword-only
        True: ``angles`` are in degrees.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global. Intrinsic ``"IJK"``:
        ``R_I(a) @ R_J(b) @ R_K(c)``; extrinsic ``"ijk"``:
        ``R_k(c) @ R_j(b) @ R_i(a)``.
    """
    angles = radians_in(angles, "angles", degrees)
    parse_seq(seq)
    arr = as_float_array(angles, "angles")
    if arr.shape == (3,):
        out = _matrix_from_angles_single(arr, seq)
        if out is not None:
            return out
    angles = check_vector(arr, "angles", 3)
    return _matrix_from_angles(angles, seq)


def _angles_from_p(p, seq, warn=True):
    """Euler angles of unit Euler parameters (Bernardes and Viollet, 2022)."""
    axes, intrinsic = parse_seq(seq)
    extrinsic = not intrinsic
    i, j, k = axes if extrinsic else axes[::-1]
    symmetric = i == k
    if symmetric:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    w = p[..., 0]
    qi = p[..., i + 1]
    qj = p[..., j + 1]
    qk = p[..., k + 1] * sign
    if symmetric:
        a, b, c, d = w, qi, qj, qk
    else:
        a, b, c, d = w - qj, qi + qk, qj + w, qk - qi
    half_sum = np.arctan2(b, a)
    half_diff = np.arctan2(d, c)
    out = np.zeros(p.shape[:-1] + (3,))
    h_ab, h_cd = np.hypot(a, b), np.hypot(c, d)
    middle = 2.0 * np.arctan2(h_cd, h_ab)
    near = (np.abs(middle) <= GIMBAL_LOCK_TOL) | (np.abs(middle - np.pi) <= GIMBAL_LOCK_TOL)
    if warn and near.any():
        index = np.argwhere(near)[0] if near.ndim else ()
        warnings.warn(
            f"Gimbal lock in sequence {seq!r}{_index_str(index)}: " + _LOCK_MESSAGE.format(tol=GIMBAL_LOCK_TOL),
            GimbalLockWarning,
            stacklevel=3,
        )
    # Near (not at) the singularity half_diff (or half_sum) comes from small
    # (c, d) (or (a, b)) and carries an error of about eps / middle, but the
    # matrix depends on it only through sin(middle): the general formulas
    # still reproduce the matrix to round-off. Only where the middle angle
    # is singular to round-off is the third angle set to zero.
    case1 = h_cd <= _LOCKED_RATIO * h_ab
    case2 = h_ab <= _LOCKED_RATIO * h_cd
    case0 = ~(case1 | case2)
    first = 0 if extrinsic else 2
    third = 2 if extrinsic else 0
    out[..., 1] = middle
    out[..., 0] = np.where(case1, 2.0 * half_sum, 2.0 * half_diff * (-1.0 if extrinsic else 1.0))
    out[..., first] = np.where(case0, half_sum - half_diff, out[..., first])
    a3 = np.where(case0, half_sum + half_diff, out[..., third])
    if not symmetric:
        a3 = a3 * sign
        out[..., 1] -= 0.5 * np.pi
    out[..., third] = a3
    # First and third angle into [-pi, pi); the middle one is already in
    # [0, pi] (proper) or [-pi/2, pi/2] (Tait-Bryan).
    out[..., 0::2] = (out[..., 0::2] + np.pi) % (2.0 * np.pi) - np.pi
    return out



def _angles_from_p_single(p, seq, warn=True):
    """:func:`_angles_from_p` for one rotation ``p`` (4 floats): (3,), the same
    formulas on floats (``atan2``, ``hypot``, the same wrapping)."""
    axes, intrinsic = parse_seq(seq)
    extrinsic = not intrinsic
    i, j, k = axes if extrinsic else axes[::-1]
    symmetric = i == k
    if symmetric:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    w, qi, qj, qk = p[0], p[i + 1], p[j + 1], p[k + 1] * sign
    if symmetric:
        a, b, c, d = w, qi, qj, qk
    else:
        a, b, c, d = w - qj, qi + qk, qj + w, qk - qi
    half_sum = math.atan2(b, a)
    half_diff = math.atan2(d, c)
    h_ab, h_cd = math.hypot(a, b), math.hypot(c, d)
    middle = 2.0 * math.atan2(h_cd, h_ab)
    if warn and (abs(middle) <= GIMBAL_LOCK_TOL or abs(middle - math.pi) <= GIMBAL_LOCK_TOL):
        warnings.warn(
            f"Gimbal lock in sequence {seq!r}: " + _LOCK_MESSAGE.format(tol=GIMBAL_LOCK_TOL),
            GimbalLockWarning,
            stacklevel=3,
        )
    case1 = h_cd <= _LOCKED_RATIO * h_ab
    case2 = h_ab <= _LOCKED_RATIO * h_cd
    case0 = not (case1 or case2)
    first = 0 if extrinsic else 2
    third = 2 if extrinsic else 0
    out = [0.0, middle, 0.0]
    out[0] = 2.0 * half_sum if case1 else 2.0 * half_diff * (-1.0 if extrinsic else 1.0)
    if case0:
        out[first] = half_sum - half_diff
    a3 = half_sum + half_diff if case0 else out[third]
    if not symmetric:
        a3 = a3 * sign
        out[1] -= 0.5 * math.pi
    out[third] = a3
    two_pi = 2.0 * math.pi
    out[0] = (out[0] + math.pi) % two_pi - math.pi
    out[2] = (out[2] + math.pi) % two_pi - math.pi
    return np.array(out)


def euler_angles_from_matrix(A, seq="ZXZ", *, degrees=False):
    """Euler angles of a rotation matrix (any sequence).

    Computed from the Euler parameters of ``A`` (Shepperd's method) with the
    quaternion method of Bernardes and Viollet (2022), accurate for every
    rotation.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    degrees : bool, keyword-only
        True: ``angles`` are returned in degrees.

    Returns
    -------
    angles : ndarray, shape (..., 3)
        In the order of ``seq``. First and third angle in ``[-pi, pi)``;
        middle angle in ``[0, pi]`` for proper Euler sequences (first and
        third axis equal, e.g. ``"ZXZ"``) and in ``[-pi/2, pi/2]`` for
        Tait-Bryan sequences (three different axes, e.g. ``"ZYX"``).

    Warns
    -----
    GimbalLockWarning
        When the middle angle is within :data:`GIMBAL_LOCK_TOL` of its
        singular value (0 or pi for proper sequences, +-pi/2 for Tait-Bryan
        ones). Then only the sum (or difference) of the first and third
        angles is well conditioned: the two angles separately carry an
        error of about ``eps / distance``, which the matrix feels only
        multiplied by the distance, so ``matrix_from_euler_angles(angles,
        seq)`` still reproduces ``A`` to round-off at any distance. Where
        the middle angle is singular to round-off (``tan(distance / 2) <=
        eps``, e.g. a matrix built with the middle angle exactly 0 or
        pi/2) the third angle is set to 0 and the first angle carries the
        rotation about the aligned axes.
    """
    check_degrees(degrees)
    parse_seq(seq)
    arr = as_float_array(A, "A")
    if arr.shape == (3, 3):  # one rotation: the float path, same formulas
        p = _p_from_matrix_single(*arr.ravel().tolist())
        if p is not None:
            return degrees_out(_angles_from_p_single(p.tolist(), seq), degrees)
    A = check_matrix(arr, "A")
    return degrees_out(_angles_from_p(_p_from_matrix(A), seq), degrees)


def euler_angles_from_euler_parameters(p, seq="ZXZ", *, degrees=False):
    """Euler angles of Euler parameters, any sequence.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    degrees : bool, keyword-only
        True: ``angles`` are returned in degrees.

    Returns
    -------
    angles : ndarray, shape (..., 3)
        As :func:`euler_angles_from_matrix`, including its gimbal-lock
        warning and choice.
    """
    check_degrees(degrees)
    parse_seq(seq)
    p = check_euler_parameters(p, "p")
    if p.shape == (4,):  # one rotation: the float path, same formulas
        return degrees_out(_angles_from_p_single(p.tolist(), seq), degrees)
    return degrees_out(_angles_from_p(p, seq), degrees)


def _p_from_angles_single(angles, seq):
    """:func:`euler_parameters_from_euler_angles` for one rotation: (4,), or
    None if an angle is not finite. The same quaternion products, zeros
    included, on floats."""
    x0, x1, x2 = angles.tolist()
    if not math.isfinite(x0 + x1 + x2):  # NaN or infinity (or overflow)
        return None
    axes, cols, _ = _single_form(seq)
    values = (0.5 * x0, 0.5 * x1, 0.5 * x2)
    qs = []
    for axis, col in zip(axes, cols):
        q = [math.cos(values[col]), 0.0, 0.0, 0.0]
        q[axis + 1] = math.sin(values[col])
        qs.append(q)
    p = _product_floats(_product_floats(qs[0], qs[1]), qs[2])
    out = np.array(p)
    return -out if p[0] < 0.0 else out


def _product_floats(a, b):
    """The arithmetic of :func:`_product` on two sequences of 4 floats."""
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3,
        a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1,
    )


def euler_parameters_from_euler_angles(angles, seq="ZXZ", *, degrees=False):
    """Euler parameters of Euler angles, any sequence.

    The product of the three elementary rotations' parameters
    ``(cos(a/2), e sin(a/2))`` in the order of the matrix product.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Angles in radians, in the order of ``seq``.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    degrees : bool, keyword-only
        True: ``angles`` are in degrees.

    Returns
    -------
    p : ndarray, shape (..., 4)
        Unit Euler parameters, scalar first, with ``theta0 >= 0``.
    """
    angles = radians_in(angles, "angles", degrees)
    parse_seq(seq)
    arr = as_float_array(angles, "angles")
    if arr.shape == (3,):
        out = _p_from_angles_single(arr, seq)
        if out is not None:
            return out
    angles = check_vector(arr, "angles", 3)
    (i, j, k), cols, _ = _intrinsic_form(seq, angles)
    half = 0.5 * angles
    c = np.cos(half)
    s = np.sin(half)
    ps = []
    for axis, col in zip((i, j, k), cols):
        q = np.zeros(angles.shape[:-1] + (4,))
        q[..., 0] = c[..., col]
        q[..., axis + 1] = s[..., col]
        ps.append(q)
    p = _product(ps[0], ps[1], np.empty_like(ps[0]))
    p = _product(p, ps[2], np.empty_like(p))
    return np.where(p[..., :1] < 0.0, -p, p)


def _G_intrinsic(axes, ang):
    """Columns e_i, R_i(a) e_j, R_i(a) R_j(b) e_k for intrinsic axes."""
    i, j, k = axes
    Ri = elementary_matrix(i, ang[..., 0])
    Rij = Ri @ elementary_matrix(j, ang[..., 1])
    G = np.zeros(ang.shape[:-1] + (3, 3))
    G[..., i, 0] = 1.0
    G[..., :, 1] = Ri[..., :, j]
    G[..., :, 2] = Rij[..., :, k]
    return G


def _intrinsic_angles(angles, seq):
    axes, cols, intrinsic = _intrinsic_form(seq, angles)
    return axes, angles[..., list(cols)], intrinsic


def euler_angle_G(angles, seq="ZXZ", *, degrees=False):
    """Matrix G with ``omega = G @ angle_rates`` (Eq. 8.8 for ``"ZXZ"``).

    For ``"ZXZ"`` (phi, theta, psi):
    ``G = [[0, cos phi, sin theta sin phi], [0, sin phi, -sin theta cos phi],
    [1, 0, cos theta]]``.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    degrees : bool, keyword-only
        True: ``angles`` are in degrees.

    Returns
    -------
    G : ndarray, shape (..., 3, 3)
        Column n is the global-frame axis of the n-th rotation of ``seq``.
        Singular where :func:`euler_angles_near_singularity` is true.
    """
    angles = radians_in(angles, "angles", degrees)
    parse_seq(seq)
    angles = check_vector(angles, "angles", 3)
    return _G(angles, seq)


def _G(angles, seq):
    axes, ang, intrinsic = _intrinsic_angles(angles, seq)
    G = _G_intrinsic(axes, ang)
    return G if intrinsic else G[..., ::-1].copy()


def euler_angle_G_bar(angles, seq="ZXZ", *, degrees=False):
    """Matrix G_bar with ``omega_body = G_bar @ angle_rates`` (Eq. 8.9 for ``"ZXZ"``).

    For ``"ZXZ"`` (phi, theta, psi):
    ``G_bar = [[sin theta sin psi, cos psi, 0], [sin theta cos psi, -sin psi, 0],
    [cos theta, 0, 1]]``; in general ``G_bar = A.T @ G``.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    degrees : bool, keyword-only
        True: ``angles`` are in degrees.

    Returns
    -------
    G_bar : ndarray, shape (..., 3, 3)
        Column n is the body-frame axis of the n-th rotation of ``seq``.
    """
    angles = radians_in(angles, "angles", degrees)
    parse_seq(seq)
    angles = check_vector(angles, "angles", 3)
    A = _matrix_from_angles(angles, seq)
    return np.swapaxes(A, -1, -2) @ _G(angles, seq)


def euler_angles_near_singularity(angles, seq="ZXZ", tol=1e-6, *, degrees=False):
    """Whether Euler angles are near the singular configuration of ``seq``.

    G and G_bar (Eqs. 8.8-8.9) are singular when the first and third
    rotation axes align: for proper Euler sequences (``"ZXZ"``, ...) when
    ``sin(b) = 0``, for Tait-Bryan sequences (``"ZYX"``, ...) when
    ``cos(b) = 0``, with ``b`` the middle angle. ``|det G|`` equals that
    sine or cosine.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    tol : float
        Threshold on ``|det G|``.
    degrees : bool, keyword-only
        True: ``angles`` are in degrees.

    Returns
    -------
    near : ndarray of bool, shape (...)
    """
    angles = radians_in(angles, "angles", degrees)
    return np.abs(_det_G(angles, seq)) <= tol


def _det_G(angles, seq):
    axes, _ = parse_seq(seq)
    angles = check_vector(angles, "angles", 3)
    b = angles[..., 1]
    return np.sin(b) if axes[0] == axes[2] else np.cos(b)


def _solve_rates(angles, omega, seq, tol, name, body):
    parse_seq(seq)
    angles = check_vector(angles, "angles", 3)
    omega = check_vector(omega, name, 3)
    (angles, omega), _ = broadcast_batch(("angles", angles, 1), (name, omega, 1))
    det = np.abs(_det_G(angles, seq))
    bad = det <= tol
    if bad.any():
        index = np.argwhere(bad)[0] if bad.ndim else ()
        raise ValueError(
            f"Expected `angles` away from the singular configuration of {seq!r} "
            f"(|det G| > {tol:g}), got angles {angles[tuple(index)]!r} with "
            f"|det G| = {float(det[tuple(index)]):.3g}{_index_str(index)}; the "
            "angle rates are not defined there (use Euler parameters)"
        )
    G = _G(angles, seq)
    if body:
        A = _matrix_from_angles(angles, seq)
        G = np.swapaxes(A, -1, -2) @ G
    return np.linalg.solve(G, omega[..., None])[..., 0]


def euler_angle_rates_from_omega(angles, omega, seq="ZXZ", *, tol=1e-6, degrees=False):
    """Euler angle rates from the global angular velocity (Eq. 8.8 inverted).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    omega : array_like, shape (..., 3)
        Angular velocity in the global frame, rad/s.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    tol : float
        Angles with ``|det G| <= tol`` are rejected
        (see :func:`euler_angles_near_singularity`).
    degrees : bool, keyword-only
        True: ``angles`` in degrees, ``rates`` returned in deg/s (``omega`` stays rad/s).

    Returns
    -------
    rates : ndarray, shape (..., 3)
        Time derivatives of the angles, rad/s.

    Raises
    ------
    ValueError
        At (or within ``tol`` of) the singular configuration.
    """
    angles = radians_in(angles, "angles", degrees)
    return degrees_out(_solve_rates(angles, omega, seq, tol, "omega", False), degrees)


def euler_angle_rates(angles, omega_body, seq="ZXZ", *, tol=1e-6, degrees=False):
    """Euler angle rates from the body angular velocity (Eq. 8.9 inverted).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    omega_body : array_like, shape (..., 3)
        Angular velocity in the body frame (omega-bar), rad/s.
    seq : str
        One of the 12 sequences; upper case intrinsic, lower case extrinsic.
    tol : float
        Angles with ``|det G_bar| <= tol`` are rejected.
    degrees : bool, keyword-only
        True: ``angles`` in degrees, ``rates`` returned in deg/s (``omega_body`` stays rad/s).

    Returns
    -------
    rates : ndarray, shape (..., 3)

    Raises
    ------
    ValueError
        At (or within ``tol`` of) the singular configuration.
    """
    angles = radians_in(angles, "angles", degrees)
    return degrees_out(_solve_rates(angles, omega_body, seq, tol, "omega_body", True), degrees)


def _angles_rates(angles, rates, seq):
    parse_seq(seq)
    angles = check_vector(angles, "angles", 3)
    rates = check_vector(rates, "rates", 3)
    (angles, rates), _ = broadcast_batch(("angles", angles, 1), ("rates", rates, 1))
    return angles, rates


def omega_from_euler_angle_rates(angles, rates, seq="ZXZ", *, degrees=False):
    """Global angular velocity ``omega = G @ rates`` (Eq. 8.8).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    rates : array_like, shape (..., 3)
        Their time derivatives, rad/s.
    seq : str
        One of the 12 sequences.
    degrees : bool, keyword-only
        True: ``angles`` in degrees and ``rates`` in deg/s (the result stays rad/s).

    Returns
    -------
    omega : ndarray, shape (..., 3)
        Angular velocity in the global frame.
    """
    angles = radians_in(angles, "angles", degrees)
    rates = radians_in(rates, "rates", degrees)
    angles, rates = _angles_rates(angles, rates, seq)
    return np.einsum("...ij,...j->...i", _G(angles, seq), rates)


def omega_body_from_euler_angle_rates(angles, rates, seq="ZXZ", *, degrees=False):
    """Body angular velocity ``omega_body = G_bar @ rates`` (Eq. 8.9).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    rates : array_like, shape (..., 3)
        Their time derivatives, rad/s.
    seq : str
        One of the 12 sequences.
    degrees : bool, keyword-only
        True: ``angles`` in degrees and ``rates`` in deg/s (the result stays rad/s).

    Returns
    -------
    omega_body : ndarray, shape (..., 3)
        Angular velocity in the body frame (omega-bar).
    """
    angles = radians_in(angles, "angles", degrees)
    rates = radians_in(rates, "rates", degrees)
    angles, rates = _angles_rates(angles, rates, seq)
    A = _matrix_from_angles(angles, seq)
    omega = np.einsum("...ij,...j->...i", _G(angles, seq), rates)
    return np.einsum("...ji,...j->...i", A, omega)


def _alpha(angles, rates, rates_dot, seq):
    parse_seq(seq)
    angles = check_vector(angles, "angles", 3)
    rates = check_vector(rates, "rates", 3)
    rates_dot = check_vector(rates_dot, "rates_dot", 3)
    (angles, rates, rates_dot), _ = broadcast_batch(
        ("angles", angles, 1), ("rates", rates, 1), ("rates_dot", rates_dot, 1)
    )
    axes, cols, _ = _intrinsic_form(seq, angles)
    cols = list(cols)
    ang = angles[..., cols]
    rd = rates[..., cols]
    rdd = rates_dot[..., cols]
    G = _G_intrinsic(axes, ang)
    g0, g1, g2 = G[..., 0], G[..., 1], G[..., 2]
    ad, bd, cd = rd[..., 0:1], rd[..., 1:2], rd[..., 2:3]
    # d/dt of the columns: g1' = a' g0 x g1, g2' = a' g0 x g2 + b' g1 x g2.
    g_dot_rates = ad * bd * np.cross(g0, g1) + cd * (
        ad * np.cross(g0, g2) + bd * np.cross(g1, g2)
    )
    alpha = np.einsum("...ij,...j->...i", G, rdd) + g_dot_rates
    return angles, alpha


def alpha_from_euler_angle_rates(angles, rates, rates_dot, seq="ZXZ", *, degrees=False):
    """Global angular acceleration ``alpha = G @ rates_dot + G_dot @ rates`` (Eqs. 8.10-8.11).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    rates : array_like, shape (..., 3)
        First time derivatives of the angles, rad/s.
    rates_dot : array_like, shape (..., 3)
        Second time derivatives of the angles, rad/s**2.
    seq : str
        One of the 12 sequences.
    degrees : bool, keyword-only
        True: ``angles``, ``rates``, ``rates_dot`` in deg, deg/s, deg/s**2 (the result stays rad/s**2).

    Returns
    -------
    alpha : ndarray, shape (..., 3)
        Angular acceleration in the global frame.
    """
    angles = radians_in(angles, "angles", degrees)
    rates = radians_in(rates, "rates", degrees)
    rates_dot = radians_in(rates_dot, "rates_dot", degrees)
    return _alpha(angles, rates, rates_dot, seq)[1]


def alpha_body_from_euler_angle_rates(angles, rates, rates_dot, seq="ZXZ", *, degrees=False):
    """Body angular acceleration ``alpha_body = G_bar @ rates_dot + G_bar_dot @ rates`` (Eqs. 8.10-8.11).

    Equal to ``A.T @ alpha``.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles in radians, in the order of ``seq``.
    rates : array_like, shape (..., 3)
        First time derivatives of the angles, rad/s.
    rates_dot : array_like, shape (..., 3)
        Second time derivatives of the angles, rad/s**2.
    seq : str
        One of the 12 sequences.
    degrees : bool, keyword-only
        True: ``angles``, ``rates``, ``rates_dot`` in deg, deg/s, deg/s**2 (the result stays rad/s**2).

    Returns
    -------
    alpha_body : ndarray, shape (..., 3)
        Angular acceleration in the body frame.
    """
    angles = radians_in(angles, "angles", degrees)
    rates = radians_in(rates, "rates", degrees)
    rates_dot = radians_in(rates_dot, "rates_dot", degrees)
    angles, alpha = _alpha(angles, rates, rates_dot, seq)
    A = _matrix_from_angles(angles, seq)
    return np.einsum("...ji,...j->...i", A, alpha)
