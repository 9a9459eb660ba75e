"""Cam-follower scene: a disk cam at constant speed drives a spring-loaded translating follower.

The cam is an eccentric circle or a rise-dwell-return cam (cycloidal,
harmonic or 3-4-5 law); the follower is flat-faced or carries a roller.
Everything shown comes from :class:`core.models.CamFollower`:

* **Closed form** (default): the follower sits on the cam, its lift ``s``,
  velocity ``omega s'``, acceleration ``omega^2 s''`` and the contact force
  ``N = (m omega^2 s'' + k s + F_0 + m g) / cos(pressure angle)`` are the
  closed forms of :meth:`CamFollower.kinematics` and
  :meth:`CamFollower.contact_force`, tabulated once per parameter set at
  1440 cam angles (every 0.25 deg). The display angle is snapped to that
  grid, so the pose and the readout at the angle shown *are* the closed
  form there, to the last digit. Above :meth:`CamFollower.jump_speed` the
  force turns negative over an interval: the constraint would have to pull;
  the interval is shaded in the plots and drawn on the cam.
* **Compliant contact** (the toggle): :meth:`CamFollower.build_system` on
  :class:`core.multibody.System` with the contact constraints (Eqs.
  8.90-8.109), continued with the Hunt-Crossley model after the first
  separation, so the follower leaves the cam and lands. It runs on the app's
  process pool in chunks of one revolution (:class:`app.jobs.ChunkTimeline`,
  each chunk continuing from the last state of the previous one) and the
  display clock holds while the chunk it needs is being computed.

  Method, tolerance and outputs: 180 outputs per revolution. While the
  follower is on the cam (constraint model) the System has no degree of
  freedom (the motor turns the cam, the contact holds the follower), so
  every output is a kinematic analysis (``simulate(method="kinematic")``):
  the contact force is exact to the Newton tolerance and one revolution
  costs about a third of DOP853's. After a separation the compliant run is
  integrated by DOP853 at rtol 1e-8 (atol 1e-10): the compliant impacts
  are sensitive: against rtol 1e-8, rtol 1e-6 moves the lift by 12 um (flat,
  1.2 x jump) and 47 um (roller), and the sampled impact force peaks by 54 N
  of 2800 N and 175 N of 1600 N, which a plot shows; the cost saved was
  20-30 %. Perturbing rtol 1e-8 itself by one part in 1e9 moves them by 0.7
  um and 3 N (the landings are that sensitive), so 1e-8 is kept. Fewer
  outputs would coarsen the plotted run, so the 180 are kept too.

The cam turns in slow motion (one turn in a few seconds of wall time,
whatever the speed used by the physics). Nodes are created once; per frame
only the cam's orientation, the follower's position, the contact point, the
common normal, the force arrow and the spring (one wire mesh, moved and
stretched along z: a position and a scale) are streamed. The cam's mesh is the extruded contour of the actual profile
(:meth:`CamFollower.cam_curve`), rebuilt on the executor only when the
profile, the follower kind, the rise angle or the roller changes.

Frames (global, metres): the cam shaft is the global y axis through the
origin, the cam profile plane is the x-z plane (profile x -> global x,
profile y -> global z, as in :meth:`CamFollower.build_system`) and the
follower slides along +z above the shaft. The cam turns about -y by the cam
angle theta (theta = 0: lowest lift).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import trimesh
from scipy.optimize import brentq

from app.controls import Choice, Slider, Toggle
from app.nodes import set_array, set_arrays, set_pose, wxyz_z_to
from app.readout import significant
from app.scenes._plots import Legend, format_rows
from app.scenes.base import PRESENTER_LINE_SCALE, Scene
from app.jobs import ChunkTimeline
from core.models import CamFollower, CamProfile

__all__ = [
    "CSV_HEADER",
    "CamFollowerScene",
    "FOLLOWERS",
    "Inputs",
    "PROFILES",
    "REVOLUTION_SAMPLES",
    "RUN_SAMPLES",
    "Revolution",
    "RunChunk",
    "build_cam",
    "compute_chunk",
    "compute_revolution",
    "run_plot_angles",
]

#: Cam profiles (the *Cam* dropdown) and their laws (None: the eccentric circle).
PROFILES = (
    "Eccentric circle",
    "Rise-dwell-return, cycloidal",
    "Rise-dwell-return, harmonic",
    "Rise-dwell-return, 3-4-5",
)
_LAWS = {PROFILES[1]: "cycloidal", PROFILES[2]: "harmonic", PROFILES[3]: "345"}
#: Follower kinds (the *Follower* dropdown) and core's names for them.
FOLLOWERS = ("Flat-faced", "Roller")
_FOLLOWER_KINDS = {FOLLOWERS[0]: "flat", FOLLOWERS[1]: "roller"}

# Fixed cam geometry (m): the eccentric circle, and the rise-dwell-return cam
# (base circle, total lift, upper dwell; rise = fall is a slider).
ECCENTRIC_RADIUS = 0.04
ECCENTRICITY = 0.01
BASE_RADIUS = 0.04
LIFT = 0.02
DWELL_DEG = 30.0
_RISE_DEG = (30.0, 150.0)  # the rise = fall slider's range (deg, whole degrees)
_ROLLER_MM = (2.0, 40.0)  # the roller radius slider's range (mm, steps of 0.5 mm)
GRAVITY = 9.81  # m/s^2, along the follower axis towards the cam (the follower stands above it)

#: Cam angles per revolution of the closed-form table (every 0.25 deg).
REVOLUTION_SAMPLES = 1440
_STEP = 2.0 * math.pi / REVOLUTION_SAMPLES
_PLOT_STRIDE = 2  # the plots show every other sample (0.5 deg)
_CONTOUR_POINTS = 720  # points of the cam's mesh contour
#: Outputs per revolution of the compliant run (every 2 deg; the display interpolates).
RUN_SAMPLES = 180
_RUN_RTOL, _RUN_ATOL = 1e-8, 1e-10  # DOP853 of the compliant run (after a separation)
_CONTACT_STIFFNESS = 1e8  # N/m^1.5, Hunt-Crossley (core's default)
_CONTACT_DAMPING = 0.5  # s/m
_CHUNKS_KEPT = 4
_REFRESH_PERIOD = 0.2  # s of wall time between readout refreshes while turning
_MAX_FRAME_DT = 0.1  # s: a stalled loop advances the cam by at most this much wall time

#: Header of the exported CSV: one revolution of the closed form.
CSV_HEADER = "cam angle (deg),lift (m),velocity (m/s),acceleration (m/s^2),contact force (N)"

# Drawing (m). The cam is 12 mm thick (global y from -6 to 6 mm); the
# contact annotations lie in the plane y = _Y_FRONT, in front of the cam and
# of the follower as the default camera (at -y) sees them.
_CAM_THICKNESS = 0.012
_Y_FRONT = -0.012
_FOLLOWER_DEPTH = 0.014
_STEM_RADIUS = 0.004
_COLLAR_RADIUS = 0.015
_COLLAR_THICKNESS = 0.003
_SPRING_RADIUS = 0.011
_SPRING_TURNS = 7
_SPRING_POINTS = 7 * 36 + 1
_SPRING_SIDES = 6  # vertices around the spring's wire
_SPRING_WIRE = 0.0011  # m: radius of the spring's wire (presenter view: x 2)
_SPRING_MIN_LENGTH = 0.045  # at the highest lift
#: m: the drawn spring's coils touch: 7 turns of the wire as thick as it is drawn in presenter view (twice
#: 1.1 mm); a compliant run whose follower flies higher stops, in either view
_SPRING_SOLID = 2.0 * _SPRING_TURNS * _SPRING_WIRE * PRESENTER_LINE_SCALE
_ARM_THICKNESS = 0.008
_BASE_Z = -0.085  # top of the base plate
_COLUMN_X = -0.095
_ARROW_MAX = 0.045  # m: the force arrow's length saturates at this
_ARROW_HALF = 40.0  # N: force drawn at half the longest arrow
_NORMAL_HALF_LENGTH = 0.03  # m: the common normal drawn either side of the contact point

# Colours: none of the arrows or marks red, green or blue (the frame axes).
_CAM_COLOR = (150, 156, 172)
_HUB_COLOR = (70, 72, 84)
_FOLLOWER_COLOR = (196, 160, 84)  # brass
_ROLLER_COLOR = (96, 100, 114)
_STAND_COLOR = (188, 190, 198)
_SPRING_COLOR = (60, 60, 72)
_FORCE_COLOR = (245, 140, 0)  # orange: N > 0, the cam pushes the follower
_PULL_COLOR = (150, 60, 200)  # purple: N < 0, the cam would have to pull
_NORMAL_COLOR = (0, 160, 150)  # teal
_POINT_COLOR = (30, 30, 40)  # near black
_SEPARATION_COLOR = _PULL_COLOR
_LABEL_SCALE = 1.3
_LABEL_DELAY_FRAMES = 10  # frames between showing the scene and showing its labels


# -- inputs and the core model --------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's model controls (the field names are the control keys)."""

    rpm: float = 800.0
    mass: float = 0.5  # kg
    stiffness: float = 2000.0  # N/m
    preload: float = 20.0  # N, spring force at zero lift
    profile: str = PROFILES[0]
    follower: str = FOLLOWERS[0]
    rise_deg: float = 90.0  # rise = fall (deg), rise-dwell-return cams
    roller_mm: float = 10.0  # roller radius (mm)

    @property
    def speed(self) -> float:
        """Cam speed omega (rad/s)."""
        return self.rpm * math.pi / 30.0

    def geometry_key(self) -> tuple:
        """What the shape of the cam and of the follower depends on."""
        law = _LAWS.get(self.profile)
        kind = _FOLLOWER_KINDS[self.follower]
        return (law, kind, self.rise_deg if law is not None else None,
                self.roller_mm if kind == "roller" else None)

    def model_key(self) -> tuple:
        """What :class:`CamFollower` depends on (all but the speed)."""
        return (*self.geometry_key(), self.mass, self.stiffness, self.preload)

    @classmethod
    def from_values(cls, values: dict[str, Any]) -> Inputs:
        """The inputs of control values ``values`` (``ControlPanel.values()``, or a state's values over them)."""
        return cls(**{f.name: values[f.name] for f in dataclasses.fields(cls)})


