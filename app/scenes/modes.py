"""Mode-shapes scene: the eigen solutions of constrained multibody systems, animated (Eqs. 8.110-8.131).

Five models of :mod:`rigidlab.core.models`, chosen in the *Model* dropdown: a chain of
``N`` pendulum links (uniform rods or point masses), a rod on a spherical
joint, a disk spinning on a flexible shaft (forward and backward whirl), the
heavy top sleeping or in steady precession, and two masses with
non-proportional damping. Each is linearized about its equilibrium or steady
motion with :func:`rigidlab.core.modal.linearize` and solved with
:meth:`rigidlab.core.modal.LinearModel.modes`; the panel shows the table of modes, the
eigenvalues in the complex plane and, for the rotor and the top, the modes
over the spin (a Campbell diagram, a root locus) from :func:`rigidlab.core.modal.sweep`.
The chosen mode moves as ``q0 + a Re(S e^(s t))``
(:meth:`rigidlab.core.modal.Modes.animate`, projected back onto the constraints by
Newton at every sample) beside a translucent ghost of the equilibrium.

The scene holds no physics and does no long work on the loop thread:

* :func:`_job` runs on the app's executor (a worker process): it builds the
  model's System from the frozen :class:`Params`, linearizes it, solves the
  eigenproblem (cached per parameter set in the worker), and animates the
  chosen mode over whole periods, 120 samples per period; it returns the
  poses of every drawn part at every sample (:class:`rigidlab.app.scenes._bodies.Placed`),
  the table, the CSV and JSON of the modes. The loop thread keeps the last
  results per parameter set and per mode, so nothing is solved again while
  the parameters are unchanged, and submits a job only when a control that
  matters changed and the scene is shown, one at a time (a slider being
  dragged gets the result of one value after another).
* The sweep runs :func:`rigidlab.core.modal.sweep` in a thread of this process that
  only waits: its values are computed on the same executor, one at a time
  (so a mode the user picks meanwhile is not queued behind the whole sweep);
  a progress bar follows it, a parameter change cancels it, and finished
  sweeps are kept per parameter set.
* Per frame the loop picks the sample of the display clock and sends the
  part poses (one batched mesh per kind of part, a spring buffer, the disk
  or the top); a new solution's table, plots and geometry are sent over
  consecutive frames, one each.
"""

from __future__ import annotations

import collections
import concurrent.futures
import dataclasses
import functools
import math
import time
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
import trimesh

from rigidlab.app.controls import Choice, Slider, Toggle
from rigidlab.app.nodes import set_pose, set_visible
from rigidlab.app.scenes._bodies import Parts, PartsView
from rigidlab.app.scenes._modal_view import (Clip, MAX_MODES, MODE_OPTIONS, ModalResults, ModeChoice, ProgressBar,
                                             SAMPLES_PER_CYCLE, SolutionArrays, SweepRun, advance, animate_group,
                                             campbell_chart, complex_plane_svg, mark_campbell, mark_root_locus,
                                             mode_groups, mode_label, mode_status, modes_table, remember, ro,
                                             root_locus_chart, send_mode_options, set_label, solution_arrays)
from rigidlab.app.scenes._plots import Legend
from rigidlab.app.scenes._svg import FONT, PRESENTER_FONT, Chart
from rigidlab.app.scenes.base import Scene
from rigidlab.core.gyroscope import RotorParams, sleeping_top_critical_spin
from rigidlab.core.modal import LinearModel, Modes, linearize
from rigidlab.core.models import disk_rotor, pendulum_chain, spherical_pendulum, steady_top, two_mass_oscillator
from rigidlab.core.rotations import euler_parameters_from_axis_angle, quaternion_product, rotate_vector

__all__ = [
    "CHAIN",
    "MODELS",
    "MODE_OPTIONS",
    "ModesScene",
    "Params",
    "ROTOR",
    "SAMPLES_PER_CYCLE",
    "SPHERICAL",
    "TOP",
    "TWO_MASS",
]

#: Model names (the *Model* dropdown).
CHAIN = "Pendulum chain"
SPHERICAL = "Rod on a spherical joint"
ROTOR = "Disk on a flexible shaft"
TOP = "Heavy top"
TWO_MASS = "Two masses, non-proportional damping"
MODELS = (CHAIN, SPHERICAL, ROTOR, TOP, TWO_MASS)
RODS, POINTS = "uniform rods", "point masses"
SLEEPING, SLOW, FAST = "sleeping (upright)", "slow precession", "fast precession"

# Models (SI units). The chain's links are 1 kg; the top is the gyroscope
# scene's (I = 1, I3 = 0.8 kg m^2, mgl = 2 N m) as a 1 kg body; the rotor is
# disk_rotor's (1 kg disk of radius 0.15 m, bearings 0.25 m either side);
# the first block of the two-mass oscillator is 1 kg on a 2000 N/m spring.
_GRAVITY = 9.81
_LINK_MASS = 1.0
_TOP_PARAMS = RotorParams(I=1.0, I3=0.8, mgl=2.0)
_DISK_RADIUS = 0.15
_HALF_SPAN = 0.25
_BLOCK_SIDE = 0.1  # two_mass_oscillator's blocks
_M1, _K1 = 1.0, 2000.0

# Drawing: every model in display coordinates (metres, global), drawn
# ``_DISPLAY[model]`` times its size from its anchor (the small ones enlarged
# so that all fit one view).
_DISPLAY = {  # anchor (global, m), scale
    CHAIN: ((0.0, 0.0, 2.7), 1.0),
    SPHERICAL: ((0.0, 0.0, 2.7), 1.0),
    ROTOR: ((0.0, 0.0, 1.35), 4.0),
    TOP: ((0.0, 0.0, 0.95), 3.0),
    TWO_MASS: ((-1.2, 0.0, 1.0), 2.0),
}
_CAPACITY = (10, 20, 2, 2)  # rods, balls, boxes, springs
_ROD_COLORS = np.array([(96, 108, 128), (178, 184, 196)] * 5, dtype=np.uint8)
_BALL_COLOR = (40, 40, 48)
_BOX_COLOR = (120, 124, 140)
_SPRING_COLOR = (150, 120, 60)
_BODY_COLOR = (205, 172, 110)  # disk, top
_GHOST_COLOR = (140, 170, 255)
_GHOST_OPACITY = 0.35
_SUPPORT_COLOR = (150, 150, 160)
_LABEL_SCALE = 1.3


