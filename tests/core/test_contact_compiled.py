"""The compiled contact kernel (``rigidlab.core.contact._compiled``) against the float path it replaces (the oracle).

Every pair of built-in surfaces the contact code supports (plane, sphere,
ellipsoid, torus, a rim, and the planar circle and line), with body i the
ground or a moving body, at random poses near contact (gaps from pressed in
to apart) and random velocities: the kernel and the interpreted float path
(``_scalar.newton_one`` / ``evaluate_one``, which ``COMPILED = False``
selects) give the same surface parameters, rows, rolling rows, rates,
``gamma`` terms and rank indicator, at every evaluation level, for the
constraint and the compliant model.

Tolerance 1e-12 relative to each result's size: the kernel does the same
floating-point operations in the same order as the float path (no fused
multiply-adds, numba's default ``fastmath=False``), so the results are
expected to be bit for bit the same; the margin allows an ulp of a sine or
cosine of another libm, amplified by Newton's last step and by the 4 x 4
minors of ``C_s`` (condition numbers up to about 1e3 here).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rigidlab.core.contact._kernel as kernel
from rigidlab.core.contact import Ellipsoid, ParametricSurface, PlanarCurve, Plane, Sphere, Torus
from rigidlab.core.contact._kernel import COMPLIANT, CONSTRAINT
from rigidlab.core.multibody import System
from rigidlab.core.multibody._engine import matrices
from rigidlab.core.rotations import euler_parameters_from_matrix, matrix_from_axis_angle

SEED = 20261129

SURFACES = {
    "plane": lambda: Plane(point=(0.01, -0.02, 0.0), normal=(0.1, -0.2, 1.0)),
    "sphere": lambda: Sphere(0.2, centre=(0.01, 0.0, -0.02)),
    "ellipsoid": lambda: Ellipsoid(0.3, 0.2, 0.25),
    "torus": lambda: Torus(0.4, 0.1, centre=(0.0, 0.02, 0.0)),
    "rim": lambda: Torus(0.25, 0.0),
}
# every ordered pair but the ones without a contact point (a plane on a plane, a rim on a rim)
PAIRS = [(a, b) for a in SURFACES for b in SURFACES if {a, b} != {"plane"} and {a, b} != {"rim"}]
CURVES = {
    "circle": lambda: PlanarCurve.circle(0.04, center=(0.01, -0.005)),
    "line": lambda: PlanarCurve.line(point=(0.0, 0.01), normal=(0.3, 1.0)),
}
CURVES.update({  # curves of user callables: Python hands their derivatives to the kernel at each Newton iterate
    "polar": lambda: PlanarCurve.polar(lambda p: 0.05 + 0.01 * np.cos(p) + 0.004 * np.sin(2 * p)),
    "ellipse": lambda: PlanarCurve(lambda s: np.stack([0.06 * np.cos(s), 0.04 * np.sin(s)], axis=-1),
                                   first=lambda s: np.stack([-0.06 * np.sin(s), 0.04 * np.cos(s)], axis=-1),
                                   second=lambda s: np.stack([-0.06 * np.cos(s), -0.04 * np.sin(s)], axis=-1),
                                   third=lambda s: np.stack([0.06 * np.sin(s), -0.04 * np.cos(s)], axis=-1),
                                   bounds=(-math.pi, math.pi)),
})
CURVE_PAIRS = [("circle", "circle"), ("circle", "line"), ("line", "circle"), ("polar", "circle"), ("line", "polar"),
               ("ellipse", "circle"), ("ellipse", "polar")]


def _quat(rng):
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    ang = rng.uniform(-3.0, 3.0)
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


def _parameters(surface, rng):
    if surface.n_parameters == 1:
        return np.array([rng.uniform(-0.02, 0.02) if surface.unbounded else rng.uniform(-3.0, 3.0)])
    if surface.unbounded:
        return rng.uniform(-0.1, 0.1, size=2)
    return np.array([rng.uniform(-2.5, 2.5), rng.uniform(-0.8, 0.8)])  # (outer side of a torus, rim outward)


def _system(si, sj, rng, *, ground: bool, gap: float, model: str, rolling: bool = False):
    """Bodies i (or the ground) and j placed with surface j touching surface i at random parameters, then moved
    by ``gap`` (times the length scale) along the normal; random velocities."""
    planar = si.n_parameters == 1
    system = System(gravity=(0.0, 0.0, -9.81))
    if ground:
        body_i, Ri, Ai = system.ground, np.zeros(3), np.eye(3)
    else:
        angle = rng.uniform(-3.0, 3.0)
        p_i = np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]) if planar else _quat(rng)
        body_i = system.add_body("i", mass=1.0, inertia=(0.3, 0.4, 0.5), position=rng.standard_normal(3) * 0.1,
                                 orientation=p_i, velocity=rng.standard_normal(3),
                                 omega_body=(0.0, 0.0, rng.standard_normal()) if planar else rng.standard_normal(3))
        Ri, Ai = system.state.position(body_i), system.state.rotation_matrix(body_i)
    s_i, s_j = _parameters(si, rng), _parameters(sj, rng)
    x_i = Ri + Ai @ si.point(s_i)
    n_i = Ai @ si.normal(s_i)
    nb = sj.normal(s_j)
    if planar:
        ang = math.atan2(-n_i[1], -n_i[0]) - math.atan2(nb[1], nb[0])
        Aj = np.array([[math.cos(ang), -math.sin(ang), 0.0], [math.sin(ang), math.cos(ang), 0.0], [0.0, 0.0, 1.0]])
    else:
        Aj = _align(nb, -n_i) @ matrix_from_axis_angle(nb, rng.uniform(-3, 3))
    L = min(si.length_scale, sj.length_scale)
    L = L if math.isfinite(L) else 1.0
    Rj = x_i + gap * L * n_i - Aj @ sj.point(s_j)
    if planar:
        Rj[2] = Ri[2] + 0.003
    w = rng.standard_normal(3) * 2.0
    v = rng.standard_normal(3)
    if planar:
        v[2] = 0.0
        w[:2] = 0.0
    body_j = system.add_body("j", mass=1.5, inertia=(0.5, 0.3, 0.4), position=Rj,
                             orientation=euler_parameters_from_matrix(Aj), velocity=v, omega_body=w)
    c = system.add_contact(body_i, si, body_j, sj, model=model, stiffness=1e5, rolling=rolling,
                           tolerance=abs(gap) * L + 1e-9)
    return system, c


def _both(system, monkeypatch, y, level, *, mode=None, t=None):
    """The float path's and the kernel's evaluations at ``y`` from the same fresh warm start."""
    eng = system._engine().workspace()
    ker = eng.contact_kernel
    n = eng.n
    A = matrices(y[3 * n : 7 * n].reshape(n, 4))
    out = []
    for compiled in (False, True):
        monkeypatch.setattr(kernel, "COMPILED", compiled)
        st = ker.copy_state(eng.contact_state)
        if mode is not None:
            st["mode"][:] = mode
        out.append((ker.evaluate(y, A, level, st, t=t, batched=False), st))
    return out


def _same(a: dict, b: dict, context: str) -> None:
    for key, x in a.items():
        if not isinstance(x, np.ndarray):
            continue
        z = b[key]
        assert x.shape == z.shape, (context, key)
        np.testing.assert_array_equal(np.isnan(x), np.isnan(z), err_msg=f"{context}: {key}")
        x, z = np.nan_to_num(x), np.nan_to_num(z)
        np.testing.assert_allclose(z, x, rtol=0, atol=1e-12 * max(1.0, float(np.max(np.abs(x)))),
                                   err_msg=f"{context}: {key}")


def _near(y, n, rng, scale):
    """A configuration near ``y``: positions and Euler parameters moved by ``scale``, velocities kept."""
    out = np.array(y)
    out[: 7 * n] += scale * rng.standard_normal(7 * n)
    return out


@pytest.mark.parametrize("ground", [True, False], ids=["i the ground", "i moving"])
@pytest.mark.parametrize("pair", PAIRS + CURVE_PAIRS, ids=[f"{a} on {b}" for a, b in PAIRS + CURVE_PAIRS])
def test_the_kernel_gives_the_float_paths_rows(pair, ground, monkeypatch):
    rng = np.random.default_rng([SEED, len(pair[0]), len(pair[1]), ground])
    make = CURVES if pair[0] in CURVES else SURFACES
    # apart or pressed in (compliant), and touching (constraint; rolling on most surfaces)
    for trial, (gap, model) in enumerate(((rng.uniform(-2e-3, 1e-2), "compliant"), (0.0, "constraint"))):
        rolling = model == "constraint" and make is SURFACES and rng.uniform() < 0.7
        system, c = _system(make[pair[0]](), make[pair[1]](), rng, ground=ground, gap=gap, model=model,
                            rolling=rolling)
        eng = system._engine().workspace()
        assert eng.contact_kernel.static[c.index].packed is not None
        n = eng.n
        y0 = np.array(system._y)
        for k, y in enumerate((y0, _near(y0, n, rng, 1e-2))):
            for level, mode in ((0, None), (1, None), (2, None), (2, CONSTRAINT)):  # (a compliant level 2: no gamma)
                (a, _), (b, _) = _both(system, monkeypatch, y, level, mode=mode, t=0.1 * k)
                _same(a, b, f"trial {trial}, pose {k}, level {level}, mode {mode}")


def test_a_sphere_rolled_beyond_its_chart_is_recharted_alike(monkeypatch):
    """A ball turned 1.3 rad about a horizontal axis: Newton's point leaves the chart's central region, the
    kernel hands it back for a new chart and continues (the float path re-charts inside its loop)."""
    system = System(gravity=(0.0, 0.0, -9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004,) * 3, position=(0.0, 0.0, 0.1))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1), rolling=True)
    eng = system._engine().workspace()
    y = np.array(system._y)
    p = euler_parameters_from_matrix(matrix_from_axis_angle(np.array([1.0, 0.0, 0.0]), 1.3))
    y[3:7] = p
    (a, st_a), (b, st_b) = _both(system, monkeypatch, y, 2)
    _same(a, b, "rolled ball")
    start = eng.contact_state["charts"][c.index][1]
    assert st_a["charts"][c.index][1] is not start and st_b["charts"][c.index][1] is not start
    np.testing.assert_array_equal(st_a["charts"][c.index][1], st_b["charts"][c.index][1])


def test_parametric_surfaces_keep_the_float_path():
    """A surface of user callables keeps the float path (``packed`` is None); the built-in ones take the kernel,
    and so does a planar curve of user callables, whose derivatives Python hands in at each Newton iterate."""
    system = System(gravity=(0.0, 0.0, -9.81))
    a = system.add_body("a", mass=1.0, inertia=(0.1,) * 3, position=(0.0, 0.0, 0.29))
    b = system.add_body("b", mass=1.0, inertia=(0.1,) * 3, position=(1.0, 0.0, 0.3))
    d = system.add_body("d", mass=1.0, inertia=(0.1,) * 3, position=(3.0, 0.0, 0.0))
    e = system.add_body("e", mass=1.0, inertia=(0.1,) * 3, position=(3.0, 0.0599, 0.0))
    bump = ParametricSurface(lambda s: np.stack([s[..., 0] + 1.0, s[..., 1], 0.0 * s[..., 0]], axis=-1),
                             bounds=((-1, 1), (-1, 1)))
    system.add_contact(system.ground, Plane(), a, Sphere(0.3), model="compliant", stiffness=1e5)
    system.add_contact(system.ground, bump, b, Sphere(0.3), model="compliant", stiffness=1e5)
    cam = PlanarCurve.polar(lambda phi: 0.02 + 0.0 * phi)
    system.add_contact(d, cam, e, PlanarCurve.circle(0.04), model="compliant", stiffness=1e5)
    ker = system._engine().workspace().contact_kernel
    assert [cs.packed is not None for cs in ker.static] == [True, False, True]
    assert [len(cs.curves) for cs in ker.static] == [0, 0, 1]  # (the polar curve's derivatives handed in)
