"""Multibody benchmark: rigidlab's ``System.simulate`` against MuJoCo and Exudyn at equal accuracy.

Models (``rigidlab.core.models``, every engine builds the same bodies, masses,
inertias, joints, gravity and initial state from the rigidlab System):

``chain2`` ... ``chain20``
    :func:`rigidlab.core.models.pendulum_chain` of N uniform 1 m, 1 kg rods on
    revolute joints, released at rest from the straight chain tilted by
    0.5 rad. Reference: its reduced Lagrange equations in the joint angles
    (:func:`rigidlab.core.models.pendulum_chain_reduced`), DOP853 at rtol = atol =
    1e-13.
``slider_crank``
    :func:`rigidlab.core.models.slider_crank` (crank 0.1 m, rod 0.3 m, motor at
    2 pi rad/s). Reference: the closed-form kinematics (the motor
    prescribes the motion).

For every model and each target position error (1e-6 and 1e-9 m: the
largest distance of any body's centre of mass from the reference, over
T = 10 s with outputs at 60 Hz), each engine's accuracy knob is searched
for the cheapest setting at or just below the target, and that setting's
CPU time (``time.process_time``, best of up to three runs) is reported with
the error it reaches:

* rigidlab: ``System.simulate`` (DOP853, projection) with ``rtol`` on a
  grid of 10^(1/8) steps and ``atol = rtol / 100`` (m); also its largest
  constraint residual ``max |C|`` (column "constraint residual");
* MuJoCo (RK4 integrator, ``timestep`` = 1/(60 k) s): hinge joints (the
  chain in reduced coordinates); the slider-crank as crank and rod on
  hinges, the slider on a slide joint and a ``connect`` equality closing
  the loop, the crank driven by a ``joint`` equality to a 1e10 kg "clock"
  body sliding at the motor's speed (equality ``solref`` = (2 dt, 1),
  ``solimp`` = (0.9999, 0.9999, 0.001, 0.5, 2); ``max |C|`` is MuJoCo's
  equality violation). Positions are read after ``mj_kinematics`` (chains)
  or ``mj_forward`` (slider-crank, for its constraint rows) at every
  output: right after an RK4 ``mj_step``, mjData holds the positions of
  the last Runge-Kutta stage, not those of the step's end (read there,
  RK4 seemed to need dt 1/1740 s instead of 1/960 s for 1e-9 on the
  10-link chain);
* Exudyn, four paths, each searched on its own:
  - redundant coordinates (``CreateRigidBody`` with Euler parameters,
    ``CreateRevoluteJoint``; for the slider-crank a ``CreateGenericJoint``
    with an offset user function as the motor, spherical, universal and
    prismatic joints as in rigidlab), generalized-alpha (its solver for
    joints; spectral radius 0.9, modified Newton, Newton relative
    tolerance 1e-10) with step 1/(60 k) s, with its dense linear solver
    (``EXUdense``, the default) and with its sparse one
    (``linearSolver.solverType = EigenSparse``);
  - chains only: minimal coordinates (``mbs.CreateKinematicTree``, an
    ``ObjectKinematicTree`` of RevoluteX joints with the links' mass,
    centre and inertia, the same gravity and initial angles) with
    explicit RK44 at dt = 1/(60 k) s, and with DOPRI5 (error control,
    ``rtol = atol`` on the rigidlab grid; its adaptive steps do not end on
    the outputs, so the run stops at every output through
    ``MainSolverExplicit.SolveSteps``, about 20 % dearer than one
    ``SolveDynamic`` on the 10-link chain); centres of mass from the joint
    angles.

Each table row is its engine's cheapest path that reaches the target (the
column "path" names it); a second table lists every path tried.
A peer whose next run would cost more than ``PEER_CPU_CAP`` seconds is
reported as "not reached" with the best error it got. The ratio column is
the peer's CPU time over rigidlab's at the same target (> 1: rigidlab is
faster). Then the issue's targets for the 10-link chain: the CPU time of one
60 Hz frame (16.7 ms simulated, measured on 60-frame chunks from t = 3 s as
a scene computes ahead) at <= 1e-6 error, and the position residual over
T = 100 s.

Run from the project root::

    .venv/bin/python bench/multibody.py            # all models (~12 min on a loaded 2-core machine)
    .venv/bin/python bench/multibody.py --quick    # chain2 and chain5 only
    .venv/bin/python bench/multibody.py --models chain10 slider_crank

MuJoCo and Exudyn come with the ``bench`` extra (``pip install -e
'.[bench]'``); without them their rows are skipped with a note. BLAS runs
on one thread (``OPENBLAS_NUM_THREADS=1``). Writes
``bench/out/multibody.json`` (bench/out/ is git-ignored).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import datetime  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rigidlab.core.models import pendulum_chain, pendulum_chain_reduced, slider_crank  # noqa: E402

OUT = Path(__file__).resolve().parent / "out"
T_END = 10.0
FPS = 60
TARGETS = (1e-6, 1e-9)
CHAIN_TILT = 0.5
MODELS = ("chain2", "chain5", "chain10", "chain20", "slider_crank")
QUICK_MODELS = ("chain2", "chain5")
#: CPU seconds above which a peer's run is not tried (the target is then "not reached").
PEER_CPU_CAP = 30.0
INSTALL_HINT = "pip install -e '.[bench]'"
REFERENCE_RTOL = 1e-13
#: The rigidlab rtol grid: 10^(-j/8).
RTOL_STEPS_PER_DECADE = 8
FRAME_TARGET_MS = 2.0
RESIDUAL_TARGET = 1e-10
COLUMNS = ("model", "target", "engine", "path", "setting", "CPU (s)", "position error (m)", "constraint residual",
           "CPU / rigidlab")


def cpu_time(func):
    """(result, CPU seconds of this process) of one call."""
    t0 = time.process_time()
    result = func()
    return result, time.process_time() - t0


# ------------------------------------------------------------------ models and references
@dataclass(frozen=True)
class Case:
    """One benchmark model: the rigidlab model and its reference motion at the output times."""

    name: str
    label: str
    kind: str  # "chain" or "slider_crank"
    n_links: int
    t: np.ndarray  # (n_out,)
    reference: np.ndarray = field(repr=False)  # (n_out, n_bodies, 3) centres of mass
    reference_cpu: float = 0.0
    reference_note: str = ""
    reference_check: float = 0.0  # estimate of the reference's own error (m)

    def build(self):
        """A fresh rigidlab model at its initial state: the System, or the SliderCrank."""
        if self.kind == "chain":
            return pendulum_chain(self.n_links, tilt=CHAIN_TILT)
        return slider_crank()


def make_case(name: str, *, t_end: float = T_END) -> Case:
    """The model ``name`` (``chainN`` or ``slider_crank``) with its reference at 60 Hz over ``t_end``."""
    t = np.linspace(0.0, t_end, round(t_end * FPS) + 1)
    if name.startswith("chain") and name[5:].isdigit():
        n = int(name[5:])
        motion, cpu = cpu_time(lambda: pendulum_chain_reduced(n, t, tilt=CHAIN_TILT, rtol=REFERENCE_RTOL,
                                                              atol=REFERENCE_RTOL))
        looser = pendulum_chain_reduced(n, t, tilt=CHAIN_TILT, rtol=1e-11, atol=1e-11)
        # DOP853 is 8th order: the 1e-13 run is ~100 times closer than the 1e-11 one
        check = float(np.linalg.norm(looser.centres - motion.centres, axis=-1).max())
        return Case(name, f"chain, {n} links", "chain", n, t, motion.centres, cpu,
                    f"reduced angles, DOP853 rtol {REFERENCE_RTOL:g}", check)
    if name == "slider_crank":
        model = slider_crank()
        ref, cpu = cpu_time(lambda: slider_crank_reference(model, t))
        return Case(name, "slider-crank", "slider_crank", 0, t, ref, cpu, "closed-form kinematics", 0.0)
    raise ValueError(f"model: expected one of {MODELS} (or chainN), got {name!r}")


def slider_crank_reference(model, t: np.ndarray) -> np.ndarray:
    """(n, 3, 3) centres of crank, rod and slider from the closed-form kinematics (motor phi = phi0 + speed t)."""
    phi = model.phi0 + model.speed * t
    r = model.crank_length
    zero = np.zeros_like(phi)
    pin = np.stack([r * np.cos(phi), zero, r * np.sin(phi)], axis=1)
    slider = np.stack([model.slider_position(phi), zero, zero], axis=1)
    return np.stack([0.5 * pin, 0.5 * (pin + slider), slider], axis=1)


def position_error(centres: np.ndarray, case: Case) -> float:
    """Largest distance of any body's centre from the reference over the run (m)."""
    return float(np.linalg.norm(centres - case.reference, axis=-1).max())


