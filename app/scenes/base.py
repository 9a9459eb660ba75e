"""The scene layer: the one small interface every scene implements, and what it gets for free.

A scene is a class in its own module under ``app/scenes/``. It declares its
controls, its state and its update; the layer gives it, the same for every
scene:

* **validated controls** -- ``self.controls.add(Slider(...))`` creates the
  element; every value a browser sends passes the gate (:mod:`rigidlab.app.gate`)
  and the control's parser before the scene sees it (:mod:`rigidlab.app.panel`);
* **shareable state** -- :meth:`Scene.state` / :meth:`Scene.load_state`
  (the values of the controls, plus what a scene adds in
  :meth:`extra_state` / :meth:`load_extra_state`);
* **failure containment** -- an exception in ``update`` is reported once
  (a notice and one log entry with its traceback) and pauses the scene,
  which resumes when a control changes; the session goes on;
* **presenter view** -- labels, arrows, lines, readouts and plots made
  with :meth:`add_label`, :meth:`add_arrows`, :meth:`add_lines`,
  :meth:`add_readout` and :meth:`add_plot` grow together when presenter
  view is on (the session's :func:`presenter_css` grows the panel's controls);
* **plots beside the scene** -- plots made inside ``with self.plot_area():``
  go in a panel docked at the left of the page, shown with the scene; data
  sent with :meth:`show_series` get axes that mean something (offset
  notation for a flat series, y limits that follow the data, drift plots
  labelled as round-off);
* **help and export** -- the class attribute :attr:`help` becomes a "What you
  see" section; :meth:`add_download` a button that sends a file to the
  browser that clicked it;
* **a frame budget** -- :meth:`frame` times each update (wall and CPU time of
  the loop thread, ``frame_seconds``); long work goes to ``self.executor``
  (see :mod:`rigidlab.app.jobs`).

Life cycle, driven by the session that owns the scene (one per server in
``shared`` mode, one per browser in ``per-client`` mode):

1. ``scene = SceneClass(target, notify, context=...)`` -- store handles, no work.
2. ``scene.build()`` -- once: nodes under ``scene.root``, controls inside
   ``scene.make_folder()``. Meshes are sent here and never again.
3. ``scene.set_active(True / False)`` -- show or hide nodes and GUI; a hidden
   scene's ``frame`` is never called, so it does no work.
4. ``scene.frame(dt)`` -- about 60 Hz while active; calls ``update(dt)``,
   which reads ``self.controls`` and assigns poses / small buffers inside
   ``target.atomic()``.
5. ``scene.close()`` -- remove nodes and GUI.

``target`` is a ``viser.ViserServer`` (shared mode) or a ``viser.ClientHandle``
(per-client mode); both expose ``.scene``, ``.gui`` and ``.atomic()``.
``notify(title, body, level)`` shows a notice to the scene's audience.
"""

from __future__ import annotations

import collections
import concurrent.futures
import dataclasses
import logging
import threading
import time
import traceback
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
import viser

from rigidlab.app.controls import Button
from rigidlab.app.gate import Gate
from rigidlab.app.panel import ControlPanel, NotifyClient
from rigidlab.app.readout import PRESENTER_FONT_SCALE, Readout
from rigidlab.app.scenes._plots import axis_offset, drift_title, label_with_offset, offset_label, y_limits
from rigidlab.app.jobs import make_executor
from rigidlab.app.nodes import set_array

__all__ = ["Scene", "SceneContext", "Notify", "PRESENTER_LABEL_SCALE", "PRESENTER_ARROW_SCALE", "aim_camera",
           "presenter_css"]

_log = logging.getLogger(__name__)

Notify = Callable[[str, str, str], None]

#: Presenter view: labels, arrow radii and line widths grow by these factors.
PRESENTER_LABEL_SCALE = 1.8
PRESENTER_ARROW_SCALE = 1.8
PRESENTER_LINE_SCALE = 2.0
#: Frame timings kept per scene (wall s, loop-thread CPU s).
FRAME_HISTORY = 4096


