"""The ``model.project`` hook of core.integrators.integrate.

Oracle: a particle on the unit circle driven by a rotation (x' = w J x) whose
exact flow keeps |x| = 1; the projection x / |x| puts every recorded state
back on the circle, while the phase still follows the exact solution to the
integrator's accuracy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core import integrators as itg


class Circle:
    """x' = w J x on R^2 with the projection onto |x| = 1; counts projections."""

    state_size = 2

    def __init__(self, w: float = 2.0, *, with_projection: bool = True):
        self.w = w
        self.calls = 0
        self.times: list[float] = []
        if not with_projection:
            self.project = None

    def rhs(self, t, y):
        return self.w * np.array([-y[1], y[0]])

    def project(self, t, y):
        self.calls += 1
        self.times.append(float(t))
        return y / np.linalg.norm(y)

    def exact(self, t):
        return np.array([math.cos(self.w * t), math.sin(self.w * t)])


@pytest.mark.parametrize("method", ["rk4", "midpoint"])
def test_fixed_step_projects_after_every_step(method):
    model = Circle()
    run = itg.integrate(model, np.array([1.0, 0.0]), (0.0, 1.0), method=method, dt=0.05)
    assert model.calls == run.n_steps == 20
    np.testing.assert_allclose(model.times, np.linspace(0.05, 1.0, 20), rtol=0, atol=1e-14)
    norms = np.linalg.norm(run.states, axis=1)
    np.testing.assert_allclose(norms, 1.0, rtol=0, atol=4e-16)  # round-off of y / |y|


def test_fixed_step_without_hook_drifts():
    # rk4 on a rotation shrinks |x| by ~ (w dt)^6 / 144 per step: visible without the hook
    run = itg.integrate(Circle(with_projection=False), np.array([1.0, 0.0]), (0.0, 10.0), method="rk4", dt=0.1)
    assert abs(np.linalg.norm(run.states[-1]) - 1.0) > 1e-7


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_adaptive_projects_steps_and_dense_outputs(method):
    model = Circle()
    t_eval = np.linspace(0.0, 3.0, 31)
    run = itg.integrate(model, np.array([1.0, 0.0]), (0.0, 3.0), method=method, rtol=1e-10, atol=1e-12,
                        t_eval=t_eval)
    np.testing.assert_array_equal(run.t, t_eval)
    np.testing.assert_allclose(np.linalg.norm(run.states, axis=1), 1.0, rtol=0, atol=4e-16)
    exact = np.array([model.exact(t) for t in t_eval])
    # phase error at the solver's tolerance (the projection changes only the radius)
    np.testing.assert_allclose(run.states, exact, rtol=0, atol=1e-8)
    # one projection per accepted step plus one per output inside a step
    assert model.calls >= run.n_steps


def test_adaptive_without_t_eval_records_projected_steps():
    model = Circle()
    run = itg.integrate(model, np.array([1.0, 0.0]), (0.0, 2.0), method="DOP853", rtol=1e-6, atol=1e-9)
    assert run.t.size == run.n_steps + 1
    np.testing.assert_allclose(np.linalg.norm(run.states[1:], axis=1), 1.0, rtol=0, atol=4e-16)


@pytest.mark.parametrize("method", ["LSODA", "splitting"])
def test_methods_that_cannot_project_refuse(method):
    model = Circle()
    model.split_flows = ()
    model.to_split_state = model.from_split_state = lambda y: y
    kwargs = {"dt": 0.1} if method == "splitting" else {}
    with pytest.raises(ValueError, match="project"):
        itg.integrate(model, np.array([1.0, 0.0]), (0.0, 1.0), method=method, **kwargs)
