"""Three-joint manipulator of Fig. 8.3: successive rotations and the Rodriguez formula.

The chapter finds the orientation of the end link of a manipulator with three
revolute joints in two ways and shows that they agree (Eqs. 8.39-8.45,
problem 12):

(a) **Successive relative rotations** (Eqs. 8.39-8.42). Joint ``k`` rotates
    link ``k`` about an axis fixed in the link before it, so

    .. math:: A = A_{21} A_{32} A_{43},

    where ``A21`` is the orientation of link 2 (the first moving link)
    relative to the ground frame 1, ``A32`` that of link 3 relative to link 2
    and ``A43`` that of link 4 (the end link) relative to link 3.

(b) **Rodriguez rotations about axes fixed in the global frame**
    (Eqs. 8.43-8.45). Starting from the zero configuration, rotate the end
    link about the global position of joint 3's axis, then links 3 and 4
    about joint 2's axis, then everything about joint 1's axis. Each step is
    the Rodriguez formula (Eq. 8.29) with the *fixed global* axis; because the
    joints are applied in the reverse order no axis has moved yet when it is
    used, and the product of the three global rotations equals ``A`` of (a).

Conventions (see docs/conventions.md): right-handed frames; rotation matrices
are active and map a link frame to the global (ground) frame,
``r_global = R + A @ u_link``; angles in radians; lengths in metres; arrays
batch over leading axes with the representation in the last axis (or two).

Frames and numbering. In the zero configuration (all joint angles zero) every
link frame is parallel to the global frame, joint 1 sits at the global origin
and link ``k`` (k = 1, 2, 3 here; links 2, 3, 4 in the chapter's body
numbering, whose ground is body 1) runs from joint ``k`` along
``link_directions[k - 1]`` for ``link_lengths[k - 1]``; joint ``k + 1`` sits at
its far end and the end object at the far end of link 3. Joint ``k`` rotates
link ``k`` about ``joint_axes[k - 1]``, a unit vector expressed in the frame of
the link before it (the ground for joint 1). Since all frames coincide in the
zero configuration, the same vectors are also the joint axes in the global
frame used by procedure (b).

The default geometry (:data:`DEFAULT_GEOMETRY`) has joint axes Z, X, Z: a base
turning about the vertical, a shoulder tilting about the turned X axis and a
wrist spinning about the tilted Z axis, with every link pointing along its own
Z axis. Its end-link orientation is the Z-X-Z (precession-nutation-spin) Euler
angle matrix, ``matrix_from_euler_angles(joint_angles, "ZXZ")``, which is the
chapter's point that the Euler angles describe exactly such a chain.
"""

from __future__ import annotations

import dataclasses

import math

import numpy as np

from rigidlab.core._validation import float_array, radians
from rigidlab.core.rotations import matrix_from_axis_angle

__all__ = [
    "DEFAULT_GEOMETRY",
    "EulerForm",
    "LinkFrames",
    "ManipulatorGeometry",
    "end_link_angular_velocity",
    "euler_form",
    "link_frames_global_axis_rotations",
    "link_frames_successive",
    "matrix_from_global_axis_rotations",
    "matrix_from_successive_rotations",
    "relative_rotation_matrices",
]

_UNIT_TOLERANCE = 1e-9
"""Allowed deviation of an axis or direction norm from 1 (a few ulps of input
rounding are fine, a non-unit vector is a mistake)."""

_AXIS_LETTERS = "XYZ"


