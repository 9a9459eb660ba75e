"""Cam-follower model of core.models against independent oracles.

* Eccentric cam, flat-faced and roller followers: lift against closed
  forms written out here and against brute-force geometry (the support
  function of a densely sampled cam contour; the lowest roller position
  clear of the sampled contour); derivatives against finite differences of
  the lift; the contact force against the follower's equation of motion
  with finite-difference accelerations and the geometric normal.
* Rise-dwell-return laws: boundary values, continuity of s, s' (and s''
  for cycloidal and 3-4-5), the known peak velocities and accelerations.
* Cam contours: derivatives against finite differences, the contact point
  on the contour, convexity and undercut refusals.
* Jump speed: N(theta) at the jump speed touches zero and is positive
  below it; the eccentric closed forms.
* Through the full System path (``simulate``: motor-driven cam, follower
  on a prismatic joint with a spring and gravity, curve-on-curve contact):
  lift, follower velocity and contact force against the closed forms; the
  separation instant against the closed-form zero of N; the compliant
  model leaves the cam and lands.
* Argument checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.models import CAM_LAWS, CamCurve, CamFollower, CamKinematics, CamMotion, CamProfile, CamSystem

TWO_PI = 2.0 * math.pi


def n_of(theta):
    """Follower axis seen from the cam (module conventions)."""
    return np.stack([np.sin(theta), np.cos(theta)], axis=-1)


def t_of(theta):
    return np.stack([np.cos(theta), -np.sin(theta)], axis=-1)


def rotate(points, angle):
    """Points of the cam frame in the fixed frame at cam angle ``angle`` (rotation by +angle)."""
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


# ------------------------------------------------------------------ eccentric cam
ECCENTRIC_CASES = [
    # (radius, eccentricity, follower, roller_radius, offset)
    (0.04, 0.01, "flat", 0.0, 0.0),
    (0.04, 0.01, "flat", 0.0, 0.012),
    (0.05, 0.02, "roller", 0.01, 0.0),
    (0.05, 0.02, "roller", 0.015, 0.01),
    (0.03, 0.012, "roller", 0.02, -0.02),
]


def eccentric_lift_closed_form(R, e, follower, rf, eo, theta):
    """s, s', s'' written out independently of core.models."""
    if follower == "flat":
        return e * (1 - np.cos(theta)), e * np.sin(theta), e * np.cos(theta)
    Rr = R + rf
    b0 = math.asin(-eo / (Rr - e))
    b = theta + b0
    S, C = np.sin(b), np.cos(b)
    w = eo - e * S
    q = np.sqrt(Rr**2 - w**2)
    s0 = math.sqrt((Rr - e) ** 2 - eo**2)
    s = q - e * C - s0
    ds = e * S + e * w * C / q
    dds = e * C - e * (e * C**2 + w * S) / q - (e * w * C) ** 2 / q**3
    return s, ds, dds


@pytest.mark.parametrize("R, e, follower, rf, eo", ECCENTRIC_CASES)
def test_eccentric_lift_closed_form_and_finite_differences(R, e, follower, rf, eo):
    cam = CamFollower(CamProfile.eccentric(R, e), follower=follower, roller_radius=rf, offset=eo)
    theta = np.linspace(-1.0, 7.5, 173)
    k = cam.kinematics(theta)
    assert isinstance(k, CamKinematics)
    s, ds, dds = eccentric_lift_closed_form(R, e, follower, rf, eo, theta)
    np.testing.assert_allclose(k.lift, s, rtol=0, atol=1e-16)
    np.testing.assert_allclose(k.dlift, ds, rtol=0, atol=1e-16)
    np.testing.assert_allclose(k.d2lift, dds, rtol=0, atol=2e-16)
    h = 1e-5
    kp, km = cam.kinematics(theta + h), cam.kinematics(theta - h)
    np.testing.assert_allclose((kp.lift - km.lift) / (2 * h), k.dlift, rtol=0, atol=1e-11)
    np.testing.assert_allclose((kp.dlift - km.dlift) / (2 * h), k.d2lift, rtol=0, atol=1e-11)
    np.testing.assert_allclose((kp.lift - 2 * k.lift + km.lift) / h**2, k.d2lift, rtol=0, atol=2e-6)
    # lowest lift at cam angle 0, zero there; periodic
    fine = np.linspace(0, TWO_PI, 20001)
    assert cam.kinematics(0.0).lift == pytest.approx(0.0, abs=1e-17)
    assert cam.kinematics(fine).lift.min() >= -1e-17
    np.testing.assert_allclose(cam.kinematics(theta + TWO_PI).lift, k.lift, atol=1e-16)


@pytest.mark.parametrize("R, e, follower, rf, eo", ECCENTRIC_CASES)
def test_eccentric_lift_against_brute_force_geometry(R, e, follower, rf, eo):
    """The follower's position found from a dense sampling of the cam circle, turned by theta."""
    cam = CamFollower(CamProfile.eccentric(R, e), follower=follower, roller_radius=rf, offset=eo)
    u = np.linspace(0, TWO_PI, 200001)
    b0 = cam.phase
    centre = e * np.array([math.sin(b0), -math.cos(b0)])  # eccentric centre in the cam frame
    contour = centre + R * np.stack([np.cos(u), np.sin(u)], axis=-1)
    theta = np.linspace(0, TWO_PI, 13)
    heights = []
    for th in theta:
        pts = rotate(contour, th)
        if follower == "flat":
            heights.append(pts[:, 1].max())  # support function along the follower axis
        else:
            dx = pts[:, 0] - eo
            near = np.abs(dx) <= rf
            heights.append(np.max(pts[near, 1] + np.sqrt(rf**2 - dx[near] ** 2)))  # lowest roller clear of the cam
    heights = np.array(heights)
    s = cam.kinematics(theta).lift
    # sampled contour: chord error R (du / 2)^2 / 2 ~ 1e-11 m
    np.testing.assert_allclose(s, heights - heights[0], rtol=0, atol=1e-10)
    base = R - e if follower == "flat" else math.sqrt((R + rf - e) ** 2 - eo**2)
    assert heights[0] == pytest.approx(base, abs=1e-10)


