"""Rolling disk scene: a coin (Euler's disk) on the ground, rolling without slip or sliding.

The disk of :func:`rigidlab.core.models.rolling_disk` on a :class:`SimulationScene`: each chunk (0.5 s, 30
samples) is one call of :func:`rigidlab.core.models.rolling_disk_run` in a worker process, continued from the
chunk before's ``final_state``; core says where the disk leaves the ground, falls flat or the run fails
(the layer's final chunk). The chunk also forms the contact point's track
(:func:`rigidlab.app.scenes._trail.sampled_curve`), which :class:`rigidlab.app.scenes._trail.SampledTrack` draws up to the
contact point in every page frame; a frame only slices arrays.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import pickle
import time
from typing import Any, ClassVar

import numpy as np
import trimesh

from rigidlab.app.controls import Choice, Slider, Toggle
from rigidlab.app.nodes import set_pose
from rigidlab.app.readout import one_digit, relation, significant
from rigidlab.app.scenes._bodies import ForceArrow, add_disk
from rigidlab.app.scenes._plots import Table, log10_floor
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene, job
from rigidlab.app.scenes._trail import SampledTrack, curve_pieces as track_pieces, sampled_curve
from rigidlab.core.models import RollingDisk, rolling_disk_critical_spin, rolling_disk_run

__all__ = ["CONTACTS", "CSV_HEADER", "Inputs", "Model", "PRESETS", "ROLLING", "RTOL", "RollingDiskScene", "SLIDING",
           "preset_inputs", "track_pieces"]

ROLLING, SLIDING = CONTACTS = ("Rolling without slip", "Frictionless sliding")
PRESETS = ("Upright, 2 × critical spin", "Upright, 0.7 × critical spin", "Leaning coin, circling", "Sliding coin")
#: DOP853's tolerances: the energy drifts by about 1e-7 of E over 3 s (the default disk).
RTOL, ATOL = 1e-6, 1e-8
CSV_HEADER = ("t (s),x (m),y (m),z (m),p0,p1,p2,p3,lean (rad),E (J),max |C| (m),max |dC/dt| (m/s),"
              "normal force (N)")
_GRAVITY = 9.81
_CHUNK, _SAMPLES = 0.5, 30  # s of simulated time per chunk, samples per chunk (plus its start)
_LIFT = 0.0015  # m: the track and the contact point above the ground, so the grid does not cover them
_FLOOR = 1e-14  # of the disk's size (m) or speed (m/s): residuals below are round-off, read "< ..."
_GRID_SECTION = 0.25  # m: the grid repeats with this period (a shift by it is invisible)
_ARROW_RADII = 3.0  # the force arrow: length 3 R |F| / (|F| + m g) from the contact point
_DISK_COLOR, _MARKER_COLOR = (196, 170, 110), (70, 45, 30)  # brass; dark stripe across the face: the spin
_TRACK_COLOR, _FORCE_COLOR, _POINT_COLOR = (0, 150, 140), (225, 95, 0), (40, 40, 48)
_POINT_RADIUS = 0.07  # of the disk's radius
_LEGEND = ((_DISK_COLOR, "disk (dark stripe: the spin)"), (_TRACK_COLOR, "track of the contact point on the ground"),
           (_FORCE_COLOR, "ground's force on the disk, at the contact point"))
_LEAN, _ENERGY, _RES_P, _RES_V, _NORMAL = 7, 8, 9, 10, 11  # columns of a chunk's table (after t)


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's model controls (degrees only for the lean)."""

    lean_deg: float = 10.0
    spin: float = 12.0
    heading_rate: float = 0.0
    contact: str = ROLLING
    radius: float = 0.1
    mass: float = 1.0


def preset_inputs(name: str, *, radius: float = Inputs.radius, mass: float = Inputs.mass) -> Inputs:
    """Control values of preset ``name`` for a disk of ``radius`` (m) and ``mass`` (kg); every preset sets
    its contact model (the upright ones roll, at a multiple of the rolling critical spin)."""
    if name in PRESETS[:2]:
        spin = (2.0 if name == PRESETS[0] else 0.7) * rolling_disk_critical_spin(radius, gravity=_GRAVITY)
        return Inputs(1.0, round(spin, 2), 0.0, ROLLING, radius, mass)
    if name in PRESETS[2:]:
        return Inputs(*((20.0, 10.0, 0.0, ROLLING) if name == PRESETS[2] else (10.0, 15.0, 0.0, SLIDING)), radius, mass)
    raise ValueError(f"name: expected one of {list(PRESETS)}, got {name!r}")