# -- parameters ------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Params:
    """One model and its parameters: what a job needs (picklable, hashable).

    Only the parameters of the chosen model are kept (the others stay at
    their zero defaults), so moving a slider of another model changes
    nothing.

    Attributes
    ----------
    model : one of :data:`MODELS`
    n_links : chain links
    chain_kind : :data:`RODS` or :data:`POINTS`
    chain_length : total length of the chain (m)
    rod_length : rod on the spherical joint (m)
    spin : rotor spin Omega about +x (rad/s)
    stiffness : each bearing spring of the shaft (N/m)
    damping : each bearing damper (N s/m)
    top_motion : :data:`SLEEPING`, :data:`SLOW` or :data:`FAST`
    top_spin : the top's spin omega3 (rad/s)
    top_theta : nutation angle of the steady precession (rad)
    c1, c2 : dampers of the two-mass oscillator (N s/m)
    k2 : its second spring (N/m)
    m2 : its second mass (kg)
    """

    model: str
    n_links: int = 0
    chain_kind: str = ""
    chain_length: float = 0.0
    rod_length: float = 0.0
    spin: float = 0.0
    stiffness: float = 0.0
    damping: float = 0.0
    top_motion: str = ""
    top_spin: float = 0.0
    top_theta: float = 0.0
    c1: float = 0.0
    c2: float = 0.0
    k2: float = 0.0
    m2: float = 0.0

    @classmethod
    def from_values(cls, v: dict[str, Any]) -> Params:
        """The parameters of the model ``v["model"]`` from control values (see :data:`PARAMETERS`)."""
        model = v["model"]
        if model == CHAIN:
            return cls(CHAIN, n_links=int(v["n_links"]), chain_kind=v["chain_kind"],
                       chain_length=float(v["chain_length"]))
        if model == SPHERICAL:
            return cls(SPHERICAL, rod_length=float(v["rod_length"]))
        if model == ROTOR:
            return cls(ROTOR, spin=float(v["spin"]), stiffness=1e3 * float(v["stiffness_kn"]),
                       damping=float(v["shaft_damping"]))
        if model == TOP:
            motion = v["top_motion"]
            theta = 0.0 if motion == SLEEPING else math.radians(float(v["top_theta_deg"]))
            return cls(TOP, top_motion=motion, top_spin=float(v["top_spin"]), top_theta=theta)
        if model == TWO_MASS:
            return cls(TWO_MASS, c1=float(v["c1"]), c2=float(v["c2"]), k2=float(v["k2"]), m2=float(v["m2"]))
        raise ValueError(f"model: expected one of {list(MODELS)}, got {model!r}")

    def control_values(self) -> dict[str, Any]:
        """The control values that give these parameters (inverse of :meth:`from_values`)."""
        if self.model == CHAIN:
            return {"n_links": self.n_links, "chain_kind": self.chain_kind, "chain_length": self.chain_length}
        if self.model == SPHERICAL:
            return {"rod_length": self.rod_length}
        if self.model == ROTOR:
            return {"spin": self.spin, "stiffness_kn": self.stiffness / 1e3, "shaft_damping": self.damping}
        if self.model == TOP:
            out = {"top_motion": self.top_motion, "top_spin": self.top_spin}
            if self.top_motion != SLEEPING:
                out["top_theta_deg"] = math.degrees(self.top_theta)
            return out
        return {"c1": self.c1, "c2": self.c2, "k2": self.k2, "m2": self.m2}

    # -- the sweep ---------------------------------------------------------------
    @property
    def sweep_field(self) -> str | None:
        """The parameter a sweep varies: the rotor's and the top's spin (None: no sweep)."""
        return {ROTOR: "spin", TOP: "top_spin"}.get(self.model)

    def with_sweep_value(self, value: float) -> Params:
        return dataclasses.replace(self, **{self.sweep_field: float(value)})

    def sweep_key(self) -> Params | None:
        """These parameters without the swept one: a sweep depends on this only."""
        return None if self.sweep_field is None else self.with_sweep_value(0.0)

    def sweep_values(self) -> np.ndarray:
        """Spins of the sweep (rad/s): 0 to 1000 for the rotor; for the top from the lowest
        spin with a steady motion to 20."""
        if self.model == ROTOR:
            return np.linspace(0.0, 1000.0, 51)
        low = 1.02 * precession_min_spin(self.top_theta) if self.top_motion != SLEEPING else 0.0
        return np.linspace(low, 20.0, 41)


def precession_min_spin(theta: float) -> float:
    """Lowest spin omega3 (rad/s) with a steady precession at ``theta`` (rad) of the scene's top:
    ``I3^2 omega3^2 >= 4 I mgl cos(theta)`` (Eq. 8.23 has real rates)."""
    c = math.cos(theta)
    p = _TOP_PARAMS
    return 2.0 * math.sqrt(p.I * p.mgl * c) / p.I3 if c > 0 else 0.0


# -- the model, built in the worker ------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Built:
    """A System built from :class:`Params`, linearized, with what is drawn of it (worker only)."""

    system: Any
    frame_omega: np.ndarray  # (3,) global, rad/s
    modes: Modes
    n_dof: int
    parts: Parts  # display units
    special: str  # "", "disk" or "top": the body drawn by its own mesh
    special_body: int
    size: float  # m, the model's size: the amplitude unit of translations
    description: str  # Markdown


def _local(state: Any, body: Any, point: Any) -> np.ndarray:
    """``point`` (global, at the built configuration) in ``body``'s frame (global for the ground)."""
    point = np.asarray(point, dtype=float)
    if body.is_ground:
        return point
    return state.rotation_matrix(body).T @ (point - state.position(body))


def _build_system(params: Params) -> tuple[Any, np.ndarray, float, str]:
    """``(system, frame_omega, size, description)`` of ``params`` (raises ValueError for bad ones)."""
    W = np.zeros(3)
    if params.model == CHAIN:
        n, total = params.n_links, params.chain_length
        kind = "rod" if params.chain_kind == RODS else "point"
        system = pendulum_chain(n, total / n, _LINK_MASS, kind, gravity=_GRAVITY)
        what = "uniform rods" if kind == "rod" else "point masses on massless links"
        text = (f"**{n} {what}** of {total / n:.3g} m and {_LINK_MASS:g} kg on revolute joints about x, "
                "hanging at rest")
        return system, W, total, text
    if params.model == SPHERICAL:
        sp = spherical_pendulum(params.rod_length, _LINK_MASS, gravity=_GRAVITY)
        return sp.system, W, params.rod_length, (f"**A uniform rod** of {params.rod_length:.3g} m and "
                                                 f"{_LINK_MASS:g} kg hanging from a spherical joint")
    if params.model == ROTOR:
        dr = disk_rotor(params.spin, mass=1.0, radius=_DISK_RADIUS, half_span=_HALF_SPAN,
                        stiffness=params.stiffness, damping=params.damping, gravity=_GRAVITY)
        return dr.system, W, _DISK_RADIUS, (
            f"**A thin disk** (1 kg, r = {_DISK_RADIUS} m) spinning at Ω = {params.spin:.4g} rad/s about x on a "
            f"flexible shaft: bearings k = {params.stiffness:.4g} N/m, c = {params.damping:.3g} N s/m at "
            f"x = ±{_HALF_SPAN} m (drawn 4× enlarged)")
    if params.model == TOP:
        precession = "fast" if params.top_motion == FAST else "slow"
        st = steady_top(_TOP_PARAMS, spin=params.top_spin, theta=params.top_theta, precession=precession,
                        mass=1.0, gravity=_GRAVITY)
        if params.top_motion == SLEEPING:
            text = f"**The heavy top sleeping** upright at ω3 = {params.top_spin:.4g} rad/s"
        else:
            text = (f"**The heavy top in {params.top_motion}** at θ = {math.degrees(params.top_theta):.3g}°, "
                    f"ω3 = {params.top_spin:.4g} rad/s, dφ/dt = {st.phi_dot:.4g} rad/s, seen from the frame "
                    "turning with the precession")
        return st.system, np.array(st.frame_omega), st.length, (
            text + " (I = 1, I3 = 0.8 kg m², mgl = 2 N m; drawn 3× enlarged)")
    if params.model == TWO_MASS:
        tm = two_mass_oscillator(masses=(_M1, params.m2), stiffness=(_K1, params.k2),
                                 damping=(params.c1, params.c2), gravity=_GRAVITY)
        return tm.system, W, 0.5, (
            f"**Two blocks** on guides along x: m1 = {_M1:g} kg, m2 = {params.m2:.3g} kg, springs "
            f"k1 = {_K1:g}, k2 = {params.k2:.4g} N/m, dampers c1 = {params.c1:.3g}, c2 = {params.c2:.3g} N s/m "
            "(drawn 2× enlarged)")
    raise ValueError(f"model: expected one of {list(MODELS)}, got {params.model!r}")