@pytest.mark.parametrize("R, e, follower, rf, eo", ECCENTRIC_CASES)
def test_eccentric_contact_force_from_the_equation_of_motion(R, e, follower, rf, eo):
    m, k, F0, g = 0.4, 1500.0, 12.0, 9.81
    cam = CamFollower(CamProfile.eccentric(R, e), follower=follower, roller_radius=rf, mass=m, stiffness=k,
                      preload=F0, gravity=g, offset=eo)
    omega = 37.0
    theta = np.linspace(0, TWO_PI, 61)
    h = 1e-4
    # follower position y(t) along its axis; acceleration by finite differences in time
    dt = h / omega
    lift = lambda th: cam.kinematics(th).lift
    accel = (lift(theta + h) - 2 * lift(theta) + lift(theta - h)) / dt**2
    axial = m * accel + k * lift(theta) + F0 + m * g
    if follower == "flat":
        normal_axial = np.ones_like(theta)
    else:
        # common normal: from the eccentric centre to the roller centre (fixed frame)
        b = theta + cam.phase
        centre = np.stack([e * np.sin(b), -e * np.cos(b)], axis=-1)
        y0 = math.sqrt((R + rf - e) ** 2 - eo**2)
        roller = np.stack([np.full_like(theta, eo), y0 + lift(theta)], axis=-1)
        nu = (roller - centre) / (R + rf)
        np.testing.assert_allclose(np.linalg.norm(roller - centre, axis=-1), R + rf, rtol=1e-13)
        normal_axial = nu[:, 1]
        np.testing.assert_allclose(np.cos(cam.pressure_angle(theta)), normal_axial, rtol=1e-13)
        # the contact normal of the model, turned to the fixed frame
        n_cam = cam.contact_normal(theta)
        n_fixed = np.stack([rotate(n_cam[i], theta[i]) for i in range(theta.size)])
        np.testing.assert_allclose(n_fixed, nu, atol=1e-14)
    N = cam.contact_force(theta, omega)
    np.testing.assert_allclose(N, axial / normal_axial, rtol=2e-6)
    # exact second derivative: agreement to round-off
    s, _, dds = eccentric_lift_closed_form(R, e, follower, rf, eo, theta)
    np.testing.assert_allclose(N, (m * omega**2 * dds + k * s + F0 + m * g) / normal_axial, rtol=1e-13)
    # the speed's sign does not matter
    np.testing.assert_allclose(cam.contact_force(theta, -omega), N, rtol=0, atol=0)


def test_flat_eccentric_jump_speed_closed_form():
    m, k, F0, g, e = 0.5, 2000.0, 20.0, 9.81, 0.01
    cam = CamFollower(CamProfile.eccentric(0.04, e), mass=m, stiffness=k, preload=F0, gravity=g)
    w = cam.jump_speed()
    assert w == pytest.approx(math.sqrt((2 * k * e + F0 + m * g) / (m * e)), rel=1e-15)
    assert w == pytest.approx(113.93419153177855, rel=1e-14)
    theta = np.linspace(0, TWO_PI, 100001)
    N = cam.contact_force(theta, w)
    assert abs(N.min()) < 1e-12 * (F0 + m * g)
    assert theta[np.argmin(N)] == pytest.approx(math.pi, abs=1e-4)
    assert cam.contact_force(theta, 0.999 * w).min() > 0
    assert cam.contact_force(theta, 1.001 * w).min() < 0


def test_roller_eccentric_jump_speed_at_the_top():
    """Zero offset: the contact force first vanishes at theta = pi, where s'' = -e (1 + e / (R + r_f))."""
    rng = np.random.default_rng(11)
    for _ in range(60):
        R = rng.uniform(0.01, 0.1)
        e = rng.uniform(0.02, 0.95) * R
        rf = rng.uniform(0.001, 0.1)
        m, k, F0 = rng.uniform(0.05, 5.0), 10 ** rng.uniform(-1, 5), rng.uniform(0, 100)
        cam = CamFollower(CamProfile.eccentric(R, e), follower="roller", roller_radius=rf, mass=m, stiffness=k,
                          preload=F0)
        expected = math.sqrt((2 * k * e + F0 + m * 9.81) / (m * e * (1 + e / (R + rf))))
        assert cam.jump_speed() == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("follower, rf, eo", [("flat", 0.0, 0.0), ("roller", 0.01, 0.0), ("roller", 0.012, 0.008)])
@pytest.mark.parametrize("law", CAM_LAWS)
def test_jump_speed_contact_force_touches_zero(law, follower, rf, eo):
    profile = CamProfile.rise_dwell_return(0.04, 0.02, math.pi / 2, math.pi / 6, math.pi / 2, law=law)
    cam = CamFollower(profile, follower=follower, roller_radius=rf, offset=eo)
    w = cam.jump_speed()
    theta = np.concatenate([np.linspace(0, TWO_PI, 400001), [math.pi / 2, 2 * math.pi / 3, 7 * math.pi / 6]])
    scale = cam.preload + cam.mass * cam.gravity
    N = cam.contact_force(theta, w)
    assert N.min() > -1e-12 * scale
    assert N.min() < 1e-8 * scale
    assert cam.contact_force(theta, 0.9999 * w).min() > 0
    assert cam.contact_force(theta, 1.0001 * w).min() < 0
    # independent of the follower: the pressure angle does not enter
    flat = CamFollower(profile)
    assert w == pytest.approx(flat.jump_speed(), rel=1e-12)


def test_default_jump_speeds():
    """The numbers quoted in docs/models.md."""
    ecc = CamProfile.eccentric()
    assert CamFollower(ecc).jump_speed() == pytest.approx(113.934, abs=1e-3)
    assert CamFollower(ecc, follower="roller", roller_radius=0.01).jump_speed() == pytest.approx(104.007, abs=1e-3)
    for law, w in (("cycloidal", 48.903), ("harmonic", 56.967), ("345", 51.451)):
        cam = CamFollower(CamProfile.rise_dwell_return(law=law))
        assert cam.jump_speed() == pytest.approx(w, abs=1e-3)


