"""URDF and MJCF loaders (core.models.from_urdf, from_mjcf) against independent references.

* A double pendulum of two uniform rods, written as URDF and as MJCF: the
  frequencies of the linearized System equal the closed form of the 2x2
  joint-space problem ``det(K - omega^2 M) = 0`` derived by hand.
* A four-joint arm (offset joints, tilted inertial frames, non-diagonal
  inertias, a fixed joint that lumps a sensor into a link): its joint-space
  mass matrix equals MuJoCo's ``mj_fullM`` for the same file (MuJoCo reads
  URDF itself), and the modes about a hanging equilibrium agree with
  MuJoCo's ``K phi = omega^2 M phi``.
* Bad files: one ValueError naming the file and the element or line.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from rigidlab.core.modal import linearize
from rigidlab.core.models import from_mjcf, from_urdf

DATA = Path(__file__).resolve().parent / "data"
PENDULUM_URDF = DATA / "double_pendulum.urdf"
PENDULUM_MJCF = DATA / "double_pendulum.xml"
ARM_URDF = DATA / "arm.urdf"
ARM_JOINTS = ("shoulder_yaw", "shoulder_pitch", "elbow", "wrist")


def _closed_form_pendulum() -> np.ndarray:
    """omega (rad/s) of two uniform rods on parallel hinges, hanging: the hand-derived 2x2 problem.

    Angles theta1, theta2 from the vertical; rod k: mass m_k, length L_k,
    centre c_k = L_k / 2 from its hinge, moment I_k = m_k L_k^2 / 12 about
    its centre. Kinetic energy ``T = 1/2 th' M th'`` with
    ``M = [[I1 + m1 c1^2 + m2 L1^2, m2 L1 c2], [m2 L1 c2, I2 + m2 c2^2]]``
    (cos(theta1 - theta2) = 1 at the linearization), potential
    ``V = -g (m1 c1 + m2 L1) cos th1 - g m2 c2 cos th2`` so
    ``K = g diag(m1 c1 + m2 L1, m2 c2)``.
    """
    g = 9.81
    m1, L1 = 1.0, 1.0
    m2, L2 = 0.5, 0.8
    c1, c2 = L1 / 2, L2 / 2
    I1, I2 = m1 * L1**2 / 12, m2 * L2**2 / 12
    M = np.array([[I1 + m1 * c1**2 + m2 * L1**2, m2 * L1 * c2], [m2 * L1 * c2, I2 + m2 * c2**2]])
    K = g * np.diag([m1 * c1 + m2 * L1, m2 * c2])
    return np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))


@pytest.mark.parametrize("kind", ["urdf", "mjcf"])
def test_double_pendulum_frequencies_match_the_closed_form(kind):
    if kind == "urdf":
        pytest.importorskip("yourdfpy")
        system = from_urdf(PENDULUM_URDF)
    else:
        pytest.importorskip("mujoco")
        system = from_mjcf(PENDULUM_MJCF)
    model = linearize(system)
    flexible = model.modes().flexible
    expected = _closed_form_pendulum()
    # a tree of revolute joints hanging at rest: linearize's matrices are exact (derivative_error 0, no finite
    # differences), so both sides are round-off of a 2x2 eigenproblem (~1e-15; measured: equal to the last
    # bit). 1e-12 leaves a margin of 1000 and catches any wrong inertia, offset or axis.
    assert model.derivative_error == 0.0
    np.testing.assert_allclose(flexible.omega_n, expected, rtol=1e-12)
    assert flexible.eigenvalues.shape == (2,)
    assert np.all(flexible.eigenvalues.imag > 0)


def test_double_pendulum_urdf_and_mjcf_give_the_same_bodies():
    pytest.importorskip("yourdfpy")
    pytest.importorskip("mujoco")
    a, b = from_urdf(PENDULUM_URDF), from_mjcf(PENDULUM_MJCF)
    assert [x.name for x in a.bodies] == [x.name for x in b.bodies] == ["rod1", "rod2"]
    assert [j.name for j in a.joints] == [j.name for j in b.joints] == ["hinge1", "hinge2"]
    for x, y in zip(a.bodies, b.bodies):
        assert x.mass == y.mass
        np.testing.assert_allclose(x.inertia, y.inertia, atol=1e-15)  # the same decimal numbers in both files
    np.testing.assert_allclose(a.state.q, b.state.q, atol=1e-15)


def _joint_space_mass(system_at, names, q, h=1e-6):
    """Joint-space mass matrix from the System's kinetic energy: ``sum_b J_b^T M_b J_b``.

    ``system_at(q)`` loads the System at joint positions ``q``; the body velocities per unit joint rate
    (``R_dot`` global, ``omega_body`` from ``A^T dA``) come from central differences with step ``h``
    (truncation ~h^2 = 1e-12, round-off ~eps/h = 1e-10, relative); the body mass matrix is the System's own
    Newton-Euler ``M = diag(m I, J_body)`` (``System.evaluate().M``).
    """
    from rigidlab.core.rotations import matrix_from_euler_parameters

    base = system_at(q)
    n = len(base.bodies)
    M_body = base.evaluate().M
    J = np.zeros((6 * n, len(names)))

    def frames(s):
        st = s.state.q
        return st[: 3 * n].reshape(n, 3), matrix_from_euler_parameters(st[3 * n :].reshape(n, 4))

    R0, A0 = frames(base)
    for k in range(len(names)):
        dq = np.zeros(len(names))
        dq[k] = h
        Rp, Ap = frames(system_at(q + dq))
        Rm, Am = frames(system_at(q - dq))
        J[: 3 * n, k] = ((Rp - Rm) / (2 * h)).ravel()
        W = np.einsum("bji,bjk->bik", A0, (Ap - Am) / (2 * h))  # A^T dA/dq = skew(omega_body)
        J[3 * n :, k] = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1).ravel()
    return J.T @ M_body @ J


def _mujoco_arm(q):
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(ARM_URDF))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    assert tuple(names) == ARM_JOINTS  # hinges only: qpos and qvel both follow the joint order
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    return mujoco, model, data, _full_m(mujoco, model, data)


def _full_m(mujoco, model, data):
    """MuJoCo's dense joint-space mass matrix (``mj_fullM``; its signature changed in MuJoCo 3.3.3/4)."""
    M = np.zeros((model.nv, model.nv))
    try:
        mujoco.mj_fullM(model, data, M)
    except TypeError:
        mujoco.mj_fullM(model, M, data.qM)
    return M