@dataclasses.dataclass(frozen=True)
class Model(RollingDisk):
    """What a chunk job needs: core's disk (picklable, hashable; it checks its values)."""

    @classmethod
    def from_inputs(cls, inputs: Inputs) -> Model:
        """The model of ``inputs`` (ValueError naming the argument)."""
        if inputs.contact not in CONTACTS:
            raise ValueError(f"contact: expected one of {list(CONTACTS)}, got {inputs.contact!r}")
        return cls(float(inputs.radius), float(inputs.mass), math.radians(inputs.lean_deg), float(inputs.spin),
                   float(inputs.heading_rate), inputs.contact == ROLLING, gravity=_GRAVITY)


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """Chunk ``k``: core's run, its CSV table, what a frame draws, the track's points (read-only)."""

    k: int
    model: Model
    run: Any  # core.models.RollingDiskRun
    table: Table  # t and the CSV columns: centre, p, lean, E, max |C|, max |dC/dt|, N
    track: np.ndarray  # (m, 3) and (n + 1,): app.scenes._trail.sampled_curve of the contact point
    track_start: np.ndarray
    energy0: float  # J at t = 0
    cpu_seconds: float
    worker: int  # pid of the process that computed it

    t, end, final = (property(lambda self, a=a: getattr(self.run, a)) for a in ("t", "end", "final"))
    frames = property(lambda self: np.column_stack([self.run.q, self.run.contact_point, self.run.contact_force]),
                      doc="(n, 13) centre, p, contact point, contact force on the disk")


@functools.lru_cache(maxsize=8)
def _built(model: Model) -> bytes:
    """The System, disk and contact of ``model``, pickled: built (placed, contact searched, assembled) once
    per model in each worker process; each chunk loads a fresh copy (about 1 ms)."""
    return pickle.dumps(model.system())


