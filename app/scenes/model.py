"""Model scene: a user's own mechanism, named with ``rigidlab serve --model PATH``, simulated and its modes shown.

One scene class per model file (:func:`model_scene_class`), titled by the
file's name; the files are loaded and checked at start
(:func:`rigidlab.app.model_file.load_model_file`), so a browser can never choose a
path. The scene is a :class:`~rigidlab.app.scenes._simulation.SimulationScene`:

* **Parameters** -- each entry of the file's ``PARAMETERS`` is a validated
  slider; a change builds the System again (on the executor).
* **Simulation** -- :meth:`rigidlab.core.multibody.System.simulate` in chunks of 1 s
  from the state the file builds (or from the equilibrium displaced along the
  chosen mode); the energy, the constraint residual ``max |C|`` and the joint
  reactions ``|F|`` (from the multipliers) are plotted live, exported as CSV.
* **Modes** -- :func:`rigidlab.core.modal.linearize` about the built state when it is
  an equilibrium or steady motion, else about the nearest static equilibrium
  (:meth:`~rigidlab.core.multibody.System.equilibrium`); the table of modes (Hz, rad/s,
  ξ, stability) is the mode picker, the chosen mode moves with the joints
  closed (:func:`rigidlab.app.scenes._modal_view.animate_group`) beside a translucent
  ghost of the equilibrium, the eigenvalues are drawn in the complex plane
  and, with ``SWEEP``, the modes over the swept parameter are computed in the
  background (:func:`rigidlab.core.modal.sweep`) with a progress bar. CSV and JSON
  export of the modes.

Drawing: a URDF's visual meshes (STL, OBJ, DAE, GLB through trimesh, and its
box / cylinder / sphere primitives) and an MJCF's geoms (primitives and
meshes, as MuJoCo compiled them) are drawn on their bodies; every other
body is drawn as the uniform box of the same mass and principal moments (a
rod when two of its edges are alike and the third three times longer);
revolute, prismatic and cylindrical joints are short cylinders on their axes,
the other joints balls; spring-dampers are zigzags.

All solving, animating and simulating runs on the app's executor; the jobs
take the file's path and SHA-256 and load it in the worker (cached there).
The shareable state records the file's name and SHA-256 and a state made for
another model is refused.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import os
import time
import warnings
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from rigidlab.app.controls import Choice, Slider, Toggle
from rigidlab.app.model_file import ModelFile, ModelFileError, load_model_file
from rigidlab.app.nodes import set_pose
from rigidlab.app.readout import one_digit, significant
from rigidlab.app.scenes._bodies import Parts, PartsView, Placed
from rigidlab.app.scenes._modal_view import (CURVE_COLORS, Clip, MAX_MODES, MODE_OPTIONS, ModalResults, ModeChoice,
                                             ProgressBar, SolutionArrays, SweepRun, advance, animate_group,
                                             campbell_chart, complex_plane_svg, mark_campbell, mark_root_locus,
                                             mode_groups, mode_label, mode_status, modes_table, remember, ro,
                                             root_locus_chart, send_mode_options, set_label, sig, solution_arrays)
from rigidlab.app.scenes._plots import Table, log10_floor
from rigidlab.app.scenes._simulation import PlotSpec, SimulationScene
from rigidlab.app.scenes._svg import FONT, PRESENTER_FONT, Chart
from rigidlab.core import RigidModeWarning

__all__ = ["ALONG_MODE", "AS_BUILT", "Clip", "Key", "MODE_VIEW", "ModelScene", "SIM_VIEW", "Solution",
           "model_scene_class", "model_scene_classes"]

#: The *View* choice: the chosen mode animated beside the equilibrium ghost, or the simulation playing.
MODE_VIEW, SIM_VIEW = "Mode shape", "Simulation"
#: Where the simulation starts: the state the file builds, or the equilibrium displaced along the chosen mode.
AS_BUILT, ALONG_MODE = "as the file builds it", "equilibrium + the chosen mode"
#: Samples per simulated second, and the sweep's values.
SAMPLES_PER_SECOND = 60
SWEEP_VALUES = 31
#: Joints whose reactions are plotted (the first ones).
MAX_REACTIONS = 6
_RTOL = 1e-8

_BODY_COLOR = (205, 172, 110)
_ROD_COLOR = (96, 108, 128)
_JOINT_COLOR = (40, 40, 48)
_SPRING_COLOR = (150, 120, 60)
_GHOST_COLOR = (140, 170, 255)
_GHOST_OPACITY = 0.35
_MESH_COLOR = (178, 184, 196)


# -- the model in a worker -------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Key:
    """What a job needs to build the System: the model file (path and SHA-256) and the parameter values."""

    path: str
    sha256: str
    values: tuple[tuple[str, float], ...] = ()

    @property
    def name(self) -> str:
        return Path(self.path).name

    def with_value(self, name: str, value: float) -> Key:
        return dataclasses.replace(self, values=tuple((k, float(value) if k == name else v) for k, v in self.values))


@functools.lru_cache(maxsize=4)
def _model_file(path: str, sha256: str) -> ModelFile:
    """The model file, loaded once per worker process; refused when it changed since the server started."""
    model = load_model_file(path)
    if model.sha256 != sha256:
        raise ValueError(f"{Path(path).name}: the file changed on disk after the server started; restart the "
                         "server to use the new file")
    return model


def _build(key: Key) -> Any:
    """A new System of ``key`` (the file's ``build`` with the parameter values)."""
    return _model_file(key.path, key.sha256).build(**dict(key.values))


@dataclasses.dataclass(frozen=True)
class Look:
    """What is drawn of a System (body frames, metres; read-only arrays).

    parts : the inertia shapes of the bodies without a mesh, the joint markers and the springs
    center, size : (3,) the middle of the model and its size (m), the camera's and the amplitude's scale
    """

    parts: Parts
    center: np.ndarray
    size: float


def _equivalent_shape(mass: float, inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(edges, axes)`` of the uniform box with ``mass`` and the principal moments of ``inertia`` (3, 3) about
    the centre of mass: ``a^2 = 6 (J2 + J3 - J1) / m`` for the edge along principal axis 1 (columns of
    ``axes``, body frame)."""
    J = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(J)
    if mass <= 0.0:
        return np.zeros(3), axes
    total = moments.sum()
    edges = np.sqrt(np.maximum(6.0 * (total - 2.0 * moments) / mass, 0.0))
    return edges, axes


def look(system: Any, meshed: frozenset[int] = frozenset()) -> Look:
    """The drawing of ``system`` at its current state; bodies in ``meshed`` (indices) have meshes of their own."""
    state = system.state
    points = [state.position(b) for b in system.bodies] + [j.point for j in system.joints]
    points += [np.asarray(s.point_i, dtype=float) for s in system.spring_dampers]
    cloud = np.array(points, dtype=float).reshape(-1, 3) if points else np.zeros((1, 3))
    lo, hi = cloud.min(axis=0), cloud.max(axis=0)
    size = max(float(np.linalg.norm(hi - lo)), 0.2)
    rods, balls, boxes, springs = [], [], [], []
    for b in system.bodies:
        if b.index in meshed:
            continue
        edges, axes = _equivalent_shape(float(b.mass), np.asarray(b.inertia, dtype=float))
        thin = 0.02 * size
        if not np.any(edges > 1e-9):  # a point mass
            balls.append((b.index, (0.0, 0.0, 0.0), 0.03 * size))
            continue
        edges = np.maximum(edges, thin)
        order = np.argsort(edges)
        aligned = np.allclose(np.abs(axes), np.eye(3)[:, np.argmax(np.abs(axes), axis=0)], atol=1e-6)
        rod_like = edges[order[2]] > 3.0 * edges[order[1]] and edges[order[1]] < 1.5 * edges[order[0]]
        if aligned and not rod_like:
            perm = np.argmax(np.abs(axes), axis=0)  # principal axis k lies along body axis perm[k]
            size_body = np.zeros(3)
            size_body[perm] = edges
            boxes.append((b.index, size_body))
        else:  # a rod along the longest principal axis, its radius from the other two edges
            axis = axes[:, order[2]] * edges[order[2]] / 2.0
            rods.append((b.index, -axis, axis, max(0.25 * (edges[order[0]] + edges[order[1]]), thin / 2)))
    marker = 0.045 * size
    for joint in system.joints:
        body = joint.body_j if not joint.body_j.is_ground else joint.body_i
        point = np.asarray(joint.point, dtype=float)
        if body.is_ground:
            continue
        A, R = state.rotation_matrix(body), state.position(body)
        u = A.T @ (point - R)
        if joint.kind in ("revolute", "prismatic", "cylindrical") and joint.axis is not None:
            h = A.T @ np.asarray(joint.axis, dtype=float) * marker
            rods.append((body.index, u - h, u + h, 0.45 * marker))
        else:
            balls.append((body.index, u, 0.6 * marker))

    def local(body: Any, p: Any) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        if body.is_ground:
            return p
        return state.rotation_matrix(body).T @ (p - state.position(body))

    for s in system.spring_dampers:
        springs.append((s.body_i.index, local(s.body_i, s.point_i), s.body_j.index, local(s.body_j, s.point_j)))
    parts = Parts.build(rods=rods, balls=balls, boxes=boxes, springs=springs, spring_width=0.02 * size)
    return Look(parts, ro(0.5 * (lo + hi)), size)


@dataclasses.dataclass(frozen=True)
class _Reference:
    """The System at its reference (equilibrium or steady motion), linearized (worker only)."""

    system: Any
    modes: Any
    groups: tuple[tuple[int, ...], ...]
    n_dof: int
    how: str  # how the reference was found (Markdown)


@functools.lru_cache(maxsize=8)
def _reference(key: Key) -> _Reference:
    """The linear model of ``key`` about the built state when it is an equilibrium or a steady motion, else about
    the nearest static equilibrium (cached: once per parameter set in each worker)."""
    from rigidlab.core.modal import linearize

    system = _build(key)
    try:
        lin = linearize(system)
        how = "about the state the file builds (an equilibrium or a steady motion)"
    except ValueError:
        system.equilibrium()
        lin = linearize(system)
        how = "about the static equilibrium nearest to the state the file builds"
    modes = lin.modes()
    groups = mode_groups(modes, rigid=True)
    # rigid-body modes last, and once: a degree of freedom without stiffness has the double eigenvalue s = 0
    # (two real eigenvalues, a displacement and a drift), of which one is shown
    rigid = [g for g in groups if modes.rigid[g[0]]]
    flexible = [g for g in groups if not modes.rigid[g[0]]]
    return _Reference(system, modes, tuple(flexible + rigid[::2]), int(lin.n_dof), how)


@dataclasses.dataclass(frozen=True)
class Solution(SolutionArrays):
    """The eigen solution of one parameter set, as the panel shows it (see
    :class:`rigidlab.app.scenes._modal_view.SolutionArrays`; ``key`` the :class:`Key`, ``groups`` includes the
    rigid-body modes, animating one warns; global coordinates).

    Attributes
    ----------
    how : how the reference was found (Markdown)
    """

    how: str


@dataclasses.dataclass(frozen=True)
class _ModalResult:
    solution: Solution
    clip: Clip
    seconds: float


def _solution(key: Key, ref: _Reference, parts: Parts) -> Solution:
    m = ref.modes
    n = m.embedding.n_bodies
    R = m.embedding.q0[: 3 * n].reshape(1, n, 3)
    P = m.embedding.q0[3 * n:].reshape(1, n, 4)
    doc = {"format": "rigidlab modes 1", "model": key.name, "sha256": key.sha256, "parameters": dict(key.values)}
    return Solution(**solution_arrays(key, m, ref.groups, ref.n_dof, parts, R, P, doc), how=ref.how)


def _modal_job(key: Key, meshed: frozenset[int], mode: int, fraction: float) -> _ModalResult:
    """Solve ``key`` (cached in the worker) and animate its mode ``mode`` (1-based, clamped)."""
    cpu0 = time.thread_time()
    ref = _reference(key)
    drawn = look(ref.system, meshed)
    solution = _solution(key, ref, drawn.parts)
    if not solution.groups:
        raise ValueError(f"{key.name}: no mode (the model has no degree of freedom)")
    mode = min(max(int(mode), 1), min(len(solution.groups), MAX_MODES))
    group = solution.groups[mode - 1]
    a = animate_group(ref.modes, ref.system, group, mode, fraction, drawn.size)
    clip = Clip.of(key, mode, fraction, a, a.positions, a.orientations, drawn.parts,
                   rigid=bool(ref.modes.rigid[group[0]]))
    return _ModalResult(solution, clip, time.thread_time() - cpu0)


def _sweep_model(key: Key, name: str, value: float) -> Any:
    """The linear model of ``key`` with parameter ``name`` at ``value`` (a sweep's ``build``; picklable)."""
    from rigidlab.core.modal import linearize

    system = _build(key.with_value(name, value))
    try:
        return linearize(system)
    except ValueError:
        system.equilibrium()
        return linearize(system)


# -- the simulation in a worker --------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Chunk:
    """One second of the motion: body poses, the parts placed, the table (energy, max |C|, |F| per joint)."""

    k: int
    t: np.ndarray  # (n,) s
    R: np.ndarray  # (n, b, 3) float32
    P: np.ndarray  # (n, b, 4) float32
    parts: Parts
    placed: Placed
    table: Table
    final_state: Any  # core's RunState
    energy0: float
    key: Key
    joint_names: tuple[str, ...]
    cpu_seconds: float
    worker: int


@functools.lru_cache(maxsize=4)
def _simulated_system(key: Key) -> Any:
    return _build(key)


def _start_state(key: Key, mode: int, fraction: float) -> Any:
    """The equilibrium displaced along mode ``mode`` (at rest), as a RunState any System of ``key`` runs from."""
    from rigidlab.core.multibody import RunState

    ref = _reference(key)
    if not ref.groups:
        return None
    mode = min(max(int(mode), 1), min(len(ref.groups), MAX_MODES))
    j = ref.groups[mode - 1][0]
    n = ref.modes.embedding.n_bodies
    shape = ref.modes.body_shapes(ref.system)[j]
    size = look(ref.system).size
    amplitude = fraction * (size if int(np.argmax(np.abs(shape))) < 3 * n else 1.0)
    for _ in range(4):
        try:
            with warnings.catch_warnings():  # (the start pose along a rigid-body mode: the table says so)
                warnings.simplefilter("ignore", RigidModeWarning)
                pose = ref.modes.animate(ref.system, j, [0.0], amplitude=amplitude)
            break
        except Exception:
            amplitude *= 0.5
    else:
        raise ValueError(f"amplitude: the constraints cannot be met along mode {mode}; choose a smaller amplitude")
    q = np.concatenate([pose.positions[0].ravel(), pose.orientations[0].ravel()])
    return RunState(0.0, q, np.zeros(6 * n))


def _sim_chunk(key: Key, meshed: frozenset[int], start: str, mode: int, fraction: float, k: int,
               previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` (1 s) of the motion of ``key``, continued from chunk ``k - 1`` (``previous``)."""
    cpu0 = time.thread_time()
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: chunk {k} continues from chunk {k - 1}, which was not given")
    system = _simulated_system(key)
    t = np.linspace(float(k), k + 1.0, SAMPLES_PER_SECOND + 1)
    initial = previous.final_state if previous is not None else (
        _start_state(key, mode, fraction) if start == ALONG_MODE else None)
    traj = system.simulate(t, initial=initial, rtol=_RTOL, atol=_RTOL * 1e-2)
    n = traj.n_bodies
    R = traj.q[:, : 3 * n].reshape(-1, n, 3)
    P = traj.q[:, 3 * n:].reshape(-1, n, 4)
    joints = system.joints[:MAX_REACTIONS]
    forces = [np.linalg.norm(traj.reaction(jt)[0], axis=1) for jt in joints]
    columns = np.column_stack([traj.energy, traj.residual_position, *forces]) if forces else np.column_stack(
        [traj.energy, traj.residual_position])
    energy0 = previous.energy0 if previous is not None else float(traj.energy[0])
    parts = previous.parts if previous is not None else look(system, meshed).parts
    return _Chunk(k, traj.t, ro(R, np.float32), ro(P, np.float32), parts, parts.place(R, P),
                  Table.build(traj.t, columns), traj.final_state, energy0, key, tuple(jt.name for jt in joints),
                  time.thread_time() - cpu0, os.getpid())


# -- meshes of a URDF (read at start, in the server's process) -------------------------------------------
def _rgba(visual: Any, materials: dict[str, Any]) -> tuple[int, int, int]:
    material = getattr(visual, "material", None)
    color = getattr(material, "color", None) if material is not None else None
    if color is None and material is not None and material.name in materials:
        color = getattr(materials[material.name], "color", None)
    rgba = getattr(color, "rgba", None) if color is not None else None
    if rgba is None:
        return _MESH_COLOR
    return tuple(int(round(255 * min(max(float(c), 0.0), 1.0))) for c in list(rgba)[:3])


def urdf_meshes(path: Path, system: Any) -> tuple[dict[int, list], list]:
    """The visual meshes of the URDF ``path`` on the bodies of ``system`` (built from it at its pose):
    ``({body index: [(vertices, faces, rgb), ...]}, [ground meshes])``, vertices in the body frame (global for
    the ground), float32.

    Raises
    ------
    ModelFileError
        Naming the file and the link for a mesh file that is missing or that trimesh cannot read.
    """
    import trimesh
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(path), build_scene_graph=False, build_collision_scene_graph=False,
                              load_meshes=False, load_collision_meshes=False)
    robot = urdf.robot
    parent = {j.child: j for j in robot.joints}
    bodies = {b.name: b for b in system.bodies}
    materials = {m.name: m for m in robot.materials or []}
    frames: dict[str, np.ndarray] = {}

    def frame(name: str) -> np.ndarray:  # the link's global frame at the pose (the joints at zero)
        if name not in frames:
            j = parent.get(name)
            origin = np.eye(4) if j is None or j.origin is None else np.asarray(j.origin, dtype=float)
            frames[name] = origin if j is None else frame(j.parent) @ origin
        return frames[name]

    def owner(name: str) -> Any:  # the body a link was lumped into (None: the ground)
        while name not in bodies:
            j = parent.get(name)
            if j is None:
                return None
            name = j.parent
        return bodies[name]

    state = system.state
    on_bodies: dict[int, list] = collections.defaultdict(list)
    ground: list = []
    for link in robot.links:
        for visual in link.visuals or []:
            g = visual.geometry
            if g is None:
                continue
            if g.mesh is not None:
                filename = g.mesh.filename
                if filename.startswith("package://") or filename.startswith("file://"):
                    filename = filename.split("://", 1)[1]
                mesh_path = (path.parent / filename).resolve()
                if not mesh_path.is_file():
                    raise ModelFileError(f"{path}: <link name={link.name!r}>: mesh file {g.mesh.filename!r} not "
                                         "found")
                try:
                    mesh = trimesh.load(str(mesh_path), force="mesh")
                except Exception as exc:
                    raise ModelFileError(f"{path}: <link name={link.name!r}>: mesh {g.mesh.filename!r} cannot be "
                                         f"read ({type(exc).__name__}: {exc})") from None
                if g.mesh.scale is not None:
                    mesh.apply_scale(np.broadcast_to(np.asarray(g.mesh.scale, dtype=float), (3,)))
            elif g.box is not None:
                mesh = trimesh.creation.box(extents=np.asarray(g.box.size, dtype=float))
            elif g.cylinder is not None:
                mesh = trimesh.creation.cylinder(radius=float(g.cylinder.radius), height=float(g.cylinder.length),
                                                 sections=24)
            elif g.sphere is not None:
                mesh = trimesh.creation.icosphere(subdivisions=2, radius=float(g.sphere.radius))
            else:
                continue
            T = frame(link.name) @ (np.eye(4) if visual.origin is None else np.asarray(visual.origin, dtype=float))
            v = np.asarray(mesh.vertices, dtype=float) @ T[:3, :3].T + T[:3, 3]
            body = owner(link.name)
            if body is not None:
                v = (v - state.position(body)) @ state.rotation_matrix(body)
            entry = (v.astype(np.float32), np.asarray(mesh.faces, dtype=np.uint32), _rgba(visual, materials))
            (ground if body is None else on_bodies[body.index]).append(entry)
    return dict(on_bodies), ground


def mjcf_meshes(path: Path, system: Any) -> tuple[dict[int, list], list]:
    """The geoms of the MJCF ``path`` (boxes, spheres, capsules, cylinders, ellipsoids, meshes; planes and
    height fields left out) on the bodies of ``system`` (built from it at ``qpos0``), as :func:`urdf_meshes`
    gives them: a MuJoCo body belongs to the System body of its own name, or of its nearest ancestor's."""
    import mujoco
    import trimesh

    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    bodies = {b.name: b for b in system.bodies}
    state = system.state
    G = mujoco.mjtGeom

    def owner(b: int) -> Any:
        while b > 0:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            if name in bodies:
                return bodies[name]
            b = int(model.body_parentid[b])
        return None

    on_bodies: dict[int, list] = collections.defaultdict(list)
    ground: list = []
    for g in range(model.ngeom):
        kind, size = int(model.geom_type[g]), np.asarray(model.geom_size[g], dtype=float)
        if kind == G.mjGEOM_BOX:
            mesh = trimesh.creation.box(extents=2.0 * size)
        elif kind == G.mjGEOM_SPHERE:
            mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
        elif kind == G.mjGEOM_ELLIPSOID:
            mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
            mesh.apply_scale(size)
        elif kind == G.mjGEOM_CAPSULE:
            mesh = trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[12, 12])
        elif kind == G.mjGEOM_CYLINDER:
            mesh = trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=24)
        elif kind == G.mjGEOM_MESH:
            m = int(model.geom_dataid[g])
            v0, nv = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
            f0, nf = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
            mesh = trimesh.Trimesh(np.asarray(model.mesh_vert[v0:v0 + nv], dtype=float),
                                   np.asarray(model.mesh_face[f0:f0 + nf], dtype=np.int64), process=False)
        else:  # a plane or a height field: the floor, not a body
            continue
        A = np.asarray(data.geom_xmat[g], dtype=float).reshape(3, 3)
        v = np.asarray(mesh.vertices, dtype=float) @ A.T + np.asarray(data.geom_xpos[g], dtype=float)
        body = owner(int(model.geom_bodyid[g]))
        if body is not None:
            v = (v - state.position(body)) @ state.rotation_matrix(body)
        rgb = tuple(int(round(255 * min(max(float(c), 0.0), 1.0))) for c in model.geom_rgba[g][:3])
        entry = (v.astype(np.float32), np.asarray(mesh.faces, dtype=np.uint32), rgb)
        (ground if body is None else on_bodies[body.index]).append(entry)
    return dict(on_bodies), ground


# -- the sweep ---------------------------------------------------------------------------------------------
def sweep_charts(result: Any, x_label: str) -> dict[float, tuple[Chart, Chart]]:
    """The sweep ``result`` (:class:`rigidlab.core.modal.SweepResult`) drawn per font size (normal and presenter
    view) off the loop thread: ``{font: (campbell, root_locus)}``, the modes' frequencies over the swept
    parameter (:func:`rigidlab.app.scenes._modal_view.campbell_chart`) and the eigenvalues in the complex plane
    across the sweep (:func:`rigidlab.app.scenes._modal_view.root_locus_chart`)."""
    return {font: (campbell_chart(result.values, result.eigenvalues, result.rigid, x_label, font=font),
                   root_locus_chart(result.eigenvalues, result.rigid, font=font)) for font in (FONT, PRESENTER_FONT)}


def _sweep_finish(run: SweepRun, result: Any, executor: Any, *, x_label: str) -> tuple[Any, dict]:
    return result, sweep_charts(result, x_label)


class ModelScene(SimulationScene):
    """The scene of one model file (a subclass per file: :func:`model_scene_class`)."""

    name: ClassVar[str] = ""  # set per file
    title: ClassVar[str] = ""
    order: ClassVar[int] = 0
    #: Set per file by :func:`model_scene_class`.
    model: ClassVar[ModelFile]
    meshes: ClassVar[dict[int, list]] = {}
    ground_meshes: ClassVar[list] = []
    capacity: ClassVar[tuple[int, int, int, int]] = (8, 8, 8, 8)
    joint_names: ClassVar[tuple[str, ...]] = ()
    chunk_time: ClassVar[float] = 1.0
    help: ClassVar[str] = (
        "Your model file, named on the command line (`rigidlab serve --model PATH`; the browser cannot choose "
        "a file), built by its `build()` with the *Parameters* sliders; the first line below the title names "
        "the file, its SHA-256, the degrees of freedom and how the modes were found. *View* shows one of two "
        "things in the 3-D view:\n\n"
        "- **Mode shape**: the System linearized (`rigidlab.core.modal.linearize`, Eqs. 8.110-8.112) about "
        "the state the file builds when it is an equilibrium or a steady motion, else about the nearest static "
        "equilibrium. The chosen mode moves as q0 + a Re(S e^(st)) (Eqs. 8.125-8.129), every sample projected "
        "back onto the constraints by Newton, so the joints stay closed at any amplitude; one period takes "
        "*Seconds per cycle* on screen (a damped or growing mode over several periods, so its envelope shows). "
        "a is the largest displacement: the amplitude times the model's size (m) for a translation, in rad for "
        "a rotation. The translucent **ghost** is the equilibrium; the label above the model names the mode "
        "and its frequency. A rigid-body mode (s = 0, listed last) has no vibration: it is shown as its shape "
        "swinging, with a warning.\n"
        "- **Simulation**: `System.simulate` (DOP853, rtol 1e-8, every step projected back onto C = 0) in "
        "chunks of 1 s, from the state the file builds or from the equilibrium displaced along the chosen "
        "mode (*Start*). Its plots, shown in this view only: the energy change E − E0 (zero but for the "
        "integrator's error when nothing dissipates), log10 max |C| against the bound 1e-8, and the joints' "
        "reaction forces |F| (from the multipliers, −Dᵀλ of each joint's rows). *Download CSV* exports the "
        "plotted window.\n\n"
        "The plots panel, in both views: the **table** of modes (the *Mode* dropdown lists its rows): the "
        "damped frequency f = |Im s|/2π, ω_n = |s| (Eq. 8.130), ξ = −Re s/|s| (Eq. 8.131), s and the "
        "stability (Re s < 0 damped, = 0 neutral, > 0 unstable); the **complex plane**: every eigenvalue "
        "(teal damped, blue neutral, orange unstable, hollow grey rigid), the chosen mode ringed, the unstable "
        "half shaded; with `SWEEP` in the file, the **sweep** over that parameter, computed in the background "
        "and tracked by shape (`rigidlab.core.modal.sweep`): the modes' frequencies over it (a Campbell "
        "diagram when it is a spin) and the root locus, the eigenvalues in the complex plane across the "
        "sweep, purple marking the value in use.\n\n"
        "**Bodies**: a URDF's visual meshes or an MJCF's geoms where the file has them, else the uniform box "
        "(or rod) with the body's mass and principal moments; joints as small cylinders on their axes "
        "(revolute, prismatic, cylindrical) or balls; springs as zigzags. *Export* gives the modes (CSV, JSON "
        "with the file's name, SHA-256 and parameters)."
    )

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.params_key: Key | None = None
        self.solution: Solution | None = None
        self.clip: Clip | None = None
        self.setup: _Chunk | None = None
        self.max_residual = 0.0
        self.solves = 0
        self.jobs_submitted = 0
        self.sweep_result: Any = None
        self._sweep_key: Key | None = None
        self._sweep_seconds = 0.0
        self._sweep_charts: dict[float, tuple[Chart, Chart]] = {}
        self._sweeps: collections.OrderedDict[Key, tuple[Any, float, dict]] = collections.OrderedDict()
        self._sweep_errors: set[Key] = set()
        self._run: SweepRun | None = None
        self._results = ModalResults(24)
        self._staged: collections.deque = collections.deque()
        self._phase = 0.0
        self._mode_drawn: tuple[int, int] | None = None
        self._view = MODE_VIEW
        self._warned_rigid: set[tuple[Key, int]] = set()
        self._solve_seconds = 0.0
        self._failed: tuple[Key, int, float] | None = None
        self._shown_parts: Parts | None = None
        self._last_dt = 0.0

    # -- what the model file gives -------------------------------------------------------------------------
    @classmethod
    def parameter_key(cls, name: str) -> str:
        return f"param_{name}"

    def key_for(self, values: dict[str, Any]) -> Key:
        m = self.model
        return Key(str(m.path), m.sha256, tuple((p.name, float(values[self.parameter_key(p.name)]))
                                               for p in m.parameters))

    @property
    def meshed(self) -> frozenset[int]:
        return frozenset(self.meshes)

    def camera_view(self) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
        return self.camera_position, self.camera_look_at

    # -- state ------------------------------------------------------------------------------------------
    def extra_state(self) -> dict[str, Any]:
        return {"model": {"file": self.model.name, "sha256": self.model.sha256}}

    def check_state(self, state: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
        if state.get("scene") == self.name:
            made = state.get("model")
            ours = {"file": self.model.name, "sha256": self.model.sha256}
            if made != ours:
                what = (f"{made.get('file')!r} (sha256 {str(made.get('sha256'))[:12]}…)" if isinstance(made, dict)
                        else "no model file")
                raise ValueError(f"state: made for {what}, not for this model {ours['file']!r} (sha256 "
                                 f"{ours['sha256'][:12]}…)")
        return super().check_state(state)

    def load_extra_state(self, extra: dict[str, Any]) -> list[str]:
        return [f"{key!r}: not part of this scene's state" for key in extra if key != "model"]

    def values_refusal(self, values: dict[str, Any]) -> str | None:
        try:
            _build(self.key_for(values))
        except (ValueError, ModelFileError) as exc:
            return f"invalid parameters: {exc}"
        return None

    # -- the simulation layer -------------------------------------------------------------------------------
    def job(self, inputs: Any, segment: Any) -> Any:
        values = dataclasses.asdict(inputs)
        return functools.partial(_sim_chunk, self.key_for(values), self.meshed, values["start"],
                                 int(values["mode"]), float(values["amplitude"]))

    def build_nodes(self) -> None:
        scene, root = self.target.scene, self.root
        self.add_ground_grid(width=max(4.0, 6 * self.size), height=max(4.0, 6 * self.size),
                             position=(float(self.camera_look_at[0]), float(self.camera_look_at[1]), self.floor),
                             cell_size=0.25, section_size=1.0)
        colors = np.array([_ROD_COLOR, (178, 184, 196)] * (self.capacity[0] // 2 + 1), dtype=np.uint8)
        self.live = PartsView(scene, f"{root}/live", capacity=self.capacity, rod_colors=colors[: self.capacity[0]],
                              ball_color=_JOINT_COLOR, box_color=_BODY_COLOR, spring_color=_SPRING_COLOR)
        self.ghost = PartsView(scene, f"{root}/ghost", capacity=self.capacity, rod_colors=_GHOST_COLOR,
                               ball_color=_GHOST_COLOR, box_color=_GHOST_COLOR, spring_color=_GHOST_COLOR,
                               opacity=_GHOST_OPACITY, spring_thickness=1.5)
        self.ghost.frame.visible = False
        self.mesh_frames: dict[int, Any] = {}
        self.ghost_frames: dict[int, Any] = {}
        for b, meshes in self.meshes.items():
            self.mesh_frames[b] = scene.add_frame(f"{root}/live/body{b}", show_axes=False)
            self.ghost_frames[b] = scene.add_frame(f"{root}/ghost/body{b}", show_axes=False)
            for i, (v, f, rgb) in enumerate(meshes):
                scene.add_mesh_simple(f"{root}/live/body{b}/mesh{i}", v, f, color=rgb)
                scene.add_mesh_simple(f"{root}/ghost/body{b}/mesh{i}", v, f, color=_GHOST_COLOR,
                                      opacity=_GHOST_OPACITY, cast_shadow=False)
        for i, (v, f, rgb) in enumerate(self.ground_meshes):
            scene.add_mesh_simple(f"{root}/fixed{i}", v, f, color=rgb)
        self.mode_label = self.add_label(f"{root}/mode_label", "", position=tuple(
            np.add(self.camera_look_at, (0.0, 0.0, 0.75 * self.size))), anchor="bottom-center", scale=1.3)

    def build_controls(self) -> None:
        gui, add = self.target.gui, self.controls.add
        self.legend = self.add_legend((
            (_BODY_COLOR, "bodies: the file's meshes, or the box / rod of their inertia"),
            (_JOINT_COLOR, "joints (cylinders on their axes, balls)"), (_SPRING_COLOR, "springs"),
            (_GHOST_COLOR, "equilibrium (translucent ghost, mode view)"), ((124, 58, 237), "the chosen mode")),
            "Colours:")
        self.mode_status = self.add_readout("Solving…")
        add(Choice("view", "View", options=(MODE_VIEW, SIM_VIEW), default=MODE_VIEW,
                   hint="The chosen mode beside the equilibrium, or the simulation"))
        if self.model.parameters:
            with gui.add_folder("Parameters"):
                for p in self.model.parameters:
                    add(Slider(self.parameter_key(p.name), p.title, min=p.low, max=p.high,
                               step=(p.high - p.low) / 200.0, default=p.default,
                               hint=f"{p.name} of build() in {self.model.name}"))
        with gui.add_folder("Mode"):
            add(ModeChoice("mode", "Mode", options=MODE_OPTIONS, default="1",
                           hint="The mode animated: a row of the table (number · frequency · ξ · stability)"))
            add(Slider("amplitude", "Amplitude", min=0.02, max=1.0, step=0.01, default=0.2,
                       hint="Largest displacement: times the model's size (m) for a translation, rad for a rotation"))
            add(Slider("cycle_seconds", "Seconds per cycle", min=0.5, max=6.0, step=0.1, default=2.0,
                       hint="One period of the mode takes this long on screen"))
            add(Toggle("animate", "Animate", default=True))
            add(Toggle("show_ghost", "Equilibrium ghost", default=True))
        with gui.add_folder("Simulation"):
            add(Choice("start", "Start", options=(AS_BUILT, ALONG_MODE), default=self.default_start,
                       hint="The state the file builds, or the equilibrium displaced along the chosen mode"))
            self.add_playback()
        self.model_info = self.add_readout("")
        with self.plot_area():
            self.table = self.add_readout("")
            with gui.add_folder("Complex plane"):
                self.plane = gui.add_html("")
            with gui.add_folder(f"Sweep over {self.model.sweep}" if self.model.sweep else "Sweep",
                                visible=self.model.sweep is not None):
                self.progress = gui.add_progress_bar(0.0, animated=True, visible=False)
                self._progress = ProgressBar(self.progress)
                self.sweep_caption = self.add_readout("")
                self.sweep_plot = gui.add_html("")
                self.locus_caption = self.add_readout("")
                self.locus_plot = gui.add_html("")
        with gui.add_folder("Export"):
            self.add_download("download_modes_csv", "Modes (CSV)", "modes.csv", self.modes_csv,
                              hint="One row per eigenvalue: s, ω_n, f, ξ, flags and the real shape")
            self.add_download("download_modes_json", "Modes (JSON)", "modes.json", self.modes_json,
                              hint="The model file's name, SHA-256 and parameters, and the modes")

    def plots(self) -> list[PlotSpec]:
        names = self.joint_names[:MAX_REACTIONS]
        specs = [
            PlotSpec("energy", "energy change E − E0", (("E − E0 (J)", "#0f766e"),),
                     lambda t, c: (c[:, 0] - (self.setup.energy0 if self.setup else 0.0),), rescale=True),
            PlotSpec("residual", "constraint residual (log10)", (("log10 max |C|", "#be185d"),
                                                                 ("bound 1e-8", "#888888")),
                     lambda t, c: (log10_floor(c[:, 1]), np.full_like(t, -8.0))),
        ]
        if names:
            specs.append(PlotSpec("reactions", "joint reaction forces |F| (N)", tuple(
                (name, CURVE_COLORS[i % len(CURVE_COLORS)]) for i, name in enumerate(names)),
                lambda t, c: tuple(c[:, 2 + i] if c.shape[1] > 2 + i else np.full_like(t, np.nan)
                                   for i in range(len(names)))))
        return specs

    def csv_header_for(self, inputs: Any) -> str:
        names = self.setup.joint_names if self.setup is not None else self.joint_names[:MAX_REACTIONS]
        return "t (s),E (J),max |C|," + ",".join(f"|F {n}| (N)" for n in names)

    def plot_title(self, spec: PlotSpec) -> str:
        if spec.name == "energy" and self.setup is not None:
            return f"energy change E − E0 (E0 = {significant(self.setup.energy0, 6)} J)"
        return spec.title

    def on_restart(self) -> None:
        self.max_residual = 0.0

    def draw(self, chunk: _Chunk, j: int) -> None:
        if self.setup is None or chunk.key != self.setup.key:
            self.setup = chunk
        self.max_residual = max(self.max_residual, float(chunk.table.columns[j, 1]))
        if self._view != SIM_VIEW:
            return
        self._show_parts(chunk.parts)
        self.live.move(chunk.placed, j)
        for b, node in self.mesh_frames.items():
            set_pose(node, position=chunk.R[j, b], wxyz=chunk.P[j, b])

    def readout_lines(self) -> list[str]:
        chunk = self.last_chunk
        if chunk is None or self.setup is None:
            return []
        j = self.sample_index(chunk)
        e, c = chunk.table.columns[j, 0], chunk.table.columns[j, 1]
        lines = [f"**E** = {significant(e, 5)} J · E − E0 = {one_digit(e - self.setup.energy0)} J",
                 f"**max |C|** = {one_digit(c)} now, {one_digit(self.max_residual)} since t = 0"]
        if chunk.table.columns.shape[1] > 2:
            forces = chunk.table.columns[j, 2:]
            i = int(np.argmax(forces))
            lines.append(f"largest joint force {significant(float(forces[i]), 3)} N ({chunk.joint_names[i]})")
        lines.append(f"{chunk.cpu_seconds:.2f} s CPU per simulated second")
        return lines

    # -- the view ---------------------------------------------------------------------------------------
    def on_frame(self, changed: set[str]) -> None:
        view = self.controls.value("view")
        if view != self._view or self.params_key is None:
            self._set_view(view)
        self.params_key = self.key_for(self.controls.values())
        if "show_ghost" in changed:
            self.ghost.frame.visible = self._view == MODE_VIEW and bool(self.controls.value("show_ghost"))
        if changed & {"cycle_seconds", "animate"}:
            self._stage(self._send_status)

    def _set_view(self, view: str) -> None:
        self._view = view
        sim = view == SIM_VIEW
        self.playback.set_playing(sim)
        with self.target.atomic():
            self.ghost.frame.visible = not sim and bool(self.controls.value("show_ghost"))
            self.mode_label.visible = not sim
            for handle in self.plot_handles.values():  # the motion's plots: nothing to show in the mode view
                if handle.visible != sim:
                    handle.visible = sim
        self._mode_drawn = None
        self._drawn = None  # the simulation's sample is drawn again

    def _show_parts(self, parts: Parts) -> None:
        """Use ``parts`` (their scales) on the live view, when they are not in use already."""
        if self._shown_parts is not parts:
            self.live.show(parts)
            self._shown_parts = parts

    # -- modes, on the loop thread ----------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """A modal job is queued or running."""
        return self._results.job is not None

    @property
    def panel_current(self) -> bool:
        """The panel shows what the scene shows (no update waiting for its frame)."""
        return not self._staged

    @property
    def sweeping(self) -> bool:
        return self._run is not None

    def background(self) -> None:
        key = self.params_key
        if key is None:
            return
        self._collect()
        mode, fraction = int(self.controls.value("mode")), float(self.controls.value("amplitude"))
        shown = self._request((key, mode, fraction))
        self._tend_sweep()
        if self._staged and not shown:
            self._staged.popleft()()
        self._play()

    def _stage(self, fn: Any) -> None:
        if fn not in self._staged:
            self._staged.append(fn)

    def _request(self, want: tuple[Key, int, float]) -> bool:
        want, shown = self._results.lookup(want)
        if shown is not None:
            return self._show(*shown)
        key, mode, fraction = want
        if want == self._failed or not self._results.submit(self.executor, want, _modal_job, key, self.meshed,
                                                            mode, fraction):
            return False
        self.jobs_submitted += 1
        if self.solution is None or self.solution.key != key:
            self.mode_status.content = "Solving…"
        return False

    def _collect(self) -> None:
        taken = self._results.take()
        if taken is None:
            return
        want, result, exc = taken
        if exc is not None:
            self._failed = want
            if want[0] == self.params_key:
                self.notify(f"{self.title}: no modes", f"{type(exc).__name__}: {exc}. Change a parameter to "
                            "try again.", "warning")
                self.mode_status.content = f"No modes for these values: {type(exc).__name__}: {exc}"
            return
        self.solves += 1
        self._solve_seconds = result.seconds

    def _show(self, solution: Solution, clip: Clip) -> bool:
        if solution is self.solution and clip is self.clip:
            return False
        new_solution = solution is not self.solution
        count = min(len(solution.groups), MAX_MODES)
        if solution.key == self.params_key and int(self.controls.value("mode")) > count:
            self.controls.set("mode", str(count))
        self._stage(self._send_status)
        self._stage(self._send_table)
        if new_solution:
            self._stage(self._send_ghost)
            self._stage(self._send_info)
            self._stage(self._send_mode_options)
        self._stage(self._send_plane)
        if new_solution and self.model.sweep is not None:
            self._stage(self._send_sweep)
        self.solution, self.clip = solution, clip
        self._phase = 0.0
        self._mode_drawn = None
        if clip.rigid and (clip.key, clip.mode) not in self._warned_rigid:
            self._warned_rigid.add((clip.key, clip.mode))
            self.notify("Rigid-body mode", f"Mode {clip.mode} is a rigid-body mode (s = 0): a motion without a "
                        "restoring force, not a vibration. It is shown as its shape swinging.", "warning")
        if self._view == MODE_VIEW:
            with self.target.atomic():
                self._draw_mode(clip.still)
                self._label()
        return True

    def _draw_mode(self, i: int) -> None:
        clip, solution = self.clip, self.solution
        self._show_parts(solution.parts)
        self.live.move(clip.placed, i)
        for b, node in self.mesh_frames.items():
            set_pose(node, position=clip.positions[i, b], wxyz=clip.orientations[i, b])
        self._mode_drawn = (id(clip), i)

    def _label(self) -> None:
        set_label(self.mode_label, mode_label(self.solution, self.clip))

    def _play(self) -> None:
        clip = self.clip
        if clip is None or self._view != MODE_VIEW:
            return
        self._phase, i = advance(clip, self._phase, self._last_dt, cycle=float(self.controls.value("cycle_seconds")),
                                 animate=bool(self.controls.value("animate")))
        if self._mode_drawn != (id(clip), i):
            with self.target.atomic():
                self._draw_mode(i)
                if self._mode_drawn is not None and self.mode_label.text == "":
                    self._label()

    def update(self, dt: float) -> None:
        self._last_dt = dt
        super().update(dt)

    # -- the panel -------------------------------------------------------------------------------------
    def _send_ghost(self) -> None:
        solution = self.solution
        if solution is None:
            return
        with self.target.atomic():
            self.ghost.show(solution.parts)
            self.ghost.move(solution.ghost, 0)
            for b, node in self.ghost_frames.items():
                set_pose(node, position=solution.ghost_R[b], wxyz=solution.ghost_P[b])
            self.ghost.frame.visible = self._view == MODE_VIEW and bool(self.controls.value("show_ghost"))

    def _send_status(self) -> None:
        if self.clip is not None and self.solution is not None:
            cycle = float(self.controls.value("cycle_seconds"))
            self.mode_status.content = mode_status(self.solution, self.clip, cycle,
                                                   animate=bool(self.controls.value("animate")))

    def _send_table(self) -> None:
        if self.solution is not None and self.clip is not None:
            self.table.content = modes_table(self.solution, self.clip.mode)

    def _send_info(self) -> None:
        solution = self.solution
        if solution is None:
            return
        n = solution.n_bodies
        values = ", ".join(f"{k} = {significant(v, 4)}" for k, v in solution.key.values)
        values = f": {values}" if values else ""
        self.model_info.content = (
            f"**{self.model.name}** ({self.model.kind}, sha256 {self.model.sha256[:12]}…){values}"
            f"  \n**{solution.n_dof} degrees of freedom** of {n} bod{'y' if n == 1 else 'ies'}; linearized "
            f"{solution.how}; eigenproblem {solution.method}, solved in {self._solve_seconds * 1e3:.0f} ms CPU on "
            "the worker.")

    def _send_mode_options(self) -> None:
        if self.solution is not None:
            send_mode_options(self.controls, self.solution, current=self.solution.key == self.params_key)

    def _send_plane(self) -> None:
        if self.solution is not None and self.clip is not None:
            font = PRESENTER_FONT if self.presenter else FONT
            self.plane.content = complex_plane_svg(self.solution, self.clip.mode, font=font)

    def _send_sweep(self) -> None:
        result = self.sweep_result
        if result is None:
            return
        name = self.model.sweep
        p = next(p for p in self.model.parameters if p.name == name)
        current = dict(self.params_key.values).get(name) if self.params_key is not None else None
        solution = self.solution if self.solution is not None and self.solution.key == self.params_key else None
        campbell, locus = self._sweep_charts[PRESENTER_FONT if self.presenter else FONT]
        if current is not None:
            campbell = mark_campbell(campbell, current, solution)
        if solution is not None:
            locus = mark_root_locus(locus, solution)
        label, unit = p.label or name, f" {p.unit}" if p.unit else ""
        lo, hi = sig(float(result.values[0])), sig(float(result.values[-1]))
        self.sweep_plot.content = campbell.svg()
        self.locus_plot.content = locus.svg()
        self.sweep_caption.content = (f"The modes over {label}: {result.values.size} values from {lo} to {hi}{unit}, "
                                      f"tracked by shape ({self._sweep_seconds:.1f} s in the background); purple: "
                                      "the value in use.")
        self.locus_caption.content = (f"Root locus: the eigenvalues in the complex plane for {label} from {lo} to "
                                      f"{hi}{unit} (small rings: {name} = {lo}); purple: the eigenvalues at the "
                                      "value in use.")

    # -- the sweep -------------------------------------------------------------------------------------
    def _sweep_base(self) -> Key | None:
        name = self.model.sweep
        if name is None or self.params_key is None:
            return None
        return self.params_key.with_value(name, 0.0)

    def _tend_sweep(self) -> None:
        base = self._sweep_base()
        if base is None:
            return
        run = self._run
        if run is not None and run.key != base:
            run.cancel.set()
            self._run = run = None
        if run is not None and run.finished.is_set():
            self._run = None
            if run.outcome is not None:
                result, charts = run.outcome
                remember(self._sweeps, run.key, (result, run.seconds, charts), 8)
            elif run.error is not None:
                self._sweep_errors.add(run.key)
                self.notify("Sweep failed", f"{type(run.error).__name__}: {run.error}", "warning")
            run = None
        done = self._sweeps.get(base)
        if done is not None:
            self._progress.set(None)
            if self.sweep_result is not done[0] or self._sweep_key != self.params_key:
                self.sweep_result, self._sweep_seconds, self._sweep_charts = done
                self._sweep_key = self.params_key
                self._stage(self._send_sweep)
            return
        if run is None and base not in self._sweep_errors:
            p = next(p for p in self.model.parameters if p.name == self.model.sweep)
            label = p.label or p.name
            run = self._run = SweepRun(base, functools.partial(_sweep_model, base, p.name),
                                       np.linspace(p.low, p.high, SWEEP_VALUES), self.executor,
                                       functools.partial(_sweep_finish, x_label=f"{label} ({p.unit})" if p.unit
                                                         else label), name="rigidlab-model-sweep")
            self.sweep_caption.content = f"Computing {run.total} values of {p.name} in the background…"
            self.sweep_plot.content = self.locus_caption.content = self.locus_plot.content = ""
            self.sweep_result = None
        if run is not None:
            self._progress.set(100.0 * run.done / max(run.total, 1))

    def set_active(self, active: bool) -> None:
        super().set_active(active)
        if not active and self._run is not None:  # nothing runs for a scene nobody looks at
            self._run.cancel.set()
            self._run = None

    def close(self) -> None:
        if self._run is not None:
            self._run.cancel.set()
        self._results.cancel()
        super().close()

    # -- export ------------------------------------------------------------------------------------------
    def modes_csv(self) -> bytes:
        """The modes shown, as CSV (:meth:`rigidlab.core.modal.Modes.to_csv`)."""
        if self.solution is None:
            raise ValueError("no modes computed yet")
        return self.solution.csv.encode()

    def modes_json(self) -> bytes:
        """The modes shown, the model file's name, SHA-256 and parameter values, as JSON."""
        if self.solution is None:
            raise ValueError("no modes computed yet")
        return self.solution.json.encode()


def model_scene_class(model: ModelFile, index: int = 0) -> type[ModelScene]:
    """The scene class of ``model`` (a checked model file): named ``model`` (``model-2``, ... for later files),
    titled ``Model: <file name>``, first in the chooser; its controls, camera and drawing made from the System
    the file builds with its defaults.

    Raises
    ------
    ModelFileError
        For a URDF whose visual mesh is missing or unreadable.
    """
    system = model.build()
    meshes, ground = {"urdf": urdf_meshes, "mjcf": mjcf_meshes}.get(model.kind, lambda p, s: ({}, []))(
        model.path, system)
    drawn = look(system, frozenset(meshes))
    counts = drawn.parts.counts
    capacity = tuple(max(2 * c, c + 8) for c in counts)
    center, size = drawn.center, drawn.size
    state = system.state
    lowest = min([float(state.position(b)[2]) for b in system.bodies] + [float(j.point[2]) for j in system.joints],
                 default=0.0)
    try:
        from rigidlab.core.modal import linearize

        linearize(model.build())
        start = ALONG_MODE  # built at rest in equilibrium (or in a steady motion): it would not move
    except Exception:
        start = AS_BUILT
    inputs = dataclasses.make_dataclass(
        "Inputs", [(ModelScene.parameter_key(p.name), float, dataclasses.field(default=p.default))
                   for p in model.parameters]
        + [("start", str, dataclasses.field(default=start)), ("mode", str, dataclasses.field(default="1")),
           ("amplitude", float, dataclasses.field(default=0.2))], frozen=True)
    name = "model" if index == 0 else f"model-{index + 1}"
    attrs = dict(
        name=name, title=f"Model: {model.name}", order=index - 100, model=model, meshes=meshes, ground_meshes=ground,
        capacity=capacity, joint_names=tuple(j.name for j in system.joints), Inputs=inputs, default_start=start,
        size=size, csv_header="t (s)", floor=min(0.0, lowest - 0.1 * size),
        camera_position=tuple(float(x) for x in center + size * np.array([1.0, 1.7, 0.6])),
        camera_look_at=tuple(float(x) for x in center),
    )
    return type(f"ModelScene_{name.replace('-', '_')}", (ModelScene,), attrs)


def model_scene_classes(paths: Any) -> dict[str, type[ModelScene]]:
    """``{name: class}`` of every model file in ``paths`` (loaded and checked; raises ModelFileError)."""
    out = {}
    for k, path in enumerate(paths):
        cls = model_scene_class(load_model_file(path), k)
        out[cls.name] = cls
    return out