@pytest.mark.parametrize("loader", ["urdf", "mjcf"])
def test_arm_mass_matrix_equals_mujoco_full_m(loader):
    q = np.array([0.4, -0.7, 1.1, 0.5])
    _, _, _, M_mj = _mujoco_arm(q)
    if loader == "urdf":
        pytest.importorskip("yourdfpy")

        def at(qq):
            return from_urdf(ARM_URDF, joint_positions=dict(zip(ARM_JOINTS, qq)))
    else:  # MuJoCo's own compiled model of the file, through from_mjcf (diagonalized inertias, iquat)
        def at(qq):
            return from_mjcf(ARM_URDF, joint_positions=dict(zip(ARM_JOINTS, qq)))
    M = _joint_space_mass(at, ARM_JOINTS, q)
    # central differences (above) leave ~1e-10 of the largest entry (measured 2.8e-11 through from_urdf,
    # 1.4e-10 through from_mjcf); MuJoCo's composite-rigid-body M is exact to round-off. 1e-8 of the largest
    # entry leaves a margin of 70 and a wrong parallel-axis term or inertia frame shows as >1e-4.
    scale = float(np.max(np.abs(M_mj)))
    assert np.max(np.abs(M - M_mj)) <= 1e-8 * scale
    assert np.max(np.abs(M_mj - np.diag(np.diag(M_mj)))) > 1e-3 * scale  # the arm couples its joints


def test_arm_pose_in_degrees_is_the_pose_in_radians():
    pytest.importorskip("yourdfpy")
    q = {"shoulder_yaw": 30.0, "elbow": -45.0}
    a = from_urdf(ARM_URDF, joint_positions=q, degrees=True)
    b = from_urdf(ARM_URDF, joint_positions={k: math.radians(v) for k, v in q.items()})
    np.testing.assert_allclose(a.state.q, b.state.q, atol=1e-15)


