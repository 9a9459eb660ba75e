"""Shareable scene state: a short string, a JSON document, a file, a link.

A scene's state is a JSON object::

    {"format": "rigidlab state 1", "scene": "gyroscope",
     "values": {"theta0_deg": 60.0, "psi_dot0": 12.0, ...}}

``values`` holds the value of every control that belongs to the state (see
:meth:`rigidlab.app.panel.ControlPanel.state`); a scene may add keys of its own.
:func:`encode` packs it into a short string (``rl1.`` + base64url of the
zlib-compressed JSON) that fits in a chat message or a link;
:func:`decode` takes that string, the JSON text itself, or a link that
carries the string, and checks the structure. Values are checked by the
scene's controls when the state is loaded, like any browser value.

A link that opens a scene with given parameters: viser's page connects its
websocket to the address in its ``?websocket=`` parameter, so
``http://HOST:PORT/?websocket=ws://HOST:PORT/state/<string>`` shows the
server the state in the websocket path (:func:`share_link`,
:func:`rigidlab.app.gate.client_request_path`).
"""

from __future__ import annotations

import base64
import binascii
import json
import os
import re
import stat
import urllib.parse
import zlib
from pathlib import Path
from typing import Any

__all__ = ["FORMAT", "PREFIX", "StateError", "encode", "decode", "share_link", "state_from_path", "load_file"]

FORMAT = "rigidlab state 1"
PREFIX = "rl1."
#: Largest decoded state accepted (bytes of JSON); real states are < 2 kB.
MAX_JSON_BYTES = 64_000
#: Largest text accepted as a state (characters).
MAX_TEXT = 20_000
#: Largest state file read (bytes; checked before reading): ``MAX_TEXT`` characters of UTF-8.
MAX_FILE_BYTES = 4 * MAX_TEXT
#: Deepest nesting of JSON arrays and objects accepted (real states: 3).
MAX_DEPTH = 16
#: Longest number accepted in a state's JSON (characters; a float's repr has at most 24).
MAX_NUMBER_CHARS = 50

_STRING_RE = re.compile(r"rl1\.[A-Za-z0-9_\-]+=*")
_JSON_STRING_RE = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKET_RE = re.compile(r"[\[\]{}]")
_LONG_NUMBER_RE = re.compile(r"[0-9.eE+\-]{%d,}" % (MAX_NUMBER_CHARS + 1))


class StateError(ValueError):
    """A state that cannot be read; the message says why."""


def encode(state: dict[str, Any]) -> str:
    """The short string of ``state`` (``rl1.`` + base64url of zlib(JSON))."""
    text = json.dumps(state, separators=(",", ":"), sort_keys=True, allow_nan=False)
    packed = zlib.compress(text.encode(), 9)
    return PREFIX + base64.urlsafe_b64encode(packed).decode().rstrip("=")


def _decode_string(token: str) -> str:
    body = token[len(PREFIX):]
    body += "=" * (-len(body) % 4)
    try:
        packed = base64.urlsafe_b64decode(body.encode())
        inflater = zlib.decompressobj()
        raw = inflater.decompress(packed, MAX_JSON_BYTES + 1)
    except (binascii.Error, zlib.error, ValueError) as exc:
        raise StateError(f"state: expected a string as 'Copy state' gives, got a damaged one ({exc})") from None
    if len(raw) > MAX_JSON_BYTES or inflater.unconsumed_tail:
        raise StateError(f"state: expected at most {MAX_JSON_BYTES} bytes of JSON, got more")
    return raw.decode("utf-8", errors="replace")


def decode(text: str) -> dict[str, Any]:
    """Read a state from its short string, its JSON text or a link carrying the string.

    Raises
    ------
    StateError
        For anything else, with what was expected and what was found.
    """
    if not isinstance(text, str):
        raise StateError(f"state: expected text, got {type(text).__name__}")
    text = text.strip()
    if not text:
        raise StateError("state: expected a state string or JSON, got an empty text")
    if len(text) > MAX_TEXT:
        raise StateError(f"state: expected at most {MAX_TEXT} characters, got {len(text)}")
    if text.startswith("{"):
        raw = text
    else:
        match = _STRING_RE.search(urllib.parse.unquote(text))
        if match is None:
            shown = text[:40] + ("..." if len(text) > 40 else "")
            raise StateError(f"state: expected a string starting with {PREFIX!r}, JSON or a link, got {shown!r}")
        raw = _decode_string(match.group(0))
    _check_json_shape(raw)
    try:
        state = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise StateError(f"state: expected JSON, got text that is not ({exc.msg} at {exc.pos})") from None
    except (ValueError, RecursionError) as exc:  # (the checks above leave none; a last resort)
        raise StateError(f"state: expected JSON, got text that is not ({type(exc).__name__})") from None
    return check(state)


