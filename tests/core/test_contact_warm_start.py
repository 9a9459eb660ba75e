"""Warm starts of the surface parameters when an adaptive integrator takes long steps.

A wheel rolling at ``omega`` turns the rim parameter of its contact point by
``omega dt`` in a step; a steady roll lets DOP853 take steps of a good
fraction of a second, so the parameters must be extrapolated with their rate
from the nearest known state (committed or last evaluated), not restarted.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigidlab.core.models import rolling_disk


@pytest.mark.parametrize("spin", [20.0, 40.0])
def test_upright_wheel_rolls_straight_with_long_steps(spin):
    R = 0.3
    system, disk, contact = rolling_disk(radius=R, mass=2.0, spin=spin)
    t = np.linspace(0.0, 3.0, 181)
    traj = system.simulate(t, rtol=1e-5, atol=1e-7)  # steps far longer than 0.2 rad of the rim
    assert traj.t[-1] == t[-1]
    hist = traj.contact(contact)
    # the contact point runs along +x at R spin; the disk stays upright
    np.testing.assert_allclose(hist.point[:, 0], R * spin * t, rtol=0, atol=1e-6 * R * spin * t[-1])
    np.testing.assert_allclose(hist.point[:, 1:], 0.0, atol=1e-9)
    np.testing.assert_allclose(traj.position(disk)[:, 2], R, atol=1e-9)
