"""Gyroscope scene: a rotor in a cardan suspension (the chapter's gyroscope).

Three nested bodies on a base, each turned by its own ZXZ Euler angle:

* the outer gimbal turns about the base axis Z1 by the precession ``phi``;
* the inner gimbal turns about the line of nodes X2 by the nutation ``theta``;
* the rotor spins about its axis Z3 by ``psi``.

The nodes are nested frames, so each frame streams one pose: three poses per
frame. The rotor-axis tip leaves a trail (chunks of segments, only the newest re-sent) on a
sphere, showing nutation loops, waves or cusps. Arrows from the fixed point
show the angular velocity, the angular momentum and the torque, in colours
that are not the red / green / blue of frame axes, with labels and a legend.

The scene holds no physics. Everything long runs on the app's executor
(:class:`app.jobs.ChunkTimeline`), in chunks of 2 s of simulated time ahead
of the display clock, and the clock holds while the chunk it needs is not
ready. Without applied torques :func:`core.gyroscope.top_motion` evaluates
the closed form at absolute times (its constants computed once per
parameter set); with them :func:`core.gyroscope.simulate` runs DOP853,
continuing from the previous chunk. The same job evaluates
:func:`core.gyroscope.rotor_vectors` and :func:`core.gyroscope.invariants`
at every sample and formats the CSV rows. The other per-model constants
(:func:`core.gyroscope.nutation`, the plot window, the static readout) are
computed once per parameter set on the executor and cached. The loop thread
only interpolates between samples and converts the angles to viser's
``wxyz`` (Euler parameters) with
:func:`core.rotations.euler_parameters_from_axis_angle`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.controls import Slider, Toggle
from app.nodes import set_array, set_pose
from app.readout import one_digit, significant
from app.scenes._playback import Playback, PlaybackRequests
from app.scenes._plots import History, Legend, PlotRefresh, Table, window_seconds
from app.scenes._trail import ChunkedTrail
from app.scenes.base import Scene
from app.jobs import ChunkTimeline
from core.gyroscope import (
    NutationResult,
    RotorParams,
    TopMotion,
    invariants,
    nutation,
    rotor_vectors,
    simulate,
    sleeping_top_critical_spin,
    steady_precession_rates,
    steady_precession_torque,
    top_motion,
)
from core.rotations import euler_parameters_from_axis_angle

__all__ = ["CSV_HEADER", "GyroscopeScene", "Inputs", "PRESETS", "SLIDERS", "drift_log10", "preset_inputs"]

# Geometry (scene units = metres): ring radii, rotor, trail sphere.
_OUTER_RADIUS = 1.2
_INNER_RADIUS = 1.0
_RING_TUBE = 0.035
_ROTOR_RADIUS = 0.6
_ROTOR_THICKNESS = 0.14
_TIP_RADIUS = 1.35  # the trail sphere: rotor axis tip
_BASE_Z = -1.6

_TRAIL_CAPACITY = 400  # line segments kept in the trail buffer
_TRAIL_MIN_STEP = 0.004  # do not add a trail point closer than this (m)
DRIFT_FLOOR_LOG10 = -17.0  # below double-precision round-off of O(1) invariants
_REFRESH_PERIOD = 0.25  # s of wall time between plot / readout refreshes (4 Hz; bytes: docs/app.md)
_TRAIL_PERIOD = 0.05  # s of wall time between trail buffer updates
_CHUNK_SIM_TIME = 2.0  # s of simulated time per computed chunk
_CHUNK_SAMPLES = 481  # samples per chunk (240 per simulated second)
_CHUNKS_KEPT = 8  # chunks the timeline keeps for a replay (the history keeps the window's tables)
_NUMERICAL_RTOL = 1e-9  # display accuracy of the torque-driven runs
_NUMERICAL_ATOL = 1e-10
_WINDOW_CAP = 60.0  # s: longest plot window
_WINDOW_FALLBACK = 10.0  # s: plot window when no nutation period is known

# Arrow lengths saturate: length = max |v| / (|v| + half) (m). omega's is
# shorter than L's, so that their tips (and labels) stay apart for a fast top,
# where both lie nearly along the rotor axis.
_ARROW_MAX = (1.8, 2.4, 2.4)  # m: omega, L, torque
_ARROW_HALF = (5.0, 4.0, 1.0)  # omega (rad/s), L (kg m^2/s), torque (N m)
# Arrow and trail colours: none of them red, green or blue (the frame axes).
_OMEGA_COLOR = (200, 30, 160)  # magenta
_MOMENTUM_COLOR = (25, 25, 35)  # near black
_TORQUE_COLOR = (245, 140, 0)  # orange
_TRAIL_COLOR = (0, 160, 150)  # teal
_ARROW_COLORS = np.array([_OMEGA_COLOR, _MOMENTUM_COLOR, _TORQUE_COLOR], dtype=np.uint8)
_OUTER_COLOR = (176, 156, 122)  # muted, so the arrows stand out
_INNER_COLOR = (128, 160, 192)
_LABEL_SCALE = 1.3  # 3-D labels: about 16 px (presenter view: x 1.8)
_ARROW_LABELS = ("ω", "L", "M")
# Where the arrow labels sit (every frame, in the message that moves the
# arrows). omega and L lie nearly along the rotor axis for a fast top: seen
# along that axis their tips fall on one spot of the screen. So the labels of
# omega and L keep the vertical order of their tips: the label of the higher
# tip sits above it (3-D offset "up", perpendicular to its arrow, and a screen
# anchor that puts the text above the point), the other's below, and both lie
# a little beyond their tips along their arrows, past the heads. A camera
# with +Z up sees the up/down offsets as up/down on the screen from any side,
# so the two labels stay apart even when both arrows point at the camera. The
# order swaps only when the other tip is higher by _LABEL_SWAP (no flicker
# while two tips are level). M's label sits beyond its tip, centred.
# Projected over 6 s of the default motion, every preset and three other
# settings, with 73 cameras (18 azimuths x 4 elevations, 0-60 deg, 4.4 m from
# O, and the default view): two of the three arrow labels overlapped in 22 %
# of the views with the labels at the tips (fixed anchors), in 2 % with this
# placement; with the camera near the rotor axis (on it and 0.3 m off), in
# 42 % and 0.1 %. tests/app/test_gyroscope.py checks the presets seen along
# the axis.
_LABEL_BEYOND = (0.15, 0.15, 0.2)  # m beyond the tip along the arrow: omega, L, M
_LABEL_ASIDE = 0.1  # m up (or down) perpendicular to the arrow: omega and L
_LABEL_SINE_FLOOR = 0.5  # the up offset shrinks for arrows nearer than asin(this) to the vertical
_LABEL_SWAP = 0.05  # m: hysteresis of the vertical order of omega's and L's tips
_UPPER_ANCHOR = "bottom-right"  # the point is the label's bottom-right corner: text above and left of it
_LOWER_ANCHOR = "top-left"  # text below and right of the point
_TORQUE_ANCHOR = "center-center"
_AXES = tuple(np.array(a) for a in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)))  # Z1, X2, Z3 in their parents


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's sliders (degrees only for theta0)."""

    theta0_deg: float = 60.0
    theta_dot0: float = 0.0
    phi_dot0: float = 0.0
    psi_dot0: float = 12.0
    I: float = 1.0
    I3: float = 0.8
    mgl: float = 2.0
    m_phi: float = 0.0
    m_theta: float = 0.0
    m_psi: float = 0.0

    @classmethod
    def from_values(cls, values: dict[str, Any]) -> Inputs:
        """The inputs of control values ``values`` (``ControlPanel.values()``, or a state's values over them)."""
        return cls(**{key: float(values[key]) for key in _MODEL_KEYS})