#: Width of a plot's y axis (px) and its tick labels' font size (px), normal view: room for labels such as
#: "-5.625" (uPlot's default 50 px cut off their first character).
PLOT_Y_AXIS_PX, PLOT_FONT_PX = 62, 12


def plot_axes(presenter: bool) -> tuple[dict, dict]:
    """uPlot options of a scene plot's x and y axes: tick labels at :data:`PLOT_FONT_PX`, times
    :data:`rigidlab.app.readout.PRESENTER_FONT_SCALE` in presenter view, the y axis widened with them."""
    f = PRESENTER_FONT_SCALE if presenter else 1.0
    font = f"{PLOT_FONT_PX * f:.0f}px system-ui, -apple-system, sans-serif"
    return ({"font": font, "size": round(50 * f)}, {"font": font, "size": round(PLOT_Y_AXIS_PX * f)})


def plot_padding(presenter: bool) -> tuple:
    """uPlot padding (top, right, bottom, left; None: uPlot's own) of a scene plot: room above the plot
    area for the upper half of the top y tick label, which uPlot's own top padding cut off under the title
    (a "45" at the top of the lean plot showed as half a number)."""
    f = PRESENTER_FONT_SCALE if presenter else 1.0
    return (round(1.2 * PLOT_FONT_PX * f), None, None, None)


def plot_text_css(presenter: bool) -> str:
    """A style sheet (HTML) that enlarges every plot's title and legend in presenter view; empty otherwise.

    uPlot draws a plot's title and legend as page elements (viser's style
    sets ``.u-title`` at 0.875 em and ``.u-legend`` at 0.7 em of the plot's
    font), outside the options :func:`plot_axes` sets, so the session's panel
    carries this sheet. In presenter view a title takes a presenter
    readout's size (:data:`rigidlab.app.readout.PRESENTER_FONT_SCALE` em of the panel's
    font, which the plot's is; both are 0.875 em otherwise) and a legend
    keeps its proportion to the title.
    """
    if not presenter:
        return ""
    title = PRESENTER_FONT_SCALE
    legend = PRESENTER_FONT_SCALE * 0.7 / 0.875
    return (f"<style>.uplot .u-title{{font-size:{title:.2f}em !important;line-height:1.3 !important}}"
            f".uplot .u-legend{{font-size:{legend:.2f}em !important}}</style>")


#: Width (px) of the panel of a scene's plots (:meth:`Scene.plot_area`), normal and presenter view.
PLOT_PANEL_PX, PRESENTER_PLOT_PANEL_PX = 420, 500
#: Presenter view: the control panel's width (px; viser's "large" control width is 384 px) and the font
#: size (px) of its controls' text: slider and field labels, inputs, dropdowns, buttons, folder and tab
#: titles, slider marks (11-12 px in the normal view).
PRESENTER_PANEL_PX = 560
NORMAL_PANEL_PX = 384
PRESENTER_CONTROL_PX = 16


