"""Command line: ``rigidlab serve`` and ``rigidlab bench``.

Examples
--------
``rigidlab serve``
    Serve every scene on http://127.0.0.1:8080 (loopback only).
``rigidlab serve --host 0.0.0.0 --mode per-client``
    Serve a classroom LAN; every browser gets its own state.
``rigidlab bench``
    List the benchmarks under ``bench/``.
``rigidlab bench rotations app_stream``
    Run ``bench/rotations.py`` then ``bench/app_stream.py``.
"""

from __future__ import annotations

import argparse
import logging
import socket
import subprocess
import sys
import threading
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


def _serve(args: argparse.Namespace) -> int:
    from app.server import create_app

    try:
        app = create_app(host=args.host, port=args.port, scene=args.scene, mode=args.mode)
    except ValueError as exc:
        print(f"rigidlab serve: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"rigidlab serve: cannot listen on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 1
    print(f"rigidlab: serving {', '.join(app.scene_names)} ({app.mode} mode)")
    print(f"rigidlab: open {app.url}")
    if args.host in ("0.0.0.0", "", "::"):
        for address in _lan_addresses():
            print(f"rigidlab: on the LAN: http://{address}:{app.port}")
    print("rigidlab: press Ctrl-C to stop", flush=True)
    try:
        threading.Event().wait()
    except KeyboardInterrupt:
        print("\nrigidlab: stopping")
    finally:
        app.stop()
    return 0


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


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rigidlab`` command."""
    from app.server import MODES

    parser = argparse.ArgumentParser(
        prog="rigidlab", description="Interactive lab for spatial rigid-body dynamics."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="serve the scenes to browsers")
    serve.add_argument("--host", default="127.0.0.1",
                       help="interface to bind (default 127.0.0.1; 0.0.0.0 serves a LAN)")
    serve.add_argument("--port", type=int, default=8080, help="TCP port (default 8080)")
    serve.add_argument("--scene", default=None, help="scene shown first (default: the first one)")
    serve.add_argument("--mode", choices=MODES, default="shared",
                       help="shared: one state for everyone; per-client: one per browser")
    serve.set_defaults(func=_serve)

    bench = sub.add_parser("bench", help="run benchmark scripts from bench/")
    bench.add_argument("names", nargs="*", metavar="NAME", help="bench/NAME.py to run")
    bench.set_defaults(func=_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rigidlab`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
