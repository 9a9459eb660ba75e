"""Bandwidth per browser: what each scene streams while it plays, and what dominates.

For every registered scene this starts ``rigidlab serve --scene NAME`` in a
subprocess on a free loopback port, connects ONE plain websocket client that
speaks viser's protocol (subprotocol ``viser-v<version>``, a camera message
first; see :mod:`rigidlab.app.wire`), waits for viser's replay of the scene to end,
makes the scene play (the timed scenes play on their own; the sandbox's
"Animate (constant ω)" and the manipulator's "Animate joints" are switched
on as a browser would), lets it run for a warm-up (``--warmup``, 8 s: the
plots then hold a full window of samples, the steady state) and then counts
every websocket frame for ``--duration`` seconds. Rows with ``drag`` also
send one ``GuiUpdateMessage`` per frame (60 Hz) for a slider, sweeping it
back and forth across part of its range, as a hand dragging it would.

Per row: kB/s on the wire per browser (websocket payload bytes: the 16-byte
header, the zstd-compressed msgpack and the raw binary buffers, which viser
does not compress) and frames per second. The breakdown attributes each
frame's bytes to its messages: a message's binary buffers exactly, the
compressed msgpack in proportion to the message's own msgpack size; the
header and alignment padding are "frame overhead". ``--top`` lists the
largest shares by message type and by node / GUI element (GUI elements
named by their label, or by the start of their text for HTML panels).

Usage::

    python bench/bandwidth.py                          # every scene, shared mode, 5 s per row
    python bench/bandwidth.py --scenes free_body,gyroscope --top 8
    python bench/bandwidth.py --mode shared,per-client --duration 3

Nothing is asserted; the table is printed and written to
``bench/out/bandwidth.json``. Loopback only; every wait is bounded.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import dataclasses
import json
import math
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import msgpack
import zstandard

from rigidlab.app.wire import browser_connection, frame_payload, gui_value_message

ROOT = Path(__file__).resolve().parent.parent
OUT_DIR = ROOT / "bench" / "out"
WARMUP_S = 8.0  # s: longer than the shortest plot window (6 s), so plots carry their full window
RATE_HZ = 60.0
STARTUP_TIMEOUT_S = 60.0
CONNECT_TIMEOUT_S = 30.0
TARGET_KBPS = 100.0
FRAME_HEADER = 16

SCENES = ("sandbox", "manipulator", "free_body", "gyroscope", "linkages", "cam_follower", "rolling_disk", "modes",
          "bicycle")

#: GUI values a browser sends to make a scene play (label, value), in order.
PLAY: dict[str, tuple[tuple[str, Any], ...]] = {
    "sandbox": (("Panel", "Angular velocity"), ("Animate (constant \u03c9)", True)),
    "manipulator": (("Animate joints", True),),
}

#: Rows with a slider dragged at 60 Hz: scene -> (slider label, fraction of its range swept).
DRAG: dict[str, tuple[str, float]] = {
    "sandbox": ("\u03c6 about Z", 0.5),
    "manipulator": ("\u03b81 (deg)", 0.5),
    "gyroscope": ("\u03b8 (deg)", 0.3),
    "free_body": ("Time scale", 0.25),
}


# -- viser's wire format (viser/infra/_infra.py, _message_producer) ------------


def _buffer_indices(value: Any) -> list[int]:
    """Indices of the binary buffers a serialized message refers to (its placeholders)."""
    if isinstance(value, dict):
        if "__binary_index" in value and "dtype" in value:
            return [int(value["__binary_index"])]
        return [i for v in value.values() for i in _buffer_indices(v)]
    if isinstance(value, (list, tuple)):
        return [i for v in value for i in _buffer_indices(v)]
    return []


@dataclasses.dataclass
class Tally:
    """Bytes counted in the measured window."""

    frames: int = 0
    total: int = 0
    by_type: collections.Counter = dataclasses.field(default_factory=collections.Counter)
    by_name: collections.Counter = dataclasses.field(default_factory=collections.Counter)
    messages_by_type: collections.Counter = dataclasses.field(default_factory=collections.Counter)


@dataclasses.dataclass
class Client:
    """One browser: GUI labels by uuid, the tally of the window, the replay's end."""

    labels: dict[str, str] = dataclasses.field(default_factory=dict)
    uuids: dict[str, str] = dataclasses.field(default_factory=dict)  # label -> uuid of inputs
    sliders: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    tally: Tally = dataclasses.field(default_factory=Tally)
    replay_done: bool = False
    counting: bool = False
    error: str | None = None

    def name_of(self, message: dict[str, Any]) -> str:
        kind = message.get("type", "?")
        if "name" in message and isinstance(message["name"], str):
            key = message["name"]
        elif "uuid" in message:
            key = "gui " + self.labels.get(message["uuid"], message["uuid"][:8])
        else:
            return kind
        if kind == "SceneNodeUpdateMessage":
            key += " [" + ",".join(sorted(message.get("updates", {}))) + "]"
        elif kind == "GuiUpdateMessage":
            key += " [" + ",".join(sorted(message.get("updates", {}))) + "]"
        elif kind in ("SetPositionMessage", "SetOrientationMessage"):
            key += " [pose]"
        return key

    def learn(self, message: dict[str, Any]) -> None:
        """Remember GUI labels (creation messages) to name later updates."""
        kind = message.get("type", "")
        if not kind.startswith("Gui") or "uuid" not in message or not isinstance(message.get("props"), dict):
            return
        props = message["props"]
        label = props.get("label")
        if not label:
            label = f"{kind[3:-7].lower()}: " + _excerpt(props)
        elif "value" in message or "value" in props:
            self.uuids[str(label)] = message["uuid"]
            if kind == "GuiSliderMessage":
                self.sliders[str(label)] = (float(props["min"]), float(props["max"]))
        if kind in ("GuiButtonGroupMessage", "GuiButtonMessage"):
            self.uuids[str(label)] = message["uuid"]
        self.labels[message["uuid"]] = str(label)

    def relabel(self, message: dict[str, Any]) -> None:
        """Name an unlabelled panel (a readout created empty) by its first text."""
        uuid = message.get("uuid")
        label = self.labels.get(uuid, "")
        if message.get("type") == "GuiUpdateMessage" and label.endswith(": ") and message.get("updates"):
            text = _excerpt(message["updates"])
            if text:
                self.labels[uuid] = label + text

    def count(self, frame: bytes, payload: dict[str, Any], compressed: int) -> None:
        messages = payload["messages"]
        lengths = payload.get("binaryBufferLengths", ())
        own = [len(msgpack.packb(m, use_bin_type=True)) for m in messages]
        total_own = sum(own) or 1
        t = self.tally
        t.frames += 1
        t.total += len(frame)
        attributed = 0.0
        for message, size in zip(messages, own):
            share = compressed * size / total_own + sum(lengths[i] for i in _buffer_indices(message))
            attributed += share
            kind = message.get("type", "?")
            t.by_type[kind] += share
            t.messages_by_type[kind] += 1
            t.by_name[self.name_of(message)] += share
        t.by_type["frame overhead"] += len(frame) - attributed
        t.by_name["frame overhead"] += len(frame) - attributed


