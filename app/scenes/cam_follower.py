"""Cam-follower scene: a disk cam at constant speed drives a spring-loaded translating follower.

A :class:`~rigidlab.app.scenes._simulation.SimulationScene` whose chunk is one revolution, drawn from core's results as they
are: the closed form (:meth:`rigidlab.core.models.CamFollower.revolution`, rows every 0.25 deg, chunk k the same a period
later) or the compliant run (:meth:`~rigidlab.core.models.CamFollower.simulate`, 180 outputs, from the previous revolution's
``final_state``; DOP853 at rtol 1e-8, atol 1e-10: against 1e-8, 1e-6 moved the lift by 12-47 um and the impact
peaks by 54-175 N, which a plot shows, for 20-30 % less cost). The help text states the equations (8.84-8.109).

Frames (global, metres): the cam shaft is the global y axis, the profile plane is the x-z plane (profile x ->
global x, profile y -> global z, as in :meth:`CamFollower.build_system`), the follower slides along +z above the
shaft; the cam turns about -y by the cam angle theta (theta = 0: lowest lift).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import trimesh

from rigidlab.app.controls import Choice, Slider, Toggle
from rigidlab.app.meshes import box, cylinder_z, extrude, follower_stand, pack, translating_follower
from rigidlab.app.nodes import set_array, set_arrays, set_pose, set_visible, wxyz_z_to
from rigidlab.app.scenes._arrows import vertex_rgb
from rigidlab.app.scenes._bodies import CoilSpring, ForceArrow
from rigidlab.app.scenes._plots import Table, format_rows
from rigidlab.app.scenes._shapes import closed_path_segments
from rigidlab.app.scenes._simulation import InputsRefused, PlotSpec, SimulationScene
from rigidlab.core import ArgumentError
from rigidlab.core.models import CamFollower, CamMotion, CamProfile, CamRevolution, largest_roller_radius, smallest_convex_rise

__all__ = ["CSV_HEADER", "CamFollowerScene", "Chunk", "FOLLOWERS", "Inputs", "Layout", "PROFILES",
           "REVOLUTION_SAMPLES", "RUN_SAMPLES", "build_cam", "compute_chunk", "compute_revolution", "layout"]

PROFILES = ("Eccentric circle", "Rise-dwell-return, cycloidal", "Rise-dwell-return, harmonic",
            "Rise-dwell-return, 3-4-5")
_LAWS = {PROFILES[1]: "cycloidal", PROFILES[2]: "harmonic", PROFILES[3]: "345"}
FOLLOWERS = ("Flat-faced", "Roller")
ECCENTRIC_RADIUS, ECCENTRICITY = 0.04, 0.01  # m
BASE_RADIUS, LIFT, DWELL_DEG = 0.04, 0.02, 30.0  # rise-dwell-return cams (m, m, deg)
_RISE_DEG, _ROLLER_MM = (30.0, 150.0), (2.0, 40.0)  # slider ranges
GRAVITY = 9.81  # m/s^2 along the follower axis towards the cam
REVOLUTION_SAMPLES, RUN_SAMPLES, _CONTOUR_POINTS = 1440, 180, 720  # per revolution: table, run outputs, contour
_RUN = {"on_separation": "compliant", "rtol": 1e-8, "atol": 1e-10,  # (module docstring); Hunt-Crossley N/m^1.5, s/m
        "contact_stiffness": 1e8, "contact_damping": 0.5}
CSV_HEADER = "cam angle (deg),lift (m),velocity (m/s),acceleration (m/s^2),contact force (N)"
# drawing (m): the cam is 12 mm thick, the contact marks lie in front of it (y = _Y_FRONT); the spring is never
# drawn shorter than _SPRING_MIN_LENGTH on the cam
_CAM_THICKNESS, _Y_FRONT, _SPRING_MIN_LENGTH, _ARM, _BASE_Z = 0.012, -0.012, 0.045, 0.008, -0.085
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

    speed = property(lambda self: self.rpm * math.pi / 30.0, doc="Cam speed omega (rad/s).")

    def geometry_key(self) -> tuple:
        law, roller = _LAWS.get(self.profile), self.follower == FOLLOWERS[1]
        return (law, "roller" if roller else "flat", self.rise_deg if law else None, self.roller_mm if roller else None)


def build_cam(inputs: Inputs, *, shape_only: bool = False) -> CamFollower:
    """The :class:`rigidlab.core.models.CamFollower` of ``inputs``, or :class:`~rigidlab.app.scenes._simulation.InputsRefused` in the
    panel's terms (rise = fall in degrees, roller in mm) naming the value that works. Only the cam's shape can be
    refused (the sliders keep ``F0 + m g > 0``): ``shape_only`` checks it alone. Off the loop thread (in the job,
    or before a state loads): a new shape costs about 5 ms, a refusal 25-75 ms (core names the largest roller)."""
    key = inputs.geometry_key()
    refusal = _refusal(key)
    if refusal is not None:
        raise InputsRefused(refusal)
    return _cam(key) if shape_only else _cam(key, inputs.mass, inputs.stiffness, inputs.preload)


@functools.lru_cache(maxsize=256)
def _refusal(key: tuple) -> str | None:
    """Why core refuses the shape ``key`` in the panel's terms (by ``ArgumentError.argument``), or None."""
    law, _, rise, roller = key
    try:
        _cam(key)
    except ArgumentError as exc:
        r = largest_roller_radius(_profile(law, rise)) if exc.argument == "roller_radius" and law else 0.0
        if r >= 1e-3 * _ROLLER_MM[0]:
            return (f"Roller radius: a {roller:g} mm roller would undercut this cam (rise = fall = {rise:g}°; the "
                    "roller centre's path curves more sharply than the roller); use a roller of at most "
                    f"{math.floor(r * 2000.0) / 2.0:g} mm or a longer rise")
        if exc.argument == "base_radius" and law:
            fits = math.ceil(math.degrees(smallest_convex_rise(BASE_RADIUS, LIFT, math.radians(DWELL_DEG), law)))
            advice = f"a rise of at least {fits}° or " if fits <= _RISE_DEG[1] else ""
            return (f"Flat-faced follower: at rise = fall = {rise:g}° the cam would not be convex (its radius of "
                    f"curvature R_b + s + s″ turns negative, and a flat face would bridge the hollow); use {advice}the "
                    "roller follower")
        return str(exc)
    return None


