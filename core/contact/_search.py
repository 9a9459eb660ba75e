"""Initial contact: surface parameters from a configuration (sampling guess, then Newton).

The parameters that satisfy the extremal conditions (see ``_kernel``) are
searched from the best of a set of sampled pairs of points: for a plane
(or a line), the samples of the other surface with the lowest signed height
above it; otherwise the pairs of samples that are nearest with opposed
normals. Newton's method (steps limited to a quarter of the length scale)
refines the best candidates; a solution must have opposed normals, and of
several the one with the largest gap (the nearest points, not the far
sides) is taken.
"""

from __future__ import annotations

import functools
from types import SimpleNamespace
from typing import Any

import numpy as np

from ._curves import PlanarCurve
from ._errors import CONTACT_RANK_TOL, ContactError
from ._geometry import (
    _extremal,
    _globalize,
    _Group,
    _stack_geometry,
    contact_rows,
    frames_of,
    solve_parameters,
)
from ._surfaces import ParametricSurface

__all__ = ["find_contact"]

_CANDIDATES = 8


def _frames(R_i, A_i, R_j, A_j):
    A_ext = np.stack([A_i, A_j, np.eye(3)])
    R_ext = np.stack([R_i, R_j, np.zeros(3)])
    return A_ext, R_ext


def _global(surface, s, R, A):
    g = surface._geometry(s, 1, None)
    x = R + g[0] @ A.T
    nu = g[4] @ A.T
    nn = np.linalg.norm(nu, axis=-1, keepdims=True)
    return x, nu / np.where(nn > 0, nn, 1.0)


def find_contact(name: str, surface_i: Any, R_i: np.ndarray, A_i: np.ndarray, surface_j: Any, R_j: np.ndarray,
                 A_j: np.ndarray) -> dict:
    """Surface parameters of the contact of two surfaces in the given configuration.

    Returns a dict: ``s`` (2p,) chart parameters, ``charts`` [chart_i,
    chart_j], ``gap`` (m), ``normal`` (3,) global, ``point_i``, ``point_j``,
    ``rank`` (the scaled volume of C_s, Eq. 8.109).

    Raises
    ------
    ContactError
        When no pair of points with opposed normals is found.
    """
    p = surface_i.n_parameters
    stand_in = SimpleNamespace(
        name=name, index=0, surface_i=surface_i, surface_j=surface_j,
        body_i=SimpleNamespace(index=0), body_j=SimpleNamespace(index=1), n_parameters=p,
    )
    group = _Group([stand_in], p, 2)
    A_ext, R_ext = _frames(R_i, A_i, R_j, A_j)
    fr = frames_of(group, A_ext, R_ext, None, None)
    candidates = _candidates(surface_i, R_i, A_i, surface_j, R_j, A_j)

    @functools.cache
    def inward() -> list[str]:  # (asked only on a failure path)
        return [label for label, surf in (("surface_i", surface_i), ("surface_j", surface_j)) if _looks_inward(surf)]

    best = None
    errors = []
    singular = None  # a failed start's Newton stuck at a singular point of a parametrization
    for s_i, s_j in candidates:
        ch_i, l_i = surface_i._default_chart(s_i)
        ch_j, l_j = surface_j._default_chart(s_j)
        charts = [[ch_i, ch_j]]
        s0 = np.concatenate([l_i, l_j])[None]
        try:
            s, gi, gj, _, _, _, Es = solve_parameters(group, fr, s0, charts, 2, max_iter=60, damped=True,
                                                      outward=True)
        except ContactError as exc:  # no convergence, or points that do not face each other
            errors.append(str(exc))
            if singular is None and getattr(exc, "iterate", None) is not None and not inward():
                # Newton stuck at a singular point of a parametrization? (not asked of a surface whose normal
                # points into its body: Newton then wanders anywhere, a pole included)
                s_last, ch_last = exc.iterate
                for surf, label, sv, chart in ((surface_i, "surface_i", s_last[0, :p], ch_last[0][0]),
                                               (surface_j, "surface_j", s_last[0, p:], ch_last[0][1])):
                    if np.all(np.isfinite(sv)) and singular is None:
                        raw = _stack_geometry([surf], sv[None], [chart], 2)
                        try:
                            _check_regular_local(_globalize(raw, np.eye(3)[None]), surf, label, sv, chart)
                        except ContactError as found:  # (reported if no other start finds the contact)
                            singular = found
            continue
        kin = contact_rows(group, fr, gi, gj, 0, np.zeros(1, dtype=bool), Es)
        cand = {"s": s[0], "charts": charts[0], "gap": float(kin.gap[0]), "normal": kin.normal[0],
                "point_i": kin.point_i[0], "point_j": kin.point_j[0], "rank": float(kin.rank[0]),
                "geometry": (gi, gj)}
        if best is None or cand["gap"] > best["gap"] + 1e-9 * group.L[0]:
            best = cand
    if best is not None:
        # Newton may converge onto a point where a parametrization is singular (a pole of a hand-made sphere):
        # C_s then loses rank there because of the parametrization, not because the surfaces conform
        gi, gj = best.pop("geometry")
        s_best = best["s"]
        for g, surf, label, sv, chart in ((gi, surface_i, "surface_i", s_best[:p], best["charts"][0]),
                                          (gj, surface_j, "surface_j", s_best[p:], best["charts"][1])):
            try:
                _check_regular_local(g, surf, label, sv, chart)
            except ContactError:
                if inward():  # (a surface turned inside out meets the other one at a pole, if anywhere)
                    raise ContactError(f"contact {name!r}: no regular pair of points with opposed normals found "
                                       f"between {surface_i!r} and {surface_j!r}{_inward_hint(inward())}") from None
                raise
        return best
    if singular is not None:
        raise singular
    if candidates:  # no convergence: a line contact, or surfaces that conform (a ball in a socket of its own
        # radius, where the socket's normal rightly points inward), has a rank-deficient C_s at the sampled guess
        s_i, s_j = candidates[0]
        ch_i, l_i = surface_i._default_chart(s_i)
        ch_j, l_j = surface_j._default_chart(s_j)
        raw_i = _stack_geometry([surface_i], l_i[None], [ch_i], 2)
        raw_j = _stack_geometry([surface_j], l_j[None], [ch_j], 2)
        gi, gj = _globalize(raw_i, fr.A_i), _globalize(raw_j, fr.A_j)
        if not inward():  # (a surface turned inside out gets the orientation hint below instead)
            for g, surf, label, sv in ((gi, surface_i, "surface_i", s_i), (gj, surface_j, "surface_j", s_j)):
                _check_regular(g, surf, label, sv)
        _, Es, _, _, _ = _extremal(group, fr, gi, gj)
        kin = contact_rows(group, fr, gi, gj, 0, np.zeros(1, dtype=bool), Es)
        check_rank(name, {"rank": float(kin.rank[0])})
    why = f" ({errors[0]})" if errors else ""
    raise ContactError(
        f"contact {name!r}: no pair of points with opposed normals found between {surface_i!r} and "
        f"{surface_j!r}{why}{_inward_hint(inward())}"
    )


