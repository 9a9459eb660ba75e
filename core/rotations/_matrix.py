"""Skew-symmetric matrices and rotation matrices about coordinate axes."""

from __future__ import annotations

import numpy as np

from ._validation import (
    check_degrees,
    degrees_out,
    radians_in,
    as_float_array,
    check_finite,
    check_matrix,
    check_scalar_array,
    check_vector,
)


def skew(v):
    """Skew-symmetric matrix of a vector, ``skew(a) @ b == cross(a, b)``.

    The chapter writes it with a tilde: ``a~`` (Eq. 8.29 uses ``v~``).

    Parameters
    ----------
    v : array_like, shape (..., 3)
        Vectors in any frame.

    Returns
    -------
    v_tilde : ndarray, shape (..., 3, 3)
        ``[[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]]``.
    """
    v = check_vector(v, "v")
    out = np.zeros(v.shape[:-1] + (3, 3))
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    out[..., 0, 1] = -z
    out[..., 0, 2] = y
    out[..., 1, 0] = z
    out[..., 1, 2] = -x
    out[..., 2, 0] = -y
    out[..., 2, 1] = x
    return out


def vector_from_skew(S, *, tol=1e-9):
    """Vector of a skew-symmetric matrix (inverse of :func:`skew`).

    Parameters
    ----------
    S : array_like, shape (..., 3, 3)
        Skew-symmetric matrices.
    tol : float
        Largest accepted entry of ``|S + S.T|``.

    Returns
    -------
    v : ndarray, shape (..., 3)
    """
    S = as_float_array(S, "S")
    if S.ndim < 2 or S.shape[-2:] != (3, 3):
        raise ValueError(f"Expected `S` to have shape (..., 3, 3), got shape {S.shape}")
    check_finite(S, "S", 2)
    asym = np.abs(S + np.swapaxes(S, -1, -2)).max(initial=0.0)
    if asym > tol:
        raise ValueError(
            f"Expected `S` to be skew-symmetric (max |S + S^T| <= {tol:g}), "
            f"got {asym:.3g}"
        )
    return np.stack([S[..., 2, 1], S[..., 0, 2], S[..., 1, 0]], axis=-1)


def elementary_matrix(axis, angle, *, degrees=False):
    """Rotation matrix about a coordinate axis.

    Parameters
    ----------
    axis : int
        0, 1 or 2 for the x, y or z axis.
    angle : array_like, shape (...)
        Rotation angle in radians (right-hand rule).
    degrees : bool, keyword-only
        True: ``angle`` is in degrees.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix; for axis 2 and angle phi this is the
        chapter's precession matrix.
    """
    angle = radians_in(angle, "angle", degrees)
    if axis not in (0, 1, 2):
        raise ValueError(f"Expected `axis` to be 0, 1 or 2, got {axis!r}")
    angle = check_scalar_array(angle, "angle")
    c = np.cos(angle)
    s = np.sin(angle)
    i1 = (axis + 1) % 3
    i2 = (axis + 2) % 3
    out = np.zeros(angle.shape + (3, 3))
    out[..., axis, axis] = 1.0
    out[..., i1, i1] = c
    out[..., i1, i2] = -s
    out[..., i2, i1] = s
    out[..., i2, i2] = c
    return out


def is_rotation_matrix(A, *, tol=1e-6):
    """Whether ``A`` is a rotation matrix (orthogonal within ``tol``, det +1).

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)

    Returns
    -------
    bool
        True when every matrix of the batch passes :func:`check_matrix`.
    """
    try:
        check_matrix(A, "A", tol)
    except ValueError:
        return False
    return True