_DEFAULT = Inputs()

#: The sliders, by folder: initial state, rotor, applied torques. Rates are
#: written dθ/dt etc. (a combining dot over φ or ψ is lost in some browsers).
SLIDERS: tuple[Slider, ...] = (
    Slider("theta0_deg", "θ (deg)", min=0.0, max=180.0, step=0.1, default=_DEFAULT.theta0_deg,
           hint="Nutation angle θ at t = 0 (deg)"),
    Slider("theta_dot0", "dθ/dt (rad/s)", min=-5.0, max=5.0, step=0.01, default=_DEFAULT.theta_dot0,
           hint="Nutation rate at t = 0"),
    Slider("phi_dot0", "dφ/dt (rad/s)", min=-5.0, max=5.0, step=0.001, default=_DEFAULT.phi_dot0,
           hint="Precession rate at t = 0"),
    Slider("psi_dot0", "dψ/dt (rad/s)", min=-100.0, max=100.0, step=0.01, default=_DEFAULT.psi_dot0,
           hint="Spin rate dψ/dt at t = 0"),
    Slider("I", "I (kg m²)", min=0.1, max=5.0, step=0.01, default=_DEFAULT.I,
           hint="Transverse moment of inertia about the fixed point"),
    Slider("I3", "I3 (kg m²)", min=0.1, max=5.0, step=0.01, default=_DEFAULT.I3,
           hint="Axial moment of inertia (at most 2 I)"),
    Slider("mgl", "mgl (N m)", min=0.0, max=10.0, step=0.01, default=_DEFAULT.mgl,
           hint="Gravity moment; 0 = balanced rotor"),
    Slider("m_phi", "M_φ (N m)", min=-5.0, max=5.0, step=0.01, default=_DEFAULT.m_phi,
           hint="Generalized torque on φ (outer gimbal motor)"),
    Slider("m_theta", "M_θ (N m)", min=-5.0, max=5.0, step=0.001, default=_DEFAULT.m_theta,
           hint="Generalized torque on θ (inner gimbal motor)"),
    Slider("m_psi", "M_ψ (N m)", min=-5.0, max=5.0, step=0.01, default=_DEFAULT.m_psi,
           hint="Generalized torque on ψ (rotor motor)"),
)
_MODEL_KEYS = frozenset(s.key for s in SLIDERS)

#: Preset names in the order of their buttons.
PRESETS = (
    "Steady precession (torque M_θ)",
    "Steady precession (gravity)",
    "Fast top (pseudo-regular)",
    "Cuspidal motion",
    "Sleeping top above critical",
    "Sleeping top below critical",
)

#: Header of the exported CSV (one line: column names with units).
CSV_HEADER = (
    "t (s),phi (rad),theta (rad),psi (rad),dphi/dt (rad/s),dtheta/dt (rad/s),dpsi/dt (rad/s),"
    "d1 (kg m^2/s),d2 (kg m^2/s),E (J)"
)


