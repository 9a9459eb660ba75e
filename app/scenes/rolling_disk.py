"""Rolling disk scene: a coin (Euler's disk) on the ground, rolling without slip or sliding.

The disk of :func:`core.models.rolling_disk`: a thin uniform disk whose rim
(a :class:`core.contact.Torus` of minor radius zero) touches the ground's
:class:`core.contact.Plane` through ``System.add_contact`` -- the five
contact constraints with the normal force as the independent multiplier,
and, rolling, the no-slip velocity constraints at the contact point. The
initial lean, spin and heading rate, the contact model, the radius and the
mass are the scene's controls; the readout compares the spin with the
critical upright spin of :func:`core.models.rolling_disk_critical_spin`.

The scene holds no physics and does no long work on the loop thread. The
motion is computed on the app's executor in chunks of 0.5 s of simulated
time ahead of the display clock (:class:`app.jobs.ChunkTimeline`,
sequential): the job :func:`_compute_chunk` takes the frozen :class:`Model`
(picklable parameters), rebuilds the System with
:func:`core.models.rolling_disk` in the worker, puts it in the final state
of the previous chunk and runs :meth:`core.multibody.System.simulate`
(DOP853); the same job reads the contact (point, force, normal force), the
energy and the constraint residuals, the lean, spin and heading rate
(:func:`core.rotations.euler_angles_from_euler_parameters` and
:func:`core.rotations.euler_angle_rates_from_omega` in the disk's ``"ZXY"``
angles), forms the plotted series (lean in degrees, the log10 energy drift
and residuals) and the track's points (below), and formats the CSV rows, so
that a frame only slices arrays. A run that cannot go on -- the disk leaves
the ground (the normal force reaches zero: a constraint cannot pull), lies
down flat (the contact loses rank, Eq. 8.109) or leans past
:data:`core.models.FLAT_LEAN` -- ends its chunk there, and the clock stops at
that instant with a notice.

Per frame the loop thread interpolates one row of samples and streams poses:
the disk (one mesh with a marker, created once and scaled when the radius
changes), the contact point, the contact-force arrow and, when the camera
follows the disk, the ground's offset. The contact point's track is a ring
of small line-segment chunks (:class:`app.scenes._trail.ChunkedTrail`) whose
newest chunk is sent ten times a second (a finished chunk is never sent
again); its newest two metres, up to the contact point drawn, are also a ring
of equal sticks placed by poses only (:class:`app.scenes._trail.StickHead`),
which the page draws in the same frame as the disk and the ground (new line
points reach the screen a page frame later: at the 2-4 fps of a software-
rendered page a track stretched every frame ended up to a metre behind).
Between two samples that turn sharply (a small coin's loops) the track
follows the parabola through the last three samples in pieces
(:func:`track_pieces`, formed by the chunk job), so it is a curve, not a
polygon of sample chords. The plots and the readout are refreshed one per
frame, four times a second (:class:`app.scenes._plots.PlotRefresh`); a
frame that sends the track's newest chunk leaves the next of them to the
frame after it, so no frame carries both.
"""

from __future__ import annotations

import bisect
import dataclasses
import functools
import math
import os
import pickle
import time
import warnings
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.controls import Choice, Slider, Toggle
from app.nodes import set_array, set_plot_data, set_pose, wxyz_z_to
from app.readout import one_digit, significant
from app.scenes._playback import Playback, PlaybackRequests
from app.scenes._plots import LOG_FLOOR, History, Legend, PlotRefresh, Table, log10_floor
from app.scenes._trail import ChunkedTrail, StickHead
from app.scenes.base import Scene
from app.jobs import ChunkTimeline
from core.contact import ContactError
from core.integrators import IntegrationError
from core.models import FLAT_LEAN, rolling_disk, rolling_disk_critical_spin
from core.multibody import AssemblyError, SingularSystemError
from core.rotations import (
    GimbalLockWarning,
    euler_angle_rates_from_omega,
    euler_angles_from_euler_parameters,
    rotate_vector,
)

__all__ = [
    "CONTACTS",
    "CSV_HEADER",
    "Inputs",
    "Model",
    "PRESETS",
    "ROLLING",
    "RTOL",
    "RollingDiskScene",
    "SLIDING",
    "log10_floor",
    "preset_inputs",
]

#: The contact models (the *Contact* dropdown).
ROLLING = "Rolling without slip"
SLIDING = "Frictionless sliding"
CONTACTS = (ROLLING, SLIDING)

#: Preset names in the order of their buttons.
PRESETS = (
    "Upright, 2 × critical spin",
    "Upright, 0.7 × critical spin",
    "Leaning coin, circling",
    "Sliding coin",
)

#: DOP853's relative tolerance (atol is 100 times smaller, in the state's
#: units). The energy then drifts by about 1e-7 of E over 3 s (the default
#: disk); positions and velocities are projected onto the constraints after
#: every step, so the residuals stay at the projection's tolerance.
RTOL = 1e-6
ATOL = 1e-8

#: Header of the exported CSV (one line: column names with units).
CSV_HEADER = ("t (s),x (m),y (m),z (m),p0,p1,p2,p3,lean (rad),E (J),max |C| (m),max |dC/dt| (m/s),"
              "normal force (N)")

_GRAVITY = 9.81
_CHUNK_SIM_TIME = 0.5  # s of simulated time per chunk
_SAMPLES = 30  # samples per chunk (60 per simulated second), plus the chunk's start
_CHUNKS_KEPT = 24
_REFRESH_PERIOD = 0.25  # s of wall time between plot / readout refreshes (4 Hz; bytes: docs/app.md)
_TRACK_PERIOD = 0.1  # s of wall time between track buffer updates (~10 Hz)
_TRACK_CAPACITY = 1000  # line segments of the contact point's track
_TRACK_MIN_STEP = 0.002  # m (for the 0.1 m disk; in proportion to the radius): a track point closer than this to
# the last one is not added
#: The track between two samples (1/60 s of motion apart) turns by at most this angle (rad) per straight piece: a
#: sample chord that turns more from the one before is cut into pieces along the parabola through the last three
#: samples (at most :data:`_TRACK_PIECES`). A 3 cm coin's samples are 6 mm apart on loops of a few centimetres:
#: their chords turn by up to 20 degrees, a visible polygon at close range.
_TRACK_TURN = math.radians(3.0)
_TRACK_PIECES = 8
_TRACK_LIFT = 0.0015  # m above the ground, so the grid does not cover the track
#: Residuals below this fraction of the disk's size (m) or speed (m/s) are round-off and read "< ..." (about
#: 50 eps: the projection stops at a few eps of its scale)
_RESIDUAL_FLOOR = 1e-14
_HEAD_STICK = 0.03  # m: the chords of the track's newest stretch, drawn by poses
_HEAD_STICKS = 64  # chords in that stretch (1.92 m: 1.6 s at the default speed, 1.2 m/s)
_WINDOW = 10.0  # s of simulated time in the plots and the CSV
_GRID_SECTION = 0.25  # m: the grid repeats with this period (so a shift by it is invisible)
_GRID_SIZE = 4.0  # m
_DISK_THICKNESS = 0.06  # of the radius: the unit disk's thickness
# The contact force arrow: length 3 R |F| / (|F| + m g) (m), from the contact point.
_ARROW_RADII = 3.0
# Colours: none of the arrows or curves red, green or blue (frame axes).
_DISK_COLOR = (196, 170, 110)  # brass
#: The disk is drawn slightly translucent: the contact-force arrow runs from the contact point inside or behind
#: it (inside near upright, behind when the disk leans towards the camera) and shows through it
_DISK_OPACITY = 0.8
_MARKER_COLOR = (70, 45, 30)  # dark brown stripe across the face: the spin
_TRACK_COLOR = (0, 150, 140)  # teal
_FORCE_COLOR = (225, 95, 0)  # orange
_POINT_COLOR = (40, 40, 48)
_LABEL_SCALE = 1.2
_POINT_RADIUS = 0.07  # of the disk's radius: the contact point's dot

