"""Manipulator scene: the three-joint arm of Fig. 8.3 (Eqs. 8.39-8.45, problem 12).

Three links and an end object (a gripper) turned by three joint-angle sliders.
The core computes the link poses in two ways and the scene draws both:

* solid links and their frames: successive relative rotations
  ``A = A21 A32 A43`` (Eqs. 8.39-8.42, :func:`rigidlab.core.manipulator.link_frames_successive`);
* longer, thinner ghost frames: Rodriguez rotations about the joint axes
  fixed in the global frame, applied joint 3 first (Eqs. 8.43-8.45,
  :func:`rigidlab.core.manipulator.link_frames_global_axis_rotations`), with those
  fixed global axes drawn as lines. A "Rodriguez steps" slider shows the
  construction after 0, 1 or 2 of its rotations with translucent ghost links.

A readout shows the end-link matrix, the largest difference between the two
procedures, and the Euler-angle form of the result (Z-X-Z for these joints);
it is rewritten at most every 0.1 s, while poses stream at the loop rate.
"Animate joints" sweeps the three joints smoothly. The scene holds no
kinematics of its own: it calls :mod:`rigidlab.core.manipulator` and converts matrices
to viser's ``wxyz`` (Euler parameters, scalar first) with
:func:`rigidlab.core.rotations.euler_parameters_from_matrix`.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from typing import Any, ClassVar

import numpy as np
import trimesh

from rigidlab.app.controls import Slider, Toggle
from rigidlab.app.nodes import set_arrays, set_pose
from rigidlab.app.scenes.base import Scene
from rigidlab.core.manipulator import (
    DEFAULT_GEOMETRY,
    ManipulatorGeometry,
    euler_form,
    link_frames_global_axis_rotations,
    link_frames_successive,
)
from rigidlab.core.rotations import (
    euler_angles_from_matrix,
    euler_parameters_from_matrix,
    matrix_from_euler_angles,
)

__all__ = ["ManipulatorScene", "joint_sweep", "readout_markdown", "wrap_deg"]

_LINK_COLORS = ((225, 125, 60), (70, 150, 225), (95, 190, 110))
_END_COLOR = (235, 200, 60)
_GHOST_COLOR = (170, 170, 255)
_GHOST_OPACITY = 0.3
_FIXED_AXIS_COLOR = (70, 70, 80)  # the fixed joint axes a1-a3: dark grey, not an axis colour
#: Anchors of the labels a1-a3 (screen-space offsets that keep them apart at the default view).
_LABEL_ANCHORS = ("top-left", "bottom-right", "top-left")
_LINK_RADIUS = 0.05
_INITIAL_DEG = (30.0, 45.0, 60.0)
_READOUT_PERIOD = 0.1  # s: shortest time between readout refreshes (poses go at the loop rate)

#: While "Animate joints" sweeps, the joint sliders are set to the drawn angles this often (s).
_SLIDER_FOLLOW_PERIOD = 0.1
# Joint sweep of "animate joints": amplitude (deg) and frequency (Hz) per joint.
_SWEEP_AMPLITUDE_DEG = (150.0, 70.0, 170.0)
_SWEEP_FREQUENCY_HZ = (0.07, 0.11, 0.17)


def joint_sweep(t: float, start: np.ndarray) -> np.ndarray:
    """Joint angles (3,) in radians of the "animate joints" sweep at time ``t`` (s).

    Each joint swings sinusoidally about its ``start`` angle (3,) in radians
    with its own amplitude and frequency, so the sweep begins exactly where
    the sliders are and passes through general configurations and, now and
    then, the Z-X-Z gimbal lock (joint 2 at 0).
    """
    amplitude = np.radians(_SWEEP_AMPLITUDE_DEG)
    omega = 2.0 * np.pi * np.array(_SWEEP_FREQUENCY_HZ)
    return np.asarray(start, dtype=float) + amplitude * np.sin(omega * t)


def wrap_deg(angle: float) -> float:
    """``angle`` in degrees wrapped to [-180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def _z_to(direction: np.ndarray) -> np.ndarray:
    """4x4 transform turning +Z onto the unit ``direction``."""
    return trimesh.geometry.align_vectors([0.0, 0.0, 1.0], direction)


def _link_mesh(geometry: ManipulatorGeometry, k: int, radius: float) -> trimesh.Trimesh:
    """Link ``k`` (0-based) in its own frame: a rod from the joint to the far end and a
    joint housing along the joint axis (which the joint rotation leaves fixed)."""
    length = float(geometry.link_lengths[k])
    rod = trimesh.creation.cylinder(radius=radius, height=length, sections=24)
    rod.apply_translation([0.0, 0.0, length / 2])
    rod.apply_transform(_z_to(geometry.link_directions[k]))
    housing = trimesh.creation.cylinder(radius=1.7 * radius, height=5.0 * radius, sections=24)
    housing.apply_transform(_z_to(geometry.joint_axes[k]))
    return trimesh.util.concatenate([rod, housing])


def _end_mesh(geometry: ManipulatorGeometry, scale: float = 1.0) -> trimesh.Trimesh:
    """The end object (a two-finger gripper) in the last link's frame, at its far end.

    The fingers lie in the link's x-z plane, so the spin of joint 3 shows."""
    parts = [trimesh.creation.box(extents=(0.26, 0.07, 0.05))]
    parts[0].apply_translation([0.0, 0.0, 0.025])
    for side in (-1.0, 1.0):
        finger = trimesh.creation.box(extents=(0.035, 0.06, 0.16))
        finger.apply_translation([side * 0.11, 0.0, 0.05 + 0.08])
        parts.append(finger)
    mesh = trimesh.util.concatenate(parts)
    mesh.apply_scale(scale)
    mesh.apply_transform(_z_to(geometry.link_directions[2]))
    mesh.apply_translation(geometry.link_vectors[2])
    return mesh


def _format_matrix(matrix: np.ndarray) -> str:
    return "\n".join(" ".join(f"{x:+.4f}" for x in row) for row in matrix)


def _format_deg(angles: np.ndarray) -> str:
    return ", ".join(f"{math.degrees(a):.1f}°" for a in angles)


@dataclasses.dataclass
class _Gui:
    """Handles of the scene's GUI elements (created once in ``build``)."""

    joint_sliders: tuple[Any, Any, Any]
    animate: Any
    show_procedure_b: Any
    steps: Any
    readout: Any  # app.readout.Readout


class ManipulatorScene(Scene):
    """Three-joint manipulator drawn by both procedures of the chapter (Fig. 8.3).

    Parameters
    ----------
    target, notify, context
        As for every scene (see :mod:`rigidlab.app.scenes.base`).
    geometry : ManipulatorGeometry, keyword-only
        Joint axes and links; default Z, X, Z joints.
    readout_period : float, keyword-only
        Shortest time (s) between two rewrites of the text readout.
    """

    name: ClassVar[str] = "manipulator"
    title: ClassVar[str] = "Manipulator (Fig. 8.3)"
    order: ClassVar[int] = 20
    help: ClassVar[str] = (
        "Three links (the chapter's bodies 2-4) turned by joints 1-3 about the axes a1, a2, a3.\n\n"
        "- **Solid links** with their frames: successive relative rotations A = A21 A32 A43, "
        "each about a joint axis fixed in the previous link (Eqs. 8.39-8.42).\n"
        "- **Ghost frames** (long thin axes): Rodriguez rotations (Eq. 8.29) about the joint axes "
        "fixed in the global frame (the dark lines a1, a2, a3), applied joint 3 first "
        "(Eqs. 8.43-8.45). *Rodriguez steps* shows the construction after 0, 1 or 2 of them.\n"
        "- The readout: the end-link matrix, the difference of the two procedures (round-off) and "
        "the Euler-angle form of the result (Z-X-Z for these joints; gimbal lock at joint 2 = 0).\n\n"
        "Frame axes: red x, green y, blue z."
    )
    # The arm stands about 2 m tall on the origin: look at its middle.
    # 3/4 view from above; the look-at point sits right of the arm so the
    # arm appears left of centre, beside the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (1.85, -1.75, 1.55)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.3, 0.25, 0.6)

    def __init__(
        self,
        target: Any,
        notify: Any,
        *,
        context: Any = None,
        geometry: ManipulatorGeometry = DEFAULT_GEOMETRY,
        readout_period: float = _READOUT_PERIOD,
    ) -> None:
        super().__init__(target, notify, context=context)
        self.geometry = geometry
        # State owned by update() (the session loop thread).
        self._time = 0.0
        self._slider_time = 0.0
        self._sweep_start = np.radians(_INITIAL_DEG)
        self._readout_period = float(readout_period)
        self._readout_time = -math.inf
        self._readout_due = False
        self._drawn: tuple[Any, ...] | None = None
        self._was_animating = False
        self._in_gimbal_lock = False
        self._readout_job: Any = None
        self._first = True
        self.joint_angles = np.radians(_INITIAL_DEG)  # (3,) radians, as last drawn
        self.difference = 0.0  # max |A_a - A_b| of the last drawn pose
        self.gui: _Gui | None = None

    # -- build ----------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        geometry = self.geometry
        self.make_root()
        root = self.root
        scene.add_frame(f"{root}/global", axes_length=0.45, axes_radius=0.008)
        self.add_ground_grid(
            width=3.0, height=3.0, position=(0.0, 0.0, -0.061), cell_size=0.1, section_size=0.5
        )
        base = trimesh.creation.cylinder(radius=0.22, height=0.06, sections=40)
        base.apply_translation([0.0, 0.0, -0.03])
        scene.add_mesh_simple(
            f"{root}/base", base.vertices, base.faces, color=(120, 120, 130), flat_shading=False
        )

        # Procedure (a): solid links; each mesh is a child of its link frame, so
        # a frame's pose is all that changes per frame.
        scene.add_frame(f"{root}/a", show_axes=False)
        self.solid_frames = []
        for k in range(3):
            frame = scene.add_frame(f"{root}/a/link{k + 1}", axes_length=0.3, axes_radius=0.012)
            mesh = _link_mesh(geometry, k, _LINK_RADIUS)
            scene.add_mesh_simple(
                f"{root}/a/link{k + 1}/mesh", mesh.vertices, mesh.faces, color=_LINK_COLORS[k]
            )
            self.solid_frames.append(frame)
        end = _end_mesh(geometry)
        scene.add_mesh_simple(f"{root}/a/link3/end", end.vertices, end.faces, color=_END_COLOR)

        # Procedure (b): ghost frames (longer, thinner axes), one batched node so
        # the three poses travel as one message. The translucent ghost links
        # show the construction (fewer than three Rodriguez steps); after all
        # three they would only coincide with the solid links, so they hide.
        self.ghost_root = scene.add_frame(f"{root}/b", show_axes=False)
        self.ghost_axes = scene.add_batched_axes(
            f"{root}/b/frames",
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (3, 1)),
            batched_positions=np.zeros((3, 3)),
            axes_length=0.45,
            axes_radius=0.005,
        )
        self.ghost_links = scene.add_frame(f"{root}/b/links", show_axes=False, visible=False)
        self.ghost_link_frames = []
        for k in range(3):
            frame = scene.add_frame(f"{root}/b/links/link{k + 1}", show_axes=False)
            mesh = _link_mesh(geometry, k, 1.35 * _LINK_RADIUS)
            scene.add_mesh_simple(
                f"{root}/b/links/link{k + 1}/mesh",
                mesh.vertices,
                mesh.faces,
                color=_GHOST_COLOR,
                opacity=_GHOST_OPACITY,
            )
            self.ghost_link_frames.append(frame)
        ghost_end = _end_mesh(geometry, scale=1.12)
        scene.add_mesh_simple(
            f"{root}/b/links/link3/end",
            ghost_end.vertices,
            ghost_end.faces,
            color=_GHOST_COLOR,
            opacity=_GHOST_OPACITY,
        )

        # The joint axes fixed in the global frame used by procedure (b): lines
        # through the joint centres of the zero configuration, in one dark
        # colour so they never read as the red/green/blue axes of a frame.
        zero = link_frames_global_axis_rotations(np.zeros(3), geometry=geometry, steps=0)
        half = 0.8
        points = np.stack(
            [
                np.stack([c - half * a, c + half * a])
                for c, a in zip(zero.origins, geometry.joint_axes)
            ]
        ).astype(np.float32)
        self.global_axes = scene.add_frame(f"{root}/global_axes", show_axes=False)
        self.add_lines(f"{root}/global_axes/lines", points, _FIXED_AXIS_COLOR, thickness=0.006)
        for k in range(3):
            # Joint 1's label goes to the lower end, clear of the arm.
            end = 0 if k == 0 else 1
            self.add_label(
                f"{root}/global_axes/a{k + 1}",
                f"a{k + 1} (fixed)",
                position=points[k, end],
                anchor=_LABEL_ANCHORS[k],
            )

        with self.make_folder():
            self.add_readout(
                "**Solid**: successive rotations A = A21 A32 A43 (Eqs. 8.39-8.42). "
                "**Ghost**: Rodriguez rotations about the fixed joint axes a1-a3 (dark lines), "
                "joint 3 first (Eqs. 8.43-8.45). Frame axes: red x, green y, blue z."
            )
            sliders = tuple(
                self.controls.add(Slider(
                    f"theta{k + 1}",
                    f"θ{k + 1} (deg)",
                    min=-180.0,
                    max=180.0,
                    step=0.1,
                    default=_INITIAL_DEG[k],
                    hint=f"Joint {k + 1} angle about axis a{k + 1} = {geometry.joint_axes[k].tolist()}",
                ))
                for k in range(3)
            )
            animate = self.controls.add(Toggle("animate", "Animate joints", hint="Sweep the three joints smoothly"))
            show_global = self.controls.add(Toggle(
                "show_b", "Show procedure (b)", default=True,
                hint="Ghost links, ghost frames and the fixed global joint axes",
            ))
            steps = self.controls.add(Slider(
                "steps", "Rodriguez steps", min=0, max=3, step=1, default=3, integer=True,
                hint="How many global-axis rotations of procedure (b) are applied (joint 3 first)",
            ))
            readout = self.add_readout("")
        self.gui = _Gui(sliders, animate, show_global, steps, readout)  # type: ignore[arg-type]

    # -- update ---------------------------------------------------------------
    def update(self, dt: float) -> None:
        now = time.monotonic()
        self._collect_readout()
        changed = self.controls.take_changes()
        values = self.controls.values()
        animate = bool(values["animate"])
        if not (changed or animate or self._first):
            if self._readout_due and now - self._readout_time >= self._readout_period:
                self._refresh_readout(now)
            return
        self._first = False
        joint_deg = tuple(float(values[f"theta{k + 1}"]) for k in range(3))
        show_global = bool(values["show_b"])
        steps = int(values["steps"])
        assert self.gui is not None

        if animate:
            if not self._was_animating:
                # The sweep starts where the sliders are; they are disabled meanwhile.
                self._time = 0.0
                self._sweep_start = np.radians(joint_deg)
                for slider in self.gui.joint_sliders:
                    slider.disabled = True
            self._time += dt
            angles = joint_sweep(self._time, self._sweep_start)
            self._slider_time += dt
            if self._slider_time >= _SLIDER_FOLLOW_PERIOD:
                # the (disabled) sliders follow the sweep, a few times a second: they show the angles drawn
                self._slider_time = 0.0
                self.controls.set_many({f"theta{k + 1}": round(wrap_deg(math.degrees(a)), 1)
                                        for k, a in enumerate(angles)})
        else:
            if self._was_animating:
                for slider in self.gui.joint_sliders:
                    slider.disabled = False
                # Leave the arm where the sweep stopped: the sliders take over.
                stopped_deg = [round(wrap_deg(math.degrees(a)), 1) for a in self.joint_angles]
                self.controls.set_many({f"theta{k + 1}": v for k, v in enumerate(stopped_deg)})
                joint_deg = tuple(stopped_deg)
            angles = np.radians(joint_deg)
        self._was_animating = animate

        geometry = self.geometry
        frames_a = link_frames_successive(angles, geometry=geometry)
        frames_b = link_frames_global_axis_rotations(angles, geometry=geometry)
        ghost = (
            frames_b
            if steps == 3
            else link_frames_global_axis_rotations(angles, geometry=geometry, steps=steps)
        )
        # one-rotation calls take core.rotations' scalar path (cheaper than a batch of three)
        wxyz_a = [euler_parameters_from_matrix(m) for m in frames_a.orientations]
        wxyz_ghost = np.array([euler_parameters_from_matrix(m) for m in ghost.orientations])
        self.joint_angles = angles
        self.difference = float(
            np.max(np.abs(frames_a.orientations[2] - frames_b.orientations[2]))
        )
        self._drawn = (angles, frames_a, frames_b, steps)
        self._readout_due = True

        with self.target.atomic():
            for k in range(3):
                set_pose(self.solid_frames[k], wxyz=wxyz_a[k], position=frames_a.origins[k])
            self.ghost_root.visible = show_global
            self.global_axes.visible = show_global
            if show_global:
                set_arrays(self.ghost_axes, batched_wxyzs=wxyz_ghost, batched_positions=ghost.origins)
                self.ghost_links.visible = steps < 3
                if steps < 3:
                    for k in range(3):
                        set_pose(self.ghost_link_frames[k], wxyz=wxyz_ghost[k], position=ghost.origins[k])
            if now - self._readout_time >= self._readout_period:
                self._refresh_readout(now)

    def _refresh_readout(self, now: float) -> None:
        """Ask for the readout of the last drawn pose (at most every readout period).

        The text is built by :func:`readout_markdown` on the background
        executor, off the loop thread; :meth:`_collect_readout` shows it when
        it is ready.
        """
        assert self.gui is not None and self._drawn is not None
        if self._readout_job is not None:
            return  # one at a time: the next one starts when this one is shown
        angles, frames_a, frames_b, steps = self._drawn
        self._readout_job = self.executor.submit(
            readout_markdown, angles, frames_a, frames_b, steps, self.difference, self.geometry
        )
        self._readout_time = now
        self._readout_due = False

    def _collect_readout(self) -> None:
        """Show a finished readout and say when the arm enters gimbal lock."""
        job = self._readout_job
        if job is None or not job.done():
            return
        self._readout_job = None
        assert self.gui is not None
        text, seq, singular = job.result()
        self.gui.readout.content = text
        if singular and not self._in_gimbal_lock:
            self.notify(
                "Gimbal lock",
                f"Joints 1 and 3 are aligned: the {seq} angles of A are not unique.",
                "info",
            )
        self._in_gimbal_lock = singular

    @property
    def readout_pending(self) -> bool:
        """Whether a readout is being computed or waits for its period."""
        return self._readout_job is not None or self._readout_due


