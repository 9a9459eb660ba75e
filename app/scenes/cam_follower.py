"""Cam-follower scene: a disk cam at constant speed drives a spring-loaded translating follower.

A :class:`~rigidlab.app.scenes._simulation.SimulationScene` whose chunk is one revolution of the closed form or of
the compliant run (:mod:`rigidlab.app.scenes._cam_motion`: the cams the panel offers, their revolutions as chunks),
drawn from core's results as they are by :class:`rigidlab.app.scenes._cam.CamMechanism`. The scene holds the panel
(controls, plots, readouts, the shareable state) and the layer's hooks. The help text states the equations
(8.84-8.109).

Frames (global, metres; :mod:`rigidlab.app.scenes._cam`): the cam shaft is the global y axis, the profile plane is
the x-z plane, the follower slides along +z above the shaft; the cam turns about -y by the cam angle theta
(theta = 0: lowest lift).
"""

from __future__ import annotations

import functools
import math
from typing import Any, ClassVar

import numpy as np

from rigidlab.app.controls import Choice, Slider, Toggle
from rigidlab.app.scenes._cam import LEGEND, CamMechanism, cam_layout
from rigidlab.app.scenes._cam_motion import (ECCENTRIC_RADIUS, ECCENTRICITY, FOLLOWERS, GRAVITY, PROFILES,
                                             REVOLUTION_SAMPLES, RISE_DEG_RANGE, ROLLER_MM_RANGE, RUN_SAMPLES, Chunk,
                                             Inputs, build_cam, closed_form_chunk, compute_chunk, compute_revolution)
from rigidlab.app.scenes._plots import format_rows
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene

__all__ = ["CSV_HEADER", "CamFollowerScene", "Chunk", "ECCENTRICITY", "ECCENTRIC_RADIUS", "FOLLOWERS", "GRAVITY",
           "Inputs", "PROFILES", "REVOLUTION_SAMPLES", "RUN_SAMPLES", "build_cam", "compute_chunk",
           "compute_revolution"]

CSV_HEADER = "cam angle (deg),lift (m),velocity (m/s),acceleration (m/s^2),contact force (N)"


def _words(pairs: Any) -> list[str]:
    """Core's ``(topic, text)`` pairs as readout lines."""
    return [f"**{topic}**: {text}." for topic, text in pairs]


def _deg(theta: float) -> float:
    return math.degrees(theta % (2.0 * math.pi))


_SHADE = ("N < 0", "rgba(150, 60, 200, 0)", {"fill": "rgba(150, 60, 200, 0.3)", "width": 1})
_CLOSED_PLOTS = {  # name: (title, first series, column of the closed table)
    "lift": ("lift s (mm)", ("s (mm)", "#2266dd"), 1), "velocity": ("velocity ω s′ (m/s)", ("v (m/s)", "#0f766e"), 2),
    "acceleration": ("acceleration ω² s″ (m/s²)", ("a (m/s²)", "#c2410c"), 3),
    "force": ("contact force N (N)", ("N (N)", "#d97706"), 4)}
_FORCE_MORE = (("N = 0", "#555555", {"dash": [6, 4], "width": 1}), ("N at jump speed", "#888888",
                                                                     {"dash": [3, 3], "width": 1}))


