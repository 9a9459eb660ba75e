"""Playback of the scenes that run a simulated clock: play, pause, reset, time scale, presets.

:class:`Playback` declares its controls on the scene's panel (a Play / Pause /
Reset button row, a "Time scale" slider checked at the gate like every
control, and one button per preset) and keeps programmatic requests for
tests and notebooks. The scene's ``update`` reads it once per frame:

.. code-block:: python

    preset = self.playback.take_preset()   # None, or a name of ``presets``
    ...                                    # apply it; self.playback.set_playing(True)
    tick = self.playback.tick(dt)
    if tick.reset:
        self._restart()                    # the scene's own sim_time = 0 etc.
    self.sim_time += tick.step

Simulated time advanced per frame is bounded (:data:`MAX_SIM_STEP`), whatever
``dt`` and the time scale, so no frame can ask for an unbounded amount of
computation. The clock's time itself stays with the scene.
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Sequence
from typing import Any

from rigidlab.app.controls import Button, ButtonGroup, Slider
from rigidlab.app.panel import ControlPanel

__all__ = ["Playback", "PlaybackRequests", "Tick", "TIME_SCALE_RANGE", "MAX_SIM_STEP", "PLAYBACK_OPTIONS"]

TIME_SCALE_RANGE = (0.05, 4.0)
"""Limits of the time-scale slider (simulated seconds per wall second)."""
MAX_SIM_STEP = 0.4
"""Most simulated seconds one frame advances (s): 0.1 s of wall time at scale 4."""
PLAYBACK_OPTIONS = ("Play", "Pause", "Reset")


@dataclasses.dataclass(frozen=True)
class Tick:
    """What the clock does in one frame."""

    reset: bool  # restart from t = 0 before advancing
    step: float  # simulated seconds to advance (0.0 while paused)


class Playback:
    """Play / pause / reset requests, time scale and pending preset of a timed scene.

    Parameters
    ----------
    presets : sequence of str
        Names accepted by :meth:`request_preset` (and shown as buttons by
        :meth:`add_preset_buttons`), in button order.
    controls : ControlPanel or None
        The scene's panel; the GUI methods need it.
    """

    def __init__(self, presets: Sequence[str] = (), controls: ControlPanel | None = None) -> None:
        self.presets = tuple(presets)
        self.controls = controls
        self._lock = threading.Lock()
        self._playing = True
        self._reset_requested = False
        self._time_scale = 1.0
        self._pending_preset: str | None = None
        self._preset_keys: dict[str, str] = {}
        self._has_slider = False  # the time scale is the slider's
        self._has_row = False  # the Play / Pause / Reset row is on the panel

    # -- requests (any thread) -----------------------------------------------
    @property
    def playing(self) -> bool:
        with self._lock:
            return self._playing

    @property
    def time_scale(self) -> float:
        if self._has_slider and self.controls is not None:
            return float(self.controls.value("time_scale"))
        with self._lock:
            return self._time_scale

    def set_playing(self, playing: bool) -> None:
        with self._lock:
            self._playing = bool(playing)

    def set_time_scale(self, scale: float) -> None:
        """Simulated seconds per wall second, finite and > 0 (within the slider's range
        when the GUI exists)."""
        scale = float(scale)
        if not (math.isfinite(scale) and scale > 0.0):
            raise ValueError(f"scale: expected a finite number > 0, got {scale!r}")
        if self._has_slider and self.controls is not None:
            self.controls.set("time_scale", scale)
            return
        with self._lock:
            self._time_scale = scale

    def request_reset(self) -> None:
        """Restart from t = 0 at the next frame."""
        with self._lock:
            self._reset_requested = True

    def request_preset(self, name: str) -> None:
        """Record preset ``name`` (one of :attr:`presets`) for the next frame.

        Raises
        ------
        ValueError
            For a name not in :attr:`presets`.
        """
        if name not in self.presets:
            raise ValueError(f"name: expected one of {list(self.presets)}, got {name!r}")
        with self._lock:
            self._pending_preset = name

    # -- the session loop --------------------------------------------------------
    def _take_clicks(self) -> None:
        if self.controls is None or not (self._has_row or self._preset_keys):
            return
        keys = ["playback", *self._preset_keys]
        for key, value, _ in self.controls.take_clicks(keys):
            if key == "playback":
                if value == "Play":
                    self.set_playing(True)
                elif value == "Pause":
                    self.set_playing(False)
                elif value == "Reset":
                    self.request_reset()
            else:
                self.request_preset(self._preset_keys[key])

    def take_preset(self) -> str | None:
        """The preset requested since the last call, if any (and forget it)."""
        self._take_clicks()
        with self._lock:
            preset, self._pending_preset = self._pending_preset, None
        return preset

    def tick(self, dt: float) -> Tick:
        """This frame's reset request (consumed) and clock step for ``dt`` wall seconds.

        The step is ``dt * time_scale`` while playing, at most :data:`MAX_SIM_STEP`.
        """
        self._take_clicks()
        scale = self.time_scale
        with self._lock:
            reset, self._reset_requested = self._reset_requested, False
            step = min(max(dt, 0.0) * scale, MAX_SIM_STEP) if self._playing else 0.0
        return Tick(reset=reset, step=step)

    # -- GUI ---------------------------------------------------------------------
    def add_gui(self, *, time_scale: bool = True) -> dict[str, Any]:
        """Add the Play / Pause / Reset row and the "Time scale" slider to the
        current GUI folder; returns their handles.

        ``time_scale`` False leaves the slider out: the scene sets the scale
        itself (:meth:`set_time_scale`, any finite scale > 0), e.g. from a
        control of its own in other units (the cam's seconds per turn).
        """
        if self.controls is None:
            raise ValueError("controls: expected the scene's ControlPanel, got None")
        lo, hi = TIME_SCALE_RANGE
        handles = {"playback": self.controls.add(ButtonGroup("playback", "Playback", options=PLAYBACK_OPTIONS))}
        if time_scale:
            handles["time_scale"] = self.controls.add(Slider(
                "time_scale", "Time scale", min=lo, max=hi, step=0.05, default=self.time_scale,
                hint="Simulated seconds per wall-clock second",
            ))
        self._has_slider, self._has_row = time_scale, True
        return handles

    def add_preset_buttons(self) -> dict[str, Any]:
        """Add a "Presets" folder with one button per preset; a click requests it."""
        if self.controls is None:
            raise ValueError("controls: expected the scene's ControlPanel, got None")
        buttons = {}
        with self.controls.gui.add_folder("Presets"):
            for i, name in enumerate(self.presets):
                key = f"preset_{i}"
                self._preset_keys[key] = name
                buttons[name] = self.controls.add(Button(key, name))
        return buttons


class PlaybackRequests:
    """Requests of a scene with a :class:`Playback` and a chunk timeline (tests, notebooks).

    A mixin for scenes that set ``self.playback`` (a :class:`Playback`) and
    ``self.timeline`` (an :class:`rigidlab.app.jobs.ChunkTimeline`); what is
    requested is applied by the scene's next ``update``.
    """

    playback: Playback
    timeline: Any

    def request_reset(self) -> None:
        """Restart the motion from t = 0 (cached chunks are reused)."""
        self.playback.request_reset()

    def apply_preset(self, name: str) -> None:
        """Record preset ``name`` (one of the scene's presets); applied by ``update``."""
        self.playback.request_preset(name)

    @property
    def playing(self) -> bool:
        return self.playback.playing

    @property
    def chunks_computed(self) -> int:
        """Chunks computed since the scene was built (all parameter sets)."""
        return self.timeline.computed
