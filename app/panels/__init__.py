"""Reusable panels for scenes about rotations.

A panel is a small class that a scene composes: ``build(scene)`` creates its
controls (through ``scene.controls.add``, so every value passes the gate),
its readouts and its 3-D nodes (through the scene's presenter-aware
``add_label`` / ``add_arrows`` / ``add_lines``); small ``read`` / ``show``
methods turn control values into core inputs and core results into node
poses and text. Panels hold no physics: the rotation math is
:mod:`rigidlab.core.rotations`, reached through the pure adapters of
:mod:`rigidlab.app.panels._views`.

* :class:`~rigidlab.app.panels.orientation.OrientationInput`: Euler angles (24 sequences),
  axis and angle, Euler parameters, Rodriguez parameters, rotation vector;
* :class:`~rigidlab.app.panels.gimbal.Gimbal`: three nested rings and the cond(G) lock gauge;
* :class:`~rigidlab.app.panels.compose.ComposePanel`: q1, q2, both products, Eq. 8.82;
* :class:`~rigidlab.app.panels.angular_velocity.AngularVelocityPanel`: omega -> rates of
  every representation, constant-omega animation;
* :class:`~rigidlab.app.panels.export.ExportPanel`: JSON with convention notes;
* :mod:`rigidlab.app.panels.body`: the body, the global axes, the rotation-axis arrow.
"""

from rigidlab.app.panels._views import (
    SEQUENCE_LABELS,
    SEQUENCES,
    ComposeViews,
    GimbalConditioning,
    GimbalLayout,
    GimbalPose,
    OrientationViews,
    RateViews,
    angle_labels,
    angle_names,
    compose_views,
    export_document,
    gimbal_conditioning,
    gimbal_layout,
    gimbal_pose,
    orientation_views,
    rate_names,
    rate_views,
    ring_rotations,
)
from rigidlab.app.panels.angular_velocity import AngularVelocityPanel
from rigidlab.app.panels.body import BodyView, GlobalAxes, RotationAxisView
from rigidlab.app.panels.compose import ComposePanel
from rigidlab.app.panels.export import ExportPanel
from rigidlab.app.panels.gimbal import Gimbal
from rigidlab.app.panels.orientation import INPUTS, InputReading, OrientationInput

__all__ = [
    "AngularVelocityPanel",
    "BodyView",
    "ComposePanel",
    "ComposeViews",
    "ExportPanel",
    "Gimbal",
    "GimbalConditioning",
    "GimbalLayout",
    "GimbalPose",
    "GlobalAxes",
    "INPUTS",
    "InputReading",
    "OrientationInput",
    "OrientationViews",
    "RateViews",
    "RotationAxisView",
    "SEQUENCES",
    "SEQUENCE_LABELS",
    "angle_labels",
    "angle_names",
    "compose_views",
    "export_document",
    "gimbal_conditioning",
    "gimbal_layout",
    "gimbal_pose",
    "orientation_views",
    "rate_names",
    "rate_views",
    "ring_rotations",
]
