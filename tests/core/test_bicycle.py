"""The Whipple bicycle from the general engine against the benchmark of Meijaard et al. (2007).

Oracles: the paper's published matrices and eigenvalues (Table 2, 14
decimals) and its linearized equations in lean and steer built from the
parameters by the Appendix A formulas (``whipple_bicycle_reference``), whose
eigenvalues at every speed are independent of the engine: the engine sees
only bodies, revolute joints and two rolling knife-edge contacts.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import math

import numpy as np
import pytest

from rigidlab.core.modal import linearize, sweep
from rigidlab.core.models import (
    MEIJAARD_2007,
    MEIJAARD_2007_EIGENVALUES,
    MEIJAARD_2007_SPEEDS,
    WhippleParameters,
    whipple_angles,
    whipple_bicycle,
    whipple_bicycle_reference,
    whipple_linear_response,
    whipple_modes,
    whipple_push,
    whipple_ride,
    whipple_speed_model,
)
from rigidlab.core.rotations import matrix_from_axis_angle
from rigidlab.core.rotations import euler_parameters_from_matrix

PUBLISHED = MEIJAARD_2007_EIGENVALUES["eigenvalues"]
# The paper's matrices of the benchmark (Table 2), typed from the paper.
M0 = [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]]
C1 = [[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]]
K0 = [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]]
K2 = [[0.0, 76.59734589573222], [0.0, 2.65431523794604]]
WEAVE_SPEED, CAPSIZE_SPEED = 4.29238253634111, 6.02426201538837  # published


def _matched_error(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    """Relative error of each eigenvalue in ``want`` against its nearest in ``got`` (one to one)."""
    from scipy.optimize import linear_sum_assignment

    cost = np.abs(got[:, None] - want[None, :])
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(want.size)
    out[cols] = cost[rows, cols] / np.abs(want[cols])
    return out


# ------------------------------------------------------------------ the reference
def test_reference_matrices_are_the_papers():
    ref = whipple_bicycle_reference("meijaard2007")
    for got, want in ((ref.M, M0), (ref.C1, C1), (ref.K0, K0), (ref.K2, K2)):
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-14)
    assert ref.gravity == 9.81


@pytest.mark.parametrize("speed", MEIJAARD_2007_SPEEDS)
def test_reference_eigenvalues_are_the_papers(speed):
    got = whipple_bicycle_reference().eigenvalues(speed)
    want = np.array(PUBLISHED[speed])
    # the table's 14 decimals: 13 to 15 significant digits (12 for the capsize root at 6 m/s)
    assert np.all(_matched_error(got, want) * np.abs(want) <= np.maximum(1e-13 * np.abs(want), 1e-14))


def test_reference_stability_boundaries_are_the_papers():
    b = whipple_bicycle_reference().stability_boundaries()
    np.testing.assert_allclose(b, [WEAVE_SPEED, CAPSIZE_SPEED], rtol=0, atol=2e-14)
    assert MEIJAARD_2007_EIGENVALUES["weave_speed"] == WEAVE_SPEED
    assert MEIJAARD_2007_EIGENVALUES["capsize_speed"] == CAPSIZE_SPEED


# ------------------------------------------------------------------ the engine
@pytest.mark.parametrize("speed", MEIJAARD_2007_SPEEDS)
def test_linearized_bicycle_eigenvalues_to_ten_digits(speed):
    """``linearize(whipple_bicycle(v))``: 4 live modes, the paper's eigenvalues to 1e-10 each (relative),
    the reference's; 6 structural zeros (place, heading, wheel angles, forward speed)."""
    lin = linearize(whipple_bicycle(speed))
    modes = lin.modes()
    assert np.sum(modes.rigid) == 6
    live = modes.eigenvalues[~modes.rigid]
    want = np.array(PUBLISHED[speed])
    assert np.max(_matched_error(live, want)) < 1e-10
    ref = whipple_bicycle_reference().eigenvalues(speed)
    assert np.max(_matched_error(live, ref)) < 1e-10
    assert lin.derivative_error < 1e-6


@pytest.mark.parametrize("speed", [0.3, 2.5, 4.5, 6.5, 8.5])
def test_linearized_bicycle_between_the_tables_speeds(speed):
    modes = linearize(whipple_bicycle(speed)).modes()
    live = modes.eigenvalues[~modes.rigid]
    assert np.max(_matched_error(live, whipple_bicycle_reference().eigenvalues(speed))) < 1e-10


