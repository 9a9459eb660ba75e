"""Rodriguez parameters ``gamma = axis tan(angle / 2)`` (Eqs. 8.58-8.64).

Three parameters with no constraint; singular at rotation angles of pi,
where ``theta0 = cos(angle / 2)`` vanishes and ``gamma`` is infinite.
"""

from __future__ import annotations

import numpy as np

from ._euler_parameters import _p_from_matrix
from ._validation import (
    _index_str,
    _scaled_from_one,
    broadcast_batch,
    check_euler_parameters,
    check_matrix,
    check_vector,
)

#: Default threshold on ``|theta0| = |cos(angle / 2)|`` below which a
#: rotation is too close to angle pi for Rodriguez parameters
#: (``|gamma| >= 1 / tol`` there).
RODRIGUEZ_SINGULARITY_TOL = 1e-6


def rodriguez_parameters_near_singularity(p, *, tol=RODRIGUEZ_SINGULARITY_TOL):
    """Whether Rodriguez parameters of ``p`` are (nearly) undefined.

    True where ``|theta0| <= tol``, i.e. the rotation angle is within about
    ``2 tol`` of pi, where ``gamma = theta / theta0`` (Eqs. 8.58-8.60) is infinite.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    tol : float

    Returns
    -------
    near : ndarray of bool, shape (...)
    """
    p = check_euler_parameters(p, "p")
    return np.abs(p[..., 0]) <= tol


def _gamma_from_unit_p(p, tol, name):
    theta0 = p[..., 0]
    bad = np.abs(theta0) <= tol
    if bad.any():
        index = np.argwhere(bad)[0] if bad.ndim else ()
        raise ValueError(
            f"Expected `{name}` to be a rotation by an angle away from pi "
            f"(|theta0| > {tol:g}), got theta0 = {float(theta0[tuple(index)]):.3g}"
            f"{_index_str(index)}; Rodriguez parameters are infinite there "
            "(use Euler parameters)"
        )
    return p[..., 1:] / theta0[..., None]


def rodriguez_parameters_from_euler_parameters(p, *, tol=RODRIGUEZ_SINGULARITY_TOL):
    """Rodriguez parameters of Euler parameters: ``gamma = theta / theta0`` (Eqs. 8.58-8.60).

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    tol : float
        Rotations with ``|theta0| <= tol`` are rejected.

    Returns
    -------
    gamma : ndarray, shape (..., 3)
        ``axis tan(angle / 2)``; the same for ``p`` and ``-p``.

    Raises
    ------
    ValueError
        Near the singularity at angle pi.
    """
    p = check_euler_parameters(p, "p")
    return _gamma_from_unit_p(p, tol, "p")


def euler_parameters_from_rodriguez_parameters(gamma):
    """Euler parameters of Rodriguez parameters (Eqs. 8.58-8.60).

    ``theta0 = 1 / sqrt(1 + gamma . gamma)``, ``theta = gamma theta0``.

    Parameters
    ----------
    gamma : array_like, shape (..., 3)
        Rodriguez parameters.

    Returns
    -------
    p : ndarray, shape (..., 4)
        Unit Euler parameters, scalar first, with ``theta0 > 0``.
    """
    g = check_vector(gamma, "gamma", 3)
    gs, inv_m = _scaled_from_one(g)
    # theta0 = 1 / sqrt(1 + g.g), written with g = m gs so that huge gamma
    # (near a half turn) tends to (0, axis) instead of overflowing.
    root = np.sqrt(inv_m * inv_m + np.einsum("...i,...i->...", gs, gs))
    out = np.empty(g.shape[:-1] + (4,))
    out[..., 0] = inv_m / root
    out[..., 1:] = gs / root[..., None]
    return out


def matrix_from_rodriguez_parameters(g):
    """Rotation matrix of Rodriguez parameters (Eqs. 8.58-8.60).

    .. math::

        A = I + \\frac{2}{1 + \\gamma^T\\gamma}(\\tilde\\gamma + \\tilde\\gamma^2)

    Parameters
    ----------
    g : array_like, shape (..., 3)
        Rodriguez (Gibbs) parameters ``gamma = axis tan(angle / 2)``.

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global.
    """
    g = check_vector(g, "g", 3)
    # With g = m gs (see _scaled_from_one): k g_i g_j = kk gs_i gs_j and
    # k g_i = kk gs_i / m, where kk = 2 / (1/m^2 + gs.gs); exact for m = 1
    # and free of overflow for huge gamma (a rotation near pi).
    gs, inv_m = _scaled_from_one(g)
    x = gs[..., 0]
    y = gs[..., 1]
    z = gs[..., 2]
    xx = x * x
    yy = y * y
    zz = z * z
    k = 2.0 / (inv_m * inv_m + xx + yy + zz)
    km = k * inv_m
    out = np.empty(g.shape[:-1] + (3, 3))
    # gamma~^2 = gamma gamma^T - (gamma . gamma) I
    out[..., 0, 0] = 1.0 - k * (yy + zz)
    out[..., 1, 1] = 1.0 - k * (xx + zz)
    out[..., 2, 2] = 1.0 - k * (xx + yy)
    out[..., 0, 1] = k * (x * y) - km * z
    out[..., 1, 0] = k * (x * y) + km * z
    out[..., 0, 2] = k * (x * z) + km * y
    out[..., 2, 0] = k * (x * z) - km * y
    out[..., 1, 2] = k * (y * z) - km * x
    out[..., 2, 1] = k * (y * z) + km * x
    return out


