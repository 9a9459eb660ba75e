"""The app shell: a viser server, scene sessions and the loop that drives them.

Two modes:

``shared``
    One :class:`Session` built on the :class:`viser.ViserServer` itself: every
    browser sees the same scene state (the instructor drives, the class
    watches). Notices about the scene go to every browser; a notice about a
    refused value goes only to the browser that sent it.
``per-client``
    One :class:`Session` per browser, built on its :class:`viser.ClientHandle`
    when the client registers and torn down when it leaves; state is isolated
    between browsers.

The pattern is the one of viser's SMPL demo: GUI callbacks (run by viser in a
thread pool) only record what changed, under a lock; one loop thread at about
60 Hz visits every session, applies a requested scene switch, presenter
toggle or state load and calls the active scene's ``frame(dt)``, which assigns
poses inside ``atomic()``. Hidden scenes are never updated. Every GUI value
passes the gate (:mod:`rigidlab.app.gate`) before viser stores it. An exception in a
scene pauses that scene (:meth:`rigidlab.app.scenes.base.Scene.frame`); the server
keeps serving. Long work runs on one background executor per app
(:mod:`rigidlab.app.jobs`).

Besides the scene chooser, every session has a presenter-view switch and a
*Share* folder: *Copy state* (the active scene's state as a short string, a
link and a copy button), *Load state* and *Download state (JSON)*, the file
that ``rigidlab serve --state FILE`` starts from (:mod:`rigidlab.app.state`).
"""

from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import dataclasses
import html
import inspect
import json
import logging
import math
import socket
import threading
import time
import traceback
import warnings
from collections.abc import Callable, Iterator
from typing import Any, Literal

import viser

from rigidlab.app import state as state_codec
from rigidlab.app.controls import Button, Choice, Text, Toggle
from rigidlab.app.gate import Gate, RefusedValue, client_request_path
from rigidlab.app.panel import ControlPanel
from rigidlab.app.scenes import discover_scenes, discovery_errors
from rigidlab.app.scenes.base import (NORMAL_PANEL_PX, PRESENTER_PANEL_PX, Scene, SceneContext, aim_camera,
                             presenter_css)
from rigidlab.app.jobs import make_executor
from rigidlab.app.loop_thread import install as install_loop_events
from rigidlab.core._warm import running_for as warm_up_running_for

__all__ = ["RigidlabApp", "Session", "create_app", "MODES"]

_log = logging.getLogger(__name__)

# viser marks a leaving browser's connection closed before it calls
# on_client_disconnect, so a per-client session's frame that runs in between
# queues its poses on the closed connection and viser warns that they will
# never be delivered. Nothing is lost (nobody is left to see them) and the
# session is closed by the callback right after: the warning is noise.
warnings.filterwarnings("ignore", message=r"Queued a \w+ on a closed connection", category=UserWarning)

MODES = ("shared", "per-client")
Mode = Literal["shared", "per-client"]

#: While the compiled kernels' warm-up (core/_warm.py, started by ``rigidlab serve``) has run this long (s)
#: and a scene's clock holds for a job (whose kernels wait for the warm-up: app.jobs), its audience sees
#: this notice, with a spinner, until the warm-up ends or the clock moves: a first start on a new install
#: compiles for a minute or two.
_WARM_NOTICE_AFTER = 2.0
_WARM_NOTICE = ("Compiling the kernels (first start only)…",
                "The compiled simulation kernels are being built for this installation (a minute or two, once). "
                "The motion starts as soon as they are ready; later starts load them in a moment.")
_WARM_CHECK_TICKS = 30  # the loop looks at the warm-up every this many ticks (0.5 s)

#: Notice colours by level (Mantine colour names understood by viser).
_LEVEL_COLORS = {"info": "blue", "warning": "yellow", "error": "red"}
#: Seconds before a notice closes on its own, by level.
_LEVEL_SECONDS = {"info": 6.0, "warning": 10.0, "error": 15.0}
#: The same notice is not repeated more often than this (seconds).
_NOTICE_REPEAT_SECONDS = 5.0
#: Loop period (about 60 Hz) and the largest dt handed to a scene (s).
_PERIOD = 1.0 / 60.0
_MAX_DT = 0.1
#: View for scenes that do not declare ``camera_position`` / ``camera_look_at``.
DEFAULT_CAMERA_POSITION = (3.2, -4.2, 2.6)
DEFAULT_CAMERA_LOOK_AT = (0.0, 0.0, 0.3)
#: Seconds after a browser joins, or a scene is shown, at which the page is asked to draw again: viser
#: 1.1.1's page registers a 3-D label (its glyphs) after the frame that mounted it and asks for no new
#: frame, so without a later redraw a fresh page showed no labels until something moved.
#: (A page under load mounts its labels late: the redraws go on, sparser, for a minute.)
_REDRAW_AFTER = (0.3, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0)
#: Thread switch interval while an app runs (s): a background job holding the
#: GIL delays the loop thread by at most about this much (Python's default is 5 ms).
SWITCH_INTERVAL = 0.0005

_COPY_JS = (
    "(function(b){var t=b.getAttribute('data-copy');var ok=function(){var o=b.innerText;"
    "b.innerText='Copied';setTimeout(function(){b.innerText=o},1500)};"
    "if(navigator.clipboard&&window.isSecureContext){navigator.clipboard.writeText(t).then(ok)}"
    "else{var a=document.createElement('textarea');a.value=t;document.body.appendChild(a);a.select();"
    "document.execCommand('copy');document.body.removeChild(a);ok()}})(this)"
)


def _send_notice(client: Any, title: str, body: str, level: str) -> None:
    """Show one notice in one browser (``client`` is a ``viser.ClientHandle``)."""
    client.add_notification(
        title,
        body,
        auto_close_seconds=_LEVEL_SECONDS.get(level, 8.0),
        color=_LEVEL_COLORS.get(level, "blue"),
        with_close_button=True,
    )


