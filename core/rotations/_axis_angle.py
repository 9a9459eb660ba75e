"""Axis and angle: the Rodriguez formula (Eqs. 8.29-8.38)."""

from __future__ import annotations

import numpy as np

from ._euler_parameters import _axis_angle_from_unit_p, _p_from_matrix
from ._batch import blocks
from ._validation import (
    NORMALIZED_TOL,
    UNIT_NORM2_TOL,
    as_float_array,
    broadcast_batch,
    check_matrix,
    check_scalar_array,
    check_unit_vector,
    check_vector,
)


def _rodriguez_block(x, y, z, angle, o):
    """Write Rodriguez matrices of unit axes (x, y, z) into ``o`` (m, 3, 3)."""
    # A = I + sin(angle) v~ + 2 sin^2(angle / 2) v~ v~  (Eq. 8.29), written
    # as cos(angle) I + sin(angle) v~ + (1 - cos(angle)) v v^T. With
    # t = tan(angle / 2): sin(angle) = 2 t / (1 + t^2) and
    # 1 - cos(angle) = 2 t^2 / (1 + t^2), exact identities that need one
    # (vectorized) tangent instead of two sines and keep full precision for
    # small angles; at angle = pi, t is large but finite in floating point
    # and both expressions stay accurate.
    t = np.tan(0.5 * angle)
    t2 = t * t
    u = 2.0 / (1.0 + t2)
    s = t * u
    k = t2 * u
    c = 1.0 - k
    kx = k * x
    ky = k * y
    kz = k * z
    sx = s * x
    sy = s * y
    sz = s * z
    kxy = kx * y
    kxz = kx * z
    kyz = ky * z
    np.add(c, kx * x, out=o[:, 0, 0])
    np.subtract(kxy, sz, out=o[:, 0, 1])
    np.add(kxz, sy, out=o[:, 0, 2])
    np.add(kxy, sz, out=o[:, 1, 0])
    np.add(c, ky * y, out=o[:, 1, 1])
    np.subtract(kyz, sx, out=o[:, 1, 2])
    np.subtract(kxz, sy, out=o[:, 2, 0])
    np.add(kyz, sx, out=o[:, 2, 1])
    np.add(c, kz * z, out=o[:, 2, 2])


def _matrix_from_unit_axis_angle(axis, angle, batch):
    """Rodriguez matrices of unit axes (no validation), batch shapes equal."""
    ax = axis.reshape(-1, 3)
    an = angle.reshape(-1)
    out = np.empty((an.shape[0], 3, 3))
    for s, e in blocks(an.shape[0]):
        b = ax[s:e]
        _rodriguez_block(b[:, 0], b[:, 1], b[:, 2], an[s:e], out[s:e])
    return out.reshape(batch + (3, 3))


def matrix_from_axis_angle(axis, angle):
    """Rotation matrix of a rotation about an axis: the Rodriguez formula (Eq. 8.29).

    .. math::

        A = I + \\tilde v \\sin\\theta + 2 \\tilde v^2 \\sin^2(\\theta/2)

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis ``v`` (same components in body and global frame),
        unit norm within :data:`UNIT_NORM_TOL`, normalized before use
        (unless already unit to rounding, ``| |v|^2 - 1 | <= 4 eps``).
    angle : array_like, shape (...)
        Rotation angle ``theta`` in radians, right-hand rule about ``axis``.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global; batch shape is the broadcast
        of the batch shapes of ``axis`` and ``angle``.
    """
    axis_in = as_float_array(axis, "axis")
    angle_in = as_float_array(angle, "angle")
    if axis_in.ndim < 1 or axis_in.shape[-1] != 3:
        check_unit_vector(axis_in, "axis")
    if axis_in.shape[:-1] != angle_in.shape:
        (ax, an), batch = broadcast_batch(("axis", axis_in, 1), ("angle", angle_in, 0))
    else:
        ax, an, batch = axis_in, angle_in, angle_in.shape
    ax = ax.reshape(-1, 3)
    an = an.reshape(-1)
    n = an.shape[0]
    out = np.empty((n, 3, 3))
    ok = np.empty(n, dtype=bool)
    # Invalid entries are only reported after the loop; until then they
    # may produce NaN silently.
    with np.errstate(all="ignore"):
        for s, e in blocks(n):
            b = ax[s:e]
            x = b[:, 0]
            y = b[:, 1]
            z = b[:, 2]
            a = an[s:e]
            n2 = x * x + y * y + z * z
            # The validation of check_unit_vector and check_scalar_array, fused
            # into the block; NaN and infinity fail it too. Nothing is returned
            # unless every block passed.
            dev = n2 - 1.0
            np.abs(dev, out=dev)
            np.less_equal(dev, UNIT_NORM2_TOL, out=ok[s:e])
            ok[s:e] &= np.isfinite(a)
            if not dev.max(initial=0.0) <= NORMALIZED_TOL:
                norm = np.sqrt(n2)
                x = x / norm
                y = y / norm
                z = z / norm
            _rodriguez_block(x, y, z, a, out[s:e])
    if not ok.all():
        check_unit_vector(axis_in, "axis")  # raises, naming the batch index
        check_scalar_array(angle_in, "angle")
    return out.reshape(batch + (3, 3))