class CamFollowerScene(SimulationScene):
    """A disk cam driving a spring-loaded translating follower (flat-faced or roller)."""

    name: ClassVar[str] = "cam_follower"
    title: ClassVar[str] = "Cam-follower (contact)"
    order: ClassVar[int] = 70
    help: ClassVar[str] = (
        "A disk cam turns at constant speed ω (*Cam speed*) and lifts a translating follower that a "
        "spring (stiffness k, force F0 at zero lift) and gravity press on it. Cam angle θ = 0 is the "
        "lowest lift; the cam turns in slow motion (*Slow motion*: seconds per turn), the physics "
        "at the real speed.\n\n"
        "- Cams: an eccentric circle (R = 40 mm, its centre e = 10 mm from the shaft) and "
        "rise-dwell-return cams (base circle 40 mm, lift 20 mm, rise = fall, 30° upper dwell) with "
        "the cycloidal, harmonic or 3-4-5 law. The cam drawn is the actual contour for the follower "
        "chosen: the envelope of the flat face's positions, or the inner offset of the path of the "
        "roller's centre.\n"
        "- Closed forms: flat face on the eccentric cam s = e (1 − cos θ); at constant ω the "
        "follower's velocity is ω s′ and its acceleration ω² s″; the contact force along the common "
        "normal is N = (m ω² s″ + k s + F0 + m g) / cos φ (φ the pressure angle, 0 for a flat face). "
        "N first reaches zero at the **jump speed** ω_j² = min over s″ < 0 of (k s + F0 + m g) / "
        "(−m s″); for the flat face on the eccentric cam ω_j = √((2 k e + F0 + m g) / (m e)). The "
        "readout's lift, velocity, acceleration and force are these closed forms at the angle shown "
        "(every 0.25°).\n"
        "- Above the jump speed N < 0 over an interval: the contact would have to pull. The interval "
        "is shaded in the plots and drawn in purple on the cam; in the closed form the follower "
        "still follows the cam there.\n"
        "- *Compliant contact*: cam and follower as a multibody System with their contact as two "
        "planar curves (the surfaces of Eqs. 8.84-8.89, the contact constraints of Eqs. 8.90-8.94, "
        "the normal force the independent multiplier of the augmented equations, Eqs. 8.95-8.108; "
        "the line contact of a flat face on a cam reduced to curve on curve, Eq. 8.109). When the "
        "multiplier crosses zero the run continues with a Hunt-Crossley contact, so the follower "
        "leaves the cam and lands. Computed one revolution at a time in a worker process: on the cam "
        "the system has no degree of freedom, so each of the 180 outputs per revolution is a kinematic "
        "analysis (positions, velocities, accelerations and the multipliers solved from the "
        "constraints); in flight DOP853 at rtol 1e-8 integrates it.\n"
        "- Drawn on the cam: the contact point (black dot), the common normal (teal) and the force of "
        "the cam on the follower, N n (orange; purple where N < 0), its length saturating at 45 mm "
        "(half of it at 40 N). In flight the normal and the force are gone and the dot is the cam's "
        "point nearest the follower.\n"
        "- *Download CSV*: one revolution of the closed form every 0.25° (angle, lift, velocity, "
        "acceleration, force)."
    )
    # Seen from the front (-y), a little from the right and above, the stand left of the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (0.12, -0.27, 0.10)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.075, 0.0, 0.055)
    Inputs = Inputs
    chunks_kept, refresh_period, csv_header, refusal_title = 4, 0.2, CSV_HEADER, "Cam refused"
    check_on_loop = False  # (a new shape costs ms: build_cam in the job)

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.revolution: Chunk | None = None  # the closed form in use (its chunk 0)
        self.revision, self.drawn_revision = 0, -1  # revolutions swapped in; the one drawn last
        self.mechanism: CamMechanism | None = None  # (build_nodes)
        self.run_chunk = None
        self.cam_angle = self.force = 0.0  # drawn: rad, N
        self.index = 0  # closed-form table row drawn
        self._angle: float | None = None  # a loaded cam angle (rad), applied at the next frame
        self._thrown, self._reconfigure = False, False

    compliant = property(lambda self: bool(self.config is not None and self.config.compliant))

    def job(self, inputs: Inputs, segment: Any) -> Any:
        return functools.partial(compute_chunk if inputs.compliant else closed_form_chunk, inputs)

    def check_inputs(self, inputs: Inputs) -> None:
        build_cam(inputs, shape_only=True)  # (a refusal in the panel's terms)

    # -- nodes and controls ------------------------------------------------------------------
    def build_nodes(self) -> None:
        flat, roller = (cam_layout(build_cam(Inputs(follower=kind), shape_only=True)) for kind in FOLLOWERS)
        self.mechanism = CamMechanism(self, self.root, flat, roller)

    def build_controls(self) -> None:
        d = Inputs()
        self.legend = self.add_legend(LEGEND, "Drawn on the cam (arrow length saturates):")
        self.add_playback(time_scale=False)  # (Slow motion sets the time scale)
        self.info = self.add_readout("")
        add = self.controls.add
        with self.target.gui.add_folder("Speed and loads"):
            add(Slider("rpm", "Cam speed (rpm)", min=10.0, max=3000.0, step=1.0, default=d.rpm,
                       hint="Constant cam speed used by the physics"))
            add(Slider("mass", "Follower mass (kg)", min=0.05, max=5.0, step=0.01, default=d.mass))
            add(Slider("stiffness", "Spring k (N/m)", min=0.0, max=20000.0, step=10.0, default=d.stiffness))
            add(Slider("preload", "Preload F0 (N)", min=0.0, max=200.0, step=0.5, default=d.preload,
                       hint="Spring force at zero lift"))
        with self.target.gui.add_folder("Cam and follower"):
            add(Choice("profile", "Cam", options=PROFILES, default=d.profile))
            add(Choice("follower", "Follower", options=FOLLOWERS, default=d.follower))
            add(Slider("rise_deg", "Rise = fall (deg)", min=RISE_DEG_RANGE[0], max=RISE_DEG_RANGE[1], step=1.0,
                       default=d.rise_deg, hint="Cam angle of the rise and of the fall (rise-dwell-return cams)"),
                disabled=True)
            add(Slider("roller_mm", "Roller radius (mm)", min=ROLLER_MM_RANGE[0], max=ROLLER_MM_RANGE[1], step=0.5,
                       default=d.roller_mm, hint="Radius of the roller (roller follower)"), disabled=True)
        with self.target.gui.add_folder("Motion"):
            add(Slider("turn_seconds", "Slow motion (s per turn)", min=0.5, max=20.0, step=0.5, default=5.0,
                       hint="Wall-clock seconds the cam takes for one turn"))
            add(Toggle("compliant", "Compliant contact (the follower can jump)", default=False,
                       hint="Run the multibody System: constraints, then a Hunt-Crossley contact after a separation"))
            add(Toggle("show_contact", "Contact point, normal, force", default=True))

    def plots(self) -> list[PlotSpec]:
        """The closed form over the cam angle (every 0.5 deg, N < 0 shaded), then the compliant run's revolution."""
        def closed(name: str) -> PlotSpec:
            title, first, y = _CLOSED_PLOTS[name]
            force = name == "force"
            return PlotSpec(name, title, (first, *(_FORCE_MORE if force else ()), _SHADE), lambda t, c: (
                c[::2, y], *((0.0 * c[::2, y], c[::2, 5], np.minimum(c[::2, 4], 0.0)) if force else
                             (np.where(c[::2, 4] < 0.0, c[::2, y], 0.0),))), x_label="θ (deg)", aspect=1.7,
                            x=lambda t, c: c[::2, 0], per_chunk=True, table=lambda chunk: self.revolution.table)
        run = {"shown": lambda inputs: inputs.compliant, "x_label": "θ (deg)", "aspect": 1.7,
               "x": lambda t, c: c[:, 0], "per_chunk": True}
        return [*(closed(name) for name in _CLOSED_PLOTS),
                PlotSpec("run_lift", "compliant run: lift (mm)", (("cam under it (mm)", "#2266dd"),
                         ("follower (mm)", "#9633c8")), lambda t, c: (c[:, 1], c[:, 2]), **run),
                PlotSpec("run_force", "compliant run: force N (N)", (("closed form (N)", "#888888"),
                         ("System (N)", "#d97706")), lambda t, c: (c[:, 3], c[:, 4]), capped=True, **run)]

    # -- state, errors ----------------------------------------------------------------------------
    def extra_state(self) -> dict[str, Any]:
        """The cam angle shown (deg) and whether the cam turns, so a paused scene is reproduced at its angle."""
        return {"cam_angle_deg": round(math.degrees(self.cam_angle), 9), "playing": self.playing}

    def load_extra_state(self, extra: dict[str, Any]) -> list[str]:
        refused = [f"{key!r}: not part of this scene's state" for key in extra if key not in ("cam_angle_deg",
                                                                                             "playing")]
        value, playing = extra.get("cam_angle_deg", 0.0), extra.get("playing", True)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 360.0:  # (nan too)
            refused.append(f"cam_angle_deg: expected a number from 0 to 360, got {value!r}")
        elif "cam_angle_deg" in extra:
            self._angle = math.radians(float(value))
        if not isinstance(playing, bool):
            refused.append(f"playing: expected true or false, got {playing!r}")
        elif "playing" in extra:
            self.playback.set_playing(playing)
        return refused

    def on_error(self, error: BaseException) -> bool:
        if self.compliant:
            self._stop_run(f"{error}. Showing the closed form again; turn the compliant contact on to try again.")
        return self.compliant

    def _stop_run(self, text: str) -> None:
        self._thrown, self._reconfigure = True, True  # (the inputs shown, from the next frame)
        self.notify("Compliant run stopped", text, "warning")
        self.controls.set("compliant", False)

    # -- the clock ----------------------------------------------------------------------------------
    def on_configure(self, inputs: Inputs) -> None:
        self.timeline.chunk_time = self.window = 2.0 * math.pi / inputs.speed  # a chunk (and the history) is a turn
        self.run_chunk, self._thrown = None, False
        if self.revolution is not None:  # (its advice follows the toggle)
            self.info.content = self._info(self.revolution)

    def update(self, dt: float) -> None:
        super().update(min(max(dt, 0.0), 0.1))  # a stalled loop advances the cam by at most 0.1 s of wall time

    def on_frame(self, changed: set[str]) -> None:
        if self._reconfigure:  # a stopped run: the closed form again
            self._reconfigure = False
            self.configure(self.inputs)
        self.playback.set_time_scale(self.timeline.chunk_time / float(self.controls.value("turn_seconds")))
        if self._angle is not None and not self.compliant:  # a loaded angle, on the table's grid
            i = round(self._angle / (2.0 * math.pi) * REVOLUTION_SAMPLES) % REVOLUTION_SAMPLES
            self.local_time = self.sim_time = i * self.timeline.chunk_time / REVOLUTION_SAMPLES
            self._angle, self._drawn = None, None
        shown = self.mechanism.contact_frame.visible
        if bool(self.controls.value("show_contact")) != shown:  # (a click or a loaded state)
            self._drawn = None

    def _use(self, rev: Chunk) -> None:
        """Draw the closed form ``rev`` from now on: its cam and follower, separation arc and info."""
        self.revolution, self.revision = rev, self.revision + 1
        self.mechanism.use(rev.layout, rev.closed.separated)
        self.info.content = self._info(rev)
        self.controls.handles["rise_deg"].disabled = rev.inputs.profile == PROFILES[0]
        self.controls.handles["roller_mm"].disabled = rev.inputs.follower != FOLLOWERS[1]

    # -- drawing -----------------------------------------------------------------------------------
    def draw(self, chunk: Chunk, j: int) -> None:
        rev = chunk if chunk.run is None else chunk.revolution
        if rev is not None and (self.revolution is None or rev.inputs != self.revolution.inputs):
            self._use(rev)
        self.drawn_revision, show, run = self.revision, bool(self.controls.value("show_contact")), chunk.run
        if run is None:
            c = chunk.closed
            self.index = i = j % REVOLUTION_SAMPLES
            self.cam_angle, self.force, lift = float(c.theta[i]), float(c.contact_force[i]), float(c.lift[i])
            self.mechanism.pose(self.cam_angle, lift, c.contact_point[i], c.contact_normal[i], self.force,
                                in_contact=True, show_contact=show)
            return
        self.run_chunk, now = chunk, run.t[0] + self.sim_time - chunk.t[0]  # (a repeated revolution: the run's clock)
        at, limit = run.at(now), self.mechanism.travel_limit
        if at.lift > limit:
            if not self._thrown:
                i = self.config
                spring = (f"the spring (k = {i.stiffness:g} N/m, F0 = {i.preload:g} N)" if i.stiffness or i.preload
                          else "gravity alone (k = 0, F0 = 0)")
                self._stop_run(f"The follower flew to the end of its travel, {1000.0 * limit:.0f} mm "
                               "above its lowest position (its spring would be solid there, and this model has no "
                               f"stop): at {i.rpm:g} rpm {spring} cannot keep it near the cam. Raise the stiffness "
                               "or the preload, or lower the cam speed. Showing the closed form again.")
            return
        self.cam_angle, self.force = (chunk.inputs.speed * self.sim_time) % (2.0 * math.pi), at.contact_force
        self.mechanism.pose(self.cam_angle, at.lift, at.contact_point[[0, 2]], at.contact_normal[[0, 2]], self.force,
                            in_contact=at.in_contact, show_contact=show)

    # -- readouts and export --------------------------------------------------------------------
    def time_text(self) -> str:
        if self.last_chunk.run is not None:
            return (f"**t** = {1000.0 * self.display_time:.2f} ms (revolution {self.last_chunk.k + 1}) · **θ** = "
                    f"{_deg(self.cam_angle):.1f}°")
        lift = float(self.revolution.closed.lift[self.index])
        return f"**θ** = {_deg(self.cam_angle):.2f}° · **s** = {1000.0 * lift:.4f} mm"

    def readout_lines(self) -> list[str]:
        chunk, turn = self.last_chunk, float(self.controls.value("turn_seconds"))
        slow = (f"*slow motion*: one turn in {turn:g} s (a real turn takes "
                f"{1000.0 * 2.0 * math.pi / self.config.speed:.1f} ms)")
        if chunk.run is not None:
            return [*self.run_lines(chunk, self.sample_index(chunk)), slow]
        c, i = self.revolution.closed, self.index
        state = ("pressing" if self.force >= 0.0 else
                 "< 0: the contact would have to pull; a real follower leaves the cam")
        return [f"**v** = ω s′ = {float(c.velocity[i]):.4f} m/s · **a** = ω² s″ = {float(c.acceleration[i]):.2f} "
                f"m/s²", f"**N** = {self.force:.3f} N ({state})", slow]

    @staticmethod
    def run_lines(chunk: Chunk, j: int) -> list[str]:
        """The readout's lines on sample ``j`` of a run's ``chunk``: the lifts, then core's words on the contact
        and the events so far in this revolution (:meth:`rigidlab.core.models.CamMotion.describe`)."""
        lift = chunk.table.columns[j]
        return [f"follower lift {lift[2]:.3f} mm, cam under it {lift[1]:.3f} mm", *_words(chunk.run.describe(j))]

    def _info(self, rev: Chunk) -> str:
        """Core's words on the revolution (the separation's advice follows the toggle) and on the cam."""
        lines = _words(rev.closed.describe())
        if rev.closed.separations:
            lines[1] += (" Shaded in the plots, purple on the cam. " + ("The compliant run (its plots below) shows "
                         "the follower leave the cam and land." if self.compliant else
                         "Turn on *Compliant contact* to see the follower jump."))
        return "\n\n".join([*lines, " ".join(_words(rev.cam.describe()))])

    def csv_bytes(self) -> bytes:
        """One revolution of the closed form in use, a row per 0.25 deg (not the plotted window: the plots are over
        the cam angle)."""
        if self.revolution is None:
            return (CSV_HEADER + "\n").encode()
        c, n = self.revolution.closed, REVOLUTION_SAMPLES
        rows = format_rows(np.arange(n) * (360.0 / n), np.column_stack([c.lift, c.velocity, c.acceleration,
                                                                         c.contact_force])[:n])
        return ("\n".join((CSV_HEADER, *rows)) + "\n").encode()