def test_jump_speed_grows_with_stiffness_and_preload():
    profile = CamProfile.rise_dwell_return(law="345")
    speeds = [CamFollower(profile, stiffness=k, preload=F0).jump_speed()
              for k, F0 in ((0.0, 5.0), (500.0, 5.0), (500.0, 50.0))]
    assert speeds[0] < speeds[1] < speeds[2]
    # with no spring rate the bound is min over s'' < 0 of F / (-m s''): the peak deceleration
    cam = CamFollower(profile, stiffness=0.0, preload=5.0, mass=0.5)
    peak = 2 * math.pi * 0.02 / (math.pi / 2) ** 2 * 10 / (math.sqrt(3) * 2 * math.pi)  # 345: 10 L / (sqrt 3 b^2)
    assert cam.jump_speed() == pytest.approx(math.sqrt((5.0 + 0.5 * 9.81) / (0.5 * peak)), rel=1e-9)


# ------------------------------------------------------------------ rise-dwell-return laws
LAW_PEAKS = {
    # peak s' * beta / L and peak |s''| * beta^2 / L
    "cycloidal": (2.0, 2 * math.pi),
    "harmonic": (math.pi / 2, math.pi**2 / 2),
    "345": (15 / 8, 10 / math.sqrt(3)),
}


@pytest.mark.parametrize("law", CAM_LAWS)
def test_rise_dwell_return_boundaries_and_continuity(law):
    L, b1, b2, b3 = 0.015, 1.3, 0.4, 1.9
    profile = CamProfile.rise_dwell_return(0.05, L, b1, b2, b3, law=law)
    boundaries = [0.0, b1, b1 + b2, b1 + b2 + b3, TWO_PI]
    values = [0.0, L, L, 0.0, 0.0]
    eps = 1e-9
    for a, v in zip(boundaries, values):
        left = profile.motion_law(a - eps)
        right = profile.motion_law(a + eps)
        at = profile.motion_law(a)
        assert at.lift == pytest.approx(v, abs=1e-15)
        assert left.lift == pytest.approx(v, abs=1e-12) and right.lift == pytest.approx(v, abs=1e-12)
        assert at.dlift == pytest.approx(0.0, abs=1e-15)
        assert left.dlift == pytest.approx(0.0, abs=1e-10) and right.dlift == pytest.approx(0.0, abs=1e-10)
        if law != "harmonic":
            assert at.d2lift == pytest.approx(0.0, abs=1e-13)
            assert left.d2lift == pytest.approx(0.0, abs=1e-8) and right.d2lift == pytest.approx(0.0, abs=1e-8)
    # harmonic: the acceleration jumps by L pi^2 / (2 beta^2) at the ends of a rise and a fall
    if law == "harmonic":
        jump = profile.motion_law(eps).d2lift - profile.motion_law(-eps).d2lift
        assert jump == pytest.approx(L * math.pi**2 / (2 * b1**2), rel=1e-8)
        jump = profile.motion_law(b1 + b2 + eps).d2lift - profile.motion_law(b1 + b2 - eps).d2lift
        assert jump == pytest.approx(-L * math.pi**2 / (2 * b3**2), rel=1e-8)
    # dwells are flat
    dwell = profile.motion_law(np.linspace(b1, b1 + b2, 11))
    np.testing.assert_allclose(dwell.lift, L, atol=1e-16)
    low = profile.motion_law(np.linspace(b1 + b2 + b3, TWO_PI, 11))
    np.testing.assert_allclose(low.lift, 0.0, atol=1e-16)
    # peaks
    v_peak, a_peak = LAW_PEAKS[law]
    rise = profile.motion_law(np.linspace(0, b1, 200001))
    assert rise.dlift.max() == pytest.approx(v_peak * L / b1, rel=1e-9)
    assert np.abs(rise.d2lift).max() == pytest.approx(a_peak * L / b1**2, rel=1e-8)
    fall = profile.motion_law(np.linspace(b1 + b2, b1 + b2 + b3, 200001))
    assert fall.dlift.min() == pytest.approx(-v_peak * L / b3, rel=1e-9)
    # monotone rise and fall
    assert np.all(np.diff(rise.lift) >= 0) and np.all(np.diff(fall.lift) <= 0)


@pytest.mark.parametrize("law", CAM_LAWS)
def test_rise_dwell_return_derivatives_by_finite_differences(law):
    profile = CamProfile.rise_dwell_return(0.05, 0.015, 1.3, 0.4, 1.9, law=law)
    # away from the segment ends (where s'' or s''' jump)
    theta = np.concatenate([np.linspace(0.05, 1.25, 20), np.linspace(1.75, 3.55, 20), np.linspace(3.7, 6.2, 7)])
    h = 1e-5
    k, kp, km = profile.motion_law(theta), profile.motion_law(theta + h), profile.motion_law(theta - h)
    np.testing.assert_allclose((kp.lift - km.lift) / (2 * h), k.dlift, rtol=0, atol=1e-11)
    np.testing.assert_allclose((kp.dlift - km.dlift) / (2 * h), k.d2lift, rtol=0, atol=1e-10)
    # every follower sees the motion law as its lift
    for cam in (CamFollower(profile), CamFollower(profile, follower="roller", roller_radius=0.01, offset=0.01)):
        got = cam.kinematics(theta)
        np.testing.assert_array_equal(got.lift, k.lift)
        np.testing.assert_array_equal(got.d2lift, k.d2lift)


def test_rise_without_dwells():
    profile = CamProfile.rise_dwell_return(0.04, 0.01, math.pi, 0.0, math.pi, law="cycloidal")
    theta = np.linspace(0, TWO_PI, 9)
    s = profile.motion_law(theta).lift
    expected = np.where(theta <= math.pi, 0.01 * (theta / math.pi - np.sin(2 * theta) / TWO_PI),
                        0.01 * (1 - ((theta - math.pi) / math.pi - np.sin(2 * (theta - math.pi)) / TWO_PI)))
    np.testing.assert_allclose(s, expected, atol=1e-17)


