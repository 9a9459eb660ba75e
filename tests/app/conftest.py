"""Fixtures for app tests: a real rigidlab server on a free loopback port."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from app.server import RigidlabApp, create_app


@pytest.fixture
def running_app() -> Iterator[Callable[..., RigidlabApp]]:
    """Factory ``running_app(scene="sandbox", mode="shared") -> RigidlabApp``.

    Each call starts a server on 127.0.0.1 with a free port (port 0); every
    app started through the factory is stopped at teardown.
    """
    apps: list[RigidlabApp] = []

    def start(scene: str | None = "sandbox", mode: str = "shared") -> RigidlabApp:
        app = create_app(host="127.0.0.1", port=0, scene=scene, mode=mode)
        apps.append(app)
        return app

    yield start
    for app in reversed(apps):
        app.stop()


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
        import viser
        import websockets

        try:
            async with websockets.connect(
                self.url, subprotocols=[f"viser-v{viser.__version__}"], max_size=None
            ) as ws:
                self._ws = ws
                await self._send_now(
                    {
                        "type": "ViewerCameraMessage",
                        "wxyz": (1.0, 0.0, 0.0, 0.0),
                        "position": (3.0, -4.0, 2.5),
                        "fov": 0.9,
                        "near": 0.01,
                        "far": 1000.0,
                        "image_height": 750,
                        "image_width": 1200,
                        "look_at": (0.0, 0.0, 0.0),
                        "up_direction": (0.0, 0.0, 1.0),
                    }
                )
                self._ready.set()
                async for _ in ws:
                    self.frames += 1
        except Exception:  # closed by close() or by the server stopping
            pass
        finally:
            self._ready.set()

    async def _send_now(self, message: dict) -> None:
        import msgpack

        await self._ws.send(msgpack.packb(message, use_bin_type=True))  # type: ignore[attr-defined]

    def send(self, message: dict) -> None:
        """Send one msgpack message (a dict with a ``type`` key)."""
        import asyncio

        future = asyncio.run_coroutine_threadsafe(self._send_now(message), self._loop)
        future.result(timeout=10.0)

    def set_gui_value(self, handle: object, value: object) -> None:
        """Change a GUI input as the browser would (``handle`` is the server's handle)."""
        uuid = handle._impl.uuid  # type: ignore[attr-defined]
        self.send({"type": "GuiUpdateMessage", "uuid": uuid, "updates": {"value": value}})

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
