"""Shareable state (app/state.py): the short string, JSON, links and files."""

from __future__ import annotations

import base64
import json
import zlib
from typing import Any

import pytest

from rigidlab.app import state as codec

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


@pytest.mark.parametrize(("text", "message"), [
    ('{"scene": "x", "values": {"a": ' + "1" * 19_000 + "}}", "expected numbers of at most 50 characters, got one of 19000"),
    ('{"scene": "x", "values": {"a": -1.' + "5" * 60 + "}}", "expected numbers of at most 50 characters, got one of 63"),
    ('{"scene": "x", "values": ' + "[" * 3000 + "]" * 3000 + "}", "expected arrays and objects nested at most 16 deep"),
    ('{"scene": "x", "values": ' + '{"a": ' * 20 + "1" + "}" * 20 + "}", "nested at most 16 deep"),
])
def test_long_numbers_and_deep_nesting_are_refused_before_parsing(text: str, message: str) -> None:
    with pytest.raises(codec.StateError, match=message):
        codec.decode(text)
    with pytest.raises(codec.StateError, match=message):  # the same inside a state string
        codec.decode(codec.PREFIX + base64.urlsafe_b64encode(zlib.compress(text.encode(), 9)).decode().rstrip("="))


def test_brackets_and_digits_inside_strings_are_text() -> None:
    state = {"scene": "x", "values": {"a": "[" * 100 + "1" * 100, "b": -1.2345678901234567e-308}}
    assert codec.decode(json.dumps(state)) == state


def test_only_small_regular_files_are_read(tmp_path: Any) -> None:
    import os

    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)  # reading it waited for a writer
    with pytest.raises(codec.StateError, match="expected a regular file, got a FIFO"):
        codec.load_file(fifo)
    with pytest.raises(codec.StateError, match="expected a regular file, got a directory"):
        codec.load_file(tmp_path)
    if os.path.exists("/dev/zero"):  # read until memory ran out
        with pytest.raises(codec.StateError, match="expected a regular file, got a device: '/dev/zero'"):
            codec.load_file("/dev/zero")
    big = tmp_path / "big.json"
    big.write_text(json.dumps({**STATE, "pad": "a" * codec.MAX_FILE_BYTES}))
    with pytest.raises(codec.StateError, match=rf"expected at most {codec.MAX_FILE_BYTES} bytes, got \d+ in"):
        codec.load_file(big)
    link = tmp_path / "link.json"
    link.symlink_to(fifo)
    with pytest.raises(codec.StateError, match="got a FIFO"):
        codec.load_file(link)


def test_a_wrong_typed_value_is_refused_by_name_and_the_rest_loads() -> None:
    """``{"axis": 1.0}`` (a number where the sandbox's axis field takes three) raised TypeError in the check, and
    nothing of the state loaded; now that value is refused with its control's name and the others are used."""
    from rigidlab.app.scenes.sandbox import SandboxScene
    from rigidlab.app.server import create_app
    from tests.helpers import wait_until

    state = {"scene": "sandbox", "values": {"axis": 1.0, "angle": 30.0, "input": "Axis and angle"}}
    app = create_app(port=0, scene_classes={"sandbox": SandboxScene}, state=state, run_unwatched=True)
    try:
        session = app.session_for()
        scene = app.scene_for()
        assert wait_until(lambda: any(n[0] == "State loaded in part" for n in session.notices), timeout=60.0)
        body = next(n[1] for n in session.notices if n[0] == "State loaded in part")
        assert "Axis: expected 3 numbers, got 1.0" in body, body
        assert scene.controls.value("angle") == 30.0 and scene.controls.value("input") == "Axis and angle"
        for values in ({"axis": {"x": 1}}, {"axis": [1, "x", 0]}, {"axis": [10**400, 0, 0]}, {"angle": [30.0]}, {"angle": 10**400}):
            accepted, refused = scene.check_state({"scene": "sandbox", "values": values})
            assert accepted == {} and len(refused) == 1 and refused[0].split(":")[0] in ("Axis", "Angle (deg)"), refused
    finally:
        app.stop()
