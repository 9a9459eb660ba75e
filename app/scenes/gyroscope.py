"""Gyroscope scene: a rotor in a cardan suspension, nested frames turned by the ZXZ angles φ, θ, ψ.

Arrows from the fixed point show ω, L and the torque, labelled at their tips (:class:`rigidlab.app.scenes._arrows.
PointArrows`); the rotor-axis tip leaves a trail. A chunk's job calls :func:`rigidlab.core.gyroscope.sample_motion` (the
closed form without applied torques, DOP853 from the previous chunk's ``final_state`` with them) and turns it
into the frames' Euler parameters and the arrow tips on the executor: a frame sends poses only.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import trimesh

from rigidlab.app.controls import Slider, Toggle
from rigidlab.app.nodes import set_pose
from rigidlab.app.readout import one_digit, significant
from rigidlab.app.scenes._arrows import PointArrows, saturated_tips, vertex_rgb
from rigidlab.app.scenes._bodies import ring_mesh, rod_mesh
from rigidlab.app.scenes._plots import LOG_FLOOR as DRIFT_FLOOR_LOG10
from rigidlab.app.scenes._plots import Table, window_seconds
from rigidlab.app.scenes._plots import log10_floor as drift_log10
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene
from rigidlab.app.scenes._trail import ChunkedTrail
from rigidlab.core.gyroscope import (MotionSamples, MotionSummary, RotorParams, RotorSetup, motion_summary, sample_motion,
                            sleeping_top_critical_spin, steady_precession_rates, steady_precession_torque)
from rigidlab.core.rotations import euler_parameters_from_rotation_vector

__all__ = ["CSV_HEADER", "DRIFT_FLOOR_LOG10", "GyroscopeScene", "Inputs", "PRESETS", "SLIDERS", "drift_log10",
           "preset_inputs"]

# Geometry (m): ring radii, rotor, the trail sphere (the rotor-axis tip), base.
_OUTER_RADIUS, _INNER_RADIUS, _RING_TUBE = 1.2, 1.0, 0.035
_ROTOR_RADIUS, _ROTOR_THICKNESS, _TIP_RADIUS, _BASE_Z = 0.6, 0.14, 1.35, -1.6
_CHUNK_SIM_TIME, _CHUNK_SAMPLES = 2.0, 481  # s of simulated time per chunk; samples (240 per second)
# Arrows ω, L, M: length = longest |v| / (|v| + half) (m); ω's is shorter than L's so that their tips
# (and labels) stay apart for a fast top, where both lie nearly along the rotor axis.
_ARROW_LONGEST, _ARROW_HALF = (1.8, 2.4, 2.4), (5.0, 4.0, 1.0)  # m; rad/s, kg m^2/s, N m
# Colours (one constant for what is drawn and its legend swatch): none red, green or blue (frame axes).
_ARROW_COLORS = ((200, 30, 160), (25, 25, 35), (245, 140, 0))  # ω magenta, L near black, M orange
_TRAIL_COLOR, _OUTER_COLOR, _INNER_COLOR = (0, 160, 150), (176, 156, 122), (128, 160, 192)
_LABEL_SCALE, _ARROW_LABELS = 1.3, ("ω", "L", "M")  # 3-D labels: about 16 px (presenter view: x 1.8)
_AXES = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))  # Z1, X2, Z3 in their parents


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

    def setup(self) -> RotorSetup:
        """The motion these values ask for (ValueError naming the parameter core refuses, e.g. I3 > 2 I)."""
        state0 = (0.0, math.radians(self.theta0_deg), 0.0, self.phi_dot0, self.theta_dot0, self.psi_dot0)
        return RotorSetup(RotorParams(I=self.I, I3=self.I3, mgl=self.mgl), state0,
                          (self.m_phi, self.m_theta, self.m_psi))


#: The sliders, by folder: initial state, rotor, applied torques (rates written dθ/dt: a combining dot is
#: lost in some browsers).
SLIDERS: tuple[Slider, ...] = tuple(
    Slider(key, label, min=lo, max=hi, step=step, default=getattr(Inputs, key), hint=hint)
    for key, label, lo, hi, step, hint in (
        ("theta0_deg", "θ (deg)", 0.0, 180.0, 0.1, "Nutation angle θ at t = 0 (deg)"),
        ("theta_dot0", "dθ/dt (rad/s)", -5.0, 5.0, 0.01, "Nutation rate at t = 0"),
        ("phi_dot0", "dφ/dt (rad/s)", -5.0, 5.0, 0.001, "Precession rate at t = 0"),
        ("psi_dot0", "dψ/dt (rad/s)", -100.0, 100.0, 0.01, "Spin rate dψ/dt at t = 0"),
        ("I", "I (kg m²)", 0.1, 5.0, 0.01, "Transverse moment of inertia about the fixed point"),
        ("I3", "I3 (kg m²)", 0.1, 5.0, 0.01, "Axial moment of inertia (at most 2 I)"),
        ("mgl", "mgl (N m)", 0.0, 10.0, 0.01, "Gravity moment; 0 = balanced rotor"),
        ("m_phi", "M_φ (N m)", -5.0, 5.0, 0.01, "Generalized torque on φ (outer gimbal motor)"),
        ("m_theta", "M_θ (N m)", -5.0, 5.0, 0.001, "Generalized torque on θ (inner gimbal motor)"),
        ("m_psi", "M_ψ (N m)", -5.0, 5.0, 0.01, "Generalized torque on ψ (rotor motor)"),
    ))
#: Preset names in the order of their buttons.
PRESETS = ("Steady precession (torque M_θ)", "Steady precession (gravity)", "Fast top (pseudo-regular)",
           "Cuspidal motion", "Sleeping top above critical", "Sleeping top below critical")
#: Header of the exported CSV (one line: column names with units).
CSV_HEADER = ("t (s),phi (rad),theta (rad),psi (rad),dphi/dt (rad/s),dtheta/dt (rad/s),dpsi/dt (rad/s),"
              "d1 (kg m^2/s),d2 (kg m^2/s),E (J)")


def preset_inputs(name: str) -> Inputs:
    """Slider values of preset ``name`` (solved with core.gyroscope); ValueError for an unknown name."""
    top = RotorParams(I=1.0, I3=0.8, mgl=2.0)
    if name == PRESETS[0]:  # balanced rotor held at theta = 90 deg by M_theta of Eq. 8.23 (4 N m)
        m_theta = float(steady_precession_torque(RotorParams(I=1.0, I3=0.8), math.pi / 2, 0.5, 10.0))
        return Inputs(90.0, 0.0, 0.5, 10.0, 1.0, 0.8, 0.0, 0.0, m_theta, 0.0)
    if name in PRESETS[1:3]:  # the slow steady rate of Eq. 8.23; the fast top starts at half of it
        theta, spin = math.radians(60.0), (15.0 if name == PRESETS[1] else 40.0)
        phid = float(steady_precession_rates(top, theta, spin).slow) * (1.0 if name == PRESETS[1] else 0.5)
        return Inputs(60.0, 0.0, phid, spin - phid * math.cos(theta), 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    if name == PRESETS[3]:  # released with phi_dot = theta_dot = 0: cusps at theta_min
        return Inputs(50.0, 0.0, 0.0, 8.0, 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    if name in PRESETS[4:]:
        spin = (1.15 if name == PRESETS[4] else 0.85) * sleeping_top_critical_spin(top)
        return Inputs(3.0, 0.0, 0.0, round(spin, 4), 1.0, 0.8, 2.0, 0.0, 0.0, 0.0)
    raise ValueError(f"name: expected one of {list(PRESETS)}, got {name!r}")


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """One chunk of the motion (read-only arrays) and what a frame sends of it."""

    k: int
    t: np.ndarray  # (n,)
    samples: MotionSamples
    summary: MotionSummary
    table: Table  # t, angles, rates, d1, d2, E
    wxyz: np.ndarray  # (n, 3, 4) Euler parameters of the outer, inner and rotor frames in their parents
    tips: np.ndarray  # (n, 3, 3) arrow tips ω, L, M (m, global frame)
    trail: np.ndarray  # (n, 3) the rotor-axis tip (m)


def _chunk(setup: RotorSetup, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``setup``'s motion (on the executor; ``previous``: chunk k - 1 of a torque-driven run)."""
    t = np.linspace(k * _CHUNK_SIM_TIME, (k + 1) * _CHUNK_SIM_TIME, _CHUNK_SAMPLES)
    s = sample_motion(setup, t, start=None if previous is None else previous.samples.final_state)
    v = s.vectors
    wxyz = euler_parameters_from_rotation_vector(s.angles[:, :, None] * np.array(_AXES))  # (n, 3, 4)
    tips = saturated_tips(np.stack([v.omega, v.angular_momentum, v.torque], 1), _ARROW_LONGEST, _ARROW_HALF)
    table = Table.build(t, np.concatenate([s.angles, s.rates, s.invariants], axis=1))
    return _Chunk(k, t, s, motion_summary(setup), table, wxyz, tips, _TIP_RADIUS * v.rotor_axis)


