"""Contact kinematics against finite differences: the five constraints, C_s, the reduced row, rolling rows.

For random poses of two bodies near contact (the compliant model allows a
gap) and random velocities, along the motion with zero Newton-Euler
accelerations ``R(tau) = R + tau R_dot``, ``p(tau) = p exp(tau omega_body /
2)``:

* the chapter's five constraints ``C(q, s)`` (Eqs. 8.90, 8.93-8.94) with the
  surface parameters moving as ``s0 + tau s_dot`` (the kernel's ``s_dot``)
  have ``d2C/dtau2 = -gamma_c`` (the chapter's ``Q_d``, Eqs. 8.98-8.104,
  which contain the third derivatives of the surfaces);
* ``C_s`` (Eq. 8.97) equals central differences in ``s``; its left null
  vector ``N`` satisfies ``N^T C_s = 0`` with its point part the unit normal
  (Eqs. 8.105-8.107);
* the reduced row is the gradient of the penetration ``-g(q)`` (``g`` from
  the surface parameters solved at every ``tau``);
* the rolling rows' ``gamma_r`` equals ``-d/dtau (D_r v)``;
* the float path and the batched numpy path give the same rows.

Tolerances: first differences h = 1e-6 (error ~1e-10 for lengths of
0.1-1 m), five-point second differences h = 1e-3 (round-off ~1e-9 relative);
checks at 1e-7 relative to the size of the terms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.contact import Ellipsoid, ParametricSurface, PlanarCurve, Plane, Sphere, Torus
from rigidlab.core.contact._scalar import _glob, _sub, _add, _dot
from rigidlab.core.contact._kernel import COMPLIANT, CONSTRAINT
from rigidlab.core.multibody import System
from rigidlab.core.multibody._engine import matrices
from rigidlab.core.multibody._system import retract
from rigidlab.core.rotations import euler_parameters_from_matrix, matrix_from_axis_angle

SEED = 20251124


def _quat(rng, scale=1.0):
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    ang = scale * rng.uniform(-1.0, 1.0)
    return np.concatenate([[math.cos(ang / 2)], math.sin(ang / 2) * axis])


def _align(a, b):
    """Rotation matrix taking the unit vector a to the unit vector b."""
    v = np.cross(a, b)
    c = float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        if c > 0:
            return np.eye(3)
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return matrix_from_axis_angle(perp / np.linalg.norm(perp), math.pi)
    return matrix_from_axis_angle(v / np.linalg.norm(v), math.atan2(np.linalg.norm(v), c))


def _rot(p):
    return matrices(np.asarray(p, dtype=float)[None])[0]


def _bump(s):
    x, y = s[..., 0], s[..., 1]
    return np.stack([x, y, -0.3 * (x * x + y * y) + 0.05 * x * y * y], axis=-1)


# (label, surface_i, surface_j, offset of body j from the contact point along the normal, planar)
PAIRS = [
    ("sphere on plane", Plane(), Sphere(0.3), "ground", False),
    ("plane on sphere (i moving)", Sphere(0.25), Plane(normal=(0.2, 0.1, 1.0)), None, False),
    ("ellipsoid on torus", Ellipsoid(0.3, 0.2, 0.25), Torus(0.4, 0.1), None, False),
    ("rim on plane", Torus(0.2, 0.0), Plane(), None, False),
    ("plane under rim (swap)", Plane(), Torus(0.2, 0.0), "ground", False),
    ("sphere on sphere", Sphere(0.2), Sphere(0.35), None, False),
    ("bump under sphere", ParametricSurface(_bump, bounds=((-1, 1), (-1, 1))), Sphere(0.3), None, False),
    ("cam and roller", PlanarCurve.polar(lambda p: 0.05 + 0.01 * np.cos(p) + 0.004 * np.sin(2 * p)),
     PlanarCurve.circle(0.02), None, True),
    ("line on circle", PlanarCurve.line(normal=(0.3, 1.0)), PlanarCurve.circle(0.04, center=(0.01, 0.0)), None,
     True),
]


def _build(pair, rng, *, rolling=False, gap=0.01):
    label, si, sj, ground, planar = pair
    system = System(gravity=(0.0, 0.0, -9.81))
    body_i = system.ground if ground == "ground" else system.add_body(
        "i", mass=1.0, inertia=(0.3, 0.4, 0.5), position=rng.standard_normal(3) * 0.1,
        orientation=(_quat(rng) if not planar else np.array([math.cos(0.3), 0.0, 0.0, math.sin(0.3)])))
    # body j placed so that its surface touches body i's at a chosen point, then moved by `gap` along the normal
    Ri = np.zeros(3) if body_i.is_ground else system.state.position(body_i)
    Ai = np.eye(3) if body_i.is_ground else system.state.rotation_matrix(body_i)
    s_i = {"sphere on plane": (0.1, -0.2), "plane on sphere (i moving)": (0.3, -1.0),
           "ellipsoid on torus": (0.2, 0.4), "rim on plane": (-1.3, 0.0), "plane under rim (swap)": (0.05, 0.1),
           "sphere on sphere": (0.4, 0.7), "bump under sphere": (0.1, 0.2), "cam and roller": (0.7,),
           "line on circle": (0.01,)}[label]
    x_i = Ri + Ai @ si.point(np.array(s_i))
    n_i = Ai @ si.normal(np.array(s_i))
    # body j turned so that its surface's normal at s_j is -n_i (the surfaces face each other)
    if sj.n_parameters == 1:
        s_j = np.array([rng.uniform(-3.0, 3.0)]) if not sj.unbounded else np.array([0.013])
    else:
        s_j = np.array([0.05, -0.1]) if sj.unbounded else sj._samples()[rng.integers(len(sj._samples()))]
        if isinstance(sj, (Sphere, Ellipsoid, Torus)):  # (a rim with its normal along its axis would lie flat)
            s_j = np.array([rng.uniform(-2, 2), rng.uniform(-1.0, 1.0)])
    nb = sj.normal(s_j)
    if planar:
        ang = math.atan2(-n_i[1], -n_i[0]) - math.atan2(nb[1], nb[0])
        Aj = np.array([[math.cos(ang), -math.sin(ang), 0.0], [math.sin(ang), math.cos(ang), 0.0], [0.0, 0.0, 1.0]])
    else:
        Aj = _align(nb, -n_i) @ matrix_from_axis_angle(nb, rng.uniform(-3, 3))
    pj = euler_parameters_from_matrix(Aj)
    Rj = x_i + gap * n_i - Aj @ sj.point(s_j)
    if planar:
        Rj[2] = Ri[2] + 0.003  # parallel planes, a little apart
    body_j = system.add_body("j", mass=1.5, inertia=(0.5, 0.3, 0.4), position=Rj, orientation=pj,
                             velocity=rng.standard_normal(3), omega_body=rng.standard_normal(3) * 2.0)
    if not body_i.is_ground:
        n = 2
        y = system._y
        y[7 * n : 10 * n][:3] = rng.standard_normal(3)
        y[10 * n :][:3] = rng.standard_normal(3) * 2.0
        if planar:
            y[7 * n + 2] = y[7 * n + 5] = 0.0
            y[10 * n : 10 * n + 2] = 0.0
            y[10 * n + 3 : 10 * n + 5] = 0.0
    if planar:
        n = system.state.n_bodies
        y = system._y
        y[7 * n + 3 * (n - 1) + 2] = 0.0
        y[10 * n + 3 * (n - 1) : 10 * n + 3 * (n - 1) + 2] = 0.0
    model = "constraint" if rolling else "compliant"
    c = system.add_contact(body_i, si, body_j, sj, model=model, stiffness=1e5, rolling=rolling,
                           tolerance=abs(gap) + 1e-9)
    return system, c


def _curve(system, y, tau):
    n = system.state.n_bodies
    return retract(y, n, tau * y[7 * n :])


def _evaluate(system, y, level, state=None, t=None):
    eng = system._engine().workspace()
    ker = eng.contact_kernel
    n = eng.n
    st = ker.copy_state(eng.contact_state if state is None else state)
    st["mode"][:] = CONSTRAINT  # every row and gamma (a compliant contact's evaluation leaves out gamma)
    res = ker.evaluate(y, matrices(y[3 * n : 7 * n].reshape(n, 4)), level, st, t=t)
    return res, st, ker


def _rows_at(system, c, y, s, charts):
    """The chapter's five (curves: three) constraints at configuration y and fixed surface parameters s."""
    from rigidlab.core.contact._kernel import _Static

    n = system.state.n_bodies
    cs = _Static(c, n)
    A = matrices(y[3 * n : 7 * n].reshape(n, 4))
    R = y[: 3 * n].reshape(n, 3)

    def frame(body):
        if body.index < 0:
            return np.eye(3), np.zeros(3)
        return A[body.index], R[body.index]

    Ai, Ri = frame(c.body_i)
    Aj, Rj = frame(c.body_j)
    p = cs.p
    Di, Dni = c.surface_i._derivs_float(tuple(s[:p]), 1, charts[0])
    Dj, Dnj = c.surface_j._derivs_float(tuple(s[p:]), 1, charts[1])
    gi = _glob(Di, Dni, tuple(map(tuple, Ai)), p, 1)
    gj = _glob(Dj, Dnj, tuple(map(tuple, Aj)), p, 1)
    d = _sub(_add(tuple(Ri), gi.rho), _add(tuple(Rj), gj.rho))
    n_a, tb = (gj.n, gi.T) if cs.swap else (gi.n, gj.T)
    P = np.eye(3) if p == 2 else Ai[:, :2]
    return np.concatenate([P.T @ np.array(d), [_dot(n_a, tb[m]) for m in range(p)]])