# Columns of _Chunk.frames: what a frame draws, interpolated as one row.
_CENTRE, _P, _POINT, _FORCE = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13)
# Columns of _Chunk.table.columns (the CSV's after t).
_LEAN, _ENERGY, _RES_P, _RES_V, _NORMAL = 7, 8, 9, 10, 11
# Columns of _Chunk.rates: lean rate, spin omega_2 (about the axis), heading rate (rad/s), speed (m/s).
_LEAN_RATE, _SPIN, _HEADING_RATE, _SPEED = 0, 1, 2, 3
# Columns of _Chunk.plots.columns: the plotted series, lean (deg), log10 |E - E0|, log10 max |C|, log10 max |dC/dt|, N.
_PLOT_LEAN, _PLOT_ENERGY, _PLOT_RES_P, _PLOT_RES_V, _PLOT_NORMAL = 0, 1, 2, 3, 4

#: The controls that define the motion (a change restarts it).
_MODEL_KEYS = frozenset({"lean_deg", "spin", "heading_rate", "contact", "radius", "mass"})


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's model controls (degrees only for the lean)."""

    lean_deg: float = 10.0
    spin: float = 12.0
    heading_rate: float = 0.0
    contact: str = ROLLING
    radius: float = 0.1
    mass: float = 1.0

    @classmethod
    def from_values(cls, values: dict[str, Any]) -> Inputs:
        """The inputs of control values ``values`` (``ControlPanel.values()``, or a state's values over them)."""
        return cls(**{f.name: values[f.name] for f in dataclasses.fields(cls)})


_DEFAULT = Inputs()

#: The model's controls, in panel order.
SLIDERS: tuple[Slider, ...] = (
    Slider("lean_deg", "Lean (deg)", min=0.0, max=60.0, step=0.5, default=_DEFAULT.lean_deg,
           hint="Initial lean θ from upright (the symmetry axis rises by θ)"),
    Slider("spin", "Spin ω2 (rad/s)", min=-60.0, max=60.0, step=0.01, default=_DEFAULT.spin,
           hint="Initial angular velocity about the disk's axis; positive rolls it along +x"),
    Slider("heading_rate", "Heading rate dψ/dt (rad/s)", min=-10.0, max=10.0, step=0.01,
           default=_DEFAULT.heading_rate, hint="Initial turning rate about the vertical"),
    Slider("radius", "Radius R (m)", min=0.03, max=0.3, step=0.005, default=_DEFAULT.radius,
           hint="Radius of the thin uniform disk"),
    Slider("mass", "Mass m (kg)", min=0.01, max=5.0, step=0.01, default=_DEFAULT.mass,
           hint="Mass of the disk (the motion does not depend on it; forces and energy do)"),
)


def preset_inputs(name: str, *, radius: float = _DEFAULT.radius, mass: float = _DEFAULT.mass,
                  contact: str = ROLLING) -> Inputs:
    """Control values of preset ``name`` for a disk of ``radius`` (m) and ``mass`` (kg).

    The upright presets spin at a multiple of the critical upright spin of
    ``contact`` (:func:`core.models.rolling_disk_critical_spin`); the others
    set their own contact model.

    Raises
    ------
    ValueError
        For an unknown preset name or a contact not in :data:`CONTACTS`.
    """
    if contact not in CONTACTS:
        raise ValueError(f"contact: expected one of {list(CONTACTS)}, got {contact!r}")
    if name in (PRESETS[0], PRESETS[1]):
        factor = 2.0 if name == PRESETS[0] else 0.7
        spin = factor * rolling_disk_critical_spin(radius, rolling=contact == ROLLING, gravity=_GRAVITY)
        return Inputs(1.0, round(spin, 2), 0.0, contact, radius, mass)
    if name == PRESETS[2]:
        return Inputs(20.0, 10.0, 0.0, ROLLING, radius, mass)
    if name == PRESETS[3]:
        return Inputs(10.0, 15.0, 0.0, SLIDING, radius, mass)
    raise ValueError(f"name: expected one of {list(PRESETS)}, got {name!r}")


@dataclasses.dataclass(frozen=True)
class Model:
    """What a chunk job needs: the disk and its initial state (picklable, hashable).

    Attributes
    ----------
    radius : R (m)
    mass : m (kg)
    lean : initial lean (rad)
    spin : initial spin omega_2 about the axis (rad/s)
    heading_rate : initial heading rate (rad/s)
    rolling : rolling without slip (True) or frictionless sliding (False)
    """

    radius: float
    mass: float
    lean: float
    spin: float
    heading_rate: float
    rolling: bool

    @classmethod
    def from_inputs(cls, inputs: Inputs) -> Model:
        """The model of ``inputs``.

        Raises
        ------
        ValueError
            For a value :func:`core.models.rolling_disk` would refuse (the
            controls' ranges keep them out; a state file is checked the same way).
        """
        if inputs.contact not in CONTACTS:
            raise ValueError(f"contact: expected one of {list(CONTACTS)}, got {inputs.contact!r}")
        model = cls(float(inputs.radius), float(inputs.mass), math.radians(inputs.lean_deg), float(inputs.spin),
                    float(inputs.heading_rate), inputs.contact == ROLLING)
        if not (math.isfinite(model.mass) and model.mass > 0.0):
            raise ValueError(f"mass: expected a finite number > 0 (kg), got {model.mass!r}")
        if not abs(model.lean) < FLAT_LEAN:
            raise ValueError(f"lean: expected |lean| < {math.degrees(FLAT_LEAN):.1f}°, got {inputs.lean_deg!r}°")
        rolling_disk_critical_spin(model.radius, rolling=model.rolling, gravity=_GRAVITY)  # checks the radius
        return model

    @property
    def critical_spin(self) -> float:
        """Critical upright spin (rad/s): sqrt(g / (3 R)) rolling, sqrt(g / R) sliding."""
        return rolling_disk_critical_spin(self.radius, rolling=self.rolling, gravity=_GRAVITY)