def _copy_button(label: str, text: str) -> str:
    return (
        f"<button data-copy=\"{html.escape(text, quote=True)}\" onclick=\"{_COPY_JS}\" "
        "style='margin:0 0.4em 0.3em 0;padding:0.25em 0.7em;border:1px solid #228be6;border-radius:4px;"
        f"background:#e7f5ff;color:#1864ab;cursor:pointer;font-size:0.85em'>{html.escape(label)}</button>"
    )


#: The page's guard of a slider's number box (JavaScript run once per page, from an HTML element): viser's box
#: sends nothing for text that is not a number ("nan", "abc", an emptied box) and then stayed blank, the
#: value in use shown nowhere. On leaving such a box the guard puts the slider's value back in it and shows
#: a notice saying what was refused and which value is in use.
_SLIDER_BOX_GUARD_JS = """(function(){
if (window.rigidlabBoxGuard) return; window.rigidlabBoxGuard = true;
var typed = new WeakMap();
document.addEventListener('keydown', function(ev){ var t = ev.target;
  if (t instanceof HTMLInputElement && ev.key.length === 1) typed.set(t, (typed.get(t) || '') + ev.key); }, true);
document.addEventListener('focusin', function(ev){ if (ev.target instanceof HTMLInputElement) typed.set(ev.target, ''); }, true);
document.addEventListener('focusout', function(ev){
  var box = ev.target; if (!(box instanceof HTMLInputElement)) return;
  var row = box.closest('.mantine-Flex-root'); if (!row) return;
  var thumb = row.querySelector('[role=slider]'); if (!thumb) return;
  var text = box.value.trim(); if (text !== '' && isFinite(Number(text))) return;
  var inUse = thumb.getAttribute('aria-valuenow'); if (inUse === null) return;
  var setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, 'value').set;
  setter.call(box, inUse); box.dispatchEvent(new Event('input', {bubbles: true}));
  var outer = row.parentElement && row.parentElement.closest('.mantine-Flex-root');
  var label = (outer || row).querySelector('label');
  var got = typed.get(box) || text;
  var note = document.createElement('div'); note.className = 'rigidlab-notice'; note.setAttribute('role', 'alert');
  note.style.cssText = 'position:fixed;top:1em;left:50%;transform:translateX(-50%);z-index:10000;max-width:32em;' +
    'background:#fff;border-left:4px solid #fab005;box-shadow:0 2px 10px rgba(0,0,0,.2);padding:.6em 1em;' +
    'font:14px system-ui,sans-serif;border-radius:4px';
  note.textContent = 'Refused: ' + (label ? label.textContent : 'value') + ' \u2014 expected a number, got ' +
    (got ? JSON.stringify(got) : 'an empty box') + '. Showing the value in use, ' + inUse + '.';
  document.body.appendChild(note); setTimeout(function(){ note.remove(); }, 8000);
}, true);
})()"""


def _page_script(js: str) -> str:
    """HTML that runs ``js`` once in the page (viser's HTML element sets inner HTML: an image that fails to
    load runs its ``onerror``)."""
    return f"<img alt='' src='data:,' style='display:none' onerror=\"{html.escape(js, quote=True)}\">"


_LOAD_CHECKER: concurrent.futures.ThreadPoolExecutor | None = None
_LOAD_CHECKER_LOCK = threading.Lock()


def _load_checker() -> concurrent.futures.ThreadPoolExecutor:
    """One thread, shared by every session, that checks loaded states (:meth:`Scene.check_state`)."""
    global _LOAD_CHECKER
    with _LOAD_CHECKER_LOCK:
        if _LOAD_CHECKER is None:
            _LOAD_CHECKER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="rigidlab-load")
        return _LOAD_CHECKER