def preset_inputs(name: str) -> Inputs:
    """Slider values of preset ``name`` (solved with core.gyroscope).

    Raises
    ------
    ValueError
        For an unknown preset name.
    """
    if name == PRESETS[0]:
        # balanced rotor held at theta = 90 deg by M_theta of Eq. 8.23
        # (I3 psi_dot phi_dot = 4 N m, inside the M_theta slider's range)
        params = RotorParams(I=1.0, I3=0.8, mgl=0.0)
        m_theta = float(steady_precession_torque(params, math.pi / 2, 0.5, 10.0))
        return Inputs(90.0, 0.0, 0.5, 10.0, 1.0, 0.8, 0.0, 0.0, m_theta, 0.0)
    if name == PRESETS[1]:
        params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
        theta, spin = math.radians(60.0), 15.0
        slow = float(steady_precession_rates(params, theta, spin).slow)
        return Inputs(60.0, 0.0, slow, spin - slow * math.cos(theta), 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    if name == PRESETS[2]:
        # fast top started at half the slow steady rate: small fast wiggles
        params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
        theta, spin = math.radians(60.0), 40.0
        slow = float(steady_precession_rates(params, theta, spin).slow)
        phid = 0.5 * slow
        return Inputs(60.0, 0.0, phid, spin - phid * math.cos(theta), 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    if name == PRESETS[3]:
        # released with phi_dot = theta_dot = 0: cusps at theta_min
        return Inputs(50.0, 0.0, 0.0, 8.0, 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    if name in (PRESETS[4], PRESETS[5]):
        params = RotorParams(I=1.0, I3=0.8, mgl=2.0)
        factor = 1.15 if name == PRESETS[4] else 0.85
        spin = factor * sleeping_top_critical_spin(params)
        return Inputs(3.0, 0.0, 0.0, round(spin, 4), 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    raise ValueError(f"name: expected one of {list(PRESETS)}, got {name!r}")


def drift_log10(drift: np.ndarray) -> np.ndarray:
    """``log10 |drift|`` for the drift plot, floored at :data:`DRIFT_FLOOR_LOG10`.

    Round-off drifts (~1e-15) would all print as ``0`` on a linear axis; an
    exact zero (the first sample) would be ``-inf``.
    """
    with np.errstate(divide="ignore"):
        return np.maximum(np.log10(np.abs(drift)), DRIFT_FLOOR_LOG10)




# -- the model: what one setting of the sliders asks the core for -------------
@dataclasses.dataclass(frozen=True)
class _Model:
    """Rotor, initial state and applied torques of one setting of the sliders.

    Built on the loop thread: :class:`RotorParams` checks the rotor (I3 <= 2 I
    and the rest) once here; the jobs only read it.
    """

    inputs: Inputs
    params: RotorParams
    state0: tuple[float, float, float, float, float, float]  # (phi, theta, psi, phi_dot, theta_dot, psi_dot)
    torques: tuple[float, float, float]  # (M_phi, M_theta, M_psi), N m

    @classmethod
    def from_inputs(cls, inputs: Inputs) -> _Model:
        """Raises ValueError (naming the parameter) for a rotor :class:`RotorParams` refuses."""
        params = RotorParams(I=inputs.I, I3=inputs.I3, mgl=inputs.mgl)
        state0 = (0.0, math.radians(inputs.theta0_deg), 0.0, inputs.phi_dot0, inputs.theta_dot0, inputs.psi_dot0)
        return cls(inputs, params, state0, (inputs.m_phi, inputs.m_theta, inputs.m_psi))

    @property
    def has_torque(self) -> bool:
        return any(m != 0.0 for m in self.torques)


@dataclasses.dataclass(frozen=True)
class _Analysis:
    """Per-model constants, computed once per parameter set (on the executor)."""

    motion: TopMotion | None  # the closed form's constants (None when torques act)
    prediction: NutationResult | None  # closed-form nutation (None when torques act)
    invariants0: np.ndarray  # (3,) d1, d2, E at t = 0
    window: float  # s, plot window
    readout: str  # the model's constants for the panel (Markdown)


@functools.lru_cache(maxsize=32)
def _analysis(model: _Model) -> _Analysis:
    """Closed-form constants, nutation prediction, invariants at t = 0, plot window and
    static readout of ``model`` (cached: once per parameter set)."""
    p = model.params
    state0 = np.array(model.state0)
    motion = prediction = None
    if not model.has_torque:
        motion = top_motion(p, state0)
        try:
            prediction = nutation(p, state0)
        except ValueError:
            prediction = None
    inv = invariants(p, state0)
    invariants0 = np.array([float(inv.d1), float(inv.d2), float(inv.energy)])
    invariants0.setflags(write=False)
    period = float(prediction.period) if prediction is not None else math.nan
    window = window_seconds(period, fallback=_WINDOW_FALLBACK, cap=_WINDOW_CAP)
    spin = state0[5] + state0[3] * math.cos(state0[1])
    lines = [
        f"**Spin** ω3 = dψ/dt + dφ/dt cos θ = {significant(spin, 3)} rad/s; "
        f"sleeping top critical spin {significant(sleeping_top_critical_spin(p), 3)} rad/s",
    ]
    if prediction is not None:
        nu = prediction
        theta_min, theta_max = math.degrees(float(nu.theta_min)), math.degrees(float(nu.theta_max))
        if math.isinf(period):
            lines.append(f"**Nutation** (Eq. 8.21): none, θ stays at {theta_min:.2f}°; "
                         f"dφ/dt = {significant(float(nu.mean_precession_rate), 3)} rad/s")
        else:
            lines.append(
                f"**Nutation** (Eq. 8.21): θ from {theta_min:.2f}° to {theta_max:.2f}°, "
                f"period {significant(period, 3)} s; mean dφ/dt "
                f"{significant(float(nu.mean_precession_rate), 3)} rad/s"
            )
        lines.append(f"Plots show the last {window:.3g} s" + (
            f" ({window / period:.1f} nutation periods)." if math.isfinite(period) else "."))
    else:
        lines.append("**Nutation**: applied torques act, no closed-form prediction "
                     "(DOP853 on Eq. 8.16).")
        lines.append(f"Plots show the last {window:.3g} s.")
    return _Analysis(motion, prediction, invariants0, window, "  \n".join(lines))


# Columns of _Chunk.samples: angles phi, theta, psi (rad); rates (rad/s); the
# rotor-axis tip on the trail sphere (m); omega (rad/s), L (kg m^2/s) and the
# torque (N m), all in the global frame.
_ANGLES, _RATES, _TIP, _VECTORS = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 18)


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """Samples of the motion over one chunk of simulated time (read-only arrays)."""

    k: int
    t0: float  # s, time of the first sample
    h: float  # s, sample spacing
    samples: np.ndarray  # (n, 18): what a frame draws, interpolated as one row (columns below)
    invariants: np.ndarray  # (n, 3) d1, d2, E
    table: Table  # t, angles, rates, invariants for the plots and the CSV
    method: str  # "closed_form", "steady" or "numerical"
    analysis: _Analysis


def _compute_chunk(model: _Model, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``model`` (runs on the executor; never on the loop thread).

    Closed form (no applied torque): exact at absolute times from the initial
    state. Torques: DOP853 from the end of chunk ``k - 1`` (``previous``).
    """
    analysis = _analysis(model)
    t = np.linspace(k * _CHUNK_SIM_TIME, (k + 1) * _CHUNK_SIM_TIME, _CHUNK_SAMPLES)
    if analysis.motion is not None:
        traj = analysis.motion.at(t)  # the per-model constants are computed once
    else:
        if k == 0 or previous is None:
            start = np.array(model.state0)
        else:
            start = np.array(previous.samples[-1, :6])
        traj = simulate(model.params, start, t - t[0], torques=model.torques,
                        rtol=_NUMERICAL_RTOL, atol=_NUMERICAL_ATOL)
    states = np.concatenate([traj.angles, traj.rates], axis=1)
    vec = rotor_vectors(model.params, states, model.torques)
    inv = invariants(model.params, states)
    inv_columns = np.stack([inv.d1, inv.d2, inv.energy], axis=1)
    vectors = np.stack([vec.omega, vec.angular_momentum, vec.torque], axis=1)
    tip = _TIP_RADIUS * vec.rotor_axis
    for name, a in (("angles", traj.angles), ("rates", traj.rates), ("vectors", vectors), ("invariants", inv_columns)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the motion left the finite range near t = {t[0]:.3g} s")
    samples = np.concatenate([traj.angles, traj.rates, tip, vectors.reshape(-1, 9)], axis=1)
    inv_columns = np.array(inv_columns, dtype=float)
    for a in (samples, inv_columns):
        a.setflags(write=False)
    table = Table.build(t, np.concatenate([traj.angles, traj.rates, inv_columns], axis=1))
    return _Chunk(k, float(t[0]), float(t[1] - t[0]), samples, inv_columns, table, traj.method, analysis)


# -- meshes ---------------------------------------------------------------------
def _ring_mesh(radius: float) -> trimesh.Trimesh:
    """A ring in the frame's x-z plane (its axis along y)."""
    ring = trimesh.creation.torus(radius, _RING_TUBE, major_sections=72, minor_sections=12)
    ring.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))
    return ring


def _cylinder_between(a, b, radius: float) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([a, b], dtype=float), sections=20)


@functools.cache  # one set per process, shared by every session: read them, never modify them
def _meshes() -> dict[str, trimesh.Trimesh]:
    base = trimesh.util.concatenate([
        trimesh.creation.cylinder(radius=0.55, height=0.1, sections=48,
                                  transform=trimesh.transformations.translation_matrix([0, 0, _BASE_Z])),
        _cylinder_between([0, 0, _BASE_Z], [0, 0, -_OUTER_RADIUS - _RING_TUBE], 0.045),
    ])
    outer = trimesh.util.concatenate([
        _ring_mesh(_OUTER_RADIUS),
        _cylinder_between([0, 0, -_OUTER_RADIUS - 0.12], [0, 0, -_OUTER_RADIUS], 0.05),
    ])
    inner = trimesh.util.concatenate([
        _ring_mesh(_INNER_RADIUS),
        _cylinder_between([-_OUTER_RADIUS, 0, 0], [-_INNER_RADIUS, 0, 0], 0.03),
        _cylinder_between([_INNER_RADIUS, 0, 0], [_OUTER_RADIUS, 0, 0], 0.03),
    ])
    rotor = trimesh.util.concatenate([
        trimesh.creation.cylinder(radius=_ROTOR_RADIUS, height=_ROTOR_THICKNESS, sections=64),
        # a thin axle, so the arrows along it (omega and L of a fast top) show around it
        _cylinder_between([0, 0, -_INNER_RADIUS], [0, 0, _TIP_RADIUS], 0.02),
        trimesh.creation.icosphere(subdivisions=2, radius=0.05).apply_translation([0, 0, _TIP_RADIUS]),
    ])
    marker = trimesh.creation.box(extents=(0.18, 0.1, _ROTOR_THICKNESS * 1.08))
    marker.apply_translation([_ROTOR_RADIUS - 0.1, 0, 0])
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=_TIP_RADIUS)
    return {"base": base, "outer": outer, "inner": inner, "rotor": rotor, "marker": marker, "sphere": sphere}


