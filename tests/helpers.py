"""Small helpers shared by the app and browser tests."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


#: The least time any wait of a test may take (s): one generous timeout for everything a test waits on, so that
#: a machine running the suite beside other work makes a test slower, never red. A passing test never waits it.
MIN_WAIT = 120.0


def wait_until(predicate: Callable[[], object], timeout: float = MIN_WAIT, *, interval: float = 0.02) -> bool:
    """Poll ``predicate`` until it is true; the session loop runs at ~60 Hz.

    Returns True as soon as ``predicate()`` is true (so ``assert wait_until(...)``
    reads naturally); raises ``AssertionError`` after ``timeout`` seconds, and
    never before :data:`MIN_WAIT` (a shorter ``timeout`` states what the wait
    takes on a quiet machine; a loaded one may need more).
    """
    timeout = max(timeout, MIN_WAIT)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    if predicate():  # one last look after the deadline
        return True
    raise AssertionError(f"condition not met within {timeout:g} s")


def wait_for_frames(scene: object, n: int, timeout: float = 120.0) -> None:
    """Wait until ``scene``'s loop has run ``n`` more frames (60 a second when the machine keeps up).

    A check that something does *not* happen (a paused clock, an untouched
    session) waits on the loop it would happen in, not on the clock: on a
    loaded machine the wait grows with the loop, and the check keeps its meaning.
    """
    start = scene.frames
    wait_until(lambda: scene.frames >= start + n, timeout)


def process_group_gone(pgid: int) -> bool:
    """Whether no process of process group ``pgid`` is left (a server started in its own session)."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


class ProcessOutput:
    """A subprocess's output (stdout, with stderr merged into it), read line by line by a thread, in order."""

    def __init__(self, process: subprocess.Popen) -> None:
        self.lines: list[str] = []
        self._lock = threading.Lock()
        threading.Thread(target=self._read, args=(process,), daemon=True).start()

    def _read(self, process: subprocess.Popen) -> None:
        assert process.stdout is not None
        for line in process.stdout:
            with self._lock:
                self.lines.append(line.rstrip("\n"))

    def text(self) -> str:
        with self._lock:
            return "\n".join(self.lines)

    def count(self, pattern: str) -> int:
        """Lines matching the regular expression ``pattern`` (``^`` and ``$`` match at each line)."""
        return len(re.findall(pattern, self.text(), flags=re.MULTILINE))


def start_serving(*serve_args: str) -> tuple[subprocess.Popen, ProcessOutput]:
    """Start ``python -m rigidlab.app.cli serve *serve_args`` from the repository; the process and its output.

    Stop it with :func:`stop_serving` (in a ``finally``).
    """
    process = subprocess.Popen([sys.executable, "-m", "rigidlab.app.cli", "serve", *serve_args], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return process, ProcessOutput(process)


def stop_serving(process: subprocess.Popen) -> None:
    """Stop a server started by :func:`start_serving` as Ctrl-C does (SIGINT); killed if it still runs
    :data:`MIN_WAIT` later."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=MIN_WAIT)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait(timeout=10.0)


#: Lines of a server's output that report a failure: a traceback, an exception's name (``OSError: ...``),
#: an "Exception ignored" note of the interpreter, or a record logged at level ERROR or CRITICAL.
FAILURE_LINE = r"Traceback|\w*(Error|Exception)\b|^(\[\w+( \d+)?\] )?(ERROR|CRITICAL) "


def failure_lines(text: str) -> list[str]:
    """The lines of ``text`` that match :data:`FAILURE_LINE`."""
    return [line for line in text.splitlines() if re.search(FAILURE_LINE, line)]


def send_value(owner: object, key: str, raw: object, *, timeout: float = MIN_WAIT) -> bool:
    """Deliver ``raw`` to control ``key`` exactly as a browser would (through the gate).

    ``owner`` is a scene, a session or a :class:`rigidlab.app.panel.ControlPanel`.
    Returns whether the gate accepted the value; an accepted value has reached
    the panel when this returns (text that does not parse is then pending).
    Button controls take ``raw=True`` (a click); button groups the option.
    """
    from rigidlab.app.controls import Button, ButtonGroup, Refused

    panel = getattr(owner, "controls", owner)
    spec = panel.specs[key]
    handle = panel.handles[key]
    version = panel.version
    before = handle.value
    try:
        checked = spec.check(raw)
    except Refused:
        checked = None
        accepted = False
    else:
        accepted = True
    panel.gate.submit(handle, raw).result(timeout)
    if not accepted:
        return False
    if not isinstance(spec, (Button, ButtonGroup)) and checked == before:
        return True  # unchanged: viser runs no callback
    wait_until(lambda: panel.version > version or key in panel._pending, timeout)
    return True


def click(owner: object, key: str, option: object = True, *, timeout: float = MIN_WAIT) -> None:
    """Click button ``key`` (or ``option`` of a button group) as a browser would."""
    assert send_value(owner, key, option, timeout=timeout)
