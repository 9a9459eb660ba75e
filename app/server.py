"""The app shell: a viser server, scene sessions and the loop that drives them.

Two modes:

``shared``
    One :class:`Session` built on the :class:`viser.ViserServer` itself: every
    browser sees the same scene state (the instructor drives, the class
    watches). Notices go to every connected browser.
``per-client``
    One :class:`Session` per browser, built on its :class:`viser.ClientHandle`
    when the client registers and torn down when it leaves; state is isolated
    between browsers.

The pattern is the one of viser's SMPL demo: GUI callbacks (run by viser in a
thread pool) only record what changed, under a lock; one loop thread at about
60 Hz visits every session, applies a requested scene switch and calls the
active scene's ``update(dt)``, which assigns poses inside ``atomic()``. Hidden
scenes are never updated. Any exception raised by a scene is caught, logged and
shown as a notice; the server keeps serving.
"""

from __future__ import annotations

import collections
import dataclasses
import logging
import threading
import time
import traceback
from collections.abc import Callable
from typing import Any, Literal

import viser

from app.scenes import discover_scenes, discovery_errors
from app.scenes.base import Scene

__all__ = ["RigidlabApp", "Session", "create_app", "MODES"]

_log = logging.getLogger(__name__)

MODES = ("shared", "per-client")
Mode = Literal["shared", "per-client"]

#: Notice colours by level (Mantine colour names understood by viser).
_LEVEL_COLORS = {"info": "blue", "warning": "yellow", "error": "red"}
#: Seconds before a notice closes on its own, by level.
_LEVEL_SECONDS = {"info": 6.0, "warning": 10.0, "error": 15.0}
#: The same notice is not repeated more often than this (seconds).
_NOTICE_REPEAT_SECONDS = 5.0
#: Loop period (about 60 Hz) and the largest dt handed to a scene (s).
_PERIOD = 1.0 / 60.0
#: View for scenes that do not declare ``camera_position`` / ``camera_look_at``.
DEFAULT_CAMERA_POSITION = (3.2, -4.2, 2.6)
DEFAULT_CAMERA_LOOK_AT = (0.0, 0.0, 0.3)
_MAX_DT = 0.1


