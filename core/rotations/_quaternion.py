"""Quaternion algebra, scalar first (Eqs. 8.65-8.83).

A quaternion ``q = (q0, q1, q2, q3)`` has scalar part ``q0`` and vector part
``(q1, q2, q3)``. Unit quaternions are Euler parameters; then
``A(q1 q2) = A(q1) A(q2)`` (Eqs. 8.77-8.79).
"""

from __future__ import annotations

import math

import numpy as np

from ._euler_parameters import _matrix_from_unit_p, _unit_p_single
from ._validation import (
    _index_str,
    as_float_array,
    _scaled_norm,
    broadcast_batch,
    check_euler_parameters,
    check_quaternion,
    check_scalar_array,
    check_unit_vector,
    check_vector,
)


def _product(a, b, out):
    a0 = a[..., 0]
    a1 = a[..., 1]
    a2 = a[..., 2]
    a3 = a[..., 3]
    b0 = b[..., 0]
    b1 = b[..., 1]
    b2 = b[..., 2]
    b3 = b[..., 3]
    out[..., 0] = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    out[..., 1] = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    out[..., 2] = a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3
    out[..., 3] = a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1
    return out


def quaternion_product(q1, q2):
    """Quaternion product ``q1 q2`` (Eqs. 8.69-8.72).

    .. math::

        q_1 q_2 = (a_0 b_0 - a \\cdot b, \\; a_0 b + b_0 a + a \\times b)

    For unit quaternions (Euler parameters) the product composes rotations:
    ``A(q1 q2) = A(q1) @ A(q2)`` (Eqs. 8.77-8.79). Not commutative.

    Parameters
    ----------
    q1, q2 : array_like, shape (..., 4)
        Quaternions, scalar first; batch shapes broadcast.

    Returns
    -------
    q : ndarray, shape (..., 4)
    """
    a = as_float_array(q1, "q1")
    b = as_float_array(q2, "q2")
    if a.shape == (4,) and b.shape == (4,):
        a0, a1, a2, a3 = a.tolist()
        b0, b1, b2, b3 = b.tolist()
        # No NaN or infinity (a finite sum that overflows only sends huge
        # quaternions to the batched path).
        if math.isfinite(a0 + a1 + a2 + a3 + b0 + b1 + b2 + b3):
            # The arithmetic of _product, on floats.
            return np.array(
                (
                    a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
                    a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                    a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3,
                    a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1,
                )
            )
    a = check_quaternion(a, "q1")
    b = check_quaternion(b, "q2")
    if a.shape != b.shape:
        (a, b), _ = broadcast_batch(("q1", a, 1), ("q2", b, 1))
    return _product(a, b, np.empty(a.shape))


def quaternion_conjugate(q):
    """Conjugate quaternion ``(q0, -q1, -q2, -q3)`` (Eqs. 8.69-8.72).

    For Euler parameters it is the inverse rotation: ``A(q*) = A(q).T``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, scalar first.

    Returns
    -------
    q_conj : ndarray, shape (..., 4)
    """
    arr = as_float_array(q, "q")
    if arr.shape == (4,):
        q0, q1, q2, q3 = arr.tolist()
        if math.isfinite(q0 + q1 + q2 + q3):
            return np.array((q0, -q1, -q2, -q3))
    q = check_quaternion(arr, "q")
    out = -q
    out[..., 0] = q[..., 0]
    return out


def quaternion_norm(q):
    """Norm ``sqrt(q q*)`` of a quaternion (Eqs. 8.69-8.72).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, scalar first.

    Returns
    -------
    norm : ndarray, shape (...)
    """
    q = check_quaternion(q, "q")
    m, _, n = _scaled_norm(q)  # no overflow / underflow of the squares
    with np.errstate(over="ignore"):  # inf only past the float64 range
        return m * n


def quaternion_inverse(q):
    """Inverse quaternion ``q* / |q|**2`` (Eqs. 8.65-8.73).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternions, scalar first.

    Returns
    -------
    q_inv : ndarray, shape (..., 4)
        ``q q_inv = q_inv q = (1, 0, 0, 0)``.
    """
    q = check_quaternion(q, "q")
    # q = m s: q^-1 = s* / (|s|^2 m), free of the overflow / underflow of
    # |q|^2 for huge or tiny q.
    m, s, n = _scaled_norm(q)
    zero = m == 0.0
    if zero.any():
        index = np.argwhere(zero)[0] if zero.ndim else ()
        raise ValueError(
            f"Expected `q` to be non-zero to invert it, got {q[tuple(index)]!r}"
            f"{_index_str(index)}"
        )
    out = -s
    out[..., 0] = s[..., 0]
    return out / (n * n)[..., None] / m[..., None]


def quaternion_sum(q1, q2):
    """Sum of quaternions, component-wise (Eqs. 8.65-8.73).

    Parameters
    ----------
    q1, q2 : array_like, shape (..., 4)
        Quaternions, scalar first; batch shapes broadcast.

    Returns
    -------
    q : ndarray, shape (..., 4)
    """
    a = check_quaternion(q1, "q1")
    b = check_quaternion(q2, "q2")
    (a, b), _ = broadcast_batch(("q1", a, 1), ("q2", b, 1))
    return a + b


