"""The app shell with a real ViserServer: registry, switching, modes, errors.

Most tests serve small counting scenes (defined here) so that they check the
shell itself; the registry and CLI tests use the real scenes.
"""

from __future__ import annotations

import time
import urllib.request
from typing import Any, ClassVar

import numpy as np
import pytest

from app import cli
from app.scenes import discover_scenes, get_scene_class
from app.scenes.base import Scene
from app.server import create_app
from tests.helpers import wait_until


class CountingScene(Scene):
    """Counts update calls; one slider whose value the update turns into a pose."""

    name: ClassVar[str] = "alpha"
    title: ClassVar[str] = "Alpha"
    order: ClassVar[int] = 1

    def build(self) -> None:
        self.updates = 0
        self.angle = 0.0
        self.make_root()
        self.body = self.target.scene.add_frame(f"{self.root}/body")
        with self.make_folder():
            self.slider = self.target.gui.add_slider(
                "angle", min=-3.0, max=3.0, step=0.01, initial_value=0.0
            )

        @self.slider.on_update
        def _(event: Any) -> None:
            with self.lock:
                self.angle = float(event.target.value)

    def update(self, dt: float) -> None:
        self.updates += 1
        with self.lock:
            angle = self.angle
        with self.target.atomic():
            self.body.wxyz = (np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2))

    def close(self) -> None:
        self.closed = True
        super().close()


class OtherScene(CountingScene):
    name: ClassVar[str] = "beta"
    title: ClassVar[str] = "Beta"
    order: ClassVar[int] = 2


class FailingScene(CountingScene):
    """Raises from update once its slider goes negative."""

    name: ClassVar[str] = "failing"
    title: ClassVar[str] = "Failing"
    order: ClassVar[int] = 3

    def update(self, dt: float) -> None:
        super().update(dt)
        if self.angle < 0:
            raise ZeroDivisionError("angle went negative")


class BrokenBuildScene(CountingScene):
    name: ClassVar[str] = "broken"
    title: ClassVar[str] = "Broken"
    order: ClassVar[int] = 4

    def build(self) -> None:
        super().build()
        raise RuntimeError("no mesh")


FAKES = {cls.name: cls for cls in (CountingScene, OtherScene, FailingScene, BrokenBuildScene)}


def fake_app(mode: str = "shared", scene: str = "alpha", run_unwatched: bool = True) -> Any:
    return create_app(
        port=0, mode=mode, scene=scene, scene_classes=FAKES, run_unwatched=run_unwatched
    )


@pytest.fixture
def fake_apps() -> Any:
    apps: list[Any] = []

    def start(mode: str = "shared", scene: str = "alpha", run_unwatched: bool = True) -> Any:
        app = fake_app(mode, scene, run_unwatched)
        apps.append(app)
        return app

    yield start
    for app in apps:
        app.stop()


def test_registry_finds_sandbox_first() -> None:
    scenes = discover_scenes()
    assert "sandbox" in scenes
    orders = [getattr(cls, "order", 1000) for cls in scenes.values()]
    assert orders == sorted(orders)
    assert get_scene_class("sandbox").order == 10
    with pytest.raises(ValueError, match=r"scene: expected one of .*got 'nope'"):
        get_scene_class("nope")


def test_create_app_validates_arguments() -> None:
    with pytest.raises(ValueError, match=r"mode: expected one of \['shared', 'per-client'\], got 'solo'"):
        create_app(mode="solo")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"scene: expected one of .*got 'nope'"):
        create_app(scene="nope")


def test_serves_http_on_loopback(running_app: Any) -> None:
    app = running_app()
    assert app.url == f"http://127.0.0.1:{app.port}"
    with urllib.request.urlopen(app.url, timeout=10) as response:
        assert response.status == 200
        assert b"<html" in response.read().lower()
    assert app.scene_for().name == "sandbox"