# ------------------------------------------------------------------ engines
@dataclass
class Run:
    """One run of an engine at one setting."""

    effort: int
    error: float
    cpu: float
    residual: float | None
    cpus: list = field(default_factory=list)


class Engine:
    """An engine with one accuracy knob, indexed by an integer effort (larger: finer, costlier)."""

    name = ""  # unique: the key of the memo and the log
    peer = ""  # the engine a row reports (its cheapest path is kept)
    path = ""  # the formulation and integrator of this path
    grid = "dt"  # "rtol": a tolerance grid (one step is close); "dt": fixed steps (20 % is close)
    order = 1.0  # error ~ knob^order, the first guess of the search
    effort_range = (1, 1)
    cost_cap: float | None = None

    def missing(self) -> str | None:
        """None when the engine can run, else why not."""
        return None

    def applies(self, case: "Case") -> bool:
        """Whether this path can run ``case``."""
        return True

    def path_for(self, case: "Case") -> str:
        return self.path

    def knob(self, effort: int) -> float:
        raise NotImplementedError

    def effort_for(self, knob: float) -> int:
        """The smallest effort whose knob is at most ``knob``."""
        raise NotImplementedError

    def start(self, target: float) -> int:
        raise NotImplementedError

    def setting(self, effort: int) -> str:
        raise NotImplementedError

    def cost_of(self, effort: int, runs: dict[int, Run]) -> float:
        """Predicted CPU seconds at ``effort`` from the runs so far."""
        return 0.0

    def run(self, case: Case, effort: int) -> tuple[np.ndarray, float | None, float]:
        """(centres (n_out, n_bodies, 3), max |C| or None, CPU seconds) of one run."""
        raise NotImplementedError


class Rigidlab(Engine):
    name = "rigidlab"
    peer = "rigidlab"
    path = "DOP853, absolute coordinates + multipliers, projection"
    grid = "rtol"
    order = 1.0
    effort_range = (16, 104)  # rtol 1e-2 .. 1e-13

    def knob(self, effort):
        return 10.0 ** (-effort / RTOL_STEPS_PER_DECADE)

    def effort_for(self, knob):
        return math.ceil(-math.log10(knob) * RTOL_STEPS_PER_DECADE - 1e-9)

    def start(self, target):
        return self.effort_for(3.0 * target)

    def setting(self, effort):
        rtol = self.knob(effort)
        return f"DOP853 rtol {rtol:.2g}, atol {rtol * 1e-2:.2g}"

    def run(self, case, effort):
        model = case.build()
        system = model if case.kind == "chain" else model.system
        rtol = self.knob(effort)
        traj, cpu = cpu_time(lambda: system.simulate(case.t, rtol=rtol, atol=rtol * 1e-2))
        centres = np.stack([traj.position(b) for b in system.bodies], axis=1)
        return centres, float(traj.residual_position.max()), cpu


class _FixedStep(Engine):
    """Engines stepping with dt = 1 / (60 k), k steps per output frame (effort k)."""

    effort_range = (1, 20000)
    cost_cap = PEER_CPU_CAP

    def knob(self, effort):
        return 1.0 / (FPS * effort)

    def effort_for(self, knob):
        return max(1, math.ceil(1.0 / (FPS * knob) - 1e-9))

    def cost_of(self, effort, runs):
        made = [e for e in runs if math.isfinite(runs[e].error)] or list(runs)
        if not made:
            return 0.0
        near = min(made, key=lambda e: abs(math.log(e / effort)))
        return runs[near].cpu * effort / near

    def _dt_text(self, effort):
        return f"dt 1/{FPS * effort} s"


class MuJoCo(_FixedStep):
    name = "MuJoCo"
    peer = "MuJoCo"
    path = "RK4, minimal (hinge joints)"
    order = 4.0

    def path_for(self, case):
        return self.path if case.kind == "chain" else "RK4, hinges + slide, soft equality constraints"

    def missing(self):
        try:
            import mujoco  # noqa: F401
        except ImportError:
            return f"not installed ({INSTALL_HINT})"
        return None

    def start(self, target):
        return 4 if target >= 1e-7 else 24

    def setting(self, effort):
        return f"RK4, {self._dt_text(effort)}"

    def run(self, case, effort):
        import mujoco

        model = case.build()
        xml, qvel, names = mujoco_model(model, case.kind, self.knob(effort))
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        ids = [m.body(name).id for name in names]
        out = np.empty((case.t.size, len(ids), 3))
        out[0] = d.xipos[ids]
        equality = mujoco.mjtConstraint.mjCNSTR_EQUALITY
        residual = np.zeros(case.t.size)

        # after an RK4 mj_step, mjData's positions (and constraint rows) are those of the last Runge-Kutta
        # stage, not of the step's end: recompute them at the frame's state before reading
        refresh = mujoco.mj_kinematics if case.kind == "chain" else mujoco.mj_forward

        def loop():
            for i in range(1, case.t.size):
                mujoco.mj_step(m, d, nstep=effort)
                refresh(m, d)
                out[i] = d.xipos[ids]
                if d.nefc:
                    residual[i] = np.abs(d.efc_pos[: d.nefc][d.efc_type[: d.nefc] == equality]).max(initial=0.0)

        _, cpu = cpu_time(loop)
        return out, (float(residual.max()) if case.kind != "chain" else None), cpu


