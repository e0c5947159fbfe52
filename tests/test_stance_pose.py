"""Where the base stands when the written stance is blocked (planning/stance_pose.py), checked with Pinocchio's
kinematics, plain plan-view geometry and PyBullet's collision shapes."""

from pathlib import Path

import numpy as np
import pinocchio as pin
from conftest import needs_pybullet

from harmony_cli.mpc.clearance import FLOOR
from harmony_cli.planning.planner import Planner
from harmony_cli.planning.stance_pose import POSITION_TOL, stance_poses
from harmony_cli.scenario import load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.world import World
except ImportError:
    pass

PAPER = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
# the cylinder just west of the drop table: the base, behind the hands as written for the place, would be in it
BLOCKED = ["world.obstacles.cylinder.position=[4.5,0.2,1.0]"]
# 0.25 m nearer the table: the base fits between the cylinder's margin and the table only under the table's top,
# with the robot's waist inside it, or inside the cylinder's margin
UNDER_TOP = ["world.obstacles.cylinder.position=[4.75,0.2,1.0]"]
# 0.1 m nearer still: not even inside the margin (FLOOR from the cylinder) with the trunk out from under the top
NO_ROOM = ["world.obstacles.cylinder.position=[4.85,0.2,1.0]"]
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
    pose = stance_poses(scenario, robot, targets, headings, first=True)[0]
    base, joints = pose.base, pose.joints
    assert not pose.relieved
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
    assert _trunk_gap(scenario, base) >= -1e-6


def _trunk_gap(scenario, base) -> float:
    """[m] how far the robot's trunk circles stay out from under the drop table's top (plan view; < 0: under)."""
    table = next(t for t in scenario.world.tables if t.name == "drop_table")
    c, s = np.cos(base[2]), np.sin(base[2])
    yaw = np.deg2rad(table.yaw_deg)
    gaps = []
    for x, y, r, bottom, top in scenario.robot.trunk:
        if not (bottom < table.height and top > table.height - table.thickness):
            continue
        d = base[:2] + [c * x - s * y, s * x + c * y] - np.asarray(table.position)
        local = np.abs([np.cos(yaw) * d[0] + np.sin(yaw) * d[1], -np.sin(yaw) * d[0] + np.cos(yaw) * d[1]])
        outside = np.maximum(local - np.asarray(table.top) / 2, 0.0)
        depth = min(0.0, (local - np.asarray(table.top) / 2).max())  # inside: minus the way out
        gaps.append((np.linalg.norm(outside) if outside.any() else depth) - r)
    return min(gaps)


def test_a_place_reached_only_inside_the_cylinder_s_margin_gets_a_pose_that_goes_in_and_keeps_the_trunk_out():
    scenario = load_scenario(PAPER, UNDER_TOP)
    robot = robot_of(scenario, PAPER.parent)
    targets, headings = _place(scenario, robot)
    pose = stance_poses(scenario, robot, targets, headings, first=True)[0]
    cylinder = scenario.world.obstacles[0]
    assert pose.relieved and pose.reliefs[0] <= cylinder.margin - FLOOR + 1e-6
    assert _trunk_gap(scenario, pose.base) >= -1e-6
    c, s = np.cos(pose.base[2]), np.sin(pose.base[2])
    centres = [pose.base[:2] + [c * x - s * y, s * x + c * y] for x, y, _ in scenario.robot.footprint]
    radii = [r for _, _, r in scenario.robot.footprint]
    gaps = [np.linalg.norm(p - cylinder.position[:2]) - r - cylinder.size[0] / 2 for p, r in zip(centres, radii)]
    assert min(gaps) >= cylinder.margin - pose.reliefs[0] - 1e-4  # the soft-min is below the circles' min
    # without the trunk the pose found stands the base under the table, its waist inside the top, and keeps the margin
    bare = load_scenario(PAPER, [*UNDER_TOP, "robot.trunk=[]"])
    pose = stance_poses(bare, robot, targets, headings, first=True)[0]
    assert _trunk_gap(scenario, pose.base) < -0.1 and not pose.relieved


def test_a_place_with_no_room_even_inside_the_margin_gets_no_pose_no_route_point_and_a_warning():
    scenario = load_scenario(PAPER, NO_ROOM)
    robot = robot_of(scenario, PAPER.parent)
    assert stance_poses(scenario, robot, *_place(scenario, robot), first=True) == []
    references = Planner(robot, scenario)
    assert references.stance_plan.vias == {}
    assert [w for w in references.warnings if w.startswith("stance: no base pose found")] == [
        "stance: no base pose found, clear of the scene (obstacles' margins down to 0.05 m; the trunk out from under "
        "table tops), from which the hands reach phases carry to retreat at the box's goal (8 starts searched; not a "
        "proof that none exists): the robot may not get there"
    ]


