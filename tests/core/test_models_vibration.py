"""The models of core.models for modal analysis: states, steadiness and argument errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.gyroscope import RotorParams, steady_precession_rates
from rigidlab.core.models import disk_rotor, spherical_pendulum, steady_top, two_mass_oscillator

TOP = RotorParams(I=0.05, I3=0.02, mgl=0.5)


def test_models_start_at_rest_or_steady():
    for system in (spherical_pendulum().system, two_mass_oscillator().system, disk_rotor(50.0).system):
        ev = system.evaluate()
        assert np.max(np.abs(ev.accelerations)) < 1e-9
    rotor = disk_rotor(50.0, stiffness=1e3)
    np.testing.assert_allclose(rotor.system.state.position(rotor.disk)[2], -9.81 / 2e3)
    np.testing.assert_allclose(rotor.system.state.omega(rotor.disk), [50.0, 0.0, 0.0])


def test_steady_top_rates_and_frame():
    top = steady_top(TOP, spin=40.0, theta=0.6, precession="fast")
    rates = steady_precession_rates(TOP, 0.6, 40.0)
    assert top.phi_dot == pytest.approx(float(rates.fast))
    assert top.psi_dot == pytest.approx(40.0 - top.phi_dot * math.cos(0.6))
    np.testing.assert_array_equal(top.frame_omega, [0.0, 0.0, top.phi_dot])
    sleeping = steady_top(TOP, spin=20.0)
    assert sleeping.phi_dot == 0.0 and not np.any(sleeping.frame_omega)


def test_errors():
    with pytest.raises(ValueError, match="length: expected a finite number > 0"):
        spherical_pendulum(0.0)
    with pytest.raises(ValueError, match="stiffness: expected a finite number > 0"):
        disk_rotor(10.0, stiffness=-1.0)
    with pytest.raises(ValueError, match="speed: expected real numbers, got complex"):
        disk_rotor(1j)
    with pytest.raises(ValueError, match="theta: expected a nutation angle in"):
        steady_top(TOP, spin=20.0, theta=4.0)
    with pytest.raises(ValueError, match="precession: expected 'slow' or 'fast'"):
        steady_top(TOP, spin=20.0, theta=0.5, precession="medium")
    with pytest.raises(ValueError, match="masses: expected two finite numbers > 0"):
        two_mass_oscillator(masses=(1.0, 0.0))
    with pytest.raises(ValueError, match="damping: expected two finite numbers >= 0"):
        two_mass_oscillator(damping=(1.0,))
