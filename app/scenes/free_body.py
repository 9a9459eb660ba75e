"""Free rigid body scene: torque-free motion, polhode, and the Dzhanibekov flip.

A body of :func:`core.models.free_body_shape` (a T-handle by default) spins freely from
:func:`core.models.free_body_start` (``L`` along +Z, so a flip about the intermediate axis turns it
upside down about a vertical ``L``). Each 1 s chunk is :func:`core.models.free_body_window`: the exact
motion and, with a ghost integrator chosen, its run compared with it. A third picture shows the
body-frame momentum sphere, the energy ellipsoid and the polhode. The scene runs on
:class:`app.scenes._simulation.SimulationScene` and holds no physics; Euler parameters go to viser's
``wxyz`` as they are (scalar first).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from typing import Any, ClassVar

import numpy as np

from app.controls import Choice, Slider
from app.nodes import set_array, set_pose
from app.readout import one_digit, significant
from app.scenes._plots import Legend, Table, log10_floor, window_seconds
from app.scenes._simulation import PlotSpec, SimulationScene
from app.scenes._shapes import arrow_segments, ellipsoid_wireframe, parts_mesh
from app.scenes._trail import SphereTrail
from core.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS, IntegrationError
from core.models import (FREE_BODY_NAMES, GHOST_COLUMNS, INVARIANT_ROUND_OFF, WINDOW_COLUMNS, FreeBodyStart,
                         FreeBodyWindow, euler_parameters_momentum_up, free_body_shape, free_body_start,
                         free_body_window, spin_about_principal_axis)

__all__ = ["BODIES", "CSV_HEADER", "CSV_HEADER_GHOST", "FreeBodyScene", "INTEGRATORS", "Inputs", "PRESETS",
           "body_mesh", "initial_orientation", "preset_omega"]

_EXACT_POS, _GHOST_POS, _SPHERE_POS = np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.9, 0.0]), np.array([0.0, -2.3, 0.0])
_ARROW_BASES = np.array([_EXACT_POS, _EXACT_POS, _GHOST_POS])  # L, omega, the ghost's L
_SPHERE_RADIUS = 0.9
_ARROW_LENGTH = 1.3  # m: L arrows; omega saturates at this length
_OMEGA_HALF = 3.0  # rad/s: omega arrow length 1.3 m |omega| / (|omega| + 3 rad/s); the L arrows 1.3 m
_SAMPLE_DT = 1.0 / 60.0  # s: ghost samples and CSV rows; without a ghost the exact body is drawn at 240 Hz
_EXACT_SAMPLES_PER_ROW = 4
_TRACE_PERIOD = 0.05  # s of wall time between polhode / label updates
_LABEL_SCALE = 1.3  # 3-D labels: about 16 px (presenter view: x 1.8)
_EXACT_COLOR, _GHOST_COLOR = (220, 150, 60), (140, 170, 255)
# no arrow or traced curve is red, green or blue (the frame axes)
_L_COLOR, _OMEGA_COLOR, _GHOST_L_COLOR = (25, 25, 35), (200, 30, 160), (130, 130, 145)
_POLHODE_COLOR, _ELLIPSOID_COLOR = (0, 160, 150), (120, 120, 145)

#: Bodies offered in the "Body" dropdown (core's shapes; mesh frame = body frame, origin at the centre of mass).
BODIES = FREE_BODY_NAMES
#: Integrators offered for the ghost body.
INTEGRATORS = ("none",) + tuple(FIXED_STEP_METHODS) + tuple(ADAPTIVE_METHODS)
#: Preset buttons: a spin of 6 rad/s about a principal axis with 2 % about the other two.
PRESETS = ("Stable spin: major axis", "Stable spin: minor axis", "Dzhanibekov flip (intermediate axis)")
_PRESET_AXIS = dict(zip(PRESETS, ("major", "minor", "intermediate"), strict=True))
#: CSV header (one line: column names with units) without and with a ghost.
CSV_HEADER = ",".join(("t (s)",) + WINDOW_COLUMNS)
CSV_HEADER_GHOST = ",".join(("t (s)",) + WINDOW_COLUMNS + GHOST_COLUMNS)


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Values of the scene's controls (the T-handle's intermediate axis is body x: the default flips)."""

    body: str = BODIES[0]
    omega_x: float = 6.0
    omega_y: float = 0.12
    omega_z: float = 0.12
    method: str = "splitting"
    dt: float = 0.01
    rtol_exp: float = -8.0

    @property
    def omega(self) -> tuple[float, float, float]:
        """Initial angular velocity, body frame (rad/s)."""
        return (self.omega_x, self.omega_y, self.omega_z)

    @property
    def rtol(self) -> float:
        return 10.0 ** float(self.rtol_exp)

    @property
    def ghost(self) -> bool:
        return self.method != "none"

    def ghost_text(self) -> str:
        """The ghost's method and step (or tolerance)."""
        return f"{self.method}, dt {self.dt:g} s" if self.method in FIXED_STEP_METHODS else \
            f"{self.method}, rtol {self.rtol:.0e}"