class ExudynAlpha(_FixedStep):
    """Exudyn's redundant coordinates (rigid bodies with Euler parameters, joints as constraints),
    generalized-alpha, with the linear solver ``linear_solver``."""

    peer = "Exudyn"
    order = 2.0
    linear_solver = "EXUdense"

    @property
    def name(self):
        return f"Exudyn alpha {self.linear_solver}"

    @property
    def path(self):
        kind = "sparse (EigenSparse)" if "Sparse" in self.linear_solver else "dense (EXUdense)"
        return f"gen.-alpha, redundant coordinates, {kind}"

    def missing(self):
        try:
            _import_exudyn()
        except ImportError:
            return f"not installed ({INSTALL_HINT})"
        return None

    def start(self, target):
        return 8 if target >= 1e-7 else 64

    def setting(self, effort):
        return f"gen.-alpha, {self._dt_text(effort)}"

    def run(self, case, effort):
        exu = _import_exudyn()
        model = case.build()
        _container, mbs, sensors = exudyn_model(exu, model, case.kind)
        settings = _exudyn_settings(exu, case, effort * (case.t.size - 1))
        settings.linearSolver.solverType = getattr(exu.LinearSolverType, self.linear_solver)
        settings.timeIntegration.newton.useModifiedNewton = True
        settings.timeIntegration.newton.relativeTolerance = 1e-10  # default 1e-8 leaves ~2e-9 m in the slider-crank
        _, cpu = cpu_time(lambda: mbs.SolveDynamic(settings, solverType=exu.DynamicSolverType.GeneralizedAlpha))
        data = np.stack([mbs.GetSensorStoredData(s) for s in sensors], axis=1)  # (rows, bodies, [t, x, y, z])
        rows = np.searchsorted(data[:, 0, 0], case.t - 0.25 / (FPS * effort))
        return data[np.minimum(rows, len(data) - 1), :, 1:], None, cpu


class ExudynAlphaSparse(ExudynAlpha):
    linear_solver = "EigenSparse"


class ExudynTreeRK44(_FixedStep):
    """Exudyn's minimal coordinates (``ObjectKinematicTree``: one joint angle per link), explicit RK44;
    centres of mass from the stored joint coordinates (the tree's forward kinematics, after the run)."""

    name = "Exudyn tree RK44"
    peer = "Exudyn"
    path = "RK44, minimal coordinates (ObjectKinematicTree)"
    order = 4.0

    def missing(self):
        return ExudynAlpha.missing(self)

    def applies(self, case):
        return case.kind == "chain"

    def start(self, target):
        return 4 if target >= 1e-7 else 16

    def setting(self, effort):
        return f"RK44, {self._dt_text(effort)}"

    def run(self, case, effort):
        exu = _import_exudyn()
        tree = chain_tree(case.n_links)
        _container, mbs, node = exudyn_tree_model(exu, tree, chain_angles0(case.n_links))
        from exudyn.utilities import SensorNode

        sensor = mbs.AddSensor(SensorNode(
            nodeNumber=node, storeInternal=True, writeToFile=False,
            outputVariableType=exu.OutputVariableType.Coordinates))
        mbs.Assemble()
        settings = _exudyn_settings(exu, case, effort * (case.t.size - 1))
        _, cpu = cpu_time(lambda: mbs.SolveDynamic(settings, solverType=exu.DynamicSolverType.RK44))
        data = mbs.GetSensorStoredData(sensor)  # (rows, [t, q_0 .. q_n-1])
        rows = np.searchsorted(data[:, 0], case.t - 0.25 / (FPS * effort))
        q = data[np.minimum(rows, len(data) - 1), 1:]
        return tree_points(tree, q)[0], None, cpu


class ExudynTreeDOPRI5(Engine):
    """Exudyn's ``ObjectKinematicTree`` with DOPRI5 (error control, ``rtol = atol``). Exudyn's adaptive
    steps do not end on the output times, so the run stops at every 60 Hz frame: ``MainSolverExplicit``
    initialized once, then ``it.endTime`` set to the next frame and ``SolveSteps`` (the step size carries
    over); the joint coordinates are read at each frame. On the 10-link chain this costs about 20 % more
    than one ``SolveDynamic`` over the same time."""

    name = "Exudyn tree DOPRI5"
    peer = "Exudyn"
    path = "DOPRI5, minimal coordinates (ObjectKinematicTree)"
    grid = "rtol"
    order = 1.0
    effort_range = (16, 104)
    cost_cap = PEER_CPU_CAP

    missing = ExudynAlpha.missing
    applies = ExudynTreeRK44.applies
    knob = Rigidlab.knob
    effort_for = Rigidlab.effort_for

    def start(self, target):
        # coarse tolerances plateau (steps of at most one frame): start at the target itself
        return self.effort_for(target)

    def setting(self, effort):
        return f"DOPRI5 rtol = atol {self.knob(effort):.2g}"

    def cost_of(self, effort, runs):
        made = [e for e in runs if math.isfinite(runs[e].error)] or list(runs)
        if not made:
            return 0.0
        near = min(made, key=lambda e: abs(e - effort))
        return runs[near].cpu * (self.knob(near) / self.knob(effort)) ** 0.2  # 5th order: cost ~ tol^(-1/5)

    def run(self, case, effort):
        exu = _import_exudyn()
        tree = chain_tree(case.n_links)
        _container, mbs, _node = exudyn_tree_model(exu, tree, chain_angles0(case.n_links))
        mbs.Assemble()
        settings = _exudyn_settings(exu, case, case.t.size - 1)
        integration = settings.timeIntegration
        integration.solverType = exu.DynamicSolverType.DOPRI5
        integration.automaticStepSize = True
        integration.relativeTolerance = integration.absoluteTolerance = self.knob(effort)
        return _dopri5_run(exu, mbs, settings, tree, case.t)


