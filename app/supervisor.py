"""Per-client mode on every core: one port served by N worker processes.

``rigidlab serve --mode per-client --workers N`` starts this supervisor. It
opens N listening sockets on the port, one per worker slot, all with
``SO_REUSEPORT``, starts N copies of ``rigidlab serve`` (each a whole app:
viser server, session loop, process pool), hands each its slot's socket,
and watches them:

* **Balancing** is the kernel's: with ``SO_REUSEPORT`` every new TCP
  connection goes to one of the listening sockets (a hash of the addresses,
  so spread evenly over many browsers, not in turn). A browser's page and
  its websocket may reach different workers; its session lives in the
  worker that holds its websocket. Nothing in between copies bytes.
* **The sockets are the supervisor's**: it keeps every slot's socket open,
  so a worker that dies takes none with it. Connections the kernel queued
  on the dead worker's socket, and those it hands that slot meanwhile, wait
  in the socket's queue for the worker's replacement, which accepts them.
  (When the worker held the socket alone, its death closed it and the
  kernel reset every connection queued there: 1 in 4 browsers that
  connected right after a SIGKILL.) A slot left stopped has its socket
  closed, so the kernel spreads the connections over the other slots.
* **Isolation**: a worker is a separate process; a crash takes its own
  browsers' sessions only: the viser client reconnects on its own (or on
  reload), with a new session.
* **Reporting and restarts**: a worker that ends unexpectedly is reported
  (exit status or signal) and replaced at once by a **spare**: a process
  that has imported the app and started its process pool, and waits (no
  socket) for the message ``start I/N`` on its control socket, which
  carries the slot's listening socket; it then listens within a second,
  where a worker started cold took 19-25 s on a busy 2-core machine
  (imports, then the fork server's preload). A new spare starts once every
  worker serves. Without a spare (two ends in a row, or a spare that keeps
  failing) the worker is started cold (its slot's connections wait that
  long). A worker that fails again within :data:`CRASH_WINDOW` seconds of
  its start three times in a row is left stopped, with a message.

Shared mode stays one process: its state is one. Beyond one machine, the
same workers sit behind a standard reverse proxy (docs/app.md, docs/nginx.conf).

Linux (and other kernels with ``SO_REUSEPORT`` load balancing) only; on a
system without it ``--workers`` above 1 is refused with a message.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TextIO

__all__ = ["default_workers", "reuse_port_supported", "serve_workers", "CRASH_WINDOW"]

#: A worker that ends this soon (s) after it started counts as a failed start.
CRASH_WINDOW = 10.0
#: Failed starts in a row after which a worker slot is left stopped.
MAX_FAILED_STARTS = 3
#: First characters of the lines of viser's start-up banner (not repeated per worker).
_BANNER = ("\u256d", "\u2502", "\u2570")
#: Seconds a worker gets to print its ready line.
STARTUP_TIMEOUT = 120.0


def default_workers() -> int:
    """The default ``--workers`` of per-client mode: the number of cores this process may use."""
    with contextlib.suppress(AttributeError, OSError):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def reuse_port_supported() -> bool:
    """Whether sockets here can share a port with ``SO_REUSEPORT`` (Linux >= 3.9, the BSDs)."""
    if not hasattr(socket, "SO_REUSEPORT"):
        return False
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
    except OSError:
        return False
    return True


#: Connections a slot's socket queues while no worker accepts them (a replacement starting).
BACKLOG = 128


def listening_sockets(host: str, port: int, count: int) -> list[socket.socket]:
    """``count`` listening ``SO_REUSEPORT`` sockets on ``host:port`` (port 0: one free port for all).

    The kernel spreads new connections over them; one is handed to each
    worker slot (see the module docstring).

    Raises
    ------
    OSError
        When the port is in use by a socket without ``SO_REUSEPORT`` or
        cannot be bound.
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sockets: list[socket.socket] = []
    try:
        for _ in range(count):
            sock = socket.socket(family, socket.SOCK_STREAM)
            sockets.append(sock)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            sock.bind((host, port))
            port = sock.getsockname()[1]  # (port 0: the others share the one the first got)
            sock.listen(BACKLOG)
    except BaseException:
        for sock in sockets:
            sock.close()
        raise
    return sockets