def _excerpt(props: dict[str, Any]) -> str:
    """The start of the text of a panel (HTML tags dropped)."""
    text = str(props.get("content") or props.get("markdown") or props.get("title") or "")
    return " ".join(_strip_tags(text).split())[:32]


def _strip_tags(text: str) -> str:
    out, inside = [], False
    for ch in text:
        if ch == "<":
            inside = True
        elif ch == ">":
            inside = False
            out.append(" ")
        elif not inside:
            out.append(ch)
    return "".join(out)


async def run_client(url: str, client: Client, stop: asyncio.Event, outbox: asyncio.Queue) -> None:
    """Register, then decode and tally every frame until ``stop``; send what ``outbox`` gets."""
    decompressor = zstandard.ZstdDecompressor()
    try:
        async with browser_connection(url, open_timeout=CONNECT_TIMEOUT_S) as ws:

            async def receive() -> None:
                async for frame in ws:
                    payload, compressed = frame_payload(frame, decompressor)
                    for message in payload["messages"]:
                        client.learn(message)
                        client.relabel(message)
                        if message.get("type") == "ReplayDoneMessage":
                            client.replay_done = True
                    if client.counting:
                        client.count(frame, payload, compressed)

            async def send() -> None:
                while True:
                    await ws.send(await outbox.get())

            tasks = [asyncio.create_task(receive()), asyncio.create_task(send())]
            await stop.wait()
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
    except Exception as exc:  # reported in the table, never silently
        client.error = f"{type(exc).__name__}: {exc}"


