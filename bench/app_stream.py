"""Streaming benchmark of the app: frames per client, pose latency and server CPU.

For every scene (sandbox, manipulator) and every client count N (1, 10, 30)
this starts ``rigidlab serve`` in a subprocess on a free loopback port
(shared mode), connects N plain websocket clients that speak viser's
protocol, and drives the scene at 60 Hz for ``--duration`` seconds:

* a separate driver client sends a GUI value update for one slider 60 times
  a second (exactly the ``GuiUpdateMessage`` a browser sends when a slider
  moves); every value is distinct, so each observer can tell which sent value
  a node pose it receives belongs to;
* the latency of a pose update is the time from sending a value to receiving
  the pose of the driven node (decoded back to the slider value) at each
  observer; the p50 and p95 over all (value, observer) pairs are reported;
* frames per second per client counts the websocket frames each observer
  receives (viser sends at most one frame per ~1/60 s per client);
* server CPU is the subprocess's ``utime + stime`` from ``/proc/<pid>/stat``
  over the measured window, in % of one core; the benchmark's own CPU (the
  clients decode every frame) is reported beside it.

The manipulator is also driven by its own "Animate joints" checkbox (the
server sweeps the joints; no per-frame input, so no latency).

Wire format (viser 1.1.1, ``viser/infra/_infra.py``): a client asks for the
subprotocol ``viser-v<version>`` and is registered only after its first
``ViewerCameraMessage``; client messages are plain msgpack dicts with a
``type`` key; each server frame is ``[u64 inner size][u64 compressed size]``
+ zstd-compressed msgpack ``{"messages": [...], ...}`` + raw numpy buffers.

Per-client rows (``--per-client``): ``rigidlab serve --mode per-client
--workers W --scene NAME`` with N browsers, each its own live scene (the
dynamic scenes play on their own), nothing sent by the clients after the
first camera message. Per row: frames per second per browser (median and
min), kB/s per browser on the wire (median and max; websocket payload
bytes), the CPU of the whole server process tree (supervisor, workers and
their process pools) in % of one core and per core of the machine, the
browsers whose connection dropped, and the load time of a late joiner (a
browser that connects after the measured window: time from connecting to
the first pose of its own scene, i.e. its session built, its scene sent and
moving). These clients only count frames and bytes
(they decompress nothing after the initial replay), so the benchmark's own
CPU stays small beside the server's.

Usage::

    python bench/app_stream.py                      # full run: 20 s per row
    python bench/app_stream.py --per-client --clients 10,20,40,60 --workers 1,2 --scenes gyroscope,free_body
    python bench/app_stream.py --duration 3 --clients 1,10
    python bench/app_stream.py --profile --clients 30 --scenes manipulator

``--profile`` runs the server under a per-thread cProfile (inflating its CPU)
and prints where its time goes. Results are also written to
``bench/out/app_stream.json``. Loopback only; every loop is bounded.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import json
import math
import os
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import zstandard

from rigidlab.app.wire import browser_connection, frame_payload, gui_value_message

ROOT = Path(__file__).resolve().parent.parent
OUT_DIR = ROOT / "bench" / "out"
RATE_HZ = 60.0
WARMUP_S = 1.0
STARTUP_TIMEOUT_S = 60.0
CONNECT_TIMEOUT_S = 30.0
TARGET_FPS = 40.0
TARGET_CPU = 50.0


# -- what each scene is driven by ---------------------------------------------


def _angle_about_z_deg(wxyz: tuple[float, ...]) -> float:
    """Angle (deg) of a rotation about +Z from its Euler parameters (scalar first)."""
    w, _, _, z = wxyz
    return math.degrees(2.0 * math.atan2(z, w))


def _first_zxz_angle_deg(wxyz: tuple[float, ...]) -> float:
    """First intrinsic Z-X-Z Euler angle (deg) of a rotation given as wxyz."""
    import warnings

    from scipy.spatial.transform import Rotation

    with warnings.catch_warnings():
        # At gimbal lock scipy warns and puts the whole turn into the first angle.
        warnings.simplefilter("ignore")
        return float(
            Rotation.from_quat(np.asarray(wxyz), scalar_first=True).as_euler("ZXZ", degrees=True)[0]
        )


@dataclasses.dataclass(frozen=True)
class DriveSpec:
    """How a scene is driven and how an observer reads the result.

    ``sliders`` are candidate labels of the driven GUI slider, the first one
    the scene has is used (empty: the scene is driven by the checkbox
    ``checkbox`` instead and no latency is measured);
    ``node`` is the scene node whose orientation follows the slider and
    ``decode`` maps that node's wxyz back to the slider value (degrees).
    Sent values are ``start + 0.1 * i`` (distinct, 0.1 deg apart).
    """

    scene: str
    label: str
    sliders: tuple[str, ...]
    node: str
    decode: Callable[[tuple[float, ...]], float]
    start: float
    checkbox: str | None = None


SPECS = {
    "sandbox": DriveSpec(
        scene="sandbox",
        label="sandbox, slider",
        # The Z-X-Z panel's first angle (older builds: a single "psi" slider).
        sliders=("\u03c6 about Z", "psi (deg)"),
        node="/sandbox/body",
        decode=_first_zxz_angle_deg,
        start=-170.0,
    ),
    "manipulator": DriveSpec(
        scene="manipulator",
        label="manipulator, slider",
        sliders=("θ1 (deg)",),
        node="/manipulator/a/link1",
        decode=_angle_about_z_deg,
        start=-170.0,
    ),
    "manipulator-animate": DriveSpec(
        scene="manipulator",
        label="manipulator, animate",
        sliders=(),
        node="/manipulator/a/link3",
        decode=_angle_about_z_deg,
        start=0.0,
        checkbox="Animate joints",
    ),
}


# -- viser's wire protocol (client messages: app/wire.py) ----------------------


def decode_frame(frame: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    """Messages of one server frame (binary buffers after the msgpack are skipped)."""
    return frame_payload(frame, decompressor)[0]["messages"]


@dataclasses.dataclass
class ClientStats:
    frames: int = 0
    frames_in_window: int = 0
    # Value key (0.1-deg step index) -> first arrival time (perf_counter).
    arrivals: dict[int, float] = dataclasses.field(default_factory=dict)
    poses: int = 0
    gui_uuids: dict[str, str] = dataclasses.field(default_factory=dict)
    replay_done: bool = False
    error: str | None = None


@dataclasses.dataclass
class Window:
    """The measured time window, shared by all clients (perf_counter seconds)."""

    start: float = math.inf
    end: float = math.inf


async def run_client(
    url: str,
    spec: DriveSpec,
    stats: ClientStats,
    window: Window,
    stop: asyncio.Event,
    outbox: asyncio.Queue | None = None,
) -> None:
    """One websocket client: register, then count and decode every frame until ``stop``."""
    decompressor = zstandard.ZstdDecompressor()
    try:
        async with browser_connection(url, open_timeout=CONNECT_TIMEOUT_S) as ws:
            sender = None
            if outbox is not None:

                async def pump() -> None:
                    while True:
                        payload = await outbox.get()
                        await ws.send(payload)

                sender = asyncio.create_task(pump())
            receive = asyncio.create_task(_receive(ws, spec, stats, window, decompressor))
            await stop.wait()
            receive.cancel()
            if sender is not None:
                sender.cancel()
            await asyncio.gather(receive, *( [sender] if sender else []), return_exceptions=True)
    except Exception as exc:  # reported in the table, never silently
        stats.error = f"{type(exc).__name__}: {exc}"


async def _receive(ws: Any, spec: DriveSpec, stats: ClientStats, window: Window, decompressor: Any) -> None:
    async for frame in ws:
        now = time.perf_counter()
        stats.frames += 1
        if window.start <= now < window.end:
            stats.frames_in_window += 1
        for message in decode_frame(frame, decompressor):
            kind = message.get("type")
            if kind == "SetOrientationMessage" and message.get("name") == spec.node:
                stats.poses += 1
                if spec.sliders:
                    key = round((spec.decode(message["wxyz"]) - spec.start) * 10.0)
                    stats.arrivals.setdefault(key, now)
            elif kind in ("GuiSliderMessage", "GuiCheckboxMessage", "GuiDropdownMessage"):
                stats.gui_uuids[message["props"]["label"]] = message["uuid"]
            elif kind == "ReplayDoneMessage":
                stats.replay_done = True


# -- server subprocess ----------------------------------------------------------


def free_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@dataclasses.dataclass
class Server:
    process: subprocess.Popen
    url: str
    log_path: Path
    profile_path: Path | None


def start_server(scene: str, *, profile: bool, workdir: Path) -> Server:
    """``rigidlab serve`` (shared mode, loopback, free port) in a subprocess."""
    port = free_port()
    serve_args = ["serve", "--host", "127.0.0.1", "--port", str(port), "--scene", scene, "--mode", "shared"]
    log_path = workdir / f"serve-{scene}-{port}.log"
    # Kept for a closer look with pstats (bench/out/ is not committed).
    profile_path = OUT_DIR / f"app_stream-{scene}-{port}.prof" if profile else None
    if profile:
        command = [sys.executable, str(Path(__file__).resolve()), "--profiled-serve", str(profile_path), "--", *serve_args]
    else:
        command = [sys.executable, "-m", "rigidlab.app.cli", *serve_args]
    log = open(log_path, "w")
    process = subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, text=True)
    log.close()
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    url = None
    while time.monotonic() < deadline and url is None:
        if process.poll() is not None:
            raise RuntimeError(f"rigidlab serve exited with {process.returncode}:\n{log_path.read_text()}")
        for line in log_path.read_text().splitlines():
            if line.startswith("rigidlab: open "):
                url = line.split("rigidlab: open ", 1)[1].strip()
        time.sleep(0.05)
    if url is None:
        stop_server(Server(process, "", log_path, profile_path))
        raise RuntimeError(f"rigidlab serve did not print its URL within {STARTUP_TIMEOUT_S} s")
    return Server(process, url.replace("http://", "ws://"), log_path, profile_path)


def stop_server(server: Server) -> None:
    if server.process.poll() is None:
        server.process.send_signal(signal.SIGINT)
        try:
            server.process.wait(timeout=20.0)
        except subprocess.TimeoutExpired:
            server.process.kill()
            server.process.wait(timeout=10.0)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` (all its threads), seconds."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    # After the ")" the fields start at field 3 (state): utime is 14, stime 15.
    utime, stime = int(fields[11]), int(fields[12])
    return (utime + stime) / os.sysconf("SC_CLK_TCK")


def own_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


# -- one run ----------------------------------------------------------------------


@dataclasses.dataclass
class RunResult:
    case: str
    clients: int
    fps_mean: float
    fps_min: float
    latency_p50_ms: float | None
    latency_p95_ms: float | None
    delivered: float | None  # fraction of sent values whose pose reached an observer
    server_cpu: float  # % of one core
    bench_cpu: float  # % of one core
    values_sent: int
    errors: list[str]


async def _run_case(spec: DriveSpec, n_clients: int, duration: float, server: Server) -> RunResult:
    window = Window()
    stop = asyncio.Event()
    driver_stats = ClientStats()
    outbox: asyncio.Queue = asyncio.Queue()
    tasks = [asyncio.create_task(run_client(server.url, spec, driver_stats, Window(), stop, outbox))]
    observers = [ClientStats() for _ in range(n_clients)]
    for stats in observers:
        tasks.append(asyncio.create_task(run_client(server.url, spec, stats, window, stop)))

    # Wait for every client to receive the replayed scene (bounded).
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    everyone = [driver_stats, *observers]
    candidates = spec.sliders or (spec.checkbox,)

    def found() -> str | None:
        return next((c for c in candidates if c in driver_stats.gui_uuids), None)

    while time.monotonic() < deadline:
        if any(s.error for s in everyone):
            break
        if all(s.replay_done for s in everyone) and found() is not None:
            break
        await asyncio.sleep(0.05)
    errors = [s.error for s in everyone if s.error]
    control = found()
    if control is None and not errors:
        errors.append(f"none of {candidates} found among {sorted(driver_stats.gui_uuids)}")
    sent: dict[int, float] = {}
    if not errors:
        uuid = driver_stats.gui_uuids[control]
        if spec.checkbox is not None:
            outbox.put_nowait(gui_value_message(uuid, True))
        t0 = time.perf_counter()
        window.start = t0 + WARMUP_S
        window.end = window.start + duration
        n_ticks = int((WARMUP_S + duration) * RATE_HZ)
        cpu_start = bench_start = None
        for i in range(n_ticks):
            tick = t0 + i / RATE_HZ
            delay = tick - time.perf_counter()
            if delay > 0:
                await asyncio.sleep(delay)
            now = time.perf_counter()
            if cpu_start is None and now >= window.start:
                cpu_start, bench_start, cpu_t0 = cpu_seconds(server.process.pid), own_cpu_seconds(), now
            if spec.sliders:
                value = round(spec.start + 0.1 * i, 1)
                sent[i] = time.perf_counter()
                outbox.put_nowait(gui_value_message(uuid, value))
        await asyncio.sleep(max(0.0, window.end - time.perf_counter()))
        cpu_end, bench_end, cpu_t1 = cpu_seconds(server.process.pid), own_cpu_seconds(), time.perf_counter()
        await asyncio.sleep(0.5)  # let the last poses arrive
    stop.set()
    try:
        await asyncio.wait_for(asyncio.gather(*tasks, return_exceptions=True), timeout=30.0)
    except asyncio.TimeoutError:
        errors.append("clients did not close within 30 s")
    errors += [s.error for s in everyone if s.error and s.error not in errors]
    if errors:
        return RunResult(spec.label, n_clients, 0, 0, None, None, None, math.nan, math.nan, 0, errors)

    fps = [s.frames_in_window / duration for s in observers]
    latencies = []
    in_window = [i for i, t in sent.items() if window.start <= t < window.end]
    delivered = 0
    for i in in_window:
        for stats in observers:
            arrival = stats.arrivals.get(i)
            if arrival is not None:
                latencies.append((arrival - sent[i]) * 1e3)
                delivered += 1
    wall = cpu_t1 - cpu_t0
    return RunResult(
        case=spec.label,
        clients=n_clients,
        fps_mean=statistics.fmean(fps),
        fps_min=min(fps),
        latency_p50_ms=float(np.percentile(latencies, 50)) if latencies else None,
        latency_p95_ms=float(np.percentile(latencies, 95)) if latencies else None,
        delivered=delivered / (len(in_window) * n_clients) if in_window else None,
        server_cpu=100.0 * (cpu_end - cpu_start) / wall,
        bench_cpu=100.0 * (bench_end - bench_start) / wall,
        values_sent=len(in_window),
        errors=[],
    )


def run_case(spec: DriveSpec, n_clients: int, duration: float, *, profile: bool, workdir: Path) -> RunResult:
    server = start_server(spec.scene, profile=profile, workdir=workdir)
    try:
        return asyncio.run(_run_case(spec, n_clients, duration, server))
    finally:
        stop_server(server)
        if profile and server.profile_path is not None:
            print_profile(server.profile_path, f"{spec.label}, {n_clients} clients")


# -- per-client rows: every browser its own live scene ----------------------------

#: Scenes that move on their own (the per-client rows' default set).
DYNAMIC_SCENES = ("gyroscope", "free_body", "linkages", "cam_follower", "rolling_disk", "modes", "bicycle")
TARGET_KBPS = 100.0


#: Messages that move a node: the first one a new browser receives means its scene is built and live.
_POSE_MESSAGES = {"SetOrientationMessage", "SetPositionMessage"}


@dataclasses.dataclass
class PerClientStats:
    frames_in_window: int = 0
    bytes_in_window: int = 0
    replay_done: float | None = None  # perf_counter when viser's replay ended
    built: float | None = None  # perf_counter when the browser's session sent its panel
    live: float | None = None  # perf_counter of the first pose after that: its own scene built and moving
    closed_early: bool = False
    error: str | None = None


async def run_counting_client(url: str, stats: PerClientStats, window: Window, stop: asyncio.Event) -> None:
    """One browser: register, decode frames only until the replay is done, then only count frames and bytes."""
    decompressor = zstandard.ZstdDecompressor()
    try:
        async with browser_connection(url, open_timeout=CONNECT_TIMEOUT_S) as ws:

            async def receive() -> None:
                async for frame in ws:
                    now = time.perf_counter()
                    if window.start <= now < window.end:
                        stats.frames_in_window += 1
                        stats.bytes_in_window += len(frame)
                    if stats.live is None:  # decode until the session's scene is built and moving
                        kinds = {m.get("type") for m in decode_frame(frame, decompressor)}
                        if stats.replay_done is None and "ReplayDoneMessage" in kinds:
                            stats.replay_done = now
                        if stats.built is None and "GuiDropdownMessage" in kinds:  # the session's scene chooser
                            stats.built = now
                        elif stats.built is not None and kinds & _POSE_MESSAGES:
                            stats.live = now
                if not stop.is_set():
                    stats.closed_early = True

            task = asyncio.create_task(receive())
            await stop.wait()
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
    except Exception as exc:  # reported in the table, never silently
        stats.error = f"{type(exc).__name__}: {exc}"


def tree_cpu_seconds(pid: int) -> float:
    """CPU seconds of ``pid`` and all its descendants alive now (``/proc``)."""
    total, todo, seen = 0.0, [pid], set()
    while todo:
        p = todo.pop()
        if p in seen:
            continue
        seen.add(p)
        try:
            total += cpu_seconds(p)
            for task in Path(f"/proc/{p}/task").iterdir():
                todo += [int(c) for c in (task / "children").read_text().split()]
        except (OSError, ValueError):
            continue
    return total


@dataclasses.dataclass
class PerClientResult:
    scene: str
    clients: int
    workers: int
    fps_median: float
    fps_min: float
    kbps_median: float
    kbps_max: float
    server_cpu: float  # % of one core, whole process tree
    bench_cpu: float
    dropped: int
    join_s: float | None
    errors: list[str]


def start_per_client_server(scene: str, workers: int, workdir: Path) -> Server:
    port = free_port()
    command = [sys.executable, "-m", "rigidlab.app.cli", "serve", "--host", "127.0.0.1", "--port", str(port), "--scene",
               scene, "--mode", "per-client", "--workers", str(workers)]
    log_path = workdir / f"serve-{scene}-{port}.log"
    log = open(log_path, "w")
    process = subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, text=True)
    log.close()
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"rigidlab serve exited with {process.returncode}:\n{log_path.read_text()}")
        if "rigidlab: open " in log_path.read_text():
            return Server(process, f"ws://127.0.0.1:{port}", log_path, None)
        time.sleep(0.05)
    stop_server(Server(process, "", log_path, None))
    raise RuntimeError(f"rigidlab serve did not start within {STARTUP_TIMEOUT_S} s")


async def _run_per_client(scene: str, n: int, workers: int, duration: float, server: Server) -> PerClientResult:
    window = Window()
    stop = asyncio.Event()
    browsers = [PerClientStats() for _ in range(n)]
    tasks = []
    for stats in browsers:  # a classroom joining: a few browsers a second, not all at once
        tasks.append(asyncio.create_task(run_counting_client(server.url, stats, window, stop)))
        await asyncio.sleep(0.05)
    deadline = time.monotonic() + CONNECT_TIMEOUT_S + 0.1 * n
    while time.monotonic() < deadline and not all(s.live or s.error for s in browsers):
        await asyncio.sleep(0.05)
    errors = sorted({s.error for s in browsers if s.error})
    if not all(s.live for s in browsers) and not errors:
        errors.append(f"{sum(not s.live for s in browsers)} of {n} browsers never got a live scene")
    join_s = None
    if not errors:
        now = time.perf_counter()
        window.start = now + WARMUP_S
        window.end = window.start + duration
        await asyncio.sleep(WARMUP_S)
        cpu0, bench0, t0 = tree_cpu_seconds(server.process.pid), own_cpu_seconds(), time.perf_counter()
        await asyncio.sleep(max(0.0, window.end - time.perf_counter()))
        cpu1, bench1, t1 = tree_cpu_seconds(server.process.pid), own_cpu_seconds(), time.perf_counter()
        # a late joiner while the others stream
        late, late_stop = PerClientStats(), asyncio.Event()
        started = time.perf_counter()
        late_task = asyncio.create_task(run_counting_client(server.url, late, Window(), late_stop))
        while late.live is None and late.error is None and time.perf_counter() - started < 30.0:
            await asyncio.sleep(0.01)
        join_s = None if late.live is None else late.live - started
        late_stop.set()
        await asyncio.gather(late_task, return_exceptions=True)
    stop.set()
    try:
        await asyncio.wait_for(asyncio.gather(*tasks, return_exceptions=True), timeout=30.0)
    except asyncio.TimeoutError:
        errors.append("clients did not close within 30 s")
    if errors:
        return PerClientResult(scene, n, workers, 0, 0, 0, 0, math.nan, math.nan, 0, None, errors)
    fps = [s.frames_in_window / duration for s in browsers]
    kbps = [s.bytes_in_window / duration / 1e3 for s in browsers]
    wall = t1 - t0
    return PerClientResult(
        scene=scene, clients=n, workers=workers, fps_median=statistics.median(fps), fps_min=min(fps),
        kbps_median=statistics.median(kbps), kbps_max=max(kbps), server_cpu=100.0 * (cpu1 - cpu0) / wall,
        bench_cpu=100.0 * (bench1 - bench0) / wall, dropped=sum(s.closed_early for s in browsers), join_s=join_s,
        errors=[],
    )


def run_per_client(scene: str, n: int, workers: int, duration: float, workdir: Path) -> PerClientResult:
    server = start_per_client_server(scene, workers, workdir)
    try:
        return asyncio.run(_run_per_client(scene, n, workers, duration, server))
    finally:
        stop_server(server)


def print_per_client_table(results: list[PerClientResult]) -> None:
    cores = os.cpu_count() or 1
    header = (f"{'scene':<13} {'N':>3} {'workers':>7} {'fps med':>7} {'fps min':>7} {'kB/s med':>8} "
              f"{'kB/s max':>8} {'server CPU%':>11} {'per core':>8} {'dropped':>7} {'join s':>6} "
              f"{'bench CPU%':>10}")
    print(header)
    print("-" * len(header))
    for r in results:
        if r.errors:
            print(f"{r.scene:<13} {r.clients:>3} {r.workers:>7} error: {'; '.join(r.errors)}")
            continue
        print(f"{r.scene:<13} {r.clients:>3} {r.workers:>7} {r.fps_median:>7.1f} {r.fps_min:>7.1f} "
              f"{r.kbps_median:>8.1f} {r.kbps_max:>8.1f} {r.server_cpu:>11.0f} {r.server_cpu / cores:>7.0f}% "
              f"{r.dropped:>7} {_fmt(r.join_s, '6.2f')} {r.bench_cpu:>10.0f}")
    print(
        f"\nper-client mode: every browser its own live scene; fps: websocket frames per second per browser"
        f"\n(median, min); kB/s: websocket payload bytes per browser per second (median, max); server CPU:"
        f"\nthe whole server process tree (supervisor, workers, their pools), % of one core, and per core of"
        f"\nthe {cores} here; dropped: browsers whose connection closed; join: a late joiner's time to the"
        f"\nfirst pose of its own live scene; bench CPU: this process (all the clients)."
        f"\ntargets: 40 browsers >= 40 fps median (gyroscope, free_body); 60 browsers >= 30 fps with 2 workers;"
        f"\n<= {TARGET_KBPS:g} kB/s per browser; late joiner < 1 s at 40 browsers; no drops."
    )


# -- profiling inside the server subprocess -------------------------------------


def profiled_serve(out_path: str, serve_args: list[str]) -> int:
    """Run ``rigidlab serve`` with a cProfile in every thread; dump combined stats at exit."""
    import cProfile
    import pstats
    import threading

    profiles: list[cProfile.Profile] = []
    lock = threading.Lock()
    original_run = threading.Thread.run

    def profiled_run(self: threading.Thread) -> None:
        profile = cProfile.Profile()
        with lock:
            profiles.append(profile)
        profile.enable()
        try:
            original_run(self)
        finally:
            profile.disable()

    threading.Thread.run = profiled_run  # type: ignore[method-assign]
    from rigidlab.app.cli import main

    status = main(serve_args)
    with lock:
        stats = None
        for profile in profiles:
            try:
                stats = pstats.Stats(profile) if stats is None else stats.add(profile)
            except TypeError:  # a thread that never ran profiled code
                continue
    if stats is not None:
        stats.dump_stats(out_path)
    return status


_IDLE_FUNCTIONS = (
    "<method 'get' of '_queue.SimpleQueue' objects>",
    "<method 'acquire' of '_thread.lock' objects>",
    "<method 'poll' of 'select.epoll' objects>",
    "<built-in method time.sleep>",
)
"""Blocking calls where threads wait (idle wall time, not CPU)."""


def _grouped_profile(stats: Any) -> dict[str, float]:
    """Own time (s) per area: viser serialization, websocket send, zstd, scenes, core, ..."""
    areas = {
        # dataclasses.is_dataclass and typing.get_args/get_origin are called by
        # viser's _prepare_for_serialization for every field of every message.
        "viser: serialize messages (per client)": (
            "viser/infra/_messages.py",
            "dataclasses.py",
            "typing.py",
            "builtins.isinstance",
            "builtins.hasattr",
            "builtins.getattr",
        ),
        "viser: message buffer / windows": ("viser/infra/_async_message_buffer.py",),
        "viser: producer loop (per client)": ("viser/infra/_infra.py",),
        "viser: scene/GUI handles": ("viser/_scene", "viser/_gui", "viser/_assignable"),
        "websockets + asyncio + sockets": ("websockets/", "asyncio/", "_socket", "selectors"),
        "zstd compress": ("zstandard",),
        "msgpack encode": ("msgspec",),
        "rigidlab scenes (app/)": ("/app/",),
        "rigidlab core (core/)": ("/core/",),
        "numpy": ("numpy/",),
    }
    totals = {name: 0.0 for name in areas}
    totals["other"] = 0.0
    for (filename, _, function), (_, _, own, _, _) in stats.stats.items():
        if filename == "~" and function in _IDLE_FUNCTIONS:
            continue
        text = f"{filename} {function}"
        for name, needles in areas.items():
            if any(n in text for n in needles):
                totals[name] += own
                break
        else:
            totals["other"] += own
    return totals


def print_profile(path: Path, title: str, limit: int = 20) -> None:
    """Where the server's CPU went: own time by area, then the busiest functions."""
    import pstats

    if not path.exists():
        print(f"(no profile written for {title})")
        return
    stats = pstats.Stats(str(path))
    totals = _grouped_profile(stats)
    busy = sum(totals.values())
    print(f"\n== server profile: {title} (all threads, whole server run, idle waits excluded)")
    print(f"{'area':<42} {'own s':>7} {'share':>6}")
    for name, seconds in sorted(totals.items(), key=lambda item: -item[1]):
        print(f"{name:<42} {seconds:>7.2f} {100 * seconds / busy:>5.1f}%")
    rows = [
        (own, calls, f"{Path(filename).name}:{line}({function})")
        for (filename, line, function), (_, calls, own, _, _) in stats.stats.items()
        if not (filename == "~" and function in _IDLE_FUNCTIONS)
    ]
    print(f"\n{'own s':>7} {'calls':>8}  function")
    for own, calls, name in sorted(rows, reverse=True)[:limit]:
        print(f"{own:>7.3f} {calls:>8}  {name}")


