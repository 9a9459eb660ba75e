"""Linkages scene: constrained multibody systems of :mod:`core.multibody`, computed in chunks.

Four models of :mod:`core.models`, chosen in the *Preset* dropdown:

* a chain of ``N`` pendulum links on revolute joints (:func:`core.models.pendulum_chain`),
  released at rest from a tilted straight pose;
* a spatial double pendulum on spherical joints (:func:`core.models.spatial_double_pendulum`);
* a slider-crank whose crank a motor turns at a set speed (:func:`core.models.slider_crank`);
* a heavy top on a spherical joint (:func:`core.models.heavy_top`), drawn beside
  a translucent copy that follows the gyroscope scene's exact motion of the
  same top (:func:`core.gyroscope.top_motion`).

Arrows at the joints show the reaction force each joint applies to its
``body_j`` (:meth:`core.multibody.MultibodyTrajectory.reaction`); plots show
the energy, its drift and the constraint residual ``max |C|`` live.

The scene holds no physics and does no long work on the loop thread. The
motion is computed on the app's executor in chunks of 1 s of simulated time
ahead of the display clock (:class:`app.jobs.ChunkTimeline`, sequential):
the job :func:`_compute_chunk` takes the frozen :class:`Model` (picklable
parameters), rebuilds the System from them in the worker, puts it in the final
state of the previous chunk and runs :meth:`core.multibody.System.simulate`
with the chosen integrator; the same job evaluates the reactions, the joint
points, the closed-form checks and the CSV rows. Each chunk carries the
model's :class:`_Setup` (what to draw, computed with chunk 0), so the loop
thread applies a new model only when its first chunk is ready. Per frame the
loop thread interpolates one row of samples and streams poses: one batched
mesh for all link rods, one for the joint spheres, one arrow buffer, and
the slider or the two tops; every node is created once in :meth:`build`.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import os
import time
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.controls import Choice, Slider, Toggle
from app.nodes import set_array, set_arrays, set_pose
from app.readout import one_digit, significant
from app.scenes._playback import Playback, PlaybackRequests
from app.scenes._plots import LOG_FLOOR, History, Legend, PlotRefresh, Table, log10_floor
from app.scenes.base import Scene
from app.jobs import ChunkTimeline
from core.gyroscope import RotorParams, top_motion
from core.models import heavy_top, pendulum_chain, slider_crank, spatial_double_pendulum
from core.multibody import ADAPTIVE_METHODS, FIXED_STEP_METHODS, JOINT_KINDS
from core.rigid_body import rotation_angle_between
from core.rotations import euler_parameters_from_euler_angles, rotate_vector

__all__ = [
    "CHAIN",
    "CRANK",
    "DOUBLE",
    "LinkagesScene",
    "Inputs",
    "METHODS",
    "Model",
    "POSITION_TOL",
    "PRESETS",
    "RESIDUAL_BOUND",
    "RTOLS",
    "STEPS",
    "TOP",
]

#: Preset names (the *Preset* dropdown).
CHAIN = "Pendulum chain (N links)"
DOUBLE = "Spatial double pendulum"
CRANK = "Slider-crank with motor"
TOP = "Heavy top vs closed form"
PRESETS = (CHAIN, DOUBLE, CRANK, TOP)
#: Integrators :meth:`core.multibody.System.simulate` accepts.
METHODS = tuple(ADAPTIVE_METHODS) + tuple(FIXED_STEP_METHODS)
#: Relative tolerances of the adaptive methods (atol is 100 times smaller).
RTOLS = ("1e-3", "1e-4", "1e-5", "1e-6", "1e-7", "1e-8", "1e-9", "1e-10")
#: Steps of the fixed-step methods (s); the samples are 1/60 s apart, so a
#: step is at most that.
STEPS = ("1/60", "1/120", "1/240", "1/480", "1/960")

#: Newton tolerance of simulate's position projection (its default): after
#: every step and at every output the positions are moved back onto
#: ``C(q, t) = 0`` until ``max |C| <= POSITION_TOL``.
POSITION_TOL = 1e-12
#: Bound on the constraint residual ``max |C|`` of every sample shown: the
#: projection stops early only at its round-off floor, below this bound, and
#: raises otherwise (the scene then stops with a notice); simulate also
#: refuses to continue from a state further off the constraints.
RESIDUAL_BOUND = 1e-8

# Models (SI units): chain of total length 2 m of 1 kg rods; rods of 1 m and
# 1 kg; slider-crank with r = 0.5 m, l = 1.5 m; the gyroscope scene's
# "cuspidal" top (I = 1, I3 = 0.8 kg m^2, mgl = 2 N m, theta0 = 50 deg,
# dpsi/dt = 8 rad/s) as a 1 kg body.
_GRAVITY = 9.81
_CHAIN_LENGTH = 2.0
_LINK_MASS = 1.0
_DOUBLE_LENGTH = 1.0
_CRANK_R, _CRANK_L = 0.5, 1.5
_CRANK_MASSES = (0.5, 1.0, 2.0)  # crank, rod, slider (kg): the builder's defaults
_TOP_PARAMS = RotorParams(I=1.0, I3=0.8, mgl=2.0)
_TOP_STATE0 = (0.0, math.radians(50.0), 0.0, 0.0, 0.0, 8.0)
_TOP_MASS = 1.0

_CHUNK_SIM_TIME = 1.0  # s of simulated time per chunk
_SAMPLES = 60  # samples per chunk (60 per simulated second), plus the chunk's start
_CHUNKS_KEPT = 8
_REFRESH_PERIOD = 0.25  # s of wall time between plot / readout refreshes (4 Hz; bytes: docs/app.md)
_WINDOW = 10.0  # s of simulated time in the plots and the CSV

# Drawing (metres). Every model hangs in its own frame ("model"), placed so
# that all four fit the one default view.
_MAX_RODS = 10
_MAX_JOINTS = 10
_ROD_RADIUS = {CHAIN: 0.032, DOUBLE: 0.036, CRANK: 0.04, TOP: 0.03}
_JOINT_RADIUS = {CHAIN: 0.055, DOUBLE: 0.06, CRANK: 0.065, TOP: 0.06}
_PLACEMENT = {  # model frame: position (global), rotation angle about +z (rad)
    CHAIN: ((0.0, 0.0, 2.45), 0.0),
    DOUBLE: ((0.0, 0.0, 2.45), 0.0),
    CRANK: ((0.0, -0.9, 1.0), math.pi / 2),  # the mechanism's x-z plane faces the camera
    # the two tops side by side across the default view (model +y along the screen's right)
    TOP: ((-0.51, -0.86, 1.1), -0.54),
}
_GHOST_OFFSET = (0.0, 2.0, 0.0)  # the closed-form top, beside the multibody one (model frame)
_SLIDER_SIDE = 0.5 * _CRANK_R  # the builder's cube of side r / 2
_TOP_DISC_RADIUS = 0.32
_TOP_AXLE_TIP = 0.6  # m above the centre of mass along the rotor axis
# Arrow lengths saturate at _ARROW_MAX: |F| / (|F| + W) with W the
# mechanism's weight (a joint carrying the whole weight gets half the maximum).
_ARROW_MAX = 0.9
_TORQUE_ARROW_MAX = 0.7
# Colours: links and joints neutral; arrows neither red, green nor blue.
_ROD_COLORS = ((96, 108, 128), (178, 184, 196))
_JOINT_COLOR = (40, 40, 48)
_FORCE_COLOR = (225, 80, 0)  # orange
_TORQUE_COLOR = (150, 60, 200)  # purple
_TOP_COLOR = (205, 172, 110)
_GHOST_COLOR = (140, 170, 255)
_SUPPORT_COLOR = (150, 150, 160)
_LABEL_SCALE = 1.3
_LABEL_RESEND_FRAMES = 30  # frames after a new model's first one (about 0.5 s)

#: The controls that define the motion (a change restarts it, if the model changes).
_MODEL_KEYS = frozenset({"preset", "n_links", "tilt_deg", "rpm", "method", "rtol", "dt"})


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's model and integrator controls."""

    preset: str = CHAIN
    n_links: int = 5
    tilt_deg: float = 60.0
    rpm: float = 60.0
    method: str = "DOP853"
    rtol: str = "1e-6"
    dt: str = "1/240"


