"""What a blocked stance changes (tasks/stance_plan.py): the chest posture, which pose it takes and where, checked
against Pinocchio's kinematics and plain geometry; and which phases get one."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from harmony_cli.scenario import load_scenario, robot_of
from harmony_cli.tasks.stance_plan import BLEND, NEAR, ChestPosture, pivot_targets
from harmony_cli.tasks.stance_pose import POSITION_TOL, stance_poses
from harmony_cli.tasks.two_stage import TaskReferences

PAPER = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
BLOCKED_PLACE = ["world.obstacles.cylinder.position=[4.5,0.2,1.0]"]
BLOCKED_GRIP = ["world.obstacles.cylinder.position=[3.2,1.6,1.0]"]
# the cylinder on the way to the place's front: the base can stand either side of it
EITHER_SIDE = ["world.obstacles.cylinder.position=[4.13,0.08,1.0]"]


def _references(*overrides):
    scenario = load_scenario(PAPER, list(overrides))
    robot = robot_of(scenario, PAPER.parent)
    return scenario, robot, TaskReferences(robot, scenario)


def _hands(middle):
    """(1, 2, 3): a hand pair 0.3 m apart about `middle` (2,) at 1.3 m."""
    return np.array([[np.r_[middle, 1.3] + [0.0, 0.15, 0.0], np.r_[middle, 1.3] - [0.0, 0.15, 0.0]]])


def test_the_posture_takes_the_chest_of_the_pose_nearest_the_base_in_full_near_the_pivot_and_none_far_from_it():
    bases, chests = np.array([[-0.6, 0.4], [-0.6, -0.4]]), np.array([[0.8], [-0.7]])
    posture = ChestPosture(frozenset({5}), np.zeros(2), bases, chests)
    north, south = np.array([-1.0, 1.0]), np.array([-1.0, -1.0])
    assert posture.at(_hands([0.1, 0.0]), north)[0, 0] == 0.8
    assert posture.at(_hands([0.1, 0.0]), south)[0, 0] == -0.7
    assert posture.at(_hands([NEAR + BLEND / 2, 0.0]), north)[0, 0] == pytest.approx(0.4)
    assert posture.at(_hands([NEAR + BLEND, 0.0]), north)[0, 0] == posture.at(_hands([3.0, 0.0]), north)[0, 0] == 0


def test_a_place_reachable_from_either_side_gets_a_pose_each_side_with_the_chest_turned_back_to_the_hands():
    scenario, robot, references = _references(*EITHER_SIDE)
    stance = next(s for s in references.stances if s.warning() is not None)
    targets, headings, _ = pivot_targets(scenario, robot, stance, references.planner.heading_offset)
    poses = stance_poses(scenario, robot, targets, headings)
    chest = robot.index(scenario.robot.chest_joints[0])
    sides = [np.sign(base[1] - stance.pivot_position[1]) for base, _ in poses]
    assert sorted(sides) == [-1, 1]
    model = pin.buildModelFromUrdf(str(robot.urdf))
    data = model.createData()
    index = [model.joints[model.getJointId(j)].idx_q for j in robot.joint_names]
    for (base, joints), side in zip(poses, sides):
        assert np.sign(joints[0, chest]) == side  # north of the place the base faces south-east, the chest turns left
        assert np.sign(base[2]) == -side
        for q, pair in zip(joints, targets):
            q_pin = np.zeros(model.nq)
            q_pin[index] = q
            pin.framesForwardKinematics(model, data, q_pin)
            hands = np.array([data.oMf[model.getFrameId(link)].translation for link in robot.end_effectors])
            assert np.abs(hands - pair).max() <= POSITION_TOL + 1e-6


def test_only_the_blocked_groups_phases_get_a_chest_posture():
    assert _references()[2].stance_plan.postures == []
    scenario, _, references = _references(*BLOCKED_PLACE)
    names = [p.name for p in scenario.task.phases]
    assert [sorted(names[i] for i in p.phases) for p in references.stance_plan.postures] == [sorted(names[5:])]
    scenario, _, references = _references(*BLOCKED_GRIP)
    assert [sorted(names[i] for i in p.phases) for p in references.stance_plan.postures] == [sorted(names[:5])]
    assert references.vias == {}  # its way in is an approach: no route point (test_stance_pose.py)
    assert references.stance_plan.chest(6, _hands([6.1, 0.0]), np.zeros(2)) is None  # the place: not blocked here
