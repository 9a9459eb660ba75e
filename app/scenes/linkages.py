"""Linkages scene: the four linkages of :func:`rigidlab.core.models.linkage`, their joints' reactions and closed forms.

A :class:`~rigidlab.app.scenes._simulation.SimulationScene`: the job :func:`_compute_chunk` runs
:func:`rigidlab.core.models.linkage_motion` for 1 s from the state the previous chunk ended in and places the rods and
joint balls (:class:`~rigidlab.app.scenes._bodies.Parts`); a frame sends the poses of one sample.
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

from rigidlab.app import meshes
from rigidlab.app.controls import Choice, Slider, Toggle
from rigidlab.app.nodes import set_pose
from rigidlab.app.readout import one_digit, significant
from rigidlab.app.scenes._arrows import vertex_rgb
from rigidlab.app.scenes._bodies import Parts, PartsView, Placed, add_body_meshes, saturating_arrows
from rigidlab.app.scenes._plots import Table, log10_floor
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene
from rigidlab.core.models import Linkage, LinkageInfo, LinkageMotion, linkage, linkage_motion
from rigidlab.core.multibody import ADAPTIVE_METHODS, FIXED_STEP_METHODS

__all__ = ["CHAIN", "CRANK", "DOUBLE", "LinkagesScene", "Inputs", "METHODS", "Model", "POSITION_TOL", "PRESETS",
           "RESIDUAL_BOUND", "RTOLS", "STEPS", "TOP"]

#: Preset names (the *Preset* dropdown), and the linkage of :func:`rigidlab.core.models.linkage` each one is.
CHAIN, DOUBLE, CRANK, TOP = ("Pendulum chain (N links)", "Spatial double pendulum", "Slider-crank with motor",
                             "Heavy top vs closed form")
PRESETS = (CHAIN, DOUBLE, CRANK, TOP)
_KINDS = {CHAIN: "chain", DOUBLE: "double_pendulum", CRANK: "slider_crank", TOP: "heavy_top"}
#: Integrators :meth:`rigidlab.core.multibody.System.simulate` accepts; tolerances (atol = rtol / 100) and steps (s).
METHODS = tuple(ADAPTIVE_METHODS) + tuple(FIXED_STEP_METHODS)
RTOLS = ("1e-3", "1e-4", "1e-5", "1e-6", "1e-7", "1e-8", "1e-9", "1e-10")
STEPS = ("1/60", "1/120", "1/240", "1/480", "1/960")
#: simulate's Newton tolerance of the position projection, and the bound on ``max |C|`` of every sample
#: shown (the projection stops early only below it, else the run stops with a notice).
POSITION_TOL, RESIDUAL_BOUND = 1e-12, 1e-8

_MAX_RODS, _ROD_RADIUS, _JOINT_RADIUS = 10, 0.036, 0.06  # rods drawn at most; radii of rods and joint balls (m)
_PLACEMENT = {  # model frame: position (global), angle about +z (rad); all four fit the one default view
    CHAIN: ((0.0, 0.0, 2.45), 0.0), DOUBLE: ((0.0, 0.0, 2.45), 0.0),
    CRANK: ((0.0, -0.9, 1.0), math.pi / 2), TOP: ((-0.51, -0.86, 1.1), -0.54)}
_GHOST_OFFSET = (0.0, 2.0, 0.0)  # the closed-form top beside the multibody one (model frame)
_ARROW_MAX, _TORQUE_ARROW_MAX = 0.9, 0.7  # m: arrows l |F| / (|F| + W), W the weight
_FORCE, _TORQUE, _JOINT, _GHOST = (225, 80, 0), (150, 60, 200), (40, 40, 48), (140, 170, 255)


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


@dataclasses.dataclass(frozen=True)
class Model:
    """The chosen preset's parameters (rad, rad/s; the other presets' left out) and integrator (rtol or dt, s)."""

    preset: str
    n_links: int = 0
    tilt: float = 0.0
    speed: float = 0.0
    method: str = "DOP853"
    rtol: float | None = 1e-6
    dt: float | None = None

    @classmethod
    def from_inputs(cls, i: Inputs) -> Model:
        if i.preset not in PRESETS:
            raise ValueError(f"preset: expected one of {list(PRESETS)}, got {i.preset!r}")
        chain, adaptive = i.preset == CHAIN, i.method in ADAPTIVE_METHODS
        return cls(i.preset, int(i.n_links) if chain else 0, math.radians(i.tilt_deg) if chain else 0.0,
                   i.rpm * math.pi / 30.0 if i.preset == CRANK else 0.0, i.method, float(i.rtol) if adaptive else None,
                   None if adaptive else 1.0 / float(i.dt.split("/")[1]))


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """One second of the motion (core's samples, the parts placed, the table) and, from chunk 0, what its model
    draws: core's summary, rods and joint balls, the longest arrow (m) and the energy at t = 0 (J)."""

    k: int
    t: np.ndarray  # (n,) s
    motion: LinkageMotion
    placed: Placed
    table: Table
    model: Model
    info: LinkageInfo
    parts: Parts
    arrow_max: float
    energy0: float
    cpu_seconds: float  # CPU time of the job
    worker: int  # pid of the process that computed it


@functools.lru_cache(maxsize=8)
def _built(model: Model) -> Linkage:
    """The linkage of ``model``, built once per model in each worker process; each job runs a copy."""
    return linkage(_KINDS[model.preset], n_links=model.n_links or 5, tilt=model.tilt, speed=model.speed)


def _compute_chunk(model: Model, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``model`` (on the executor), continued from chunk ``k - 1`` (``previous``)."""
    cpu0 = time.thread_time()
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: chunk {k} continues from chunk {k - 1}, which was not given")
    link, t = copy.deepcopy(_built(model)), np.linspace(k, k + 1.0, 61)
    step = {"rtol": model.rtol, "atol": model.rtol * 1e-2} if model.rtol is not None else {"dt": model.dt}
    m = linkage_motion(link, t, initial=previous.motion.final_state if previous else None, method=model.method, **step)
    info, energy0 = (previous.info, previous.energy0) if previous else (link.info, float(m.energy[0]))
    parts = previous.parts if previous else Parts.build(  # rods along their body z axis, centred; joint balls
        rods=[(i, (0, 0, -L / 2), (0, 0, L / 2), _ROD_RADIUS) for i, L in info.links],
        balls=[(b, u, _JOINT_RADIUS) for b, u in zip(info.joint_bodies, info.joint_points_body)])
    drawn = (model, info, parts, min([_ARROW_MAX] + [1.2 * L for _, L in info.links]), energy0)
    return _Chunk(k, m.t, m, drawn[2].place(m.R, m.p), Table.build(t, m.table()), *drawn, time.thread_time() - cpu0,
                  os.getpid())


def _supports() -> dict[str, trimesh.Trimesh]:
    """Static parts (model frame, m): the chain's ceiling; the crank's pedestal and the slider's guide; the tops'."""
    box, z, top = trimesh.creation.box, -_PLACEMENT[CRANK][0][2], meshes.pedestal(_PLACEMENT[TOP][0][2])
    crank = [box(size).apply_translation(at) for size, at in (((0.16, 0.12, -z), (0, 0.12, z / 2)), (
        (1.7, 0.08, 0.1), (1.5, 0.2, 0)), ((0.06, 0.06, -z), (0.7, 0.2, z / 2)), ((0.06, 0.06, -z), (2.3, 0.2, z / 2)))]
    return {"chain": box((0.5, 0.5, 0.06)).apply_translation((0, 0, 0.08)), "crank": trimesh.util.concatenate(
        [*crank, trimesh.creation.cylinder(radius=0.03, segment=((0, 0, 0), (0, 0.12, 0)), sections=16)]),
        "top": trimesh.util.concatenate([trimesh.Trimesh(*top), trimesh.Trimesh(*top).apply_translation(
            _GHOST_OFFSET)])}


class LinkagesScene(SimulationScene):
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
        "- **Plots**: the energy's change E − E0 (E0 in the title; the motor's work for the "
        "slider-crank), log10 |E − E0| beside its round-off level 16 ε E0 (models without a motor), the "
        "closed-form difference (slider position, or the top's attitude, Eq. 8.82) and "
        "log10 max |C|. *Download CSV* exports the samples of the plotted window."
    )
    camera_position: ClassVar[tuple[float, float, float]] = (3.6, -0.9, 2.55)  # 3/4 view, models left of the panel
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.0, 1.25, 1.35)
    Inputs = Inputs
    csv_header = "t (s)"  # per model: csv_header_for

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.model: Model | None = None  # the model in use
        self.setup: _Chunk | None = None  # the chunk 0 of the model drawn (what it draws)
        self.max_residual = 0.0  # largest max |C| drawn since t = 0

    def job(self, inputs: Inputs, segment: Any) -> Any:
        return functools.partial(_compute_chunk, self.model)

    def configure(self, inputs: Inputs) -> None:
        """A new model restarts the motion and shows its controls; a slider of another preset is only kept."""
        model, self.config = Model.from_inputs(inputs), inputs
        if model != self.model:
            self.model = model
            for key, shown in (("n_links", model.n_links > 0), ("tilt_deg", model.n_links > 0), ("dt", model.dt),
                               ("rpm", model.preset == CRANK), ("rtol", model.rtol is not None)):
                self.controls.handles[key].visible = bool(shown)
            self._model_folder.visible = model.preset in (CHAIN, CRANK)
            super().configure(inputs)

    def build_nodes(self) -> None:
        scene, m = self.target.scene, f"{self.root}/model"
        self.add_ground_grid(width=8.0, height=8.0, position=(0.0, 0.0, 0.0), cell_size=0.25, section_size=1.0)
        self.model_frame = scene.add_frame(m, show_axes=False)
        self.supports = {key: add_body_meshes(scene, f"{m}/support_{key}", [(mesh, (150, 150, 160))], visible=False)
                         for key, mesh in _supports().items()}
        self.parts = PartsView(scene, f"{m}/parts", capacity=(_MAX_RODS, _MAX_RODS, 1, 1),
                               rod_colors=[((96, 108, 128), (178, 184, 196))[i % 2] for i in range(_MAX_RODS)],
                               ball_color=_JOINT, box_color=_JOINT, spring_color=_JOINT)
        self.slider = scene.add_box(f"{m}/slider", color=(120, 122, 134), dimensions=(0.125,) * 3, visible=False)
        self.ghost_pivot = scene.add_frame(f"{m}/ghost_pivot", show_axes=False, position=_GHOST_OFFSET, visible=False)
        top = meshes.spinning_top(2.0 / 9.81)  # core's top: its centre of mass l = mgl / (m g) above the pivot
        self.top = add_body_meshes(scene, f"{m}/top", [(top["body"], (205, 172, 110)), (top["marker"], (90, 60, 40))],
                                   visible=False)
        self.ghost = add_body_meshes(scene, f"{m}/ghost_pivot/top", [(top["body"], _GHOST), (top["marker"], _GHOST)],
                                     opacity=0.4)
        arrow = dict(shaft_radius=0.016, head_radius=0.05, head_length=0.12, visible=False)
        self.force_arrows = self.add_arrows(f"{m}/forces", np.zeros((1, 2, 3)), vertex_rgb(_FORCE), **arrow)
        self.torque_arrow = self.add_arrows(f"{m}/torque", np.zeros((1, 2, 3)), vertex_rgb(_TORQUE), **arrow)
        self.labels = {key: self.add_label(f"{m}/label_{key}", text, position=position, anchor="top-center",
                                           scale=1.3, visible=False) for key, text, position in (
            ("top", "multibody top\n(spherical joint)", (0.0, 0.0, -0.55)),
            ("ghost", "closed form\n(core.gyroscope)", np.add(_GHOST_OFFSET, (0.0, 0.0, -0.55))),
            ("motor", "motor", (0.0, 0.0, -0.6)))}

    def build_controls(self) -> None:
        self.add_legend(((_FORCE, "reaction force on the lower / driven body at each joint"), (_TORQUE, "motor "
                         "torque on the crank"), (_JOINT, "joints"), (_GHOST, "closed-form heavy top (translucent)")),
                        "Colours (arrow lengths saturate, see What you see):")
        self.add_playback()
        self.info = self.add_readout("")
        d, add = Inputs(), self.controls.add
        add(Choice("preset", "Preset", options=PRESETS, default=d.preset))
        with self.target.gui.add_folder("Model") as self._model_folder:
            add(Slider("n_links", "N links", min=1, max=_MAX_RODS, step=1, integer=True, default=d.n_links,
                       hint="Links of the chain (total length 2 m)"))
            add(Slider("tilt_deg", "Tilt (deg)", min=0.0, max=170.0, step=1.0, default=d.tilt_deg,
                       hint="The straight chain is released at rest, turned this far from hanging"))
            add(Slider("rpm", "Motor (rpm)", min=-300.0, max=300.0, step=1.0, default=d.rpm,
                       hint="Crank speed imposed by the motor"))
        with self.target.gui.add_folder("Integrator"):
            add(Choice("method", "Method", options=METHODS, default=d.method,
                       hint="DOP853 and RK45 adaptive (scipy); rk4 and midpoint fixed-step"))
            add(Choice("rtol", "rtol", options=RTOLS, default=d.rtol,
                       hint="Relative tolerance of DOP853 / RK45 (atol = rtol / 100)"))
            add(Choice("dt", "Step dt (s)", options=STEPS, default=d.dt, hint="Step of rk4 / midpoint"))
        with self.target.gui.add_folder("Show"):
            add(Toggle("show_forces", "Reaction arrows", default=True))

    def plots(self) -> list[PlotSpec]:
        e = lambda c: 7 * self.setup.info.n_bodies  # noqa: E731 - the energy's column
        return [
            PlotSpec("energy", "energy change E − E0", (("E − E0 (J)", "#0f766e"),),
                     lambda t, c: (c[:, e(c)] - self.setup.energy0,), rescale=True),
            PlotSpec("drift", "energy drift (log10)", (("log10 |E − E0| (J)", "#b45309"),
                                                      ("round-off scale 16 ε |E0|", "#888888")),
                     lambda t, c: (log10_floor(c[:, e(c)] - self.setup.energy0),
                                   np.full_like(t, math.log10(16 * np.finfo(float).eps * abs(self.setup.energy0)))),
                     shown=lambda inputs: inputs.preset != CRANK),
            PlotSpec("check", "difference from the closed form (log10)", (("log10 difference", "#7c3aed"),),
                     lambda t, c: (log10_floor(c[:, -1]),), shown=lambda inputs: inputs.preset in (CRANK, TOP)),
            PlotSpec("residual", "constraint residual (log10)", (
                ("log10 max |C|", "#be185d"), ("bound 1e-8", "#888888"), ("Newton tol 1e-12", "#bbbbbb")),
                lambda t, c: (log10_floor(c[:, e(c) + 1]), np.full_like(t, -8.0), np.full_like(t, -12.0)))]

    def plot_title(self, spec: PlotSpec) -> str:
        if spec.name == "energy" and self.setup is not None:
            return f"energy change E − E0 (E0 = {significant(self.setup.energy0, 6)} J)"
        return spec.title

    def csv_header_for(self, inputs: Inputs) -> str:
        return "t (s)," + ",".join(self.setup.info.columns()) if self.setup is not None else "t (s)"

    def on_restart(self) -> None:
        self.max_residual = 0.0

    def _show(self, setup: _Chunk) -> None:
        """A new model: its parts, supports, labels and constants."""
        self.setup, info, preset = setup, setup.info, setup.model.preset
        position, angle = _PLACEMENT[preset]
        set_pose(self.model_frame, position=position, wxyz=(math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)))
        self.parts.show(setup.parts)
        for key, node in self.supports.items():
            node.visible = key == {TOP: "top", CRANK: "crank"}.get(preset, "chain")
        self.slider.visible, self.top.visible, self.ghost_pivot.visible = info.slider >= 0, info.top >= 0, info.top >= 0
        self.labels["top"].visible = self.labels["ghost"].visible = info.top >= 0
        self.labels["motor"].visible = info.motor
        self.resend_labels()
        self.info.content = "  \n".join(info.description())

    def draw(self, chunk: _Chunk, j: int) -> None:
        m, info, show = chunk.motion, chunk.info, bool(self.controls.value("show_forces"))
        if self.setup is None or chunk.model != self.setup.model:
            self._show(chunk)
        self.parts.move(chunk.placed, j)
        if info.slider >= 0:
            set_pose(self.slider, position=m.R[j, info.slider], wxyz=m.p[j, info.slider])
        if info.top >= 0:
            set_pose(self.top, position=m.R[j, info.top], wxyz=m.p[j, info.top])
            set_pose(self.ghost, position=m.closed_form_center[j], wxyz=m.closed_form[j])
        self.max_residual = max(self.max_residual, float(m.residual[j]))
        self.set_arrows(self.force_arrows, saturating_arrows(
            m.joint_points[j], m.joint_forces[j], half=info.weight, longest=chunk.arrow_max) if show else None)
        self.set_arrows(self.torque_arrow, saturating_arrows(  # the motor's torque: half the longest arrow at W r
            m.joint_points[j, :1], m.motor_torque[j : j + 1], half=0.5 * info.weight, longest=_TORQUE_ARROW_MAX)
            if show and info.motor else None)

    def readout_lines(self) -> list[str]:
        setup, model, chunk = self.setup, self.model, self.last_chunk
        if setup is None or chunk is None or chunk.model != model:
            return []
        info, m, j = setup.info, chunk.motion, self.sample_index(chunk)
        forces = np.linalg.norm(m.joint_forces[j], axis=1)  # N
        lines = [f"**E** = {significant(m.energy[j], 5)} J · " + (
            f"E − E0 = {one_digit(m.energy[j] - setup.energy0)} J" if info.conserved else "the motor does work"),
            f"**max |C|** = {one_digit(m.residual[j])} now, {one_digit(self.max_residual)} since t = 0 "
            f"(bound {RESIDUAL_BOUND:.0e})"]
        if m.difference is not None:
            lines.append(f"slider x − closed form: {one_digit(m.difference[j])} m" if info.slider >= 0 else
                         f"attitude difference to the closed form: {one_digit(m.difference[j])} rad")
        i = int(np.argmax(forces))
        step = f"rtol {model.rtol:.0e}" if model.rtol is not None else f"dt = 1/{round(1.0 / model.dt)} s"
        return lines + [f"largest joint force {significant(float(forces[i]), 3)} N ({info.joint_names[i]})",
                        f"{model.method}, {step}: {m.n_steps} steps, {m.n_rhs} right sides, "
                        f"{chunk.cpu_seconds:.2f} s CPU per simulated second"]