def test_other_parameters_change_the_eigenvalues_alike():
    """A bicycle that is not the benchmark (longer trail, heavier fork, slacker head): engine and formulas agree."""
    p = dataclasses.replace(MEIJAARD_2007, trail=0.11, steer_axis_tilt=0.35, fork_mass=6.0,
                            fork_inertia=(0.09, 0.1, 0.012, -0.01), front_radius=0.33)
    for speed in (1.5, 5.0):
        modes = linearize(whipple_bicycle(speed, p)).modes()
        live = modes.eigenvalues[~modes.rigid]
        assert np.max(_matched_error(live, whipple_bicycle_reference(p).eigenvalues(speed))) < 1e-10


@pytest.mark.slow
def test_weave_and_capsize_speeds_by_sweep_and_root_finding():
    def build(speed):
        return linearize(whipple_bicycle(speed))

    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        result = sweep(build, np.linspace(0.0, 10.0, 11), executor=pool)
    b = result.boundaries(xtol=1e-13)
    assert b.shape == (2,)
    np.testing.assert_allclose(b, [WEAVE_SPEED, CAPSIZE_SPEED], rtol=1e-11)
    stable = np.all(result.stable, axis=1)
    np.testing.assert_array_equal(stable, (result.values > WEAVE_SPEED) & (result.values < CAPSIZE_SPEED))


@pytest.mark.parametrize("speed", [0.0, 0.5, 1.0, 5.0, 10.0])
def test_modes_named_and_shaped_as_the_reference(speed):
    """Names (weave, capsize, castering) and the lean / steer ratio of each mode against the
    eigenvectors of the paper's equations (same signs of lean and steer)."""
    modes = whipple_modes(linearize(whipple_bicycle(speed)))
    assert [m.name for m in modes][-2:] == ["capsize", "castering"]
    assert [m.name for m in modes][:2] == ["weave", "weave"]
    A = whipple_bicycle_reference().state_matrix(speed)
    s_ref, V = np.linalg.eig(A)
    for m in modes:
        k = int(np.argmin(np.abs(s_ref - m.eigenvalue)))
        phi, delta = V[0, k], V[1, k]
        if abs(m.lean) >= abs(m.steer):
            np.testing.assert_allclose(m.steer, delta / phi, rtol=1e-8, atol=1e-10)
        else:
            np.testing.assert_allclose(m.lean, phi / delta, rtol=1e-8, atol=1e-10)
    castering = modes[-1]
    assert abs(castering.steer) == pytest.approx(1.0) and abs(castering.lean) < 0.05  # mostly steer
    if speed >= 1.0:
        assert modes[0].eigenvalue.imag > 0 and modes[1].eigenvalue == modes[0].eigenvalue.conjugate()
    if speed == 5.0:
        assert all(m.stable for m in modes)
        assert abs(modes[2].lean) == pytest.approx(1.0)  # capsize: mostly lean


# ------------------------------------------------------------------ built once, copied per speed
def _built_afresh(speed, p=MEIJAARD_2007):
    """The System of ``whipple_bicycle`` built and assembled at ``speed`` step by step (no cache): the oracle."""
    from rigidlab.core.contact import Plane, Torus
    from rigidlab.core.multibody import System

    T = np.diag([1.0, -1.0, -1.0])

    def tensor(i):
        return T @ np.array([[i[0], 0.0, i[3]], [0.0, i[1], 0.0], [i[3], 0.0, i[2]]]) @ T

    w, c, rR, rF = p.wheelbase, p.trail, p.rear_radius, p.front_radius
    fwd = (speed, 0.0, 0.0)
    s = System(gravity=(0.0, 0.0, -p.gravity))
    rear = s.add_body("rear_wheel", mass=p.rear_mass, inertia=(p.rear_inertia[0], p.rear_inertia[1], p.rear_inertia[0]),
                      position=(0.0, 0.0, rR), velocity=fwd, omega=(0.0, speed / rR, 0.0))
    frame = s.add_body("frame", mass=p.frame_mass, inertia=tensor(p.frame_inertia),
                       position=(p.frame_position[0], 0.0, -p.frame_position[1]), velocity=fwd)
    fork = s.add_body("fork", mass=p.fork_mass, inertia=tensor(p.fork_inertia),
                      position=(p.fork_position[0], 0.0, -p.fork_position[1]), velocity=fwd)
    front = s.add_body("front_wheel", mass=p.front_mass, inertia=(p.front_inertia[0], p.front_inertia[1],
                                                                  p.front_inertia[0]),
                       position=(w, 0.0, rF), velocity=fwd, omega=(0.0, speed / rF, 0.0))
    a = p.steer_axis
    hub, foot = np.array([w, 0.0, rF]), np.array([w + c, 0.0, 0.0])
    s.add_joint("revolute", frame, rear, point=(0.0, 0.0, rR), axis=(0.0, 1.0, 0.0), name="rear_hub")
    s.add_joint("revolute", frame, fork, point=foot + ((hub - foot) @ a) * a, axis=a, name="steer")
    s.add_joint("revolute", fork, front, point=hub, axis=(0.0, 1.0, 0.0), name="front_hub")
    s.add_contact(s.ground, Plane(), rear, Torus(rR, 0.0), rolling=True, name="rear_contact")
    s.add_contact(s.ground, Plane(), front, Torus(rF, 0.0), rolling=True, name="front_contact")
    s.assemble()
    return s


