"""Constraint equations of core.multibody against finite differences, for every joint kind.

For random configurations (joints added in a random pose, then the state
moved off the constraints and given random velocities) the analytic terms
of System.evaluate are compared with numerical derivatives of the
constraint values C(q, t):

* ``C_q`` (m, 7n) against central differences in the 7n coordinates
  ``q = [R, p]`` (``C`` depends on ``p`` through ``A(p / |p|)``);
* ``D v + C_t`` against ``dC/dtau`` along the curve ``R(tau) = R + tau
  R_dot``, ``p(tau) = p * exp(tau omega_body / 2)``, ``t + tau`` (the motion
  with velocities ``v`` and zero Newton-Euler accelerations);
* ``gamma`` (the chapter's Q_d) against ``-d2C/dtau2`` along the same curve:
  with zero accelerations ``C_dd = D a - gamma = -gamma``, i.e. this checks
  ``gamma = -(C_q q_dot)_q q_dot - 2 C_qt q_dot - C_tt``.

Tolerances: central differences with h = 1e-6 have truncation ~h^2 |C'''|
~1e-12 and round-off ~eps |C| / h ~ 1e-10; the five-point second
difference with h = 1e-3 has truncation ~h^4 |C^(6)| / 90 ~ 1e-13 and
round-off ~ 16 eps |C| / (12 h^2) ~ 1e-9 for |C| ~ 1 (coordinates of a few
metres). The checks use 1e-8 (first derivatives) and 1e-7 (second).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rigidlab.core.multibody import JOINT_KINDS, System
from rigidlab.core.multibody._system import retract

SEED = 20240610


def _unit(rng):
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def _random_p(rng):
    p = rng.standard_normal(4)
    return p / np.linalg.norm(p)


def _two_bodies(rng, *, ground_i=False):
    system = System(gravity=(0.0, 0.0, -9.81))
    bodies = []
    for name in ("a", "b"):
        bodies.append(system.add_body(
            name, mass=1.0 + rng.random(), inertia=(0.4, 0.5, 0.6), position=rng.standard_normal(3),
            orientation=_random_p(rng)))
    i = system.ground if ground_i else bodies[0]
    return system, i, bodies[1]


def _joint(system, kind, i, j, rng):
    point = rng.standard_normal(3)
    if kind in ("fixed", "spherical"):
        return system.add_joint(kind, i, j, point=point)
    axis = _unit(rng)
    if kind == "universal":
        other = np.cross(axis, _unit(rng))
        return system.add_joint(kind, i, j, point=point, axis=axis, axis_j=other)
    return system.add_joint(kind, i, j, point=point, axis=axis)


def _scramble(system, rng, scale=0.05):
    """Move the state off the constraints by a random tangent step and give it random velocities."""
    n = len(system.bodies)
    state = system.state.displaced(dq=scale * rng.standard_normal(6 * n), dv=rng.standard_normal(6 * n) - system.state.v)
    system.set_state(state)


def _C(system, y, t):
    n = len(system.bodies)
    state = dataclasses.replace(system.state, t=t, q=y[: 7 * n], v=y[7 * n :])
    system.set_state(state)
    return np.array(system.evaluate(t=t).C)


def _curve(y, n, tau):
    dq = tau * y[7 * n :]
    return retract(y, n, dq)


def _check(system, t=0.3):
    n = len(system.bodies)
    y0 = np.concatenate([system.state.q, system.state.v])
    ev = system.evaluate(t=t)
    # C_q by central differences in the 7n coordinates
    h = 1e-6
    Cq = np.zeros_like(ev.C_q)
    for k in range(7 * n):
        yp, ym = y0.copy(), y0.copy()
        yp[k] += h
        ym[k] -= h
        Cq[:, k] = (_C(system, yp, t) - _C(system, ym, t)) / (2 * h)
    np.testing.assert_allclose(ev.C_q, Cq, rtol=0, atol=1e-8)
    # D v + C_t along the zero-acceleration curve
    dC = (_C(system, _curve(y0, n, h), t + h) - _C(system, _curve(y0, n, -h), t - h)) / (2 * h)
    np.testing.assert_allclose(ev.D @ y0[7 * n :] + ev.C_t, dC, rtol=0, atol=1e-8)
    # gamma = -C_dd along the same curve (five-point second difference)
    h2 = 1e-3
    c = [_C(system, _curve(y0, n, k * h2), t + k * h2) for k in (-2, -1, 0, 1, 2)]
    d2C = (-c[0] + 16 * c[1] - 30 * c[2] + 16 * c[3] - c[4]) / (12 * h2 * h2)
    np.testing.assert_allclose(ev.gamma, -d2C, rtol=0, atol=1e-7)
    return ev


@pytest.mark.parametrize("kind", sorted(JOINT_KINDS))
@pytest.mark.parametrize("ground_i", [False, True])
def test_joint_derivatives(kind, ground_i):
    rng = np.random.default_rng([SEED, sorted(JOINT_KINDS).index(kind), ground_i])
    for _ in range(2):
        system, i, j = _two_bodies(rng, ground_i=ground_i)
        joint = _joint(system, kind, i, j, rng)
        assert np.max(np.abs(system.evaluate().C)) < 1e-12  # added in the current configuration
        _scramble(system, rng)
        ev = _check(system)
        assert ev.C.shape == (JOINT_KINDS[kind],)
        assert np.max(np.abs(ev.C)) > 1e-4  # really off the constraints
        assert joint.kind == kind


def _motor_system(rng, kind):
    system, i, j = _two_bodies(rng)
    joint = _joint(system, kind, i, j, rng)
    return system, joint


@pytest.mark.parametrize(
    ("kind", "coordinate"),
    [("revolute", "angle"), ("cylindrical", "angle"), ("prismatic", "displacement"), ("cylindrical", "displacement")],
)
@pytest.mark.parametrize("rule", ["given", "complex step", "finite differences"])
def test_motor_derivatives(kind, coordinate, rule):
    rng = np.random.default_rng([SEED, 7, ["revolute", "cylindrical", "prismatic"].index(kind), len(rule)])
    system, joint = _motor_system(rng, kind)
    if rule == "given":
        f = (lambda t: 0.3 + 0.7 * t + 0.2 * np.sin(2 * t), lambda t: 0.7 + 0.4 * np.cos(2 * t),
             lambda t: -0.8 * np.sin(2 * t))
    elif rule == "complex step":
        f = lambda t: 0.3 + 0.7 * t + 0.2 * np.sin(2 * t)  # noqa: E731 - numpy accepts complex t
    else:
        f = lambda t: 0.3 + 0.7 * t + 0.2 * math.sin(2 * t)  # noqa: E731 - math.sin refuses complex t
    motor = system.add_motor(joint, **{coordinate: f})
    assert motor.derivatives == rule
    _scramble(system, rng, scale=0.02)
    ev = _check(system)
    assert np.any(ev.C_t != 0.0)


@pytest.mark.parametrize("f", [lambda t: np.sin(3 * t) + t**3, lambda t: np.exp(0.5 * t) * np.cos(t)])
def test_motor_function_derivative_rules(f):
    """The derivative rules of add_motor against the exact derivatives (complex step ~1e-12, differences ~1e-7)."""
    from rigidlab.core.multibody._drivers import driver_function

    ts = np.array([0.0, 0.37, 2.5, 11.0])
    cs, how = driver_function(f, "angle", 0.0)
    assert how == "complex step"
    fd_rule, how2 = driver_function(lambda t: float(np.real(f(t))), "angle", 0.0)
    assert how2 == "finite differences"
    for t in ts:
        # reference derivatives by complex step on a 1e-30 step for f' and 6th-order differences of f' for f''
        d1 = (f(complex(t, 1e-30))).imag / 1e-30
        h = 1e-3
        dd = [(f(complex(t + k * h, 1e-30))).imag / 1e-30 for k in (-3, -2, -1, 1, 2, 3)]
        d2 = (-dd[0] + 9 * dd[1] - 45 * dd[2] + 45 * dd[3] - 9 * dd[4] + dd[5]) / (60 * h)
        v, v1, v2 = cs(t)
        assert v == pytest.approx(float(np.real(f(t))), abs=1e-15 * (1 + abs(v)))
        assert v1 == pytest.approx(d1, rel=1e-13, abs=1e-13)
        assert v2 == pytest.approx(d2, rel=1e-9, abs=1e-9)
        w, w1, w2 = fd_rule(t)
        assert w1 == pytest.approx(d1, rel=1e-8, abs=1e-8)
        assert w2 == pytest.approx(d2, rel=1e-5, abs=1e-5)


def test_jacobians_of_a_mixed_system():
    """Several kinds at once (one batched evaluation per kind) and a spring: rows stay independent of order."""
    rng = np.random.default_rng([SEED, 99])
    system = System()
    bodies = [system.add_body(f"b{k}", mass=1.0, inertia=(0.3, 0.4, 0.5), position=rng.standard_normal(3),
                              orientation=_random_p(rng)) for k in range(4)]
    _joint(system, "revolute", system.ground, bodies[0], rng)
    _joint(system, "universal", bodies[0], bodies[1], rng)
    _joint(system, "cylindrical", bodies[1], bodies[2], rng)
    j = _joint(system, "prismatic", bodies[2], bodies[3], rng)
    system.add_motor(j, displacement=lambda t: 0.1 * t * t)
    system.add_spring_damper(bodies[0], rng.standard_normal(3), bodies[3], rng.standard_normal(3), stiffness=10.0,
                             damping=0.5)
    _scramble(system, rng, scale=0.02)
    _check(system)
