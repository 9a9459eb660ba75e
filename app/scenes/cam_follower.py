"""Cam-follower scene: a disk cam at constant speed drives a spring-loaded translating follower.

The motion is a :class:`app.scenes._simulation.SimulationScene` whose chunk is one revolution (display time is
the physical time; *Slow motion* sets the time scale to one turn per so many wall seconds):

* **Closed form** (default): a periodic motion. Its chunk is the :class:`Revolution`: lift, velocity ``omega s'``,
  acceleration ``omega^2 s''`` and contact force ``N cos(phi) = m omega^2 s'' + k s + F_0 + m g`` (Eqs.
  8.95-8.108 reduced to the follower's axis) of :meth:`core.models.CamFollower.kinematics` and
  :meth:`~core.models.CamFollower.contact_force` at 1440 cam angles, the contact point and common normal of
  :meth:`~core.models.CamFollower.touch_location`, and the separation intervals (N < 0 past
  :meth:`~core.models.CamFollower.jump_speed`) of :meth:`~core.models.CamFollower.separation_intervals`. Chunk k
  is the same table one period later. The sample drawn is on the table's 0.25 deg grid, so the pose and readout
  are the closed form at the angle shown, to the last digit.
* **Compliant contact**: :meth:`core.models.CamFollower.simulate` one revolution per chunk (180 outputs), each
  continuing from the previous one's ``final_state``: the contact constraints (Eqs. 8.90-8.94, kinematic
  analysis: the System has no degree of freedom on the cam), then a Hunt-Crossley contact after a separation,
  integrated by DOP853 at rtol 1e-8 (atol 1e-10): against 1e-8, 1e-6 moved the lift by 12-47 um and the impact
  peaks by 54-175 N, which a plot shows; the cost saved was 20-30 %.

Frames (global, metres): the cam shaft is the global y axis, the profile plane is the x-z plane (profile x ->
global x, profile y -> global z, as in :meth:`CamFollower.build_system`), the follower slides along +z above the
shaft; the cam turns about -y by the cam angle theta (theta = 0: lowest lift).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.controls import Choice, Slider, Toggle
from app.meshes import box, cylinder_z, extrude, helix_tube, pack
from app.nodes import set_array, set_arrays, set_pose, wxyz_z_to
from app.readout import significant
from app.scenes._arrows import vertex_rgb
from app.scenes._plots import Table, format_rows
from app.scenes._simulation import PlotSpec, SimulationScene
from app.scenes.base import PRESENTER_LINE_SCALE
from core import ArgumentError
from core.models import CamFollower, CamProfile, smallest_convex_rise

__all__ = ["CSV_HEADER", "CamFollowerScene", "CamRefused", "FOLLOWERS", "Inputs", "PROFILES", "REVOLUTION_SAMPLES",
           "RUN_SAMPLES", "Revolution", "RunChunk", "build_cam", "compute_chunk", "compute_revolution",
           "run_force_range", "run_plot_angles"]

PROFILES = ("Eccentric circle", "Rise-dwell-return, cycloidal", "Rise-dwell-return, harmonic",
            "Rise-dwell-return, 3-4-5")
_LAWS = {PROFILES[1]: "cycloidal", PROFILES[2]: "harmonic", PROFILES[3]: "345"}
FOLLOWERS = ("Flat-faced", "Roller")
ECCENTRIC_RADIUS, ECCENTRICITY = 0.04, 0.01  # m
BASE_RADIUS, LIFT, DWELL_DEG = 0.04, 0.02, 30.0  # rise-dwell-return cams (m, m, deg)
_RISE_DEG, _ROLLER_MM = (30.0, 150.0), (2.0, 40.0)  # slider ranges
GRAVITY = 9.81  # m/s^2 along the follower axis towards the cam
REVOLUTION_SAMPLES = 1440  # closed-form table: every 0.25 deg
_STEP = 2.0 * math.pi / REVOLUTION_SAMPLES
RUN_SAMPLES = 180  # outputs per revolution of the compliant run
_RUN_RTOL, _RUN_ATOL = 1e-8, 1e-10  # the compliant run's DOP853 (module docstring)
_CONTACT = {"contact_stiffness": 1e8, "contact_damping": 0.5}  # Hunt-Crossley, N/m^1.5 and s/m
_CONTOUR_POINTS = 720
CSV_HEADER = "cam angle (deg),lift (m),velocity (m/s),acceleration (m/s^2),contact force (N)"
# drawing (m): the cam is 12 mm thick; the contact marks lie in front of it (y = _Y_FRONT)
_CAM_THICKNESS, _Y_FRONT, _FOLLOWER_DEPTH, _STEM_RADIUS = 0.012, -0.012, 0.014, 0.004
_COLLAR_RADIUS, _COLLAR_THICKNESS, _ARM_THICKNESS, _BASE_Z, _COLUMN_X = 0.015, 0.003, 0.008, -0.085, -0.095
_SPRING = {"radius": 0.011, "turns": 7}
_SPRING_WIRE, _SPRING_MIN_LENGTH = 0.0011, 0.045
#: the drawn spring is solid (its coils touch, as thick as in presenter view): a run flying higher stops
_SPRING_SOLID = 2.0 * _SPRING["turns"] * _SPRING_WIRE * PRESENTER_LINE_SCALE
_ARROW_MAX, _ARROW_HALF, _NORMAL_HALF = 0.045, 40.0, 0.03  # m, N, m
_CAM_COLOR, _HUB_COLOR, _FOLLOWER_COLOR = (150, 156, 172), (70, 72, 84), (196, 160, 84)
_ROLLER_COLOR, _STAND_COLOR, _SPRING_COLOR = (96, 100, 114), (188, 190, 198), (60, 60, 72)
_FORCE_COLOR, _PULL_COLOR, _NORMAL_COLOR, _POINT_COLOR = (245, 140, 0), (150, 60, 200), (0, 160, 150), (30, 30, 40)


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the controls the motion depends on (field names = control keys)."""

    rpm: float = 800.0
    mass: float = 0.5  # kg
    stiffness: float = 2000.0  # N/m
    preload: float = 20.0  # N at zero lift
    profile: str = PROFILES[0]
    follower: str = FOLLOWERS[0]
    rise_deg: float = 90.0  # rise = fall (deg)
    roller_mm: float = 10.0
    compliant: bool = False

    @property
    def speed(self) -> float:
        """Cam speed omega (rad/s)."""
        return self.rpm * math.pi / 30.0

    def geometry_key(self) -> tuple:
        law, roller = _LAWS.get(self.profile), self.follower == FOLLOWERS[1]
        return (law, "roller" if roller else "flat", self.rise_deg if law else None, self.roller_mm if roller else None)

    def model_key(self) -> tuple:
        return (*self.geometry_key(), self.mass, self.stiffness, self.preload)


