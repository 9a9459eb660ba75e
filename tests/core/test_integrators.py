"""Tests of core.integrators on models with closed-form solutions.

Oracles: the harmonic oscillator's exact solution and energy, the
convergence order of every fixed-step method, and a finite-time blow-up
(y' = y**2) for the divergence error.
"""

from __future__ import annotations

import math
import re
from dataclasses import FrozenInstanceError

import numpy as np
import pytest

from rigidlab.core import integrators as itg


class Oscillator:
    """q'' = -w**2 q as a first-order system, with exact split flows."""

    state_size = 2

    def __init__(self, w: float = 1.3):
        self.w = w
        # H = p^2/2 (drift) + w^2 q^2/2 (kick): both flows are exact.
        self.split_flows = (self._kick, self._drift)

    def rhs(self, t, y):
        return np.array([y[1], -self.w**2 * y[0]])

    def invariants(self, ys):
        ys = np.asarray(ys)
        return {"energy": 0.5 * ys[..., 1] ** 2 + 0.5 * self.w**2 * ys[..., 0] ** 2}

    def exact(self, y0, t):
        q0, p0 = y0
        c, s = math.cos(self.w * t), math.sin(self.w * t)
        return np.array([q0 * c + p0 / self.w * s, -q0 * self.w * s + p0 * c])

    def to_split_state(self, y):
        return (float(y[0]), float(y[1]))

    def from_split_state(self, z):
        return np.array(z)

    def _kick(self, z, h):
        return (z[0], z[1] - h * self.w**2 * z[0])

    def _drift(self, z, h):
        return (z[0] + h * z[1], z[1])


class Forced:
    """y' = cos(t): checks that the time argument reaches the rhs."""

    state_size = 1

    def rhs(self, t, y):
        return np.array([math.cos(t)])


class BlowUp:
    """y' = y**2 with y(0) = 1 blows up at t = 1."""

    state_size = 1

    def rhs(self, t, y):
        with np.errstate(over="ignore", invalid="ignore"):
            return y**2


Y0 = np.array([1.0, 0.4])


def _error(method, dt, t_end=2.0):
    model = Oscillator()
    run = itg.integrate(model, Y0, (0.0, t_end), method=method, dt=dt)
    return float(np.max(np.abs(run.states[-1] - model.exact(Y0, t_end))))


@pytest.mark.parametrize(
    ("method", "dt"),
    [("rk4", 0.1), ("midpoint", 0.1), ("splitting", 0.1), ("splitting4", 0.1), ("splitting6", 0.25),
     ("splitting8", 0.5)],
)
def test_convergence_order(method, dt):
    # Halving the step divides the global error by ~2**k. The observed
    # exponent differs from k by higher-order terms of relative size O(dt);
    # 0.25 on log2 separates order k from k +- 1 at these steps while
    # errors stay far above round-off (>= 2e-12 against ~1e-15).
    k = itg.METHOD_ORDERS[method]
    e = [_error(method, dt / 2**i) for i in range(3)]
    assert e[-1] > 2e-12
    rates = [math.log2(e[i] / e[i + 1]) for i in range(2)]
    assert all(abs(r - k) < 0.25 for r in rates), (method, e, rates)


def test_rk4_uses_time_argument():
    # y' = cos t integrates to sin t; RK4 with dt = 0.01 has error ~ dt^4 = 1e-8.
    run = itg.integrate(Forced(), np.zeros(1), (0.0, 3.0), method="rk4", dt=0.01)
    assert abs(run.states[-1, 0] - math.sin(3.0)) < 1e-8
    assert run.n_rhs == 4 * run.n_steps


