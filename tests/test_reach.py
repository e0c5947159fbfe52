"""How high both hands reach together (robot/reach.py), checked against Pinocchio's kinematics."""

import numpy as np
import pinocchio as pin

from harmony_cli.robot.reach import ROTATION_TOL, hand_ceiling, highest_pose

WIDTH = 0.308  # the paper's box between the pads


def _home_at_origin(robot):
    home = robot.home.copy()
    home[list(robot.base_joints)] = 0.0
    return home


def test_the_highest_level_grip_is_a_pose_within_the_limits_that_pinocchio_puts_at_that_height(eva):
    height, q = highest_pose(eva, WIDTH)
    bounded = [i for i in range(eva.n_dof) if i not in eva.continuous]
    assert np.all(q[bounded] >= eva.lower[bounded] - 1e-7) and np.all(q[bounded] <= eva.upper[bounded] + 1e-7)
    model = pin.buildModelFromUrdf(str(eva.urdf))
    data = model.createData()
    q_pin = np.zeros(model.nq)
    q_pin[[model.joints[model.getJointId(j)].idx_q for j in eva.joint_names]] = q
    pin.framesForwardKinematics(model, data, q_pin)
    frames = [data.oMf[model.getFrameId(link)] for link in eva.end_effectors]
    np.testing.assert_allclose([f.translation[2] for f in frames], height, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(frames[1].translation - frames[0].translation), WIDTH, atol=1e-6)
    for frame, (_, home_rotation) in zip(frames, eva.hand_poses_numeric(_home_at_origin(eva))):
        turn = frame.rotation @ home_rotation.T  # the pads level: a turn about the vertical only
        assert np.sum((turn[:, 2] - [0, 0, 1]) ** 2) <= 4 * ROTATION_TOL


def test_the_ceiling_is_above_home_computed_once_then_read_back_from_the_cache(eva, tmp_path, monkeypatch):
    monkeypatch.setattr("harmony_cli.cache.CACHE_DIR", tmp_path)
    home = _home_at_origin(eva)
    computed = hand_ceiling(eva, WIDTH)
    assert computed > eva.hand_poses_numeric(home)[0][0].ravel()[2] + 0.3  # the arms lift well above home
    assert len(list(tmp_path.glob("reach/*.json"))) == 1
    assert hand_ceiling(eva, WIDTH) == computed
    assert abs(computed - highest_pose(eva, WIDTH)[0]) < 1e-9


def test_a_carry_written_above_the_ceiling_is_warned_of_and_the_paper_s_is_not():
    from pathlib import Path

    from harmony_cli.planning.planner import Planner
    from harmony_cli.scenario import load_scenario, robot_of

    path = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
    high = ["task.phases.carry.hands.left=[6.1,0.154,1.75]", "task.phases.carry.hands.right=[6.1,-0.154,1.75]"]
    for overrides, expected in (([], 0), (high, 1)):
        scenario = load_scenario(path, overrides)
        references = Planner(robot_of(scenario, path.parent), scenario)
        assert len(references.warnings) == expected
    assert references.warnings[0].startswith("reach: phase carry asks the left hand at z = 1.750 m, above the")


def test_a_carry_higher_than_either_arm_reaches_is_refused_before_the_robot_moves():
    from pathlib import Path

    from harmony_cli.scenario import load_scenario
    from harmony_cli.tasks.scene_check import SceneCheck

    path = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
    check = SceneCheck(path.parent)
    assert check.unreachable(load_scenario(path)) is None
    # 2.3 m: above the arms' links laid end to end (2.26 m), so certainly out of reach
    high = ["task.phases.carry.hands.left=[6.1,0.154,2.3]", "task.phases.carry.hands.right=[6.1,-0.154,2.3]"]
    why = check.unreachable(load_scenario(path, high))
    assert why is not None and why.startswith("phase carry: the left hand's target [6.1, 0.154, 2.3] and the"), why
    assert why.endswith("out of reach from every collision-free base pose")


def test_a_place_amid_a_table_wider_than_the_arms_reach_is_refused_for_the_trunk_not_for_the_footprint():
    from pathlib import Path

    from harmony_cli.scenario import load_scenario
    from harmony_cli.tasks.scene_check import SceneCheck

    path = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
    check = SceneCheck(path.parent)
    # the drop table 4 m square, centred on the place: the base fits between its legs, under its top; the waist
    # does not, and from outside the top the place is farther than either hand reaches (1.1-1.2 m)
    wide = ["world.tables.drop_table.top=[4.0,4.0]", "world.tables.drop_table.position=[6.1,0.0]"]
    assert check.unreachable(load_scenario(path, [*wide, "robot.trunk=[]"])) is None
    why = check.unreachable(load_scenario(path, wide))
    assert why is not None and why.startswith("phase carry:") and why.endswith("collision-free base pose"), why


def test_no_joint_values_put_a_hand_beyond_its_reach_bound_in_pinocchio_s_kinematics(eva):
    from harmony_cli.robot.reach_bound import reach_bound

    model = pin.buildModelFromUrdf(str(eva.urdf))
    data = model.createData()
    rng = np.random.default_rng(0)
    arms = [i for i in range(eva.n_dof) if i not in eva.base_joints]
    for hand in range(2):
        bound, frame = reach_bound(eva, hand), model.getFrameId(eva.end_effectors[hand])
        farthest = 0.0
        for _ in range(2000):
            q = _home_at_origin(eva)
            q[arms] = rng.uniform(np.maximum(eva.lower[arms], -np.pi), np.minimum(eva.upper[arms], np.pi))
            q_pin = np.zeros(model.nq)
            q_pin[[model.joints[model.getJointId(j)].idx_q for j in eva.joint_names]] = q
            pin.framesForwardKinematics(model, data, q_pin)
            p = data.oMf[frame].translation
            radius = bound.radius(float(p[2]))
            assert radius is not None and np.hypot(p[0], p[1]) <= radius + 1e-9
            farthest = max(farthest, np.hypot(p[0], p[1]) / radius)
        assert farthest > 0.6  # the bound is not vacuous: random poses come within reach of it


def test_the_reach_bound_is_at_least_the_farthest_reach_the_optimiser_finds(eva):
    from harmony_cli.robot.reach import hand_radius
    from harmony_cli.robot.reach_bound import reach_bound

    for hand in range(2):
        bound = reach_bound(eva, hand)
        for z in (1.0, 1.245, 1.5):
            found = hand_radius(eva, hand, z)
            assert found is not None and found <= bound.radius(z)