#: A surface's parametrization is singular at a point where ``|du/ds1 x du/ds2|`` is below this fraction of the
#: square of its longest tangent: the sine of the angle between the tangents, times their ratio (a pole of a
#: longitude-latitude sphere: 0; a regular point of an isotropic parametrization: 1).
REGULAR_TOL = 1e-6


def _check_regular(g, surf, label: str, s) -> None:
    """Refuse a point of ``surf`` where its parametrization is singular (global geometry ``g`` of one
    point; ``s`` the canonical parameters, for the message). Scale-free; not asked of curves, nor of a
    surface whose normal is not ``du/ds1 x du/ds2`` (a rim's normal field, ``degenerate_tangents``)."""
    if surf.n_parameters < 2 or getattr(surf, "degenerate_tangents", False):
        return
    t1, t2 = g.T[0][:, 0], g.T[0][:, 1]
    longest = max(float(np.linalg.norm(t1)), float(np.linalg.norm(t2)))
    if not float(np.linalg.norm(np.cross(t1, t2))) > REGULAR_TOL * max(longest * longest, 1e-300):
        raise ContactError(
            f"{label}: {surf!r} is degenerate near s={np.round(np.asarray(s, dtype=float), 6).tolist()}: its "
            "normal du/ds1 x du/ds2 vanishes (parallel or zero tangents; a pole of a longitude-latitude "
            "parametrization) at the contact point; choose a parametrization that is regular there, or "
            "rotate the surface in its body so that its pole is away from the contact")