# -- the job: rebuild the disk in the worker, simulate one chunk ----------------------
@dataclasses.dataclass(frozen=True)
class _Chunk:
    """Samples of one chunk of simulated time (read-only arrays).

    ``frames`` holds, per sample, what a frame draws (centre, Euler
    parameters, contact point, contact force; interpolated as one row);
    ``q_end`` / ``v_end`` are the final state the next chunk continues from.
    ``end`` is empty while the motion goes on, else why it stopped at ``t[-1]``.
    ``track`` holds the points that extend the contact point's track to
    each sample (lifted over the ground, through :func:`track_pieces`; a
    sample at the time of the one before adds none) and ``plots`` the
    plotted series, both formed with the chunk, so that a frame only slices
    them.
    """

    k: int
    model: Model
    t: np.ndarray  # (n,) s, n >= 2
    frames: np.ndarray  # (n, 13) centre (3), p (4), contact point (3), contact force on the disk (3)
    rates: np.ndarray  # (n, 4) lean rate, spin omega_2, heading rate (rad/s), speed of the centre (m/s)
    table: Table  # t and the CSV columns: centre, p, lean, E, max |C|, max |dC/dt|, N
    plots: Table  # t and the plotted series: lean (deg), log10 |E - E0|, log10 max |C|, log10 max |dC/dt|, N
    track: np.ndarray  # (m, 3) track points (global, m, lifted); sample i adds track[track_start[i]:track_start[i + 1]]
    track_start: np.ndarray  # (n + 1,) int
    q_end: np.ndarray  # (7,)
    v_end: np.ndarray  # (6,)
    energy0: float  # J, at t = 0
    end: str  # "" while the motion goes on; else what ended it at t[-1]
    n_steps: int
    n_rhs: int
    cpu_seconds: float  # CPU time of the job (the worker's thread)
    worker: int  # pid of the process that computed it

    @property
    def final(self) -> bool:
        return bool(self.end)


def _continuous(P: np.ndarray, before: np.ndarray | None = None) -> np.ndarray:
    """Euler parameters (n, 4) with signs flipped so consecutive samples agree (for nlerp),
    the first with ``before`` (4,) when given."""
    P = np.array(P)
    if before is not None and float(P[0] @ before) < 0.0:
        P[0] = -P[0]
    for i in range(1, P.shape[0]):
        if float(P[i] @ P[i - 1]) < 0.0:
            P[i] = -P[i]
    return P


_RUN_ERRORS = (ContactError, SingularSystemError, IntegrationError, AssemblyError)


def _separation_text(traj: Any) -> str:
    return (f"the disk left the ground at t = {traj.separations[-1].t:.3f} s: the normal force reached zero "
            "and a contact constraint cannot pull (Eq. 8.107)")


def _simulate(system: Any, t: np.ndarray) -> tuple[list[Any], str]:
    """Run ``system`` over the times ``t``: its trajectories and why the run ended early ("" if not).

    A separation ends the run at its instant (``on_separation="stop"``). A
    run that fails (the contact lying flat, Eq. 8.109, or the integrator) is
    run again in pieces of about 1/20 of the chunk (at least one sample
    interval) and ends after the last piece that worked; the list then holds
    the pieces (possibly none).
    """
    options = {"method": "DOP853", "rtol": RTOL, "atol": ATOL, "on_separation": "stop"}
    start = system.state
    try:
        traj = system.simulate(t, **options)
    except _RUN_ERRORS as exc:
        failure = exc
    else:
        return [traj], _separation_text(traj) if traj.status == "separated" else ""
    pieces: list[Any] = []
    step = max(1, (t.size - 1) // 20)
    system.set_state(start)
    i = 0
    while i < t.size - 1:
        try:
            traj = system.simulate(t[i: i + step + 1], **options)
        except _RUN_ERRORS:
            break
        pieces.append(traj)
        if traj.status == "separated":
            return pieces, _separation_text(traj)
        system.set_state(traj.state(-1))
        i += step
    if isinstance(failure, ContactError) and "rank" in str(failure):
        return pieces, (f"the disk lay down flat near t = {t[i]:.3f} s: its contact constraints lose rank "
                        "there (Eq. 8.109)")
    return pieces, f"the run stopped near t = {t[i]:.3f} s: {type(failure).__name__}: {failure}"


def _joined(trajs: list[Any], contact: Any, disk: Any) -> dict[str, np.ndarray]:
    """Arrays of a run's pieces, joined without repeating the times they share."""
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "q", "v", "omega", "energy", "res_p", "res_v",
                                                           "point", "force", "normal")}
    for j, traj in enumerate(trajs):
        s = slice(1 if j else 0, None)
        history = traj.contact(contact)
        for key, a in (("t", traj.t), ("q", traj.q), ("v", traj.v), ("omega", traj.omega(disk)),
                       ("energy", traj.energy), ("res_p", traj.residual_position),
                       ("res_v", traj.residual_velocity), ("point", history.point), ("force", history.force),
                       ("normal", history.normal_force)):
            parts[key].append(np.asarray(a)[s])
    return {k: np.concatenate(v) for k, v in parts.items()}


def _still(previous: _Chunk, k: int, end: str, cpu0: float) -> _Chunk:
    """Chunk ``k`` after a motion that ended: the last sample of ``previous``, held."""
    return dataclasses.replace(
        previous, k=k, t=previous.t[-1:].repeat(2), frames=previous.frames[-1:].repeat(2, axis=0),
        rates=previous.rates[-1:].repeat(2, axis=0),
        table=Table.build(previous.t[-1:], previous.table.columns[-1:]),
        plots=Table(previous.plots.t[-1:], previous.plots.columns[-1:], ()), track=_NO_TRACK,
        track_start=np.zeros(3, dtype=np.intp), end=end, n_steps=0, n_rhs=0,
        cpu_seconds=time.thread_time() - cpu0, worker=os.getpid(),
    )


_NO_TRACK = np.zeros((0, 3))
_NO_TRACK.setflags(write=False)


