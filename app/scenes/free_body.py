"""Free rigid body scene: torque-free motion, polhode, and the Dzhanibekov flip.

A body of :func:`rigidlab.core.models.free_body_shape` spins freely from :func:`rigidlab.core.models.free_body_start` (``L`` along
+Z: a flip about the intermediate axis turns it upside down). Each 1 s chunk is :func:`rigidlab.core.models.free_body_window`,
the exact motion and, with a ghost integrator chosen, its run compared with it; a third picture shows the momentum
sphere, the energy ellipsoid and the polhode. Runs on :class:`rigidlab.app.scenes._simulation.SimulationScene`; no physics.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import time
from typing import Any, ClassVar

import numpy as np

from rigidlab.app.controls import Choice, Slider
from rigidlab.app.nodes import set_array, set_pose
from rigidlab.app.readout import one_digit, significant
from rigidlab.app.scenes._plots import Table, log10_floor, window_seconds
from rigidlab.app.scenes._shapes import arrow_segments, ellipsoid_wireframe, parts_mesh
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene
from rigidlab.app.scenes._trail import SphereTrail
from rigidlab.core.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS, IntegrationError
from rigidlab.core.models import (FREE_BODY_NAMES, GHOST_COLUMNS, INVARIANT_ROUND_OFF, WINDOW_COLUMNS, FreeBodyStart,
                         FreeBodyWindow, euler_parameters_momentum_up, free_body_shape, free_body_start,
                         free_body_window, spin_about_principal_axis)

__all__ = ["BODIES", "CSV_HEADER", "CSV_HEADER_GHOST", "FreeBodyScene", "INTEGRATORS", "Inputs", "PRESETS",
           "body_mesh", "initial_orientation", "preset_omega"]

_EXACT_POS, _GHOST_POS, _SPHERE_POS = np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.9, 0.0]), np.array([0.0, -2.3, 0.0])
_SPHERE_RADIUS = 0.9
_ARROW_LENGTH, _OMEGA_HALF = 1.3, 3.0  # m: the L arrows; omega's is 1.3 m |omega| / (|omega| + 3 rad/s)
_SAMPLE_DT, _EXACT_SAMPLES_PER_ROW = 1.0 / 60.0, 4  # s: ghost samples and CSV rows; the exact body alone: 240 Hz
_TRACE_PERIOD = 0.05  # s of wall time between polhode updates
_LABEL_SCALE = 1.3  # 3-D labels: about 16 px (presenter view: x 1.8)
# (colour, legend) of what is drawn; no arrow or traced curve is red, green or blue (the frame axes)
_EXACT, _GHOST = ((220, 150, 60), "exact solution (body axes red x, green y, blue z)"), \
    ((140, 170, 255), "ghost: the chosen integrator")
_L, _OMEGA, _GHOST_L = ((25, 25, 35), "L angular momentum (fixed in space)"), ((200, 30, 160), "ω angular velocity"), \
    ((130, 130, 145), "the ghost's L")
_POLHODE, _ELLIPSOID = ((0, 160, 150), "polhode: L_body on the momentum sphere"), \
    ((120, 120, 145), "energy ellipsoid L·I⁻¹L = 2E")

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
    omega_x: float = 6.0  # initial omega, body frame (rad/s)
    omega_y: float = 0.12
    omega_z: float = 0.12
    method: str = "splitting"
    dt: float = 0.01
    rtol_exp: float = -8.0

    omega = property(lambda self: (self.omega_x, self.omega_y, self.omega_z))
    rtol = property(lambda self: 10.0 ** float(self.rtol_exp))
    ghost = property(lambda self: self.method != "none")

    def ghost_text(self) -> str:
        """The ghost's method and step (or tolerance)."""
        step = f"dt {self.dt:g} s" if self.method in FIXED_STEP_METHODS else f"rtol {self.rtol:.0e}"
        return f"{self.method}, {step}"


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


@functools.lru_cache(maxsize=32)
def _start(body: str, omega: tuple[float, float, float]) -> FreeBodyStart:
    return free_body_start(free_body_shape(body), omega)


@dataclasses.dataclass(frozen=True)
class _Chunk:
    k: int
    t: np.ndarray  # (n,) the ghost's samples when one runs, else the exact body's at 240 Hz
    window: FreeBodyWindow
    arrows: np.ndarray  # (n, 3, 2, 3) float32: L and omega at the exact body, the ghost's L at the ghost
    polhode: np.ndarray  # (n, 3) L_body in the sphere's picture
    failure: str | None  # why the ghost stopped in this chunk
    table: Table  # the CSV's columns, then the omega error and the drifts (plotted only)
    setup: FreeBodyStart