class Session:
    """Scenes of one audience (the whole server, or one browser).

    Parameters
    ----------
    target : viser.ViserServer or viser.ClientHandle
        Where nodes and GUI are created.
    scene_classes : dict
        ``{name: SceneClass}`` in display order (from the registry).
    initial_scene : str
        Name of the scene shown first.
    send_notice : callable
        ``send_notice(title, body, level)`` shows a notice to this audience.
    executor : concurrent.futures.Executor, keyword-only
        Background executor for the scenes' long work.
    page_url : str, keyword-only
        Address of the page (for share links).
    presenter : bool, keyword-only
        Start in presenter view.

    Notes
    -----
    Scenes are built lazily, the first time they are shown, so a scene nobody
    opens costs nothing. ``run_lock`` is held while a scene is built, switched
    or updated; ``lock`` only guards the recorded requests.
    """

    def __init__(
        self,
        target: Any,
        scene_classes: dict[str, type[Scene]],
        initial_scene: str,
        send_notice: Callable[[str, str, str], None],
        *,
        client_id: int | None = None,
        executor: concurrent.futures.Executor | None = None,
        page_url: str = "",
        presenter: bool = False,
    ) -> None:
        self.target = target
        self.client_id = client_id
        self.scene_classes = dict(scene_classes)
        self.scenes: dict[str, Scene] = {}
        self.lock = threading.Lock()
        self.run_lock = threading.RLock()
        self.active_name: str | None = None
        self.closed = False
        self.presenter = bool(presenter)
        self.page_url = page_url
        self._owns_executor = executor is None
        self.executor = executor if executor is not None else make_executor()
        self._initial = initial_scene
        self._pending: str | None = None
        self._pending_states: list[tuple[dict[str, Any], str]] = []
        self._loads: list[tuple[Scene, str, dict[str, Any], str, concurrent.futures.Future]] = []
        self._send_notice = send_notice
        self._last_notice: dict[tuple[str, str], float] = {}
        self._notice_lock = threading.Lock()
        self._title_to_name = {
            (cls.title or name): name for name, cls in self.scene_classes.items()
        }
        self._name_to_title = {n: t for t, n in self._title_to_name.items()}
        self.update_counts: dict[str, int] = {name: 0 for name in self.scene_classes}
        #: The latest notices shown to this audience: ``(title, body, level)``.
        self.notices: collections.deque[tuple[str, str, str]] = collections.deque(maxlen=100)
        self._progress: dict[int, Any] | None = None  # client id: show_progress's notice in that browser
        self.gate = Gate.for_gui(target.gui, on_refused=self._on_refused)
        self.controls = ControlPanel(target.gui, self.gate, self.notify_client)
        self._chooser: Any = None
        self._plot_css: Any = None  # presenter view's style sheet (controls, plot titles), an HTML element
        self._redraw_node: Any = None  # an empty hidden frame whose visibility flips to make pages redraw
        self._redraws: list[float] = []  # monotonic times of the coming redraws

    # -- notices ---------------------------------------------------------
    def notify(self, title: str, body: str, level: str = "info") -> None:
        """Show a notice to this session's audience (rate limited per text)."""
        key = (title, body)
        now = time.monotonic()
        with self._notice_lock:
            last = self._last_notice.get(key)
            if last is not None and now - last < _NOTICE_REPEAT_SECONDS:
                return
            self._last_notice[key] = now
            self.notices.append((title, body, level))
        log = _log.warning if level in ("warning", "error") else _log.info
        log("notice [%s] %s: %s", level, title, body)
        try:
            self._send_notice(title, body, level)
        except Exception:  # a vanished client must not break the caller
            _log.debug("could not deliver notice", exc_info=True)

    def show_progress(self, title: str, body: str) -> None:
        """Show a notice with a spinner that stays until :meth:`end_progress` (loop thread); browsers that join
        meanwhile get it at the next call. Recorded in :attr:`notices` once."""
        clients = (self.target.get_clients() if isinstance(self.target, viser.ViserServer)
                   else {self.target.client_id: self.target})
        if self._progress is None:
            self._progress = {}
            with self._notice_lock:
                self.notices.append((title, body, "info"))
            _log.info("notice [progress] %s: %s", title, body)
        for client_id, client in clients.items():
            if client_id in self._progress:
                continue
            try:
                self._progress[client_id] = client.add_notification(title, body, loading=True, color="blue",
                                                                    with_close_button=True)
            except Exception:  # a vanished client must not break the loop
                _log.debug("could not deliver notice", exc_info=True)

    def end_progress(self) -> None:
        """Remove the notice of :meth:`show_progress` (loop thread)."""
        handles, self._progress = self._progress or {}, None
        for handle in handles.values():
            try:
                handle.remove()
            except Exception:
                _log.debug("could not remove notice", exc_info=True)

    @property
    def progress_shown(self) -> bool:
        """Whether a notice of :meth:`show_progress` is up."""
        return self._progress is not None

    def notify_client(self, client: Any, title: str, body: str, level: str = "info") -> None:
        """A notice to the browser ``client`` only (the audience when None)."""
        if client is None or not isinstance(self.target, viser.ViserServer):
            self.notify(title, body, level)
            return
        with self._notice_lock:
            self.notices.append((title, body, level))
        _log.info("notice to client %s [%s] %s: %s", getattr(client, "client_id", "?"), level, title, body)
        try:
            _send_notice(client, title, body, level)
        except Exception:
            _log.debug("could not deliver notice", exc_info=True)

    def _client(self, client_id: int) -> Any:
        if isinstance(self.target, viser.ViserServer):
            return self.target.get_clients().get(client_id)
        return self.target if self.target.client_id == client_id else None

    def _on_refused(self, refused: RefusedValue) -> None:
        # viser's event loop thread: a notice to the sender only
        in_use = refused.in_use
        shown = in_use if isinstance(in_use, str) else json.dumps(in_use) if in_use is not None else ""
        body = f"{refused.reason}." + (f" Keeping {shown}." if shown else "")
        client = self._client(refused.client_id)
        if client is None:
            with self._notice_lock:
                self.notices.append((f"Refused: {refused.label}", body, "warning"))
            return
        self.notify_client(client, f"Refused: {refused.label}", body, "warning")

    def _guard(self, what: str, func: Callable[[], Any]) -> bool:
        """Run ``func``; on an exception log it, show a notice, return False."""
        try:
            func()
        except Exception as exc:
            _log.error("%s failed:\n%s", what, traceback.format_exc())
            self.notify(
                f"Error in {what}",
                f"{type(exc).__name__}: {exc}. The server keeps running.",
                "error",
            )
            return False
        return True

    # -- life cycle -------------------------------------------------------
    def build(self) -> None:
        """Create the scene chooser, presenter switch and Share folder; show the initial scene."""
        with self.run_lock:
            gui = self.target.gui
            titles = tuple(self._title_to_name)
            initial_title = self._name_to_title[self._initial]
            self._chooser = self.controls.add(
                Choice("scene", "Scene", options=titles, default=initial_title, in_state=False),
                order=-1000.0,
            )
            self.controls.add(
                Toggle("presenter", "Presenter view", default=self.presenter, in_state=False,
                       hint="Large labels, thick arrows and large readouts for a projector."),
                order=-999.0,
            )
            self._plot_css = gui.add_html(presenter_css(self.presenter), order=-998.0)
            gui.add_html(_page_script(_SLIDER_BOX_GUARD_JS), order=-997.0)
            if self.presenter:
                self._set_panel_width()
            self._redraw_node = self.target.scene.add_frame("/_rigidlab_redraw", show_axes=False, visible=False)
            with gui.add_folder("Share", order=1e6, expand_by_default=False):
                self.controls.add(Button("copy_state", "Copy state",
                                         hint="The scene's parameters as a short string and a link"))
                self.controls.add(Text("state_out", "State", disabled=True))
                self._share_html = gui.add_html("")
                self.controls.add(Text("state_in", "State to load",
                                       hint="Paste a state string, its JSON or a link, then press Load state"))
                self.controls.add(Button("load_state", "Load state"))
                self.controls.add(Button("download_state", "Download state (JSON)",
                                         hint="A file for rigidlab serve --state FILE"))
            if not self.activate(self._initial):
                raise RuntimeError(f"the initial scene {self._initial!r} could not be built")

    def request_switch(self, name: str) -> None:
        """Record a scene switch; the loop applies it before the next update."""
        if name not in self.scene_classes:
            raise ValueError(
                f"name: expected one of {list(self.scene_classes)}, got {name!r}"
            )
        with self.lock:
            self._pending = name

    def request_state(self, state: dict[str, Any], *, source: str = "a state") -> None:
        """Record a state to load (switching scene if needed) at the next tick."""
        state = state_codec.check(state)
        with self.lock:
            self._pending_states.append((state, source))

    def context(self) -> SceneContext:
        return SceneContext(
            gate=self.gate, executor=self.executor, notify_client=self.notify_client,
            presenter=self.presenter,
        )

    def activate(self, name: str) -> bool:
        """Show scene ``name`` now (building it first if needed); hide the others.

        Returns False (and shows a notice) if the scene could not be built; the
        previous scene then stays active.
        """
        if name not in self.scene_classes:
            raise ValueError(
                f"name: expected one of {list(self.scene_classes)}, got {name!r}"
            )
        with self.run_lock:
            if self.closed:
                return False
            if name == self.active_name:
                return True
            previous = self.active_name
            if name not in self.scenes:
                cls = self.scene_classes[name]
                scene = cls(self.target, self.notify, context=self.context())
                if not self._guard(f"building scene '{name}'", scene.build):
                    self._guard(f"removing scene '{name}'", scene.close)
                    self._set_chooser(previous)
                    return False
                self.scenes[name] = scene
            if previous is not None:
                self._guard(
                    f"hiding scene '{previous}'",
                    lambda: self.scenes[previous].set_active(False),
                )
            scene = self.scenes[name]
            if scene.presenter != self.presenter:
                self._guard(f"presenter view of '{name}'", lambda: scene.set_presenter(self.presenter))
            self._guard(f"showing scene '{name}'", lambda: scene.set_active(True))
            self.active_name = name
            self._set_chooser(name)
            if previous is not None and self.controls.value("state_out"):
                # a copied state is the previous scene's: its string and link would open that scene
                self.controls.set("state_out", "")
                self._share_html.content = ""
            self._guard(f"framing scene '{name}'", lambda: self._frame_camera(name))
            self.redraw_soon()
            return True

    def _frame_camera(self, name: str) -> None:
        """Point the camera(s) at the scene, if it declares a framing."""
        scene = self.scenes.get(name)
        view = scene.camera_view() if scene is not None else None
        position, look_at = view if view is not None else (DEFAULT_CAMERA_POSITION, DEFAULT_CAMERA_LOOK_AT)
        aim_camera(self.target, position, look_at)

    def _set_chooser(self, name: str | None) -> None:
        if self._chooser is None or name is None:
            return
        self.controls.set("scene", self._name_to_title[name])

    def set_presenter(self, on: bool) -> None:
        """Presenter view on or off for every built scene (loop thread)."""
        with self.run_lock:
            self.presenter = bool(on)
            if self._chooser is not None:
                self.controls.set("presenter", self.presenter)
            if self._plot_css is not None:
                self._plot_css.content = presenter_css(self.presenter)
                self._set_panel_width()
            for name, scene in self.scenes.items():
                self._guard(f"presenter view of '{name}'", lambda scene=scene: scene.set_presenter(self.presenter))

    def _set_panel_width(self) -> None:
        """The control panel's width for the view (:data:`PRESENTER_PANEL_PX` in presenter view)."""
        self.target.gui.main_panel.set_width(PRESENTER_PANEL_PX if self.presenter else NORMAL_PANEL_PX)

    def redraw_soon(self) -> None:
        """Ask this audience's pages to draw again at :data:`_REDRAW_AFTER` seconds from now (any thread): a
        page that joined, or a scene just shown, then shows its 3-D labels without waiting for a change."""
        now = time.monotonic()
        with self.lock:
            self._redraws = sorted({*self._redraws, *(now + s for s in _REDRAW_AFTER)})

    def _redraw_due(self) -> None:
        """Flip the hidden redraw node if a redraw is due (loop thread): a visibility change makes viser's
        page compute visibilities again and draw a frame, in which its label renderer builds the glyphs
        of labels it registered since (and asks for further frames until they are drawn)."""
        if not self._redraws or self._redraw_node is None:
            return
        now = time.monotonic()
        with self.lock:
            due = [t for t in self._redraws if t <= now]
            if not due:
                return
            self._redraws = [t for t in self._redraws if t > now]
        self._redraw_node.visible = not self._redraw_node.visible
        scene = self.scenes.get(self.active_name) if self.active_name is not None else None
        if scene is not None:
            scene.nudge_labels()  # (an even number of nudges: the sizes end where they were)

    def active_scene(self) -> Scene | None:
        with self.run_lock:
            return None if self.active_name is None else self.scenes[self.active_name]

    # -- the loop ---------------------------------------------------------------
    def step(self, dt: float) -> None:
        """One loop tick: shell requests, then the active scene's frame."""
        changes = self.controls.take_changes()
        clicks = self.controls.take_clicks()
        if "scene" in changes:
            name = self._title_to_name.get(self.controls.value("scene"))
            if name is not None:
                with self.lock:
                    self._pending = name
        with self.lock:
            pending, self._pending = self._pending, None
            states, self._pending_states = self._pending_states, []
        with self.run_lock:
            if self.closed:
                return
            if "presenter" in changes:
                self.set_presenter(bool(self.controls.value("presenter")))
            if pending is not None and pending != self.active_name:
                self.activate(pending)
            for state, source in states:
                self._load(state, source)
            for key, _, client in clicks:
                self._guard(f"Share: {key.replace('_', ' ')}", lambda key=key, client=client: self._share(key, client))
            self._finish_loads()
            self._guard("redrawing the page", self._redraw_due)
            name = self.active_name
            if name is None:
                return
            scene = self.scenes[name]
            self.update_counts[name] += 1
            try:
                scene.frame(dt)
            except Exception:  # frame contains scene errors; this is a last resort
                _log.error("frame of scene %r failed:\n%s", name, traceback.format_exc())

    def _share(self, key: str, client: Any) -> None:
        scene = self.active_scene()
        if scene is None:
            return
        if key == "copy_state":
            string = state_codec.encode(scene.state())
            self.controls.set("state_out", string)
            link = state_codec.share_link(self._link_base(client), string)
            self._share_html.content = (
                "<div style='padding:0 0.75em 0.5em 0.75em;font-size:0.8em'>"
                + _copy_button("Copy state string", string) + _copy_button("Copy link", link)
                + f"<div style='word-break:break-all;color:#555'>Link (opens {html.escape(scene.title)} "
                f"with these values in a per-client session): <a href=\"{html.escape(link, quote=True)}\" "
                f"target='_blank'>{html.escape(link)}</a></div></div>"
            )
        elif key == "load_state":
            # the text as viser stored it when its message came (in order, before the click's): the panel's
            # copy is set by a callback in viser's thread pool, which a quick click can overtake
            text = self.controls.handles["state_in"].value
            if not isinstance(text, str):
                text = self.controls.value("state_in")
            try:
                state = state_codec.decode(text)
            except state_codec.StateError as exc:
                self.notify_client(client, "Load state", f"{exc}.", "warning")
                return
            self._load(state, "the pasted state", client=client)
        elif key == "download_state":
            content = json.dumps(scene.state(), indent=2).encode()
            target = client if client is not None else self.target
            target.send_file_download(f"{scene.name}_state.json", content, save_immediately=True)

    def _link_base(self, client: Any) -> str:
        """``http://host:port`` as the browser ``client`` reached the server."""
        if client is not None and isinstance(self.target, viser.ViserServer):
            try:
                connection = self.target._websock_server._live_connections.get(client.client_id)
                host = connection.request.headers.get("Host") if connection is not None else None
                if host:
                    return f"http://{host}"
            except Exception:
                _log.debug("no Host header", exc_info=True)
        return self.page_url

    def _load(self, state: dict[str, Any], source: str, *, client: Any = None) -> None:
        name = state.get("scene")
        if name not in self.scene_classes:
            self.notify_client(
                client, "Load state",
                f"state: expected a scene of {list(self.scene_classes)}, got {name!r}.", "warning",
            )
            return
        if name != self.active_name and not self.activate(name):
            return
        scene = self.scenes[name]
        # the check builds the scene's model (a 20-link chain: ~75 ms): off the loop; applied by a later step
        self._loads.append((scene, name, state, source, _load_checker().submit(scene.check_state, state)))

    def _finish_loads(self) -> None:
        """Apply the states whose check (:meth:`_load`) is done (loop thread)."""
        if not self._loads:
            return
        # one look at each future: one that finished between two looks would be in neither list, a load lost
        done, pending = [], []
        for entry in self._loads:
            (done if entry[4].done() else pending).append(entry)
        self._loads = pending
        for scene, name, state, source, future in done:
            self._guard("Load state", lambda: self._apply_load(scene, name, state, source, future))

    def _apply_load(self, scene: Scene, name: str, state: dict[str, Any], source: str,
                    future: concurrent.futures.Future) -> None:
        title = self._name_to_title[name]
        try:
            accepted, refused = future.result()
        except ValueError as exc:  # the values together (nothing was applied)
            self.notify("State not loaded",
                        f"{title}: the values from {source} are refused together: "
                        f"{str(exc).removeprefix('state: ')}. The values in use are kept.", "warning")
            return
        refused = scene.apply_state(state, accepted, refused)
        if refused:
            self.notify(
                "State loaded in part",
                f"{title}: from {source}; refused: " + "; ".join(refused[:6])
                + (" ..." if len(refused) > 6 else "") + ". The other values are in use.",
                "warning",
            )
        else:
            self.notify("State loaded", f"{title}: every value from {source} is in use.", "info")

    def close(self, *, client_gone: bool = False) -> None:
        """Close every built scene (so it can release what it holds) and the shell GUI.

        With ``client_gone`` (the browser already left, its nodes died with
        the connection) failures are only logged: nobody is left to notify.
        """
        with self.run_lock:
            if self.closed:
                return
            self.closed = True
            closers = [(f"closing scene '{n}'", sc.close) for n, sc in self.scenes.items()]
            for key, handle in self.controls.handles.items():
                closers.append((f"removing {key}", handle.remove))
            closers.append(("releasing the shell controls", self.controls.remove_all))
            for what, close in closers:
                if client_gone:
                    try:
                        close()
                    except Exception:
                        _log.debug("%s after the client left failed", what, exc_info=True)
                else:
                    self._guard(what, close)
            self.scenes.clear()
            if self._owns_executor:
                self.executor.shutdown(wait=False, cancel_futures=True)