def presenter_css(presenter: bool) -> str:
    """The session's style sheet (HTML) for presenter view: every control of the panel at
    :data:`PRESENTER_CONTROL_PX` and the plots' titles and legends grown (:func:`plot_text_css`); empty
    in the normal view.

    viser sizes a control's text in em of the panel's font or with Mantine's ``xs`` size (0.75 rem), so
    the sheet sets both the controls' boxes and their text; the panel's width is set apart
    (:data:`PRESENTER_PANEL_PX`, ``gui.main_panel.set_width``).
    """
    if not presenter:
        return ""
    px = PRESENTER_CONTROL_PX
    controls = (
        # labels of rows (sliders, fields, dropdowns, checkboxes), folder titles, tab titles
        "label, .mantine-Text-root, .mantine-Checkbox-label, .mantine-Tabs-tab, .mantine-Tabs-tabLabel, "
        "[role=tab], legend, .mantine-Fieldset-legend"
    )
    boxes = (
        ".mantine-Input-input, .mantine-NumberInput-input, .mantine-TextInput-input, .mantine-Select-input, "
        ".mantine-Textarea-input, .mantine-Select-option, .mantine-Combobox-option"
    )
    return (
        "<style>"
        f":root{{--mantine-font-size-xs:{px}px;--mantine-font-size-sm:{px}px;"
        f"--input-height-xs:{round(px * 2.0)}px;--input-height-sm:{round(px * 2.1)}px}}"
        f"{controls}{{font-size:{px}px !important;line-height:1.35 !important}}"
        f"{boxes}{{font-size:{px}px !important;min-height:{round(px * 1.9)}px !important;"
        f"height:auto !important}}"
        f".mantine-Button-root{{font-size:{px}px !important;height:auto !important;"
        f"min-height:{round(px * 2.1)}px !important;padding-top:0.2em;padding-bottom:0.2em}}"
        f".mantine-Button-label, .mantine-Button-inner{{font-size:{px}px !important}}"
        f".mantine-Slider-markLabel{{font-size:{round(px * 0.8)}px !important}}"
        # a folder's title: viser draws it as a Paper, the first child of the folder's Paper
        f".mantine-Paper-root > .mantine-Paper-root:first-child{{font-size:{px}px !important}}"
        f".mantine-Slider-thumb{{width:{round(px * 1.1)}px;height:{round(px * 1.1)}px}}"
        ".mantine-Tooltip-tooltip{font-size:15px !important}"
        "</style>"
        + plot_text_css(True)
    )


@dataclasses.dataclass
class SceneContext:
    """What the session gives each scene.

    Attributes
    ----------
    gate : the validation gate of the target's GUI API
    executor : background executor for long work (one per app)
    notify_client : ``notify_client(client, title, body, level)``: a notice to
        the browser that acted (``client``), or to the audience when None
    presenter : whether presenter view is on when the scene is built
    owns_executor : whether the scene shuts ``executor`` down when closed
    """

    gate: Gate
    executor: concurrent.futures.Executor
    notify_client: NotifyClient
    presenter: bool = False
    owns_executor: bool = False

    @classmethod
    def standalone(cls, target: Any, notify: Notify) -> SceneContext:
        """A context for a scene used without a session (tests, notebooks)."""

        def notify_client(client: Any, title: str, body: str, level: str) -> None:
            notify(title, body, level)

        return cls(
            gate=Gate.for_gui(target.gui),
            executor=make_executor(),
            notify_client=notify_client,
            owns_executor=True,
        )


def aim_camera(target: Any, position: tuple[float, float, float], look_at: tuple[float, float, float]) -> None:
    """Point the camera of ``target`` (a client) or of every client of ``target`` (a server, whose initial
    camera for browsers that join later is set too) at ``look_at`` from ``position``."""
    clients = [target]
    if isinstance(target, viser.ViserServer):
        target.initial_camera.position = position
        target.initial_camera.look_at = look_at
        clients = list(target.get_clients().values())
    for client in clients:
        with client.atomic():
            client.camera.position = position
            client.camera.look_at = look_at