def test_symplectic_methods_bound_energy_error():
    # Over 1000 periods, RK4's energy error grows linearly (dissipative)
    # while the symplectic methods oscillate within an O(dt^k) band.
    model = Oscillator()
    T = 1000 * 2 * math.pi / model.w
    for method in ("midpoint", "splitting"):
        run = itg.integrate(model, Y0, (0.0, T), method=method, dt=0.2, save_every=100)
        e = model.invariants(run.states)["energy"]
        # Midpoint conserves this quadratic energy exactly (round-off,
        # ~1e-16 per step over 3.7e4 steps with random-walk growth); the
        # Strang splitting conserves a modified energy, within O(dt^2) = 4e-2.
        bound = 1e-12 if method == "midpoint" else 0.05
        assert np.max(np.abs(e - e[0])) / e[0] < bound
        first, last = np.ptp(e[: len(e) // 2]), np.ptp(e[len(e) // 2 :])
        if method == "splitting":
            assert last < 1.5 * first  # no secular growth
    run = itg.integrate(model, Y0, (0.0, T), method="rk4", dt=0.2, save_every=100)
    e = model.invariants(run.states)["energy"]
    assert e[-1] < 0.95 * e[0]  # RK4 damps the oscillator: ~10% here, a visible drift


def test_trajectory_is_frozen_and_inputs_untouched():
    y0 = Y0.copy()
    run = itg.integrate(Oscillator(), y0, (0.0, 1.0), method="rk4", dt=0.1, save_every=3)
    np.testing.assert_array_equal(y0, Y0)
    assert run.t.shape == (5,) and run.states.shape == (5, 2)  # steps 0, 3, 6, 9, 10
    np.testing.assert_allclose(run.t, [0.0, 0.3, 0.6, 0.9, 1.0], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="read-only"):
        run.states[0, 0] = 1.0
    with pytest.raises(FrozenInstanceError):
        run.method = "x"  # type: ignore[misc]
    assert set(run.drift.max_abs) == {"energy"}
    assert "energy" in str(run.drift)


def test_steps_are_pure():
    model = Oscillator()
    for name, step in itg.FIXED_STEP_METHODS.items():
        y = Y0.copy()
        y1 = step(model, y, 0.1)
        np.testing.assert_array_equal(y, Y0, err_msg=name)
        # one step agrees with integrate() over one step
        run = itg.integrate(model, Y0, (0.0, 0.1), method=name, dt=0.1)
        np.testing.assert_allclose(run.states[-1], y1, rtol=0, atol=1e-15, err_msg=name)


@pytest.mark.parametrize("method", itg.ADAPTIVE_METHODS)
def test_adaptive_wrappers(method):
    # Tolerances rtol=1e-10, atol=1e-12 give a global error of ~1e-8 over
    # two periods (error accumulates over ~100 steps; LSODA is the loosest).
    model = Oscillator()
    t_eval = np.linspace(0.0, 10.0, 11)
    run = itg.integrate(model, Y0, (0.0, 10.0), method=method, rtol=1e-10, atol=1e-12, t_eval=t_eval)
    assert run.states.shape == (11, 2) and run.n_steps > 0 and run.n_rhs > run.n_steps
    ref = np.array([model.exact(Y0, t) for t in t_eval])
    assert np.max(np.abs(run.states - ref)) < 1e-7


def test_divergence_error_names_step_and_time():
    with pytest.raises(itg.DivergenceError, match=r"non-finite state at step \d+ \(t=1\.0\d*"):
        itg.integrate(BlowUp(), np.ones(1), (0.0, 2.0), method="rk4", dt=1e-3)


class NotANumber:
    """y'' = -y until ``t_nan``, then a NaN derivative (a force law that fails there)."""

    state_size = 2

    def __init__(self, t_nan: float, *, project: bool = False):
        self.t_nan = t_nan
        if project:
            self.project = lambda t, y: y

    def rhs(self, t, y):
        return np.array([y[1], math.nan if t >= self.t_nan else -y[0]])


@pytest.mark.parametrize("project", [False, True])
@pytest.mark.parametrize("method", itg.ADAPTIVE_METHODS)
@pytest.mark.parametrize("t_nan", [0.0, 0.5])
def test_adaptive_run_with_a_nan_derivative_is_divergence(method, t_nan, project):
    """A NaN derivative at the start gave DOP853 and RK45 a NaN first step, after which they looped at t = nan
    (ten million evaluations); later, they shrank the step to the spacing of floats. Now DivergenceError names
    the time of the first non-finite derivative: a trial stage at or after t_nan, before the next step ends."""
    if project and method == "LSODA":
        pytest.skip("LSODA refuses a model with project")
    with pytest.raises(itg.DivergenceError, match=r"run diverged: the model's right-hand side returned a "
                                                  r"non-finite derivative at t=(?P<t>\S+) \(at a finite state\)") as info:
        # (max_steps: the old loop at t = nan ends as an IntegrationError in seconds instead of minutes)
        itg.integrate(NotANumber(t_nan, project=project), Y0, (0.0, 2.0), method=method, max_steps=100_000)
    assert info.value.t >= t_nan and (info.value.t == 0.0 if t_nan == 0.0 else info.value.t < 1.0)
    assert f"t={info.value.t:.6g}" in str(info.value)


def test_invariant_blow_up_is_divergence():
    # Explicit steps far beyond the stability limit (w dt = 3.9 > 2.83 for
    # RK4) make the energy grow geometrically; the run stops with a clear error.
    with pytest.raises(itg.DivergenceError, match=r"invariant 'energy' drifted .* at step \d+ \(t="):
        itg.integrate(Oscillator(w=1.3), Y0, (0.0, 100.0), method="rk4", dt=3.0)
    assert issubclass(itg.DivergenceError, ValueError)


def test_adaptive_failure_is_integration_error():
    with pytest.raises(itg.IntegrationError, match=r"RK45 failed at step \d+ \(t=(0\.99\d*|1)\)"):
        itg.integrate(BlowUp(), np.ones(1), (0.0, 2.0), method="RK45")


def test_midpoint_nonconvergence_message():
    # Fixed-point iteration contracts only for w dt < 2; w dt = 13 diverges.
    with pytest.raises(itg.IntegrationError, match=r"step 1: implicit midpoint: .* did not converge"):
        itg.integrate(Oscillator(w=1.3), Y0, (0.0, 20.0), method="midpoint", dt=10.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(method="euler", dt=0.1), r"method: expected one of .* got 'euler'"),
        (dict(method="rk4"), r"dt: method 'rk4' needs a finite step dt > 0, got None"),
        (dict(method="rk4", dt=-1.0), r"dt: .* got -1.0"),
        (dict(method="rk4", dt=0.1, t_eval=[0.5]), r"t_eval: applies to adaptive methods only"),
        (dict(method="rk4", dt=0.1, save_every=0), r"save_every: expected an integer >= 1, got 0"),
        (dict(method="DOP853", dt=0.1), r"dt: adaptive method 'DOP853' takes rtol/atol"),
        (dict(method="RK45", rtol=0.0), r"rtol, atol: expected > 0"),
        (dict(method="RK45", t_eval=[3.0]), r"t_eval: expected sorted 1-D times within t_span"),
        (dict(method="rk4", dt=0.1, max_drift=0), r"max_drift: expected a real number > 0 \(inf: never stop\), got 0"),
    ],
)
def test_argument_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        itg.integrate(Oscillator(), Y0, (0.0, 1.0), **kwargs)