def _as_unit_rows(value: object, name: str) -> np.ndarray:
    array = float_array(value, name, expected="a (3, 3) array of unit vectors", copy=True)
    if array.shape != (3, 3):
        raise ValueError(
            f"{name} must have shape (3, 3) (one unit 3-vector per joint), "
            f"got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    norms = np.linalg.norm(array, axis=-1)
    if np.any(np.abs(norms - 1.0) > _UNIT_TOLERANCE):
        raise ValueError(
            f"{name} rows must be unit vectors (norm 1 within "
            f"{_UNIT_TOLERANCE:g}), got norms {norms.tolist()}"
        )
    array.setflags(write=False)
    return array


@dataclasses.dataclass(frozen=True, eq=False)
class ManipulatorGeometry:
    """Constant geometry of the three-joint manipulator of Fig. 8.3.

    Parameters
    ----------
    joint_axes : (3, 3) array_like
        Row ``k`` is the unit axis of joint ``k + 1``, expressed in the frame
        of the link before that joint (the ground frame for the first joint).
        In the zero configuration it is also the joint's axis in the global
        frame. Default rows Z, X, Z.
    link_lengths : (3,) array_like
        Lengths of the three links in metres, each > 0. Link ``k`` runs from
        joint ``k`` to joint ``k + 1`` (the last one to the end object).
    link_directions : (3, 3) array_like
        Row ``k`` is the unit direction of link ``k + 1`` from its joint to
        its far end, in that link's own frame. Default: every link along +Z.

    Raises
    ------
    ValueError
        If a shape is wrong, a value is not finite, an axis or direction is
        not a unit vector, or a length is not positive.
    """

    joint_axes: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    )  # (3, 3) unit rows, joint k+1's axis in the previous link's frame
    link_lengths: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([0.6, 0.8, 0.5])
    )  # (3,) metres
    link_directions: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([[0.0, 0.0, 1.0]] * 3)
    )  # (3, 3) unit rows, link k+1's direction in its own frame

    def __post_init__(self) -> None:
        object.__setattr__(self, "joint_axes", _as_unit_rows(self.joint_axes, "joint_axes"))
        object.__setattr__(
            self, "link_directions", _as_unit_rows(self.link_directions, "link_directions")
        )
        lengths = float_array(self.link_lengths, "link_lengths", expected="3 lengths in metres", copy=True)
        if lengths.shape != (3,):
            raise ValueError(
                f"link_lengths must have shape (3,) (one length per link), "
                f"got shape {lengths.shape}"
            )
        if not np.all(np.isfinite(lengths)) or np.any(lengths <= 0.0):
            raise ValueError(
                f"link_lengths must be finite and > 0 metres, got {lengths.tolist()}"
            )
        lengths.setflags(write=False)
        object.__setattr__(self, "link_lengths", lengths)
        # Python-float copies for the one-configuration paths (validated arrays are read-only).
        object.__setattr__(self, "_floats", (
            [tuple(float(c) for c in row) for row in self.joint_axes],
            [tuple(float(c) for c in row) for row in self.link_vectors],
        ))

    @property
    def link_vectors(self) -> np.ndarray:
        """(3, 3) row ``k``: link ``k + 1`` from its joint to its far end, in its own frame."""
        return self.link_lengths[:, None] * self.link_directions


DEFAULT_GEOMETRY = ManipulatorGeometry()
"""Joint axes Z, X, Z; links 0.6, 0.8 and 0.5 m long, each along its own Z axis."""


@dataclasses.dataclass(frozen=True, eq=False)
class LinkFrames:
    """Poses of the three links (and the end point) in the global frame.

    Attributes
    ----------
    orientations : (..., 3, 3, 3) ndarray
        ``orientations[..., k, :, :]`` is the rotation matrix of link ``k + 1``
        (link frame to global frame): ``A21``, ``A21 A32`` and
        ``A21 A32 A43`` in the chapter's numbering. The last one is the end
        link's orientation ``A``.
    origins : (..., 3, 3) ndarray
        ``origins[..., k, :]`` is the origin of link ``k + 1``'s frame (the
        centre of joint ``k + 1``) in the global frame, metres.
    end_point : (..., 3) ndarray
        Far end of the last link, where the end object sits, global frame.
    """

    orientations: np.ndarray  # (..., 3, 3, 3) A_global_link for links 1..3
    origins: np.ndarray  # (..., 3, 3) joint centres, global frame
    end_point: np.ndarray  # (..., 3) tip of the last link, global frame


@dataclasses.dataclass(frozen=True, eq=False)
class EulerForm:
    """The end-link orientation written as an Euler-angle matrix.

    ``matrix_from_euler_angles(angles, seq)`` equals the manipulator's
    ``A = A21 A32 A43``.

    Attributes
    ----------
    seq : str
        Intrinsic Euler sequence (upper case, scipy's letters), e.g. ``"ZXZ"``.
    angles : (..., 3) ndarray
        Euler angles in radians for ``seq``: the joint angles, with the sign
        flipped for a joint whose axis is a negative coordinate axis.
    """

    seq: str
    angles: np.ndarray  # (..., 3) radians