def test_motion_law_of_an_eccentric_cam_is_refused():
    with pytest.raises(ValueError, match="kind: the eccentric cam has no motion law"):
        CamProfile.eccentric().motion_law(0.0)


# ------------------------------------------------------------------ cam contours
CONTOUR_CASES = [
    (CamProfile.eccentric(0.04, 0.01), "flat", 0.0, 0.0),
    (CamProfile.eccentric(0.04, 0.01), "roller", 0.01, 0.004),
    (CamProfile.rise_dwell_return(0.04, 0.02, 1.6, 0.5, 1.6, law="cycloidal"), "flat", 0.0, 0.0),
    (CamProfile.rise_dwell_return(0.04, 0.02, 1.6, 0.5, 1.6, law="345"), "roller", 0.012, 0.006),
    (CamProfile.rise_dwell_return(0.04, 0.02, 1.6, 0.5, 1.6, law="harmonic"), "roller", 0.01, 0.0),
]


@pytest.mark.parametrize("profile, follower, rf, eo", CONTOUR_CASES)
def test_cam_curve_derivatives_by_finite_differences(profile, follower, rf, eo):
    cam = CamFollower(profile, follower=follower, roller_radius=rf, offset=eo)
    # away from segment ends, where the third derivative jumps
    u = np.array([0.3, 0.9, 1.4, 1.9, 2.5, 3.0, 3.5, 4.5, 5.5, 6.0])
    h = 1e-5
    for curve_of in (cam.cam_curve, cam.pitch_curve):
        c, cp, cm = curve_of(u), curve_of(u + h), curve_of(u - h)
        assert isinstance(c, CamCurve) and c.point.shape == (10, 2)
        scale = np.abs(c.d3).max() + np.abs(c.d2).max()
        np.testing.assert_allclose((cp.point - cm.point) / (2 * h), c.d1, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose((cp.d1 - cm.d1) / (2 * h), c.d2, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose((cp.d2 - cm.d2) / (2 * h), c.d3, rtol=0, atol=1e-8 * scale)


@pytest.mark.parametrize("profile, follower, rf, eo", CONTOUR_CASES)
def test_float_contour_is_the_array_contour(profile, follower, rf, eo):
    """The contact kernel's one-point path (written-out derivative rules) against the array path, to
    round-off: both evaluate the same formulas, in another order of the sums."""
    cam = CamFollower(profile, follower=follower, roller_radius=rf, offset=eo)
    u = np.linspace(0.05, TWO_PI - 0.05, 41)
    c = cam.cam_curve(u)
    want = np.stack([c.point, c.d1, c.d2, c.d3], axis=1)  # (n, 4, 2)
    got = np.array([cam._curve_float(float(x)) for x in u])
    scale = np.abs(want).max(axis=(0, 2))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * float(scale.max()))


def test_written_out_derivative_rules_are_the_general_ones():
    """Leibniz products, square roots and reciprocals of 4 and 5 derivatives, written out, against the
    general recurrences (random stacks; other lengths take the recurrences)."""
    from rigidlab.core.models import _cam

    rng = np.random.default_rng(7)
    for m in (2, 3, 4, 5):
        for _ in range(50):
            a, b = list(rng.normal(size=m)), list(rng.normal(size=m))
            a[0] = abs(a[0]) + 0.5
            for fast, loops, args in ((_cam._mul_f, _cam._mul_f_loops, (a, b)),
                                      (_cam._sqrt_f, _cam._sqrt_f_loops, (a,)),
                                      (_cam._reciprocal_f, _cam._reciprocal_f_loops, (a,))):
                want = np.array(loops(*args))
                np.testing.assert_allclose(fast(*args), want, rtol=1e-14, atol=1e-14 * np.abs(want).max())


@pytest.mark.parametrize("profile, follower, rf, eo", CONTOUR_CASES)
def test_cam_curve_point_is_the_contact_point(profile, follower, rf, eo):
    cam = CamFollower(profile, follower=follower, roller_radius=rf, offset=eo)
    theta = np.linspace(0, TWO_PI, 41)
    contour = cam.cam_curve(np.linspace(0, TWO_PI, 20001)).point
    p = cam.cam_curve(theta).point
    s = cam.kinematics(theta).lift
    n, t = n_of(theta), t_of(theta)
    if follower == "flat":
        # on the face, and the face supports the whole cam
        np.testing.assert_allclose(np.sum(p * n, -1), profile.base_radius + s, atol=1e-15)
        support = (contour @ n.T).max(axis=0)
        np.testing.assert_allclose(support, profile.base_radius + s, atol=1e-9)
    else:
        y0 = math.sqrt((profile.base_radius + rf) ** 2 - eo**2)
        centre = eo * t + (y0 + s)[:, None] * n
        np.testing.assert_allclose(cam.pitch_curve(theta).point, centre, atol=1e-16)
        np.testing.assert_allclose(np.linalg.norm(p - centre, axis=-1), rf, rtol=1e-13)
        # the roller clears the cam everywhere: no contour point inside it
        d = np.linalg.norm(contour[:, None, :] - centre[None], axis=-1)
        assert d.min() > rf - 1e-9
        # the normal is along the line from the contact point to the centre
        np.testing.assert_allclose(cam.contact_normal(theta), (centre - p) / rf, atol=1e-12)
    # the contour is tangent to the follower at the contact point
    d1 = cam.cam_curve(theta).d1
    normal = cam.contact_normal(theta)
    np.testing.assert_allclose(np.sum(d1 * normal, -1), 0.0, atol=1e-15)


def test_eccentric_contour_is_the_circle():
    for follower, rf, eo in (("flat", 0.0, 0.01), ("roller", 0.01, 0.0), ("roller", 0.01, -0.02)):
        cam = CamFollower(CamProfile.eccentric(0.04, 0.01), follower=follower, roller_radius=rf, offset=eo)
        centre = 0.01 * np.array([math.sin(cam.phase), -math.cos(cam.phase)])
        p = cam.cam_curve(np.linspace(0, TWO_PI, 101)).point
        np.testing.assert_allclose(np.linalg.norm(p - centre, axis=-1), 0.04, rtol=1e-14)
        np.testing.assert_allclose(cam.radius_of_curvature(np.linspace(0, 6, 7)), 0.04, rtol=1e-12)


@pytest.mark.parametrize("profile, follower, rf, eo", CONTOUR_CASES)
def test_radius_of_curvature_against_the_contour(profile, follower, rf, eo):
    cam = CamFollower(profile, follower=follower, roller_radius=rf, offset=eo)
    u = np.array([0.3, 0.9, 1.4, 1.9, 2.5, 3.0, 3.5, 4.5, 5.5, 6.0])
    h = 1e-4
    pts = [cam.cam_curve(u + k * h).point for k in (-1, 0, 1)]
    d1 = (pts[2] - pts[0]) / (2 * h)
    d2 = (pts[2] - 2 * pts[1] + pts[0]) / h**2
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    rho_fd = -np.linalg.norm(d1, axis=-1) ** 3 / cross  # clockwise: convex parts have cross < 0
    np.testing.assert_allclose(cam.radius_of_curvature(u), rho_fd, rtol=1e-5)


def test_flat_face_needs_a_convex_cam():
    profile = CamProfile.rise_dwell_return(0.01, 0.03, math.pi / 4, 0.2, math.pi / 4)
    with pytest.raises(ValueError, match=r"base_radius: a flat-faced follower needs a convex cam.*use base_radius > 0\.27"):
        CamFollower(profile)
    # the base radius it names is enough
    needed = 0.27834
    CamFollower(CamProfile.rise_dwell_return(needed + 1e-4, 0.03, math.pi / 4, 0.2, math.pi / 4))
    with pytest.raises(ValueError, match="base_radius"):
        CamFollower(CamProfile.rise_dwell_return(needed - 1e-4, 0.03, math.pi / 4, 0.2, math.pi / 4))
    # a roller follower can ride the same motion law
    CamFollower(profile, follower="roller", roller_radius=0.005)


def test_undercut_roller_is_refused():
    profile = CamProfile.rise_dwell_return(0.01, 0.03, math.pi / 4, 0.2, math.pi / 4)
    with pytest.raises(ValueError, match="roller_radius: expected less than the pitch curve's smallest convex radius"):
        CamFollower(profile, follower="roller", roller_radius=0.02)


@pytest.mark.parametrize("offset", [0.0, 0.01])
def test_the_undercut_refusal_names_the_largest_roller_that_fits(offset):
    """The pitch curve grows with the roller, so the radius of curvature the refusal quotes moved with the
    roller typed (0.0245, then 0.0220, 0.0212 m: each a roller that was refused too). It names the root of
    rho_min(r) = r as well, which is accepted just below and refused just above."""
    profile = CamProfile.rise_dwell_return(0.04, 0.02, math.radians(40.0), math.radians(30.0), math.radians(40.0))
    largest = CamFollower(profile, follower="roller", roller_radius=0.005, offset=offset).largest_roller_radius()
    assert 0.01 < largest < 0.03
    for r in (0.03, 0.024, largest + 2e-6):
        with pytest.raises(ValueError, match=rf"use roller_radius < {largest:.6g} m \(the largest roller"):
            CamFollower(profile, follower="roller", roller_radius=r, offset=offset)
    CamFollower(profile, follower="roller", roller_radius=largest - 2e-6, offset=offset)
    eccentric = CamFollower(CamProfile.eccentric(), follower="roller", roller_radius=0.01)
    assert eccentric.largest_roller_radius() == math.inf


# ------------------------------------------------------------------ shapes and arguments
@pytest.mark.parametrize("shape", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes(shape):
    rng = np.random.default_rng(3)
    theta = rng.uniform(-7, 7, shape)
    for cam in (CamFollower(CamProfile.eccentric(), follower="roller", roller_radius=0.01, offset=0.005),
                CamFollower(CamProfile.rise_dwell_return(law="345"))):
        k = cam.kinematics(theta)
        assert k.lift.shape == shape and k.dlift.shape == shape and k.d2lift.shape == shape
        assert cam.contact_force(theta, 30.0).shape == shape
        assert cam.pressure_angle(theta).shape == shape
        assert cam.radius_of_curvature(theta).shape == shape
        assert cam.contact_normal(theta).shape == shape + (2,)
        for c in (cam.cam_curve(theta), cam.pitch_curve(theta)):
            assert c.point.shape == c.d1.shape == c.d2.shape == c.d3.shape == shape + (2,)
        flat = np.ravel(theta)
        np.testing.assert_array_equal(np.ravel(k.lift), cam.kinematics(flat).lift)


@pytest.mark.parametrize("args, kwargs, message", [
    (("eccentric", 0.03), {}, r"radius, eccentricity: an 'eccentric' profile needs radius, eccentricity \(build a "
                              r"profile with CamProfile.eccentric\(...\) or CamProfile.rise_dwell_return\(...\)\)"),
    (("spiral", 0.03), {}, r"kind: expected 'eccentric' or 'rise_dwell_return' .*got 'spiral'"),
    (("eccentric", 0.04), dict(radius=0.04, eccentricity=0.01), r"base_radius: expected 0.03 m .*got 0.04"),
    (("eccentric", 0.03), dict(radius=0.04, eccentricity=0.05), r"eccentricity: expected less than radius"),
    (("eccentric", 0.03), dict(radius=0.04, eccentricity=0.01, law="345"), r"law: an 'eccentric' profile has no law"),
    (("rise_dwell_return", 0.04), dict(lift=0.02, rise=1.0, dwell=0.5, fall=1.0), r"law: a 'rise_dwell_return' "
                                                                                  r"profile needs law"),
    (("rise_dwell_return", 0.04), dict(lift=0.02, rise=1.0, dwell=0.5, fall=1.0, law="nope"), r"law: expected one of"),
])
def test_a_profile_built_directly_is_checked_as_the_factories_check(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        CamProfile(*args, **kwargs)


def test_a_profile_built_directly_equals_the_factorys():
    assert CamProfile("eccentric", 0.03, radius=0.04, eccentricity=0.01) == CamProfile.eccentric(0.04, 0.01)
    made = CamProfile.rise_dwell_return(0.05, 0.01, 1.0, 0.5, 1.2, law="345")
    assert CamProfile("rise_dwell_return", 0.05, lift=0.01, rise=1.0, dwell=0.5, fall=1.2, law="345") == made


def test_pressure_angle_is_zero_for_a_flat_face():
    cam = CamFollower(CamProfile.eccentric(), offset=0.01)
    np.testing.assert_array_equal(cam.pressure_angle(np.linspace(0, 6, 7)), 0.0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(radius=0.0), "radius: expected a finite number > 0"),
        (dict(radius=-1.0), "radius: expected a finite number > 0"),
        (dict(radius=float("nan")), "radius: expected a finite number > 0"),
        (dict(eccentricity=0.0), "eccentricity: expected a finite number > 0"),
        (dict(radius=0.02, eccentricity=0.02), "eccentricity: expected less than radius"),
        (dict(eccentricity=1j), "eccentricity: expected real numbers, got complex"),
        (dict(radius="big"), "radius: expected a finite number > 0"),
    ],
)
def test_eccentric_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CamProfile.eccentric(**kwargs)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(base_radius=0.0), "base_radius: expected a finite number > 0"),
        (dict(lift=-0.01), "lift: expected a finite number > 0"),
        (dict(rise=0.0), "rise: expected a finite number > 0"),
        (dict(fall=float("inf")), "fall: expected a finite number > 0"),
        (dict(dwell=-0.1), "dwell: expected a finite number >= 0"),
        (dict(rise=3.0, dwell=1.0, fall=3.0), r"rise, dwell, fall: expected rise \+ dwell \+ fall <= 2 pi"),
        (dict(law="parabolic"), "law: expected one of"),
        (dict(law=None), "law: expected one of"),
    ],
)
def test_rise_dwell_return_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CamProfile.rise_dwell_return(**kwargs)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(follower="knife"), "follower: expected one of"),
        (dict(roller_radius=0.01), "roller_radius: a flat-faced follower has no roller"),
        (dict(follower="roller"), "roller_radius: expected a roller radius > 0"),
        (dict(follower="roller", roller_radius=-0.01), "roller_radius: expected a finite number >= 0"),
        (dict(mass=0.0), "mass: expected a finite number > 0"),
        (dict(mass=True), "mass: expected a finite number > 0"),
        (dict(stiffness=-1.0), "stiffness: expected a finite number >= 0"),
        (dict(preload=-1.0), "preload: expected a finite number >= 0"),
        (dict(preload=0.0, gravity=0.0), r"preload: expected preload \+ mass \* gravity > 0"),
        (dict(preload=1.0, gravity=-9.81, mass=0.5), r"preload: expected preload \+ mass \* gravity > 0"),
        (dict(gravity=float("nan")), "gravity: expected a finite acceleration"),
        (dict(offset=float("inf")), "offset: expected a finite distance"),
        (dict(follower="roller", roller_radius=0.01, offset=0.04), r"offset: expected \|offset\| < radius - eccentricity \+ roller_radius"),
    ],
)
def test_follower_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CamFollower(CamProfile.eccentric(0.04, 0.01), **kwargs)


