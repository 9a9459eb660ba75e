"""The four linkages of core.models.linkage and their sampled motion (core/models/_linkage_motion.py).

Oracles: statics of a hanging chain (joint k carries the links below it), the
joint points as seen from either body of a joint, the slider-crank's closed
form, core.gyroscope's closed-form top, one long run against the same run
split in two (the continuation from ``final_state``), and the counts of
equations and freedoms the chapter gives.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from rigidlab.core.models import LINKAGE_KINDS, linkage, linkage_motion
from rigidlab.core.rotations import rotate_vector


@pytest.mark.parametrize(("kind", "counts"), [
    ("chain", (25, 25, 5)),  # 5 revolute joints of 5 rows
    ("double_pendulum", (6, 6, 6)),  # 2 spherical joints of 3 rows
    ("slider_crank", (18, 18, 0)),  # revolute 5 + spherical 3 + universal 4 + prismatic 5 + the motor
    ("heavy_top", (3, 3, 3)),
])
def test_counts_of_equations_rank_and_freedom(kind, counts):
    info = linkage(kind).info
    assert (info.n_equations, info.rank, info.degrees_of_freedom) == counts
    assert info.kind == kind and len(info.columns()) == 7 * info.n_bodies + 2 + {
        "slider_crank": 1, "heavy_top": 5}.get(kind, 0)
    assert info.conserved == (kind != "slider_crank")
    text = info.description()
    assert f"{counts[0]} constraint equations (rank {counts[1]})" in text[1]
    assert f"{counts[2]} degrees of freedom" in text[1]


def test_a_hanging_chain_is_static_and_its_joints_carry_the_links_below():
    chain = linkage("chain", n_links=4, tilt=0.0)
    t = np.linspace(0.0, 0.5, 11)
    motion = linkage_motion(chain, t, method="DOP853", rtol=1e-10, atol=1e-12)
    # joint k at the top of link k: 0.5 m apart straight down from the origin
    np.testing.assert_allclose(motion.joint_points[:, :, 2], -0.5 * np.arange(4) * np.ones((11, 1)), atol=1e-12)
    np.testing.assert_allclose(motion.joint_points[:, :, :2], 0.0, atol=1e-12)
    # each joint holds the weight of the links below it, straight up (1 kg links)
    expected = np.zeros((4, 3))
    expected[:, 2] = 9.81 * np.array([4, 3, 2, 1])
    np.testing.assert_allclose(motion.joint_forces, np.broadcast_to(expected, (11, 4, 3)), rtol=1e-9, atol=1e-9)
    assert motion.motor_torque is None and motion.closed_form is None and motion.difference is None
    np.testing.assert_allclose(motion.energy, motion.energy[0], rtol=0.0, atol=1e-12)
    assert chain.info.weight == pytest.approx(4 * 9.81)


@pytest.mark.parametrize("kind", LINKAGE_KINDS)
def test_joint_points_are_where_both_bodies_of_the_joint_put_them(kind):
    """A joint point from body_j (what linkage_motion reports) equals the same point carried by body_i (the
    other side of the joint), at every sample of a moving linkage: the constraint, read back."""
    link = linkage(kind)
    motion = linkage_motion(link, np.linspace(0.0, 0.6, 13), method="DOP853", rtol=1e-9, atol=1e-11)
    state = link.system.state
    for k, joint in enumerate(link.joints):
        if joint.kind not in ("revolute", "spherical"):
            continue  # the slider's prismatic and universal points are not shared by both bodies
        if joint.body_i.is_ground:
            carried = np.broadcast_to(np.asarray(joint.point, dtype=float), (13, 3))
        else:
            i = joint.body_i.index
            u_i = state.rotation_matrix(joint.body_i).T @ (np.asarray(joint.point, dtype=float) - state.position(
                joint.body_i))
            carried = motion.R[:, i] + rotate_vector(motion.p[:, i], u_i)
        np.testing.assert_allclose(motion.joint_points[:, k], carried, atol=1e-9)


def test_euler_parameters_keep_their_sign_from_sample_to_sample():
    motion = linkage_motion(linkage("double_pendulum"), np.linspace(0.0, 3.0, 181), method="DOP853", rtol=1e-8,
                            atol=1e-10)
    dots = np.einsum("nbi,nbi->nb", motion.p[1:], motion.p[:-1])
    assert np.all(dots > 0.0)
    np.testing.assert_allclose(np.linalg.norm(motion.p, axis=-1), 1.0, atol=1e-12)


def test_the_slider_crank_follows_its_closed_form_and_its_motor_does_work():
    link = linkage("slider_crank", speed=2.0 * math.pi)
    motion = linkage_motion(link, np.linspace(0.0, 1.0, 61), method="DOP853", rtol=1e-8, atol=1e-10)
    sc = link.slider_crank
    np.testing.assert_allclose(motion.closed_form, sc.slider_position(2.0 * math.pi * motion.t), rtol=1e-15)
    assert np.abs(motion.difference).max() < 1e-9
    assert motion.motor_torque.shape == (61, 3) and np.abs(motion.motor_torque).max() > 0.1
    assert np.ptp(motion.energy) > 0.1  # the motor does work: the energy is not constant
    assert motion.table().shape == (61, len(link.info.columns()))


def test_the_heavy_top_follows_the_closed_form_of_core_gyroscope():
    link = linkage("heavy_top")
    motion = linkage_motion(link, np.linspace(0.0, 2.0, 121), method="DOP853", rtol=1e-10, atol=1e-12)
    assert motion.difference[0] < 1e-12 and np.abs(motion.difference).max() < 1e-6
    # the closed-form top's centre of mass is l along its axis: the multibody one's, to the same accuracy
    np.testing.assert_allclose(np.linalg.norm(motion.closed_form_center, axis=1), link.top.length, rtol=1e-12)
    np.testing.assert_allclose(motion.closed_form_center, motion.R[:, 0], atol=1e-5)
    table = motion.table()
    np.testing.assert_allclose(table[:, -5:-1], motion.closed_form)
    np.testing.assert_allclose(table[:, -1], motion.difference)


@pytest.mark.parametrize("kind", LINKAGE_KINDS)
def test_a_motion_continued_from_its_final_state_is_the_long_run(kind):
    """Two runs of 1 s, the second from the first's final_state (pickled, as a worker process gets it), give
    the run of 2 s to the integrator's accuracy; the first run's System is left at t = 0."""
    link = linkage(kind)
    options = dict(method="DOP853", rtol=1e-10, atol=1e-12)
    first = linkage_motion(link, np.linspace(0.0, 1.0, 61), **options)
    second = linkage_motion(link, np.linspace(1.0, 2.0, 61), initial=pickle.loads(pickle.dumps(first.final_state)),
                            **options)
    whole = linkage_motion(link, np.linspace(0.0, 2.0, 121), **options)
    np.testing.assert_array_equal(second.R[0], first.R[-1])
    np.testing.assert_allclose(second.R, whole.R[60:], atol=1e-8)
    np.testing.assert_allclose(second.energy, whole.energy[60:], atol=1e-8)
    assert link.system.state.t == 0.0


def test_fixed_steps_continue_bit_for_bit():
    link = linkage("chain", n_links=3)
    first = linkage_motion(link, np.linspace(0.0, 0.5, 31), method="rk4", dt=1 / 240)
    second = linkage_motion(link, np.linspace(0.5, 1.0, 31), initial=first.final_state, method="rk4", dt=1 / 240)
    whole = linkage_motion(link, np.linspace(0.0, 1.0, 61), method="rk4", dt=1 / 240)
    np.testing.assert_allclose(second.R, whole.R[30:], rtol=0.0, atol=1e-13)


def test_refused_arguments_name_themselves():
    with pytest.raises(ValueError, match=r"kind: expected one of \['chain'"):
        linkage("four_bar")
    chain = linkage("chain", n_links=2)
    other = linkage_motion(linkage("heavy_top"), np.linspace(0.0, 0.1, 3))
    with pytest.raises(ValueError, match="initial: expected the state of 2 bodies"):
        linkage_motion(chain, np.linspace(0.1, 0.2, 3), initial=other.final_state)
    mine = linkage_motion(chain, np.linspace(0.0, 0.1, 3))
    with pytest.raises(ValueError, match=r"t: a run from initial starts at initial.t = 0.1"):
        linkage_motion(chain, np.linspace(0.0, 0.2, 3), initial=mine.final_state)