def _profile(law: str | None, rise_deg: float | None) -> CamProfile:
    if law is None:
        return CamProfile.eccentric(radius=ECCENTRIC_RADIUS, eccentricity=ECCENTRICITY)
    rise = math.radians(rise_deg)
    return CamProfile.rise_dwell_return(base_radius=BASE_RADIUS, lift=LIFT, rise=rise, dwell=math.radians(DWELL_DEG),
                                        fall=rise, law=law)


@functools.lru_cache(maxsize=256)
def _cam(key: tuple, mass: float = 0.5, stiffness: float = 2000.0, preload: float = 20.0) -> CamFollower:
    law, kind, rise_deg, roller_mm = key
    return CamFollower(_profile(law, rise_deg), follower=kind, roller_radius=(roller_mm or 0.0) / 1000.0, mass=mass,
                       stiffness=stiffness, preload=preload, gravity=GRAVITY)


@dataclasses.dataclass(frozen=True)
class Layout:
    """What is drawn of a cam and follower: meshes ``(vertices, faces)``, the cam's in its body frame (profile =
    body x-y), the follower's in its frame (:func:`rigidlab.app.meshes.translating_follower`), the stand's global; metres."""

    key: tuple  # Inputs.geometry_key()
    contour: np.ndarray  # (_CONTOUR_POINTS, 2) the cam's contour (core's cam_curve), body frame
    cam: tuple
    follower: tuple
    roller: tuple | None
    stand: tuple
    pitch_height: float  # global z of the follower's origin at zero lift
    seat: float  # the spring's seat above the follower's origin
    spring_top: float  # global z
    stem_top: float  # global z at zero lift
    spring_length: float  # the spring's length in the middle of its travel (its mesh is built at it)