def test_follower_argument_types_and_calls():
    with pytest.raises(ValueError, match="profile: expected a CamProfile"):
        CamFollower("eccentric")
    profile = CamProfile.rise_dwell_return()
    with pytest.raises(ValueError, match=r"offset: expected \|offset\| < base_radius \+ roller_radius"):
        CamFollower(profile, follower="roller", roller_radius=0.01, offset=-0.06)
    cam = CamFollower(profile)
    with pytest.raises(ValueError, match="theta: expected finite cam angles"):
        cam.kinematics([0.0, float("nan")])
    with pytest.raises(ValueError, match="theta: expected real numbers, got complex"):
        cam.kinematics(1j)
    with pytest.raises(ValueError, match=r"theta: expected cam angles \(rad\), got a boolean True"):
        cam.kinematics(True)  # (not 1 rad: bools are refused as every scalar argument refuses them)
    with pytest.raises(ValueError, match="speed: expected a finite cam speed"):
        cam.contact_force(0.0, float("inf"))
    with pytest.raises(ValueError, match="u: expected finite cam angles"):
        cam.cam_curve(float("nan"))
    # a negative gravity component is allowed while the preload holds the follower on the cam
    held = CamFollower(profile, gravity=-9.81, preload=10.0)
    assert held.jump_speed() < cam.jump_speed()