def _compute_chunk(inputs: Inputs, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` (1 s) of the motion for ``inputs`` (runs on the executor)."""
    setup, t0, run, failure = _start(inputs.body, inputs.omega), float(k), None, None
    before = previous.window.ghost if previous is not None else None  # the ghost continues from its last state
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
    vectors = np.stack([np.broadcast_to(setup.L_global, (n, 3)), w.omega, np.zeros((n, 3)) if g is None else g.L], 1)
    arrows = arrow_segments((_EXACT_POS, _EXACT_POS, _GHOST_POS), vectors, length=_ARROW_LENGTH,
                            half=(0.0, _OMEGA_HALF, 0.0))
    scale = _SPHERE_RADIUS / setup.geometry.L_norm if setup.geometry.L_norm > 0 else 0.0
    return _Chunk(k, w.t, w, arrows, w.L_body * scale, failure, Table.build(w.t[::every], columns, plotted=plotted),
                  setup)


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
        "and drawn on the dashed grey round-off line. *Download CSV* exports the samples of the window."
    )
    # look a little right of the body so the GUI panel does not cover the ghost
    camera_position: ClassVar[tuple[float, float, float]] = (4.4, 0.85, 1.85)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 1.3, -0.15)
    Inputs, presets, csv_header = Inputs, PRESETS, CSV_HEADER
    window = 20.0  # s until the first chunk gives the motion's period

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.setup: FreeBodyStart | None = None  # core's motion drawn (from the chunks)
        self.omega_exact = np.zeros(3)  # omega_body of the exact body drawn (rad/s)
        self.ghost_error, self.ghost_failed = {}, False  # the drawn sample's (core's GhostComparison.errors, and t)
        self.arrow_points = np.zeros((3, 2, 3), dtype=np.float32)
        self._traced, self._trace_due = -math.inf, False  # wall clock of the last polhode update; one is due

    def job(self, inputs: Inputs, segment: Any) -> Any:
        return functools.partial(_compute_chunk, inputs)

    def preset_values(self, name: str) -> dict[str, Any]:
        w = preset_omega(name, body_mesh(str(self.controls.value("body")))[2]).tolist()
        return dict(zip(("omega_x", "omega_y", "omega_z"), w, strict=True))

    def csv_header_for(self, inputs: Inputs) -> str:
        return CSV_HEADER_GHOST if inputs.ghost else CSV_HEADER

    def build_nodes(self) -> None:
        scene, root = self.target.scene, self.root
        frame = functools.partial(scene.add_frame, axes_length=0.5, axes_radius=0.015)
        self.exact_frame = frame(f"{root}/exact", position=tuple(_EXACT_POS))
        self.ghost_frame = frame(f"{root}/ghost", position=tuple(_GHOST_POS))
        self.body_frames, self.ghost_frames = {}, {}
        for (i, name), (frames, which, color, opacity) in itertools.product(enumerate(BODIES), (
                (self.body_frames, "exact", _EXACT[0], None), (self.ghost_frames, "ghost", _GHOST[0], 0.45))):
            frames[name] = scene.add_mesh_simple(f"{root}/{which}/body{i}", *body_mesh(name)[:2], color=color,
                                                 opacity=opacity, visible=name == _DEFAULT.body)
        self.arrows = self.add_arrows(f"{root}/arrows", self.arrow_points, np.array([_L[0], _OMEGA[0], _GHOST_L[0]]),
                                      shaft_radius=0.025, head_radius=0.06, head_length=0.12)
        self.polhode = SphereTrail(self, f"{root}/momentum", _POLHODE[0], position=_SPHERE_POS, radius=_SPHERE_RADIUS,
                                   thickness=0.025, capacity=600, min_step=0.005, marker_color=_L[0], axes_length=1.1)
        self.ellipsoid = self.add_lines(f"{root}/momentum/ellipsoid", ellipsoid_wireframe(np.zeros(3)),
                                        _ELLIPSOID[0], thickness=0.008)
        # 3-D labels in static places (a label in a turning frame would orbit with it), ω's at its arrow's tip
        self.labels = {key: self.add_label(f"{root}/label_{key}", text, position=position, anchor=anchor,
                                           scale=_LABEL_SCALE) for key, text, position, anchor in (
            ("exact", "exact solution", _EXACT_POS + (0.0, 0.0, -0.95), "top-center"),
            ("ghost", "ghost\n" + _DEFAULT.ghost_text(), _GHOST_POS + (0, 0, _ARROW_LENGTH + 0.08), "bottom-center"),
            ("sphere", "momentum sphere\n(body frame)", _SPHERE_POS + (0.0, 0.0, _SPHERE_RADIUS + 0.12),
             "bottom-center"),
            ("L", "L", _EXACT_POS + (0.0, 0.0, _ARROW_LENGTH + 0.08), "bottom-center"),
            ("omega", "ω", (0.0, 0.0, 0.0), "bottom-left"))}

    def build_controls(self) -> None:
        self.legend = self.add_legend((_EXACT, _GHOST, _L, _OMEGA, _GHOST_L, _POLHODE, _ELLIPSOID))
        self.add_playback()
        self.info = self.add_readout("")  # the motion's constants (sent when they change)
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
        floor, ghost = math.log10(INVARIANT_ROUND_OFF), (lambda inputs: inputs.ghost)
        return [
            PlotSpec("omega", "exact ω_body(t) (body frame)", (("ω_x (rad/s)", "#dc2626"),
                     ("ω_y (rad/s)", "#16a34a"), ("ω_z (rad/s)", "#2563eb")), lambda t, c: tuple(c[:, 4:7].T)),
            PlotSpec("error", "ghost error vs exact (log10)", (("log10 angle error (rad)", "#b45309"),
                     ("log10 |ω error| (rad/s)", "#7c3aed")), lambda t, c: tuple(log10_floor(c[:, 18:20]).T),
                     shown=ghost),
            PlotSpec("drift", "ghost drift of invariants (log10; the dashed grey line is round-off)",
                     (("log10 |ΔE|/E", "#0f766e"), ("log10 |Δ|L||/|L|", "#1f2937"), ("log10 ||p|-1|", "#be185d"),
                      (f"round-off (10 ε = {INVARIANT_ROUND_OFF:.1e})", "#9ca3af", {"dash": [6, 4], "width": 1})),
                     lambda t, c: (*np.maximum(log10_floor(c[:, 20:23]), floor).T, np.full(t.size, floor)),
                     shown=ghost),
        ]

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
            self.setup, self.window = setup, window_seconds(float(setup.solution.period), fallback=20.0, cap=120.0)
            self.info.content, n = self.info_text(setup), setup.geometry.L_norm
            self.ellipsoid.points = ellipsoid_wireframe(setup.geometry.semi_axes, setup.geometry.axes,
                                                        scale=_SPHERE_RADIUS / n if n > 0 else 0.0)
            self.labels["L"].visible = n > 0
        self.ghost_failed |= chunk.failure is not None
        self.omega_exact = w.omega_body[j]
        if finite := bool(np.all(np.isfinite(chunk.arrows[j]))):  # never send a non-finite point
            self.arrow_points = chunk.arrows[j]
            set_array(self.arrows, "points", self.arrow_points)
        self.arrows.visible = finite
        # with a ghost both bodies are drawn at its sample instant, so that the two poses compare directly
        set_pose(self.exact_frame, wxyz=w.p[j])
        self.ghost_frame.visible = self.labels["ghost"].visible = g is not None
        if g is not None:
            self.ghost_error = {"t": float(w.t[j]), **g.errors(j)}
            set_pose(self.ghost_frame, wxyz=g.p[j])
        tip = self.arrow_points[1, 1]  # ω . L = 2E > 0: in the upper half
        if shown := bool(np.any(tip != self.arrow_points[1, 0])):
            set_pose(self.labels["omega"], position=tip)
        self.labels["omega"].visible = shown
        # the polhode every 0.05 s of wall time, not in a frame that sends a plot; at once when the clock stands
        self._trace_due |= self.polhode.add(chunk.polhode[j])
        if self._trace_due and (not self.playback.playing or self.sim_time == 0.0 or (
                self.refresh_due is None and time.monotonic() - self._traced >= _TRACE_PERIOD)):
            self._traced, self._trace_due = time.monotonic(), False
            self.polhode.flush()

    def info_text(self, start: FreeBodyStart) -> str:
        """The motion's constants (Markdown), sent when they change."""
        g = start.geometry
        lines = [f"**Motion**: {start.motion}; plots show the last {self.window:.3g} s",
                 "**Principal moments** " + ", ".join(significant(float(m), 3) for m in g.moments) + " kg m²"]
        if g.L_norm > 0:
            lines.append(f"**E** = {significant(g.energy)} J, **|L|** = {significant(g.L_norm)} kg m²/s (constant); "
                         + start.polhode.description)
        return "  \n".join(lines)

    def readout_lines(self) -> list[str]:
        ghost, e, r = f"**Ghost** {self.config.ghost_text()}", self.ghost_error, INVARIANT_ROUND_OFF
        if not self.config.ghost or not (e or self.ghost_failed):
            return []
        if self.ghost_failed:
            return [f"{ghost}: stopped (see the notice)"]
        drifts = ", ".join(f"{name} {one_digit(e[key], r)}" for name, key in
                           (("|ΔE|/E", "energy"), ("|Δ|L||/|L|", "L"), ("||p| − 1|", "p_norm")))
        return [f"{ghost}: angle error {e['angle']:.1e} rad, {drifts}" + f" (< {r:.0e}: round-off)" * ("<" in drifts)]