def _send_notice(client: Any, title: str, body: str, level: str) -> None:
    """Show one notice in one browser (``client`` is a ``viser.ClientHandle``)."""
    client.add_notification(
        title,
        body,
        auto_close_seconds=_LEVEL_SECONDS.get(level, 8.0),
        color=_LEVEL_COLORS.get(level, "blue"),
        with_close_button=True,
    )


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

    Notes
    -----
    Scenes are built lazily, the first time they are shown, so a scene nobody
    opens costs nothing. ``run_lock`` is held while a scene is built, switched
    or updated; ``lock`` only guards the recorded (pending) scene switch.
    """

    def __init__(
        self,
        target: Any,
        scene_classes: dict[str, type[Scene]],
        initial_scene: str,
        send_notice: Callable[[str, str, str], None],
        *,
        client_id: int | None = None,
    ) -> None:
        self.target = target
        self.client_id = client_id
        self.scene_classes = dict(scene_classes)
        self.scenes: dict[str, Scene] = {}
        self.lock = threading.Lock()
        self.run_lock = threading.RLock()
        self.active_name: str | None = None
        self.closed = False
        self._initial = initial_scene
        self._pending: str | None = None
        self._send_notice = send_notice
        self._last_notice: dict[tuple[str, str], float] = {}
        self._notice_lock = threading.Lock()
        self._chooser: Any = None
        self._title_to_name = {
            (cls.title or name): name for name, cls in self.scene_classes.items()
        }
        self._name_to_title = {n: t for t, n in self._title_to_name.items()}
        self.update_counts: dict[str, int] = {name: 0 for name in self.scene_classes}
        #: The latest notices shown to this audience: ``(title, body, level)``.
        self.notices: collections.deque[tuple[str, str, str]] = collections.deque(maxlen=100)

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
        """Create the scene chooser and show the initial scene."""
        with self.run_lock:
            titles = list(self._title_to_name)
            initial_title = self._name_to_title[self._initial]
            self._chooser = self.target.gui.add_dropdown(
                "Scene", options=titles, initial_value=initial_title, order=-1000.0
            )
            self._chooser.on_update(self._on_chooser)
            if not self.activate(self._initial):
                raise RuntimeError(f"the initial scene {self._initial!r} could not be built")

    def _on_chooser(self, event: Any) -> None:
        # GUI thread pool: only record the request; the loop applies it.
        name = self._title_to_name.get(event.target.value)
        if name is not None:
            with self.lock:
                self._pending = name

    def request_switch(self, name: str) -> None:
        """Record a scene switch; the loop applies it before the next update."""
        if name not in self.scene_classes:
            raise ValueError(
                f"name: expected one of {list(self.scene_classes)}, got {name!r}"
            )
        with self.lock:
            self._pending = name

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
                scene = cls(self.target, self.notify)
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
            self._guard(f"showing scene '{name}'", lambda: self.scenes[name].set_active(True))
            self.active_name = name
            self._set_chooser(name)
            self._guard(f"framing scene '{name}'", lambda: self._frame_camera(name))
            return True

    def _frame_camera(self, name: str) -> None:
        """Point the camera(s) at the scene, if it declares a framing.

        A scene may set the optional class attributes ``camera_position`` and
        ``camera_look_at`` (global frame, metres); scenes without them get the
        app's default view.
        """
        cls = self.scene_classes[name]
        position = getattr(cls, "camera_position", None) or DEFAULT_CAMERA_POSITION
        look_at = getattr(cls, "camera_look_at", None) or DEFAULT_CAMERA_LOOK_AT
        if isinstance(self.target, viser.ViserServer):
            self.target.initial_camera.position = position
            self.target.initial_camera.look_at = look_at
            clients = list(self.target.get_clients().values())
        else:
            clients = [self.target]
        for client in clients:
            with client.atomic():
                client.camera.position = position
                client.camera.look_at = look_at

    def _set_chooser(self, name: str | None) -> None:
        if self._chooser is None or name is None:
            return
        title = self._name_to_title[name]
        if self._chooser.value != title:
            # Assigning fires _on_chooser synchronously; it records the same
            # name, which the loop then sees as already active.
            self._chooser.value = title

    def step(self, dt: float) -> None:
        """One loop tick: apply a recorded switch, then update the active scene."""
        with self.lock:
            pending, self._pending = self._pending, None
        with self.run_lock:
            if self.closed:
                return
            if pending is not None and pending != self.active_name:
                self.activate(pending)
            name = self.active_name
            if name is None:
                return
            scene = self.scenes[name]
            self.update_counts[name] += 1
            self._guard(f"scene '{name}'", lambda: scene.update(dt))

    def close(self, *, client_gone: bool = False) -> None:
        """Close every built scene (so it can release what it holds) and the chooser.

        With ``client_gone`` (the browser already left, its nodes died with
        the connection) failures are only logged: nobody is left to notify.
        """
        with self.run_lock:
            if self.closed:
                return
            self.closed = True
            closers = [(f"closing scene '{n}'", sc.close) for n, sc in self.scenes.items()]
            if self._chooser is not None:
                closers.append(("removing the scene chooser", self._chooser.remove))
            for what, close in closers:
                if client_gone:
                    try:
                        close()
                    except Exception:
                        _log.debug("%s after the client left failed", what, exc_info=True)
                else:
                    self._guard(what, close)
            self.scenes.clear()


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
    """

    server: viser.ViserServer
    url: str
    port: int
    mode: str
    scene_names: tuple[str, ...]
    initial_scene: str
    run_unwatched: bool
    _scene_classes: dict[str, type[Scene]]
    _shared: Session | None = None
    _sessions: dict[int, Session] = dataclasses.field(default_factory=dict)
    _lock: threading.Lock = dataclasses.field(default_factory=threading.Lock)
    _stop: threading.Event = dataclasses.field(default_factory=threading.Event)
    _thread: threading.Thread | None = None
    _ticks: int = 0

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
            next_tick += _PERIOD
            delay = next_tick - time.perf_counter()
            if delay < -_PERIOD:  # fell behind: do not try to catch up
                next_tick = time.perf_counter()
                delay = 0.0
            self._stop.wait(max(delay, 0.0))

    def _on_connect(self, client: viser.ClientHandle) -> None:
        if self.mode != "per-client" or self._stop.is_set():
            return
        session = Session(
            client,
            self._scene_classes,
            self.initial_scene,
            lambda t, b, lvl: _send_notice(client, t, b, lvl),
            client_id=client.client_id,
        )
        ok = session._guard("building the session", session.build)
        if not ok:
            return
        with self._lock:
            if self._stop.is_set():
                return
            self._sessions[client.client_id] = session

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            session = self._sessions.pop(client.client_id, None)
        if session is not None:
            session.close(client_gone=True)

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
        self.server.stop()