def test_arm_modes_agree_with_mujoco():
    pytest.importorskip("yourdfpy")
    mujoco, model, data, _ = _mujoco_arm(np.zeros(4))

    def bias(q):  # qfrc_bias at rest: the generalized gravity force dV/dq
        data.qpos[:] = q
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        return data.qfrc_bias.copy()

    # the hanging equilibrium: Newton on dV/dq = 0 with a finite-difference Hessian (pinv: the yaw joint's axis
    # is vertical, so gravity does not hold it and the Hessian has a zero row)
    q = np.array([0.0, 1.5, 0.2, 0.0])
    h = 1e-6

    def hessian(q):
        return np.stack([(bias(q + h * e) - bias(q - h * e)) / (2 * h) for e in np.eye(4)], axis=1)

    for _ in range(30):
        step = np.linalg.pinv(hessian(q), rcond=1e-10) @ bias(q)
        q = q - step
        if np.max(np.abs(step)) < 1e-13:
            break
    assert np.max(np.abs(bias(q))) < 1e-10
    K = hessian(q)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    M = _full_m(mujoco, model, data)
    lam = scipy.linalg.eigh(0.5 * (K + K.T), M, eigvals_only=True)
    assert lam[0] < 1e-8 * lam[-1]  # the yaw joint: a rigid-body mode
    expected = np.sqrt(lam[1:])

    system = from_urdf(ARM_URDF, joint_positions=dict(zip(ARM_JOINTS, q)))
    system.equilibrium()  # polishes the pose (MuJoCo's equilibrium to ~1e-10 N m)
    flexible = linearize(system).modes().flexible
    # the MuJoCo side's K comes from central differences of qfrc_bias with h = 1e-6 (round-off ~eps/h = 1e-10
    # relative; truncation ~h^2); rigidlab's linearization is exact here. Measured 1.8e-10 relative on omega;
    # 1e-7 leaves a margin of 500 and still catches a wrong inertia (1% of a moment moves omega by ~1e-3).
    np.testing.assert_allclose(flexible.omega_n, expected, rtol=1e-7)
    assert np.all(flexible.stable)


LEG_MJCF = DATA / "leg.xml"


def test_several_joints_on_one_body_become_one_joint():
    """MuJoCo bodies with three hinges (hip), two (knee) and a hinge with a slide (ankle): one spherical,
    universal and cylindrical joint each, with MuJoCo's mass matrix in its own joint coordinates, every
    motion of those coordinates allowed by the combined joints, and MuJoCo's modes."""
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(LEG_MJCF))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    system = from_mjcf(LEG_MJCF)
    assert [(j.name, j.kind) for j in system.joints] == [
        ("hip_z+hip_x+hip_y", "spherical"), ("knee_x+knee_y", "universal"), ("ankle_roll+ankle_slide", "cylindrical")]
    q = np.array([0.3, -0.2, 0.4, 0.5, -0.3, 0.2, 0.05])
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    M_mj = _full_m(mujoco, model, data)

    def at(qq):
        return from_mjcf(LEG_MJCF, joint_positions=dict(zip(names, qq)))

    M = _joint_space_mass(at, names, q)
    # as for the arm: central differences ~1e-10 of the largest entry (measured 1.4e-10)
    assert np.max(np.abs(M - M_mj)) <= 1e-8 * float(np.max(np.abs(M_mj)))
    # the combined joints allow exactly the 7 motions of MuJoCo's coordinates: same count of degrees of freedom
    D = at(q).evaluate().D
    assert D.shape[1] - np.linalg.matrix_rank(D) == 7

    # modes at q = 0 (centres of mass below the joints): K = d(qfrc_bias)/dq by central differences
    def bias(qq):
        data.qpos[:] = qq
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        return data.qfrc_bias.copy()

    h = 1e-6
    K = np.stack([(bias(h * e) - bias(-h * e)) / (2 * h) for e in np.eye(7)], axis=1)
    bias(np.zeros(7))
    lam = scipy.linalg.eigh(0.5 * (K + K.T), _full_m(mujoco, model, data), eigvals_only=True)
    # one zero (the turn about the vertical hip axis) and one negative eigenvalue: sliding the foot sideways
    # while the leg tilts lowers it (V has a term m g x theta), a divergent mode with s = +sqrt(-lambda)
    assert abs(lam[1]) < 1e-8 * lam[-1] and lam[0] < 0
    expected = np.sort(np.sqrt(np.abs(np.delete(lam, 1))))
    flexible = linearize(system).modes().flexible
    # MuJoCo's K by central differences (~1e-10 relative), rigidlab's exact here: 1e-7 as for the arm
    np.testing.assert_allclose(flexible.omega_n, expected, rtol=1e-7)
    assert int(np.sum(~flexible.stable)) == 1


