"""Model builders of core.models against closed forms.

* pendulum_chain: at rest in the hanging equilibrium; one link (point mass
  or uniform rod) swings with the exact large-amplitude period
  ``4 sqrt(l_eq / g) K(sin^2(theta0 / 2))`` (``l_eq = L`` for the point mass,
  ``2 L / 3`` for the rod).
* pendulum_chain_reduced (the joint-angle equations): the same period,
  energy conservation, the initial state of pendulum_chain, argument checks
  (against System.simulate in test_multibody_dynamics).
* slider_crank, spatial_double_pendulum, heavy_top: geometry, assembly and
  argument checks (their dynamics are tested in test_multibody_dynamics).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

from rigidlab.core.gyroscope import RotorParams
from rigidlab.core.integrators import IntegrationError
from rigidlab.core.models import (
    ROD_RADIUS_RATIO,
    HeavyTop,
    SliderCrank,
    SpatialDoublePendulum,
    ReducedChainMotion,
    heavy_top,
    pendulum_chain,
    pendulum_chain_reduced,
    slider_crank,
    spatial_double_pendulum,
)
from rigidlab.core.models._pendulum import MAX_LINKS
from rigidlab.core.multibody import System


@pytest.mark.parametrize("kind", ["rod", "point"])
@pytest.mark.parametrize("n", [1, 3])
def test_pendulum_chain_hangs_at_rest(kind, n):
    system = pendulum_chain(n, length=0.7, mass=2.0, kind=kind)
    assert isinstance(system, System) and len(system.bodies) == n and len(system.joints) == n
    assert all(j.kind == "revolute" for j in system.joints)
    np.testing.assert_allclose([j.axis for j in system.joints], np.tile([1.0, 0.0, 0.0], (n, 1)))
    offset = 0.5 if kind == "rod" else 1.0
    for k, body in enumerate(system.bodies):
        np.testing.assert_allclose(system.state.position(body), [0.0, 0.0, -0.7 * (k + offset)], atol=1e-15)
        assert body.mass == 2.0 and body.name == f"link{k}"
    assert np.all(system.state.v == 0.0)
    # the hanging chain is an equilibrium: nothing moves, joints carry the weight below them
    traj = system.simulate([0.0, 0.5])
    np.testing.assert_allclose(traj.q[-1], traj.q[0], atol=1e-14)
    F, _ = traj.reaction(system.joints[0])
    np.testing.assert_allclose(F[0], [0.0, 0.0, n * 2.0 * 9.81], atol=1e-10)
    # equilibrium() agrees: already there
    assert system.equilibrium().moved == ()


def test_rod_inertia_is_the_slender_rod_one():
    system = pendulum_chain(1, length=2.0, mass=3.0)
    J = system.bodies[0].inertia
    np.testing.assert_allclose(np.diag(J), [3.0 * 4.0 / 12.0, 3.0 * 4.0 / 12.0, 0.5 * 3.0 * (ROD_RADIUS_RATIO * 2.0) ** 2])
    assert pendulum_chain(1, kind="point").bodies[0].inertia.max() == 0.0


@pytest.mark.parametrize(("kind", "l_eq"), [("point", 1.2), ("rod", 0.8)])
def test_single_link_large_amplitude_period(kind, l_eq):
    theta0, L, g = 1.0, 1.2, 9.81
    system = pendulum_chain(1, length=L, kind=kind, tilt=theta0, gravity=g)
    period = 4.0 * math.sqrt(l_eq / g) * ellipk(math.sin(theta0 / 2.0) ** 2)
    traj = system.simulate([0.0, period / 2.0, period], rtol=1e-11, atol=1e-12)
    start = traj.position(system.bodies[0])[0]
    # after half a period the link is at -theta0, after a full one back at theta0
    np.testing.assert_allclose(traj.position(system.bodies[0])[1], start * [1.0, -1.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(traj.position(system.bodies[0])[2], start, atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(n=0), r"n: expected an integer >= 1"),
        (dict(n=2, length=0.0), r"length: expected a finite length > 0"),
        (dict(n=2, mass=-1.0), r"mass: expected a finite mass > 0"),
        (dict(n=2, kind="chain"), r"kind: expected 'rod' or 'point'"),
        (dict(n=2, gravity=-9.81), r"gravity: expected a finite g >= 0"),
    ],
)
def test_pendulum_chain_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        pendulum_chain(**kwargs)


@pytest.mark.parametrize("n", [10**6, MAX_LINKS + 1])
def test_chains_longer_than_max_links_are_refused_at_once(n):
    """pendulum_chain(10**6) never finished (the assembly's cost grows as n^3: 300 links take about a minute)."""
    assert MAX_LINKS == 300
    message = rf"n: expected a number of links from 1 to core.models._pendulum.MAX_LINKS = 300 .*, got {n}"
    with pytest.raises(ValueError, match=message):
        pendulum_chain(n)
    with pytest.raises(ValueError, match=message):
        pendulum_chain_reduced(n, [0.0, 1.0])


def test_reduced_chain_runs_that_could_not_end_are_stopped():
    """The reduced equations ran through scipy's solve_ivp with no budget: a horizon of 1e300 s ran forever."""
    with pytest.raises(IntegrationError, match=r"DOP853 stopped at t=\S+ before t1=1e\+300: at its pace so far "
                                               r"\(10,000 right-hand-side evaluations"):
        pendulum_chain_reduced(2, [0.0, 1e300], tilt=0.3)
    with pytest.raises(ValueError, match=r"rtol: expected a relative tolerance >= core.integrators.MIN_RTOL"):
        pendulum_chain_reduced(2, [0.0, 1e4], tilt=0.3, rtol=1e-16)


def test_tilted_chain_is_straight_and_at_rest():
    system = pendulum_chain(4, tilt=0.6)
    direction = np.array([0.0, math.sin(0.6), -math.cos(0.6)])
    for k, body in enumerate(system.bodies):
        np.testing.assert_allclose(system.state.position(body), (k + 0.5) * direction, atol=1e-15)
    assert np.all(system.state.v == 0.0)


@pytest.mark.parametrize(("kind", "l_eq"), [("point", 1.2), ("rod", 0.8)])
def test_reduced_single_link_large_amplitude_period(kind, l_eq):
    theta0, L, g = 1.0, 1.2, 9.81
    period = 4.0 * math.sqrt(l_eq / g) * ellipk(math.sin(theta0 / 2.0) ** 2)
    motion = pendulum_chain_reduced(1, [0.0, period / 2.0, period], length=L, kind=kind, tilt=theta0, gravity=g)
    assert isinstance(motion, ReducedChainMotion)
    np.testing.assert_allclose(motion.angles[:, 0], [theta0, -theta0, theta0], atol=1e-11)
    np.testing.assert_allclose(motion.rates[:, 0], 0.0, atol=1e-10)


@pytest.mark.parametrize("kind", ["rod", "point"])
def test_reduced_chain_starts_at_the_model_and_conserves_energy(kind):
    n, L, m, g, tilt = 4, 0.9, 1.7, 9.81, 0.8
    t = np.linspace(0.0, 3.0, 31)
    motion = pendulum_chain_reduced(n, t, length=L, mass=m, kind=kind, tilt=tilt, gravity=g)
    assert motion.t.shape == (31,) and motion.angles.shape == motion.rates.shape == (31, n)
    assert motion.centres.shape == (31, n, 3)
    system = pendulum_chain(n, length=L, mass=m, kind=kind, tilt=tilt, gravity=g)
    np.testing.assert_allclose(motion.centres[0], [system.state.position(b) for b in system.bodies], atol=1e-15)
    np.testing.assert_allclose(motion.centres[..., 0], 0.0)
    # energy from the centres' velocities (sum over the links above of L phi_dot (0, cos, sin)) and heights
    offset = 0.5 if kind == "rod" else 1.0
    J = m * L * L / 12.0 if kind == "rod" else 0.0
    i, k = np.indices((n, n))
    a = np.where(i < k, L, 0.0) + np.where(i == k, offset * L, 0.0)
    de = np.stack([np.cos(motion.angles), np.sin(motion.angles)], axis=-1) * motion.rates[..., None]
    v = np.einsum("ik,tid->tkd", a, de)
    energy = 0.5 * m * (v**2).sum(axis=(1, 2)) + 0.5 * J * (motion.rates**2).sum(axis=1)
    energy += m * g * motion.centres[..., 2].sum(axis=1)
    assert np.ptp(motion.rates) > 1.0  # it moves
    assert np.ptp(energy) < 1e-10 * abs(energy[0])


def test_reduced_chain_with_one_time_is_the_initial_state():
    motion = pendulum_chain_reduced(2, [1.5], tilt=0.3)
    np.testing.assert_allclose(motion.angles, [[0.3, 0.3]])
    np.testing.assert_allclose(motion.rates, 0.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(n=0, t=[0.0, 1.0]), r"n: expected an integer >= 1"),
        (dict(n=2, t=[0.0, 1.0], kind="chain"), r"kind: expected 'rod' or 'point'"),
        (dict(n=2, t=[1.0, 0.0]), r"t: expected non-decreasing times \(s\), got t\[1\] = 0.0 after t\[0\] = 1.0"),
        (dict(n=2, t=[]), r"t: expected a non-empty 1-D array of output times \(s\), got shape \(0,\)"),
        (dict(n=2, t=[0.0, np.nan]), r"t: expected finite times \(s\), got t\[1\] = nan"),
        (dict(n=2, t=[0.0, 1.0j]), r"t: expected real numbers, got complex"),
        (dict(n=2, t=[0.0, 1.0], rtol=0.0), r"rtol: expected a finite tolerance > 0"),
        (dict(n=2, t=[0.0, 1.0], atol=-1.0), r"atol: expected a finite tolerance > 0"),
    ],
)
def test_pendulum_chain_reduced_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        pendulum_chain_reduced(**kwargs)