def _check_joint_vector(value: object, name: str) -> np.ndarray:
    array = float_array(value, name, expected="a (..., 3) array of real numbers")
    if array.ndim == 0 or array.shape[-1] != 3:
        raise ValueError(
            f"{name} must have shape (..., 3) (one value per joint), got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got non-finite values in {name}")
    return array


def _check_arguments(joint_angles: object, geometry: object) -> tuple[ManipulatorGeometry, np.ndarray]:
    """Validated ``geometry`` and ``joint_angles`` (..., 3) of a public entry point."""
    if not isinstance(geometry, ManipulatorGeometry):
        raise ValueError(
            f"geometry must be a ManipulatorGeometry, got {type(geometry).__name__}"
        )
    return geometry, _check_joint_vector(joint_angles, "joint_angles")


def _axis_rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodriguez rotation (Eq. 8.29) about a fixed unit ``axis`` (3,) by ``angle`` (...)."""
    return matrix_from_axis_angle(np.broadcast_to(axis, angle.shape + (3,)), angle)


def relative_rotation_matrices(
    joint_angles: object, *, geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    degrees: bool = False
) -> np.ndarray:
    """Relative rotation matrices ``A21``, ``A32``, ``A43`` of the three joints.

    Each is the Rodriguez formula (Eq. 8.29) about the joint's axis expressed
    in the previous link's frame (Eqs. 8.39-8.41).

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    degrees : bool, keyword-only
        True: ``joint_angles`` are in degrees.

    Returns
    -------
    (..., 3, 3, 3) ndarray
        ``[..., k, :, :]`` maps link ``k + 1``'s frame to the previous link's
        frame (the ground for ``k = 0``).

    Raises
    ------
    ValueError
        If ``joint_angles`` is not (..., 3) or not finite, or ``geometry`` is
        not a :class:`ManipulatorGeometry`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    geometry, theta = _check_arguments(joint_angles, geometry)
    return np.stack(
        [_axis_rotation(geometry.joint_axes[k], theta[..., k]) for k in range(3)],
        axis=-3,
    )


def link_frames_successive(
    joint_angles: object, *, geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    degrees: bool = False
) -> LinkFrames:
    """Link poses by successive relative rotations, procedure (a) (Eqs. 8.39-8.42).

    Orientations accumulate by right multiplication, ``A_1(k+1) = A_1k A_k(k+1)``,
    so each joint turns about its axis as carried by the links before it;
    positions chain along the links, ``o_(k+1) = o_k + A_1k @ (l_k d_k)``.

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    degrees : bool, keyword-only
        True: ``joint_angles`` are in degrees.

    Returns
    -------
    LinkFrames
        Orientations (..., 3, 3, 3), origins (..., 3, 3) and end point (..., 3)
        in the global frame.

    Raises
    ------
    ValueError
        As :func:`relative_rotation_matrices`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    geometry, theta = _check_arguments(joint_angles, geometry)
    if theta.ndim == 1:  # one configuration: the scalar path of the rotation core
        return _successive_single(theta, geometry)
    relative = relative_rotation_matrices(theta, geometry=geometry)
    batch = relative.shape[:-3]
    orientations = np.empty(batch + (3, 3, 3))
    origins = np.empty(batch + (3, 3))
    orientation = relative[..., 0, :, :]
    origin = np.zeros(batch + (3,))
    link_vectors = geometry.link_vectors
    for k in range(3):
        if k > 0:
            orientation = orientation @ relative[..., k, :, :]
        orientations[..., k, :, :] = orientation
        origins[..., k, :] = origin
        origin = origin + orientation @ link_vectors[k]
    return LinkFrames(orientations=orientations, origins=origins, end_point=origin)



def _rodriguez_floats(axis: tuple[float, float, float], angle: float) -> tuple[float, ...]:
    """Row-major Rodriguez matrix (Eq. 8.29) of a unit ``axis`` on Python floats.

    ``R = I + sin(theta) a~ + 2 sin^2(theta/2) a~^2``: the same formula as
    :func:`rigidlab.core.rotations.matrix_from_axis_angle`, without array overhead (a
    one-configuration call costs a few microseconds instead of tens).
    """
    x, y, z = axis
    s = math.sin(angle)
    v = 2.0 * math.sin(0.5 * angle) ** 2
    return (
        1.0 - v * (y * y + z * z), v * x * y - s * z, v * x * z + s * y,
        v * x * y + s * z, 1.0 - v * (x * x + z * z), v * y * z - s * x,
        v * x * z - s * y, v * y * z + s * x, 1.0 - v * (x * x + y * y),
    )


def _mul33(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
    """Row-major product of two 3x3 matrices given as 9-tuples."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (
        a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
        a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
        a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8,
    )


