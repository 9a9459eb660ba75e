"""Tests of core.manipulator: the three-joint manipulator of Fig. 8.3 (Eqs. 8.39-8.45).

Oracles: scipy's ``Rotation`` (Euler sequences and rotation vectors, composed
independently of core.rotations), hand-computed poses, central finite
differences of the orientation for the angular velocity, and the Euler-angle
``G`` matrix of core.rotations.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from rigidlab.core.manipulator import (
    DEFAULT_GEOMETRY,
    ManipulatorGeometry,
    end_link_angular_velocity,
    euler_form,
    link_frames_global_axis_rotations,
    link_frames_successive,
    matrix_from_global_axis_rotations,
    matrix_from_successive_rotations,
    relative_rotation_matrices,
)
from rigidlab.core.rotations import euler_angle_G, matrix_from_euler_angles

# Products of three rotation matrices of unit-size entries: rounding stays
# within a few dozen ulps (2.2e-16 each) of the exact result.
ROUNDING = 1e-14

EULER_SEQUENCES = [
    "".join(s) for s in itertools.product("XYZ", repeat=3) if s[0] != s[1] and s[1] != s[2]
]


def random_angles(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(-np.pi, np.pi, size=shape + (3,))


def random_geometry(rng: np.random.Generator) -> ManipulatorGeometry:
    axes = rng.normal(size=(3, 3))
    directions = rng.normal(size=(3, 3))
    return ManipulatorGeometry(
        joint_axes=axes / np.linalg.norm(axes, axis=-1, keepdims=True),
        link_lengths=rng.uniform(0.1, 2.0, size=3),
        link_directions=directions / np.linalg.norm(directions, axis=-1, keepdims=True),
    )


def scipy_chain(geometry: ManipulatorGeometry, angles: np.ndarray) -> list[Rotation]:
    """Cumulative link orientations from scipy rotation vectors, composed as A21 A32 A43."""
    relative = [Rotation.from_rotvec(angles[..., k, None] * geometry.joint_axes[k]) for k in range(3)]
    return [relative[0], relative[0] * relative[1], relative[0] * relative[1] * relative[2]]


# -- the two procedures -------------------------------------------------


def test_procedures_agree_for_default_joints_and_match_zxz_euler_matrix() -> None:
    rng = np.random.default_rng(20261122)
    angles = random_angles(rng, (500,))
    successive = matrix_from_successive_rotations(angles)
    global_axes = matrix_from_global_axis_rotations(angles)
    np.testing.assert_allclose(successive, global_axes, rtol=0, atol=ROUNDING)
    # Independent oracle: scipy's intrinsic Z-X-Z Euler matrix.
    oracle = Rotation.from_euler("ZXZ", angles).as_matrix()
    np.testing.assert_allclose(successive, oracle, rtol=0, atol=ROUNDING)
    # The core's own Euler-angle matrix (the chapter's precession-nutation-spin).
    np.testing.assert_allclose(
        successive, matrix_from_euler_angles(angles, "ZXZ"), rtol=0, atol=ROUNDING
    )


def test_procedures_agree_for_arbitrary_joint_axes_and_match_scipy() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        geometry = random_geometry(rng)
        angles = random_angles(rng, (50,))
        successive = matrix_from_successive_rotations(angles, geometry=geometry)
        global_axes = matrix_from_global_axis_rotations(angles, geometry=geometry)
        np.testing.assert_allclose(successive, global_axes, rtol=0, atol=ROUNDING)
        oracle = scipy_chain(geometry, angles)[2].as_matrix()
        np.testing.assert_allclose(successive, oracle, rtol=0, atol=ROUNDING)


@pytest.mark.parametrize(
    "angles",
    [
        (0.0, 0.0, 0.0),  # identity
        (np.pi, np.pi, np.pi),  # half turns
        (-np.pi, np.pi / 2, np.pi),
        (0.7, 0.0, -0.7),  # Z-X-Z gimbal lock: joints 1 and 3 aligned, cancelling
        (1e-12, -1e-12, 1e-12),  # near zero
        (40.0, -25.0, 1000.0),  # many turns
    ],
)
def test_special_angles_agree_with_scipy(angles) -> None:
    angles = np.array(angles)
    oracle = Rotation.from_euler("ZXZ", angles).as_matrix()
    for matrix in (matrix_from_successive_rotations(angles), matrix_from_global_axis_rotations(angles)):
        # Angles up to 1000 rad lose ~1e3 * eps in sin/cos of the argument.
        np.testing.assert_allclose(matrix, oracle, rtol=0, atol=1e-12)
        np.testing.assert_allclose(matrix @ matrix.T, np.eye(3), rtol=0, atol=ROUNDING)
        assert np.linalg.det(matrix) == pytest.approx(1.0, abs=ROUNDING)


@settings(max_examples=200, deadline=None)
@given(
    arrays(np.float64, 3, elements=st.floats(-20.0, 20.0)),
    arrays(np.float64, (3, 3), elements=st.floats(-1.0, 1.0)).filter(
        lambda a: np.all(np.linalg.norm(a, axis=-1) > 1e-3)
    ),
)
def test_procedures_agree_property(angles: np.ndarray, axes: np.ndarray) -> None:
    geometry = ManipulatorGeometry(joint_axes=axes / np.linalg.norm(axes, axis=-1, keepdims=True))
    a = link_frames_successive(angles, geometry=geometry)
    b = link_frames_global_axis_rotations(angles, geometry=geometry)
    # Angles up to 20 rad: sin/cos rounding grows with the argument (~20 eps).
    np.testing.assert_allclose(a.orientations, b.orientations, rtol=0, atol=1e-13)
    np.testing.assert_allclose(a.end_point, b.end_point, rtol=0, atol=1e-13)


def test_relative_rotations_are_rotations_about_the_joint_axes() -> None:
    rng = np.random.default_rng(3)
    geometry = random_geometry(rng)
    angles = random_angles(rng, (40,))
    relative = relative_rotation_matrices(angles, geometry=geometry)
    assert relative.shape == (40, 3, 3, 3)
    for k in range(3):
        oracle = Rotation.from_rotvec(angles[:, k, None] * geometry.joint_axes[k]).as_matrix()
        np.testing.assert_allclose(relative[:, k], oracle, rtol=0, atol=ROUNDING)
        # The joint axis is fixed by its own rotation.
        np.testing.assert_allclose(
            relative[:, k] @ geometry.joint_axes[k],
            np.broadcast_to(geometry.joint_axes[k], (40, 3)),
            rtol=0,
            atol=ROUNDING,
        )


def test_link_frames_of_both_procedures_agree_and_match_scipy_chain() -> None:
    rng = np.random.default_rng(11)
    for geometry in [DEFAULT_GEOMETRY] + [random_geometry(rng) for _ in range(10)]:
        angles = random_angles(rng, (30,))
        a = link_frames_successive(angles, geometry=geometry)
        b = link_frames_global_axis_rotations(angles, geometry=geometry)
        # Link lengths up to 2 m: positions carry lengths times rounding.
        for field in ("orientations", "origins", "end_point"):
            np.testing.assert_allclose(
                getattr(a, field), getattr(b, field), rtol=0, atol=10 * ROUNDING
            )
        chain = scipy_chain(geometry, angles)
        expected_origin = np.zeros((30, 3))
        for k in range(3):
            np.testing.assert_allclose(
                a.orientations[:, k], chain[k].as_matrix(), rtol=0, atol=ROUNDING
            )
            np.testing.assert_allclose(a.origins[:, k], expected_origin, rtol=0, atol=10 * ROUNDING)
            expected_origin = expected_origin + chain[k].apply(geometry.link_vectors[k])
        np.testing.assert_allclose(a.end_point, expected_origin, rtol=0, atol=10 * ROUNDING)


def test_hand_computed_pose_base_quarter_turn_and_shoulder_quarter_tilt() -> None:
    # theta = (90 deg, 90 deg, 0): Rx(90) tips +Z to -Y, Rz(90) turns -Y to +X,
    # so links 2 and 3 lie along +X at the top of the 0.6 m column.
    angles = np.array([np.pi / 2, np.pi / 2, 0.0])
    for frames in (link_frames_successive(angles), link_frames_global_axis_rotations(angles)):
        np.testing.assert_allclose(frames.origins, [[0, 0, 0], [0, 0, 0.6], [0.8, 0, 0.6]], atol=1e-15)
        np.testing.assert_allclose(frames.end_point, [1.3, 0.0, 0.6], atol=1e-15)
        np.testing.assert_allclose(
            frames.orientations[2], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15
        )


def test_partial_global_axis_procedure_applies_joints_in_reverse_order() -> None:
    rng = np.random.default_rng(5)
    angles = random_angles(rng, (10,))
    geometry = DEFAULT_GEOMETRY
    zero = link_frames_global_axis_rotations(angles, steps=0)
    np.testing.assert_array_equal(zero.orientations, np.broadcast_to(np.eye(3), (10, 3, 3, 3)))
    np.testing.assert_allclose(zero.end_point, np.broadcast_to([0, 0, 1.9], (10, 3)), atol=1e-15)
    # One step: only the last link has turned, about joint 3's axis (global Z)
    # through its centre; as the link lies on that axis its tip stays put.
    one = link_frames_global_axis_rotations(angles, steps=1)
    spin = Rotation.from_euler("z", angles[:, 2, None]).as_matrix()
    np.testing.assert_allclose(one.orientations[:, 2], spin, atol=ROUNDING)
    np.testing.assert_array_equal(one.orientations[:, :2], zero.orientations[:, :2])
    np.testing.assert_allclose(one.end_point, zero.end_point, atol=ROUNDING)
    # Two steps: joint 2 tilted links 2 and 3 about global X through (0, 0, 0.6).
    two = link_frames_global_axis_rotations(angles, steps=2)
    tilt = Rotation.from_euler("x", angles[:, 1, None])
    np.testing.assert_allclose(two.orientations[:, 2], tilt.as_matrix() @ spin, atol=ROUNDING)
    np.testing.assert_allclose(
        two.end_point, [0, 0, 0.6] + tilt.apply([0, 0, 1.3]), atol=10 * ROUNDING
    )
    assert geometry.link_lengths.sum() == pytest.approx(1.9)


# -- Euler-angle form -----------------------------------------------------


@pytest.mark.parametrize("seq", EULER_SEQUENCES)
def test_coordinate_joint_axes_give_the_euler_angle_matrix(seq: str) -> None:
    rng = np.random.default_rng(EULER_SEQUENCES.index(seq))
    unit = {"X": [1.0, 0, 0], "Y": [0, 1.0, 0], "Z": [0, 0, 1.0]}
    for signs in itertools.product((1.0, -1.0), repeat=3):
        geometry = ManipulatorGeometry(
            joint_axes=[s * np.array(unit[c]) for s, c in zip(signs, seq)]
        )
        angles = random_angles(rng, (20,))
        form = euler_form(angles, geometry=geometry)
        assert form.seq == seq
        np.testing.assert_allclose(form.angles, angles * np.array(signs), rtol=0, atol=0)
        matrix = matrix_from_successive_rotations(angles, geometry=geometry)
        # scipy oracle: intrinsic sequence with the sign-corrected angles.
        oracle = Rotation.from_euler(seq, form.angles).as_matrix()
        np.testing.assert_allclose(matrix, oracle, rtol=0, atol=ROUNDING)
        np.testing.assert_allclose(
            matrix, matrix_from_euler_angles(form.angles, seq), rtol=0, atol=ROUNDING
        )


def test_default_euler_form_is_zxz_with_the_joint_angles() -> None:
    angles = np.array([0.3, -1.2, 2.5])
    form = euler_form(angles)
    assert form.seq == "ZXZ"
    np.testing.assert_array_equal(form.angles, angles)


# -- angular velocity ---------------------------------------------------


def test_end_link_angular_velocity_matches_finite_differences() -> None:
    rng = np.random.default_rng(17)
    for geometry in (DEFAULT_GEOMETRY, random_geometry(rng)):
        angles = random_angles(rng, (25,))
        rates = rng.normal(size=(25, 3))
        omega = end_link_angular_velocity(angles, rates, geometry=geometry)
        h = 1e-6
        # Central difference: truncation ~ h^2 = 1e-12, rounding ~ eps / h = 2e-10.
        a_plus = matrix_from_successive_rotations(angles + h * rates, geometry=geometry)
        a_minus = matrix_from_successive_rotations(angles - h * rates, geometry=geometry)
        a = matrix_from_successive_rotations(angles, geometry=geometry)
        omega_skew = (a_plus - a_minus) / (2 * h) @ np.swapaxes(a, -1, -2)
        omega_fd = np.stack(
            [omega_skew[:, 2, 1], omega_skew[:, 0, 2], omega_skew[:, 1, 0]], axis=-1
        )
        np.testing.assert_allclose(omega, omega_fd, rtol=0, atol=1e-8)


def test_end_link_angular_velocity_is_euler_angle_g_times_rates_for_zxz() -> None:
    rng = np.random.default_rng(19)
    angles = random_angles(rng, (25,))
    rates = rng.normal(size=(25, 3))
    omega = end_link_angular_velocity(angles, rates)
    expected = np.einsum("...ij,...j->...i", euler_angle_G(angles, "ZXZ"), rates)
    np.testing.assert_allclose(omega, expected, rtol=0, atol=ROUNDING)


def test_angular_velocity_broadcasts_rates_against_angles() -> None:
    rng = np.random.default_rng(23)
    angles = random_angles(rng, (4, 1))
    rates = np.array([0.5, -1.0, 2.0])
    omega = end_link_angular_velocity(angles, rates)
    assert omega.shape == (4, 1, 3)
    one = end_link_angular_velocity(angles[2, 0], rates)
    # one configuration takes the float path: same formulas, other rounding order
    np.testing.assert_allclose(omega[2, 0], one, rtol=0, atol=ROUNDING)


# -- batch shapes ---------------------------------------------------------


@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2, 1)])
def test_batch_shapes_and_elementwise_agreement(batch: tuple[int, ...]) -> None:
    rng = np.random.default_rng(29)
    angles = random_angles(rng, batch)
    a = matrix_from_successive_rotations(angles)
    b = matrix_from_global_axis_rotations(angles)
    assert a.shape == batch + (3, 3) and b.shape == batch + (3, 3)
    assert relative_rotation_matrices(angles).shape == batch + (3, 3, 3)
    for frames in (link_frames_successive(angles), link_frames_global_axis_rotations(angles)):
        assert frames.orientations.shape == batch + (3, 3, 3)
        assert frames.origins.shape == batch + (3, 3)
        assert frames.end_point.shape == batch + (3,)
    assert euler_form(angles).angles.shape == batch + (3,)
    assert end_link_angular_velocity(angles, np.ones(batch + (3,))).shape == batch + (3,)
    flat = angles.reshape(-1, 3)
    for i, single in enumerate(flat):
        # One configuration takes the scalar float path, a batch numpy's matmul: the same
        # products summed in another order, so entries (|x| <= 1) agree to a few ulps, not bitwise.
        np.testing.assert_allclose(
            a.reshape(-1, 3, 3)[i], matrix_from_successive_rotations(single), rtol=0, atol=4e-16
        )


def test_inputs_are_not_mutated_and_geometry_is_frozen() -> None:
    angles = np.array([[0.1, 0.2, 0.3]])
    copy = angles.copy()
    link_frames_global_axis_rotations(angles)
    link_frames_successive(angles)
    np.testing.assert_array_equal(angles, copy)
    with pytest.raises(dataclasses.FrozenInstanceError):
        DEFAULT_GEOMETRY.link_lengths = np.ones(3)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        DEFAULT_GEOMETRY.joint_axes[0, 0] = 2.0


# -- validation ---------------------------------------------------------


@pytest.mark.parametrize(
    "function",
    [
        matrix_from_successive_rotations,
        matrix_from_global_axis_rotations,
        link_frames_successive,
        link_frames_global_axis_rotations,
        relative_rotation_matrices,
        euler_form,
    ],
)
def test_joint_angles_are_validated(function) -> None:
    with pytest.raises(ValueError, match=r"joint_angles must have shape \(\.\.\., 3\).*got shape \(2,\)"):
        function(np.zeros(2))
    with pytest.raises(ValueError, match=r"joint_angles must have shape \(\.\.\., 3\).*got shape \(\)"):
        function(0.0)
    with pytest.raises(ValueError, match="joint_angles must be finite"):
        function([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="geometry must be a ManipulatorGeometry, got dict"):
        function(np.zeros(3), geometry={})


def test_geometry_is_validated() -> None:
    with pytest.raises(ValueError, match=r"joint_axes must have shape \(3, 3\).*got shape \(2, 3\)"):
        ManipulatorGeometry(joint_axes=np.eye(3)[:2])
    with pytest.raises(ValueError, match="joint_axes rows must be unit vectors.*norms"):
        ManipulatorGeometry(joint_axes=2 * np.eye(3))
    with pytest.raises(ValueError, match="joint_axes must be finite"):
        ManipulatorGeometry(joint_axes=[[np.inf, 0, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="link_directions rows must be unit vectors"):
        ManipulatorGeometry(link_directions=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"link_lengths must have shape \(3,\).*got shape \(2,\)"):
        ManipulatorGeometry(link_lengths=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"link_lengths must be finite and > 0 metres, got \[1.0, 0.0, 1.0\]"):
        ManipulatorGeometry(link_lengths=[1.0, 0.0, 1.0])


@pytest.mark.parametrize("steps", [-1, 4, 1.5, True, "3"])
def test_steps_is_validated(steps) -> None:
    with pytest.raises(ValueError, match="steps must be an integer from 0 to 3, got"):
        link_frames_global_axis_rotations(np.zeros(3), steps=steps)


def test_euler_form_rejects_axes_without_an_euler_sequence() -> None:
    tilted = ManipulatorGeometry(
        joint_axes=[[0, 0, 1], [np.sqrt(0.5), np.sqrt(0.5), 0], [0, 0, 1]]
    )
    with pytest.raises(ValueError, match=r"coordinate axes.*joint 2 axis"):
        euler_form(np.zeros(3), geometry=tilted)
    repeated = ManipulatorGeometry(joint_axes=[[0, 0, 1], [0, 0, -1], [1, 0, 0]])
    with pytest.raises(ValueError, match="consecutive joints about different axes.*ZZX"):
        euler_form(np.zeros(3), geometry=repeated)
    # The two procedures still agree for such axes; only the Euler form is missing.
    angles = np.array([0.4, 0.5, 0.6])
    for geometry in (tilted, repeated):
        np.testing.assert_allclose(
            matrix_from_successive_rotations(angles, geometry=geometry),
            matrix_from_global_axis_rotations(angles, geometry=geometry),
            atol=ROUNDING,
        )


def test_joint_rates_are_validated() -> None:
    with pytest.raises(ValueError, match=r"joint_rates must have shape \(\.\.\., 3\).*got shape \(4,\)"):
        end_link_angular_velocity(np.zeros(3), np.zeros(4))
    with pytest.raises(ValueError, match="joint_rates must be finite"):
        end_link_angular_velocity(np.zeros(3), [np.nan, 0, 0])
    with pytest.raises(ValueError, match=r"joint_rates must broadcast against joint_angles.*\(2, 3\).*\(5, 3\)"):
        end_link_angular_velocity(np.zeros((5, 3)), np.zeros((2, 3)))


@pytest.mark.parametrize("steps", [0, 1, 2, 3])
def test_one_configuration_float_path_matches_the_batch(steps: int) -> None:
    """A (3,) configuration takes the Python-float path; a (1, 3) batch the array path."""
    rng = np.random.default_rng(31 + steps)
    axes = rng.normal(size=(3, 3))
    directions = rng.normal(size=(3, 3))
    geometry = ManipulatorGeometry(
        joint_axes=axes / np.linalg.norm(axes, axis=1, keepdims=True),
        link_lengths=[0.3, 1.2, 0.7],
        link_directions=directions / np.linalg.norm(directions, axis=1, keepdims=True),
    )
    for angles in random_angles(rng, (50,)):
        for function, kwargs in (
            (link_frames_successive, {"geometry": geometry}),
            (link_frames_global_axis_rotations, {"geometry": geometry, "steps": steps}),
            (link_frames_global_axis_rotations, {"steps": steps}),
        ):
            one = function(angles, **kwargs)
            batch = function(angles[None], **kwargs)
            np.testing.assert_allclose(one.orientations, batch.orientations[0], rtol=0, atol=ROUNDING)
            np.testing.assert_allclose(one.origins, batch.origins[0], rtol=0, atol=ROUNDING)
            np.testing.assert_allclose(one.end_point, batch.end_point[0], rtol=0, atol=ROUNDING)