def _dopri5_run(exu, mbs, settings, tree, t):
    """(centres (n_out, n, 3), None, CPU s): ``MainSolverExplicit`` stopped at every output time."""
    solver = exu.MainSolverExplicit()
    q = np.empty((t.size, len(tree.mass)))

    def loop():
        solver.InitializeSolver(mbs, settings)
        q[0] = mbs.systemData.GetODE2Coordinates()
        for i in range(1, t.size):
            solver.it.endTime = float(t[i])
            solver.SolveSteps(mbs, settings)
            q[i] = mbs.systemData.GetODE2Coordinates()
        solver.FinalizeSolver(mbs, settings)

    _, cpu = cpu_time(loop)
    if abs(solver.it.currentTime - t[-1]) > 1e-9:
        raise RuntimeError(f"DOPRI5 stopped at t = {solver.it.currentTime:g} s")
    return tree_points(tree, q)[0], None, cpu


def _exudyn_settings(exu, case, n_steps: int):
    """Simulation settings over ``case.t`` with ``n_steps`` steps (the largest step of an adaptive solver),
    sensors every 60 Hz frame, no files, no console output."""
    settings = exu.SimulationSettings()
    integration = settings.timeIntegration
    integration.numberOfSteps = int(n_steps)
    integration.endTime = float(case.t[-1])
    integration.verboseMode = 0
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = 1.0 / FPS
    settings.show.computationTime = False
    settings.show.statistics = False
    return settings


def _import_exudyn():
    if "exudyn" not in sys.modules:
        sys.exudynFast = True  # the build without range checks
        with contextlib.redirect_stdout(io.StringIO()):
            import exudyn  # noqa: F401
    import exudyn

    return exudyn


#: The paths of each peer; a table row reports the peer's cheapest path that reaches the target.
ENGINES = {"rigidlab": (Rigidlab,), "MuJoCo": (MuJoCo,),
           "Exudyn": (ExudynAlpha, ExudynAlphaSparse, ExudynTreeRK44, ExudynTreeDOPRI5)}


# ------------------------------------------------------------------ peer models
def _f(x: float) -> str:
    return repr(float(x))


def _vec(v) -> str:
    return " ".join(_f(x) for x in v)


def _quat_conj(p):
    return np.array([p[0], -p[1], -p[2], -p[3]])


def _quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _mj_body(state, body, parent, *, joint: str, extra: str = "", children: str = "") -> str:
    """A MJCF body at its rigidlab pose relative to ``parent`` (None: the world), frame = the body frame."""
    R, p = state.position(body), state.orientation(body)
    if parent is None:
        pos, quat = R, p
    else:
        A_parent = state.rotation_matrix(parent)
        pos = A_parent.T @ (R - state.position(parent))
        quat = _quat_mul(_quat_conj(state.orientation(parent)), p)
    J = body.inertia
    inertia = f"{_f(J[0, 0])} {_f(J[1, 1])} {_f(J[2, 2])} {_f(J[0, 1])} {_f(J[0, 2])} {_f(J[1, 2])}"
    return (f'<body name="{body.name}" pos="{_vec(pos)}" quat="{_vec(quat)}">{joint}'
            f'<inertial pos="0 0 0" mass="{_f(body.mass)}" fullinertia="{inertia}"/>{extra}{children}</body>')


def _mj_joint(state, body, joint, kind: str) -> str:
    """A MJCF hinge or slide joint of ``body`` at a rigidlab joint (global point and axis -> body frame)."""
    A = state.rotation_matrix(body)
    pos = A.T @ (joint.point - state.position(body))
    axis = A.T @ joint.axis
    return f'<joint name="{joint.name}" type="{kind}" pos="{_vec(pos)}" axis="{_vec(axis)}"/>'


def mujoco_model(model, kind: str, dt: float) -> tuple[str, np.ndarray, list[str]]:
    """(MJCF XML, initial qvel, names of the bodies in rigidlab's order) of a rigidlab model."""
    system = model if kind == "chain" else model.system
    state = system.state
    g = system.gravity
    option = (f'<option timestep="{_f(dt)}" integrator="RK4" gravity="{_vec(g)}">'
              f'<flag contact="disable"/></option>')
    if kind == "chain":
        xml = ""
        for k in reversed(range(len(system.bodies))):
            body = system.bodies[k]
            parent = system.bodies[k - 1] if k else None
            xml = _mj_body(state, body, parent, joint=_mj_joint(state, body, system.joints[k], "hinge"), children=xml)
        qvel = np.zeros(len(system.bodies))  # released at rest
        return (f"<mujoco>{option}<worldbody>{xml}</worldbody></mujoco>", qvel,
                [b.name for b in system.bodies])
    # slider-crank: crank (hinge) -> rod (hinge about the crank axis: the planar
    # equivalent of the spherical joint), slider on a slide joint; a connect
    # equality closes the loop at the rod-slider joint; the crank angle equals
    # a clock coordinate moving at the motor's speed (joint equality).
    crank, rod, slider = model.crank, model.rod, model.slider
    rod_hinge = model.crank_rod_joint
    axis = model.crank_joint.axis
    A_rod = state.rotation_matrix(rod)
    anchor = A_rod.T @ (model.rod_slider_joint.point - state.position(rod))
    hinge_pos = A_rod.T @ (rod_hinge.point - state.position(rod))
    rod_joint = f'<joint name="rod_hinge" type="hinge" pos="{_vec(hinge_pos)}" axis="{_vec(A_rod.T @ axis)}"/>'
    rod_xml = _mj_body(state, rod, crank, joint=rod_joint)
    crank_xml = _mj_body(state, crank, None, joint=_mj_joint(state, crank, model.crank_joint, "hinge"),
                         children=rod_xml)
    slider_xml = _mj_body(state, slider, None, joint=_mj_joint(state, slider, model.slider_joint, "slide"))
    clock = ('<body name="clock" pos="0 0 -10"><joint name="clock" type="slide" axis="1 0 0"/>'
             '<inertial pos="0 0 0" mass="1e10" diaginertia="1 1 1"/></body>')
    equality = (f'<equality><connect body1="rod" body2="slider" anchor="{_vec(anchor)}"/>'
                f'<joint joint1="{model.crank_joint.name}" joint2="clock" polycoef="0 1 0 0 0"/></equality>')
    default = (f'<default><equality solref="{_f(2.0 * dt)} 1" solimp="0.9999 0.9999 0.001 0.5 2"/></default>')
    w_crank = state.omega(crank) @ axis
    w_rod = (state.omega(rod) - state.omega(crank)) @ axis
    v_slider = state.velocity(slider) @ model.slider_joint.axis
    qvel = np.array([w_crank, w_rod, v_slider, model.speed])
    xml = f"<mujoco>{option}{default}<worldbody>{crank_xml}{slider_xml}{clock}</worldbody>{equality}</mujoco>"
    return xml, qvel, [crank.name, rod.name, slider.name]


