"""Per-client mode on several worker processes (``rigidlab serve --workers N``, :mod:`app.supervisor`).

The multi-worker test starts the real command in a subprocess: two workers
share one port, plain websocket clients connect until both workers hold
browsers, one worker is killed by SIGKILL, and the other keeps serving its
browsers and takes new ones while the supervisor reports the loss and the
warm spare worker takes the dead one's place (listening on the port).
"""

from __future__ import annotations

import re
import subprocess

import pytest

from app import cli
from app.supervisor import reuse_port_supported
from tests.app.conftest import WsClient
from tests.helpers import ProcessOutput, failure_lines, process_group_gone, start_serving, stop_serving, wait_until

pytestmark = pytest.mark.skipif(not reuse_port_supported(), reason="needs SO_REUSEPORT (Linux)")


def _connections(out: ProcessOutput, worker: int) -> int:
    return out.count(rf"^\[worker {worker}\] .*browser \d+ connected")


def _listening_pids(port: int) -> set[int]:
    """Processes holding a listening TCP socket on ``port`` (from /proc: the socket inodes of each process)."""
    import os

    inodes = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as rows:
            for row in list(rows)[1:]:
                fields = row.split()
                if int(fields[1].rsplit(":", 1)[1], 16) == port and fields[3] == "0A":  # 0A: LISTEN
                    inodes.add(fields[9])
    pids = set()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            links = [os.readlink(f"/proc/{pid}/fd/{fd}") for fd in os.listdir(f"/proc/{pid}/fd")]
        except OSError:
            continue
        if any(link.startswith("socket:[") and link[8:-1] in inodes for link in links):
            pids.add(int(pid))
    return pids


def test_two_workers_share_a_port_and_survive_the_loss_of_one() -> None:
    clients: list[WsClient] = []
    process, out = start_serving("--mode", "per-client", "--workers", "2", "--port", "0", "--scene", "gyroscope")
    try:
        wait_until(lambda: "rigidlab: open " in out.text() or process.poll() is not None, timeout=120.0)
        assert process.poll() is None, out.text()
        url = re.search(r"rigidlab: open (\S+)", out.text()).group(1)
        pids: dict[int, int] = {}
        for pid, index in re.findall(r"worker ready \(pid (\d+), (\d) of 2", out.text()):
            pids[int(index)] = int(pid)
        assert sorted(pids) == [1, 2], out.text()

        # Connect one browser at a time (so each log line names its worker) until both hold some.
        where: list[int] = []
        for _ in range(24):
            before = [_connections(out, 1), _connections(out, 2)]
            clients.append(WsClient(url))
            wait_until(lambda: _connections(out, 1) + _connections(out, 2) > sum(before), timeout=30.0)
            where.append(1 if _connections(out, 1) > before[0] else 2)
            if 1 in where and 2 in where and len(where) >= 4:
                break
        assert 1 in where and 2 in where, f"the kernel gave every browser to one worker: {where}"

        # Browsers of both workers stream the live scene.
        counts = [c.frames for c in clients]
        wait_until(lambda: all(c.frames > n for c, n in zip(clients, counts)), timeout=60.0)

        # A spare worker waits (warm, not listening) to replace a worker that ends.
        wait_until(lambda: "[spare] rigidlab: spare worker ready" in out.text(), timeout=120.0)
        spare = int(re.search(r"spare worker ready \(pid (\d+)", out.text()).group(1))
        port = int(url.rsplit(":", 1)[1])
        assert spare not in _listening_pids(port)

        # Kill worker 1: reported, its browsers' sockets close, worker 2's keep streaming.
        process_1 = pids[1]
        subprocess.run(["kill", "-KILL", str(process_1)], check=True)
        wait_until(lambda: f"worker 1 (pid {process_1}) was killed by SIGKILL" in out.text(), timeout=20.0)
        # nothing of it is left: its executor's fork server and pool processes (its process group) are gone
        assert wait_until(lambda: process_group_gone(process_1), timeout=20.0)
        survivors = [c for c, w in zip(clients, where) if w == 2]
        lost = [c for c, w in zip(clients, where) if w == 1]
        wait_until(lambda: all(not c._thread.is_alive() for c in lost), timeout=20.0)
        counts = [c.frames for c in survivors]
        wait_until(lambda: all(c.frames > n for c, n in zip(survivors, counts)), timeout=60.0)  # worker 2 serves

        # A browser that reloads connects to a live worker and gets a scene.
        again = WsClient(url)
        clients.append(again)
        wait_until(lambda: again.frames > 5, timeout=30.0)
        # ... and the spare takes worker 1's place: it listens on the port (replaced within a second where a
        # worker started cold took 19-25 s; the time is in docs/app.md, not asserted here).
        wait_until(lambda: f"worker 1 restarted (pid {spare}; the spare worker took its place)" in out.text(),
                   timeout=20.0)
        wait_until(lambda: spare in _listening_pids(port), timeout=60.0)
        wait_until(lambda: out.count(r"worker ready \(pid \d+, 1 of 2") == 2, timeout=120.0)
        # and a new spare is started once both workers serve
        wait_until(lambda: out.count(r"\[spare\] rigidlab: spare worker ready") == 2, timeout=120.0)
    finally:
        for client in clients:
            client.close()
        stop_serving(process)
    assert process.returncode == 0, out.text()
    assert not failure_lines(out.text()), "\n".join(failure_lines(out.text())) + "\n\n" + out.text()


def test_shared_mode_refuses_several_workers(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["serve", "--mode", "shared", "--workers", "2"]) == 2
    assert "shared mode runs one process" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["0", "-1", "two", "65"])
def test_bad_worker_counts_are_refused(value: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["serve", "--mode", "per-client", "--workers", value])
    assert exc.value.code == 2
    assert "--workers" in capsys.readouterr().err
