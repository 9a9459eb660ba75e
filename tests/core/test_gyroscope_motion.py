"""rigidlab.core.gyroscope.top_motion (constants once, evaluation per chunk) and fuzz findings of simulate.

Oracles: simulate itself (the closed form it had before, now routed through
TopMotion), the vectorized cubic-root bisection for the float one, and the
conservation of d1, d2 and the energy.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import rigidlab.core.gyroscope as gy
from rigidlab.core.gyroscope import RotorParams, invariants, simulate, top_motion

HEAVY = RotorParams(I=1.0, I3=0.8, mgl=2.0)
BALANCED = RotorParams(I=1.0, I3=0.6, mgl=0.0)
MOTIONS = [
    ("heavy looping", HEAVY, [0.3, 0.7, 0.1, 2.0, 0.0, 10.0], "closed_form"),
    ("heavy cusp", HEAVY, [0.0, 1.0, 0.0, 0.0, 0.0, 6.0], "closed_form"),
    ("balanced", BALANCED, [0.0, math.radians(30.0), 0.0, 0.5, 0.3, 40.0], "closed_form"),
    ("theta outside [0, pi]", HEAVY, [0.2, -0.9, 0.4, 0.5, 0.3, 8.0], "closed_form"),
    ("through the top pole", HEAVY, [0.0, 0.3, 0.0, 0.0, -2.0, 5.0], "closed_form"),
    ("sleeping top", HEAVY, [0.0, 0.0, 0.0, 0.0, 0.0, 30.0], "steady"),
    ("steady precession", BALANCED, [0.0, 0.8, 0.0, 0.0, 0.0, 12.0], "steady"),
]


@pytest.mark.parametrize(("name", "params", "state", "method"), MOTIONS, ids=[m[0] for m in MOTIONS])
def test_top_motion_at_equals_simulate_chunk_by_chunk(name, params, state, method):
    motion = top_motion(params, state)
    assert motion.method == method
    for k in range(5):  # the scene's 2 s chunks of 481 samples
        t = np.linspace(2.0 * k, 2.0 * (k + 1), 481)
        got = motion.at(t)
        want = simulate(params, state, t)
        assert got.method == want.method == method
        np.testing.assert_array_equal(got.t, want.t)
        np.testing.assert_array_equal(got.angles, want.angles)
        np.testing.assert_array_equal(got.rates, want.rates)
        assert not (got.angles.flags.writeable or got.rates.flags.writeable or got.t.flags.writeable)
        inv = invariants(params, np.concatenate([got.angles, got.rates], axis=-1))
        inv0 = invariants(params, np.asarray(state, dtype=float))
        for a, b in ((inv.d1, inv0.d1), (inv.d2, inv0.d2), (inv.energy, inv0.energy)):
            np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * (1.0 + abs(float(b))))


def test_top_motion_is_a_frozen_record_of_the_motion():
    motion = top_motion(HEAVY, [0.3, 0.7, 0.1, 2.0, 0.0, 10.0])
    assert motion.params is HEAVY
    assert motion.state0.shape == (6,) and not motion.state0.flags.writeable
    assert motion.period == pytest.approx(gy.nutation(HEAVY, motion.state0).period, rel=1e-15)
    with pytest.raises(dataclasses.FrozenInstanceError):
        motion.method = "steady"
    assert top_motion(HEAVY, [0.0, 0.0, 0.0, 0.0, 0.0, 30.0]).period == math.inf
    # theta is mapped into [0, pi] once, as simulate does
    flipped = top_motion(HEAVY, [0.2, -0.9, 0.4, 0.5, 0.3, 8.0]).state0
    np.testing.assert_allclose(flipped, [0.2 + math.pi, 0.9, 0.4 + math.pi, 0.5, -0.3, 8.0], rtol=0, atol=1e-15)


def test_top_motion_validates_like_simulate():
    good = [0.3, 0.7, 0.1, 2.0, 0.0, 10.0]
    motion = top_motion(HEAVY, good)
    with pytest.raises(ValueError, match=r"params: expected a RotorParams, got dict"):
        top_motion({"I": 1.0}, good)
    with pytest.raises(ValueError, match=r"state0: expected shape \(6,\), got \(2, 6\)"):
        top_motion(HEAVY, [good, good])
    with pytest.raises(ValueError, match=r"state0: expected finite values"):
        top_motion(HEAVY, [0.3, np.nan, 0.1, 2.0, 0.0, 10.0])
    with pytest.raises(ValueError, match=r"state0: expected real numbers, got complex"):
        top_motion(HEAVY, np.asarray(good) + 0j)
    with pytest.raises(ValueError, match=r"t: expected non-decreasing times \(s\), got t\[2\] = 1.0 after t\[1\] = 2.0"):
        motion.at([0.0, 2.0, 1.0])
    with pytest.raises(ValueError, match=r"t: expected a non-empty 1-D array of output times \(s\), got shape \(0,\)"):
        motion.at([])
    with pytest.raises(ValueError, match=r"t: expected finite times \(s\), got t\[1\] = inf"):
        motion.at([0.0, np.inf])


def test_float_bisection_equals_the_vectorized_one():
    # One state takes a Python-float loop with the same operations; it must
    # give the same root, bit for bit, as the vectorized bisection.
    rng = np.random.default_rng(77)
    for _ in range(500):
        c = rng.normal(size=4) * 10.0 ** rng.integers(-3, 3, size=4)
        lo, hi = -abs(rng.normal()), abs(rng.normal())
        positive = c[0] + lo * (c[1] + lo * (c[2] + lo * c[3])) >= 0.0
        one = gy._cubic_root_bisect(*map(np.float64, c), np.float64(lo), np.float64(hi), positive_at_lo=positive)
        batch = gy._cubic_root_bisect(*(np.array([v]) for v in c), np.array([lo]), np.array([hi]),
                                      positive_at_lo=positive)
        assert one == batch[0] or (np.isnan(one) and np.isnan(batch[0]))


# ------------------------------------------------------------ fuzz findings
S0 = [0.0, 1.0, 0.0, 0.1, 0.0, 20.0]
ROTOR = RotorParams(1.0, 0.5, 0.2)


@pytest.mark.parametrize("m", [1e300, 1e150, 1e20])
def test_huge_torques_are_refused_up_front(m):
    # 1e300 raised AttributeError; 1e20 ran for minutes.
    with pytest.raises(ValueError, match=r"torques: the numerical path \(applied torques\) would turn the rotor "
                                         r"through about .* rad by t=1 s .* more than max_steps=10000000 "
                                         r"right-hand-side evaluations .* smaller torques"):
        simulate(ROTOR, S0, np.linspace(0.0, 1.0, 5), torques=(m, 0.0, 0.0))


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_torques_too_large_for_float64_steps_name_torques():
    # With the limit lifted, the run fails inside scipy; the message says why.
    with pytest.raises(ValueError, match=r"torques: the numerical integration failed after t=0 s \(Required step size "
                                         r"is less than spacing between numbers.\); angular accelerations 1\.4.e\+300 "
                                         r"rad/s\^2 .* the applied torques are too large for this rotor"):
        simulate(ROTOR, S0, np.linspace(0.0, 1.0, 5), torques=(1e300, 0.0, 0.0), max_steps=10**400)


def test_huge_time_spans_are_refused_and_the_budget_is_kept():
    # gravity (mgl = 0.2) and the spin, not the torque of 0.1 N m, make this run long
    with pytest.raises(ValueError, match=r"t: the numerical path .* by t=1e\+09 s"):
        simulate(ROTOR, S0, [0.0, 1e9], torques=(0.1, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"t: the numerical path .* \|omega0\| = 20\.\d rad/s, \|M\| = 0 N m"):
        simulate(ROTOR, S0, [0.0, 1e9], torques=lambda t, s: (0.0, 0.0, 0.0))
    # past the up-front estimate, the evaluations are counted during the run
    # (estimate 5e3 rad, while DOP853 needs ~30 evaluations per radian)
    with pytest.raises(ValueError, match=r"t: the numerical path \(applied torques\) used max_steps=10000 right-hand-side "
                                         r"evaluations and stopped at t=.* s before t=100 s"):
        simulate(ROTOR, S0, np.linspace(0.0, 100.0, 11), torques=(0.1, 0.0, 0.0), max_steps=10_000)
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match=r"max_steps: expected an integer >= 1"):
            simulate(ROTOR, S0, [0.0, 1.0], torques=(0.1, 0.0, 0.0), max_steps=bad)
    # the closed form costs O(n) whatever the span
    assert simulate(ROTOR, S0, [0.0, 1e6]).method == "closed_form"


def test_pole_switch_before_the_first_sample():
    # theta = 0.06 falling at 1 rad/s reaches the switch to Euler parameters
    # (|sin theta| < 0.05) at t ~ 0.01 s, before the first sample at 0.5 s:
    # solve_ivp returned no samples and the run failed with AttributeError.
    params = RotorParams(1.0, 0.8, 0.5)
    state = [0.0, 0.06, 0.0, 0.0, -1.0, 10.0]
    run = simulate(params, state, [0.0, 0.5], torques=(0.0, 0.1, 0.0))
    fine = simulate(params, state, np.linspace(0.0, 0.5, 501), torques=(0.0, 0.1, 0.0))
    # the same orientation (phi and psi are defined modulo 2 pi; sparse samples
    # may pick another branch than dense ones)
    turn = np.angle(np.exp(1j * (run.angles[-1] - fine.angles[-1])))
    np.testing.assert_allclose(turn, 0.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.rates[-1], fine.rates[-1], rtol=0, atol=1e-7)