def test_state_and_span_errors():
    with pytest.raises(ValueError, match=r"state0: expected shape \(2,\), got \(3,\)"):
        itg.integrate(Oscillator(), np.zeros(3), (0.0, 1.0), dt=0.1)
    with pytest.raises(ValueError, match=r"state0: expected finite values"):
        itg.integrate(Oscillator(), np.array([np.nan, 0.0]), (0.0, 1.0), dt=0.1)
    with pytest.raises(ValueError, match=r"t_span: expected finite t0 < t1, got \(1.0, 0.0\)"):
        itg.integrate(Oscillator(), Y0, (1.0, 0.0), dt=0.1)
    with pytest.raises(ValueError, match=r"t_span: expected \(t0, t1\)"):
        itg.integrate(Oscillator(), Y0, 1.0, dt=0.1)


def test_splitting_needs_split_model():
    with pytest.raises(ValueError, match=r"method 'splitting4' needs a model with split_flows.*got Forced"):
        itg.integrate(Forced(), np.zeros(1), (0.0, 1.0), method="splitting4", dt=0.1)


def test_watched_invariants_do_not_stop_a_run():
    # y' = y grows e-fold per unit time; its "size" invariant is only watched
    # (conserves_invariants = False), so it is reported, not treated as a blow-up.
    class Growth:
        state_size = 1
        conserves_invariants = False

        def rhs(self, t, y):
            return y

        def invariants(self, ys):
            return {"size": np.abs(np.asarray(ys)[..., 0])}

    run = itg.integrate(Growth(), np.ones(1), (0.0, 3.0), method="rk4", dt=0.01)
    assert run.drift.max_rel["size"] == pytest.approx(math.e**3 - 1, rel=1e-8)  # RK4 error ~1e-9


