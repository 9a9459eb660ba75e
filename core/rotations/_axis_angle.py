"""Axis and angle: the Rodriguez formula (Eqs. 8.29-8.38)."""

from __future__ import annotations

import numpy as np

from ._euler_parameters import _axis_angle_from_unit_p, _p_from_matrix
from ._validation import (
    broadcast_batch,
    check_matrix,
    check_scalar_array,
    check_unit_vector,
    check_vector,
)


def _matrix_from_unit_axis_angle(axis, angle, batch):
    # A = I + sin(angle) v~ + 2 sin^2(angle / 2) v~ v~  (Eq. 8.29), written
    # as cos(angle) I + sin(angle) v~ + (1 - cos(angle)) v v^T with
    # 1 - cos(angle) = 2 sin^2(angle / 2), which keeps full relative
    # precision for small angles.
    x = axis[..., 0]
    y = axis[..., 1]
    z = axis[..., 2]
    s = np.sin(angle)
    h = np.sin(0.5 * angle)
    k = 2.0 * h * h
    c = 1.0 - k
    out = np.empty(batch + (3, 3))
    kx = k * x
    ky = k * y
    kz = k * z
    sx = s * x
    sy = s * y
    sz = s * z
    kxy = kx * y
    kxz = kx * z
    kyz = ky * z
    out[..., 0, 0] = c + kx * x
    out[..., 0, 1] = kxy - sz
    out[..., 0, 2] = kxz + sy
    out[..., 1, 0] = kxy + sz
    out[..., 1, 1] = c + ky * y
    out[..., 1, 2] = kyz - sx
    out[..., 2, 0] = kxz - sy
    out[..., 2, 1] = kyz + sx
    out[..., 2, 2] = c + kz * z
    return out


def matrix_from_axis_angle(axis, angle):
    """Rotation matrix of a rotation about an axis: the Rodriguez formula (Eq. 8.29).

    .. math::

        A = I + \\tilde v \\sin\\theta + 2 \\tilde v^2 \\sin^2(\\theta/2)

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis ``v`` (same components in body and global frame),
        unit norm within :data:`UNIT_NORM_TOL` (normalized before use).
    angle : array_like, shape (...)
        Rotation angle ``theta`` in radians, right-hand rule about ``axis``.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global; batch shape is the broadcast
        of the batch shapes of ``axis`` and ``angle``.
    """
    axis = check_unit_vector(axis, "axis")
    angle = check_scalar_array(angle, "angle")
    if axis.shape[:-1] != angle.shape:
        (axis, angle), batch = broadcast_batch(("axis", axis, 1), ("angle", angle, 0))
    else:
        batch = angle.shape
    return _matrix_from_unit_axis_angle(axis, angle, batch)


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
    """Global angular velocity from axis, angle and their rates (Eqs. 8.31-8.35).

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
    """Body angular velocity from axis, angle and their rates (Eqs. 8.36-8.38).

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