def rodriguez_parameters_from_matrix(A, *, tol=RODRIGUEZ_SINGULARITY_TOL):
    """Rodriguez parameters of a rotation matrix (inverse of Eqs. 8.58-8.60).

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).
    tol : float
        Rotations with ``|cos(angle / 2)| <= tol`` are rejected.

    Returns
    -------
    gamma : ndarray, shape (..., 3)
        ``axis tan(angle / 2)``.

    Raises
    ------
    ValueError
        Near the singularity at angle pi.
    """
    A = check_matrix(A, "A")
    return _gamma_from_unit_p(_p_from_matrix(A), tol, "A")


def _gamma_vec(gamma, v, name):
    g = check_vector(gamma, "gamma", 3)
    v = check_vector(v, name, 3)
    (g, v), _ = broadcast_batch(("gamma", g, 1), (name, v, 1))
    return g, v


def omega_from_rodriguez_parameter_rates(gamma, gamma_dot):
    """Global angular velocity from Rodriguez parameter rates (Eqs. 8.61-8.64).

    ``omega = 2 (gamma_dot + gamma x gamma_dot) / (1 + gamma . gamma)``.

    Parameters
    ----------
    gamma : array_like, shape (..., 3)
        Rodriguez parameters.
    gamma_dot : array_like, shape (..., 3)
        Their time derivatives, 1/s.

    Returns
    -------
    omega : ndarray, shape (..., 3)
        Angular velocity in the global frame.
    """
    g, gd = _gamma_vec(gamma, gamma_dot, "gamma_dot")
    k = 2.0 / (1.0 + np.einsum("...i,...i->...", g, g))
    return k[..., None] * (gd + np.cross(g, gd))


def omega_body_from_rodriguez_parameter_rates(gamma, gamma_dot):
    """Body angular velocity from Rodriguez parameter rates (Eqs. 8.61-8.64).

    ``omega_body = 2 (gamma_dot - gamma x gamma_dot) / (1 + gamma . gamma)``.

    Parameters
    ----------
    gamma : array_like, shape (..., 3)
        Rodriguez parameters.
    gamma_dot : array_like, shape (..., 3)
        Their time derivatives, 1/s.

    Returns
    -------
    omega_body : ndarray, shape (..., 3)
        Angular velocity in the body frame (omega-bar).
    """
    g, gd = _gamma_vec(gamma, gamma_dot, "gamma_dot")
    k = 2.0 / (1.0 + np.einsum("...i,...i->...", g, g))
    return k[..., None] * (gd - np.cross(g, gd))


def rodriguez_parameter_rates_from_omega(gamma, omega):
    """Rodriguez parameter rates from the global angular velocity (Eqs. 8.61-8.64).

    ``gamma_dot = (omega - gamma x omega + gamma (gamma . omega)) / 2``.

    Parameters
    ----------
    gamma : array_like, shape (..., 3)
        Rodriguez parameters.
    omega : array_like, shape (..., 3)
        Angular velocity in the global frame, rad/s.

    Returns
    -------
    gamma_dot : ndarray, shape (..., 3)
    """
    g, w = _gamma_vec(gamma, omega, "omega")
    with np.errstate(over="ignore", invalid="ignore"):
        gw = np.einsum("...i,...i->...", g, w)
        rates = 0.5 * (w - np.cross(g, w) + g * gw[..., None])
    return _finite_rates(rates, g)


def rodriguez_parameter_rates(gamma, omega_body):
    """Rodriguez parameter rates from the body angular velocity (Eqs. 8.61-8.64).

    ``gamma_dot = (omega_body + gamma x omega_body + gamma (gamma . omega_body)) / 2``.

    Parameters
    ----------
    gamma : array_like, shape (..., 3)
        Rodriguez parameters.
    omega_body : array_like, shape (..., 3)
        Angular velocity in the body frame (omega-bar), rad/s.

    Returns
    -------
    gamma_dot : ndarray, shape (..., 3)
    """
    g, w = _gamma_vec(gamma, omega_body, "omega_body")
    with np.errstate(over="ignore", invalid="ignore"):
        gw = np.einsum("...i,...i->...", g, w)
        rates = 0.5 * (w + np.cross(g, w) + g * gw[..., None])
    return _finite_rates(rates, g)


def _finite_rates(rates, g):
    """Return ``rates``, or raise when they overflow float64.

    The rates grow like |gamma|^2 |omega| near a half turn, where the
    Rodriguez parameters themselves go to infinity (Eqs. 8.61-8.64).
    """
    bad = ~np.isfinite(rates).all(axis=-1)
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            "Expected `gamma` small enough for finite Rodriguez parameter rates "
            f"(they grow like |gamma|^2 |omega| near a half turn), got |gamma| = "
            f"{float(np.max(np.abs(g[index]))):.3g} (max entry) at index {index}"
        )
    return rates
