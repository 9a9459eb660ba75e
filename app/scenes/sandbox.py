"""Rotation sandbox: one orientation, every representation of the chapter.

A body (hull, nose along +x_b, fin along +z_b, labelled body axes) turns in a
fixed global frame. One input panel at a time drives its orientation: Euler
angles of any of the 24 sequences (12 axis orders x intrinsic / extrinsic),
axis and angle (the Rodriguez formula, Eq. 8.29), Euler parameters
(Eq. 8.46, normalized with a notice), Rodriguez parameters (Eqs. 8.58-8.60)
or a rotation vector. Live readouts show all the other representations.

Beside the body, a cardan gimbal of three nested rings realises the chosen
sequence: the rings turn by exactly the three Euler angles, so gimbal lock
(G of Eqs. 8.7-8.9 singular) shows as two rings becoming coplanar; a gauge
reports the smallest singular value and condition number of G. The rotation
axis is drawn as an arrow with the angle.

Panels: *Compose* shows A(q1 q2) and A(q2 q1) as two ghost bodies and their
relative rotation (Eq. 8.82); *Angular velocity* converts omega (global or
body frame) into rates of Euler angles, Euler parameters and Rodriguez
parameters (Eqs. 8.8-8.9, 8.51-8.54, 8.61-8.64) and can animate the body
under that constant omega; *Export* gives the orientation as JSON with
convention notes for scipy, viser and MuJoCo.

All rotation math is done by :mod:`core.rotations`; this module only adapts
results to viser nodes (created once in :meth:`SandboxScene.build`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
import warnings
from typing import Any, ClassVar

import numpy as np

import core.rotations as rot
from app import meshes
from app.scenes.base import Scene

__all__ = [
    "SandboxScene",
    "SEQUENCES",
    "INPUTS",
    "PANELS",
    "OrientationViews",
    "GimbalPose",
    "ComposeViews",
    "RateViews",
    "orientation_views",
    "gimbal_pose",
    "compose_views",
    "rate_views",
    "export_document",
]

# -- conventions shown in the GUI ---------------------------------------------
_PROPER = ("ZXZ", "XYX", "YZY", "ZYZ", "XZX", "YXY")
_TAIT_BRYAN = ("XYZ", "YZX", "ZXY", "XZY", "ZYX", "YXZ")
#: All 24 sequences: upper case intrinsic, lower case extrinsic (scipy's letters).
SEQUENCES: tuple[str, ...] = tuple(
    s for base in _PROPER + _TAIT_BRYAN for s in (base, base.lower())
)
_SEQ_LABELS = {
    s: f"{s}  ({'intrinsic, turning axes' if s.isupper() else 'extrinsic, fixed axes'})"
    for s in SEQUENCES
}
_LABEL_SEQS = {label: s for s, label in _SEQ_LABELS.items()}

INPUTS = (
    "Euler angles",
    "Axis and angle",
    "Euler parameters",
    "Rodriguez parameters",
    "Rotation vector",
)
PANELS = ("Orientation", "Compose q1, q2", "Angular velocity", "Export")
#: Largest |omega component| (rad/s) taken by the angular-velocity panel: far
#: beyond anything a frame-by-frame animation can show, and keeps every
#: rate readout a readable, finite number.
_OMEGA_MAX = 1e6
_OMEGA_FRAMES = ("global frame (omega)", "body frame (omega-bar)")

_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}
_PRIMES = ("", "\u2032", "\u2033")
#: Colours of the rings by angle (first, second, third) and their names.
_RING_COLORS = ((238, 146, 38), (142, 88, 196), (32, 160, 160))
_RING_COLOR_NAMES = ("orange", "purple", "teal")
_RING_RADII = (1.0, 0.84, 0.68)
_RING_TUBE = 0.03
_STATOR_RADIUS = 1.16
_X_COLOR, _Y_COLOR, _Z_COLOR = (214, 56, 56), (44, 160, 72), (48, 96, 214)

# Scene layout (metres, global frame; +Z up).
_GIMBAL_POSITION = np.array([0.0, 2.7, 0.0])
_GHOST_POSITIONS = (np.array([0.0, 0.0, 0.0]), np.array([0.0, 2.7, 0.0]))
_AXIS_ARROW_LENGTH = 1.3
_OMEGA_ARROW_SCALE = 0.9  # metres per rad/s
_OMEGA_ARROW_MAX = 2.0

#: Gauge thresholds on cond(G) = sigma_max / sigma_min.
_COND_WARN = 8.0
_COND_DANGER = 40.0
#: |det G| below which the Euler-angle rates are reported as singular (core's tol).
_RATE_TOL = 1e-6
#: Readouts are refreshed at most this often while the body moves (s).
_READOUT_PERIOD = 1.0 / 12.0
#: Tolerance on | |p| - 1 | before the Euler parameter input is renormalized.
_UNIT_TOL = rot.UNIT_NORM_TOL


def angle_names(seq: str) -> tuple[str, str, str]:
    """Names of the three angles: the chapter's (phi, theta, psi) for ZXZ."""
    if seq == "ZXZ":
        return ("\u03c6", "\u03b8", "\u03c8")
    return ("\u03b1\u2081", "\u03b1\u2082", "\u03b1\u2083")


def angle_labels(seq: str) -> tuple[str, str, str]:
    """Slider labels naming each angle's axis (primes: turned axes)."""
    names = angle_names(seq)
    if seq.isupper():
        return tuple(f"{n} about {a}{p}" for n, a, p in zip(names, seq, _PRIMES))  # type: ignore[return-value]
    return tuple(f"{n} about {a} (fixed)" for n, a in zip(names, seq))  # type: ignore[return-value]