def exudyn_model(exu, model, kind: str):
    """(SystemContainer, MainSystem, sensors of the bodies' centres in rigidlab's order) of a rigidlab model,
    assembled (keep the container while the MainSystem is used)."""
    from exudyn.utilities import RigidBodyInertia, SensorBody

    system = model if kind == "chain" else model.system
    state = system.state
    container = exu.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.CreateGround()
    item = {}
    sensors = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for b in system.bodies:
            item[b.name] = mbs.CreateRigidBody(
                inertia=RigidBodyInertia(b.mass, b.inertia, inertiaTensorAtCOM=True),
                referencePosition=state.position(b), referenceRotationMatrix=state.rotation_matrix(b),
                initialVelocity=state.velocity(b), initialAngularVelocity=state.omega(b), gravity=system.gravity)
            sensors.append(mbs.AddSensor(SensorBody(bodyNumber=item[b.name], storeInternal=True, writeToFile=False,
                                                    outputVariableType=exu.OutputVariableType.Position)))

        def ref(body):
            return ground if body.is_ground else item[body.name]

        if kind == "chain":
            for j in system.joints:
                mbs.CreateRevoluteJoint(itemNumbers=[ref(j.body_i), ref(j.body_j)], position=j.point, axis=j.axis)
        else:
            speed = model.speed
            crank_joint = model.crank_joint
            z = crank_joint.axis
            x = np.cross(z, [0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.cross(z, [1.0, 0.0, 0.0])
            x = x / np.linalg.norm(x)
            frame = np.stack([x, np.cross(z, x), z], axis=1)
            # the motor: all six coordinates fixed, the rotation about the axis offset by speed * t
            mbs.CreateGenericJoint(itemNumbers=[ref(crank_joint.body_i), ref(crank_joint.body_j)],
                                   position=crank_joint.point, rotationMatrixAxes=frame, constrainedAxes=[1] * 6,
                                   offsetUserFunction=lambda mbs_, t, i, p: [0, 0, 0, 0, 0, speed * t],
                                   offsetUserFunction_t=lambda mbs_, t, i, p: [0, 0, 0, 0, 0, speed])
            j = model.crank_rod_joint
            mbs.CreateSphericalJoint(itemNumbers=[ref(j.body_i), ref(j.body_j)], position=j.point)
            j = model.rod_slider_joint
            # universal: joint y axis = the cross arm on body_i, z = the arm on body_j; t_y0 . t_z1 = 0
            frame = np.stack([np.cross(j.axis, j.axis_j), j.axis, j.axis_j], axis=1)
            mbs.CreateGenericJoint(itemNumbers=[ref(j.body_i), ref(j.body_j)], position=j.point,
                                   rotationMatrixAxes=frame, constrainedAxes=[1, 1, 1, 1, 0, 0])
            j = model.slider_joint
            mbs.CreatePrismaticJoint(itemNumbers=[ref(j.body_i), ref(j.body_j)], position=j.point, axis=j.axis)
    mbs.Assemble()
    return container, mbs, sensors


# ------------------------------------------------------------------ the chain as a kinematic tree
@dataclass(frozen=True)
class ChainTree:
    """:func:`rigidlab.core.models.pendulum_chain` as a kinematic tree (link k's parent is link k - 1), read from
    the rigidlab System hanging at rest (tilt 0): every joint frame is then parallel to the global frame,
    and the joint coordinates are the relative angles about the common joint axis (global x)."""

    offset: np.ndarray  # (n, 3) joint k from joint k - 1 (joint 0 from the origin), global axes (m)
    com: np.ndarray  # (n, 3) centre of mass of link k from joint k (m)
    tip: np.ndarray  # (3,) the free end of the last link from its joint (m)
    mass: np.ndarray  # (n,) kg
    inertia: np.ndarray  # (n, 3, 3) about the centre of mass, global axes (kg m^2)
    axis: np.ndarray  # (3,) the joints' common axis
    gravity: np.ndarray  # (3,) m/s^2


def chain_tree(n_links: int, *, system=None, tilt: float = 0.0) -> ChainTree:
    """The kinematic tree of ``pendulum_chain(n_links)`` (same masses, inertias, joints, gravity), read
    from ``system`` (default: a new ``pendulum_chain(n_links)``), a chain at rest tilted by ``tilt`` (rad)."""
    if system is None:
        system = pendulum_chain(n_links, tilt=tilt)
    state = system.state
    c, s = math.cos(tilt), math.sin(tilt)
    untilt = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])  # turns the chain back by -tilt about x
    points = np.array([untilt @ np.asarray(j.point, dtype=float) for j in system.joints])
    centres = np.array([untilt @ state.position(b) for b in system.bodies])
    axes = np.array([untilt @ np.asarray(j.axis, dtype=float) for j in system.joints])
    if not np.allclose(axes, axes[0]) or not np.allclose(axes[0], [1.0, 0.0, 0.0]):
        raise ValueError("chain_tree: expected every joint about the global x axis")
    frames = [untilt @ state.rotation_matrix(b) for b in system.bodies]
    inertia = np.array([A @ np.asarray(b.inertia) @ A.T for A, b in zip(frames, system.bodies, strict=True)])
    offset = np.diff(np.vstack([np.zeros(3), points]), axis=0)
    tip = 2.0 * (centres[-1] - points[-1])  # uniform rods: the centre is mid-length
    return ChainTree(offset, centres - points, tip, np.array([b.mass for b in system.bodies], dtype=float),
                     inertia, axes[0], np.asarray(system.gravity, dtype=float))


def chain_angles0(n_links: int) -> np.ndarray:
    """(n,) relative joint angles of ``pendulum_chain(n_links, tilt=CHAIN_TILT)``: the top joint turned by
    the tilt, the others straight."""
    q0 = np.zeros(n_links)
    q0[0] = CHAIN_TILT
    return q0


def _rotate_x(phi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(..., 3): vectors ``v`` (..., 3) turned by ``phi`` (...) about the x axis."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.broadcast_to(v[..., 0], c.shape), c * v[..., 1] - s * v[..., 2],
                     s * v[..., 1] + c * v[..., 2]], axis=-1)