_DEFAULT = Inputs()


def build_cam(inputs: Inputs) -> CamFollower:
    """The :class:`core.models.CamFollower` of ``inputs`` (cached per process).

    Raises
    ------
    ValueError
        In the panel's terms (:func:`_refusal`), when core refuses the cam: a
        flat face on a cam that would not be convex, a roller that would
        undercut it.
    """
    key = inputs.model_key()
    try:
        return _cam(key)
    except ValueError as exc:
        raise ValueError(_refusal(key, exc)) from exc


def _refusal(key: tuple, exc: ValueError) -> str:
    """Core's refusal of the cam of ``key`` in the panel's terms, with the value that works.

    Core names its own parameters (``base_radius``, ``lift``, angles in
    rad), which the panel does not have; the panel has the rise = fall
    angle (deg) and the roller radius (mm). Runs in the job (a few cams
    are built to find the value: about 20 ms).
    """
    law, kind, rise_deg, roller_mm, *rest = key
    text = str(exc)
    if law is None:
        return text
    if kind == "roller" and text.startswith("roller_radius:"):
        try:
            largest = _cam((law, kind, rise_deg, 1.0, *rest)).largest_roller_radius()
        except ValueError:
            largest = 0.0
        if largest * 1000.0 >= _ROLLER_MM[0]:
            return (f"Roller radius: a {roller_mm:g} mm roller would undercut this cam (rise = fall = "
                    f"{rise_deg:g}°; the roller centre's path curves more sharply than the roller); use a roller "
                    f"of at most {math.floor(largest * 2000.0) / 2.0:g} mm or a longer rise")
        return f"Roller radius: no roller fits this cam at rise = fall = {rise_deg:g}°; use a longer rise"
    if kind == "flat" and text.startswith("base_radius:"):
        lo, hi = int(math.floor(rise_deg)), int(_RISE_DEG[1])
        fits = None
        while lo < hi:  # the smallest whole-degree rise that makes the cam convex (s'' shrinks as 1/rise^2)
            mid = (lo + hi) // 2
            try:
                _cam((law, kind, float(mid), roller_mm, *rest))
                hi = fits = mid
            except ValueError:
                lo = mid + 1
        if fits is None:
            with contextlib.suppress(ValueError):
                _cam((law, kind, float(hi), roller_mm, *rest))
                fits = hi
        advice = f"a rise of at least {fits}° or " if fits is not None else ""
        return (f"Flat-faced follower: at rise = fall = {rise_deg:g}° the cam would not be convex (its radius of "
                f"curvature R_b + s + s″ turns negative, and a flat face would bridge the hollow); use "
                f"{advice}the roller follower")
    return text


@functools.lru_cache(maxsize=64)
def _cam(key: tuple) -> CamFollower:
    law, kind, rise_deg, roller_mm, mass, stiffness, preload = key
    if law is None:
        profile = CamProfile.eccentric(radius=ECCENTRIC_RADIUS, eccentricity=ECCENTRICITY)
    else:
        rise = math.radians(rise_deg)
        profile = CamProfile.rise_dwell_return(base_radius=BASE_RADIUS, lift=LIFT, rise=rise,
                                               dwell=math.radians(DWELL_DEG), fall=rise, law=law)
    roller = roller_mm / 1000.0 if kind == "roller" else 0.0
    return CamFollower(profile, follower=kind, roller_radius=roller, mass=mass, stiffness=stiffness,
                       preload=preload, gravity=GRAVITY)


@functools.lru_cache(maxsize=64)
def _jump_speed(key: tuple) -> float:
    return float(_cam(key).jump_speed())


# -- geometry: meshes of the actual profile (built once per shape) --------------------
@dataclasses.dataclass(frozen=True)
class Geometry:
    """Meshes and drawing constants of one cam shape and follower (read-only arrays).

    Meshes are ``(vertices (n, 3) float32, faces (m, 3) uint32)`` in their node's
    frame: the cam in its body frame (profile plane = body x-y, extruded along
    body z), the follower parts in the follower's frame (origin at the face's
    point on the axis or at the roller's centre, +z up the stem), the stand in
    the global frame.
    """

    key: tuple
    cam_mesh: tuple[np.ndarray, np.ndarray]
    follower_mesh: tuple[np.ndarray, np.ndarray]  # the stem with the flat face, or with the roller's fork
    roller_mesh: tuple[np.ndarray, np.ndarray] | None  # the roller and its pin (None: flat face)
    stand_mesh: tuple[np.ndarray, np.ndarray]
    contour: np.ndarray  # (_CONTOUR_POINTS, 2) cam contour at u = i 2 pi / n, body frame (m)
    pitch_height: float  # m: global z of the follower's origin at zero lift
    spring_seat: float  # m: height of the spring's lower end above the follower's origin
    spring_top: float  # m: global z of the spring's upper end (under the arm)
    label_follower: float  # m: global z of the follower's label


def _pack(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


def _cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the cross product of plane vectors (..., 2)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _triangulate(points: np.ndarray) -> np.ndarray:
    """Triangles (n - 2, 3) of a simple counter-clockwise polygon ``points`` (n, 2), by ear clipping."""
    idx = list(range(points.shape[0]))
    triangles = []
    while len(idx) > 3:
        m = len(idx)
        poly = points[idx]
        prev, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
        convex = _cross2(poly - prev, nxt - poly) > 0
        for k in np.flatnonzero(convex):
            a, b, c = poly[k - 1], poly[k], poly[(k + 1) % m]
            others = np.delete(np.arange(m), [(k - 1) % m, k, (k + 1) % m])
            p = poly[others][~convex[others]]  # only reflex vertices can lie inside an ear
            if p.size:
                d1 = _cross2(b - a, p - a)
                d2 = _cross2(c - b, p - b)
                d3 = _cross2(a - c, p - c)
                if np.any((d1 >= 0) & (d2 >= 0) & (d3 >= 0)):
                    continue
            triangles.append((idx[(k - 1) % m], idx[k], idx[(k + 1) % m]))
            del idx[k]
            break
        else:
            raise ValueError("contour: expected a simple polygon, got one without an ear")
    triangles.append(tuple(idx))
    return np.array(triangles, dtype=np.int64)


def _extrude(contour: np.ndarray, z0: float, z1: float) -> trimesh.Trimesh:
    """The prism over the closed plane curve ``contour`` (n, 2) from z0 to z1, outward faces.

    The caps are fans from the origin where the contour is star-shaped about it
    (a cam about its shaft), else ear-clipped; either way the mesh has the same
    numbers of vertices and faces for a given ``n`` (padded with an unused
    vertex and degenerate faces), so a new cam replaces the buffers in place.
    """
    ccw = contour if _signed_area(contour) > 0 else contour[::-1]
    n = ccw.shape[0]
    i = np.arange(n)
    j = (i + 1) % n
    side_v = np.concatenate([np.column_stack([ccw, np.full(n, z0)]), np.column_stack([ccw, np.full(n, z1)])])
    side_f = np.concatenate([np.column_stack([i, j, n + j]), np.column_stack([i, n + j, n + i])])
    angle = np.unwrap(np.arctan2(ccw[:, 1], ccw[:, 0]))
    if np.all(np.diff(angle) > 0) and angle[-1] - angle[0] < 2 * math.pi:
        top_v = np.vstack([np.column_stack([ccw, np.full(n, z1)]), [0.0, 0.0, z1]])
        top_f = np.column_stack([np.full(n, n), i, j])
    else:
        top_v = np.vstack([np.column_stack([ccw, np.full(n, z1)]), [0.0, 0.0, z1]])
        top_f = np.vstack([_triangulate(ccw), np.full((2, 3), n)])
    bottom_v = top_v.copy()
    bottom_v[:, 2] = z0
    bottom_f = top_f[:, ::-1]
    offset = side_v.shape[0]
    vertices = np.concatenate([side_v, top_v, bottom_v])
    faces = np.concatenate([side_f, top_f + offset, bottom_f + offset + top_v.shape[0]])
    return trimesh.Trimesh(vertices, faces, process=False)


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    lo_a, hi_a = np.array(lo, dtype=float), np.array(hi, dtype=float)
    return trimesh.creation.box(extents=hi_a - lo_a,
                                transform=trimesh.transformations.translation_matrix((lo_a + hi_a) / 2))


def _cylinder_z(radius: float, z0: float, z1: float, sections: int = 32) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([[0.0, 0.0, z0], [0.0, 0.0, z1]]),
                                     sections=sections)


