"""Helpers of the scene base class (app/scenes/base.py): a legend that follows presenter view, arrows shown
and hidden with only the changes sent."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from rigidlab.app.readout import PRESENTER_FONT_SCALE
from rigidlab.app.scenes.base import Scene


class _Plain(Scene):
    name: ClassVar[str] = "plain"
    title: ClassVar[str] = "Plain"

    def build(self) -> None:
        self.make_root()
        with self.make_folder():
            self.legend = self.add_legend((((225, 80, 0), "a force"),), "Colours:")
        self.label = self.add_label(f"{self.root}/label", "a label", visible=False)
        self.arrows = self.add_arrows(f"{self.root}/arrows", np.zeros((1, 2, 3)), (225, 80, 0), shaft_radius=0.01,
                                      head_radius=0.03, head_length=0.05, visible=False)

    def update(self, dt: float) -> None:
        pass


def test_a_legend_grows_in_presenter_view_and_shrinks_back(make_bare_scene: Any) -> None:
    scene, _ = make_bare_scene(_Plain)
    assert "0.875em" in scene.legend.handle.content and "a force" in scene.legend.handle.content
    scene.set_presenter(True)
    assert f"{PRESENTER_FONT_SCALE:.2f}em" in scene.legend.handle.content
    scene.set_presenter(False)
    assert "0.875em" in scene.legend.handle.content


def test_set_arrows_shows_moves_and_hides_them(make_bare_scene: Any) -> None:
    scene, _ = make_bare_scene(_Plain)
    points = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0], [1.0, 0.5, 0.0]]])
    scene.set_arrows(scene.arrows, points)
    assert scene.arrows.visible
    np.testing.assert_allclose(np.asarray(scene.arrows.points), points)
    scene.set_arrows(scene.arrows, None)
    assert not scene.arrows.visible
    np.testing.assert_allclose(np.asarray(scene.arrows.points), points)  # kept while hidden


def test_labels_are_sent_again_the_given_frames_after_they_are_shown(make_bare_scene: Any) -> None:
    scene, _ = make_bare_scene(_Plain)
    sent: list[bool] = []
    scene._resend_labels = lambda: sent.append(scene.label.visible)  # count the re-sends
    scene.label.visible = True
    scene.resend_labels(after=3)
    for _ in range(2):
        scene.tick_labels()
    assert sent == []
    scene.tick_labels()
    assert sent == [True]
    for _ in range(5):
        scene.tick_labels()
    assert sent == [True]  # once
