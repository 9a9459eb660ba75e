"""Command line: ``rigidlab serve`` and ``rigidlab bench``.

Examples
--------
``rigidlab serve``
    Serve every scene on http://127.0.0.1:8080 (loopback only).
``rigidlab serve --host 0.0.0.0 --mode per-client``
    Serve a classroom LAN; every browser gets its own state, the browsers
    spread over one worker process per core (``--workers N`` to choose;
    :mod:`rigidlab.app.supervisor`).
``rigidlab serve --present --state demo.json``
    Start in presenter view from a saved scene state (Share > Download state).
``rigidlab bench``
    List the benchmarks under ``bench/``.
``rigidlab bench rotations app_stream``
    Run ``bench/rotations.py`` then ``bench/app_stream.py``.
"""

from __future__ import annotations

import argparse
import errno
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main", "bench_dir", "available_benchmarks"]


def bench_dir() -> Path:
    """The ``bench/`` folder of the source tree (next to ``app/``)."""
    return Path(__file__).resolve().parent.parent / "bench"


def available_benchmarks() -> list[str]:
    """Names of the benchmark scripts ``bench/<name>.py``, sorted."""
    folder = bench_dir()
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.glob("*.py") if not p.name.startswith("_"))


def _lan_addresses() -> list[str]:
    try:
        infos = socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)
    except OSError:
        return []
    return sorted({info[4][0] for info in infos if not info[4][0].startswith("127.")})


