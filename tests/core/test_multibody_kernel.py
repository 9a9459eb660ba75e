"""The compiled kernels (core.multibody._kernel) against the numpy evaluation of the same engine.

The numpy evaluation (``_Engine.table``, ``constraint_rows``, ``applied``,
``solve``) is the oracle: it forms the chapter's augmented equations densely
(Eq. 8.109, D M^-1 D^T by Cholesky). On randomized systems with every joint
kind, both motor coordinates, spring-dampers (with and without free length),
torsion springs, user forces and torques and loops closed by extra joints,
at random (unassembled) states, the compiled rows, Jacobian, C_t, gamma,
forces, accelerations and multipliers agree with it. Tolerance: 1e-12
relative to each quantity's largest entry (the rows and forces are the same
arithmetic in another order, a few ulp; the solves differ in elimination
order, bounded by the condition of D M^-1 D^T, which these systems keep
below about 1e3).
"""

from __future__ import annotations

import numpy as np
import pytest

from rigidlab.core.models import pendulum_chain
from rigidlab.core.multibody import System
from rigidlab.core.multibody._analysis import analyze_rank
from rigidlab.core.multibody._simulate import _Dynamics
import rigidlab.core.multibody._simulate as simulate_module

KINDS = ("spherical", "revolute", "fixed", "universal", "cylindrical", "prismatic")


def _unit(rng, k=3):
    v = rng.normal(size=k)
    return v / np.linalg.norm(v)


def random_system(seed: int, *, n_bodies: int = 6, loops: int = 1) -> System:
    """Bodies with full inertia tensors on a random tree of every joint kind, motors, springs, loads, loops."""
    rng = np.random.default_rng(seed)
    s = System(gravity=tuple(rng.normal(size=3)))
    bodies = []
    for k in range(n_bodies):
        principal = np.sort(rng.uniform(0.5, 1.5, size=3))
        principal[2] = min(principal[2], principal[0] + principal[1] - 0.05)  # triangle inequality
        Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        J = Q @ np.diag(principal) @ Q.T
        bodies.append(s.add_body(f"b{k}", mass=rng.uniform(0.5, 2.0), inertia=(J + J.T) / 2,
                                 position=rng.normal(size=3), orientation=_unit(rng, 4),
                                 velocity=rng.normal(size=3), omega=rng.normal(size=3)))
    joints = []
    for k, b in enumerate(bodies):
        idx = int(rng.integers(-1, k))  # -1: the ground
        parent = s.ground if idx < 0 else bodies[idx]
        kind = KINDS[(seed + k) % len(KINDS)]
        axis = _unit(rng)
        extra = {}
        if kind in ("revolute", "cylindrical", "prismatic"):
            extra["axis"] = axis
        elif kind == "universal":
            other = _unit(rng)
            extra["axis"] = axis
            extra["axis_j"] = other - (other @ axis) * axis
        joints.append(s.add_joint(kind, parent, b, point=rng.normal(size=3), **extra))
    for _ in range(loops):  # a loop through two bodies far apart in the tree
        s.add_joint("spherical", bodies[-1], bodies[0] if n_bodies > 2 else s.ground, point=rng.normal(size=3))
    for jt in joints:
        if jt.kind in ("revolute", "cylindrical") and rng.random() < 0.5:
            w = rng.uniform(0.5, 2.0)
            s.add_motor(jt, angle=(lambda t, w=w: 0.3 * np.sin(w * t), lambda t, w=w: 0.3 * w * np.cos(w * t),
                                   lambda t, w=w: -0.3 * w * w * np.sin(w * t)))
        elif jt.kind in ("revolute", "cylindrical"):
            s.add_rotational_spring_damper(jt, stiffness=rng.uniform(1, 10), damping=rng.uniform(0, 1),
                                           angle0=rng.uniform(-1, 1))
        if jt.kind in ("prismatic", "cylindrical") and rng.random() < 0.7:
            s.add_motor(jt, displacement=lambda t: 0.1 * t * t)
    for k in range(3):
        bi, bj = (s.ground if k == 0 else bodies[k - 1]), bodies[-1 - k]
        s.add_spring_damper(bi, rng.normal(size=3), bj, rng.normal(size=3), stiffness=rng.uniform(1, 50),
                            damping=rng.uniform(0, 2), free_length=(0.0 if k == 2 else None))
    s.add_force(bodies[1], lambda t, state: np.array([np.cos(t), 1.0, -0.5]), point=rng.normal(size=3))
    s.add_force(bodies[2], lambda t, state: np.array([0.0, 0.2, t]))
    s.add_torque(bodies[-1], lambda t, state: np.array([0.1, -0.2, 0.3 * np.sin(t)]))
    return s