_DEFAULT = Inputs()


@dataclasses.dataclass(frozen=True)
class Model:
    """What a chunk job needs: the model's parameters and the integrator (picklable, hashable).

    Only the parameters of the chosen preset are kept, so moving the slider
    of another preset does not restart the motion.

    Attributes
    ----------
    preset : one of :data:`PRESETS`
    n_links : chain links (chain only, else 0)
    tilt : initial tilt of the straight chain from hanging (rad; chain only)
    speed : crank speed (rad/s; slider-crank only)
    method : one of :data:`METHODS`
    rtol : relative tolerance (adaptive methods; atol = rtol / 100), else None
    dt : step (s; fixed-step methods), else None
    """

    preset: str
    n_links: int = 0
    tilt: float = 0.0
    speed: float = 0.0
    method: str = "DOP853"
    rtol: float | None = 1e-6
    dt: float | None = None

    @classmethod
    def from_inputs(cls, inputs: Inputs) -> Model:
        adaptive = inputs.method in ADAPTIVE_METHODS
        common = dict(method=inputs.method, rtol=float(inputs.rtol) if adaptive else None,
                      dt=None if adaptive else 1.0 / float(inputs.dt.split("/")[1]))
        if inputs.preset == CHAIN:
            return cls(CHAIN, n_links=int(inputs.n_links), tilt=math.radians(inputs.tilt_deg), **common)
        if inputs.preset == CRANK:
            return cls(CRANK, speed=inputs.rpm * 2.0 * math.pi / 60.0, **common)
        if inputs.preset in (DOUBLE, TOP):
            return cls(inputs.preset, **common)
        raise ValueError(f"preset: expected one of {list(PRESETS)}, got {inputs.preset!r}")

    def options(self) -> dict[str, Any]:
        """Keyword arguments of :meth:`core.multibody.System.simulate`."""
        if self.rtol is not None:
            return {"method": self.method, "rtol": self.rtol, "atol": self.rtol * 1e-2}
        return {"method": self.method, "dt": self.dt}

    def integrator_text(self) -> str:
        if self.rtol is not None:
            return f"{self.method}, rtol {self.rtol:.0e}"
        return f"{self.method}, dt = 1/{round(1.0 / self.dt)} s"


# -- the job: rebuild the model in the worker, simulate one chunk ---------------------
@dataclasses.dataclass(frozen=True)
class _Built:
    """A System built from a :class:`Model` and the handles a chunk reads."""

    system: Any
    joints: tuple[Any, ...]
    motor: Any  # the crank's motor, or None
    crank: Any  # core.models.SliderCrank, or None
    top: Any  # core.models.HeavyTop, or None
    points_body: tuple[np.ndarray, ...]  # (3,) per joint: its point in body_j's frame (or global)


def _build(model: Model) -> _Built:
    """The assembled System of ``model`` at t = 0 (runs in the worker)."""
    motor = crank = top = None
    if model.preset == CHAIN:
        system = pendulum_chain(model.n_links, _CHAIN_LENGTH / model.n_links, _LINK_MASS, "rod",
                                tilt=model.tilt, gravity=_GRAVITY)
        joints = tuple(system.joints)
    elif model.preset == DOUBLE:
        sdp = spatial_double_pendulum(_DOUBLE_LENGTH, _LINK_MASS, gravity=_GRAVITY)
        system, joints = sdp.system, tuple(sdp.joints)
    elif model.preset == CRANK:
        crank = slider_crank(crank_length=_CRANK_R, rod_length=_CRANK_L, crank_mass=_CRANK_MASSES[0],
                             rod_mass=_CRANK_MASSES[1], slider_mass=_CRANK_MASSES[2], speed=model.speed,
                             gravity=_GRAVITY)
        system, motor = crank.system, crank.motor
        joints = (crank.crank_joint, crank.crank_rod_joint, crank.rod_slider_joint, crank.slider_joint)
    elif model.preset == TOP:
        top = heavy_top(_TOP_PARAMS, _TOP_STATE0, mass=_TOP_MASS, gravity=_GRAVITY)
        system, joints = top.system, (top.joint,)
    else:
        raise ValueError(f"preset: expected one of {list(PRESETS)}, got {model.preset!r}")
    # Joint.point is global in the configuration the joint was added in, which
    # the builders' assembly leaves in place: u = A^T (point - R) in body_j.
    state = system.state
    points = []
    for joint in joints:
        if joint.body_j.is_ground:
            points.append(np.array(joint.point, dtype=float))
        else:
            A = state.rotation_matrix(joint.body_j)
            points.append(A.T @ (np.asarray(joint.point, dtype=float) - state.position(joint.body_j)))
    return _Built(system, joints, motor, crank, top, tuple(points))