@dataclasses.dataclass(eq=False)
class RigidlabApp:
    """A running rigidlab server (create it with :func:`create_app`).

    Attributes
    ----------
    server : viser.ViserServer
        The viser server.
    url : str
        Address to open in a browser.
    port : int
        TCP port actually bound.
    mode : str
        ``"shared"`` or ``"per-client"``.
    scene_names : tuple of str
        Registered scenes in display order.
    run_unwatched : bool
        Keep updating the shared scene while no browser is connected (tests
        and notebooks that inspect the scene without a browser). By default
        a shared scene nobody looks at does no work at all.
    presenter : bool
        Sessions start in presenter view.
    initial_state : dict or None
        State every new session starts from (``rigidlab serve --state``).
    """

    server: viser.ViserServer
    url: str
    port: int
    mode: str
    scene_names: tuple[str, ...]
    initial_scene: str
    run_unwatched: bool
    _scene_classes: dict[str, type[Scene]]
    presenter: bool = False
    initial_state: dict[str, Any] | None = None
    executor: concurrent.futures.Executor = dataclasses.field(default_factory=make_executor)
    _shared: Session | None = None
    _sessions: dict[int, Session] = dataclasses.field(default_factory=dict)
    _lock: threading.Lock = dataclasses.field(default_factory=threading.Lock)
    _stop: threading.Event = dataclasses.field(default_factory=threading.Event)
    _thread: threading.Thread | None = None
    _ticks: int = 0
    _switch_interval: float | None = None

    # -- sessions -------------------------------------------------------
    def session_for(self, client_id: int | None = None) -> Session:
        """The shared session, or the session of browser ``client_id``.

        Raises
        ------
        ValueError
            In per-client mode without a ``client_id``.
        KeyError
            If no session exists (yet) for ``client_id``.
        """
        if self.mode == "shared":
            assert self._shared is not None
            return self._shared
        if client_id is None:
            raise ValueError(
                "client_id: expected the id of a connected browser in per-client "
                "mode, got None"
            )
        with self._lock:
            try:
                return self._sessions[client_id]
            except KeyError:
                raise KeyError(f"no session for client_id {client_id}") from None

    def scene_for(self, client_id: int | None = None) -> Scene:
        """Active scene of the shared session, or of browser ``client_id``."""
        session = self.session_for(client_id)
        with session.run_lock:
            assert session.active_name is not None
            return session.scenes[session.active_name]

    def switch_scene(self, name: str, client_id: int | None = None) -> None:
        """Show scene ``name`` (shared session, or browser ``client_id``'s).

        The switch happens before this returns.

        Raises
        ------
        ValueError
            If ``name`` is not a registered scene.
        """
        if name not in self._scene_classes:
            raise ValueError(f"name: expected one of {list(self.scene_names)}, got {name!r}")
        self.session_for(client_id).activate(name)

    def client_ids(self) -> list[int]:
        """Ids of browsers that are ready: registered and (per-client) with a session."""
        if self.mode == "shared":
            return sorted(self.server.get_clients())
        with self._lock:
            return sorted(self._sessions)

    def wait_for_client(self, known: set[int] | frozenset[int] = frozenset(), timeout: float = 20.0) -> int:
        """Block until a browser not in ``known`` is ready; return its id.

        Raises
        ------
        TimeoutError
            If none arrives within ``timeout`` seconds.
        """
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            new = [c for c in self.client_ids() if c not in known]
            if new:
                return new[0]
            time.sleep(0.05)
        raise TimeoutError(f"no new browser registered within {timeout} s")

    def notify_all(self, title: str, body: str, level: str = "info") -> None:
        """Show a notice in every connected browser."""
        for client in self.server.get_clients().values():
            try:
                _send_notice(client, title, body, level)
            except Exception:
                _log.debug("could not deliver notice", exc_info=True)

    # -- loop -------------------------------------------------------------
    def _loop(self) -> None:
        last = time.perf_counter()
        next_tick = last
        while not self._stop.is_set():
            now = time.perf_counter()
            dt = min(now - last, _MAX_DT)
            last = now
            if self._shared is not None:
                # Nothing at all for a scene no client is looking at.
                watched = self.run_unwatched or bool(self.server.get_clients())
                sessions = [self._shared] if watched else []
            else:
                with self._lock:
                    sessions = list(self._sessions.values())
            for session in sessions:
                try:
                    session.step(dt)
                except Exception:  # step guards scenes; this is a last resort
                    _log.error("session step failed:\n%s", traceback.format_exc())
            self._ticks += 1
            if self._ticks % _WARM_CHECK_TICKS == 0:
                self._notice_warm_up(sessions)
            flush = getattr(self.executor, "flush", None)
            if flush is not None:
                flush()  # jobs the frames asked for go to the workers while the loop sleeps
            next_tick += _PERIOD
            delay = next_tick - time.perf_counter()
            if delay < -_PERIOD:  # fell behind: do not try to catch up
                next_tick = time.perf_counter()
                delay = 0.0
            self._stop.wait(max(delay, 0.0))

    def _notice_warm_up(self, sessions: list[Session]) -> None:
        """Show :data:`_WARM_NOTICE` to the audiences whose scene's clock holds for a job while the kernels'
        warm-up runs, and take it down when the clock moves or the warm-up ends (loop thread)."""
        try:
            running = warm_up_running_for()
        except Exception:  # a notice must never stop the loop
            running = None
        for session in sessions:
            try:
                scene = session.active_scene()
                timeline = getattr(scene, "timeline", None)
                # (a scene whose jobs need no kernel goes on during a warm-up: its clock does not hold)
                holds = bool(getattr(scene, "waiting", False) and getattr(timeline, "busy", False))
                if running is not None and running >= _WARM_NOTICE_AFTER and holds:
                    session.show_progress(*_WARM_NOTICE)
                elif session.progress_shown:
                    session.end_progress()
            except Exception:  # (a session closing meanwhile)
                _log.debug("warm-up notice", exc_info=True)

    def _link_state(self, client_id: int) -> dict[str, Any] | None:
        string = state_codec.state_from_path(client_request_path(self.server, client_id))
        if string is None:
            return None
        try:
            return state_codec.decode(string)
        except state_codec.StateError as exc:
            client = self.server.get_clients().get(client_id)
            if client is not None:
                _send_notice(client, "State link", f"{exc}.", "warning")
            return None

    def _on_connect(self, client: viser.ClientHandle) -> None:
        if self._stop.is_set():
            return
        link_state = self._link_state(client.client_id)
        if self.mode != "per-client":
            if self._shared is not None:
                self._shared.redraw_soon()  # the new page's labels (see Session.redraw_soon)
            if link_state is not None:
                _send_notice(
                    client, "State link not applied",
                    "This server runs one shared scene for everyone, so a link does not change it. "
                    "Paste the state into Share > State to load to apply it for everyone.", "info",
                )
            return
        session = Session(
            client,
            self._scene_classes,
            self.initial_scene,
            lambda t, b, lvl: _send_notice(client, t, b, lvl),
            client_id=client.client_id,
            executor=self.executor,
            page_url=self.url,
            presenter=self.presenter,
        )
        ok = session._guard("building the session", session.build)
        if not ok:
            return
        for state, source in ((self.initial_state, "--state"), (link_state, "the link")):
            if state is not None:
                session.request_state(state, source=source)
        with self._lock:
            if self._stop.is_set():
                return
            self._sessions[client.client_id] = session
            count = len(self._sessions)
        _log.info("browser %d connected (%d session%s in this process)", client.client_id, count,
                  "" if count == 1 else "s")
        if client.client_id not in self.server.get_clients():
            # the browser left while its session was built: viser removed it (before its disconnect callback,
            # which found no session to close), so the session would run for nobody
            self._on_disconnect(client)

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            session = self._sessions.pop(client.client_id, None)
            count = len(self._sessions)
        if session is not None:
            session.close(client_gone=True)
            _log.info("browser %d left (%d session%s in this process)", client.client_id, count,
                      "" if count == 1 else "s")

    def stop(self) -> None:
        """Stop the loop, close the scenes and stop the viser server."""
        if self._stop.is_set():
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        with self._lock:
            sessions = list(self._sessions.values())
            self._sessions.clear()
        for session in sessions:
            session.close(client_gone=True)
        if self._shared is not None:
            self._shared.close()
        self.executor.shutdown(wait=False, cancel_futures=True)
        self.server.stop()
        if self._switch_interval is not None:
            import sys

            sys.setswitchinterval(self._switch_interval)


