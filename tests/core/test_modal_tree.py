"""The fast path of core.modal.linearize (compiled reference, the spanning tree's null-space basis, block-sparse
stiffness) against the general path (numpy evaluation, dense QR of the constraint Jacobian) on the same System.

The general path is the oracle: it is what linearize does for Systems the compiled kernels do not cover
(contacts), and it was the only path before. Both embed the same null space (Eq. 8.111), so the eigenvalues
agree to round-off and the bases span the same subspace (principal angles at round-off)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from rigidlab.core.modal import _orthonormal_columns, linearize
from rigidlab.core.gyroscope import RotorParams
from rigidlab.core.models import disk_rotor, pendulum_chain, spatial_double_pendulum, steady_top, two_mass_oscillator
from rigidlab.core.multibody import System
from rigidlab.core.multibody import _linearization as hooks
from rigidlab.core.multibody import _simulate

# Eigenvalues: the two paths differ by the multipliers of the reference (Baraff's O(N) solve against the dense
# solve: ~1e-13 relative on these systems, conditions up to ~1e3), the orthonormal basis of the null space and the
# summation order of the products; the eigenvalues move by that round-off times the conditioning of the
# eigenproblem (well separated roots; rigid modes at 0), far below 1e-10 of the largest |s|.
EIGEN_RTOL = 1e-10
# Principal angles between the two bases: a null space computed from rows of condition up to ~1e3 (lever arms
# of 10 m against unit axes) is fixed to ~1e3 eps.
ANGLE_TOL = 1e-11


def _general(make, **kwargs):
    """linearize on the general path: numpy reference, dense QR null space, numpy assembly check."""
    patch = pytest.MonkeyPatch()
    patch.setattr(hooks, "tree_null_space", lambda *a: None)
    patch.setattr(hooks, "_compiled_accelerations", lambda *a: None)
    patch.setattr(_simulate, "_assembled_compiled", lambda *a: False)
    try:
        return linearize(make(), **kwargs)
    finally:
        patch.undo()


def _rod(system, name, mass, length, position, orientation=(1.0, 0.0, 0.0, 0.0)):
    r = 0.01 * length
    inertia = (mass * length**2 / 12.0, mass * length**2 / 12.0, 0.5 * mass * r * r)
    return system.add_body(name, mass=mass, inertia=inertia, position=position, orientation=orientation)


def hanging_four_bar() -> System:
    """Two cranks hanging from the ground, their lower ends joined by a coupler: a closed loop of revolute
    joints (three rows redundant, two secondary rows on the tree), plus a pendulum hanging from the coupler."""
    system = System(gravity=(0.0, 0.0, -9.81))
    a = _rod(system, "crank_a", 1.0, 1.0, (0.0, -0.5, -0.5))
    b = _rod(system, "crank_b", 1.5, 1.0, (0.0, 0.5, -0.5))
    down = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))
    c = system.add_body("coupler", mass=2.0, inertia=(0.2, 0.01, 0.2), position=(0.0, 0.0, -1.0),
                        orientation=down)
    d = _rod(system, "bob", 0.5, 0.6, (0.0, 0.2, -1.3))
    x = (1.0, 0.0, 0.0)
    system.add_joint("revolute", system.ground, a, point=(0.0, -0.5, 0.0), axis=x)
    system.add_joint("revolute", system.ground, b, point=(0.0, 0.5, 0.0), axis=x)
    system.add_joint("revolute", a, c, point=(0.0, -0.5, -1.0), axis=x)
    system.add_joint("spherical", c, b, point=(0.0, 0.5, -1.0))
    system.add_joint("universal", c, d, point=(0.0, 0.2, -1.0), axis=x, axis_j=(0.0, 1.0, 0.0))
    system.assemble()
    system.equilibrium()
    return system


def branched_tree() -> System:
    """A trunk on a spherical joint carrying a revolute, a universal and a cylindrical branch, a slider on a
    prismatic joint, springs and a torsion spring (a tree with every joint kind but fixed, off symmetry)."""
    system = System(gravity=(0.0, 0.0, -9.81))
    trunk = system.add_body("trunk", mass=3.0, inertia=(0.3, 0.25, 0.05), position=(0.0, 0.0, -0.6))
    system.add_joint("spherical", system.ground, trunk, point=(0.0, 0.0, 0.0))
    left = _rod(system, "left", 1.0, 0.8, (0.0, -0.3, -1.5))
    j_left = system.add_joint("revolute", trunk, left, point=(0.0, -0.3, -1.1), axis=(1.0, 0.2, 0.0))
    system.add_rotational_spring_damper(j_left, stiffness=4.0)
    right = _rod(system, "right", 0.7, 0.6, (0.0, 0.3, -1.4))
    system.add_joint("universal", trunk, right, point=(0.0, 0.3, -1.1), axis=(1.0, 0.0, 0.0), axis_j=(0.0, 1.0, 0.0))
    tip = _rod(system, "tip", 0.4, 0.5, (0.0, 0.3, -1.95))
    system.add_joint("cylindrical", right, tip, point=(0.0, 0.3, -1.7), axis=(0.0, 0.0, 1.0))
    system.add_spring_damper(right, (0.0, 0.3, -1.7), tip, (0.0, 0.3, -1.8), stiffness=300.0)
    slider = system.add_body("slider", mass=0.5, inertia=(0.01, 0.01, 0.01), position=(0.2, 0.0, -1.0))
    system.add_joint("prismatic", trunk, slider, point=(0.2, 0.0, -1.0), axis=(1.0, 0.0, 0.0))
    system.add_spring_damper(trunk, (0.0, 0.0, -1.0), slider, (0.2, 0.0, -1.0), stiffness=50.0, free_length=0.1)
    system.assemble()
    system.equilibrium()
    return system


def free_base() -> System:
    """Without gravity: a free body (a root of the tree, six free columns) carrying a two-link arm."""
    system = System(gravity=(0.0, 0.0, 0.0))
    base = system.add_body("base", mass=5.0, inertia=(0.5, 0.4, 0.3), position=(0.0, 0.0, 0.0))
    a = _rod(system, "a", 1.0, 1.0, (0.5, 0.0, 0.0), (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0))
    b = _rod(system, "b", 1.0, 1.0, (1.5, 0.0, 0.0), (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0))
    system.add_joint("revolute", base, a, point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0))
    j = system.add_joint("revolute", a, b, point=(1.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    system.add_rotational_spring_damper(j, stiffness=10.0)
    system.assemble()
    return system


def gyro_pendulum() -> System:
    """A frame hanging from a spherical joint with a disk spinning at 200 rad/s on a revolute joint about the
    vertical, held sideways by a damped spring: gyroscopic and damped (the state-space problem)."""
    system = System(gravity=(0.0, 0.0, -9.81))
    frame = _rod(system, "frame", 1.0, 0.8, (0.0, 0.0, -0.4))
    system.add_joint("spherical", system.ground, frame, point=(0.0, 0.0, 0.0))
    disk = system.add_body("disk", mass=2.0, inertia=(0.01, 0.01, 0.02), position=(0.0, 0.0, -0.8),
                           omega_body=(0.0, 0.0, 200.0))
    system.add_joint("revolute", frame, disk, point=(0.0, 0.0, -0.8), axis=(0.0, 0.0, 1.0))
    system.add_spring_damper(system.ground, (0.3, 0.0, -0.8), frame, (0.0, 0.0, -0.8), stiffness=20.0,
                             damping=0.5)
    system.assemble()
    return system


def held_chain() -> System:
    """A chain of four rods whose second joint an angle motor holds at zero and whose third a displacement
    motor holds on a cylindrical joint: tree joints of six rows (no free direction) and motor rows."""
    system = System(gravity=(0.0, 0.0, -9.81))
    x = (1.0, 0.0, 0.0)
    prev = system.ground
    joints = []
    for k in range(4):
        body = _rod(system, f"rod{k}", 1.0 + 0.2 * k, 1.0, (0.0, 0.0, -(k + 0.5)))
        kind = "cylindrical" if k == 2 else "revolute"
        joints.append(system.add_joint(kind, prev, body, point=(0.0, 0.0, -float(k)), axis=x if k != 2 else
                                       (0.0, 0.0, 1.0)))
        prev = body
    system.add_motor(joints[1], angle=lambda t: 0.0 * t)
    system.add_motor(joints[2], displacement=lambda t: 0.0 * t)
    system.assemble()
    return system


CASES = {
    "chain of 30 rods": lambda: pendulum_chain(30, kind="rod"),
    "four-bar loop with a pendulum": hanging_four_bar,
    "chain held by motors": held_chain,
    "branched tree with springs": branched_tree,
    "free base with an arm": free_base,
    "spinning rotor on springs": lambda: disk_rotor(300.0).system,
    "gyroscopic pendulum with a damper": gyro_pendulum,
    "sleeping top": lambda: steady_top(RotorParams(I=0.05, I3=0.02, mgl=0.5), spin=40.0).system,
    "two-mass oscillator": lambda: two_mass_oscillator().system,
    "spatial double pendulum": lambda: spatial_double_pendulum(tilt=(0.0, 0.0), azimuth=(0.0, 0.0),
                                                               spin=0.0).system,
}


@pytest.mark.parametrize("name", list(CASES))
def test_fast_path_agrees_with_the_general_path(name):
    make = CASES[name]
    system = make()
    eng, ref = hooks.reference(system, system.state.t, np.zeros(3))
    assert hooks.tree_null_space(eng, ref) is not None  # (the fast path is taken)
    fast = linearize(system)
    general = _general(make)
    assert fast.n_dof == general.n_dof
    angles = scipy.linalg.subspace_angles(fast.embedding.basis, general.embedding.basis)
    assert np.max(angles) <= ANGLE_TOL
    f = fast.n_dof
    np.testing.assert_allclose(fast.embedding.basis.T @ fast.embedding.basis, np.eye(f), rtol=0, atol=1e-14)
    mf, mg = fast.modes(), general.modes()
    assert mf.method == mg.method
    np.testing.assert_allclose(mf.eigenvalues, mg.eigenvalues, rtol=0, atol=EIGEN_RTOL * mg.scale)
    np.testing.assert_array_equal(mf.rigid, mg.rigid)
    np.testing.assert_array_equal(mf.stable, mg.stable)
    # the complex shapes of the simple modes, embedded (z = N u, independent of the basis), are parallel: MAC 1
    # to round-off (a multiple root's shapes are any basis of its eigenspace and are left out)
    simple = np.array([np.sum(np.abs(mg.eigenvalues - s) <= 1e-6 * mg.scale) == 1 for s in mg.eigenvalues])
    zf = mf.complex_shapes[simple] @ fast.embedding.basis.T
    zg = mg.complex_shapes[simple] @ general.embedding.basis.T
    mac = np.abs(np.sum(np.conj(zf) * zg, axis=1)) ** 2 / (np.sum(np.abs(zf) ** 2, axis=1)
                                                          * np.sum(np.abs(zg) ** 2, axis=1))
    np.testing.assert_allclose(mac, 1.0, rtol=0, atol=1e-10)


def test_the_loop_rows_are_secondary_and_redundant_rows_dropped():
    system = hanging_four_bar()
    eng, ref = hooks.reference(system, system.state.t, np.zeros(3))
    assert eng.keep is not None and eng.keep.size < eng.m  # the planar loop's redundant rows
    B = hooks.tree_null_space(eng, ref)
    assert eng.compiled.tree_now.sec_rows.size > 0
    # every kept row, tree or loop, is met by the basis: D_z B = 0 (D in [R_dot, omega_body], dpi = A^T dtheta)
    n = eng.n
    Dz = ref.D[eng.keep].copy()
    Dz[:, 3 * n :] = np.einsum("rbi,bji->rbj", Dz[:, 3 * n :].reshape(-1, n, 3), ref.A).reshape(-1, 3 * n)
    assert np.max(np.abs(Dz @ B)) <= 1e-13 * np.max(np.abs(Dz)) * np.max(np.abs(B))
    assert B.shape[1] == linearize(system).n_dof == 3  # the four-bar's swing and the pendulum's two


def test_systems_off_the_compiled_kernels_take_the_general_path():
    """Point masses (zero rotational inertia) are not compiled: no tree basis, the dense null space."""
    system = pendulum_chain(3, kind="point")
    eng, ref = hooks.reference(system, 0.0, np.zeros(3))
    assert eng.compiled is None and hooks.tree_null_space(eng, ref) is None


def test_orthonormal_columns_against_householder():
    """Cholesky QR twice spans the columns and is orthonormal; ill-conditioned columns take Householder QR."""
    rng = np.random.default_rng(3)
    for cond in (1.0, 1e3, 1e9):
        U, _ = np.linalg.qr(rng.normal(size=(60, 12)))
        V, _ = np.linalg.qr(rng.normal(size=(12, 12)))
        B = U @ np.diag(np.logspace(0.0, -math.log10(cond), 12)) @ V
        Q = _orthonormal_columns(B)
        np.testing.assert_allclose(Q.T @ Q, np.eye(12), rtol=0, atol=1e-14)
        # the same span as the thin QR (angles at round-off times the condition)
        assert np.max(scipy.linalg.subspace_angles(Q, U)) <= 1e-15 * cond * 100
