"""The one small interface every scene implements.

A scene is a class in its own module under ``app/scenes/``. The session that
owns it (one per server in ``shared`` mode, one per browser in ``per-client``
mode) drives it:

1. ``scene = SceneClass(target, notify)`` -- store handles, do no work.
2. ``scene.build()`` -- once: create scene nodes under ``scene.root`` and GUI
   elements inside one GUI folder. Meshes are sent here and never again.
3. ``scene.set_active(True / False)`` -- show or hide the nodes and the GUI
   folder. A hidden scene's ``update`` is never called, so it does no work.
4. ``scene.update(dt)`` -- called by the session loop (about 60 Hz) while the
   scene is active. GUI callbacks only record changes (under ``self.lock``);
   ``update`` recomputes what is dirty and assigns poses / small buffers
   inside ``target.atomic()``.
5. ``scene.close()`` -- remove nodes and GUI (server shutdown or client leaving).

``target`` is a ``viser.ViserServer`` (shared mode) or a ``viser.ClientHandle``
(per-client mode); both expose ``.scene``, ``.gui`` and ``.atomic()``.
``notify(title, body, level)`` shows a visible notice in the browser(s) that
the scene belongs to (``level`` is ``"info"``, ``"warning"`` or ``"error"``).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, ClassVar

Notify = Callable[[str, str, str], None]


class Scene:
    """Base class of every scene (see the module docstring for the life cycle).

    Subclasses set ``name`` (registry key, used by ``--scene``), ``title``
    (shown in the scene chooser), ``order`` (position in the chooser) and,
    optionally, ``camera_position`` / ``camera_look_at``, and override ``build``, ``update`` and, if
    they hold extra resources, ``close``.
    """

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    #: Position in the scene chooser (lower first).
    order: ClassVar[int] = 1000
    #: Optional default view when the scene is shown (global frame, metres);
    #: ``None`` means the app's default view.
    camera_position: ClassVar[tuple[float, float, float] | None] = None
    camera_look_at: ClassVar[tuple[float, float, float] | None] = None

    def __init__(self, target: Any, notify: Notify) -> None:
        self.target = target
        self.notify = notify
        self.lock = threading.Lock()
        self.root = f"/{self.name}"
        self.active = False
        self._node_handles: list[Any] = []
        self._gui_folder: Any = None

    # -- life cycle -----------------------------------------------------
    def build(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def update(self, dt: float) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def set_active(self, active: bool) -> None:
        """Show or hide this scene's root frame and GUI folder."""
        self.active = active
        root = getattr(self, "root_frame", None)
        if root is not None:
            root.visible = active
        if self._gui_folder is not None:
            self._gui_folder.visible = active

    def close(self) -> None:
        root = getattr(self, "root_frame", None)
        if root is not None:
            root.remove()
        if self._gui_folder is not None:
            self._gui_folder.remove()

    # -- helpers for subclasses -----------------------------------------
    def make_root(self) -> Any:
        """Create the scene's root frame; every node goes under ``self.root``."""
        self.root_frame = self.target.scene.add_frame(self.root, show_axes=False)
        return self.root_frame

    def add_ground_grid(
        self,
        *,
        width: float,
        height: float,
        position: tuple[float, float, float],
        cell_size: float,
        section_size: float,
    ) -> Any:
        """Add the scene's ground grid at ``{root}/grid`` (metres, global frame).

        Every scene uses the same light colours and shadow, so the scenes
        look alike; only the extent, height and spacing differ.
        """
        return self.target.scene.add_grid(
            f"{self.root}/grid", width=width, height=height, position=position,
            cell_size=cell_size, section_size=section_size, cell_color=(226, 228, 234),
            section_color=(196, 200, 210), shadow_opacity=0.08,
        )

    def make_folder(self) -> Any:
        """Create the scene's GUI folder; every GUI element goes inside it."""
        self._gui_folder = self.target.gui.add_folder(self.title)
        return self._gui_folder
