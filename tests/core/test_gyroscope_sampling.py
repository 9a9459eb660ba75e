"""rigidlab.core.gyroscope.RotorSetup, motion_summary and sample_motion: one motion sampled stretch by stretch.

Oracles: simulate (the closed form, and DOP853 from the same start),
rotor_vectors and invariants at the same states, nutation for the summary,
and the chapter's numbers for the default top (theta 60-62.22 deg, period
0.668 s).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.gyroscope import (
    RotorParams,
    RotorSetup,
    invariants,
    motion_summary,
    nutation,
    rotor_vectors,
    sample_motion,
    simulate,
)

TOP = RotorParams(I=1.0, I3=0.8, mgl=2.0)
DEFAULT = RotorSetup(TOP, (0.0, math.radians(60.0), 0.0, 0.0, 0.0, 12.0))
TORQUED = RotorSetup(TOP, (0.0, math.radians(60.0), 0.0, 0.3, 0.0, 12.0), (0.5, 1.0, 0.2))


@pytest.mark.parametrize(("state0", "torques", "match"), [
    ((0.0, 1.0, 0.0), (0.0, 0.0, 0.0), r"state0: expected shape \(\.\.\., 6\)"),
    (((0.0,) * 6,) * 2, (0.0, 0.0, 0.0), r"state0: expected shape \(6,\), got \(2, 6\)"),
    ((0.0, math.nan, 0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), "state0: expected finite"),
    ((0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.0, 2.0), r"torques: expected shape \(3,\)"),
    ((0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.0, math.inf, 0.0), "torques: expected finite"),
])
def test_setup_refuses_bad_values_naming_them(state0, torques, match) -> None:
    with pytest.raises(ValueError, match=match):
        RotorSetup(TOP, state0, torques)


def test_setup_is_hashable_floats_and_says_whether_torques_act() -> None:
    setup = RotorSetup(TOP, np.array([0, 1, 0, 0, 0, 2]), [0, 0, 0])
    assert setup.state0 == (0.0, 1.0, 0.0, 0.0, 0.0, 2.0) and all(type(x) is float for x in setup.state0)
    assert hash(setup) == hash(RotorSetup(TOP, (0.0, 1.0, 0.0, 0.0, 0.0, 2.0)))
    assert not setup.has_torque and TORQUED.has_torque
    with pytest.raises(ValueError, match="params: expected a RotorParams"):
        RotorSetup("top", (0.0,) * 6)  # type: ignore[arg-type]


def test_stretches_at_absolute_times_are_the_closed_form() -> None:
    t = np.linspace(0.0, 4.0, 961)
    whole = simulate(TOP, np.array(DEFAULT.state0), t)
    for k in range(2):
        stretch = t[k * 480:(k + 1) * 480 + 1]
        s = sample_motion(DEFAULT, stretch)
        assert s.method == "closed_form"
        np.testing.assert_array_equal(s.t, stretch)
        np.testing.assert_allclose(s.angles, whole.angles[k * 480:(k + 1) * 480 + 1], rtol=0, atol=1e-12)
        states = np.concatenate([s.angles, s.rates], axis=1)
        v = rotor_vectors(TOP, states)
        np.testing.assert_array_equal(s.vectors.omega, v.omega)
        np.testing.assert_array_equal(s.vectors.angular_momentum, v.angular_momentum)
        inv = invariants(TOP, states)
        np.testing.assert_array_equal(s.invariants, np.stack([inv.d1, inv.d2, inv.energy], axis=1))
        np.testing.assert_array_equal(s.final_state, states[-1])
    assert not s.invariants.flags.writeable


def test_a_torque_driven_stretch_continues_from_the_previous_final_state() -> None:
    first = sample_motion(TORQUED, np.linspace(0.0, 1.0, 101))
    second = sample_motion(TORQUED, np.linspace(1.0, 2.0, 101), start=first.final_state)
    assert first.method == second.method == "numerical"
    direct = simulate(TOP, first.final_state, np.linspace(0.0, 1.0, 101), torques=TORQUED.torques,
                      rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(second.angles, direct.angles, rtol=0, atol=1e-13)  # (t - t[0]: round-off)
    np.testing.assert_array_equal(second.t, np.linspace(1.0, 2.0, 101))  # absolute times
    # one long run agrees to the tolerances' order (the restart re-starts the step size control)
    long = simulate(TOP, np.array(TORQUED.state0), np.linspace(0.0, 2.0, 201), torques=TORQUED.torques,
                    rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(second.angles, long.angles[100:], atol=1e-6)
    # d1 grows at M_psi (Eq. 8.16): d1' = M_psi
    assert second.invariants[-1, 0] - first.invariants[0, 0] == pytest.approx(0.2 * 2.0, rel=1e-6)


def test_sampling_refuses_a_missing_start_and_reports_a_failed_run() -> None:
    with pytest.raises(ValueError, match=r"start: expected the state at t\[0\] = 1.0 s"):
        sample_motion(TORQUED, [1.0, 2.0])
    with pytest.raises(ValueError, match=r"start: expected shape \(\.\.\., 6\)"):
        sample_motion(TORQUED, [1.0, 2.0], start=[0.0, 1.0])
    locked = RotorSetup(TOP, (0.0, 0.0, 0.0, 0.0, 0.0, 12.0), (5.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"sin\(theta\) = 0"):
        sample_motion(locked, np.linspace(0.0, 2.0, 11))
    with pytest.raises(ValueError, match="setup: expected a RotorSetup"):
        motion_summary("top")  # type: ignore[arg-type]


def test_summary_predicts_and_describes_the_motion() -> None:
    summary = motion_summary(DEFAULT)
    assert motion_summary(DEFAULT) is summary  # once per setup
    nu = nutation(TOP, np.array(DEFAULT.state0))
    assert summary.period == float(nu.period) and summary.prediction.theta_max == nu.theta_max
    inv = invariants(TOP, np.array(DEFAULT.state0))
    np.testing.assert_array_equal(summary.invariants0, [inv.d1, inv.d2, inv.energy])
    assert summary.spin == 12.0 and summary.critical_spin == pytest.approx(2 * math.sqrt(2.0) / 0.8)
    words = dict(summary.describe())
    assert words["Spin"] == "ω3 = dψ/dt + dφ/dt cos θ = 12.0 rad/s; sleeping top critical spin 3.54 rad/s"
    assert words["Nutation"].startswith("(Eq. 8.21): θ from 60.00° to 62.22°, period 0.668 s; mean dφ/dt ")


def test_summary_of_a_steady_and_of_a_torque_driven_motion() -> None:
    steady = motion_summary(RotorSetup(TOP, (0.0, 0.0, 0.0, 0.0, 0.0, 30.0)))  # a sleeping top
    assert math.isinf(steady.period)
    assert dict(steady.describe())["Nutation"].startswith("(Eq. 8.21): none, θ stays at 0.00°")
    torqued = motion_summary(TORQUED)
    assert torqued.motion is None and torqued.prediction is None and math.isnan(torqued.period)
    assert "applied torques act" in dict(torqued.describe())["Nutation"]