@dataclasses.dataclass(frozen=True)
class _Setup:
    """Constants of one model: what to draw and how to read a chunk (from chunk 0).

    Plain tuples and numbers only, so two setups compare cheaply.
    """

    model: Model
    n_bodies: int
    n_equations: int  # constraint equations, motors included
    rank: int  # independent equations
    dof: int  # degrees of freedom left (0 for the driven slider-crank)
    rods: tuple[int, ...]  # bodies drawn as rods along their body z axis, centred
    rod_lengths: tuple[float, ...]  # m
    slider: int  # body drawn as the slider box (-1: none)
    top: int  # body drawn as the top (-1: none)
    joint_names: tuple[str, ...]
    weight: float  # N, total weight (arrow scale)
    arrow_max: float  # m, longest arrow: 0.9 m, or 1.2 times the shortest rod
    energy0: float  # J, at t = 0
    check: str  # closed-form check: "" (none), "slider" (m) or "top" (rad)
    csv_header: str
    n_joints: int  # joints with a reaction arrow
    motor: bool  # the crank's motor drives the model

    @property
    def conserved(self) -> bool:
        """Energy is constant (no motor doing work)."""
        return not self.motor

    def frame_slices(self) -> dict[str, slice]:
        n, j = self.n_bodies, self.n_joints
        out, at = {}, 0
        for name, size in (("R", 3 * n), ("P", 4 * n), ("joints", 3 * j), ("forces", 3 * j),
                           ("torque", 3 if self.motor else 0), ("ghost_R", 3 if self.top >= 0 else 0),
                           ("ghost_P", 4 if self.top >= 0 else 0)):
            out[name] = slice(at, at + size)
            at += size
        return out


def _setup(model: Model, built: _Built, energy0: float) -> _Setup:
    system = built.system
    report = system.assemble()  # already assembled: counts rows, rank and freedom
    n = len(system.bodies)
    if model.preset == CHAIN:
        rods, lengths = tuple(range(n)), (_CHAIN_LENGTH / model.n_links,) * n
    elif model.preset == DOUBLE:
        rods, lengths = (0, 1), (_DOUBLE_LENGTH, _DOUBLE_LENGTH)
    elif model.preset == CRANK:
        rods, lengths = (built.crank.crank.index, built.crank.rod.index), (_CRANK_R, _CRANK_L)
    else:
        rods, lengths = (), ()
    slider = built.crank.slider.index if built.crank is not None else -1
    top = built.top.body.index if built.top is not None else -1
    masses = float(sum(b.mass for b in system.bodies))
    n_equations = sum(JOINT_KINDS[j.kind] for j in system.joints) + len(system.motors)
    columns = []
    for body in system.bodies:
        columns += [f"{body.name} {c}" for c in ("x (m)", "y (m)", "z (m)", "p0", "p1", "p2", "p3")]
    columns += ["E (J)", "max |C|"]
    check = "slider" if built.crank is not None else "top" if built.top is not None else ""
    if check == "slider":
        columns.append("slider x - closed form (m)")
    elif check == "top":
        columns += ["closed-form p0", "closed-form p1", "closed-form p2", "closed-form p3",
                    "attitude difference (rad)"]
    return _Setup(
        model=model, n_bodies=n, n_equations=int(n_equations), rank=int(report.rank),
        dof=int(report.degrees_of_freedom), rods=tuple(int(i) for i in rods),
        rod_lengths=tuple(float(x) for x in lengths), slider=int(slider), top=int(top),
        joint_names=tuple(j.name for j in built.joints), weight=masses * _GRAVITY,
        arrow_max=min(_ARROW_MAX, 1.2 * min(lengths)) if lengths else _ARROW_MAX, energy0=float(energy0),
        check=check, csv_header="t (s)," + ",".join(columns), n_joints=len(built.joints),
        motor=built.motor is not None,
    )


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """Samples of one chunk of simulated time (read-only arrays).

    ``frames`` holds, per sample, everything a frame draws (interpolated as
    one row; columns in :meth:`_Setup.frame_slices`); ``q_end`` / ``v_end``
    are the final state the next chunk continues from.
    """

    k: int
    t: np.ndarray  # (n,) s
    frames: np.ndarray  # (n, F)
    energy: np.ndarray  # (n,) J
    residual: np.ndarray  # (n,) max |C| per sample
    check: np.ndarray | None  # (n,) closed-form difference (m or rad), or None
    force_norms: np.ndarray  # (n, J) N
    q_end: np.ndarray  # (7 nb,)
    v_end: np.ndarray  # (6 nb,)
    table: Table
    setup: _Setup
    n_steps: int
    n_rhs: int
    cpu_seconds: float  # CPU time of the job (the worker's thread)
    worker: int  # pid of the process that computed it


def _continuous(P: np.ndarray) -> np.ndarray:
    """Euler parameters (n, ..., 4) with signs flipped so consecutive samples agree (for nlerp)."""
    P = np.array(P)
    for i in range(1, P.shape[0]):
        flip = np.einsum("...i,...i->...", P[i], P[i - 1]) < 0.0
        P[i][flip] *= -1.0
    return P


@functools.lru_cache(maxsize=8)
def _built(model: Model) -> _Built:
    """:func:`_build` of ``model``, built and assembled once per model in each worker process (about 40 % of
    a chunk's CPU for the default chain). Never run: each chunk runs a deep copy of it (about 1 ms), so a job
    stays a function of its arguments only (the slider-crank's motor law is a closure: no pickle)."""
    return _build(model)


