"""Rotation sandbox (first cut: a body turned about the global Z axis)."""

from __future__ import annotations

import math
from typing import Any, ClassVar

from app.scenes.base import Scene


class SandboxScene(Scene):
    """A body with its axes, turned by one slider about global Z."""

    name: ClassVar[str] = "sandbox"
    title: ClassVar[str] = "Rotation sandbox"
    order: ClassVar[int] = 10

    def __init__(self, target: Any, notify: Any) -> None:
        super().__init__(target, notify)
        self._angle = 0.0
        self._dirty = True

    def build(self) -> None:
        self.make_root()
        scene = self.target.scene
        scene.add_frame(f"{self.root}/global", axes_length=1.2, axes_radius=0.01)
        self.body = scene.add_frame(f"{self.root}/body", axes_length=0.8, axes_radius=0.02)
        scene.add_box(f"{self.root}/body/box", dimensions=(0.6, 0.4, 0.2), color=(90, 140, 220))
        with self.make_folder():
            self.slider = self.target.gui.add_slider(
                "psi (deg)", min=-180.0, max=180.0, step=1.0, initial_value=0.0
            )
        self.slider.on_update(self._on_slider)

    def _on_slider(self, event: Any) -> None:
        with self.lock:
            self._angle = math.radians(float(event.target.value))
            self._dirty = True

    def update(self, dt: float) -> None:
        with self.lock:
            if not self._dirty:
                return
            angle, self._dirty = self._angle, False
        with self.target.atomic():
            self.body.wxyz = (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))