class CamRefused(ValueError):
    """Core refused the cam of the panel's values (the message in the panel's terms)."""


def build_cam(inputs: Inputs) -> CamFollower:
    """The :class:`core.models.CamFollower` of ``inputs``; :class:`CamRefused` in the panel's terms (rise = fall
    in degrees, roller in mm) with the value that works, from core's ``ArgumentError.argument``."""
    key = inputs.model_key()
    try:
        return _cam(key)
    except ArgumentError as exc:
        law, kind, rise, roller, *rest = key
        if exc.argument == "roller_radius" and law:
            largest = _cam((law, kind, rise, 1.0, *rest)).largest_roller_radius() if rise else 0.0
            if largest * 1000.0 >= _ROLLER_MM[0]:
                raise CamRefused(f"Roller radius: a {roller:g} mm roller would undercut this cam (rise = fall = "
                                 f"{rise:g}°; the roller centre's path curves more sharply than the roller); use a "
                                 f"roller of at most {math.floor(largest * 2000.0) / 2.0:g} mm or a longer rise") from exc
        if exc.argument == "base_radius" and law:
            fits = math.ceil(math.degrees(smallest_convex_rise(BASE_RADIUS, LIFT, math.radians(DWELL_DEG), law)))
            advice = f"a rise of at least {fits}° or " if fits <= _RISE_DEG[1] else ""
            raise CamRefused(f"Flat-faced follower: at rise = fall = {rise:g}° the cam would not be convex (its radius "
                             f"of curvature R_b + s + s″ turns negative, and a flat face would bridge the hollow); use "
                             f"{advice}the roller follower") from exc
        raise CamRefused(str(exc)) from exc


@functools.lru_cache(maxsize=256)
def _cam(key: tuple) -> CamFollower:
    law, kind, rise_deg, roller_mm, mass, stiffness, preload = key
    profile = (CamProfile.eccentric(radius=ECCENTRIC_RADIUS, eccentricity=ECCENTRICITY) if law is None else
               CamProfile.rise_dwell_return(base_radius=BASE_RADIUS, lift=LIFT, rise=math.radians(rise_deg),
                                            dwell=math.radians(DWELL_DEG), fall=math.radians(rise_deg), law=law))
    return CamFollower(profile, follower=kind, roller_radius=roller_mm / 1000.0 if roller_mm else 0.0, mass=mass,
                       stiffness=stiffness, preload=preload, gravity=GRAVITY)


@dataclasses.dataclass(frozen=True)
class Geometry:
    """Meshes ``(vertices, faces)`` of a cam shape and follower: the cam in its body frame (profile = body x-y),
    the follower parts in the follower's frame (origin at the face or the roller's centre), the stand global."""

    key: tuple
    cam_mesh: tuple
    follower_mesh: tuple
    roller_mesh: tuple | None
    stand_mesh: tuple
    contour: np.ndarray  # (_CONTOUR_POINTS, 2) the cam's contour (body frame, m)
    pitch_height: float  # m: global z of the follower's origin at zero lift
    spring_seat: float  # m above the follower's origin
    spring_top: float  # m, global z
    label_follower: float  # m, global z


@functools.lru_cache(maxsize=32)
def _geometry(key: tuple) -> Geometry:
    law, kind, rise_deg, roller_mm = key
    cam = _cam((*key, 0.5, 2000.0, 20.0))
    u = np.arange(_CONTOUR_POINTS) * (2.0 * math.pi / _CONTOUR_POINTS)
    contour, kin = np.array(cam.cam_curve(u).point), cam.kinematics(u)
    pitch_height = float(cam.pitch_curve(0.0).point[1])
    if kind == "flat":  # the face reaches past the farthest contact point, |s'| from the axis
        w = float(np.max(np.abs(kin.dlift))) + 0.008
        lower, stem_start, roller_mesh = [box((-w, -_FOLLOWER_DEPTH / 2, 0.0), (w, _FOLLOWER_DEPTH / 2, 0.004))], 0.004, None
    else:
        r = roller_mm / 1000.0
        parts = [trimesh.creation.cylinder(radius=r, height=0.010, sections=64),
                 trimesh.creation.cylinder(radius=min(0.0025, 0.5 * r), height=0.016, sections=16)]
        for part in parts:
            part.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1.0, 0.0, 0.0)))
        roller_mesh, stem_start = pack(trimesh.util.concatenate(parts)), r + 0.004
        lower = [box((-0.004, y0, -0.002), (0.004, y1, stem_start)) for y0, y1 in ((-0.0075, -0.0055), (0.0055, 0.0075))]
        lower.append(box((-0.006, -0.0075, stem_start - 0.003), (0.006, 0.0075, stem_start)))
    seat = stem_start + 0.03
    spring_top = pitch_height + float(np.max(kin.lift)) + seat + _COLLAR_THICKNESS + _SPRING_MIN_LENGTH
    stem_top, arm_top = spring_top - pitch_height + _ARM_THICKNESS + 0.015, spring_top + _ARM_THICKNESS
    follower = trimesh.util.concatenate(lower + [cylinder_z(_STEM_RADIUS, stem_start, stem_top),
                                                 cylinder_z(_COLLAR_RADIUS, seat, seat + _COLLAR_THICKNESS, 40)])
    hub = trimesh.creation.cylinder(radius=0.013, segment=np.array([[0.0, 0.009, 0.0], [0.0, 0.03, 0.0]]), sections=40)
    stand = trimesh.util.concatenate([  # base plate, bearing pedestal, hub, column, the arm guiding the stem
        box((-0.12, -0.04, _BASE_Z - 0.008), (0.09, 0.045, _BASE_Z)), box((-0.012, 0.012, _BASE_Z), (0.012, 0.03, 0.0)),
        hub, box((_COLUMN_X - 0.007, 0.015, _BASE_Z), (_COLUMN_X + 0.007, 0.03, arm_top)),
        box((_COLUMN_X - 0.007, -0.012, spring_top), (0.02, 0.03, arm_top))])
    return Geometry(key, pack(extrude(contour, -_CAM_THICKNESS / 2, _CAM_THICKNESS / 2)), pack(follower),
                    roller_mesh, pack(stand), contour.astype(np.float32), pitch_height, seat + _COLLAR_THICKNESS,
                    spring_top, pitch_height + stem_top)