@functools.lru_cache(maxsize=32)
def layout(key: tuple) -> Layout:
    """The :class:`Layout` of ``Inputs.geometry_key()`` (its follower must fit the cam: :func:`build_cam`)."""
    cam = _cam(key)
    u = np.arange(_CONTOUR_POINTS) * (2.0 * math.pi / _CONTOUR_POINTS)
    contour, kin, pitch = np.asarray(cam.cam_curve(u).point), cam.kinematics(u), float(cam.pitch_curve(0.0).point[1])
    top = float(np.max(kin.lift))
    travel = top + _SPRING_MIN_LENGTH + _ARM + 0.015  # the stem's length above the spring's seat
    follower, roller, seat = translating_follower(  # a flat face reaches past the farthest contact point, |s'|
        travel=travel, face_halfwidth=float(np.max(np.abs(kin.dlift))) + 0.008, roller_radius=cam.roller_radius)
    spring_top = pitch + top + seat + _SPRING_MIN_LENGTH
    return Layout(key, contour.astype(np.float32), pack(extrude(contour, -_CAM_THICKNESS / 2, _CAM_THICKNESS / 2)),
                  follower, roller, follower_stand(spring_top, base=_BASE_Z, arm=_ARM), pitch, seat, spring_top,
                  pitch + seat + travel, 0.5 * (top + 2.0 * _SPRING_MIN_LENGTH))


@dataclasses.dataclass(frozen=True)
class Chunk:
    """Revolution ``k`` of the motion, rows at times ``t``: the closed form (``closed``: core's table of the
    revolution, rows every 0.25 deg; ``table``: cam angle (deg), lift (mm), v, a, N and N at the jump speed) or the
    compliant run (``run``: core's run over the revolution, 180 outputs; ``table``: the cam angle in the revolution
    (deg), the cam's lift under the follower and the follower's lift (mm), the closed-form and the run's force)."""

    k: int
    t: np.ndarray  # (n,) s
    table: Table
    inputs: Inputs
    closed: CamRevolution | None = None
    run: CamMotion | None = None
    revolution: Chunk | None = None  # the closed form's chunk 0 (run revolution 0 only; else None)
    layout: Layout | None = None  # what is drawn (closed form's chunks only)
    cam: CamFollower | None = None  # (closed form's chunks only)

    def later(self, k: int) -> Chunk:
        """Chunk ``k``: this revolution ``k - self.k`` periods later."""
        t = self.t + (k - self.k) * 2.0 * math.pi / self.inputs.speed
        return dataclasses.replace(self, k=k, t=t, table=Table.build(t, self.table.columns))


@functools.lru_cache(maxsize=8)
def compute_revolution(inputs: Inputs) -> Chunk:
    """Revolution 0 of the closed form of ``inputs`` (on the executor)."""
    inputs = dataclasses.replace(inputs, compliant=False)
    cam = build_cam(inputs)
    rev = cam.revolution(inputs.speed, samples=REVOLUTION_SAMPLES)
    columns = np.column_stack([np.degrees(rev.theta), 1000.0 * rev.lift, rev.velocity, rev.acceleration,
                               rev.contact_force, rev.force_at_jump])
    if not (np.all(np.isfinite(columns)) and np.all(np.isfinite(rev.contact_point))):
        raise ValueError("the closed form gave a non-finite value; choose other parameters")
    return Chunk(0, rev.theta / rev.speed, Table.build(rev.theta / rev.speed, columns), inputs, rev,
                 layout=layout(inputs.geometry_key()), cam=cam)


def closed_form_chunk(inputs: Inputs, k: int, previous: Chunk | None) -> Chunk:
    """Chunk ``k`` of the closed form: revolution 0 of ``inputs``, ``k`` periods on (the motion is periodic)."""
    revolution = previous or compute_revolution(inputs)
    return revolution if revolution.k == k else revolution.later(k)