# ------------------------------------------------------------------ bad files
def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


LINK = '<link name="{0}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>' \
       "</inertial></link>"


def _urdf(*items):
    return '<?xml version="1.0"?>\n<robot name="r">\n' + "\n".join(items) + "\n</robot>\n"


def _joint(name, kind, parent, child):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            '<axis xyz="1 0 0"/></joint>')


def test_urdf_missing_file(tmp_path):
    pytest.importorskip("yourdfpy")
    path = tmp_path / "nothing.urdf"
    with pytest.raises(ValueError, match=r"path: .*nothing\.urdf: no such file"):
        from_urdf(path)


def test_urdf_malformed_xml_names_file_and_line(tmp_path):
    pytest.importorskip("yourdfpy")
    path = _write(tmp_path, "broken.urdf", _urdf(LINK.format("a"), '<link name="b">'))
    with pytest.raises(ValueError, match=r"broken\.urdf:\d+: malformed XML"):
        from_urdf(path)


def test_urdf_cycle_names_the_joint(tmp_path):
    pytest.importorskip("yourdfpy")
    text = _urdf(LINK.format("a"), LINK.format("b"), LINK.format("c"),
                 _joint("ab", "revolute", "a", "b"), _joint("bc", "revolute", "b", "c"), _joint("ca", "revolute", "c", "a"))
    path = _write(tmp_path, "cycle.urdf", text)
    with pytest.raises(ValueError, match=r"cycle\.urdf:\d+: <joint name='ab'>: the joints form a cycle"):
        from_urdf(path)


def test_urdf_closed_loop_names_the_second_parent(tmp_path):
    pytest.importorskip("yourdfpy")
    text = _urdf(LINK.format("a"), LINK.format("b"), LINK.format("c"),
                 _joint("ab", "revolute", "a", "b"), _joint("ac", "revolute", "a", "c"), _joint("bc", "revolute", "b", "c"))
    path = _write(tmp_path, "loop.urdf", text)
    with pytest.raises(ValueError, match=r"loop\.urdf:8: <joint name='bc'>: link 'c' is already the child of joint 'ac'"):
        from_urdf(path)


@pytest.mark.parametrize("kind", ["planar", "floating"])
def test_urdf_unsupported_joint_kind(tmp_path, kind):
    pytest.importorskip("yourdfpy")
    path = _write(tmp_path, "odd.urdf", _urdf(LINK.format("a"), LINK.format("b"), _joint("j", kind, "a", "b")))
    with pytest.raises(ValueError, match=rf"odd\.urdf:5: <joint name='j'>: joint type '{kind}' is not supported"):
        from_urdf(path)