def readout_markdown(
    angles: np.ndarray, frames_a: Any, frames_b: Any, steps: int, difference: float,
    geometry: ManipulatorGeometry,
) -> tuple[str, str, bool]:
    """Markdown readout of one pose: the matrix, the difference of the procedures,
    the Euler form; also the Euler sequence and whether it is at gimbal lock.

    A pure function of picklable arguments: it runs on the app's executor.
    """
    matrix = frames_a.orientations[2]
    position_difference = max(
        float(np.max(np.abs(frames_a.origins - frames_b.origins))),
        float(np.max(np.abs(frames_a.end_point - frames_b.end_point))),
    )
    lines = [
        f"**Joint angles**: {_format_deg(angles)}",
        "",
        "**End link** A = A21 A32 A43 (successive rotations, Eq. 8.42):",
        "```",
        _format_matrix(matrix),
        "```",
        "**Procedures (a) vs (b)** (all three Rodriguez steps):",
        "",
        f"- max |A_a − A_b| = {difference:.1e}",
        f"- max |r_a − r_b| = {position_difference:.1e} m",
    ]
    if steps < 3:
        lines.append(f"- Ghost shows (b) after {steps} of 3 steps (joint 3 first).")
    try:
        form = euler_form(angles, geometry=geometry)
    except ValueError as exc:
        lines += ["", f"**Euler-angle form**: none for these joint axes ({exc})."]
        return "\n".join(lines), "", False
    euler_matrix = matrix_from_euler_angles(form.angles, form.seq)
    lines += [
        "",
        f"**Euler-angle form** ({form.seq}, intrinsic):",
        "",
        f"- A = A_{form.seq}({_format_deg(form.angles)})",
        f"- max |A − A_{form.seq}| = {float(np.max(np.abs(matrix - euler_matrix))):.1e}",
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        recovered = euler_angles_from_matrix(matrix, form.seq)
    singular = bool(caught)
    lines.append(f"- Euler angles recovered from A: {_format_deg(recovered)}")
    if singular:
        lines.append(
            "- **gimbal lock**: the first and third axes align, only the sum "
            "(or difference) of their angles is determined."
        )
    return "\n".join(lines), form.seq, singular
