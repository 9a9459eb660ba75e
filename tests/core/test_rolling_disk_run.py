"""rigidlab.core.models.rolling_disk_run: the disk's System run until it cannot go on, against independent oracles.

* The run's lean, spin, heading rate, speed, normal force and energy equal the
  reduced equations (:func:`rolling_disk_reference`), and its Euler angle
  rates are the derivatives of its angles (finite differences).
* A run continued from ``final_state`` follows the one long run.
* Ends: without spin the rolling disk leaves the ground where the normal
  force reaches zero (Eq. 8.107); the frictionless disk falls flat before its
  contact loses rank (Eq. 8.109); the lean limit cuts the run at the last
  sample before it.
* Argument checks.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from rigidlab.core.models import RollingDiskRun, rolling_disk, rolling_disk_reference, rolling_disk_run


@pytest.mark.parametrize("rolling", [True, False])
def test_the_run_is_the_reduced_equations(rolling):
    lean, spin, heading_rate = 0.3, 11.0, 1.2
    t = np.linspace(0.0, 1.0, 601)
    run = rolling_disk_run(*rolling_disk(0.1, 1.3, lean, spin, rolling, heading_rate=heading_rate), t,
                           rtol=1e-10, atol=1e-12)
    ref = rolling_disk_reference(t, 0.1, 1.3, lean, spin, rolling, heading_rate=heading_rate)
    assert isinstance(run, RollingDiskRun) and not run.final and run.end == ""
    np.testing.assert_array_equal(run.t, t)
    np.testing.assert_allclose(run.lean, ref.lean, atol=1e-7)
    np.testing.assert_allclose(run.spin, ref.spin, atol=1e-6)
    np.testing.assert_allclose(run.heading_rate, ref.heading_rate, atol=1e-6)
    np.testing.assert_allclose(run.lean_rate, ref.lean_rate, atol=1e-6)
    np.testing.assert_allclose(run.speed, np.linalg.norm(ref.velocity, axis=1), atol=1e-7)
    np.testing.assert_allclose(run.normal_force, ref.normal_force, rtol=1e-6)
    np.testing.assert_allclose(run.energy, ref.energy[0], rtol=1e-9)
    np.testing.assert_allclose(run.contact_point[:, 2], 0.0, atol=1e-12)
    assert run.residual_position.max() < 1e-10 and run.residual_velocity.max() < 1e-10
    # the rates are the derivatives of the lean (central differences, h = 1/600 s: error h^2 |theta'''| / 6 < 1e-3)
    h = t[1] - t[0]
    np.testing.assert_allclose((run.lean[2:] - run.lean[:-2]) / (2 * h), run.lean_rate[1:-1], atol=2e-3)
    for a in (run.t, run.q, run.lean, run.spin):
        assert not a.flags.writeable


def test_a_run_continued_from_its_final_state_follows_the_long_run():
    system, disk, contact = rolling_disk(0.1, 1.0, 0.2, 12.0, True)
    q0 = system.state.q.copy()
    first = rolling_disk_run(system, disk, contact, np.linspace(0.0, 0.5, 31), rtol=1e-10, atol=1e-12)
    state = pickle.loads(pickle.dumps(first.final_state))  # (a worker process continues it)
    second = rolling_disk_run(system, disk, contact, np.linspace(0.5, 1.0, 31), initial=state, rtol=1e-10,
                              atol=1e-12)
    one = rolling_disk_run(system, disk, contact, np.linspace(0.0, 1.0, 61), rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(system.state.q, q0)  # the System is not changed
    np.testing.assert_allclose(second.q[0], first.q[-1], atol=1e-12)
    # both integrators keep their local error within the tolerance: the pieces agree to about 1e-9
    np.testing.assert_allclose(second.q, one.q[30:], atol=1e-8)
    np.testing.assert_allclose(second.energy, one.energy[0], rtol=1e-9)


def test_without_spin_the_disk_leaves_the_ground_where_the_normal_force_vanishes():
    run = rolling_disk_run(*rolling_disk(0.1, 1.0, math.radians(10.0), 0.0, True), np.linspace(0.0, 2.0, 121))
    assert run.final and "left the ground" in run.end and "8.107" in run.end
    assert run.t[-1] < 2.0 and run.normal_force[-1] < 0.05 * 9.81 and run.normal_force[0] > 0.5 * 9.81


def test_the_frictionless_disk_falls_flat_before_its_contact_loses_rank():
    run = rolling_disk_run(*rolling_disk(0.1, 1.0, math.radians(20.0), 0.0, False), np.linspace(0.0, 0.5, 31))
    assert run.final and "flat" in run.end and run.t[-1] < 0.5
    assert np.all(np.isfinite(run.lean))
    # a lower lean limit ends the run at the last sample below it
    limited = rolling_disk_run(*rolling_disk(0.1, 1.0, math.radians(20.0), 0.0, False), np.linspace(0.0, 0.5, 31),
                               lean_limit=0.6)
    assert "fell flat" in limited.end and np.abs(limited.lean).max() < 0.6 and limited.t.size < run.t.size


@pytest.mark.parametrize("kwargs, match", [
    ({"t": [0.0]}, "t: expected at least two"),
    ({"t": [0.0, 0.0]}, "t: expected at least two"),
    ({"t": [0.0, math.nan]}, "t: expected at least two"),
    ({"lean_limit": 2.0}, "lean_limit: expected"),
    ({"lean_limit": -0.1}, "lean_limit: expected"),
])
def test_arguments(kwargs, match):
    system, disk, contact = rolling_disk()
    t = kwargs.pop("t", [0.0, 0.1])
    with pytest.raises(ValueError, match=match):
        rolling_disk_run(system, disk, contact, t, **kwargs)