def _d1(f, h=1e-6):
    return (f(h) - f(-h)) / (2 * h)


def _d2(f, h=1e-3):
    return (-f(2 * h) + 16 * f(h) - 30 * f(0.0) + 16 * f(-h) - f(-2 * h)) / (12 * h * h)


@pytest.mark.parametrize("pair", PAIRS, ids=[p[0] for p in PAIRS])
def test_five_constraints_cs_and_gamma_against_differences(pair):
    rng = np.random.default_rng(SEED)
    system, c = _build(pair, rng)
    y0 = np.array(system._y)
    res, st, ker = _evaluate(system, y0, 2, t=0.0)
    p = c.n_parameters
    r = 2 * p + 1
    q = c.index
    s0 = np.array(st["s"][q])
    charts = st["charts"][q]
    sdot = np.array(st["rate"][q][1])  # the kernel's s_dot, from the extremal conditions

    def C(tau):
        return _rows_at(system, c, _curve(system, y0, tau), s0 + tau * sdot, charts)

    gamma_c = res["gamma_c"][q, :r]
    scale = max(1.0, float(np.max(np.abs(gamma_c))))
    np.testing.assert_allclose(-_d2(C), gamma_c, atol=1e-6 * scale)
    # C_s by central differences in s
    Cs = np.zeros((r, 2 * p))
    for l in range(2 * p):
        e = np.zeros(2 * p)
        e[l] = 1e-6
        Cs[:, l] = (_rows_at(system, c, y0, s0 + e, charts) - _rows_at(system, c, y0, s0 - e, charts)) / 2e-6
    N = res["N"][q, :r]
    np.testing.assert_allclose(N @ Cs, 0.0, atol=1e-7 * max(1.0, float(np.max(np.abs(N[:, None] * Cs)))))
    # N's point part is the unit normal (P N_p = n_i)
    n = system.state.n_bodies
    Ai = np.eye(3) if c.body_i.index < 0 else matrices(y0[3 * n : 7 * n].reshape(n, 4))[c.body_i.index]
    P = np.eye(3) if p == 2 else Ai[:, :2]
    np.testing.assert_allclose(P @ N[: P.shape[1]] @ res["normal"][q], 1.0, rtol=1e-12)
    # the row's value is the penetration
    np.testing.assert_allclose(N @ _rows_at(system, c, y0, s0, charts), -res["gap"][q], atol=1e-14)


