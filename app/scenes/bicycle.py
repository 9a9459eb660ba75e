"""Bicycle scene: the Whipple bicycle of Meijaard et al. (2007) steering itself upright.

A :class:`~rigidlab.app.scenes._simulation.SimulationScene` whose job is
:func:`rigidlab.core.models.whipple_ride_from` (0.5 s a chunk, each from the last one's
``final_state``; *Push* starts a segment from the sample shown, pushed; times
on the display clock). Side jobs in ``background``: the modes at the current
speed (:func:`rigidlab.core.models.whipple_modes_at`) and the eigenvalues against speed
(:func:`rigidlab.core.models.whipple_sweep`), drawn as the paper's figure. Per frame:
four interpolated body poses under a *world* frame that keeps the bicycle in
view, the ground grid shifted under it and the wheels' tracks.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from rigidlab.app.controls import Button, Slider, Toggle
from rigidlab.app.meshes import bicycle_meshes
from rigidlab.app.nodes import set_pose, set_visible
from rigidlab.app.readout import mode_table
from rigidlab.app.scenes._plots import Legend, Table, hex_color
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene, job
from rigidlab.app.scenes._svg import Chart
from rigidlab.app.scenes._trail import HeadedTrail
from rigidlab.core.models import MEIJAARD_2007, WhippleRide, whipple_modes_at, whipple_ride_from, whipple_sweep
from rigidlab.core.multibody import RunState

__all__ = ["BicycleScene", "CSV_HEADER", "PRESETS", "RideChunk", "eigenvalue_svg"]

_P = MEIJAARD_2007
_CHUNK = 0.5  # s of ride per chunk
_SAMPLES = 21  # samples per chunk (40 per second; frames interpolate)
_RTOL, _ATOL = 1e-5, 1e-7  # DOP853 (a display: lean to about 1e-5 rad)
_GRID_SECTION = 2.0  # m
_POSE_END = 28  # columns of RideChunk.rows: the four bodies' poses (position, Euler parameters), then contacts
#: Presets: speed (m/s) and the push (N s) given at t = 0.
PRESETS = {"Self-stable: 5 m/s, push": (5.0, 40.0), "Weave: 2 m/s, push": (2.0, 20.0),
           "Capsize: 8 m/s, push": (8.0, 60.0), "Upright at 5 m/s": (5.0, 0.0)}
#: Header of the exported CSV (one line: column names with units).
CSV_HEADER = "t (s),lean (deg),steer (deg),yaw (deg),rear contact x (m),rear contact y (m),speed (m/s)"
# Colours: none of them the red, green or blue of frame axes.
_FRAME, _FORK, _TIRE, _RIDER, _SPOKE = (40, 90, 160), (200, 110, 30), (45, 45, 50), (120, 120, 130), (210, 60, 130)
_REAR_TRACK, _FRONT_TRACK = (25, 25, 35), (230, 140, 0)
_MODE_COLORS = {"weave": (29, 78, 216), "capsize": (194, 65, 12), "castering": (21, 128, 61)}
_CURRENT, _BAND = (126, 34, 206), "#dcfce7"
_CHART_FONT = (14.0, 17.0)  # px of the 340-px drawing: normal, presenter


@dataclasses.dataclass(frozen=True)
class RideChunk:
    """0.5 s of ride (core's, times on the display clock) and its table (read-only)."""

    k: int
    ride: WhippleRide
    table: Table  # lean, steer, yaw (deg), rear contact x, y (m), speed (m/s)
    #: (n, 36) what a frame interpolates, one row a sample: poses (28), contacts (6), lean and steer (rad)
    rows: np.ndarray

    t, final = property(lambda self: self.ride.t), property(lambda self: self.ride.fallen)


def _ride_chunk(speed: float, t0: float, start: RunState | None, impulse: float, k: int,
                previous: RideChunk | None) -> RideChunk:
    """Chunk ``k`` of a segment from ``start`` at ``t0`` (pushed by ``impulse``), on the executor."""
    t = t0 + np.linspace(k * _CHUNK, (k + 1) * _CHUNK, _SAMPLES)
    if previous is not None:
        t[0] = previous.ride.final_state.t
        ride = whipple_ride_from(speed, t, initial=previous.ride.final_state, rtol=_RTOL, atol=_ATOL)
    else:
        ride = whipple_ride_from(speed, t, initial=start, impulse=impulse, rtol=_RTOL, atol=_ATOL)
    c = ride.contact_points
    columns = np.column_stack([np.degrees(np.stack([ride.lean, ride.steer, ride.yaw], axis=1)), c[:, 0, :2],
                               ride.rear_speed])
    rows = np.column_stack([ride.poses.reshape(c.shape[0], -1), c.reshape(c.shape[0], -1), ride.lean, ride.steer])
    return RideChunk(k, ride, Table.build(ride.t, columns), rows)


def eigenvalue_svg(sweep: Any, current: tuple[float, tuple] | None, *, font: float = _CHART_FONT[0],
                   base: Chart | None = None) -> str:
    """The paper's figure: its equations (lines; weave Im s dashed), the System's eigenvalues (dots), the
    self-stable band and the modes at the current speed (``current``: (v, core's modes), purple). ``base``:
    :func:`eigenvalue_chart` of ``sweep`` and ``font``, kept (the rest costs little)."""
    chart = (base if base is not None else eigenvalue_chart(sweep, font)).copy()
    if current is not None:
        purple, s, v = hex_color(_CURRENT), np.array([m.eigenvalue for m in current[1]]), np.full(4, current[0])
        chart.vline(current[0], purple, dash=None, width=1.5)
        chart.points(v, s.real, purple, radius=4.5)
        chart.points(v, np.where(s.imag > 0, s.imag, np.nan), purple, radius=4.5, hollow=True)
    return chart.svg()


def eigenvalue_chart(sweep: Any, font: float) -> Chart:
    """The figure's axes, band, lines and dots of ``sweep`` (core's WhippleSweep, or None: the axes)."""
    chart = Chart((0.0, 10.0), (-10.0, 10.0), "speed v (m/s)", "eigenvalue s (1/s)", height=250, font=font)
    if sweep is not None:
        lo, hi = sweep.reference_stable_speeds
        chart.band(lo, hi, _BAND)
        chart.text(0.5 * (lo + hi), 10.0, "self-stable", color="#166534", anchor="middle", dy=1.2 * font)
        for name, y in sweep.curves().items():
            chart.curve(sweep.speeds, y, hex_color(_MODE_COLORS[name.split("_")[0]]), width=2.0,
                        dash="5 4" if name == "weave_frequency" else None)
        for k, name in enumerate(("weave", "weave", "capsize", "castering")):
            chart.points(sweep.speeds[::2], sweep.eigenvalues[::2, k].real, hex_color(_MODE_COLORS[name]),
                         radius=2.4, stroke="#ffffff")
    return chart


_Inputs = dataclasses.make_dataclass("_Inputs", [("speed", float, 5.0)], frozen=True)  # m/s: the ride's inputs


class BicycleScene(SimulationScene):
    """The Whipple bicycle: self-stability between the weave and capsize speeds."""

    name: ClassVar[str] = "bicycle"
    title: ClassVar[str] = "Bicycle (self-stability)"
    order: ClassVar[int] = 90
    help: ClassVar[str] = (
        "The benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab (2007) built from the "
        "general engine: four rigid bodies (rear wheel, rear frame with the rider, fork with the "
        "handlebar, front wheel), three revolute joints, and two knife-edge wheels whose rims (tori "
        "of minor radius 0) roll without slip on the ground plane: the five contact constraints "
        "of each (Eqs. 8.90-8.94) reduced to the normal-force row (Eqs. 8.105-8.107), plus two "
        "rolling rows. No bicycle equation is written anywhere.\n\n"
        "- **Ride**: DOP853 on the augmented equations of the System, in chunks of 0.5 s. *Push* "
        "gives the rear frame a lateral impulse (positive: to the right) at the instant shown: "
        "the velocities jump by the constrained impulse response. The ride stops when the lean "
        "passes 60° or a wheel leaves the ground.\n"
        "- **Modes**: the System linearized about the straight run at the chosen speed "
        "(Eqs. 8.110-8.112, the rolling rows of a moving reference included) and its state-space "
        "eigenvalues (Eqs. 8.117-8.124) with six structural zeros (place, heading, wheel angles, "
        "speed) split off; named weave (oscillating: lean and steer), capsize (slow, mostly lean) "
        "and castering (fast, mostly steer). They agree with the paper's table to 11-15 digits.\n"
        "- **Plot of the eigenvalues against speed** (the paper's figure): real parts solid, the "
        "weave's frequency (imaginary part) dashed, the self-stable band shaded (every real part "
        "negative, between the weave speed 4.29 and the capsize speed 6.02 m/s), the current "
        "speed in purple.\n"
        "- **Tracks**: the rear (dark) and front (orange) contact points on the ground; the "
        "ground grid moves under the bicycle, which the view follows. *Download CSV* exports "
        "lean, steer, yaw and the rear contact of the plotted window."
    )
    # From the left and behind, the bicycle left of the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (-0.55, -3.0, 1.45)
    camera_look_at: ClassVar[tuple[float, float, float]] = (1.75, 0.75, 0.55)
    Inputs = _Inputs
    presets = tuple(PRESETS)
    chunk_time = _CHUNK
    csv_header = CSV_HEADER

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.start_impulse = 0.0  # the push the ride from t = 0 starts with (N s; Reset replays it)
        self._next_impulse: float | None = None  # for the next start (None: the slider's, for the first ride)
        self.pushes, self.lean, self.steer = 0, 0.0, 0.0  # pushes given; lean, steer shown (rad)
        self.center = np.zeros(2)  # the world offset: the bicycle's place on the ground (m)
        self.modes: tuple[float, tuple] | None = None  # (speed, core's WhippleModes) at the current speed
        self.sweep: Any = None  # core's WhippleSweep (eigenvalues against speed)
        self._drawn_segment: Any = None
        self._chart_due, self._base = True, (None, None)

    # -- what the layer asks -----------------------------------------------------------------
    def job(self, inputs: _Inputs, segment: Any) -> Any:
        return job(_ride_chunk, inputs.speed, segment.t0, segment.start, self.segment_push(segment))

    def segment_push(self, segment: Any = None) -> float:
        """The push (N s) the segment starts with (the segment shown by default)."""
        return float((self.segment if segment is None else segment).extra or 0.0)

    def initial_extra(self) -> float:
        return self.start_impulse

    def preset_values(self, name: str) -> dict[str, Any]:
        speed, self._next_impulse = PRESETS[name]
        return {"speed": speed}

    def on_configure(self, inputs: _Inputs) -> None:
        first = self._next_impulse is None  # the first ride starts with the slider's push: the recovery shows
        self.start_impulse = float(self.controls.value("impulse")) if first else self._next_impulse
        self._next_impulse = 0.0  # a new speed rides upright
        self._chart_due = True

    def on_restart(self) -> None:
        self.pushes += 1 if self.start_impulse else 0
        for track in self.tracks:
            track.clear()

    def plots(self) -> list[PlotSpec]:
        return [PlotSpec("angles", "lean and steer (positive: right)",
                         (("lean φ (deg)", "#1d4ed8"), ("steer δ (deg)", "#c2410c")),
                         lambda t, c: (c[:, 0], c[:, 1]), y_span=1.0)]

    # -- building --------------------------------------------------------------------------------
    def build_nodes(self) -> None:
        scene, root, meshes = self.target.scene, self.root, bicycle_meshes(_P)
        self.grid = self.add_ground_grid(width=24.0, height=24.0, position=(0.0, 0.0, 0.0), cell_size=0.5,
                                         section_size=_GRID_SECTION)
        self.world = scene.add_frame(f"{root}/world", show_axes=False)
        self.bodies = [scene.add_frame(f"{root}/world/{name}", show_axes=False)
                       for name in ("rear_wheel", "frame", "fork", "front_wheel")]
        for name, color in (("rear_wheel", _TIRE), ("frame", _FRAME), ("fork", _FORK), ("front_wheel", _TIRE),
                            ("rear_mark", _SPOKE), ("front_mark", _SPOKE)):
            body = name.replace("mark", "wheel")
            scene.add_mesh_simple(f"{root}/world/{body}/{name}", meshes[name].vertices, meshes[name].faces,
                                  color=color)
        self.rider = scene.add_mesh_simple(f"{root}/world/frame/rider", meshes["rider"].vertices,
                                           meshes["rider"].faces, color=_RIDER, opacity=0.55)
        # each track's newest 6.4 m up to the wheel placed by poses: drawn in the frame that moves the bicycle
        self.tracks = [HeadedTrail(self, f"{root}/world/{name}", color, thickness=3.0, thickness_units="screen",
                                   capacity=500, min_step=0.04, length=0.2, count=32)
                       for name, color in (("rear_track", _REAR_TRACK), ("front_track", _FRONT_TRACK))]

    def build_controls(self) -> None:
        gui = self.target.gui
        self.add_playback()
        self.controls.add(Slider("speed", "Speed (m/s)", min=0.0, max=10.0, step=0.1, default=5.0,
                                 hint="Forward speed of the straight run; the ride restarts upright"))
        self.controls.add(Slider("impulse", "Push (N s)", min=-80.0, max=80.0, step=1.0, default=40.0,
                                 hint="Lateral impulse on the rear frame; positive pushes to the right"))
        self.controls.add(Button("push", "Push", hint="Push the rear frame sideways now"))
        self.add_presets()
        self.modes_readout = self.add_readout("*Computing the modes…*")
        self.eigen_plot = gui.add_html("")
        self.legends = [Legend(gui, ((_MODE_COLORS["weave"], "weave: Re s solid, Im s dashed"),
                                     (_MODE_COLORS["capsize"], "capsize"), (_MODE_COLORS["castering"], "castering"),
                                     (_CURRENT, "the current speed's modes")),
                               "Lines: the paper's equations; dots: the linearized System.", presenter=self.presenter),
                        Legend(gui, ((_FRAME, "rear frame (with the rider)"), (_FORK, "front fork and handlebar"),
                                     (_REAR_TRACK, "rear wheel track"), (_FRONT_TRACK, "front wheel track")), "",
                               presenter=self.presenter)]
        with gui.add_folder("Show"):
            self.controls.add(Toggle("show_tracks", "Wheel tracks", default=True))
            self.controls.add(Toggle("show_rider", "Rider", default=True))

    def on_presenter(self, on: bool) -> None:
        for legend in self.legends:
            legend.set_presenter(on)
        self._chart_due = True

    def on_frame(self, changed: set[str]) -> None:
        if not self.controls.take_clicks(["push"]):
            return
        push, chunk = float(self.controls.value("impulse")), self.last_chunk
        if self.ended:
            self.notify("The bicycle has fallen", "Press Reset (or move the speed) to ride again, then push.", "info")
        elif chunk is None or self._drawn_segment is not self.segment:
            self.start_impulse = push
            self.restart()
        else:  # a new segment from the sample shown
            j = int(np.searchsorted(chunk.t, self.display_time))
            self.continue_from(RunState(chunk.t[j], chunk.ride.q[j], chunk.ride.v[j]), push)
            self.pushes += 1

    # -- drawing -------------------------------------------------------------------------------
    def draw(self, chunk: RideChunk, j: int) -> None:
        self._drawn_segment = self.segment
        row = self.interpolated(chunk, chunk.rows, j)  # poses, contacts, lean, steer (rows made on the executor)
        pose = row[:_POSE_END].reshape(4, 7)
        pose[:, 3:] /= np.sqrt(np.einsum("ij,ij->i", pose[:, 3:], pose[:, 3:]))[:, None]
        values = row.tolist()
        self.lean, self.steer = values[-2], values[-1]
        rx, ry, rz, fx, fy, fz = values[_POSE_END:_POSE_END + 6]
        cx, cy = 0.5 * (rx + fx), 0.5 * (ry + fy)
        self.center = np.array((cx, cy))
        set_pose(self.world, position=(-cx, -cy, 0.0))
        set_pose(self.grid, position=(-(cx - _GRID_SECTION * round(cx / _GRID_SECTION)),
                                      -(cy - _GRID_SECTION * round(cy / _GRID_SECTION)), 0.0))
        for b, node in enumerate(self.bodies):
            set_pose(node, position=values[7 * b:7 * b + 3], wxyz=values[7 * b + 3:7 * b + 7])
        # a frame that sends a plot or the readout sends no track buffer (they come a frame later)
        show_tracks, hold = bool(self.controls.value("show_tracks")), self.refresh_due is not None
        for track, point in zip(self.tracks, ((rx, ry, rz + 0.003), (fx, fy, fz + 0.003))):
            track.add(point)
            track.draw(show_tracks, hold=hold)
        set_visible(self.rider, self.controls.value("show_rider"))

    # -- side jobs: the modes at the current speed, then the eigenvalues against speed --------------
    def background(self) -> None:
        for key, result in self.side_results():
            if key == "Sweep":
                self.sweep = result
            else:
                self.modes = (float(key.split()[1]), result)
            self._chart_due = True
        if self._chart_due and self.config is not None:
            self._chart_due = False
            if self.modes is not None and self.modes[0] == self.config.speed:
                v, modes = self.modes
                self.modes_readout.content = mode_table(
                    f"**Modes at {v:.2f} m/s** (the System linearized, Eqs. 8.110-8.131)",
                    [(m.name, m.eigenvalue) for m in modes],
                    shape=("φ : δ", [f"{abs(m.lean):.2f} : {abs(m.steer):.2f}" for m in modes]))
            if self._base[0] != (key := (id(self.sweep), self.presenter)):  # built again when these change
                self._base = (key, eigenvalue_chart(self.sweep, _CHART_FONT[self.presenter]))
            self.eigen_plot.content = eigenvalue_svg(self.sweep, self.modes, base=self._base[1])
        timeline = self.timeline
        ahead = not timeline.busy and (timeline.ready(timeline.index(self.local_time) + 1) or self.ended
                                       or not self.playback.playing or timeline.error is not None)
        if self.side_jobs or self.config is None or (not ahead and self.sim_time < 1.0):
            return
        speed = self.config.speed
        if self.modes is None or self.modes[0] != speed:
            self.submit_side_job(f"Modes {speed}", whipple_modes_at, speed, _P)
        elif self.sweep is None and ahead:
            self.submit_side_job("Sweep", whipple_sweep, np.linspace(0.0, 10.0, 101), _P)

    def readout_lines(self) -> list[str]:
        lines = [f"**v** = {self.config.speed:.2f} m/s · lean φ = {math.degrees(self.lean):+.2f}° · "
                 f"steer δ = {math.degrees(self.steer):+.2f}°"]
        if self.ended:
            lines.append(f"**Fallen**: {self.last_chunk.ride.end}.")
        if self.sweep is None:
            return lines + ["*The eigenvalues against speed are being computed…*"]
        (pw, pc), (ew, ec) = self.sweep.reference_stable_speeds, self.sweep.stable_speeds
        return lines + [f"Self-stable from v_w = {pw:.4f} to v_c = {pc:.4f} m/s (the paper's equations, lines); "
                        f"the System's eigenvalues (dots) cross zero at {ew:.4f} and {ec:.4f} m/s."]

    def end_notice(self, chunk: RideChunk) -> tuple[str, str]:
        return "The bicycle fell", f"{chunk.ride.end}. Press Reset, move the speed or choose a preset."