def axis_angle_from_matrix(A):
    """Axis and angle of a rotation matrix (inverse of Eq. 8.29).

    Computed through Euler parameters with Shepperd's pivoting, so the axis
    is accurate for every angle including angles near 0 and near pi.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit rotation axis; ``(0, 0, 1)`` for the identity (any axis would
        do). At exactly pi, ``axis`` and ``-axis`` are equivalent; the one
        returned has its first non-zero Euler parameter positive.
    angle : ndarray, shape (...)
        Rotation angle in ``[0, pi]``.
    """
    A = check_matrix(A, "A")
    return _axis_angle_from_unit_p(_p_from_matrix(A))


def _omega_axis_angle(axis, angle, axis_dot, angle_dot, sign):
    v = check_unit_vector(axis, "axis")
    th = check_scalar_array(angle, "angle")
    vd = check_vector(axis_dot, "axis_dot", 3)
    thd = check_scalar_array(angle_dot, "angle_dot")
    (v, th, vd, thd), _ = broadcast_batch(
        ("axis", v, 1), ("angle", th, 0), ("axis_dot", vd, 1), ("angle_dot", thd, 0)
    )
    along = np.einsum("...i,...i->...", v, vd)
    tol = 1e-6 * (1.0 + np.sqrt(np.einsum("...i,...i->...", vd, vd)))
    bad = np.abs(along) > tol
    if bad.any():
        index = tuple(np.argwhere(bad)[0]) if bad.ndim else ()
        raise ValueError(
            "Expected `axis_dot` to be perpendicular to `axis` (the derivative "
            f"of a unit vector), got axis . axis_dot = {float(along[index]):.3g}"
        )
    h = np.sin(0.5 * th)
    one_minus_cos = 2.0 * h * h
    return (
        thd[..., None] * v
        + np.sin(th)[..., None] * vd
        + sign * one_minus_cos[..., None] * np.cross(v, vd)
    )


def omega_from_axis_angle_rates(axis, angle, axis_dot, angle_dot):
    """Global angular velocity from axis, angle and their rates (Eqs. 8.31-8.38).

    .. math::

        \\omega = \\dot\\theta v + \\sin\\theta \\, \\dot v
                  + (1 - \\cos\\theta) \\, v \\times \\dot v

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis ``v``.
    angle : array_like, shape (...)
        Rotation angle ``theta``, rad.
    axis_dot : array_like, shape (..., 3)
        Time derivative of the axis (perpendicular to it), 1/s.
    angle_dot : array_like, shape (...)
        Time derivative of the angle, rad/s.

    Returns
    -------
    omega : ndarray, shape (..., 3)
        Angular velocity in the global frame.
    """
    return _omega_axis_angle(axis, angle, axis_dot, angle_dot, 1.0)


def omega_body_from_axis_angle_rates(axis, angle, axis_dot, angle_dot):
    """Body angular velocity from axis, angle and their rates (Eqs. 8.31-8.38).

    .. math::

        \\bar\\omega = \\dot\\theta v + \\sin\\theta \\, \\dot v
                       - (1 - \\cos\\theta) \\, v \\times \\dot v

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis ``v`` (same components in both frames).
    angle : array_like, shape (...)
        Rotation angle ``theta``, rad.
    axis_dot : array_like, shape (..., 3)
        Time derivative of the axis (perpendicular to it), 1/s.
    angle_dot : array_like, shape (...)
        Time derivative of the angle, rad/s.

    Returns
    -------
    omega_body : ndarray, shape (..., 3)
        Angular velocity in the body frame (omega-bar).
    """
    return _omega_axis_angle(axis, angle, axis_dot, angle_dot, -1.0)