def _random_state(system: System, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = len(system.bodies)
    y = np.array(system._y, dtype=float)
    y[: 3 * n] = rng.normal(size=3 * n)
    y[3 * n : 7 * n] = np.concatenate([_unit(rng, 4) for _ in range(n)])
    y[7 * n :] = rng.normal(size=6 * n)
    return y


def _close(a, b, rel=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = max(1.0, float(np.max(np.abs(b))) if b.size else 1.0)
    assert a.shape == b.shape
    assert float(np.max(np.abs(a - b))) <= rel * scale if b.size else True


@pytest.mark.parametrize("seed", range(12))
def test_the_compiled_rows_forces_and_solve_agree_with_the_numpy_evaluation(seed):
    s = random_system(seed)
    eng = s._engine().workspace()
    kc = eng.compiled
    assert kc is not None
    model = _Dynamics(s, eng, stabilization="projection", baumgarte=1.0, position_tol=1e-10)
    y = _random_state(s, seed + 100)
    t = 0.37 + 0.1 * seed
    At, Y, Phi, gam = eng.table(t, y, level=2)
    C, D, Ct, gamma = eng.constraint_rows(t, Y, Phi, gam, level=2)
    Q = eng.applied(t, y, At, Y, Phi, model._state)
    kc.select(None)
    kc.evaluate(t, y, 2)
    assert kc.applied(t, y, model._loads) == -1
    _close(kc.C, C)
    _close(kc.dense_jacobian(), D)
    _close(kc.Ct, Ct)
    _close(kc.gamma, gamma)
    _close(kc.Q, Q)
    # the augmented equations (Eq. 8.109): accelerations and multipliers, with the independent rows the rank
    # analysis keeps (where a random state makes some dependent)
    analyze_rank(eng, t, y)
    a, lam = eng.solve(t, D, Q, gamma)
    kc.select(eng.keep)
    kc.evaluate(t, y, 2)
    kc.applied(t, y, model._loads)
    x = np.zeros(6 * eng.n)
    kc.lam[:] = 0.0
    assert kc.solve(0, kc.Q, kc.gamma, x) == 0
    assert kc.tree_now.sec_rows.size > 0 or eng.keep is not None  # (loops: closed by the Schur block)
    _close(x, a, 1e-10)
    _close(kc.lam, lam, 1e-10)
    # the whole right-hand side, compiled and numpy
    f_compiled = model.rhs(t, y)
    model.kc = None
    f_numpy = model.rhs(t, y)
    _close(f_compiled, f_numpy, 1e-10)


@pytest.mark.parametrize("seed", [0, 3, 5])
def test_the_solve_is_exact_on_the_residual_of_the_augmented_equations(seed):
    # independent of the numpy path: [[M, D^T], [D, 0]] [a; lam] - [Q; gamma] vanishes to round-off (relative
    # to the terms' sizes; these states keep the multipliers below about 2e3, so a few ulp of them)
    s = random_system(seed, n_bodies=8, loops=1)
    eng = s._engine().workspace()
    kc = eng.compiled
    y = _random_state(s, 7)
    analyze_rank(eng, 0.2, y)
    kc.select(eng.keep)
    kc.evaluate(0.2, y, 2)
    kc.applied(0.2, y, _Dynamics(s, eng, stabilization="projection", baumgarte=1.0, position_tol=1e-10)._loads)
    x = np.zeros(6 * eng.n)
    kc.lam[:] = 0.0
    assert kc.solve(0, kc.Q, kc.gamma, x) == 0
    D = kc.dense_jacobian(eng.keep)
    lam = kc.lam if eng.keep is None else kc.lam[eng.keep]
    gamma = kc.gamma if eng.keep is None else kc.gamma[eng.keep]
    M = eng.M
    r1 = M @ x + D.T @ lam - kc.Q
    r2 = D @ x - gamma
    assert np.max(np.abs(r1)) <= 1e-12 * max(1.0, np.max(np.abs(kc.Q)), np.max(np.abs(D.T @ lam)))
    assert np.max(np.abs(r2)) <= 1e-12 * max(1.0, np.max(np.abs(gamma)), np.max(np.abs(D)) * np.max(np.abs(x)))


def test_a_tree_without_loops_has_no_secondary_rows_and_every_node_before_its_parent():
    s = pendulum_chain(7)
    kc = s._engine().workspace().compiled
    tr = kc.tree(None)
    assert tr.sec_rows.size == 0
    assert tr.order_size.size == 14  # 7 bodies, 7 joints
    parents = tr.order_parent
    assert np.all((parents == -1) | (parents > np.arange(parents.size)))
    assert int(np.count_nonzero(parents == -1)) == 1  # one tree, rooted at the ground joint


@pytest.mark.parametrize("n_links, rtol", [(3, 1e-7), (10, 1e-10)])
def test_the_compiled_step_loop_takes_the_interpreted_loops_steps(monkeypatch, n_links, rtol):
    s = pendulum_chain(n_links, tilt=0.5)
    s.assemble()
    tt = np.linspace(0.0, 2.0, 61)
    a = s.simulate(tt, rtol=rtol, atol=rtol / 100)
    monkeypatch.setattr(simulate_module, "_run_compiled", lambda *args, **kw: None)
    b = s.simulate(tt, rtol=rtol, atol=rtol / 100)
    assert a.n_steps == b.n_steps
    assert abs(a.n_rhs - b.n_rhs) <= 0.01 * b.n_rhs  # (a projection at a round-off boundary may differ by one)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.v, b.v, rtol=0, atol=1e-11)
    np.testing.assert_allclose(a.residual_position, b.residual_position, rtol=0, atol=1e-12)


def test_three_thousand_free_bodies_evaluate_without_a_dense_matrix():
    import tracemalloc

    n = 3000
    s = System(gravity=(0.0, 0.0, -9.81))
    rng = np.random.default_rng(0)
    for k in range(n):
        s.add_body(f"b{k}", mass=1.0, inertia=(0.1, 0.2, 0.3), position=rng.normal(size=3),
                   omega_body=rng.normal(size=3))
    tracemalloc.start()
    try:
        eng = s._engine()
        model = _Dynamics(s, eng.workspace(), stabilization="projection", baumgarte=1.0, position_tol=1e-10)
        f = model.rhs(0.0, np.array(s._y))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert model.kc is not None and np.all(np.isfinite(f))
    # linear: a few kB per body (a dense 18000 x 18000 mass matrix alone would be 2.6 GB)
    assert peak < 20_000 * n