def tree_points(tree: ChainTree, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres (..., n, 3), tip (..., 3)) of the chain at relative joint angles ``q`` (..., n)."""
    phi = np.cumsum(q, axis=-1)  # absolute angles about x
    moved = _rotate_x(phi[..., :-1], tree.offset[1:])  # (..., n - 1, 3)
    joints = tree.offset[0] + np.concatenate([np.zeros(q.shape[:-1] + (1, 3)), np.cumsum(moved, axis=-2)],
                                             axis=-2)
    centres = joints + _rotate_x(phi, tree.com)
    tip = joints[..., -1, :] + _rotate_x(phi[..., -1], tree.tip)
    return centres, tip


def exudyn_tree_model(exu, tree: ChainTree, q0: np.ndarray):
    """(SystemContainer, MainSystem, node of the joint coordinates) of the chain as an Exudyn
    ``ObjectKinematicTree`` (``mbs.CreateKinematicTree``: RevoluteX joints, the links' mass, centre and
    inertia about the centre), at the joint angles ``q0`` and at rest; not yet assembled."""
    from exudyn.rigidBodyUtilities import RigidBodyInertia, TreeLink

    container = exu.SystemContainer()
    mbs = container.AddSystem()
    links = []
    for k in range(len(tree.mass)):
        frame = np.eye(4)
        frame[:3, 3] = tree.offset[k]
        links.append(TreeLink(linkInertia=RigidBodyInertia(tree.mass[k], tree.inertia[k], tree.com[k],
                                                           inertiaTensorAtCOM=True),
                              jointType=exu.JointType.RevoluteX, jointHT=frame, graphicsDataList=[]))
    obj = mbs.CreateKinematicTree(listOfTreeLinks=links, initialCoordinates=np.asarray(q0, dtype=float),
                                  gravity=tree.gravity, baseGraphicsDataList=[], show=False)
    return container, mbs, mbs.GetObject(obj)["nodeNumber"]


def pinocchio_chain_model(pin, tree: ChainTree):
    """(pin.Model, pin.Data) of the chain: revolute joints about x (``JointModelRX``) placed at the joint
    offsets, each link's mass, centre and inertia about the centre, the same gravity."""
    model = pin.Model()
    parent = 0
    for k in range(len(tree.mass)):
        parent = model.addJoint(parent, pin.JointModelRX(), pin.SE3(np.eye(3), tree.offset[k]), f"joint{k}")
        model.appendBodyToJoint(parent, pin.Inertia(float(tree.mass[k]), tree.com[k], tree.inertia[k]),
                                pin.SE3.Identity())
    model.gravity = pin.Motion(tree.gravity, np.zeros(3))
    return model, model.createData()


# ------------------------------------------------------------------ search
def evaluate(engine: Engine, case: Case, effort: int, runs: dict[int, Run]) -> Run:
    """Run ``engine`` at ``effort`` once (memoized in ``runs``); a failed run counts as an infinite error."""
    if effort not in runs:
        t0 = time.process_time()
        try:
            centres, residual, cpu = engine.run(case, effort)
            error = position_error(centres, case)
        except Exception as exc:  # a peer's solver giving up at a coarse step
            print(f"  {engine.name} at {engine.setting(effort)} failed: {(str(exc) or type(exc).__name__)[:80]}")
            residual, cpu, error = None, time.process_time() - t0, math.inf
        runs[effort] = Run(effort, error if math.isfinite(error) else math.inf, cpu, residual, [cpu])
        print(f"    {engine.name}: {engine.setting(effort)}: error {error:.2e}, CPU {cpu:.3f} s", flush=True)
    return runs[effort]


def search(engine: Engine, case: Case, target: float, runs: dict[int, Run], *, max_runs: int = 8):
    """The cheapest effort with error <= target: (Run, reached). ``runs`` holds earlier runs and gains new ones.

    Fits ``log error = c + p log knob`` through the two runs nearest the
    target, aims at 0.8 times the target, and narrows the bracket between
    the finest failing and the coarsest passing effort until they are one
    grid step apart (rtol grid) or within 20 % in dt, or a passing run is
    within a factor 2 of the target. A run that would cost more than the
    engine's cap is replaced once by the finest affordable one when that is
    at least 1.5 times finer than every run made (its error is then the best
    reachable); an error that stops falling as the step shrinks ends the
    search too.
    """
    lo, hi = engine.effort_range
    finite = [e for e in runs if math.isfinite(runs[e].error)]
    effort = (min(finite, key=lambda e: abs(math.log(runs[e].error / target))) if finite
              else engine.start(target))
    capped = False
    for _ in range(max_runs):
        run = evaluate(engine, case, effort, runs)
        passing = [e for e, r in runs.items() if r.error <= target]
        best = min(passing) if passing else None
        failing = [e for e, r in runs.items() if r.error > target and (best is None or e < best)]
        worst = max(failing) if failing else None
        if best is not None and (best == lo or runs[best].error >= 0.5 * target
                                 or (worst is not None and _close(engine, worst, best))):
            break
        finite = [e for e in runs if math.isfinite(runs[e].error)]
        if not finite:
            if effort >= hi or len(runs) >= 3:
                break
            nxt = min(hi, 4 * effort)
        else:
            # slope from the two runs nearest the target in error
            near = sorted(finite, key=lambda e: abs(math.log(runs[e].error / target)))[:2]
            p = engine.order
            if len(near) == 2 and runs[near[0]].error != runs[near[1]].error:
                slope = (math.log(runs[near[0]].error / runs[near[1]].error)
                         / math.log(engine.knob(near[0]) / engine.knob(near[1])))
                if 0.5 <= slope <= 10.0:
                    p = slope
            knob = engine.knob(near[0]) * (0.8 * target / runs[near[0]].error) ** (1.0 / p)
            nxt = min(max(engine.effort_for(knob), lo), hi)
        if worst is not None:
            nxt = max(nxt, worst + 1)
        if best is not None:
            nxt = min(nxt, best - 1)
        if nxt in runs:  # the model points at a run already made: bisect the bracket
            top = best if best is not None else hi
            bottom = worst if worst is not None else lo
            nxt = round(math.sqrt(top * bottom))
            if nxt in runs or nxt <= bottom or nxt >= top:
                break
        if best is None and worst is not None and engine.grid == "dt":
            coarser = [e for e in failing if engine.knob(e) >= 2.0 * engine.knob(worst)]
            if coarser and runs[worst].error > 0.5 * runs[max(coarser)].error:
                break  # halving the step no longer halves the error: a floor, not the step size
        if engine.cost_cap is not None and engine.cost_of(nxt, runs) > engine.cost_cap:
            if capped:
                break
            capped = True
            floor = worst if worst is not None else lo - 1
            nxt = next((e for e in range(nxt - 1, floor, -1) if engine.cost_of(e, runs) <= engine.cost_cap), None)
            if nxt is None or nxt in runs or nxt < 1.5 * max(runs):
                break  # nothing affordable is much finer than the runs made
        effort = nxt
    passing = [e for e, r in runs.items() if r.error <= target]
    if passing:
        return runs[min(passing)], True
    return runs[min(runs, key=lambda e: runs[e].error)], False


def _close(engine: Engine, fine: int, coarse: int) -> bool:
    if engine.grid == "rtol":
        return coarse - fine <= 1
    return engine.knob(fine) / engine.knob(coarse) <= 1.2 or coarse - fine <= 1