@dataclasses.dataclass(frozen=True)
class Revolution:
    """Chunk ``k`` of the closed-form motion: one revolution at constant speed, rows ``i = 0 .. n`` at cam angles
    ``i 2 pi / n`` (n = :data:`REVOLUTION_SAMPLES`), times ``t = (k + i / n) T``; points and normals global x-z."""

    k: int
    t: np.ndarray  # (n + 1,) s
    table: Table  # t; the plotted columns
    inputs: Inputs  # (compliant False: the closed form's inputs)
    speed: float  # rad/s
    jump_speed: float  # rad/s
    lift: np.ndarray  # (n + 1,) m
    velocity: np.ndarray  # (n + 1,) m/s
    acceleration: np.ndarray  # (n + 1,) m/s^2
    force: np.ndarray  # (n + 1,) N, > 0 pressing
    force_at_jump: np.ndarray  # (n + 1,) N at the jump speed
    contact: np.ndarray  # (n + 1, 2) m
    normal: np.ndarray  # (n + 1, 2)
    follower_z: np.ndarray  # (n + 1,) m
    separations: tuple  # cam-angle intervals (rad) where N < 0
    separation_segments: np.ndarray | None  # (720, 2, 3) the intervals on the cam's contour (body frame)
    min_force: tuple[float, float]  # (N, rad)
    geometry: Geometry

    @property
    def revolution(self) -> Revolution:
        return self

    @staticmethod
    def angle(i: int) -> float:
        return i * _STEP

    def later(self, k: int) -> Revolution:
        """Chunk ``k``: the same revolution ``k - self.k`` periods later."""
        t = self.t + (k - self.k) * 2.0 * math.pi / self.speed
        return dataclasses.replace(self, k=k, t=t, table=Table.build(t, self.table.columns))

    def csv(self) -> bytes:
        """:data:`CSV_HEADER`, then one row per 0.25 deg (15 significant digits)."""
        n = REVOLUTION_SAMPLES
        rows = format_rows(np.arange(n) * (360.0 / n),
                           np.column_stack([self.lift, self.velocity, self.acceleration, self.force])[:n])
        return ("\n".join((CSV_HEADER, *rows)) + "\n").encode()


@functools.lru_cache(maxsize=8)
def compute_revolution(inputs: Inputs) -> Revolution:
    """Chunk 0 of the closed form of ``inputs`` (on the executor); :class:`CamRefused` for a cam core refuses."""
    inputs = dataclasses.replace(inputs, compliant=False)
    rev = build_cam(inputs).revolution(inputs.speed, samples=REVOLUTION_SAMPLES)
    geometry = _geometry(inputs.geometry_key())
    arrays = [rev.lift, rev.velocity, rev.acceleration, rev.contact_force, rev.force_at_jump, rev.contact_point,
              rev.contact_normal, geometry.pitch_height + rev.lift]
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise CamRefused("the closed form gave a non-finite value; choose other parameters")
    t = rev.theta / rev.speed
    columns = np.column_stack([np.degrees(rev.theta), 1000.0 * rev.lift, *arrays[1:5]])
    return Revolution(0, t, Table.build(t, columns), inputs, rev.speed, rev.jump_speed, *arrays, rev.separations,
                      _separation_segments(geometry.contour, rev.separations), rev.min_force, geometry)


def closed_form_chunk(inputs: Inputs, k: int, previous: Revolution | None) -> Revolution:
    """Chunk ``k`` of the closed form: the revolution of ``inputs``, ``k`` periods on (the motion is periodic)."""
    revolution = previous or compute_revolution(inputs)
    return revolution if revolution.k == k else revolution.later(k)


@dataclasses.dataclass(frozen=True)
class RunChunk:
    """Revolution ``k`` of the compliant run, outputs ``t = k T + j T / RUN_SAMPLES`` (points global x-z)."""

    k: int
    t: np.ndarray  # (n,) s
    table: Table  # t; cam angle in the revolution (deg), cam lift and lift (mm), closed-form and run force (N)
    revolution: Revolution | None  # the closed form (revolution 0 only)
    theta: np.ndarray  # (n,) rad
    follower_z: np.ndarray  # (n,) m
    lift: np.ndarray  # (n,) m
    cam_lift: np.ndarray  # (n,) m, the closed-form lift under the follower
    force: np.ndarray  # (n,) N
    closed_force: np.ndarray  # (n,) N
    point: np.ndarray  # (n, 2) m
    normal: np.ndarray  # (n, 2)
    gap: np.ndarray  # (n,) m
    constraint: np.ndarray  # (n,) bool
    separations: np.ndarray  # (m,) s: separations and gap openings
    landings: np.ndarray  # (m,) s: gap closings
    final_state: Any  # core's RunState to continue from
    periodic: bool  # core's CamMotion.periodic: the next revolution repeats this one

    @property
    def t0(self) -> float:
        return float(self.t[0])

    @property
    def h(self) -> float:
        return float(self.t[1] - self.t[0])


