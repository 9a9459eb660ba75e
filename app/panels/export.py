"""Export panel: the current orientation as JSON, with convention notes for scipy, viser and MuJoCo.

The document (:func:`rigidlab.app.panels._views.export_document`) holds every
representation, the Euler angles of all 24 sequences too: 24 core calls,
a few milliseconds, too much for one 60 Hz frame. So the preview in the
panel is computed on the scene's background executor while the panel is
shown (one job at a time, the newest orientation wins) and swapped in when
ready; *Download JSON* sends the same document (reusing the preview when it
is current).
"""

from __future__ import annotations

import concurrent.futures
import json
from collections.abc import Callable
from typing import Any

from rigidlab.app.panels._views import OrientationViews, export_document

__all__ = ["ExportPanel", "export_json"]


def export_json(views: OrientationViews) -> str:
    """The export document of ``views`` as JSON text: one line per entry, readable in the panel."""
    return _json_lines(export_document(views))


def _json_lines(doc: dict[str, Any], depth: int = 1) -> str:
    """``doc`` as JSON with one line per key (objects of objects nested one level more)."""
    pad = " " * depth
    lines = []
    for key, value in doc.items():
        if isinstance(value, dict) and any(isinstance(v, (dict, list, str)) for v in value.values()):
            text = _json_lines(value, depth + 1)
        else:
            text = json.dumps(value, allow_nan=False)
        lines.append(f"{pad}{json.dumps(key)}: {text}")
    return "{\n" + ",\n".join(lines) + "\n" + " " * (depth - 1) + "}"


def _key(views: OrientationViews) -> tuple[bytes, str, bytes]:
    return (views.p.tobytes(), views.seq, views.euler.tobytes())


class ExportPanel:
    """*Download JSON* and a live preview (see the module docstring).

    Parameters
    ----------
    filename : name of the downloaded file
    prefix : prefix of the control keys
    """

    def __init__(self, *, filename: str = "orientation.json", prefix: str = "") -> None:
        self.filename = filename
        self.key_download = f"{prefix}download"
        self.visible = False
        self._job: concurrent.futures.Future | None = None
        self._job_key: Any = None
        self._done: tuple[Any, str] | None = None
        self._wanted: OrientationViews | None = None

    def build(self, scene: Any, current: Callable[[], OrientationViews]) -> Any:
        """A folder with the download button and the preview; ``current()`` gives the views to export."""
        self._executor = scene.executor
        self._current = current
        self.folder = scene.target.gui.add_folder("Export", visible=False)
        with self.folder:
            scene.add_download(
                self.key_download, "Download JSON", self.filename, self._download_bytes,
                hint="Every representation of the current orientation, with notes for scipy, viser and MuJoCo.",
            )
            self.readout = scene.add_readout("*Preparing the JSON ...*")
        return self.folder

    def set_visible(self, on: bool) -> None:
        self.visible = bool(on)
        self.folder.visible = self.visible

    @property
    def busy(self) -> bool:
        """Whether a preview is being computed or waits to be."""
        return self._job is not None or self._wanted is not None

    def request(self, views: OrientationViews) -> None:
        """Ask for the preview of ``views`` (computed in the background while the panel is shown)."""
        if self.visible and (self._done is None or self._done[0] != _key(views)):
            self._wanted = views
        self.poll()

    def poll(self) -> None:
        """Swap in a finished preview and start the next one (loop thread)."""
        job = self._job
        if job is not None:
            if not job.done():
                return
            self._job = None
            try:
                text = job.result()
            except Exception as exc:  # shown, never raised into the frame
                self.readout.content = f"*Could not prepare the JSON: {type(exc).__name__}: {exc}*"
            else:
                self._done = (self._job_key, text)
                self.readout.content = f"```\n{text}\n```"
        wanted, self._wanted = self._wanted, None
        if wanted is not None and self.visible:
            self._job_key = _key(wanted)
            if self._done is not None and self._done[0] == self._job_key:
                return
            self._job = self._executor.submit(export_json, wanted)

    def _download_bytes(self) -> bytes:
        views = self._current()
        if self._done is not None and self._done[0] == _key(views):
            return self._done[1].encode()
        return export_json(views).encode()
