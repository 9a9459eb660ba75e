"""Free rigid body scene: torque-free motion, polhode, and the Dzhanibekov flip.

An asymmetric body (a T-handle by default; its inertia comes from the
trimesh mesh's mass properties) spins freely. Its motion is the exact
solution of :func:`core.rigid_body.free_body_solution` (Jacobi elliptic
functions). The body starts turned so that its angular momentum ``L`` points
up (+Z), so a flip about the intermediate axis turns it upside down about a
vertical ``L``; the angular-velocity arrow moves around it.

Beside it, a chooser runs a numerical integrator of :mod:`core.integrators`
on :class:`core.rigid_body.FreeBodyModel` from the same initial state, drawn
as a translucent ghost; plots show the exact ``omega_body(t)``, the ghost's
error against the exact solution (orientation angle, omega) and its drift of
the energy, ``|L|`` and ``|p| - 1``.

A third picture shows the body-frame momentum space: the momentum sphere
``|L| = const``, the energy ellipsoid ``L . I^-1 L = 2E`` (wireframe) and
the polhode traced live by ``L_body(t)``, scaled so the sphere has a fixed
radius. 3-D labels name the bodies, the sphere and the arrows (whose colours
are not those of the frame axes); the panel's legend keys the colours, and
*Download CSV* exports the samples of the plotted window.

The scene holds no physics, and the loop thread does no long work: the
motion is computed on the app's executor in chunks of 1 s of simulated time
ahead of the display clock (:class:`app.jobs.ChunkTimeline`; the ghost
continues from the end of the previous chunk, never recursively), and the
clock holds while the chunk it needs is not ready. The per-model constants
(the exact solution, the model with its principal axes, the momentum
geometry) are computed once per parameter set on the executor and cached.
Each frame draws the sample at or before the clock: with a ghost running,
both bodies at the ghost's sample instant (every 1/60 s of simulated time, or
every step when the step is coarser); without one, the exact body every
1/240 s. Euler parameters go to viser's ``wxyz`` as they are (scalar first).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.controls import Choice, Slider
from app.nodes import set_array, set_pose
from app.readout import significant
from app.scenes._playback import Playback, PlaybackRequests
from app.scenes._plots import History, Legend, PlotRefresh, Table, window_seconds
from app.scenes._trail import ChunkedTrail
from app.scenes.base import Scene
from app.jobs import ChunkTimeline
from core.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS, IntegrationError, integrate
from core.rigid_body import (
    FreeBodyModel,
    FreeBodySolution,
    MomentumGeometry,
    free_body_solution,
    momentum_geometry,
    principal_axes,
    rotation_angle_between,
)
from core.rotations import euler_parameters_from_axis_angle, normalize_euler_parameters, rotate_vector

__all__ = [
    "BODIES",
    "CSV_HEADER",
    "CSV_HEADER_GHOST",
    "FreeBodyScene",
    "INTEGRATORS",
    "Inputs",
    "PRESETS",
    "body_mesh",
    "initial_orientation",
    "preset_omega",
]

_EXACT_POS = np.array([0.0, 0.0, 0.0])
_GHOST_POS = np.array([0.0, 1.9, 0.0])
_SPHERE_POS = np.array([0.0, -2.3, 0.0])
_SPHERE_RADIUS = 0.9
_ARROW_LENGTH = 1.3  # m: L arrows; omega saturates at this length
_OMEGA_HALF = 3.0  # rad/s: omega arrow length 1.3 m |omega| / (|omega| + 3 rad/s)
_POLHODE_CAPACITY = 600  # line segments of the traced polhode
_POLHODE_MIN_STEP = 0.005
_ELLIPSE_SEGMENTS = 64
_CHUNK_SIM_TIME = 1.0  # s of simulated time per chunk
_SAMPLE_DT = 1.0 / 60.0  # s: ghost samples (and CSV rows) per simulated second: 60
_EXACT_SAMPLES_PER_ROW = 4  # without a ghost the exact body is sampled at 240 Hz, exported at 60 Hz
_CHUNKS_KEPT = 8  # chunks the timeline keeps for a replay (the history keeps the window's tables)
_REFRESH_PERIOD = 0.25  # s of wall time between plot / readout refreshes (4 Hz; bytes: docs/app.md)
_TRACE_PERIOD = 0.05  # s of wall time between polhode / label updates
_LOG_FLOOR = 1e-17  # plotted on log axes: exact zeros shown at this floor
_WINDOW_CAP = 120.0  # s: longest plot window
_WINDOW_FALLBACK = 20.0  # s: plot window when omega has no finite period
_MIN_DT = 1e-4  # s: the smallest fixed step a ghost takes (the slider's minimum is 1e-3)
_LABEL_SCALE = 1.3  # 3-D labels: about 16 px (presenter view: x 1.8)

# Colours: no arrow or traced curve is red, green or blue (the frame axes).
_EXACT_COLOR = (220, 150, 60)
_GHOST_COLOR = (140, 170, 255)
_L_COLOR = (25, 25, 35)  # near black
_OMEGA_COLOR = (200, 30, 160)  # magenta
_GHOST_L_COLOR = (130, 130, 145)  # grey
_POLHODE_COLOR = (0, 160, 150)  # teal
_ELLIPSOID_COLOR = (120, 120, 145)
_ARROW_COLORS = np.array([_L_COLOR, _OMEGA_COLOR, _GHOST_L_COLOR], dtype=np.uint8)

#: Bodies offered in the "Body" dropdown (mesh frame = body frame, origin at
#: the centre of mass, density 1000 kg/m^3).
BODIES = ("T-handle", "Brick 1 x 0.6 x 0.3", "Disc (symmetric top)")
#: Integrators offered for the ghost body.
INTEGRATORS = ("none",) + tuple(FIXED_STEP_METHODS) + tuple(ADAPTIVE_METHODS)
#: Preset buttons.
PRESETS = (
    "Stable spin: major axis",
    "Stable spin: minor axis",
    "Dzhanibekov flip (intermediate axis)",
)
_PRESET_AXIS = {PRESETS[0]: 2, PRESETS[1]: 0, PRESETS[2]: 1}  # index into ascending moments
_PRESET_SPIN = 6.0  # rad/s about the chosen principal axis
_PRESET_OFFSET = 0.02  # relative perturbation about the other two axes
# The readout calls a motion a flip about the intermediate axis (Dzhanibekov) when the polhode passes
# within this angle of that axis (the flip preset's 2 % offset: about 2 deg; the stable spins: over 80 deg).
_NEAR_SEPARATRIX_DEG = 10.0

#: CSV header (one line: column names with units) without and with a ghost.
CSV_HEADER = "t (s),p0,p1,p2,p3,omega_x (rad/s),omega_y (rad/s),omega_z (rad/s),E (J),|L| (kg m^2/s)"
CSV_HEADER_GHOST = CSV_HEADER + (
    ",ghost p0,ghost p1,ghost p2,ghost p3,ghost omega_x (rad/s),ghost omega_y (rad/s),"
    "ghost omega_z (rad/s),ghost E (J),ghost |L| (kg m^2/s),ghost angle error (rad)"
)


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's controls."""

    body: str = BODIES[0]
    # the T-handle's intermediate axis is body x: start with the flip
    omega_x: float = 6.0
    omega_y: float = 0.12
    omega_z: float = 0.12
    method: str = "splitting"
    dt: float = 0.01
    rtol_exp: float = -8.0

    @property
    def omega_body0(self) -> np.ndarray:
        """(3,) initial angular velocity, body frame (rad/s)."""
        return np.array([self.omega_x, self.omega_y, self.omega_z])