@functools.lru_cache(maxsize=32)
def _geometry(key: tuple) -> Geometry:
    """Meshes of the cam shape and follower of ``key`` (:meth:`Inputs.geometry_key`)."""
    law, kind, rise_deg, roller_mm = key
    cam = _cam((*key, _DEFAULT.mass, _DEFAULT.stiffness, _DEFAULT.preload))
    u = np.arange(_CONTOUR_POINTS) * (2.0 * math.pi / _CONTOUR_POINTS)
    contour = np.array(cam.cam_curve(u).point)
    cam_mesh = _extrude(contour, -_CAM_THICKNESS / 2, _CAM_THICKNESS / 2)
    pitch_height = float(cam.pitch_curve(0.0).point[1])
    lift_max = float(np.max(cam.kinematics(u).lift))
    if kind == "flat":
        # the face reaches past the farthest contact point, |s'| from the axis
        half_width = float(np.max(np.abs(cam.kinematics(u).dlift))) + 0.008
        lower = [_box((-half_width, -_FOLLOWER_DEPTH / 2, 0.0), (half_width, _FOLLOWER_DEPTH / 2, 0.004))]
        stem_start, roller_mesh = 0.004, None
    else:
        r = roller_mm / 1000.0
        roller = trimesh.creation.cylinder(radius=r, height=0.010, sections=64)
        roller.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1.0, 0.0, 0.0)))
        pin = trimesh.creation.cylinder(radius=min(0.0025, 0.5 * r), height=0.016, sections=16)
        pin.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1.0, 0.0, 0.0)))
        roller_mesh = _pack(trimesh.util.concatenate([roller, pin]))
        top = r + 0.004
        lower = [_box((-0.004, y0, -0.002), (0.004, y1, top)) for y0, y1 in ((-0.0075, -0.0055), (0.0055, 0.0075))]
        lower.append(_box((-0.006, -0.0075, top - 0.003), (0.006, 0.0075, top)))
        stem_start = top
    seat = stem_start + 0.03
    spring_top = pitch_height + lift_max + seat + _COLLAR_THICKNESS + _SPRING_MIN_LENGTH
    stem_top = spring_top - pitch_height + _ARM_THICKNESS + 0.015
    follower = trimesh.util.concatenate(lower + [
        _cylinder_z(_STEM_RADIUS, stem_start, stem_top),
        _cylinder_z(_COLLAR_RADIUS, seat, seat + _COLLAR_THICKNESS, 40),
    ])
    # The stand: base plate, bearing pedestal behind the cam, column and the arm
    # that guides the stem and holds the spring.
    arm_top = spring_top + _ARM_THICKNESS
    hub = trimesh.creation.cylinder(radius=0.013, segment=np.array([[0.0, 0.009, 0.0], [0.0, 0.03, 0.0]]),
                                    sections=40)
    stand = trimesh.util.concatenate([
        _box((-0.12, -0.04, _BASE_Z - 0.008), (0.09, 0.045, _BASE_Z)),
        _box((-0.012, 0.012, _BASE_Z), (0.012, 0.03, 0.0)),
        hub,
        _box((_COLUMN_X - 0.007, 0.015, _BASE_Z), (_COLUMN_X + 0.007, 0.03, arm_top)),
        _box((_COLUMN_X - 0.007, -0.012, spring_top), (0.02, 0.03, arm_top)),
    ])
    contour_f = np.ascontiguousarray(contour, dtype=np.float32)
    contour_f.setflags(write=False)
    return Geometry(key, _pack(cam_mesh), _pack(follower), roller_mesh, _pack(stand), contour_f, pitch_height,
                    seat + _COLLAR_THICKNESS, spring_top, pitch_height + stem_top)


def _hub_mesh() -> tuple[np.ndarray, np.ndarray]:
    """The shaft and an index stripe on the cam's front face (body frame; the stripe
    points along body +y, at the follower when theta = 0, the lowest lift)."""
    shaft = _cylinder_z(0.006, -0.022, _CAM_THICKNESS / 2 + 0.004)
    stripe = _box((-0.0015, 0.008, _CAM_THICKNESS / 2), (0.0015, 0.028, _CAM_THICKNESS / 2 + 0.0008))
    return _pack(trimesh.util.concatenate([shaft, stripe]))


# -- one revolution of the closed form (a job for the executor) -------------------------
@dataclasses.dataclass(frozen=True)
class Revolution:
    """The closed form over one revolution at constant cam speed (read-only arrays).

    Rows ``i = 0 .. REVOLUTION_SAMPLES`` are the cam angles ``theta_i = i *
    2 pi / REVOLUTION_SAMPLES`` (the last one closes the revolution).
    ``contact`` and ``normal`` are global x-z components (the profile plane).
    """

    inputs: Inputs
    speed: float  # rad/s
    jump_speed: float  # rad/s
    lift: np.ndarray  # (n + 1,) m
    velocity: np.ndarray  # (n + 1,) m/s, omega s'
    acceleration: np.ndarray  # (n + 1,) m/s^2, omega^2 s''
    force: np.ndarray  # (n + 1,) N, positive pressing
    force_at_jump: np.ndarray  # (n + 1,) N, the force at the jump speed (touches zero)
    contact: np.ndarray  # (n + 1, 2) contact point (global x, z), m
    normal: np.ndarray  # (n + 1, 2) common normal from the cam to the follower (global x, z)
    follower_z: np.ndarray  # (n + 1,) global z of the follower's origin, m
    separations: tuple[tuple[float, float], ...]  # cam-angle intervals (rad) where N < 0 (may wrap)
    separation_segments: np.ndarray | None  # (m, 2, 3) the intervals on the cam contour (body frame)
    min_force: tuple[float, float]  # (N, cam angle rad) of the smallest force
    geometry_key: tuple
    geometry: Geometry | None  # None when the job was told the scene shows this shape already

    @staticmethod
    def angle(i: int) -> float:
        """Cam angle (rad) of row ``i``."""
        return i * _STEP

    @staticmethod
    def index_of(theta: float) -> int:
        """The table row nearest the cam angle ``theta`` (rad), modulo one revolution."""
        return int(round((theta % (2.0 * math.pi)) / _STEP)) % REVOLUTION_SAMPLES

    def plot_data(self, name: str) -> tuple[np.ndarray, ...]:
        """Series of plot ``name`` ("lift", "velocity", "acceleration", "force"), x = cam angle (deg)."""
        k = _PLOT_STRIDE
        x = np.arange(0, REVOLUTION_SAMPLES + 1, k) * (360.0 / REVOLUTION_SAMPLES)
        force = self.force[::k]
        separated = force < 0.0
        if name == "force":
            return (x, force, np.zeros_like(x), self.force_at_jump[::k], np.minimum(force, 0.0))
        y = {"lift": 1000.0 * self.lift[::k], "velocity": self.velocity[::k],
             "acceleration": self.acceleration[::k]}[name]
        return (x, y, np.where(separated, y, 0.0))

    def csv(self) -> bytes:
        """The revolution as CSV: :data:`CSV_HEADER`, then one row per 0.25 deg (15 significant digits)."""
        n = REVOLUTION_SAMPLES
        angles = np.arange(n) * (360.0 / n)
        rows = format_rows(angles, np.column_stack([self.lift, self.velocity, self.acceleration, self.force])[:n])
        return ("\n".join((CSV_HEADER, *rows)) + "\n").encode()


def compute_revolution(inputs: Inputs, shown_geometry: tuple | None = None) -> Revolution:
    """The closed-form revolution of ``inputs`` (runs on the executor).

    ``shown_geometry`` is the :meth:`Inputs.geometry_key` the scene draws
    already: its meshes are not sent again.

    Raises
    ------
    ValueError
        What :class:`core.models.CamFollower` raises for a cam it refuses.
    """
    cam = build_cam(inputs)
    w = inputs.speed
    jump = _jump_speed(inputs.model_key())
    key = inputs.geometry_key()
    geometry = _geometry(key)
    theta = np.arange(REVOLUTION_SAMPLES + 1) * _STEP
    kin = cam.kinematics(theta)
    force = np.asarray(cam.contact_force(theta, w))
    velocity = w * kin.dlift
    acceleration = w * w * kin.d2lift
    force_at_jump = np.asarray(cam.contact_force(theta, jump))
    c, s = np.cos(theta), np.sin(theta)
    p = np.asarray(cam.cam_curve(theta).point)
    nrm = np.asarray(cam.contact_normal(theta))
    # the cam turned by theta: profile-plane rotation of the cam-frame vectors
    contact = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]])
    normal = np.column_stack([c * nrm[:, 0] - s * nrm[:, 1], s * nrm[:, 0] + c * nrm[:, 1]])
    follower_z = geometry.pitch_height + kin.lift
    separations = _separations(cam, w, theta, force)
    k = int(np.argmin(force))
    arrays = [kin.lift, velocity, acceleration, force, force_at_jump, contact, normal, follower_z]
    for a in arrays:
        if not np.all(np.isfinite(a)):
            raise ValueError("the closed form gave a non-finite value; choose other parameters")
        a.setflags(write=False)
    return Revolution(inputs, w, jump, kin.lift, velocity, acceleration, force, force_at_jump, contact, normal,
                      follower_z, separations, _separation_segments(geometry, separations),
                      (float(force[k]), float(theta[k])), key, None if key == shown_geometry else geometry)