def test_slider_crank_geometry():
    model = slider_crank(crank_length=0.1, rod_length=0.3, phi0=0.8, speed=5.0)
    assert isinstance(model, SliderCrank)
    report = model.system.assemble()
    assert report.rank == 18 and report.redundant == () and report.degrees_of_freedom == 0  # motor included
    np.testing.assert_allclose(model.system.state.position(model.slider)[0], model.slider_position(0.8), atol=1e-15)
    np.testing.assert_allclose(model.system.state.omega(model.crank), [0.0, -5.0, 0.0], atol=1e-14)
    with pytest.raises(ValueError, match=r"rod_length: expected longer than crank_length"):
        slider_crank(crank_length=0.3, rod_length=0.2)


def test_spatial_double_pendulum_geometry():
    model = spatial_double_pendulum(length=0.5, tilt=(0.4, 0.9), azimuth=(0.0, 1.0), spin=2.0)
    assert isinstance(model, SpatialDoublePendulum) and model.length == 0.5
    assert [j.kind for j in model.joints] == ["spherical", "spherical"]
    np.testing.assert_allclose(model.system.state.omega(model.links[0]), [0.0, 0.0, 2.0], atol=1e-14)
    tip = model.system.state.point(model.links[0], (0.0, 0.0, 0.25))  # body z points along the link
    np.testing.assert_allclose(tip, 0.5 * np.array([math.sin(0.4), 0.0, -math.cos(0.4)]), atol=1e-15)


def test_heavy_top_body_matches_the_rotor():
    params = RotorParams(I=0.5, I3=0.4, mgl=1.0)
    top = heavy_top(params, [0.0, 0.5, 0.0, 0.0, 0.0, 10.0], mass=2.0, gravity=10.0)
    assert isinstance(top, HeavyTop) and top.length == pytest.approx(0.05)
    np.testing.assert_allclose(np.diag(top.body.inertia), [0.5 - 2.0 * 0.05**2, 0.5 - 2.0 * 0.05**2, 0.4])
    with pytest.raises(ValueError, match=r"mass: with m=400.0 the centre of mass"):
        heavy_top(params, [0.0, 0.5, 0.0, 0.0, 0.0, 10.0], mass=400.0, gravity=0.01)
    with pytest.raises(ValueError, match=r"params: expected a core.gyroscope.RotorParams"):
        heavy_top((0.5, 0.4, 1.0), np.zeros(6))
    with pytest.raises(ValueError, match=r"state0: expected 6 finite numbers"):
        heavy_top(params, np.zeros(5))