def _parts(params: Params, system: Any) -> tuple[Parts, str, int]:
    """What is drawn of ``system`` (display units), and its specially drawn body.

    Points on a body are in its frame, scaled by the display scale; points on
    the ground in display coordinates (``anchor + scale * point``).
    """
    anchor, s = _DISPLAY[params.model]
    state = system.state
    bodies = system.bodies
    balls = []
    for joint in system.joints:
        if joint.kind in ("revolute", "spherical", "universal") and not joint.body_j.is_ground:
            body = joint.body_j
            balls.append((body.index, s * _local(state, body, joint.point), 0.05 if params.model == CHAIN else 0.045))
    rods, boxes, springs = [], [], []
    special, special_body = "", -1
    if params.model == CHAIN:
        L = params.chain_length / params.n_links
        for b in bodies:
            if params.chain_kind == RODS:
                rods.append((b.index, (0.0, 0.0, -0.5 * L), (0.0, 0.0, 0.5 * L), 0.03))
            else:
                rods.append((b.index, (0.0, 0.0, 0.0), (0.0, 0.0, L), 0.014))
                balls.append((b.index, (0.0, 0.0, 0.0), 0.085))
    elif params.model == SPHERICAL:
        L = params.rod_length
        rods.append((bodies[0].index, (0.0, 0.0, -0.5 * L), (0.0, 0.0, 0.5 * L), 0.035))
    elif params.model == ROTOR:
        a = s * _HALF_SPAN
        rods.append((bodies[0].index, (-a - 0.1, 0.0, 0.0), (a + 0.1, 0.0, 0.0), 0.025))
        special, special_body = "disk", bodies[0].index
    elif params.model == TOP:
        special, special_body = "top", bodies[0].index
    elif params.model == TWO_MASS:
        half = 0.5 * _BLOCK_SIDE * s
        boxes = [(b.index, (2 * half,) * 3) for b in bodies]

    def point(body: Any, p: Any) -> np.ndarray:
        local = s * _local(state, body, p)
        return np.add(anchor, local) if body.is_ground else local

    for spring in system.spring_dampers:
        ui, uj = point(spring.body_i, spring.point_i), point(spring.body_j, spring.point_j)
        if params.model == TWO_MASS:  # drawn between the blocks' faces
            half = 0.5 * _BLOCK_SIDE * s
            if not spring.body_i.is_ground:
                ui = ui + (half, 0.0, 0.0)
            uj = uj - (half, 0.0, 0.0)
        springs.append((spring.body_i.index, ui, spring.body_j.index, uj))
    parts = Parts.build(rods=rods, balls=balls, boxes=boxes, springs=springs,
                        spring_width=0.06 if params.model == TWO_MASS else 0.02)
    return parts, special, special_body


@functools.lru_cache(maxsize=8)
def _built(params: Params) -> _Built:
    """The linearized model of ``params`` (cached: once per parameter set in each worker)."""
    system, W, size, text = _build_system(params)
    lin = linearize(system, frame_omega=W)
    modes = lin.modes()
    parts, special, special_body = _parts(params, system)
    return _Built(system, W, modes, int(lin.n_dof), parts, special, special_body, size, text)


# -- results ---------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Solution(SolutionArrays):
    """The eigen solution of one parameter set, as the panel shows it (see
    :class:`rigidlab.app.scenes._modal_view.SolutionArrays`; ``key`` the :class:`Params`, ``groups`` the
    non-rigid modes; display units and coordinates).

    Attributes
    ----------
    description : the model in a sentence (Markdown)
    special, special_body : the body drawn by its own mesh ("disk", "top" or "")
    """

    description: str
    special: str
    special_body: int