def _check_regular_local(g, surf, label: str, s_local, chart) -> None:
    """:func:`_check_regular` at the chart parameters ``s_local`` of ``chart`` (named by their canonical ones)."""
    _check_regular(g, surf, label, surf._chart_parameters(np.asarray(s_local, dtype=float), chart))


def _inward_hint(inward: list[str]) -> str:
    if not inward:
        return ""
    return (f"; the normal of {' and '.join(inward)} (du/ds1 x du/ds2, for a curve c' x e_z) points back towards "
            "its body's origin at its points farthest from it: if that is into the body (not a bowl's inside), "
            "orient the parametrization outward (swap s1 and s2, or reverse a curve)")


def _looks_inward(surf) -> bool:
    """Whether a user surface or curve seems oriented into its body: at most of its sampled points farthest
    from the body's origin (within 90 % of the largest distance, where its normal is defined), the normal
    points back towards the origin (an outward one of a closed or a bowl-like surface points away)."""
    if not isinstance(surf, (ParametricSurface, PlanarCurve)):
        return False
    S = surf._samples()
    x, nu = _global(surf, S, np.zeros(3), np.eye(3))
    r = np.linalg.norm(x, axis=1)
    far = (r >= 0.9 * r.max()) & (np.linalg.norm(nu, axis=1) > 0.5) & (r > 0)
    if not far.any():
        return False
    return bool(np.mean(np.einsum("ki,ki->k", nu[far], x[far]) < 0.0) > 0.5)


def _candidates(surface_i, R_i, A_i, surface_j, R_j, A_j) -> list[tuple[np.ndarray, np.ndarray]]:
    """Start parameters (canonical) for Newton, best first."""
    if surface_i.unbounded or surface_j.unbounded:
        flat_i = surface_i.unbounded
        flat, Rf, Af = (surface_i, R_i, A_i) if flat_i else (surface_j, R_j, A_j)
        other, Ro, Ao = (surface_j, R_j, A_j) if flat_i else (surface_i, R_i, A_i)
        S = other._samples()
        x, nrm = _global(other, S, Ro, Ao)
        foot = flat.parameters((x - Rf) @ Af)
        xf, nf = _global(flat, foot, Rf, Af)
        h = np.einsum("ki,ki->k", nf, x - xf)
        merit = h + other.length_scale * (1.0 + np.einsum("ki,ki->k", nrm, nf))
        order = np.argsort(merit)[:_CANDIDATES]
        if flat_i:
            return [(foot[q], S[q]) for q in order]
        return [(S[q], foot[q]) for q in order]
    Si, Sj = surface_i._samples(), surface_j._samples()
    xi, ni = _global(surface_i, Si, R_i, A_i)
    xj, nj = _global(surface_j, Sj, R_j, A_j)
    L = min(surface_i.length_scale, surface_j.length_scale)
    dist = np.linalg.norm(xi[:, None, :] - xj[None, :, :], axis=-1)
    merit = dist / L + (1.0 + ni @ nj.T)
    flat_order = np.argsort(merit, axis=None)[: 4 * _CANDIDATES]
    out = []
    seen = set()
    for f in flat_order:
        a, b = divmod(int(f), Sj.shape[0])
        key = (a, b)
        if key in seen:
            continue
        seen.add(key)
        out.append((Si[a], Sj[b]))
        if len(out) >= _CANDIDATES:
            break
    return out


def check_rank(name: str, info: dict) -> None:
    """Refuse a contact whose C_s lacks full column rank (Eq. 8.109): a line or surface contact."""
    if not info["rank"] > CONTACT_RANK_TOL:
        raise ContactError(
            f"contact {name!r}: C_s has lost rank at the contact point (Eq. 8.109; scaled volume "
            f"{info['rank']:.1e} <= {CONTACT_RANK_TOL:g}): the surfaces touch along a line or over an area "
            "(a cylinder or a torus lying on a plane, parallel flat faces, conforming surfaces), where the "
            "contact point is not unique. For a planar mechanism (a cam and its follower, rollers) describe "
            "both profiles as PlanarCurve in their bodies' x-y planes (curve-on-curve contact, one parameter "
            "per body). A torus whose axis is along the other surface's normal (a wheel lying on its side) "
            "touches along a circle: stand it up. A ball in a socket of its own radius conforms to it: give "
            "the socket a larger radius. Otherwise use surfaces that curve in both directions and differently "
            "at the contact (a sphere, a torus on its tread, an ellipsoid)"
        )