# -- pure adapters: core results -> what the scene shows ----------------------
@dataclasses.dataclass(frozen=True)
class OrientationViews:
    """Every representation of one orientation (from :func:`orientation_views`).

    Attributes
    ----------
    p : (4,) unit Euler parameters, scalar first, theta0 >= 0 (viser ``wxyz``)
    A : (3, 3) rotation matrix, body to global
    seq : Euler angle sequence of ``euler``
    euler : (3,) Euler angles (rad) of ``A`` in ``seq``
    gimbal_lock : whether ``euler`` was taken at (or near) the singularity
    axis : (3,) unit rotation axis (global = body components)
    angle : rotation angle in [0, pi] (rad)
    rotation_vector : (3,) axis * angle (rad)
    gamma : (3,) Rodriguez parameters, or None at angle pi (infinite)
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


def _euler_from_matrix(A: np.ndarray, seq: str) -> tuple[np.ndarray, bool]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", rot.GimbalLockWarning)
        euler = rot.euler_angles_from_matrix(A, seq)
    locked = any(issubclass(w.category, rot.GimbalLockWarning) for w in caught)
    return np.asarray(euler, dtype=float), locked


def orientation_views(p: np.ndarray, seq: str) -> OrientationViews:
    """All representations of the orientation with Euler parameters ``p``.

    Parameters
    ----------
    p : (4,) unit Euler parameters, scalar first.
    seq : one of :data:`SEQUENCES`.
    """
    p = rot.canonical_euler_parameters(p)
    A = rot.matrix_from_euler_parameters(p)
    euler, locked = _euler_from_matrix(A, seq)
    axis, angle = rot.axis_angle_from_euler_parameters(p)
    gamma = None
    if not bool(rot.rodriguez_parameters_near_singularity(p)):
        gamma = rot.rodriguez_parameters_from_euler_parameters(p)
    return OrientationViews(
        p=p,
        A=A,
        seq=seq,
        euler=euler,
        gimbal_lock=locked,
        axis=np.asarray(axis, dtype=float),
        angle=float(angle),
        rotation_vector=rot.rotation_vector_from_euler_parameters(p),
        gamma=gamma,
    )


@dataclasses.dataclass(frozen=True)
class GimbalPose:
    """Pose of the three gimbal rings for Euler angles (from :func:`gimbal_pose`).

    Ring 0 is the outer ring (carried by the fixed stator), ring 2 the inner
    ring (carrying the body). For an intrinsic sequence ring k turns by angle
    k about the k-th letter; for an extrinsic one the order is reversed
    (``R = R3 R2 R1``), so the outer ring turns by the third angle.

    Attributes
    ----------
    axes : (3, 3) unit rotation axis of each ring in its carrier's frame
    angle_index : (3,) which Euler angle turns each ring
    wxyz : (3, 4) each ring's rotation relative to its carrier
    mount_wxyz : (3, 4) fixed orientation of each ring's mesh (ring plane
        through its own axis and its child's axis)
    stator_wxyz : (4,) orientation of the fixed bearings of the outer ring
    singular_values : (3,) singular values of G, descending
    condition : sigma_max / sigma_min of G (inf when singular)
    det : |det G| (the core's singularity measure)
    """

    axes: np.ndarray
    angle_index: tuple[int, int, int]
    wxyz: np.ndarray
    mount_wxyz: np.ndarray
    stator_wxyz: np.ndarray
    singular_values: np.ndarray
    condition: float
    det: float


def _frame_wxyz(x_axis: np.ndarray, z_axis: np.ndarray) -> np.ndarray:
    """Euler parameters of the frame with the given (orthonormal) x and z axes."""
    A = np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis])
    return rot.euler_parameters_from_matrix(A)


def gimbal_pose(angles: np.ndarray, seq: str) -> GimbalPose:
    """Ring rotations that realise Euler ``angles`` (rad) of ``seq`` (Eqs. 8.7-8.9).

    The product of the three ring rotations, outer to inner, equals
    ``matrix_from_euler_angles(angles, seq)``.
    """
    angles = np.asarray(angles, dtype=float)
    letters = seq.upper() if seq.isupper() else seq.upper()[::-1]
    index = (0, 1, 2) if seq.isupper() else (2, 1, 0)
    axes = np.eye(3)[[_AXIS_INDEX[c] for c in letters]]
    wxyz = rot.euler_parameters_from_axis_angle(axes, angles[list(index)])
    normals = [np.cross(axes[0], axes[1]), np.cross(axes[1], axes[2]), axes[1]]
    mount = np.stack([_frame_wxyz(axes[k], normals[k]) for k in range(3)])
    stator = mount[0]
    G = rot.euler_angle_G(angles, seq)
    s = np.linalg.svd(G, compute_uv=False)
    condition = float(s[0] / s[-1]) if s[-1] > 1e-12 * s[0] else math.inf
    return GimbalPose(
        axes=axes,
        angle_index=index,  # type: ignore[arg-type]
        wxyz=wxyz,
        mount_wxyz=mount,
        stator_wxyz=stator,
        singular_values=s,
        condition=condition,
        det=float(abs(np.linalg.det(G))),
    )


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
    """Products ``q1 q2`` and ``q2 q1`` and the rotation between them."""
    p12 = rot.quaternion_product(q1, q2)
    p21 = rot.quaternion_product(q2, q1)
    A12 = rot.matrix_from_euler_parameters(p12)
    A21 = rot.matrix_from_euler_parameters(p21)
    relative = rot.relative_euler_parameters(p12, p21)
    axis, angle = rot.axis_angle_from_euler_parameters(relative)
    return ComposeViews(
        q1=np.asarray(q1, dtype=float),
        q2=np.asarray(q2, dtype=float),
        p12=p12,
        p21=p21,
        difference=float(np.linalg.norm(A12 - A21)),
        relative=relative,
        relative_axis=np.asarray(axis, dtype=float),
        relative_angle=float(angle),
    )


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
    """
    omega = np.asarray(omega, dtype=float)
    if body_frame:
        omega_body = omega
        omega = rot.rotate_vector(p, omega_body)
    else:
        omega_body = rot.rotate_vector(rot.quaternion_conjugate(p), omega)
    det_G = float(abs(np.linalg.det(rot.euler_angle_G(angles, seq))))
    euler_rates = None
    if det_G > _RATE_TOL:
        euler_rates = rot.euler_angle_rates_from_omega(angles, omega, seq, tol=_RATE_TOL)
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
    """JSON-ready dict of ``views`` in every representation, with convention notes."""
    all_sequences = {s: _euler_from_matrix(views.A, s)[0].tolist() for s in SEQUENCES}
    mujoco_seq = views.seq.swapcase()
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
            "mujoco_eulerseq": mujoco_seq,
        },
        "euler_angles_all_sequences_rad": all_sequences,
    }


# -- small formatting helpers -------------------------------------------------
def _fmt(v: Any, digits: int = 4) -> str:
    arr = np.atleast_1d(np.asarray(v, dtype=float))
    return ", ".join(f"{x: .{digits}f}" for x in arr)