def _compute_chunk(model: Model, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``model`` (runs on the executor; never on the loop thread).

    The System is built from ``model`` (a job gets picklable parameters
    only; :func:`_built` keeps it per worker process); chunk 0 starts from the builder's assembled initial state, chunk
    ``k > 0`` from the final state of chunk ``k - 1`` (``previous``), at its
    time. Raises what :meth:`core.multibody.System.simulate` raises when the
    integration or the projection fails.
    """
    cpu0 = time.thread_time()
    built = copy.deepcopy(_built(model))  # a fresh copy: each job starts from the same System
    system = built.system
    if k > 0:
        if previous is None or previous.k != k - 1:
            raise ValueError(f"previous: chunk {k} continues from chunk {k - 1}, which was not given")
        system.set_state(dataclasses.replace(system.state, t=float(previous.t[-1]), q=previous.q_end,
                                             v=previous.v_end))
    t = np.linspace(k * _CHUNK_SIM_TIME, (k + 1) * _CHUNK_SIM_TIME, _SAMPLES + 1)
    traj = system.simulate(t, **model.options())
    setup = previous.setup if previous is not None else _setup(model, built, float(traj.energy[0]))
    n, N = setup.n_bodies, t.size
    R = traj.q[:, : 3 * n].reshape(N, n, 3)
    P = _continuous(traj.q[:, 3 * n :].reshape(N, n, 4))
    joints, forces = [], []
    for joint, u in zip(built.joints, built.points_body, strict=True):
        body = joint.body_j
        if body.is_ground:
            joints.append(np.broadcast_to(u, (N, 3)))
        else:
            joints.append(R[:, body.index] + rotate_vector(P[:, body.index], u))
        forces.append(traj.reaction(joint)[0])  # on body_j, global (N)
    joints_a = np.stack(joints, axis=1)  # (N, J, 3)
    forces_a = np.stack(forces, axis=1)
    parts = [R.reshape(N, -1), P.reshape(N, -1), joints_a.reshape(N, -1), forces_a.reshape(N, -1)]
    if built.motor is not None:
        parts.append(traj.reaction(built.motor)[1])  # the driving torque on the crank
    check = None
    extra_columns: list[np.ndarray] = []
    if built.crank is not None:
        sc = built.crank
        phi = sc.phi0 + sc.speed * t
        check = R[:, sc.slider.index, 0] - sc.slider_position(phi)
        extra_columns = [check[:, None]]
    if built.top is not None:
        motion = top_motion(_TOP_PARAMS, np.array(_TOP_STATE0))  # the closed form's constants
        exact = motion.at(t)
        p_exact = _continuous(euler_parameters_from_euler_angles(exact.angles, "ZXZ"))
        axis = rotate_vector(p_exact, np.array([0.0, 0.0, 1.0]))
        parts += [built.top.length * axis, p_exact]
        check = rotation_angle_between(P[:, built.top.body.index], p_exact)
        extra_columns = [p_exact, check[:, None]]
    frames = np.concatenate(parts, axis=1)
    energy = np.array(traj.energy)
    residual = np.array(traj.residual_position)
    for name, a in (("positions", frames), ("energy", energy), ("residual", residual)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the motion left the finite range near t = {t[0]:.3g} s")
    columns = np.concatenate([R.reshape(N, n, 3), traj.q[:, 3 * n :].reshape(N, n, 4)], axis=2).reshape(N, -1)
    table = Table.build(t, np.concatenate([columns, energy[:, None], residual[:, None], *extra_columns], axis=1))
    force_norms = np.linalg.norm(forces_a, axis=2)
    q_end, v_end = np.array(traj.q[-1]), np.array(traj.v[-1])
    for a in (t, frames, energy, residual, force_norms, q_end, v_end) + ((check,) if check is not None else ()):
        a.setflags(write=False)
    return _Chunk(k, t, frames, energy, residual, check, force_norms, q_end, v_end, table, setup,
                  int(traj.n_steps), int(traj.n_rhs), time.thread_time() - cpu0, os.getpid())


# -- meshes (created once, in build) ---------------------------------------------------
def _rod_mesh() -> trimesh.Trimesh:
    """Unit rod: radius 1, length 1 along z, centred (scaled per link to (r, r, L))."""
    return trimesh.creation.cylinder(radius=1.0, height=1.0, sections=20)


def _top_mesh() -> trimesh.Trimesh:
    """The top in its body frame: origin at the centre of mass, rotor axis z; the
    axle runs from the fixed point O (z = -l) past the disc."""
    length = _TOP_PARAMS.mgl / (_TOP_MASS * _GRAVITY)
    disc = trimesh.creation.cylinder(radius=_TOP_DISC_RADIUS, height=0.07, sections=48)
    axle = trimesh.creation.cylinder(radius=0.025, segment=np.array([[0.0, 0.0, -length], [0.0, 0.0, _TOP_AXLE_TIP]]),
                                     sections=16)
    knob = trimesh.creation.icosphere(subdivisions=2, radius=0.045).apply_translation([0.0, 0.0, _TOP_AXLE_TIP])
    return trimesh.util.concatenate([disc, axle, knob])


def _top_marker() -> trimesh.Trimesh:
    """A dark block on the disc's rim, so the spin shows."""
    return trimesh.creation.box(extents=(0.12, 0.07, 0.08)).apply_translation([_TOP_DISC_RADIUS - 0.06, 0.0, 0.0])


def _supports() -> dict[str, trimesh.Trimesh]:
    """Static parts per preset, in the model frame (m)."""
    ceiling = trimesh.creation.box(extents=(0.5, 0.5, 0.06)).apply_translation([0.0, 0.0, 0.08])
    base_z = -_PLACEMENT[CRANK][0][2]  # the ground, in the crank's model frame
    crank = trimesh.util.concatenate([
        # pedestal under the crank pivot, and the axle stub along the crank axis (-y)
        trimesh.creation.box(extents=(0.16, 0.12, -base_z)).apply_translation([0.0, 0.12, base_z / 2]),
        trimesh.creation.cylinder(radius=0.03, segment=np.array([[0.0, 0.0, 0.0], [0.0, 0.12, 0.0]]), sections=16),
        # the slider's guide along x, just behind the plane of the mechanism
        # (which it never crosses), on two posts
        trimesh.creation.box(extents=(1.7, 0.08, 0.1)).apply_translation([1.5, 0.2, 0.0]),
        trimesh.creation.box(extents=(0.06, 0.06, -base_z)).apply_translation([0.7, 0.2, base_z / 2]),
        trimesh.creation.box(extents=(0.06, 0.06, -base_z)).apply_translation([2.3, 0.2, base_z / 2]),
    ])
    top_z = -_PLACEMENT[TOP][0][2]
    pedestal = trimesh.util.concatenate([
        trimesh.creation.cylinder(radius=0.035, segment=np.array([[0.0, 0.0, top_z], [0.0, 0.0, -0.05]]), sections=16),
        trimesh.creation.cylinder(radius=0.25, height=0.05, sections=32).apply_translation([0.0, 0.0, top_z + 0.025]),
    ])
    offset = np.array(_GHOST_OFFSET)
    tops = trimesh.util.concatenate([pedestal, pedestal.copy().apply_translation(offset)])
    return {"chain": ceiling, "crank": crank, "top": tops}


def _wxyz_about_z(angle: float) -> tuple[float, float, float, float]:
    return (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))


@dataclasses.dataclass
class _Gui:
    readout: Any  # app.readout.Readout: the motion now (about 5 times a second)
    info: Any  # app.readout.Readout: the model's constants (when they change)
    legend: Legend
    plot_energy: Any
    plot_drift: Any
    plot_check: Any
    plot_residual: Any





