"""System.add_rod / add_box / add_cylinder against the textbook inertia formulas, and Modes.flexible.

References: the moments of uniform solids (a solid circular cylinder of
radius r and length L about its centre: ``m (3 r^2 + L^2) / 12`` across,
``m r^2 / 2`` about its axis; a box of edges a, b, c: ``m (b^2 + c^2) / 12``
...), written here independently of the code, and rotated into the global
frame as ``A J A^T`` with scipy's Rotation. Tolerances: the formulas are
evaluated in a different order on each side, so they agree to a few ulps;
1e-14 relative to the largest moment.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigidlab.core.modal import LinearModel, linearize
from rigidlab.core.multibody import System
from rigidlab.core.rotations import matrix_from_euler_parameters


def _global_tensor(system, body):
    n = len(system.bodies)
    i = body.index
    A = matrix_from_euler_parameters(system.state.q[3 * n + 4 * i : 3 * n + 4 * i + 4])
    return A, A @ body.inertia @ A.T


def test_rod_along_a_rotated_direction():
    rng = np.random.default_rng(7)
    system = System()
    for k in range(20):
        start = rng.normal(size=3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        L, r, m = 0.3 + rng.random(), 0.01 + 0.1 * rng.random(), 0.5 + rng.random()
        body = system.add_rod(f"rod{k}", start, start + L * d, m, radius=r)
        A, J = _global_tensor(system, body)
        side, axial = m * (3 * r * r + L * L) / 12, m * r * r / 2
        expected = side * (np.eye(3) - np.outer(d, d)) + axial * np.outer(d, d)
        np.testing.assert_allclose(J, expected, rtol=0, atol=1e-14 * side)
        np.testing.assert_allclose(A[:, 2], d, atol=1e-14)  # the body z axis along the rod
        np.testing.assert_allclose(system.state.q[3 * k : 3 * k + 3], start + 0.5 * L * d, atol=1e-14)
        assert body.mass == m


@pytest.mark.parametrize("d", [(0, 0, 1), (0, 0, -1), (1, 0, 0), (0, -2, 0)])
def test_rod_along_the_axes(d):
    system = System()
    d = np.array(d, dtype=float)
    body = system.add_rod("rod", (0, 0, 0), d, 2.0)  # default radius 0.01 m
    A, J = _global_tensor(system, body)
    u = d / np.linalg.norm(d)
    L = np.linalg.norm(d)
    np.testing.assert_allclose(A[:, 2], u, atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(A), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(J)),
                               np.sort([2.0 * 1e-4 / 2, 2.0 * (3e-4 + L * L) / 12, 2.0 * (3e-4 + L * L) / 12]),
                               rtol=1e-14)


def test_box_textbook_moments_and_rotated_orientation():
    a, b, c, m = 0.4, 0.2, 0.1, 3.0
    moments = m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    rot = Rotation.from_euler("ZXZ", [0.3, 1.1, -0.7])
    p = rot.as_quat(scalar_first=True)
    system = System()
    body = system.add_box("box", (1.0, 2.0, 3.0), (a, b, c), m, orientation=p)
    np.testing.assert_allclose(np.diag(body.inertia), moments, rtol=1e-15)
    A, J = _global_tensor(system, body)
    R = rot.as_matrix()
    np.testing.assert_allclose(A, R, atol=1e-15)
    np.testing.assert_allclose(J, R @ np.diag(moments) @ R.T, atol=1e-14 * moments.max())
    np.testing.assert_allclose(system.state.q[:3], [1.0, 2.0, 3.0])
    cube = System().add_box("cube", (0, 0, 0), (0.5, 0.5, 0.5), 1.0)
    np.testing.assert_allclose(np.diag(cube.inertia), [0.5**2 / 6] * 3, rtol=1e-15)  # m s^2 / 6


def test_cylinder_textbook_moments():
    r, L, m = 0.1, 0.6, 4.0
    system = System()
    axis = np.array([1.0, 1.0, 0.0])
    body = system.add_cylinder("drum", (0, 0, 1), axis, r, L, m)
    A, J = _global_tensor(system, body)
    u = axis / np.linalg.norm(axis)
    np.testing.assert_allclose(A[:, 2], u, atol=1e-15)
    side, axial = m * (3 * r * r + L * L) / 12, m * r * r / 2
    np.testing.assert_allclose(J, side * (np.eye(3) - np.outer(u, u)) + axial * np.outer(u, u), atol=1e-14 * side)
    disk = System().add_cylinder("disk", (0, 0, 0), (0, 0, 1), 0.5, 0.0, 2.0)
    np.testing.assert_allclose(np.diag(disk.inertia), [2.0 * 0.25 / 4, 2.0 * 0.25 / 4, 2.0 * 0.25 / 2])  # thin disk


def test_shape_errors():
    system = System()
    with pytest.raises(ValueError, match=r"start, end: expected two different points"):
        system.add_rod("r", (1, 2, 3), (1, 2, 3), 1.0)
    with pytest.raises(ValueError, match=r"radius: expected a finite number >= 0"):
        system.add_rod("r", (0, 0, 0), (1, 0, 0), 1.0, radius=-0.1)
    with pytest.raises(ValueError, match=r"mass: expected a finite number > 0"):
        system.add_box("b", (0, 0, 0), (1, 1, 1), 0.0)
    with pytest.raises(ValueError, match=r"size: expected edge lengths >= 0"):
        system.add_box("b", (0, 0, 0), (1, -1, 1), 1.0)
    with pytest.raises(ValueError, match=r"axis: expected a nonzero axis"):
        system.add_cylinder("c", (0, 0, 0), (0, 0, 0), 0.1, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"orientation: expected unit Euler parameters"):
        system.add_box("b", (0, 0, 0), (1, 1, 1), 1.0, orientation=(2, 0, 0, 0))
    assert system.bodies == ()


# --------------------------------------------------------------- Modes.flexible
def _free_free(damping=0.0):
    """Two free boxes in space joined by a spring between their centres: one vibration mode, eleven rigid."""
    system = System(gravity=(0.0, 0.0, 0.0))
    a = system.add_box("a", (0, 0, 0), (0.2, 0.1, 0.1), 2.0)
    b = system.add_box("b", (1, 0, 0), (0.1, 0.3, 0.2), 3.0)
    system.add_spring_damper(a, (0, 0, 0), b, (1, 0, 0), stiffness=600.0, damping=damping)
    return system


def test_flexible_leaves_out_the_rigid_modes_of_a_free_free_system():
    modes = linearize(_free_free()).modes()
    assert modes.method == "symmetric"
    assert int(np.sum(modes.rigid)) == 2 * 11
    flexible = modes.flexible
    # the axial mode of two masses on a spring: omega^2 = k (1/m1 + 1/m2); linearize is exact for a spring
    # between centres at rest, so round-off only (1e-12)
    np.testing.assert_allclose(flexible.omega_n, [np.sqrt(600.0 * (1 / 2.0 + 1 / 3.0))], rtol=1e-12)
    assert flexible.eigenvalues.imag[0] > 0 and not flexible.rigid.any()
    assert flexible.embedding is modes.embedding


def test_flexible_of_a_damped_free_free_system_keeps_one_root_per_pair():
    modes = linearize(_free_free(damping=20.0)).modes()
    assert modes.method == "state-space"
    flexible = modes.flexible
    k, c, mu = 600.0, 20.0, 1 / (1 / 2.0 + 1 / 3.0)  # reduced mass
    s = (-c + np.sqrt(complex(c * c - 4 * mu * k))) / (2 * mu)  # mu s^2 + c s + k = 0, the upper root
    # the state-space problem with 22 rigid roots deflated: ~1e-10 relative to the scale of the roots
    np.testing.assert_allclose(flexible.eigenvalues, [s], rtol=1e-9)


def test_flexible_of_matrices_one_entry_per_mode_ascending():
    # omega^2 = 9, 0 (rigid), -4 (divergent: roots +-2), 1: three modes by omega_n 1, 2, 3
    modes = LinearModel(np.eye(4), np.diag([9.0, 0.0, -4.0, 1.0])).modes()
    flexible = modes.flexible
    np.testing.assert_allclose(flexible.omega_n, [1.0, 2.0, 3.0], rtol=1e-14)
    np.testing.assert_allclose(flexible.eigenvalues, [1j, 2.0, 3j], atol=1e-14)
    assert list(flexible.stable) == [True, False, True]
    np.testing.assert_allclose(np.abs(flexible.shapes), np.eye(4)[[3, 2, 0]], atol=1e-14)
    # overdamped (state space): two real roots of one coordinate, both kept (each is its own motion)
    over = LinearModel(np.eye(1), np.array([[1.0]]), C=np.array([[5.0]])).modes().flexible
    np.testing.assert_allclose(np.sort(over.eigenvalues.real), np.sort(np.roots([1.0, 5.0, 1.0])), rtol=1e-12)
    assert np.all(over.eigenvalues.imag == 0)