def best_of(engine: Engine, case: Case, run: Run, repeats: int) -> float:
    """Best CPU seconds of ``run``'s setting over ``repeats`` runs (fewer for slow settings)."""
    wanted = repeats if run.cpu < 2.0 else (min(repeats, 2) if run.cpu < 10.0 else 1)
    while len(run.cpus) < wanted:
        _, _, cpu = engine.run(case, run.effort)
        run.cpus.append(cpu)
    run.cpu = min(run.cpus)
    return run.cpu


# ------------------------------------------------------------------ table
def build_table(models=MODELS, *, targets=TARGETS, t_end: float = T_END, engines=tuple(ENGINES), repeats: int = 3,
                log=print) -> tuple[list[dict], dict]:
    """Rows of the benchmark table (dicts keyed by :data:`COLUMNS` plus raw numbers) and a summary.

    Parameters
    ----------
    models : sequence of str
        Names from :data:`MODELS` (or any ``chainN``).
    targets : sequence of float
        Position error targets (m).
    t_end : float
        Simulated time (s), outputs at 60 Hz.
    engines : sequence of str
        Keys of :data:`ENGINES`; rigidlab is always run (the ratios need it).
    repeats : int
        Best of this many runs for settings under 2 s of CPU.
    """
    engine_objs = [Rigidlab()] + [cls() for name in engines if name != "rigidlab" for cls in ENGINES[name]]
    missing = {e.peer: e.missing() for e in engine_objs if e.missing()}
    for name, why in missing.items():
        log(f"{name}: {why}")
    peers = list(dict.fromkeys(e.peer for e in engine_objs))
    rows: list[dict] = []
    summary: dict = {"missing": missing, "cases": {}, "paths": []}
    for name in models:
        case = make_case(name, t_end=t_end)
        log(f"[{name}] reference: {case.reference_note}, CPU {case.reference_cpu:.2f} s")
        rows.append(_row(case.label, "-", "reference", "-", case.reference_note, case.reference_cpu,
                         case.reference_check, None, None, note="self-check" if case.kind == "chain" else "exact"))
        summary["cases"][name] = {"reference_cpu": case.reference_cpu, "reference_check": case.reference_check,
                                  "rtol": {}}
        memo: dict[str, dict[int, Run]] = {e.name: {} for e in engine_objs}
        for target in targets:
            base = None
            for peer in peers:
                if peer in missing:
                    continue
                tried = []
                for engine in (e for e in engine_objs if e.peer == peer and e.applies(case)):
                    run, reached = search(engine, case, target, memo[engine.name])
                    if reached:
                        best_of(engine, case, run, repeats)
                    tried.append((engine, run, reached))
                    summary["paths"].append({"model": case.label, "target": target, "engine": peer,
                                             "path": engine.path_for(case), "setting": engine.setting(run.effort),
                                             "reached": reached, "cpu_s": run.cpu, "error_m": run.error})
                    log(f"[{name}] {target:g} {peer} ({engine.path_for(case)}): {engine.setting(run.effort)}, "
                        f"{'reached' if reached else 'not reached'}, CPU {run.cpu:.3f} s, error {run.error:.2e}")
                passing = [x for x in tried if x[2]]
                engine, run, reached = (min(passing, key=lambda x: x[1].cpu) if passing
                                        else min(tried, key=lambda x: x[1].error))
                setting = engine.setting(run.effort)
                if not reached:
                    setting = f"not reached: best {run.error:.1e} at {setting}"
                if peer == "rigidlab":
                    base = run.cpu if reached else None
                    if reached:
                        summary["cases"][name]["rtol"][f"{target:g}"] = engine.knob(run.effort)
                ratio = run.cpu / base if (reached and base and peer != "rigidlab") else None
                rows.append(_row(case.label, f"{target:g}", peer, engine.path_for(case), setting, run.cpu, run.error,
                                 run.residual, ratio, reached=reached, knob=engine.knob(run.effort),
                                 runs=len(memo[engine.name])))
    for entry in summary["paths"]:
        base = next((r["cpu_s"] for r in rows if r["model"] == entry["model"] and r["engine"] == "rigidlab"
                     and r["target"] == f"{entry['target']:g}" and r["reached"]), None)
        entry["ratio"] = entry["cpu_s"] / base if (base and entry["reached"]) else None
    return rows, summary


def _row(model, target, engine, path, setting, cpu, error, residual, ratio, *, note=None, reached=True, knob=None,
         runs=None) -> dict:
    error_text = f"{error:.1e}" + (f" ({note})" if note else "")
    return {
        "model": model, "target": target, "engine": engine, "path": path, "setting": setting,
        "CPU (s)": f"{cpu:.3f}",
        "position error (m)": error_text,
        "constraint residual": "-" if residual is None else f"{residual:.1e}",
        "CPU / rigidlab": "-" if ratio is None else f"{ratio:.2f}",
        "cpu_s": cpu, "error_m": error, "residual": residual, "ratio": ratio, "reached": reached, "knob": knob,
        "search_runs": runs,
    }