@pytest.mark.parametrize("speed", [0.0, 2.5, -3.0])
def test_each_call_is_the_system_built_afresh_and_its_own(speed):
    """``whipple_bicycle`` copies one assembled System per parameter set and scales its velocities: the state is
    that of the System built and assembled at the speed (positions to 1e-15 m, velocities to 1e-15 of the speed:
    the assembly's least-change projection of velocities that already satisfy the rows moves them by round-off
    only), and a copy changed does not change the next one."""
    got = whipple_bicycle(speed)
    want = _built_afresh(speed)
    np.testing.assert_allclose(got.state.q, want.state.q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(got.state.v, want.state.v, rtol=0, atol=1e-15 * max(abs(speed), 1.0))
    assert [b.name for b in got.bodies] == [b.name for b in want.bodies]
    assert [c.name for c in got.contacts] == ["rear_contact", "front_contact"]
    assert got.evaluate().D.shape == want.evaluate().D.shape
    got.set_state(whipple_push(got, 30.0))
    again = whipple_bicycle(speed)
    np.testing.assert_allclose(again.state.v, want.state.v, rtol=0, atol=1e-15 * max(abs(speed), 1.0))
    assert again.bodies[0] is not got.bodies[0]


# ------------------------------------------------------------------ the linear model at every speed
@pytest.mark.parametrize("speed", [0.0, 0.5, 3.0, 6.0, 10.0, 12.0])
def test_speed_model_is_the_linearization_at_that_speed(speed):
    """``whipple_speed_model().linear_model(v)`` against ``linearize(whipple_bicycle(v))``: the same embedding, and
    matrices equal to 1e-12 of their largest entry (the differenced derivatives are linear in the residual,
    which is a polynomial of degree 2 in the speed, so only the round-off of the scaling separates them; 12 m/s
    lies beyond the reference speed)."""
    model = whipple_speed_model().linear_model(speed)
    direct = linearize(whipple_bicycle(speed))
    np.testing.assert_array_equal(model.embedding.basis, direct.embedding.basis)
    np.testing.assert_array_equal(model.embedding.velocity_basis, direct.embedding.velocity_basis)
    np.testing.assert_allclose(model.embedding.v0, direct.embedding.v0, rtol=0, atol=1e-15 * max(speed, 1.0))
    for got, want in ((model.M, direct.M), (model.K, direct.K), (model.velocity_matrix, direct.velocity_matrix),
                      (model.velocity_map, direct.velocity_map), (model.state_matrix(), direct.state_matrix())):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * max(np.max(np.abs(want)), 1.0))
    assert (model.position_rate_map is None) == (direct.position_rate_map is None)
    assert (model.C is None) == (direct.C is None)


@pytest.mark.parametrize("speed", MEIJAARD_2007_SPEEDS)
def test_speed_model_eigenvalues_to_ten_digits(speed):
    modes = whipple_speed_model().linear_model(speed).modes()
    assert np.sum(modes.rigid) == 6
    live = modes.eigenvalues[~modes.rigid]
    assert np.max(_matched_error(live, np.array(PUBLISHED[speed]))) < 1e-10
    assert np.max(_matched_error(live, whipple_bicycle_reference().eigenvalues(speed))) < 1e-10
    assert [m.name for m in whipple_modes(whipple_speed_model().linear_model(speed))][-2:] == ["capsize", "castering"]