def _separations(cam: CamFollower, w: float, theta: np.ndarray, force: np.ndarray) -> tuple[tuple[float, float], ...]:
    """Cam-angle intervals ``(start, end)`` (rad, end may exceed 2 pi) where ``N < 0``.

    Ends are the sign changes of the tabulated force, refined by Brent's
    method on :meth:`CamFollower.contact_force` (to 1e-12 rad).
    """
    negative = force[:-1] < 0.0
    if not np.any(negative):
        return ()

    def f(x: float) -> float:
        return float(cam.contact_force(x, w))

    def root(i: int) -> float:  # force changes sign between samples i and i + 1
        a, b = float(theta[i]), float(theta[i + 1])
        if force[i] == 0.0:
            return a
        return float(brentq(f, a, b, xtol=1e-12))

    starts = [i for i in range(REVOLUTION_SAMPLES) if force[i] >= 0.0 > force[i + 1]]
    ends = [i for i in range(REVOLUTION_SAMPLES) if force[i] < 0.0 <= force[i + 1]]
    if not starts:  # negative everywhere but never crossing: not reached for a real cam
        return ((0.0, 2.0 * math.pi),)
    intervals = []
    end_roots = sorted(root(i) for i in ends)
    for i in starts:
        a = root(i)
        later = [e for e in end_roots if e > a]
        b = later[0] if later else end_roots[0] + 2.0 * math.pi
        intervals.append((a, b))
    return tuple(intervals)


# -- one revolution of the compliant run (a job for the executor) ------------------------
@dataclasses.dataclass(frozen=True)
class RunChunk:
    """Revolution ``k`` of the run on :class:`core.multibody.System` (read-only arrays).

    Times ``t = k T + j T / RUN_SAMPLES``, ``j = 0 .. RUN_SAMPLES`` (``T = 2 pi /
    omega``); points and normals are global x-z components.
    """

    k: int
    t0: float  # s
    h: float  # s, output spacing
    theta: np.ndarray  # (n,) cam angle omega t (rad)
    follower_z: np.ndarray  # (n,) m, global z of the follower's origin (simulated)
    lift: np.ndarray  # (n,) m, the follower's lift (simulated)
    cam_lift: np.ndarray  # (n,) m, the closed-form lift under it (the cam's surface)
    force: np.ndarray  # (n,) N: the multiplier (on the cam) or the Hunt-Crossley force
    closed_force: np.ndarray  # (n,) N: the closed form at the same angles
    point: np.ndarray  # (n, 2) contact point on the cam (global x, z), m
    normal: np.ndarray  # (n, 2) common normal (global x, z)
    gap: np.ndarray  # (n,) m, negative: pressed in
    constraint: np.ndarray  # (n,) bool: the contact constraint held
    separations: np.ndarray  # (m,) times (s) the follower left the cam: the constraint's separation
    #                          events, and the openings of the compliant contact's gap
    landings: np.ndarray  # (m,) times (s) the compliant contact's gap closed
    q_end: np.ndarray  # the System's positions at the end (to continue from)
    v_end: np.ndarray
    constraint_end: bool