# -- server subprocess ------------------------------------------------------------


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def start_server(scene: str, mode: str, workdir: Path) -> tuple[subprocess.Popen, str]:
    """``rigidlab serve`` (loopback, free port) in a subprocess; returns it and its ws:// URL."""
    port = free_port()
    command = [sys.executable, "-m", "rigidlab.app.cli", "serve", "--host", "127.0.0.1", "--port", str(port),
               "--scene", scene, "--mode", mode]
    if mode == "per-client":
        command += ["--workers", "1"]
    log_path = workdir / f"serve-{scene}-{port}.log"
    with open(log_path, "w") as log:
        process = subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"rigidlab serve exited with {process.returncode}:\n{log_path.read_text()}")
        if "rigidlab: open " in log_path.read_text():
            return process, f"ws://127.0.0.1:{port}"
        time.sleep(0.05)
    stop_server(process)
    raise RuntimeError(f"rigidlab serve did not start within {STARTUP_TIMEOUT_S} s")


def stop_server(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=20.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=10.0)


# -- one row ----------------------------------------------------------------------


@dataclasses.dataclass
class Row:
    scene: str
    mode: str
    case: str  # "play" or "drag <slider>"
    kbps: float
    fps: float
    by_type: dict[str, float]  # kB/s
    by_name: dict[str, float]  # kB/s
    error: str | None = None


async def _measure(url: str, scene: str, mode: str, drag: str | None, duration: float, warmup: float) -> Row:
    client, stop, outbox = Client(), asyncio.Event(), asyncio.Queue()
    task = asyncio.create_task(run_client(url, client, stop, outbox))
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    while time.monotonic() < deadline and not client.replay_done and client.error is None:
        await asyncio.sleep(0.05)
    case = "play" if drag is None else f"drag {drag}"
    error = client.error or (None if client.replay_done else "the scene was never replayed")
    # A dragged slider is what moves the sandbox and the manipulator; the
    # timed scenes play on their own in both cases.
    for label, value in PLAY.get(scene, ()) if drag is None else ():
        if label not in client.uuids:
            error = error or f"no control {label!r}"
            break
        outbox.put_nowait(gui_value_message(client.uuids[label], value))
        await asyncio.sleep(0.2)
    if drag is not None and drag not in client.sliders:
        error = error or f"no slider {drag!r} among {sorted(client.sliders)}"
    if error is None:
        lo, hi = client.sliders[drag] if drag is not None else (0.0, 0.0)
        span = DRAG[scene][1] * (hi - lo) if drag is not None else 0.0
        centre = 0.5 * (lo + hi)
        t0 = time.perf_counter()
        n_ticks = int((warmup + duration) * RATE_HZ)
        started = None
        for i in range(n_ticks):
            delay = t0 + i / RATE_HZ - time.perf_counter()
            if delay > 0:
                await asyncio.sleep(delay)
            if started is None and time.perf_counter() >= t0 + warmup:
                client.counting, started = True, time.perf_counter()
            if drag is not None:  # a triangle wave: 2 s out and back
                phase = (i / RATE_HZ) % 2.0
                value = centre - 0.5 * span + span * (phase if phase < 1.0 else 2.0 - phase)
                outbox.put_nowait(gui_value_message(client.uuids[drag], round(value, 6)))
        await asyncio.sleep(max(0.0, t0 + warmup + duration - time.perf_counter()))
        client.counting = False
        wall = time.perf_counter() - (started if started is not None else t0)
    stop.set()
    await asyncio.wait_for(asyncio.gather(task, return_exceptions=True), timeout=30.0)
    error = error or client.error
    if error is not None:
        return Row(scene, mode, case, math.nan, math.nan, {}, {}, error)
    t = client.tally
    return Row(scene, mode, case, t.total / wall / 1e3, t.frames / wall,
               {k: v / wall / 1e3 for k, v in t.by_type.most_common()},
               {k: v / wall / 1e3 for k, v in t.by_name.most_common()})