@functools.cache  # one set per process, shared by every session: read them, never modify them
def _meshes() -> dict[str, trimesh.Trimesh]:
    cat, o, i, r, tube = trimesh.util.concatenate, _OUTER_RADIUS, _INNER_RADIUS, _ROTOR_RADIUS, _RING_TUBE
    return {
        "base": cat([rod_mesh([0, 0, _BASE_Z - 0.05], [0, 0, _BASE_Z + 0.05], 0.55, sections=48),
                     rod_mesh([0, 0, _BASE_Z], [0, 0, -o - tube], 0.045)]),
        "outer": cat([ring_mesh(o, tube), rod_mesh([0, 0, -o - 0.12], [0, 0, -o], 0.05)]),
        "inner": cat([ring_mesh(i, tube), rod_mesh([-o, 0, 0], [-i, 0, 0], 0.03),
                      rod_mesh([i, 0, 0], [o, 0, 0], 0.03)]),
        # a thin axle, so that the arrows along it (ω and L of a fast top) show around it
        "rotor": cat([trimesh.creation.cylinder(radius=r, height=_ROTOR_THICKNESS, sections=64),
                      rod_mesh([0, 0, -i], [0, 0, _TIP_RADIUS], 0.02),
                      trimesh.creation.icosphere(subdivisions=2, radius=0.05).apply_translation((0, 0, _TIP_RADIUS))]),
        "marker": trimesh.creation.box(bounds=[(r - 0.19, -0.05, -0.0756), (r - 0.01, 0.05, 0.0756)]),  # on the rim
        "sphere": trimesh.creation.icosphere(subdivisions=3, radius=_TIP_RADIUS),
    }


