"""Rotation vectors ``r = axis * angle`` (as in scipy's ``as_rotvec``)."""

from __future__ import annotations

import math

import numpy as np

from ._axis_angle import _matrix_from_unit_axis_angle
from ._euler_parameters import _p_from_matrix
from ._validation import (
    check_degrees,
    degrees_out,
    radians_in,
    _index_str,
    as_float_array,
    check_euler_parameters,
    check_matrix,
    check_vector,
)


def _p_from_rotation_vector_single(x, y, z):
    """:func:`euler_parameters_from_rotation_vector` for one rotation: (4,),
    or None for a non-finite entry or an angle beyond float64."""
    angle = math.hypot(math.hypot(x, y), z)
    if not math.isfinite(angle):
        return None
    half = 0.5 * angle
    s = math.sin(half)
    if angle < 1.0:
        # 0.5 * np.sinc(angle / (2 pi)), as numpy evaluates it (1 at 0)
        arg = _PI * (angle / _TWO_PI)
        scale = 0.5 * (math.sin(arg) / arg) if arg != 0.0 else 0.5
        return np.array((math.cos(half), x * scale, y * scale, z * scale))
    return np.array((math.cos(half), x / angle * s, y / angle * s, z / angle * s))


_PI = float(np.pi)
_TWO_PI = 2.0 * _PI


def euler_parameters_from_rotation_vector(r, *, degrees=False):
    """Euler parameters of rotation vectors (Eq. 8.46 with ``angle = |r|``).

    Parameters
    ----------
    r : array_like, shape (..., 3)
        Rotation vectors: unit axis times angle in radians.
    degrees : bool, keyword-only
        True: ``r`` (``axis * angle``) is in degrees.

    Returns
    -------
    p : ndarray, shape (..., 4)
        Unit Euler parameters, scalar first (``theta0 < 0`` when
        ``|r| > pi``); unit also for huge ``|r|``.

    Raises
    ------
    ValueError
        If ``|r|`` (the angle) exceeds the float64 range.
    """
    r = radians_in(r, "r", degrees)
    arr = as_float_array(r, "r")
    if arr.shape == (3,):
        out = _p_from_rotation_vector_single(*arr.tolist())
        if out is not None:
            return out
    r = check_vector(arr, "r", 3)
    angle = _angle(r)
    half = 0.5 * angle
    small = angle < 1.0
    # sin(angle / 2) / angle = sinc(angle / (2 pi)) / 2, exact at angle 0;
    # beyond one radian sin(angle / 2) / angle directly, so that theta0 and
    # the vector part share one argument reduction (|p| = 1 also for huge
    # angles, where sinc's pi * x would round differently from angle / 2).
    scale = np.where(
        small,
        0.5 * np.sinc(np.where(small, angle, 0.0) / (2.0 * np.pi)),
        np.sin(half) / np.where(small, 1.0, angle),
    )
    out = np.empty(r.shape[:-1] + (4,))
    out[..., 0] = np.cos(half)
    # r / angle first: sin(half) / angle alone would lose digits (subnormal)
    # for angles near the largest float.
    big = ~small
    out[..., 1:] = r * scale[..., None]
    if np.any(big):
        axis = r[big] / angle[big][..., None]
        out[..., 1:][big] = axis * np.sin(half[big])[..., None]
    return out


def _angle(r):
    """``|r|`` (hypot: exact for tiny and huge vectors); raises past float64."""
    with np.errstate(over="ignore"):
        angle = np.hypot(np.hypot(r[..., 0], r[..., 1]), r[..., 2])
    if not np.all(np.isfinite(angle)):
        index = np.argwhere(~np.isfinite(angle))[0] if angle.ndim else ()
        raise ValueError(
            f"Expected `r` to have a norm (the angle) below the float64 maximum, "
            f"got {r[tuple(index)].tolist()!r}{_index_str(index)}"
        )
    return angle


def rotation_vector_from_euler_parameters(p, *, degrees=False):
    """Rotation vectors of Euler parameters.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    degrees : bool, keyword-only
        True: ``r`` is returned in degrees.

    Returns
    -------
    r : ndarray, shape (..., 3)
        ``axis * angle`` with angle in ``[0, pi]``.
    """
    check_degrees(degrees)
    p = check_euler_parameters(p, "p")
    return degrees_out(_rotvec_from_unit_p(p), degrees)


def _rotvec_from_unit_p(p):
    p = np.where(p[..., :1] < 0.0, -p, p)
    v = p[..., 1:]
    # hypot does not underflow for tiny vector parts (angles below 1e-150).
    s = np.hypot(np.hypot(v[..., 0], v[..., 1]), v[..., 2])
    angle = 2.0 * np.arctan2(s, p[..., 0])
    zero = s == 0.0
    # angle / s -> 2 / theta0 = 2 as s -> 0 (theta0 -> 1).
    scale = np.where(zero, 2.0, angle / np.where(zero, 1.0, s))
    return v * scale[..., None]


def matrix_from_rotation_vector(r, *, degrees=False):
    """Rotation matrices of rotation vectors (Rodriguez formula, Eq. 8.29).

    Parameters
    ----------
    r : array_like, shape (..., 3)
        Rotation vectors: unit axis times angle in radians.
    degrees : bool, keyword-only
        True: ``r`` (``axis * angle``) is in degrees.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global.

    Raises
    ------
    ValueError
        If ``|r|`` (the angle) exceeds the float64 range.
    """
    r = radians_in(r, "r", degrees)
    r = check_vector(r, "r", 3)
    angle = _angle(r)
    zero = angle == 0.0
    axis = r / np.where(zero, 1.0, angle)[..., None]
    axis[zero] = (0.0, 0.0, 1.0)
    return _matrix_from_unit_axis_angle(axis, angle, angle.shape)


def rotation_vector_from_matrix(A, *, degrees=False):
    """Rotation vectors of rotation matrices.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).
    degrees : bool, keyword-only
        True: ``r`` is returned in degrees.

    Returns
    -------
    r : ndarray, shape (..., 3)
        ``axis * angle`` with angle in ``[0, pi]``.
    """
    check_degrees(degrees)
    A = check_matrix(A, "A")
    return degrees_out(_rotvec_from_unit_p(_p_from_matrix(A)), degrees)