def _unit_direction(v: Any) -> np.ndarray | None:
    """``v / |v|`` for any non-zero finite 3-vector, else ``None``.

    Scaled by the largest entry first, so huge (1e200) and tiny (1e-200)
    vectors, whose squares overflow or underflow, keep their direction.
    """
    arr = np.asarray(v, dtype=float)
    if not _all_finite(arr):
        return None
    largest = float(np.max(np.abs(arr)))
    if largest == 0.0:
        return None
    scaled = arr / largest
    return scaled / float(np.linalg.norm(scaled))


def _all_finite(*arrays: Any) -> bool:
    return all(np.all(np.isfinite(np.asarray(a, dtype=float))) for a in arrays)


# -- the scene ----------------------------------------------------------------
class SandboxScene(Scene):
    """Rotation sandbox (see the module docstring)."""

    name: ClassVar[str] = "sandbox"
    title: ClassVar[str] = "Rotation sandbox"
    order: ClassVar[int] = 10
    #: Framing used by the app shell when the scene is shown (global frame, m).
    camera_position: ClassVar[tuple[float, float, float]] = (3.9, -0.4, 1.75)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 2.05, -0.05)

    def __init__(self, target: Any, notify: Any) -> None:
        super().__init__(target, notify)
        # State below is read and written by the update loop only; callbacks
        # touch nothing but ``_dirty`` / ``_downloads`` under ``self.lock``.
        self.seq = "ZXZ"
        self.input = INPUTS[0]
        self.panel = PANELS[0]
        self.p = rot.euler_parameters_from_euler_angles(
            np.radians([30.0, 40.0, 20.0]), "ZXZ"
        )
        self.gimbal_angles = np.radians([30.0, 40.0, 20.0])
        self.views: OrientationViews | None = None
        self.gimbal: GimbalPose | None = None
        self.compose: ComposeViews | None = None
        self.rates: RateViews | None = None
        self.animating = False
        self._dirty: set[str] = {"all"}
        self._downloads: list[Any] = []
        self._programmatic = threading.local()
        self._last_readout = 0.0
        self._readout_stale = True
        self._ep_notice_time = 0.0
        self._mounted_seq: str | None = None

    # ---------------------------------------------------------------- build
    def build(self) -> None:
        scene = self.target.scene
        gui = self.target.gui
        root = self.root
        self.make_root()

        # Fixed global frame with labelled axes and a floor grid.
        # Global axes: thin pale lines, so the thick body axes stand out.
        ends = 1.5 * np.eye(3)
        scene.add_line_segments(
            f"{root}/global_axes",
            points=np.stack([np.zeros((3, 3)), ends], axis=1).astype(np.float32),
            colors=np.repeat(np.array([[[236, 128, 128]], [[120, 200, 140]], [[130, 160, 236]]]), 2, axis=1),
            thickness=2.5, thickness_units="screen",
        )
        for label, vec in (("X", (1.62, 0, 0)), ("Y", (0, 1.62, 0)), ("Z", (0, 0, 1.62))):
            scene.add_label(f"{root}/global_label_{label}", label, position=vec, anchor="center-center")
        self.add_ground_grid(
            width=5.0, height=7.0, position=(0.0, 1.35, -1.3), cell_size=0.25, section_size=1.0
        )

        # The body: frame with labelled axes, hull, nose (+x_b) and fin (+z_b).
        self.body_frame = scene.add_frame(
            f"{root}/body", axes_length=0.95, axes_radius=0.022, wxyz=self.p
        )
        self._add_body_meshes(f"{root}/body", 1.0, opacity=None)
        for label, vec in (("x_b", (1.05, 0, 0)), ("y_b", (0, 1.05, 0)), ("z_b", (0, 0, 1.05))):
            scene.add_label(f"{root}/body/label_{label}", label, position=vec, anchor="center-center")

        # Rotation axis arrow (+z of its frame) with the angle as an arc and a label.
        self.axis_frame = scene.add_frame(f"{root}/rotation_axis", show_axes=False)
        scene.add_arrows(
            f"{root}/rotation_axis/arrow",
            points=np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, _AXIS_ARROW_LENGTH]]]),
            colors=(230, 180, 20), shaft_radius=0.018, head_radius=0.05, head_length=0.12,
        )
        self.axis_arc = scene.add_line_segments(
            f"{root}/rotation_axis/arc", points=self._arc_points(0.0),
            colors=(230, 180, 20), thickness=3.0, thickness_units="screen",
        )
        self.axis_label = scene.add_label(
            f"{root}/rotation_axis/label", "angle", position=(0.0, 0.0, _AXIS_ARROW_LENGTH + 0.3),
            anchor="bottom-center",
        )

        # Angular velocity arrow (global frame), shown in the omega panel.
        self.omega_frame = scene.add_frame(f"{root}/omega", show_axes=False, visible=False)
        self.omega_arrow = scene.add_arrows(
            f"{root}/omega/arrow", points=np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]]),
            colors=(200, 40, 160), shaft_radius=0.02, head_radius=0.055, head_length=0.12,
        )
        self.omega_label = scene.add_label(
            f"{root}/omega/label", "\u03c9", position=(0.0, 0.0, 1.1), anchor="bottom-center"
        )

        self._build_gimbal()

        # Ghost bodies for the compose panel.
        self.ghosts = []
        self.ghost_labels = []
        for k, (position, color, text) in enumerate(
            zip(_GHOST_POSITIONS, ((238, 146, 38), (142, 88, 196)), ("A(q1 q2)", "A(q2 q1)"))
        ):
            holder = scene.add_frame(f"{root}/ghost{k}", show_axes=False, position=position, visible=False)
            frame = scene.add_frame(f"{root}/ghost{k}/body", axes_length=0.9, axes_radius=0.018)
            self._add_body_meshes(f"{root}/ghost{k}/body", 1.0, opacity=0.55, color=color)
            label = scene.add_label(
                f"{root}/ghost{k}/label", text, position=(0.0, 0.0, 1.25), anchor="bottom-center"
            )
            self.ghosts.append((holder, frame))
            self.ghost_labels.append(label)

        self._build_gui(gui)

    def _add_body_meshes(
        self, parent: str, length: float, *, opacity: float | None,
        color: tuple[int, int, int] = (176, 190, 214),
    ) -> None:
        parts = meshes.body_parts(length)
        colors = {"hull": color, "nose": _X_COLOR, "fin": _Z_COLOR}
        for part, (vertices, faces) in parts.items():
            self.target.scene.add_mesh_simple(
                f"{parent}/{part}", vertices, faces, color=colors[part], opacity=opacity,
                flat_shading=part != "nose",
            )

    def _build_gimbal(self) -> None:
        scene = self.target.scene
        base = f"{self.root}/gimbal"
        self.gimbal_root = scene.add_frame(base, show_axes=False, position=_GIMBAL_POSITION)
        self.stator = scene.add_frame(f"{base}/stator", show_axes=False)
        vertices, faces = meshes.pins(_STATOR_RADIUS - 0.02, _STATOR_RADIUS + 0.1, 0.055)
        scene.add_mesh_simple(f"{base}/stator/bearings", vertices, faces, color=(120, 120, 128))
        self.ring_frames = []
        self.ring_mounts = []
        self.ring_meshes = []
        self.ring_labels = []
        parent = base
        outer = _STATOR_RADIUS
        for k in range(3):
            name = f"{parent}/ring{k}"
            frame = scene.add_frame(name, show_axes=False)
            mount = scene.add_frame(f"{name}/mount", show_axes=False)
            v, f = meshes.ring(_RING_RADII[k], _RING_TUBE)
            mesh = scene.add_mesh_simple(f"{name}/mount/ring", v, f, color=_RING_COLORS[k])
            v, f = meshes.pins(_RING_RADII[k], outer, 0.022)
            scene.add_mesh_simple(f"{name}/mount/pins", v, f, color=(150, 150, 158))
            label = scene.add_label(
                f"{name}/mount/label", "", position=(0.0, _RING_RADII[k], 0.0), anchor="bottom-center"
            )
            self.ring_frames.append(frame)
            self.ring_mounts.append(mount)
            self.ring_meshes.append(mesh)
            self.ring_labels.append(label)
            parent = name
            outer = _RING_RADII[k]
        # A smaller copy of the body rides in the inner ring.
        inner = f"{parent}/body"
        scene.add_frame(inner, axes_length=0.5, axes_radius=0.012)
        self._add_body_meshes(inner, 0.62, opacity=None)
        self.gimbal_label = scene.add_label(
            f"{base}/caption", "", position=(0.0, 0.0, 1.35), anchor="bottom-center"
        )

    def _build_gui(self, gui: Any) -> None:
        folder = self.make_folder()
        with folder:
            self.legend = gui.add_markdown(
                "Body: red nose = x<sub>b</sub>, blue fin = z<sub>b</sub>; thin pale axes = global X, Y, Z. "
                "Gimbal rings: orange, purple, teal = Euler angles 1, 2, 3. Yellow arrow: rotation axis."
            )
            self.panel_dropdown = gui.add_dropdown(
                "Panel", options=PANELS, initial_value=self.panel,
                hint="What to explore: orientation inputs, composition, angular velocity, export.",
            )
            # -- orientation inputs
            self.input_folder = gui.add_folder("Input (one at a time)")
            with self.input_folder:
                self.input_dropdown = gui.add_dropdown(
                    "Input with", options=INPUTS, initial_value=self.input,
                    hint="Which representation drives the body; the others are read out below.",
                )
                self.seq_dropdown = gui.add_dropdown(
                    "Euler sequence", options=[_SEQ_LABELS[s] for s in SEQUENCES],
                    initial_value=_SEQ_LABELS[self.seq],
                    hint="Upper case: intrinsic (about the turning axes); lower case: extrinsic "
                         "(about the fixed global axes). Also sets the gimbal and the readouts.",
                )
                self.euler_folder = gui.add_folder("Euler angles (deg)")
                with self.euler_folder:
                    labels = angle_labels(self.seq)
                    self.euler_sliders = [
                        gui.add_slider(
                            labels[k], min=-180.0, max=180.0, step=0.5,
                            initial_value=float(np.degrees(self.gimbal_angles[k])),
                            hint=f"Angle {k + 1}: turns the {_RING_COLOR_NAMES[k]} gimbal ring.",
                        )
                        for k in range(3)
                    ]
                self.axis_angle_folder = gui.add_folder("Axis and angle", visible=False)
                with self.axis_angle_folder:
                    self.axis_input = gui.add_vector3(
                        "Axis", initial_value=(0.0, 0.0, 1.0), step=0.05,
                        hint="Any non-zero vector; it is normalized (Eq. 8.29).",
                    )
                    self.angle_slider = gui.add_slider(
                        "Angle (deg)", min=-360.0, max=360.0, step=0.5, initial_value=0.0
                    )
                self.ep_folder = gui.add_folder("Euler parameters", visible=False)
                with self.ep_folder:
                    self.ep_inputs = [
                        gui.add_number(f"\u03b8{k}", initial_value=1.0 if k == 0 else 0.0, step=0.01)
                        for k in range(4)
                    ]
                    self.ep_status = gui.add_markdown("")
                self.gamma_folder = gui.add_folder("Rodriguez parameters", visible=False)
                with self.gamma_folder:
                    self.gamma_input = gui.add_vector3(
                        "\u03b3", initial_value=(0.0, 0.0, 0.0), step=0.05,
                        hint="gamma = axis tan(angle / 2); angle 180 deg is at infinity (Eqs. 8.58-8.60).",
                    )
                self.rotvec_folder = gui.add_folder("Rotation vector (rad)", visible=False)
                with self.rotvec_folder:
                    self.rotvec_input = gui.add_vector3(
                        "axis \u00d7 angle", initial_value=(0.0, 0.0, 0.0), step=0.05,
                        hint="Direction: rotation axis; length: angle in radians.",
                    )
                self.reset_button = gui.add_button("Reset orientation", hint="Back to phi, theta, psi = 30, 40, 20 deg (ZXZ).")
            # -- gimbal gauge
            self.gauge_folder = gui.add_folder("Gimbal: how far from lock")
            with self.gauge_folder:
                self.gauge = gui.add_progress_bar(100.0, color="green")
                self.gauge_text = gui.add_markdown("")
            # -- compose
            self.compose_folder = gui.add_folder("Compose q1, q2", visible=False)
            with self.compose_folder:
                self.q_axes = []
                self.q_angles = []
                for k, (axis, angle) in enumerate((((1.0, 0.0, 0.0), 90.0), ((0.0, 0.0, 1.0), 90.0))):
                    self.q_axes.append(gui.add_vector3(f"q{k + 1} axis", initial_value=axis, step=0.05))
                    self.q_angles.append(
                        gui.add_slider(f"q{k + 1} angle (deg)", min=-180.0, max=180.0, step=1.0, initial_value=angle)
                    )
                self.q1_from_body_button = gui.add_button(
                    "q1 \u2190 current body orientation",
                    hint="Copy the orientation set in the Orientation panel into q1 (axis and angle).",
                )
                self.compose_text = gui.add_markdown("")
            # -- angular velocity
            self.omega_folder = gui.add_folder("Angular velocity", visible=False)
            with self.omega_folder:
                self.omega_input = gui.add_vector3(
                    "\u03c9 (rad/s)", initial_value=(0.0, 0.0, 1.0), step=0.1
                )
                self.omega_frame_dropdown = gui.add_dropdown(
                    "\u03c9 given in", options=_OMEGA_FRAMES, initial_value=_OMEGA_FRAMES[0]
                )
                self.animate_checkbox = gui.add_checkbox(
                    "Animate (constant \u03c9)", initial_value=False,
                    hint="Turn the body under this constant angular velocity (exact update).",
                )
                self.rates_text = gui.add_markdown("")
            # -- export
            self.export_folder = gui.add_folder("Export", visible=False)
            with self.export_folder:
                self.download_button = gui.add_button("Download JSON")
                self.export_text = gui.add_text("JSON", initial_value="", multiline=True, disabled=True)
            # -- readouts
            self.readout_folder = gui.add_folder("Readouts (current orientation)")
            with self.readout_folder:
                self.readout_text = gui.add_markdown("")

        self._connect_callbacks()

    def _connect_callbacks(self) -> None:
        def mark(key: str) -> Any:
            def callback(_: Any) -> None:
                if getattr(self._programmatic, "on", False):
                    return  # the loop itself wrote this value
                with self.lock:
                    self._dirty.add(key)
            return callback

        self.panel_dropdown.on_update(mark("panel"))
        self.input_dropdown.on_update(mark("input"))
        self.seq_dropdown.on_update(mark("seq"))
        for slider in self.euler_sliders:
            slider.on_update(mark("Euler angles"))
        self.axis_input.on_update(mark("Axis and angle"))
        self.angle_slider.on_update(mark("Axis and angle"))
        for number in self.ep_inputs:
            number.on_update(mark("Euler parameters"))
        self.gamma_input.on_update(mark("Rodriguez parameters"))
        self.rotvec_input.on_update(mark("Rotation vector"))
        self.reset_button.on_click(mark("reset"))
        for handle in (*self.q_axes, *self.q_angles):
            handle.on_update(mark("compose"))
        self.q1_from_body_button.on_click(mark("q1_from_body"))
        self.omega_input.on_update(mark("omega"))
        self.omega_frame_dropdown.on_update(mark("omega"))
        self.animate_checkbox.on_update(mark("animate"))

        @self.download_button.on_click
        def _(event: Any) -> None:
            with self.lock:
                self._downloads.append(event.client)

    # --------------------------------------------------------------- update
    def update(self, dt: float) -> None:
        with self.lock:
            dirty, self._dirty = self._dirty, set()
            downloads, self._downloads = self._downloads, []
        if not dirty and not downloads and not self.animating and not self._readout_stale:
            return
        if "all" in dirty:
            dirty |= {"panel", "input", "seq", "compose", "omega", "animate"}
        moved = "all" in dirty

        if "panel" in dirty:
            self.panel = str(self.panel_dropdown.value)
        if "animate" in dirty:
            self.animating = bool(self.animate_checkbox.value)
            if not self.animating:
                dirty.add("sync")
        if "reset" in dirty:
            self.seq = "ZXZ"
            self.gimbal_angles = np.radians([30.0, 40.0, 20.0])
            self.p = rot.euler_parameters_from_euler_angles(self.gimbal_angles, self.seq)
            self.animating = False
            dirty |= {"sync", "seq_widgets", "animate_widget"}
            moved = True
        if "seq" in dirty and "reset" not in dirty:
            seq = _LABEL_SEQS.get(str(self.seq_dropdown.value), self.seq)
            if seq != self.seq:
                self.seq = seq
                # Same orientation, new angles: the sliders and rings follow.
                self.gimbal_angles, _ = _euler_from_matrix(rot.matrix_from_euler_parameters(self.p), seq)
                dirty |= {"sync", "seq_widgets"}
                moved = True
        if "input" in dirty:
            new_input = str(self.input_dropdown.value)
            if new_input != self.input:
                self.input = new_input
                dirty.add("sync")
        for key in INPUTS:
            if key in dirty and key == self.input:
                moved |= self._apply_input(key)
        if self.animating and dt > 0:
            moved |= self._advance(dt)
            if time.monotonic() - self._last_readout > _READOUT_PERIOD:
                dirty.add("sync")

        if moved:
            self.views = orientation_views(self.p, self.seq)
            if self.input != "Euler angles" or self.animating:
                self.gimbal_angles = self.views.euler
            self.gimbal = gimbal_pose(self.gimbal_angles, self.seq)
            self._readout_stale = True
        if moved or "omega" in dirty or "panel" in dirty:
            self.rates = self._rates()
            self._readout_stale = True  # the rates text follows omega
        if "q1_from_body" in dirty:
            views = self.views or orientation_views(self.p, self.seq)
            with self._writing():
                self.q_axes[0].value = tuple(np.round(views.axis, 6))
                self.q_angles[0].value = round(math.degrees(views.angle), 3)
            dirty.add("compose")
        if "compose" in dirty:
            self.compose = self._compose()

        now = time.monotonic()
        write_text = self._readout_stale and (now - self._last_readout >= _READOUT_PERIOD)
        with self.target.atomic():
            if moved:
                self._show_orientation()
            if "panel" in dirty or "all" in dirty:
                self._show_panel()
            if "compose" in dirty and self.compose is not None:
                self._show_compose()
            if moved or "omega" in dirty or "panel" in dirty:
                self._show_omega_arrow()
            with self._writing():
                if "seq_widgets" in dirty or "all" in dirty:
                    self._show_sequence_widgets()
                if "input" in dirty or "all" in dirty:
                    self._show_input_folders()
                if "animate_widget" in dirty:
                    self.animate_checkbox.value = self.animating
                if "sync" in dirty:
                    self._sync_input_fields()
                if write_text:
                    self._show_text()
        if write_text:
            self._last_readout = now
            self._readout_stale = False
        for client in downloads:
            self._send_download(client)

    # -- input -> orientation ---------------------------------------------
    def _apply_input(self, key: str) -> bool:
        """Read the active input panel; return True if the orientation changed.

        A new orientation is accepted only if the core returns finite unit
        Euler parameters; otherwise (values too large to represent, or a
        ValueError from the core) a notice explains and nothing moves.
        """
        previous = self.p
        try:
            with np.errstate(all="ignore"):
                changed = self._read_input(key)
        except ValueError as exc:
            self.p = previous
            self.notify(key, f"{exc}. The orientation is unchanged.", "warning")
            return False
        if changed:
            norm = float(rot.quaternion_norm(self.p)) if _all_finite(self.p) else math.nan
            if not abs(norm - 1.0) <= _UNIT_TOL:
                self.p = previous
                self.notify(
                    key,
                    "These values are too large to represent a rotation in floating point; "
                    "the orientation is unchanged.",
                    "warning",
                )
                return False
        return changed

    def _read_input(self, key: str) -> bool:
        if key == "Euler angles":
            angles = np.radians([float(s.value) for s in self.euler_sliders])
            if not _all_finite(angles):
                self.notify("Euler angles", "The angles must be finite numbers.", "warning")
                return False
            self.gimbal_angles = angles
            self.p = rot.euler_parameters_from_euler_angles(angles, self.seq)
            return True
        if key == "Axis and angle":
            axis = np.asarray(self.axis_input.value, dtype=float)
            angle = math.radians(float(self.angle_slider.value))
            unit = _unit_direction(axis)
            if unit is None or not math.isfinite(angle):
                self.notify(
                    "Axis and angle",
                    f"The axis must be a non-zero finite vector, got ({', '.join(f'{x:.3g}' for x in axis)}); "
                    "the orientation is unchanged.",
                    "warning",
                )
                return False
            self.p = rot.euler_parameters_from_axis_angle(unit, angle)
            return True
        if key == "Euler parameters":
            raw = np.array([float(n.value) for n in self.ep_inputs])
            norm = float(rot.quaternion_norm(raw)) if _all_finite(raw) else math.nan
            if not (1e-12 < norm < math.inf):
                self.notify(
                    "Euler parameters",
                    f"(\u03b80..\u03b83) = ({_fmt(raw, 3)}) has no direction (zero, too large or not finite); "
                    "the orientation is unchanged.",
                    "error",
                )
                self._ep_status(f"**Not a rotation:** |p| = {norm:.4g}. Enter four numbers, not all zero.")
                return False
            self.p = rot.normalize_euler_parameters(raw)
            if abs(norm - 1.0) > _UNIT_TOL:
                message = (
                    f"|p| = {norm:.4f}, not 1: using p / |p| = ({_fmt(self.p, 4)}). "
                    "The Euler parameters of a rotation satisfy \u03b80\u00b2+\u03b81\u00b2+\u03b82\u00b2+\u03b83\u00b2 = 1."
                )
                self._ep_status(f"**Normalized:** {message}")
                now = time.monotonic()
                if now - self._ep_notice_time > 3.0:
                    self._ep_notice_time = now
                    self.notify("Euler parameters normalized", message, "warning")
            else:
                self._ep_status("Unit length: |p| = 1.")
            return True
        if key == "Rodriguez parameters":
            gamma = np.asarray(self.gamma_input.value, dtype=float)
            if not _all_finite(gamma):
                self.notify("Rodriguez parameters", "The parameters must be finite numbers.", "warning")
                return False
            self.p = rot.euler_parameters_from_rodriguez_parameters(gamma)
            return True
        if key == "Rotation vector":
            r = np.asarray(self.rotvec_input.value, dtype=float)
            if not _all_finite(r):
                self.notify("Rotation vector", "The components must be finite numbers.", "warning")
                return False
            self.p = rot.euler_parameters_from_rotation_vector(r)
            return True
        raise ValueError(f"key: expected one of {INPUTS}, got {key!r}")

    def _ep_status(self, text: str) -> None:
        with self._writing():
            self.ep_status.content = text

    def _advance(self, dt: float) -> bool:
        """Turn the body for ``dt`` seconds under the constant omega (exact)."""
        omega = self._omega_value()
        if omega is None or not np.any(omega):
            return False
        step = rot.euler_parameters_from_rotation_vector(omega * dt)
        if self._omega_in_body():
            p = rot.quaternion_product(self.p, step)  # A <- A R(omega_body dt)
        else:
            p = rot.quaternion_product(step, self.p)  # A <- R(omega dt) A
        self.p = rot.normalize_euler_parameters(p)
        return True

    def _omega_in_body(self) -> bool:
        return str(self.omega_frame_dropdown.value) == _OMEGA_FRAMES[1]

    def _omega_value(self) -> np.ndarray | None:
        """The entered omega, or ``None`` unless finite within +-_OMEGA_MAX."""
        omega = np.asarray(self.omega_input.value, dtype=float)
        if not _all_finite(omega) or float(np.max(np.abs(omega))) > _OMEGA_MAX:
            return None
        return omega

    def _rates(self) -> RateViews | None:
        omega = self._omega_value()
        if omega is None:
            entered = np.asarray(self.omega_input.value, dtype=float)
            self.notify(
                "Angular velocity",
                f"omega must have finite components within ±{_OMEGA_MAX:.0e} rad/s, "
                f"got ({', '.join(f'{x:.3g}' for x in entered)}); rates and animation are off.",
                "warning",
            )
            return None
        return rate_views(self.p, self.gimbal_angles, self.seq, omega, body_frame=self._omega_in_body())

    def _compose(self) -> ComposeViews | None:
        qs = []
        for k in range(2):
            axis = np.asarray(self.q_axes[k].value, dtype=float)
            unit = _unit_direction(axis)
            if unit is None:
                self.notify(
                    "Compose",
                    f"q{k + 1} axis must be a non-zero finite vector, got ({', '.join(f'{x:.3g}' for x in axis)}).",
                    "warning",
                )
                return self.compose
            qs.append(rot.euler_parameters_from_axis_angle(unit, math.radians(float(self.q_angles[k].value))))
        return compose_views(qs[0], qs[1])

    # -- orientation -> nodes ----------------------------------------------
    def _writing(self) -> Any:
        scene = self

        class _Flag:
            def __enter__(self) -> None:
                scene._programmatic.on = True

            def __exit__(self, *exc: Any) -> None:
                scene._programmatic.on = False

        return _Flag()

    @staticmethod
    def _arc_points(angle: float, radius: float = 0.32, height: float = 0.95, n: int = 40) -> np.ndarray:
        t = np.linspace(0.0, angle, n + 1)
        pts = np.stack([radius * np.cos(t), radius * np.sin(t), np.full_like(t, height)], axis=-1)
        return np.stack([pts[:-1], pts[1:]], axis=1).astype(np.float32)

    @staticmethod
    def _z_to(direction: np.ndarray) -> np.ndarray:
        """Euler parameters of a rotation taking +z to the unit vector ``direction``."""
        ez = np.array([0.0, 0.0, 1.0])
        cross = np.cross(ez, direction)
        s = float(np.linalg.norm(cross))
        c = float(np.dot(ez, direction))
        if s < 1e-12:
            return np.array([1.0, 0, 0, 0]) if c > 0 else np.array([0.0, 1.0, 0, 0])
        return rot.euler_parameters_from_axis_angle(cross / s, math.atan2(s, c))

    def _show_orientation(self) -> None:
        views, gimbal = self.views, self.gimbal
        assert views is not None and gimbal is not None
        if not _all_finite(views.p, gimbal.wxyz, gimbal.mount_wxyz):
            self.notify("Rotation sandbox", "A non-finite orientation was refused.", "error")
            return
        self.body_frame.wxyz = views.p
        # rotation axis arrow and angle arc (hidden for the identity)
        has_axis = views.angle > math.radians(0.05)
        self.axis_frame.visible = has_axis and self.panel != PANELS[1]
        if has_axis:
            self.axis_frame.wxyz = self._z_to(views.axis)
        # gimbal rings
        for k in range(3):
            self.ring_frames[k].wxyz = gimbal.wxyz[k]
        if self._mounted_seq != self.seq:  # ring planes change only with the sequence
            self._mounted_seq = self.seq
            for k in range(3):
                self.ring_mounts[k].wxyz = gimbal.mount_wxyz[k]
            self.stator.wxyz = gimbal.stator_wxyz

    def _show_labels(self) -> None:
        """Angle arc and 3-D labels: sent with the readouts (about 12 Hz), not
        every frame, since every message is sent to every client."""
        views, gimbal = self.views, self.gimbal
        if views is None or gimbal is None:
            return
        if views.angle > math.radians(0.05):
            self.axis_arc.points = self._arc_points(views.angle)
            self.axis_label.text = f"rotation axis, {math.degrees(views.angle):.1f}\u00b0"
        self.gimbal_label.text = f"{self.seq} gimbal: cond G = {_cond_text(gimbal.condition)}"

    def _show_sequence_widgets(self) -> None:
        labels = angle_labels(self.seq)
        names = angle_names(self.seq)
        for k, slider in enumerate(self.euler_sliders):
            slider.label = labels[k]
        gimbal = self.gimbal
        if gimbal is not None:
            for k in range(3):
                j = gimbal.angle_index[k]
                letter = self.seq[j]
                self.ring_labels[k].text = f"{names[j]} ({letter})"
                self.ring_meshes[k].color = _RING_COLORS[j]
        wanted = _SEQ_LABELS[self.seq]
        if self.seq_dropdown.value != wanted:
            self.seq_dropdown.value = wanted

    def _show_input_folders(self) -> None:
        folders = {
            "Euler angles": self.euler_folder,
            "Axis and angle": self.axis_angle_folder,
            "Euler parameters": self.ep_folder,
            "Rodriguez parameters": self.gamma_folder,
            "Rotation vector": self.rotvec_folder,
        }
        for key, folder in folders.items():
            folder.visible = key == self.input

    def _show_panel(self) -> None:
        orientation, compose, omega, export = (self.panel == p for p in PANELS)
        self.input_folder.visible = orientation
        self.gauge_folder.visible = orientation or omega
        self.compose_folder.visible = compose
        self.omega_folder.visible = omega
        self.export_folder.visible = export
        self.readout_folder.visible = not compose
        # 3-D: the compose panel swaps the body and gimbal for the two ghosts.
        self.body_frame.visible = not compose
        self.gimbal_root.visible = not compose
        if self.views is not None:
            self.axis_frame.visible = (not compose) and self.views.angle > math.radians(0.05)
        for holder, _ in self.ghosts:
            holder.visible = compose
        self.omega_frame.visible = omega
        self._readout_stale = True

    def _show_compose(self) -> None:
        c = self.compose
        assert c is not None
        if not _all_finite(c.p12, c.p21):
            return
        self.ghosts[0][1].wxyz = c.p12
        self.ghosts[1][1].wxyz = c.p21
        self._readout_stale = True

    def _show_omega_arrow(self) -> None:
        r = self.rates
        if r is None:  # refused omega: nothing stale stays on screen
            self.omega_arrow.visible = False
            self.omega_label.visible = False
            return
        norm = float(np.linalg.norm(r.omega))
        if norm < 1e-12 or not math.isfinite(norm):
            self.omega_arrow.visible = False
            self.omega_label.visible = False
            return
        length = min(_OMEGA_ARROW_SCALE * norm, _OMEGA_ARROW_MAX)
        self.omega_arrow.visible = True
        self.omega_label.visible = True
        self.omega_frame.wxyz = self._z_to(r.omega / norm)
        self.omega_arrow.points = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, length]]], dtype=np.float32)
        self.omega_label.position = (0.0, 0.0, length + 0.08)

    def _sync_input_fields(self) -> None:
        """Show the current orientation in the active input's fields."""
        views = self.views or orientation_views(self.p, self.seq)
        if self.input == "Euler angles":
            for k, slider in enumerate(self.euler_sliders):
                slider.value = float(np.clip(round(math.degrees(self.gimbal_angles[k]) * 2) / 2, -180, 180))
        elif self.input == "Axis and angle":
            self.axis_input.value = tuple(np.round(views.axis, 4))
            self.angle_slider.value = round(math.degrees(views.angle) * 2) / 2
        elif self.input == "Euler parameters":
            for k, number in enumerate(self.ep_inputs):
                number.value = round(float(views.p[k]), 4)
            self.ep_status.content = "Unit length: |p| = 1."
        elif self.input == "Rodriguez parameters":
            if views.gamma is None:
                self.notify(
                    "Rodriguez parameters",
                    "The angle is 180\u00b0: gamma = axis tan(90\u00b0) is infinite, so the "
                    "fields keep their values.",
                    "info",
                )
            else:
                self.gamma_input.value = tuple(np.round(views.gamma, 4))
        elif self.input == "Rotation vector":
            self.rotvec_input.value = tuple(np.round(views.rotation_vector, 4))

    # -- text ---------------------------------------------------------------
    def _show_text(self) -> None:
        views, gimbal = self.views, self.gimbal
        if views is None or gimbal is None:
            return
        self._show_labels()
        self.readout_text.content = self._readout_markdown(views)
        s = gimbal.singular_values
        fraction = float(s[-1] / s[0]) if s[0] > 0 else 0.0
        self.gauge.value = float(np.clip(100.0 * fraction, 0.0, 100.0))
        if gimbal.condition > _COND_DANGER:
            self.gauge.color = "red"
            state = "**Gimbal lock!** Two rings are (nearly) coplanar: the first and third axes align and one degree of freedom is lost."
        elif gimbal.condition > _COND_WARN:
            self.gauge.color = "orange"
            state = "**Near gimbal lock:** rates of the Euler angles grow like 1 / |det G|."
        else:
            self.gauge.color = "green"
            state = "Far from gimbal lock."
        self.gauge_text.content = (
            f"G of {self.seq} (\u03c9 = G \u00b7 angle rates, Eq. 8.8): "
            f"\u03c3_min = {s[-1]:.3f}, cond = {_cond_text(gimbal.condition)}, "
            f"|det G| = {gimbal.det:.3f}. {state}"
        )
        if self.panel == PANELS[1] and self.compose is not None:
            self.compose_text.content = self._compose_markdown(self.compose)
        if self.panel == PANELS[2]:
            self.rates_text.content = (
                self._rates_markdown(self.rates) if self.rates is not None
                else "*No valid \u03c9 entered: rates and animation are off.*"
            )
        if self.panel == PANELS[3]:
            self.export_text.value = json.dumps(export_document(views), indent=1)

    def _readout_markdown(self, v: OrientationViews) -> str:
        names = angle_names(v.seq)
        A = v.A
        matrix = "\n".join("[" + _fmt(row, 4) + " ]" for row in A)
        gamma = (
            f"({_fmt(v.gamma, 4)})" if v.gamma is not None
            else "infinite (angle = 180\u00b0, Eq. 8.58)"
        )
        lock = "  \u26a0 gimbal lock: angles 1 and 3 are not unique" if v.gimbal_lock else ""
        return (
            "**A** (body \u2192 global, columns = body axes in global)\n"
            f"```\n{matrix}\n```\n"
            f"**Euler angles {v.seq}** (deg): "
            + ", ".join(f"{n} = {math.degrees(a):.2f}" for n, a in zip(names, v.euler))
            + f"{lock}\n\n"
            f"**Euler parameters** \u03b80..\u03b83: ({_fmt(v.p, 4)}) (shown with \u03b80 \u2265 0; \u2212p is the same rotation)\n\n"
            f"**Rodriguez parameters** \u03b3: {gamma}\n\n"
            f"**Axis, angle:** ({_fmt(v.axis, 4)}), {math.degrees(v.angle):.2f}\u00b0\n\n"
            f"**Rotation vector** (rad): ({_fmt(v.rotation_vector, 4)})"
        )

    @staticmethod
    def _compose_markdown(c: ComposeViews) -> str:
        same = c.difference < 1e-9
        verdict = (
            "The two products are equal: these rotations commute (same axis, or an angle is 0)."
            if same else
            f"**A(q1 q2) \u2260 A(q2 q1)**: \u2016A(q1 q2) \u2212 A(q2 q1)\u2016 = {c.difference:.4f}. "
            "Finite rotations do not commute (problem 4)."
        )
        return (
            f"q1 = ({_fmt(c.q1, 4)})  \nq2 = ({_fmt(c.q2, 4)})\n\n"
            f"**q1 q2** = ({_fmt(c.p12, 4)}) (orange ghost)  \n"
            f"**q2 q1** = ({_fmt(c.p21, 4)}) (purple ghost)\n\n{verdict}\n\n"
            f"**Relative rotation** of the purple body seen from the orange one, "
            f"p = (q1 q2)* (q2 q1) (Eq. 8.82): ({_fmt(c.relative, 4)}), "
            f"{math.degrees(c.relative_angle):.2f}\u00b0 about ({_fmt(c.relative_axis, 3)}) in the orange body's frame."
        )

    def _rates_markdown(self, r: RateViews) -> str:
        names = angle_names(self.seq)
        if r.euler_rates is None:
            euler = (
                f"**singular** (|det G| = {r.det_G:.2e}): the first and third axes of {self.seq} "
                "are aligned, so their rates only enter as a sum or difference; a component of "
                "\u03c9 along the missing direction needs infinite rates. Euler parameters have no such point."
            )
        else:
            euler = ", ".join(f"{n}\u0307 = {x:.4f}" for n, x in zip(names, r.euler_rates))
            if r.det_G < 0.1:
                euler += f" (near singular: |det G| = {r.det_G:.3f}, rates grow like 1/|det G|)"
        gamma = (
            f"({_fmt(r.gamma_dot, 4)})" if r.gamma_dot is not None
            else "**undefined**: at 180\u00b0 \u03b3 is infinite (Eq. 8.58)"
        )
        return (
            f"\u03c9 (global) = ({_fmt(r.omega, 3)}), \u03c9\u0304 (body) = ({_fmt(r.omega_body, 3)}) rad/s\n\n"
            f"**Euler angle rates {self.seq}** (rad/s, \u03c9 = G \u00b7 rates, Eq. 8.8): {euler}\n\n"
            f"**Euler parameter rates** \u1e57 = G\u1d40\u03c9/2 (Eqs. 8.51-8.54): ({_fmt(r.p_dot, 4)}); "
            "never singular.\n\n"
            f"**Rodriguez parameter rates** \u03b3\u0307 (Eqs. 8.61-8.64): {gamma}"
        )

    def _send_download(self, client: Any) -> None:
        views = self.views or orientation_views(self.p, self.seq)
        content = json.dumps(export_document(views), indent=2).encode()
        target = client if client is not None else self.target
        target.send_file_download("orientation.json", content)


def _cond_text(condition: float) -> str:
    return "\u221e" if not math.isfinite(condition) else f"{condition:.2f}"