def _track(t: np.ndarray, points: np.ndarray, previous: _Chunk | None) -> tuple[np.ndarray, np.ndarray]:
    """The track points of a chunk's samples: ``(track (m, 3), track_start (n + 1,))`` (see :class:`_Chunk`).

    ``t`` (n,) and ``points`` (n, 3) are the samples' times and contact
    points (global). Each sample extends the track from the two samples
    before it (the previous chunk's last two for the first ones; none at
    t = 0) through :func:`track_pieces`. A sample at the time of the one
    before (a chunk's first, which ends the previous chunk) adds nothing.
    """
    lifted = np.array(points, dtype=float)
    lifted[:, 2] += _TRACK_LIFT
    samples: list[np.ndarray] = []
    last = -math.inf
    if previous is not None:
        before = previous.frames[-2:, _POINT].copy()
        before[:, 2] += _TRACK_LIFT
        samples = list(before)
        last = float(previous.t[-1])
    parts: list[np.ndarray] = []
    start = [0]
    for ti, q in zip(t.tolist(), lifted):
        if ti > last:
            pieces = track_pieces(samples, q)
            parts.extend(pieces)
            samples = [*samples[-1:], q]
            last = ti
        start.append(len(parts))
    track = np.array(parts, dtype=float).reshape(-1, 3)
    track_start = np.array(start, dtype=np.intp)
    return track, track_start


@functools.lru_cache(maxsize=8)
def _built(model: Model) -> bytes:
    """The System, disk and contact of ``model`` as :func:`core.models.rolling_disk` builds them, pickled.

    Built once per model in each worker process: the builder places the disk,
    searches the contact and assembles (about a quarter of a chunk's CPU);
    each chunk loads a copy of it (about 1 ms), so a job stays a function of
    its arguments only (what an earlier job ran on the System never carries
    over).
    """
    return pickle.dumps(rolling_disk(model.radius, model.mass, model.lean, model.spin, model.rolling,
                                     heading_rate=model.heading_rate, gravity=_GRAVITY),
                        protocol=pickle.HIGHEST_PROTOCOL)


def _compute_chunk(model: Model, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``model`` (runs on the executor; never on the loop thread).

    The System is built from ``model`` (a job gets picklable parameters
    only; :func:`_built` keeps it per worker process); chunk 0 starts from
    the builder's assembled initial state, chunk ``k > 0`` from the final
    state of chunk ``k - 1`` (``previous``), at its time. After a chunk that
    ended the motion, the next one holds its last sample.

    Raises
    ------
    ValueError
        When chunk 0 cannot start at all, or the motion leaves the finite range.
    """
    cpu0 = time.thread_time()
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: chunk {k} continues from chunk {k - 1}, which was not given")
    if previous is not None and previous.final:
        return _still(previous, k, previous.end, cpu0)
    system, disk, contact = pickle.loads(_built(model))  # a fresh copy: each job starts from the same System
    if previous is not None:
        system.set_state(dataclasses.replace(system.state, t=float(previous.t[-1]), q=previous.q_end,
                                             v=previous.v_end))
    t = np.linspace(k * _CHUNK_SIM_TIME, (k + 1) * _CHUNK_SIM_TIME, _SAMPLES + 1)
    trajs, end = _simulate(system, t)
    if not trajs:  # not even the first piece: the motion ends where the chunk starts
        if previous is None:
            raise ValueError(end)
        return _still(previous, k, end, cpu0)
    s = _joined(trajs, contact, disk)
    P = _continuous(s["q"][:, 3:7], previous.frames[-1, _P] if previous is not None else None)
    with warnings.catch_warnings():  # past FLAT_LEAN the angles near their singularity; cut off below
        warnings.simplefilter("ignore", GimbalLockWarning)
        angles = euler_angles_from_euler_parameters(P / np.linalg.norm(P, axis=1)[:, None], "ZXY")
    flat = np.flatnonzero(np.abs(angles[:, 1]) >= FLAT_LEAN)  # (psi, theta, phi): theta is the lean
    if flat.size:  # the disk lies down: the motion ends at the last sample before FLAT_LEAN
        n = max(int(flat[0]), 1)
        end = (f"the disk fell flat at t = {s['t'][n - 1]:.3f} s (its lean reached "
               f"{math.degrees(FLAT_LEAN):.0f}°)")
        s = {key: a[:n] for key, a in s.items()}
        P, angles = P[:n], angles[:n]
    lean = angles[:, 1]
    rates = euler_angle_rates_from_omega(angles, s["omega"], "ZXY", tol=1e-9)  # d(psi, theta, phi)/dt
    spin = np.einsum("ij,ij->i", s["omega"], rotate_vector(P, np.array([0.0, 1.0, 0.0])))  # along the axis
    speed = np.linalg.norm(s["v"][:, :3], axis=1)
    frames = np.concatenate([s["q"][:, :3], P, s["point"], s["force"]], axis=1)
    columns = np.concatenate([s["q"][:, :3], s["q"][:, 3:7], lean[:, None], s["energy"][:, None],
                              s["res_p"][:, None], s["res_v"][:, None], s["normal"][:, None]], axis=1)
    rate_columns = np.stack([rates[:, 1], spin, rates[:, 0], speed], axis=1)
    for name, a in (("positions", frames), ("columns", columns), ("rates", rate_columns)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the motion left the finite range near t = {t[0]:.3g} s")
    table = Table.build(s["t"], columns)
    energy0 = previous.energy0 if previous is not None else float(columns[0, _ENERGY])
    series = np.stack([np.degrees(lean), log10_floor(s["energy"] - energy0), log10_floor(s["res_p"]),
                       log10_floor(s["res_v"]), s["normal"]], axis=1)
    tt = s["t"]
    if tt.size == 1:  # the run ended where it began: a still chunk of two equal samples
        tt, frames, rate_columns = (np.repeat(a, 2, axis=0) for a in (tt, frames, rate_columns))
    track, track_start = _track(tt, frames[:, _POINT], previous)
    q_end, v_end = np.array(s["q"][-1]), np.array(s["v"][-1])
    for a in (tt, frames, rate_columns, q_end, v_end, series, track, track_start):
        a.setflags(write=False)
    return _Chunk(k, model, tt, frames, rate_columns, table, Table(table.t, series, ()), track, track_start,
                  q_end, v_end, energy0, end, sum(int(tr.n_steps) for tr in trajs),
                  sum(int(tr.n_rhs) for tr in trajs), time.thread_time() - cpu0, os.getpid())


# -- meshes (created once, in build) ---------------------------------------------------
def track_pieces(samples: list[np.ndarray], q2: np.ndarray) -> list[np.ndarray]:
    """The points that draw the track from the last sample to the next one ``q2``, ending with ``q2``.

    ``samples``: up to two samples before ``q2`` (equally spaced in time, oldest first). When the chord to
    ``q2`` turns by more than :data:`_TRACK_TURN` from the chord before, it is cut into equal steps of time on
    the parabola through the three samples, ``q(s) = q1 + s (q2 - q0) / 2 + s^2 (q2 - 2 q1 + q0) / 2`` (``s``
    from 0 at ``q1`` to 1 at ``q2``; its error is third order in the time step), so that each piece turns
    by about :data:`_TRACK_TURN`, at most :data:`_TRACK_PIECES` pieces.
    """
    if len(samples) < 2:
        return [q2]
    q0, q1 = samples[-2], samples[-1]
    a, b = q1 - q0, q2 - q1
    la, lb = math.sqrt(float(a @ a)), math.sqrt(float(b @ b))
    if la == 0.0 or lb == 0.0:
        return [q2]
    turn = math.acos(min(max(float(a @ b) / (la * lb), -1.0), 1.0))
    pieces = min(_TRACK_PIECES, math.ceil(turn / _TRACK_TURN - 1e-9))
    if pieces <= 1:
        return [q2]
    slope, bend = 0.5 * (q2 - q0), 0.5 * (q2 - 2.0 * q1 + q0)
    return [q1 + (i / pieces) * slope + (i / pieces) ** 2 * bend for i in range(1, pieces)] + [q2]


def _disk_meshes() -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """The unit disk (radius 1, axis along body y, centred) and its marker stripe.

    The stripe runs across both faces from the rim to the centre along body
    +x, so the spin shows from either side; both are scaled by R per radius.
    """
    disk = trimesh.creation.cylinder(radius=1.0, height=_DISK_THICKNESS, sections=72)
    disk.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1.0, 0.0, 0.0]))
    stripe = trimesh.creation.box(extents=(0.92, _DISK_THICKNESS * 1.25, 0.16))
    stripe.apply_translation([0.5, 0.0, 0.0])
    return disk, stripe


@dataclasses.dataclass
class _Gui:
    readout: Any  # app.readout.Readout: the motion now (about 5 times a second)
    info: Any  # app.readout.Readout: the model's constants (when they change)
    legend: Legend
    plot_lean: Any
    plot_energy: Any
    plot_residual: Any
    plot_normal: Any


def _arrow_sizes(radius: float) -> dict[str, float]:
    """The force arrow's shaft and head (m) for a disk of ``radius``: in proportion to it (3.5 mm shaft, 9 mm
    head radius and 20 mm head for the default 0.1 m), so a 3 cm coin's arrow is not as large as the coin."""
    s = radius / _DEFAULT.radius
    return {"shaft_radius": 0.0035 * s, "head_radius": 0.009 * s, "head_length": 0.02 * s}