#: The 3-D labels on the bodies: (node under the root, text, position in its frame, screen anchor). None spins;
#: the rotor's is carried by the inner gimbal. Presenter view shows the angles (BODY_SYMBOLS): texts overlapped.
BODY_LABELS = (
    ("outer", "outer gimbal φ", (0.0, 0.0, _OUTER_RADIUS + _RING_TUBE), "bottom-left"),
    ("outer/inner", "inner gimbal θ", (-_OUTER_RADIUS - _RING_TUBE, 0.0, 0.0), "top-center"),
    ("outer/inner", "rotor ψ", (0.0, -_ROTOR_RADIUS - 0.02, 0.0), "top-center"),
)
BODY_SYMBOLS = ("φ", "θ", "ψ")


class GyroscopeScene(SimulationScene):
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
    Inputs = Inputs
    presets = PRESETS
    chunk_time = _CHUNK_SIM_TIME
    sequential = False  # the closed form is evaluated at absolute times; set per motion (on_configure)
    csv_header = CSV_HEADER
    refusal_title = "Invalid rotor parameters"

    model: RotorSetup | None = None  # the motion in use
    summary: MotionSummary | None = None  # its constants (from the chunk drawn)
    method = ""  # of the chunk drawn: "closed_form", "steady" or "numerical"
    angles = rates = current_invariants = np.zeros(3)  # as drawn (replaced, never written into)

    @property
    def window(self) -> float:  # type: ignore[override]  # (s) at least two predicted nutation periods
        return window_seconds(self.summary.period if self.summary is not None else math.nan, fallback=10.0)

    # -- building --------------------------------------------------------------------------------
    def build_nodes(self) -> None:
        scene, root = self.target.scene, self.root
        self.add_ground_grid(width=6.0, height=6.0, position=(0.0, 0.0, _BASE_Z - 0.05), cell_size=0.25,
                             section_size=1.0)
        self.outer_frame = scene.add_frame(f"{root}/outer", show_axes=False)
        self.inner_frame = scene.add_frame(f"{root}/outer/inner", show_axes=False)
        self.rotor_frame = scene.add_frame(f"{root}/outer/inner/rotor", axes_length=0.4, axes_radius=0.012)
        for path, mesh, color in (("base", "base", (110, 110, 120)), ("sphere", "sphere", (200, 200, 220)),
                                  ("outer/mesh", "outer", _OUTER_COLOR), ("outer/inner/mesh", "inner", _INNER_COLOR),
                                  ("outer/inner/rotor/mesh", "rotor", (170, 170, 180)),
                                  ("outer/inner/rotor/marker", "marker", (220, 60, 60))):
            scene.add_mesh_simple(f"{root}/{path}", _meshes()[mesh].vertices, _meshes()[mesh].faces, color=color,
                                  opacity=0.08 if mesh == "sphere" else None)
        self.body_labels = [self.add_label(f"{root}/{node}/label_{i}", BODY_SYMBOLS[i] if self.presenter else text,
                                           position=position, anchor=anchor, scale=_LABEL_SCALE)
                            for i, (node, text, position, anchor) in enumerate(BODY_LABELS)]
        self.trail = ChunkedTrail(self, f"{root}/trail", vertex_rgb(_TRAIL_COLOR), thickness=3.0, capacity=400,
                                  min_step=0.004, thickness_units="screen")
        self.vectors = PointArrows(self, f"{root}/vectors", _ARROW_LABELS, _ARROW_COLORS, beyond=(0.15, 0.15, 0.2),
                                   label_scale=_LABEL_SCALE, shaft_radius=0.04, head_radius=0.1, head_length=0.18)
        self.arrows, self.arrow_labels = self.vectors.arrows, self.vectors.labels

    def build_controls(self) -> None:
        gui = self.target.gui
        self.legend = self.add_legend(tuple(zip((*_ARROW_COLORS, _TRAIL_COLOR), (
            "ω angular velocity", "L angular momentum about O", "M torque (gravity + applied)",
            "trail of the rotor-axis tip"))), "Arrows from O (rotor frame: red x, green y, blue z; gimbals φ, θ, ψ)")
        self.add_playback()
        self.info = self.add_readout("")
        self.add_presets()
        for title, specs in (("Initial state (t = 0)", SLIDERS[:4]), ("Rotor", SLIDERS[4:7]),
                             ("Applied torques", SLIDERS[7:])):
            with gui.add_folder(title):
                for spec in specs:
                    self.controls.add(spec)
        with gui.add_folder("Show"):
            self.controls.add(Toggle("show_trail", "Tip trail", default=True))
            self.controls.add(Toggle("show_arrows", "Arrows ω, L, M", default=True))

    def on_presenter(self, on: bool) -> None:
        for label, (_, text, _, _), symbol in zip(self.body_labels, BODY_LABELS, BODY_SYMBOLS, strict=True):
            label.text = symbol if on else text

    def plots(self) -> list[PlotSpec]:
        dashed = {"dash": [6, 4], "width": 1}
        return [
            PlotSpec("theta", "θ(t) and its predicted bounds",
                     (("θ (deg)", "#2266dd"), ("θ min", "#888888", dashed), ("θ max", "#888888", dashed)),
                     self._theta_series),
            PlotSpec("phi_dot", "precession rate dφ/dt", (("dφ/dt (rad/s)", "#c2410c"),), lambda t, c: (c[:, 3],)),
            PlotSpec("drift", "log10 |change since t = 0| of d1, d2, E",
                     (("log10|Δd1|", "#b91c1c"), ("log10|Δd2|", "#1d4ed8"), ("log10|ΔE|", "#15803d")),
                     lambda t, c: tuple(drift_log10(c[:, 6:9] - self.summary.invariants0).T)),
        ]

    def _theta_series(self, t: np.ndarray, columns: np.ndarray) -> tuple[np.ndarray, ...]:
        theta, nu = np.degrees(columns[:, 1]), self.summary.prediction
        # torques act: no prediction, the lines show the observed range
        lo, hi = (theta.min(), theta.max()) if nu is None else np.degrees([nu.theta_min, nu.theta_max])
        return theta, np.full_like(t, lo), np.full_like(t, hi)

    # -- the motion --------------------------------------------------------------------------------
    def job(self, inputs: Inputs, segment: Any) -> Any:
        return functools.partial(_chunk, inputs.setup())

    def preset_values(self, name: str) -> dict[str, Any]:
        return dataclasses.asdict(preset_inputs(name))

    def check_inputs(self, inputs: Inputs) -> None:
        inputs.setup()

    def on_configure(self, inputs: Inputs) -> None:
        self.model = inputs.setup()
        self.timeline.sequential = self.model.has_torque
        self.summary = None

    def on_restart(self) -> None:
        self.trail.clear()

    def on_frame(self, changed: set[str]) -> None:
        if changed & {"show_trail", "show_arrows"}:
            self.trail.visible = bool(self.controls.value("show_trail"))
            self.vectors.visible = bool(self.controls.value("show_arrows"))

    def draw(self, chunk: _Chunk, j: int) -> None:
        s = chunk.samples
        self.angles, self.rates, self.current_invariants = s.angles[j], s.rates[j], s.invariants[j]
        self.method = s.method
        if self.summary is not chunk.summary:
            self.summary = chunk.summary
            period = self.summary.period
            self.info.content = "  \n".join([f"**{topic}** {text}" for topic, text in self.summary.describe()] + [
                f"Plots show the last {self.window:.3g} s" + (
                    f" ({self.window / period:.1f} nutation periods)." if math.isfinite(period) else ".")])
        for frame, q in zip((self.outer_frame, self.inner_frame, self.rotor_frame), chunk.wxyz[j], strict=True):
            set_pose(frame, wxyz=q)
        self.trail.add(chunk.trail[j])
        if self.trail.visible and self.trail.pending and self.frames % 3 == 0:
            self.trail.flush()  # the newest chunk of the trail only, every third frame
        if self.vectors.visible:
            self.vectors.draw(chunk.tips[j])  # the labels move in the message batch of their arrows

    def readout_lines(self) -> list[str]:  # (refreshed after a draw: the summary is the chunk's)
        d1, d2, energy = (significant(float(x)) for x in self.current_invariants)
        c1, c2, c3 = (one_digit(float(x)) for x in self.current_invariants - self.summary.invariants0)
        change = "change since t = 0 (torques act)" if self.model.has_torque else "drift since t = 0 (round-off)"
        return [f"θ = {math.degrees(self.angles[1]):.2f}° · dφ/dt = {significant(float(self.rates[0]), 3)} rad/s",
                f"**d1** = {d1} kg m²/s, **d2** = {d2} kg m²/s, **E** = {energy} J  \n{change}: {c1}, {c2}, {c3}"]