def _mulv(a: tuple[float, ...], v: tuple[float, float, float]) -> tuple[float, float, float]:
    """Row-major 3x3 matrix times a vector."""
    x, y, z = v
    return (
        a[0] * x + a[1] * y + a[2] * z,
        a[3] * x + a[4] * y + a[5] * z,
        a[6] * x + a[7] * y + a[8] * z,
    )


_IDENTITY9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def _float_geometry(geometry: ManipulatorGeometry) -> tuple[list, list]:
    """Joint axes and link vectors of ``geometry`` as tuples of Python floats."""
    return geometry._floats  # type: ignore[attr-defined]


def _successive_single(theta: np.ndarray, geometry: ManipulatorGeometry) -> LinkFrames:
    """:func:`link_frames_successive` for one configuration ``theta`` (3,), on floats."""
    axes, links = _float_geometry(geometry)
    orientations = []
    origins = []
    origin = (0.0, 0.0, 0.0)
    orientation = _IDENTITY9
    for k in range(3):
        orientation = _mul33(orientation, _rodriguez_floats(axes[k], float(theta[k])))
        orientations.append(orientation)
        origins.append(origin)
        step = _mulv(orientation, links[k])
        origin = (origin[0] + step[0], origin[1] + step[1], origin[2] + step[2])
    return LinkFrames(
        orientations=np.array(orientations).reshape(3, 3, 3),
        origins=np.array(origins),
        end_point=np.array(origin),
    )


def _global_single(theta: np.ndarray, geometry: ManipulatorGeometry, steps: int) -> LinkFrames:
    """:func:`link_frames_global_axis_rotations` for one configuration, on floats."""
    axes, links = _float_geometry(geometry)
    zero = [(0.0, 0.0, 0.0)]
    for link in links:
        last = zero[-1]
        zero.append((last[0] + link[0], last[1] + link[1], last[2] + link[2]))
    orientations = [_IDENTITY9] * 3
    points = list(zero)
    for joint in range(2, 2 - steps, -1):
        rotation = _rodriguez_floats(axes[joint], float(theta[joint]))
        px, py, pz = zero[joint]
        for k in range(joint, 3):
            orientations[k] = _mul33(rotation, orientations[k])
        for k in range(joint + 1, 4):
            x = points[k]
            r = _mulv(rotation, (x[0] - px, x[1] - py, x[2] - pz))
            points[k] = (px + r[0], py + r[1], pz + r[2])
    return LinkFrames(
        orientations=np.array(orientations).reshape(3, 3, 3),
        origins=np.array(points[:3]),
        end_point=np.array(points[3]),
    )