def _port(text: str) -> int:
    """argparse type of ``--port``: an integer from 0 to 65535."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer from 0 to 65535, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"expected an integer from 0 to 65535, got {port}")
    return port


def _is_loopback(host: str) -> bool:
    return host in ("localhost", "::1") or host.startswith("127.")


def _port_free(host: str, port: int) -> OSError | None:
    """None if ``host:port`` can be bound now, else the error (port 0 is always free)."""
    if port == 0:
        return None
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as exc:
            return exc
    return None


#: Seconds ``--host`` may take to resolve before ``rigidlab serve`` gives up.
HOST_TIMEOUT = 4.0


def _host_problem(host: str, timeout: float = HOST_TIMEOUT) -> str | None:
    """Why ``host`` cannot be served on (it does not resolve within ``timeout`` seconds, or is not an address
    of this machine), or None. viser binds in a thread of its own and waited forever for a server that
    could not start: an unresolvable ``--host`` hung the command without a word."""
    if host in ("", "0.0.0.0", "::"):
        return None
    found: list = []

    def resolve() -> None:
        try:
            found.append(socket.getaddrinfo(host, None, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE))
        except (OSError, UnicodeError) as exc:
            found.append(exc)

    thread = threading.Thread(target=resolve, name="rigidlab-resolve", daemon=True)
    thread.start()
    thread.join(timeout)
    if not found:
        return f"{host!r} did not resolve within {timeout:g} s"
    if isinstance(found[0], Exception):
        exc = found[0]
        return f"cannot resolve {host!r} ({getattr(exc, 'strerror', None) or exc})"
    family, _, _, _, address = found[0][0]
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((address[0], 0, *address[2:]))
        except OSError as exc:
            return f"cannot listen on {host!r} ({address[0]}: {exc.strerror or exc})"
    return None


def _check_host_first(argv: list[str]) -> int | None:
    """``rigidlab serve --host H``: 2 (and one line) if ``H`` cannot be served on, checked before the parser
    imports the scenes (seconds), so the answer comes within :data:`HOST_TIMEOUT`; None otherwise."""
    if not argv or argv[0] != "serve" or "--worker-index" in argv or "--spare" in argv:
        return None
    early = argparse.ArgumentParser(add_help=False)
    early.add_argument("--host", default=None)
    try:
        known, _ = early.parse_known_args(argv[1:])
    except SystemExit:
        return None  # the full parser reports it
    if known.host is None:
        return None
    problem = _host_problem(known.host)
    if problem is None:
        return None
    print(f"rigidlab serve: --host: {problem}; use an address of this machine, such as 127.0.0.1 "
          "or 0.0.0.0 (every interface)", file=sys.stderr)
    return 2


def _positive_workers(text: str) -> int:
    """argparse type of ``--workers``: an integer from 1 to 64."""
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer from 1 to 64, got {text!r}") from None
    if not 1 <= count <= 64:
        raise argparse.ArgumentTypeError(f"expected an integer from 1 to 64, got {count}")
    return count


def _worker_index(text: str) -> tuple[int, int]:
    """argparse type of the internal ``--worker-index I/N``."""
    try:
        i, n = (int(x) for x in text.split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected I/N, got {text!r}") from None
    if not 1 <= i <= n:
        raise argparse.ArgumentTypeError(f"expected I/N with 1 <= I <= N, got {text!r}")
    return i, n


def _exit_with_parent() -> None:
    """A worker stops when its supervisor is gone (killed without the chance to stop it)."""
    import os

    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os.kill(os.getpid(), signal.SIGINT)
                return

    threading.Thread(target=watch, name="rigidlab-parent-watch", daemon=True).start()


def _lan_notes(host: str, port: int, mode: str) -> None:
    """For a host other than loopback: the LAN addresses to open, and the no-password warning."""
    if _is_loopback(host):
        return
    from rigidlab.app.server import page_url

    for address in _lan_addresses():
        print(f"rigidlab: on the LAN: {page_url(address, port)}", flush=True)
    warning = (f"rigidlab: warning: serving on {host}: anyone who can reach this address can "
               "open the page, with no password")
    if mode == "shared":
        warning += (", and every browser drives the same scene; for a class of students exploring "
                    "on their own, use --mode per-client")
    print(warning + ".", file=sys.stderr, flush=True)


def _serve(args: argparse.Namespace) -> int:
    from rigidlab.app import state as state_codec
    from rigidlab.app.supervisor import default_workers, serve_workers

    worker = args.worker_index
    workers = args.workers
    if args.mode == "shared" and workers is not None and workers > 1:
        print("rigidlab serve: --workers: shared mode runs one process (its scene state is one); "
              "use --mode per-client to spread browsers over several workers", file=sys.stderr)
        return 2
    if worker is None and not args.spare and args.mode == "per-client":
        workers = default_workers() if workers is None else workers
        if workers > 1:
            if args.state is not None:  # refuse a bad file once, not in every worker
                try:
                    state_codec.load_file(args.state)
                except state_codec.StateError as exc:
                    print(f"rigidlab serve: --state: {exc}", file=sys.stderr)
                    return 2
            passed = [] if args.scene is None else ["--scene", args.scene]
            passed += ["--present"] if args.present else []
            passed += [] if args.state is None else ["--state", args.state]
            if args.model:  # refuse a bad model file once, not in every worker
                status = _check_models(args.model)
                if status is not None:
                    return status
                passed += [arg for path in args.model for arg in ("--model", path)]
            warm = _warm_kernels()  # once for every worker process (they load the kernels it compiles)
            try:
                return serve_workers(host=args.host, port=args.port, count=workers, worker_args=passed,
                                     on_ready=lambda port: _lan_notes(args.host, port, "per-client"))
            finally:
                if warm is not None and warm.poll() is None:
                    warm.terminate()

    state = None
    if args.state is not None:
        try:
            state = state_codec.load_file(args.state)
        except state_codec.StateError as exc:
            print(f"rigidlab serve: --state: {exc}", file=sys.stderr)
            return 2
    if args.spare:
        return _serve_spare(args, state)
    busy = None if worker is not None else _port_free(args.host, args.port)  # a worker shares the port
    if busy is not None:
        reason = "is in use" if busy.errno == errno.EADDRINUSE else f"cannot be used ({busy.strerror or busy})"
        print(f"rigidlab serve: port {args.port} on {args.host} {reason}; choose another with --port "
              "(--port 0 picks a free one)", file=sys.stderr)
        return 2
    return _run_app(args, state, worker)


def _check_models(paths: Sequence[str]) -> int | None:
    """Exit status 2 after one line on stderr for the first model file that cannot be used (None: all good)."""
    from rigidlab.app.model_file import ModelFileError
    from rigidlab.app.scenes.model import model_scene_classes

    try:
        model_scene_classes(paths)
    except ModelFileError as exc:
        print(f"rigidlab serve: --model: {exc}", file=sys.stderr)
        return 2
    return None


def _serve_spare(args: argparse.Namespace, state: dict | None) -> int:
    """A spare worker of :mod:`rigidlab.app.supervisor`: import everything and start the process pool, then wait for the
    supervisor's message ``start I/N`` on the control socket (``--control-fd``), which carries the listening
    socket of slot I, and serve as worker I of N on it (end of input: exit quietly).

    A worker started cold spends most of its start (9 s of imports and 11 s of the fork server's preload on a
    busy 2-core machine) before it listens; a spare listens within a second of the line.
    """
    from rigidlab.app.jobs import make_executor
    from rigidlab.app.scenes import discover_scenes

    previous = _stop_signals_as_interrupt()
    executor = None
    listening = None
    control = socket.socket(fileno=args.control_fd)
    try:  # (a supervisor that is gone closes its end: end of input)
        classes = discover_scenes()
        executor = make_executor(processes=True, preload=[cls.__module__ for cls in classes.values()])
        print(f"rigidlab: spare worker ready (pid {os.getpid()})", flush=True)
        message, fds, _, _ = socket.recv_fds(control, 64, 1)
        listening = [socket.socket(fileno=fd) for fd in fds]
        line = message.decode("ascii", "replace").split()
        if len(line) != 2 or line[0] != "start" or len(listening) != 1:
            raise KeyboardInterrupt  # the supervisor is gone (end of input)
        worker = _worker_index(line[1])
    except (KeyboardInterrupt, argparse.ArgumentTypeError):
        if executor is not None:
            executor.shutdown(wait=False, cancel_futures=True)
        for sock in listening or ():
            sock.close()
        return 0
    finally:
        control.close()
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return _run_app(args, state, worker, executor=executor, sock=listening[0])


def _run_app(args: argparse.Namespace, state: dict | None, worker: tuple[int, int] | None, *,
             executor=None, sock: socket.socket | None = None) -> int:
    """Build the app and serve until Ctrl-C or SIGTERM (``worker``: as worker I of N of a supervisor, on its
    slot's listening socket ``sock``, or ``--listen-fd``'s)."""
    from rigidlab.app.server import create_app

    # SIGTERM stops the app from here on: viser answers on the port while create_app is still building the
    # session, and a SIGTERM then (a service manager, a script that waits for the port) killed the process
    # outright and left its fork server and resource tracker running, orphaned
    previous = _stop_signals_as_interrupt()
    app = None
    # the compiled kernels, compiled in a child process (once per machine; later starts only load numba's
    # cache) from the start, while the first page loads; a scene's job that needs them meanwhile waits for it
    warm = _warm_kernels() if worker is None else None
    if sock is None and args.listen_fd is not None:
        sock = socket.socket(fileno=args.listen_fd)
    try:
        scene_classes = None
        if args.model:  # the Model scenes first: the first one is shown unless --scene says otherwise
            from rigidlab.app.model_file import ModelFileError
            from rigidlab.app.scenes import discover_scenes
            from rigidlab.app.scenes.model import model_scene_classes

            try:
                scene_classes = {**model_scene_classes(args.model), **discover_scenes()}
            except ModelFileError as exc:
                print(f"rigidlab serve: --model: {exc}", file=sys.stderr)
                return 2
        try:
            app = create_app(host=args.host, port=args.port, scene=args.scene, mode=args.mode,
                             presenter=args.present, state=state, sock=sock, executor=executor,
                             scene_classes=scene_classes)
            executor = sock = None  # the app's now
        except ValueError as exc:
            print(f"rigidlab serve: {exc}", file=sys.stderr)
            return 2
        except (OSError, OverflowError) as exc:
            print(f"rigidlab serve: cannot listen on {args.host}:{args.port}: {exc}", file=sys.stderr)
            return 2
        if args.port != 0 and app.port != args.port:  # taken between the check and the bind
            print(f"rigidlab serve: port {args.port} on {args.host} is in use; choose another with --port",
                  file=sys.stderr)
            return 2
        if worker is not None:
            _exit_with_parent()
            print(f"rigidlab: worker ready (pid {os.getpid()}, {worker[0]} of {worker[1]}, port {app.port})",
                  flush=True)
        else:
            print(f"rigidlab: serving {', '.join(app.scene_names)} ({app.mode} mode"
                  f"{', presenter view' if args.present else ''})")
            print(f"rigidlab: open {app.url}")
            _lan_notes(args.host, app.port, app.mode)
            print("rigidlab: press Ctrl-C to stop", flush=True)
        # woken twice a second: a stop signal the kernel delivers to another thread of the process (one of
        # viser's) only sets Python's flag, and the handler runs when the main thread next runs Python code;
        # blocked in Event().wait() it never did, and the server ignored that SIGTERM
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        if worker is None:
            print("\nrigidlab: stopping", flush=True)
    finally:
        if warm is not None and warm.poll() is None:
            warm.terminate()
        if app is not None:
            app.stop()
        if executor is not None:  # (create_app failed)
            executor.shutdown(wait=False, cancel_futures=True)
        if sock is not None:
            sock.close()
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 0


def _warm_kernels() -> subprocess.Popen | None:
    """Start ``python -m rigidlab.core._warm`` (see core/_warm.py); None if it cannot start.

    At the server's own priority: a scene's job that needs the kernels waits for it (:mod:`rigidlab.app.jobs`),
    so it compiles for that job. (At nice 10 it was starved on a busy machine while the job waited: 40 s
    of CPU in 4 min at a load of 13 on 2 cores.)
    """
    try:
        proc = subprocess.Popen([sys.executable, "-m", "rigidlab.core._warm"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return None
    threading.Thread(target=proc.wait, name="rigidlab-warm-wait", daemon=True).start()  # (reaped when it ends)
    return proc


def _stop_signals_as_interrupt() -> dict:
    """SIGTERM (a service manager's stop) and SIGINT stop the server as Ctrl-C does, so its process pool is
    shut down instead of left to the interpreter's exit; returns the previous handlers (none off the main
    thread).

    SIGINT too: a process started as a background job of a shell without job control (``rigidlab serve &``
    in a script) inherits SIGINT ignored, and Python then installs no KeyboardInterrupt for it. Such a
    server could not be stopped by SIGINT, nor could the supervisor stop its workers (it sends them SIGINT),
    nor a worker stop itself when its supervisor was gone.
    """
    if threading.current_thread() is not threading.main_thread():
        return {}

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    from rigidlab.app.supervisor import unignore_sigint

    previous = {signal.SIGTERM: signal.signal(signal.SIGTERM, interrupt)}
    ignored = unignore_sigint()
    if ignored is not None:
        previous[signal.SIGINT] = ignored
    return previous


def _bench(args: argparse.Namespace) -> int:
    names = available_benchmarks()
    if not args.names:
        if names:
            print("available benchmarks (rigidlab bench NAME...):")
            for name in names:
                print(f"  {name}")
        else:
            print(f"no benchmarks found in {bench_dir()}")
        return 0
    unknown = [n for n in args.names if n not in names]
    if unknown:
        print(
            f"rigidlab bench: NAME: expected one of {names}, got {unknown}",
            file=sys.stderr,
        )
        return 2
    status = 0
    for name in args.names:
        print(f"== bench/{name}.py", flush=True)
        result = subprocess.run([sys.executable, str(bench_dir() / f"{name}.py")], check=False)
        if result.returncode != 0:
            print(f"rigidlab bench: {name} exited with {result.returncode}", file=sys.stderr)
            status = result.returncode
    return status


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit status 2)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rigidlab`` command."""
    from rigidlab.app.server import MODES

    parser = _Parser(
        prog="rigidlab", description="Interactive lab for spatial rigid-body dynamics."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    from rigidlab.app.scenes import discover_scenes

    scene_names = list(discover_scenes())
    serve = sub.add_parser(
        "serve", help="serve the scenes to browsers",
        description="Serve the scenes to browsers. Scenes: " + ", ".join(scene_names) + ".",
    )
    serve.add_argument("--host", default="127.0.0.1",
                       help="interface to bind (default 127.0.0.1, this machine only; 0.0.0.0 serves "
                            "the LAN, with no password)")
    serve.add_argument("--port", type=_port, default=8080,
                       help="TCP port, 0-65535 (default 8080; 0 picks a free one)")
    serve.add_argument("--scene", default=None, choices=scene_names, metavar="NAME",
                       help="scene shown first: " + ", ".join(scene_names) + " (default: the first)")
    serve.add_argument("--mode", choices=MODES, default="shared",
                       help="shared: one state for everyone; per-client: one per browser")
    serve.add_argument("--workers", type=_positive_workers, default=None, metavar="N",
                       help="per-client mode: worker processes sharing the port, the browsers spread over "
                            "them (default: one per core); shared mode is one process")
    serve.add_argument("--worker-index", type=_worker_index, default=None, help=argparse.SUPPRESS)
    serve.add_argument("--spare", action="store_true", help=argparse.SUPPRESS)  # app.supervisor's spare worker
    # app.supervisor's: a worker's listening socket, a spare's control socket (inherited file descriptors)
    serve.add_argument("--listen-fd", type=int, default=None, help=argparse.SUPPRESS)
    serve.add_argument("--control-fd", type=int, default=None, help=argparse.SUPPRESS)
    serve.add_argument("--present", action="store_true",
                       help="start in presenter view (large labels, thick arrows, large readouts)")
    serve.add_argument("--state", default=None, metavar="FILE",
                       help="start from a scene state saved with Share > Download state (JSON) "
                            "or a state string")
    serve.add_argument("--model", action="append", default=None, metavar="PATH",
                       help="a model file to show in a Model scene (repeatable): a Python file with "
                            "build(**parameters) -> System (and PARAMETERS, SWEEP), a URDF or an MJCF; its code "
                            "runs because you name it here (no browser can choose a file)")
    serve.set_defaults(func=_serve)

    bench = sub.add_parser("bench", help="run benchmark scripts from bench/")
    bench.add_argument("names", nargs="*", metavar="NAME", help="bench/NAME.py to run")
    bench.set_defaults(func=_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rigidlab`` console script; returns the exit status."""
    status = _check_host_first(sys.argv[1:] if argv is None else list(argv))
    if status is not None:
        return status
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