def test_follower_is_frozen_and_values_are_floats():
    cam = CamFollower(CamProfile.eccentric(), mass=1, stiffness=100, preload=5, offset=0)
    assert isinstance(cam.mass, float) and isinstance(cam.stiffness, float) and isinstance(cam.offset, float)
    with pytest.raises(AttributeError):
        cam.mass = 2.0  # type: ignore[misc]


# ------------------------------------------------------------------ through core.multibody.System
def check_against_closed_forms(cam, motion, speed, *, force_rtol=1e-8):
    """Lift, follower velocity and contact force of a constraint-model run against the closed forms."""
    k = cam.kinematics(motion.cam_angle)
    scale = np.abs(k.lift).max()
    np.testing.assert_allclose(motion.lift, k.lift, rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(motion.lift_rate, speed * k.dlift, rtol=0, atol=1e-8 * speed * np.abs(k.dlift).max())
    N = cam.contact_force(motion.cam_angle, speed)
    np.testing.assert_allclose(motion.contact_force, N, rtol=force_rtol)
    np.testing.assert_allclose(motion.gap, 0.0, atol=1e-10)


@pytest.mark.parametrize("follower, rf, eo", [("flat", 0.0, 0.01), ("roller", 0.01, 0.008)])
def test_simulate_eccentric_matches_the_closed_forms(follower, rf, eo):
    cam = CamFollower(CamProfile.eccentric(), follower=follower, roller_radius=rf, offset=eo)
    speed = 30.0
    t = np.linspace(0.0, TWO_PI / speed, 41)
    motion = cam.simulate(speed, t)
    assert isinstance(motion, CamMotion) and motion.status == "completed"
    assert motion.separations.shape == (0, 2) and motion.landings.shape == (0, 2)
    np.testing.assert_allclose(motion.cam_angle, speed * t)
    check_against_closed_forms(cam, motion, speed)
    # the contact point on the cam is the contour's point at the cam angle, turned into the global x-z plane
    p = cam.cam_curve(motion.cam_angle).point
    c, s_ = np.cos(motion.cam_angle), np.sin(motion.cam_angle)
    x, z = c * p[:, 0] - s_ * p[:, 1], s_ * p[:, 0] + c * p[:, 1]
    np.testing.assert_allclose(motion.contact_point, np.stack([x, 0 * x, z], axis=-1), atol=1e-11)
    # the follower's axis: the contact point of a roller is one roller radius from the roller centre
    if follower == "roller":
        centre = motion.trajectory.q[:, 3:6]
        np.testing.assert_allclose(np.linalg.norm(motion.contact_point - centre, axis=-1), rf, rtol=1e-9)


def test_build_system_frames():
    cam = CamFollower(CamProfile.eccentric(), follower="roller", roller_radius=0.01, offset=0.005)
    built = cam.build_system(25.0, start=0.1)
    assert isinstance(built, CamSystem)
    state = built.system.state
    assert state.t == 0.1
    s = float(cam.kinematics(2.5).lift)
    np.testing.assert_allclose(state.position(built.follower), [0.005, 0.0, built.lift_origin + s], atol=1e-14)
    np.testing.assert_allclose(state.omega(built.cam), [0.0, -25.0, 0.0], atol=1e-13)
    np.testing.assert_allclose(state.velocity(built.follower)[2], 25.0 * float(cam.kinematics(2.5).dlift), rtol=1e-12)
    assert built.cam_joint.kind == "revolute" and built.follower_joint.kind == "prismatic"
    assert built.contact.model == "constraint"
    # without a spring rate the preload is a constant force
    no_spring = CamFollower(CamProfile.eccentric(), stiffness=0.0, preload=5.0).build_system(10.0)
    assert no_spring.system.spring_dampers == ()


def test_separation_at_the_closed_form_angle():
    cam = CamFollower(CamProfile.eccentric(), stiffness=200.0, preload=2.0)
    speed = 1.2 * cam.jump_speed()
    motion = cam.simulate(speed, np.linspace(0.0, TWO_PI / speed, 121))
    assert motion.status == "separated"
    # N = m w^2 e cos th + k e (1 - cos th) + F0 + m g = 0
    m, k, e = cam.mass, cam.stiffness, 0.01
    F = cam.preload + m * cam.gravity
    expected = math.acos(-(k * e + F) / (m * speed**2 * e - k * e))
    assert motion.separations.shape == (1, 2)
    assert motion.separations[0, 1] == pytest.approx(expected, abs=1e-8)
    assert motion.separations[0, 0] == pytest.approx(expected / speed, abs=1e-8 / speed)
    assert motion.cam_angle[-1] <= expected
    check_against_closed_forms(cam, motion, speed)
    # below the jump speed nothing separates
    below = cam.simulate(0.98 * cam.jump_speed(), np.linspace(0.0, TWO_PI / speed, 31))
    assert below.status == "completed" and below.separations.size == 0


@pytest.mark.slow
@pytest.mark.parametrize("law", CAM_LAWS)
@pytest.mark.parametrize("follower, rf, eo", [("flat", 0.0, 0.0), ("roller", 0.01, 0.005)])
def test_simulate_rise_dwell_return_matches_the_closed_forms(law, follower, rf, eo):
    cam = CamFollower(CamProfile.rise_dwell_return(law=law), follower=follower, roller_radius=rf, offset=eo)
    speed = 0.8 * cam.jump_speed()
    t = np.linspace(0.01, 0.01 + TWO_PI / speed, 91)
    motion = cam.simulate(speed, t)
    assert motion.status == "completed"
    # the harmonic law's acceleration jumps at the ends of the rise and the fall; outputs there see one side
    exact = np.ones(t.size, dtype=bool)
    if law == "harmonic":
        theta = np.mod(motion.cam_angle, TWO_PI)
        for edge in (0.0, math.pi / 2, 2 * math.pi / 3, 7 * math.pi / 6, TWO_PI):
            exact &= np.abs(theta - edge) > 1e-6
    sub = CamMotion(**{**motion.__dict__, "t": motion.t[exact], "cam_angle": motion.cam_angle[exact],
                       "lift": motion.lift[exact], "lift_rate": motion.lift_rate[exact],
                       "contact_force": motion.contact_force[exact], "gap": motion.gap[exact]})
    check_against_closed_forms(cam, sub, speed)


@pytest.mark.slow
@pytest.mark.parametrize("follower, rf", [("flat", 0.0), ("roller", 0.01)])
def test_eccentric_over_three_revolutions(follower, rf):
    cam = CamFollower(CamProfile.eccentric(), follower=follower, roller_radius=rf)
    speed = 0.9 * cam.jump_speed()
    motion = cam.simulate(speed, np.linspace(0.0, 3 * TWO_PI / speed, 181))
    check_against_closed_forms(cam, motion, speed)


@pytest.mark.slow
def test_compliant_follower_leaves_and_lands():
    cam = CamFollower(CamProfile.eccentric(), stiffness=200.0, preload=2.0)
    speed = 1.2 * cam.jump_speed()
    t = np.linspace(0.0, 2 * TWO_PI / speed, 481)
    motion = cam.simulate(speed, t, on_separation="compliant")
    assert motion.status == "completed"
    first = motion.separations[0]
    m, k, e = cam.mass, cam.stiffness, 0.01
    F = cam.preload + m * cam.gravity
    assert first[1] == pytest.approx(math.acos(-(k * e + F) / (m * speed**2 * e - k * e)), abs=1e-8)
    assert len(motion.landings) >= 1 and motion.landings[0, 0] > first[0]
    # separations and landings alternate after the first separation
    events = sorted([(x, "s") for x in motion.separations[:, 0]] + [(x, "l") for x in motion.landings[:, 0]])
    kinds = [kind for _, kind in events]
    assert all(a != b for a, b in zip(kinds, kinds[1:]))
    # in flight the follower is above the cam and feels no force
    flying = motion.gap > 1e-6
    assert np.any(flying)
    np.testing.assert_array_equal(motion.contact_force[flying], 0.0)
    assert np.all(motion.contact_force >= 0)
    # the model="compliant" run agrees with the constraint run before the separation (pressed in by ~1e-5 m)
    compliant = cam.simulate(0.5 * cam.jump_speed(), np.linspace(0, TWO_PI / (0.5 * cam.jump_speed()), 61),
                             model="compliant")
    N = cam.contact_force(compliant.cam_angle, 0.5 * cam.jump_speed())
    np.testing.assert_allclose(compliant.contact_force, N, rtol=2e-2)
    assert np.all(compliant.gap < 0)
    assert compliant.separations.size == 0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(speed=float("nan")), "speed: expected a finite cam speed"),
        # (its accelerations would overflow, and the contact search blamed the curve)
        (dict(speed=1e300), r"speed: expected a cam speed \(rad/s\) of magnitude at most 1e\+100, got 1e\+300"),
        (dict(model="rigid"), "model: expected one of"),
        (dict(contact_stiffness=0.0), "contact_stiffness: expected a finite number > 0"),
        # (a soft compliant contact starts deep in the cam: the System blamed the bodies' placement)
        (dict(model="compliant", contact_stiffness=1e4),
         r"contact_stiffness: expected a contact stiff enough .* got 10000.0 N/m\^1.5: the contact force of "
         r".* presses it 0.0\d+ m into the cam, .*; use contact_stiffness > \d"),
        (dict(contact_damping=-1.0), "contact_damping: expected a finite number >= 0"),
        (dict(contact_exponent=0.5), "contact_exponent: expected a finite exponent >= 1"),
        (dict(t=[0.1, 0.2, 0.15]), r"t: expected non-decreasing times \(s\), got t\[2\] = 0.15 after t\[1\] = 0.2"),
        (dict(on_separation="jump"), "on_separation: expected one of"),
    ],
)
def test_simulate_arguments(kwargs, message):
    cam = CamFollower(CamProfile.eccentric())
    args = {"speed": 10.0, "t": [0.0, 0.01], **kwargs}
    with pytest.raises(ValueError, match=message):
        cam.simulate(args.pop("speed"), args.pop("t"), **args)