#: The 3-D labels on the bodies: (node under the scene root, text, position in
#: that node's frame, screen anchor). None spins: the outer gimbal's sits on
#: the top of its ring (on Z1), the inner gimbal's on its pivot on -X2
#: (gravity's torque points along +X2), and the rotor's on the rim of the disc
#: at -Y of the inner gimbal's frame: a point of the (round) rotor whatever
#: its spin, carried by the inner gimbal so that it does not turn with psi,
#: and off the rotor axis. (It sat on the axle's lower end, on the axis: seen
#: along the axis it fell on the labels of omega and L.) Chosen by projecting
#: them with the default camera along every preset's motion: they overlap
#: each other rarely, and never at t = 0.
BODY_LABELS = (
    ("outer", "outer gimbal φ", (0.0, 0.0, _OUTER_RADIUS + _RING_TUBE), "bottom-left"),
    ("outer/inner", "inner gimbal θ", (-_OUTER_RADIUS - _RING_TUBE, 0.0, 0.0), "top-center"),
    ("outer/inner", "rotor ψ", (0.0, -_ROTOR_RADIUS - 0.02, 0.0), "top-center"),
)


@dataclasses.dataclass
class _Gui:
    readout: Any  # app.readout.Readout: the motion now (rewritten ~5 times a second)
    info: Any  # app.readout.Readout: the model's constants (rewritten when they change)
    legend: Legend
    plot_theta: Any
    plot_phi_dot: Any
    plot_drift: Any


