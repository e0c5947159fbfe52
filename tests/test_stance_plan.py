"""What a blocked stance changes (planning/stance_plan.py): the chest posture and the base's stance, which pose they
take and where, checked against Pinocchio's kinematics and plain geometry; which phases get one; and the margins
the whole-body MPC lowers where no pose keeps them."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from harmony_cli.mpc.clearance import FLOOR
from harmony_cli.planning.planner import Planner
from harmony_cli.planning.stance_plan import (
    BLEND,
    NEAR,
    RELIEF_SPARE,
    STANCE_BLEND,
    ChestRamp,
    Posture,
    StancePlan,
    pivot_targets,
)
from harmony_cli.planning.stance_pose import POSITION_TOL, stance_poses
from harmony_cli.scenario import load_scenario, robot_of

PAPER = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
BLOCKED_PLACE = ["world.obstacles.cylinder.position=[4.5,0.2,1.0]"]
BLOCKED_GRIP = ["world.obstacles.cylinder.position=[3.2,1.6,1.0]"]
# the cylinder on the way to the place's front: the base can stand either side of it
EITHER_SIDE = ["world.obstacles.cylinder.position=[4.13,0.08,1.0]"]


def _references(*overrides):
    scenario = load_scenario(PAPER, list(overrides))
    robot = robot_of(scenario, PAPER.parent)
    return scenario, robot, Planner(robot, scenario)


def _hands(middle):
    """(1, 2, 3): a hand pair 0.3 m apart about `middle` (2,) at 1.3 m."""
    return np.array([[np.r_[middle, 1.3] + [0.0, 0.15, 0.0], np.r_[middle, 1.3] - [0.0, 0.15, 0.0]]])


def _posture() -> Posture:
    bases, chests = np.array([[-0.6, 0.4, -0.5], [-0.6, -0.4, 0.5]]), np.array([[0.8], [-0.7]])
    return Posture(frozenset({5}), np.zeros(2), bases, chests)


def test_the_posture_takes_the_chest_of_the_pose_nearest_the_base_in_full_near_the_pivot_and_none_far_from_it():
    posture = _posture()
    north, south = np.array([-1.0, 1.0]), np.array([-1.0, -1.0])
    assert posture.chest(_hands([0.1, 0.0]), north)[0, 0] == 0.8
    assert posture.chest(_hands([0.1, 0.0]), south)[0, 0] == -0.7
    assert posture.chest(_hands([NEAR + BLEND / 2, 0.0]), north)[0, 0] == pytest.approx(0.4)
    far = posture.chest(_hands([3.0, 0.0]), north)[0, 0]
    assert posture.chest(_hands([NEAR + BLEND, 0.0]), north)[0, 0] == far == 0


def test_the_stance_puts_the_base_where_the_nearest_pose_stands_from_the_pivot_at_the_knots_near_it_alone():
    posture = _posture()
    stance = posture.stance(_hands([0.3, 0.1]), np.array([-1.0, -1.0]))  # the southern pose is nearest
    blend = 1.0 - (np.hypot(0.3, 0.1) - NEAR) / STANCE_BLEND
    np.testing.assert_allclose(stance[:, 0], [0.3 - 0.6, 0.1 - 0.4, 0.5, blend])
    assert posture.stance(_hands([NEAR + STANCE_BLEND, 0.0]), np.zeros(2))[3, 0] == 0.0  # on the way: none


def test_a_place_reachable_from_either_side_gets_a_pose_each_side_with_the_chest_turned_back_to_the_hands():
    scenario, robot, references = _references(*EITHER_SIDE)
    stance = next(s for s in references.stances if s.warning() is not None)
    targets, headings, _ = pivot_targets(stance, references.planner.heading_offset)
    poses = stance_poses(scenario, robot, targets, headings)
    chest = robot.index(scenario.robot.chest_joints[0])
    sides = [np.sign(pose.base[1] - stance.pivot_position[1]) for pose in poses]
    assert sorted(sides) == [-1, 1]
    model = pin.buildModelFromUrdf(str(robot.urdf))
    data = model.createData()
    index = [model.joints[model.getJointId(j)].idx_q for j in robot.joint_names]
    for pose, side in zip(poses, sides):
        assert np.sign(pose.joints[0, chest]) == side  # north of the place the base faces south-east, chest left
        assert np.sign(pose.base[2]) == -side
        for q, pair in zip(pose.joints, targets):
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
    assert references.stance_plan.vias == {}  # its way in is an approach: no route point (test_stance_pose.py)
    assert references.stance_plan.posture(6) is None  # the place: not blocked here, no chest posture


def test_a_place_reached_only_inside_the_cylinder_s_margin_lowers_that_margin_in_the_place_s_phases_alone():
    scenario, _, references = _references("world.obstacles.cylinder.position=[5.14,0.64,1.0]")
    names = [p.name for p in scenario.task.phases]
    plan = references.stance_plan
    assert sorted(names[i] for i in plan.reliefs) == sorted(names[5:])
    relief = plan.reliefs[names.index("lower")]
    give = scenario.world.obstacles[0].margin - FLOOR
    assert relief.shape == (1,) and RELIEF_SPARE < relief[0] <= give
    scenario, _, references = _references(*BLOCKED_PLACE)  # a pose that keeps the margin: nothing lowered
    assert references.stance_plan.reliefs == {}


def test_a_chest_posture_that_ends_turns_back_no_faster_than_the_rate():
    ramp, knots, dt = ChestRamp(0.5, 0.1), np.linspace(0.0, 5.0, 26), 0.02
    posture = np.full((1, knots.size), 1.4)
    assert ramp(None, 7.0, knots, np.zeros(1)) is None  # no posture yet: straight, nothing to ramp
    first = ramp(posture, 7.0, knots, np.full(1, 0.1))
    np.testing.assert_allclose(first[0], np.minimum(0.1 + 0.5 * knots, 1.4))  # from the measured chest, at the rate
    ramp = ChestRamp(0.5, 0.1)
    t, refs = 0.0, []
    while (ref := ramp(posture if t < 3.0 else None, t, knots, np.zeros(1))) is not None:
        refs.append(ref[0, 0])
        t += dt
    assert max(refs) == pytest.approx(1.4) and np.abs(np.diff(refs)).max() <= 0.5 * dt + 1e-12
    assert t == pytest.approx(3.0 + 1.4 / 0.5, abs=2 * dt)  # back to straight, then None again


def test_a_chest_turned_under_a_held_box_turns_back_at_the_held_rate():
    ramp, knots, dt = ChestRamp(0.5, 0.1), np.linspace(0.0, 5.0, 26), 0.02
    assert ramp(None, 0.0, knots, np.zeros(1), held=True) is None  # straight: nothing to ramp
    first = ramp(None, 0.0, knots, np.full(1, 0.3), held=True)  # turned with no posture: from where it is
    np.testing.assert_allclose(first[0], np.maximum(0.3 - 0.1 * knots, 0.0))
    t, refs = dt, [first[0, 0]]
    while (ref := ramp(None, t, knots, np.zeros(1), held=True)) is not None:
        refs.append(ref[0, 0])
        t += dt
    assert np.abs(np.diff(refs)).max() <= 0.1 * dt + 1e-12 and t == pytest.approx(0.3 / 0.1, abs=2 * dt)


def test_a_stalled_phases_posture_comes_first_for_it_alone_and_its_reliefs_are_the_larger_per_obstacle():
    group = _posture()  # phase 5's, with its group
    plan = StancePlan({}, [group], [], {5: np.array([0.1, 0.0]), 6: np.array([0.1, 0.0])})
    mine = Posture(frozenset({5}), np.ones(2), np.array([[0.5, 0.5, 0.0]]), np.array([[0.3]]))
    recovered = plan.recovered(mine, np.array([0.05, 0.2]))
    assert recovered.postures == [mine, group] and plan.postures == [group]
    assert recovered.posture(5).chest(_hands([1.0, 1.0]), np.zeros(2))[0, 0] == 0.3
    np.testing.assert_array_equal(recovered.reliefs[5], [0.1, 0.2])
    np.testing.assert_array_equal(recovered.reliefs[6], [0.1, 0.0])
