"""viser's websocket protocol as a headless client speaks it (viser 1.1.1).

Load benchmarks (bench/app_stream.py) and app tests drive a running rigidlab
server with plain websocket clients instead of browsers. A client asks for
the subprotocol ``viser-v<version>`` (others are closed with code 1002) and
is registered only after its first ``ViewerCameraMessage``; client messages
are plain msgpack dicts with a ``type`` key (``viser/infra/_infra.py``).
"""

from __future__ import annotations

import contextlib
from typing import Any

import msgpack
import viser

__all__ = ["SUBPROTOCOL", "browser_connection", "camera_message", "frame_payload", "gui_value_message"]

SUBPROTOCOL = f"viser-v{viser.__version__}"
"""The websocket subprotocol the server accepts."""


def camera_message() -> bytes:
    """The first message of a client (a 1200 x 750 view of the origin from
    (3, -4, 2.5), +Z up); the server registers the client on receipt."""
    return msgpack.packb(
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
        },
        use_bin_type=True,
    )


def gui_value_message(uuid: str, value: Any) -> bytes:
    """A GUI input change of the element ``uuid``, exactly as the browser sends it."""
    return msgpack.packb(
        {"type": "GuiUpdateMessage", "uuid": uuid, "updates": {"value": value}},
        use_bin_type=True,
    )


def frame_payload(frame: bytes, decompressor: Any) -> tuple[dict[str, Any], int]:
    """The msgpack payload of one server frame (``messages``, ``binaryBufferLengths``) and the
    compressed size of that payload (bytes).

    A frame is ``[u64 inner size][u64 compressed size]``, the zstd-compressed
    msgpack payload, then its binary buffers aligned to 8 bytes (viser
    1.1.1's ``_message_producer``); ``decompressor`` is a
    ``zstandard.ZstdDecompressor``.
    """
    inner_size = int.from_bytes(frame[0:8], "little")
    compressed_size = int.from_bytes(frame[8:16], "little")
    inner = decompressor.decompress(frame[16 : 16 + compressed_size], max_output_size=inner_size)
    return msgpack.unpackb(inner, raw=False), compressed_size


@contextlib.asynccontextmanager
async def browser_connection(url: str, *, open_timeout: float | None = None):
    """A websocket to a viser server registered as a browser (its camera message sent first), without
    compression or pings (benchmark clients that count every byte)."""
    import websockets

    async with websockets.connect(url, subprotocols=[SUBPROTOCOL], max_size=None, compression=None,
                                  ping_interval=None, open_timeout=open_timeout) as ws:
        await ws.send(camera_message())
        yield ws