def rotate_vector(p, u_body):
    """Rotate vectors by Euler parameters: ``A(p) @ u_body`` (Eqs. 8.77-8.79).

    Equal to the vector part of ``p (0, u_body) p*``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    u_body : array_like, shape (..., 3)
        Vectors with components in the body frame.

    Returns
    -------
    u_global : ndarray, shape (..., 3)
        The same vectors with components in the global frame.
    """
    p_in = as_float_array(p, "p")
    u_in = as_float_array(u_body, "u_body")
    if p_in.shape == (4,) and u_in.shape == (3,):
        unit = _unit_p_single(*p_in.tolist())
        u0, u1, u2 = u_in.tolist()
        if unit is not None and math.isfinite(u0 + u1 + u2):
            w, v0, v1, v2 = unit
            # u + w t + v x t with t = 2 v x u, as np.cross orders it.
            t0 = 2.0 * (v1 * u2 - v2 * u1)
            t1 = 2.0 * (v2 * u0 - v0 * u2)
            t2 = 2.0 * (v0 * u1 - v1 * u0)
            return np.array(
                (
                    u0 + w * t0 + (v1 * t2 - v2 * t1),
                    u1 + w * t1 + (v2 * t0 - v0 * t2),
                    u2 + w * t2 + (v0 * t1 - v1 * t0),
                )
            )
    p = check_euler_parameters(p_in, "p")
    u = check_vector(u_in, "u_body", 3)
    (p, u), _ = broadcast_batch(("p", p, 1), ("u_body", u, 1))
    w = p[..., :1]
    v = p[..., 1:]
    t = 2.0 * np.cross(v, u)
    return u + w * t + np.cross(v, t)


def relative_euler_parameters(p_i, p_j):
    """Euler parameters of body j relative to body i (Eq. 8.82).

    ``p_ij = p_i* p_j``, so that ``A(p_ij) = A(p_i).T @ A(p_j)``: the
    orientation of body j in the frame of body i.

    Parameters
    ----------
    p_i, p_j : array_like, shape (..., 4)
        Unit Euler parameters of bodies i and j, scalar first (each relative
        to the global frame).

    Returns
    -------
    p_ij : ndarray, shape (..., 4)
        Unit Euler parameters, scalar first (sign follows from the inputs).
    """
    a = check_euler_parameters(p_i, "p_i")
    b = check_euler_parameters(p_j, "p_j")
    (a, b), _ = broadcast_batch(("p_i", a, 1), ("p_j", b, 1))
    a = a * np.array([1.0, -1.0, -1.0, -1.0])
    return _product(a, b, np.empty(a.shape))


def constant_relative_rotation_residual(p_i, p_j, axis, rate, t, *, p_ij0=None):
    """Residual of the constant relative angular velocity constraint (Eq. 8.83).

    Body j rotates relative to body i about ``axis`` (fixed in body i) with
    constant ``rate``: ``p_ij(t) = p_ij0 (cos(rate t / 2), axis sin(rate t / 2))``.
    The residual is the vector part of ``p_drive* p_ij`` with
    ``p_ij = p_i* p_j`` (Eq. 8.82): three independent equations, zero
    exactly when ``A(p_ij) = A(p_drive)``, whichever sign ``p_ij`` has, and
    equal to ``sin(e / 2)`` times the error axis for an orientation error
    of angle ``e``.

    Parameters
    ----------
    p_i, p_j : array_like, shape (..., 4)
        Unit Euler parameters of bodies i and j, scalar first.
    axis : array_like, shape (..., 3)
        Unit axis of the relative rotation, components in body i's frame.
    rate : array_like, shape (...)
        Constant relative angular velocity, rad/s.
    t : array_like, shape (...)
        Time, s.
    p_ij0 : array_like, shape (..., 4), optional
        Relative Euler parameters at ``t = 0``; identity by default.

    Returns
    -------
    residual : ndarray, shape (..., 3)
    """
    a = check_euler_parameters(p_i, "p_i")
    b = check_euler_parameters(p_j, "p_j")
    axis = check_unit_vector(axis, "axis")
    rate = check_scalar_array(rate, "rate")
    t = check_scalar_array(t, "t")
    if p_ij0 is None:
        p0 = np.array([1.0, 0.0, 0.0, 0.0])
    else:
        p0 = check_euler_parameters(p_ij0, "p_ij0")
    (a, b, axis, rate, t, p0), batch = broadcast_batch(
        ("p_i", a, 1), ("p_j", b, 1), ("axis", axis, 1), ("rate", rate, 0),
        ("t", t, 0), ("p_ij0", p0, 1),
    )
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    p_ij = _product(a * conj, b, np.empty(batch + (4,)))
    half = 0.5 * rate * t
    step = np.empty(batch + (4,))
    step[..., 0] = np.cos(half)
    step[..., 1:] = axis * np.sin(half)[..., None]
    drive = _product(p0, step, np.empty(batch + (4,)))
    err = _product(drive * conj, p_ij, np.empty(batch + (4,)))
    return err[..., 1:]


def matrix_from_quaternion_product(q1, q2):
    """``A(q1 q2)`` for unit quaternions; equals ``A(q1) @ A(q2)`` (Eqs. 8.77-8.79).

    Parameters
    ----------
    q1, q2 : array_like, shape (..., 4)
        Unit Euler parameters, scalar first.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
    """
    a = check_euler_parameters(q1, "q1")
    b = check_euler_parameters(q2, "q2")
    (a, b), batch = broadcast_batch(("q1", a, 1), ("q2", b, 1))
    return _matrix_from_unit_p(_product(a, b, np.empty(batch + (4,))))
