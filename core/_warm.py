"""Compile (or load from numba's cache) every compiled kernel once: ``python -m core._warm``.

The kernels are compiled with ``cache=True``: the first process on a machine
compiles them (about a minute of CPU, once per change of their source) and
writes numba's cache beside the modules; every later process, pytest worker
and app worker loads them from there in well under a second. ``rigidlab
serve`` runs this module in a child process at start, so that the first scene
never waits on compilation, and the test suite runs it once before its
workers start.
"""

from __future__ import annotations

import time

import numpy as np


def warm() -> float:
    """Run each compiled entry point once on a small model; returns the CPU seconds it took."""
    t0 = time.process_time()
    from core.models import pendulum_chain
    from core.multibody._simulate import _Dynamics
    from core.rotations import matrix_from_axis_angle, matrix_from_euler_parameters, euler_parameters_from_matrix

    system = pendulum_chain(2, tilt=0.5)
    system.add_spring_damper(system.ground, (0.0, 0.5, 0.0), system.bodies[1], (0.0, 0.0, -1.5), stiffness=1.0)
    system.assemble()
    system.simulate([0.0, 0.05, 0.1])  # the compiled step loop and projection
    eng = system._engine().workspace()
    model = _Dynamics(system, eng, stabilization="projection", baumgarte=1.0, position_tol=1e-10)
    y = np.array(system._y)
    model.rhs(0.0, y)  # the right-hand side as the interpreted loops call it
    kc = eng.compiled
    kc.select(None)
    kc.evaluate(0.0, y, 2)
    kc.applied(0.0, y, model._loads)
    kc.solve(0, kc.Q, kc.gamma, np.zeros(6 * eng.n))
    _warm_contacts()
    from core.modal import linearize

    linearize(pendulum_chain(2))  # the tree's null-space basis (_tree_basis)
    rng = np.random.default_rng(0)
    p = rng.normal(size=(128, 4))
    A = matrix_from_euler_parameters(p / np.linalg.norm(p, axis=1, keepdims=True))
    euler_parameters_from_matrix(A)
    axis = rng.normal(size=(128, 3))
    matrix_from_axis_angle(axis / np.linalg.norm(axis, axis=1, keepdims=True), rng.normal(size=128))
    return time.process_time() - t0


def _warm_contacts() -> None:
    """The compiled contact kernel (``core.contact._compiled``): a ball on the ground, every evaluation level."""
    from core.contact import Plane, Sphere
    from core.multibody import System
    from core.multibody._engine import matrices

    system = System(gravity=(0.0, 0.0, -9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004,) * 3, position=(0.0, 0.0, 0.1), omega_body=(1.0, 0, 0))
    system.add_contact(system.ground, Plane(), ball, Sphere(0.1), rolling=True)
    eng = system._engine().workspace()
    ker = eng.contact_kernel
    y = np.array(system._y)
    A = matrices(y[3:7].reshape(1, 4))
    for level in (0, 1, 2):
        ker.evaluate(y, A, level, ker.copy_state(eng.contact_state), t=0.0)


if __name__ == "__main__":
    print(f"rigidlab: compiled kernels ready ({warm():.1f} s of CPU)")