def test_urdf_unknown_link_and_massless_moving_link(tmp_path):
    pytest.importorskip("yourdfpy")
    path = _write(tmp_path, "ghost.urdf", _urdf(LINK.format("a"), _joint("j", "revolute", "a", "nowhere")))
    with pytest.raises(ValueError, match=r"ghost\.urdf:4: <joint name='j'>: names link 'nowhere'"):
        from_urdf(path)
    # a massless link between two parallel hinges that are apart: no single joint does what they do
    text = _urdf(LINK.format("a"), '<link name="b"/>', LINK.format("c"), _joint("j", "revolute", "a", "b"),
                 '<joint name="k" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0 -1"/>'
                 '<axis xyz="1 0 0"/></joint>')
    path = _write(tmp_path, "light.urdf", text)
    with pytest.raises(ValueError, match=r"light\.urdf:4: <link name='b'>: link 'b' has no mass and its joints "
                                         r"\['j', 'k'\] \(\['revolute', 'revolute'\]\) do not make one universal"):
        from_urdf(path)
    # a massless link that carries nothing is left out with its joint
    path = _write(tmp_path, "leaf.urdf", _urdf(LINK.format("a"), LINK.format("c"), '<link name="b"/>',
                                                _joint("j", "revolute", "a", "b"), _joint("k", "revolute", "a", "c")))
    system = from_urdf(path)
    assert [b.name for b in system.bodies] == ["c"] and [j.name for j in system.joints] == ["k"]
    # a massless floating base is refused
    path = _write(tmp_path, "float.urdf", _urdf('<link name="a"/>', LINK.format("c"), _joint("k", "revolute", "a", "c")))
    with pytest.raises(ValueError, match=r"float\.urdf:3: <link name='a'>: link 'a' moves .* has no mass"):
        from_urdf(path, fixed_base=False)