def _display(params: Params, R: np.ndarray, P: np.ndarray, t: np.ndarray,
             W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body poses (m, n, 3), (m, n, 4) seen from the observer frame turning at ``W``, in display coordinates."""
    if np.any(W):
        w = float(np.linalg.norm(W))
        turn = np.array([euler_parameters_from_axis_angle(W / w, -w * ti) for ti in t])  # (m, 4)
        R = rotate_vector(turn[:, None, :], R)
        P = quaternion_product(turn[:, None, :], P)
    anchor, s = _DISPLAY[params.model]
    return np.asarray(anchor) + s * R, P


def _solution(params: Params, built: _Built) -> Solution:
    m = built.modes
    n = m.embedding.n_bodies
    R0 = m.embedding.q0[: 3 * n].reshape(1, n, 3)
    P0 = m.embedding.q0[3 * n :].reshape(1, n, 4)
    R, P = _display(params, R0, P0, np.zeros(1), built.frame_omega)
    doc = {"format": "rigidlab modes 1", "model": params.model,
           "parameters": {k: v for k, v in dataclasses.asdict(params).items() if v not in (0, 0.0, "")}}
    return Solution(**solution_arrays(params, m, mode_groups(m), built.n_dof, built.parts, R, P, doc),
                    description=built.description, special=built.special, special_body=built.special_body)


def _clip(params: Params, built: _Built, group: tuple[int, ...], mode: int, fraction: float) -> Clip:
    """Mode ``group`` animated by :meth:`rigidlab.core.modal.Modes.animate` (runs in the worker;
    :func:`rigidlab.app.scenes._modal_view.animate_group`)."""
    a = animate_group(built.modes, built.system, group, mode, fraction, built.size)
    R, P = _display(params, a.positions, a.orientations, a.t, built.frame_omega)
    return Clip.of(params, mode, fraction, a, R, P, built.parts)


@dataclasses.dataclass(frozen=True)
class _Result:
    solution: Solution
    clip: Clip
    seconds: float  # CPU time of the job (s)


def _job(params: Params, mode: int, fraction: float) -> _Result:
    """Solve ``params`` (cached in the worker) and animate its mode ``mode`` (1-based; clamped)."""
    cpu0 = time.thread_time()
    built = _built(params)
    solution = _solution(params, built)
    if not solution.groups:
        raise ValueError(f"{params.model}: no mode to animate (every mode is a rigid-body mode)")
    mode = min(max(int(mode), 1), min(len(solution.groups), MAX_MODES))
    clip = _clip(params, built, solution.groups[mode - 1], mode, fraction)
    return _Result(solution, clip, time.thread_time() - cpu0)


# -- sweeps ---------------------------------------------------------------------------
def _sweep_model(key: Params, value: float) -> LinearModel:
    """The linear model of ``key`` at the swept value (a sweep's ``build``; module level, picklable)."""
    params = key.with_sweep_value(value)
    system, W, _, _ = _build_system(params)
    return linearize(system, frame_omega=W)


def _boundaries(result: Any) -> np.ndarray:
    return result.boundaries()


@dataclasses.dataclass(frozen=True)
class SweepOutcome:
    """A finished sweep (read-only arrays).

    Attributes
    ----------
    key : Params without the swept value
    values : (v,) spins (rad/s)
    eigenvalues : (v, k) tracked eigenvalues
    rigid : (v, k) bool
    boundaries : spins where a mode crosses Re s = 0 (root finding)
    csv : :meth:`rigidlab.core.modal.SweepResult.to_csv`
    seconds : wall time of the sweep (s)
    charts : ``{font: (chart, caption)}``, the chart drawn once per font size
        (normal and presenter view) off the loop thread
    """

    key: Params
    values: np.ndarray
    eigenvalues: np.ndarray
    rigid: np.ndarray
    boundaries: np.ndarray
    csv: str
    seconds: float
    charts: dict = dataclasses.field(default_factory=dict, compare=False, repr=False)

    def chart(self, font: float) -> tuple[Chart, str]:
        if font not in self.charts:
            self.charts[font] = _sweep_chart(self, font=font)
        return self.charts[font]


def _sweep_run(key: Params, executor: concurrent.futures.Executor) -> SweepRun:
    """The sweep of ``key`` over its spins in the background (see the module docstring); its outcome a
    :class:`SweepOutcome`, with the top's stability boundaries found by Brent's method in a worker too."""
    return SweepRun(key, functools.partial(_sweep_model, key), key.sweep_values(), executor, _sweep_outcome,
                    name="rigidlab-modes-sweep")


def _sweep_outcome(run: SweepRun, result: Any, executor: concurrent.futures.Executor) -> SweepOutcome:
    key = run.key
    boundaries = np.zeros(0)
    if key.model == TOP:  # Brent's method on build, in a worker too
        boundaries = np.asarray(run.wait(executor.submit(_boundaries, result)), dtype=float)
    outcome = SweepOutcome(key, ro(result.values), ro(result.eigenvalues, complex), ro(result.rigid, bool),
                           ro(boundaries), result.to_csv(), run.elapsed())
    for font in (FONT, PRESENTER_FONT):  # drawn here, not in a frame of the loop
        outcome.chart(font)
    return outcome


def _sweep_chart(outcome: SweepOutcome, *, font: float) -> tuple[Chart, str]:
    """The static part of the sweep's chart: a Campbell diagram (rotor) or root locus (top)."""
    v, ev, rigid = outcome.values, outcome.eigenvalues, outcome.rigid
    if outcome.key.model == ROTOR:
        chart = campbell_chart(v, ev, rigid, "spin Ω (rad/s)", spin_line=True, font=font)
        title = (f"Campbell diagram: {v.size} spins from 0 to {v[-1]:.0f} rad/s; dashed: the spin frequency "
                 "(it meets a branch at a critical speed)")
        return chart, title
    chart = root_locus_chart(ev, rigid, font=font)
    title = (f"Root locus: eigenvalues for ω3 from {v[0]:.3g} to {v[-1]:.3g} rad/s (small rings: "
             f"ω3 = {v[0]:.3g})")
    if outcome.boundaries.size:
        title += "; stability boundary at ω3 = " + ", ".join(f"{b:.6g}" for b in outcome.boundaries) + " rad/s"
        if outcome.key.top_motion == SLEEPING:
            title += f" (closed form 2√(mgl I)/I3 = {sleeping_top_critical_spin(_TOP_PARAMS):.6g})"
    return chart, title


def sweep_svg(outcome: SweepOutcome, solution: Solution | None, *, font: float = FONT) -> tuple[str, str]:
    """``(svg, caption)`` of the sweep with the current parameter (``solution``) marked in purple."""
    chart, caption = outcome.chart(font)
    if solution is None or solution.key.sweep_key() != outcome.key:
        return chart.svg(), caption
    if outcome.key.model == ROTOR:
        chart = mark_campbell(chart, getattr(solution.key, solution.key.sweep_field), solution)
    else:
        chart = mark_root_locus(chart, solution)
    return chart.svg(), caption + "; purple: the current spin"


# -- controls ------------------------------------------------------------------------------
_DEFAULTS: dict[str, Any] = {
    "model": CHAIN, "n_links": 3, "chain_kind": RODS, "chain_length": 2.0, "rod_length": 1.5, "spin": 300.0,
    "stiffness_kn": 20.0, "shaft_damping": 0.0, "top_motion": SLEEPING, "top_spin": 6.0, "top_theta_deg": 30.0,
    "c1": 4.0, "c2": 0.5, "k2": 1000.0, "m2": 1.0, "mode": "1", "amplitude": 0.3, "cycle_seconds": 2.0,
    "animate": True, "show_ghost": True,
}

#: The model's controls, in panel order, with the models that show them.
PARAMETERS: tuple[tuple[Any, tuple[str, ...]], ...] = (
    (Slider("n_links", "Links N", min=1, max=10, step=1, integer=True, default=_DEFAULTS["n_links"],
            hint="Links of the chain"), (CHAIN,)),
    (Choice("chain_kind", "Links", options=(RODS, POINTS), default=_DEFAULTS["chain_kind"],
            hint="Uniform slender rods, or a point mass at the end of each massless link"), (CHAIN,)),
    (Slider("chain_length", "Chain length (m)", min=0.5, max=2.5, step=0.05, default=_DEFAULTS["chain_length"],
            hint="Total length; every link is this over N, 1 kg"), (CHAIN,)),
    (Slider("rod_length", "Rod length (m)", min=0.2, max=2.5, step=0.05, default=_DEFAULTS["rod_length"],
            hint="Uniform 1 kg rod hanging from a spherical joint"), (SPHERICAL,)),
    (Slider("spin", "Spin Ω (rad/s)", min=0.0, max=1000.0, step=1.0, default=_DEFAULTS["spin"],
            hint="Spin of the disk about the shaft (x)"), (ROTOR,)),
    (Slider("stiffness_kn", "Bearing k (kN/m)", min=5.0, max=50.0, step=0.5, default=_DEFAULTS["stiffness_kn"],
            hint="Stiffness of each of the two bearing springs"), (ROTOR,)),
    (Slider("shaft_damping", "Bearing c (N s/m)", min=0.0, max=20.0, step=0.1, default=_DEFAULTS["shaft_damping"],
            hint="Damping of each bearing"), (ROTOR,)),
    (Choice("top_motion", "Motion", options=(SLEEPING, SLOW, FAST), default=_DEFAULTS["top_motion"],
            hint="Upright spinning, or a steady precession at the slow or fast rate of Eq. 8.23"), (TOP,)),
    (Slider("top_spin", "Spin ω3 (rad/s)", min=0.0, max=20.0, step=0.05, default=_DEFAULTS["top_spin"],
            hint="ω3 = dψ/dt + dφ/dt cos θ"), (TOP,)),
    (Slider("top_theta_deg", "Nutation θ (deg)", min=5.0, max=80.0, step=0.5, default=_DEFAULTS["top_theta_deg"],
            hint="Tilt of the steadily precessing top"), (TOP,)),
    (Slider("c1", "Damper c1 (N s/m)", min=0.0, max=20.0, step=0.1, default=_DEFAULTS["c1"],
            hint="Between the wall and block 1"), (TWO_MASS,)),
    (Slider("c2", "Damper c2 (N s/m)", min=0.0, max=20.0, step=0.1, default=_DEFAULTS["c2"],
            hint="Between the blocks"), (TWO_MASS,)),
    (Slider("k2", "Spring k2 (N/m)", min=100.0, max=4000.0, step=10.0, default=_DEFAULTS["k2"],
            hint="Between the blocks (k1 = 2000 N/m to the wall)"), (TWO_MASS,)),
    (Slider("m2", "Mass m2 (kg)", min=0.2, max=5.0, step=0.05, default=_DEFAULTS["m2"],
            hint="Second block (m1 = 1 kg)"), (TWO_MASS,)),
)
_KEPT = 24  # solutions and clips
_SWEEPS_KEPT = 12


# -- meshes ------------------------------------------------------------------------------
def _disk_mesh() -> trimesh.Trimesh:
    """The rotor's disk in display units: axis along its body x."""
    _, s = _DISPLAY[ROTOR]
    disk = trimesh.creation.cylinder(radius=s * _DISK_RADIUS, height=s * 0.025, sections=64)
    hub = trimesh.creation.cylinder(radius=s * 0.03, height=s * 0.06, sections=24)
    mesh = trimesh.util.concatenate([disk, hub])
    mesh.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    return mesh


def _top_mesh() -> trimesh.Trimesh:
    """The top in display units: origin at the centre of mass, axis along body z, O at z = -l."""
    _, s = _DISPLAY[TOP]
    length = _TOP_PARAMS.mgl / (1.0 * _GRAVITY)
    disc = trimesh.creation.cylinder(radius=s * 0.16, height=s * 0.035, sections=48)
    axle = trimesh.creation.cylinder(radius=s * 0.008, sections=16,
                                     segment=np.array([[0.0, 0.0, -s * length], [0.0, 0.0, s * 0.2]]))
    knob = trimesh.creation.icosphere(subdivisions=2, radius=s * 0.015).apply_translation([0.0, 0.0, s * 0.2])
    return trimesh.util.concatenate([disc, axle, knob])


def _supports() -> dict[str, trimesh.Trimesh]:
    """Static parts of each model in display coordinates (global)."""
    out = {}
    for model in (CHAIN, SPHERICAL):
        anchor, _ = _DISPLAY[model]
        out[model] = trimesh.creation.box(extents=(0.5, 0.5, 0.06)).apply_translation(np.add(anchor, (0, 0, 0.08)))
    anchor, s = _DISPLAY[ROTOR]
    parts = []
    for x in (-s * _HALF_SPAN, s * _HALF_SPAN):
        ring = trimesh.creation.torus(0.07, 0.018, major_sections=32, minor_sections=10)
        ring.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
        parts.append(ring.apply_translation(np.add(anchor, (x, 0.0, 0.0))))
        height = anchor[2] - 0.09
        parts.append(trimesh.creation.box(extents=(0.08, 0.12, height)).apply_translation((x, 0.0, height / 2)))
    out[ROTOR] = trimesh.util.concatenate(parts)
    anchor, s = _DISPLAY[TOP]
    out[TOP] = trimesh.util.concatenate([
        trimesh.creation.cylinder(radius=0.035, segment=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, anchor[2] - 0.04]]),
                                  sections=16),
        trimesh.creation.cylinder(radius=0.3, height=0.05, sections=32).apply_translation((0.0, 0.0, 0.025)),
    ])
    anchor, s = _DISPLAY[TWO_MASS]
    half = 0.5 * _BLOCK_SIDE * s
    out[TWO_MASS] = trimesh.util.concatenate([
        trimesh.creation.box(extents=(0.04, 0.4, 0.5)).apply_translation(np.add(anchor, (-0.02, 0.0, 0.1))),
        trimesh.creation.box(extents=(2.9, 0.3, 0.03)).apply_translation(np.add(anchor, (1.45, 0.0, -half - 0.015))),
        trimesh.creation.box(extents=(0.1, 0.16, anchor[2] - half - 0.03)).apply_translation(
            (anchor[0] + 1.45, 0.0, (anchor[2] - half - 0.03) / 2)),
    ])
    return out


