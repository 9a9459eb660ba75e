"""Pure adapters shared by the rotation panels: core results -> what a panel shows.

Every function here calls :mod:`rigidlab.core.rotations` for the rotation math and
returns a frozen dataclass (or a string); none touches viser, so they are
tested without a server and reused by any scene. Conventions are the
project's: active rotations, body to global (``r_global = A @ u_body``);
Euler parameters ``p = (theta0, theta1, theta2, theta3)``, scalar first
(viser's ``wxyz``); Euler sequences in scipy's letters, upper case intrinsic
(turning axes), lower case extrinsic (fixed axes); radians unless a name says
degrees; ``omega`` in the global frame, ``omega_body`` (the chapter's
omega-bar) in the body frame.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import Any

import numpy as np

import rigidlab.core.rotations as rot

__all__ = [
    "SEQUENCES",
    "SEQUENCE_LABELS",
    "sequence_of_label",
    "angle_names",
    "angle_labels",
    "rate_names",
    "OrientationViews",
    "orientation_views",
    "euler_angles_of",
    "GimbalLayout",
    "gimbal_layout",
    "ring_rotations",
    "GimbalConditioning",
    "gimbal_conditioning",
    "GimbalPose",
    "gimbal_pose",
    "ComposeViews",
    "compose_views",
    "RateViews",
    "rate_views",
    "CONVENTION_NOTES",
    "export_document",
    "unit_direction",
    "wxyz_z_to",
    "fmt_vector",
    "fmt_g",
    "cond_text",
    "set_readout",
]

# -- sequences and names --------------------------------------------------------
_PROPER = ("ZXZ", "XYX", "YZY", "ZYZ", "XZX", "YXY")
_TAIT_BRYAN = ("XYZ", "YZX", "ZXY", "XZY", "ZYX", "YXZ")
#: All 24 sequences: upper case intrinsic, lower case extrinsic (scipy's letters).
SEQUENCES: tuple[str, ...] = tuple(s for base in _PROPER + _TAIT_BRYAN for s in (base, base.lower()))
#: Dropdown text of each sequence.
SEQUENCE_LABELS: dict[str, str] = {
    s: f"{s} ({'intrinsic, turning axes' if s.isupper() else 'extrinsic, fixed axes'})" for s in SEQUENCES
}
_LABEL_TO_SEQUENCE = {label: s for s, label in SEQUENCE_LABELS.items()}
_PRIMES = ("", "\u2032", "\u2033")


def sequence_of_label(label: str) -> str:
    """The sequence letters of a dropdown text of :data:`SEQUENCE_LABELS`.

    Raises
    ------
    ValueError
        If ``label`` is not one of them.
    """
    try:
        return _LABEL_TO_SEQUENCE[label]
    except KeyError:
        raise ValueError(f"label: expected one of the sequence labels, got {label!r}") from None


def angle_names(seq: str) -> tuple[str, str, str]:
    """Names of the three angles: the chapter's (phi, theta, psi) for ZXZ, else alpha1..3."""
    if seq == "ZXZ":
        return ("\u03c6", "\u03b8", "\u03c8")
    return ("\u03b1\u2081", "\u03b1\u2082", "\u03b1\u2083")


def angle_labels(seq: str) -> tuple[str, str, str]:
    """Slider labels naming each angle's axis (primes: turned axes)."""
    names = angle_names(seq)
    if seq.isupper():
        return tuple(f"{n} about {a}{p}" for n, a, p in zip(names, seq, _PRIMES))  # type: ignore[return-value]
    return tuple(f"{n} about {a} (fixed)" for n, a in zip(names, seq))  # type: ignore[return-value]


def rate_names(seq: str) -> tuple[str, str, str]:
    """Rates written as ``dφ/dt``: a combining dot over φ or ψ is lost in some browsers."""
    return tuple(f"d{n}/dt" for n in angle_names(seq))  # type: ignore[return-value]


# -- one orientation in every representation -----------------------------------
@dataclasses.dataclass(frozen=True)
class OrientationViews:
    """Every representation of one orientation (from :func:`orientation_views`).

    Attributes
    ----------
    p : (4,) unit Euler parameters, scalar first, theta0 >= 0 (viser ``wxyz``)
    A : (3, 3) rotation matrix, body to global
    seq : Euler angle sequence of ``euler``
    euler : (3,) Euler angles (rad) in ``seq`` (the ones the gimbal shows)
    gimbal_lock : whether ``euler`` is at the singularity of ``seq`` (|det G| <= 1e-6)
    axis : (3,) unit rotation axis (same components in body and global frame)
    angle : rotation angle in [0, pi] (rad)
    rotation_vector : (3,) axis * angle (rad)
    gamma : (3,) Rodriguez parameters axis tan(angle / 2), or None at angle pi (infinite)
    """

    p: np.ndarray
    A: np.ndarray
    seq: str
    euler: np.ndarray
    gimbal_lock: bool
    axis: np.ndarray
    angle: float
    rotation_vector: np.ndarray
    gamma: np.ndarray | None


