"""Drawing a disk cam and its translating follower: :class:`CamMechanism`, a drawing component as
:class:`rigidlab.app.scenes._bodies.CoilSpring` is, and its :class:`CamLayout`.

The mechanism is drawn from core's :class:`rigidlab.core.models.CamFollower` as it is: the cam's contour is
core's ``cam_curve`` (the envelope of the flat face's positions, or the inner offset of the roller centre's
path), extruded; the follower (flat face, or fork and roller: :func:`rigidlab.app.meshes.translating_follower`)
slides in a stand (:func:`rigidlab.app.meshes.follower_stand`) under a coil spring; the contact point, the
common normal and the contact force ``N n`` lie in front of the cam, and the separation interval (where the
closed form's ``N < 0``) is drawn on its front face.

Frames (global, metres): the cam shaft is the global y axis, the profile plane is the x-z plane (profile x ->
global x, profile y -> global z, as in :meth:`rigidlab.core.models.CamFollower.build_system`), the follower
slides along +z above the shaft; the cam turns about -y by the cam angle theta (theta = 0: lowest lift).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import trimesh

from rigidlab.app.meshes import box, cylinder_z, extrude, follower_stand, pack, translating_follower
from rigidlab.app.nodes import set_array, set_arrays, set_pose, set_visible, wxyz_z_to
from rigidlab.app.scenes._arrows import vertex_rgb
from rigidlab.app.scenes._bodies import CoilSpring, ForceArrow
from rigidlab.app.scenes._shapes import closed_path_segments
from rigidlab.core.models import CamFollower

__all__ = ["CONTOUR_POINTS", "CamLayout", "CamMechanism", "LEGEND", "cam_layout"]

#: Points of the cam's drawn contour (every 0.5 deg of the contour's parameter).
CONTOUR_POINTS = 720
# drawing (m): the cam is 12 mm thick, the contact marks lie in front of it (y = _Y_FRONT); the spring is never
# drawn shorter than _SPRING_MIN_LENGTH on the cam
_CAM_THICKNESS, _Y_FRONT, _SPRING_MIN_LENGTH, _ARM, _BASE_Z = 0.012, -0.012, 0.045, 0.008, -0.085
_ARROW_MAX, _ARROW_HALF, _NORMAL_HALF = 0.045, 40.0, 0.03  # m, N, m
_CAM_COLOR, _HUB_COLOR, _FOLLOWER_COLOR = (150, 156, 172), (70, 72, 84), (196, 160, 84)
_ROLLER_COLOR, _STAND_COLOR, _SPRING_COLOR = (96, 100, 114), (188, 190, 198), (60, 60, 72)
_FORCE_COLOR, _PULL_COLOR, _NORMAL_COLOR, _POINT_COLOR = (245, 140, 0), (150, 60, 200), (0, 160, 150), (30, 30, 40)
#: The colour key of what is drawn on the cam (:meth:`rigidlab.app.scenes._simulation.SimulationScene.add_legend`).
LEGEND = ((_FORCE_COLOR, "N n: force of the cam on the follower (N > 0)"),
          (_PULL_COLOR, "N < 0: the contact would have to pull (separation interval)"),
          (_NORMAL_COLOR, "common normal at the contact point (hidden in flight)"),
          (_POINT_COLOR, "contact point (in flight: the cam's point nearest the follower)"))


@dataclasses.dataclass(frozen=True)
class CamLayout:
    """What is drawn of a cam and follower: meshes ``(vertices, faces)``, the cam's in its body frame (profile =
    body x-y), the follower's in its frame (:func:`rigidlab.app.meshes.translating_follower`), the stand's global;
    metres."""

    cam_model: CamFollower  # the shape drawn (its loads aside)
    contour: np.ndarray  # (CONTOUR_POINTS, 2) the cam's contour (core's cam_curve), body frame
    cam: tuple
    follower: tuple
    roller: tuple | None
    stand: tuple
    pitch_height: float  # global z of the follower's origin at zero lift
    seat: float  # the spring's seat above the follower's origin
    spring_top: float  # global z
    stem_top: float  # global z at zero lift
    spring_length: float  # the spring's length in the middle of its travel (its mesh is built at it)


@functools.lru_cache(maxsize=32)
def cam_layout(cam: CamFollower) -> CamLayout:
    """The :class:`CamLayout` of core's ``cam`` (its shape: profile, follower, roller; give every shape with the
    same loads, so that one shape is one layout)."""
    u = np.arange(CONTOUR_POINTS) * (2.0 * math.pi / CONTOUR_POINTS)
    contour, kin, pitch = np.asarray(cam.cam_curve(u).point), cam.kinematics(u), float(cam.pitch_curve(0.0).point[1])
    top = float(np.max(kin.lift))
    travel = top + _SPRING_MIN_LENGTH + _ARM + 0.015  # the stem's length above the spring's seat
    follower, roller, seat = translating_follower(  # a flat face reaches past the farthest contact point, |s'|
        travel=travel, face_halfwidth=float(np.max(np.abs(kin.dlift))) + 0.008, roller_radius=cam.roller_radius)
    spring_top = pitch + top + seat + _SPRING_MIN_LENGTH
    return CamLayout(cam, contour.astype(np.float32), pack(extrude(contour, -_CAM_THICKNESS / 2, _CAM_THICKNESS / 2)),
                     follower, roller, follower_stand(spring_top, base=_BASE_Z, arm=_ARM), pitch, seat, spring_top,
                     pitch + seat + travel, 0.5 * (top + 2.0 * _SPRING_MIN_LENGTH))


class CamMechanism:
    """The nodes of a cam and follower under ``{name}``, created once: the stand on a ground grid, the cam on
    its shaft (and the separation interval on its front face), the follower (flat face, or fork and roller),
    the coil spring, the contact point with the common normal and the force arrow, and 3-D labels.
    :meth:`use` swaps in another cam's meshes; :meth:`pose` draws one instant (inside ``target.atomic()``).

    Parameters
    ----------
    scene : app.scenes.base.Scene
        The scene drawing it (its labels, lines and arrows grow in presenter view).
    name : str
        Path of the mechanism's nodes (the scene's root).
    flat, roller : CamLayout
        Layouts of a flat-faced and a roller follower: the nodes start with their meshes, the flat one shown.
    """

    def __init__(self, scene: Any, name: str, flat: CamLayout, roller: CamLayout) -> None:
        add = scene.target.scene
        self.layout, self.follower_z = flat, flat.pitch_height
        scene.add_ground_grid(width=0.6, height=0.4, position=(0.0, 0.0, _BASE_Z - 0.0081), cell_size=0.01,
                              section_size=0.05)
        self.stand = add.add_mesh_simple(f"{name}/stand", *flat.stand, color=_STAND_COLOR)
        add.add_frame(f"{name}/cam_plane", show_axes=False, wxyz=(math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0))
        self.cam_frame = add.add_frame(f"{name}/cam_plane/cam", show_axes=False)
        self.cam_mesh = add.add_mesh_simple(f"{name}/cam_plane/cam/body", *flat.cam, color=_CAM_COLOR)
        hub = trimesh.util.concatenate([cylinder_z(0.006, -0.022, _CAM_THICKNESS / 2 + 0.004),  # shaft, index stripe
                                        box((-0.0015, 0.008, _CAM_THICKNESS / 2), (0.0015, 0.028, 0.0068))])
        add.add_mesh_simple(f"{name}/cam_plane/cam/hub", *pack(hub), color=_HUB_COLOR)
        self.separation_arc = scene.add_lines(f"{name}/cam_plane/cam/separation", np.zeros((CONTOUR_POINTS, 2, 3)),
                                              vertex_rgb(np.full((CONTOUR_POINTS, 2, 3), _PULL_COLOR)), thickness=5.0,
                                              thickness_units="screen", visible=False)
        self.follower_frame = add.add_frame(f"{name}/follower", show_axes=False, position=(0, 0, flat.pitch_height))
        self.follower_meshes = {"flat": add.add_mesh_simple(f"{name}/follower/flat", *flat.follower,
                                                            color=_FOLLOWER_COLOR),
                                "roller": add.add_mesh_simple(f"{name}/follower/fork", *roller.follower,
                                                              color=_FOLLOWER_COLOR, visible=False)}
        self.roller_mesh = add.add_mesh_simple(f"{name}/follower/roller", *roller.roller, color=_ROLLER_COLOR,
                                               visible=False)
        self.spring = CoilSpring(scene, f"{name}/spring", radius=0.011, turns=7, wire=0.0011, color=_SPRING_COLOR,
                                 length=flat.spring_length)
        self.contact_frame = add.add_frame(f"{name}/contact", show_axes=False)
        # at the contact point, +z along the common normal: one pose moves the dot, the normal and the arrow
        self.contact_point = add.add_frame(f"{name}/contact/point", show_axes=False)
        add.add_icosphere(f"{name}/contact/point/dot", radius=0.0026, color=_POINT_COLOR, subdivisions=2)
        self.normal_line = scene.add_lines(f"{name}/contact/point/normal", [[(0, 0, -_NORMAL_HALF),
                                           (0, 0, _NORMAL_HALF)]], vertex_rgb([[_NORMAL_COLOR] * 2]), thickness=2.5,
                                           thickness_units="screen")
        self.force_arrow = ForceArrow(scene, f"{name}/contact/point/force", _FORCE_COLOR, tip_at_point=True,
                                      sizes={"shaft_radius": 0.0016, "head_radius": 0.004, "head_length": 0.008})
        self.force_label = scene.add_label(f"{name}/contact/label", "N", anchor="top-right", scale=1.3)
        self.labels = {key: scene.add_label(f"{name}/label_{key}", text, position=(x, _Y_FRONT, z), anchor=anchor,
                                            scale=1.3) for key, text, x, z, anchor in (
            ("cam", "cam (turns at ω)", -0.048, -0.03, "center-right"),
            ("follower", "follower", 0.008, flat.stem_top - 0.004, "center-left"),
            ("spring", "spring k, F0", 0.016, flat.spring_top - 0.02, "center-left"))}

    @property
    def travel_limit(self) -> float:
        """The largest lift (m) the stand allows: the drawn spring is solid there."""
        return self.layout.spring_top - self.layout.pitch_height - self.layout.seat - self.spring.solid

    def use(self, layout: CamLayout, separated: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        """Draw the cam and follower of ``layout`` from now on (meshes sent when the shape changed), the
        separation interval on the cam's front face where ``separated(u)`` (a revolution's
        :meth:`rigidlab.core.models.CamRevolution.separated`) marks the contour's cam angles ``u`` (None: none)."""
        if layout.cam_model != self.layout.cam_model:
            self.layout, kind = layout, "flat" if layout.roller is None else "roller"
            self.spring.rebuild(layout.spring_length)
            for node, mesh in ((self.cam_mesh, layout.cam), (self.stand, layout.stand),
                               (self.follower_meshes[kind], layout.follower), (self.roller_mesh, layout.roller)):
                if mesh is not None:
                    set_arrays(node, vertices=mesh[0], faces=mesh[1])
            for key, handle in (*self.follower_meshes.items(), ("roller", self.roller_mesh)):
                handle.visible = key == kind
            set_pose(self.labels["follower"], position=(0.008, _Y_FRONT, layout.stem_top - 0.004))
            set_pose(self.labels["spring"], position=(0.016, _Y_FRONT, layout.spring_top - 0.02))
        u = np.arange(CONTOUR_POINTS) * (2.0 * math.pi / CONTOUR_POINTS)
        front = np.column_stack([layout.contour, np.full(CONTOUR_POINTS, _CAM_THICKNESS / 2 + 0.0006)])
        arc = None if separated is None else closed_path_segments(front, separated(u))  # (body frame)
        if arc is not None:
            set_array(self.separation_arc, "points", arc)
        self.separation_arc.visible = arc is not None

    def pose(self, theta: float, lift: float, contact: np.ndarray, normal: np.ndarray, force: float, *,
             in_contact: bool, show_contact: bool) -> None:
        """Draw the cam at angle ``theta`` (rad), the follower at ``lift`` (m) and, with ``show_contact``, the
        ``contact`` point and unit ``normal`` (2,) (x, z: global, in the profile plane; from the cam to the
        follower) with the force of the cam on the follower ``force n`` (N; purple when ``force < 0``, gone in
        flight: not ``in_contact``). Inside ``target.atomic()``."""
        self.follower_z = self.layout.pitch_height + lift
        set_pose(self.cam_frame, wxyz=(math.cos(0.5 * theta), 0.0, 0.0, math.sin(0.5 * theta)))
        set_pose(self.follower_frame, position=(0.0, 0.0, self.follower_z))
        self.spring.span(self.follower_z + self.layout.seat, self.layout.spring_top)
        set_visible(self.contact_frame, show_contact)
        if not show_contact:
            return
        (x, z), (nx, nz) = (float(v) for v in contact), (float(v) for v in normal)
        set_pose(self.contact_point, position=(x, _Y_FRONT, z), wxyz=wxyz_z_to((nx, 0.0, nz), 1.0))
        set_visible(self.normal_line, in_contact)  # in flight there is no contact normal
        drawn = in_contact and force != 0.0  # (N n ends at the contact point)
        set_visible(self.force_label, drawn)
        self.force_arrow.show((0.0, 0.0, force) if drawn else None, scale=_ARROW_MAX, reference=_ARROW_HALF,
                              color=_FORCE_COLOR if force >= 0.0 else _PULL_COLOR)
        if drawn:
            tail = math.copysign(self.force_arrow.length, force)  # the label at the arrow's tail
            set_pose(self.force_label, position=(x - tail * nx, _Y_FRONT, z - tail * nz))
