"""viser's websocket protocol as a headless client speaks it (viser 1.1.1).

Load benchmarks (bench/app_stream.py) and app tests drive a running rigidlab
server with plain websocket clients instead of browsers. A client asks for
the subprotocol ``viser-v<version>`` (others are closed with code 1002) and
is registered only after its first ``ViewerCameraMessage``; client messages
are plain msgpack dicts with a ``type`` key (``viser/infra/_infra.py``).
"""

from __future__ import annotations

from typing import Any

import msgpack
import viser

__all__ = ["SUBPROTOCOL", "camera_message", "gui_value_message"]

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