def euler_angles_of(p: np.ndarray, seq: str) -> tuple[np.ndarray, bool]:
    """Euler angles (3,) in radians of unit ``p`` in ``seq``, and whether at gimbal lock.

    At gimbal lock the core sets the third angle to 0 (and warns); the
    warning becomes the returned flag.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", rot.GimbalLockWarning)
        angles = rot.euler_angles_from_euler_parameters(p, seq)
    locked = any(issubclass(w.category, rot.GimbalLockWarning) for w in caught)
    return np.asarray(angles, dtype=float), locked


def orientation_views(p: np.ndarray, seq: str, *, euler: np.ndarray | None = None) -> OrientationViews:
    """All representations of the orientation with Euler parameters ``p``.

    Parameters
    ----------
    p : (4,) unit Euler parameters, scalar first.
    seq : one of :data:`SEQUENCES`.
    euler : (3,) Euler angles (rad) in ``seq`` of the same orientation, keyword-only.
        Given when they are known already (the input sliders, the gimbal),
        so they are neither recomputed nor replaced by the equivalent triple
        the matrix would give; else taken from ``p``.
    """
    p = rot.canonical_euler_parameters(p)
    if euler is None:
        euler, locked = euler_angles_of(p, seq)
    else:
        euler = np.asarray(euler, dtype=float)
        locked = bool(rot.euler_angles_near_singularity(euler, seq))
    axis, angle = rot.axis_angle_from_euler_parameters(p)
    gamma = None
    if not bool(rot.rodriguez_parameters_near_singularity(p)):
        gamma = rot.rodriguez_parameters_from_euler_parameters(p)
    return OrientationViews(
        p=p,
        A=rot.matrix_from_euler_parameters(p),
        seq=seq,
        euler=euler,
        gimbal_lock=locked,
        axis=np.asarray(axis, dtype=float),
        angle=float(angle),
        rotation_vector=rot.rotation_vector_from_euler_parameters(p),
        gamma=gamma,
    )


# -- the gimbal ------------------------------------------------------------------
_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


@dataclasses.dataclass(frozen=True)
class GimbalLayout:
    """What of a cardan gimbal depends only on the sequence (from :func:`gimbal_layout`).

    Ring 0 is the outer ring (carried by the fixed stator), ring 2 the inner
    ring (carrying the body). For an intrinsic sequence ring k turns by
    angle k about the k-th letter; for an extrinsic one the order is
    reversed (``A = R3 R2 R1``), so the outer ring turns by the third angle.

    Attributes
    ----------
    seq : the sequence
    axes : (3, 3) unit rotation axis of each ring in its carrier's frame
    angle_index : (3,) which Euler angle turns each ring
    mount_wxyz : (3, 4) fixed orientation of each ring's mesh in its own
        frame (ring plane through its own axis and its child's axis)
    stator_wxyz : (4,) orientation of the fixed bearings of the outer ring
    """

    seq: str
    axes: np.ndarray
    angle_index: tuple[int, int, int]
    mount_wxyz: np.ndarray
    stator_wxyz: np.ndarray


def _frame_wxyz(x_axis: np.ndarray, z_axis: np.ndarray) -> np.ndarray:
    """Euler parameters of the frame with the given orthonormal x and z axes."""
    A = np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis])
    return rot.euler_parameters_from_matrix(A)


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


@functools.lru_cache(maxsize=len(SEQUENCES))
def gimbal_layout(seq: str) -> GimbalLayout:
    """Ring axes and mounts of the gimbal of ``seq`` (cached: it depends on nothing else)."""
    if seq not in SEQUENCES:
        raise ValueError(f"seq: expected one of {list(SEQUENCES[:4])}... (24 sequences), got {seq!r}")
    letters = seq.upper() if seq.isupper() else seq.upper()[::-1]
    index = (0, 1, 2) if seq.isupper() else (2, 1, 0)
    axes = np.eye(3)[[_AXIS_INDEX[c] for c in letters]]
    normals = [np.cross(axes[0], axes[1]), np.cross(axes[1], axes[2]), axes[1]]
    mount = np.stack([_frame_wxyz(axes[k], normals[k]) for k in range(3)])
    return GimbalLayout(
        seq=seq,
        axes=_readonly(axes),
        angle_index=index,
        mount_wxyz=_readonly(mount),
        stator_wxyz=_readonly(mount[0]),
    )


def ring_rotations(angles: np.ndarray, seq: str) -> np.ndarray:
    """(3, 4) Euler parameters of each ring relative to its carrier, outer to inner.

    Their product, outer to inner, equals the orientation of Euler ``angles``
    (rad) of ``seq`` (Eqs. 8.7-8.9: one elementary rotation per ring).
    """
    layout = gimbal_layout(seq)
    return np.stack([
        rot.euler_parameters_from_axis_angle(layout.axes[k], float(angles[layout.angle_index[k]]))
        for k in range(3)
    ])


@dataclasses.dataclass(frozen=True)
class GimbalConditioning:
    """How far Euler angles are from gimbal lock (from :func:`gimbal_conditioning`).

    Attributes
    ----------
    singular_values : (3,) singular values of G (omega = G @ angle rates, Eq. 8.8), descending
    condition : sigma_max / sigma_min (inf when singular)
    det : |det G| (the core's singularity measure)
    """

    singular_values: np.ndarray
    condition: float
    det: float


def gimbal_conditioning(angles: np.ndarray, seq: str) -> GimbalConditioning:
    """Singular values and condition number of G at Euler ``angles`` (rad) of ``seq``."""
    G = rot.euler_angle_G(angles, seq)
    s = np.linalg.svd(G, compute_uv=False)
    condition = float(s[0] / s[-1]) if s[-1] > 1e-12 * s[0] else math.inf
    return GimbalConditioning(singular_values=s, condition=condition, det=float(s[0] * s[1] * s[2]))


@dataclasses.dataclass(frozen=True)
class GimbalPose:
    """Everything the gimbal shows for Euler angles (from :func:`gimbal_pose`).

    Attributes
    ----------
    layout : what depends on the sequence only (:class:`GimbalLayout`)
    wxyz : (3, 4) each ring's rotation relative to its carrier
    conditioning : distance from gimbal lock (:class:`GimbalConditioning`)
    """

    layout: GimbalLayout
    wxyz: np.ndarray
    conditioning: GimbalConditioning

    @property
    def angle_index(self) -> tuple[int, int, int]:
        return self.layout.angle_index

    @property
    def singular_values(self) -> np.ndarray:
        return self.conditioning.singular_values

    @property
    def condition(self) -> float:
        return self.conditioning.condition


def gimbal_pose(angles: np.ndarray, seq: str) -> GimbalPose:
    """Ring rotations and conditioning that realise Euler ``angles`` (rad) of ``seq``."""
    angles = np.asarray(angles, dtype=float)
    return GimbalPose(
        layout=gimbal_layout(seq),
        wxyz=ring_rotations(angles, seq),
        conditioning=gimbal_conditioning(angles, seq),
    )


# -- composition ---------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ComposeViews:
    """Two rotations and their products in both orders (problem 4, Eq. 8.82).

    Attributes
    ----------
    q1, q2 : (4,) Euler parameters of the two rotations
    p12, p21 : (4,) Euler parameters of ``q1 q2`` and ``q2 q1`` (Eqs. 8.69-8.72)
    difference : Frobenius norm of ``A(q1 q2) - A(q2 q1)``
    relative : (4,) parameters of body 2 (``q2 q1``) relative to body 1
        (``q1 q2``), ``A1.T @ A2`` (Eq. 8.82)
    relative_axis : (3,) its axis, in body 1's frame
    relative_angle : its angle (rad)
    """

    q1: np.ndarray
    q2: np.ndarray
    p12: np.ndarray
    p21: np.ndarray
    difference: float
    relative: np.ndarray
    relative_axis: np.ndarray
    relative_angle: float


def compose_views(q1: np.ndarray, q2: np.ndarray) -> ComposeViews:
    """Products ``q1 q2`` and ``q2 q1`` (unit Euler parameters) and the rotation between them."""
    p12 = rot.quaternion_product(q1, q2)
    p21 = rot.quaternion_product(q2, q1)
    relative = rot.relative_euler_parameters(p12, p21)
    axis, angle = rot.axis_angle_from_euler_parameters(relative)
    difference = rot.matrix_from_euler_parameters(p12) - rot.matrix_from_euler_parameters(p21)
    return ComposeViews(
        q1=np.asarray(q1, dtype=float),
        q2=np.asarray(q2, dtype=float),
        p12=p12,
        p21=p21,
        difference=float(np.linalg.norm(difference)),
        relative=relative,
        relative_axis=np.asarray(axis, dtype=float),
        relative_angle=float(angle),
    )


# -- angular velocity -----------------------------------------------------------
#: |det G| at or below which Euler angle rates are reported as singular (core's tol).
RATE_TOL = 1e-6


@dataclasses.dataclass(frozen=True)
class RateViews:
    """Rates of three representations that produce one angular velocity.

    Attributes
    ----------
    omega : (3,) angular velocity, global frame (rad/s)
    omega_body : (3,) the same, body frame (omega-bar)
    euler_rates : (3,) Euler angle rates (rad/s), or None where G is singular
    det_G : |det G| at the current angles
    p_dot : (4,) Euler parameter rates (never singular)
    gamma_dot : (3,) Rodriguez parameter rates, or None at angle pi
    """

    omega: np.ndarray
    omega_body: np.ndarray
    euler_rates: np.ndarray | None
    det_G: float
    p_dot: np.ndarray
    gamma_dot: np.ndarray | None


def rate_views(
    p: np.ndarray, angles: np.ndarray, seq: str, omega: np.ndarray, *, body_frame: bool
) -> RateViews:
    """Rates for ``omega`` given in the global frame or (``body_frame``) the body frame.

    Problems 10-11: Euler angle rates from Eq. 8.8 inverted (singular where
    |det G| = 0), Euler parameter rates ``p_dot = G.T omega / 2``
    (Eqs. 8.51-8.54), Rodriguez parameter rates (Eqs. 8.61-8.64, infinite
    at angle pi).

    Parameters
    ----------
    p : (4,) unit Euler parameters of the body, scalar first.
    angles : (3,) Euler angles (rad) of the same orientation in ``seq``.
    seq : one of :data:`SEQUENCES`.
    omega : (3,) angular velocity (rad/s) in the frame ``body_frame`` says.
    body_frame : bool, keyword-only
        Whether ``omega`` is omega_body (body frame) rather than global.
    """
    omega = np.asarray(omega, dtype=float)
    if body_frame:
        omega_body = omega
        omega = rot.rotate_vector(p, omega_body)
    else:
        omega_body = rot.rotate_vector(rot.quaternion_conjugate(p), omega)
    det_G = float(abs(np.linalg.det(rot.euler_angle_G(angles, seq))))
    euler_rates = None
    if det_G > RATE_TOL:
        euler_rates = rot.euler_angle_rates_from_omega(angles, omega, seq, tol=RATE_TOL)
    gamma_dot = None
    if not bool(rot.rodriguez_parameters_near_singularity(p)):
        gamma = rot.rodriguez_parameters_from_euler_parameters(p)
        gamma_dot = rot.rodriguez_parameter_rates_from_omega(gamma, omega)
    return RateViews(
        omega=omega,
        omega_body=omega_body,
        euler_rates=euler_rates,
        det_G=det_G,
        p_dot=rot.euler_parameter_rates_from_omega(p, omega),
        gamma_dot=gamma_dot,
    )


# -- export ------------------------------------------------------------------------
CONVENTION_NOTES = {
    "rigidlab": (
        "Active rotation, body to global: r_global = A @ u_body. Euler parameters "
        "are scalar first (theta0, theta1, theta2, theta3). Euler sequences use "
        "scipy's letters: upper case intrinsic (turning axes), lower case "
        "extrinsic (fixed axes). Angles in radians unless a key says degrees."
    ),
    "scipy": (
        "Rotation.from_quat(euler_parameters, scalar_first=True) (scipy >= 1.14; "
        "older: from_quat(p[[1, 2, 3, 0]])), Rotation.from_matrix(matrix_body_to_global), "
        "Rotation.from_rotvec(rotation_vector), Rotation.from_euler(seq, angles) with "
        "the same letters (upper case intrinsic) and radians (degrees=True for degrees); "
        "as_matrix() returns the same body-to-global matrix."
    ),
    "viser": (
        "Assign euler_parameters directly: frame.wxyz = euler_parameters (scalar "
        "first); a node's wxyz is its orientation relative to its parent (active)."
    ),
    "mujoco": (
        "MJCF quat=\"w x y z\" is scalar first: use euler_parameters as they are. "
        "MJCF eulerseq uses the OPPOSITE case: lower case is intrinsic, upper case "
        "extrinsic, and the euler attribute is in degrees unless <compiler "
        "angle=\"radian\"/>. So intrinsic ZXZ here is eulerseq=\"zxz\" there; "
        "see euler_angles.mujoco_eulerseq."
    ),
}


def export_document(views: OrientationViews) -> dict[str, Any]:
    """JSON-ready dict of ``views`` in every representation, with convention notes.

    Includes the Euler angles of all 24 sequences (24 core calls: a few
    milliseconds, so a scene computes it off its loop or on request).
    """
    all_sequences = {s: euler_angles_of(views.p, s)[0].tolist() for s in SEQUENCES}
    return {
        "format": "rigidlab orientation 1",
        "conventions": CONVENTION_NOTES,
        "matrix_body_to_global": views.A.tolist(),
        "euler_parameters": views.p.tolist(),
        "axis_angle": {
            "axis": views.axis.tolist(),
            "angle_rad": views.angle,
            "angle_deg": math.degrees(views.angle),
        },
        "rotation_vector_rad": views.rotation_vector.tolist(),
        "rodriguez_parameters": None if views.gamma is None else views.gamma.tolist(),
        "rodriguez_note": (
            "axis * tan(angle / 2)" if views.gamma is not None
            else "infinite: the rotation angle is 180 degrees"
        ),
        "euler_angles": {
            "sequence": views.seq,
            "radians": views.euler.tolist(),
            "degrees": np.degrees(views.euler).tolist(),
            "gimbal_lock": views.gimbal_lock,
            "mujoco_eulerseq": views.seq.swapcase(),
        },
        "euler_angles_all_sequences_rad": all_sequences,
    }


# -- small helpers -----------------------------------------------------------------
def unit_direction(v: Any) -> np.ndarray | None:
    """``v / |v|`` for any non-zero finite 3-vector, else ``None``.

    Scaled by the largest entry first, so huge (1e200) and tiny (1e-200)
    vectors, whose squares overflow or underflow, keep their direction.
    """
    arr = np.asarray(v, dtype=float)
    if arr.shape != (3,) or not bool(np.all(np.isfinite(arr))):
        return None
    largest = float(np.max(np.abs(arr)))
    if largest == 0.0:
        return None
    scaled = arr / largest
    return scaled / float(np.linalg.norm(scaled))


_EZ = np.array([0.0, 0.0, 1.0])


def wxyz_z_to(direction: np.ndarray) -> np.ndarray:
    """Euler parameters of the shortest rotation taking +z to the unit ``direction``.

    Used to point a node built along +z (an arrow) along ``direction``.
    """
    d = np.asarray(direction, dtype=float)
    cross = np.array([-d[1], d[0], 0.0])  # e_z x d
    s = math.hypot(d[0], d[1])
    if s < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0]) if d[2] > 0 else np.array([0.0, 1.0, 0.0, 0.0])
    return rot.euler_parameters_from_axis_angle(cross / s, math.atan2(s, float(d[2])))


def fmt_vector(v: Any, digits: int = 3) -> str:
    """``"0.123, -0.457, 1.000"``: fixed decimals, the digits that mean something."""
    values = np.asarray(v, dtype=float).ravel().tolist()  # Python floats format faster
    return ", ".join(_fixed(x, digits) for x in values)


def _fixed(x: float, digits: int) -> str:
    if not math.isfinite(x):
        return "\u221e" if x > 0 else "-\u221e" if x < 0 else "undefined"
    if abs(x) >= 1e5:
        return fmt_g(x, digits)
    text = f"{x:.{digits}f}"
    if float(text) == 0.0:  # no "-0.000"
        text = f"{0.0:.{digits}f}"
    return text


def fmt_g(x: float, sig: int = 3) -> str:
    """``x`` with ``sig`` significant digits (``2.75``, ``0.0087``, ``1.2e+06``)."""
    if not math.isfinite(x):
        return "\u221e" if x > 0 else "-\u221e" if x < 0 else "undefined"
    return f"{x + 0.0:.{sig}g}"  # + 0.0: no "-0"


def cond_text(condition: float) -> str:
    """cond(G) for a readout: three significant digits, ``∞`` when singular."""
    return "\u221e" if not math.isfinite(condition) else fmt_g(condition, 3)


def set_readout(readout: Any, text: str) -> None:
    """Assign ``text`` to a readout unless it already shows it.

    A readout renders its HTML on every assignment before comparing; this
    skips the rendering too when the Markdown is unchanged.
    """
    if readout.content != text:
        readout.content = text