# -- table ------------------------------------------------------------------------


def _fmt(value: float | None, spec: str) -> str:
    """``value`` formatted with ``spec`` (e.g. ``"7.1f"``), or a dash of the same width."""
    width = int(spec.split(".")[0] or 0)
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-".rjust(width)
    return format(value, spec)


def print_table(results: list[RunResult]) -> None:
    header = (
        f"{'case':<22} {'N':>3} {'fps/client':>10} {'min fps':>8} {'p50 ms':>7} {'p95 ms':>7} "
        f"{'seen':>5} {'server CPU%':>11} {'CPU/N=1':>8} {'bench CPU%':>10} {'target':>6}"
    )
    print(header)
    print("-" * len(header))
    baseline: dict[str, float] = {}
    for r in results:
        if r.errors:
            print(f"{r.case:<22} {r.clients:>3} error: {'; '.join(r.errors)}")
            continue
        if r.clients == 1:
            baseline[r.case] = r.server_cpu
        ratio = r.server_cpu / baseline[r.case] if baseline.get(r.case) else None
        met = r.fps_min >= TARGET_FPS and r.server_cpu <= TARGET_CPU
        print(
            f"{r.case:<22} {r.clients:>3} {r.fps_mean:>10.1f} {r.fps_min:>8.1f} "
            f"{_fmt(r.latency_p50_ms, '7.1f')} {_fmt(r.latency_p95_ms, '7.1f')} "
            f"{'-' if r.delivered is None else format(100 * r.delivered, '.0f') + '%':>5} "
            f"{r.server_cpu:>11.1f} {_fmt(ratio, '8.2f')} {r.bench_cpu:>10.1f} {'yes' if met else 'NO':>6}"
        )
    print(
        f"\nfps/client: websocket frames per second per observer (mean; min over observers);"
        f"\np50/p95: slider value sent -> driven node's pose received, over all (value, observer);"
        f"\nseen: share of sent values whose pose reached an observer (others were coalesced);"
        f"\nserver CPU: rigidlab serve's utime+stime over the window, % of one core; CPU/N=1: ratio to"
        f"\nthe same case with one client in this run; bench CPU: this process (decodes every frame)."
        f"\ntarget: >= {TARGET_FPS:.0f} fps for every client and server <= {TARGET_CPU:.0f}% of one core."
    )


