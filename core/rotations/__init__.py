"""Rotations in every representation of the chapter, batched over leading axes.

Conventions (stated once in ``docs/conventions.md``): right-handed frames;
rotation matrices are active and map body to global (``u_global = A @
u_body``); Euler parameters are unit quaternions, scalar first
``(theta0, theta1, theta2, theta3)`` (viser's ``wxyz``); Euler angle
sequences use scipy's letters (upper case intrinsic, lower case extrinsic);
``omega`` is in the global frame and ``omega_body`` in the body frame;
radians; float64 arrays whose representation lives in the last axis (or
last two).
"""

from ._axis_angle import (
    axis_angle_from_matrix,
    matrix_from_axis_angle,
    omega_body_from_axis_angle_rates,
    omega_from_axis_angle_rates,
)
from ._euler_angles import (
    GIMBAL_LOCK_TOL,
    GimbalLockWarning,
    alpha_body_from_euler_angle_rates,
    alpha_from_euler_angle_rates,
    euler_angle_G,
    euler_angle_G_bar,
    euler_angle_rates,
    euler_angle_rates_from_omega,
    euler_angles_from_euler_parameters,
    euler_angles_from_matrix,
    euler_angles_near_singularity,
    euler_parameters_from_euler_angles,
    matrix_from_euler_angles,
    omega_body_from_euler_angle_rates,
    omega_from_euler_angle_rates,
)
from ._euler_parameters import (
    alpha_body_from_euler_parameters,
    alpha_from_euler_parameters,
    axis_angle_from_euler_parameters,
    canonical_euler_parameters,
    euler_parameter_accelerations,
    euler_parameter_G,
    euler_parameter_G_bar,
    euler_parameter_rates,
    euler_parameter_rates_from_omega,
    euler_parameters_from_axis_angle,
    euler_parameters_from_matrix,
    matrix_from_euler_parameters,
    normalize_euler_parameters,
    omega_body_from_euler_parameter_rates,
    omega_from_euler_parameter_rates,
)
from ._matrix import elementary_matrix, is_rotation_matrix, skew, vector_from_skew
from ._mrp import (
    euler_parameters_from_mrp,
    matrix_from_mrp,
    mrp_from_euler_parameters,
    mrp_from_matrix,
)
from ._quaternion import (
    constant_relative_rotation_residual,
    matrix_from_quaternion_product,
    quaternion_conjugate,
    quaternion_inverse,
    quaternion_norm,
    quaternion_product,
    quaternion_sum,
    relative_euler_parameters,
    rotate_vector,
)
from ._rodriguez_parameters import (
    RODRIGUEZ_SINGULARITY_TOL,
    euler_parameters_from_rodriguez_parameters,
    matrix_from_rodriguez_parameters,
    omega_body_from_rodriguez_parameter_rates,
    omega_from_rodriguez_parameter_rates,
    rodriguez_parameter_rates,
    rodriguez_parameter_rates_from_omega,
    rodriguez_parameters_from_euler_parameters,
    rodriguez_parameters_from_matrix,
    rodriguez_parameters_near_singularity,
)
from ._rotation_vector import (
    euler_parameters_from_rotation_vector,
    matrix_from_rotation_vector,
    rotation_vector_from_euler_parameters,
    rotation_vector_from_matrix,
)
from ._scipy_boundary import from_scipy, to_scipy
from ._validation import (
    ORTHOGONALITY_TOL,
    UNIT_NORM_TOL,
    check_euler_parameters,
    check_matrix,
)

__all__ = [
    "GIMBAL_LOCK_TOL",
    "ORTHOGONALITY_TOL",
    "RODRIGUEZ_SINGULARITY_TOL",
    "UNIT_NORM_TOL",
    "GimbalLockWarning",
    "alpha_body_from_euler_angle_rates",
    "alpha_body_from_euler_parameters",
    "alpha_from_euler_angle_rates",
    "alpha_from_euler_parameters",
    "axis_angle_from_euler_parameters",
    "axis_angle_from_matrix",
    "canonical_euler_parameters",
    "check_euler_parameters",
    "check_matrix",
    "constant_relative_rotation_residual",
    "elementary_matrix",
    "euler_angle_G",
    "euler_angle_G_bar",
    "euler_angle_rates",
    "euler_angle_rates_from_omega",
    "euler_angles_from_euler_parameters",
    "euler_angles_from_matrix",
    "euler_angles_near_singularity",
    "euler_parameter_G",
    "euler_parameter_G_bar",
    "euler_parameter_accelerations",
    "euler_parameter_rates",
    "euler_parameter_rates_from_omega",
    "euler_parameters_from_axis_angle",
    "euler_parameters_from_euler_angles",
    "euler_parameters_from_matrix",
    "euler_parameters_from_mrp",
    "euler_parameters_from_rodriguez_parameters",
    "euler_parameters_from_rotation_vector",
    "from_scipy",
    "is_rotation_matrix",
    "matrix_from_axis_angle",
    "matrix_from_euler_angles",
    "matrix_from_euler_parameters",
    "matrix_from_mrp",
    "matrix_from_quaternion_product",
    "matrix_from_rodriguez_parameters",
    "matrix_from_rotation_vector",
    "mrp_from_euler_parameters",
    "mrp_from_matrix",
    "normalize_euler_parameters",
    "omega_body_from_axis_angle_rates",
    "omega_body_from_euler_angle_rates",
    "omega_body_from_euler_parameter_rates",
    "omega_body_from_rodriguez_parameter_rates",
    "omega_from_axis_angle_rates",
    "omega_from_euler_angle_rates",
    "omega_from_euler_parameter_rates",
    "omega_from_rodriguez_parameter_rates",
    "quaternion_conjugate",
    "quaternion_inverse",
    "quaternion_norm",
    "quaternion_product",
    "quaternion_sum",
    "relative_euler_parameters",
    "rodriguez_parameter_rates",
    "rodriguez_parameter_rates_from_omega",
    "rodriguez_parameters_from_euler_parameters",
    "rodriguez_parameters_from_matrix",
    "rodriguez_parameters_near_singularity",
    "rotate_vector",
    "rotation_vector_from_euler_parameters",
    "rotation_vector_from_matrix",
    "skew",
    "vector_from_skew",
]
