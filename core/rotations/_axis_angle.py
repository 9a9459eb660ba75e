"""Axis and angle: the Rodriguez formula (Eqs. 8.29-8.38)."""

from __future__ import annotations

import math

import numpy as np

from ._euler_parameters import (
    _axis_and_angle_floats,
    _axis_angle_from_unit_p,
    _matrix_from_rows,
    _matrix_single,
    _matrix_from_unit_p,
    _p_from_matrix,
)
from ._batch import BLOCK, blocks, compiled
from ._validation import (
    check_degrees,
    degrees_out,
    radians_in,
    UNIT_NORM2_TOL,
    as_float_array,
    broadcast_batch,
    check_matrix,
    check_scalar_array,
    check_unit_vector,
    check_vector,
)


def _matrix_from_unit_axis_angle(axis, angle, batch):
    """Rotation matrices of unit axes and angles (no validation), equal batches."""
    half = 0.5 * angle
    p = np.empty(batch + (4,))
    p[..., 0] = np.cos(half)
    p[..., 1:] = axis * np.sin(half)[..., None]
    return _matrix_from_unit_p(p)


def _matrix_from_axis_angle_single(x, y, z, angle):
    """The blocked arithmetic of :func:`matrix_from_axis_angle` for one
    rotation: (3, 3), or None if the axis is not unit or the angle not
    finite."""
    n2 = x * x + y * y + z * z
    if not (abs(n2 - 1.0) <= UNIT_NORM2_TOL and math.isfinite(angle)):
        return None
    h = math.tan(angle * 0.25)
    h2 = h * h
    den = h2 + 1.0
    w = (1.0 - h2) / den
    den *= math.sqrt(n2)
    h = (h + h) / den
    return _matrix_single(w, x * h, y * h, z * h)


def matrix_from_axis_angle(axis, angle, *, degrees=False):
    """Rotation matrix of a rotation about an axis: the Rodriguez formula (Eq. 8.29).

    .. math::

        A = I + \\tilde v \\sin\\theta + 2 \\tilde v^2 \\sin^2(\\theta/2)

    It is evaluated through the Euler parameters of the rotation
    (``theta0 = cos(theta / 2)``, ``axis sin(theta / 2)``, Eq. 8.46) and
    Eq. 8.48, an exact rewriting whose diagonal
    ``theta0^2 + theta_i^2 - theta_j^2 - theta_k^2`` avoids the cancellation
    of ``cos(theta) + (1 - cos(theta)) v_i^2`` near theta = pi.

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis ``v`` (same components in body and global frame),
        unit norm within :data:`UNIT_NORM_TOL` (normalized before use).
    angle : array_like, shape (...)
        Rotation angle ``theta`` in radians, right-hand rule about ``axis``.
    degrees : bool, keyword-only
        True: ``angle`` is in degrees.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global; batch shape is the broadcast
        of the batch shapes of ``axis`` and ``angle``.
    """
    angle = radians_in(angle, "angle", degrees)
    single = _axis_and_angle_floats(axis, angle)
    if single is not None:
        out = _matrix_from_axis_angle_single(*single)
        if out is not None:
            return out
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
    kernels = compiled(n)
    if kernels is not None:
        # The same validation and arithmetic in one compiled loop.
        ok = not kernels.matrix_from_axis_angle(
            np.ascontiguousarray(ax), np.ascontiguousarray(an), out, UNIT_NORM2_TOL
        )
    else:
        ok = _matrix_from_axis_angle_blocks(ax, an, out)
    if not ok:
        check_unit_vector(axis_in, "axis")  # raises, naming the batch index
        check_scalar_array(angle_in, "angle")
    return out.reshape(batch + (3, 3))