#: Largest camera coordinate accepted from a browser (m); the scenes are a few metres across.
CAMERA_LIMIT = 1e6
#: A browser's dropped camera messages are logged at most this often (s).
_CAMERA_LOG_SECONDS = 10.0


def page_url(host: str, port: int) -> str:
    """The address browsers open for a server bound to ``host``: a wildcard (``0.0.0.0``, ``::``) shows
    127.0.0.1, and an IPv6 address goes in brackets (``http://[::1]:8080``, RFC 3986)."""
    shown = "127.0.0.1" if host in ("0.0.0.0", "", "::") else host
    if ":" in shown and not shown.startswith("["):
        shown = f"[{shown}]"
    return f"http://{shown}:{port}"


def camera_refusal(message: Any) -> str | None:
    """Why a browser's ``ViewerCameraMessage`` is refused, or None.

    viser stores the camera a browser reports as it comes; a NaN, an infinity,
    a zero quaternion or up vector, or a look-at point on the camera then made
    viser's camera setters raise (``Camera look_at must be finite``) when a
    scene aimed the camera, a traceback in the log per hostile message.
    """
    def vector(name: str, size: int, limit: float = CAMERA_LIMIT) -> tuple[float, ...]:
        value = getattr(message, name)
        if (not isinstance(value, (tuple, list)) or len(value) != size
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)):
            raise ValueError(f"{name}: expected {size} numbers, got {value!r:.60}")
        if not all(math.isfinite(x) and abs(x) <= limit for x in value):
            raise ValueError(f"{name}: expected {size} finite numbers of at most {limit:g}, got {value!r:.60}")
        return tuple(float(x) for x in value)

    def number(name: str, lo: float, hi: float) -> float:
        value = getattr(message, name)
        if (not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value)
                or not lo <= value <= hi):
            raise ValueError(f"{name}: expected a number from {lo:g} to {hi:g}, got {value!r:.60}")
        return float(value)

    try:
        wxyz = vector("wxyz", 4, 2.0)
        if not 0.5 < math.sqrt(sum(x * x for x in wxyz)) < 2.0:
            raise ValueError(f"wxyz: expected a unit quaternion, got {wxyz}")
        position = vector("position", 3)
        look_at = vector("look_at", 3)
        up = vector("up_direction", 3)
        if position == look_at:
            raise ValueError("look_at: expected a point other than the camera position, got the position")
        if not any(up):
            raise ValueError("up_direction: expected a nonzero vector, got (0, 0, 0)")
        number("fov", 1e-6, math.pi)
        near = number("near", 0.0, CAMERA_LIMIT)
        number("far", near, 1e12)
        number("image_height", 0, 100_000)
        number("image_width", 0, 100_000)
    except ValueError as exc:
        return str(exc)
    return None


