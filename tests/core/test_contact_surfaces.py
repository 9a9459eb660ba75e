"""Contact surfaces and planar curves: derivatives against central differences, normals, inverse maps, errors.

Every surface's closed-form derivatives ``u_s``, ``u_ss``, ``u_sss`` (Eqs.
8.85-8.89) and the derivatives of its normal field are compared with
central differences of the next lower derivative (step 1e-5: truncation
~1e-10 |u'''|, round-off ~1e-11 |u| / 1e-5; tolerance 1e-8 relative to the
surface's size). The complex-step derivatives of user surfaces are
compared with the analytic ones (1e-9). The float path used by the
contact kernel (``_derivs_float``) must equal the array path exactly (to
round-off).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.contact import Ellipsoid, ParametricSurface, PlanarCurve, Plane, Sphere, Torus
from rigidlab.core.contact._surfaces import _dicts_from_arrays

SEED = 20251123
H = 1e-5


def _saddle(s):
    x, y = s[..., 0], s[..., 1]
    return np.stack([x, y, 0.1 * np.sin(2.0 * x) * np.cos(y) + 0.05 * x * y], axis=-1)


def _saddle_first(s):
    x, y = s[..., 0], s[..., 1]
    out = np.zeros(s.shape[:-1] + (3, 2))
    out[..., 0, 0] = 1.0
    out[..., 1, 1] = 1.0
    out[..., 2, 0] = 0.2 * np.cos(2 * x) * np.cos(y) + 0.05 * y
    out[..., 2, 1] = -0.1 * np.sin(2 * x) * np.sin(y) + 0.05 * x
    return out


def _saddle_second(s):
    x, y = s[..., 0], s[..., 1]
    out = np.zeros(s.shape[:-1] + (3, 2, 2))
    out[..., 2, 0, 0] = -0.4 * np.sin(2 * x) * np.cos(y)
    out[..., 2, 0, 1] = out[..., 2, 1, 0] = -0.2 * np.cos(2 * x) * np.sin(y) + 0.05
    out[..., 2, 1, 1] = -0.1 * np.sin(2 * x) * np.cos(y)
    return out


def _saddle_third(s):
    x, y = s[..., 0], s[..., 1]
    out = np.zeros(s.shape[:-1] + (3, 2, 2, 2))
    out[..., 2, 0, 0, 0] = -0.8 * np.cos(2 * x) * np.cos(y)
    v = 0.4 * np.sin(2 * x) * np.sin(y)
    for idx in ((0, 0, 1), (0, 1, 0), (1, 0, 0)):
        out[(..., 2) + idx] = v
    w = -0.2 * np.cos(2 * x) * np.cos(y)
    for idx in ((0, 1, 1), (1, 0, 1), (1, 1, 0)):
        out[(..., 2) + idx] = w
    out[..., 2, 1, 1, 1] = 0.1 * np.sin(2 * x) * np.sin(y)
    return out


def _ellipse(s):
    return np.stack([0.03 * np.cos(s) + 0.005, 0.02 * np.sin(s)], axis=-1)


SURFACES = {
    "plane": Plane(),
    "tilted plane": Plane(point=(0.1, -0.2, 0.3), normal=(1.0, 2.0, -0.5)),
    "sphere": Sphere(0.3, centre=(0.1, 0.0, -0.2)),
    "ellipsoid": Ellipsoid(0.3, 0.2, 0.1),
    "torus": Torus(0.5, 0.1, centre=(0.0, 0.1, 0.0)),
    "rim": Torus(0.5, 0.0),
    "parametric (complex step)": ParametricSurface(_saddle, bounds=((-1, 1), (-1, 1))),
    "parametric (given)": ParametricSurface(_saddle, first=_saddle_first, second=_saddle_second,
                                            third=_saddle_third, bounds=((-1, 1), (-1, 1))),
    "polar curve": PlanarCurve.polar(lambda p: 0.04 + 0.01 * np.cos(p) + 0.003 * np.sin(3 * p)),
    "polar curve (given)": PlanarCurve.polar(
        lambda p: 0.04 + 0.01 * np.cos(p), first=lambda p: -0.01 * np.sin(p), second=lambda p: -0.01 * np.cos(p),
        third=lambda p: 0.01 * np.sin(p)),
    "circle": PlanarCurve.circle(0.02, center=(0.1, -0.05)),
    "line": PlanarCurve.line(point=(0.01, 0.02), normal=(1.0, -1.0)),
    "parametric curve": PlanarCurve(_ellipse, bounds=(0.0, 2 * math.pi)),
}


def _points(surface, rng, k=5):
    if surface.n_parameters == 1:
        return rng.uniform(-3.0, 3.0, size=(k, 1))
    return rng.uniform(-1.2, 1.2, size=(k, 2))


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_derivatives_match_central_differences(name):
    surface = SURFACES[name]
    rng = np.random.default_rng(SEED)
    s = _points(surface, rng)
    p = surface.n_parameters
    u, U1, U2, U3 = surface.derivatives(s, order=3)
    nu, N1, N2 = surface.normal_field(s)
    size = surface.length_scale if math.isfinite(surface.length_scale) else 1.0
    for l in range(p):
        e = np.zeros(p)
        e[l] = H
        up, um = surface.derivatives(s + e), surface.derivatives(s - e)
        np.testing.assert_allclose(U1[..., l], (up[0] - um[0]) / (2 * H), atol=1e-8 * size)
        np.testing.assert_allclose(U2[..., l], (up[1] - um[1]) / (2 * H), atol=1e-8 * size)
        np.testing.assert_allclose(U3[..., l], (up[2] - um[2]) / (2 * H), atol=1e-7 * size)
        npl, nml = surface.normal_field(s + e), surface.normal_field(s - e)
        scale = max(1.0, float(np.max(np.abs(nu))))
        np.testing.assert_allclose(N1[..., l], (npl[0] - nml[0]) / (2 * H), atol=1e-8 * scale)
        np.testing.assert_allclose(N2[..., l], (npl[1] - nml[1]) / (2 * H), atol=1e-7 * scale)
    # derivatives are symmetric in their parameter indices
    np.testing.assert_allclose(U2, np.swapaxes(U2, -1, -2), atol=1e-12 * size)
    np.testing.assert_allclose(U3, np.swapaxes(U3, -1, -3), atol=1e-11 * size)


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_float_path_equals_array_path(name):
    surface = SURFACES[name]
    rng = np.random.default_rng(SEED + 1)
    for s in _points(surface, rng, 3):
        for order in (0, 1, 2, 3):
            D, Dn = surface._derivs_float(tuple(s.tolist()), order, None)
            D2, Dn2 = _dicts_from_arrays(surface._geometry(s, order, None), surface.n_parameters, order)
            assert set(D) == set(D2)
            for key in D2:
                np.testing.assert_allclose(D[key], D2[key], atol=1e-14)
            if Dn is not None:
                for key in Dn2:
                    np.testing.assert_allclose(Dn[key], Dn2[key], atol=1e-14)


def test_complex_step_derivatives_agree_with_given_ones():
    rng = np.random.default_rng(SEED + 2)
    s = rng.uniform(-1.0, 1.0, size=(7, 2))
    a = SURFACES["parametric (complex step)"].derivatives(s)
    b = SURFACES["parametric (given)"].derivatives(s)
    for x, y, tol in zip(a, b, (0.0, 1e-13, 1e-12, 1e-10)):
        np.testing.assert_allclose(x, y, atol=tol)
    phi = rng.uniform(-3.0, 3.0, size=9)
    a = SURFACES["polar curve (given)"].derivatives(phi)
    curve = PlanarCurve.polar(lambda p: 0.04 + 0.01 * np.cos(p))
    b = curve.derivatives(phi)
    for x, y, tol in zip(a, b, (0.0, 1e-15, 1e-14, 1e-12)):
        np.testing.assert_allclose(x, y, atol=tol)


def test_closed_forms_of_normals_and_points():
    rng = np.random.default_rng(SEED + 3)
    s = rng.uniform(-1.2, 1.2, size=(6, 2))
    sph = SURFACES["sphere"]
    u = sph.point(s)
    np.testing.assert_allclose(np.linalg.norm(u - sph.centre, axis=-1), 0.3, rtol=1e-15)
    np.testing.assert_allclose(sph.normal(s), (u - sph.centre) / 0.3, atol=1e-15)
    ell = SURFACES["ellipsoid"]
    u = ell.point(s)
    np.testing.assert_allclose(np.sum((u / [0.3, 0.2, 0.1]) ** 2, axis=-1), 1.0, rtol=1e-14)
    grad = u / np.array([0.3, 0.2, 0.1]) ** 2  # outward normal of the level set
    np.testing.assert_allclose(ell.normal(s), grad / np.linalg.norm(grad, axis=-1, keepdims=True), atol=1e-14)
    tor = SURFACES["torus"]
    u = tor.point(s) - tor.centre
    ring = np.stack([u[:, 0], np.zeros(6), u[:, 2]], axis=-1)
    ring = 0.5 * ring / np.linalg.norm(ring, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.linalg.norm(u - ring, axis=-1), 0.1, rtol=1e-14)
    np.testing.assert_allclose(tor.normal(s), (u - ring) / 0.1, atol=1e-14)
    # the rim: the point does not depend on psi, the normal turns about the rim's tangent
    rim = SURFACES["rim"]
    u, U1 = rim.derivatives(s, order=1)
    np.testing.assert_allclose(U1[..., 1], 0.0, atol=1e-16)
    n = rim.normal(s)
    np.testing.assert_allclose(np.einsum("ki,ki->k", n, U1[..., 0]), 0.0, atol=1e-15)
    np.testing.assert_allclose(n[:, 1], np.sin(s[:, 1]), atol=1e-15)
    pl = SURFACES["tilted plane"]
    np.testing.assert_allclose(pl.normal(s), np.tile([1.0, 2.0, -0.5] / np.linalg.norm([1.0, 2.0, -0.5]), (6, 1)),
                               atol=1e-15)
    # a curve's normal points outward (counter-clockwise closed curves) and is in its plane
    circle = SURFACES["circle"]
    phi = rng.uniform(-3, 3, size=5)
    np.testing.assert_allclose(circle.normal(phi), np.stack([np.cos(phi), np.sin(phi), 0 * phi], -1), atol=1e-15)
    line = SURFACES["line"]
    np.testing.assert_allclose(line.normal(phi), np.tile(np.array([1.0, -1.0, 0.0]) / math.sqrt(2), (5, 1)),
                               atol=1e-15)


@pytest.mark.parametrize("name", ["plane", "tilted plane", "sphere", "ellipsoid", "torus", "circle", "line"])
def test_inverse_maps_round_trip(name):
    surface = SURFACES[name]
    rng = np.random.default_rng(SEED + 4)
    if surface.n_parameters == 1:
        s = rng.uniform(-3.0, 3.0, size=(8, 1))
    else:
        s = rng.uniform(-1.4, 1.4, size=(8, 2))
        if name == "torus":
            s = rng.uniform(-3.0, 3.0, size=(8, 2))
    back = surface.parameters(surface.point(s))
    np.testing.assert_allclose(surface.point(back), surface.point(s), atol=1e-14)


@pytest.mark.parametrize("shape", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes(shape):
    rng = np.random.default_rng(SEED + 5)
    s = rng.uniform(-1, 1, size=shape + (2,))
    u, U1, U2, U3 = SURFACES["torus"].derivatives(s)
    assert u.shape == shape + (3,) and U3.shape == shape + (3, 2, 2, 2)
    assert SURFACES["torus"].normal(s).shape == shape + (3,)
    phi = rng.uniform(-1, 1, size=shape + (1,))  # a trailing axis of length 1 is the curve's parameter
    c = SURFACES["circle"].derivatives(phi)
    assert c[0].shape == shape + (3,) and c[3].shape == shape + (3, 1, 1, 1)
    if shape[-1:] != (1,):
        assert SURFACES["circle"].point(phi[..., 0]).shape == shape + (3,)


def test_charts_describe_the_same_surface():
    rng = np.random.default_rng(SEED + 6)
    for surface in (SURFACES["sphere"], SURFACES["ellipsoid"]):
        s0 = rng.uniform(-1.0, 1.0, size=2)
        chart, local = surface._new_chart(s0, None)
        np.testing.assert_allclose(local, 0.0)
        g = surface._geometry(local, 3, chart)
        np.testing.assert_allclose(g[0], surface.point(s0), atol=1e-15)
        np.testing.assert_allclose(surface._chart_parameters(local, chart), s0, atol=1e-14)
        # same tangent plane and outward normal direction
        n = g[4] / np.linalg.norm(g[4])
        np.testing.assert_allclose(n, surface.normal(s0), atol=1e-14)


@pytest.mark.parametrize("make, message", [
    (lambda: Sphere(0.0), r"radius: expected a finite length > 0 \(m\), got 0.0"),
    (lambda: Sphere(-1.0), r"radius: expected a finite length > 0 \(m\), got -1.0"),
    (lambda: Sphere(float("nan")), r"radius: expected a finite length > 0"),
    (lambda: Sphere(1j), r"radius: expected real numbers, got complex"),
    (lambda: Sphere(0.1, centre=(0, 0)), r"centre: expected shape \(3,\)"),
    (lambda: Ellipsoid(0.1, 0.0, 0.1), r"b: expected a finite length > 0 \(m\), got 0.0"),
    (lambda: Torus(0.0, 0.0), r"major_radius: expected a finite length > 0"),
    (lambda: Torus(0.1, -0.01), r"minor_radius: expected a finite length >= 0"),
    (lambda: Torus(0.1, 0.1), r"minor_radius: expected 0 <= minor_radius < major_radius"),
    (lambda: Plane(normal=(0, 0, 0)), r"normal: expected a nonzero vector"),
    (lambda: PlanarCurve.circle(0.0), r"radius: expected a finite length > 0"),
    (lambda: PlanarCurve.line(normal=(0, 0)), r"normal: expected a nonzero vector"),
    (lambda: PlanarCurve.polar(lambda p: 0.01 * np.cos(p)), r"radius: expected r\(phi\) > 0"),
    (lambda: PlanarCurve.polar(0.04), r"radius: expected a callable"),
    (lambda: PlanarCurve(_ellipse, bounds=(1.0, 0.0)), r"bounds: expected \(s_min, s_max\)"),
    (lambda: ParametricSurface(_saddle, bounds=((0, 1),)), r"bounds: expected"),
    (lambda: ParametricSurface(lambda s: s, bounds=((0, 1), (0, 1))), r"point: expected values of shape"),
    (lambda: ParametricSurface(lambda s: np.real(_saddle(s)), bounds=((0, 1), (0, 1))),
     r"point: the function dropped the imaginary part"),
    # one component only: its derivatives would be half the true ones (the mean round the circle's real part)
    (lambda: ParametricSurface(lambda s: np.stack([s[..., 0], s[..., 1], np.real(s[..., 0]) ** 2], -1),
                               bounds=((-1, 1), (-1, 1))),
     r"point: the function dropped the imaginary part of complex parameters \(component 2 of its value\)"),
    (lambda: ParametricSurface(lambda s: np.stack([s[..., 0], s[..., 1], np.abs(s[..., 0])], -1),
                               bounds=((-1, 1), (-1, 1))),
     r"point: the function dropped the imaginary part of complex parameters \(component 2 of its value\)"),
    # part of a component real (the rest analytic): wrong derivatives (half the curvature of Re(z^2) + z^2)
    (lambda: ParametricSurface(lambda s: np.stack([s[..., 0], -s[..., 1], np.real(s[..., 0] ** 2) + s[..., 1] ** 2],
                                                  -1), bounds=((-0.1, 0.1), (-0.1, 0.1))),
     r"point: the function is not analytic in its complex parameters \(component 2 of its value near s=\["),
    (lambda: ParametricSurface(lambda s: np.stack([s[..., 0], -s[..., 1], np.abs(s[..., 0]) ** 2
                                                   + 0.5 * s[..., 1] ** 2], -1), bounds=((-0.1, 0.1), (-0.1, 0.1))),
     r"point: the function is not analytic .* z \* z, not abs\(z\) \*\* 2 or np.real\(z \*\* 2\)\)"),
    (lambda: PlanarCurve.polar(lambda p: 0.04 + 0.01 * np.real(np.cos(p)) * np.cos(p)),
     r"radius: the function is not analytic in its complex parameters \(component 0 of its value near s="),
    (lambda: PlanarCurve(lambda s: np.stack([s, np.abs(s) ** 2], -1), bounds=(-1.0, 1.0)),
     r"point: the function is not analytic in its complex parameters \(component 1"),
    (lambda: ParametricSurface(lambda s: [math.sin(x) for x in s], bounds=((0, 1), (0, 1))),
     r"point: the function raised"),
    (lambda: ParametricSurface(_saddle, first=lambda s: np.zeros((3, 2)), bounds=((0, 1), (0, 1))),
     r"first: expected shape"),
    (lambda: ParametricSurface(lambda s: np.full(s.shape[:-1] + (3,), np.nan), bounds=((0, 1), (0, 1))),
     r"point: expected finite values"),
])
def test_bad_surfaces_are_refused(make, message):
    with pytest.raises(ValueError, match=message):
        make()


@pytest.mark.parametrize("make", [
    # analytic functions that vary quickly on the complex steps' circle (k h up to 1.6): accepted
    lambda: ParametricSurface(lambda s: np.stack([s[..., 0], s[..., 1], 0.01 * np.cos(40.0 * s[..., 0])], -1),
                              bounds=((0.0, 1.0), (0.0, 1.0))),
    lambda: PlanarCurve(lambda s: np.stack([s, 0.01 * np.sin(30.0 * s)], -1), bounds=(0.0, 1.0)),
    lambda: PlanarCurve.polar(lambda p: 0.04 + 0.003 * np.cos(16.0 * p)),  # a 16-lobe cam
], ids=["ripple 40 rad/m", "curve ripple", "16-lobe cam"])
def test_quickly_varying_analytic_surfaces_are_accepted(make):
    make()


def test_a_surface_not_analytic_away_from_the_diagonal_of_its_bounds_is_refused():
    # Re(z0^2) only where s0 > s1 + 0.5: the check's points cover the bounds, not only s0 = s1
    def point(s):
        bump = np.where(s[..., 0].real - s[..., 1].real > 0.5, 1.0, 0.0)
        return np.stack([s[..., 0], s[..., 1], s[..., 0] ** 2 + bump * np.real(s[..., 0] ** 2)], -1)

    with pytest.raises(ValueError, match=r"point: the function is not analytic"):
        ParametricSurface(point, bounds=((0.0, 1.0), (0.0, 1.0)))


def test_bad_parameters_and_orders_are_refused():
    with pytest.raises(ValueError, match=r"s: expected parameters of shape \(\.\.\., 2\)"):
        Sphere(1.0).point([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=r"s: expected real numbers, got complex"):
        Sphere(1.0).point([0.1j, 0.2])
    with pytest.raises(ValueError, match=r"s: expected finite parameters"):
        Sphere(1.0).point([np.nan, 0.2])
    for order in (4, 2.0, True):
        with pytest.raises(ValueError, match=r"order: expected 0, 1, 2 or 3, got " + repr(order)):
            Sphere(1.0).derivatives([0.1, 0.2], order=order)
    assert len(Sphere(1.0).derivatives([0.1, 0.2], order=np.int64(2))) == 3
    # at the pole of the parametrization cos(pi/2) is 6e-17, not zero: the normal is still the radial one
    np.testing.assert_allclose(Sphere(1.0).normal([0.0, math.pi / 2]), [0.0, 0.0, 1.0], atol=1e-15)


def test_a_bump_too_narrow_for_the_complex_steps_gets_the_advice_that_fixes_it():
    """A bump 5 cm wide with parameters in metres varies too fast on the steps' circle (radius 0.04 in the
    parameters' units): the error says to give the parameters larger units, and in centimetres it is
    accepted with the curvature of the closed form at its top, -2 h / w^2."""

    def bump(scale):
        def point(s):
            x, y = s[..., 0] / scale, s[..., 1] / scale
            return np.stack([x, y, 0.01 * np.exp(-(x * x + y * y) / 0.05**2)], -1)
        return point

    with pytest.raises(ValueError, match=r"give the parameters larger units, such as centimetres"):
        ParametricSurface(bump(1.0), bounds=((-0.15, 0.15), (-0.15, 0.15)))
    cm = ParametricSurface(bump(100.0), bounds=((-15.0, 15.0), (-15.0, 15.0)))
    d2 = cm.derivatives([0.0, 0.0], order=2)[2]  # d2u/ds_a ds_b (3, 2, 2), per cm^2
    np.testing.assert_allclose(d2[2, 0, 0] * 100.0**2, -2.0 * 0.01 / 0.05**2, rtol=1e-9)