def test_follower_and_motion_pickle():
    """Scenes compute on a process pool: the model and its results cross process boundaries."""
    import pickle

    for cam in (CamFollower(CamProfile.eccentric(), follower="roller", roller_radius=0.01, offset=0.003),
                CamFollower(CamProfile.rise_dwell_return(law="345"), stiffness=500.0)):
        copy = pickle.loads(pickle.dumps(cam))
        assert copy == cam
        theta = np.linspace(0, TWO_PI, 7)
        np.testing.assert_array_equal(copy.kinematics(theta).d2lift, cam.kinematics(theta).d2lift)
        assert copy.jump_speed() == cam.jump_speed()
    motion = cam.simulate(10.0, [0.0, 0.01])
    copy = pickle.loads(pickle.dumps(motion))
    assert copy.trajectory is None and copy.status == motion.status
    np.testing.assert_array_equal(copy.contact_force, motion.contact_force)
    np.testing.assert_array_equal(copy.separations, motion.separations)


@pytest.mark.parametrize("speed", [-30.0, 0.0])
def test_simulate_backwards_and_at_rest(speed):
    cam = CamFollower(CamProfile.rise_dwell_return(law="cycloidal"), follower="roller", roller_radius=0.01,
                      offset=0.004)
    motion = cam.simulate(speed, np.linspace(0.02, 0.2, 10))
    assert motion.status == "completed"
    np.testing.assert_allclose(motion.lift, cam.kinematics(motion.cam_angle).lift, rtol=0, atol=1e-11)
    np.testing.assert_allclose(motion.contact_force, cam.contact_force(motion.cam_angle, speed), rtol=1e-8)


