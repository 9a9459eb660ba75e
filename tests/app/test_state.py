"""Shareable state (app/state.py): the short string, JSON, links and files."""

from __future__ import annotations

import base64
import json
import zlib
from typing import Any

import pytest

from app import state as codec

STATE = {"format": codec.FORMAT, "scene": "gyroscope",
         "values": {"theta0_deg": 60.0, "psi_dot0": 12.345678901234567, "method": "rk4", "show": True}}


def test_string_round_trip_is_exact_and_short() -> None:
    string = codec.encode(STATE)
    assert string.startswith("rl1.") and len(string) < 200
    assert set(string[4:]) <= set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_")
    assert codec.decode(string) == STATE
    assert codec.decode("  " + string + "\n") == STATE  # pasted with whitespace


def test_json_and_links_decode() -> None:
    assert codec.decode(json.dumps(STATE)) == STATE
    string = codec.encode(STATE)
    link = codec.share_link("http://10.0.0.5:8080", string)
    assert link.startswith("http://10.0.0.5:8080/?websocket=ws%3A%2F%2F10.0.0.5%3A8080%2Fstate%2Frl1.")
    assert codec.decode(link) == STATE
    assert codec.state_from_path("/state/" + string) == string
    assert codec.state_from_path("/") is None and codec.state_from_path(None) is None


@pytest.mark.parametrize(("text", "message"), [
    ("", "expected a state string or JSON, got an empty text"),
    ("hello", "expected a string starting with 'rl1.', JSON or a link, got 'hello'"),
    ("rl1.AAAA", "expected a string as 'Copy state' gives, got a damaged one"),
    ("{", "expected JSON, got text that is not"),
    ("[1, 2]", "expected a string starting with"),
    ('{"scene": 3}', "expected a scene name, got 3"),
    ('{"scene": "x", "values": []}', "expected 'values' to be an object, got list"),
    ('{"format": "other 2", "scene": "x"}', "expected format 'rigidlab state 1', got 'other 2'"),
    ("x" * 30_000, "expected at most 20000 characters, got 30000"),
])
def test_bad_states_are_refused_with_a_reason(text: str, message: str) -> None:
    with pytest.raises(codec.StateError, match=message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        codec.decode(text)


def test_compressed_bomb_is_refused() -> None:
    bomb = zlib.compress(b'{"scene": "x", "values": {}, "pad": "' + b"a" * 5_000_000 + b'"}', 9)
    string = "rl1." + base64.urlsafe_b64encode(bomb).decode().rstrip("=")
    assert len(string) < 20_000
    with pytest.raises(codec.StateError, match="expected at most 64000 bytes of JSON, got more"):
        codec.decode(string)


def test_files(tmp_path: Any) -> None:
    path = tmp_path / "demo.json"
    path.write_text(json.dumps(STATE))
    assert codec.load_file(path) == STATE
    path.write_text(codec.encode(STATE))
    assert codec.load_file(path) == STATE
    path.write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(codec.StateError, match="expected text"):
        codec.load_file(path)
    with pytest.raises(codec.StateError, match="cannot read"):
        codec.load_file(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="not JSON compliant|Out of range float"):
        codec.encode({"scene": "x", "values": {"a": float("nan")}})