def _matrix_from_axis_angle_blocks(ax, an, out):
    """Rotation matrices of axes ``ax`` (n, 3) and angles ``an`` (n,) into
    ``out`` (n, 3, 3), block by block; whether every input passed the
    validation (unit axis, finite angle)."""
    n = an.shape[0]
    ok = np.empty(n, dtype=bool)
    ws = np.empty((17, min(n, BLOCK)))
    mul = np.multiply
    # Invalid entries are only reported after the loop; until then they
    # may produce NaN silently.
    with np.errstate(all="ignore"):
        for s, e in blocks(n):
            m = e - s
            comp = ws[13:17, :m]
            np.copyto(comp[1:], ax[s:e].T)
            x, y, z = comp[1:]
            a = an[s:e]
            n2 = ws[11, :m]
            t = ws[12, :m]
            mul(x, x, out=n2)
            mul(y, y, out=t)
            n2 += t
            mul(z, z, out=t)
            n2 += t
            # The validation of check_unit_vector and check_scalar_array,
            # fused into the block; NaN and infinity fail it too. Nothing is
            # returned unless every block passed.
            np.subtract(n2, 1.0, out=t)
            np.abs(t, out=t)
            np.less_equal(t, UNIT_NORM2_TOL, out=ok[s:e])
            ok[s:e] &= np.isfinite(a)
            # Euler parameters of the rotation (Eq. 8.46) with the half-angle
            # tangent h = tan(angle / 4): cos(angle / 2) = (1 - h^2) / (1 + h^2)
            # and sin(angle / 2) = 2 h / (1 + h^2), one vectorized tangent
            # instead of a sine and a cosine; the axis norm is divided out
            # on the way.
            h = ws[0, :m]
            h2 = ws[1, :m]
            den = ws[2, :m]
            mul(a, 0.25, out=h)
            np.tan(h, out=h)
            mul(h, h, out=h2)
            np.add(h2, 1.0, out=den)
            np.subtract(1.0, h2, out=comp[0])
            comp[0] /= den
            np.sqrt(n2, out=n2)
            den *= n2
            h += h
            h /= den
            comp[1:] *= h
            _matrix_from_rows(comp, out[s:e], ws)
    return bool(ok.all())


def axis_angle_from_matrix(A, *, degrees=False):
    """Axis and angle of a rotation matrix (inverse of Eq. 8.29).

    Computed through Euler parameters with Shepperd's pivoting, so the axis
    is accurate for every angle including angles near 0 and near pi.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).
    degrees : bool, keyword-only
        True: ``angle`` is returned in degrees.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit rotation axis; ``(0, 0, 1)`` for the identity (any axis would
        do). At exactly pi, ``axis`` and ``-axis`` are equivalent; the one
        returned has its first non-zero Euler parameter positive.
    angle : ndarray, shape (...)
        Rotation angle in ``[0, pi]``.
    """
    check_degrees(degrees)
    A = check_matrix(A, "A")
    axis, angle = _axis_angle_from_unit_p(_p_from_matrix(A))
    return axis, degrees_out(angle, degrees)


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


def omega_from_axis_angle_rates(axis, angle, axis_dot, angle_dot, *, degrees=False):
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
    degrees : bool, keyword-only
        True: ``angle`` in degrees and ``angle_dot`` in deg/s (the result stays rad/s).

    Returns
    -------
    omega : ndarray, shape (..., 3)
        Angular velocity in the global frame.
    """
    angle = radians_in(angle, "angle", degrees)
    angle_dot = radians_in(angle_dot, "angle_dot", degrees)
    return _omega_axis_angle(axis, angle, axis_dot, angle_dot, 1.0)


def omega_body_from_axis_angle_rates(axis, angle, axis_dot, angle_dot, *, degrees=False):
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
    degrees : bool, keyword-only
        True: ``angle`` in degrees and ``angle_dot`` in deg/s (the result stays rad/s).

    Returns
    -------
    omega_body : ndarray, shape (..., 3)
        Angular velocity in the body frame (omega-bar).
    """
    angle = radians_in(angle, "angle", degrees)
    angle_dot = radians_in(angle_dot, "angle_dot", degrees)
    return _omega_axis_angle(axis, angle, axis_dot, angle_dot, -1.0)