def compute_chunk(inputs: Inputs, k: int, previous: RunChunk | None) -> RunChunk:
    """Revolution ``k`` of the run of ``inputs`` (runs on the executor).

    Revolution 0 starts on the cam at cam angle 0 with the contact
    constraints; later ones continue from the final state of revolution ``k -
    1`` (``previous``), with the constraints while the follower has not left
    the cam yet, else with the Hunt-Crossley contact. A separation switches
    to the compliant model (``on_separation="compliant"``).

    A revolution that stayed on the cam throughout (constraint model, no
    separation) repeats: the motor turns the cam at a constant speed and
    the System has no degree of freedom, so the kinematic solution at ``t +
    T`` is the one at ``t``. The next revolution is then that one a period
    later (:func:`_repeated`), not computed again.

    Raises
    ------
    ValueError
        Without the previous revolution for ``k > 0``; what the core raises
        when the run fails.
    """
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: revolution {k} continues from revolution {k - 1}, which was not given")
    w = inputs.speed
    period = 2.0 * math.pi / w
    if previous is not None and previous.separations.size == 0 and bool(np.all(previous.constraint)):
        return _repeated(previous, period)
    cam = build_cam(inputs)
    t = (k + np.arange(RUN_SAMPLES + 1) / RUN_SAMPLES) * period
    model = "constraint" if previous is None or previous.constraint_end else "compliant"
    built = cam.build_system(w, start=float(t[0]), model=model, contact_stiffness=_CONTACT_STIFFNESS,
                             contact_damping=_CONTACT_DAMPING)
    system = built.system
    if previous is not None:
        system.set_state(dataclasses.replace(system.state, t=float(t[0]), q=previous.q_end, v=previous.v_end))
    # on the cam: no degree of freedom, a kinematic analysis per output; in flight: DOP853
    method = "kinematic" if model == "constraint" else "DOP853"
    traj = system.simulate(t, method=method, rtol=_RUN_RTOL, atol=_RUN_ATOL, on_separation="compliant")
    history = traj.contact(built.contact)
    follower = system.bodies.index(built.follower)
    z = np.array(traj.q[:, 3 * follower + 2])
    theta = w * np.asarray(traj.t)
    point = np.asarray(history.point)[:, [0, 2]]
    normal = np.asarray(history.normal)[:, [0, 2]]
    force = np.array(history.normal_force)
    gap = np.array(history.gap)
    constraint = np.array(history.constraint, dtype=bool)
    for name, a in (("lift", z), ("force", force), ("point", point), ("gap", gap)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the run left the finite range in revolution {k + 1}")
    times = np.asarray(traj.t)
    events = np.array([event.t for event in traj.separations], dtype=float)
    opened, landings = _gap_crossings(times, gap, constraint)
    separations = np.sort(np.concatenate([events, opened]))
    arrays = dict(theta=theta, follower_z=z, lift=z - built.lift_origin,
                  cam_lift=np.asarray(cam.kinematics(theta).lift), force=force,
                  closed_force=np.asarray(cam.contact_force(theta, w)), point=point, normal=normal, gap=gap,
                  constraint=constraint, separations=separations, landings=landings)
    for a in arrays.values():
        a.setflags(write=False)
    return RunChunk(k, float(t[0]), float(period / RUN_SAMPLES), **arrays, q_end=np.array(traj.q[-1]),
                    v_end=np.array(traj.v[-1]), constraint_end=bool(constraint[-1]))


def run_plot_angles(chunk: RunChunk) -> np.ndarray:
    """The run plots' x values: the cam angle within the revolution (deg, 0 to 360), rounded to 1e-9 deg
    (``degrees(theta) - 360 k`` is 5.7e-14 instead of 0 at a later revolution's start, and uPlot then drops
    the axis's 0 tick)."""
    return np.round(np.degrees(chunk.theta) - 360.0 * chunk.k, 9)


#: The plots' x scale: the cam angle (deg), not a time axis.
_X_SCALE = {"x": {"time": False}}
#: Legend label of the System's force in the compliant run's plot (the off-scale impact peak is added to it).
_RUN_FORCE_LABEL = "System (N)"
#: The compliant run's force plot shows up to this many times the closed form's span above the closed form's
#: maximum: the impacts of a landing reach kilonewtons, and a range fitted to them would draw the closed form
#: (tens of newtons) as a flat line at zero.
_RUN_FORCE_HEADROOM = 2.0


def run_force_range(chunk: RunChunk) -> tuple[tuple[float, float], float | None]:
    """The y range (N) of the compliant run's force plot and the off-scale peak force (N), or None.

    The range holds the closed form, zero and the run's force, except the force above the closed form's
    maximum plus :data:`_RUN_FORCE_HEADROOM` times its span (impact peaks), with 5 % margins.
    """
    closed, force = chunk.closed_force, chunk.force
    lo = min(float(closed.min()), float(force.min()), 0.0)
    top = max(float(closed.max()), 0.0)
    cap = top + _RUN_FORCE_HEADROOM * max(top - min(float(closed.min()), 0.0), 1.0)
    peak = float(force.max())
    hi = max(top, min(peak, cap))
    pad = 0.05 * max(hi - lo, 1.0)
    return (lo - pad, hi + pad), (peak if peak > cap else None)


def _newtons(x: float) -> str:
    """A force for a title: ``2.7 kN`` from 1000 N up, ``850 N`` below."""
    return f"{x / 1000.0:.1f} kN" if abs(x) >= 1000.0 else f"{x:.0f} N"


def _repeated(previous: RunChunk, period: float) -> RunChunk:
    """Revolution ``previous.k + 1`` of a revolution that stayed on the cam: the same motion one ``period``
    (s) later, the cam angle one turn further (see :func:`compute_chunk`)."""
    theta = previous.theta + 2.0 * math.pi
    theta.setflags(write=False)
    return dataclasses.replace(previous, k=previous.k + 1, t0=previous.t0 + period, theta=theta)


def _gap_crossings(t: np.ndarray, gap: np.ndarray, constraint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times the compliant contact's gap opens and closes between outputs (linear interpolation);
    outputs in the constraint model do not count (their gap is round-off)."""
    a, b = gap[:-1], gap[1:]
    both = ~constraint[:-1] & ~constraint[1:]
    out = []
    for idx in (np.flatnonzero(both & (a <= 0.0) & (b > 0.0)), np.flatnonzero(both & (a > 0.0) & (b <= 0.0))):
        out.append(t[idx] + a[idx] / (a[idx] - b[idx]) * (t[idx + 1] - t[idx]))
    return out[0], out[1]


# -- drawing helpers (loop thread, plain floats) ------------------------------------
def _arrow_length(force: float) -> float:
    """Length (m) of the force arrow: ``_ARROW_MAX |N| / (|N| + _ARROW_HALF)``, which saturates."""
    return _ARROW_MAX * abs(force) / (abs(force) + _ARROW_HALF)


def _arrow(length: float, force: float) -> np.ndarray:
    """The force on the follower, ``N n``, in the contact point's frame (+z along the normal ``n``), (1, 2,
    3): N > 0 ends at the contact point, N < 0 starts there."""
    ends = ((0.0, 0.0, -length), (0.0, 0.0, 0.0))
    return np.array([ends if force >= 0.0 else ends[::-1]], dtype=np.float32)


def _slow_motion_text(turn: float, speed: float) -> str:
    """The readouts' last line: the wall seconds of a shown turn against a real one at ``speed`` (rad/s)."""
    return f"*slow motion*: one turn in {turn:g} s (a real turn takes {1000.0 * 2.0 * math.pi / speed:.1f} ms)"


_HELIX_U = np.linspace(0.0, 1.0, _SPRING_POINTS)
_HELIX_X = (_SPRING_RADIUS * np.cos(2.0 * math.pi * _SPRING_TURNS * _HELIX_U)).astype(np.float32)
_HELIX_Y = (_SPRING_RADIUS * np.sin(2.0 * math.pi * _SPRING_TURNS * _HELIX_U)).astype(np.float32)


def _spring_tube(length: float, wire_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """A wire of ``wire_radius`` (m) along the helix from z = 0 up to ``length`` (m): vertices
    (p * k, 3) float32 and faces (2 (p - 1) k, 3) uint32, ``k`` vertices around the wire.

    The scene draws it with a scale along z of (current length) / ``length``, so the
    spring follows the follower with one position and one scale per frame instead of
    its whole helix; built at the middle of the spring's travel, the wire's section
    stays within about 15 % of round.
    """
    k = _SPRING_SIDES
    centre = np.column_stack([_HELIX_X, _HELIX_Y, length * _HELIX_U]).astype(float)
    tangent = np.gradient(centre, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    radial = np.column_stack([_HELIX_X, _HELIX_Y, np.zeros(_SPRING_POINTS)]) / _SPRING_RADIUS
    normal = np.cross(tangent, radial)
    phi = np.arange(k) * (2.0 * math.pi / k)
    ring = np.cos(phi)[None, :, None] * radial[:, None, :] + np.sin(phi)[None, :, None] * normal[:, None, :]
    vertices = (centre[:, None, :] + wire_radius * ring).reshape(-1, 3).astype(np.float32)
    i = np.arange(_SPRING_POINTS - 1)[:, None] * k
    j = np.arange(k)[None, :]
    a, b, c, d = i + j, i + (j + 1) % k, i + k + j, i + k + (j + 1) % k
    faces = np.concatenate([np.stack([a, c, b], axis=-1).reshape(-1, 3), np.stack([b, c, d], axis=-1).reshape(-1, 3)])
    return vertices, faces.astype(np.uint32)


def _separation_segments(geometry: Geometry, intervals: tuple[tuple[float, float], ...]) -> np.ndarray | None:
    """Segments (n - 1, 2, 3) along the cam contour over the separation intervals, on the
    cam's front face (body frame); None without separation."""
    n = _CONTOUR_POINTS
    u = np.arange(n) * (2.0 * math.pi / n)
    mask = np.zeros(n, dtype=bool)
    for a, b in intervals:
        mask |= ((u - a) % (2.0 * math.pi)) <= (b - a)
    if not np.any(mask):
        return None
    c = geometry.contour
    z = _CAM_THICKNESS / 2 + 0.0006
    pts = np.column_stack([c, np.full(n, z, dtype=np.float32)]).astype(np.float32)
    seg = np.stack([pts, np.roll(pts, -1, axis=0)], axis=1)
    keep = mask & np.roll(mask, -1)
    if not np.any(keep):
        keep = mask
    used = seg[keep]
    out = np.repeat(used[:1], n, axis=0)  # unused segments repeat the first one
    out[: used.shape[0]] = used
    return out


def _deg(theta: float) -> float:
    return math.degrees(theta % (2.0 * math.pi))


def _interval_text(intervals: tuple[tuple[float, float], ...]) -> str:
    return ", ".join(f"θ = {_deg(a):.2f}° to {_deg(b):.2f}°" for a, b in intervals)


@dataclasses.dataclass
class _Gui:
    readout: Any  # app.readout.Readout: the angle shown (rewritten up to 5 times a second)
    info: Any  # app.readout.Readout: jump speed, separation, the cam (rewritten per parameter set)
    legend: Legend
    plots: dict  # name -> uPlot handle (closed form over a revolution)
    run_plots: dict  # name -> uPlot handle (compliant run, this revolution)


#: Panel and buffer updates, one per frame, in this order (see ``_refresh_one``).
_REFRESH_ORDER = ("meshes", "info", "marks", "lift", "velocity", "acceleration", "force", "run_lift", "run_force")


class CamFollowerScene(Scene):
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

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.timeline = ChunkTimeline(self.executor, functools.partial(compute_chunk, _DEFAULT),
                                      chunk_time=2.0 * math.pi / _DEFAULT.speed, sequential=True,
                                      capacity=_CHUNKS_KEPT)
        # Owned by update() (the session loop thread).
        self.revolution: Revolution | None = None
        self.revision = 0  # counts the revolutions swapped in
        self.drawn_revision = -1  # the revision whose pose was drawn last
        self.geometry: Geometry | None = None
        self._wanted: Inputs | None = None
        self._job: tuple[Inputs, Any] | None = None
        self.cam_angle = 0.0  # rad, the cam angle drawn (closed form: on the table's grid)
        self._angle = 0.0  # rad, the display clock of the closed form
        self.index = 0  # table row drawn (closed form)
        self.sim_time = 0.0  # s, the compliant run's clock
        self.compliant = False  # the compliant run is shown
        self.waiting = False  # the compliant run's clock holds for its next revolution
        self.run_chunk: RunChunk | None = None
        self.force = 0.0  # N, the contact force drawn
        self.follower_z = 0.0  # m, the follower's origin drawn
        self._drawn: tuple | None = None
        self._readout_key: tuple | None = None
        self._since_readout = math.inf
        self._pending: set[str] = set()
        self._run_plot_k = -1
        self._csv: tuple[Revolution, bytes] | None = None
        self._labels_shown = False
        self._labels_due = 0
        self._error_reported = False
        self.gui: _Gui | None = None

    # -- build ----------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        self.add_ground_grid(width=0.6, height=0.4, position=(0.0, 0.0, _BASE_Z - 0.0081), cell_size=0.01,
                             section_size=0.05)
        flat = _geometry(_DEFAULT.geometry_key())
        roller = _geometry(dataclasses.replace(_DEFAULT, follower=FOLLOWERS[1]).geometry_key())
        self.stand = scene.add_mesh_simple(f"{root}/stand", *flat.stand_mesh, color=_STAND_COLOR)
        scene.add_frame(f"{root}/cam_plane", show_axes=False, wxyz=(math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0))
        self.cam_frame = scene.add_frame(f"{root}/cam_plane/cam", show_axes=False)
        self.cam_mesh = scene.add_mesh_simple(f"{root}/cam_plane/cam/body", *flat.cam_mesh, color=_CAM_COLOR)
        scene.add_mesh_simple(f"{root}/cam_plane/cam/hub", *_hub_mesh(), color=_HUB_COLOR)
        self.separation_arc = self.add_lines(
            f"{root}/cam_plane/cam/separation", np.zeros((_CONTOUR_POINTS, 2, 3), dtype=np.float32),
            np.full((_CONTOUR_POINTS, 2, 3), _SEPARATION_COLOR, dtype=np.uint8), thickness=5.0,
            thickness_units="screen", visible=False,
        )
        self.follower_frame = scene.add_frame(f"{root}/follower", show_axes=False,
                                              position=(0.0, 0.0, flat.pitch_height))
        # one mesh node per follower kind (each keeps its numbers of vertices and faces)
        self.follower_meshes = {
            "flat": scene.add_mesh_simple(f"{root}/follower/flat", *flat.follower_mesh, color=_FOLLOWER_COLOR),
            "roller": scene.add_mesh_simple(f"{root}/follower/fork", *roller.follower_mesh, color=_FOLLOWER_COLOR,
                                            visible=False),
        }
        self.roller_mesh = scene.add_mesh_simple(f"{root}/follower/roller", *roller.roller_mesh,
                                                 color=_ROLLER_COLOR, visible=False)
        # one instance of a wire mesh, moved and stretched along z every frame (24 bytes)
        # rather than a helix of 252 segments (6 kB) re-sent every frame
        self._spring_reference = self._spring_reference_length(flat)
        z0 = flat.pitch_height + flat.spring_seat
        self.spring = scene.add_batched_meshes_simple(
            f"{root}/spring", *_spring_tube(self._spring_reference, self.spring_wire_radius),
            batched_wxyzs=np.array([[1.0, 0.0, 0.0, 0.0]], dtype=np.float32),
            batched_positions=np.array([[0.0, 0.0, z0]], dtype=np.float32),
            batched_scales=np.array([[1.0, 1.0, (flat.spring_top - z0) / self._spring_reference]], dtype=np.float32),
            batched_colors=_SPRING_COLOR, lod="off", side="double",
        )
        self.contact_frame = scene.add_frame(f"{root}/contact", show_axes=False)
        # the contact point's frame: at the point, +z along the common normal. The dot, the normal and the
        # force arrow are drawn in it, so that one pose moves all three together (points re-sent every
        # frame reached the page frames after the pose); the arrow is re-sent only when its length has
        # changed by 2 % or its sense has flipped
        self.contact_point = scene.add_frame(f"{root}/contact/point", show_axes=False)
        scene.add_icosphere(f"{root}/contact/point/dot", radius=0.0026, color=_POINT_COLOR, subdivisions=2)
        self.normal_line = self.add_lines(
            f"{root}/contact/point/normal",
            np.array([[(0.0, 0.0, -_NORMAL_HALF_LENGTH), (0.0, 0.0, _NORMAL_HALF_LENGTH)]], dtype=np.float32),
            np.full((1, 2, 3), _NORMAL_COLOR, dtype=np.uint8), thickness=2.5, thickness_units="screen")
        self.arrow = self.add_arrows(f"{root}/contact/point/force", np.zeros((1, 2, 3), dtype=np.float32),
                                     np.array([_FORCE_COLOR], dtype=np.uint8), shaft_radius=0.0016,
                                     head_radius=0.004, head_length=0.008)
        self._arrow_sent = (0.0, True)  # (length, N >= 0) of the arrow as sent
        # Labels start hidden and are shown by a later frame (see set_active).
        self.force_label = self.add_label(f"{root}/contact/label", "N", anchor="top-right", scale=_LABEL_SCALE,
                                          visible=False)
        self.labels = {
            "cam": self.add_label(f"{root}/label_cam", "cam (turns at ω)", position=(-0.048, _Y_FRONT, -0.03),
                                  anchor="center-right", scale=_LABEL_SCALE, visible=False),
            "follower": self.add_label(f"{root}/label_follower", "follower", anchor="center-left",
                                       position=_follower_label(flat), scale=_LABEL_SCALE, visible=False),
            "spring": self.add_label(f"{root}/label_spring", "spring k, F0", anchor="center-left",
                                     position=_spring_label(flat), scale=_LABEL_SCALE, visible=False),
        }
        self.geometry = flat
        gui = self.target.gui
        with self.make_folder():
            legend = Legend(gui, (
                (_FORCE_COLOR, "N n: force of the cam on the follower (N > 0)"),
                (_PULL_COLOR, "N < 0: the contact would have to pull (separation interval)"),
                (_NORMAL_COLOR, "common normal at the contact point (hidden in flight)"),
                (_POINT_COLOR, "contact point (in flight: the cam's point nearest the follower)"),
            ), "Drawn on the cam (arrow length saturates):", presenter=self.presenter)
            readout = self.add_readout("Computing the cam…")
            info = self.add_readout("")
            with gui.add_folder("Speed and loads"):
                self.controls.add(Slider("rpm", "Cam speed (rpm)", min=10.0, max=3000.0, step=1.0,
                                         default=_DEFAULT.rpm, hint="Constant cam speed used by the physics"))
                self.controls.add(Slider("mass", "Follower mass (kg)", min=0.05, max=5.0, step=0.01,
                                         default=_DEFAULT.mass))
                self.controls.add(Slider("stiffness", "Spring k (N/m)", min=0.0, max=20000.0, step=10.0,
                                         default=_DEFAULT.stiffness))
                self.controls.add(Slider("preload", "Preload F0 (N)", min=0.0, max=200.0, step=0.5,
                                         default=_DEFAULT.preload, hint="Spring force at zero lift"))
            with gui.add_folder("Cam and follower"):
                self.controls.add(Choice("profile", "Cam", options=PROFILES, default=_DEFAULT.profile))
                self.controls.add(Choice("follower", "Follower", options=FOLLOWERS, default=_DEFAULT.follower))
                self.controls.add(Slider("rise_deg", "Rise = fall (deg)", min=_RISE_DEG[0], max=_RISE_DEG[1],
                                         step=1.0,
                                         default=_DEFAULT.rise_deg,
                                         hint="Cam angle of the rise and of the fall (rise-dwell-return cams)"),
                                  disabled=True)
                self.controls.add(Slider("roller_mm", "Roller radius (mm)", min=_ROLLER_MM[0], max=_ROLLER_MM[1],
                                         step=0.5,
                                         default=_DEFAULT.roller_mm, hint="Radius of the roller (roller follower)"),
                                  disabled=True)
            with gui.add_folder("Motion"):
                self.controls.add(Toggle("animate", "Turn the cam", default=True))
                self.controls.add(Slider("turn_seconds", "Slow motion (s per turn)", min=0.5, max=20.0, step=0.5,
                                         default=5.0, hint="Wall-clock seconds the cam takes for one turn"))
                self.controls.add(Toggle("compliant", "Compliant contact (the follower can jump)", default=False,
                                         hint="Run the multibody System: constraints, then a Hunt-Crossley "
                                              "contact after a separation"))
                self.controls.add(Toggle("show_contact", "Contact point, normal, force", default=True))
            with gui.add_folder("Plots (one revolution)"):
                x_series = {"label": "θ (deg)"}
                # the fill marks the separation interval; no stroke (it would draw a line at zero elsewhere)
                shade = {"label": "N < 0", "stroke": "rgba(150, 60, 200, 0)", "fill": "rgba(150, 60, 200, 0.3)",
                         "width": 1}
                empty = np.zeros(2)
                plots = {
                    "lift": self.add_plot(
                        (empty,) * 3, (x_series, {"label": "s (mm)", "stroke": "#2266dd", "width": 2}, shade),
                        title="lift s (mm)", scales=_X_SCALE, aspect=1.7),
                    "velocity": self.add_plot(
                        (empty,) * 3, (x_series, {"label": "v (m/s)", "stroke": "#0f766e", "width": 2}, shade),
                        title="velocity ω s′ (m/s)", scales=_X_SCALE, aspect=1.7),
                    "acceleration": self.add_plot(
                        (empty,) * 3, (x_series, {"label": "a (m/s²)", "stroke": "#c2410c", "width": 2}, shade),
                        title="acceleration ω² s″ (m/s²)", scales=_X_SCALE, aspect=1.7),
                    "force": self.add_plot(
                        (empty,) * 5,
                        (x_series, {"label": "N (N)", "stroke": "#d97706", "width": 2},
                         {"label": "N = 0", "stroke": "#555555", "dash": [6, 4], "width": 1},
                         {"label": "N at jump speed", "stroke": "#888888", "dash": [3, 3], "width": 1}, shade),
                        title="contact force N (N)", scales=_X_SCALE, aspect=1.7),
                }
                run_plots = {
                    "run_lift": self.add_plot(
                        (empty,) * 3,
                        (x_series, {"label": "cam under it (mm)", "stroke": "#2266dd", "width": 2},
                         {"label": "follower (mm)", "stroke": "#9633c8", "width": 2}),
                        title="compliant run: lift (mm)", scales=_X_SCALE, aspect=1.7, visible=False),
                    "run_force": self.add_plot(
                        (empty,) * 3,
                        (x_series, {"label": "closed form (N)", "stroke": "#888888", "dash": [6, 4], "width": 1},
                         {"label": _RUN_FORCE_LABEL, "stroke": "#d97706", "width": 2}),
                        title="compliant run: force N (N)", scales=_X_SCALE, aspect=1.7,
                        visible=False),
                }
            self.add_download("download_csv", "Download CSV", "cam_follower.csv", self.csv_bytes,
                              hint="One revolution of the closed form: angle, lift, velocity, acceleration, force")
        self.gui = _Gui(readout, info, legend, plots, run_plots)

    def set_active(self, active: bool) -> None:
        """Show or hide the scene; the 3-D labels appear a few frames after it is shown.

        viser 1.1.1's page does not draw a label created while it is connected
        until the label's visibility changes in a later message (a change sent
        with the node's creation, or toggled within one message group, is
        lost), so the labels are hidden here and shown by a later frame.
        """
        super().set_active(active)
        if active:
            with self.target.atomic():
                for label in (*self.labels.values(), self.force_label):
                    label.visible = False
            self._labels_shown = False
            self._labels_due = self.frames + _LABEL_DELAY_FRAMES
            self._drawn = None

    def on_presenter(self, on: bool) -> None:
        if self.gui is not None:
            self.gui.legend.set_presenter(on)
        if getattr(self, "spring", None) is not None:
            self._send_spring_mesh()

    @property
    def spring_wire_radius(self) -> float:
        """Radius of the spring's wire as drawn (m): twice as thick in presenter view."""
        return _SPRING_WIRE * (PRESENTER_LINE_SCALE if self.presenter else 1.0)

    def _travel_limit(self) -> float:
        """The largest lift (m) the stand allows: the drawn spring is solid there (:data:`_SPRING_SOLID`)."""
        geometry = self.geometry
        return geometry.spring_top - geometry.pitch_height - geometry.spring_seat - _SPRING_SOLID

    @staticmethod
    def _spring_reference_length(geometry: Geometry) -> float:
        """The spring's length (m) in the middle of its travel, where its mesh is built."""
        free = geometry.spring_top - geometry.pitch_height - geometry.spring_seat  # at zero lift
        return 0.5 * (free + _SPRING_MIN_LENGTH)

    def _send_spring_mesh(self) -> None:
        """The spring's wire mesh for the current geometry and presenter view (and the
        reference length its z scale is relative to)."""
        reference = self._spring_reference_length(self.geometry)
        vertices, faces = _spring_tube(reference, self.spring_wire_radius)
        set_arrays(self.spring, vertices=vertices, faces=faces)
        self._spring_reference = reference

    # -- state ------------------------------------------------------------------------
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
                self._angle = math.radians(float(value)) % (2.0 * math.pi)
                self._drawn = None
        return refused

    # -- inputs and jobs ----------------------------------------------------------------
    def inputs_from_controls(self) -> Inputs:
        """The model controls' values in use."""
        return Inputs.from_values(self.controls.values())

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            build_cam(Inputs.from_values(values))
        except ValueError as exc:
            return f"cam refused: {exc}"
        return None

    def _request(self, inputs: Inputs) -> None:
        """Ask for the revolution of ``inputs``: one job at a time, the newest inputs win."""
        self._wanted = inputs
        if self._job is None and (self.revolution is None or self.revolution.inputs != inputs):
            shown = self.geometry.key if self.geometry is not None else None
            self._job = (inputs, self.executor.submit(compute_revolution, inputs, shown))

    def _collect(self) -> None:
        """Take the finished job: use its revolution, or refuse its inputs with a notice."""
        if self._job is None or not self._job[1].done():
            return
        inputs, future = self._job
        self._job = None
        if future.cancelled():
            return
        exc = future.exception()
        if isinstance(exc, ValueError):
            if inputs == self._wanted:
                kept = self.revolution.inputs if self.revolution is not None else _DEFAULT
                self.notify("Cam refused", f"{exc}. Keeping the values in use (the controls are set back).",
                            "warning")
                self.controls.set_many(dataclasses.asdict(kept))
                self._wanted = kept
        elif exc is not None:
            raise exc
        else:
            self._swap(future.result())
        if self._wanted is not None:
            self._request(self._wanted)

    def _swap(self, revolution: Revolution) -> None:
        """Use ``revolution`` from now on: new plots, maybe new meshes, a compliant run restarted."""
        old = self.revolution
        self.revolution = revolution
        self.revision += 1
        if revolution.geometry is not None and (self.geometry is None or self.geometry.key != revolution.geometry_key):
            self.geometry = revolution.geometry
            self._pending.add("meshes")
        self._drawn = None
        self._readout_key = None
        self._pending |= {"info", "marks", "lift", "velocity", "acceleration", "force"}
        if old is None or old.inputs != revolution.inputs:
            self._restart_run()
        inputs = revolution.inputs
        self.controls.handles["rise_deg"].disabled = inputs.profile == PROFILES[0]
        self.controls.handles["roller_mm"].disabled = inputs.follower != FOLLOWERS[1]

    def _restart_run(self) -> None:
        rev = self.revolution
        if rev is None:
            return
        self.timeline.reset(functools.partial(compute_chunk, rev.inputs))
        self.timeline.chunk_time = 2.0 * math.pi / rev.speed
        self.sim_time = 0.0
        self.run_chunk = None
        self._run_plot_k = -1
        self._error_reported = False
        self._drawn = None

    # -- update ------------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        changed = self.controls.take_changes()
        if self._wanted is None or changed & _MODEL_KEYS:
            self._request(self.inputs_from_controls())
        self._collect()
        rev = self.revolution
        if rev is None:
            return
        compliant = bool(self.controls.value("compliant"))
        if compliant != self.compliant:
            self.compliant = compliant
            self._restart_run()
            self._angle = 0.0
            for plot in self.gui.run_plots.values():
                plot.visible = compliant
            self._pending.add("info")  # (its advice on the toggle)
        playing = bool(self.controls.value("animate"))
        turn = float(self.controls.value("turn_seconds"))
        wall = min(max(dt, 0.0), _MAX_FRAME_DT) if playing else 0.0
        show = bool(self.controls.value("show_contact"))
        self._since_readout += dt
        with self.target.atomic():
            if not self._labels_shown and self.frames >= self._labels_due:
                self._labels_shown = True
                for label in self.labels.values():
                    label.visible = True
            if self.compliant:
                self._frame_compliant(rev, wall, turn, show, playing)
            else:
                self._frame_closed_form(rev, wall, turn, show, playing)
            self._refresh_one()

    def _readout_due(self, key: tuple, playing: bool) -> bool:
        """Whether to rewrite the readout for what is drawn (``key``): at most every
        0.2 s while turning, at once when the clock stands."""
        if key == self._readout_key or (playing and self._since_readout < _REFRESH_PERIOD):
            return False
        self._readout_key = key
        self._since_readout = 0.0
        return True

    # -- closed form --------------------------------------------------------------------
    def _frame_closed_form(self, rev: Revolution, wall: float, turn: float, show: bool, playing: bool) -> None:
        self._angle = (self._angle + 2.0 * math.pi * wall / turn) % (2.0 * math.pi)
        i = rev.index_of(self._angle)
        key = ("closed", i, show, self.revision)
        if key != self._drawn:
            self._drawn = key
            self.drawn_revision = self.revision
            self.index = i
            theta = rev.angle(i)
            self.cam_angle = theta
            self.force = float(rev.force[i])
            self.follower_z = float(rev.follower_z[i])
            contact = (float(rev.contact[i, 0]), float(rev.contact[i, 1]))
            normal = (float(rev.normal[i, 0]), float(rev.normal[i, 1]))
            self._draw(theta, self.follower_z, contact, normal, self.force, show, in_contact=True)
        if self._readout_due(("closed", i, self.revision, turn), playing):
            self.gui.readout.content = self._readout_closed(rev, i, turn)

    def _readout_closed(self, rev: Revolution, i: int, turn: float) -> str:
        force = float(rev.force[i])
        state = "pressing" if force >= 0.0 else "< 0: the contact would have to pull; a real follower leaves the cam"
        return "\n".join([
            f"**θ** = {math.degrees(rev.angle(i)):.2f}° · **s** = {1000.0 * float(rev.lift[i]):.4f} mm  ",
            f"**v** = ω s′ = {float(rev.velocity[i]):.4f} m/s · **a** = ω² s″ = "
            f"{float(rev.acceleration[i]):.2f} m/s²  ",
            f"**N** = {force:.3f} N ({state})  ",
            _slow_motion_text(turn, rev.speed),
        ])

    # -- compliant run --------------------------------------------------------------------
    def _frame_compliant(self, rev: Revolution, wall: float, turn: float, show: bool, playing: bool) -> None:
        period = 2.0 * math.pi / rev.speed
        self.timeline.chunk_at(self.sim_time, ahead=0.0)  # the next revolution as soon as this one is in
        self.sim_time, chunk, self.waiting = self.timeline.advance(self.sim_time, period * wall / turn)
        if self.timeline.error is not None:
            if not self._error_reported:
                self._error_reported = True
                self.notify("Compliant run stopped",
                            f"{self.timeline.error}. Showing the closed form again; turn the compliant contact "
                            "on to try again.", "warning")
                self.controls.set("compliant", False)
            return
        if chunk is None:
            if self._readout_due(("waiting", self.revision), False):
                self.gui.readout.content = "*Computing the compliant run (one revolution at a time)…*"
            return
        self.run_chunk = chunk
        x = (self.sim_time - chunk.t0) / chunk.h
        j = min(max(int(x), 0), chunk.theta.size - 2)
        w = min(max(x - j, 0.0), 1.0)
        near = j + 1 if w >= 0.5 else j
        lift = float(chunk.lift[j] + w * (chunk.lift[j + 1] - chunk.lift[j]))
        limit = self._travel_limit()
        if lift > limit:
            self._error_reported = True
            inputs = rev.inputs
            spring = (f"the spring (k = {inputs.stiffness:g} N/m, F0 = {inputs.preload:g} N)" if inputs.stiffness
                      or inputs.preload else "gravity alone (k = 0, F0 = 0)")
            self.notify("Compliant run stopped",
                        f"The follower flew to the end of its travel, {1000.0 * limit:.0f} mm above its lowest "
                        "position (its spring would be solid there, and this model has no stop): at "
                        f"{inputs.rpm:g} rpm {spring} cannot keep it near the cam. Raise the "
                        "stiffness or the preload, or lower the cam speed. Showing the closed form again.",
                        "warning")
            self.controls.set("compliant", False)
            return
        key = ("run", chunk.k, j, w, show, self.revision)
        if key != self._drawn:
            self._drawn = key
            self.drawn_revision = self.revision

            def lerp(a: np.ndarray) -> float:
                return float(a[j] + w * (a[j + 1] - a[j]))

            theta = rev.speed * self.sim_time
            self.cam_angle = theta % (2.0 * math.pi)
            self.follower_z = lerp(chunk.follower_z)
            self.force = lerp(chunk.force)
            contact = (lerp(chunk.point[:, 0]), lerp(chunk.point[:, 1]))
            nx, nz = lerp(chunk.normal[:, 0]), lerp(chunk.normal[:, 1])
            norm = math.hypot(nx, nz) or 1.0
            in_flight = not chunk.constraint[near] and lerp(chunk.gap) > 0.0
            self._draw(theta, self.follower_z, contact, (nx / norm, nz / norm), self.force, show,
                       in_contact=not in_flight)
        if self._readout_due(("run", chunk.k, near, self.waiting, turn), playing):
            self.gui.readout.content = self._readout_run(rev, chunk, near, turn)
        if chunk.k != self._run_plot_k:
            self._run_plot_k = chunk.k
            self._pending |= {"run_lift", "run_force"}

    def _readout_run(self, rev: Revolution, chunk: RunChunk, j: int, turn: float) -> str:
        gap = float(chunk.gap[j])
        if gap > 0.0 and not chunk.constraint[j]:
            contact = f"**in flight**: gap {1000.0 * gap:.3f} mm, N = 0"
        elif chunk.constraint[j]:
            contact = f"**on the cam** (contact constraint): N = {float(chunk.force[j]):.3f} N"
        else:
            contact = (f"**on the cam** (Hunt-Crossley, pressed in {significant(1e6 * -gap, 3)} µm): "
                       f"N = {float(chunk.force[j]):.3f} N")
        now = float(chunk.t0 + j * chunk.h)
        left = int(np.count_nonzero(chunk.separations <= now))
        landed = int(np.count_nonzero(chunk.landings <= now))
        events = f"so far this revolution: {left} separation(s), {landed} landing(s)"
        lines = [
            f"**t** = {1000.0 * float(chunk.t0 + j * chunk.h):.2f} ms (revolution {chunk.k + 1}) · **θ** = "
            f"{math.degrees(float(chunk.theta[j]) % (2.0 * math.pi)):.1f}°  ",
            f"follower lift {1000.0 * float(chunk.lift[j]):.3f} mm, cam under it "
            f"{1000.0 * float(chunk.cam_lift[j]):.3f} mm  ",
            contact + "  ",
            events + "  ",
        ]
        if self.waiting:
            lines.append("*computing the next revolution…*  ")
        lines.append(_slow_motion_text(turn, rev.speed))
        return "\n".join(lines)

    # -- drawing ------------------------------------------------------------------------------
    def _draw(self, theta: float, follower_z: float, contact: tuple[float, float], normal: tuple[float, float],
              force: float, show: bool, *, in_contact: bool) -> None:
        geometry = self.geometry
        half = 0.5 * theta
        set_pose(self.cam_frame, wxyz=(math.cos(half), 0.0, 0.0, math.sin(half)))
        set_pose(self.follower_frame, position=(0.0, 0.0, follower_z))
        z0 = follower_z + geometry.spring_seat
        set_arrays(self.spring, batched_positions=((0.0, 0.0, z0),),
                   batched_scales=((1.0, 1.0, (geometry.spring_top - z0) / self._spring_reference),))
        self.contact_frame.visible = show
        if not show:
            return
        set_pose(self.contact_point, position=(contact[0], _Y_FRONT, contact[1]),
                 wxyz=wxyz_z_to((normal[0], 0.0, normal[1]), 1.0))
        if self.normal_line.visible != in_contact:  # in flight there is no contact normal to draw
            self.normal_line.visible = in_contact
        drawn = in_contact and force != 0.0
        self.arrow.visible = drawn
        self.force_label.visible = drawn and self._labels_shown
        if drawn:
            length, pressing = _arrow_length(force), force >= 0.0
            sent, sent_pressing = self._arrow_sent
            if pressing != sent_pressing or abs(length - sent) > 0.02 * sent:
                self._arrow_sent = (length, pressing)
                color = _FORCE_COLOR if pressing else _PULL_COLOR
                set_arrays(self.arrow, points=_arrow(length, force), colors=np.array([color], dtype=np.uint8))
            # the label at the arrow's tail (the end away from the contact point), in global coordinates
            tail = self._arrow_sent[0]
            set_pose(self.force_label,
                     position=(contact[0] - tail * normal[0], _Y_FRONT, contact[1] - tail * normal[1]))

    def _refresh_one(self) -> None:
        """One pending panel or buffer update per frame (meshes, info, marks, one plot)."""
        if not self._pending:
            return
        what = next(name for name in _REFRESH_ORDER if name in self._pending)
        self._pending.discard(what)
        rev, gui, geometry = self.revolution, self.gui, self.geometry
        if what == "meshes":
            self._send_spring_mesh()
            set_arrays(self.cam_mesh, vertices=geometry.cam_mesh[0], faces=geometry.cam_mesh[1])
            set_arrays(self.stand, vertices=geometry.stand_mesh[0], faces=geometry.stand_mesh[1])
            kind = "roller" if geometry.roller_mesh is not None else "flat"
            mesh = self.follower_meshes[kind]
            set_arrays(mesh, vertices=geometry.follower_mesh[0], faces=geometry.follower_mesh[1])
            for name, handle in self.follower_meshes.items():
                handle.visible = name == kind
            if geometry.roller_mesh is not None:
                set_arrays(self.roller_mesh, vertices=geometry.roller_mesh[0], faces=geometry.roller_mesh[1])
            self.roller_mesh.visible = geometry.roller_mesh is not None
            set_pose(self.labels["follower"], position=_follower_label(geometry))
            set_pose(self.labels["spring"], position=_spring_label(geometry))
        elif what == "info":
            gui.info.content = self._info(rev)
        elif what == "marks":
            if rev.separation_segments is not None:
                set_array(self.separation_arc, "points", rev.separation_segments)
            self.separation_arc.visible = rev.separation_segments is not None
        elif what in gui.plots:
            gui.plots[what].data = rev.plot_data(what)
        elif self.run_chunk is not None:
            chunk = self.run_chunk
            x = run_plot_angles(chunk)
            if what == "run_lift":
                gui.run_plots[what].data = (x, 1000.0 * chunk.cam_lift, 1000.0 * chunk.lift)
            else:
                (lo, hi), peak = run_force_range(chunk)
                plot = gui.run_plots[what]
                plot.scales = {**_X_SCALE, "y": {"auto": False, "range": [lo, hi]}}
                label = _RUN_FORCE_LABEL + ("" if peak is None else f", peak {_newtons(peak)} off scale")
                if plot.series[2]["label"] != label:
                    plot.series = (*plot.series[:2], {**plot.series[2], "label": label})
                plot.data = (x, chunk.closed_force, chunk.force)

    def _info(self, rev: Revolution) -> str:
        inputs = rev.inputs
        jump_rpm = rev.jump_speed * 30.0 / math.pi
        lines = [
            f"**jump speed = {jump_rpm:.1f} rpm** ({rev.jump_speed:.3f} rad/s); the cam turns at "
            f"{inputs.rpm:g} rpm, {100.0 * rev.speed / rev.jump_speed:.1f} % of it.",
        ]
        if rev.separations:
            then = ("The compliant run (its plots below) shows the follower leave the cam and land."
                    if self.compliant else "Turn on *Compliant contact* to see the follower jump.")
            lines.append(f"**Separation**: N < 0 from {_interval_text(rev.separations)} (shaded); the contact "
                         f"would have to pull. {then}")
        else:
            n_min, at = rev.min_force
            lines.append(f"**No separation**: N > 0 all round (smallest {n_min:.3f} N at θ = {_deg(at):.2f}°).")
        if inputs.profile == PROFILES[0]:
            cam = f"eccentric circle R = {1000 * ECCENTRIC_RADIUS:g} mm, e = {1000 * ECCENTRICITY:g} mm"
        else:
            cam = (f"{_LAWS[inputs.profile]} rise-dwell-return, base circle {1000 * BASE_RADIUS:g} mm, lift "
                   f"{1000 * LIFT:g} mm, rise = fall = {inputs.rise_deg:g}°, dwell {DWELL_DEG:g}°")
        follower = "flat face" if inputs.follower == FOLLOWERS[0] else f"roller r = {inputs.roller_mm:g} mm"
        lines.append(f"Cam: {cam}; follower: {follower}, m = {inputs.mass:g} kg, k = {inputs.stiffness:g} N/m, "
                     f"F0 = {inputs.preload:g} N, g = {GRAVITY:g} m/s² towards the cam.")
        return "\n\n".join(lines)

    # -- export -----------------------------------------------------------------------------
    def csv_bytes(self) -> bytes:
        """One revolution of the closed form in use (CSV, 15 significant digits; cached per revolution)."""
        rev = self.revolution
        if rev is None:
            return (CSV_HEADER + "\n").encode()
        if self._csv is None or self._csv[0] is not rev:
            self._csv = (rev, rev.csv())
        return self._csv[1]


_MODEL_KEYS = frozenset(f.name for f in dataclasses.fields(Inputs))


def _follower_label(geometry: Geometry) -> tuple[float, float, float]:
    return (0.008, _Y_FRONT, geometry.label_follower - 0.004)


def _spring_label(geometry: Geometry) -> tuple[float, float, float]:
    return (0.016, _Y_FRONT, geometry.spring_top - 0.02)