_DEFAULT = Inputs()
_INPUT_KEYS = frozenset(f.name for f in dataclasses.fields(Inputs))
_OMEGA_KEYS = ("omega_x", "omega_y", "omega_z")


@functools.lru_cache(maxsize=None)
def body_mesh(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mesh of body ``name`` centred at its centre of mass, and its inertia.

    Returns
    -------
    vertices : (n, 3) float32, body frame, metres.
    faces : (m, 3) uint32.
    inertia : (3, 3) inertia tensor about the centre of mass (body frame),
        kg m^2, from trimesh's mass properties at density 1000 kg/m^3.
    """
    if name == BODIES[0]:
        # handle bar along x; stem along -z below it, then a knob. The parts
        # touch without overlapping, so their mass properties simply add.
        bar = trimesh.creation.cylinder(radius=0.08, height=1.2, sections=32)
        bar.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
        stem = trimesh.creation.cylinder(radius=0.07, height=0.62, sections=32)
        stem.apply_translation([0.0, 0.0, -0.08 - 0.31])
        knob = trimesh.creation.box(extents=(0.22, 0.22, 0.12))
        knob.apply_translation([0.0, 0.0, -0.76])
        mesh = trimesh.util.concatenate([bar, stem, knob])
    elif name == BODIES[1]:
        mesh = trimesh.creation.box(extents=(1.0, 0.6, 0.3))
    elif name == BODIES[2]:
        mesh = trimesh.creation.cylinder(radius=0.6, height=0.15, sections=64)
    else:
        raise ValueError(f"name: expected one of {list(BODIES)}, got {name!r}")
    mesh.density = 1000.0
    center = np.array(mesh.center_mass)
    inertia = np.array(mesh.moment_inertia, dtype=float)
    inertia = 0.5 * (inertia + inertia.T)
    vertices = np.ascontiguousarray(mesh.vertices - center, dtype=np.float32)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    for a in (vertices, faces, inertia):
        a.setflags(write=False)
    return vertices, faces, inertia


def preset_omega(name: str, inertia: np.ndarray) -> np.ndarray:
    """Initial omega_body (3,) of preset ``name``: a spin of 6 rad/s about a
    principal axis with a 2 % perturbation about the other two.

    Raises
    ------
    ValueError
        For an unknown preset name.
    """
    if name not in _PRESET_AXIS:
        raise ValueError(f"name: expected one of {list(PRESETS)}, got {name!r}")
    _, Q = principal_axes(inertia)
    k = _PRESET_AXIS[name]
    w_principal = np.full(3, _PRESET_OFFSET * _PRESET_SPIN)
    w_principal[k] = _PRESET_SPIN
    w = Q @ w_principal
    return np.round(w, 3)


def initial_orientation(inertia: np.ndarray, omega_body0: np.ndarray) -> np.ndarray:
    """Euler parameters p0 (4,) (scalar first) that turn ``L_body = I omega_body0`` onto +Z.

    The smallest rotation that does it (identity at rest or when L is already
    along +Z; half a turn about X when it is along -Z).
    """
    L = np.asarray(inertia, dtype=float) @ np.asarray(omega_body0, dtype=float)
    n = float(np.linalg.norm(L))
    if n == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    l = L / n
    axis = np.array([l[1], -l[0], 0.0])  # l x Z
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0]) if l[2] > 0.0 else np.array([0.0, 1.0, 0.0, 0.0])
    return euler_parameters_from_axis_angle(axis / s, math.atan2(s, float(l[2])))


def _ellipsoid_segments(semi_axes: np.ndarray, axes: np.ndarray, scale: float) -> np.ndarray:
    """Wireframe of an ellipsoid: 3 principal ellipses + 4 latitude rings, (k, 2, 3)."""
    s = np.linspace(0.0, 2.0 * math.pi, _ELLIPSE_SEGMENTS + 1)
    c, n = np.cos(s), np.sin(s)
    rings = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        u = np.zeros((s.size, 3))
        u[:, i], u[:, j] = c, n
        rings.append(u)
    for z in (-0.8, -0.45, 0.45, 0.8):
        u = np.zeros((s.size, 3))
        r = math.sqrt(1.0 - z * z)
        u[:, 0], u[:, 1], u[:, 2] = r * c, r * n, z
        rings.append(u)
    pts = [(u * semi_axes) @ axes.T * scale for u in rings]
    return np.concatenate([np.stack([p[:-1], p[1:]], axis=1) for p in pts]).astype(np.float32)



# -- per-model constants (computed once per parameter set, on the executor) ----
@dataclasses.dataclass(frozen=True)
class _Setup:
    """The exact motion of one body and initial omega, and what the scene draws of it."""

    body: str
    inertia: np.ndarray  # (3, 3) kg m^2, body frame
    omega_body0: np.ndarray  # (3,) rad/s, body frame
    p0: np.ndarray  # (4,) Euler parameters at t = 0: L along +Z
    solution: FreeBodySolution
    model: FreeBodyModel
    geometry: MomentumGeometry
    L_global: np.ndarray  # (3,) constant angular momentum, global frame (kg m^2/s)
    ellipsoid: np.ndarray  # (k, 2, 3) float32 energy-ellipsoid wireframe in the sphere's picture
    window: float  # s, plot window
    readout: str  # the motion's constants for the panel (Markdown)

    @property
    def state0(self) -> np.ndarray:
        """(7,) ``p0``, ``omega_body0``: the ghost's initial state."""
        return np.concatenate([self.p0, self.omega_body0])


def _polhode_text(solution: FreeBodySolution, g: MomentumGeometry) -> str:
    """What the polhode does, for the readout (``g.L_norm > 0``).

    ``2 E J2 / |L|^2`` (``J2`` the intermediate moment) is 1 on the separatrix, below 1 when the polhode
    circles the major axis and above 1 when it circles the minor one. The polhode comes closest to the
    intermediate axis where it crosses the plane of that axis and the axis it circles; there
    ``(L . e2)^2 / |L|^2 = (r J3 - J2) / (J3 - J2)`` (circling the major axis, ``r`` the ratio above)
    or ``(J2 - r J1) / (J2 - J1)`` (the minor one). Within :data:`_NEAR_SEPARATRIX_DEG` of the
    intermediate axis the body spins about that axis and flips over every half period of ω (the
    Dzhanibekov effect): just off the separatrix, which side the polhode circles does not change what
    one sees, so the text says both.
    """
    J1, J2, J3 = (float(m) for m in g.moments)
    # r - 1 = -(|L|^2 - 2 E J2) / |L|^2, the difference summed without cancellation (as the core does)
    w_principal = g.axes.T @ solution.omega_body0
    below = float(np.sum(g.moments * (g.moments - J2) * w_principal**2)) / g.L_norm**2  # 1 - r
    ratio = 1.0 - below
    if abs(below) >= 5e-5:
        shown = f"2E J2/|L|² = {ratio:.4f}"
    elif below == 0.0:
        shown = "2E J2/|L|² = 1"
    else:  # would print as 1.0000: the distance from 1 is what matters
        shown = f"2E J2/|L|² = 1 {'−' if below > 0.0 else '+'} {abs(below):.1e}"
    if solution.kind == "symmetric":
        axis = "major" if J2 - J1 <= J3 - J2 else "minor"  # the unequal moment's axis
        return (f"{shown}. Two equal principal moments: no intermediate axis and no flip; the polhode "
                f"circles the symmetry axis (the {axis} axis), a regular precession")
    if solution.kind == "steady":
        return f"{shown}. The polhode is a point: steady rotation about a principal axis"
    if solution.kind == "separatrix":
        return (f"{shown}, the separatrix: the intermediate axis turns over from along L to against it "
                "(or back) once, starting and ending only as t → ±∞")
    side = "major" if below > 0.0 else "minor"
    if below > 0.0:
        closest = (ratio * J3 - J2) / (J3 - J2)
    else:
        closest = (J2 - ratio * J1) / (J2 - J1)
    angle = math.degrees(math.acos(math.sqrt(min(max(closest, 0.0), 1.0))))
    if angle > _NEAR_SEPARATRIX_DEG:
        return f"{shown}: the polhode circles the {side} axis"
    flip = significant(0.5 * float(solution.period), 3)
    return (f"{shown}, near 1 (the separatrix): the body spins about its intermediate axis and flips over "
            f"every {flip} s (half the ω period), the Dzhanibekov effect. Just {'below' if below > 0.0 else 'above'} "
            f"1, the polhode passes {angle:.1f}° from the intermediate axis and circles the {side} axis")


@functools.lru_cache(maxsize=32)
def _setup(body: str, omega: tuple[float, float, float]) -> _Setup:
    _, _, inertia = body_mesh(body)
    w0 = np.array(omega, dtype=float)
    p0 = initial_orientation(inertia, w0)
    solution = free_body_solution(inertia, w0, p0)
    model = FreeBodyModel(inertia)
    g = momentum_geometry(inertia, w0)
    L_global = model.angular_momentum_global(w0, p0)
    scale = _SPHERE_RADIUS / g.L_norm if g.L_norm > 0 else 0.0
    ellipsoid = _ellipsoid_segments(g.semi_axes, g.axes, scale)
    period = float(solution.period)
    window = window_seconds(period, fallback=_WINDOW_FALLBACK, cap=_WINDOW_CAP)
    if period == 0.0:
        kind = "steady rotation" if solution.kind == "steady" else "at rest"
        motion = f"**Motion**: {kind}, ω constant"
    elif math.isinf(period):
        motion = "**Motion**: on the separatrix (ω period infinite)"
    else:
        motion = f"**Motion**: {solution.kind}, ω period {significant(period, 3)} s"
    lines = [
        motion + f"; plots show the last {window:.3g} s",
        "**Principal moments** " + ", ".join(significant(float(m), 3) for m in g.moments) + " kg m²",
    ]
    if g.L_norm > 0:
        lines.append(
            f"**E** = {significant(g.energy)} J, **|L|** = {significant(g.L_norm)} kg m²/s (constant); "
            + _polhode_text(solution, g)
        )
    for a in (w0, p0, L_global):
        a.setflags(write=False)
    return _Setup(body, inertia, w0, p0, solution, model, g, L_global, ellipsoid, window, "  \n".join(lines))


@dataclasses.dataclass(frozen=True)
class _Config:
    """What one setting of the controls asks for (hashable: the compute key)."""

    body: str
    omega: tuple[float, float, float]  # rad/s, body frame
    method: str
    dt: float  # s, fixed-step methods
    rtol: float  # adaptive methods

    @classmethod
    def from_inputs(cls, inputs: Inputs) -> _Config:
        return cls(inputs.body, (inputs.omega_x, inputs.omega_y, inputs.omega_z), inputs.method,
                   max(float(inputs.dt), _MIN_DT), 10.0 ** float(inputs.rtol_exp))

    @property
    def ghost(self) -> bool:
        return self.method != "none"

    def ghost_text(self) -> str:
        """The ghost's method and step (or tolerance)."""
        if self.method in FIXED_STEP_METHODS:
            return f"{self.method}, dt {self.dt:g} s"
        return f"{self.method}, rtol {self.rtol:.0e}"


def _ghost_label(config: _Config) -> str:
    """The ghost's 3-D label: two short lines."""
    return "ghost\n" + config.ghost_text()


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """One chunk of simulated time: exact samples and, with a ghost, the ghost's (read-only)."""

    k: int
    t: np.ndarray  # (n,) sample times (the ghost's when one runs), s
    exact_p: np.ndarray  # (n, 4) Euler parameters of the exact body
    exact_w: np.ndarray  # (n, 3) omega_body of the exact body (rad/s)
    omega_global: np.ndarray  # (n, 3) omega of the exact body, global frame (rad/s)
    ghost_p: np.ndarray | None  # (n, 4) ghost Euler parameters, normalized for drawing
    ghost_L: np.ndarray | None  # (n, 3) ghost's angular momentum, global frame
    errors: np.ndarray | None  # (n, 5) angle, |omega error|, |dE|/E, |d|L||/|L|, ||p| - 1|
    ghost_end: np.ndarray | None  # (7,) ghost state at the chunk's end (the next chunk starts there)
    failure: str | None  # why the ghost stopped in this chunk
    table: Table
    setup: _Setup


def _run_ghost(setup: _Setup, config: _Config, y0: np.ndarray, t0: float) -> Any:
    """The ghost's run over one chunk from ``y0`` at ``t0``, sampled on the 60 Hz grid
    (or at every step when the step is coarser)."""
    t1 = t0 + _CHUNK_SIM_TIME
    n_samples = round(_CHUNK_SIM_TIME / _SAMPLE_DT)
    if config.method in FIXED_STEP_METHODS:
        if config.dt <= _SAMPLE_DT:  # several steps per display sample
            sub = max(1, round(_SAMPLE_DT / config.dt))
            h = _CHUNK_SIM_TIME / (n_samples * sub)
        else:  # coarse steps: every step is a sample
            sub = 1
            h = _CHUNK_SIM_TIME / math.ceil(_CHUNK_SIM_TIME / config.dt - 1e-9)
        return integrate(setup.model, y0, (t0, t1), method=config.method, dt=h, save_every=sub)
    t_eval = np.linspace(t0, t1, n_samples + 1)
    return integrate(setup.model, y0, (t0, t1), method=config.method, rtol=config.rtol,
                     atol=config.rtol * 1e-2, t_eval=t_eval)


def _compute_chunk(config: _Config, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``config`` (runs on the executor; never on the loop thread)."""
    setup = _setup(config.body, config.omega)
    t0 = k * _CHUNK_SIM_TIME
    run = failure = None
    if config.ghost:
        y0 = setup.state0 if k == 0 else (previous.ghost_end if previous is not None else None)
        if y0 is not None:
            try:
                run = _run_ghost(setup, config, y0, t0)
            except (IntegrationError, ValueError) as exc:
                failure = f"{config.method}: {exc}"
    if run is not None:
        t = np.array(run.t)
    else:  # the exact body alone: drawn at 240 Hz, exported at 60 Hz
        n = round(_CHUNK_SIM_TIME / _SAMPLE_DT) * _EXACT_SAMPLES_PER_ROW
        t = np.linspace(t0, t0 + _CHUNK_SIM_TIME, n + 1)
    exact = setup.solution.at(t)
    p, w = np.array(exact.p), np.array(exact.omega_body)
    omega_global = rotate_vector(p, w)
    rows = slice(None) if run is not None else slice(None, None, _EXACT_SAMPLES_PER_ROW)
    model = setup.model
    inv = model.invariants(np.concatenate([p[rows], w[rows]], axis=1))
    L_norm = np.linalg.norm(inv["angular_momentum_global"], axis=1)
    columns = [p[rows], w[rows], inv["energy"][:, None], L_norm[:, None]]
    ghost_p = ghost_L = errors = ghost_end = None
    if run is not None:
        states = np.array(run.states)
        ghost_inv = model.invariants(states)
        unit = normalize_euler_parameters(states[:, :4])
        ghost_L = model.angular_momentum_global(states[:, 4:], unit)
        ghost_L_norm = np.linalg.norm(ghost_inv["angular_momentum_global"], axis=1)
        energy0, L0 = setup.geometry.energy, setup.geometry.L_norm
        angle = rotation_angle_between(p, states[:, :4])
        errors = np.stack([
            angle,
            np.linalg.norm(w - states[:, 4:], axis=1),
            np.abs(ghost_inv["energy"] / energy0 - 1.0) if energy0 > 0 else np.zeros(t.size),
            np.abs(ghost_L_norm / L0 - 1.0) if L0 > 0 else np.zeros(t.size),
            np.abs(ghost_inv["p_norm"] - 1.0),
        ], axis=1)
        ghost_p, ghost_end = unit, states[-1].copy()
        columns += [states, ghost_inv["energy"][:, None], ghost_L_norm[:, None], angle[:, None]]
    elif config.ghost:
        columns.append(np.full((columns[0].shape[0], 10), np.nan))  # the ghost stopped: empty fields
    arrays = [p, w, omega_global, ghost_p, ghost_L, errors, ghost_end]
    for a in arrays:
        if a is not None:
            a.setflags(write=False)
    t.setflags(write=False)
    table = Table.build(t[rows], np.concatenate(columns, axis=1))
    return _Chunk(k, t, *arrays, failure=failure, table=table, setup=setup)


@dataclasses.dataclass
class _Gui:
    readout: Any  # app.readout.Readout: the motion now (rewritten ~5 times a second)
    info: Any  # app.readout.Readout: the motion's constants (rewritten when they change)
    legend: Legend
    plot_omega: Any
    plot_error: Any
    plot_drift: Any


class FreeBodyScene(PlaybackRequests, Scene):
    """Torque-free rigid body from the exact solution, with a numerical ghost."""

    name: ClassVar[str] = "free_body"
    title: ClassVar[str] = "Free rigid body (Dzhanibekov)"
    order: ClassVar[int] = 30
    help: ClassVar[str] = (
        "A rigid body turning freely about its centre of mass (no torque), started with L "
        "along +Z.\n\n"
        "- **Orange body**: the exact solution of Euler's equations I dω/dt = (I ω) × ω "
        "(body frame) with the Euler-parameter kinematics dp/dt = Ḡ(p)ᵀ ω / 2 "
        "(Eqs. 8.53-8.54; A(p) of Eq. 8.48): ω in Jacobi elliptic functions and the precession "
        "about L by an elliptic integral of the third kind (Landau & Lifshitz sec. 37). "
        "E, |L| and |p| = 1 hold to round-off.\n"
        "- **Blue ghost**: the same equations integrated numerically by the chosen method "
        "(fixed step dt or adaptive with rtol); both bodies are drawn at the ghost's sample "
        "instant. Its error is the angle of the rotation between the two (Eq. 8.82).\n"
        "- **Momentum sphere** (body frame): L_body stays on the sphere |L| = const and on the "
        "energy ellipsoid L·I⁻¹L = 2E; their intersection is the **polhode**. Spin about the "
        "major or minor axis is stable; about the intermediate axis the polhode passes near "
        "the separatrix and the body flips (the Dzhanibekov effect).\n"
        "- Plots: the exact ω_body(t), the ghost's error and its drift of E, |L| and |p| − 1, "
        "over at least two periods of ω. *Download CSV* exports the samples of the window."
    )
    # look a little right of the body so the GUI panel does not cover the ghost
    camera_position: ClassVar[tuple[float, float, float]] = (4.4, 0.85, 1.85)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 1.3, -0.15)

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.playback = Playback(PRESETS, controls=self.controls)
        self.config = _Config.from_inputs(_DEFAULT)
        self.timeline = ChunkTimeline(self.executor, functools.partial(_compute_chunk, self.config),
                                      chunk_time=_CHUNK_SIM_TIME, sequential=True, capacity=_CHUNKS_KEPT)
        self.history = History()
        self._refresh = PlotRefresh(("readout", "omega", "error", "drift"), _REFRESH_PERIOD)
        # owned by update() (the session loop thread)
        self.setup: _Setup | None = None  # constants of the motion drawn (from the chunks)
        self._configured = False
        self.sim_time = 0.0
        self.display_time = 0.0  # time of the drawn poses (the ghost's sample time when one runs)
        self.waiting = False  # the clock holds: the chunk it needs is not ready
        self.p_exact = np.array([1.0, 0.0, 0.0, 0.0])
        self.omega_exact = np.zeros(3)
        self.p_ghost: np.ndarray | None = None
        self.ghost_error: dict[str, float] = {}
        self.ghost_failed = False
        self._error_reported = False
        self.arrow_points = np.zeros((3, 2, 3), dtype=np.float32)
        self._since_trace = math.inf
        self._trace_due = False
        self._trace_part = 0
        self._drawn: tuple[float, int, Any] | None = None
        self._refreshed_time = -1.0
        self._plot_window: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros((0, 0)))
        self.gui: _Gui | None = None

    # -- build -----------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        self.body_frames: dict[str, Any] = {}
        self.ghost_frames: dict[str, Any] = {}
        self.exact_frame = scene.add_frame(f"{root}/exact", position=tuple(_EXACT_POS), axes_length=0.5,
                                           axes_radius=0.015)
        self.ghost_frame = scene.add_frame(f"{root}/ghost", position=tuple(_GHOST_POS), axes_length=0.5,
                                           axes_radius=0.015)
        for i, name in enumerate(BODIES):
            v, f, _ = body_mesh(name)
            self.body_frames[name] = scene.add_mesh_simple(
                f"{root}/exact/body{i}", v, f, color=_EXACT_COLOR, visible=(name == _DEFAULT.body))
            self.ghost_frames[name] = scene.add_mesh_simple(
                f"{root}/ghost/body{i}", v, f, color=_GHOST_COLOR, opacity=0.45,
                visible=(name == _DEFAULT.body))
        self.arrows = self.add_arrows(
            f"{root}/arrows", np.zeros((3, 2, 3), dtype=np.float32), _ARROW_COLORS,
            shaft_radius=0.025, head_radius=0.06, head_length=0.12,
        )
        sphere = trimesh.creation.icosphere(subdivisions=3, radius=_SPHERE_RADIUS)
        self.sphere_frame = scene.add_frame(f"{root}/momentum", position=tuple(_SPHERE_POS), axes_length=1.1,
                                            axes_radius=0.01)
        scene.add_mesh_simple(f"{root}/momentum/sphere", sphere.vertices.astype(np.float32),
                              sphere.faces.astype(np.uint32), color=(200, 200, 230), opacity=0.15)
        self.ellipsoid = self.add_lines(
            f"{root}/momentum/ellipsoid", np.zeros((7 * _ELLIPSE_SEGMENTS, 2, 3), dtype=np.float32),
            _ELLIPSOID_COLOR, thickness=0.008,
        )
        self.polhode = ChunkedTrail(self, f"{root}/momentum/polhode", _POLHODE_COLOR, thickness=0.025,
                                    capacity=_POLHODE_CAPACITY, min_step=_POLHODE_MIN_STEP)
        self.L_point = scene.add_icosphere(f"{root}/momentum/L", radius=0.05, color=_L_COLOR)
        # 3-D labels, in static places (a label in a turning frame would orbit
        # with it): below the exact body, above the ghost's L arrow, above the
        # sphere, at the tip of L (always along +Z) and at the tip of omega
        # (which moves; omega . L = 2E > 0 keeps it in the upper half).
        self.labels = {
            "exact": self.add_label(f"{root}/label_exact", "exact solution",
                                    position=_EXACT_POS + (0.0, 0.0, -0.95), anchor="top-center",
                                    scale=_LABEL_SCALE),
            "ghost": self.add_label(f"{root}/label_ghost", _ghost_label(self.config),
                                    position=_GHOST_POS + (0.0, 0.0, _ARROW_LENGTH + 0.08), anchor="bottom-center",
                                    scale=_LABEL_SCALE),
            "sphere": self.add_label(f"{root}/label_sphere", "momentum sphere\n(body frame)",
                                     position=_SPHERE_POS + (0.0, 0.0, _SPHERE_RADIUS + 0.12),
                                     anchor="bottom-center", scale=_LABEL_SCALE),
            "L": self.add_label(f"{root}/label_L", "L", position=_EXACT_POS + (0.0, 0.0, _ARROW_LENGTH + 0.08),
                                anchor="bottom-center", scale=_LABEL_SCALE),
            "omega": self.add_label(f"{root}/label_omega", "ω", anchor="bottom-left", scale=_LABEL_SCALE),
        }
        gui = self.target.gui
        with self.make_folder():
            legend = Legend(gui, (
                (_EXACT_COLOR, "exact solution (body axes red x, green y, blue z)"),
                (_GHOST_COLOR, "ghost: the chosen integrator"),
                (_L_COLOR, "L angular momentum (fixed in space)"),
                (_OMEGA_COLOR, "ω angular velocity"),
                (_GHOST_L_COLOR, "the ghost's L"),
                (_POLHODE_COLOR, "polhode: L_body on the momentum sphere"),
                (_ELLIPSOID_COLOR, "energy ellipsoid L·I⁻¹L = 2E"),
            ), presenter=self.presenter)
            self.playback.add_gui()
            readout = self.add_readout("Computing the motion…")
            info = self.add_readout("")
            self.controls.add(Choice("body", "Body", options=BODIES, default=_DEFAULT.body))
            self.playback.add_preset_buttons()
            with gui.add_folder("Initial ω (body frame, rad/s)"):
                for key, label in zip(_OMEGA_KEYS, ("ω_x", "ω_y", "ω_z"), strict=True):
                    self.controls.add(Slider(key, label, min=-10.0, max=10.0, step=0.001,
                                             default=getattr(_DEFAULT, key)))
            with gui.add_folder("Ghost integrator"):
                self.controls.add(Choice("method", "Method", options=INTEGRATORS, default=_DEFAULT.method))
                self.controls.add(Slider("dt", "Step dt (s)", min=0.001, max=0.2, step=0.001, default=_DEFAULT.dt,
                                         hint="Fixed-step methods"))
                self.controls.add(Slider("rtol_exp", "log10 rtol", min=-13.0, max=-3.0, step=1.0,
                                         default=_DEFAULT.rtol_exp, hint="Adaptive methods (scipy)"))
            with self.plot_area():
                # plotted as log10 values on linear axes (uPlot's log axes label
                # tiny values as 0)
                floor = math.log10(_LOG_FLOOR)
                x_scale = {"x": {"time": False}}
                plot_omega = self.add_plot(
                    (np.zeros(2),) + (np.zeros(2),) * 3,
                    ({"label": "t (s)"}, {"label": "ω_x (rad/s)", "stroke": "#dc2626", "width": 2},
                     {"label": "ω_y (rad/s)", "stroke": "#16a34a", "width": 2},
                     {"label": "ω_z (rad/s)", "stroke": "#2563eb", "width": 2}),
                    title="exact ω_body(t) (body frame)", scales=x_scale, aspect=1.6,
                )
                plot_error = self.add_plot(
                    (np.zeros(2), np.full(2, floor), np.full(2, floor)),
                    ({"label": "t (s)"}, {"label": "log10 angle error (rad)", "stroke": "#b45309", "width": 2},
                     {"label": "log10 |ω error| (rad/s)", "stroke": "#7c3aed", "width": 2}),
                    title="ghost error vs exact (log10)", scales=x_scale, aspect=1.6,
                )
                plot_drift = self.add_plot(
                    (np.zeros(2),) + (np.full(2, floor),) * 3,
                    ({"label": "t (s)"}, {"label": "log10 |ΔE|/E", "stroke": "#0f766e"},
                     {"label": "log10 |Δ|L||/|L|", "stroke": "#1f2937"},
                     {"label": "log10 ||p|-1|", "stroke": "#be185d"}),
                    title="ghost drift of invariants (log10)", scales=x_scale, aspect=1.6,
                )
            self.add_download("download_csv", "Download CSV", "free_body.csv", self.csv_bytes,
                              hint="t, Euler parameters, ω_body, E, |L| of the plotted window (and the ghost's)")
        self.gui = _Gui(readout, info, legend, plot_omega, plot_error, plot_drift)

    def on_presenter(self, on: bool) -> None:
        if self.gui is not None:
            self.gui.legend.set_presenter(on)

    # -- read by tests and notebooks ---------------------------------------------
    @property
    def inputs(self) -> Inputs:
        """The values of the controls in use."""
        values = self.controls.values()
        return Inputs(**{key: values[key] for key in _INPUT_KEYS})

    @property
    def window(self) -> float:
        """Length of the plot window (s) of the motion drawn."""
        return self.setup.window if self.setup is not None else _WINDOW_FALLBACK

    # -- inputs ------------------------------------------------------------------
    def _configure(self, inputs: Inputs) -> None:
        """Use ``inputs``: new chunks from t = 0."""
        config = _Config.from_inputs(inputs)
        previous = self.config
        self.config = config
        self._configured = True
        self.ghost_failed = False
        self._error_reported = False
        self.ghost_error = {}
        self.timeline.reset(functools.partial(_compute_chunk, config))
        self.labels["ghost"].text = _ghost_label(config)
        if config.body != previous.body or not self.body_frames[config.body].visible:
            for name in BODIES:
                self.body_frames[name].visible = name == config.body
                self.ghost_frames[name].visible = name == config.body
        for plot in (self.gui.plot_error, self.gui.plot_drift):
            plot.visible = config.ghost
        self._restart()

    def _restart(self) -> None:
        self.sim_time = 0.0
        self.polhode.clear()
        self._trace_due = True
        self._since_trace = math.inf
        self.history.clear()
        self._drawn = None
        self._refreshed_time = -1.0
        self._refresh.force()

    # -- update --------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        preset = self.playback.take_preset()
        changed = self.controls.take_changes()
        if preset is not None:
            _, _, inertia = body_mesh(str(self.controls.value("body")))
            w = preset_omega(preset, inertia)
            self.controls.set_many({key: float(x) for key, x in zip(_OMEGA_KEYS, w, strict=True)})
            self.playback.set_playing(True)
        if not self._configured or preset is not None or changed & _INPUT_KEYS:
            self._configure(self.inputs)
        tick = self.playback.tick(dt)
        if tick.reset:
            self._restart()
        chunk = self._advance(tick.step)
        if chunk is not None:
            self._draw(chunk, dt)

    def _advance(self, step: float) -> _Chunk | None:
        """Move the clock by ``step`` if the chunk it lands in is ready; the chunk to draw."""
        self.sim_time, chunk, self.waiting = self.timeline.advance(self.sim_time, step)
        if self.timeline.error is not None and not self._error_reported:
            # not a ghost failure (those travel in the chunks): the exact motion failed
            self._error_reported = True
            self.playback.set_playing(False)
            self.notify("Motion stopped", f"{type(self.timeline.error).__name__}: {self.timeline.error}", "warning")
        return chunk

    def _draw(self, chunk: _Chunk, dt: float) -> None:
        new_setup = chunk.setup is not self.setup
        key = (self.sim_time, chunk.k, chunk.setup)
        self._since_trace += dt
        due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
        if key == self._drawn and not new_setup:
            # paused: the poses are on the page already; only a last refresh may be due
            if due is not None or self._trace_due:
                with self.target.atomic():
                    while self._trace_due:
                        self._send_trace()
                    if due is not None:
                        self._refresh_one(due)
            return
        self._drawn = key
        setup = chunk.setup
        if new_setup:
            self.setup = setup
        self.history.add(chunk.k, chunk.table)
        if chunk.failure is not None and not self.ghost_failed:
            self.ghost_failed = True
            self.notify("Ghost integrator stopped", chunk.failure, "warning")
        # The sample at or before the clock: the ghost's (every 1/60 s of
        # simulated time, or every step when the step is coarser), or the exact
        # body's alone (every 1/240 s). With a ghost, the exact body is drawn at
        # the ghost's instant (at most one sample behind the clock) so that the
        # two poses compare directly.
        i = max(0, int(np.searchsorted(chunk.t, self.sim_time + 1e-9, side="right")) - 1)
        self.display_time = float(chunk.t[i])
        p, w, omega_global = chunk.exact_p[i], chunk.exact_w[i], chunk.omega_global[i]
        ghost_p = ghost_L = None
        if chunk.ghost_p is not None:
            ghost_p, ghost_L = chunk.ghost_p[i], chunk.ghost_L[i]
            assert chunk.errors is not None
            self.ghost_error = dict(zip(("t", "angle", "omega", "energy", "L", "p_norm"),
                                        [self.display_time, *chunk.errors[i].tolist()], strict=True))
        self.p_exact, self.omega_exact, self.p_ghost = p, w, ghost_p
        # body-frame angular momentum on the momentum sphere (polhode)
        L_norm = setup.geometry.L_norm
        point = (setup.inertia @ w) * (_SPHERE_RADIUS / L_norm) if L_norm > 0 else np.zeros(3)
        self._trace_due |= self.polhode.add(point)
        arrows = self._arrow_points(setup, omega_global, ghost_L)
        finite = bool(np.all(np.isfinite(arrows)))  # never send a non-finite point
        if finite:
            self.arrow_points = arrows
        with self.target.atomic():
            if new_setup:
                self.gui.info.content = setup.readout
                self.ellipsoid.points = setup.ellipsoid
                self.labels["L"].visible = setup.geometry.L_norm > 0
            set_pose(self.exact_frame, wxyz=p)
            self.ghost_frame.visible = ghost_p is not None
            self.labels["ghost"].visible = ghost_p is not None
            if ghost_p is not None:
                set_pose(self.ghost_frame, wxyz=ghost_p)
            self.arrows.visible = finite
            if finite:
                set_array(self.arrows, "points", arrows)
            # one part of the trace per frame, not in a frame that sends a plot
            if due is None and self._trace_due and (self._since_trace >= _TRACE_PERIOD or self._trace_part != 0):
                self._send_trace()
            if due is not None:
                self._refresh_one(due)

    def _send_trace(self) -> None:
        """Polhode, the L point on the sphere and the ω label, one of them per frame
        (each at most every 0.05 s), so no frame sends all three."""
        part = self._trace_part
        self._trace_part = (part + 1) % 3
        if part == 2:
            self._since_trace = 0.0
            self._trace_due = False
        if part == 0:
            self.polhode.flush()  # the newest chunk of the polhode only
        elif part == 1:
            newest = self.polhode.newest
            if newest is not None:
                set_pose(self.L_point, position=newest)
        else:
            tip = self.arrow_points[1, 1]
            omega_shown = bool(np.any(tip != self.arrow_points[1, 0]))
            if omega_shown:
                set_pose(self.labels["omega"], position=tip)
            self.labels["omega"].visible = omega_shown

    @staticmethod
    def _arrow_points(setup: _Setup, omega_global: np.ndarray, ghost_L: np.ndarray | None) -> np.ndarray:
        """L and omega at the exact body, the ghost's L at the ghost: (3, 2, 3) float32."""
        out = np.zeros((3, 2, 3), dtype=np.float32)
        out[:, 0] = (_EXACT_POS, _EXACT_POS, _GHOST_POS)
        out[:, 1] = out[:, 0]
        n = setup.geometry.L_norm
        if n > 0:
            out[0, 1] = _EXACT_POS + _ARROW_LENGTH * setup.L_global / n
        m = float(np.linalg.norm(omega_global))
        if m > 0:  # length saturates: 1.3 m |omega| / (|omega| + 3 rad/s)
            out[1, 1] = _EXACT_POS + _ARROW_LENGTH * omega_global / (m + _OMEGA_HALF)
        if ghost_L is not None:
            ng = float(np.linalg.norm(ghost_L))
            if ng > 0:
                # the ghost's |p| drifts with the integrator's error (plotted); the
                # arrow is drawn for the rotation it represents
                out[2, 1] = _GHOST_POS + _ARROW_LENGTH * ghost_L / ng
        return out

    # -- plots, readout, export ------------------------------------------------------
    def _window_start(self) -> float:
        return max(0.0, self.display_time - self.window)

    def _refresh_one(self, what: str) -> None:
        assert self.gui is not None and self.setup is not None
        if what == "readout":
            # the readout opens each refresh cycle: the plots of the cycle
            # (the next frames) show the window as it is now
            self._refreshed_time = self.sim_time
            self._plot_window = self.history.trimmed_window(self._window_start(), self.display_time)
            self.gui.readout.content = self._readout()
            return
        if what in ("error", "drift") and not self.config.ghost:
            return
        t, columns = self._plot_window
        if t.size == 0:
            return
        if what == "omega":
            self.gui.plot_omega.data = (t, columns[:, 4], columns[:, 5], columns[:, 6])
            return
        if columns.shape[1] < 19:
            return
        ghost = columns[:, 9:]  # p (4), omega (3), E, |L|, angle error
        g = self.setup.geometry
        with np.errstate(divide="ignore", invalid="ignore"):
            if what == "error":
                values = (ghost[:, 9], np.linalg.norm(ghost[:, 4:7] - columns[:, 4:7], axis=1))
            else:
                values = (
                    np.abs(ghost[:, 7] / g.energy - 1.0) if g.energy > 0 else np.zeros(t.size),
                    np.abs(ghost[:, 8] / g.L_norm - 1.0) if g.L_norm > 0 else np.zeros(t.size),
                    np.abs(np.linalg.norm(ghost[:, :4], axis=1) - 1.0),
                )
            logs = [np.log10(np.maximum(np.nan_to_num(v, nan=_LOG_FLOOR), _LOG_FLOOR)) for v in values]
        plot = self.gui.plot_error if what == "error" else self.gui.plot_drift
        plot.data = (t, *logs)

    def _readout(self) -> str:
        assert self.setup is not None
        lines = [f"**t** = {self.display_time:.2f} s"]
        config = self.config
        if config.ghost:
            if self.ghost_failed:
                lines.append(f"**Ghost** {config.ghost_text()}: stopped (see the notice)")
            elif self.ghost_error:
                e = self.ghost_error
                lines.append(
                    f"**Ghost** {config.ghost_text()}: angle error {e['angle']:.1e} rad, "
                    f"|ΔE|/E {e['energy']:.0e}, |Δ|L||/|L| {e['L']:.0e}, ||p| − 1| {e['p_norm']:.0e}"
                )
        if self.waiting and self.playback.playing:
            lines.append("*computing the next chunk…*")
        return "\n\n".join(lines)

    def csv_bytes(self) -> bytes:
        """The CSV of the trajectory in the plot window, up to the displayed time."""
        header = CSV_HEADER_GHOST if self.config.ghost else CSV_HEADER
        return self.history.csv(header, self._window_start(), self.display_time)