@pytest.mark.parametrize("method", ["rk4", "midpoint", "LSODA", 3])
def test_simulate_names_the_methods_it_takes(method):
    cam = CamFollower(CamProfile.eccentric())
    with pytest.raises(ValueError, match=r"method: expected one of 'kinematic', 'DOP853', 'RK45' or None \(the "
                                         r"cam's run takes rtol and atol, not a fixed step\), got"):
        cam.simulate(50.0, np.linspace(0.0, 0.01, 3), method=method)


@pytest.mark.parametrize("outputs", [13, 61, 121])
def test_the_force_at_a_law_breakpoint_is_one_sides_limit(outputs):
    """The harmonic law's acceleration jumps where the rise starts (cam angle 0 = 2 pi): the force there is
    the one-sided limit of either side, never a mix. At 61 outputs the last (t = T, the contact parameter
    within 1e-15 of the breakpoint) gave 40.02 N between 25.03 and 77.87 N: s_dot came from E_s of Newton's
    last iterate on one side, gamma from the geometry on the other."""
    profile = CamProfile.rise_dwell_return(base_radius=0.04, lift=0.02, rise=math.radians(90.0),
                                           dwell=math.radians(30.0), fall=math.radians(90.0), law="harmonic")
    cam = CamFollower(profile, follower="roller", roller_radius=0.01, offset=0.005)
    w = 0.9 * cam.jump_speed()
    period = 2.0 * math.pi / w
    sides = cam.contact_force(np.array([-1e-9, 1e-9]), w)  # dwell side, rise side
    assert sides[1] - sides[0] > 50.0
    force = cam.simulate(w, np.linspace(0.0, period, outputs)).contact_force[-1]
    assert min(abs(force - sides[0]), abs(force - sides[1])) < 1e-6 * sides[1], (force, sides)