@dataclasses.dataclass(repr=False)
class _Gui:
    status: Any  # Readout: the selected mode
    info: Any  # Readout: the model
    table: Any  # Readout: the modes
    plane: Any  # HTML: eigenvalues in the complex plane
    sweep_folder: Any
    progress: Any  # progress bar of the sweep
    sweep_caption: Any  # Readout
    sweep_plot: Any  # HTML
    legend: Legend


class ModesScene(Scene):
    """Mode shapes of constrained systems: table, complex plane, Campbell diagram / root locus, animation."""

    name: ClassVar[str] = "modes"
    title: ClassVar[str] = "Mode shapes"
    order: ClassVar[int] = 60
    help: ClassVar[str] = (
        "A System linearized about its equilibrium or steady motion and its eigen solution "
        "(`rigidlab.core.modal`):\n\n"
        "- **Linearization** (Eqs. 8.110-8.112): perturbations z = (dR, dθ) of every body, "
        "embedded in the degrees of freedom by an orthonormal null space N of the constraint "
        "Jacobian (z = N u), giving M ü + (C + G) u̇ + K u = 0. K holds the geometric stiffness "
        "of the constraint forces (without it a pendulum in absolute coordinates has none); C + G "
        "keeps the skew gyroscopic part, which splits the rotor's whirl and keeps a fast top up.\n"
        "- **Eigenproblem**: without damping or spin K φ = ω² M φ (Eqs. 8.113-8.116), otherwise "
        "the state-space problem of [u, u̇] (Eqs. 8.117-8.124). The **table** gives per mode the "
        "damped frequency f = |Im s|/2π, ω_n = |s| (Eq. 8.130), ξ = −Re s/|s| (Eq. 8.131), s "
        "and its stability (Re s < 0 damped, = 0 neutral, > 0 unstable; a decaying s whose mirror −s̄ "
        "grows belongs to an unstable equilibrium); rigid-body (zero) "
        "eigenvalues are listed below it.\n"
        "- **Animation**: the chosen mode as q0 + a Re(S e^(st)) (Eqs. 8.125-8.129), every sample "
        "projected back onto the constraints by Newton, so the joints stay closed at any "
        "amplitude; whole periods at 120 samples each, slowed or sped up to the chosen seconds "
        "per cycle (a damped or growing mode over several periods, so its envelope shows). a is the "
        "largest displacement: the amplitude times the model's size (m) for a translation, in rad "
        "for a rotation. A mode that does not oscillate (real s) is shown as its shape swinging. "
        "The translucent **ghost** is the equilibrium (the top in precession is seen from the "
        "frame turning with it).\n"
        "- **Complex plane**: every eigenvalue (teal damped, blue neutral, orange unstable, hollow "
        "grey rigid), the chosen mode ringed, the unstable half shaded.\n"
        "- **Sweep** (rotor, top): the modes over the spin, tracked by shape correlation "
        "(`rigidlab.core.modal.sweep`, in the background): the rotor's Campbell diagram with its forward "
        "and backward whirl, the top's root locus with the stability boundary found by root "
        "finding. *Download* gives the modes (CSV, JSON) and the sweep (CSV)."
    )
    camera_position: ClassVar[tuple[float, float, float]] = (3.6, -2.4, 2.55)
    camera_look_at: ClassVar[tuple[float, float, float]] = (0.35, 1.05, 1.35)

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        # Owned by update() (the session loop thread).
        self.params: Params | None = None  # wanted
        self.solution: Solution | None = None  # shown
        self.clip: Clip | None = None  # shown
        self.sweep: SweepOutcome | None = None  # shown
        self._framing: tuple[str, int] | None = None  # (model, mode) the cameras were aimed at
        self.sim_time = 0.0  # display seconds since the clip was shown
        self.solves = 0  # jobs finished
        self.jobs_submitted = 0
        self.sweeps_cancelled = 0
        self.sweeps_started = 0
        self._results = ModalResults(_KEPT)
        self._sweeps: collections.OrderedDict[Params, SweepOutcome] = collections.OrderedDict()
        self._run: SweepRun | None = None
        self._sweep_errors: set[Params] = set()
        self._staged: collections.deque[Callable[[], None]] = collections.deque()
        self._phase = 0.0
        self._drawn: tuple[int, int] | None = None
        self._solve_seconds = 0.0
        self._collected = False  # a result was shown by _collect in this frame
        self._staging = False  # a panel update is being sent
        self.gui: _Gui | None = None

    # -- build -----------------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        self.add_ground_grid(width=8.0, height=8.0, position=(0.0, 0.0, 0.0), cell_size=0.25, section_size=1.0)
        self.supports = {
            model: scene.add_mesh_simple(f"{root}/support_{i}", mesh.vertices.astype(np.float32),
                                         mesh.faces.astype(np.uint32), color=_SUPPORT_COLOR, visible=False)
            for i, (model, mesh) in enumerate(_supports().items())
        }
        self.live = PartsView(scene, f"{root}/live", capacity=_CAPACITY, rod_colors=_ROD_COLORS,
                              ball_color=_BALL_COLOR, box_color=_BOX_COLOR, spring_color=_SPRING_COLOR)
        self.ghost = PartsView(scene, f"{root}/ghost", capacity=_CAPACITY, rod_colors=_GHOST_COLOR,
                               ball_color=_GHOST_COLOR, box_color=_GHOST_COLOR, spring_color=_GHOST_COLOR,
                               opacity=_GHOST_OPACITY, spring_thickness=1.5)
        disk, top = _disk_mesh(), _top_mesh()
        self.special: dict[str, Any] = {}
        self.special_ghost: dict[str, Any] = {}
        for key, mesh in (("disk", disk), ("top", top)):
            self.special[key] = scene.add_frame(f"{root}/live/{key}", show_axes=False, visible=False)
            scene.add_mesh_simple(f"{root}/live/{key}/mesh", mesh.vertices.astype(np.float32),
                                  mesh.faces.astype(np.uint32), color=_BODY_COLOR)
            self.special_ghost[key] = scene.add_frame(f"{root}/ghost/{key}", show_axes=False, visible=False)
            scene.add_mesh_simple(f"{root}/ghost/{key}/mesh", mesh.vertices.astype(np.float32),
                                  mesh.faces.astype(np.uint32), color=_GHOST_COLOR, opacity=_GHOST_OPACITY,
                                  cast_shadow=False)
        self.mode_label = self.add_label(f"{root}/mode_label", "", position=(0.0, 0.0, 3.2),
                                         anchor="bottom-center", scale=_LABEL_SCALE)
        gui = self.target.gui
        with self.make_folder():
            legend = Legend(gui, (
                (_ROD_COLORS[0], "bodies in the mode's motion (rods, blocks, disk, top)"),
                (_GHOST_COLOR, "equilibrium / steady motion (translucent ghost)"),
                (_SPRING_COLOR, "springs"),
                ((15, 118, 110), "eigenvalue: damped (Re s < 0)"),
                ((29, 78, 216), "neutral (Re s = 0)"),
                ((194, 65, 12), "unstable (Re s > 0)"),
                ((124, 58, 237), "the chosen mode"),
            ), "Colours:", presenter=self.presenter)
            status = self.add_readout("Solving…")
            self.controls.add(Choice("model", "Model", options=MODELS, default=_DEFAULTS["model"],
                                     hint="The system whose modes are shown"))
            with gui.add_folder("Parameters"):
                for spec, _ in PARAMETERS:
                    self.controls.add(spec)
            with gui.add_folder("Mode"):
                self.controls.add(ModeChoice("mode", "Mode", options=MODE_OPTIONS, default=_DEFAULTS["mode"],
                                             hint="The mode animated: a row of the table (number · frequency · "
                                                  "damping ratio ξ · stability)"))
                self.controls.add(Slider("amplitude", "Amplitude", min=0.02, max=1.0, step=0.01,
                                         default=_DEFAULTS["amplitude"],
                                         hint="Largest displacement: times the model's size (m) for a "
                                              "translation, rad for a rotation"))
                self.controls.add(Slider("cycle_seconds", "Seconds per cycle", min=0.5, max=6.0, step=0.1,
                                         default=_DEFAULTS["cycle_seconds"],
                                         hint="One period of the mode takes this long on screen"))
                self.controls.add(Toggle("animate", "Animate", default=_DEFAULTS["animate"]))
                self.controls.add(Toggle("show_ghost", "Equilibrium ghost", default=_DEFAULTS["show_ghost"]))
            info = self.add_readout("")
            with self.plot_area():  # the plots panel: the table, the complex plane and the sweep beside the 3-D view
                table = self.add_readout("")
                with gui.add_folder("Complex plane"):
                    plane = gui.add_html("")
                with gui.add_folder("Sweep over the spin") as sweep_folder:
                    progress = gui.add_progress_bar(0.0, animated=True, visible=False)
                    sweep_caption = self.add_readout("")
                    sweep_plot = gui.add_html("")
            with gui.add_folder("Export"):
                self.add_download("download_csv", "Modes (CSV)", "modes.csv", self.csv_bytes,
                                  hint="One row per eigenvalue: s, ω_n, f, ξ, flags and the real shape")
                self.add_download("download_json", "Modes (JSON)", "modes.json", self.json_bytes,
                                  hint="The model's parameters and the modes, with the complex shapes")
                self.add_download("download_sweep", "Sweep (CSV)", "sweep.csv", self.sweep_bytes,
                                  hint="The tracked eigenvalues at every spin of the sweep")
        self.gui = _Gui(status, info, table, plane, sweep_folder, progress, sweep_caption, sweep_plot, legend)
        self._progress = ProgressBar(progress)
        self._show_controls(_DEFAULTS["model"], _DEFAULTS["top_motion"])

    def on_presenter(self, on: bool) -> None:
        if self.gui is None:
            return
        self.gui.legend.set_presenter(on)
        self._stage(self._send_plane)
        self._stage(self._send_sweep)

    @property
    def font(self) -> float:
        return PRESENTER_FONT if self.presenter else FONT

    # -- life cycle --------------------------------------------------------------------
    def set_active(self, active: bool) -> None:
        super().set_active(active)
        if not active:
            self._cancel_sweep()  # nothing runs for a scene nobody looks at

    def close(self) -> None:
        self._cancel_sweep()
        self._results.cancel()
        super().close()

    # -- requests (tests, notebooks) -----------------------------------------------------
    @property
    def busy(self) -> bool:
        """A job is queued or running."""
        return self._results.job is not None

    @property
    def panel_current(self) -> bool:
        """The panel shows what the scene shows (no update waiting for its frame)."""
        return not self._staged and not self._staging

    @property
    def sweeping(self) -> bool:
        return self._run is not None

    @property
    def sweep_progress(self) -> tuple[int, int]:
        """(done, total) of the running sweep, (0, 0) when none runs."""
        run = self._run
        return (run.done, run.total) if run is not None else (0, 0)

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            _build_system(Params.from_values(values))
        except ValueError as exc:
            return f"invalid parameters: {exc}"
        return None

    def wanted(self) -> tuple[Params, int, float]:
        values = self.controls.values()
        return Params.from_values(values), int(values["mode"]), float(values["amplitude"])

    # -- update ----------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        changed = self.controls.take_changes()
        if changed & {"model", "top_motion"} or self.params is None:
            values = self.controls.values()
            self._show_controls(values["model"], values["top_motion"])
        want = self.wanted()
        self.params = want[0]
        self._collected = False
        self._collect()
        shown = self._request(want) or self._collected
        self._tend_sweep()
        if self._staged and not shown:
            # one panel update per frame, none in a frame that shows a new mode
            self._staging = True
            try:
                self._staged.popleft()()
            finally:
                self._staging = False
        self._play(dt, changed)

    def _show_controls(self, model: str, motion: str) -> None:
        handles = self.controls.handles
        for spec, models in PARAMETERS:
            shown = model in models and not (spec.key == "top_theta_deg" and motion == SLEEPING)
            if handles[spec.key].visible != shown:
                handles[spec.key].visible = shown
        if self.gui is not None:
            has_sweep = model in (ROTOR, TOP)
            if self.gui.sweep_folder.visible != has_sweep:
                self.gui.sweep_folder.visible = has_sweep
            button = handles["download_sweep"]
            if button.visible != has_sweep:  # no sweep, no button (it offered a file it could not make)
                button.visible = has_sweep
            self._sync_sweep_button()

    def _sync_sweep_button(self) -> None:
        """"Sweep (CSV)" is enabled only while a sweep is shown (it is hidden for models without one)."""
        button = self.controls.handles.get("download_sweep")
        if button is not None and button.disabled != (self.sweep is None):
            button.disabled = self.sweep is None

    def _request(self, want: tuple[Params, int, float]) -> bool:
        """Show ``want`` from the caches, or submit the job that computes it.

        Returns whether a new solution or clip was shown in this frame.
        """
        want, shown = self._results.lookup(want)
        if shown is not None:
            return self._show(*shown)
        # one job at a time: while a slider is dragged, each job takes the value the slider has when the one
        # before is done (and that one is shown meanwhile, see _collect)
        if not self._results.submit(self.executor, want, _job, *want):
            return False
        self.jobs_submitted += 1
        if self.solution is None or self.solution.key != want[0]:
            self.gui.status.content = "Solving…"
        return False

    def _collect(self) -> None:
        taken = self._results.take()
        if taken is None:
            return
        want, result, exc = taken
        if exc is not None:
            self._refuse(want, exc)
            return
        self.solves += 1
        self._solve_seconds = result.seconds
        shown = self.clip
        if shown is None or (shown.key, shown.fraction) != (self.params, self.controls.value("amplitude")):
            # the controls moved on while this was computed (a slider being
            # dragged): show it until the result they ask for is in
            self._show(result.solution, result.clip)
            self._collected = True

    def _refuse(self, want: tuple[Params, int, float], exc: BaseException) -> None:
        """A job failed: a notice, and the controls go back to what is shown.

        A ValueError of the model (no steady precession at this spin) or of the
        animation (an amplitude the constraints cannot meet) is a refusal; any
        other error pauses the scene (it resumes at the next change).
        """
        if want[0] != self.params:
            return  # a stale job: the controls moved on
        shown = (self.solution, self.clip)
        if not isinstance(exc, ValueError) or shown[0] is None or shown[1] is None:
            raise exc
        solution, clip = shown
        if want[0] != solution.key:
            self.notify("Invalid parameters", f"{exc}. Keeping the previous values (the controls are set back).",
                        "warning")
            self.controls.set("model", solution.key.model)
            self.controls.set_many(solution.key.control_values())
            self._show_controls(solution.key.model, solution.key.top_motion or SLEEPING)
        else:
            self.notify("Animation refused", f"{exc}. Keeping the mode shown (the controls are set back).",
                        "warning")
        self.controls.set("mode", str(clip.mode))
        self.controls.set("amplitude", clip.fraction)

    # -- showing a solution and a clip -----------------------------------------------------
    def _show(self, solution: Solution, clip: Clip) -> bool:
        if solution is self.solution and clip is self.clip:
            return False
        new_model = self.solution is None or solution.parts is not self.solution.parts
        new_solution = solution is not self.solution
        count = min(len(solution.groups), MAX_MODES)
        if solution.key == self.params and int(self.controls.value("mode")) > count:
            self.controls.set("mode", str(count))  # a mode beyond this model's: the last one
        # The panel updates are staged before the new solution is assigned, so that a
        # reader on another thread never sees the new solution with ``panel_current``
        # true while the panel still shows the old one (they run in later frames).
        if new_model and self._send_ghost not in self._staged:
            self._staged.appendleft(self._send_ghost)  # the ghost in the next frame
        self._stage(self._send_status)
        self._stage(self._send_table)
        if new_solution:
            self._stage(self._send_info)
            self._stage(self._send_mode_options)
        self._stage(self._send_plane)
        if new_solution and solution.key.sweep_field is not None:
            self._stage(self._send_sweep)
        self.solution, self.clip = solution, clip
        framing = (solution.key.model, clip.mode)
        if framing != self._framing:  # a new model or mode: a camera that shows its motion
            self._framing = framing
            self.reframe()
        self._phase = 0.0
        self.sim_time = 0.0
        self._drawn = None
        with self.target.atomic():
            if new_model:
                self._apply_geometry(solution)
            self._draw(clip.still)
            self._label()
        return True

    def camera_view(self) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
        """The view of the mode shown: the default view turned to look across its motion (:func:`mode_camera`)."""
        clip = self.clip
        if clip is None:
            return super().camera_view()
        return mode_camera(clip.positions, self.camera_position, self.camera_look_at)

    def _stage(self, fn: Callable[[], None]) -> None:
        if fn not in self._staged:
            self._staged.append(fn)

    def _apply_geometry(self, solution: Solution) -> None:
        """A new set of parts: scales, supports and special meshes (in the frame's atomic group)."""
        self.live.show(solution.parts)
        for model, node in self.supports.items():
            set_visible(node, model == solution.key.model)
        for key in ("disk", "top"):
            shown = solution.special == key
            if self.special[key].visible != shown:
                self.special[key].visible = shown
        anchor, _ = _DISPLAY[solution.key.model]
        set_pose(self.mode_label, position=_label_position(solution.key.model, anchor))

    def _send_ghost(self) -> None:
        """The equilibrium ghost of the solution shown."""
        solution = self.solution
        if solution is None:
            return
        with self.target.atomic():
            self.ghost.show(solution.parts)
            self.ghost.move(solution.ghost, 0)
            show_ghost = bool(self.controls.value("show_ghost"))
            for key in ("disk", "top"):
                shown = solution.special == key
                self.special_ghost[key].visible = shown and show_ghost
                if shown:
                    b = solution.special_body
                    set_pose(self.special_ghost[key], position=solution.ghost_R[b], wxyz=solution.ghost_P[b])
            self.ghost.frame.visible = show_ghost

    def _draw(self, i: int) -> None:
        clip, solution = self.clip, self.solution
        assert clip is not None and solution is not None
        self.live.move(clip.placed, i)
        if solution.special:
            b = solution.special_body
            set_pose(self.special[solution.special], position=clip.positions[i, b], wxyz=clip.orientations[i, b])
        self._drawn = (id(clip), i)

    def _label(self) -> None:
        set_label(self.mode_label, mode_label(self.solution, self.clip))

    def _play(self, dt: float, changed: set[str]) -> None:
        clip = self.clip
        if clip is None:
            return
        if "show_ghost" in changed:
            show = bool(self.controls.value("show_ghost"))
            with self.target.atomic():
                self.ghost.frame.visible = show
                for key in ("disk", "top"):
                    self.special_ghost[key].visible = show and self.solution.special == key
        animate = bool(self.controls.value("animate"))
        self._phase, i = advance(clip, self._phase, dt, cycle=float(self.controls.value("cycle_seconds")),
                                 animate=animate)
        if animate:
            self.sim_time += min(dt, 0.1)
        if self._drawn != (id(clip), i):
            with self.target.atomic():
                self._draw(i)
        if "cycle_seconds" in changed or "animate" in changed:
            self._stage(self._send_status)

    # -- the panel -------------------------------------------------------------------------
    def _send_status(self) -> None:
        if self.clip is not None and self.solution is not None:
            self.gui.status.content = mode_status(self.solution, self.clip, float(self.controls.value("cycle_seconds")),
                                                  animate=bool(self.controls.value("animate")))

    def _send_table(self) -> None:
        if self.solution is not None and self.clip is not None:
            self.gui.table.content = modes_table(self.solution, self.clip.mode)

    def _send_info(self) -> None:
        solution = self.solution
        if solution is None:
            return
        method = ("symmetric K φ = ω² M φ (Eqs. 8.113-8.116)" if solution.method == "symmetric"
                  else "state-space A x = s x (Eqs. 8.117-8.124)")
        n = solution.n_bodies
        self.gui.info.content = (
            f"{solution.description}.  \n**{solution.n_dof} degrees of freedom** of {n} "
            f"bod{'y' if n == 1 else 'ies'} ({7 * n} coordinates R, p); eigenproblem: {method}; "
            f"solved in {self._solve_seconds * 1e3:.0f} ms CPU on the worker."
        )

    def _send_mode_options(self) -> None:
        if self.solution is not None:
            send_mode_options(self.controls, self.solution, current=self.solution.key == self.params)

    def _send_plane(self) -> None:
        if self.solution is not None and self.clip is not None:
            self.gui.plane.content = complex_plane_svg(self.solution, self.clip.mode, font=self.font)

    def _send_sweep(self) -> None:
        outcome = self.sweep
        if outcome is None or self.solution is None or self.solution.key.sweep_key() != outcome.key:
            return
        svg, caption = sweep_svg(outcome, self.solution, font=self.font)
        self.gui.sweep_plot.content = svg
        self.gui.sweep_caption.content = caption + f" ({outcome.seconds:.1f} s in the background)."

    # -- sweeps ---------------------------------------------------------------------------
    def _tend_sweep(self) -> None:
        """Start the sweep of the wanted parameters, follow its progress, take its result."""
        assert self.gui is not None and self.params is not None
        key = self.params.sweep_key()
        run = self._run
        if run is not None and run.key != key:
            self._cancel_sweep()
            run = None
        if run is not None and run.finished.is_set():
            self._run = None
            if run.outcome is not None:
                remember(self._sweeps, run.key, run.outcome, _SWEEPS_KEPT)
            elif run.error is not None:
                self._sweep_errors.add(run.key)
                self.notify("Sweep failed", f"{type(run.error).__name__}: {run.error}", "warning")
            run = None
        if key is None:
            self._progress.set(None)
            return
        outcome = self._sweeps.get(key)
        if outcome is not None:
            self._progress.set(None)
            if self.sweep is not outcome:
                self._stage(self._send_sweep)  # staged first: see _show
                self.sweep = outcome
                self._sync_sweep_button()
            return
        if run is None and key not in self._sweep_errors:
            run = self._run = _sweep_run(key, self.executor)
            self.sweeps_started += 1
            self.gui.sweep_caption.content = f"Computing {run.total} spins in the background…"
            self.gui.sweep_plot.content = ""
            self.sweep = None
            self._sync_sweep_button()
        if run is not None:
            self._progress.set(100.0 * run.done / max(run.total, 1))

    def _cancel_sweep(self) -> None:
        run = self._run
        if run is not None:
            run.cancel.set()
            self._run = None
            self.sweeps_cancelled += 1

    # -- export ----------------------------------------------------------------------------
    def _need_solution(self) -> Solution:
        if self.solution is None:
            raise ValueError("no modes computed yet")
        return self.solution

    def csv_bytes(self) -> bytes:
        """The modes shown, as CSV (:meth:`rigidlab.core.modal.Modes.to_csv`)."""
        return self._need_solution().csv.encode()

    def json_bytes(self) -> bytes:
        """The modes shown and the model's parameters, as JSON."""
        return self._need_solution().json.encode()

    def sweep_bytes(self) -> bytes:
        """The sweep shown, as CSV (:meth:`rigidlab.core.modal.SweepResult.to_csv`)."""
        if self.sweep is None:
            raise ValueError("no sweep for this model (the rotor and the top have one), or it is not done yet")
        return self.sweep.csv.encode()


