"""Jacobi's elliptic functions with the complementary parameter given exactly.

The closed forms of the heavy top (Eq. 8.21) need ``sn``, ``cn`` and ``dn``
at a parameter ``m`` that can lie within ``1e-28`` of 1 (a top started
within ``1e-14`` rad of the vertical below its critical spin). ``m`` itself
cannot be stored that close to 1, so the functions here take the
complementary parameter ``mc = 1 - m``, formed by the caller without
cancellation, and never rebuild it from ``m``.

Relative accuracy of ``cn`` (the one that matters near a turning point),
from the error terms of each regime at the fold ``|u| = K/2`` (worst case):

- ``mc >= 1e-3``: scipy's ``ellipj`` at ``m = 1 - mc`` on the whole of
  [-K, K] (no reflection: there ``dn >= 0.03`` and ``cn`` is good to
  ``1e-16`` absolute, which is all the top's ``1 - u = (1 - u1) cn^2 + ...``
  needs); the rounding of ``m`` changes ``cn`` by ``~1e-16 / sqrt(mc)``
  relative at most (``3e-15``).
- ``1e-11 <= mc < 1e-3``: the arithmetic-geometric mean (Abramowitz &
  Stegun 16.4) started from ``b0 = sqrt(mc)``; ``cn = cos(phi)`` is good to
  ``1e-16 / cn`` with ``cn >= mc^(1/4)`` (``3e-13``).
- ``mc < 1e-11``: the first-order expansion in ``mc`` (A&S 16.15.1-3), whose
  neglected term is ``(mc sinh(2u) / 8)^2 <= mc / 16`` relative.

For ``mc < 1e-3``, beyond ``|u| = K/2`` the quarter-period reflection (A&S 16.8)
``sn(K - x) = cn(x)/dn(x)``, ``cn(K - x) = sqrt(mc) sn(x)/dn(x)``,
``dn(K - x) = sqrt(mc)/dn(x)`` keeps ``cn`` and ``dn`` accurate to their last
digits where they are as small as ``sqrt(mc)``.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.special import ellipj, elliprf

__all__ = ["complete_k", "jacobi"]

SCIPY_MC = 1e-3  # at and above: scipy's ellipj at m = 1 - mc
EXPANSION_MC = 1e-11  # below: first-order expansion in mc


def complete_k(mc: float | np.ndarray) -> float | np.ndarray:
    """``K(m) = R_F(0, mc, 1)`` from the complementary parameter ``mc = 1 - m``."""
    return elliprf(0.0, mc, 1.0)


@functools.lru_cache(maxsize=64)
def _agm(mc: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The c_i and a_i of the arithmetic-geometric mean from a0 = 1, b0 = sqrt(mc) (A&S 16.4)."""
    a, b = 1.0, math.sqrt(mc)
    cs, as_ = [], []
    for _ in range(60):
        c = 0.5 * (a - b)
        a, b = 0.5 * (a + b), math.sqrt(a * b)
        cs.append(c)
        as_.append(a)
        if abs(c) <= 2.2e-16 * a:
            break
    return tuple(cs), tuple(as_)


def agm_sn_cn(u: np.ndarray, mc: float) -> tuple[np.ndarray, np.ndarray]:
    """sn and cn as the sine and cosine of the amplitude, from the arithmetic-geometric mean started at
    ``b0 = sqrt(mc)`` (A&S 16.4): no rounding of ``m = 1 - mc``, but cn only to ``1e-16`` absolute."""
    cs, as_ = _agm(mc)
    phi = (2.0 ** len(cs)) * as_[-1] * u
    for c, a in zip(reversed(cs), reversed(as_), strict=True):
        phi = 0.5 * (phi + np.arcsin(np.clip(c / a * np.sin(phi), -1.0, 1.0)))
    return np.sin(phi), np.cos(phi)


def _direct(u: np.ndarray, mc: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sn, cn, dn for ``0 <= u <= K/2`` and ``mc < SCIPY_MC`` (see the module's error budget)."""
    if mc >= EXPANSION_MC:
        sn, cn = agm_sn_cn(u, mc)
    else:
        # A&S 16.15: sn = tanh u + mc/4 (sinh u cosh u - u) sech^2 u, ...
        ch = np.cosh(u)
        th = np.tanh(u)
        sech = 1.0 / ch
        w = 0.25 * mc * (np.sinh(u) * ch - u)
        sn = th + w * sech * sech
        cn = sech - w * th * sech
    # dn^2 = 1 - m sn^2 = cn^2 + mc sn^2, without cancellation
    return sn, cn, np.sqrt(cn * cn + mc * sn * sn)


def jacobi(u: np.ndarray, mc: float, K: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``sn(u|m)``, ``cn(u|m)``, ``dn(u|m)`` for ``-K <= u <= K``, ``m = 1 - mc``.

    Parameters
    ----------
    u : array of arguments in [-K, K] (the caller reduces by the period).
    mc : complementary parameter ``1 - m`` in (0, 1].
    K : ``complete_k(mc)``.

    Returns
    -------
    (sn, cn, dn), each shaped like ``u``; ``cn >= 0`` and ``dn > 0`` on [-K, K].
    """
    u = np.asarray(u, dtype=float)
    if mc >= SCIPY_MC:
        sn, cn, dn, _ = ellipj(u, 1.0 - mc)
        return sn, cn, dn
    x = np.abs(u)
    far = x > 0.5 * K
    s, c, d = _direct(np.where(far, np.maximum(K - x, 0.0), x), mc)
    kc = math.sqrt(mc)
    sn = np.where(far, c / d, s)
    sn = np.where(u < 0.0, -sn, sn)
    cn = np.where(far, kc * s / d, c)
    dn = np.where(far, kc / d, d)
    return sn, cn, dn
