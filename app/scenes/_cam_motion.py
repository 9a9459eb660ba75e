"""The cam-follower scene's motion: the cams its panel offers as core's models, and their revolutions as chunks.

What the jobs of :class:`rigidlab.app.scenes.cam_follower.CamFollowerScene` run on the executor (picklable,
module-level): :func:`build_cam` makes core's :class:`rigidlab.core.models.CamFollower` of the panel's
:class:`Inputs` or refuses it in the panel's terms (rise = fall in degrees, roller in mm);
:func:`compute_revolution` and :func:`closed_form_chunk` give the closed form
(:meth:`rigidlab.core.models.CamFollower.revolution`, rows every 0.25 deg, chunk k the same a period later),
:func:`compute_chunk` the compliant run (:meth:`~rigidlab.core.models.CamFollower.simulate`, 180 outputs per
revolution, from the previous revolution's ``final_state``; DOP853 at rtol 1e-8, atol 1e-10: against 1e-8, 1e-6
moved the lift by 12-47 um and the impact peaks by 54-175 N, which a plot shows, for 20-30 % less cost). A
chunk is one revolution (:class:`Chunk`), holding core's results as they are.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from rigidlab.app.scenes._cam import CamLayout, cam_layout
from rigidlab.app.scenes._plots import Table
from rigidlab.app.scenes._simulation import InputsRefused
from rigidlab.core import ArgumentError
from rigidlab.core.models import CamFollower, CamMotion, CamProfile, CamRevolution, smallest_convex_rise

__all__ = ["BASE_RADIUS", "DWELL_DEG", "ECCENTRICITY", "ECCENTRIC_RADIUS", "FOLLOWERS", "GRAVITY", "LIFT", "PROFILES",
           "REVOLUTION_SAMPLES", "RISE_DEG_RANGE", "ROLLER_MM_RANGE", "RUN_SAMPLES", "Chunk", "Inputs", "build_cam",
           "closed_form_chunk", "compute_chunk", "compute_revolution"]

PROFILES = ("Eccentric circle", "Rise-dwell-return, cycloidal", "Rise-dwell-return, harmonic",
            "Rise-dwell-return, 3-4-5")
_LAWS = {PROFILES[1]: "cycloidal", PROFILES[2]: "harmonic", PROFILES[3]: "345"}
FOLLOWERS = ("Flat-faced", "Roller")
ECCENTRIC_RADIUS, ECCENTRICITY = 0.04, 0.01  # m
BASE_RADIUS, LIFT, DWELL_DEG = 0.04, 0.02, 30.0  # rise-dwell-return cams (m, m, deg)
RISE_DEG_RANGE, ROLLER_MM_RANGE = (30.0, 150.0), (2.0, 40.0)  # the sliders' ranges
GRAVITY = 9.81  # m/s^2 along the follower axis towards the cam
REVOLUTION_SAMPLES, RUN_SAMPLES = 1440, 180  # per revolution: the closed form's table, the run's outputs
_RUN = {"on_separation": "compliant", "rtol": 1e-8, "atol": 1e-10,  # (module docstring); Hunt-Crossley N/m^1.5, s/m
        "contact_stiffness": 1e8, "contact_damping": 0.5}


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
    or before a state loads): a new shape costs about 5 ms, a refused roller about 40 ms (core's refusal finds the
    largest roller, once)."""
    key = inputs.geometry_key()
    refusal = _refusal(key)
    if refusal is not None:
        raise InputsRefused(refusal)
    return _cam(key) if shape_only else _cam(key, inputs.mass, inputs.stiffness, inputs.preload)


@functools.lru_cache(maxsize=256)
def _refusal(key: tuple) -> str | None:
    """Why core refuses the shape ``key`` in the panel's terms (by ``ArgumentError.argument``, and its ``limit``:
    the largest roller that does not undercut the cam), or None."""
    law, _, rise, roller = key
    try:
        _cam(key)
    except ArgumentError as exc:
        r = exc.limit if exc.argument == "roller_radius" and law and exc.limit is not None else 0.0
        if r >= 1e-3 * ROLLER_MM_RANGE[0]:
            return (f"Roller radius: a {roller:g} mm roller would undercut this cam (rise = fall = {rise:g}°; the "
                    "roller centre's path curves more sharply than the roller); use a roller of at most "
                    f"{math.floor(r * 2000.0) / 2.0:g} mm or a longer rise")
        if exc.argument == "base_radius" and law:
            fits = math.ceil(math.degrees(smallest_convex_rise(BASE_RADIUS, LIFT, math.radians(DWELL_DEG), law)))
            advice = f"a rise of at least {fits}° or " if fits <= RISE_DEG_RANGE[1] else ""
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
    layout: CamLayout | None = None  # what is drawn (closed form's chunks only)
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
                 layout=cam_layout(_cam(inputs.geometry_key())), cam=cam)


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
