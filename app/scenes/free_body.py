"""Free rigid body scene: torque-free motion, polhode, and the Dzhanibekov flip.

An asymmetric body (a T-handle by default; its inertia comes from the
trimesh mesh's mass properties) spins freely. Its motion is the exact
solution of :func:`core.rigid_body.free_body_solution` (Jacobi elliptic
functions), evaluated only at the displayed time. The angular-momentum
vector is drawn at the body (fixed in space), with the angular velocity.

Beside it, a chooser runs a numerical integrator of
:mod:`core.integrators` on :class:`core.rigid_body.FreeBodyModel` from the
same initial state, drawn as a translucent ghost; two plots show its error
against the exact solution (orientation angle, omega) and the drift of the
energy, ``|L|`` and ``|p| - 1``. The ghost's trajectory is computed in
chunks of simulated time ahead of the display clock and cached while the
parameters do not change.

A third picture shows the body-frame momentum space: the momentum sphere
``|L| = const``, the energy ellipsoid ``L . I^-1 L = 2E`` (wireframe) and
the polhode traced live by ``L_body(t)``, scaled so the sphere has a fixed
radius.

The scene holds no physics: it calls :mod:`core.rigid_body` and
:mod:`core.integrators`; Euler parameters go to viser's ``wxyz`` as they
are (scalar first).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.scenes._controls import Playback
from app.scenes._trail import extend_trail, trail_segments
from app.scenes.base import Scene
from core.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS, IntegrationError, Trajectory, integrate
from core.rigid_body import (
    FreeBodyModel,
    FreeBodySolution,
    angular_momentum_global,
    free_body_solution,
    momentum_geometry,
    principal_axes,
    rotation_angle_between,
)
from core.rotations import normalize_euler_parameters, rotate_vector

__all__ = ["BODIES", "FreeBodyScene", "INTEGRATORS", "Inputs", "PRESETS", "body_mesh", "preset_omega"]

_EXACT_POS = np.array([0.0, 0.0, 0.0])
_GHOST_POS = np.array([0.0, 1.9, 0.0])
_SPHERE_POS = np.array([0.0, -2.3, 0.0])
_SPHERE_RADIUS = 0.9
_ARROW_LENGTH = 1.3
_POLHODE_CAPACITY = 600  # line segments of the traced polhode
_POLHODE_MIN_STEP = 0.005
_ELLIPSE_SEGMENTS = 64
_CHUNK_SIM_TIME = 2.0  # s of simulated time per ghost chunk
_SAMPLE_DT = 1.0 / 60.0  # ghost samples (and plot points) per simulated second: 60
_CACHE_CHUNKS = 32
_HISTORY = 600
_PLOT_PERIOD = 0.2  # s of wall time between plot / readout refreshes
_LOG_FLOOR = 1e-17  # plotted on log axes: exact zeros shown at this floor

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


@dataclasses.dataclass
class _Gui:
    body: Any
    sliders: dict[str, Any]
    method: Any
    dt: Any
    rtol_exp: Any
    play: Any
    pause: Any
    reset: Any
    time_scale: Any
    preset_buttons: dict[str, Any]
    readout: Any
    plot_error: Any
    plot_drift: Any


@dataclasses.dataclass(frozen=True)
class _Setup:
    """What one setting of the controls asks the core for."""

    inputs: Inputs
    inertia: np.ndarray  # (3, 3)
    omega_body0: np.ndarray  # (3,)
    p0: np.ndarray  # (4,)
    solution: FreeBodySolution
    model: FreeBodyModel


_P0 = np.array([1.0, 0.0, 0.0, 0.0])


class FreeBodyScene(Scene):
    """Torque-free rigid body from the exact solution, with a numerical ghost."""

    name: ClassVar[str] = "free_body"
    title: ClassVar[str] = "Free rigid body (Dzhanibekov)"
    order: ClassVar[int] = 30
    # look a little right of the body so the GUI panel does not cover the ghost
    camera_position: ClassVar[tuple[float, float, float]] = (4.5, 1.0, 1.9)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 1.0, 0.0)

    def __init__(self, target: Any, notify: Any) -> None:
        super().__init__(target, notify)
        # recorded by GUI callbacks (under self.lock)
        self._inputs = Inputs()
        self._dirty = True
        self._ghost_dirty = True
        self.playback = Playback(PRESETS)  # play / pause / reset / time scale / presets
        # owned by update() (the session loop thread)
        self.setup: _Setup | None = None
        self.sim_time = 0.0
        self.display_time = 0.0  # time of the drawn poses (the ghost's sample time when one runs)
        self.p_exact = _P0.copy()
        self.omega_exact = np.zeros(3)
        self.p_ghost: np.ndarray | None = None
        self.ghost_error: dict[str, float] = {}
        self.chunks_computed = 0
        self._chunks: dict[int, tuple[Trajectory, np.ndarray]] = {}
        self._ghost_failed = False
        self._polhode = np.zeros((0, 3))
        self._history = np.zeros((0, 6))  # t, angle error, omega error, dE, d|L|, |p|-1
        self._since_plot = _PLOT_PERIOD
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
                f"{root}/exact/body{i}", v, f, color=(220, 150, 60), visible=(name == self._inputs.body))
            self.ghost_frames[name] = scene.add_mesh_simple(
                f"{root}/ghost/body{i}", v, f, color=(140, 170, 255), opacity=0.45,
                visible=(name == self._inputs.body))
        self.arrows = scene.add_arrows(
            f"{root}/arrows", np.zeros((3, 2, 3), dtype=np.float32),
            np.array([[60, 110, 230], [230, 70, 60], [120, 140, 230]], dtype=np.uint8),
            shaft_radius=0.02, head_radius=0.05, head_length=0.1,
        )
        sphere = trimesh.creation.icosphere(subdivisions=3, radius=_SPHERE_RADIUS)
        self.sphere_frame = scene.add_frame(f"{root}/momentum", position=tuple(_SPHERE_POS), axes_length=1.1,
                                            axes_radius=0.01)
        scene.add_mesh_simple(f"{root}/momentum/sphere", sphere.vertices.astype(np.float32),
                              sphere.faces.astype(np.uint32), color=(200, 200, 230), opacity=0.15)
        self.ellipsoid = scene.add_line_segments(
            f"{root}/momentum/ellipsoid", np.zeros((7 * _ELLIPSE_SEGMENTS, 2, 3), dtype=np.float32),
            (90, 180, 90), thickness=0.008,
        )
        self.polhode = scene.add_line_segments(
            f"{root}/momentum/polhode", np.zeros((_POLHODE_CAPACITY, 2, 3), dtype=np.float32),
            (240, 170, 20), thickness=0.025,
        )
        self.L_point = scene.add_icosphere(f"{root}/momentum/L", radius=0.05, color=(60, 110, 230))
        gui = self.target.gui
        with self.make_folder():
            gui.add_markdown(
                "Torque-free body from the **exact solution** (orange), a numerical **ghost** "
                "(blue, right) and the body-frame **momentum sphere** with the **energy ellipsoid** "
                "(green) and the **polhode** (yellow, left). Arrows: **L** blue (fixed in space), "
                "**ω** red."
            )
            playback = self.playback.add_gui(gui)
            body = gui.add_dropdown("Body", options=BODIES, initial_value=self._inputs.body)
            preset_buttons = self.playback.add_preset_buttons(gui)
            sliders = {}
            with gui.add_folder("Initial ω (body frame, rad/s)"):
                for field, label in (("omega_x", "ω_x"), ("omega_y", "ω_y"), ("omega_z", "ω_z")):
                    sliders[field] = gui.add_slider(label, min=-10.0, max=10.0, step=0.001,
                                                    initial_value=getattr(self._inputs, field))
            with gui.add_folder("Ghost integrator"):
                method = gui.add_dropdown("Method", options=INTEGRATORS, initial_value=self._inputs.method)
                dt = gui.add_slider("Step dt (s)", min=0.001, max=0.2, step=0.001, initial_value=self._inputs.dt,
                                    hint="Fixed-step methods")
                rtol_exp = gui.add_slider("log10 rtol", min=-13.0, max=-3.0, step=1.0,
                                          initial_value=self._inputs.rtol_exp, hint="Adaptive methods (scipy)")
            readout = gui.add_markdown("")
            # plotted as log10 values on linear axes (uPlot's log axes label
            # tiny values as 0)
            floor = math.log10(_LOG_FLOOR)
            empty = (np.zeros(2), np.full(2, floor), np.full(2, floor))
            x_scale = {"x": {"time": False}}
            plot_error = gui.add_uplot(
                empty,
                ({"label": "t (s)"}, {"label": "log10 angle error (rad)", "stroke": "#cc3333", "width": 2},
                 {"label": "log10 |ω error| (rad/s)", "stroke": "#3366cc", "width": 2}),
                title="ghost error vs exact (log10)", scales=x_scale, aspect=1.6,
            )
            plot_drift = gui.add_uplot(
                empty + (np.full(2, floor),),
                ({"label": "t (s)"}, {"label": "log10 |ΔE|/E", "stroke": "#33aa55"},
                 {"label": "log10 |Δ|L||/|L|", "stroke": "#3366cc"}, {"label": "log10 ||p|-1|", "stroke": "#cc3333"}),
                title="ghost drift of invariants (log10)", scales=x_scale, aspect=1.6,
            )
        self.gui = _Gui(body, sliders, method, dt, rtol_exp, playback.play, playback.pause, playback.reset,
                        playback.time_scale, preset_buttons, readout, plot_error, plot_drift)
        for field, slider in sliders.items():
            slider.on_update(lambda e, field=field: self._record(field, float(e.target.value)))
        body.on_update(lambda e: self._record("body", str(e.target.value)))
        method.on_update(lambda e: self._record("method", str(e.target.value)))
        dt.on_update(lambda e: self._record("dt", float(e.target.value)))
        rtol_exp.on_update(lambda e: self._record("rtol_exp", float(e.target.value)))

    # -- GUI callbacks: record only ---------------------------------------------
    def _record(self, field: str, value: Any) -> None:
        with self.lock:
            if getattr(self._inputs, field) == value:
                return
            self._inputs = dataclasses.replace(self._inputs, **{field: value})
            if field in ("method", "dt", "rtol_exp"):
                self._ghost_dirty = True
            else:
                self._dirty = True

    def request_reset(self) -> None:
        """Restart from t = 0 (cached ghost chunks are reused)."""
        self.playback.request_reset()

    def apply_preset(self, name: str) -> None:
        """Record preset ``name`` (one of :data:`PRESETS`); applied by ``update``."""
        self.playback.request_preset(name)

    @property
    def inputs(self) -> Inputs:
        with self.lock:
            return self._inputs

    # -- computation -------------------------------------------------------------
    def _make_setup(self, inputs: Inputs) -> _Setup:
        _, _, inertia = body_mesh(inputs.body)
        w0 = np.array([inputs.omega_x, inputs.omega_y, inputs.omega_z])
        solution = free_body_solution(inertia, w0, _P0)
        return _Setup(inputs, inertia, w0, _P0, solution, FreeBodyModel(inertia))

    def _restart(self) -> None:
        self.sim_time = 0.0
        self._polhode = np.zeros((0, 3))
        self._history = np.zeros((0, 6))
        self._since_plot = _PLOT_PERIOD

    def _ghost_chunk(self, k: int) -> tuple[Trajectory, np.ndarray] | None:
        """Ghost trajectory over chunk k and its error rows (cached); None if off/failed."""
        setup = self.setup
        assert setup is not None
        method = setup.inputs.method
        if method == "none" or self._ghost_failed:
            return None
        cached = self._chunks.get(k)
        if cached is not None:
            return cached
        if k == 0:
            y0 = np.concatenate([setup.p0, setup.omega_body0])
        else:
            prev = self._ghost_chunk(k - 1)
            if prev is None:
                return None
            y0 = np.array(prev[0].states[-1])
        t0 = k * _CHUNK_SIM_TIME
        n_samples = round(_CHUNK_SIM_TIME / _SAMPLE_DT)
        try:
            if method in FIXED_STEP_METHODS:
                if setup.inputs.dt <= _SAMPLE_DT:  # several steps per display sample
                    sub = max(1, round(_SAMPLE_DT / setup.inputs.dt))
                    h = _CHUNK_SIM_TIME / (n_samples * sub)
                else:  # coarse steps: every step is a sample
                    sub = 1
                    h = _CHUNK_SIM_TIME / math.ceil(_CHUNK_SIM_TIME / setup.inputs.dt - 1e-9)
                run = integrate(setup.model, y0, (t0, t0 + _CHUNK_SIM_TIME), method=method, dt=h,
                                save_every=sub)
            else:
                tol = 10.0 ** setup.inputs.rtol_exp
                t_eval = np.linspace(t0, t0 + _CHUNK_SIM_TIME, n_samples + 1)
                run = integrate(setup.model, y0, (t0, t0 + _CHUNK_SIM_TIME), method=method,
                                rtol=tol, atol=tol * 1e-2, t_eval=t_eval)
        except (IntegrationError, ValueError) as exc:
            self._ghost_failed = True
            self.notify("Ghost integrator stopped", f"{method}: {exc}", "warning")
            return None
        exact = setup.solution.at(run.t)
        inv = setup.model.invariants(run.states)
        E0 = setup.model.invariants(np.concatenate([setup.p0, setup.omega_body0]))
        L0 = float(np.linalg.norm(E0["angular_momentum_global"]))
        rows = np.stack([
            run.t,
            rotation_angle_between(exact.p, run.states[:, :4]),
            np.linalg.norm(exact.omega_body - run.states[:, 4:], axis=1),
            np.abs(inv["energy"] / float(E0["energy"]) - 1.0) if float(E0["energy"]) > 0 else np.zeros(run.t.size),
            np.abs(np.linalg.norm(inv["angular_momentum_global"], axis=-1) / L0 - 1.0) if L0 > 0
            else np.zeros(run.t.size),
            np.abs(inv["p_norm"] - 1.0),
        ], axis=1)
        if len(self._chunks) >= _CACHE_CHUNKS:
            for old in sorted(self._chunks)[: len(self._chunks) - _CACHE_CHUNKS + 1]:
                del self._chunks[old]
        self._chunks[k] = (run, rows)
        self.chunks_computed += 1
        return run, rows

    def _apply_inputs(self, inputs: Inputs, ghost_only: bool) -> None:
        try:
            setup = self._make_setup(inputs) if not ghost_only or self.setup is None else dataclasses.replace(
                self.setup, inputs=inputs)
        except ValueError as exc:
            self.notify("Invalid input", f"{exc}. Keeping the previous values.", "warning")
            return
        self.setup = setup
        self._chunks = {}
        self._ghost_failed = False
        self.ghost_error = {}
        if not ghost_only:
            self._restart()
            self._set_static_geometry()
        else:
            self._history = self._history[:0]

    def _set_static_geometry(self) -> None:
        setup = self.setup
        assert setup is not None
        g = momentum_geometry(setup.inertia, setup.omega_body0)
        scale = _SPHERE_RADIUS / g.L_norm if g.L_norm > 0 else 0.0
        self._ellipsoid_points = _ellipsoid_segments(g.semi_axes, g.axes, scale)
        self._geometry = g
        for name in BODIES:
            self.body_frames[name].visible = name == setup.inputs.body
            self.ghost_frames[name].visible = name == setup.inputs.body

    # -- update --------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        preset = self.playback.take_preset()
        if preset is not None:
            _, _, inertia = body_mesh(self.inputs.body)
            w = preset_omega(preset, inertia)
            for field, value in zip(("omega_x", "omega_y", "omega_z"), w, strict=True):
                self.gui.sliders[field].value = float(value)  # runs _record
            with self.lock:
                self._inputs = dataclasses.replace(self._inputs, omega_x=float(w[0]), omega_y=float(w[1]),
                                                   omega_z=float(w[2]))
                self._dirty = True
            self.playback.set_playing(True)
        with self.lock:
            dirty, ghost_dirty = self._dirty, self._ghost_dirty
            self._dirty = self._ghost_dirty = False
            inputs = self._inputs
        tick = self.playback.tick(dt)
        if dirty or self.setup is None:
            self._apply_inputs(inputs, ghost_only=False)
        elif ghost_dirty:
            self._apply_inputs(inputs, ghost_only=True)
        if self.setup is None:
            return
        if tick.reset:
            self._restart()
        self.sim_time += tick.step
        setup = self.setup
        # ghost: the last sample at or before the clock (samples every 1/60 s
        # of simulated time, or every step when the step is coarser)
        k = int(self.sim_time // _CHUNK_SIM_TIME)
        chunk = self._ghost_chunk(k)
        ghost_p = ghost_w = None
        self.display_time = self.sim_time
        if chunk is not None:
            run, rows = chunk
            i = max(0, int(np.searchsorted(run.t, self.sim_time + 1e-9, side="right")) - 1)
            if np.all(np.isfinite(run.states[i])) and np.linalg.norm(run.states[i, :4]) > 0:
                ghost_p = np.array(run.states[i, :4])
                ghost_w = np.array(run.states[i, 4:])
                # show the exact body at the ghost's instant (at most one
                # sample, 1/60 s or one coarse step, behind the clock) so the
                # two poses compare directly
                self.display_time = float(run.t[i])
                self.ghost_error = dict(zip(("t", "angle", "omega", "energy", "L", "p_norm"),
                                            rows[i].tolist(), strict=True))
                done = rows[: i + 1]
                if self._history.shape[0] == 0 or done[-1, 0] > self._history[-1, 0]:
                    new = done[done[:, 0] > (self._history[-1, 0] if self._history.shape[0] else -1.0)]
                    self._history = np.vstack([self._history, new])[-_HISTORY:]
            if self.sim_time - k * _CHUNK_SIM_TIME > 0.5 * _CHUNK_SIM_TIME:
                self._ghost_chunk(k + 1)  # compute ahead of the display clock
        motion = setup.solution.at(self.display_time)
        p, w = np.asarray(motion.p), np.asarray(motion.omega_body)
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(w))):
            self.notify("Motion stopped", "the exact solution left the finite range", "warning")
            self.playback.set_playing(False)
            return
        self.p_exact, self.omega_exact = p, w
        self.p_ghost = ghost_p
        # body-frame angular momentum on the momentum sphere (polhode)
        L_body = setup.inertia @ w
        g = self._geometry
        point = L_body * (_SPHERE_RADIUS / g.L_norm) if g.L_norm > 0 else np.zeros(3)
        self._polhode, _ = extend_trail(self._polhode, point, min_step=_POLHODE_MIN_STEP, capacity=_POLHODE_CAPACITY)
        arrows = self._arrow_points(p, w, ghost_p, ghost_w)
        self._since_plot += dt
        refresh = self._since_plot >= _PLOT_PERIOD
        with self.target.atomic():
            self.exact_frame.wxyz = tuple(p)
            self.ghost_frame.visible = ghost_p is not None
            if ghost_p is not None:
                self.ghost_frame.wxyz = tuple(ghost_p / np.linalg.norm(ghost_p))
            self.arrows.points = arrows
            self.polhode.points = trail_segments(self._polhode, _POLHODE_CAPACITY)
            self.L_point.position = tuple(point)
            if dirty:  # the ellipsoid changes only with the body or omega0
                self.ellipsoid.points = self._ellipsoid_points
            if refresh:
                self._since_plot = 0.0
                self._refresh_plots()

    def _arrow_points(self, p: np.ndarray, w: np.ndarray, ghost_p: np.ndarray | None,
                      ghost_w: np.ndarray | None) -> np.ndarray:
        setup = self.setup
        assert setup is not None
        out = np.zeros((3, 2, 3), dtype=np.float32)
        out[:, 0] = [_EXACT_POS, _EXACT_POS, _GHOST_POS]
        out[:, 1] = out[:, 0]
        L_global = angular_momentum_global(setup.inertia, w, p)
        n = float(np.linalg.norm(L_global))
        if n > 0:
            out[0, 1] = _EXACT_POS + _ARROW_LENGTH * L_global / n
        omega_global = rotate_vector(p, w)
        m = float(np.linalg.norm(omega_global))
        if m > 0:  # length saturates: 1.3 m |omega| / (|omega| + 3 rad/s)
            out[1, 1] = _EXACT_POS + _ARROW_LENGTH * omega_global / (m + 3.0)
        if ghost_p is not None and ghost_w is not None:
            # The ghost's |p| drifts with the integrator's error (the drift is
            # plotted); the arrow is drawn for the rotation it represents.
            Lg = angular_momentum_global(setup.inertia, ghost_w, normalize_euler_parameters(ghost_p))
            ng = float(np.linalg.norm(Lg))
            if ng > 0:
                out[2, 1] = _GHOST_POS + _ARROW_LENGTH * Lg / ng
        return out

    def _refresh_plots(self) -> None:
        assert self.gui is not None and self.setup is not None
        setup, g = self.setup, self._geometry
        sol = setup.solution
        period = "∞" if math.isinf(sol.period) else ("—" if sol.period == 0 else f"{sol.period:.4g} s")
        lines = [
            f"**t** = {self.sim_time:.2f} s, motion: **{sol.kind}**, ω period {period}",
            f"principal moments (kg m²): {', '.join(f'{m:.4g}' for m in g.moments)}",
            f"E = {g.energy:.6g} J, |L| = {g.L_norm:.6g} kg m²/s, "
            f"2E·J₂/|L|² = {2 * g.energy * g.moments[1] / g.L_norm**2:.6g}" if g.L_norm > 0 else "at rest",
        ]
        if self.setup.inputs.method != "none":
            if self._ghost_failed:
                lines.append(f"ghost **{setup.inputs.method}**: stopped (see notice)")
            elif self.ghost_error:
                e = self.ghost_error
                lines.append(
                    f"ghost **{setup.inputs.method}**: angle error {e['angle']:.2e} rad, "
                    f"|ΔE|/E {e['energy']:.1e}, ||p|-1| {e['p_norm']:.1e}"
                )
        self.gui.readout.content = "\n\n".join(lines)
        h = self._history
        if h.shape[0] < 2:
            return
        f = np.log10(np.maximum(h[:, 1:], _LOG_FLOOR))
        self.gui.plot_error.data = (h[:, 0], f[:, 0], f[:, 1])
        self.gui.plot_drift.data = (h[:, 0], f[:, 2], f[:, 3], f[:, 4])