@dataclass
class _Worker:
    """One worker slot: its listening socket, its process, when it started and how often it failed to start."""

    index: int
    sock: socket.socket
    process: subprocess.Popen | None = None
    started: float = 0.0
    failed_starts: int = 0
    ready: threading.Event = field(default_factory=threading.Event)
    stopped: bool = False  # left stopped after repeated failures


def _exit_text(code: int) -> str:
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"was killed by {signal.Signals(-code).name}"
        return f"was killed by signal {-code}"
    return f"exited with status {code}"


class Supervisor:
    """Starts, watches and stops the worker processes of one port (see the module docstring)."""

    def __init__(self, worker_args: Sequence[str], sockets: Sequence[socket.socket], *,
                 out: TextIO = sys.stdout) -> None:
        self.worker_args = list(worker_args)
        self.workers = [_Worker(i, sock) for i, sock in enumerate(sockets)]
        self.out = out
        self._print_lock = threading.Lock()
        self._stop = threading.Event()
        self._slots = threading.Lock()  # held while the watcher starts processes, and by stop
        self.spare: subprocess.Popen | None = None  # a warm process waiting to replace a worker
        self.spare_control: socket.socket | None = None  # the supervisor's end of the spare's control socket
        self.spare_ready = threading.Event()
        self.failed_spares = 0

    def say(self, text: str) -> None:
        with self._print_lock:
            print(text, file=self.out, flush=True)

    def _command(self, worker: _Worker) -> list[str]:
        return [sys.executable, "-m", "rigidlab.app.cli", "serve", *self.worker_args,
                "--worker-index", f"{worker.index + 1}/{len(self.workers)}", "--listen-fd", str(worker.sock.fileno())]

    def _popen(self, command: list[str], **kwargs) -> subprocess.Popen:
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
            start_new_session=True,  # Ctrl-C reaches the supervisor only; it stops the workers in order
            **kwargs,
        )
        threading.Thread(target=self._forward, args=(process,), daemon=True,
                         name=f"rigidlab-worker-{process.pid}-log").start()
        return process

    def start(self, worker: _Worker) -> None:
        """Start ``worker`` cold (a new process, given the slot's socket)."""
        worker.ready.clear()
        worker.process = self._popen(self._command(worker), pass_fds=(worker.sock.fileno(),))
        worker.started = time.monotonic()

    def start_spare(self) -> None:
        """Start a spare worker (see the module docstring); its control socket is a socket pair's end."""
        self.spare_ready.clear()
        ours, theirs = socket.socketpair()
        with theirs:  # (the spare's copy is its own; closing ours tells it that the supervisor is gone)
            command = [sys.executable, "-m", "rigidlab.app.cli", "serve", *self.worker_args, "--spare",
                       "--control-fd", str(theirs.fileno())]
            try:
                self.spare = self._popen(command, pass_fds=(theirs.fileno(),))
            except BaseException:
                ours.close()
                raise
        self.spare_control = ours

    def _close_spare_control(self) -> None:
        control, self.spare_control = self.spare_control, None
        if control is not None:
            control.close()

    def replace(self, worker: _Worker) -> bool:
        """Hand ``worker``'s slot (its socket) to the spare; False if there is none (or it cannot take it)."""
        spare, self.spare = self.spare, None
        control, self.spare_control = self.spare_control, None
        with contextlib.ExitStack() as closing:
            if control is not None:
                closing.callback(control.close)  # (the message stays queued for the spare)
            if spare is None or control is None or spare.poll() is not None:
                if spare is not None:  # it ended: what is left of its process group goes with it
                    _end_group(spare)
                return False
            worker.ready.clear()
            worker.process = spare
            worker.started = time.monotonic()
            with contextlib.suppress(OSError):  # it ended meanwhile: reported as that worker's end at the next look
                socket.send_fds(control, [f"start {worker.index + 1}/{len(self.workers)}".encode()],
                                [worker.sock.fileno()])
        return True

    def _owner(self, process: subprocess.Popen) -> _Worker | None:
        return next((w for w in self.workers if w.process is process), None)

    def _forward(self, process: subprocess.Popen) -> None:
        """Print a worker's output with its number (a spare's with "spare"); notice its ready line."""
        assert process.stdout is not None
        for line in process.stdout:
            line = line.rstrip("\n")
            worker = self._owner(process)
            if worker is not None and line.startswith("rigidlab: worker ready"):
                worker.ready.set()
            elif line.startswith("rigidlab: spare worker ready") and process is self.spare:
                self.spare_ready.set()
            if line[:1] in _BANNER or not line.strip():
                continue  # viser's boxed address banner, the same in every worker
            self.say(f"[worker {worker.index + 1}] {line}" if worker is not None else f"[spare] {line}")

    def wait_ready(self, timeout: float = STARTUP_TIMEOUT) -> list[int]:
        """Wait until every worker printed its ready line; the (1-based) numbers of those that did not."""
        deadline = time.monotonic() + timeout
        missing = []
        for worker in self.workers:
            while not worker.ready.wait(0.1):
                if worker.process is None or worker.process.poll() is not None or time.monotonic() > deadline:
                    missing.append(worker.index + 1)
                    break
        return missing

    def watch(self) -> None:
        """Until :meth:`stop`: report a worker that ends and start it again (see the module docstring)."""
        while not self._stop.wait(0.1):
            with self._slots:
                if self._stop.is_set():
                    return
                if self._look():
                    return

    def _look(self) -> bool:
        """One look of :meth:`watch`; True when no worker is left running."""
        self._watch_spare()
        for worker in self.workers:
            process = worker.process
            if worker.stopped or process is None or process.poll() is None:
                continue
            code = process.returncode
            _end_group(process)
            alive = sum(1 for w in self.workers if w.process is not None and w.process.poll() is None)
            self.say(f"rigidlab: worker {worker.index + 1} (pid {process.pid}) {_exit_text(code)}; its "
                     f"browsers lost their sessions and reconnect to a live worker ({alive} running) "
                     "when the page reloads")
            if time.monotonic() - worker.started < CRASH_WINDOW:
                worker.failed_starts += 1
            else:
                worker.failed_starts = 0
            if worker.failed_starts >= MAX_FAILED_STARTS:
                worker.stopped = True
                worker.sock.close()  # the kernel hands its share of the connections to the other slots
                self.say(f"rigidlab: worker {worker.index + 1} failed {MAX_FAILED_STARTS} times within "
                         f"{CRASH_WINDOW:g} s of starting; it stays stopped (see its output above)")
                continue
            if self.replace(worker):
                how = "the spare worker took its place"
            else:
                self.start(worker)
                how = "started cold, no spare was running"
            self.say(f"rigidlab: worker {worker.index + 1} restarted (pid {worker.process.pid}; {how})")
        if all(w.stopped for w in self.workers):
            self.say("rigidlab: no worker is running; stopping")
            return True
        return False

    def _watch_spare(self) -> None:
        """Report a spare that ended; start one when every live worker serves (after a start or a replacement,
        so that it does not slow them down); give up on spares after repeated failures."""
        spare = self.spare
        if spare is not None and spare.poll() is not None:
            self.spare = None
            self._close_spare_control()
            _end_group(spare)
            self.failed_spares += 1
            self.say(f"rigidlab: the spare worker (pid {spare.pid}) {_exit_text(spare.returncode)}"
                     + ("; no more spares: a worker that ends is started cold"
                        if self.failed_spares >= MAX_FAILED_STARTS else ""))
        if self.spare is None and self.failed_spares < MAX_FAILED_STARTS and all(
                w.stopped or (w.ready.is_set() and w.process is not None and w.process.poll() is None)
                for w in self.workers):
            self.start_spare()

    def stop(self, timeout: float = 20.0) -> None:
        """Ask every worker to stop (SIGINT, as Ctrl-C), then kill the ones still running after ``timeout``.

        A second Ctrl-C while waiting kills the workers at once.
        """
        self._stop.set()
        with self._slots:  # (the watcher starts nothing from here on)
            running = [w.process for w in self.workers if w.process is not None and w.process.poll() is None]
            spare, self.spare = self.spare, None
            self._close_spare_control()
        if spare is not None:  # it holds nothing: killed with its process group (interrupted in its imports, it
            _end_group(spare)  # printed a KeyboardInterrupt traceback)
            with contextlib.suppress(subprocess.TimeoutExpired, KeyboardInterrupt):
                spare.wait(timeout=10.0)
        for process in running:
            with contextlib.suppress(ProcessLookupError):
                process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + timeout
        try:
            for process in running:
                try:
                    process.wait(timeout=max(0.1, deadline - time.monotonic()))
                except subprocess.TimeoutExpired:
                    process.kill()
        except KeyboardInterrupt:
            self.say("rigidlab: stopping the workers now")
        for process in running:
            if process.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    process.kill()
                with contextlib.suppress(subprocess.TimeoutExpired, KeyboardInterrupt):
                    process.wait(timeout=10.0)
            _end_group(process)