class LinkagesScene(PlaybackRequests, Scene):
    """Constrained multibody systems: chain, spatial double pendulum, slider-crank, heavy top."""

    name: ClassVar[str] = "linkages"
    title: ClassVar[str] = "Linkages (multibody)"
    order: ClassVar[int] = 50
    help: ClassVar[str] = (
        "Bodies in absolute coordinates: each body's centre of mass R and Euler parameters p "
        "(A(p) of Eq. 8.48), joints and the crank's motor as algebraic constraints C(q, t) = 0.\n\n"
        "- **Equations of motion**: the augmented equations [[M, Dᵀ], [D, 0]] [a; λ] = "
        "[Q_e + Q_v; γ] with the Lagrange multipliers λ; in Euler parameters the mass matrix is "
        "M_q = diag(m I, 4 Ḡᵀ I Ḡ) with the normalization pᵀp = 1 adjoined and "
        "dp/dt = Ḡᵀ ω_body / 2 (Eqs. 8.51-8.57). The motor is the driving constraint of the "
        "relative rotation (Eqs. 8.82-8.83).\n"
        "- **Integration**: the chosen integrator (DOP853 / RK45 adaptive with rtol, atol = "
        "rtol/100; rk4 / midpoint with a fixed step) in chunks of 1 s ahead of the clock. After "
        "every step the positions are projected back onto C = 0 (Newton, to max |C| <= 1e-12) and "
        "the velocities onto dC/dt = 0: the residual stays below 1e-8 or the run stops with a "
        "notice.\n"
        "- **Orange arrows**: the reaction force each joint applies to its lower (driven) body, "
        "from the multipliers (−Dᵀλ of the joint's rows), drawn at the joint point; length "
        "ℓ |F| / (|F| + W), W the mechanism's weight, ℓ = 0.9 m or 1.2 times the shortest link. "
        "**Purple**: the motor's torque on the crank, 0.7 m |M| / (|M| + W r).\n"
        "- **Heavy top**: the same top as the gyroscope scene (I = 1, I3 = 0.8 kg m², "
        "mgl = 2 N m, θ0 = 50°, dψ/dt = 8 rad/s) as one body on a spherical joint; the "
        "translucent top beside it follows the closed form (Eqs. 8.19-8.21).\n"
        "- **Plots**: energy E, log10 |E − E0| (constant energy without a motor), the "
        "closed-form difference (slider position, or the top's attitude, Eq. 8.82) and "
        "log10 max |C|. *Download CSV* exports the samples of the plotted window."
    )
    # A 3/4 view from the +x side, the models left of the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (3.6, -0.9, 2.55)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 1.25, 1.35)

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.playback = Playback((), controls=self.controls)
        self.timeline = ChunkTimeline(self.executor, functools.partial(_compute_chunk, Model.from_inputs(_DEFAULT)),
                                      chunk_time=_CHUNK_SIM_TIME, sequential=True, capacity=_CHUNKS_KEPT)
        self.history = History()
        self._refresh = PlotRefresh(("window", "readout", "energy", "drift", "check", "residual"),
                                    _REFRESH_PERIOD)
        # Owned by update() (the session loop thread).
        self.model: Model | None = None
        self.setup: _Setup | None = None  # the model drawn (from its chunks)
        self.sim_time = 0.0
        self.waiting = False  # the clock holds: the chunk it needs is not ready
        self.energy = math.nan  # J, at the computed sample nearest the clock
        self.residual = math.nan  # max |C| at that sample
        self.max_residual = 0.0  # largest max |C| of the samples drawn since t = 0
        self.check = math.nan  # closed-form difference at that sample (m or rad)
        self.forces = np.zeros((0,))  # |F| per joint at that sample (N)
        self.last_chunk: _Chunk | None = None
        self._drawn: tuple[float, int, bool, Any] | None = None
        self._refreshed_time = -1.0
        self._plot_window: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros((0, 0)))
        self._error_reported = False
        self._rod_positions = np.zeros((_MAX_RODS, 3), dtype=np.float32)
        self._rod_wxyzs = np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (_MAX_RODS, 1))
        self._joint_positions = np.zeros((_MAX_JOINTS, 3), dtype=np.float32)
        self._labels_due = 0  # frames until the labels' visibility is sent again
        self.gui: _Gui | None = None

    # -- build ------------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        self.add_ground_grid(width=8.0, height=8.0, position=(0.0, 0.0, 0.0), cell_size=0.25, section_size=1.0)
        self.model_frame = scene.add_frame(f"{root}/model", show_axes=False)
        m = f"{root}/model"
        supports = _supports()
        self.supports = {
            key: scene.add_mesh_simple(f"{m}/support_{key}", mesh.vertices.astype(np.float32),
                                       mesh.faces.astype(np.uint32), color=_SUPPORT_COLOR, visible=False)
            for key, mesh in supports.items()
        }
        rod = _rod_mesh()
        self.rods = scene.add_batched_meshes_simple(
            f"{m}/rods", rod.vertices.astype(np.float32), rod.faces.astype(np.uint32),
            batched_wxyzs=self._rod_wxyzs, batched_positions=self._rod_positions,
            batched_scales=np.zeros((_MAX_RODS, 3), dtype=np.float32),
            batched_colors=np.array([_ROD_COLORS[i % 2] for i in range(_MAX_RODS)], dtype=np.uint8),
            lod="off",
        )
        ball = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        self.joint_spheres = scene.add_batched_meshes_simple(
            f"{m}/joints", ball.vertices.astype(np.float32), ball.faces.astype(np.uint32),
            batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (_MAX_JOINTS, 1)),
            batched_positions=self._joint_positions, batched_scales=np.zeros(_MAX_JOINTS, dtype=np.float32),
            batched_colors=_JOINT_COLOR, lod="off",
        )
        self.slider = scene.add_box(f"{m}/slider", color=(120, 122, 134), dimensions=(_SLIDER_SIDE,) * 3,
                                    visible=False)
        top, marker = _top_mesh(), _top_marker()
        self.top = scene.add_frame(f"{m}/top", show_axes=False, visible=False)
        scene.add_mesh_simple(f"{m}/top/mesh", top.vertices.astype(np.float32), top.faces.astype(np.uint32),
                              color=_TOP_COLOR)
        scene.add_mesh_simple(f"{m}/top/marker", marker.vertices.astype(np.float32),
                              marker.faces.astype(np.uint32), color=(90, 60, 40))
        self.ghost_pivot = scene.add_frame(f"{m}/ghost_pivot", show_axes=False, position=_GHOST_OFFSET,
                                           visible=False)
        self.ghost = scene.add_frame(f"{m}/ghost_pivot/top", show_axes=False)
        scene.add_mesh_simple(f"{m}/ghost_pivot/top/mesh", top.vertices.astype(np.float32),
                              top.faces.astype(np.uint32), color=_GHOST_COLOR, opacity=0.4)
        scene.add_mesh_simple(f"{m}/ghost_pivot/top/marker", marker.vertices.astype(np.float32),
                              marker.faces.astype(np.uint32), color=_GHOST_COLOR, opacity=0.6)
        self.force_arrows = self.add_arrows(
            f"{m}/forces", np.zeros((1, 2, 3), dtype=np.float32), _FORCE_COLOR,
            shaft_radius=0.016, head_radius=0.05, head_length=0.12, visible=False,
        )
        self.torque_arrow = self.add_arrows(
            f"{m}/torque", np.zeros((1, 2, 3), dtype=np.float32), _TORQUE_COLOR,
            shaft_radius=0.016, head_radius=0.05, head_length=0.12, visible=False,
        )
        self.labels = {
            "top": self.add_label(f"{m}/label_top", "multibody top\n(spherical joint)",
                                  position=(0.0, 0.0, -0.55), anchor="top-center", scale=_LABEL_SCALE,
                                  visible=False),
            "ghost": self.add_label(f"{m}/label_ghost", "closed form\n(core.gyroscope)",
                                    position=np.array(_GHOST_OFFSET) + (0.0, 0.0, -0.55), anchor="top-center",
                                    scale=_LABEL_SCALE, visible=False),
            "motor": self.add_label(f"{m}/label_motor", "motor", position=(0.0, 0.0, -0.6),
                                    anchor="top-center", scale=_LABEL_SCALE, visible=False),
        }
        gui = self.target.gui
        with self.make_folder():
            legend = Legend(gui, (
                (_FORCE_COLOR, "reaction force on the lower / driven body at each joint"),
                (_TORQUE_COLOR, "motor torque on the crank"),
                (_JOINT_COLOR, "joints"),
                (_GHOST_COLOR, "closed-form heavy top (translucent)"),
            ), "Colours (arrow lengths saturate, see What you see):", presenter=self.presenter)
            self.playback.add_gui()
            readout = self.add_readout("Computing the motion…")
            info = self.add_readout("")
            self.controls.add(Choice("preset", "Preset", options=PRESETS, default=_DEFAULT.preset))
            with gui.add_folder("Model") as self._model_folder:
                self.controls.add(Slider("n_links", "N links", min=1, max=_MAX_RODS, step=1, integer=True,
                                         default=_DEFAULT.n_links, hint="Links of the chain (total length 2 m)"))
                self.controls.add(Slider("tilt_deg", "Tilt (deg)", min=0.0, max=170.0, step=1.0,
                                         default=_DEFAULT.tilt_deg,
                                         hint="The straight chain is released at rest, turned this far from hanging"))
                self.controls.add(Slider("rpm", "Motor (rpm)", min=-300.0, max=300.0, step=1.0,
                                         default=_DEFAULT.rpm, hint="Crank speed imposed by the motor"))
            with gui.add_folder("Integrator"):
                self.controls.add(Choice("method", "Method", options=METHODS, default=_DEFAULT.method,
                                         hint="DOP853 and RK45 adaptive (scipy); rk4 and midpoint fixed-step"))
                self.controls.add(Choice("rtol", "rtol", options=RTOLS, default=_DEFAULT.rtol,
                                         hint="Relative tolerance of DOP853 / RK45 (atol = rtol / 100)"))
                self.controls.add(Choice("dt", "Step dt (s)", options=STEPS, default=_DEFAULT.dt,
                                         hint="Step of rk4 / midpoint"))
            with gui.add_folder("Show"):
                self.controls.add(Toggle("show_forces", "Reaction arrows", default=True))
            with self.plot_area():
                x_scale = {"x": {"time": False}}
                empty = np.zeros(2)
                plot_energy = self.add_plot(
                    (empty, empty, empty),
                    ({"label": "t (s)"}, {"label": "E (J)", "stroke": "#0f766e", "width": 2},
                     {"label": "E0", "stroke": "#888888", "dash": [6, 4]}),
                    title="energy E(t)", scales=x_scale, aspect=1.6,
                )
                plot_drift = self.add_plot(
                    (empty, np.full(2, LOG_FLOOR)),
                    ({"label": "t (s)"}, {"label": "log10 |E − E0| (J)", "stroke": "#b45309", "width": 2}),
                    title="energy drift (log10)", scales=x_scale, aspect=1.6,
                )
                plot_check = self.add_plot(
                    (empty, np.full(2, LOG_FLOOR)),
                    ({"label": "t (s)"}, {"label": "log10 difference", "stroke": "#7c3aed", "width": 2}),
                    title="difference from the closed form (log10)", scales=x_scale, aspect=1.6,
                )
                plot_residual = self.add_plot(
                    (empty, np.full(2, LOG_FLOOR), np.full(2, math.log10(RESIDUAL_BOUND)),
                     np.full(2, math.log10(POSITION_TOL))),
                    ({"label": "t (s)"}, {"label": "log10 max |C|", "stroke": "#be185d", "width": 2},
                     {"label": "bound 1e-8", "stroke": "#888888", "dash": [6, 4]},
                     {"label": "Newton tol 1e-12", "stroke": "#bbbbbb", "dash": [2, 4]}),
                    title="constraint residual (log10)", scales=x_scale, aspect=1.6,
                )
            self.add_download("download_csv", "Download CSV", "linkages.csv", self.csv_bytes,
                              hint="t, every body's R and p, E, max |C| (and the closed-form check) "
                                   "of the plotted window")
        self.gui = _Gui(readout, info, legend, plot_energy, plot_drift, plot_check, plot_residual)
        self._show_controls(_DEFAULT)

    def on_presenter(self, on: bool) -> None:
        if self.gui is not None:
            self.gui.legend.set_presenter(on)

    # -- read by tests and notebooks --------------------------------------------------
    @property
    def visible_links(self) -> int:
        """Rods drawn (instances of the rod batch with a nonzero scale)."""
        scales = np.asarray(self.rods.batched_scales)
        return int(np.count_nonzero(np.any(scales != 0.0, axis=1)))

    @property
    def inputs(self) -> Inputs:
        values = self.controls.values()
        return Inputs(**{f.name: values[f.name] for f in dataclasses.fields(Inputs)})

    # -- inputs ------------------------------------------------------------------------
    def _show_controls(self, inputs: Inputs) -> None:
        """Show the sliders of the chosen preset and the tolerance of the chosen method."""
        handles = self.controls.handles
        has_sliders = inputs.preset in (CHAIN, CRANK)
        if self._model_folder.visible != has_sliders:
            self._model_folder.visible = has_sliders
        for key, shown in (("n_links", inputs.preset == CHAIN), ("tilt_deg", inputs.preset == CHAIN),
                           ("rpm", inputs.preset == CRANK), ("rtol", inputs.method in ADAPTIVE_METHODS),
                           ("dt", inputs.method in FIXED_STEP_METHODS)):
            if handles[key].visible != shown:
                handles[key].visible = shown

    def _apply_inputs(self, inputs: Inputs) -> None:
        """Use ``inputs``: a new model restarts the motion (its chunks from t = 0)."""
        self._show_controls(inputs)
        model = Model.from_inputs(inputs)
        if model == self.model:
            return  # a slider of another preset moved
        self.model = model
        self._error_reported = False
        self.timeline.reset(functools.partial(_compute_chunk, model))
        self._restart()

    def _restart(self) -> None:
        self.sim_time = 0.0
        self.max_residual = 0.0
        self.history.clear()
        self._drawn = None
        self._refreshed_time = -1.0
        self._refresh.force()

    # -- update --------------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        changed = self.controls.take_changes()
        if self.model is None or changed & _MODEL_KEYS:
            self._apply_inputs(self.inputs)
        tick = self.playback.tick(dt)
        if tick.reset:
            self._restart()
        # ask for the next chunk as soon as the clock enters a chunk (a whole
        # chunk of lead: each continues from the one before, so none can be
        # computed further ahead)
        self.timeline.chunk_at(self.sim_time, ahead=0.0)
        self.sim_time, chunk, self.waiting = self.timeline.advance(self.sim_time, tick.step)
        if self.timeline.error is not None and not self._error_reported:
            self._error_reported = True
            self.playback.set_playing(False)
            error = self.timeline.error
            self.notify("Simulation stopped",
                        f"{type(error).__name__}: {error}. The motion stops at t = {self.sim_time:.2f} s; "
                        "choose another integrator, step or tolerance and press Play.", "warning")
        show = bool(self.controls.value("show_forces"))
        if chunk is None or chunk.setup.model != self.model:
            if self.setup is None or self.setup.model != self.model:
                self.gui.readout.content = "Computing the motion…"  # sent once
            if self.setup is not None and self.force_arrows.visible and not show:
                self.force_arrows.visible = False
                self.torque_arrow.visible = False
            return
        self._draw(chunk, dt, show)

    def _apply_setup(self, setup: _Setup) -> None:
        """Show a new model: rod and joint scales, its parts, plots (in the frame's atomic group)."""
        self.setup = setup
        preset = setup.model.preset
        position, angle = _PLACEMENT[preset]
        set_pose(self.model_frame, position=position, wxyz=_wxyz_about_z(angle))
        scales = np.zeros((_MAX_RODS, 3), dtype=np.float32)
        radius = _ROD_RADIUS[preset]
        for i, length in enumerate(setup.rod_lengths):
            scales[i] = (radius, radius, length)
        set_array(self.rods, "batched_scales", scales)
        # the rods' poses are sent again with the new scales (unused rods at
        # the model's origin), as the joints' are
        self._rod_positions[:] = 0.0
        self._rod_wxyzs[:] = (1.0, 0.0, 0.0, 0.0)
        joint_scales = np.zeros(_MAX_JOINTS, dtype=np.float32)
        joint_scales[: setup.n_joints] = _JOINT_RADIUS[preset]
        set_array(self.joint_spheres, "batched_scales", joint_scales)
        for key, node in self.supports.items():
            node.visible = key == {CHAIN: "chain", DOUBLE: "chain", CRANK: "crank", TOP: "top"}[preset]
        self.slider.visible = setup.slider >= 0
        self.top.visible = setup.top >= 0
        self.ghost_pivot.visible = setup.top >= 0
        self.labels["top"].visible = self.labels["ghost"].visible = setup.top >= 0
        self.labels["motor"].visible = setup.motor
        self.gui.plot_drift.visible = setup.conserved
        self.gui.plot_check.visible = bool(setup.check)
        self.gui.info.content = self._info(setup)
        self._slices = setup.frame_slices()
        self._rod_index = np.array(setup.rods, dtype=np.intp)
        self._labels_due = _LABEL_RESEND_FRAMES

    def _draw(self, chunk: _Chunk, dt: float, show: bool) -> None:
        assert self.gui is not None
        setup = chunk.setup
        due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
        resend = False
        if self._labels_due > 0:
            self._labels_due -= 1
            resend = self._labels_due == 0
        key = (self.sim_time, chunk.k, show, setup)
        if key == self._drawn and setup == self.setup:
            if due is not None or resend:  # paused: the poses are on the page
                with self.target.atomic():
                    if due is not None:
                        self._refresh_one(due)
                    if resend:
                        self._resend_labels()
            return
        self._drawn = key
        self.last_chunk = chunk
        self.history.add(chunk.k, chunk.table)
        # linear interpolation between the two samples around the clock
        t = chunk.t
        h = float(t[1] - t[0])
        x = (self.sim_time - float(t[0])) / h
        j = min(max(int(x), 0), t.size - 2)
        w = min(max(x - j, 0.0), 1.0)
        row = chunk.frames[j] + w * (chunk.frames[j + 1] - chunk.frames[j])
        near = j + 1 if w >= 0.5 else j  # conserved quantities at a computed sample
        self.energy, self.residual = float(chunk.energy[near]), float(chunk.residual[near])
        self.check = float(chunk.check[near]) if chunk.check is not None else math.nan
        self.forces = chunk.force_norms[near]
        with self.target.atomic():
            if setup != self.setup:
                self._apply_setup(setup)
            s = self._slices
            n = setup.n_bodies
            R = row[s["R"]].reshape(n, 3)
            P = row[s["P"]].reshape(n, 4)
            P = P / np.sqrt(np.einsum("ij,ij->i", P, P))[:, None]  # nlerp
            rods = self._rod_index
            self._rod_positions[: rods.size] = R[rods]
            self._rod_wxyzs[: rods.size] = P[rods]
            set_arrays(self.rods, batched_positions=self._rod_positions, batched_wxyzs=self._rod_wxyzs)
            joints = row[s["joints"]].reshape(-1, 3)
            self._joint_positions[: joints.shape[0]] = joints
            set_arrays(self.joint_spheres, batched_positions=self._joint_positions)
            if setup.slider >= 0:
                set_pose(self.slider, position=R[setup.slider], wxyz=P[setup.slider])
            if setup.top >= 0:
                set_pose(self.top, position=R[setup.top], wxyz=P[setup.top])
                ghost_p = row[s["ghost_P"]]
                set_pose(self.ghost, position=row[s["ghost_R"]], wxyz=ghost_p / math.sqrt(float(ghost_p @ ghost_p)))
            if show:
                arrows = _arrow_points(joints, row[s["forces"]].reshape(-1, 3), setup.weight, setup.arrow_max)
                set_array(self.force_arrows, "points", arrows)
                if setup.motor:
                    torque = _arrow_points(joints[:1], row[s["torque"]].reshape(1, 3),
                                           setup.weight * _CRANK_R, _TORQUE_ARROW_MAX)
                    set_array(self.torque_arrow, "points", torque)
            if self.force_arrows.visible != show:
                self.force_arrows.visible = show
            torque_shown = show and setup.motor
            if self.torque_arrow.visible != torque_shown:
                self.torque_arrow.visible = torque_shown
            if due is not None:
                self._refresh_one(due)
            if resend:
                self._resend_labels()

    def _resend_labels(self) -> None:
        """Send the visibility of the shown labels again (coalesced into one update each).

        viser 1.1.1's page may not draw a label made visible soon after it
        was created while a browser is connected (the layer does the same in
        ``set_active``); the labels of a preset are shown when its first
        chunk arrives, which can be that soon.
        """
        for label in self.labels.values():
            if label.visible:
                label.visible = False
                label.visible = True

    # -- plots, readout, export ----------------------------------------------------------
    def _window_start(self) -> float:
        return max(0.0, self.sim_time - _WINDOW)

    def _refresh_one(self, what: str) -> None:
        assert self.gui is not None and self.setup is not None
        setup = self.setup
        if what == "window":
            # each refresh cycle starts here: the readout and plots of the
            # cycle (the next frames) show the window as it is now
            self._refreshed_time = self.sim_time
            self._plot_window = self.history.trimmed_window(self._window_start(), self.sim_time)
            t, columns = self._plot_window
            if t.size:
                self.max_residual = max(self.max_residual, float(np.max(columns[:, 7 * setup.n_bodies + 1])))
            return
        if what == "readout":
            self.gui.readout.content = self._readout()
            return
        t, columns = self._plot_window
        if t.size == 0:
            return
        e_col = 7 * setup.n_bodies
        if what == "energy":
            self.gui.plot_energy.data = (t, columns[:, e_col], np.full_like(t, setup.energy0))
        elif what == "drift" and setup.conserved:
            self.gui.plot_drift.data = (t, log10_floor(columns[:, e_col] - setup.energy0))
        elif what == "check" and setup.check:
            self.gui.plot_check.data = (t, log10_floor(columns[:, -1]))
        elif what == "residual":
            self.gui.plot_residual.data = (t, log10_floor(columns[:, e_col + 1]),
                                           np.full_like(t, math.log10(RESIDUAL_BOUND)),
                                           np.full_like(t, math.log10(POSITION_TOL)))

    def _info(self, setup: _Setup) -> str:
        """The model's constants (rewritten when the model changes)."""
        preset = setup.model.preset
        kinds = {CHAIN: f"{setup.n_bodies} rods on revolute joints", DOUBLE: "2 rods on spherical joints",
                 CRANK: "crank, rod, slider: revolute, spherical, universal, prismatic joints and a motor",
                 TOP: "one body on a spherical joint"}[preset]
        n = setup.n_bodies
        lines = [
            f"**{n} {'body' if n == 1 else 'bodies'}**, {7 * n} coordinates (R, p); {kinds}",
            f"**{setup.n_equations} constraint equations** (rank {setup.rank}) + {n} "
            f"normalization{'' if n == 1 else 's'} pᵀp = 1: **{setup.dof} degrees of freedom**"
            + (" (the motor drives the one left)" if setup.motor else ""),
        ]
        return "  \n".join(lines)

    def _readout(self) -> str:
        assert self.setup is not None and self.model is not None
        setup = self.setup
        lines = [f"**t** = {self.sim_time:.2f} s · **E** = {significant(self.energy, 5)} J"]
        if setup.conserved:
            lines[0] += f" · E − E0 = {one_digit(self.energy - setup.energy0)} J"
        else:
            lines[0] += " (the motor does work)"
        lines.append(f"**max |C|** = {one_digit(self.residual)} now, {one_digit(self.max_residual)} since t = 0 "
                     f"(bound {RESIDUAL_BOUND:.0e})")
        if setup.check == "slider":
            lines.append(f"slider x − closed form: {one_digit(self.check)} m")
        elif setup.check == "top":
            lines.append(f"attitude difference to the closed form: {one_digit(self.check)} rad")
        if self.forces.size:
            i = int(np.argmax(self.forces))
            lines.append(f"largest joint force {significant(float(self.forces[i]), 3)} N ({setup.joint_names[i]})")
        chunk = self.last_chunk
        if chunk is not None and chunk.setup == setup:
            lines.append(f"{self.model.integrator_text()}: {chunk.n_steps} steps, {chunk.n_rhs} right sides, "
                         f"{chunk.cpu_seconds:.2f} s CPU per simulated second")
        if self.waiting and self.playing:
            lines.append("*computing the next chunk…*")
        return "  \n".join(lines)

    def csv_bytes(self) -> bytes:
        """The CSV of the motion in the plot window, up to the displayed time."""
        if self.setup is None:
            return b""
        return self.history.csv(self.setup.csv_header, self._window_start(), self.sim_time)


def _arrow_points(starts: np.ndarray, vectors: np.ndarray, half: float, longest: float) -> np.ndarray:
    """Arrows (n, 2, 3) float32 from ``starts`` (n, 3) along ``vectors`` (n, 3), lengths
    ``longest |v| / (|v| + half)`` (m)."""
    norms = np.sqrt(np.einsum("ij,ij->i", vectors, vectors))
    k = longest / (norms + half)
    out = np.empty((starts.shape[0], 2, 3), dtype=np.float32)
    out[:, 0] = starts
    out[:, 1] = starts + vectors * k[:, None]
    return out