class GyroscopeScene(PlaybackRequests, Scene):
    """Rotor in a cardan suspension: precession, nutation, spin (ZXZ)."""

    name: ClassVar[str] = "gyroscope"
    title: ClassVar[str] = "Gyroscope (cardan rotor)"
    order: ClassVar[int] = 40
    help: ClassVar[str] = (
        "A symmetric rotor turning about a fixed point O, the centre of a cardan suspension, "
        "with intrinsic Z-X-Z Euler angles: the **outer gimbal** turns by the precession φ about "
        "the base axis Z1, the **inner gimbal** by the nutation θ about the line of nodes X2, the "
        "**rotor** by the spin ψ about its axis Z3. Gravity acts along −Z1 when mgl > 0.\n\n"
        "- Motion without applied torques: the exact solution of the Lagrange equations "
        "(Eq. 8.16) with the kinetic energy of Eq. 8.14: the momenta d1 = I3 ω3 and "
        "d2 = I dφ/dt sin²θ + d1 cos θ (Eqs. 8.19-8.20) and the energy E are constant, and "
        "u = cos θ moves between the roots of the cubic of Eq. 8.21 (Jacobi's sn).\n"
        "- With the torques M_φ, M_θ, M_ψ: DOP853 on Eq. 8.16 (Euler parameters near "
        "θ = 0 or π, Eqs. 8.51-8.54); d1, d2 and E then change.\n"
        "- Steady precession presets: M_θ of Eq. 8.23, or the slow rate of Eq. 8.23 with "
        "gravity alone; the sleeping top's critical spin is 2 √(mgl I) / I3.\n"
        "- Arrows from O: ω = G (dφ/dt, dθ/dt, dψ/dt) (Eq. 8.8), the angular momentum L and "
        "the torque M (gravity plus applied), lengths saturating at 1.8 m (ω) and 2.4 m.\n"
        "- Plots: θ with the predicted bounds, dφ/dt, and log10 of the change of d1, d2, E "
        "since t = 0 (round-off without torques); their window spans at least two nutation "
        "periods. *Download CSV* exports the samples of the window."
    )
    # A 3/4 view from above, the suspension left of centre beside the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (3.08, -2.58, 1.64)
    camera_look_at: ClassVar[tuple[float, float, float]] = (1.05, 1.25, -0.15)

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.playback = Playback(PRESETS, controls=self.controls)
        self.timeline = ChunkTimeline(self.executor, functools.partial(_compute_chunk, _Model.from_inputs(_DEFAULT)),
                                      chunk_time=_CHUNK_SIM_TIME, sequential=False, capacity=_CHUNKS_KEPT)
        self.history = History()
        self._refresh = PlotRefresh(("readout", "theta", "phi_dot", "drift"), _REFRESH_PERIOD)
        # Owned by update() (the session loop thread).
        self.model: _Model | None = None
        self.analysis: _Analysis | None = None
        self.sim_time = 0.0
        self.waiting = False  # the clock holds: the chunk it needs is not ready
        self.method = ""  # path of the chunk drawn: "closed_form", "steady" or "numerical"
        self.angles = np.zeros(3)  # (phi, theta, psi) as last drawn
        self.rates = np.zeros(3)
        self.current_invariants = np.zeros(3)  # d1, d2, E at the computed sample nearest the clock
        self._label_shown = [True, True, True]
        # L's label above its tip, omega's below (swapped when omega's tip is the higher one)
        self.momentum_label_above = True
        self._drawn: tuple[float, int, bool, bool] | None = None
        self.arrow_points = np.zeros((3, 2, 3), dtype=np.float32)
        self._since_trail = math.inf
        self._refreshed_time = -1.0
        self._error_reported = False
        self._error_paused = False  # the failure paused a running clock (not one paused by hand)
        self.gui: _Gui | None = None

    # -- build ----------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        meshes = _meshes()
        self.add_ground_grid(
            width=6.0, height=6.0, position=(0.0, 0.0, _BASE_Z - 0.05), cell_size=0.25, section_size=1.0
        )
        scene.add_mesh_simple(f"{root}/base", meshes["base"].vertices, meshes["base"].faces, color=(110, 110, 120))
        scene.add_mesh_simple(f"{root}/sphere", meshes["sphere"].vertices, meshes["sphere"].faces,
                              color=(200, 200, 220), opacity=0.08)
        self.outer_frame = scene.add_frame(f"{root}/outer", show_axes=False)
        scene.add_mesh_simple(f"{root}/outer/mesh", meshes["outer"].vertices, meshes["outer"].faces,
                              color=_OUTER_COLOR)
        self.inner_frame = scene.add_frame(f"{root}/outer/inner", show_axes=False)
        scene.add_mesh_simple(f"{root}/outer/inner/mesh", meshes["inner"].vertices, meshes["inner"].faces,
                              color=_INNER_COLOR)
        self.rotor_frame = scene.add_frame(f"{root}/outer/inner/rotor", axes_length=0.4, axes_radius=0.012)
        scene.add_mesh_simple(f"{root}/outer/inner/rotor/mesh", meshes["rotor"].vertices, meshes["rotor"].faces,
                              color=(170, 170, 180))
        scene.add_mesh_simple(f"{root}/outer/inner/rotor/marker", meshes["marker"].vertices,
                              meshes["marker"].faces, color=(220, 60, 60))
        self.body_labels = [
            self.add_label(f"{root}/{node}/label_{i}", text, position=position, anchor=anchor, scale=_LABEL_SCALE)
            for i, (node, text, position, anchor) in enumerate(BODY_LABELS)
        ]
        self.trail = ChunkedTrail(self, f"{root}/trail", _TRAIL_COLOR, thickness=3.0, thickness_units="screen",
                                  capacity=_TRAIL_CAPACITY, min_step=_TRAIL_MIN_STEP)
        self.vectors_frame = scene.add_frame(f"{root}/vectors", show_axes=False)
        self.arrows = self.add_arrows(
            f"{root}/vectors/arrows", np.zeros((3, 2, 3), dtype=np.float32), _ARROW_COLORS,
            shaft_radius=0.04, head_radius=0.1, head_length=0.18,
        )
        self.arrow_labels = [
            self.add_label(f"{root}/vectors/label_{i}", text, anchor=anchor, scale=_LABEL_SCALE)
            for i, (text, anchor) in enumerate(zip(_ARROW_LABELS, _arrow_label_anchors(self.momentum_label_above),
                                                   strict=True))
        ]
        gui = self.target.gui
        with self.make_folder():
            legend = Legend(gui, (
                (_OMEGA_COLOR, "ω angular velocity"),
                (_MOMENTUM_COLOR, "L angular momentum about O"),
                (_TORQUE_COLOR, "M torque (gravity + applied)"),
                (_TRAIL_COLOR, "trail of the rotor-axis tip"),
            ), "Arrows from the fixed point O (rotor frame: red x, green y, blue z):", presenter=self.presenter)
            self.playback.add_gui()
            readout = self.add_readout("Computing the motion…")
            info = self.add_readout("")
            self.playback.add_preset_buttons()
            groups = (("Initial state (t = 0)", SLIDERS[:4]), ("Rotor", SLIDERS[4:7]),
                      ("Applied torques", SLIDERS[7:]))
            for title, specs in groups:
                with gui.add_folder(title):
                    for spec in specs:
                        self.controls.add(spec)
            with gui.add_folder("Show"):
                self.controls.add(Toggle("show_trail", "Tip trail", default=True))
                self.controls.add(Toggle("show_arrows", "Arrows ω, L, M", default=True))
            with self.plot_area():
                empty = (np.zeros(2), np.zeros(2))
                # x is simulated time in seconds, not a calendar date (uPlot's default)
                x_scale = {"x": {"time": False}}
                plot_theta = self.add_plot(
                    empty + (np.zeros(2), np.zeros(2)),
                    ({"label": "t (s)"}, {"label": "θ (deg)", "stroke": "#2266dd", "width": 2},
                     {"label": "θ min", "stroke": "#888888", "dash": [6, 4]},
                     {"label": "θ max", "stroke": "#888888", "dash": [6, 4]}),
                    title="θ(t) and its predicted bounds", scales=x_scale, aspect=1.6,
                )
                plot_phi_dot = self.add_plot(
                    empty, ({"label": "t (s)"}, {"label": "dφ/dt (rad/s)", "stroke": "#c2410c", "width": 2}),
                    title="precession rate dφ/dt", scales=x_scale, aspect=1.6,
                )
                plot_drift = self.add_plot(
                    empty + (np.zeros(2), np.zeros(2)),
                    ({"label": "t (s)"}, {"label": "log10|Δd1|", "stroke": "#b91c1c"},
                     {"label": "log10|Δd2|", "stroke": "#1d4ed8"}, {"label": "log10|ΔE|", "stroke": "#15803d"}),
                    title="log10 |change since t = 0| of d1, d2, E", scales=x_scale, aspect=1.6,
                )
            self.add_download("download_csv", "Download CSV", "gyroscope.csv", self.csv_bytes,
                              hint="t, φ, θ, ψ, their rates, d1, d2, E of the plotted window")
        self.gui = _Gui(readout, info, legend, plot_theta, plot_phi_dot, plot_drift)

    def on_presenter(self, on: bool) -> None:
        if self.gui is not None:
            self.gui.legend.set_presenter(on)

    # -- read by tests and notebooks -----------------------------------------------
    @property
    def window(self) -> float:
        """Length of the plot window (s) of the model in use."""
        return self.analysis.window if self.analysis is not None else _WINDOW_FALLBACK

    # -- inputs --------------------------------------------------------------------
    def _inputs_from_controls(self) -> Inputs:
        return Inputs.from_values(self.controls.values())

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            _Model.from_inputs(Inputs.from_values(values))
        except ValueError as exc:
            return f"invalid rotor parameters: {exc}"
        return None

    def _apply_inputs(self, inputs: Inputs) -> None:
        """Use ``inputs`` (restart), or refuse them with a notice and set the sliders back."""
        try:
            model = _Model.from_inputs(inputs)
        except ValueError as exc:
            kept = self.model.inputs if self.model is not None else _DEFAULT
            self.notify("Invalid rotor parameters",
                        f"{exc}. Keeping the previous values (the sliders are set back).", "warning")
            self.controls.set_many(dataclasses.asdict(kept))
            if self.model is not None:
                return
            model = _Model.from_inputs(kept)
        self.model = model
        self.analysis = None
        failed = self._error_reported and self._error_paused
        self._error_reported = False
        self.timeline.reset(functools.partial(_compute_chunk, model))
        self.timeline.sequential = model.has_torque
        self._restart()
        if failed:  # the failed run had paused the clock: the notice promised that a slider runs it again
            self.playback.set_playing(True)

    def _restart(self) -> None:
        self.sim_time = 0.0
        self.trail.clear()
        self._since_trail = math.inf
        self.history.clear()
        self._drawn = None
        self._refreshed_time = -1.0
        self._refresh.force()

    # -- update ----------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        preset = self.playback.take_preset()
        changed = self.controls.take_changes()
        if preset is not None:
            self.controls.set_many(dataclasses.asdict(preset_inputs(preset)))
            self.playback.set_playing(True)
        if self.model is None or preset is not None or changed & _MODEL_KEYS:
            self._apply_inputs(self._inputs_from_controls())
        tick = self.playback.tick(dt)
        if tick.reset:
            self._restart()
        chunk = self._advance(tick.step)
        show_trail = bool(self.controls.value("show_trail"))
        show_arrows = bool(self.controls.value("show_arrows"))
        if chunk is None:
            with self.target.atomic():
                self.trail.visible = show_trail
                self.vectors_frame.visible = show_arrows
            return
        self._draw(chunk, dt, show_trail, show_arrows)

    def _advance(self, step: float) -> _Chunk | None:
        """Move the clock by ``step`` if the chunk it lands in is ready; the chunk to draw."""
        self.sim_time, chunk, self.waiting = self.timeline.advance(self.sim_time, step)
        if self.timeline.error is not None and not self._error_reported:
            self._error_reported = True
            self._error_paused = self.playback.playing  # (a failure found while paused by hand stays paused)
            self.playback.set_playing(False)
            self.notify("Simulation stopped",
                        f"{self.timeline.error}. The motion stops at t = {self.sim_time:.2f} s; "
                        "change a slider to run it again (Reset replays it up to there).", "warning")
        return chunk

    def _draw(self, chunk: _Chunk, dt: float, show_trail: bool, show_arrows: bool) -> None:
        key = (self.sim_time, chunk.k, show_trail, show_arrows)
        if key == self._drawn and chunk.analysis is self.analysis:
            # paused: the poses are on the page already; only a last refresh may be due
            due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
            if due is not None:
                with self.target.atomic():
                    self._refresh_one(due)
            return
        self._drawn = key
        if self.analysis is not chunk.analysis:
            self.analysis = chunk.analysis
            self.gui.info.content = chunk.analysis.readout
        self.history.add(chunk.k, chunk.table)
        # linear interpolation between the two samples around the clock
        samples = chunk.samples
        x = (self.sim_time - chunk.t0) / chunk.h
        j = min(max(int(x), 0), samples.shape[0] - 2)
        w = min(max(x - j, 0.0), 1.0)
        row = samples[j] + w * (samples[j + 1] - samples[j])
        angles, rates, tip = row[_ANGLES], row[_RATES], row[_TIP]
        vectors = row[_VECTORS].reshape(3, 3)
        # The invariants at the computed sample nearest the clock: linear
        # interpolation between samples does not conserve them.
        self.current_invariants = chunk.invariants[j + 1 if w >= 0.5 else j]
        self.angles, self.rates, self.method = angles, rates, chunk.method
        wxyz = [euler_parameters_from_axis_angle(axis, float(angle)) for axis, angle in zip(_AXES, angles)]
        self.trail.add(tip)
        self._since_trail += dt
        send_trail = show_trail and self.trail.pending and self._since_trail >= _TRAIL_PERIOD
        arrows = _arrow_points(vectors)
        finite = bool(np.all(np.isfinite(arrows)))  # never send a non-finite point
        if finite:
            self.arrow_points = arrows
        due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
        with self.target.atomic():
            set_pose(self.outer_frame, wxyz=wxyz[0])
            set_pose(self.inner_frame, wxyz=wxyz[1])
            set_pose(self.rotor_frame, wxyz=wxyz[2])
            self.trail.visible = show_trail
            if send_trail:
                self.trail.flush()  # the newest chunk of the trail only
                self._since_trail = 0.0
            self.vectors_frame.visible = show_arrows and finite
            if show_arrows and finite:
                # the labels move in the same message batch as their arrows
                set_array(self.arrows, "points", arrows)
                self._place_arrow_labels(arrows)
            if due is not None:
                self._refresh_one(due)

    def _place_arrow_labels(self, arrows: np.ndarray) -> None:
        """Put the labels of ω, L, M by their arrows' tips (``arrows`` (3, 2, 3)); hide the label of a
        zero arrow. Three position messages a frame (about 0.1 kB each before compression), an anchor
        change only when ω's and L's labels swap."""
        above = _momentum_label_above(arrows, self.momentum_label_above)
        if above != self.momentum_label_above:
            self.momentum_label_above = above
            for label, anchor in zip(self.arrow_labels[:2], _arrow_label_anchors(above)[:2], strict=True):
                label.anchor = anchor
        positions = _arrow_label_positions(arrows, momentum_above=above)
        for i, label in enumerate(self.arrow_labels):
            shown = positions[i] is not None
            if shown:
                set_pose(label, position=positions[i])
            if shown != self._label_shown[i]:
                label.visible = shown
                self._label_shown[i] = shown

    # -- plots, readout, export --------------------------------------------------------
    def _window_start(self) -> float:
        return max(0.0, self.sim_time - self.window)

    def _refresh_one(self, what: str) -> None:
        assert self.gui is not None and self.analysis is not None
        if what == "readout":
            # the readout opens each refresh cycle: the plots of the cycle
            # (the next frames) show the window as it is now
            self._refreshed_time = self.sim_time
            self._plot_window = self.history.trimmed_window(self._window_start(), self.sim_time)
            self.gui.readout.content = self._readout()
            return
        t, columns = self._plot_window
        if t.size == 0:
            return
        if what == "theta":
            theta = np.degrees(columns[:, 1])
            prediction = self.analysis.prediction
            if prediction is not None:
                lo = np.full_like(t, math.degrees(float(prediction.theta_min)))
                hi = np.full_like(t, math.degrees(float(prediction.theta_max)))
            else:
                # torques act: no prediction, the lines show the observed range
                lo, hi = np.full_like(t, theta.min()), np.full_like(t, theta.max())
            self.gui.plot_theta.data = (t, theta, lo, hi)
        elif what == "phi_dot":
            self.gui.plot_phi_dot.data = (t, columns[:, 3])
        elif what == "drift":
            self.gui.plot_drift.data = (t, *drift_log10(columns[:, 6:9] - self.analysis.invariants0).T)

    def _readout(self) -> str:
        assert self.analysis is not None
        d1, d2, energy = (float(x) for x in self.current_invariants)
        c1, c2, c3 = (float(x) for x in self.current_invariants - self.analysis.invariants0)
        change = "change since t = 0 (torques act)" if self.model is not None and self.model.has_torque \
            else "drift since t = 0 (round-off)"
        lines = [
            f"**t** = {self.sim_time:.2f} s · θ = {math.degrees(self.angles[1]):.2f}° · "
            f"dφ/dt = {significant(float(self.rates[0]), 3)} rad/s",
            f"**d1** = {significant(d1)} kg m²/s, **d2** = {significant(d2)} kg m²/s, "
            f"**E** = {significant(energy)} J  \n{change}: {one_digit(c1)}, {one_digit(c2)}, {one_digit(c3)}",
        ]
        if self.waiting and self.playing:
            lines.insert(1, "*computing the next chunk…*")
        return "\n\n".join(lines)

    def csv_bytes(self) -> bytes:
        """The CSV of the trajectory in the plot window, up to the displayed time."""
        return self.history.csv(CSV_HEADER, self._window_start(), self.sim_time)