_DEFAULT = Inputs()


@functools.lru_cache(maxsize=None)
def body_mesh(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mesh ``(vertices (n, 3) float32, faces (m, 3) uint32)`` of body ``name`` in its body frame (centre of
    mass at the origin, metres) drawn from core's parts, and core's inertia tensor (3, 3) (kg m^2)."""
    shape = free_body_shape(name)
    return (*parts_mesh(shape.parts, shape.center_of_mass), shape.inertia)


def preset_omega(name: str, inertia: np.ndarray) -> np.ndarray:
    """Initial omega_body (3,) of preset ``name`` (core's spin, rounded to the sliders' step)."""
    if name not in _PRESET_AXIS:
        raise ValueError(f"name: expected one of {list(PRESETS)}, got {name!r}")
    return np.round(spin_about_principal_axis(inertia, _PRESET_AXIS[name], rate=6.0, offset=0.02), 3)


initial_orientation = euler_parameters_momentum_up


@dataclasses.dataclass(frozen=True)
class _Setup:
    """Core's motion of one body and initial omega (its fields read through), the plot window and the readout."""

    body: str
    start: FreeBodyStart
    window: float  # s
    readout: str  # the motion's constants (Markdown)

    def __getattr__(self, name: str) -> Any:  # inertia, omega_body0, p0, solution, geometry, L_global, state0
        if name.startswith("__") or name == "start":
            raise AttributeError(name)
        return getattr(self.start, name)


@functools.lru_cache(maxsize=32)
def _setup(body: str, omega: tuple[float, float, float]) -> _Setup:
    start = free_body_start(body_mesh(body)[2], omega)
    g, period = start.geometry, float(start.solution.period)
    window = window_seconds(period, fallback=20.0, cap=120.0)
    motion = (f"{start.solution.kind}, ω period {significant(period, 3)} s" if 0.0 < period < math.inf else
              "on the separatrix (ω period infinite)" if period > 0.0 else
              f"{'steady rotation' if start.solution.kind == 'steady' else 'at rest'}, ω constant")
    lines = [f"**Motion**: {motion}; plots show the last {window:.3g} s",
             "**Principal moments** " + ", ".join(significant(float(m), 3) for m in g.moments) + " kg m²"]
    if g.L_norm > 0:
        lines.append(f"**E** = {significant(g.energy)} J, **|L|** = {significant(g.L_norm)} kg m²/s (constant); "
                     + start.polhode.description)
    return _Setup(body, start, window, "  \n".join(lines))


@dataclasses.dataclass(frozen=True)
class _Chunk:
    k: int
    t: np.ndarray  # (n,) the ghost's samples when one runs, else the exact body's at 240 Hz
    window: FreeBodyWindow
    arrows: np.ndarray  # (n, 3, 2, 3) float32: L and omega at the exact body, the ghost's L at the ghost
    polhode: np.ndarray  # (n, 3) L_body in the sphere's picture
    failure: str | None  # why the ghost stopped in this chunk
    table: Table  # exported columns (CSV_HEADER_GHOST), then omega error and the drifts, plotted only
    setup: _Setup


def _compute_chunk(inputs: Inputs, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` (1 s) of the motion for ``inputs`` (runs on the executor)."""
    setup = _setup(inputs.body, inputs.omega)
    t0, run, failure = float(k), None, None
    before = previous.window.ghost if previous is not None else None
    y0 = setup.state0 if k == 0 else before.final_state if before is not None else None
    if inputs.ghost and y0 is not None:
        try:
            run = free_body_window(setup.solution, t0, t0 + 1.0, sample_dt=_SAMPLE_DT, method=inputs.method,
                                   state0=y0, dt=inputs.dt, rtol=inputs.rtol)
        except (IntegrationError, ValueError) as exc:
            failure = f"Ghost integrator stopped: {inputs.method}: {exc}"
    w = run or free_body_window(setup.solution, t0, t0 + 1.0, sample_dt=_SAMPLE_DT / _EXACT_SAMPLES_PER_ROW)
    g, n, every = w.ghost, w.t.size, 1 if run is not None else _EXACT_SAMPLES_PER_ROW
    columns, plotted = w.columns(every=every), None
    if g is not None:
        plotted = np.column_stack([g.omega_error, g.energy_drift, g.L_drift, g.p_norm_error])
    elif inputs.ghost:  # the ghost stopped: empty fields
        columns = np.hstack([columns, np.full((columns.shape[0], len(GHOST_COLUMNS)), np.nan)])
        plotted = np.full((columns.shape[0], 4), np.nan)
    vectors = np.stack([np.broadcast_to(setup.L_global, (n, 3)), w.omega, g.L if g is not None else np.zeros((n, 3))], 1)
    L_norm = setup.geometry.L_norm
    return _Chunk(k, w.t, w, arrow_segments(_ARROW_BASES, vectors, length=_ARROW_LENGTH, half=(0.0, _OMEGA_HALF, 0.0)),
                  w.L_body * (_SPHERE_RADIUS / L_norm if L_norm > 0 else 0.0), failure,
                  Table.build(w.t[::every], columns, plotted=plotted), setup)


class FreeBodyScene(SimulationScene):
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
        "over at least two periods of ω; drifts at or below 10 machine epsilons are round-off "
        "and drawn on the grey round-off line. *Download CSV* exports the samples of the window."
    )
    # look a little right of the body so the GUI panel does not cover the ghost
    camera_position: ClassVar[tuple[float, float, float]] = (4.4, 0.85, 1.85)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 1.3, -0.15)
    Inputs = Inputs
    presets = PRESETS
    csv_header = CSV_HEADER
    window = 20.0  # s until the first chunk gives the motion's period

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.setup: _Setup | None = None  # constants of the motion drawn (from the chunks)
        self.p_exact, self.omega_exact, self.p_ghost = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), None
        self.ghost_error: dict[str, float] = {}
        self.ghost_failed = False
        self.arrow_points = np.zeros((3, 2, 3), dtype=np.float32)
        self._traced, self._trace_due = -math.inf, False  # wall clock of the last trace; one is due

    def job(self, inputs: Inputs, segment: Any) -> Any:
        return functools.partial(_compute_chunk, inputs)

    def preset_values(self, name: str) -> dict[str, Any]:
        w = preset_omega(name, body_mesh(str(self.controls.value("body")))[2])
        return {key: float(x) for key, x in zip(("omega_x", "omega_y", "omega_z"), w, strict=True)}

    def csv_header_for(self, inputs: Inputs) -> str:
        return CSV_HEADER_GHOST if inputs.ghost else CSV_HEADER

    # -- build ---------------------------------------------------------------------------------------
    def build_nodes(self) -> None:
        scene, root = self.target.scene, self.root
        frame = functools.partial(scene.add_frame, axes_length=0.5, axes_radius=0.015)
        self.exact_frame = frame(f"{root}/exact", position=tuple(_EXACT_POS))
        self.ghost_frame = frame(f"{root}/ghost", position=tuple(_GHOST_POS))
        self.body_frames, self.ghost_frames = {}, {}
        for i, name in enumerate(BODIES):
            v, f, _ = body_mesh(name)
            shown = name == _DEFAULT.body
            self.body_frames[name] = scene.add_mesh_simple(f"{root}/exact/body{i}", v, f, color=_EXACT_COLOR,
                                                           visible=shown)
            self.ghost_frames[name] = scene.add_mesh_simple(f"{root}/ghost/body{i}", v, f, color=_GHOST_COLOR,
                                                            opacity=0.45, visible=shown)
        self.arrows = self.add_arrows(f"{root}/arrows", np.zeros((3, 2, 3), dtype=np.float32),
                                      np.array([_L_COLOR, _OMEGA_COLOR, _GHOST_L_COLOR], dtype=np.uint8),
                                      shaft_radius=0.025, head_radius=0.06, head_length=0.12)
        self.polhode = SphereTrail(self, f"{root}/momentum", _POLHODE_COLOR, position=_SPHERE_POS,
                                   radius=_SPHERE_RADIUS, thickness=0.025, capacity=600, min_step=0.005,
                                   marker_color=_L_COLOR, axes_length=1.1)
        self.ellipsoid = self.add_lines(f"{root}/momentum/ellipsoid", ellipsoid_wireframe(np.zeros(3)),
                                        _ELLIPSOID_COLOR, thickness=0.008)
        # 3-D labels in static places (a label in a turning frame would orbit with it), ω's at its arrow's tip
        up = functools.partial(self.add_label, anchor="bottom-center", scale=_LABEL_SCALE)
        self.labels = {
            "exact": self.add_label(f"{root}/label_exact", "exact solution", position=_EXACT_POS + (0.0, 0.0, -0.95),
                                    anchor="top-center", scale=_LABEL_SCALE),
            "ghost": up(f"{root}/label_ghost", "ghost\n" + _DEFAULT.ghost_text(),
                        position=_GHOST_POS + (0.0, 0.0, _ARROW_LENGTH + 0.08)),
            "sphere": up(f"{root}/label_sphere", "momentum sphere\n(body frame)",
                         position=_SPHERE_POS + (0.0, 0.0, _SPHERE_RADIUS + 0.12)),
            "L": up(f"{root}/label_L", "L", position=_EXACT_POS + (0.0, 0.0, _ARROW_LENGTH + 0.08)),
            "omega": self.add_label(f"{root}/label_omega", "ω", anchor="bottom-left", scale=_LABEL_SCALE),
        }

    def build_controls(self) -> None:
        self.legend = Legend(self.target.gui, (
            (_EXACT_COLOR, "exact solution (body axes red x, green y, blue z)"),
            (_GHOST_COLOR, "ghost: the chosen integrator"),
            (_L_COLOR, "L angular momentum (fixed in space)"),
            (_OMEGA_COLOR, "ω angular velocity"),
            (_GHOST_L_COLOR, "the ghost's L"),
            (_POLHODE_COLOR, "polhode: L_body on the momentum sphere"),
            (_ELLIPSOID_COLOR, "energy ellipsoid L·I⁻¹L = 2E"),
        ), presenter=self.presenter)
        self.add_playback()
        self.info = self.add_readout("")
        self.controls.add(Choice("body", "Body", options=BODIES, default=_DEFAULT.body))
        self.add_presets()
        with self.target.gui.add_folder("Initial ω (body frame, rad/s)"):
            for key, label in (("omega_x", "ω_x"), ("omega_y", "ω_y"), ("omega_z", "ω_z")):
                self.controls.add(Slider(key, label, min=-10.0, max=10.0, step=0.001, default=getattr(_DEFAULT, key)))
        with self.target.gui.add_folder("Ghost integrator"):
            self.controls.add(Choice("method", "Method", options=INTEGRATORS, default=_DEFAULT.method))
            self.controls.add(Slider("dt", "Step dt (s)", min=0.001, max=0.2, step=0.001, default=_DEFAULT.dt,
                                     hint="Fixed-step methods"))
            self.controls.add(Slider("rtol_exp", "log10 rtol", min=-13.0, max=-3.0, step=1.0,
                                     default=_DEFAULT.rtol_exp, hint="Adaptive methods (scipy)"))

    def plots(self) -> list[PlotSpec]:
        # log10 values on linear axes (uPlot's log axes label tiny values as 0); a drift at or below round-off
        # is drawn on the grey round-off line (it would jump between a few eps and exact zeros, a square wave)
        floor = math.log10(INVARIANT_ROUND_OFF)
        ghost = lambda inputs: inputs.ghost  # noqa: E731
        return [
            PlotSpec("omega", "exact ω_body(t) (body frame)", (("ω_x (rad/s)", "#dc2626"), ("ω_y (rad/s)", "#16a34a"),
                     ("ω_z (rad/s)", "#2563eb")), lambda t, c: (c[:, 4], c[:, 5], c[:, 6])),
            PlotSpec("error", "ghost error vs exact (log10)", (("log10 angle error (rad)", "#b45309"),
                     ("log10 |ω error| (rad/s)", "#7c3aed")), lambda t, c: (log10_floor(c[:, 18]), log10_floor(c[:, 19])),
                     shown=ghost),
            PlotSpec("drift", "ghost drift of invariants (log10; the grey line is round-off)",
                     (("log10 |ΔE|/E", "#0f766e"), ("log10 |Δ|L||/|L|", "#1f2937"), ("log10 ||p|-1|", "#be185d"),
                      (f"round-off (10 ε = {INVARIANT_ROUND_OFF:.1e})", "#9ca3af")),
                     lambda t, c: (*np.maximum(log10_floor(c[:, 20:23]), floor).T, np.full(t.size, floor)), shown=ghost),
        ]

    def on_presenter(self, on: bool) -> None:
        self.legend.set_presenter(on)

    # -- the motion -------------------------------------------------------------------------------------
    def on_configure(self, inputs: Inputs) -> None:
        self.ghost_failed, self.ghost_error = False, {}
        self.labels["ghost"].text = "ghost\n" + inputs.ghost_text()
        for name in BODIES:
            self.body_frames[name].visible = self.ghost_frames[name].visible = name == inputs.body

    def on_restart(self) -> None:
        self.polhode.clear()
        self._trace_due, self._traced = True, -math.inf

    def draw(self, chunk: _Chunk, j: int) -> None:
        setup, w, g = chunk.setup, chunk.window, chunk.window.ghost
        if setup is not self.setup:
            self.setup, self.window, self.info.content = setup, setup.window, setup.readout
            n = setup.geometry.L_norm
            self.ellipsoid.points = ellipsoid_wireframe(setup.geometry.semi_axes, setup.geometry.axes,
                                                        scale=_SPHERE_RADIUS / n if n > 0 else 0.0)
            self.labels["L"].visible = n > 0
        self.ghost_failed |= chunk.failure is not None
        # with a ghost both bodies are drawn at its sample instant, so that the two poses compare directly
        self.p_exact, self.omega_exact, self.p_ghost = w.p[j], w.omega_body[j], g.p[j] if g is not None else None
        if g is not None:
            self.ghost_error = {"t": float(w.t[j]), "angle": float(g.angle_error[j]), "omega": float(g.omega_error[j]),
                                "energy": float(g.energy_drift[j]), "L": float(g.L_drift[j]),
                                "p_norm": float(g.p_norm_error[j])}
        self._trace_due |= self.polhode.add(chunk.polhode[j])
        if finite := bool(np.all(np.isfinite(chunk.arrows[j]))):  # never send a non-finite point
            self.arrow_points = chunk.arrows[j]
            set_array(self.arrows, "points", self.arrow_points)
        self.arrows.visible = finite
        set_pose(self.exact_frame, wxyz=self.p_exact)
        self.ghost_frame.visible = self.labels["ghost"].visible = g is not None
        if g is not None:
            set_pose(self.ghost_frame, wxyz=self.p_ghost)
        tip = self.arrow_points[1, 1]  # the ω label at its arrow's tip (ω . L = 2E > 0: the upper half)
        if shown := bool(np.any(tip != self.arrow_points[1, 0])):
            set_pose(self.labels["omega"], position=tip)
        self.labels["omega"].visible = shown
        # the polhode and its marker every 0.05 s of wall time, not in a frame that sends a plot; at once when
        # the clock stands (the first frame of a motion, paused)
        if self._trace_due and (not self.playback.playing or self.sim_time == 0.0 or (
                self.refresh_due is None and time.monotonic() - self._traced >= _TRACE_PERIOD)):
            self._traced, self._trace_due = time.monotonic(), False
            self.polhode.flush()

    def readout_lines(self) -> list[str]:
        ghost, e, r = f"**Ghost** {self.config.ghost_text()}", self.ghost_error, INVARIANT_ROUND_OFF
        if not self.config.ghost or not (e or self.ghost_failed):
            return []
        if self.ghost_failed:
            return [f"{ghost}: stopped (see the notice)"]
        drifts = ", ".join(f"{name} {one_digit(e[key], r)}" for name, key in
                           (("|ΔE|/E", "energy"), ("|Δ|L||/|L|", "L"), ("||p| − 1|", "p_norm")))
        return [f"{ghost}: angle error {e['angle']:.1e} rad, {drifts}" + (f" (< {r:.0e}: round-off)" * ("<" in drifts))]