def _end_group(process: subprocess.Popen) -> None:
    """Kill what is left of an ended worker's process group (its own session: the worker and its descendants).

    A worker killed outright (SIGKILL, the out-of-memory killer) cannot stop
    its executor: its fork server and a pool process kept each other alive
    (each holds the other's pipe) and outlived it.
    """
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)


def unignore_sigint():
    """Give SIGINT Python's default handler (KeyboardInterrupt) if it is ignored, as in a process started as a
    background job of a shell without job control; returns the ignored handler to restore, or None when
    SIGINT was not ignored (main thread only)."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        return None
    return signal.signal(signal.SIGINT, signal.default_int_handler)


def serve_workers(*, host: str, port: int, count: int, worker_args: Sequence[str], out: TextIO = sys.stdout,
                  err: TextIO = sys.stderr, on_ready: Callable[[int], None] | None = None) -> int:
    """Run ``count`` per-client workers on ``host:port`` until Ctrl-C or SIGTERM; the exit status.

    ``worker_args`` are the ``rigidlab serve`` options every worker gets
    besides ``--host``, ``--port`` and ``--mode per-client``; ``on_ready``
    is called with the port once the workers serve (the LAN notes).
    """
    if not reuse_port_supported():
        print("rigidlab serve: --workers above 1 needs SO_REUSEPORT, which this system does not offer; "
              "use --workers 1", file=err)
        return 2
    try:
        sockets = listening_sockets(host, port, count)
    except OSError as exc:
        print(f"rigidlab serve: cannot listen on {host}:{port}: {exc.strerror or exc}; choose another "
              "with --port (--port 0 picks a free one)", file=err)
        return 2
    with contextlib.ExitStack() as closing:
        for sock in sockets:
            closing.enter_context(sock)  # closed after the workers stopped (a stopped slot's already is)
        bound = sockets[0].getsockname()[1]
        args = ["--host", host, "--port", str(bound), "--mode", "per-client", *worker_args]
        supervisor = Supervisor(args, sockets, out=out)
        stop_signal = threading.Event()
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGTERM, lambda *_: stop_signal.set()) if main else None
        # started with SIGINT ignored (a background job of a script): Ctrl-C's signal stops it all the same,
        # and the workers, started from here, get the default (see app.cli._stop_signals_as_interrupt)
        previous_int = unignore_sigint() if main else None
        try:
            for worker in supervisor.workers:
                supervisor.start(worker)
            missing = supervisor.wait_ready()
            if len(missing) == count:
                supervisor.stop()
                print("rigidlab serve: no worker started (see their output above)", file=err)
                return 1
            from rigidlab.app.server import page_url

            supervisor.say(f"rigidlab: {count - len(missing)} of {count} workers serve port {bound} "
                           "(per-client mode; the kernel spreads the browsers over them)")
            supervisor.say(f"rigidlab: open {page_url(host, bound)}")
            if on_ready is not None:
                on_ready(bound)
            supervisor.say("rigidlab: press Ctrl-C to stop")
            watcher = threading.Thread(target=supervisor.watch, name="rigidlab-supervisor", daemon=True)
            watcher.start()
            while watcher.is_alive() and not stop_signal.wait(0.2):
                pass
        except KeyboardInterrupt:
            supervisor.say("\nrigidlab: stopping")
        finally:
            supervisor.stop()
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)
            if previous_int is not None:
                signal.signal(signal.SIGINT, previous_int)
    return 0