@pytest.mark.parametrize("pair", PAIRS, ids=[p[0] for p in PAIRS])
def test_reduced_row_is_the_gradient_of_the_penetration(pair):
    rng = np.random.default_rng(SEED + 1)
    for gap in (0.0, 0.02, -0.005):
        system, c = _build(pair, rng, gap=gap)
        y0 = np.array(system._y)
        n = system.state.n_bodies
        res, st, _ = _evaluate(system, y0, 1)
        q = c.index

        def pen(tau):
            r, _, _ = _evaluate(system, _curve(system, y0, tau), 0, st)
            return -r["gap"][q]

        rate = res["D"][q] @ y0[7 * n :]
        # exact on the manifold; off it the row differs from the gradient by O(gap^2 curvature)
        tol = 1e-8 + 50.0 * gap * gap * float(np.max(np.abs(y0[7 * n :])))
        assert abs(_d1(pen) - rate) <= tol, (gap, _d1(pen), rate)


@pytest.mark.parametrize("pair", [p for p in PAIRS if p[0] in ("sphere on plane", "rim on plane", "sphere on sphere",
                                                                "plane under rim (swap)", "cam and roller")],
                         ids=lambda p: p[0])
def test_rolling_rows_and_their_gamma(pair):
    rng = np.random.default_rng(SEED + 2)
    system, c = _build(pair, rng, rolling=True, gap=0.0)
    y0 = np.array(system._y)
    n = system.state.n_bodies
    res, st, _ = _evaluate(system, y0, 2)
    q = c.index
    p = c.n_parameters
    v = y0[7 * n :]

    def rows(tau):
        r, _, _ = _evaluate(system, _curve(system, y0, tau), 1, st)
        return r["Dr"][q, :p] @ v

    gr = res["gamma_r"][q, :p]
    np.testing.assert_allclose(-_d1(rows), gr, atol=1e-7 * max(1.0, float(np.max(np.abs(gr)))))
    # the rolling rows are the tangential relative velocity of the material points at the contact
    assert res["Dr"][q, :p].shape == (p, 6 * n)


