"""Where the base stands when the written stance is blocked (tasks/stance_pose.py), checked with Pinocchio's
kinematics and plain plan-view geometry."""

from pathlib import Path

import numpy as np
import pinocchio as pin

from harmony_cli.scenario import load_scenario, robot_of
from harmony_cli.tasks.stance_pose import POSITION_TOL, stance_pose
from harmony_cli.tasks.two_stage import TaskReferences

PAPER = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
# the cylinder just west of the drop table: the base, behind the hands as written for the place, would be in it
BLOCKED = ["world.obstacles.cylinder.position=[4.75,0.2,1.0]"]
PLACE = ("carry", "approach_drop", "lower", "release", "open")


def _place(scenario, robot):
    phases = [p for p in scenario.task.phases if p.name in PLACE]
    targets = np.array([[p.hands[h] for h in robot.hand_names] for p in phases], dtype=float)
    d = targets[:, 1] - targets[:, 0]
    return targets, np.arctan2(d[:, 1], d[:, 0]) + np.pi / 2  # EVA's hands at home: left at +y, heading 0


def test_a_blocked_place_gets_a_pose_whose_hands_pinocchio_puts_on_the_targets_and_whose_base_clears():
    scenario = load_scenario(PAPER, BLOCKED)
    robot = robot_of(scenario, PAPER.parent)
    targets, headings = _place(scenario, robot)
    base, joints = stance_pose(scenario, robot, targets, headings)
    model = pin.buildModelFromUrdf(str(robot.urdf))
    data = model.createData()
    for q, pair in zip(joints, targets):
        q_pin = np.zeros(model.nq)
        q_pin[[model.joints[model.getJointId(j)].idx_q for j in robot.joint_names]] = q
        pin.framesForwardKinematics(model, data, q_pin)
        hands = np.array([data.oMf[model.getFrameId(link)].translation for link in robot.end_effectors])
        assert np.abs(hands - pair).max() <= POSITION_TOL + 1e-6
    cylinder = scenario.world.obstacles[0]
    c, s = np.cos(base[2]), np.sin(base[2])
    for x, y, r in scenario.robot.footprint:
        centre = base[:2] + [c * x - s * y, s * x + c * y]
        gap = np.linalg.norm(centre - np.asarray(cylinder.position[:2])) - r - cylinder.size[0] / 2
        assert gap >= cylinder.margin - 1e-4  # the soft-min over the circles is below their min: a margin to spare


def test_only_a_blocked_stance_routes_its_first_phase_through_a_pose_that_clears():
    scenario = load_scenario(PAPER)
    assert TaskReferences(robot_of(scenario, PAPER.parent), scenario).vias == {}
    scenario = load_scenario(PAPER, BLOCKED)
    references = TaskReferences(robot_of(scenario, PAPER.parent), scenario)
    assert [scenario.task.phases[i].name for i in references.vias] == ["carry"]
    assert np.linalg.norm(references.vias[5] - [4.75, 0.2]) > 0.6 + 0.3  # outside the cylinder and its margin


def test_a_blocked_grip_reached_through_an_approach_phase_gets_no_route_point():
    # the stance is found for the phases at the box; the approach ends 0.5 m before it, where that pose is not the
    # point to pass (routed through it, none of the study's blocked grips gained)
    scenario = load_scenario(PAPER, ["world.obstacles.cylinder.position=[3.2,1.6,1.0]"])
    references = TaskReferences(robot_of(scenario, PAPER.parent), scenario)
    assert references.stances[0].warning() is not None and references.vias == {}