def matrix_from_successive_rotations(
    joint_angles: object, *, geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    degrees: bool = False
) -> np.ndarray:
    """End-link orientation ``A = A21 A32 A43``, procedure (a) (Eq. 8.42).

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    degrees : bool, keyword-only
        True: ``joint_angles`` are in degrees.

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrix of the end link, end-link frame to global frame.

    Raises
    ------
    ValueError
        As :func:`relative_rotation_matrices`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    relative = relative_rotation_matrices(joint_angles, geometry=geometry)
    return relative[..., 0, :, :] @ relative[..., 1, :, :] @ relative[..., 2, :, :]


def link_frames_global_axis_rotations(
    joint_angles: object,
    *,
    geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    steps: int = 3,
    degrees: bool = False,
) -> LinkFrames:
    """Link poses by Rodriguez rotations about global joint axes, procedure (b) (Eqs. 8.43-8.45).

    Start from the zero configuration and apply rigid rotations in the reverse
    joint order: first joint 3 turns the last link by ``theta3`` about its
    axis ``a3`` through the joint centre; then joint 2 turns the last two links
    by ``theta2`` about ``a2``; then joint 1 turns all links by ``theta1`` about
    ``a1``. Every axis is the joint's axis in the global frame in the zero
    configuration, still in place when it is used. Each step is the Rodriguez
    formula (Eq. 8.29)

    .. math:: R_k = I + \\sin\\theta_k\\,\\tilde a_k + 2\\sin^2(\\theta_k/2)\\,\\tilde a_k^2,

    applied by left multiplication to orientations, ``A <- R_k A``, and to
    points as ``x <- o_k + R_k (x - o_k)``. After all three steps the end link's
    orientation is ``R_1 R_2 R_3``, equal to ``A21 A32 A43`` of procedure (a).

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    steps : int, keyword-only
        How many of the three rotations to apply, 0 to 3 (joint 3 first).
        ``steps=3`` (default) is the full procedure; fewer steps give the
        intermediate configurations of the construction.
    degrees : bool, keyword-only
        True: ``joint_angles`` are in degrees.

    Returns
    -------
    LinkFrames
        Orientations (..., 3, 3, 3), origins (..., 3, 3) and end point (..., 3)
        in the global frame after ``steps`` rotations.

    Raises
    ------
    ValueError
        If ``steps`` is not an integer in 0..3, or as
        :func:`relative_rotation_matrices`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    geometry, theta = _check_arguments(joint_angles, geometry)
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or not 0 <= steps <= 3:
        raise ValueError(f"steps must be an integer from 0 to 3, got {steps!r}")
    if theta.ndim == 1:  # one configuration: the scalar path of the rotation core
        return _global_single(theta, geometry, steps)
    batch = theta.shape[:-1]
    # Zero configuration: every link frame parallel to the global frame.
    zero_origins = np.zeros((4, 3))
    zero_origins[1:] = np.cumsum(geometry.link_vectors, axis=0)
    orientations = np.broadcast_to(np.eye(3), batch + (3, 3, 3)).copy()
    points = np.broadcast_to(zero_origins, batch + (4, 3)).copy()  # 3 origins + end point
    for joint in range(2, 2 - steps, -1):
        rotation = _axis_rotation(geometry.joint_axes[joint], theta[..., joint])
        pivot = zero_origins[joint]  # the joint centre has not moved yet
        moved = slice(joint, 3)  # links joint+1 .. 3 turn with this joint
        orientations[..., moved, :, :] = rotation[..., None, :, :] @ orientations[..., moved, :, :]
        moved_points = slice(joint + 1, 4)
        offsets = points[..., moved_points, :] - pivot
        points[..., moved_points, :] = pivot + np.einsum(
            "...ij,...kj->...ki", rotation, offsets
        )
    return LinkFrames(
        orientations=orientations, origins=points[..., :3, :], end_point=points[..., 3, :]
    )