def test_weave_and_capsize_speeds_from_the_speed_model():
    """The sweep and Brent's method on the speed model (one eigenvalue problem a speed) find the published
    weave and capsize speeds to 1e-11 relative, as on the engine linearized at every speed (the slow test above)."""
    model = whipple_speed_model()
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        result = sweep(model.linear_model, np.linspace(0.0, 10.0, 11), executor=pool)
    np.testing.assert_allclose(result.boundaries(xtol=1e-13), [WEAVE_SPEED, CAPSIZE_SPEED], rtol=1e-11)
    assert whipple_speed_model() is model  # kept per parameter set


def test_speed_model_of_other_parameters_and_errors():
    p = dataclasses.replace(MEIJAARD_2007, trail=0.11, steer_axis_tilt=0.35, fork_mass=6.0,
                            fork_inertia=(0.09, 0.1, 0.012, -0.01), front_radius=0.33)
    model = whipple_speed_model(p, reference_speed=7.0)
    assert model.reference_speed == 7.0
    for speed in (1.5, 5.0):
        modes = model.linear_model(speed).modes()
        live = modes.eigenvalues[~modes.rigid]
        assert np.max(_matched_error(live, whipple_bicycle_reference(p).eigenvalues(speed))) < 1e-10
    with pytest.raises(ValueError, match="reference_speed: expected a finite speed > 0"):
        whipple_speed_model(reference_speed=0.0)
    with pytest.raises(ValueError, match="reference_speed: expected a finite speed"):
        whipple_speed_model(reference_speed=math.nan)
    with pytest.raises(ValueError, match="parameters: expected a WhippleParameters"):
        whipple_speed_model("penny-farthing")
    with pytest.raises(ValueError, match="speed: expected a finite forward speed"):
        whipple_speed_model().linear_model(math.inf)
    with pytest.raises(ValueError):
        model.K0[0, 0] = 1.0  # shared between calls: read-only


# ------------------------------------------------------------------ angles, push
def test_angles_follow_the_papers_signs():
    system = whipple_bicycle(5.0)
    q = np.array(system.state.q)
    heading, lean, steer = 0.3, 0.1, 0.2
    A_frame = matrix_from_axis_angle(np.array([0.0, 0.0, 1.0]), heading) @ matrix_from_axis_angle(
        np.array([1.0, 0.0, 0.0]), lean)
    A_fork = A_frame @ matrix_from_axis_angle(MEIJAARD_2007.steer_axis, steer)
    q[12 + 4:12 + 8] = euler_parameters_from_matrix(A_frame)
    q[12 + 8:12 + 12] = euler_parameters_from_matrix(A_fork)
    ang = whipple_angles(q)
    np.testing.assert_allclose([ang.lean, ang.steer, ang.yaw, ang.pitch], [lean, steer, -heading, 0.0], atol=1e-14)
    assert whipple_angles(np.stack([q, q, q])).lean.shape == (3,)


def test_push_moves_the_frame_sideways_within_the_constraints():
    system = whipple_bicycle(5.0)
    pushed = whipple_push(system, 10.0)
    ev = system.evaluate()
    D = np.asarray(ev.D)
    assert np.max(np.abs(D @ pushed.v)) < 1e-12  # joints and rolling rows keep holding
    np.testing.assert_array_equal(pushed.q, system.state.q)
    frame = system.bodies[1]
    assert pushed.velocity(frame)[1] < 0  # the paper's right is the engine's -y
    assert pushed.omega(frame)[0] > 0  # and it starts to lean right
    with pytest.raises(ValueError, match="impulse: expected a finite impulse"):
        whipple_push(system, math.nan)