def test_hidden_scene_gets_no_updates(fake_apps: Any) -> None:
    app = fake_apps()
    alpha = app.scene_for()
    assert wait_until(lambda: alpha.updates > 5)
    app.switch_scene("beta")
    beta = app.scene_for()
    assert beta.name == "beta" and beta is not alpha
    assert not alpha.active and beta.active
    assert alpha.root_frame.visible is False and alpha._gui_folder.visible is False
    frozen = alpha.updates
    assert wait_until(lambda: beta.updates > 10)
    assert alpha.updates == frozen  # hidden: not one update call
    # Switching back reuses the built scene (nodes are created once).
    app.switch_scene("alpha")
    assert app.scene_for() is alpha and alpha.root_frame.visible is True
    assert wait_until(lambda: alpha.updates > frozen)
    with pytest.raises(ValueError, match=r"name: expected one of .*got 'gamma'"):
        app.switch_scene("gamma")


def test_shared_scene_does_no_work_while_nobody_watches(fake_apps: Any, ws_client: Any) -> None:
    app = fake_apps(run_unwatched=False)  # the default of create_app / rigidlab serve
    alpha = app.scene_for()
    time.sleep(0.5)  # ~30 loop ticks at 60 Hz
    assert alpha.updates == 0
    client, _ = ws_client(app)
    assert wait_until(lambda: alpha.updates > 5)
    client.close()
    assert wait_until(lambda: not app.server.get_clients())
    time.sleep(0.1)  # a tick in flight may still finish
    frozen = alpha.updates
    time.sleep(0.5)
    assert alpha.updates == frozen


def test_chooser_dropdown_switches_through_the_loop(fake_apps: Any, ws_client: Any) -> None:
    app = fake_apps()
    client, _ = ws_client(app)
    session = app.session_for()
    client.set_gui_value(session._chooser, "Beta")  # as a browser would
    assert wait_until(lambda: session.active_name == "beta")
    assert app.scene_for().name == "beta"


def test_per_client_sessions_are_isolated(fake_apps: Any, ws_client: Any) -> None:
    app = fake_apps(mode="per-client")
    with pytest.raises(ValueError, match="client_id: expected the id of a connected browser"):
        app.scene_for()
    client_a, id_a = ws_client(app)
    client_b, id_b = ws_client(app)
    assert id_a != id_b
    scene_a, scene_b = app.scene_for(id_a), app.scene_for(id_b)
    assert scene_a is not scene_b
    client_a.set_gui_value(scene_a.slider, 1.5)
    assert wait_until(lambda: np.allclose(scene_a.body.wxyz, (np.cos(0.75), 0, 0, np.sin(0.75))))
    time.sleep(0.1)
    assert np.allclose(scene_b.body.wxyz, (1, 0, 0, 0))  # b's state untouched
    # A browser can only reach its own GUI: a's update sent to b's slider uuid is ignored.
    client_a.set_gui_value(scene_b.slider, -1.0)
    time.sleep(0.2)
    assert scene_b.slider.value == 0.0
    # Switching scenes in one browser leaves the other alone.
    app.switch_scene("beta", client_id=id_b)
    assert app.scene_for(id_b).name == "beta" and app.scene_for(id_a).name == "alpha"
    # Disconnect tears the session down.
    client_a.close()
    assert wait_until(lambda: id_a not in app.client_ids())
    assert wait_until(lambda: getattr(scene_a, "closed", False))  # released on disconnect
    assert not getattr(scene_b, "closed", False)
    with pytest.raises(KeyError, match=f"no session for client_id {id_a}"):
        app.scene_for(id_a)
    assert app.scene_for(id_b).name == "beta"