def _check_json_shape(raw: str) -> None:
    """Refuse JSON nested deeper than :data:`MAX_DEPTH` or with a number longer than :data:`MAX_NUMBER_CHARS`,
    before the parser sees it: Python's parser recurses per level (RecursionError at ~1000) and refuses
    integers of more than 4300 digits with a bare ValueError."""
    skeleton = _JSON_STRING_RE.sub('""', raw)  # brackets and digits inside strings are text
    long_number = _LONG_NUMBER_RE.search(skeleton)
    if long_number is not None:
        raise StateError(f"state: expected numbers of at most {MAX_NUMBER_CHARS} characters, got one of "
                         f"{len(long_number.group(0))}")
    depth = 0
    for bracket in _BRACKET_RE.finditer(skeleton):
        depth += 1 if bracket.group(0) in "[{" else -1
        if depth > MAX_DEPTH:
            raise StateError(f"state: expected arrays and objects nested at most {MAX_DEPTH} deep, got deeper")


def check(state: Any) -> dict[str, Any]:
    """``state`` if it has the structure of a state (scene name, values)."""
    if not isinstance(state, dict):
        raise StateError(f"state: expected a JSON object, got {type(state).__name__}")
    fmt = state.get("format", FORMAT)
    if fmt != FORMAT:
        raise StateError(f"state: expected format {FORMAT!r}, got {fmt!r}")
    scene = state.get("scene")
    if not isinstance(scene, str) or not scene:
        raise StateError(f"state: expected a scene name, got {scene!r}")
    values = state.get("values", {})
    if not isinstance(values, dict):
        raise StateError(f"state: expected 'values' to be an object, got {type(values).__name__}")
    return state


def share_link(page_url: str, string: str) -> str:
    """A link that opens the page and hands the server ``string`` (see module docstring).

    ``page_url`` is the address the browsers use (``http://HOST:PORT``).
    """
    base = page_url.rstrip("/")
    ws = base.replace("https://", "wss://").replace("http://", "ws://")
    return f"{base}/?websocket={urllib.parse.quote(ws + '/state/' + string, safe='')}"


def state_from_path(path: str | None) -> str | None:
    """The state string in a websocket request path ``/state/<string>``, if any."""
    if not path:
        return None
    match = _STRING_RE.search(urllib.parse.unquote(path))
    return None if match is None else match.group(0)


def load_file(path: str | Path) -> dict[str, Any]:
    """Read a state from a file (JSON or the short string).

    Only a regular file of at most :data:`MAX_FILE_BYTES` bytes is read; its
    kind and size are checked before reading (``/dev/zero`` would be read
    until memory runs out, a FIFO would wait for a writer).

    Raises
    ------
    StateError
        If the file cannot be read, is not a regular file, is too large or
        does not hold a state.
    """
    name = str(path)
    try:
        _check_file(os.stat(path), name)
        # O_NONBLOCK: a FIFO put in the file's place since the stat does not block the open (fstat refuses it)
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))
        with os.fdopen(fd, "rb") as file:
            _check_file(os.fstat(fd), name)
            data = file.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise StateError(f"state file: cannot read {name!r} ({exc.strerror or exc})") from None
    if len(data) > MAX_FILE_BYTES:  # grew since the check
        raise StateError(f"state file: expected at most {MAX_FILE_BYTES} bytes, got more in {name!r}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise StateError(f"state file: expected text (JSON or a state string), got binary data in {name!r}") from None
    return decode(text)


def _check_file(info: os.stat_result, name: str) -> None:
    if not stat.S_ISREG(info.st_mode):
        kind = ("a directory" if stat.S_ISDIR(info.st_mode) else "a FIFO" if stat.S_ISFIFO(info.st_mode)
                else "a device" if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
                else "a socket" if stat.S_ISSOCK(info.st_mode) else "not a regular file")
        raise StateError(f"state file: expected a regular file, got {kind}: {name!r}")
    if info.st_size > MAX_FILE_BYTES:
        raise StateError(f"state file: expected at most {MAX_FILE_BYTES} bytes, got {info.st_size} in {name!r}")