def _relation(x: float, floor: float) -> str:
    """``= 3e-12`` for a residual, ``< 1e-15`` at round-off (below ``floor``)."""
    text = one_digit(x, floor)
    return text if text.startswith("<") else f"= {text}"


class RollingDiskScene(PlaybackRequests, Scene):
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
        "- **Integration**: DOP853 (rtol 1e-6) in chunks of 0.5 s ahead of the clock, positions "
        "and velocities projected onto the constraints after every step. The run stops where "
        "the normal force reaches zero (the disk would leave the ground) or the disk falls flat.\n"
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

    def camera_view(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The class's view scaled by the disk's radius against the default one (about the origin, where
        *Follow the disk* keeps the disk): a 0.3 m disk stays in view and a 3 cm one is not a few pixels."""
        radius = self.model.radius if self.model is not None else _DEFAULT.radius
        s = radius / _DEFAULT.radius
        position = tuple(float(s * x) for x in self.camera_position)
        look_at = tuple(float(s * x) for x in self.camera_look_at)
        return position, look_at  # type: ignore[return-value]

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.playback = Playback(PRESETS, controls=self.controls)
        self.timeline = ChunkTimeline(self.executor, functools.partial(_compute_chunk, Model.from_inputs(_DEFAULT)),
                                      chunk_time=_CHUNK_SIM_TIME, sequential=True, capacity=_CHUNKS_KEPT)
        self.history = History()  # the CSV's tables
        self.plot_history = History()  # the plotted series (_Chunk.plots)
        self._refresh = PlotRefresh(("window", "readout", "lean", "energy", "residual", "normal"), _REFRESH_PERIOD)
        # Owned by update() (the session loop thread).
        self.model: Model | None = None
        self.drawn_model: Model | None = None  # the model of the chunk drawn last
        self.sim_time = 0.0
        self.waiting = False  # the clock holds: the chunk it needs is not ready
        self.ended = ""  # why the motion stopped (a final chunk was reached), else ""
        self.energy0 = math.nan
        self._near: tuple[_Chunk, int] | None = None  # the chunk drawn and its computed sample nearest the clock
        self._floats: dict[int, tuple[Any, ...]] = {}  # _floats_of's lists of the chunks drawn, by index
        self._row = [0.0] * 13  # the row of _Chunk.frames drawn last (interpolated)
        self.last_chunk: _Chunk | None = None
        self._drawn: tuple[Any, ...] | None = None
        self._refreshed_time = -1.0
        self._plot_window: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros((0, 0)))
        self._error_reported = False
        self._error_paused = False  # the failure paused a running clock (not one paused by hand)
        self._end_reported = ""
        self._track_time = -math.inf  # time of the newest sample in the track
        self._since_track = math.inf
        self._scale = math.nan  # radius the disk mesh is drawn at
        self._arrow_length = 0.0  # m, length of the force arrow as sent
        self.gui: _Gui | None = None

    # -- build ------------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        self.grid = self.add_ground_grid(width=_GRID_SIZE, height=_GRID_SIZE, position=(0.0, 0.0, 0.0),
                                         cell_size=0.05, section_size=_GRID_SECTION)
        # the ground frame carries what is fixed to the ground: it moves when the camera follows the disk
        self.ground = scene.add_frame(f"{root}/ground", show_axes=False)
        self.track = ChunkedTrail(self, f"{root}/ground/track", _TRACK_COLOR, thickness=3.0,
                                  thickness_units="screen", capacity=_TRACK_CAPACITY, min_step=_TRACK_MIN_STEP)
        # the newest stretch up to the contact point drawn, placed by poses: the page draws it in the
        # frame that moves the disk and the ground (the chunks' points reach the screen a frame later)
        self.track_head = StickHead(self, f"{root}/ground/track_head", _TRACK_COLOR, thickness=3.0,
                                    thickness_units="screen", length=_HEAD_STICK, count=_HEAD_STICKS)
        ball = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        self.point = scene.add_frame(f"{root}/ground/point", show_axes=False)
        self.point_mesh = scene.add_mesh_simple(f"{root}/ground/point/mesh", ball.vertices.astype(np.float32),
                                                ball.faces.astype(np.uint32), color=_POINT_COLOR,
                                                scale=_POINT_RADIUS * _DEFAULT.radius)
        # the force arrow points along +z of its own frame at the contact point: the
        # frame's pose turns it (a pose reaches the page with the other poses of
        # the frame), its length changes only when it has changed by 2 %
        self.force_frame = scene.add_frame(f"{root}/ground/point/force", show_axes=False)
        self.force_arrow = self.add_arrows(
            f"{root}/ground/point/force/arrow", np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]], dtype=np.float32),
            _FORCE_COLOR, **_arrow_sizes(_DEFAULT.radius),
        )
        self.disk = scene.add_frame(f"{root}/disk", show_axes=False, position=(0.0, 0.0, _DEFAULT.radius))
        disk, stripe = _disk_meshes()
        self.disk_mesh = scene.add_mesh_simple(f"{root}/disk/mesh", disk.vertices.astype(np.float32),
                                               disk.faces.astype(np.uint32), color=_DISK_COLOR,
                                               opacity=_DISK_OPACITY, scale=_DEFAULT.radius)
        self.disk_marker = scene.add_mesh_simple(f"{root}/disk/marker", stripe.vertices.astype(np.float32),
                                                 stripe.faces.astype(np.uint32), color=_MARKER_COLOR,
                                                 scale=_DEFAULT.radius)
        self._scale = _DEFAULT.radius
        self.point_label = self.add_label(f"{root}/ground/point/label", "contact point", position=(0.0, 0.0, 0.0),
                                          anchor="top-left", scale=_LABEL_SCALE)
        gui = self.target.gui
        with self.make_folder():
            legend = Legend(gui, (
                (_DISK_COLOR, "disk (dark stripe: the spin)"),
                (_TRACK_COLOR, "track of the contact point on the ground"),
                (_FORCE_COLOR, "ground's force on the disk, at the contact point"),
            ), "Colours:", presenter=self.presenter)
            self.playback.add_gui()
            readout = self.add_readout("Computing the motion…")
            info = self.add_readout("")
            self.playback.add_preset_buttons()
            with gui.add_folder("Initial state (t = 0)"):
                for spec in SLIDERS[:3]:
                    self.controls.add(spec)
            with gui.add_folder("Disk and contact"):
                self.controls.add(Choice("contact", "Contact", options=CONTACTS, default=_DEFAULT.contact,
                                         hint="Rolling without slip, or sliding on a frictionless ground"))
                for spec in SLIDERS[3:]:
                    self.controls.add(spec)
            with gui.add_folder("Show"):
                self.controls.add(Toggle("follow", "Follow the disk", default=True,
                                         hint="Keep the disk in view: the ground moves under it"))
                self.controls.add(Toggle("show_track", "Track", default=True))
                self.controls.add(Toggle("show_force", "Contact force arrow", default=True))
            with self.plot_area():
                x_scale = {"x": {"time": False}}
                empty = np.zeros(2)
                plot_lean = self.add_plot(
                    (empty, empty),
                    ({"label": "t (s)"}, {"label": "lean θ (deg)", "stroke": "#2266dd", "width": 2}),
                    title="lean θ(t)", scales=x_scale, aspect=1.6,
                )
                plot_energy = self.add_plot(
                    (empty, np.full(2, LOG_FLOOR)),
                    ({"label": "t (s)"}, {"label": "log10 |E − E0| (J)", "stroke": "#b45309", "width": 2}),
                    title="energy drift (log10)", scales=x_scale, aspect=1.6,
                )
                plot_residual = self.add_plot(
                    (empty, np.full(2, LOG_FLOOR), np.full(2, LOG_FLOOR)),
                    ({"label": "t (s)"}, {"label": "log10 max |C| (m)", "stroke": "#be185d", "width": 2},
                     {"label": "log10 max |dC/dt| (m/s)", "stroke": "#7c3aed", "width": 2}),
                    title="constraint residuals (log10)", scales=x_scale, aspect=1.6,
                )
                plot_normal = self.add_plot(
                    (empty, empty, empty),
                    ({"label": "t (s)"}, {"label": "N (N)", "stroke": "#0f766e", "width": 2},
                     {"label": "m g", "stroke": "#888888", "dash": [6, 4]}),
                    title="normal force N (Eq. 8.107)", scales=x_scale, aspect=1.6,
                )
            self.add_download("download_csv", "Download CSV", "rolling_disk.csv", self.csv_bytes,
                              hint="t, position, Euler parameters, lean, E, residuals, normal force of the "
                                   "plotted window")
        self.gui = _Gui(readout, info, legend, plot_lean, plot_energy, plot_residual, plot_normal)

    def on_presenter(self, on: bool) -> None:
        if self.gui is not None:
            self.gui.legend.set_presenter(on)

    # -- read by tests and notebooks --------------------------------------------------
    @property
    def inputs(self) -> Inputs:
        return Inputs.from_values(self.controls.values())

    @property
    def columns(self) -> np.ndarray:
        """(12,) the CSV columns (after t) at the computed sample nearest the clock (NaN before a chunk is drawn)."""
        if self._near is None:
            return np.full(12, math.nan)
        chunk, near = self._near
        return chunk.table.columns[min(near, chunk.table.columns.shape[0] - 1)]

    @property
    def rates(self) -> np.ndarray:
        """(4,) lean rate, spin, heading rate (rad/s) and speed (m/s) at that sample."""
        if self._near is None:
            return np.full(4, math.nan)
        chunk, near = self._near
        return chunk.rates[near]

    @property
    def centre(self) -> np.ndarray:
        """(3,) the disk's centre as drawn (global, m)."""
        return np.array(self._row[_CENTRE])

    @property
    def contact_point(self) -> np.ndarray:
        """(3,) the contact point as drawn (global, m)."""
        return np.array(self._row[_POINT])

    @property
    def track_points(self) -> np.ndarray:
        """(n, 3) the contact point's track drawn (global, m, lifted over the ground), oldest first."""
        return self.track.points

    # -- inputs ------------------------------------------------------------------------
    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            Model.from_inputs(Inputs.from_values(values))
        except ValueError as exc:
            return f"invalid disk parameters: {exc}"
        return None

    def _apply_inputs(self, inputs: Inputs) -> None:
        """Use ``inputs`` (restart), or refuse them with a notice and set the controls back."""
        try:
            model = Model.from_inputs(inputs)
        except ValueError as exc:
            kept = self.model if self.model is not None else Model.from_inputs(_DEFAULT)
            self.notify("Invalid disk parameters", f"{exc}. Keeping the previous values.", "warning")
            self.controls.set_many({"lean_deg": math.degrees(kept.lean), "spin": kept.spin,
                                    "heading_rate": kept.heading_rate, "radius": kept.radius, "mass": kept.mass,
                                    "contact": ROLLING if kept.rolling else SLIDING})
            if self.model is not None:
                return
            model = kept
        if model == self.model:
            return
        resized = model.radius != (self.model.radius if self.model is not None else _DEFAULT.radius)
        self.model = model
        halted = self._halted()
        self._error_reported = False
        if self.gui is not None:
            self.gui.info.content = self._info(model)
        self.timeline.reset(functools.partial(_compute_chunk, model))
        self._restart()
        if halted:  # the motion had stopped itself: the notice promised that a control runs it again
            self.playback.set_playing(True)
        if resized:
            self.reframe()
            # sticks in proportion to the disk (3 cm for 0.1 m): a 3 cm coin's track is then not a polygon
            self.track_head.set_length(_HEAD_STICK * model.radius / _DEFAULT.radius)
            self.track.min_step = _TRACK_MIN_STEP * model.radius / _DEFAULT.radius

    def _halted(self) -> bool:
        """The motion stopped itself (it left the ground, fell flat, or its run failed) and paused the clock
        that was running (not a pause by hand)."""
        return bool(self.ended) or (self._error_reported and self._error_paused)

    def _restart(self) -> None:
        self.sim_time = 0.0
        self.ended = ""
        self._end_reported = ""
        self.track.clear()
        self.track_head.clear()
        self._track_time = -math.inf
        self._since_track = math.inf
        self.history.clear()
        self.plot_history.clear()
        self._drawn = None
        self._refreshed_time = -1.0
        self._refresh.force()

    # -- update --------------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        preset = self.playback.take_preset()
        changed = self.controls.take_changes()
        if preset is not None:
            values = self.controls.values()
            inputs = preset_inputs(preset, radius=float(values["radius"]), mass=float(values["mass"]),
                                   contact=values["contact"])
            self.controls.set_many(dataclasses.asdict(inputs))
            self.playback.set_playing(True)
        if self.model is None or preset is not None or changed & _MODEL_KEYS:
            before = self.model
            self._apply_inputs(self.inputs)
            if preset is not None and self.model is before:  # its values were set already: start it again
                self._restart()
        tick = self.playback.tick(dt)
        if tick.reset:
            ended = self.ended
            self._restart()
            if ended:  # the motion had ended itself: play it again (a failed run would fail again: it waits
                self.playback.set_playing(True)  # for a control)
        step = tick.step
        # ask for the next chunk as soon as the clock enters a chunk (each
        # continues from the one before, so none can be computed further ahead)
        here = self.timeline.chunk_at(self.sim_time, ahead=0.0)
        if here is not None and here.model == self.model and here.final:
            step = min(step, max(0.0, float(here.t[-1]) - self.sim_time))  # the motion ends there
        self.sim_time, chunk, self.waiting = self.timeline.advance(self.sim_time, step)
        if self.timeline.error is not None and not self._error_reported:
            self._error_reported = True
            self._error_paused = self.playback.playing  # (a failure found while paused by hand stays paused)
            self.playback.set_playing(False)
            error = self.timeline.error
            self.notify("Simulation stopped",
                        f"{type(error).__name__}: {error}. The motion stops at t = {self.sim_time:.2f} s; "
                        "change a control to run it again (Reset replays it up to there).", "warning")
        if chunk is None or chunk.model != self.model:
            if self.drawn_model != self.model:
                self.gui.readout.content = "Computing the motion…"  # sent once
            return
        self._draw(chunk, dt)

    def _draw(self, chunk: _Chunk, dt: float) -> None:
        assert self.gui is not None and self.model is not None
        value = self.controls.value
        follow, show_track, show_force = bool(value("follow")), bool(value("show_track")), bool(value("show_force"))
        key = (self.sim_time, chunk.k, follow, show_track, show_force, chunk.model)
        if key == self._drawn:
            due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
            if due is not None:  # paused: the poses are on the page; only a last refresh may be due
                with self.target.atomic():
                    self._refresh_one(due)
            return
        self._drawn = key
        self.energy0 = chunk.energy0
        self.history.add(chunk.k, chunk.table)
        self.plot_history.add(chunk.k, chunk.plots)
        # linear interpolation between the two samples around the clock, on floats (13 numbers)
        times, frames, track, track_start = self._floats_of(chunk)
        t0 = times[0]
        h = times[1] - t0
        x = (self.sim_time - t0) / h if h > 0.0 else 0.0
        j = min(max(int(x), 0), len(times) - 2)
        w = min(max(x - j, 0.0), 1.0)
        row = [a + w * (b - a) for a, b in zip(frames[j], frames[j + 1])]
        self._near = (chunk, j + 1 if w >= 0.5 else j)  # conserved quantities at a computed sample
        self._row = row
        cx, cy, cz, p0, p1, p2, p3, px, py, pz, fx, fy, fz = row
        k = 1.0 / math.sqrt(p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3)  # nlerp
        # the track: every computed contact point the clock has passed (the
        # rest of the chunk before, when the clock crossed into this one)
        previous = self.last_chunk
        sources = (previous, chunk) if previous is not None and previous.k == chunk.k - 1 else (chunk,)
        for source in sources:
            if source is not chunk and source.model != chunk.model:
                continue
            times, _, track, track_start = self._floats_of(source)
            i0 = bisect.bisect_right(times, self._track_time)
            i1 = bisect.bisect_right(times, self.sim_time)
            if i1 > i0:
                for q in track[track_start[i0]:track_start[i1]]:
                    self.track.add(q)
                    self.track_head.add(q)
                self._track_time = times[i1 - 1]
        # the head runs on to the contact point drawn (on the straight piece to the next sample)
        self.track_head.add((px, py, pz + _TRACK_LIFT))
        self._since_track += dt
        send_track = show_track and self.track.pending and self._since_track >= _TRACK_PERIOD
        # a frame that sends the track's newest chunk leaves the next plot or readout to the frame after it
        due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time, hold=send_track)
        self.last_chunk = chunk
        self.drawn_model = chunk.model
        ox, oy = (cx, cy) if follow else (0.0, 0.0)
        radius = chunk.model.radius
        mg = chunk.model.mass * _GRAVITY
        magnitude = math.sqrt(fx * fx + fy * fy + fz * fz)
        length = _ARROW_RADII * radius * magnitude / (magnitude + mg)
        send_length = abs(length - self._arrow_length) > 0.02 * self._arrow_length or (length == 0.0) != (
            self._arrow_length == 0.0)
        with self.target.atomic():
            if radius != self._scale:
                self._scale = radius
                self.disk_mesh.scale = radius
                self.disk_marker.scale = radius
                self.point_mesh.scale = _POINT_RADIUS * radius
                self.resize_arrows(self.force_arrow, **_arrow_sizes(radius))
            set_pose(self.disk, position=(cx - ox, cy - oy, cz), wxyz=(p0 * k, p1 * k, p2 * k, p3 * k))
            set_pose(self.ground, position=(-ox, -oy, 0.0))
            set_pose(self.grid, position=(-math.fmod(ox, _GRID_SECTION), -math.fmod(oy, _GRID_SECTION), 0.0))
            set_pose(self.point, position=(px, py, pz + _TRACK_LIFT))
            if self.track.visible != show_track:
                self.track.visible = show_track
                self.track_head.visible = show_track
            if send_track:
                self.track.flush()  # the newest chunk only
                self._since_track = 0.0
            if show_track:
                self.track_head.draw()  # poses of the new sticks and of the tip
            if self.force_frame.visible != show_force:
                self.force_frame.visible = show_force
            if show_force:
                set_pose(self.force_frame, wxyz=wxyz_z_to((fx, fy, fz), magnitude))
                if send_length:
                    self._arrow_length = length
                    set_array(self.force_arrow, "points", (((0.0, 0.0, 0.0), (0.0, 0.0, length)),))
            if due is not None:
                self._refresh_one(due)
        if chunk.final and self.sim_time >= float(chunk.t[-1]) and self._end_reported != chunk.end:
            self._end_reported = chunk.end
            self.ended = chunk.end
            self.playback.set_playing(False)
            self.notify("Rolling disk stopped", f"{chunk.end[0].upper()}{chunk.end[1:]}. "
                        "Change a control, pick a preset or press Reset.", "warning")
            self._refresh.force()

    def _floats_of(self, chunk: _Chunk) -> tuple[list[float], list[list[float]], list[list[float]], list[int]]:
        """The arrays a frame reads of ``chunk`` as lists of floats (its times, frames, track points and their
        start per sample), made once per chunk: a frame's few numbers cost less as floats than as numpy calls."""
        cached = self._floats.get(chunk.k)
        if cached is None or cached[0] is not chunk:
            cached = (chunk, chunk.t.tolist(), chunk.frames.tolist(), chunk.track.tolist(), chunk.track_start.tolist())
            self._floats = {k: v for k, v in self._floats.items() if abs(k - chunk.k) <= 1}  # (the two drawn)
            self._floats[chunk.k] = cached
        return cached[1:]

    # -- plots, readout, export ----------------------------------------------------------
    def _window_start(self) -> float:
        return max(0.0, self.sim_time - _WINDOW)

    def _refresh_one(self, what: str) -> None:
        assert self.gui is not None
        if what == "window":
            # each refresh cycle starts here: the readout and plots of the
            # cycle (the next frames) show the window as it is now
            self._refreshed_time = self.sim_time
            start = self._window_start()
            self.history.trim(start)
            self._plot_window = self.plot_history.trimmed_window(start, self.sim_time)
            return
        if what == "readout":
            self.gui.readout.content = self._readout()
            return
        t, series = self._plot_window  # formed with the chunks (_Chunk.plots)
        if t.size == 0:
            return
        gui = self.gui
        if what == "lean":
            set_plot_data(gui.plot_lean, (t, series[:, _PLOT_LEAN]))
        elif what == "energy":
            set_plot_data(gui.plot_energy, (t, series[:, _PLOT_ENERGY]))
        elif what == "residual":
            set_plot_data(gui.plot_residual, (t, series[:, _PLOT_RES_P], series[:, _PLOT_RES_V]))
        elif what == "normal" and self.drawn_model is not None:
            mg = np.full_like(t, self.drawn_model.mass * _GRAVITY)
            set_plot_data(gui.plot_normal, (t, series[:, _PLOT_NORMAL], mg))

    def _info(self, model: Model) -> str:
        """The critical upright spin of the model and the initial spin against it."""
        critical = model.critical_spin
        formula = "√(g / (3 R))" if model.rolling else "√(g / R)"
        above = abs(model.spin) > critical
        verdict = ("**above** it: upright motion is stable (a small lean wobbles)" if above else
                   "**below** it: upright motion is unstable (a small lean grows)")
        # rolling, the spin is the rolling speed over R; sliding on frictionless ground, the centre's speed
        # plays no part (it keeps its horizontal velocity whatever the spin)
        where = (f"rolling at R ω = {significant(critical * model.radius, 3)} m/s" if model.rolling else
                 "sliding: the centre's speed plays no part")
        return (f"**Critical upright spin** {formula} = {significant(critical, 3)} rad/s ({where}).  \n"
                f"Initial spin |ω2| = {significant(abs(model.spin), 3)} rad/s = "
                f"{significant(abs(model.spin) / critical, 3)} × critical: {verdict}.")

    def _readout(self) -> str:
        assert self.model is not None
        c = self.columns
        lean_rate, spin, heading_rate, speed = (float(x) for x in self.rates)
        energy = float(c[_ENERGY])
        lines = [
            f"**t** = {self.sim_time:.2f} s · **lean** θ = {math.degrees(float(c[_LEAN])):.2f}° · "
            f"**spin** ω2 = {significant(spin, 3)} rad/s · dψ/dt = {significant(heading_rate, 3)} rad/s · "
            f"speed {significant(speed, 3)} m/s",
            f"**N** = {significant(float(c[_NORMAL]), 4)} N · **E** = {significant(energy, 6)} J, "
            f"E − E0 = {one_digit(energy - self.energy0)} J · **max |C|** "
            f"{_relation(float(c[_RES_P]), _RESIDUAL_FLOOR * self.model.radius)} m, max |dC/dt| "
            f"{_relation(float(c[_RES_V]), _RESIDUAL_FLOOR * max(speed, self.model.radius * abs(spin), 1e-3))} m/s",
        ]
        chunk = self.last_chunk
        if chunk is not None and chunk.model == self.model and chunk.n_rhs:
            lines.append(f"DOP853 rtol {RTOL:.0e}: {chunk.n_steps} steps, {chunk.n_rhs} right sides, "
                         f"{chunk.cpu_seconds / _CHUNK_SIM_TIME:.2f} s CPU per simulated second")
        if self.ended:
            lines.append(f"*Stopped: {self.ended}.*")
        elif self.waiting and self.playing:
            lines.append("*computing the next chunk…*")
        return "  \n".join(lines)

    def csv_bytes(self) -> bytes:
        """The CSV of the motion in the plot window, up to the displayed time."""
        return self.history.csv(CSV_HEADER, self._window_start(), self.sim_time)
