"""The joints a robot moves by default (the chains from its root to the hands) and its mimic joints: locked off the
chains, moving with their leader on one, the same in the MPC, OpTaS, Pinocchio and PyBullet; an explicit list wins."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import assert_rejected, needs_pybullet

from harmony_cli.mpc.knot_params import hand_rows
from harmony_cli.mpc.wholebody import WholeBodyMPC
from harmony_cli.robot.mimic import Coupling
from harmony_cli.robot.presets import resolve_path
from harmony_cli.robot.reach import highest_pose
from harmony_cli.scenario import load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass

BASE = ("base_x", "base_y", "base_yaw")
ARMS = ("l_shoulder", "l_elbow", "l_wrist", "r_shoulder", "r_elbow", "r_wrist")
WRIST_MIMIC = (0.5, 0.2)  # an on-chain mimic: wrist = 0.5 elbow + 0.2 rad
INERTIAL = (
    '<inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
)


def _joint(name: str, kind: str, parent: str, child: str, xyz: str, axis: str = "0 1 0", mimic: str = "") -> str:
    limit = '<limit lower="-2" upper="2" effort="50" velocity="2"/>'
    moving = f'<axis xyz="{axis}"/>{limit}{mimic}' if kind != "fixed" else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="0 0 0"/>{moving}</joint>'
    )


def two_arm_urdf(path: Path, wrist_mimic: bool = False) -> Path:
    """A torso with a head (a joint off the chains) and two 3-joint arms, each hand with a tool frame (a fixed link)
    and a parallel gripper whose second finger mimics the first (-1 x finger + 0.01 m); with `wrist_mimic`, each
    wrist mimics its elbow (WRIST_MIMIC), a mimic joint on the chain to the hand."""
    parts = [f'<robot name="two_arm"><link name="torso">{INERTIAL}</link><link name="head">{INERTIAL}</link>']
    parts.append(_joint("head_pan", "revolute", "torso", "head", "0 0 0.7", axis="0 0 1"))
    for side, y in (("l", 0.2), ("r", -0.2)):
        links = ("upper", "fore", "hand", "finger_a", "finger_b")
        parts += [f'<link name="{side}_{link}">{INERTIAL}</link>' for link in links]
        wrist = f'<mimic joint="{side}_elbow" multiplier="{WRIST_MIMIC[0]}" offset="{WRIST_MIMIC[1]}"/>'
        parts += [
            _joint(f"{side}_shoulder", "revolute", "torso", f"{side}_upper", f"0 {y} 0.5"),
            _joint(f"{side}_elbow", "revolute", f"{side}_upper", f"{side}_fore", "0.3 0 0"),
            _joint(
                f"{side}_wrist",
                "revolute",
                f"{side}_fore",
                f"{side}_hand",
                "0.3 0 0",
                mimic=wrist if wrist_mimic else "",
            ),
            _joint(f"{side}_finger", "prismatic", f"{side}_hand", f"{side}_finger_a", "0.05 0.02 0"),
            _joint(
                f"{side}_finger_mirror",
                "prismatic",
                f"{side}_hand",
                f"{side}_finger_b",
                "0.05 -0.02 0",
                mimic=f'<mimic joint="{side}_finger" multiplier="-1" offset="0.01"/>',
            ),
            f'<link name="{side}_tool"/>',
            _joint(f"{side}_tool_joint", "fixed", f"{side}_hand", f"{side}_tool", "0.12 0 0"),
        ]
    path.write_text("\n".join([*parts, "</robot>"]))
    return path


def _scenario(tmp_path: Path, fields: str = "", wrist_mimic: bool = False) -> Path:
    two_arm_urdf(tmp_path / "two_arm.urdf", wrist_mimic)
    path = tmp_path / "scenario.yaml"
    path.write_text(
        "name: two_arm\nrobot: {urdf: two_arm.urdf, end_effectors: {left: l_tool, right: r_tool}, mount: null"
        f"{', ' + fields if fields else ''}}}\nreference: {{type: hold}}\n"
    )
    return path


def _robot(tmp_path: Path, fields: str = "", wrist_mimic: bool = False):
    path = _scenario(tmp_path, fields, wrist_mimic)
    scenario = load_scenario(path)
    return scenario, robot_of(scenario, tmp_path)


def _note(robot, start: str) -> str:
    return next(note for note in robot.notes if note.startswith(start))


def test_by_default_the_arms_on_the_chains_move_and_the_mimic_fingers_are_locked(tmp_path):
    _, robot = _robot(tmp_path)
    assert robot.joint_names == (*BASE, *ARMS) and robot.couplings == ()
    assert _note(robot, "urdf: locked joints") == (
        "urdf: locked joints (off the chains to the hands): 5: head_pan=0, l_finger=0, r_finger=0, "
        "l_finger_mirror=0.01, r_finger_mirror=0.01"
    )


def test_an_explicit_active_joints_list_wins_over_the_chains(tmp_path):
    _, robot = _robot(tmp_path, "active_joints: [head_pan, l_shoulder, l_elbow, r_shoulder, r_elbow]")
    assert robot.joint_names == (*BASE, "head_pan", "l_shoulder", "l_elbow", "r_shoulder", "r_elbow")
    assert _note(robot, "urdf: locked joints").startswith(
        "urdf: locked joints (not in robot.active_joints): 6: l_wrist=0, l_finger=0, r_wrist=0, r_finger=0,"
    )


def test_a_pinned_joint_off_the_chains_stays_active(tmp_path):
    _, robot = _robot(tmp_path, "pinned_joints: [head_pan]")
    assert robot.joint_names == (*BASE, "head_pan", *ARMS) and robot.pinned_joints == (3,)


def test_a_listed_leader_moves_its_mimic_joint_with_it(tmp_path):
    _, robot = _robot(tmp_path, f"active_joints: [{', '.join(ARMS)}, l_finger]")
    follower, leader = robot.index("l_finger_mirror"), robot.index("l_finger")
    assert robot.couplings == (Coupling(follower, leader, -1.0, 0.01),)
    assert robot.home[follower] == pytest.approx(0.01)
    assert "urdf: mimic joints moving with their leader: 1: l_finger_mirror=-1*l_finger+0.01" in robot.notes


def test_a_mimic_joint_listed_without_its_leader_is_refused_in_one_line(tmp_path):
    path = _scenario(tmp_path, f"active_joints: [{', '.join(ARMS)}, l_finger_mirror]")
    assert_rejected(path, ["robot.active_joints: 'l_finger_mirror' mimics 'l_finger', which is not listed"])


def test_a_home_for_a_mimic_joint_off_its_leaders_value_is_refused_in_one_line(tmp_path):
    path = _scenario(tmp_path, "home: {l_finger_mirror: 0.03}")
    assert_rejected(path, ["robot.home.l_finger_mirror: 'l_finger_mirror' mimics 'l_finger'"])


@pytest.fixture
def bullet():
    client = BulletClient(pybullet.DIRECT)
    yield client
    client.disconnect()


@needs_pybullet
def test_an_on_chain_mimic_puts_the_hand_where_optas_pinocchio_and_pybullet_agree(tmp_path, bullet):
    """The wrist follows the elbow: OpTaS on the coupled joint vector, Pinocchio's own mimic model given the
    leaders only, and PyBullet given every joint put the hands at the same place."""
    _, robot = _robot(tmp_path, wrist_mimic=True)
    assert robot.couplings == tuple(
        Coupling(robot.index(f"{s}_wrist"), robot.index(f"{s}_elbow"), *WRIST_MIMIC) for s in "lr"
    )
    mimicking = pin.buildModelFromUrdf(str(robot.urdf), True)
    data = mimicking.createData()
    body = bullet.loadURDF(str(robot.urdf), useFixedBase=True)
    info = [bullet.getJointInfo(body, i) for i in range(bullet.getNumJoints(body))]
    joints, links = {i[1].decode(): i[0] for i in info}, {i[12].decode(): i[0] for i in info}
    for elbow in (-1.2, 0.4, 1.5):
        q = robot.home.copy()
        q[[robot.index("l_elbow"), robot.index("r_elbow")]] = elbow, -elbow
        q = robot.coupled(q)
        config = pin.neutral(mimicking)
        for name, value in zip(robot.joint_names, q, strict=True):
            joint = mimicking.joints[mimicking.getJointId(name)]
            if name not in ("l_wrist", "r_wrist"):
                config[joint.idx_q] = value
        pin.framesForwardKinematics(mimicking, data, config)
        for name, value in zip(robot.joint_names, q, strict=True):
            bullet.resetJointState(body, joints[name], value)
        for hand, (position, _) in enumerate(robot.hand_poses_numeric(q)):
            link = robot.end_effectors[hand]
            np.testing.assert_allclose(data.oMf[mimicking.getFrameId(link)].translation, position.ravel(), atol=1e-9)
            in_bullet = bullet.getLinkState(body, links[link], computeForwardKinematics=True)[4]
            np.testing.assert_allclose(in_bullet, position.ravel(), atol=1e-6)
        uncoupled, followers = q.copy(), [c.follower for c in robot.couplings]
        uncoupled[followers] = robot.home[followers]  # the wrists left where they were: the hands elsewhere
        assert np.linalg.norm(robot.hand_poses_numeric(uncoupled)[0][0] - robot.hand_poses_numeric(q)[0][0]) > 0.01


@pytest.mark.parametrize(
    ("transcription", "integration"), [("bezier", "euler"), ("traditional", "euler"), ("traditional", "trapezoidal")]
)
def test_the_whole_body_mpc_moves_an_on_chain_mimic_with_its_leader(tmp_path, transcription, integration):
    scenario, robot = _robot(tmp_path, wrist_mimic=True)
    mpc_spec = {"transcription": transcription, "integration": integration, "knots": 6}
    scenario = scenario.model_copy(update={"mpc": scenario.mpc.model_copy(update=mpc_spec)})
    mpc = WholeBodyMPC(robot, scenario, scenario.sim.control_dt)
    K = mpc.transcription.n_knots
    poses = robot.hand_poses_numeric(robot.home)
    positions = np.array([[p.ravel() + [0.0, 0.0, 0.05] for p, _ in poses]] * K)  # both hands 5 cm up
    rotations = np.array([[r for _, r in poses]] * K)
    command, result = mpc.step(robot.home.copy(), hand_rows(positions, rotations))
    assert result.success
    q, dq, _ = mpc.transcription.knots(mpc.x)
    for c in robot.couplings:
        np.testing.assert_allclose(q[c.follower], c.multiplier * q[c.leader] + c.offset, atol=1e-9)
        np.testing.assert_allclose(dq[c.follower], c.multiplier * dq[c.leader], atol=1e-9)
        assert command.q[c.follower] == pytest.approx(c.multiplier * command.q[c.leader] + c.offset, abs=1e-9)
    assert np.ptp(q[robot.index("l_elbow")]) > 1e-3  # the leader moves, and its follower with it


def test_the_reach_search_moves_an_on_chain_mimic_only_through_its_leader(tmp_path):
    """The hands' highest height the search reports is where its joint positions put them, and those keep each
    wrist on its elbow."""
    _, robot = _robot(tmp_path, wrist_mimic=True)
    height, q = highest_pose(robot, 0.4)  # the arms turn in their planes, 0.4 m apart
    np.testing.assert_allclose(q, robot.coupled(q), atol=1e-12)
    (left, _), (right, _) = robot.hand_poses_numeric(q)
    assert 0.5 * (left[2] + right[2]) == pytest.approx(height, abs=1e-6)
    assert abs(q[robot.index("l_elbow")] - robot.home[robot.index("l_elbow")]) > 1e-3


def test_a_catalogue_robot_with_mimic_fingers_loads_from_a_three_line_robot_section(tmp_path):
    """TIAGo Pro (example-robot-data, no preset): its grippers' ten mimic joints locked, the chains to the hands
    (torso lift and 2 x 7 arm joints) active."""
    urdf = resolve_path("example-robot-data:example-robot-data/robots/tiago_pro_description/robots/tiago_pro.urdf", "")
    path = tmp_path / "tiago_pro.yaml"
    path.write_text(
        f"name: tiago_pro\nrobot:\n  urdf: {urdf}\n  package_paths: [{resolve_path('example-robot-data:', '')}]\n"
        "  end_effectors: {left: arm_left_tool_link, right: arm_right_tool_link}\nreference: {type: hold}\n"
    )
    scenario = load_scenario(path)
    robot = robot_of(scenario, tmp_path)
    arms = tuple(f"arm_{side}_{i}_joint" for side in ("left", "right") for i in range(1, 8))
    assert robot.joint_names == (*BASE, "torso_lift_joint", *arms)
    assert _note(robot, "urdf: locked joints").startswith("urdf: locked joints (off the chains to the hands): 18: ")