def _arrow_label_anchors(momentum_above: bool) -> tuple[str, str, str]:
    """Screen anchors of the labels of ω, L, M: the upper of ω's and L's labels has its text above
    its point, the lower below."""
    if momentum_above:
        return (_LOWER_ANCHOR, _UPPER_ANCHOR, _TORQUE_ANCHOR)
    return (_UPPER_ANCHOR, _LOWER_ANCHOR, _TORQUE_ANCHOR)


def _momentum_label_above(arrows: np.ndarray, previous: bool) -> bool:
    """Whether L's label is the upper of ω's and L's (``arrows`` (3, 2, 3), global frame, +Z up):
    the label of the higher tip, kept as ``previous`` until the other tip is higher by
    :data:`_LABEL_SWAP`."""
    z_omega, z_momentum = float(arrows[0, 1, 2]), float(arrows[1, 1, 2])
    if previous:
        return not z_omega > z_momentum + _LABEL_SWAP
    return z_momentum > z_omega + _LABEL_SWAP


def _arrow_label_positions(arrows: np.ndarray, *, momentum_above: bool) -> list[tuple[float, float, float] | None]:
    """Positions (global frame, m) of the labels of ω, L, M for ``arrows`` (3, 2, 3) from O (None for
    a zero arrow).

    Each label lies :data:`_LABEL_BEYOND` beyond its tip along its arrow; ω's and L's are also moved
    :data:`_LABEL_ASIDE` perpendicular to their arrows, up (the label of ``momentum_above``'s arrow) or
    down, along ``Z - (Z . u) u`` (``u`` the arrow's direction). That direction shortens as the arrow
    turns vertical; below sin = 0.5 (within 30 deg of Z) the offset shrinks with it instead of
    swinging round the arrow. Plain floats: it runs on the loop thread every frame.
    """
    out: list[tuple[float, float, float] | None] = []
    for i in range(3):
        x, y, z = (float(c) for c in arrows[i, 1])
        length = math.sqrt(x * x + y * y + z * z)
        if length == 0.0:
            out.append(None)
            continue
        ux, uy, uz = x / length, y / length, z / length
        beyond = _LABEL_BEYOND[i]
        px, py, pz = x + beyond * ux, y + beyond * uy, z + beyond * uz
        if i < 2:
            # Z minus its component along u: |v| = sin(angle between u and Z)
            vx, vy, vz = -uz * ux, -uz * uy, 1.0 - uz * uz
            sine = math.sqrt(vx * vx + vy * vy + vz * vz)
            up = momentum_above if i == 1 else not momentum_above
            k = (_LABEL_ASIDE if up else -_LABEL_ASIDE) / max(sine, _LABEL_SINE_FLOOR)
            px, py, pz = px + k * vx, py + k * vy, pz + k * vz
        out.append((px, py, pz))
    return out


def _arrow_points(vectors: np.ndarray) -> np.ndarray:
    """Arrows (3, 2, 3) float32 from the fixed point along omega, L and the torque
    (``vectors`` (3, 3), global frame), lengths ``max |v| / (|v| + half)`` m."""
    tips = []
    for (x, y, z), longest, half in zip(vectors.tolist(), _ARROW_MAX, _ARROW_HALF, strict=True):
        k = longest / (math.sqrt(x * x + y * y + z * z) + half)
        tips.append(((0.0, 0.0, 0.0), (x * k, y * k, z * k)))
    return np.array(tips, dtype=np.float32)
