"""3-D pieces that show one orientation: the body, the global frame, the rotation axis.

Each piece is a small class: ``build(scene)`` creates its nodes once under
``scene.root`` (labels, arrows and lines through the scene's presenter-aware
helpers), ``show(...)`` assigns a pose, the only thing that changes per
frame. Colours: red, green and blue belong to frame axes (x, y, z); arrows
and rotation axes use other colours (see :data:`ROTATION_AXIS_COLOR`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import rigidlab.core.rotations as rot
from rigidlab.app import meshes
from rigidlab.app.nodes import set_array, set_pose
from rigidlab.app.panels._views import wxyz_z_to

__all__ = [
    "BodyView",
    "GlobalAxes",
    "RotationAxisView",
    "add_body_meshes",
    "LABEL_SCALE",
    "X_COLOR",
    "Z_COLOR",
    "HULL_COLOR",
    "ROTATION_AXIS_COLOR",
]

#: Normal-view size of the 3-D labels (presenter view multiplies it).
LABEL_SCALE = 1.3
X_COLOR, Z_COLOR = (214, 56, 56), (48, 96, 214)
HULL_COLOR = (176, 190, 214)
#: The rotation axis (and its angle arc): dark gold, never a frame-axis colour.
ROTATION_AXIS_COLOR = (196, 140, 0)
#: Offset (m) of the global Z label from the end of its line.
_Z_LABEL_SHIFT = np.array([0.0, 0.08, -0.06])
#: Global axes: thin, pale red / green / blue lines.
_GLOBAL_AXIS_COLORS = ((236, 128, 128), (120, 200, 140), (130, 160, 236))
#: The angle arc: radius (m) about the axis and height as a fraction of the arrow.
_ARC_RADIUS = 0.26
_ARC_HEIGHT = 0.8
#: No rotation axis is drawn below this angle (rad): it is undefined at the identity.
_MIN_AXIS_ANGLE = math.radians(0.05)


def add_body_meshes(
    scene_api: Any, parent: str, length: float, *, opacity: float | None = None,
    color: tuple[int, int, int] = HULL_COLOR,
) -> None:
    """Hull, red nose (+x_b) and blue fin (+z_b) under node ``parent`` (see :func:`rigidlab.app.meshes.body_parts`)."""
    colors = {"hull": color, "nose": X_COLOR, "fin": Z_COLOR}
    for part, (vertices, faces) in meshes.body_parts(length).items():
        scene_api.add_mesh_simple(
            f"{parent}/{part}", vertices, faces, color=colors[part], opacity=opacity,
            flat_shading=part != "nose",
        )


class BodyView:
    """A body with its frame axes (and, optionally, labelled ``x_b, y_b, z_b``).

    Parameters
    ----------
    name : node name under the scene root
    length : hull length (m)
    axes_length, axes_radius : body frame axes (m)
    labels : whether to label the body axes
    color, opacity : hull colour and opacity (None: opaque)
    position : (3,) origin of the body in the global frame (m)
    """

    def __init__(
        self, name: str = "body", *, length: float = 1.0, axes_length: float = 0.95,
        axes_radius: float = 0.022, labels: bool = True, color: tuple[int, int, int] = HULL_COLOR,
        opacity: float | None = None, position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.name = name
        self.length = length
        self.axes_length = axes_length
        self.axes_radius = axes_radius
        self.labels = labels
        self.color = color
        self.opacity = opacity
        self.position = position
        self.frame: Any = None
        self.label_handles: list[Any] = []

    def build(self, scene: Any, p: np.ndarray) -> None:
        """Create the nodes under ``scene.root``, oriented by Euler parameters ``p``.

        The body's frame is the node ``{root}/{name}`` itself (its ``wxyz`` is
        the orientation shown), with the meshes and axis labels as children.
        """
        api = scene.target.scene
        path = f"{scene.root}/{self.name}"
        self.frame = api.add_frame(
            path, axes_length=self.axes_length, axes_radius=self.axes_radius, wxyz=p, position=self.position,
        )
        add_body_meshes(api, path, self.length, opacity=self.opacity, color=self.color)
        if self.labels:
            reach = self.axes_length + 0.13
            for text, vec in (("x_b", (reach, 0, 0)), ("y_b", (0, reach, 0)), ("z_b", (0, 0, reach))):
                self.label_handles.append(
                    scene.add_label(f"{path}/label_{text}", text, position=vec, scale=LABEL_SCALE)
                )

    @property
    def visible(self) -> bool:
        return bool(self.frame.visible)

    @visible.setter
    def visible(self, on: bool) -> None:
        self.frame.visible = bool(on)

    @property
    def wxyz(self) -> np.ndarray:
        return np.asarray(self.frame.wxyz)

    def show(self, p: np.ndarray) -> None:
        """Orient the body by unit Euler parameters ``p`` (scalar first)."""
        set_pose(self.frame, wxyz=p)


class GlobalAxes:
    """The fixed global frame: thin pale X, Y, Z lines from the origin, labelled at their ends."""

    def __init__(self, name: str = "global_axes", *, length: float = 1.5, label_reach: float = 1.65) -> None:
        self.name = name
        self.length = length
        self.label_reach = label_reach
        self.label_handles: list[Any] = []

    def build(self, scene: Any) -> None:
        path = f"{scene.root}/{self.name}"
        ends = self.length * np.eye(3)
        points = np.stack([np.zeros((3, 3)), ends], axis=1)
        colors = np.repeat(np.array(_GLOBAL_AXIS_COLORS, dtype=np.uint8)[:, None, :], 2, axis=1)
        scene.add_lines(f"{path}/lines", points, colors, thickness=2.5, thickness_units="screen")
        # Z is labelled beside its line, towards +Y (to the right in the
        # scenes' views): a rotation axis near Z has its own label at its
        # tip, up and to the left, and the two stay apart.
        for k, text in enumerate("XYZ"):
            position = self.label_reach * np.eye(3)[k]
            if k == 2:
                position = position + _Z_LABEL_SHIFT
            self.label_handles.append(scene.add_label(
                f"{path}/{text}", text, position=position, scale=LABEL_SCALE,
                anchor="bottom-left" if k == 2 else "center-center",
            ))


class RotationAxisView:
    """The rotation axis of an orientation: an arrow, an arc for the angle and a label.

    The arrow is built along +z of its frame; :meth:`show` turns the frame
    onto the axis (per frame, cheap) and :meth:`show_text` redraws the arc
    and the label (at the readout rate). Hidden for the identity, where the
    axis is undefined.
    """

    def __init__(self, name: str = "rotation_axis", *, length: float = 1.6,
                 color: tuple[int, int, int] = ROTATION_AXIS_COLOR) -> None:
        self.name = name
        self.length = length
        self.color = color
        self.angle = 0.0
        self.enabled = True
        self._has_axis = False
        self._p: np.ndarray | None = None  # the orientation last shown (or to show when enabled)

    def build(self, scene: Any) -> None:
        api = scene.target.scene
        path = f"{scene.root}/{self.name}"
        self.frame = api.add_frame(path, show_axes=False)
        self.arrow = scene.add_arrows(
            f"{path}/arrow", np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, self.length]]]), self.color,
            shaft_radius=0.016, head_radius=0.05, head_length=0.12,
        )
        self.arc = scene.add_lines(
            f"{path}/arc", self._arc_points(0.0), self.color, thickness=3.0, thickness_units="screen",
        )
        self.label = scene.add_label(
            f"{path}/label", "rotation axis", position=(0.0, 0.0, self.length + 0.05),
            anchor="bottom-right", scale=LABEL_SCALE,
        )

    def _arc_points(self, angle: float, n: int = 24) -> np.ndarray:
        """Segments of an arc of ``angle`` (rad) about +z near the arrow's tip."""
        radius, height = _ARC_RADIUS, _ARC_HEIGHT * self.length
        t = np.linspace(0.0, angle, n + 1)
        pts = np.stack([radius * np.cos(t), radius * np.sin(t), np.full_like(t, height)], axis=-1)
        return np.stack([pts[:-1], pts[1:]], axis=1).astype(np.float32)

    def set_enabled(self, on: bool) -> None:
        """Show the axis (when it exists) or hide it whatever the orientation."""
        self.enabled = bool(on)
        if self.enabled and self._p is not None:
            self.show(self._p)
        self.frame.visible = self.enabled and self._has_axis

    def show(self, p: np.ndarray) -> None:
        """Point the arrow along the rotation axis of unit Euler parameters ``p`` (Eq. 8.46).

        While disabled only ``p`` is kept (nothing is computed or sent).
        """
        self._p = p
        if not self.enabled:
            return
        axis, angle = rot.axis_angle_from_euler_parameters(p)
        self.angle = float(angle)
        self._has_axis = self.angle > _MIN_AXIS_ANGLE
        self.frame.visible = self.enabled and self._has_axis
        if self._has_axis:
            set_pose(self.frame, wxyz=wxyz_z_to(np.asarray(axis, dtype=float)))

    def show_text(self) -> None:
        """Arc and label for the angle of the last :meth:`show`."""
        self.show_arc()
        self.show_label()

    def show_arc(self) -> None:
        """The arc of the angle of the last :meth:`show`."""
        if self._has_axis:
            set_array(self.arc, "points", self._arc_points(self.angle))

    def show_label(self) -> None:
        """The label of the angle of the last :meth:`show`."""
        if self._has_axis:
            self.label.text = f"rotation axis\n{math.degrees(self.angle):.1f}\u00b0"