def matrix_from_global_axis_rotations(
    joint_angles: object, *, geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    degrees: bool = False
) -> np.ndarray:
    """End-link orientation from Rodriguez rotations about global axes, procedure (b) (Eqs. 8.43-8.45).

    Applies ``R_3``, then ``R_2``, then ``R_1`` (each the Rodriguez formula,
    Eq. 8.29, about the joint's fixed global axis) to the end link's frame,
    which starts parallel to the global frame: ``A = R_1 (R_2 (R_3 I))``.

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    degrees : bool, keyword-only
        True: ``joint_angles`` are in degrees.

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrix of the end link, end-link frame to global frame;
        equal to :func:`matrix_from_successive_rotations` up to rounding.

    Raises
    ------
    ValueError
        As :func:`relative_rotation_matrices`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    geometry, theta = _check_arguments(joint_angles, geometry)
    matrix = np.broadcast_to(np.eye(3), theta.shape[:-1] + (3, 3))
    for joint in (2, 1, 0):
        matrix = _axis_rotation(geometry.joint_axes[joint], theta[..., joint]) @ matrix
    return matrix


def euler_form(
    joint_angles: object, *, geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    degrees: bool = False
) -> EulerForm:
    """Write the end-link orientation as an Euler-angle matrix.

    When every joint axis is a coordinate axis (``+-X``, ``+-Y`` or ``+-Z``) of
    the previous link's frame and consecutive axes differ, ``A21 A32 A43`` is
    the intrinsic Euler-angle matrix of that axis sequence (each relative
    rotation is an elementary rotation about a body axis, the construction
    of the Euler angles); a negative axis flips the sign of its angle. For the default Z,
    X, Z joints this is the chapter's precession-nutation-spin sequence.

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    degrees : bool, keyword-only
        True: ``joint_angles`` are in degrees (the returned angles stay radians).

    Returns
    -------
    EulerForm
        ``seq`` (e.g. ``"ZXZ"``) and the Euler angles (..., 3) in radians,
        with ``matrix_from_euler_angles(angles, seq) == A``.

    Raises
    ------
    ValueError
        If a joint axis is not a coordinate axis, if two consecutive joint
        axes are about the same coordinate axis, or as
        :func:`relative_rotation_matrices`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    geometry, theta = _check_arguments(joint_angles, geometry)
    letters = []
    signs = np.empty(3)
    for k, axis in enumerate(geometry.joint_axes):
        index = int(np.argmax(np.abs(axis)))
        if abs(abs(axis[index]) - 1.0) > _UNIT_TOLERANCE:
            raise ValueError(
                "joint_axes must all be coordinate axes (+-X, +-Y or +-Z) for an "
                f"Euler-angle form, got joint {k + 1} axis {axis.tolist()}"
            )
        letters.append(_AXIS_LETTERS[index])
        signs[k] = np.sign(axis[index])
    seq = "".join(letters)
    if seq[0] == seq[1] or seq[1] == seq[2]:
        raise ValueError(
            "joint_axes must have consecutive joints about different axes for an "
            f"Euler-angle form, got the sequence {seq}"
        )
    return EulerForm(seq=seq, angles=theta * signs)


def end_link_angular_velocity(
    joint_angles: object,
    joint_rates: object,
    *,
    geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
    degrees: bool = False,
) -> np.ndarray:
    """Angular velocity of the end link in the global frame.

    Each joint adds its rate about its axis as carried by the links before it:

    .. math:: \\omega = a_1 \\dot\\theta_1 + A_{21} a_2 \\dot\\theta_2
              + A_{21} A_{32} a_3 \\dot\\theta_3,

    which satisfies ``skew(omega) = dA/dt @ A.T`` for ``A = A21 A32 A43``. For
    Z, X, Z joints the coefficient matrix is the Euler-angle ``G`` of
    Eqs. 8.7-8.9 (``euler_angle_G(joint_angles, "ZXZ")``).

    Parameters
    ----------
    joint_angles : (..., 3) array_like
        Joint angles ``theta1, theta2, theta3`` in radians.
    joint_rates : (..., 3) array_like
        Joint rates in rad/s; broadcast against ``joint_angles``.
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default :data:`DEFAULT_GEOMETRY`.
    degrees : bool, keyword-only
        True: ``joint_angles`` in degrees and ``joint_rates`` in deg/s (``omega`` stays rad/s).

    Returns
    -------
    (..., 3) ndarray
        ``omega`` of the end link in the global frame, rad/s.

    Raises
    ------
    ValueError
        If ``joint_rates`` is not (..., 3), not finite or does not broadcast
        against ``joint_angles``, or as :func:`relative_rotation_matrices`.
    """
    joint_angles = radians(joint_angles, "joint_angles", degrees)
    joint_rates = radians(joint_rates, "joint_rates", degrees)
    rates = _check_joint_vector(joint_rates, "joint_rates")
    frames = link_frames_successive(joint_angles, geometry=geometry)
    try:
        batch = np.broadcast_shapes(frames.origins.shape[:-2], rates.shape[:-1])
    except ValueError:
        raise ValueError(
            "joint_rates must broadcast against joint_angles, got shapes "
            f"{rates.shape} and {frames.origins.shape[:-2] + (3,)}"
        ) from None
    # Axis of joint k in the global frame: carried by links 1..k-1.
    axes_global = np.empty(frames.orientations.shape[:-3] + (3, 3))
    axes_global[..., 0, :] = geometry.joint_axes[0]
    for k in (1, 2):
        axes_global[..., k, :] = frames.orientations[..., k - 1, :, :] @ geometry.joint_axes[k]
    axes_global = np.broadcast_to(axes_global, batch + (3, 3))
    return np.einsum("...kj,...k->...j", axes_global, np.broadcast_to(rates, batch + (3,)))