def _integers(parser: argparse.ArgumentParser, option: str, text: str, lo: int, hi: int) -> list[int]:
    """A comma-separated list of integers from ``lo`` to ``hi`` (the parser's error otherwise)."""
    try:
        values = [int(c) for c in text.split(",") if c]
    except ValueError:
        parser.error(f"{option}: expected comma-separated integers, got {text!r}")
    if not values or any(v < lo or v > hi for v in values):
        parser.error(f"{option}: expected integers from {lo} to {hi}, got {text!r}")
    return values


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--profiled-serve":
        separator = argv.index("--")
        return profiled_serve(argv[1], argv[separator + 1 :])
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=20.0, help="measured seconds per row (default 20)")
    parser.add_argument("--clients", default="1,10,30", help="comma-separated client counts (default 1,10,30)")
    parser.add_argument(
        "--scenes",
        default="sandbox,manipulator,manipulator-animate",
        help=f"comma-separated cases from {sorted(SPECS)}",
    )
    parser.add_argument("--profile", action="store_true", help="profile the server (inflates its CPU)")
    parser.add_argument("--per-client", action="store_true",
                        help="per-client rows: every browser its own live scene (--scenes from "
                             f"{list(DYNAMIC_SCENES)}, default all of them; --workers)")
    parser.add_argument("--workers", default="1,2", help="per-client rows: comma-separated worker counts")
    args = parser.parse_args(argv)
    if args.per_client:
        return main_per_client(parser, args)
    counts = _integers(parser, "--clients", args.clients, 1, 200)
    if not 0.5 <= args.duration <= 600:
        parser.error(f"--duration: expected 0.5 to 600 seconds, got {args.duration}")
    cases = [c for c in args.scenes.split(",") if c]
    unknown = [c for c in cases if c not in SPECS]
    if unknown:
        parser.error(f"--scenes: expected names from {sorted(SPECS)}, got {unknown}")

    OUT_DIR.mkdir(parents=True, exist_ok=True)
    results: list[RunResult] = []
    with tempfile.TemporaryDirectory(prefix="app_stream-") as tmp:
        for case in cases:
            for n in counts:
                print(f"running {SPECS[case].label} with {n} client(s) for {args.duration:g} s ...", flush=True)
                results.append(run_case(SPECS[case], n, args.duration, profile=args.profile, workdir=Path(tmp)))
    print()
    print(f"app_stream: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}, {args.duration:g} s per row, "
          f"driven at {RATE_HZ:.0f} Hz{' (server profiled: CPU inflated)' if args.profile else ''}\n")
    print_table(results)
    out = OUT_DIR / "app_stream.json"
    out.write_text(json.dumps([dataclasses.asdict(r) for r in results], indent=2))
    print(f"\nwrote {out.relative_to(ROOT)}")
    return 0 if all(not r.errors for r in results) else 1