class Scene:
    """Base class of every scene (see the module docstring).

    Subclasses set ``name`` (registry key, used by ``--scene``), ``title``
    (shown in the scene chooser), ``order`` (position in the chooser),
    ``help`` (the "What you see" text, naming the equations) and,
    optionally, ``camera_position`` / ``camera_look_at``; they override
    ``build`` and ``update`` and, if they hold extra resources, ``close``.
    """

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    #: Position in the scene chooser (lower first).
    order: ClassVar[int] = 1000
    #: "What you see": what the scene shows and the equations behind it (Markdown).
    help: ClassVar[str] = ""
    #: Optional default view when the scene is shown (global frame, metres);
    #: ``None`` means the app's default view.
    camera_position: ClassVar[tuple[float, float, float] | None] = None
    camera_look_at: ClassVar[tuple[float, float, float] | None] = None

    def __init__(self, target: Any, notify: Notify, *, context: SceneContext | None = None) -> None:
        self.target = target
        self.notify = notify
        self.context = context if context is not None else SceneContext.standalone(target, notify)
        self.executor = self.context.executor
        self.controls = ControlPanel(target.gui, self.context.gate, self.context.notify_client)
        self.lock = threading.Lock()
        self.root = f"/{self.name}"
        self.active = False
        self.presenter = bool(self.context.presenter)
        self.paused_error: str | None = None
        self._paused_version = -1
        self._logged_errors: set[str] = set()
        self._gui_folder: Any = None
        self._plot_panel: Any = None
        self._plot_tab: Any = None
        self._plot_axes: dict[int, tuple] = {}
        self._labels: list[tuple[Any, float]] = []
        self._label_nudge = False
        self._arrows: list[tuple[Any, float, float, float]] = []
        self._lines: list[tuple[Any, float]] = []
        self._readouts: list[Readout] = []
        self._plots: list[Any] = []
        self._downloads: dict[str, tuple[str, Callable[[], bytes]]] = {}
        self._labels_due = 0  # frames until the labels' visibility is sent again (resend_labels)
        #: (wall seconds, loop-thread CPU seconds) of the latest frames.
        self.frame_seconds: collections.deque[tuple[float, float]] = collections.deque(maxlen=FRAME_HISTORY)
        self.frames = 0

    # -- life cycle -----------------------------------------------------
    def build(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def update(self, dt: float) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def frame(self, dt: float) -> None:
        """One loop tick: text restores, downloads, then ``update(dt)`` unless paused.

        An exception in ``update`` pauses the scene (reported once: a notice
        and one log entry); it resumes at the next browser change or click.
        """
        wall0, cpu0 = time.perf_counter(), time.thread_time()
        try:
            self.controls.poll()
            self._serve_downloads()
            if self.paused_error is not None:
                if self.controls.version == self._paused_version:
                    return
                self.paused_error = None
                self.notify(f"{self.title} resumed", "A control changed: the scene runs again.", "info")
            self.update(dt)
        except Exception as exc:
            self._pause(exc)
        finally:
            self.frames += 1
            self.frame_seconds.append((time.perf_counter() - wall0, time.thread_time() - cpu0))

    def _pause(self, exc: BaseException) -> None:
        message = f"{type(exc).__name__}: {exc}"
        self.paused_error = message
        self._paused_version = self.controls.version
        if message not in self._logged_errors:
            self._logged_errors.add(message)
            _log.error("scene %r paused after an error:\n%s", self.name, traceback.format_exc())
        self.notify(
            f"{self.title} paused",
            f"{message}. The scene is paused; change a control (or press Reset) to run it again. "
            "The server keeps running.",
            "error",
        )

    def camera_view(self) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
        """``(position, look_at)`` the viewers' cameras are pointed at when the scene is shown: the class's
        ``camera_position`` and ``camera_look_at`` (None: the session's default view). A scene whose size
        follows a control overrides it and calls :meth:`reframe` when the size changes."""
        if self.camera_position is None or self.camera_look_at is None:
            return None
        return self.camera_position, self.camera_look_at

    def reframe(self) -> None:
        """Point the cameras of this scene's viewers at :meth:`camera_view` again (loop thread; only while
        the scene is shown). Every browser of a shared session is re-aimed, as at a scene switch."""
        view = self.camera_view()
        if self.active and view is not None:
            aim_camera(self.target, *view)

    def set_active(self, active: bool) -> None:
        """Show or hide this scene's root frame and GUI folder.

        On showing, the visibility of the labels made with :meth:`add_label`
        is sent again: viser 1.1.1's page does not draw a label created while
        it is connected (a scene built when a browser first opens it) until
        the label's visibility changes.
        """
        self.active = active
        root = getattr(self, "root_frame", None)
        if root is not None:
            root.visible = active
        if self._gui_folder is not None:
            self._gui_folder.visible = active
        if self._plot_panel is not None and self._plot_panel.visible != active:
            self._plot_panel.visible = active
        if active and self._labels:
            self._resend_labels()

    def _resend_labels(self) -> None:
        with self.target.atomic():
            for handle, _ in self._labels:
                if handle.visible:
                    handle.visible = False
                    handle.visible = True

    def resend_labels(self, *, after: int = 30) -> None:
        """Send the visibility of the shown labels again ``after`` frames from now (counted by
        :meth:`tick_labels`): viser 1.1.1's page may not draw a label made visible soon after it was created
        while a browser is connected (a scene that shows its labels with its first chunk)."""
        self._labels_due = int(after)

    def tick_labels(self) -> None:
        """Count one frame towards :meth:`resend_labels` (the timed scenes' layer calls it every frame)."""
        if self._labels_due > 0:
            self._labels_due -= 1
            if self._labels_due == 0:
                self._resend_labels()

    def nudge_labels(self) -> None:
        """Make viser's page rebuild the glyphs of this scene's labels (loop thread; the session calls it a
        few times after a browser joins or the scene is shown, with a redraw).

        viser 1.1.1's page builds a label's glyphs in a frame after it registered the label, and a fresh
        page often drew none (the sandbox opened without labels in 5 of 5 loads) until a label changed: a
        change of its font size gives its group a new build. The size moves by a relative 1e-12 and back at
        the next call (nothing a reader or a test sees).
        """
        self._label_nudge = not self._label_nudge
        f = (PRESENTER_LABEL_SCALE if self.presenter else 1.0) * (1.0 + 1e-12 * self._label_nudge)
        if self._labels:
            with self.target.atomic():
                for handle, base in self._labels:
                    handle.font_screen_scale = base * f

    def close(self) -> None:
        self.controls.remove_all()
        root = getattr(self, "root_frame", None)
        if root is not None:
            root.remove()
        if self._gui_folder is not None:
            self._gui_folder.remove()
        if self._plot_panel is not None:
            self._plot_panel.remove()
        if self.context.owns_executor:
            self.executor.shutdown(wait=False, cancel_futures=True)

    # -- presenter view -------------------------------------------------------
    def set_presenter(self, on: bool) -> None:
        """Large labels, thick arrows and lines, large readouts (``on``), or normal."""
        self.presenter = bool(on)
        label_scale = PRESENTER_LABEL_SCALE if on else 1.0
        arrow_scale = PRESENTER_ARROW_SCALE if on else 1.0
        line_scale = PRESENTER_LINE_SCALE if on else 1.0
        for handle, base in self._labels:
            handle.font_screen_scale = base * label_scale
        for handle, shaft, head, length in self._arrows:
            handle.shaft_radius = shaft * arrow_scale
            handle.head_radius = head * arrow_scale
            handle.head_length = length * arrow_scale
        for handle, thickness in self._lines:
            handle.thickness = thickness * line_scale
        for readout in self._readouts:
            readout.set_presenter(on)
        if self._plot_panel is not None:
            self._plot_panel.set_width(PRESENTER_PLOT_PANEL_PX if on else PLOT_PANEL_PX)
        axes, padding = plot_axes(on), plot_padding(on)
        for plot in self._plots:
            plot.axes = axes
            plot.padding = padding
        self.on_presenter(bool(on))

    def on_presenter(self, on: bool) -> None:
        """Hook: anything else a scene enlarges in presenter view."""

    # -- shareable state ------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """The scene's state: ``{"scene": name, "values": {...}}`` plus :meth:`extra_state`."""
        out: dict[str, Any] = {"format": "rigidlab state 1", "scene": self.name, "values": self.controls.state()}
        out.update(self.extra_state())
        return out

    def extra_state(self) -> dict[str, Any]:
        """Hook: state that is not a control value (JSON types)."""
        return {}

    def load_state(self, state: dict[str, Any]) -> list[str]:
        """Apply ``state`` (as :meth:`state` gives, checked like browser input).

        :meth:`check_state` then :meth:`apply_state`. Returns one message per
        refused entry; the accepted values are applied and count as changes
        (a paused scene resumes).

        Raises
        ------
        ValueError
            If ``state`` belongs to another scene, or if the scene refuses
            its accepted values together with the others in use
            (:meth:`values_refusal`, e.g. a rotor with ``I3 > 2 I``); then
            nothing is applied.
        """
        accepted, refused = self.check_state(state)
        return self.apply_state(state, accepted, refused)

    def check_state(self, state: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
        """``(accepted, refused)``: the control values of ``state`` each control accepts, and one message per
        refused one; nothing is applied. Any thread (the session runs it off the loop: building a model to
        check values together may take tens of ms).

        Raises
        ------
        ValueError
            As :meth:`load_state`.
        """
        scene = state.get("scene")
        if scene != self.name:
            raise ValueError(f"state: expected a state of scene {self.name!r}, got one of {scene!r}")
        values = state.get("values", {})
        if not isinstance(values, dict):
            raise ValueError(f"state: expected 'values' to be an object, got {type(values).__name__}")
        accepted, refused = self.controls.check(values)
        # each value alone passed its control; the scene may still refuse them together, and a load that said
        # "State loaded" before the scene set its controls back contradicted itself
        together = self.values_refusal({**self.controls.values(), **accepted}) if accepted else None
        if together is not None:
            raise ValueError(f"state: {together}")
        return accepted, refused

    def apply_state(self, state: dict[str, Any], accepted: dict[str, Any], refused: list[str]) -> list[str]:
        """Apply what :meth:`check_state` accepted of ``state``, and its extra state (:meth:`load_extra_state`);
        returns ``refused`` and the extra state's refusals."""
        self.controls.apply(accepted)
        return refused + self.load_extra_state(
            {k: v for k, v in state.items() if k not in ("format", "scene", "values")})

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        """Hook: why the scene would refuse the control values ``values`` (every control's) together, or None.

        Called by :meth:`check_state` before anything is applied, off the
        loop in a session: build the scene's model from ``values`` without
        touching the scene. The scenes whose model
        checks values together (the gyroscope's rotor, the rolling disk,
        the cam, the mode-shapes models) override it with the check their
        controls' changes get.
        """
        return None

    def load_extra_state(self, extra: dict[str, Any]) -> list[str]:
        """Hook: apply what :meth:`extra_state` gave; return refusal messages."""
        return [f"{key!r}: not part of this scene's state" for key in extra]

    # -- helpers for subclasses -----------------------------------------
    def make_root(self) -> Any:
        """Create the scene's root frame; every node goes under ``self.root``."""
        self.root_frame = self.target.scene.add_frame(self.root, show_axes=False)
        return self.root_frame

    def make_folder(self) -> Any:
        """Create the scene's GUI folder (with its "What you see" section)."""
        gui = self.target.gui
        self._gui_folder = gui.add_folder(self.title)
        if self.help:
            with self._gui_folder:
                with gui.add_folder("What you see", expand_by_default=False):
                    self.help_readout = self.add_readout(self.help)
        return self._gui_folder

    def plot_area(self) -> Any:
        """The GUI container a scene's plots and tables go in (a context manager): every scene calls this
        instead of making its own "Plots" folder, so the page's layout of plots is decided here, once.

        The plots go in a panel of their own, docked at the left edge of the page
        (``gui.add_panel().dock_left()``, :data:`PLOT_PANEL_PX` wide, :data:`PRESENTER_PLOT_PANEL_PX` in
        presenter view): the 3-D view sits between it and the control panel, so at 1600 x 900 a plot and the
        scene are seen together, without scrolling (the gyroscope's plots were some 1400 px down the
        control panel). The panel is made at the first call and shown only while the scene is
        (:meth:`set_active`); a scene that never calls this has none.
        """
        if self._plot_tab is None:
            gui = self.target.gui
            self._plot_panel = gui.add_panel()
            self._plot_tab = self._plot_panel.add_tab(f"{self.title}: plots")
            self._plot_panel.dock_left()
            self._plot_panel.set_width(PRESENTER_PLOT_PANEL_PX if self.presenter else PLOT_PANEL_PX)
        return self._plot_tab

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

    def add_label(self, name: str, text: str, *, position: Any = (0.0, 0.0, 0.0),
                  scale: float = 1.0, **kwargs: Any) -> Any:
        """A 3-D label that grows in presenter view (``scale`` is its normal size)."""
        kwargs.setdefault("anchor", "center-center")
        handle = self.target.scene.add_label(
            name, text, position=tuple(float(x) for x in position),
            font_screen_scale=scale * (PRESENTER_LABEL_SCALE if self.presenter else 1.0), **kwargs,
        )
        self._labels.append((handle, scale))
        return handle

    def add_arrows(self, name: str, points: Any, colors: Any, *, shaft_radius: float, head_radius: float,
                   head_length: float, **kwargs: Any) -> Any:
        """Arrows whose radii and heads grow in presenter view."""
        f = PRESENTER_ARROW_SCALE if self.presenter else 1.0
        handle = self.target.scene.add_arrows(
            name, np.asarray(points, dtype=np.float32), colors, shaft_radius=shaft_radius * f,
            head_radius=head_radius * f, head_length=head_length * f, **kwargs,
        )
        self._arrows.append((handle, shaft_radius, head_radius, head_length))
        return handle

    def resize_arrows(self, handle: Any, *, shaft_radius: float, head_radius: float, head_length: float) -> None:
        """New sizes (m) for arrows made with :meth:`add_arrows` (grown in presenter view as before)."""
        f = PRESENTER_ARROW_SCALE if self.presenter else 1.0
        for k, entry in enumerate(self._arrows):
            if entry[0] is handle:
                self._arrows[k] = (handle, shaft_radius, head_radius, head_length)
                handle.shaft_radius = shaft_radius * f
                handle.head_radius = head_radius * f
                handle.head_length = head_length * f
                return
        raise ValueError(f"handle: expected arrows made with add_arrows, got {handle!r}")

    def add_lines(self, name: str, points: Any, colors: Any, *, thickness: float, **kwargs: Any) -> Any:
        """Line segments whose width grows in presenter view."""
        f = PRESENTER_LINE_SCALE if self.presenter else 1.0
        handle = self.target.scene.add_line_segments(
            name, np.asarray(points, dtype=np.float32), colors, thickness=thickness * f, **kwargs,
        )
        self._lines.append((handle, thickness))
        return handle

    def add_plot(self, data: tuple, series: tuple, **options: Any) -> Any:
        """A uPlot chart in the current GUI folder (``gui.add_uplot``) whose axes' tick labels grow in
        presenter view (:func:`plot_axes`), with room above for the top tick label (:func:`plot_padding`)."""
        options.setdefault("axes", plot_axes(self.presenter))
        options.setdefault("padding", plot_padding(self.presenter))
        handle = self.target.gui.add_uplot(data, series, **options)
        self._plots.append(handle)
        return handle

    def add_legend(self, items: Any, title: str = "") -> Any:
        """A colour key (:class:`rigidlab.app.scenes._plots.Legend`: ``(rgb, text)`` items) in the current GUI folder, its
        text enlarged in presenter view with the readouts'."""
        from rigidlab.app.scenes._plots import Legend  # (the scenes' plotting helpers import nothing of this module)

        legend = Legend(self.target.gui, items, title, presenter=self.presenter)
        self._readouts.append(legend)  # set_presenter(on), as a Readout
        return legend

    def set_arrows(self, handle: Any, points: Any) -> None:
        """Show arrows made with :meth:`add_arrows` at ``points`` ((n, 2, 3) m), or hide them (None); the
        visibility is sent only when it changes."""
        if points is not None:
            set_array(handle, "points", points)
        if handle.visible != (points is not None):
            handle.visible = points is not None

    def show_series(self, plot: Any, x: Any, ys: Any, *, title: str | None = None, unit: str = "",
                    min_span: float = 0.0, include: tuple[float, ...] = (), offset: bool = True,
                    drift_scale: float | None = None, log10: bool = False) -> None:
        """Send new data to a plot made with :meth:`add_plot`, with axes that mean something.

        * **offset notation** -- a series whose spread is tiny beside its value (an energy that stays
          26.886 J) is drawn as ``y - offset`` (:func:`rigidlab.app.scenes._plots.axis_offset`); the series'
          legend labels and the title say so ("E − 26.886 (J)"), and the ticks differ;
        * **limits that follow the data** -- the y range is the data's (:func:`~rigidlab.app.scenes._plots.y_limits`,
          at least ``min_span`` wide, containing ``include``), kept while the data stay inside it and
          fill at least 40 % of it, so it does not jitter every refresh;
        * **round-off** -- with ``drift_scale`` (the size of the quantity the series is an error of; ``log10``:
          the series are ``log10 |error|``) the title says "round-off level" when every value is
          (:func:`~rigidlab.app.scenes._plots.drift_title`).

        Parameters
        ----------
        plot : the handle :meth:`add_plot` returned
        x : (n,) the x values
        ys : sequence of (n,) arrays, one per series after x (in the plot's order)
        title : str or None, keyword-only
            The plot's title without the notes above (None: the title is left as it is).
        unit : str, keyword-only
            Unit of the y values, for the offset's label.
        min_span : float, keyword-only
            Smallest span of the y range (in the y unit).
        include : tuple of float, keyword-only
            y values the range always contains (a bound drawn as a line, 0).
        offset : bool, keyword-only
            Whether a flat series may be drawn with an offset (False: as it is; never for ``log10``).
        drift_scale, log10 : keyword-only
            See above.
        """
        columns = [np.asarray(y, dtype=float) for y in ys]
        values = np.concatenate([c.ravel() for c in columns]) if columns else np.zeros(0)
        off = axis_offset(values) if offset and not log10 else 0.0
        shown = [c - off for c in columns]
        key = id(plot)
        labels, old_off, old_lim, old_title = self._plot_axes.get(key) or (
            tuple(str(s.get("label", "")) for s in plot.series), None, None, None)
        finite = values[np.isfinite(values)] - off
        lim = old_lim
        if lim is None or finite.size == 0 or finite.min() < lim[0] or finite.max() > lim[1] or (
                lim[1] - lim[0] > max(min_span, 0.0) and finite.max() - finite.min() < 0.4 * (lim[1] - lim[0])) \
                or old_off != off:
            lim = y_limits(finite, min_span=min_span, include=tuple(v - off for v in include))
        plot.data = (np.asarray(x, dtype=float), *shown)
        if old_off != off:
            plot.series = tuple(
                s if k == 0 else {**s, "label": label_with_offset(labels[k], off)} for k, s in enumerate(plot.series))
        if lim != old_lim:
            plot.scales = {**(plot.scales or {}), "y": {"auto": False, "range": (float(lim[0]), float(lim[1]))}}
        text = old_title
        if title is not None:
            text = title if drift_scale is None else drift_title(title, values, scale=drift_scale, log10=log10)
            if off:
                text = f"{text} \u2014 shown as {offset_label('y', off, unit)}"
            if text != old_title:
                plot.title = text
        self._plot_axes[key] = (labels, off, lim, text)

    def add_readout(self, content: str = "", **kwargs: Any) -> Readout:
        """A text panel in the current GUI folder (sent only when it changes)."""
        handle = self.target.gui.add_html("", **kwargs)
        readout = Readout(handle, presenter=self.presenter)
        readout.content = content
        self._readouts.append(readout)
        return readout

    def add_download(self, key: str, label: str, filename: str, make: Callable[[], bytes],
                     *, hint: str | None = None) -> Any:
        """A button that sends ``make()`` as ``filename`` to the browser that clicked it.

        ``make`` runs on the loop thread when the click is served.
        """
        handle = self.controls.add(Button(key, label, hint=hint))
        self._downloads[key] = (filename, make)
        return handle

    def _serve_downloads(self) -> None:
        if not self._downloads:
            return
        for key, _, client in self.controls.take_clicks(self._downloads):
            filename, make = self._downloads[key]
            try:
                content = make()
            except Exception as exc:
                _log.error("export %s failed:\n%s", filename, traceback.format_exc())
                self.notify("Export failed", f"{filename}: {type(exc).__name__}: {exc}", "warning")
                continue
            target = client if client is not None else self.target
            target.send_file_download(filename, content, save_immediately=True)