def compute_chunk(inputs: Inputs, k: int, previous: RunChunk | None) -> RunChunk:
    """Revolution ``k`` of the compliant run of ``inputs`` (on the executor): :meth:`CamFollower.simulate`
    continuing from ``previous.final_state`` (revolution ``k - 1``). A revolution that stayed on the cam repeats
    (the System has no degree of freedom there): the next is the same one a period later."""
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: revolution {k} continues from revolution {k - 1}, which was not given")
    w = inputs.speed
    period = 2.0 * math.pi / w
    if previous is not None and previous.periodic:
        t = previous.t + period
        return dataclasses.replace(previous, k=k, t=t, theta=w * t, revolution=None,
                                   table=Table.build(t, previous.table.columns))
    cam = build_cam(inputs)
    times = (k + np.arange(RUN_SAMPLES + 1) / RUN_SAMPLES) * period
    run = cam.simulate(w, times, model="constraint", on_separation="compliant", rtol=_RUN_RTOL, atol=_RUN_ATOL,
                       initial=None if previous is None else previous.final_state, **_CONTACT)
    for name in ("lift", "contact_force", "contact_point", "gap"):
        if not np.all(np.isfinite(getattr(run, name))):
            raise ValueError(f"{name}: the run left the finite range in revolution {k + 1}")
    theta, force = run.cam_angle, run.contact_force
    cam_lift, closed = cam.kinematics(theta).lift, np.asarray(cam.contact_force(theta, w))
    table = Table.build(run.t, np.column_stack([np.round(np.degrees(theta) - 360.0 * k, 9), 1000.0 * cam_lift,
                                                1000.0 * run.lift, closed, force]))
    return RunChunk(k, run.t, table, compute_revolution(inputs) if k == 0 else None, theta,
                    run.lift + _geometry(inputs.geometry_key()).pitch_height, run.lift, cam_lift, force, closed,
                    run.contact_point[:, [0, 2]], run.contact_normal[:, [0, 2]], run.gap, run.constraint,
                    run.separations[:, 0], run.landings[:, 0], run.final_state, run.periodic)


def run_plot_angles(chunk: RunChunk) -> np.ndarray:
    """The run plots' x: the cam angle in the revolution (deg), rounded to 1e-9 deg (uPlot drops the 0 tick
    for 5.7e-14)."""
    return chunk.table.columns[:, 0]


def run_force_range(chunk: RunChunk) -> tuple[tuple[float, float], float | None]:
    """The run force plot's y range (N) and the off-scale peak (N) or None (:func:`_force_range`)."""
    return _force_range(chunk.closed_force, chunk.force)


def _force_range(closed: np.ndarray, force: np.ndarray) -> tuple[tuple[float, float], float | None]:
    """Zero, the closed form and the run's force up to twice the closed form's span above its top (a landing's
    impact reaches kilonewtons against tens of newtons), with 5 % margins."""
    lo, top = min(float(closed.min()), float(force.min()), 0.0), max(float(closed.max()), 0.0)
    cap = top + 2.0 * max(top - min(float(closed.min()), 0.0), 1.0)
    peak = float(force.max())
    hi = max(top, min(peak, cap))
    pad = 0.05 * max(hi - lo, 1.0)
    return (lo - pad, hi + pad), (peak if peak > cap else None)


def _separation_segments(contour: np.ndarray, intervals: tuple) -> np.ndarray | None:
    """(n, 2, 3) segments of the contour over the separation intervals on the cam's front face (body frame; unused
    ones repeat the first), or None."""
    n = contour.shape[0]
    u = np.arange(n) * (2.0 * math.pi / n)
    mask = np.zeros(n, dtype=bool)
    for a, b in intervals:
        mask |= ((u - a) % (2.0 * math.pi)) <= (b - a)
    if not np.any(mask):
        return None
    pts = np.column_stack([contour, np.full(n, _CAM_THICKNESS / 2 + 0.0006)]).astype(np.float32)
    seg = np.stack([pts, np.roll(pts, -1, axis=0)], axis=1)
    used = seg[mask & np.roll(mask, -1)] if np.any(mask & np.roll(mask, -1)) else seg[mask]
    out = np.repeat(used[:1], n, axis=0)
    out[: used.shape[0]] = used
    return out


def _deg(theta: float) -> float:
    return math.degrees(theta % (2.0 * math.pi))


def _newtons(x: float) -> str:
    return f"{x / 1000.0:.1f} kN" if abs(x) >= 1000.0 else f"{x:.0f} N"


