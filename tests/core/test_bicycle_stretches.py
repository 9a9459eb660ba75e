"""A ride computed stretch by stretch (core.models.whipple_ride_from), the modes at a speed and against speed
(whipple_modes_at, whipple_sweep): what a viewer asks of the bicycle."""

from __future__ import annotations

import numpy as np
import pytest

from rigidlab.core._errors import ArgumentError
from rigidlab.core.models import (
    MEIJAARD_2007_EIGENVALUES,
    whipple_bicycle_reference,
    whipple_modes_at,
    whipple_ride_from,
    whipple_sweep,
)
from rigidlab.core.multibody import RunState


def test_stretches_continue_one_ride():
    t = np.linspace(0.0, 1.0, 41)
    whole = whipple_ride_from(5.0, t, impulse=30.0)
    first = whipple_ride_from(5.0, t[:21], impulse=30.0)
    second = whipple_ride_from(5.0, t[20:], initial=first.final_state)
    np.testing.assert_allclose(second.q, whole.q[20:], atol=1e-8)
    np.testing.assert_allclose(second.lean, whole.lean[20:], atol=1e-8)
    assert np.max(whole.lean) > 0.01  # pushed to the right: it leans right


def test_a_push_from_a_sample_starts_there_on_its_clock():
    t = np.linspace(0.0, 0.5, 21)
    ride = whipple_ride_from(5.0, t)
    j = 12
    start = RunState(ride.t[j], ride.q[j], ride.v[j])  # no contact parameters: a state from a sample
    same = whipple_ride_from(5.0, np.linspace(ride.t[j], 0.5, 21 - j), initial=start)
    np.testing.assert_allclose(same.lean, ride.lean[j:], atol=1e-6)
    pushed = whipple_ride_from(5.0, np.linspace(ride.t[j], ride.t[j] + 0.5, 21), initial=start, impulse=-40.0)
    assert pushed.t[0] == ride.t[j] and np.min(pushed.lean) < -0.01  # to the left
    np.testing.assert_allclose(pushed.q[0], ride.q[j], atol=1e-12)  # a push changes velocities only


def test_a_fall_is_timed_on_the_callers_clock():
    t0 = 3.0
    upright = whipple_ride_from(2.0, np.linspace(0.0, 0.1, 5))
    start = RunState(t0, upright.q[0], upright.v[0])
    ride = whipple_ride_from(2.0, t0 + np.linspace(0.0, 6.0, 241), initial=start, impulse=40.0)
    assert ride.fallen and ride.t[-1] > t0
    when = float(ride.end.rsplit("t = ", 1)[1].split()[0])  # the end's time, on the clock of t
    assert ride.t[-1] - 1e-9 <= when <= ride.t[-1] + 0.025 + 1e-9


def test_derived_samples():
    ride = whipple_ride_from(5.0, np.linspace(0.0, 0.5, 21), impulse=20.0)
    n = ride.t.size
    assert ride.poses.shape == (n, 4, 7) and ride.contact_points.shape == (n, 2, 3)
    np.testing.assert_allclose(ride.contact_points[:, 0], ride.rear_contact)
    np.testing.assert_allclose(np.linalg.norm(ride.poses[:, :, 3:], axis=2), 1.0, atol=1e-12)
    assert np.min(np.einsum("nbi,nbi->nb", ride.poses[1:, :, 3:], ride.poses[:-1, :, 3:])) > 0
    np.testing.assert_allclose(ride.rear_speed, 5.0, atol=0.1)


def test_refused_arguments():
    with pytest.raises(ArgumentError, match="initial: expected a RunState"):
        whipple_ride_from(5.0, [0.0, 0.1], initial=(1, 2))
    with pytest.raises(ValueError, match="impulse"):
        whipple_ride_from(5.0, [0.0, 0.1], impulse=float("nan"))
    with pytest.raises(ArgumentError, match="speeds: expected at least two"):
        whipple_sweep([1.0, 1.0])


def test_modes_at_a_speed_and_the_sweep_agree_with_the_paper():
    want = whipple_bicycle_reference().eigenvalues(5.0)
    got = sorted((m.eigenvalue for m in whipple_modes_at(5.0)), key=lambda s: (s.real, s.imag))
    np.testing.assert_allclose(got, want, rtol=1e-9)
    sweep = whipple_sweep(np.linspace(0.0, 10.0, 41))
    np.testing.assert_allclose(sweep.eigenvalues, sweep.reference, atol=1e-8)
    paper = (MEIJAARD_2007_EIGENVALUES["weave_speed"], MEIJAARD_2007_EIGENVALUES["capsize_speed"])
    np.testing.assert_allclose(sweep.reference_stable_speeds, paper, atol=1e-12)
    np.testing.assert_allclose(sweep.stable_speeds, paper, atol=1e-8)
    curves = sweep.curves()
    i = 20  # 5 m/s: the weave oscillates, capsize and castering are real
    assert curves["weave"][i] == curves["weave_2"][i] and curves["weave_frequency"][i] > 0
    assert np.isnan(curves["weave_frequency"][0])  # at rest all four roots are real
    np.testing.assert_allclose(curves["castering"][i], MEIJAARD_2007_EIGENVALUES["eigenvalues"][5.0][0].real,
                               atol=1e-12)