def create_app(
    *,
    host: str = "127.0.0.1",
    port: int = 0,
    scene: str | None = None,
    mode: Mode = "shared",
    scene_classes: dict[str, type[Scene]] | None = None,
    run_unwatched: bool = False,
) -> RigidlabApp:
    """Start a viser server with every registered scene and the session loop.

    Parameters
    ----------
    host : str
        Interface to bind; loopback by default (``"0.0.0.0"`` serves a LAN).
    port : int
        TCP port; 0 picks a free one (read it back from ``app.port``).
    scene : str or None
        Name of the scene shown first; default the first registered one.
    mode : {"shared", "per-client"}
        One state for every browser, or one per browser.
    scene_classes : dict or None
        ``{name: SceneClass}`` to serve instead of the registry (tests, or an
        app serving a subset of scenes).
    run_unwatched : bool
        Shared mode only: keep updating the scene while no browser is
        connected. Default False: with nobody watching, the loop does nothing.

    Returns
    -------
    RigidlabApp
        The running app; call ``stop()`` when done.

    Raises
    ------
    ValueError
        For an unknown ``mode`` or ``scene``, or when no scene is registered.
    """
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {list(MODES)}, got {mode!r}")
    if scene_classes is None:
        scene_classes = discover_scenes()
    if not scene_classes:
        raise ValueError(
            f"no scene is registered (import errors: {discovery_errors() or 'none'})"
        )
    if scene is None:
        scene = next(iter(scene_classes))
    elif scene not in scene_classes:
        raise ValueError(f"scene: expected one of {list(scene_classes)}, got {scene!r}")

    server = viser.ViserServer(host=host, port=port, label="rigidlab", verbose=False)
    try:
        server.gui.configure_theme(control_width="large", show_share_button=False)
        bound = server.get_port()
        shown_host = "127.0.0.1" if host in ("0.0.0.0", "", "::") else host
        app = RigidlabApp(
            server=server,
            url=f"http://{shown_host}:{bound}",
            port=bound,
            mode=mode,
            scene_names=tuple(scene_classes),
            initial_scene=scene,
            run_unwatched=run_unwatched,
            _scene_classes=scene_classes,
        )
        if mode == "shared":
            session = Session(
                server, scene_classes, scene, app.notify_all, client_id=None
            )
            if not session._guard("building the session", session.build):
                raise RuntimeError(f"the initial scene {scene!r} could not be built")
            app._shared = session
        else:
            server.on_client_connect(app._on_connect)
            server.on_client_disconnect(app._on_disconnect)
        app._thread = threading.Thread(target=app._loop, name="rigidlab-loop", daemon=True)
        app._thread.start()
    except BaseException:
        server.stop()
        raise
    return app