def _compute_chunk(model: Model, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``model``, continued from chunk ``k - 1`` (``previous``): runs on the executor."""
    cpu0 = time.thread_time()
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: chunk {k} continues from chunk {k - 1}, which was not given")
    run = rolling_disk_run(*pickle.loads(_built(model)), np.linspace(k * _CHUNK, (k + 1) * _CHUNK, _SAMPLES + 1),
                           initial=None if previous is None else previous.run.final_state, rtol=RTOL, atol=ATOL)
    before = previous and (float(previous.t[-1]), previous.run.contact_point[-2:] + (0.0, 0.0, _LIFT))
    track, start = sampled_curve(run.t, run.contact_point + (0.0, 0.0, _LIFT), before=before)
    table = Table.build(run.t, np.column_stack([run.q, run.lean, run.energy, run.residual_position,
                                                run.residual_velocity, run.normal_force]))
    return _Chunk(k, model, run, table, track, start, previous.energy0 if previous else float(run.energy[0]),
                  time.thread_time() - cpu0, os.getpid())


class RollingDiskScene(SimulationScene):
    """A thin disk on the ground: rolling without slip or frictionless sliding (core.contact)."""

    name: ClassVar[str] = "rolling_disk"
    title: ClassVar[str] = "Rolling disk (contact)"
    order: ClassVar[int] = 80
    help: ClassVar[str] = (
        "A thin uniform disk (radius R, mass m, moments m R²/4 about a diameter and m R²/2 about "
        "its axis) on the ground, as one body of the multibody System with one contact: its rim, a "
        "torus of minor radius 0, on the ground plane.\n\n"
        "- **Contact constraints**: the rim point and the ground point coincide (Eq. 8.90) and "
        "the ground's normal is perpendicular to the rim's two tangents (Eqs. 8.91, 8.93-8.94), in "
        "the body coordinates and the four surface parameters, which have no inertia. Adjoined "
        "with multipliers in the augmented equations (Eqs. 8.95-8.106), C_sᵀλ = 0 leaves one "
        "independent multiplier, the **normal force** (Eq. 8.107); C_s keeps full rank while "
        "the disk stands on its rim (Eq. 8.109; it is lost when the disk lies flat).\n"
        "- **Rolling without slip** adds the nonholonomic constraint that the rim's contact "
        "point has zero velocity, v + ω × (r_P − R) = 0; **frictionless sliding** leaves the "
        "horizontal velocity of the centre constant.\n"
        "- **Critical upright spin**: upright rolling is stable for ω2² > g / (3 R) (rolling, "
        "Routh) and ω2² > g / R (sliding); below it a small lean grows. The readout compares "
        "the initial spin with it (it speaks of the upright disk: a leaning disk circles "
        "instead).\n"
        "- **Integration**: DOP853 (rtol 1e-6) in chunks of 0.5 s ahead of the clock "
        "(core.models.rolling_disk_run), positions and velocities projected onto the constraints after "
        "every step. The run stops where the normal force reaches zero (the disk would leave the ground) "
        "or the disk falls flat.\n"
        "- **Drawn**: the disk with a dark stripe (the spin), the contact point's track on the "
        "ground (teal) and the ground's force on the disk (orange arrow, length 3 R |F| / "
        "(|F| + m g)). *Follow the disk* moves the ground under a fixed disk.\n"
        "- **Plots**: lean, log10 |E − E0| (energy is conserved: neither constraint does work), "
        "log10 of the constraint residuals max |C| and max |dC/dt|, and the normal force. "
        "*Download CSV* exports t, position, Euler parameters, lean, E, residuals and the normal "
        "force of the plotted window."
    )
    # A 3/4 view from the front left, the disk left of the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (0.32, -0.52, 0.27)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.14, 0.1, 0.04)
    Inputs = Inputs
    presets = PRESETS
    chunk_time = _CHUNK
    chunks_kept = 24
    csv_header = CSV_HEADER

    model: Model | None = None  # the model in use (loop thread)
    last_drawn: _Chunk | None = None  # the chunk drawn last, its sample _j, and the radius the disk is drawn at
    energy0, _j, _scale = math.nan, 0, Inputs.radius

    def camera_view(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The class's view scaled by the disk's radius (about the origin, where *Follow* keeps the disk)."""
        s = getattr(self.model, "radius", Inputs.radius) / Inputs.radius
        return tuple(s * x for x in self.camera_position), tuple(s * x for x in self.camera_look_at)  # type: ignore

    def job(self, inputs: Inputs, segment: Any) -> Any:
        return job(_compute_chunk, Model.from_inputs(inputs))

    def build_nodes(self) -> None:
        scene, root = self.target.scene, self.root
        self.grid = self.add_ground_grid(width=4.0, height=4.0, position=(0.0, 0.0, 0.0), cell_size=0.05,
                                         section_size=_GRID_SECTION)
        # what is fixed to the ground moves with it when the camera follows the disk
        self.ground = scene.add_frame(f"{root}/ground", show_axes=False)
        self.path = SampledTrack(self, f"{root}/ground/track", _TRACK_COLOR, thickness=3.0, thickness_units="screen",
                                 capacity=1000, min_step=0.002, head_length=0.03, head_count=64)
        self.track, self.track_head = self.path.trail, self.path.head
        self.point = scene.add_frame(f"{root}/ground/point", show_axes=False)
        ball = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        self.point_mesh = scene.add_mesh_simple(f"{root}/ground/point/mesh", ball.vertices, ball.faces,
                                                color=_POINT_COLOR, scale=_POINT_RADIUS * Inputs.radius)
        self.force = ForceArrow(self, f"{root}/ground/point/force", _FORCE_COLOR,  # for R = 0.1 m; with R
                                sizes={"shaft_radius": 0.0035, "head_radius": 0.009, "head_length": 0.02})
        self.force_frame, self.force_arrow = self.force.frame, self.force.arrow
        self.disk, self.disk_mesh, self.disk_marker = add_disk(  # translucent: the force arrow shows through
            scene, f"{root}/disk", color=_DISK_COLOR, marker_color=_MARKER_COLOR, radius=Inputs.radius, opacity=0.8,
            position=(0.0, 0.0, Inputs.radius))
        self.point_label = self.add_label(f"{root}/ground/point/label", "contact point", anchor="top-left", scale=1.2)

    def build_controls(self) -> None:
        self.legend = self.add_legend(_LEGEND, "Colours:")
        self.add_playback()
        self.info = self.add_readout("")
        self.add_presets()
        c, gui = self.controls, self.target.gui
        with gui.add_folder("Initial state (t = 0)"):
            c.add(Slider("lean_deg", "Lean (deg)", min=0.0, max=60.0, step=0.5, default=Inputs.lean_deg,
                         hint="Initial lean θ from upright (the symmetry axis rises by θ)"))
            c.add(Slider("spin", "Spin ω2 (rad/s)", min=-60.0, max=60.0, step=0.01, default=Inputs.spin,
                         hint="Initial angular velocity about the disk's axis; positive rolls it along +x"))
            c.add(Slider("heading_rate", "Heading rate dψ/dt (rad/s)", min=-10.0, max=10.0, step=0.01,
                         default=Inputs.heading_rate, hint="Initial turning rate about the vertical"))
        with gui.add_folder("Disk and contact"):
            c.add(Choice("contact", "Contact", options=CONTACTS, default=Inputs.contact,
                         hint="Rolling without slip, or sliding on a frictionless ground"))
            c.add(Slider("radius", "Radius R (m)", min=0.03, max=0.3, step=0.005, default=Inputs.radius,
                         hint="Radius of the thin uniform disk"))
            c.add(Slider("mass", "Mass m (kg)", min=0.01, max=5.0, step=0.01, default=Inputs.mass,
                         hint="Mass of the disk (the motion does not depend on it; forces and energy do)"))
        with gui.add_folder("Show"):
            c.add(Toggle("follow", "Follow the disk", default=True, hint="Keep the disk in view: the ground moves"))
            c.add(Toggle("show_track", "Track", default=True))
            c.add(Toggle("show_force", "Contact force arrow", default=True))

    def plots(self) -> list[PlotSpec]:
        return [
            PlotSpec("lean", "lean θ(t)", (("lean θ (deg)", "#2266dd"),), lambda t, c: (np.degrees(c[:, _LEAN]),)),
            PlotSpec("energy", "energy drift (log10)", (("log10 |E − E0| (J)", "#b45309"),),
                     lambda t, c: (log10_floor(c[:, _ENERGY] - self.energy0),)),
            PlotSpec("residual", "constraint residuals (log10)", (("log10 max |C| (m)", "#be185d"),
                     ("log10 max |dC/dt| (m/s)", "#7c3aed")),
                     lambda t, c: (log10_floor(c[:, _RES_P]), log10_floor(c[:, _RES_V]))),
            PlotSpec("normal", "normal force N (Eq. 8.107)", (("N (N)", "#0f766e"), ("m g", "#888888")),
                     lambda t, c: (c[:, _NORMAL], np.full_like(t, self.config.mass * _GRAVITY))),
        ]

    def check_inputs(self, inputs: Inputs) -> None:
        Model.from_inputs(inputs)  # (core's checks; the controls' ranges keep the values in)

    def preset_values(self, name: str) -> dict[str, Any]:
        values = self.controls.values()
        return dataclasses.asdict(preset_inputs(name, radius=values["radius"], mass=values["mass"]))

    def on_configure(self, inputs: Inputs) -> None:
        model = self.model = Model.from_inputs(inputs)
        rolling, critical = model.rolling, model.critical_spin
        verdict = ("**above** it: upright motion is stable (a small lean wobbles)" if abs(model.spin) > critical
                   else "**below** it: upright motion is unstable (a small lean grows)")
        where = (f"rolling at R ω = {significant(critical * model.radius, 3)} m/s" if rolling else
                 "sliding: the centre's speed plays no part")
        self.info.content = (
            f"**Critical upright spin** {'√(g / (3 R))' if rolling else '√(g / R)'} = {significant(critical, 3)} "
            f"rad/s ({where}).  \nInitial spin |ω2| = {significant(abs(model.spin), 3)} rad/s = "
            f"{significant(abs(model.spin) / critical, 3)} × critical: {verdict}.")
        if model.radius != self._scale:
            self.reframe()
            self.path.scale(model.radius / Inputs.radius)

    def on_restart(self) -> None:
        self.path.clear()
        self.last_drawn = None

    def end_notice(self, chunk: _Chunk) -> tuple[str, str]:
        return "Rolling disk stopped", f"{chunk.end[0].upper()}{chunk.end[1:]}. " \
                                       "Change a control, pick a preset or press Reset."

    def draw(self, chunk: _Chunk, j: int) -> None:
        previous, self.last_drawn, self._j, self.energy0 = self.last_drawn, chunk, j, chunk.energy0
        follow, show_track, show_force = (self.controls.value(k) for k in ("follow", "show_track", "show_force"))
        (cx, cy, cz, p0, p1, p2, p3), (px, py, pz), force = (a[j].tolist() for a in (
            chunk.run.q, chunk.run.contact_point + (0.0, 0.0, _LIFT), chunk.run.contact_force))
        self.path.follow(chunk.k, chunk.track, chunk.track_start, j, (px, py, pz), previous and (
            previous.k, previous.track, previous.track_start))
        ox, oy = (cx, cy) if follow else (0.0, 0.0)
        radius = chunk.model.radius
        if radius != self._scale:
            self._scale = self.disk_mesh.scale = self.disk_marker.scale = radius
            self.point_mesh.scale = _POINT_RADIUS * radius
            self.force.resize(radius / Inputs.radius)
        set_pose(self.disk, position=(cx - ox, cy - oy, cz), wxyz=(p0, p1, p2, p3))
        set_pose(self.ground, position=(-ox, -oy, 0.0))
        set_pose(self.grid, position=(-math.fmod(ox, _GRID_SECTION), -math.fmod(oy, _GRID_SECTION), 0.0))
        set_pose(self.point, position=(px, py, pz))
        self.path.visible = show_track
        self.path.draw(hold=self.refresh_due is not None)  # a frame that sends a plot sends no track buffer
        self.force.show(force if show_force else None, scale=_ARROW_RADII * radius,
                        reference=chunk.model.mass * _GRAVITY)

    drawn_model = property(lambda self: getattr(self.last_chunk, "model", None), doc="model of the chunk drawn")
    columns = property(lambda self: self.last_chunk.table.columns[self._j], doc="(12,) CSV columns drawn (after t)")
    centre = property(lambda self: np.array(self.last_chunk.run.q[self._j, :3]), doc="(3,) centre drawn (m)")
    contact_point = property(lambda self: np.array(self.last_chunk.run.contact_point[self._j]),
                             doc="(3,) the contact point drawn (global, m)")
    track_points = property(lambda self: self.track.points, doc="(n, 3) the track drawn, oldest first")

    def readout_lines(self) -> list[str]:
        if self.model is None or self.last_chunk is None:
            return []
        c, chunk, j = self.columns, self.last_chunk, self._j
        spin, heading_rate, speed = (float(a[j]) for a in (chunk.run.spin, chunk.run.heading_rate, chunk.run.speed))
        radius, energy = self.model.radius, float(c[_ENERGY])
        lines = [
            f"**lean** θ = {math.degrees(float(c[_LEAN])):.2f}° · **spin** ω2 = {significant(spin, 3)} rad/s · "
            f"dψ/dt = {significant(heading_rate, 3)} rad/s · speed {significant(speed, 3)} m/s",
            f"**N** = {significant(float(c[_NORMAL]), 4)} N · **E** = {significant(energy, 6)} J, E − E0 = "
            f"{one_digit(energy - self.energy0)} J · **max |C|** {relation(float(c[_RES_P]), _FLOOR * radius)} m, "
            f"max |dC/dt| {relation(float(c[_RES_V]), _FLOOR * max(speed, radius * abs(spin), 1e-3))} m/s",
        ]
        if chunk.run.n_rhs:
            lines.append(f"DOP853 rtol {RTOL:.0e}: {chunk.run.n_steps} steps, {chunk.run.n_rhs} right sides, "
                         f"{chunk.cpu_seconds / _CHUNK:.2f} s CPU per simulated second")
        if self.ended:
            lines.append(f"*Stopped: {chunk.end}.*")
        return lines