def format_table(rows: list[dict]) -> str:
    """The rows as a Markdown table (header, rule, one line per row)."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "|".join("---:" if c in ("CPU (s)", "CPU / rigidlab") else "---"
                                                           for c in COLUMNS) + "|"]
    lines += ["| " + " | ".join(str(r[c]) for c in COLUMNS) + " |" for r in rows]
    return "\n".join(lines)


def format_paths(paths: list[dict]) -> str:
    """Every path of every engine at every target (the table keeps each engine's cheapest) as Markdown."""
    lines = ["| model | target | engine | path | setting | CPU (s) | error (m) | CPU / rigidlab |",
             "|---|---|---|---|---|---:|---|---:|"]
    for p in paths:
        setting = p["setting"] if p["reached"] else f"not reached ({p['setting']})"
        ratio = "-" if p["ratio"] is None else f"{p['ratio']:.2f}"
        lines.append(f"| {p['model']} | {p['target']:g} | {p['engine']} | {p['path']} | {setting} | "
                     f"{p['cpu_s']:.3f} | {p['error_m']:.1e} | {ratio} |")
    return "\n".join(lines)


def ratio_summary(rows: list[dict]) -> str:
    """One line per target: each peer's range of CPU / rigidlab and how many models it reached."""
    lines = ["Ratios (peer CPU / rigidlab CPU at the same target; > 1: rigidlab is faster):"]
    targets = [t for t in dict.fromkeys(r["target"] for r in rows) if t != "-"]
    for target in targets:
        parts = []
        for engine in dict.fromkeys(r["engine"] for r in rows if r["target"] == target):
            if engine == "rigidlab":
                continue
            peer = [r for r in rows if r["target"] == target and r["engine"] == engine]
            ratios = [r["ratio"] for r in peer if r["ratio"] is not None]
            span = f"{min(ratios):.2g} .. {max(ratios):.2g}" if ratios else "-"
            parts.append(f"{engine} {span} (reached on {len(ratios)} of {len(peer)} models)")
        lines.append(f"- {target}: " + "; ".join(parts))
    return "\n".join(lines)


# ------------------------------------------------------------------ issue targets
def frame_target(rtol: float, *, n_links: int = 10, repeats: int = 10) -> dict:
    """CPU per 60 Hz frame of the chain at ``rtol`` (ms): 60-frame chunks from t = 3 s (min, median over
    ``repeats``), and one call of ``simulate`` per frame (min), from the same state."""
    system = pendulum_chain(n_links, tilt=CHAIN_TILT)
    lead = system.simulate(np.linspace(0.0, 3.0, 3 * FPS + 1), rtol=rtol, atol=rtol * 1e-2)
    system.set_state(lead.state(-1))
    t = np.linspace(3.0, 4.0, FPS + 1)
    per_frame = []
    for _ in range(repeats):
        _, cpu = cpu_time(lambda: system.simulate(t, rtol=rtol, atol=rtol * 1e-2))
        per_frame.append(cpu / FPS * 1e3)
    single = []
    for _ in range(repeats):
        _, cpu = cpu_time(lambda: system.simulate(t[:2], rtol=rtol, atol=rtol * 1e-2))
        single.append(cpu * 1e3)
    return {"rtol": rtol, "min_ms": min(per_frame), "median_ms": statistics.median(per_frame),
            "single_call_min_ms": min(single)}


def residual_target(rtol: float, *, n_links: int = 10, t_end: float = 100.0) -> dict:
    """Largest position residual of the chain over ``t_end`` at ``rtol`` (60 Hz outputs)."""
    system = pendulum_chain(n_links, tilt=CHAIN_TILT)
    traj, cpu = cpu_time(lambda: system.simulate(np.linspace(0.0, t_end, round(t_end * FPS) + 1), rtol=rtol,
                                                 atol=rtol * 1e-2))
    return {"rtol": rtol, "t_end": t_end, "residual": float(traj.residual_position.max()),
            "velocity_residual": float(traj.residual_velocity.max()), "cpu_s": cpu}


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def git_revision() -> str:
    """The measured rigidlab: ``<commit> (<commit date>)``, plus a note when core/ has uncommitted changes."""
    import subprocess

    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "log", "-1", "--format=%h (%cs)"], cwd=root, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "core"], cwd=root, capture_output=True,
                               text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown revision"
    return head + (" + uncommitted changes in core/" if dirty else "")


def _versions() -> dict:
    import scipy

    versions = {"numpy": np.__version__, "scipy": scipy.__version__}
    with contextlib.suppress(ImportError):
        import mujoco

        versions["mujoco"] = mujoco.__version__
    with contextlib.suppress(ImportError):
        versions["exudyn"] = _import_exudyn().__version__
    with contextlib.suppress(ImportError):
        import pinocchio

        versions["pinocchio"] = pinocchio.__version__
    return versions


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="chain2 and chain5 only, no issue targets")
    parser.add_argument("--models", nargs="+", metavar="NAME", help=f"models to run, from {', '.join(MODELS)}")
    args = parser.parse_args(argv)
    models = args.models or (QUICK_MODELS if args.quick else MODELS)
    for name in models:
        if not (name in MODELS or (name.startswith("chain") and name[5:].isdigit())):
            parser.error(f"--models: expected names from {MODELS} (or chainN), got {name!r}")
    started = time.perf_counter()
    machine, versions = _machine(), _versions()
    print(f"# rigidlab multibody benchmark{' (quick)' if args.quick else ''}, "
          f"{datetime.date.today().isoformat()}, rigidlab {git_revision()}")
    print(f"{machine}; " + ", ".join(f"{k} {v}" for k, v in versions.items()))
    print(f"T = {T_END:g} s, outputs at {FPS} Hz; error = largest distance of a body's centre of mass from the "
          f"reference; CPU = process time, best of up to 3 runs\n")
    rows, summary = build_table(models)
    print()
    print(format_table(rows))
    print("\nEvery path tried (each row of the table above is its engine's cheapest path reaching the target):\n")
    print(format_paths(summary["paths"]))
    print("\n" + ratio_summary(rows))
    targets = {}
    rtol = summary["cases"].get("chain10", {}).get("rtol", {}).get("1e-06")
    if args.quick or rtol is None:
        print("\nIssue targets (10-link chain): not measured (run without --quick, with chain10)")
    else:
        frame = frame_target(rtol)
        residual = residual_target(rtol)
        run10 = next(r for r in rows if r["model"] == "chain, 10 links" and r["target"] == "1e-06"
                     and r["engine"] == "rigidlab")
        targets = {"frame": frame, "residual": residual, "run_10s_ms_per_frame": run10["cpu_s"] / (T_END * FPS) * 1e3}
        print(f"\nIssue targets (10-link chain, rtol {rtol:.2g} found for 1e-6):")
        print(f"- one 60 Hz frame (16.7 ms simulated) at <= 1e-6 error: {frame['min_ms']:.2f} ms CPU min, "
              f"{frame['median_ms']:.2f} ms median over 60-frame chunks from t = 3 s (whole 10 s run: "
              f"{targets['run_10s_ms_per_frame']:.2f} ms per frame, error {run10['error_m']:.1e} m); target <= "
              f"{FRAME_TARGET_MS:g} ms: {'met' if frame['min_ms'] <= FRAME_TARGET_MS else 'NOT met'}; "
              f"one simulate call per frame instead: {frame['single_call_min_ms']:.2f} ms")
        print(f"- position residual over T = {residual['t_end']:g} s: max |C| = {residual['residual']:.1e} "
              f"(velocity {residual['velocity_residual']:.1e}); target <= {RESIDUAL_TARGET:g}: "
              f"{'met' if residual['residual'] <= RESIDUAL_TARGET else 'NOT met'}")
    elapsed = time.perf_counter() - started
    print(f"\n(bench wall time {elapsed:.0f} s)")
    OUT.mkdir(exist_ok=True)
    clean = [{k: v for k, v in r.items()} for r in rows]
    (OUT / "multibody.json").write_text(json.dumps(
        {"date": datetime.date.today().isoformat(), "machine": machine, "versions": versions, "quick": args.quick,
         "models": list(models), "t_end": T_END, "fps": FPS, "targets": list(TARGETS), "peer_cpu_cap_s": PEER_CPU_CAP,
         "rows": clean, "summary": summary, "issue_targets": targets, "wall_s": elapsed}, indent=1))
    print(f"wrote {OUT / 'multibody.json'}")


if __name__ == "__main__":
    main()