@pytest.mark.parametrize("pair", PAIRS, ids=[p[0] for p in PAIRS])
def test_float_and_batched_paths_agree(pair):
    rng = np.random.default_rng(SEED + 3)
    system, c = _build(pair, rng, gap=0.01)
    y0 = np.array(system._y)
    eng = system._engine().workspace()
    ker = eng.contact_kernel
    n = eng.n
    A = matrices(y0[3 * n : 7 * n].reshape(n, 4))

    def fresh():
        st = ker.copy_state(eng.contact_state)
        st["mode"][:] = CONSTRAINT  # every row and gamma (the batched path has no compliant shortcut)
        return st

    a = ker.evaluate(y0, A, 2, fresh(), batched=False)
    b = ker.evaluate(y0, A, 2, fresh(), batched=True)
    for key in ("value", "gap", "normal", "point_i", "point_j", "N", "D", "Dr", "gamma", "gamma_r", "rate",
                "gamma_c"):
        x, z = np.nan_to_num(a[key]), np.nan_to_num(b[key])
        np.testing.assert_allclose(x, z, atol=1e-11 * max(1.0, float(np.max(np.abs(x)))), err_msg=key)
    # the rank indicator (Eq. 8.109) is computed below level 2 (the projections) by the float path
    a = ker.evaluate(y0, A, 1, fresh(), batched=False)
    b = ker.evaluate(y0, A, 1, fresh(), batched=True)
    np.testing.assert_allclose(a["rank"], b["rank"], rtol=1e-9)
    assert np.all(a["rank"] > 1e-3)


@pytest.mark.parametrize("pair", PAIRS, ids=[p[0] for p in PAIRS])
def test_a_compliant_contact_gets_what_its_force_needs_without_gamma(pair):
    """Level 2 for a compliant contact leaves out gamma (and the third derivatives); the gap, normal, row
    and its rate, which the Hunt-Crossley force is made of, are those of the full evaluation."""
    rng = np.random.default_rng(SEED + 5)
    system, c = _build(pair, rng, gap=-1e-4)  # pressed in
    y0 = np.array(system._y)
    eng = system._engine().workspace()
    ker = eng.contact_kernel
    n = eng.n
    A = matrices(y0[3 * n : 7 * n].reshape(n, 4))
    full_state = ker.copy_state(eng.contact_state)
    full_state["mode"][:] = CONSTRAINT
    full = ker.evaluate(y0, A, 2, full_state, batched=False)
    light_state = ker.copy_state(eng.contact_state)
    assert light_state["mode"][c.index] == COMPLIANT
    light = ker.evaluate(y0, A, 2, light_state, batched=False)
    for key in ("value", "gap", "normal", "point_i", "point_j", "D", "rate"):
        np.testing.assert_allclose(light[key], full[key], rtol=0, atol=1e-13 * max(1.0, np.max(np.abs(full[key]))),
                                   err_msg=key)
    assert light["gap"][c.index] < 0.0
    assert np.all(np.isnan(light["gamma_c"][c.index])) and not np.all(np.isnan(full["gamma_c"][c.index]))
    F, Q = ker.compliant_forces(light, light_state["mode"])
    assert F[c.index] > 0.0 and np.all(np.isfinite(Q))