_SHADE = {"label": "N < 0", "stroke": "rgba(150, 60, 200, 0)", "fill": "rgba(150, 60, 200, 0.3)", "width": 1}
_CLOSED_PLOTS = {  # name: (title, series after x, column of the table (y), scale)
    "lift": ("lift s (mm)", ({"label": "s (mm)", "stroke": "#2266dd", "width": 2}, _SHADE), 1),
    "velocity": ("velocity ω s′ (m/s)", ({"label": "v (m/s)", "stroke": "#0f766e", "width": 2}, _SHADE), 2),
    "acceleration": ("acceleration ω² s″ (m/s²)", ({"label": "a (m/s²)", "stroke": "#c2410c", "width": 2}, _SHADE), 3),
    "force": ("contact force N (N)", ({"label": "N (N)", "stroke": "#d97706", "width": 2},
                                      {"label": "N = 0", "stroke": "#555555", "dash": [6, 4], "width": 1},
                                      {"label": "N at jump speed", "stroke": "#888888", "dash": [3, 3], "width": 1},
                                      _SHADE), 4),
}
_RUN_FORCE_LABEL = "System (N)"


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
    chunks_kept = 4
    refresh_period = 0.2
    csv_header = CSV_HEADER

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.revolution: Revolution | None = None  # the closed form in use
        self.revision, self.drawn_revision = 0, -1  # revolutions swapped in; the one drawn last
        self.geometry = _geometry(Inputs().geometry_key())
        self.run_chunk: RunChunk | None = None
        self.cam_angle = self.force = self.follower_z = 0.0  # drawn: rad, N, m
        self.index = 0  # closed-form table row drawn
        self._pending: list[str] = []  # meshes, info, marks, closed-form plots: one per frame
        self._angle: float | None = None  # a loaded cam angle (rad), applied at the next frame
        self._arrow_sent, self._thrown, self._reconfigure = (0.0, True), False, False

    compliant = property(lambda self: bool(self.config is not None and self.config.compliant))

    def job(self, inputs: Inputs, segment: Any) -> Any:
        return functools.partial(compute_chunk if inputs.compliant else closed_form_chunk, inputs)

    # -- nodes and controls ------------------------------------------------------------------
    def build_nodes(self) -> None:
        scene, root, flat = self.target.scene, self.root, self.geometry
        roller = _geometry(Inputs(follower=FOLLOWERS[1]).geometry_key())
        self.add_ground_grid(width=0.6, height=0.4, position=(0.0, 0.0, _BASE_Z - 0.0081), cell_size=0.01,
                             section_size=0.05)
        self.stand = scene.add_mesh_simple(f"{root}/stand", *flat.stand_mesh, color=_STAND_COLOR)
        scene.add_frame(f"{root}/cam_plane", show_axes=False, wxyz=(math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0))
        self.cam_frame = scene.add_frame(f"{root}/cam_plane/cam", show_axes=False)
        self.cam_mesh = scene.add_mesh_simple(f"{root}/cam_plane/cam/body", *flat.cam_mesh, color=_CAM_COLOR)
        hub = trimesh.util.concatenate([cylinder_z(0.006, -0.022, _CAM_THICKNESS / 2 + 0.004),  # shaft, index stripe
                                        box((-0.0015, 0.008, _CAM_THICKNESS / 2), (0.0015, 0.028, 0.0068))])
        scene.add_mesh_simple(f"{root}/cam_plane/cam/hub", *pack(hub), color=_HUB_COLOR)
        n = _CONTOUR_POINTS
        self.separation_arc = self.add_lines(f"{root}/cam_plane/cam/separation", np.zeros((n, 2, 3), np.float32),
                                             np.full((n, 2, 3), _PULL_COLOR, np.uint8), thickness=5.0,
                                             thickness_units="screen", visible=False)
        self.follower_frame = scene.add_frame(f"{root}/follower", show_axes=False, position=(0, 0, flat.pitch_height))
        self.follower_meshes = {
            "flat": scene.add_mesh_simple(f"{root}/follower/flat", *flat.follower_mesh, color=_FOLLOWER_COLOR),
            "roller": scene.add_mesh_simple(f"{root}/follower/fork", *roller.follower_mesh, color=_FOLLOWER_COLOR,
                                            visible=False)}
        self.roller_mesh = scene.add_mesh_simple(f"{root}/follower/roller", *roller.roller_mesh, color=_ROLLER_COLOR,
                                                 visible=False)
        # one wire mesh, moved and stretched along z every frame (a position and a scale)
        self._spring_reference = self._spring_length(flat)
        self.spring = scene.add_batched_meshes_simple(
            f"{root}/spring", *helix_tube(self._spring_reference, self.spring_wire_radius, **_SPRING),
            batched_wxyzs=np.array([[1.0, 0.0, 0.0, 0.0]]), batched_positions=np.zeros((1, 3)),
            batched_scales=np.ones((1, 3)), batched_colors=_SPRING_COLOR, lod="off", side="double")
        self.contact_frame = scene.add_frame(f"{root}/contact", show_axes=False)
        # at the contact point, +z along the common normal: one pose moves the dot, the normal and the arrow
        self.contact_point = scene.add_frame(f"{root}/contact/point", show_axes=False)
        scene.add_icosphere(f"{root}/contact/point/dot", radius=0.0026, color=_POINT_COLOR, subdivisions=2)
        self.normal_line = self.add_lines(f"{root}/contact/point/normal",
                                          np.array([[(0, 0, -_NORMAL_HALF), (0, 0, _NORMAL_HALF)]], np.float32),
                                          np.full((1, 2, 3), _NORMAL_COLOR, np.uint8), thickness=2.5,
                                          thickness_units="screen")
        self.arrow = self.add_arrows(f"{root}/contact/point/force", np.zeros((1, 2, 3), np.float32),
                                     vertex_rgb([_FORCE_COLOR]), shaft_radius=0.0016, head_radius=0.004,
                                     head_length=0.008)
        self.force_label = self.add_label(f"{root}/contact/label", "N", anchor="top-right", scale=1.3)
        self.labels = {
            "cam": self.add_label(f"{root}/label_cam", "cam (turns at ω)", position=(-0.048, _Y_FRONT, -0.03),
                                  anchor="center-right", scale=1.3),
            "follower": self.add_label(f"{root}/label_follower", "follower", anchor="center-left", scale=1.3,
                                       position=(0.008, _Y_FRONT, flat.label_follower - 0.004)),
            "spring": self.add_label(f"{root}/label_spring", "spring k, F0", anchor="center-left", scale=1.3,
                                     position=(0.016, _Y_FRONT, flat.spring_top - 0.02))}

    def build_controls(self) -> None:
        d = Inputs()
        self.legend = self.add_legend((
            (_FORCE_COLOR, "N n: force of the cam on the follower (N > 0)"),
            (_PULL_COLOR, "N < 0: the contact would have to pull (separation interval)"),
            (_NORMAL_COLOR, "common normal at the contact point (hidden in flight)"),
            (_POINT_COLOR, "contact point (in flight: the cam's point nearest the follower)"),
        ), "Drawn on the cam (arrow length saturates):")
        self.status = self.add_readout("Computing the cam…")
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
            add(Slider("rise_deg", "Rise = fall (deg)", min=_RISE_DEG[0], max=_RISE_DEG[1], step=1.0,
                       default=d.rise_deg, hint="Cam angle of the rise and of the fall (rise-dwell-return cams)"),
                disabled=True)
            add(Slider("roller_mm", "Roller radius (mm)", min=_ROLLER_MM[0], max=_ROLLER_MM[1], step=0.5,
                       default=d.roller_mm, hint="Radius of the roller (roller follower)"), disabled=True)
        with self.target.gui.add_folder("Motion"):
            add(Toggle("animate", "Turn the cam", default=True))
            add(Slider("turn_seconds", "Slow motion (s per turn)", min=0.5, max=20.0, step=0.5, default=5.0,
                       hint="Wall-clock seconds the cam takes for one turn"))
            add(Toggle("compliant", "Compliant contact (the follower can jump)", default=False,
                       hint="Run the multibody System: constraints, then a Hunt-Crossley contact after a separation"))
            add(Toggle("show_contact", "Contact point, normal, force", default=True))
        with self.plot_area():
            self.closed_plots = {name: self.add_plot((np.zeros(2),) * (len(series) + 1),
                                                     ({"label": "θ (deg)"}, *series), title=title,
                                                     scales={"x": {"time": False}}, aspect=1.7)
                                 for name, (title, series, _) in _CLOSED_PLOTS.items()}

    def plots(self) -> list[PlotSpec]:
        angle, compliant = (lambda t, c: c[:, 0]), (lambda inputs: inputs.compliant)
        return [PlotSpec("run_lift", "compliant run: lift (mm)", (("cam under it (mm)", "#2266dd"),
                         ("follower (mm)", "#9633c8")), lambda t, c: (c[:, 1], c[:, 2]), compliant, "θ (deg)", 1.7,
                         x=angle, per_chunk=True),
                PlotSpec("run_force", "compliant run: force N (N)", (("closed form (N)", "#888888"),
                         (_RUN_FORCE_LABEL, "#d97706")), lambda t, c: (c[:, 3], c[:, 4]), compliant, "θ (deg)", 1.7,
                         x=angle, per_chunk=True)]

    @property
    def gui(self) -> SimpleNamespace:
        run = {name: self.plot_handles[name] for name in ("run_lift", "run_force")}
        return SimpleNamespace(readout=self.status, info=self.info, legend=self.legend, plots=self.closed_plots,
                               run_plots=run)

    def set_plot_data(self, handle: Any, data: tuple) -> None:
        if handle is self.plot_handles.get("run_force"):  # scaled to the closed form; an impact peak is named
            (lo, hi), peak = _force_range(data[1], data[2])
            handle.scales = {"x": {"time": False}, "y": {"auto": False, "range": [lo, hi]}}
            label = _RUN_FORCE_LABEL + ("" if peak is None else f", peak {_newtons(peak)} off scale")
            if handle.series[2]["label"] != label:
                handle.series = (*handle.series[:2], {**handle.series[2], "label": label})
        super().set_plot_data(handle, data)

    def on_presenter(self, on: bool) -> None:
        super().on_presenter(on)
        self._send_spring_mesh()

    @property
    def spring_wire_radius(self) -> float:
        """Radius of the drawn spring's wire (m): twice as thick in presenter view."""
        return _SPRING_WIRE * (PRESENTER_LINE_SCALE if self.presenter else 1.0)

    def _travel_limit(self) -> float:
        """The largest lift (m) the stand allows: the drawn spring is solid there."""
        g = self.geometry
        return g.spring_top - g.pitch_height - g.spring_seat - _SPRING_SOLID

    @staticmethod
    def _spring_length(g: Geometry) -> float:  # the spring's length (m) in the middle of its travel
        return 0.5 * (g.spring_top - g.pitch_height - g.spring_seat + _SPRING_MIN_LENGTH)

    def _send_spring_mesh(self) -> None:
        self._spring_reference = self._spring_length(self.geometry)
        vertices, faces = helix_tube(self._spring_reference, self.spring_wire_radius, **_SPRING)
        set_arrays(self.spring, vertices=vertices, faces=faces)

    # -- state, refusals ------------------------------------------------------------------------
    def extra_state(self) -> dict[str, Any]:
        """The cam angle shown (deg), so a paused scene is reproduced at its angle."""
        return {"cam_angle_deg": round(math.degrees(self.cam_angle), 9)}

    def load_extra_state(self, extra: dict[str, Any]) -> list[str]:
        refused = []
        for key, value in extra.items():
            if key != "cam_angle_deg":
                refused.append(f"{key!r}: not part of this scene's state")
            elif (isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value)
                  or not 0.0 <= value <= 360.0):
                refused.append(f"cam_angle_deg: expected a number from 0 to 360, got {value!r}")
            else:
                self._angle = math.radians(float(value))
        return refused

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            build_cam(Inputs(**{f.name: values[f.name] for f in dataclasses.fields(Inputs)}))
        except ValueError as exc:
            return f"cam refused: {exc}"
        return None

    def on_error(self, error: BaseException) -> bool:
        if isinstance(error, CamRefused):  # the values in use again
            kept = dataclasses.asdict(self.revolution.inputs if self.revolution is not None else Inputs())
            self.notify("Cam refused", f"{error}. Keeping the values in use (the controls are set back).", "warning")
            self.controls.set_many({k: v for k, v in kept.items() if k != "compliant"})
            self._reconfigure = True
            return True
        if self.compliant:
            self._stop_run(f"{error}. Showing the closed form again; turn the compliant contact on to try again.")
            return True
        return False

    def _stop_run(self, text: str) -> None:
        self._thrown = True
        self.notify("Compliant run stopped", text, "warning")
        self.controls.set("compliant", False)
        self._reconfigure = True

    # -- the clock --------------------------------------------------------------------------------
    def on_configure(self, inputs: Inputs) -> None:
        self.timeline.chunk_time = self.window = 2.0 * math.pi / inputs.speed  # a chunk (and the history) is a turn
        self.run_chunk, self._thrown = None, False
        self._pending.append("info")  # (its advice follows the toggle)

    def update(self, dt: float) -> None:
        super().update(min(max(dt, 0.0), 0.1))  # a stalled loop advances the cam by at most 0.1 s of wall time

    def on_frame(self, changed: set[str]) -> None:
        if self._reconfigure:  # the scene set controls back (a refused cam, a stopped run)
            self._reconfigure = False
            self.configure(self.inputs)
        self.playback.set_playing(bool(self.controls.value("animate")))
        self.playback.set_time_scale(self.timeline.chunk_time / float(self.controls.value("turn_seconds")))
        if self._angle is not None and not self.compliant:  # a loaded angle, on the table's grid
            i = round((self._angle % (2.0 * math.pi)) / _STEP) % REVOLUTION_SAMPLES
            self.local_time = self.sim_time = i * self.timeline.chunk_time / REVOLUTION_SAMPLES
            self._angle, self._drawn = None, None
        if bool(self.controls.value("show_contact")) != self.contact_frame.visible:  # (a click or a loaded state)
            self._drawn = None
        if self._pending:
            with self.target.atomic():
                self._refresh_pending(self._pending.pop(0))

    def _use(self, rev: Revolution) -> None:
        """Draw ``rev`` from now on: its meshes, info, marks and plots (one per frame)."""
        self.revolution, self.revision = rev, self.revision + 1
        if rev.geometry.key != self.geometry.key:
            self.geometry = rev.geometry
            self._pending.append("meshes")
        self._pending += ["info", "marks", *self.closed_plots]
        self.controls.handles["rise_deg"].disabled = rev.inputs.profile == PROFILES[0]
        self.controls.handles["roller_mm"].disabled = rev.inputs.follower != FOLLOWERS[1]

    def _refresh_pending(self, what: str) -> None:
        rev, g = self.revolution, self.geometry
        if what == "meshes":
            self._send_spring_mesh()
            set_arrays(self.cam_mesh, vertices=g.cam_mesh[0], faces=g.cam_mesh[1])
            set_arrays(self.stand, vertices=g.stand_mesh[0], faces=g.stand_mesh[1])
            kind = "flat" if g.roller_mesh is None else "roller"
            set_arrays(self.follower_meshes[kind], vertices=g.follower_mesh[0], faces=g.follower_mesh[1])
            for name, handle in self.follower_meshes.items():
                handle.visible = name == kind
            if g.roller_mesh is not None:
                set_arrays(self.roller_mesh, vertices=g.roller_mesh[0], faces=g.roller_mesh[1])
            self.roller_mesh.visible = g.roller_mesh is not None
            set_pose(self.labels["follower"], position=(0.008, _Y_FRONT, g.label_follower - 0.004))
            set_pose(self.labels["spring"], position=(0.016, _Y_FRONT, g.spring_top - 0.02))
        elif rev is None:
            return
        elif what == "info":
            self.info.content = self._info(rev)
        elif what == "marks":
            if rev.separation_segments is not None:
                set_array(self.separation_arc, "points", rev.separation_segments)
            self.separation_arc.visible = rev.separation_segments is not None
        else:
            c = rev.table.columns[::2]  # every 0.5 deg
            y = c[:, _CLOSED_PLOTS[what][2]]
            shade = np.minimum(c[:, 4], 0.0) if what == "force" else np.where(c[:, 4] < 0.0, y, 0.0)
            extra = (np.zeros_like(y), c[:, 5]) if what == "force" else ()
            self.closed_plots[what].data = (c[:, 0], y, *extra, shade)

    # -- drawing -----------------------------------------------------------------------------------
    def draw(self, chunk: Revolution | RunChunk, j: int) -> None:
        rev = chunk.revolution
        if rev is not None and (self.revolution is None or rev.inputs != self.revolution.inputs):
            self._use(rev)
        self.drawn_revision = self.revision
        show = bool(self.controls.value("show_contact"))
        if isinstance(chunk, Revolution):
            i = j % REVOLUTION_SAMPLES
            self.index, self.cam_angle = i, Revolution.angle(i)
            self.force, self.follower_z = float(chunk.force[i]), float(chunk.follower_z[i])
            self._pose(chunk.contact[i], chunk.normal[i], show, in_contact=True)
            return
        self.run_chunk = chunk
        k = min(j, chunk.t.size - 2)
        w = min(max((self.sim_time - chunk.t[k]) / (chunk.t[k + 1] - chunk.t[k]), 0.0), 1.0)

        def lerp(a: np.ndarray) -> Any:
            return a[k] + w * (a[k + 1] - a[k])

        if lerp(chunk.lift) > self._travel_limit():
            if not self._thrown:
                i = self.config
                spring = (f"the spring (k = {i.stiffness:g} N/m, F0 = {i.preload:g} N)" if i.stiffness or i.preload
                          else "gravity alone (k = 0, F0 = 0)")
                self._stop_run(f"The follower flew to the end of its travel, {1000.0 * self._travel_limit():.0f} mm "
                               "above its lowest position (its spring would be solid there, and this model has no "
                               f"stop): at {i.rpm:g} rpm {spring} cannot keep it near the cam. Raise the stiffness "
                               "or the preload, or lower the cam speed. Showing the closed form again.")
            return
        self.cam_angle = (self.revolution.speed * self.sim_time) % (2.0 * math.pi)
        self.follower_z, self.force = float(lerp(chunk.follower_z)), float(lerp(chunk.force))
        normal = lerp(chunk.normal)
        near = k + 1 if w >= 0.5 else k
        flight = not chunk.constraint[near] and lerp(chunk.gap) > 0.0
        self._pose(lerp(chunk.point), normal / (np.hypot(*normal) or 1.0), show, in_contact=not flight)

    def _pose(self, contact: np.ndarray, normal: np.ndarray, show: bool, *, in_contact: bool) -> None:
        g, theta, force = self.geometry, self.cam_angle, self.force
        set_pose(self.cam_frame, wxyz=(math.cos(0.5 * theta), 0.0, 0.0, math.sin(0.5 * theta)))
        set_pose(self.follower_frame, position=(0.0, 0.0, self.follower_z))
        z0 = self.follower_z + g.spring_seat
        set_arrays(self.spring, batched_positions=((0.0, 0.0, z0),),
                   batched_scales=((1.0, 1.0, (g.spring_top - z0) / self._spring_reference),))
        self.contact_frame.visible = show
        if not show:
            return
        (x, z), (nx, nz) = (float(v) for v in contact), (float(v) for v in normal)
        set_pose(self.contact_point, position=(x, _Y_FRONT, z), wxyz=wxyz_z_to((nx, 0.0, nz), 1.0))
        if self.normal_line.visible != in_contact:  # in flight there is no contact normal
            self.normal_line.visible = in_contact
        drawn = in_contact and force != 0.0
        self.arrow.visible = self.force_label.visible = drawn
        if drawn:
            length = _ARROW_MAX * abs(force) / (abs(force) + _ARROW_HALF)  # saturates
            sent, pressing = self._arrow_sent
            if (force >= 0.0) != pressing or abs(length - sent) > 0.02 * sent:
                self._arrow_sent = (length, force >= 0.0)
                ends = ((0.0, 0.0, -length), (0.0, 0.0, 0.0))  # N n ends at the contact point; N < 0 starts there
                set_arrays(self.arrow, points=np.array([ends if force >= 0.0 else ends[::-1]], np.float32),
                           colors=vertex_rgb([_FORCE_COLOR if force >= 0.0 else _PULL_COLOR]))
            tail = self._arrow_sent[0]  # the label at the arrow's tail
            set_pose(self.force_label, position=(x - tail * nx, _Y_FRONT, z - tail * nz))

    # -- readouts and export --------------------------------------------------------------------
    def time_text(self) -> str:
        chunk = self.last_chunk
        if isinstance(chunk, RunChunk):
            return (f"**t** = {1000.0 * self.display_time:.2f} ms (revolution {chunk.k + 1}) · **θ** = "
                    f"{_deg(self.cam_angle):.1f}°")
        rev, i = self.revolution, self.index
        return f"**θ** = {_deg(self.cam_angle):.2f}° · **s** = {1000.0 * float(rev.lift[i]):.4f} mm"

    def readout_lines(self) -> list[str]:
        rev, chunk, turn = self.revolution, self.last_chunk, float(self.controls.value("turn_seconds"))
        if isinstance(chunk, RunChunk):
            return self._readout_run(rev, chunk, self.sample_index(chunk), turn).split("\n")[1:]
        i, force = self.index, float(rev.force[self.index])
        state = "pressing" if force >= 0.0 else "< 0: the contact would have to pull; a real follower leaves the cam"
        return [f"**v** = ω s′ = {float(rev.velocity[i]):.4f} m/s · **a** = ω² s″ = {float(rev.acceleration[i]):.2f} "
                f"m/s²", f"**N** = {force:.3f} N ({state})", _slow_motion(turn, rev.speed)]

    def _readout_run(self, rev: Revolution, chunk: RunChunk, j: int, turn: float) -> str:
        gap, force, now = float(chunk.gap[j]), float(chunk.force[j]), float(chunk.t[j])
        if gap > 0.0 and not chunk.constraint[j]:
            contact = f"**in flight**: gap {1000.0 * gap:.3f} mm, N = 0"
        elif chunk.constraint[j]:
            contact = f"**on the cam** (contact constraint): N = {force:.3f} N"
        else:
            contact = f"**on the cam** (Hunt-Crossley, pressed in {significant(1e6 * -gap, 3)} µm): N = {force:.3f} N"
        return "\n".join([
            f"**t** = {1000.0 * now:.2f} ms (revolution {chunk.k + 1}) · **θ** = {_deg(float(chunk.theta[j])):.1f}°",
            f"follower lift {1000.0 * float(chunk.lift[j]):.3f} mm, cam under it {1000.0 * float(chunk.cam_lift[j]):.3f} mm",
            contact, f"so far this revolution: {int(np.count_nonzero(chunk.separations <= now))} separation(s), "
            f"{int(np.count_nonzero(chunk.landings <= now))} landing(s)", _slow_motion(turn, rev.speed)])

    def _info(self, rev: Revolution) -> str:
        i = rev.inputs
        lines = [f"**jump speed = {rev.jump_speed * 30.0 / math.pi:.1f} rpm** ({rev.jump_speed:.3f} rad/s); the cam "
                 f"turns at {i.rpm:g} rpm, {100.0 * rev.speed / rev.jump_speed:.1f} % of it."]
        if rev.separations:
            then = ("The compliant run (its plots below) shows the follower leave the cam and land." if self.compliant
                    else "Turn on *Compliant contact* to see the follower jump.")
            spans = ", ".join(f"θ = {_deg(a):.2f}° to {_deg(b):.2f}°" for a, b in rev.separations)
            lines.append(f"**Separation**: N < 0 from {spans} (shaded); the contact would have to pull. {then}")
        else:
            lines.append(f"**No separation**: N > 0 all round (smallest {rev.min_force[0]:.3f} N at θ = "
                         f"{_deg(rev.min_force[1]):.2f}°).")
        cam = (f"eccentric circle R = {1000 * ECCENTRIC_RADIUS:g} mm, e = {1000 * ECCENTRICITY:g} mm"
               if i.profile == PROFILES[0] else f"{_LAWS[i.profile]} rise-dwell-return, base circle "
               f"{1000 * BASE_RADIUS:g} mm, lift {1000 * LIFT:g} mm, rise = fall = {i.rise_deg:g}°, dwell {DWELL_DEG:g}°")
        follower = "flat face" if i.follower == FOLLOWERS[0] else f"roller r = {i.roller_mm:g} mm"
        lines.append(f"Cam: {cam}; follower: {follower}, m = {i.mass:g} kg, k = {i.stiffness:g} N/m, "
                     f"F0 = {i.preload:g} N, g = {GRAVITY:g} m/s² towards the cam.")
        return "\n\n".join(lines)

    def csv_bytes(self) -> bytes:
        """One revolution of the closed form in use (not the plotted window: the plots are over the cam angle)."""
        return self.revolution.csv() if self.revolution is not None else (CSV_HEADER + "\n").encode()


def _slow_motion(turn: float, speed: float) -> str:
    return f"*slow motion*: one turn in {turn:g} s (a real turn takes {1000.0 * 2.0 * math.pi / speed:.1f} ms)"