def _trunk_contact_in_pybullet(scenario, robot, joints) -> float:
    """[m] PyBullet's closest distance between the drop table's top and the robot's links that are not arms
    (the base, waist, chest, head) with the joints at `joints`; < 0: they overlap."""
    client = BulletClient(connection_mode=pybullet.DIRECT)
    top = World(client, scenario.world).tables["drop_table"][0]
    body = client.loadURDF(str(robot.urdf), useFixedBase=True)
    names = {client.getJointInfo(body, i)[1].decode(): i for i in range(client.getNumJoints(body))}
    for j, name in enumerate(robot.joint_names):
        client.resetJointState(body, names[name], joints[j])
    trunk = [i for i in range(client.getNumJoints(body)) if "ARM" not in client.getJointInfo(body, i)[12].decode()]
    gaps = [p[8] for i in trunk for p in client.getClosestPoints(body, top, 0.5, linkIndexA=i)]
    client.disconnect()
    return min(gaps, default=0.5)


@needs_pybullet
def test_pybullet_sees_the_waist_inside_the_table_top_at_the_trunkless_pose_and_nothing_at_the_trunk_aware_one():
    robot = robot_of(load_scenario(PAPER), PAPER.parent)
    bare = load_scenario(PAPER, [*UNDER_TOP, "robot.trunk=[]"])
    targets, headings = _place(bare, robot)
    joints = stance_poses(bare, robot, targets, headings, first=True)[0].joints
    assert min(_trunk_contact_in_pybullet(bare, robot, q) for q in joints) < -0.05
    blocked = load_scenario(PAPER, BLOCKED)
    joints = stance_poses(blocked, robot, *_place(blocked, robot), first=True)[0].joints
    assert min(_trunk_contact_in_pybullet(blocked, robot, q) for q in joints) > 0.0


def test_only_a_blocked_stance_routes_its_first_phase_through_a_pose_that_clears():
    scenario = load_scenario(PAPER)
    assert Planner(robot_of(scenario, PAPER.parent), scenario).stance_plan.vias == {}
    scenario = load_scenario(PAPER, BLOCKED)
    references = Planner(robot_of(scenario, PAPER.parent), scenario)
    assert [scenario.task.phases[i].name for i in references.stance_plan.vias] == ["carry"]
    assert (
        np.linalg.norm(references.stance_plan.vias[5] - [4.5, 0.2]) > 0.6 + 0.3
    )  # outside the cylinder and its margin


def test_a_blocked_grip_reached_through_an_approach_phase_gets_no_route_point():
    # the stance is found for the phases at the box; the approach ends 0.5 m before it, where that pose is not the
    # point to pass (routed through it, none of the study's blocked grips gained)
    scenario = load_scenario(PAPER, ["world.obstacles.cylinder.position=[3.2,1.6,1.0]"])
    references = Planner(robot_of(scenario, PAPER.parent), scenario)
    assert references.stances[0].warning() is not None and references.stance_plan.vias == {}


def test_the_pose_found_faces_the_pads_across_the_targets_whatever_the_robot_s_start_yaw():
    from harmony_cli.planning.stance_check import home_hands

    for yaw_deg in (0.0, 40.0):
        scenario = load_scenario(PAPER, [*BLOCKED, f"robot.base_pose=[0.0,0.0,{yaw_deg}]"])
        robot = robot_of(scenario, PAPER.parent)
        targets, _ = _place(scenario, robot)
        d = targets[:, 1] - targets[:, 0]
        headings = np.arctan2(d[:, 1], d[:, 0]) + home_hands(robot)[1]  # the planner's: 0 at home as it starts
        for q, pair in zip(stance_poses(scenario, robot, targets, headings, first=True)[0].joints, targets):
            across = (pair[1] - pair[0]) / np.linalg.norm(pair[1] - pair[0])
            for h, (_, rotation) in enumerate(robot.hand_poses_numeric(q)):
                normal = rotation[:, 2]  # the pad's normal points at the other pad
                assert normal @ (across if h == 0 else -across) > np.cos(np.deg2rad(3.0)), (yaw_deg, h)
