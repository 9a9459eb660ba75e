"""What a browser receives: a plain websocket client that decodes every server frame.

:class:`Recorder` connects to a viser server as a browser would (see
:mod:`rigidlab.app.wire`), decodes each frame (``[u64 inner size][u64 compressed
size]`` + zstd msgpack + 8-byte aligned raw buffers, viser 1.1.1's
``_message_producer``) with its numpy buffers put back in place, and keeps
every message in arrival order. :meth:`Recorder.nodes` replays the scene
messages into the state of each node the page would hold (its props, with
updates applied, and its visibility).
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any

import msgpack
import numpy as np
import zstandard

from rigidlab.app.wire import SUBPROTOCOL, camera_message, frame_payload


def decode_frame(frame: bytes, decompressor: zstandard.ZstdDecompressor) -> list[tuple[dict[str, Any], int]]:
    """The messages of one server frame, arrays restored, each with its size on the wire
    (its own msgpack bytes before compression plus its binary buffers)."""
    payload, compressed_size = frame_payload(frame, decompressor)
    buffers = []
    offset = 16 + compressed_size
    for length in payload.get("binaryBufferLengths", ()):
        offset += (8 - offset % 8) % 8
        buffers.append(frame[offset:offset + length])
        offset += length

    def restore(value: Any) -> tuple[Any, int]:
        if isinstance(value, dict):
            if "__binary_index" in value and "dtype" in value:
                data = buffers[value["__binary_index"]]
                return np.frombuffer(data, dtype=np.dtype(value["dtype"])), len(data)
            out, size = {}, 0
            for k, v in value.items():
                out[k], n = restore(v)
                size += n
            return out, size
        if isinstance(value, list):
            pairs = [restore(v) for v in value]
            return [p[0] for p in pairs], sum(p[1] for p in pairs)
        return value, 0

    out = []
    for message in payload["messages"]:
        own = len(msgpack.packb(message, use_bin_type=True))
        restored, binary = restore(message)
        out.append((restored, own + binary))
    return out


class Recorder:
    """A headless browser on ``url`` (``http://`` or ``ws://``) recording every message it receives."""

    def __init__(self, url: str) -> None:
        self.url = url.replace("http://", "ws://")
        self.messages: list[tuple[dict[str, Any], int]] = []
        self.replay_done = threading.Event()
        self._lock = threading.Lock()
        self._loop = asyncio.new_event_loop()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._loop.run_until_complete, args=(self._main(),), daemon=True)
        self._thread.start()
        if not self.replay_done.wait(timeout=20.0):
            raise TimeoutError(f"no replay from {self.url}")

    async def _main(self) -> None:
        import websockets

        self._stop = asyncio.Event()
        decompressor = zstandard.ZstdDecompressor()
        try:
            async with websockets.connect(self.url, subprotocols=[SUBPROTOCOL], max_size=None) as ws:
                await ws.send(camera_message())

                async def receive() -> None:
                    async for frame in ws:
                        for message, size in decode_frame(frame, decompressor):
                            with self._lock:
                                self.messages.append((message, size))
                            if message.get("type") == "ReplayDoneMessage":
                                self.replay_done.set()

                task = asyncio.create_task(receive())
                await self._stop.wait()
                task.cancel()
        except Exception:  # the server stopped
            pass
        finally:
            self.replay_done.set()

    def received(self) -> list[tuple[dict[str, Any], int]]:
        """Every ``(message, size in bytes)`` so far, in arrival order."""
        with self._lock:
            return list(self.messages)

    def nodes(self) -> dict[str, dict[str, Any]]:
        """Scene nodes as the page holds them: ``{name: {"props": {...}, "visible": bool}}``."""
        state: dict[str, dict[str, Any]] = {}
        for message, _ in self.received():
            kind = message.get("type", "")
            name = message.get("name")
            if kind == "RemoveSceneNodeMessage":
                state.pop(name, None)
            elif kind == "SceneNodeUpdateMessage" and name in state:
                state[name]["props"].update(message["updates"])
            elif kind == "SetSceneNodeVisibilityMessage" and name in state:
                state[name]["visible"] = bool(message["visible"])
            elif isinstance(message.get("props"), dict) and isinstance(name, str) and kind.endswith("Message") \
                    and not kind.startswith("Gui"):
                state[name] = {"props": dict(message["props"]), "visible": True}
        return state

    def close(self) -> None:
        if self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(timeout=10.0)