def mode_camera(positions: Any, position: Any, look_at: Any) -> tuple[tuple[float, float, float],
                                                                        tuple[float, float, float]]:
    """A camera ``(position, look_at)`` that shows a mode's motion: the default view turned about the
    vertical through ``look_at`` until the camera looks perpendicular to the motion.

    The motion's principal directions are those of the bodies' displacements over the clip (SVD of
    ``positions`` minus their mean). A motion along one line (a pendulum's swing) is seen square on; a
    motion in a vertical plane is seen along the plane's normal. The distance and the elevation of the
    default view are kept. A motion that is vertical, in a horizontal plane, or that moves no body's centre
    (a spin) keeps the default view, which shows it already.

    Parameters
    ----------
    positions : (m, n, 3) body positions over the clip (display coordinates, metres)
    position, look_at : (3,) the default camera position and target (metres)
    """
    p = np.asarray(positions, dtype=float)
    default = tuple(float(v) for v in position), tuple(float(v) for v in look_at)
    x = (p - p.mean(axis=0)).reshape(-1, 3)
    if x.size == 0 or not np.all(np.isfinite(x)) or np.abs(x).max() < 1e-9:
        return default
    _, sv, vt = np.linalg.svd(x, full_matrices=False)
    up = np.array([0.0, 0.0, 1.0])
    if sv.size > 1 and sv[1] > 0.5 * sv[0]:
        along = np.cross(vt[2], up)  # the horizontal direction in the plane of the motion
    else:
        along = vt[0] * np.array([1.0, 1.0, 0.0])
    if np.linalg.norm(along) < 0.3:  # vertical motion, or a horizontal plane: the default view shows it
        return default
    along = along / np.linalg.norm(along)
    offset = np.asarray(position, dtype=float) - np.asarray(look_at, dtype=float)
    distance = float(np.linalg.norm(offset))
    horizontal = float(np.hypot(offset[0], offset[1]))
    if distance == 0.0 or horizontal == 0.0:
        return default
    elevation = math.asin(offset[2] / distance)
    side = np.array([-along[1], along[0]])  # horizontal, perpendicular to the motion
    if side @ offset[:2] < 0.0:
        side = -side  # the side the default camera is on
    new = np.asarray(look_at, dtype=float) + distance * np.array(
        [math.cos(elevation) * side[0], math.cos(elevation) * side[1], math.sin(elevation)])
    return tuple(float(v) for v in new), default[1]


def _label_position(model: str, anchor: tuple[float, float, float]) -> tuple[float, float, float]:
    """Where the mode's 3-D label goes: above the model."""
    x, y, z = anchor
    return {CHAIN: (x, y, z + 0.35), SPHERICAL: (x, y, z + 0.35), ROTOR: (x, y, z + 1.0),
            TOP: (x, y, z + 1.5), TWO_MASS: (x + 1.5, y, z + 0.8)}[model]