def measure(scene: str, mode: str, drag: str | None, duration: float, warmup: float, workdir: Path) -> Row:
    try:
        process, url = start_server(scene, mode, workdir)
    except RuntimeError as exc:
        return Row(scene, mode, "play" if drag is None else f"drag {drag}", math.nan, math.nan, {}, {}, str(exc))
    try:
        return asyncio.run(_measure(url, scene, mode, drag, duration, warmup))
    finally:
        stop_server(process)


# -- table ------------------------------------------------------------------------


def print_table(rows: list[Row], top: int) -> None:
    header = f"{'scene':<13} {'mode':<10} {'case':<22} {'kB/s':>7} {'fps':>5} {'ok':>3}  largest shares (kB/s)"
    print(header)
    print("-" * len(header))
    for r in rows:
        if r.error is not None:
            print(f"{r.scene:<13} {r.mode:<10} {r.case:<22} error: {r.error}")
            continue
        shares = ", ".join(f"{k} {v:.1f}" for k, v in list(r.by_name.items())[:3])
        ok = "yes" if r.kbps <= TARGET_KBPS else "NO"
        print(f"{r.scene:<13} {r.mode:<10} {r.case:<22} {r.kbps:>7.1f} {r.fps:>5.1f} {ok:>3}  {shares}")
    if top:
        for r in rows:
            if r.error is not None:
                continue
            print(f"\n== {r.scene}, {r.mode}, {r.case}: {r.kbps:.1f} kB/s")
            print("  by message type:")
            for k, v in list(r.by_type.items())[:top]:
                print(f"    {v:>7.2f}  {k}")
            print("  by node / GUI element:")
            for k, v in list(r.by_name.items())[:top]:
                print(f"    {v:>7.2f}  {k}")
    print(f"\nkB/s: websocket payload bytes per browser per second (one browser); fps: websocket frames per"
          f"\nsecond; ok: <= {TARGET_KBPS:g} kB/s. Shares: binary buffers exactly, compressed msgpack in"
          f"\nproportion to each message's own msgpack size; header and padding are frame overhead.")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(SCENES), help="comma-separated scene names (default: all)")
    parser.add_argument("--mode", default="shared", help="comma-separated modes: shared, per-client")
    parser.add_argument("--duration", type=float, default=5.0, help="measured seconds per row (default 5)")
    parser.add_argument("--warmup", type=float, default=WARMUP_S,
                        help=f"seconds played before counting (default {WARMUP_S:g})")
    parser.add_argument("--no-drag", action="store_true", help="skip the rows with a slider dragged")
    parser.add_argument("--top", type=int, default=6, help="largest shares listed per row (0: none)")
    args = parser.parse_args(argv)
    scenes = [s for s in args.scenes.split(",") if s]
    modes = [m for m in args.mode.split(",") if m]
    unknown = [s for s in scenes if s not in SCENES] + [m for m in modes if m not in ("shared", "per-client")]
    if unknown:
        parser.error(f"--scenes / --mode: expected names from {list(SCENES)} and shared, per-client, got {unknown}")
    if not 0.5 <= args.duration <= 120:
        parser.error(f"--duration: expected 0.5 to 120 seconds, got {args.duration}")
    if not 0.0 <= args.warmup <= 120:
        parser.error(f"--warmup: expected 0 to 120 seconds, got {args.warmup}")
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="bandwidth-") as tmp:
        for mode in modes:
            for scene in scenes:
                cases = [None] + ([DRAG[scene][0]] if scene in DRAG and not args.no_drag else [])
                for drag in cases:
                    print(f"measuring {scene} ({mode}{', drag ' + drag if drag else ''}) ...", flush=True)
                    rows.append(measure(scene, mode, drag, args.duration, args.warmup, Path(tmp)))
    print(f"\nbandwidth: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}, {args.duration:g} s per row "
          f"after {args.warmup:g} s\n")
    print_table(rows, args.top)
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    out = OUT_DIR / "bandwidth.json"
    out.write_text(json.dumps([dataclasses.asdict(r) for r in rows], indent=2))
    print(f"\nwrote {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