def test_unstable_splitting_run_is_divergence():
    # The leapfrog (Strang) splitting of the oscillator is stable only for
    # w dt < 2; at w dt = 3.9 the energy grows geometrically and the run
    # reports the first recorded step where it blew up (or became non-finite).
    with pytest.raises(itg.DivergenceError, match=r"run diverged: .* at step \d+ \(t="):
        itg.integrate(Oscillator(w=1.3), Y0, (0.0, 300.0), method="splitting", dt=3.0)


# ------------------------------------------------------------ fuzz findings
STEPS = [itg.rk4_step, itg.implicit_midpoint_step, itg.splitting_step, itg.splitting4_step,
         itg.splitting6_step, itg.splitting8_step]


@pytest.mark.parametrize("step", STEPS, ids=lambda f: f.__name__)
@pytest.mark.parametrize(
    ("dt", "match"),
    [
        (math.nan, r"dt: expected a finite step dt > 0, got nan"),
        (math.inf, r"dt: expected a finite step dt > 0, got inf"),
        (-math.inf, r"dt: expected a finite step dt > 0, got -inf"),
        (0.0, r"dt: expected a finite step dt > 0, got 0\.0"),
        (-0.1, r"dt: expected a finite step dt > 0, got -0\.1"),
        (True, r"dt: expected a finite step dt > 0, got True"),
        ("0.1", r"dt: expected a finite step dt > 0, got '0\.1'"),
        (0.1 + 0j, r"dt: expected real numbers, got complex"),
    ],
)
def test_step_functions_refuse_bad_dt(step, dt, match):
    # NaN and inf gave NaN states or a math domain error, zero and negative
    # steps were taken silently.
    with pytest.raises(ValueError, match=match):
        step(Oscillator(), Y0, dt)


@pytest.mark.parametrize("step", STEPS, ids=lambda f: f.__name__)
def test_step_functions_refuse_bad_states_and_times(step):
    with pytest.raises(ValueError, match=r"state: expected finite values, got nan at index 1"):
        step(Oscillator(), np.array([0.0, np.nan]), 0.1)
    with pytest.raises(ValueError, match=r"state: expected finite values, got inf at index 0"):
        step(Oscillator(), np.array([np.inf, 0.0]), 0.1)
    with pytest.raises(ValueError, match=r"state: expected shape \(2,\), got \(3,\)"):
        step(Oscillator(), np.zeros(3), 0.1)
    with pytest.raises(ValueError, match=r"state: expected real numbers, got complex"):
        step(Oscillator(), Y0 + 0j, 0.1)
    with pytest.raises(ValueError, match=r"t: expected a finite time, got nan"):
        step(Oscillator(), Y0, 0.1, t=math.nan)


def test_step_functions_accept_numpy_scalars_and_do_not_mutate():
    y = Y0.copy()
    a = itg.rk4_step(Oscillator(), y, np.float32(0.25), t=np.int64(1))
    b = itg.rk4_step(Oscillator(), y, 0.25, t=1.0)
    np.testing.assert_allclose(a, b, rtol=0, atol=0)
    np.testing.assert_array_equal(y, Y0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(max_iter=0), r"max_iter: expected an integer >= 1, got 0"),
        (dict(max_iter=-3), r"max_iter: expected an integer >= 1, got -3"),
        (dict(max_iter=2.5), r"max_iter: expected an integer >= 1, got 2\.5"),
        (dict(max_iter=True), r"max_iter: expected an integer >= 1, got True"),
        (dict(tol=math.nan), r"tol: expected a finite tolerance >= 0, got nan"),
        (dict(tol=-1e-12), r"tol: expected a finite tolerance >= 0, got -1e-12"),
        (dict(tol=math.inf), r"tol: expected a finite tolerance >= 0, got inf"),
    ],
)
def test_midpoint_options_are_validated(kwargs, match):
    # max_iter=0 raised UnboundLocalError; tol=nan iterated max_iter times.
    with pytest.raises(ValueError, match=match):
        itg.implicit_midpoint_step(Oscillator(), Y0, 0.1, **kwargs)


