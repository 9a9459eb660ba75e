"""Playback controls shared by the scenes that run a simulated clock.

:class:`Playback` holds what the Play / Pause / Reset buttons, the time-scale
slider and the preset buttons ask for. GUI callbacks and public requests only
record (under the controller's own lock, so they never wait for a frame); the
scene's ``update`` reads them once per frame:

.. code-block:: python

    preset = self.playback.take_preset()   # None, or a name of ``presets``
    ...                                    # apply it; self.playback.set_playing(True)
    tick = self.playback.tick(dt)
    if tick.reset:
        self._restart()                    # the scene's own sim_time = 0 etc.
    self.sim_time += tick.step

The clock's time itself stays with the scene (it also restarts when the
scene's inputs change).
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Sequence
from typing import Any

__all__ = ["Playback", "PlaybackGui", "Tick"]

TIME_SCALE_RANGE = (0.05, 4.0)
"""Limits of the time-scale slider (simulated seconds per wall second)."""


@dataclasses.dataclass(frozen=True)
class PlaybackGui:
    """Handles of the playback controls."""

    play: Any  # button
    pause: Any  # button
    reset: Any  # button
    time_scale: Any  # slider, simulated seconds per wall second


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
    """

    def __init__(self, presets: Sequence[str] = ()) -> None:
        self.presets = tuple(presets)
        self._lock = threading.Lock()
        self._playing = True
        self._reset_requested = False
        self._time_scale = 1.0
        self._pending_preset: str | None = None

    # -- requests (any thread) -----------------------------------------------
    @property
    def playing(self) -> bool:
        with self._lock:
            return self._playing

    @property
    def time_scale(self) -> float:
        with self._lock:
            return self._time_scale

    def set_playing(self, playing: bool) -> None:
        with self._lock:
            self._playing = bool(playing)

    def set_time_scale(self, scale: float) -> None:
        """Simulated seconds per wall second, finite and > 0."""
        scale = float(scale)
        if not (math.isfinite(scale) and scale > 0.0):
            raise ValueError(f"scale: expected a finite number > 0, got {scale!r}")
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
    def take_preset(self) -> str | None:
        """The preset requested since the last call, if any (and forget it)."""
        with self._lock:
            preset, self._pending_preset = self._pending_preset, None
        return preset

    def tick(self, dt: float) -> Tick:
        """This frame's reset request (consumed) and clock step for ``dt`` wall seconds."""
        with self._lock:
            reset, self._reset_requested = self._reset_requested, False
            step = dt * self._time_scale if self._playing else 0.0
        return Tick(reset=reset, step=step)

    # -- GUI ---------------------------------------------------------------------
    def add_gui(self, gui: Any) -> PlaybackGui:
        """Add Play, Pause, Reset and a "Time scale" slider to ``gui`` (in the
        current folder) and connect them to this controller."""
        play = gui.add_button("Play")
        pause = gui.add_button("Pause")
        reset = gui.add_button("Reset")
        lo, hi = TIME_SCALE_RANGE
        time_scale = gui.add_slider("Time scale", min=lo, max=hi, step=0.05, initial_value=self.time_scale)
        play.on_click(lambda _e: self.set_playing(True))
        pause.on_click(lambda _e: self.set_playing(False))
        reset.on_click(lambda _e: self.request_reset())
        time_scale.on_update(lambda e: self.set_time_scale(e.target.value))
        return PlaybackGui(play, pause, reset, time_scale)

    def add_preset_buttons(self, gui: Any) -> dict[str, Any]:
        """Add a "Presets" folder with one button per preset; a click requests it."""
        with gui.add_folder("Presets"):
            buttons = {name: gui.add_button(name) for name in self.presets}
        for name, button in buttons.items():
            button.on_click(lambda _e, name=name: self.request_preset(name))
        return buttons
