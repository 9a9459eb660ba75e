"""Compiled kernels of the large-batch conversions (numba, ``cache=True``).

Imported on the first batch of at least :data:`._batch.COMPILED_MIN`
rotations (see :func:`._batch.compiled`), never by ``import core.rotations``:
numba's import and the kernels' compilation (or loading from numba's cache)
happen on first use only. Each kernel is one loop over a flattened batch
doing the arithmetic of the blocked numpy kernel it replaces, in the same
order (no ``fastmath``, so no reassociation and no fused multiply-adds):
the results equal the blocked path's to the last bit, up to the last bit of
a tangent from another library and the normalization skipped per rotation
instead of per block (Euler parameters that are unit to rounding). The
validation of the public function is fused into the loop: a kernel returns
the number of rotations that failed it (NaN and infinity fail), and the
Python caller raises the usual error, naming the batch index, when one
did. Single-threaded (no ``prange``); ``nogil``, so that a scene's worker
thread does not hold up the server's loop thread. Tolerances are arguments,
not globals frozen into the cached machine code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# error_model="numpy": division by zero gives inf / NaN (the input is then
# reported invalid) instead of raising ZeroDivisionError inside the loop.
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@njit(**_JIT, inline="always")
def _write_matrix(w, x, y, z, out, i):
    """``out[i]`` = the matrix of unit Euler parameters (Eqs. 8.48-8.50), the
    arithmetic of ``_matrix_from_rows``: diagonal
    ``theta0^2 + theta_i^2 - theta_j^2 - theta_k^2``, doubled products."""
    X = x + x
    Y = y + y
    Z = z + z
    ww = w * w
    xx = x * x
    yy = y * y
    zz = z * z
    xy = X * y
    xz = X * z
    yz = Y * z
    zw = Z * w
    yw = Y * w
    xw = X * w
    a = ww - zz
    b = xx - yy
    c = ww + zz
    d = xx + yy
    out[i, 0, 0] = a + b
    out[i, 0, 1] = xy - zw
    out[i, 0, 2] = xz + yw
    out[i, 1, 0] = xy + zw
    out[i, 1, 1] = a - b
    out[i, 1, 2] = yz - xw
    out[i, 2, 0] = xz - yw
    out[i, 2, 1] = yz + xw
    out[i, 2, 2] = c - d


@njit(**_JIT)
def matrix_from_euler_parameters(p, out, unit_norm2_tol, normalized_tol):
    """Rotation matrices of Euler parameters ``p`` (n, 4) into ``out`` (n, 3, 3).

    Returns the number of ``p_i`` failing ``| ||p_i||^2 - 1 | <=
    unit_norm2_tol``. ``p_i`` is divided by its norm unless
    ``| ||p_i||^2 - 1 | <= normalized_tol`` (unit to rounding).
    """
    bad = 0
    for i in range(p.shape[0]):
        w = p[i, 0]
        x = p[i, 1]
        y = p[i, 2]
        z = p[i, 3]
        n2 = w * w + x * x + y * y + z * z
        t = abs(n2 - 1.0)
        if not t <= unit_norm2_tol:
            bad += 1
        if t > normalized_tol:
            norm = np.sqrt(n2)
            w = w / norm
            x = x / norm
            y = y / norm
            z = z / norm
        _write_matrix(w, x, y, z, out, i)
    return bad


@njit(**_JIT)
def matrix_from_axis_angle(axis, angle, out, unit_norm2_tol):
    """Rotation matrices of axes ``axis`` (n, 3) and angles ``angle`` (n,)
    into ``out`` (n, 3, 3): the Euler parameters of the rotation (Eq. 8.46)
    from the half-angle tangent ``h = tan(angle / 4)``, then Eq. 8.48.

    Returns the number of rotations whose axis is not unit within
    ``unit_norm2_tol`` (squared norm) or whose angle is not finite. The
    axis norm is divided out on the way.
    """
    bad = 0
    for i in range(angle.shape[0]):
        x = axis[i, 0]
        y = axis[i, 1]
        z = axis[i, 2]
        a = angle[i]
        n2 = x * x + y * y + z * z
        if not (abs(n2 - 1.0) <= unit_norm2_tol and np.isfinite(a)):
            bad += 1
        # cos(angle / 2) = (1 - h^2) / (1 + h^2), sin(angle / 2) = 2 h / (1 + h^2)
        h = np.tan(a * 0.25)
        h2 = h * h
        den = h2 + 1.0
        w = (1.0 - h2) / den
        den = den * np.sqrt(n2)
        h = (h + h) / den
        _write_matrix(w, x * h, y * h, z * h, out, i)
    return bad


@njit(**_JIT)
def euler_parameters_from_matrix(A, out, orthogonality_tol):
    """Euler parameters with ``theta0 >= 0`` of rotation matrices ``A``
    (n, 3, 3) into ``out`` (n, 4): Shepperd's method, the arithmetic of
    ``_shepperd_block`` (the first largest pivot, as ``np.argmax`` picks it).

    Returns the number of matrices failing the validation of
    ``check_matrix``: every entry of ``|A A^T - I|`` within
    ``orthogonality_tol`` and ``det A > 0`` (``orthogonality_deviation``).
    """
    bad = 0
    for i in range(A.shape[0]):
        a00 = A[i, 0, 0]
        a01 = A[i, 0, 1]
        a02 = A[i, 0, 2]
        a10 = A[i, 1, 0]
        a11 = A[i, 1, 1]
        a12 = A[i, 1, 2]
        a20 = A[i, 2, 0]
        a21 = A[i, 2, 1]
        a22 = A[i, 2, 2]
        tol = orthogonality_tol
        if not (
            abs(a00 * a00 + a01 * a01 + a02 * a02 - 1.0) <= tol
            and abs(a10 * a10 + a11 * a11 + a12 * a12 - 1.0) <= tol
            and abs(a20 * a20 + a21 * a21 + a22 * a22 - 1.0) <= tol
            and abs(a00 * a10 + a01 * a11 + a02 * a12) <= tol
            and abs(a00 * a20 + a01 * a21 + a02 * a22) <= tol
            and abs(a10 * a20 + a11 * a21 + a12 * a22) <= tol
            and (a01 * a12 - a02 * a11) * a20
            + (a02 * a10 - a00 * a12) * a21
            + (a00 * a11 - a01 * a10) * a22
            > 0.0
        ):
            bad += 1
        trace = a00 + a11 + a22
        d0 = 1.0 + trace
        e = 1.0 - trace
        d1 = e + 2.0 * a00
        d2 = e + 2.0 * a11
        d3 = e + 2.0 * a22
        s01 = a21 - a12
        s02 = a02 - a20
        s03 = a10 - a01
        if d0 >= d1 and d0 >= d2 and d0 >= d3:
            q0, q1, q2, q3 = d0, s01, s02, s03
        elif d1 >= d2 and d1 >= d3:
            q0, q1, q2, q3 = s01, d1, a10 + a01, a02 + a20
        elif d2 >= d3:
            q0, q1, q2, q3 = s02, a10 + a01, d2, a21 + a12
        else:
            q0, q1, q2, q3 = s03, a02 + a20, a21 + a12, d3
        norm = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        # The norm with the sign of theta0, so that theta0 >= 0.
        norm = math.copysign(norm, q0)
        out[i, 0] = q0 / norm
        out[i, 1] = q1 / norm
        out[i, 2] = q2 / norm
        out[i, 3] = q3 / norm
    return bad