def test_midpoint_with_one_iteration_or_zero_tolerance():
    # max_iter=1 is a valid (if loose) request: one fixed-point update, then
    # the non-convergence error; tol=0 iterates until the update stagnates.
    with pytest.raises(itg.IntegrationError, match=r"did not converge in 1 iterations"):
        itg.implicit_midpoint_step(Oscillator(), Y0, 0.1, max_iter=1)
    y = itg.implicit_midpoint_step(Oscillator(), Y0, 0.1, tol=0.0)
    assert np.all(np.isfinite(y))


@pytest.mark.parametrize(
    ("span", "dt", "count"),
    [((0.0, 1e3), 1e-12, r"1e\+15"), ((0.0, 1e300), 1.0, r"1e\+300"), ((0.0, 1.0), 1e-320, r"inf")],
)
def test_runs_beyond_max_steps_are_refused_up_front(span, dt, count):
    # These used to allocate the whole run (MemoryError) or overflow range().
    with pytest.raises(ValueError, match=rf"dt: t_span .* needs {count} steps, more than max_steps=10000000 "
                                         r"\(core.integrators.MAX_STEPS = 10000000\)"):
        itg.integrate(Oscillator(), Y0, span, method="rk4", dt=dt)


def test_max_steps_keyword_moves_the_limit():
    assert itg.MAX_STEPS == 10_000_000
    with pytest.raises(ValueError, match=r"needs 200 steps, more than max_steps=100"):
        itg.integrate(Oscillator(), Y0, (0.0, 2.0), method="rk4", dt=0.01, max_steps=100)
    run = itg.integrate(Oscillator(), Y0, (0.0, 2.0), method="rk4", dt=0.01, max_steps=200)
    assert run.n_steps == 200
    for bad in (0, 2.5, True, None):
        with pytest.raises(ValueError, match=r"max_steps: expected an integer >= 1"):
            itg.integrate(Oscillator(), Y0, (0.0, 2.0), method="rk4", dt=0.01, max_steps=bad)


def test_adaptive_runs_stop_at_max_steps_evaluations():
    with pytest.raises(itg.IntegrationError, match=r"RK45 stopped at t=.* before t1=1000: it used max_steps=50 "
                                                   r"right-hand-side evaluations"):
        itg.integrate(Oscillator(), Y0, (0.0, 1000.0), method="RK45", max_steps=50)
    run = itg.integrate(Oscillator(), Y0, (0.0, 1.0), method="RK45", max_steps=10_000)
    assert run.n_rhs <= 10_000


@pytest.mark.parametrize("method", itg.ADAPTIVE_METHODS)
@pytest.mark.parametrize(("t1", "tolerances"), [(1e300, {}), (1e7, dict(rtol=1e-13, atol=1e-13))])
def test_adaptive_runs_that_cannot_end_within_max_steps_stop_at_their_first_pace_check(method, t1, tolerances):
    """A horizon of 1e300 s, or 1e7 s (1.6e6 periods) at rtol 1e-13, ran until max_steps (ten million
    evaluations: minutes here, hours for a multibody model); the pace after PACE_CHECK_CALLS says so at once."""
    assert itg.PACE_CHECK_CALLS == 10_000 and itg.PACE_MARGIN == 2.0
    model = Oscillator()
    with pytest.raises(itg.IntegrationError, match=rf"{method} stopped at t=\S+ before t1={re.escape(f'{t1:g}')}: at its pace so far "
                                                   r"\(10,000 right-hand-side evaluations for \S+ % of the time "
                                                   r"span\) it needs about \S+, more than 2 x max_steps=10000000"):
        itg.integrate(model, Y0, (0.0, t1), method=method, **tolerances)
    # a run within its budget is not stopped by the check: 1000 s at rtol 1e-10 takes about 1e5 evaluations
    run = itg.integrate(model, Y0, (0.0, 1000.0), method="DOP853", rtol=1e-10, atol=1e-12)
    assert run.n_rhs > 4 * itg.PACE_CHECK_CALLS
    np.testing.assert_allclose(run.states[-1], model.exact(Y0, 1000.0), atol=1e-6)