def test_urdf_round_off_moments_count_as_zero(tmp_path):
    pytest.importorskip("yourdfpy")
    point = ('<link name="b"><inertial><origin xyz="0 0 -1"/><mass value="0.5"/>'
             '<inertia ixx="-5.42101e-20" iyy="-5.42101e-20" izz="4e-18" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    system = from_urdf(_write(tmp_path, "point.urdf", _urdf(LINK.format("a"), point, _joint("j", "revolute", "a", "b"))))
    assert np.all(system.bodies[0].inertia == 0.0)  # a point mass (as the file meant), not a refused tensor
    real = point.replace("-5.42101e-20", "-1e-3")
    with pytest.raises(ValueError, match=r"real\.urdf:4: <link name='b'>: link 'b': inertia: expected principal "
                                         r"moments >= 0"):
        from_urdf(_write(tmp_path, "real.urdf", _urdf(LINK.format("a"), real, _joint("j", "revolute", "a", "b"))))
    with pytest.raises(ValueError, match=r"empty\.urdf:2: <robot> without a name"):
        from_urdf(_write(tmp_path, "empty.urdf", '<?xml version="1.0"?>\n<robot>\n</robot>\n'))


def test_urdf_bad_joint_positions():
    pytest.importorskip("yourdfpy")
    with pytest.raises(ValueError, match=r"joint_positions: .* has no moving joint named 'knee'"):
        from_urdf(ARM_URDF, joint_positions={"knee": 0.1})
    with pytest.raises(ValueError, match=r"joint_positions\['elbow'\]: expected a finite joint position"):
        from_urdf(ARM_URDF, joint_positions={"elbow": float("nan")})


def test_urdf_floating_base_is_a_free_body():
    pytest.importorskip("yourdfpy")
    fixed = from_urdf(ARM_URDF)
    free = from_urdf(ARM_URDF, fixed_base=False, gravity=(0.0, 0.0, 0.0))
    assert [b.name for b in free.bodies] == ["base"] + [b.name for b in fixed.bodies]
    assert len(free.joints) == len(fixed.joints) == 4
    modes = linearize(free).modes()
    # a free arm in space without springs: 6 + 4 degrees of freedom, all of them rigid-body motions
    assert modes.eigenvalues.shape == (20,) and np.all(modes.rigid)
    assert modes.flexible.eigenvalues.shape == (0,)


def test_mjcf_bad_files(tmp_path):
    pytest.importorskip("mujoco")
    with pytest.raises(ValueError, match=r"path: .*none\.xml: no such file"):
        from_mjcf(tmp_path / "none.xml")
    path = _write(tmp_path, "broken.xml", "<mujoco><worldbody><body name='a'>\n</worldbody></mujoco>\n")
    with pytest.raises(ValueError, match=r"broken\.xml: MuJoCo could not load the model: .*[Ll]ine"):
        from_mjcf(path)
    path = _write(tmp_path, "kind.xml", "<mujoco><worldbody><body name='a'>\n<joint type='planar'/>"
                  "<geom size='0.1'/></body></worldbody></mujoco>\n")
    with pytest.raises(ValueError, match=r"kind\.xml: MuJoCo could not load the model: .*Element 'joint', line 2"):
        from_mjcf(path)
    path = _write(tmp_path, "two.xml", "<mujoco><worldbody><body name='a'><joint name='j1' axis='1 0 0'/>"
                  "<joint name='j2' axis='1 0 0' pos='0 0 0.1'/><geom size='0.1'/></body></worldbody></mujoco>\n")
    with pytest.raises(ValueError, match=r"two\.xml: <body name='a'>: link 'a/j1' has no mass and its joints "
                                         r"\['j1', 'j2'\] .* do not make one universal"):
        from_mjcf(path)


def test_mjcf_ball_free_and_slide_joints(tmp_path):
    pytest.importorskip("mujoco")
    text = """<mujoco><option gravity="0 0 -9.81"/><worldbody>
      <body name="float" pos="0 0 2"><freejoint name="f"/><geom type="box" size="0.1 0.2 0.3" mass="2"/>
        <body name="ball" pos="0 0 -0.5"><joint name="b" type="ball"/><geom type="sphere" size="0.1" mass="1"/></body>
      </body>
      <body name="cart" pos="1 0 0"><joint name="s" type="slide" axis="1 0 0"/><geom type="box" size="0.1 0.1 0.1"
        mass="3"/></body>
    </worldbody></mujoco>"""
    system = from_mjcf(_write(tmp_path, "mixed.xml", text), joint_positions={"s": 0.25})
    assert [j.kind for j in system.joints] == ["spherical", "prismatic"]
    assert [b.name for b in system.bodies] == ["float", "ball", "cart"]
    np.testing.assert_allclose(system.state.q[6:9], [1.25, 0.0, 0.0], atol=1e-15)
    assert system.bodies[0].mass == pytest.approx(2.0, rel=1e-12)


# ------------------------------------------------------------------ real robots (optional)
def _example_robot(relative):
    """A URDF shipped by the PyPI package example-robot-data (Pinocchio's robot set: `pip install
    'rigidlab[robots]'`), or a skip when it is not installed."""
    from importlib import metadata

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install 'rigidlab[robots]')")
    path = Path(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/{relative}"))
    if not path.is_file():
        pytest.skip(f"example-robot-data has no {relative}")
    return path


@pytest.mark.parametrize("relative", ["ur_description/urdf/ur5_robot.urdf", "panda_description/urdf/panda.urdf",
                                      "human_description/robots/human.urdf"])
def test_real_robot_mass_matrix_equals_pinocchio_crba(relative):
    pytest.importorskip("yourdfpy")
    pinocchio = pytest.importorskip("pinocchio")
    path = _example_robot(relative)
    model = pinocchio.buildModelFromUrdf(str(path))
    names = [model.names[j] for j in range(1, model.njoints)]
    rng = np.random.default_rng(3)
    values = rng.uniform(-1.0, 1.0, len(names))
    is_prismatic = ["Prismatic" in model.joints[j].shortname() for j in range(1, model.njoints)]
    values[is_prismatic] = 0.02  # the panda's fingers: 2 cm open
    v = np.zeros(model.nv)
    for k, j in enumerate(range(1, model.njoints)):
        v[model.joints[j].idx_v] = values[k]
    q = pinocchio.integrate(model, pinocchio.neutral(model), v)  # also for Pinocchio's (cos, sin) revolutes
    data = model.createData()
    upper = pinocchio.crba(model, data, q)
    M_pin = np.triu(upper) + np.triu(upper, 1).T
    order = [model.joints[j].idx_v for j in range(1, model.njoints)]
    M_pin = M_pin[np.ix_(order, order)]

    system = from_urdf(path)
    # (the human's hips, spine and neck: revolute joints through massless links, combined into spherical and
    # universal joints named "a+b+c")
    assert {n for j in system.joints for n in j.name.split("+")} <= set(names)

    def at(qq):
        return from_urdf(path, joint_positions=dict(zip(names, qq)))

    M = _joint_space_mass(at, names, values)
    # as for the arm above: central differences leave ~1e-10 of the largest entry, Pinocchio's CRBA round-off
    scale = float(np.max(np.abs(M_pin)))
    assert np.max(np.abs(M - M_pin)) <= 1e-8 * scale
