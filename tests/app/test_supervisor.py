"""Per-client mode on several worker processes (``rigidlab serve --workers N``, :mod:`rigidlab.app.supervisor`).

The multi-worker test starts the real command in a subprocess: two workers
share one port, plain websocket clients connect until both workers hold
browsers, one worker is killed by SIGKILL while a dozen browsers connect at
once (every one is served: those the kernel hands the dead worker's slot
wait in its socket's queue for the replacement), and the other keeps
serving its browsers and takes new ones while the supervisor reports the
loss and the warm spare worker takes the dead one's place (listening on the
port).
"""

from __future__ import annotations

import asyncio
import os
import re
import signal

import pytest

from rigidlab.app import cli
from rigidlab.app.supervisor import reuse_port_supported
from rigidlab.app.wire import SUBPROTOCOL, camera_message
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


#: Browsers that connect at once right after a worker is killed (all must be served).
RIGHT_AFTER_KILL = 12


async def _connect_at_once(url: str, count: int, *, frames: int = 5) -> list[BaseException | None]:
    """Open ``count`` websockets at once, as browsers: each registers and receives ``frames`` frames; the
    failure of each (None: served)."""
    import websockets
    from websockets.exceptions import WebSocketException

    async def browser() -> None:
        async with websockets.connect(url, subprotocols=[SUBPROTOCOL], max_size=None, open_timeout=120) as ws:
            await ws.send(camera_message())
            for _ in range(frames):
                await ws.recv()

    async def failure(connection) -> BaseException | None:
        try:
            await connection
        except (OSError, TimeoutError, WebSocketException) as exc:  # a reset, a refused handshake, a closed socket
            return exc
        return None

    return await asyncio.wait_for(asyncio.gather(*(failure(browser()) for _ in range(count))), timeout=180)


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

        # Kill worker 1, and at once browsers connect: every one is served (the kernel keeps handing worker
        # 1's share of them to its slot's listening socket, which the supervisor holds: they wait there for
        # the spare instead of being reset with the dead worker's socket).
        process_1 = pids[1]
        before = [_connections(out, 1), _connections(out, 2)]
        os.kill(process_1, signal.SIGKILL)
        failures = asyncio.run(_connect_at_once(url.replace("http://", "ws://"), RIGHT_AFTER_KILL))
        assert failures == [None] * RIGHT_AFTER_KILL, failures
        wait_until(lambda: _connections(out, 1) + _connections(out, 2) == sum(before) + RIGHT_AFTER_KILL,
                   timeout=60.0)
        print(f"of {RIGHT_AFTER_KILL} browsers connected right after the kill, "
              f"{_connections(out, 1) - before[0]} were served by worker 1's replacement")

        # The kill is reported; its browsers' sockets close, worker 2's keep streaming.
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
        # ... and the spare took worker 1's place: it listens on the port (replaced within a second where a
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
