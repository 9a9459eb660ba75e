"""Complex input is refused by every public entry point of the core.

numpy casts complex arrays to float64 by dropping the imaginary part (with
only a ComplexWarning); the core used to compute silently with the real
part. Every array argument of every public function (and the array
arguments of the public classes and methods) is replaced in turn by its
complex twin, with a zero and with a non-zero imaginary part, and must
raise a ValueError saying ``real numbers, got complex``. A coverage check
keeps the table complete when public names are added.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import rigidlab.core.gyroscope as gy
import rigidlab.core.integrators as itg
import rigidlab.core.manipulator as mp
import rigidlab.core.rigid_body as rb
import rigidlab.core.rotations as cr

P = np.array([0.5, 0.5, 0.5, 0.5])
Q = np.array([np.cos(0.3), 0.0, np.sin(0.3), 0.0])
A = cr.matrix_from_euler_parameters(P)
ANGLES = np.array([0.3, 0.7, -0.2])
AXIS = np.array([0.0, 0.6, 0.8])
V3 = np.array([0.1, -0.2, 0.3])
GAMMA = np.array([0.1, 0.2, -0.1])
INERTIA = np.array([1.0, 2.0, 2.5])
STATE13 = np.concatenate([V3, P, V3, V3])
STATE12 = np.concatenate([V3, GAMMA, V3, V3])
STATE7 = np.concatenate([P, V3])
ROTOR = gy.RotorParams(I=1.0, I3=0.6, mgl=0.5)
S6 = np.array([0.1, 0.8, 0.0, 0.5, 0.2, 20.0])
T = np.linspace(0.0, 1.0, 5)
BODY = rb.RigidBody(2.0, INERTIA)
FREE = rb.FreeBodyModel(INERTIA)
SOLUTION = rb.free_body_solution(INERTIA, V3, P)
TOP = gy.top_motion(ROTOR, S6)
GEOMETRY = mp.ManipulatorGeometry()


class Oscillator:
    state_size = 2

    def rhs(self, t, y):
        return np.array([y[1], -y[0]])


# (label, callable, positional args, indices of the array arguments)
CALLS = [
    # core.rotations
    ("cr.alpha_body_from_euler_angle_rates", cr.alpha_body_from_euler_angle_rates, (ANGLES, V3, V3), (0, 1, 2)),
    ("cr.alpha_body_from_euler_parameters", cr.alpha_body_from_euler_parameters, (P, Q), (0, 1)),
    ("cr.alpha_from_euler_angle_rates", cr.alpha_from_euler_angle_rates, (ANGLES, V3, V3), (0, 1, 2)),
    ("cr.alpha_from_euler_parameters", cr.alpha_from_euler_parameters, (P, Q), (0, 1)),
    ("cr.axis_angle_from_euler_parameters", cr.axis_angle_from_euler_parameters, (P,), (0,)),
    ("cr.axis_angle_from_matrix", cr.axis_angle_from_matrix, (A,), (0,)),
    ("cr.canonical_euler_parameters", cr.canonical_euler_parameters, (P,), (0,)),
    ("cr.check_euler_parameters", cr.check_euler_parameters, (P,), (0,)),
    ("cr.check_matrix", cr.check_matrix, (A,), (0,)),
    ("cr.constant_relative_rotation_residual", cr.constant_relative_rotation_residual,
     (P, Q, AXIS, 0.5, 1.0), (0, 1, 2, 3, 4)),
    ("cr.elementary_matrix", cr.elementary_matrix, (2, 0.4), (1,)),
    ("cr.euler_angle_G", cr.euler_angle_G, (ANGLES,), (0,)),
    ("cr.euler_angle_G_bar", cr.euler_angle_G_bar, (ANGLES,), (0,)),
    ("cr.euler_angle_rates", cr.euler_angle_rates, (ANGLES, V3), (0, 1)),
    ("cr.euler_angle_rates_from_omega", cr.euler_angle_rates_from_omega, (ANGLES, V3), (0, 1)),
    ("cr.euler_angles_from_euler_parameters", cr.euler_angles_from_euler_parameters, (P,), (0,)),
    ("cr.euler_angles_from_matrix", cr.euler_angles_from_matrix, (A,), (0,)),
    ("cr.euler_angles_near_singularity", cr.euler_angles_near_singularity, (ANGLES,), (0,)),
    ("cr.euler_parameter_G", cr.euler_parameter_G, (P,), (0,)),
    ("cr.euler_parameter_G_bar", cr.euler_parameter_G_bar, (P,), (0,)),
    ("cr.euler_parameter_accelerations", cr.euler_parameter_accelerations, (P, V3, V3), (0, 1, 2)),
    ("cr.euler_parameter_rates", cr.euler_parameter_rates, (P, V3), (0, 1)),
    ("cr.euler_parameter_rates_from_omega", cr.euler_parameter_rates_from_omega, (P, V3), (0, 1)),
    ("cr.euler_parameters_from_axis_angle", cr.euler_parameters_from_axis_angle, (AXIS, 0.4), (0, 1)),
    ("cr.euler_parameters_from_euler_angles", cr.euler_parameters_from_euler_angles, (ANGLES,), (0,)),
    ("cr.euler_parameters_from_matrix", cr.euler_parameters_from_matrix, (A,), (0,)),
    ("cr.euler_parameters_from_mrp", cr.euler_parameters_from_mrp, (GAMMA,), (0,)),
    ("cr.euler_parameters_from_rodriguez_parameters", cr.euler_parameters_from_rodriguez_parameters, (GAMMA,), (0,)),
    ("cr.euler_parameters_from_rotation_vector", cr.euler_parameters_from_rotation_vector, (V3,), (0,)),
    ("cr.matrix_from_axis_angle", cr.matrix_from_axis_angle, (AXIS, 0.4), (0, 1)),
    ("cr.matrix_from_euler_angles", cr.matrix_from_euler_angles, (ANGLES,), (0,)),
    ("cr.matrix_from_euler_parameters", cr.matrix_from_euler_parameters, (P,), (0,)),
    ("cr.matrix_from_mrp", cr.matrix_from_mrp, (GAMMA,), (0,)),
    ("cr.matrix_from_quaternion_product", cr.matrix_from_quaternion_product, (P, Q), (0, 1)),
    ("cr.matrix_from_rodriguez_parameters", cr.matrix_from_rodriguez_parameters, (GAMMA,), (0,)),
    ("cr.matrix_from_rotation_vector", cr.matrix_from_rotation_vector, (V3,), (0,)),
    ("cr.mrp_from_euler_parameters", cr.mrp_from_euler_parameters, (P,), (0,)),
    ("cr.mrp_from_matrix", cr.mrp_from_matrix, (A,), (0,)),
    ("cr.normalize_euler_parameters", cr.normalize_euler_parameters, (P,), (0,)),
    ("cr.omega_body_from_axis_angle_rates", cr.omega_body_from_axis_angle_rates,
     (AXIS, 0.4, np.array([1.0, 0.0, 0.0]), 0.2), (0, 1, 2, 3)),
    ("cr.omega_body_from_euler_angle_rates", cr.omega_body_from_euler_angle_rates, (ANGLES, V3), (0, 1)),
    ("cr.omega_body_from_euler_parameter_rates", cr.omega_body_from_euler_parameter_rates, (P, Q), (0, 1)),
    ("cr.omega_body_from_rodriguez_parameter_rates", cr.omega_body_from_rodriguez_parameter_rates,
     (GAMMA, V3), (0, 1)),
    ("cr.omega_from_axis_angle_rates", cr.omega_from_axis_angle_rates,
     (AXIS, 0.4, np.array([1.0, 0.0, 0.0]), 0.2), (0, 1, 2, 3)),
    ("cr.omega_from_euler_angle_rates", cr.omega_from_euler_angle_rates, (ANGLES, V3), (0, 1)),
    ("cr.omega_from_euler_parameter_rates", cr.omega_from_euler_parameter_rates, (P, Q), (0, 1)),
    ("cr.omega_from_rodriguez_parameter_rates", cr.omega_from_rodriguez_parameter_rates, (GAMMA, V3), (0, 1)),
    ("cr.quaternion_conjugate", cr.quaternion_conjugate, (P,), (0,)),
    ("cr.quaternion_inverse", cr.quaternion_inverse, (P,), (0,)),
    ("cr.quaternion_norm", cr.quaternion_norm, (P,), (0,)),
    ("cr.quaternion_product", cr.quaternion_product, (P, Q), (0, 1)),
    ("cr.quaternion_sum", cr.quaternion_sum, (P, Q), (0, 1)),
    ("cr.relative_euler_parameters", cr.relative_euler_parameters, (P, Q), (0, 1)),
    ("cr.rodriguez_parameter_rates", cr.rodriguez_parameter_rates, (GAMMA, V3), (0, 1)),
    ("cr.rodriguez_parameter_rates_from_omega", cr.rodriguez_parameter_rates_from_omega, (GAMMA, V3), (0, 1)),
    ("cr.rodriguez_parameters_from_euler_parameters", cr.rodriguez_parameters_from_euler_parameters, (P,), (0,)),
    ("cr.rodriguez_parameters_from_matrix", cr.rodriguez_parameters_from_matrix, (A,), (0,)),
    ("cr.rodriguez_parameters_near_singularity", cr.rodriguez_parameters_near_singularity, (P,), (0,)),
    ("cr.rotate_vector", cr.rotate_vector, (P, V3), (0, 1)),
    ("cr.rotation_vector_from_euler_parameters", cr.rotation_vector_from_euler_parameters, (P,), (0,)),
    ("cr.rotation_vector_from_matrix", cr.rotation_vector_from_matrix, (A,), (0,)),
    ("cr.skew", cr.skew, (V3,), (0,)),
    ("cr.to_scipy", cr.to_scipy, (P,), (0,)),
    ("cr.vector_from_skew", cr.vector_from_skew, (cr.skew(V3),), (0,)),
    # core.rigid_body
    ("rb.angular_momentum_body", rb.angular_momentum_body, (INERTIA, V3), (0, 1)),
    ("rb.angular_momentum_global", rb.angular_momentum_global, (INERTIA, V3, P), (0, 1, 2)),
    ("rb.euler_parameter_norm_error", rb.euler_parameter_norm_error, (P,), (0,)),
    ("rb.euler_parameter_state", rb.euler_parameter_state, (V3, P, V3, V3), (0, 1, 2, 3)),
    ("rb.free_body_exact", rb.free_body_exact, (INERTIA, V3, P, T), (0, 1, 2, 3)),
    ("rb.free_body_solution", rb.free_body_solution, (INERTIA, V3, P), (0, 1, 2)),
    ("rb.free_body_state", rb.free_body_state, (P, V3), (0, 1)),
    ("rb.kinetic_energy", rb.kinetic_energy, (2.0, INERTIA, V3, V3), (0, 1, 2, 3)),
    ("rb.momentum_geometry", rb.momentum_geometry, (INERTIA, V3), (0, 1)),
    ("rb.principal_axes", rb.principal_axes, (INERTIA,), (0,)),
    ("rb.rodriguez_state", rb.rodriguez_state, (V3, GAMMA, V3, V3), (0, 1, 2, 3)),
    ("rb.rotation_angle_between", rb.rotation_angle_between, (P, Q), (0, 1)),
    ("rb.rotational_kinetic_energy", rb.rotational_kinetic_energy, (INERTIA, V3), (0, 1)),
    ("rb.RigidBody", rb.RigidBody, (2.0, INERTIA), (0, 1)),
    ("rb.FreeBodyModel", rb.FreeBodyModel, (INERTIA,), (0,)),
    ("rb.FreeBodyModel.rhs", FREE.rhs, (0.0, STATE7), (1,)),
    ("rb.FreeBodyModel.invariants", FREE.invariants, (STATE7,), (0,)),
    ("rb.FreeBodyModel.exact", FREE.exact, (STATE7, T), (0, 1)),
    ("rb.FreeBodyModel.angular_momentum_global", FREE.angular_momentum_global, (V3, P), (0, 1)),
    ("rb.FreeBodyModel.to_split_state", FREE.to_split_state, (STATE7,), (0,)),
    ("rb.FreeBodySolution.at", SOLUTION.at, (T,), (0,)),
    ("rb.EulerParameterModel.rhs", rb.EulerParameterModel(BODY).rhs, (0.0, STATE13), (1,)),
    ("rb.EulerParameterModel.invariants", rb.EulerParameterModel(BODY).invariants, (STATE13,), (0,)),
    ("rb.RodriguezModel.rhs", rb.RodriguezModel(BODY).rhs, (0.0, STATE12), (1,)),
    ("rb.RodriguezModel.invariants", rb.RodriguezModel(BODY).invariants, (STATE12,), (0,)),
    ("rb.RodriguezModel.euler_parameters", rb.RodriguezModel.euler_parameters, (STATE12,), (0,)),
    # core.gyroscope
    ("gy.equations_of_motion", gy.equations_of_motion, (ROTOR, S6, V3), (1, 2)),
    ("gy.invariants", gy.invariants, (ROTOR, S6), (1,)),
    ("gy.nutation", gy.nutation, (ROTOR, S6), (1,)),
    ("gy.rotor_vectors", gy.rotor_vectors, (ROTOR, S6, V3), (1, 2)),
    ("gy.simulate", gy.simulate, (ROTOR, S6, T, V3), (1, 2, 3)),
    ("gy.sample_motion", gy.sample_motion, (gy.RotorSetup(ROTOR, tuple(S6)), T), (1,)),
    ("gy.steady_precession_rates", gy.steady_precession_rates, (ROTOR, 0.8, 20.0), (1, 2)),
    ("gy.steady_precession_torque", gy.steady_precession_torque, (ROTOR, 0.8, 0.5, 20.0), (1, 2, 3)),
    ("gy.top_motion", gy.top_motion, (ROTOR, S6), (1,)),
    ("gy.TopMotion.at", TOP.at, (T,), (0,)),
    ("gy.RotorParams", gy.RotorParams, (1.0, 0.6, 0.5), (0, 1, 2)),
    # core.integrators
    ("itg.rk4_step", itg.rk4_step, (Oscillator(), np.array([1.0, 0.0]), 0.1), (1, 2)),
    ("itg.implicit_midpoint_step", itg.implicit_midpoint_step, (Oscillator(), np.array([1.0, 0.0]), 0.1), (1, 2)),
    ("itg.splitting_step", itg.splitting_step, (FREE, STATE7, 0.1), (1, 2)),
    ("itg.splitting4_step", itg.splitting4_step, (FREE, STATE7, 0.1), (1, 2)),
    ("itg.splitting6_step", itg.splitting6_step, (FREE, STATE7, 0.1), (1, 2)),
    ("itg.splitting8_step", itg.splitting8_step, (FREE, STATE7, 0.1), (1, 2)),
    ("itg.integrate", lambda model, y0, span: itg.integrate(model, y0, span, method="splitting", dt=0.1),
     (FREE, STATE7, (0.0, 1.0)), (1,)),
    ("itg.drift_report", itg.drift_report, (FREE, STATE7[None]), (1,)),
    # core.manipulator
    ("mp.end_link_angular_velocity", mp.end_link_angular_velocity, (ANGLES, V3), (0, 1)),
    ("mp.euler_form", mp.euler_form, (ANGLES,), (0,)),
    ("mp.link_frames_global_axis_rotations", mp.link_frames_global_axis_rotations, (ANGLES,), (0,)),
    ("mp.link_frames_successive", mp.link_frames_successive, (ANGLES,), (0,)),
    ("mp.matrix_from_global_axis_rotations", mp.matrix_from_global_axis_rotations, (ANGLES,), (0,)),
    ("mp.matrix_from_successive_rotations", mp.matrix_from_successive_rotations, (ANGLES,), (0,)),
    ("mp.relative_rotation_matrices", mp.relative_rotation_matrices, (ANGLES,), (0,)),
    ("mp.ManipulatorGeometry", mp.ManipulatorGeometry,
     (np.eye(3)[[2, 0, 2]], np.array([0.6, 0.8, 0.5]), np.eye(3)[[2, 2, 2]]), (0, 1, 2)),
]

# Public names without array arguments (or that take none of their own).
NOT_ARRAY_FUNCTIONS = {
    "cr.from_scipy",  # takes a scipy Rotation
    "cr.is_rotation_matrix",  # a predicate: False for complex input (tested below)
    "gy.sleeping_top_critical_spin",  # takes RotorParams only
}


def _complex_twins(x):
    arr = np.asarray(x, dtype=float)
    return [arr + 0j, arr + 1e-3j]


@pytest.mark.parametrize(
    "label, f, args, which",
    CALLS,
    ids=[row[0] for row in CALLS],
)
def test_complex_input_is_refused(label, f, args, which):
    f(*args)  # the real inputs are valid
    for k in which:
        for twin in _complex_twins(args[k]):
            bad = list(args)
            bad[k] = twin if np.ndim(twin) else twin[()]
            with pytest.raises(ValueError, match=r"real numbers, got complex"):
                f(*bad)


def test_complex_keyword_and_callable_outputs_are_refused():
    with pytest.raises(ValueError, match=r"dt: expected real numbers, got complex"):
        itg.integrate(FREE, STATE7, (0.0, 1.0), dt=0.1 + 0j)
    with pytest.raises(ValueError, match=r"t_span: expected real numbers, got complex"):
        itg.integrate(FREE, STATE7, (0.0, np.complex128(1.0)), dt=0.1)
    with pytest.raises(ValueError, match=r"t: expected real numbers, got complex"):
        itg.rk4_step(FREE, STATE7, 0.1, t=1j)
    with pytest.raises(ValueError, match=r"rtol, atol: expected real numbers, got complex"):
        itg.integrate(FREE, STATE7, (0.0, 1.0), method="RK45", rtol=1e-8 + 0j)
    with pytest.raises(ValueError, match=r"t_eval: expected real numbers, got complex"):
        itg.integrate(FREE, STATE7, (0.0, 1.0), method="RK45", t_eval=T + 0j)
    with pytest.raises(ValueError, match=r"torques: expected real numbers, got complex"):
        gy.simulate(ROTOR, S6, T, torques=lambda t, s: np.array([0.1, 0.0, 0.0]) + 0j)
    body = rb.RigidBody(2.0, INERTIA, force=lambda t, y: V3 + 0j)
    with pytest.raises(ValueError, match=r"force: expected real numbers, got complex"):
        rb.EulerParameterModel(body).rhs(0.0, STATE13)
    # object arrays holding complex numbers are refused too
    with pytest.raises(ValueError, match=r"real numbers, got complex"):
        cr.matrix_from_euler_parameters(np.array([1.0, 0.0, 0.0, 1j * 0], dtype=object))
    with pytest.raises(ValueError, match=r"real numbers, got complex"):
        rb.principal_axes(np.array([1.0, 2.0, 2.5 + 0j], dtype=object))
    assert cr.is_rotation_matrix(A) and not cr.is_rotation_matrix(A + 0j)
    with pytest.raises(ValueError, match=r"gamma_max: expected real numbers, got complex"):
        rb.RodriguezModel(BODY, gamma_max=1e3 + 0j)
    with pytest.raises(ValueError, match=r"equal_tol: expected real numbers, got complex"):
        rb.free_body_solution(INERTIA, V3, P, equal_tol=1e-12 + 0j)
    with pytest.raises(ValueError, match=r"equal_tol: expected a finite tolerance >= 0, got -1\.0"):
        rb.free_body_solution(INERTIA, V3, P, equal_tol=-1.0)


def _public_callables(module, prefix):
    names = set()
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.isfunction(obj):
            names.add(f"{prefix}.{name}")
    return names


def test_every_public_function_is_in_the_table():
    listed = {row[0] for row in CALLS} | NOT_ARRAY_FUNCTIONS
    for module, prefix in ((cr, "cr"), (rb, "rb"), (gy, "gy"), (itg, "itg"), (mp, "mp")):
        missing = _public_callables(module, prefix) - listed
        assert not missing, f"add these public functions to CALLS: {sorted(missing)}"
