"""Fixtures for app tests: a real rigidlab server on a free loopback port.

``running_app`` starts rigidlab apps, ``running_scene`` an app showing one
timed scene that has started moving, ``ws_client`` connects plain websocket
clients to an app, ``per_client_scenes`` a per-client app with several
clients, and ``server`` is a bare ``viser.ViserServer`` for tests that build
and update a scene themselves.
"""

from __future__ import annotations

import concurrent.futures
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import viser

from rigidlab.app.gate import Gate
from rigidlab.app.scenes.base import Scene, SceneContext
from rigidlab.app.server import RigidlabApp, create_app
from rigidlab.app.wire import SUBPROTOCOL, camera_message, gui_value_message
from tests.helpers import wait_until


@pytest.fixture
def running_app() -> Iterator[Callable[..., RigidlabApp]]:
    """Factory ``running_app(scene="sandbox", mode="shared", run_unwatched=True, scene_classes=None) -> RigidlabApp``.

    Each call starts a server on 127.0.0.1 with a free port (port 0); every
    app started through the factory is stopped at teardown. Tests inspect
    scenes without a browser, so the shared scene runs unwatched unless a
    test asks for the default (``run_unwatched=False``).
    """
    apps: list[RigidlabApp] = []

    def start(
        scene: str | None = "sandbox", mode: str = "shared", run_unwatched: bool = True,
        scene_classes: dict[str, type[Scene]] | None = None,
    ) -> RigidlabApp:
        app = create_app(
            host="127.0.0.1", port=0, scene=scene, mode=mode, run_unwatched=run_unwatched,
            scene_classes=scene_classes,
        )
        apps.append(app)
        return app

    yield start
    for app in reversed(apps):
        app.stop()


@pytest.fixture
def running_scene(running_app: Callable[..., RigidlabApp]) -> Callable[[type[Scene]], tuple[RigidlabApp, Any]]:
    """Factory ``running_scene(SceneClass) -> (app, scene)`` for a scene with a
    simulated clock (``sim_time``): a shared-mode app showing it, returned once
    the session loop has run it for 0.1 s of simulated time."""

    def start(scene_class: type[Scene]) -> tuple[RigidlabApp, Any]:
        app = running_app(scene=scene_class.name)
        scene = app.scene_for()
        assert isinstance(scene, scene_class)
        wait_until(lambda: scene.sim_time > 0.1)
        return app, scene

    return start


@pytest.fixture(scope="module")
def server() -> Iterator[viser.ViserServer]:
    """A bare ``viser.ViserServer`` on a free loopback port (no rigidlab session)."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server
    server.stop()


class WsClient:
    """A plain websocket client that speaks viser's protocol (no browser).

    It asks for the ``viser-v<version>`` subprotocol, sends one camera message
    (a client is registered only after its first camera message), drains every
    server frame in a background thread, and can send GUI updates exactly as
    the browser does (``GuiUpdateMessage`` with the element's uuid).
    """

    def __init__(self, url: str) -> None:
        import asyncio
        import threading

        self.url = url.replace("http://", "ws://")
        self.frames = 0
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._ws: object | None = None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout=20.0):
            raise TimeoutError(f"could not connect to {self.url}")

    def _run(self) -> None:
        import asyncio

        asyncio.set_event_loop(self._loop)
        self._loop.run_until_complete(self._main())

    async def _main(self) -> None:
        import websockets

        try:
            async with websockets.connect(self.url, subprotocols=[SUBPROTOCOL], max_size=None) as ws:
                self._ws = ws
                await ws.send(camera_message())
                self._ready.set()
                async for _ in ws:
                    self.frames += 1
        except Exception:  # closed by close() or by the server stopping
            pass
        finally:
            self._ready.set()

    def send(self, payload: bytes) -> None:
        """Send one packed client message (see :mod:`rigidlab.app.wire`)."""
        import asyncio

        future = asyncio.run_coroutine_threadsafe(self._ws.send(payload), self._loop)  # type: ignore[attr-defined]
        future.result(timeout=10.0)

    def set_gui_value(self, handle: object, value: object) -> None:
        """Change a GUI input as the browser would (``handle`` is the server's handle)."""
        self.send(gui_value_message(handle._impl.uuid, value))  # type: ignore[attr-defined]

    def close(self) -> None:
        import asyncio

        if self._ws is not None and self._thread.is_alive():
            asyncio.run_coroutine_threadsafe(self._ws.close(), self._loop)  # type: ignore[attr-defined]
        self._thread.join(timeout=10.0)


@pytest.fixture
def ws_client() -> Iterator[Callable[[RigidlabApp], tuple[WsClient, int]]]:
    """Factory ``ws_client(app) -> (client, client_id)``: a registered plain
    websocket client (and, in per-client mode, its session is ready)."""
    clients: list[WsClient] = []

    def connect(app: RigidlabApp) -> tuple[WsClient, int]:
        known = set(app.client_ids())
        client = WsClient(app.url)
        clients.append(client)
        return client, app.wait_for_client(known, timeout=20.0)

    yield connect
    for client in clients:
        client.close()


@pytest.fixture
def per_client_scenes(
    running_app: Callable[..., RigidlabApp], ws_client: Callable[[RigidlabApp], tuple[WsClient, int]]
) -> Callable[..., tuple[RigidlabApp, list[tuple[WsClient, Any]]]]:
    """Factory ``per_client_scenes(SceneClass, n=2) -> (app, [(client, scene), ...])``:
    an app in per-client mode showing ``SceneClass`` and ``n`` registered
    websocket clients, each with its own instance of the scene."""

    def start(scene_class: type[Scene], n: int = 2) -> tuple[RigidlabApp, list[tuple[WsClient, Any]]]:
        app = running_app(scene=scene_class.name, mode="per-client")
        pairs = []
        for _ in range(n):
            client, client_id = ws_client(app)
            pairs.append((client, app.scene_for(client_id)))
        scenes = [scene for _, scene in pairs]
        assert all(isinstance(scene, scene_class) for scene in scenes)
        assert len({id(scene) for scene in scenes}) == n  # one scene per browser
        return app, pairs

    return start


class GatedExecutor(concurrent.futures.Executor):
    """Runs jobs on one thread, but only while ``open`` is set (tests that hold
    a scene's background work back to see what the loop does meanwhile)."""

    def __init__(self) -> None:
        self.open = threading.Event()
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=1)

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[no-untyped-def]
        def gated():  # type: ignore[no-untyped-def]
            self.open.wait()
            return fn(*args, **kwargs)

        return self._pool.submit(gated)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self.open.set()
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)


@pytest.fixture
def make_bare_scene(server: viser.ViserServer) -> Iterator[Callable[..., tuple[Any, list[Any]]]]:
    """Factory ``make_bare_scene(SceneClass, executor=None) -> (scene, notices)``: a
    scene built and shown on the module's bare server, driven frame by frame by
    the test (``scene.frame(dt)``), with its own executor (a thread by default)."""
    made: list[Any] = []

    def make(scene_class: type[Scene], executor: Any = None) -> tuple[Any, list[Any]]:
        notices: list[Any] = []
        executor = executor or concurrent.futures.ThreadPoolExecutor(max_workers=1)
        context = SceneContext(gate=Gate.for_gui(server.gui), executor=executor,
                               notify_client=lambda client, *n: notices.append(n), owns_executor=True)
        scene = scene_class(server, lambda *n: notices.append(n), context=context)
        scene.build()
        scene.set_active(True)
        made.append(scene)
        return scene, notices

    yield make
    for scene in made:
        scene.close()