def compute_chunk(inputs: Inputs, k: int, previous: Chunk | None) -> Chunk:
    """Revolution ``k`` of the compliant run of ``inputs`` (on the executor): :meth:`CamFollower.simulate`
    continuing from ``previous.run.final_state`` (revolution ``k - 1``), or ``previous`` a period later when that
    run is periodic (core's ``CamMotion.periodic``: on the cam throughout, it has no degree of freedom there)."""
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: revolution {k} continues from revolution {k - 1}, which was not given")
    if previous is not None and previous.run.periodic:
        return dataclasses.replace(previous.later(k), revolution=None)
    cam, w = build_cam(inputs), inputs.speed
    times = (k + np.arange(RUN_SAMPLES + 1) / RUN_SAMPLES) * 2.0 * math.pi / w
    run = cam.simulate(w, times, initial=None if previous is None else previous.run.final_state, **_RUN)
    for name in ("lift", "contact_force", "contact_point", "gap"):
        if not np.all(np.isfinite(getattr(run, name))):
            raise ValueError(f"{name}: the run left the finite range in revolution {k + 1}")
    theta = run.cam_angle  # (the plots' x rounded to 1e-9 deg: uPlot drops the 0 tick for 5.7e-14)
    columns = np.column_stack([np.round(np.degrees(theta) - 360.0 * k, 9), 1000.0 * cam.kinematics(theta).lift,
                               1000.0 * run.lift, cam.contact_force(theta, w), run.contact_force])
    return Chunk(k, run.t, Table.build(run.t, columns), inputs, run=run,
                 revolution=compute_revolution(inputs) if k == 0 else None)


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
        self.layout, self.run_chunk = layout(Inputs().geometry_key()), None
        self.cam_angle = self.force = self.follower_z = 0.0  # drawn: rad, N, m
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
        scene, root, flat = self.target.scene, self.root, self.layout
        roller = layout(Inputs(follower=FOLLOWERS[1]).geometry_key())
        self.add_ground_grid(width=0.6, height=0.4, position=(0.0, 0.0, _BASE_Z - 0.0081), cell_size=0.01,
                             section_size=0.05)
        self.stand = scene.add_mesh_simple(f"{root}/stand", *flat.stand, color=_STAND_COLOR)
        scene.add_frame(f"{root}/cam_plane", show_axes=False, wxyz=(math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0))
        self.cam_frame = scene.add_frame(f"{root}/cam_plane/cam", show_axes=False)
        self.cam_mesh = scene.add_mesh_simple(f"{root}/cam_plane/cam/body", *flat.cam, color=_CAM_COLOR)
        hub = trimesh.util.concatenate([cylinder_z(0.006, -0.022, _CAM_THICKNESS / 2 + 0.004),  # shaft, index stripe
                                        box((-0.0015, 0.008, _CAM_THICKNESS / 2), (0.0015, 0.028, 0.0068))])
        scene.add_mesh_simple(f"{root}/cam_plane/cam/hub", *pack(hub), color=_HUB_COLOR)
        self.separation_arc = self.add_lines(f"{root}/cam_plane/cam/separation", np.zeros((_CONTOUR_POINTS, 2, 3)),
                                             vertex_rgb(np.full((_CONTOUR_POINTS, 2, 3), _PULL_COLOR)), thickness=5.0,
                                             thickness_units="screen", visible=False)
        self.follower_frame = scene.add_frame(f"{root}/follower", show_axes=False, position=(0, 0, flat.pitch_height))
        self.follower_meshes = {"flat": scene.add_mesh_simple(f"{root}/follower/flat", *flat.follower,
                                                              color=_FOLLOWER_COLOR),
                                "roller": scene.add_mesh_simple(f"{root}/follower/fork", *roller.follower,
                                                                color=_FOLLOWER_COLOR, visible=False)}
        self.roller_mesh = scene.add_mesh_simple(f"{root}/follower/roller", *roller.roller, color=_ROLLER_COLOR,
                                                 visible=False)
        self.spring = CoilSpring(self, f"{root}/spring", radius=0.011, turns=7, wire=0.0011, color=_SPRING_COLOR,
                                 length=flat.spring_length)
        self.contact_frame = scene.add_frame(f"{root}/contact", show_axes=False)
        # at the contact point, +z along the common normal: one pose moves the dot, the normal and the arrow
        self.contact_point = scene.add_frame(f"{root}/contact/point", show_axes=False)
        scene.add_icosphere(f"{root}/contact/point/dot", radius=0.0026, color=_POINT_COLOR, subdivisions=2)
        self.normal_line = self.add_lines(f"{root}/contact/point/normal", [[(0, 0, -_NORMAL_HALF),
                                          (0, 0, _NORMAL_HALF)]], vertex_rgb([[_NORMAL_COLOR] * 2]), thickness=2.5,
                                          thickness_units="screen")
        self.force_arrow = ForceArrow(self, f"{root}/contact/point/force", _FORCE_COLOR, tip_at_point=True,
                                      sizes={"shaft_radius": 0.0016, "head_radius": 0.004, "head_length": 0.008})
        self.force_label = self.add_label(f"{root}/contact/label", "N", anchor="top-right", scale=1.3)
        self.labels = {name: self.add_label(f"{root}/label_{name}", text, position=(x, _Y_FRONT, z), anchor=anchor,
                                            scale=1.3) for name, text, x, z, anchor in (
            ("cam", "cam (turns at ω)", -0.048, -0.03, "center-right"),
            ("follower", "follower", 0.008, flat.stem_top - 0.004, "center-left"),
            ("spring", "spring k, F0", 0.016, flat.spring_top - 0.02, "center-left"))}

    def build_controls(self) -> None:
        d = Inputs()
        self.legend = self.add_legend((
            (_FORCE_COLOR, "N n: force of the cam on the follower (N > 0)"),
            (_PULL_COLOR, "N < 0: the contact would have to pull (separation interval)"),
            (_NORMAL_COLOR, "common normal at the contact point (hidden in flight)"),
            (_POINT_COLOR, "contact point (in flight: the cam's point nearest the follower)"),
        ), "Drawn on the cam (arrow length saturates):")
        self.status, self.info = self.add_readout("Computing the cam…"), self.add_readout("")
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

    def _travel_limit(self) -> float:
        """The largest lift (m) the stand allows: the drawn spring is solid there."""
        return self.layout.spring_top - self.layout.pitch_height - self.layout.seat - self.spring.solid

    # -- state, errors ----------------------------------------------------------------------------
    def extra_state(self) -> dict[str, Any]:
        """The cam angle shown (deg), so a paused scene is reproduced at its angle."""
        return {"cam_angle_deg": round(math.degrees(self.cam_angle), 9)}

    def load_extra_state(self, extra: dict[str, Any]) -> list[str]:
        refused = [f"{key!r}: not part of this scene's state" for key in extra if key != "cam_angle_deg"]
        value = extra.get("cam_angle_deg", 0.0)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 360.0:  # (nan too)
            refused.append(f"cam_angle_deg: expected a number from 0 to 360, got {value!r}")
        elif "cam_angle_deg" in extra:
            self._angle = math.radians(float(value))
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
        self.playback.set_playing(bool(self.controls.value("animate")))
        self.playback.set_time_scale(self.timeline.chunk_time / float(self.controls.value("turn_seconds")))
        if self._angle is not None and not self.compliant:  # a loaded angle, on the table's grid
            i = round(self._angle / (2.0 * math.pi) * REVOLUTION_SAMPLES) % REVOLUTION_SAMPLES
            self.local_time = self.sim_time = i * self.timeline.chunk_time / REVOLUTION_SAMPLES
            self._angle, self._drawn = None, None
        if bool(self.controls.value("show_contact")) != self.contact_frame.visible:  # (a click or a loaded state)
            self._drawn = None

    def _use(self, rev: Chunk) -> None:
        """Draw the closed form ``rev`` from now on: its meshes, info and separation arc."""
        self.revolution, self.revision, g = rev, self.revision + 1, rev.layout
        if g.key != self.layout.key:
            self.layout, kind = g, "flat" if g.roller is None else "roller"
            self.spring.rebuild(g.spring_length)
            for node, mesh in ((self.cam_mesh, g.cam), (self.stand, g.stand), (self.follower_meshes[kind], g.follower),
                               (self.roller_mesh, g.roller)):
                if mesh is not None:
                    set_arrays(node, vertices=mesh[0], faces=mesh[1])
            for name, handle in (*self.follower_meshes.items(), ("roller", self.roller_mesh)):
                handle.visible = name == kind
            set_pose(self.labels["follower"], position=(0.008, _Y_FRONT, g.stem_top - 0.004))
            set_pose(self.labels["spring"], position=(0.016, _Y_FRONT, g.spring_top - 0.02))
        self.info.content = self._info(rev)
        u = np.arange(_CONTOUR_POINTS) * (2.0 * math.pi / _CONTOUR_POINTS)
        front = np.column_stack([g.contour, np.full(_CONTOUR_POINTS, _CAM_THICKNESS / 2 + 0.0006)])
        arc = closed_path_segments(front, rev.closed.separated(u))  # on the cam's front face (body frame)
        if arc is not None:
            set_array(self.separation_arc, "points", arc)
        self.separation_arc.visible = arc is not None
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
            self._pose(lift, c.contact_point[i], c.contact_normal[i], show, in_contact=True)
            return
        self.run_chunk, now = chunk, run.t[0] + self.sim_time - chunk.t[0]  # (a repeated revolution: the run's clock)
        at = run.at(now)
        if at.lift > self._travel_limit():
            if not self._thrown:
                i = self.config
                spring = (f"the spring (k = {i.stiffness:g} N/m, F0 = {i.preload:g} N)" if i.stiffness or i.preload
                          else "gravity alone (k = 0, F0 = 0)")
                self._stop_run(f"The follower flew to the end of its travel, {1000.0 * self._travel_limit():.0f} mm "
                               "above its lowest position (its spring would be solid there, and this model has no "
                               f"stop): at {i.rpm:g} rpm {spring} cannot keep it near the cam. Raise the stiffness "
                               "or the preload, or lower the cam speed. Showing the closed form again.")
            return
        self.cam_angle, self.force = (chunk.inputs.speed * self.sim_time) % (2.0 * math.pi), at.contact_force
        self._pose(at.lift, at.contact_point[[0, 2]], at.contact_normal[[0, 2]], show, in_contact=at.in_contact)

    def _pose(self, lift: float, contact: np.ndarray, normal: np.ndarray, show: bool, *, in_contact: bool) -> None:
        theta, force, self.follower_z = self.cam_angle, self.force, self.layout.pitch_height + lift
        set_pose(self.cam_frame, wxyz=(math.cos(0.5 * theta), 0.0, 0.0, math.sin(0.5 * theta)))
        set_pose(self.follower_frame, position=(0.0, 0.0, self.follower_z))
        self.spring.span(self.follower_z + self.layout.seat, self.layout.spring_top)
        set_visible(self.contact_frame, show)
        if not show:
            return
        (x, z), (nx, nz) = (float(v) for v in contact), (float(v) for v in normal)
        set_pose(self.contact_point, position=(x, _Y_FRONT, z), wxyz=wxyz_z_to((nx, 0.0, nz), 1.0))
        set_visible(self.normal_line, in_contact)  # in flight there is no contact normal
        drawn = in_contact and force != 0.0  # (N n ends at the contact point)
        set_visible(self.force_label, drawn)
        self.force_arrow.show((0.0, 0.0, force) if drawn else None, scale=_ARROW_MAX, reference=_ARROW_HALF,
                              color=_FORCE_COLOR if force >= 0.0 else _PULL_COLOR)
        if drawn:
            tail = math.copysign(self.force_arrow.length, force)  # the label at the arrow's tail
            set_pose(self.force_label, position=(x - tail * nx, _Y_FRONT, z - tail * nz))

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