def test_the_long_run_check_of_compiled_loops_stops_a_run_beyond_its_budget():
    """Compiled loops count their own evaluations and call _CountingModel._warn_long at LONG_RUN_CALLS: a run
    that at that pace needs more than PACE_MARGIN x max_steps stops there with an IntegrationError."""
    counter = itg._CountingModel(Oscillator(), max_calls=10_000_000, span=(0.0, 1e7))
    with pytest.warns(RuntimeWarning, match="this run has used 1,000,000 right-hand sides"):
        with pytest.raises(itg.IntegrationError, match=r"the run stopped at t=1000 before t1=1e\+07: at its pace so far "
                                                       r"\(1,000,000 right-hand-side evaluations for 0.01 % of the "
                                                       r"time span\) it needs about 1e\+10") as info:
            counter._warn_long(1000.0)
    assert type(info.value) is itg.IntegrationError and info.value.t == 1000.0
    # at a pace that ends within the budget it only warns
    with pytest.warns(RuntimeWarning, match="this run has used 1,000,000 right-hand sides"):
        itg._CountingModel(Oscillator(), max_calls=10_000_000, span=(0.0, 2e4))._warn_long(2000.0)


@pytest.mark.parametrize("method", itg.ADAPTIVE_METHODS)
def test_rtol_below_round_off_is_refused(method):
    """scipy raises an rtol below 100 machine epsilons to that value (with a warning); asked for 1e-16 over a
    long span, the run crawled until max_steps."""
    assert itg.MIN_RTOL == 100.0 * np.finfo(float).eps
    with pytest.raises(ValueError, match=r"rtol: expected a relative tolerance >= core.integrators.MIN_RTOL = "
                                         r"2.22e-14 \(100 machine epsilons: .*\), got 1e-16"):
        itg.integrate(Oscillator(), Y0, (0.0, 1e6), method=method, rtol=1e-16)
    run = itg.integrate(Oscillator(), Y0, (0.0, 1.0), method=method, rtol=itg.MIN_RTOL, atol=1e-14)
    np.testing.assert_allclose(run.states[-1], Oscillator().exact(Y0, 1.0), atol=1e-9)


def test_integrate_refuses_bad_numbers():
    with pytest.raises(ValueError, match=r"t_span: expected finite t0 < t1, got \(0.0, nan\)"):
        itg.integrate(Oscillator(), Y0, (0.0, math.nan), dt=0.1)
    with pytest.raises(ValueError, match=r"t_span: expected finite t0 < t1, got \(-1e\+308, 1e\+308\)"):
        itg.integrate(Oscillator(), Y0, (-1e308, 1e308), dt=0.1)
    with pytest.raises(ValueError, match=r"dt: expected a finite step dt > 0 for method 'rk4', got True"):
        itg.integrate(Oscillator(), Y0, (0.0, 1.0), dt=True)
    with pytest.raises(ValueError, match=r"max_drift: expected a real number > 0 \(inf: never stop\), got nan"):
        itg.integrate(Oscillator(), Y0, (0.0, 1.0), dt=0.1, max_drift=math.nan)
    # numpy scalars are numbers too (np.float32 was refused as a dt)
    run = itg.integrate(Oscillator(), Y0, (np.float32(0.0), np.int64(1)), dt=np.float32(0.25))
    assert run.n_steps == 4
    assert itg.integrate(Oscillator(), Y0, (0.0, 1.0), dt=0.1, max_drift=math.inf).n_steps == 10
