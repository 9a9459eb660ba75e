"""Modified Rodriguez parameters ``sigma = axis tan(angle / 4)``.

Used in spacecraft attitude and robotics code (scipy's ``as_mrp``). Singular
only at angle 2 pi; functions here return the shortest set, ``|sigma| <= 1``.
"""

from __future__ import annotations

import numpy as np

from ._euler_parameters import _matrix_from_unit_p, _p_from_matrix
from ._validation import _scaled_from_one, check_euler_parameters, check_matrix, check_vector


def euler_parameters_from_mrp(sigma):
    """Euler parameters of modified Rodriguez parameters.

    ``theta0 = (1 - |sigma|^2) / (1 + |sigma|^2)``,
    ``theta = 2 sigma / (1 + |sigma|^2)``.

    Parameters
    ----------
    sigma : array_like, shape (..., 3)
        Modified Rodriguez parameters ``axis tan(angle / 4)``.

    Returns
    -------
    p : ndarray, shape (..., 4)
        Unit Euler parameters, scalar first; huge ``sigma`` (an angle near
        2 pi) tends to ``(-1, 0, 0, 0)``, the identity, without overflow.
    """
    s = check_vector(sigma, "sigma", 3)
    # sigma = m ss with m = max(1, max|sigma_i|): exact for |sigma_i| <= 1
    # (m = 1) and free of overflow for huge sigma (an angle near 2 pi, whose
    # limit is theta0 = -1, theta = 0: the identity).
    ss, inv_m = _scaled_from_one(s)
    inv_m2 = inv_m * inv_m
    s2 = np.einsum("...i,...i->...", ss, ss)
    d = 1.0 / (inv_m2 + s2)
    out = np.empty(s.shape[:-1] + (4,))
    out[..., 0] = (inv_m2 - s2) * d
    out[..., 1:] = 2.0 * ss * (inv_m * d)[..., None]
    return out


def _mrp_from_unit_p(p):
    p = np.where(p[..., :1] < 0.0, -p, p)
    return p[..., 1:] / (1.0 + p[..., :1])


def mrp_from_euler_parameters(p):
    """Modified Rodriguez parameters of Euler parameters: ``theta / (1 + theta0)``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first;
        ``p`` and ``-p`` give the same result.

    Returns
    -------
    sigma : ndarray, shape (..., 3)
        Shortest modified Rodriguez parameters, ``|sigma| <= 1``.
    """
    return _mrp_from_unit_p(check_euler_parameters(p, "p"))


def matrix_from_mrp(sigma):
    """Rotation matrices of modified Rodriguez parameters.

    Parameters
    ----------
    sigma : array_like, shape (..., 3)
        Modified Rodriguez parameters ``axis tan(angle / 4)``.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global.
    """
    return _matrix_from_unit_p(euler_parameters_from_mrp(sigma))


def mrp_from_matrix(A):
    """Modified Rodriguez parameters of rotation matrices.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).

    Returns
    -------
    sigma : ndarray, shape (..., 3)
        Shortest modified Rodriguez parameters, ``|sigma| <= 1``.
    """
    return _mrp_from_unit_p(_p_from_matrix(check_matrix(A, "A")))
