"""Displayed pace of every timed scene with one browser: does the clock keep real time?

For every timed scene at its default settings (and the cam-follower's
compliant run, at its default speed and past the jump speed, where the
follower flies), a real app (``create_app``, shared mode) is opened by one
headless Chromium (Debian's ``/usr/bin/chromium`` through Playwright, software
WebGL, as tests/browser does). Once the scene has moved, it is watched for
``--seconds`` of wall time and the table gives:

``pace``
    simulated seconds advanced per wall second, divided by what the controls
    ask for (the time scale, 1 by default; the cam's slow motion: one turn in
    *Slow motion* seconds), so 1.00 is real time (the cam: its set pace);
``waits``
    frames whose clock held because the chunk it needed was not computed yet
    (the scene then shows "Computing..."), and the longest such hold (s);
``start``
    wall seconds from the browser's registration (its first camera message) to the scene's first motion
    (the first chunk's computation, kernels loaded or compiled included);
``sim CPU/frame``
    CPU time of the worker processes (the simulation jobs) over the window,
    divided by the frames displayed in it; the target is <= 1 ms per frame;
``loop p99``
    the loop thread's wall time per frame (p99; target <= 2 ms).

The machine's load average is printed with the table: the browser alone
takes most of one core, so run it when the machine is otherwise idle.

Run: ``python bench/scene_pace.py`` (``--scenes a,b``, ``--seconds S``).
Writes ``bench/out/scene_pace.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rigidlab.app.server import create_app  # noqa: E402

CHROMIUM = os.environ.get("RIGIDLAB_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]
VIEWPORT = {"width": 1200, "height": 750}
TARGET_CPU_MS = 1.0

#: (row name, scene, state values loaded before watching). Defaults unless named.
CASES: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("gyroscope", "gyroscope", {}),
    ("free_body", "free_body", {}),
    ("linkages", "linkages", {}),
    ("rolling_disk", "rolling_disk", {}),
    ("cam_follower", "cam_follower", {}),
    ("cam compliant", "cam_follower", {"compliant": True}),
    ("cam compliant 1300 rpm", "cam_follower", {"compliant": True, "rpm": 1300.0}),
    ("bicycle", "bicycle", {}),
    ("modes", "modes", {}),
)


def _ticks_per_second() -> float:
    return float(os.sysconf("SC_CLK_TCK"))


def _cpu_seconds(pids: list[int]) -> float:
    """User + system CPU seconds of the processes ``pids`` (those that are gone count 0)."""
    total = 0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += int(fields[11]) + int(fields[12])  # utime, stime (fields 14 and 15)
    return total / _ticks_per_second()


def _worker_pids(app: Any) -> list[int]:
    pool = getattr(app.executor, "_pool", None)
    processes = getattr(pool, "_processes", None) or {}
    return list(processes)


class _Clock:
    """The scene's display clock as a frame leaves it: (wall s, clock, nominal rate, waiting) per frame.

    The clock is in the scene's own unit: simulated seconds (nominal rate: the
    time scale) or, for the cam, the cam angle (rad; nominal rate: one turn in
    *Slow motion* seconds).
    """

    def __init__(self, scene: Any) -> None:
        self.scene = scene
        self.samples: list[tuple[float, float, float, bool]] = []
        self._angle = 0.0
        self._last: float | None = None
        self._lock = threading.Lock()
        update = scene.update

        def timed(dt: float) -> None:
            update(dt)
            self._record()

        scene.update = timed

    def _cam_angle(self) -> float:
        scene = self.scene
        if scene.compliant:
            rev = scene.revolution
            return scene.sim_time * rev.speed if rev is not None else 0.0
        a = scene.cam_angle  # the closed form's display angle (wraps at 2 pi): unwrapped here
        if self._last is not None:
            d = (a - self._last) % (2.0 * math.pi)
            self._angle += d if d < math.pi else d - 2.0 * math.pi
        self._last = a
        return self._angle

    def _record(self) -> None:
        scene = self.scene
        if scene.name == "cam_follower":
            clock = self._cam_angle()
            turn = float(scene.controls.value("turn_seconds"))
            rate = 2.0 * math.pi / turn if scene.playing else 0.0
            waiting = bool(scene.waiting) if scene.compliant else scene.revolution is None
        else:
            clock = float(scene.sim_time)
            playback = getattr(scene, "playback", None)
            rate = float(playback.time_scale) if playback is not None else 1.0
            waiting = bool(getattr(scene, "waiting", False))
        with self._lock:
            self.samples.append((time.perf_counter(), clock, rate, waiting))

    def since(self, t0: float) -> np.ndarray:
        with self._lock:
            rows = [s for s in self.samples if s[0] >= t0]
        return np.array(rows, dtype=float).reshape(-1, 4)


def _open_page(browser: Any, app: Any) -> Any:
    known = set(app.client_ids())
    context = browser.new_context(viewport=VIEWPORT)
    page = context.new_page()
    page.goto(app.url, timeout=60_000)
    page.wait_for_selector("canvas", timeout=60_000)
    app.wait_for_client(known, timeout=60.0)
    return context


def _moving(clock: _Clock) -> bool:
    s = clock.since(0.0)
    return s.shape[0] > 1 and s[-1, 1] > s[0, 1]


def run_case(browser: Any, name: str, scene_name: str, values: dict[str, Any], seconds: float,
             settle: float) -> dict[str, Any]:
    app = create_app(port=0, scene=scene_name)
    context = None
    try:
        scene = app.scene_for()
        if values:
            refused = scene.load_state({"scene": scene_name, "values": values})
            if refused:
                raise RuntimeError(f"{name}: state refused: {refused}")
        clock = _Clock(scene)
        context = _open_page(browser, app)
        connected = time.perf_counter()
        deadline = time.monotonic() + 300.0
        while not _moving(clock) and time.monotonic() < deadline and scene.paused_error is None:
            time.sleep(0.02)
        first = clock.since(0.0)
        moved = first[np.flatnonzero(first[:, 1] > first[0, 1])[0], 0] if _moving(clock) else math.nan
        start = max(moved - connected, 0.0)
        time.sleep(settle)
        pids = _worker_pids(app)
        cpu0, frames0, t0 = _cpu_seconds(pids), scene.frames, time.perf_counter()
        time.sleep(seconds)
        cpu1, frames1, t1 = _cpu_seconds(pids), scene.frames, time.perf_counter()
        s = clock.since(t0)
        frames = max(frames1 - frames0, 1)
        nominal = float(np.sum(np.diff(s[:, 0]) * s[1:, 2])) if s.shape[0] > 1 else math.nan
        advanced = float(s[-1, 1] - s[0, 1]) if s.shape[0] > 1 else 0.0
        waits = s[:, 3].astype(bool)
        longest, run = 0.0, 0.0
        for k in range(1, s.shape[0]):
            run = run + (s[k, 0] - s[k - 1, 0]) if waits[k] else 0.0
            longest = max(longest, run)
        loop = np.array(list(scene.frame_seconds)[-frames:], dtype=float).reshape(-1, 2)
        return {
            "case": name, "scene": scene_name, "values": values, "seconds": t1 - t0, "frames": frames,
            "fps": frames / (t1 - t0), "pace": advanced / nominal if nominal > 0 else math.nan,
            "wait_frames": int(waits.sum()), "longest_wait_s": longest, "start_s": start,
            "sim_cpu_ms_per_frame": 1e3 * (cpu1 - cpu0) / frames,
            "loop_p99_ms": float(np.percentile(loop[:, 0], 99) * 1e3) if loop.size else math.nan,
            "paused": scene.paused_error,
        }
    finally:
        if context is not None:
            context.close()
        app.stop()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="wall seconds watched per case")
    parser.add_argument("--settle", type=float, default=3.0, help="wall seconds after the first motion")
    parser.add_argument("--scenes", default="", help="comma-separated case or scene names (default: all)")
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    wanted = [w for w in args.scenes.split(",") if w]
    cases = [c for c in CASES if not wanted or c[0] in wanted or c[1] in wanted]
    load_before = os.getloadavg()
    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        try:
            for name, scene_name, values in cases:
                rows.append(run_case(browser, name, scene_name, values, args.seconds, args.settle))
                r = rows[-1]
                print(f"  {name}: pace {r['pace']:.3f}, {r['wait_frames']} waiting frames, "
                      f"{r['sim_cpu_ms_per_frame']:.3f} ms sim CPU/frame", file=sys.stderr, flush=True)
        finally:
            browser.close()
    load_after = os.getloadavg()
    print(f"Displayed pace with one headless Chromium, {args.seconds:g} s watched per row after the first "
          f"motion + {args.settle:g} s; load average {load_before[0]:.2f} before, {load_after[0]:.2f} after "
          f"({os.cpu_count()} cores)")
    header = ("case", "pace", "waiting frames", "longest wait s", "start s", "sim CPU/frame ms", "fps",
              "loop p99 ms", "ok")
    print("| " + " | ".join(header) + " |")
    print("|---|" + "---:|" * (len(header) - 2) + "---|")
    failed = 0
    for r in rows:
        ok = (r["paused"] is None and r["pace"] >= 0.98 and r["wait_frames"] == 0
              and r["sim_cpu_ms_per_frame"] <= TARGET_CPU_MS)
        failed += not ok
        print(f"| {r['case']} | {r['pace']:.3f} | {r['wait_frames']} | {r['longest_wait_s']:.2f} | "
              f"{r['start_s']:.2f} | {r['sim_cpu_ms_per_frame']:.3f} | {r['fps']:.1f} | {r['loop_p99_ms']:.2f} | "
              f"{'yes' if ok else 'NO'}{'' if r['paused'] is None else ' (paused: ' + r['paused'] + ')'} |")
    out = Path(__file__).resolve().parent / "out"
    out.mkdir(exist_ok=True)
    (out / "scene_pace.json").write_text(json.dumps(rows, indent=1))
    print(f"{len(rows) - failed} of {len(rows)} rows at 1x with no wait and <= {TARGET_CPU_MS:g} ms of "
          f"simulation CPU per frame; JSON in {out / 'scene_pace.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
