"""Gyroscope scene: a rotor in a cardan suspension (the chapter's gyroscope).

Three nested bodies on a base, each turned by its own ZXZ Euler angle:

* the outer gimbal turns about the base axis Z1 by the precession ``phi``;
* the inner gimbal turns about the line of nodes X2 by the nutation ``theta``;
* the rotor spins about its axis Z3 by ``psi``.

The nodes are nested frames, so each frame streams one pose: three poses per
frame. The rotor-axis tip leaves a trail (a capped line-segment buffer) on a
sphere, showing nutation loops, waves or cusps. Arrows show the angular
velocity, the angular momentum and the torque about the fixed point.

The scene holds no physics: :func:`core.gyroscope.simulate` computes the
motion (closed form without applied torques, DOP853 with them) in chunks of
simulated time ahead of the display clock, cached while the parameters do
not change; :func:`core.gyroscope.nutation`, :func:`invariants`,
:func:`rotor_vectors`, :func:`steady_precession_rates`,
:func:`steady_precession_torque` and :func:`sleeping_top_critical_spin` give
the readouts, plots and presets. Poses go to viser as Euler parameters
(``wxyz``) from :func:`core.rotations.euler_parameters_from_axis_angle`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.scenes._controls import Playback
from app.scenes._trail import extend_trail, trail_segments
from app.scenes.base import Scene
from core.gyroscope import (
    GyroscopeTrajectory,
    RotorParams,
    invariants,
    nutation,
    rotor_vectors,
    simulate,
    sleeping_top_critical_spin,
    steady_precession_rates,
    steady_precession_torque,
)
from core.rotations import euler_parameters_from_axis_angle

__all__ = ["GyroscopeScene", "PRESETS", "Inputs"]

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
_HISTORY = 360  # samples kept for the plots
_PLOT_PERIOD = 0.25  # s of wall time between plot / readout refreshes
_TRAIL_PERIOD = 0.05  # s of wall time between trail buffer updates
_CHUNK_SIM_TIME = 2.0  # s of simulated time per computed chunk
_CHUNK_SAMPLES = 481
_CACHE_CHUNKS = 64
_NUMERICAL_RTOL = 1e-9  # display accuracy of the torque-driven runs
_NUMERICAL_ATOL = 1e-10

# Arrow lengths saturate: length = 2.4 |v| / (|v| + half) (m).
_ARROW_MAX = 2.4
_ARROW_HALF = {"omega": 5.0, "momentum": 4.0, "torque": 1.0}
_ARROW_COLORS = np.array([[230, 70, 60], [60, 110, 230], [40, 170, 80]], dtype=np.uint8)


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


_SLIDERS = (
    # field, label, min, max, step, hint
    ("theta0_deg", "θ0 (deg)", 0.0, 180.0, 0.1, "Initial nutation angle theta (deg)"),
    ("theta_dot0", "θ̇0 (rad/s)", -5.0, 5.0, 0.01, "Initial nutation rate"),
    ("phi_dot0", "φ̇0 (rad/s)", -5.0, 5.0, 0.001, "Initial precession rate"),
    ("psi_dot0", "ψ̇0 spin (rad/s)", -100.0, 100.0, 0.01, "Initial spin rate psi_dot"),
    ("I", "I (kg m²)", 0.1, 5.0, 0.01, "Transverse moment about the fixed point"),
    ("I3", "I3 (kg m²)", 0.1, 5.0, 0.01, "Axial moment (must be <= 2 I)"),
    ("mgl", "mgl (N m)", 0.0, 10.0, 0.01, "Gravity moment; 0 = balanced rotor"),
    ("m_phi", "M_φ (N m)", -5.0, 5.0, 0.01, "Generalized torque on phi (outer gimbal motor)"),
    ("m_theta", "M_θ (N m)", -5.0, 5.0, 0.001, "Generalized torque on theta (inner gimbal motor)"),
    ("m_psi", "M_ψ (N m)", -5.0, 5.0, 0.01, "Generalized torque on psi (rotor motor)"),
)

#: Preset names in the order of their buttons.
PRESETS = (
    "Steady precession (torque M_θ)",
    "Steady precession (gravity)",
    "Fast top (pseudo-regular)",
    "Cuspidal motion",
    "Sleeping top above critical",
    "Sleeping top below critical",
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


def _ring_mesh(radius: float) -> trimesh.Trimesh:
    """A ring in the frame's x-z plane (its axis along y)."""
    ring = trimesh.creation.torus(radius, _RING_TUBE, major_sections=72, minor_sections=12)
    ring.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))
    return ring