def _guard_camera_messages(server: viser.ViserServer) -> None:
    """Put :func:`camera_refusal` in front of viser's camera handler of every connection: a refused camera
    message is dropped (never stored, so it never reaches a scene's camera) with one log line."""
    from viser import _messages

    def on_connection(conn: Any) -> None:
        handlers = conn._incoming_handlers.get(_messages.ViewerCameraMessage, [])
        last_log = [-math.inf, 0]  # (time, drops since)

        def guarded(viser_handler: Callable[..., Any]) -> Callable[..., Any]:
            async def handle(client_id: int, message: Any) -> None:
                reason = camera_refusal(message)
                if reason is None:
                    result = viser_handler(client_id, message)
                    if inspect.isawaitable(result):
                        await result
                    return
                now = time.monotonic()
                last_log[1] += 1
                if now - last_log[0] >= _CAMERA_LOG_SECONDS:
                    _log.warning("browser %d: camera message dropped (%s)%s", client_id, reason,
                                 f"; {last_log[1] - 1} more dropped since the last report" if last_log[1] > 1 else "")
                    last_log[0], last_log[1] = now, 0
            return handle

        handlers[:] = [guarded(h) for h in handlers]

    server._websock_server.on_client_connect(on_connection)


def _drop_undecodable_messages() -> None:
    """Make viser's websocket reader drop a message it cannot decode, with one log line (idempotent).

    viser 1.1.1's ``_message_consumer`` decodes each client message into its
    typed dataclass (``float("abc")`` for a camera's look-at, a text frame, an
    unknown type); the exception ended the connection with a traceback in the
    log (websockets' "connection handler failed"). The replacement keeps the
    connection and logs one line per connection at most every 10 s.
    """
    from viser.infra import _infra

    if getattr(_infra._message_consumer, "rigidlab_guarded", False):
        return

    async def _message_consumer(websocket: Any, handle_message: Callable[[Any], None], message_class: Any) -> None:
        last_log, dropped = -math.inf, 0
        while True:
            raw = await websocket.recv()
            try:
                if not isinstance(raw, bytes):
                    raise ValueError("a text frame, expected binary msgpack")
                message = message_class.deserialize(raw)
            except Exception as exc:  # a hostile or broken client: its message only
                dropped += 1
                now = time.monotonic()
                if now - last_log >= _CAMERA_LOG_SECONDS:
                    _log.warning("connection %s: undecodable message dropped (%s: %.120s)%s",
                                 getattr(websocket, "id", "?"), type(exc).__name__, exc,
                                 f"; {dropped - 1} more dropped since the last report" if dropped > 1 else "")
                    last_log, dropped = now, 0
                continue
            handle_message(message)

    _message_consumer.rigidlab_guarded = True  # type: ignore[attr-defined]
    _infra._message_consumer = _message_consumer


