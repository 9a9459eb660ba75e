"""Model files: a :class:`~rigidlab.core.multibody.System` from a URDF (through ``yourdfpy``) or an MJCF (through MuJoCo).

Both loaders build the System at one pose and at rest: every rigid group of
links (links joined by fixed joints, or MuJoCo bodies without joints) becomes
one body with the lumped mass, centre of mass and inertia tensor of its
links (parallel-axis theorem), its frame the frame of the group's first
link; every moving joint becomes a joint of the System at its global point
and axis in that pose. A group fixed to the world becomes part of
``system.ground``. The optional packages are imported only when a loader is
called: ``pip install 'rigidlab[urdf]'`` (yourdfpy) or ``'rigidlab[mjcf]'``
(mujoco).

Every problem with a file is one ``ValueError`` that names the file and the
element (and its line where the parser keeps it).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigidlab.core._validation import real_number, short_repr

__all__ = ["from_mjcf", "from_urdf"]

#: URDF joint types the loader turns into joints (``continuous`` is a revolute joint without limits).
URDF_JOINT_KINDS = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed"}


# --------------------------------------------------------------- lumping
@dataclass
class _Group:
    """Links welded together: one body of the System."""

    name: str
    A: np.ndarray  # (3, 3) global orientation of the body frame (the first link's frame)
    masses: list = field(default_factory=list)  # kg
    centres: list = field(default_factory=list)  # (3,) global centres of mass
    tensors: list = field(default_factory=list)  # (3, 3) global inertia tensors about their own centres
    fixed_to_world: bool = False
    body: Any = None

    def add(self, m: float, c: np.ndarray, J_global: np.ndarray) -> None:
        if m > 0.0 or np.any(J_global):
            self.masses.append(float(m))
            self.centres.append(np.asarray(c, dtype=float))
            self.tensors.append(np.asarray(J_global, dtype=float))

    def lumped(self) -> tuple[float, np.ndarray, np.ndarray]:
        """(mass, global centre of mass, inertia tensor about it in the body frame)."""
        m = float(sum(self.masses))
        if m <= 0.0:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        c = sum(mi * ci for mi, ci in zip(self.masses, self.centres)) / m
        J = np.zeros((3, 3))
        for mi, ci, Ji in zip(self.masses, self.centres, self.tensors):
            d = ci - c
            J += Ji + mi * (float(d @ d) * np.eye(3) - np.outer(d, d))  # parallel-axis theorem
        J_body = self.A.T @ J @ self.A
        return m, c, 0.5 * (J_body + J_body.T)


#: Principal moments of a link within ``SNAP_MOMENT * mass * (1 m)^2`` of zero count as zero: written files
#: carry round-off such as ``ixx="-5.42101e-20"`` or moments ``(0, 0, 4e-18)`` for a point mass of 0.5 kg,
#: which no mass distribution has (a negative moment, a broken triangle inequality); 1e-12 is 1e-6 of the
#: moment of a 1 mm body.
SNAP_MOMENT = 1e-12


def _snap_round_off(J: np.ndarray, m: float) -> np.ndarray:
    """The symmetric tensor ``J`` with principal moments of round-off size (``SNAP_MOMENT``) set to 0."""
    w, V = np.linalg.eigh(J)
    tiny = np.abs(w) <= SNAP_MOMENT * max(m, 0.0)
    if np.any(tiny & (w != 0.0)):
        return (V * np.where(tiny, 0.0, w)) @ V.T
    return J


def _add_groups(system: Any, groups: list[_Group], where: Any) -> None:
    """Add a body per moving group; ``where(group)`` names the file and element for an error."""
    from rigidlab.core.rotations import euler_parameters_from_matrix

    for g in groups:
        if g.fixed_to_world:
            g.body = system.ground
            continue
        m, c, J = g.lumped()
        if not m > 0.0:
            raise ValueError(f"{where(g)}: link {g.name!r} moves (a joint or a floating base carries it) but has no "
                             "mass: give it (or a link fixed to it) an inertial with mass > 0")
        p = euler_parameters_from_matrix(g.A)
        try:
            g.body = system.add_body(g.name, mass=m, inertia=J, position=c, orientation=p)
        except ValueError as exc:
            raise ValueError(f"{where(g)}: link {g.name!r}: {exc}") from None


#: Joints that meet through massless links must meet: lines of joint axes within ``MEET_TOL`` (m) of a common
#: point, axes perpendicular (universal) or parallel (cylindrical) within ``MEET_TOL`` (|cos| or |sin|). Files
#: write their numbers to about 6 digits.
MEET_TOL = 1e-6


def _meeting_point(points: list, axes: list) -> tuple[np.ndarray, float]:
    """The point nearest to the lines ``p + s a`` (least squares) and its largest distance from them."""
    P = [np.eye(3) - np.outer(a, a) for a in axes]
    x = np.linalg.lstsq(np.sum(P, axis=0), np.sum([Pk @ p for Pk, p in zip(P, points)], axis=0), rcond=None)[0]
    return x, max(float(np.linalg.norm(Pk @ (x - p))) for Pk, p in zip(P, points))


def _combined(chain: list) -> tuple[str, np.ndarray, Any, Any] | None:
    """(kind, point, axis, axis_j) of one joint equivalent to ``chain`` (joint records meeting through massless
    frames), or None: two revolute joints with perpendicular axes that intersect (universal), three revolute
    joints whose axes meet at one point and span space (spherical), a revolute and a prismatic joint along one
    line (cylindrical)."""
    kinds = [c[0] for c in chain]
    points = [np.asarray(c[3], dtype=float) for c in chain]
    axes = [np.asarray(c[4], dtype=float) / np.linalg.norm(c[4]) for c in chain]
    if kinds == ["revolute", "revolute"]:
        x, gap = _meeting_point(points, axes)
        if gap <= MEET_TOL and abs(float(axes[0] @ axes[1])) <= MEET_TOL:
            b = axes[1] - float(axes[0] @ axes[1]) * axes[0]  # perpendicular to round-off, as add_joint checks
            return "universal", x, axes[0], b / np.linalg.norm(b)
    if kinds == ["revolute"] * 3:
        x, gap = _meeting_point(points, axes)
        if gap <= MEET_TOL and abs(float(np.linalg.det(np.stack(axes)))) > MEET_TOL:
            return "spherical", x, None, None
    if sorted(kinds) == ["prismatic", "revolute"]:
        r = kinds.index("revolute")
        if float(np.linalg.norm(np.cross(axes[0], axes[1]))) <= MEET_TOL:
            d = points[1 - r] - points[r]
            if float(np.linalg.norm(d - float(d @ axes[r]) * axes[r])) <= MEET_TOL:
                return "cylindrical", points[r], axes[r], None
    return None


def _combine_massless(groups: list, joints: list, where: Any) -> tuple[list, list]:
    """Replace chains of joints through massless groups by one joint; drop massless leaves.

    ``joints``: records ``(kind, group_i, group_j, point, axis, name)``. A moving group without mass whose
    one outgoing joint continues the chain (the virtual links of humanoid hips, MuJoCo bodies with several
    joints) is removed with its joints, which become one universal, spherical or cylindrical joint named
    ``"j1+j2[+j3]"`` (see :func:`_combined`); a massless group that carries nothing (no outgoing joint) is
    left out with its joint. Any other massless moving group is left for :func:`_add_groups` to refuse.
    """
    def massless(g):
        return not g.fixed_to_world and not g.lumped()[0] > 0.0

    out_of: dict[int, list] = {}
    into: dict[int, Any] = {}
    for rec in joints:
        out_of.setdefault(id(rec[1]), []).append(rec)
        into[id(rec[2])] = rec
    dropped: set[int] = set()
    # leaves first (repeatedly: a massless link on a massless link)
    changed = True
    while changed:
        changed = False
        for g in groups:
            if id(g) in dropped or not massless(g) or id(g) not in into:
                continue
            if not [r for r in out_of.get(id(g), []) if id(r[2]) not in dropped]:
                dropped.add(id(g))
                changed = True
    kept_joints = [r for r in joints if id(r[2]) not in dropped]
    result = []
    absorbed: set[int] = set()
    for rec in kept_joints:
        if massless(rec[1]) and id(rec[1]) not in dropped:
            continue  # an inner joint of a chain: handled from the chain's first joint
        chain = [rec]
        while massless(chain[-1][2]):
            nxt = [r for r in out_of.get(id(chain[-1][2]), []) if id(r[2]) not in dropped]
            if len(nxt) != 1 or len(chain) == 3:
                break
            chain.append(nxt[0])
        if len(chain) == 1:
            result.append(rec)
            continue
        combo = _combined(chain)
        if combo is None or massless(chain[-1][2]):
            names = [c[5] for c in chain]
            g = chain[0][2]
            raise ValueError(
                f"{where(g)}: link {g.name!r} has no mass and its joints {names} ({[c[0] for c in chain]}) do not "
                "make one universal (two revolute axes that intersect at a right angle), spherical (three revolute "
                "axes through one point) or cylindrical joint (a revolute and a prismatic joint along one line); "
                "give it an inertial with mass > 0")
        for c in chain[:-1]:
            absorbed.add(id(c[2]))
        kind, point, axis, axis_j = combo
        result.append((kind, chain[0][1], chain[-1][2], point, (axis, axis_j), "+".join(c[5] for c in chain)))
    keep = [g for g in groups if id(g) not in dropped and id(g) not in absorbed]
    return keep, result


def _add_joint(system: Any, kind: str, gi: _Group, gj: _Group, point: Any, axis: Any, name: str) -> None:
    if kind == "universal":
        system.add_joint(kind, gi.body, gj.body, point=point, axis=axis[0], axis_j=axis[1], name=name)
    elif isinstance(axis, tuple):
        system.add_joint(kind, gi.body, gj.body, point=point, axis=axis[0], name=name)
    else:
        system.add_joint(kind, gi.body, gj.body, point=point, axis=axis, name=name)


def _positions(joint_positions: Any, names: set[str], path: str) -> dict:
    if joint_positions is None:
        return {}
    if not isinstance(joint_positions, dict):
        raise ValueError(f"joint_positions: expected a dict joint name -> value or None, got "
                         f"{short_repr(joint_positions)}")
    unknown = sorted(set(joint_positions) - names)
    if unknown:
        raise ValueError(f"joint_positions: {path} has no moving joint named {unknown[0]!r} (moving joints: "
                         f"{sorted(names)})")
    return joint_positions


def _check_path(path: Any) -> str:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path: expected a file name, got {short_repr(path)}")
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"path: {path}: no such file")
    return path


# ------------------------------------------------------------------ URDF
def from_urdf(path: Any, *, fixed_base: bool = True, gravity: Any = (0.0, 0.0, -9.81), joint_positions: Any = None,
              degrees: bool = False):
    """A System from a URDF file (parsed by ``yourdfpy``), at the given joint positions and at rest.

    Each ``<link>`` with an ``<inertial>`` (``origin`` xyz/rpy, ``mass``,
    the ``inertia`` tensor ixx ... izz about the centre of mass in the
    inertial frame) contributes its mass; links joined by ``fixed`` joints
    are lumped into one body (parallel-axis theorem), named after the first
    of them and with its frame. ``revolute`` and ``continuous`` joints become
    revolute joints, ``prismatic`` joints prismatic ones, at the joint
    frame's origin and along its ``axis`` (global in the pose). Joints that
    meet through links without mass (the virtual links of humanoid hips)
    become one joint named ``"j1+j2[+j3]"``: two revolute joints whose axes
    intersect at a right angle a universal joint, three revolute joints
    whose axes pass through one point a spherical joint, a revolute and a
    prismatic joint along one line a cylindrical joint (within ``MEET_TOL``,
    1e-6); a link without mass that carries nothing is left out with its
    joint. Joint limits,
    ``<dynamics>`` (damping, friction), ``<mimic>`` (the joint moves
    independently), transmissions, visuals and collisions are ignored.
    ``planar`` and ``floating`` joints are refused.

    Parameters
    ----------
    path : str or os.PathLike
        The URDF file.
    fixed_base : bool, keyword-only
        True (default): the root link (with every link fixed to it) is the
        ground; False: it is a free body (a floating base; it needs mass).
    gravity : (3,) array_like, keyword-only
        Global gravitational acceleration (m/s^2), +Z up.
    joint_positions : dict or None, keyword-only
        Joint name -> position of a moving joint (rad for revolute and
        continuous joints, m for prismatic ones); a joint not named is at 0
        (the pose the file describes). The System is built in this pose.
    degrees : bool, keyword-only
        True: the positions of revolute and continuous joints are in degrees.

    Returns
    -------
    System
        Bodies named after their links, joints after the URDF joints, all
        at rest.

    Raises
    ------
    ValueError
        One message naming the file and the element (and its line): a
        missing file, malformed XML, a link that is the child of two joints
        or a cycle of joints, a joint naming an unknown link, a ``planar``
        or ``floating`` joint, a moving link without mass whose joints do
        not combine into one, an inertia that is not a valid tensor (moments
        within ``SNAP_MOMENT`` (1e-12) kg m^2 per kg of zero count as zero),
        an unknown joint name in ``joint_positions``.
    """
    from rigidlab.core.multibody import System

    path = _check_path(path)
    if not isinstance(fixed_base, (bool, np.bool_)):
        raise ValueError(f"fixed_base: expected True or False, got {short_repr(fixed_base)}")
    if not isinstance(degrees, (bool, np.bool_)):
        raise ValueError(f"degrees: expected True or False, got {short_repr(degrees)}")
    try:
        from lxml import etree
        import yourdfpy
    except ImportError:  # pragma: no cover - depends on the installation
        raise ValueError("from_urdf: needs the optional package yourdfpy (pip install 'rigidlab[urdf]')") from None
    try:
        root = etree.parse(path, parser=etree.XMLParser(remove_blank_text=True)).getroot()
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno is not None else "?"
        raise ValueError(f"{path}:{line}: malformed XML: {exc.msg}") from None
    if root.tag != "robot":
        raise ValueError(f"{path}:{root.sourceline}: expected a URDF <robot> element, got <{root.tag}>")
    if root.get("name") is None:
        raise ValueError(f"{path}:{root.sourceline}: <robot> without a name")
    if not root.findall("link"):
        raise ValueError(f"{path}:{root.sourceline}: <robot name={root.get('name')!r}> has no <link>")
    lines = {("link", el.get("name")): el.sourceline for el in root.findall("link")}
    lines.update({("joint", el.get("name")): el.sourceline for el in root.findall("joint")})
    for el in root.findall("joint"):
        name = el.get("name")
        what = f"{path}:{el.sourceline}: <joint name={name!r}>"
        if name is None:
            raise ValueError(f"{path}:{el.sourceline}: <joint> without a name")
        kind = el.get("type")
        if kind not in URDF_JOINT_KINDS:
            raise ValueError(f"{what}: joint type {kind!r} is not supported (supported: "
                             f"{', '.join(URDF_JOINT_KINDS)})")
        for tag in ("parent", "child"):
            sub = el.find(tag)
            if sub is None or sub.get("link") is None:
                raise ValueError(f"{what}: expected a <{tag} link=...> element")
    for el in root.findall("link"):
        if el.get("name") is None:
            raise ValueError(f"{path}:{el.sourceline}: <link> without a name")
    try:
        urdf = yourdfpy.URDF.load(path, build_scene_graph=False, build_collision_scene_graph=False,
                                  load_meshes=False, load_collision_meshes=False)
    except Exception as exc:  # yourdfpy raises what its parser meets
        raise ValueError(f"{path}: yourdfpy could not read the URDF: {exc}") from None
    robot = urdf.robot

    def at(kind: str, name: str) -> str:
        return f"{path}:{lines.get((kind, name), '?')}: <{kind} name={name!r}>"

    links = {ln.name: ln for ln in robot.links}
    if len(links) != len(robot.links):
        seen = set()
        for ln in robot.links:
            if ln.name in seen:
                raise ValueError(f"{at('link', ln.name)}: a second link of this name")
            seen.add(ln.name)
    parent_joint: dict[str, Any] = {}
    children: dict[str, list] = {name: [] for name in links}
    for jt in robot.joints:
        for end in (jt.parent, jt.child):
            if end not in links:
                raise ValueError(f"{at('joint', jt.name)}: names link {end!r}, which the file does not define")
        if jt.child in parent_joint:
            other = parent_joint[jt.child]
            raise ValueError(f"{at('joint', jt.name)}: link {jt.child!r} is already the child of joint {other.name!r} "
                             f"(line {lines.get(('joint', other.name), '?')}): a URDF is a tree (closed loops "
                             "are not supported)")
        if jt.parent == jt.child:
            raise ValueError(f"{at('joint', jt.name)}: joins link {jt.child!r} to itself")
        parent_joint[jt.child] = jt
        children[jt.parent].append(jt)
    roots = [name for name in links if name not in parent_joint]
    if not roots:
        jt = robot.joints[0]
        raise ValueError(f"{at('joint', jt.name)}: the joints form a cycle (no link is without a parent): a URDF "
                         "is a tree (closed loops are not supported)")
    if len(roots) > 1:
        raise ValueError(f"{at('link', roots[1])}: not connected to the root link {roots[0]!r}: a URDF is one tree "
                         f"(links without a parent joint: {roots})")
    moving = {jt.name for jt in robot.joints if jt.type != "fixed"}
    positions = _positions(joint_positions, moving, path)

    # forward kinematics from the root, every link's global frame
    T = {roots[0]: np.eye(4)}
    group_of: dict[str, _Group] = {roots[0]: _Group(roots[0], np.eye(3), fixed_to_world=bool(fixed_base))}
    groups = [group_of[roots[0]]]
    order: list = []  # moving joints in tree order: (joint, point, axis)
    stack = [roots[0]]
    visited = set()
    while stack:
        name = stack.pop()
        visited.add(name)
        for jt in reversed(children[name]):
            origin = np.eye(4) if jt.origin is None else np.asarray(jt.origin, dtype=float)
            T_joint = T[name] @ origin
            axis = np.array([1.0, 0.0, 0.0]) if jt.axis is None else np.asarray(jt.axis, dtype=float)
            motion = np.eye(4)
            if jt.type != "fixed":
                if not np.all(np.isfinite(axis)) or not np.linalg.norm(axis) > 0.0:
                    raise ValueError(f"{at('joint', jt.name)}: expected a nonzero <axis xyz=...>, got {axis.tolist()}")
                axis = axis / np.linalg.norm(axis)
                q = positions.get(jt.name, 0.0)
                q = real_number(q, f"joint_positions[{jt.name!r}]", expected="a finite joint position")
                if jt.type in ("revolute", "continuous"):
                    if degrees:
                        q = math.radians(q)
                    from rigidlab.core.rotations import matrix_from_axis_angle

                    motion[:3, :3] = matrix_from_axis_angle(axis, q)
                else:
                    motion[:3, 3] = q * axis
            T[jt.child] = T_joint @ motion
            if jt.type == "fixed":
                group_of[jt.child] = group_of[name]
            else:
                g = _Group(jt.child, T[jt.child][:3, :3].copy())
                group_of[jt.child] = g
                groups.append(g)
                order.append((jt, T_joint[:3, 3].copy(), T_joint[:3, :3] @ axis))
            stack.append(jt.child)

    for name, link in links.items():
        inertial = link.inertial
        if inertial is None or inertial.mass is None:
            continue
        m = float(inertial.mass)
        I_in = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
        if not (math.isfinite(m) and m >= 0.0 and np.all(np.isfinite(I_in))):
            raise ValueError(f"{at('link', name)}: expected a finite mass >= 0 and a finite inertia, got mass {m!r}")
        I_in = _snap_round_off(0.5 * (I_in + I_in.T), m)
        T_in = T[name] @ (np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float))
        R_in = T_in[:3, :3]
        group_of[name].add(m, T_in[:3, 3], R_in @ I_in @ R_in.T)

    joints = [(URDF_JOINT_KINDS[jt.type], group_of[jt.parent], group_of[jt.child], point, axis, jt.name)
              for jt, point, axis in order]
    groups, joints = _combine_massless(groups, joints, lambda g: at("link", g.name))
    system = System(gravity=gravity)
    _add_groups(system, groups, lambda g: at("link", g.name))
    for kind, gi, gj, point, axis, name in joints:
        _add_joint(system, kind, gi, gj, point, axis, name)
    return system


# ------------------------------------------------------------------ MJCF
def from_mjcf(path: Any, *, joint_positions: Any = None, degrees: bool = False, gravity: Any = None):
    """A System from an MJCF file (compiled by MuJoCo's own parser), at the given joint positions and at rest.

    The kinematic tree of the compiled model: each MuJoCo body with its
    inertial (``body_mass``, the principal moments ``body_inertia`` in the
    frame ``body_ipos``/``body_iquat``, as MuJoCo computes them, from the
    geoms when the file gives no ``<inertial>``) becomes a body; a body
    without joints is lumped into its parent (parallel-axis theorem, the
    world's: into the ground); ``hinge`` joints become revolute joints,
    ``slide`` joints prismatic ones, ``ball`` joints spherical ones (at
    MuJoCo's global anchor and axis ``xanchor``/``xaxis`` in the pose), a
    ``free`` joint leaves its body free. Several joints on one body combine
    into one, as massless links do in :func:`from_urdf`: three hinges
    through one point a spherical joint, two perpendicular hinges through
    one point a universal joint, a hinge and a slide along one line a
    cylindrical joint, named ``"j1+j2[+j3]"``. Joint limits, ``stiffness``,
    ``damping``, ``armature``, ``frictionloss``, actuators, tendons,
    equality constraints and contacts are ignored.

    Parameters
    ----------
    path : str or os.PathLike
        The MJCF (or any file ``mujoco.MjModel.from_xml_path`` reads).
    joint_positions : dict or None, keyword-only
        Joint name -> MuJoCo ``qpos`` of that joint: an angle (rad) for a
        hinge (counted as MuJoCo does, from the model's zero pose), a
        displacement (m) for a slide, Euler parameters (4,) scalar first for
        a ball, position and Euler parameters (7,) for a free joint. Joints
        not named are at ``qpos0``, the pose of the file.
    degrees : bool, keyword-only
        True: hinge angles are in degrees.
    gravity : (3,) array_like or None, keyword-only
        Global gravitational acceleration (m/s^2); default the file's
        (``<option gravity=...>``, MuJoCo's default ``(0, 0, -9.81)``).

    Returns
    -------
    System
        Bodies and joints named as in the file (``body<k>``/``joint<k>``
        for unnamed ones), at rest.

    Raises
    ------
    ValueError
        One message naming the file and MuJoCo's element and line: a
        missing file, malformed XML, an element MuJoCo refuses; a body
        whose joints do not combine into one, a moving body without mass, an
        unknown joint name in ``joint_positions``.
    """
    from rigidlab.core.multibody import System

    path = _check_path(path)
    if not isinstance(degrees, (bool, np.bool_)):
        raise ValueError(f"degrees: expected True or False, got {short_repr(degrees)}")
    try:
        import mujoco
    except ImportError:  # pragma: no cover - depends on the installation
        raise ValueError("from_mjcf: needs the optional package mujoco (pip install 'rigidlab[mjcf]')") from None
    try:
        model = mujoco.MjModel.from_xml_path(path)
    except ValueError as exc:
        text = " ".join(str(exc).split())
        raise ValueError(f"{path}: MuJoCo could not load the model: {text}") from None
    data = mujoco.MjData(model)

    def body_name(b: int) -> str:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"

    def joint_name(j: int) -> str:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"

    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): "hinge", int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
             int(mujoco.mjtJoint.mjJNT_BALL): "ball", int(mujoco.mjtJoint.mjJNT_FREE): "free"}
    names = {joint_name(j): j for j in range(model.njnt)}
    positions = _positions(joint_positions, set(names), path)
    qpos = model.qpos0.copy()
    sizes = {"hinge": 1, "slide": 1, "ball": 4, "free": 7}
    for name, value in positions.items():
        j = names[name]
        kind = kinds[int(model.jnt_type[j])]
        adr = int(model.jnt_qposadr[j])
        val = np.asarray(value, dtype=float).reshape(-1) if not isinstance(value, (bool, np.bool_)) else None
        if val is None or val.size != sizes[kind] or not np.all(np.isfinite(val)):
            raise ValueError(f"joint_positions[{name!r}]: expected {sizes[kind]} finite number(s) for a {kind} joint, "
                             f"got {short_repr(value)}")
        if kind == "hinge" and degrees:
            val = np.radians(val)
        qpos[adr : adr + sizes[kind]] = val
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)

    group_of: dict[int, _Group] = {0: _Group("world", np.eye(3), fixed_to_world=True)}
    groups: list[_Group] = [group_of[0]]
    joints = []  # (kind, parent group, child group, point, axis, name)
    for b in range(1, model.nbody):
        parent = int(model.body_parentid[b])
        count = int(model.body_jntnum[b])
        A = data.xmat[b].reshape(3, 3).copy()
        if count == 0:
            g = group_of[parent]
        else:
            # several joints on one body act one after the other: a chain through massless frames, which
            # _combine_massless turns into one universal, spherical or cylindrical joint
            previous = group_of[parent]
            for k in range(count):
                j = int(model.body_jntadr[b]) + k
                kind = kinds[int(model.jnt_type[j])]
                if kind == "free" and count > 1:
                    raise ValueError(f"{path}: <body name={body_name(b)!r}>: a free joint with other joints")
                last = k == count - 1
                g = _Group(body_name(b) if last else f"{body_name(b)}/{joint_name(j)}", A)
                groups.append(g)
                if kind != "free":
                    rl = {"hinge": "revolute", "slide": "prismatic", "ball": "spherical"}[kind]
                    joints.append((rl, previous, g, data.xanchor[j].copy(),
                                   None if kind == "ball" else data.xaxis[j].copy(), joint_name(j)))
                previous = g
        group_of[b] = g
        R_in = data.ximat[b].reshape(3, 3)
        g.add(float(model.body_mass[b]), data.xipos[b].copy(), R_in @ np.diag(model.body_inertia[b]) @ R_in.T)

    g_vec = model.opt.gravity.copy() if gravity is None else gravity

    def where(g):
        return f"{path}: <body name={g.name.split('/')[0]!r}>"

    groups, joints = _combine_massless(groups, joints, where)
    system = System(gravity=g_vec)
    _add_groups(system, groups, where)
    for kind, gi, gj, point, axis, name in joints:
        _add_joint(system, kind, gi, gj, point, axis, name)
    return system