def _cylinder_between(a, b, radius: float) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([a, b], dtype=float), sections=20)


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
        _cylinder_between([0, 0, -_INNER_RADIUS], [0, 0, _TIP_RADIUS], 0.03),
        trimesh.creation.icosphere(subdivisions=2, radius=0.06).apply_translation([0, 0, _TIP_RADIUS]),
    ])
    marker = trimesh.creation.box(extents=(0.18, 0.1, _ROTOR_THICKNESS * 1.08))
    marker.apply_translation([_ROTOR_RADIUS - 0.1, 0, 0])
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=_TIP_RADIUS)
    return {"base": base, "outer": outer, "inner": inner, "rotor": rotor, "marker": marker, "sphere": sphere}


@dataclasses.dataclass
class _Gui:
    sliders: dict[str, Any]
    play: Any
    pause: Any
    reset: Any
    time_scale: Any
    preset_buttons: dict[str, Any]
    show_trail: Any
    show_arrows: Any
    readout: Any
    plot_theta: Any
    plot_phi_dot: Any
    plot_drift: Any


@dataclasses.dataclass(frozen=True)
class _Model:
    """What one setting of the sliders asks the core for."""

    params: RotorParams
    state0: np.ndarray  # (6,)
    torques: tuple[float, float, float]


class GyroscopeScene(Scene):
    """Rotor in a cardan suspension: precession, nutation, spin (ZXZ)."""

    name: ClassVar[str] = "gyroscope"
    title: ClassVar[str] = "Gyroscope (cardan rotor)"
    order: ClassVar[int] = 40
    # A 3/4 view from above, the suspension left of centre beside the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (3.08, -2.58, 1.64)
    camera_look_at: ClassVar[tuple[float, float, float]] = (1.05, 1.25, -0.15)

    def __init__(self, target: Any, notify: Any) -> None:
        super().__init__(target, notify)
        # Recorded by GUI callbacks (guarded by self.lock).
        self._inputs = Inputs()
        self._inputs_dirty = True
        self.playback = Playback(PRESETS)  # play / pause / reset / time scale / presets
        self._show_trail = True
        self._show_arrows = True
        # Owned by update() (the session loop thread).
        self.model: _Model | None = None
        self.sim_time = 0.0
        self.angles = np.zeros(3)  # (phi, theta, psi) as last drawn
        self.rates = np.zeros(3)
        self._nearest_state = np.zeros(6)  # computed sample nearest sim_time
        self._model_inputs = Inputs()  # slider values of the model in use
        self._chunks: dict[int, GyroscopeTrajectory] = {}
        self._trail = np.zeros((0, 3))
        self._history = np.zeros((0, 6))  # t, theta, phi_dot, dd1, dd2, dE
        self._since_plot = _PLOT_PERIOD
        self._since_trail = _TRAIL_PERIOD
        self._trail_changed = True
        self._inv0 = None
        self._predicted = None
        self._readout_static = ""
        self.chunks_computed = 0
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
                              color=(200, 140, 60))
        self.inner_frame = scene.add_frame(f"{root}/outer/inner", show_axes=False)
        scene.add_mesh_simple(f"{root}/outer/inner/mesh", meshes["inner"].vertices, meshes["inner"].faces,
                              color=(90, 160, 210))
        self.rotor_frame = scene.add_frame(f"{root}/outer/inner/rotor", axes_length=0.4, axes_radius=0.012)
        scene.add_mesh_simple(f"{root}/outer/inner/rotor/mesh", meshes["rotor"].vertices, meshes["rotor"].faces,
                              color=(170, 170, 180))
        scene.add_mesh_simple(f"{root}/outer/inner/rotor/marker", meshes["marker"].vertices,
                              meshes["marker"].faces, color=(220, 60, 60))
        self.trail = scene.add_line_segments(
            f"{root}/trail", np.zeros((_TRAIL_CAPACITY, 2, 3), dtype=np.float32),
            np.full((_TRAIL_CAPACITY, 2, 3), (250, 200, 40), dtype=np.uint8), thickness=3.0, thickness_units="screen",
        )
        self.arrows = scene.add_arrows(
            f"{root}/arrows", np.zeros((3, 2, 3), dtype=np.float32), _ARROW_COLORS,
            shaft_radius=0.02, head_radius=0.05, head_length=0.1,
        )
        gui = self.target.gui
        with self.make_folder():
            gui.add_markdown(
                "Rotor in a cardan suspension, ZXZ angles: outer gimbal **φ** about Z1, "
                "inner gimbal **θ** about X2, rotor **ψ** about Z3. Gravity along −Z1 when "
                "mgl > 0. Arrows: **ω** red, **L** blue, **torque** green."
            )
            playback = self.playback.add_gui(gui)
            preset_buttons = self.playback.add_preset_buttons(gui)
            sliders = {}
            groups = (("Initial state", _SLIDERS[:4]), ("Rotor", _SLIDERS[4:7]), ("Applied torques", _SLIDERS[7:]))
            for title, rows in groups:
                with gui.add_folder(title):
                    for field, label, lo, hi, step, hint in rows:
                        sliders[field] = gui.add_slider(label, min=lo, max=hi, step=step,
                                                        initial_value=getattr(self._inputs, field), hint=hint)
            with gui.add_folder("Show"):
                show_trail = gui.add_checkbox("Tip trail", True)
                show_arrows = gui.add_checkbox("Arrows ω, L, torque", True)
            readout = gui.add_markdown("")
            empty = (np.zeros(2), np.zeros(2))
            # x is simulated time in seconds, not a calendar date (uPlot's default)
            x_scale = {"x": {"time": False}}
            plot_theta = gui.add_uplot(
                empty + (np.zeros(2), np.zeros(2)),
                ({"label": "t (s)"}, {"label": "θ (deg)", "stroke": "#2266dd", "width": 2},
                 {"label": "θ_min", "stroke": "#999999", "dash": [6, 4]},
                 {"label": "θ_max", "stroke": "#999999", "dash": [6, 4]}),
                title="θ(t) and predicted bounds", scales=x_scale, aspect=1.6,
            )
            plot_phi_dot = gui.add_uplot(
                empty, ({"label": "t (s)"}, {"label": "φ̇ (rad/s)", "stroke": "#dd6622", "width": 2}),
                title="φ̇(t)", scales=x_scale, aspect=1.6,
            )
            plot_drift = gui.add_uplot(
                empty + (np.zeros(2), np.zeros(2)),
                ({"label": "t (s)"}, {"label": "log10|Δd1|", "stroke": "#cc3333"},
                 {"label": "log10|Δd2|", "stroke": "#3366cc"}, {"label": "log10|ΔE|", "stroke": "#33aa55"}),
                title="log10 |drift| of d1, d2, E", scales=x_scale,
                aspect=1.6,
            )
        self.gui = _Gui(sliders, playback.play, playback.pause, playback.reset, playback.time_scale, preset_buttons,
                        show_trail, show_arrows, readout, plot_theta, plot_phi_dot, plot_drift)
        for field, slider in sliders.items():
            slider.on_update(lambda event, field=field: self._on_slider(field, event.target.value))
        show_trail.on_update(lambda e: self._set_show("trail", bool(e.target.value)))
        show_arrows.on_update(lambda e: self._set_show("arrows", bool(e.target.value)))

    # -- GUI callbacks and requests: record only -----------------------------------
    def _on_slider(self, field: str, value: Any) -> None:
        with self.lock:
            self._inputs = dataclasses.replace(self._inputs, **{field: float(value)})
            self._inputs_dirty = True

    def _set_show(self, what: str, value: bool) -> None:
        with self.lock:
            if what == "trail":
                self._show_trail = value
            else:
                self._show_arrows = value

    def request_reset(self) -> None:
        """Restart the motion from the initial state (cached chunks are reused)."""
        self.playback.request_reset()

    def apply_preset(self, name: str) -> None:
        """Record preset ``name`` (one of :data:`PRESETS`); applied by ``update``."""
        self.playback.request_preset(name)

    @property
    def playing(self) -> bool:
        return self.playback.playing

    # -- computation ---------------------------------------------------------------
    def _make_model(self, inputs: Inputs) -> _Model:
        params = RotorParams(I=inputs.I, I3=inputs.I3, mgl=inputs.mgl)
        state0 = np.array([0.0, math.radians(inputs.theta0_deg), 0.0,
                           inputs.phi_dot0, inputs.theta_dot0, inputs.psi_dot0])
        return _Model(params, state0, (inputs.m_phi, inputs.m_theta, inputs.m_psi))

    def _has_torque(self) -> bool:
        assert self.model is not None
        return any(m != 0.0 for m in self.model.torques)

    def _chunk(self, k: int) -> GyroscopeTrajectory:
        """Trajectory over [k, k + 1] chunk lengths of simulated time (cached)."""
        cached = self._chunks.get(k)
        if cached is not None:
            return cached
        model = self.model
        assert model is not None
        t = np.linspace(k * _CHUNK_SIM_TIME, (k + 1) * _CHUNK_SIM_TIME, _CHUNK_SAMPLES)
        if not self._has_torque():
            # closed form: exact from the initial state at absolute times
            traj = simulate(model.params, model.state0, t)
        else:
            # numerical: continue from the end of the previous chunk
            if k == 0:
                start = model.state0
            else:
                prev = self._chunk(k - 1)
                start = np.concatenate([prev.angles[-1], prev.rates[-1]])
            traj = simulate(model.params, start, t - t[0], torques=model.torques,
                            rtol=_NUMERICAL_RTOL, atol=_NUMERICAL_ATOL)
            traj = GyroscopeTrajectory(t=t, angles=traj.angles, rates=traj.rates, method=traj.method)
        if len(self._chunks) >= _CACHE_CHUNKS:
            # keep the most recent chunks (the numerical path needs k - 1)
            for old in sorted(self._chunks)[: len(self._chunks) - _CACHE_CHUNKS + 1]:
                del self._chunks[old]
        self._chunks[k] = traj
        self.chunks_computed += 1
        return traj

    def _sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        k = int(t // _CHUNK_SIM_TIME)
        traj = self._chunk(k)
        if t - k * _CHUNK_SIM_TIME > 0.5 * _CHUNK_SIM_TIME:
            self._chunk(k + 1)  # compute ahead of the display clock
        angles = np.array([np.interp(t, traj.t, traj.angles[:, i]) for i in range(3)])
        rates = np.array([np.interp(t, traj.t, traj.rates[:, i]) for i in range(3)])
        # The computed sample nearest t: the invariants are evaluated there,
        # since linear interpolation between samples does not conserve them
        # (it showed drifts of 1e-8..1e-5 where the solution has round-off).
        j = min(int(round((t - traj.t[0]) / (traj.t[1] - traj.t[0]))), traj.t.size - 1)
        self._nearest_state = np.concatenate([traj.angles[j], traj.rates[j]])
        return angles, rates

    def _restart(self) -> None:
        self.sim_time = 0.0
        self._trail = np.zeros((0, 3))
        self._history = np.zeros((0, 6))
        self._since_plot = _PLOT_PERIOD
        self._trail_changed = True

    def _set_model(self, inputs: Inputs) -> bool:
        try:
            model = self._make_model(inputs)
        except ValueError as exc:
            self.notify("Invalid rotor parameters",
                        f"{exc}. Keeping the previous values (the sliders are set back).", "warning")
            return False
        self.model = model
        self._model_inputs = inputs
        self._chunks = {}
        self._inv0 = invariants(model.params, model.state0)
        try:
            self._predicted = nutation(model.params, model.state0) if not self._has_torque() else None
        except ValueError:
            self._predicted = None
        self._readout_static = self._static_readout()
        self._restart()
        return True

    def _revert_sliders(self) -> None:
        """Show the values in use again after rejected input (sliders and model agree)."""
        assert self.gui is not None
        kept = self._model_inputs
        for field, slider in self.gui.sliders.items():
            if slider.value != getattr(kept, field):
                slider.value = getattr(kept, field)  # runs the callback (takes the lock)
        with self.lock:
            self._inputs = kept
            self._inputs_dirty = False

    # -- update ----------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        preset = self.playback.take_preset()
        if preset is not None:
            values = preset_inputs(preset)
            # setting slider values runs their callbacks (which take the lock)
            for field, slider in self.gui.sliders.items():
                slider.value = getattr(values, field)
            with self.lock:
                self._inputs = values
                self._inputs_dirty = True
            self.playback.set_playing(True)
        with self.lock:
            dirty = self._inputs_dirty
            self._inputs_dirty = False
            inputs = self._inputs
            show_trail, show_arrows = self._show_trail, self._show_arrows
        tick = self.playback.tick(dt)
        if dirty or self.model is None:
            if not self._set_model(inputs):
                if self.model is None:
                    self._set_model(Inputs())
                else:
                    self._revert_sliders()
        if tick.reset:
            self._restart()
        self.sim_time += tick.step
        try:
            angles, rates = self._sample(self.sim_time)
        except ValueError as exc:
            self.notify("Simulation stopped", f"{exc}", "warning")
            self.playback.set_playing(False)
            return
        if not (np.all(np.isfinite(angles)) and np.all(np.isfinite(rates))):
            self.notify("Simulation stopped", "the motion left the finite range", "warning")
            self.playback.set_playing(False)
            return
        self.angles, self.rates = angles, rates
        model = self.model
        assert model is not None
        state = np.concatenate([angles, rates])
        axes = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        wxyz = euler_parameters_from_axis_angle(axes, angles)
        vectors = rotor_vectors(model.params, state, model.torques)
        tip = _TIP_RADIUS * vectors.rotor_axis
        self._trail, added = extend_trail(self._trail, tip, min_step=_TRAIL_MIN_STEP, capacity=_TRAIL_CAPACITY)
        if added:
            self._trail_changed = True
        self._since_trail += dt
        send_trail = show_trail and self._trail_changed and self._since_trail >= _TRAIL_PERIOD
        trail_points = trail_segments(self._trail, _TRAIL_CAPACITY) if send_trail else None
        arrow_points = self._arrow_points(vectors)
        inv = invariants(model.params, self._nearest_state)
        row = np.array([[self.sim_time, math.degrees(angles[1]), rates[0],
                         float(inv.d1 - self._inv0.d1), float(inv.d2 - self._inv0.d2),
                         float(inv.energy - self._inv0.energy)]])
        if self._history.shape[0] and self.sim_time <= self._history[-1, 0]:
            pass  # paused: no new sample
        else:
            self._history = np.vstack([self._history, row])[-_HISTORY:]
        self._since_plot += dt
        refresh = self._since_plot >= _PLOT_PERIOD
        with self.target.atomic():
            self.outer_frame.wxyz = wxyz[0]
            self.inner_frame.wxyz = wxyz[1]
            self.rotor_frame.wxyz = wxyz[2]
            self.trail.visible = show_trail
            if trail_points is not None:
                self.trail.points = trail_points
                self._since_trail = 0.0
                self._trail_changed = False
            self.arrows.visible = show_arrows
            if show_arrows:
                self.arrows.points = arrow_points
            if refresh:
                self._since_plot = 0.0
                self._refresh_plots(inv)

    @staticmethod
    def _arrow_points(vectors: Any) -> np.ndarray:
        out = np.zeros((3, 2, 3), dtype=np.float32)
        for i, (key, v) in enumerate((("omega", vectors.omega), ("momentum", vectors.angular_momentum),
                                      ("torque", vectors.torque))):
            norm = float(np.linalg.norm(v))
            if norm > 1e-12:
                out[i, 1] = v / norm * _ARROW_MAX * norm / (norm + _ARROW_HALF[key])
        return out

    def _static_readout(self) -> str:
        model = self.model
        assert model is not None
        p = model.params
        lines = [f"**Critical spin** (sleeping top): {sleeping_top_critical_spin(p):.4g} rad/s"]
        spin = model.state0[5] + model.state0[3] * math.cos(model.state0[1])
        lines.append(f"- spin ω3 = ψ̇ + φ̇ cos θ = {spin:.4g} rad/s")
        if self._predicted is not None:
            nu = self._predicted
            period = float(nu.period)
            lines += [
                f"**Nutation** (Eq. 8.21): θ in [{math.degrees(float(nu.theta_min)):.3f}°, "
                f"{math.degrees(float(nu.theta_max)):.3f}°]",
                f"- period {'∞ (θ constant)' if math.isinf(period) else f'{period:.4g} s'}",
                f"- mean precession φ̇ = {float(nu.mean_precession_rate):.5g} rad/s",
            ]
        else:
            lines.append("**Nutation**: applied torques act, no closed-form prediction.")
        return "\n".join(lines)

    def _refresh_plots(self, inv: Any) -> None:
        assert self.gui is not None
        h = self._history
        lines = [
            f"**t** = {self.sim_time:.2f} s, θ = {math.degrees(self.angles[1]):.3f}°, "
            f"φ̇ = {self.rates[0]:.4g} rad/s",
            f"**d1** = {float(inv.d1):.10g}, **d2** = {float(inv.d2):.10g}, **E** = {float(inv.energy):.10g}",
            self._readout_static,
        ]
        self.gui.readout.content = "\n\n".join(lines)
        if h.shape[0] < 2:
            return
        t = h[:, 0]
        if self._predicted is not None:
            lo = np.full_like(t, math.degrees(float(self._predicted.theta_min)))
            hi = np.full_like(t, math.degrees(float(self._predicted.theta_max)))
        else:
            # torques act: no prediction, the lines show the observed range
            lo = np.full_like(t, h[:, 1].min())
            hi = np.full_like(t, h[:, 1].max())
        self.gui.plot_theta.data = (t, h[:, 1], lo, hi)
        self.gui.plot_phi_dot.data = (t, h[:, 2])
        self.gui.plot_drift.data = (t, *drift_log10(h[:, 3:6]).T)