def test_parameter_errors():
    with pytest.raises(ValueError, match="parameters: expected a WhippleParameters or one of"):
        whipple_bicycle(5.0, "penny-farthing")
    with pytest.raises(ValueError, match="speed: expected a finite forward speed"):
        whipple_bicycle(math.inf)
    with pytest.raises(ValueError, match="wheelbase: expected a finite number > 0"):
        dataclasses.replace(MEIJAARD_2007, wheelbase=0.0)
    with pytest.raises(ValueError, match="steer_axis_tilt: expected an angle"):
        dataclasses.replace(MEIJAARD_2007, steer_axis_tilt=2.0)
    with pytest.raises(ValueError, match="frame_inertia: expected a positive definite"):
        dataclasses.replace(MEIJAARD_2007, frame_inertia=(1.0, 1.0, 5.0, 0.0))
    with pytest.raises(ValueError, match="rear_inertia: expected 0 < I_yy <= 2 I_xx"):
        dataclasses.replace(MEIJAARD_2007, rear_inertia=(0.05, 0.2))
    with pytest.raises(ValueError, match="fork_position: expected 2 finite numbers"):
        dataclasses.replace(MEIJAARD_2007, fork_position=(0.9, -0.7, 0.0))
    assert isinstance(MEIJAARD_2007, WhippleParameters)
    with pytest.raises(ValueError, match="model: expected core.modal.linearize"):
        whipple_modes("not a model")


# ------------------------------------------------------------------ nonlinear rides
FALL_BOUND = 0.5  # rad: "fallen" in these tests (29 deg; the ride itself stops at 60 deg)


@pytest.mark.slow
def test_push_at_a_self_stable_speed_recovers():
    system = whipple_bicycle(5.0)
    system.set_state(whipple_push(system, 10.0))
    ride = whipple_ride(system, np.linspace(0.0, 8.0, 321))
    assert not ride.fallen and ride.t[-1] == 8.0
    assert np.max(np.abs(ride.lean)) < 0.05
    assert np.max(np.abs(ride.lean[ride.t > 6.0])) < 0.01  # the weave has died out, capsize decays slowly
    assert np.max(np.abs(ride.steer[ride.t > 6.0])) < 0.01
    assert np.all(np.isfinite(ride.rear_contact)) and abs(ride.rear_contact[-1, 2]) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("speed", [2.0, 8.0])
def test_push_outside_the_self_stable_range_falls(speed):
    """2 m/s: the weave grows (Re s = 2.68 /s); 8 m/s: capsize (s = 0.143 /s) tips it over slowly."""
    system = whipple_bicycle(speed)
    system.set_state(whipple_push(system, 10.0))
    ride = whipple_ride(system, np.linspace(0.0, 40.0, 1601))
    assert np.max(np.abs(ride.lean)) > FALL_BOUND
    assert ride.fallen


@pytest.mark.slow
def test_linear_and_nonlinear_lean_agree_for_a_small_push():
    """Lean and steer of the linear model against the nonlinear ride over 3 s at 5 m/s: the error shrinks
    at least as the push squared (the bicycle is symmetric, so the lean's error is odd: cubic); the
    forward speed, constant in the linear model, changes as the push squared."""
    t = np.linspace(0.0, 3.0, 61)
    errors, speed_changes = [], []
    for push in (2.0, 1.0, 0.5):
        system = whipple_bicycle(5.0)
        lin = linearize(system)
        pushed = whipple_push(system, push)
        lean, steer = whipple_linear_response(lin, pushed.v - system.state.v, t)
        system.set_state(pushed)
        ride = whipple_ride(system, t, rtol=1e-11, atol=1e-13)
        assert ride.t.size == t.size
        errors.append(max(np.max(np.abs(ride.lean - lean)), np.max(np.abs(ride.steer - steer))))
        speed_changes.append(abs(np.linalg.norm(ride.v[-1, 0:3]) - 5.0))  # the rear hub's speed
        assert errors[-1] < 2e-3 * np.max(np.abs(ride.lean))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 4.0 * 0.95), ratios
    speed_ratios = np.array(speed_changes[:-1]) / np.array(speed_changes[1:])
    np.testing.assert_allclose(speed_ratios, 4.0, rtol=0.05)


def test_mode_names_of_the_references_eigenvalues():
    from rigidlab.core.models import whipple_mode_names

    ref = whipple_bicycle_reference()
    assert sorted(whipple_mode_names(ref.eigenvalues(0.5))) == ["capsize", "castering", "weave", "weave"]
    s = ref.eigenvalues(5.0)  # sorted by real part: castering, weave, weave, capsize
    assert whipple_mode_names(s) == ("castering", "weave", "weave", "capsize")
    with pytest.raises(ValueError, match="expected the 4 eigenvalues"):
        whipple_mode_names(s[:3])
