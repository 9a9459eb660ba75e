"""The thin disk on the ground: reduced equations (rolling and frictionless sliding) against independent oracles.

* Energy conserved; the contact point on the ground and, rolling, at rest.
* The reported velocities and angular velocities are the time derivatives
  of the reported positions and attitudes (finite differences).
* Steady circular rolling (lean and heading rate from the force balance)
  stays steady.
* Small perturbations of upright motion follow the linearized equations:
  a wobble of angular frequency ``sqrt((4/5)(3 Omega^2 - g/R))`` above the
  critical spin ``sqrt(g / (3 R))``, growth below it; sliding: ``2
  sqrt(Omega^2 - g/R)``.
* Through the System (``rolling_disk``: the rim, a zero-tube Torus, on
  the ground Plane, with rolling rows or frictionless): pose, normal force
  (the contact multiplier) and energy against the reduced equations;
  upright rolling stable above the critical spin, unstable below it.
* Argument checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigidlab.core.models import (
    FLAT_LEAN,
    RollingDiskMotion,
    rolling_disk,
    rolling_disk_critical_spin,
    rolling_disk_reference,
)
from rigidlab.core.rotations import matrix_from_euler_parameters

G = 9.81


@pytest.mark.parametrize("rolling", [True, False])
def test_energy_and_contact(rolling):
    m, R = 1.3, 0.12
    t = np.linspace(0.0, 4.0, 401)
    motion = rolling_disk_reference(t, R, m, lean=0.35, spin=9.0, rolling=rolling, heading_rate=1.5, lean_rate=-0.4)
    assert isinstance(motion, RollingDiskMotion)
    assert np.abs(motion.lean - 0.35).max() > 0.05  # it moves
    e0 = motion.energy[0]
    assert np.ptp(motion.energy) < 1e-12 * e0
    # contact point on the ground, the lowest point of the rim
    np.testing.assert_allclose(motion.contact_point[:, 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(motion.contact_point - motion.centre, axis=-1), R, rtol=1e-14)
    A = matrix_from_euler_parameters(motion.orientation)
    axis = A[:, :, 1]  # symmetry axis: body y
    np.testing.assert_allclose(np.sum((motion.contact_point - motion.centre) * axis, -1), 0.0, atol=1e-15)
    slip = motion.velocity + np.cross(motion.omega, motion.contact_point - motion.centre)
    if rolling:
        np.testing.assert_allclose(slip, 0.0, atol=1e-14)
    else:
        # no friction: horizontal momentum conserved, the rim slips
        np.testing.assert_allclose(motion.velocity[:, :2] - motion.velocity[0, :2], 0.0, atol=1e-15)
        assert np.abs(slip[:, :2]).max() > 0.1
        np.testing.assert_allclose(slip[:, 2], 0.0, atol=1e-14)
    assert motion.normal_force.min() > 0
    assert motion.t.shape == (401,) and motion.centre.shape == (401, 3) and motion.orientation.shape == (401, 4)


@pytest.mark.parametrize("rolling", [True, False])
def test_rates_are_derivatives_of_the_pose(rolling):
    h = 1e-5
    base = np.linspace(0.1, 2.0, 11)
    t = np.sort(np.concatenate([base - h, base, base + h]))
    motion = rolling_disk_reference(t, 0.1, 1.0, lean=0.3, spin=10.0, rolling=rolling, heading_rate=2.0,
                                    lean_rate=0.5)
    i0, i1, i2 = np.arange(0, t.size, 3), np.arange(1, t.size, 3), np.arange(2, t.size, 3)
    A = matrix_from_euler_parameters(motion.orientation)
    dA = (A[i2] - A[i0]) / (2 * h)
    W = np.einsum("nij,nkj->nik", dA, A[i1])  # skew(omega) = A_dot A^T
    omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)
    np.testing.assert_allclose(omega, motion.omega[i1], rtol=0, atol=2e-6)
    v = (motion.centre[i2] - motion.centre[i0]) / (2 * h)
    np.testing.assert_allclose(v, motion.velocity[i1], rtol=0, atol=1e-8)
    # normal force = m (g + z_ddot)
    zdd = (motion.velocity[i2, 2] - motion.velocity[i0, 2]) / (2 * h)
    np.testing.assert_allclose(motion.normal_force[i1], 1.0 * (G + zdd), rtol=0, atol=1e-6)
    for name, rate in (("lean", "lean_rate"), ("heading", "heading_rate")):
        x = getattr(motion, name)
        np.testing.assert_allclose((x[i2] - x[i0]) / (2 * h), getattr(motion, rate)[i1], atol=1e-7)
    # the spin omega_2 is the angular velocity along the symmetry axis
    np.testing.assert_allclose(np.sum(motion.omega * A[:, :, 1], -1), motion.spin, atol=1e-13)


def test_steady_circular_rolling():
    m, R = 1.0, 0.1
    A, C = m * R * R / 4, m * R * R / 2
    lean, heading_rate = 0.4, 3.0
    s, c = math.sin(lean), math.cos(lean)
    # (A + m R^2) theta_ddot = 0 = -A psi_dot^2 s c + (C + m R^2) psi_dot c w2 + m g R s
    w2 = (A * heading_rate**2 * s * c - m * G * R * s) / ((C + m * R * R) * heading_rate * c)
    t = np.linspace(0, 3, 31)
    motion = rolling_disk_reference(t, R, m, lean=lean, spin=w2, heading_rate=heading_rate)
    np.testing.assert_allclose(motion.lean, lean, atol=1e-12)
    np.testing.assert_allclose(motion.heading_rate, heading_rate, rtol=1e-12)
    np.testing.assert_allclose(motion.spin, w2, rtol=1e-12)
    np.testing.assert_allclose(motion.normal_force, m * G, rtol=1e-12)
    # the centre runs on a horizontal circle of radius R w2 / psi_dot about a fixed point
    # the centre runs on a horizontal circle of signed radius R w2 / psi_dot, turning about +z (to its left)
    rho = R * w2 / heading_rate
    middle = motion.centre[0, :2] + np.array([0.0, rho])
    np.testing.assert_allclose(np.linalg.norm(motion.centre[:, :2] - middle, axis=-1), abs(rho), rtol=1e-11)


def _linear_upright(t, lean_rate0, spin, R, rolling):
    """Linearized upright motion (thin disk) started upright with lean rate lean_rate0 and psi_dot = 0.

    Rolling: ``(5/4) theta_ddot = (3/2) Omega psi_dot + (g/R) theta`` and
    ``psi_dot = -2 Omega theta``; sliding: ``theta_ddot = 2 Omega psi_dot +
    4 (g/R) theta``, ``psi_dot = -2 Omega theta``.
    """
    k2 = 0.8 * (3 * spin**2 - G / R) if rolling else 4 * (spin**2 - G / R)  # theta_ddot = -k2 theta
    if k2 > 0:
        return lean_rate0 / math.sqrt(k2) * np.sin(math.sqrt(k2) * t)
    return lean_rate0 / math.sqrt(-k2) * np.sinh(math.sqrt(-k2) * t)


@pytest.mark.parametrize("rolling", [True, False])
@pytest.mark.parametrize("factor", [1.5, 0.7])
def test_upright_stability_matches_the_linearization(rolling, factor):
    R = 0.1
    critical = rolling_disk_critical_spin(R, rolling=rolling)
    spin = factor * critical
    eps = 1e-7
    growth = math.sqrt(max(0.8 * (G / R - 3 * spin**2) if rolling else 4 * (G / R - spin**2), 1e-300))
    t = np.linspace(0, min(2.0, 12.0 / growth), 201)  # unstable: until the lean grows e^12 times (still small)
    motion = rolling_disk_reference(t, R, 1.0, spin=spin, rolling=rolling, lean_rate=eps)
    expected = _linear_upright(t, eps, spin, R, rolling)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(motion.lean, expected, rtol=0, atol=1e-4 * scale)
    np.testing.assert_allclose(motion.heading_rate, -2 * spin * expected, rtol=0, atol=1e-4 * 2 * spin * scale)
    if factor > 1:
        assert np.abs(motion.lean).max() < 1e-7  # stays near upright
    else:
        assert np.abs(motion.lean).max() > 1e-5  # falls away


@pytest.mark.parametrize("rolling", [True, False])
def test_stable_above_and_unstable_below_the_critical_spin(rolling):
    """Nonlinear runs kicked by a 0.05 rad/s lean rate: bounded just above the critical spin, growing below."""
    R = 0.1
    critical = rolling_disk_critical_spin(R, rolling=rolling)
    t = np.linspace(0, 3.0, 301)
    above = rolling_disk_reference(t, R, 1.0, spin=1.1 * critical, rolling=rolling, lean_rate=0.05)
    assert np.abs(above.lean).max() < 0.03
    below = rolling_disk_reference(t, R, 1.0, spin=0.9 * critical, rolling=rolling, lean_rate=0.05)
    assert np.abs(below.lean).max() > 0.3


def test_critical_spin_values():
    assert rolling_disk_critical_spin() == pytest.approx(math.sqrt(G / 0.3), rel=1e-15)
    assert rolling_disk_critical_spin(0.1) == pytest.approx(5.718391382198319, rel=1e-14)
    assert rolling_disk_critical_spin(0.1, rolling=False) == pytest.approx(math.sqrt(G / 0.1), rel=1e-15)
    assert rolling_disk_critical_spin(0.2, gravity=1.62) == pytest.approx(math.sqrt(1.62 / 0.6), rel=1e-15)
    assert rolling_disk_critical_spin(0.2, gravity=0.0) == 0.0


def test_initial_state():
    motion = rolling_disk_reference([0.0], 0.1, 2.0, lean=0.2, spin=5.0, heading_rate=0.7, lean_rate=0.3)
    np.testing.assert_allclose(motion.contact_point[0], 0.0, atol=1e-17)
    np.testing.assert_allclose(motion.centre[0], [0.0, -0.1 * math.sin(0.2), 0.1 * math.cos(0.2)], atol=1e-17)
    assert motion.lean[0] == 0.2 and motion.heading[0] == 0.0 and motion.spin_angle[0] == 0.0
    assert motion.spin[0] == 5.0 and motion.heading_rate[0] == 0.7 and motion.lean_rate[0] == 0.3
    A = matrix_from_euler_parameters(motion.orientation[0])
    np.testing.assert_allclose(A[:, 0], [1.0, 0.0, 0.0], atol=1e-16)  # body x: rolling direction
    np.testing.assert_allclose(A[:, 1], [0.0, math.cos(0.2), math.sin(0.2)], atol=1e-16)  # symmetry axis rises
    upright = rolling_disk_reference([0.0, 1.0], 0.1, 1.0, spin=20.0)
    np.testing.assert_allclose(upright.velocity[0], [2.0, 0.0, 0.0])
    np.testing.assert_allclose(upright.centre[-1], [2.0, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(upright.orientation[0], [1.0, 0.0, 0.0, 0.0])


def test_a_falling_disk_is_reported():
    with pytest.raises(RuntimeError, match=r"the disk fell \(\|lean\| reached FLAT_LEAN = 1.5 rad\) at t = "):
        rolling_disk_reference(np.linspace(0, 5, 11), lean=0.5, spin=0.0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(radius=0.0), "radius: expected a finite number > 0"),
        (dict(mass=-1.0), "mass: expected a finite number > 0"),
        (dict(lean=FLAT_LEAN), r"lean: expected \|lean\| < 1.5 rad"),
        (dict(lean=float("nan")), "lean: expected a finite lean angle"),
        (dict(spin=1j), "spin: expected real numbers, got complex"),
        (dict(rolling=1), "rolling: expected True"),
        (dict(heading_rate=float("inf")), "heading_rate: expected a finite heading rate"),
        (dict(lean_rate="fast"), "lean_rate: expected a finite lean rate"),
        (dict(gravity=-1.0), "gravity: expected a finite g >= 0"),
        (dict(rtol=0.0), "rtol: expected a finite number > 0"),
        (dict(t=[1.0, 0.0]), r"t: expected non-decreasing times \(s\), got t\[1\] = 0.0 after t\[0\] = 1.0"),
        (dict(t=[]), r"t: expected a non-empty 1-D array of output times \(s\), got shape \(0,\)"),
    ],
)
def test_reference_arguments(kwargs, message):
    kwargs = {"t": [0.0, 0.1], **kwargs}
    with pytest.raises(ValueError, match=message):
        rolling_disk_reference(**kwargs)


def test_critical_spin_arguments():
    with pytest.raises(ValueError, match="radius: expected a finite number > 0"):
        rolling_disk_critical_spin(-0.1)
    with pytest.raises(ValueError, match="rolling: expected True"):
        rolling_disk_critical_spin(0.1, rolling="yes")


# ------------------------------------------------------------------ through core.multibody.System
def compare_with_reference(system, disk, contact, t, reference, *, tol):
    traj = system.simulate(t, rtol=1e-11, atol=1e-13)
    assert traj.status == "completed"
    state_centre = np.array([traj.state(i).position(disk) for i in range(t.size)])
    A = np.array([traj.state(i).rotation_matrix(disk) for i in range(t.size)])
    np.testing.assert_allclose(state_centre, reference.centre, rtol=0, atol=tol * 0.1)
    np.testing.assert_allclose(A, matrix_from_euler_parameters(reference.orientation), rtol=0, atol=tol)
    history = traj.contact(contact)
    np.testing.assert_allclose(history.normal_force, reference.normal_force, rtol=tol)
    np.testing.assert_allclose(history.point, reference.contact_point, rtol=0, atol=tol * 0.1)
    return traj


def test_rolling_disk_builder():
    system, disk, contact = rolling_disk(0.15, 2.0, lean=0.2, spin=8.0, heading_rate=1.0, lean_rate=-0.3)
    assert system.bodies == (disk,) and system.contacts == (contact,)
    assert contact.rolling and contact.model == "constraint"
    assert contact.surface_j.major_radius == 0.15 and contact.surface_j.minor_radius == 0.0
    np.testing.assert_allclose(np.diag(disk.inertia), [2 * 0.15**2 / 4, 2 * 0.15**2 / 2, 2 * 0.15**2 / 4])
    ref = rolling_disk_reference([0.0], 0.15, 2.0, lean=0.2, spin=8.0, heading_rate=1.0, lean_rate=-0.3)
    state = system.state
    np.testing.assert_allclose(state.position(disk), ref.centre[0], atol=1e-15)
    np.testing.assert_allclose(state.rotation_matrix(disk), matrix_from_euler_parameters(ref.orientation[0]),
                               atol=1e-15)
    np.testing.assert_allclose(state.velocity(disk), ref.velocity[0], atol=1e-14)
    np.testing.assert_allclose(state.omega(disk), ref.omega[0], atol=1e-14)
    # identity orientation = upright, rolling along +x
    system, disk, _ = rolling_disk()
    np.testing.assert_allclose(system.state.orientation(disk), [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(system.state.velocity(disk), [2.0, 0.0, 0.0])
    sliding = rolling_disk(rolling=False)[2]
    assert not sliding.rolling


def test_rolling_disk_system_matches_the_reduced_equations():
    kwargs = dict(lean=0.3, spin=10.0, heading_rate=2.0, lean_rate=0.5)
    t = np.linspace(0.0, 1.0, 21)
    system, disk, contact = rolling_disk(**kwargs)
    traj = compare_with_reference(system, disk, contact, t, rolling_disk_reference(t, **kwargs), tol=1e-8)
    assert np.ptp(traj.energy) < 1e-10 * abs(traj.energy[0])
    # no slip at the contact point
    history = traj.contact(contact)
    for i in range(t.size):
        st = traj.state(i)
        r = history.point[i] - st.position(disk)
        np.testing.assert_allclose(st.velocity(disk) + np.cross(st.omega(disk), r), 0.0, atol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("rolling", [True, False])
def test_disk_system_over_three_seconds(rolling):
    kwargs = dict(lean=0.4, spin=9.0, heading_rate=1.5, lean_rate=-0.4, rolling=rolling)
    t = np.linspace(0.0, 3.0, 301)
    system, disk, contact = rolling_disk(**kwargs)
    traj = compare_with_reference(system, disk, contact, t, rolling_disk_reference(t, **kwargs), tol=1e-8)
    assert np.ptp(traj.energy) < 1e-10 * abs(traj.energy[0])


@pytest.mark.parametrize("factor", [1.5, 0.7])
def test_upright_rolling_stability_through_the_system(factor):
    """A 1e-4 rad/s lean kick: bounded wobble above the critical spin, exponential fall below (System and reference)."""
    spin = factor * rolling_disk_critical_spin(0.1)
    t = np.linspace(0.0, 1.2, 25)
    system, disk, contact = rolling_disk(spin=spin, lean_rate=1e-4)
    traj = system.simulate(t, rtol=1e-11, atol=1e-13)
    A = np.array([traj.state(i).rotation_matrix(disk) for i in range(t.size)])
    lean = np.arcsin(A[:, 2, 1])  # the symmetry axis (body y) rises by sin(lean)
    reference = rolling_disk_reference(t, spin=spin, lean_rate=1e-4)
    np.testing.assert_allclose(lean, reference.lean, rtol=0, atol=1e-9)
    linear = _linear_upright(t, 1e-4, spin, 0.1, True)
    np.testing.assert_allclose(lean, linear, rtol=0, atol=1e-2 * np.abs(linear).max())
    if factor > 1:
        assert np.abs(lean).max() < 2e-5
    else:
        assert np.abs(lean).max() > 1e-2


def test_rolling_disk_arguments():
    with pytest.raises(ValueError, match="radius: expected a finite number > 0"):
        rolling_disk(radius=0.0)
    with pytest.raises(ValueError, match=r"lean: expected \|lean\| < 1.5 rad"):
        rolling_disk(lean=2.0)
    with pytest.raises(ValueError, match="rolling: expected True"):
        rolling_disk(rolling="no")
    with pytest.raises(ValueError, match="lean_rate: expected a finite lean rate"):
        rolling_disk(lean_rate=float("nan"))


def test_a_run_too_long_for_its_spin_is_refused_or_announced():
    """At least one right-hand side a radian: a coin spun at 1e6 rad/s for 20 s cannot end within max_steps
    (refused before it starts), and 0.2 s of it (2e5 rad, minutes of CPU) is announced with a warning."""
    from rigidlab.core.multibody._simulate import LONG_RUN_RADIANS, _check_turns

    system, disk, _ = rolling_disk(spin=1e6)
    with pytest.raises(ValueError, match=r"t: body 'disk' turns at 1e\+06 rad/s, about 2e\+07 rad by t=20, .*"
                                         r"more than max_steps=10000000"):
        system.simulate([0.0, 20.0])
    with pytest.raises(ValueError, match=r"about 2e\+05 rad by t=0.2.*more than max_steps=1000"):
        system.simulate([0.0, 0.2], max_steps=1000)
    y0 = np.concatenate([system.state.q, system.state.v])
    with pytest.warns(RuntimeWarning, match=r"simulate: body 'disk' turns at 1e\+06 rad/s, about 2e\+05 rad .*"
                                            r"this run takes minutes"):
        _check_turns(system, y0, 0.0, 0.2, 10_000_000)
    assert 1e6 * 0.05 < LONG_RUN_RADIANS  # 0.05 s of it is quiet
    system, disk, _ = rolling_disk(spin=20.0)
    system.simulate([0.0, 0.01])  # an ordinary spin: neither


@pytest.mark.parametrize("lean", [0.0, 0.2])
def test_without_gravity_the_zero_normal_force_is_not_a_separation(lean):
    """With no gravity the normal force of a rolling disk is zero in exact arithmetic; its round-off (about
    1e-14 N) once counted as a separation, at t = 0 with a lean, because the force scale of the separation
    test had only the applied forces (none) and fell to its floor. The bodies' centripetal forces
    (m |omega|^2 r_g, 28 N here) now set it: 1e-9 of them is far above round-off and far below a real pull."""
    system, _, contact = rolling_disk(radius=0.1, mass=1.0, lean=lean, spin=20.0, rolling=True, gravity=0.0)
    traj = system.simulate(np.linspace(0.0, 1.0, 11), rtol=1e-10, atol=1e-12)
    assert traj.status == "completed" and not traj.separations
    assert np.max(np.abs(traj.contact(contact).normal_force)) < 1e-12