def test_scene_exception_gives_notice_and_server_keeps_serving(fake_apps: Any, ws_client: Any) -> None:
    app = fake_apps(scene="failing")
    client, _ = ws_client(app)
    session = app.session_for()
    scene = app.scene_for()
    frames_before = client.frames
    client.set_gui_value(scene.slider, -1.0)
    assert wait_until(lambda: any("angle went negative" in body for _, body, _ in session.notices))
    title, body, level = session.notices[-1]
    assert title == "Error in scene 'failing'" and level == "error"
    # Rate limited: the same error every frame is shown once, not 60 times a second.
    time.sleep(0.5)
    assert sum("angle went negative" in b for _, b, _ in session.notices) == 1
    # Still serving: the loop ticks, HTTP answers, the client gets frames, switching works.
    ticks = app._ticks
    assert wait_until(lambda: app._ticks > ticks + 5)
    with urllib.request.urlopen(app.url, timeout=10) as response:
        assert response.status == 200
    client.set_gui_value(session._chooser, "Alpha")
    assert wait_until(lambda: session.active_name == "alpha")
    assert wait_until(lambda: client.frames > frames_before)


def test_scene_that_fails_to_build_is_refused(fake_apps: Any) -> None:
    app = fake_apps()
    session = app.session_for()
    assert session.activate("broken") is False
    assert session.active_name == "alpha" and session._chooser.value == "Alpha"
    assert session.notices[-1][0] == "Error in building scene 'broken'"
    assert "RuntimeError: no mesh" in session.notices[-1][1]


def test_cli_parses_serve_and_lists_benchmarks(capsys: Any) -> None:
    args = cli.build_parser().parse_args(["serve"])
    assert (args.host, args.port, args.scene, args.mode) == ("127.0.0.1", 8080, None, "shared")
    args = cli.build_parser().parse_args(
        ["serve", "--host", "0.0.0.0", "--port", "9000", "--scene", "sandbox", "--mode", "per-client"]
    )
    assert (args.host, args.port, args.scene, args.mode) == ("0.0.0.0", 9000, "sandbox", "per-client")
    with pytest.raises(SystemExit):
        cli.build_parser().parse_args(["serve", "--mode", "solo"])
    assert cli.main(["bench"]) == 0
    out = capsys.readouterr().out
    names = cli.available_benchmarks()
    assert all(name in out for name in names)
    assert cli.main(["bench", "no_such_bench"]) == 2
    assert "NAME: expected one of" in capsys.readouterr().err
    assert cli.main(["serve", "--scene", "nope", "--port", "0"]) == 2
    assert "scene: expected one of" in capsys.readouterr().err


def test_rigidlab_serve_prints_url_and_stops_on_ctrl_c() -> None:
    import os
    import signal
    import subprocess
    import sys

    process = subprocess.Popen(
        [sys.executable, "-c", "import sys; from app.cli import main; sys.exit(main())",
         "serve", "--port", "0", "--scene", "sandbox"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        url = None
        deadline = time.monotonic() + 60
        lines = []
        while time.monotonic() < deadline and url is None:
            line = process.stdout.readline()  # type: ignore[union-attr]
            if not line:
                break
            lines.append(line)
            if line.startswith("rigidlab: open http://127.0.0.1:"):
                url = line.split()[-1]
        assert url is not None, "".join(lines)
        with urllib.request.urlopen(url, timeout=10) as response:
            assert response.status == 200
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=30) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def test_registry_skips_a_module_that_fails_to_import(monkeypatch: Any) -> None:
    import importlib

    import app.scenes as registry

    real_import = importlib.import_module

    def failing_import(name: str, *args: Any) -> Any:
        if name == "app.scenes.sandbox":
            raise ImportError("simulated broken scene")
        return real_import(name, *args)

    monkeypatch.setattr(registry.importlib, "import_module", failing_import)
    scenes = discover_scenes()
    assert "sandbox" not in scenes
    assert "simulated broken scene" in registry.discovery_errors()["app.scenes.sandbox"]
    monkeypatch.undo()
    assert "sandbox" in discover_scenes() and "app.scenes.sandbox" not in registry.discovery_errors()