def main_per_client(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    counts = _integers(parser, "--clients", args.clients, 1, 200)
    workers = _integers(parser, "--workers", args.workers, 1, 16)
    scenes = list(DYNAMIC_SCENES) if args.scenes == parser.get_default("scenes") else \
        [c for c in args.scenes.split(",") if c]
    unknown = [c for c in scenes if c not in DYNAMIC_SCENES]
    if unknown:
        parser.error(f"--scenes: expected names from {list(DYNAMIC_SCENES)}, got {unknown}")
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    results: list[PerClientResult] = []
    with tempfile.TemporaryDirectory(prefix="app_stream-") as tmp:
        for scene in scenes:
            for w in workers:
                for n in counts:
                    print(f"running per-client {scene}, {n} browser(s), {w} worker(s), {args.duration:g} s ...",
                          flush=True)
                    results.append(run_per_client(scene, n, w, args.duration, Path(tmp)))
    print()
    print(f"app_stream per-client: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}, "
          f"{args.duration:g} s per row\n")
    print_per_client_table(results)
    out = OUT_DIR / "app_stream_per_client.json"
    out.write_text(json.dumps([dataclasses.asdict(r) for r in results], indent=2))
    print(f"\nwrote {out.relative_to(ROOT)}")
    return 0 if all(not r.errors for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