@contextlib.contextmanager
def _listening_on(sock: socket.socket) -> Iterator[None]:
    """While inside, a viser server started in this process serves on the listening socket ``sock``.

    viser 1.1.1 starts ``websockets.asyncio.server.serve(handler, host,
    port, ...)`` without a way to pass a socket; ``serve`` forwards extra
    keywords to ``loop.create_server``, so a subclass that passes ``sock``
    instead of the host and port stands in for it while the
    ``ViserServer`` starts (its constructor returns once it serves). The
    per-client workers of :mod:`rigidlab.app.supervisor` serve on their slot's socket.
    """
    import websockets.asyncio.server as ws_server

    original = ws_server.serve

    class serve(original):  # type: ignore[misc, valid-type]
        def __init__(self, handler: Any, host: Any = None, port: Any = None, **kwargs: Any) -> None:
            super().__init__(handler, sock=sock, **kwargs)

    ws_server.serve = serve
    try:
        yield
    finally:
        ws_server.serve = original


def create_app(
    *,
    host: str = "127.0.0.1",
    port: int = 0,
    scene: str | None = None,
    mode: Mode = "shared",
    scene_classes: dict[str, type[Scene]] | None = None,
    run_unwatched: bool = False,
    presenter: bool = False,
    state: dict[str, Any] | None = None,
    sock: socket.socket | None = None,
    executor: concurrent.futures.Executor | None = None,
) -> RigidlabApp:
    """Start a viser server with every registered scene and the session loop.

    Parameters
    ----------
    host : str
        Interface to bind; loopback by default (``"0.0.0.0"`` serves a LAN).
    port : int
        TCP port; 0 picks a free one (read it back from ``app.port``).
    scene : str or None
        Name of the scene shown first; default the first registered one (or
        the scene of ``state``).
    mode : {"shared", "per-client"}
        One state for every browser, or one per browser.
    scene_classes : dict or None
        ``{name: SceneClass}`` to serve instead of the registry (tests, or an
        app serving a subset of scenes).
    run_unwatched : bool
        Shared mode only: keep updating the scene while no browser is
        connected. Default False: with nobody watching, the loop does nothing.
    presenter : bool
        Start in presenter view (large labels, thick arrows, large readouts).
    state : dict or None
        A scene state (:mod:`rigidlab.app.state`) every session starts from.
    sock : socket.socket or None
        Serve on this listening socket instead of binding ``host:port``
        (the app owns it from then on): the per-client workers of
        :mod:`rigidlab.app.supervisor`, whose sockets share one port with
        ``SO_REUSEPORT``.
    executor : concurrent.futures.Executor or None
        The background executor, made beforehand with
        ``rigidlab.app.jobs.make_executor(processes=True, preload=...)`` (a spare
        worker of :mod:`rigidlab.app.supervisor` starts its process pool before it is
        needed); the app owns it and shuts it down. Default: made here.

    Returns
    -------
    RigidlabApp
        The running app; call ``stop()`` when done.

    Raises
    ------
    ValueError
        For an unknown ``mode`` or ``scene``, a ``state`` of an unknown
        scene, or when no scene is registered.
    """
    import sys

    if mode not in MODES:
        raise ValueError(f"mode: expected one of {list(MODES)}, got {mode!r}")
    if scene_classes is None:
        scene_classes = discover_scenes()
    if not scene_classes:
        raise ValueError(
            f"no scene is registered (import errors: {discovery_errors() or 'none'})"
        )
    if state is not None:
        state = state_codec.check(state)
        if state["scene"] not in scene_classes:
            raise ValueError(f"state: expected a scene of {list(scene_classes)}, got {state['scene']!r}")
        if scene is None:
            scene = state["scene"]
    if scene is None:
        scene = next(iter(scene_classes))
    elif scene not in scene_classes:
        raise ValueError(f"scene: expected one of {list(scene_classes)}, got {scene!r}")

    _drop_undecodable_messages()
    if executor is None:
        executor = make_executor(processes=True, preload=[cls.__module__ for cls in scene_classes.values()])
    install_loop_events()  # the loop thread's writes wake viser's event loop thread-safely (app/loop_thread.py)
    try:
        with _listening_on(sock) if sock is not None else contextlib.nullcontext():
            server = viser.ViserServer(host=host, port=port, label="rigidlab", verbose=False)
    except BaseException:
        executor.shutdown(wait=False, cancel_futures=True)
        raise
    try:
        server.gui.configure_theme(control_width="large", show_share_button=False)
        _guard_camera_messages(server)
        bound = server.get_port()
        app = RigidlabApp(
            server=server,
            url=page_url(host, bound),
            port=bound,
            mode=mode,
            scene_names=tuple(scene_classes),
            initial_scene=scene,
            run_unwatched=run_unwatched,
            _scene_classes=scene_classes,
            presenter=presenter,
            initial_state=state,
            executor=executor,
        )
        app._switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(min(SWITCH_INTERVAL, app._switch_interval))
        server.on_client_connect(app._on_connect)
        if mode == "shared":
            session = Session(
                server, scene_classes, scene, app.notify_all, client_id=None,
                executor=app.executor, page_url=app.url, presenter=presenter,
            )
            if not session._guard("building the session", session.build):
                raise RuntimeError(f"the initial scene {scene!r} could not be built")
            if state is not None:
                session.request_state(state, source="--state")
            app._shared = session
        else:
            server.on_client_disconnect(app._on_disconnect)
        app._thread = threading.Thread(target=app._loop, name="rigidlab-loop", daemon=True)
        app._thread.start()
    except BaseException:
        server.stop()
        executor.shutdown(wait=False, cancel_futures=True)
        raise
    return app
