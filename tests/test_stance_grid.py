"""The stance search (planning/stance_pose.py) against a brute-force grid of base poses on a small scene: every pose of
the grid is checked with plain plan-view geometry (shapely) and Pinocchio's inverse kinematics, independent of the
search's CasADi model."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import shapely
from shapely.affinity import rotate, translate
from shapely.geometry import box

from harmony_cli.maths.rotations import rot_z
from harmony_cli.mpc.clearance import SOFTMIN
from harmony_cli.planning.stance_pose import POSITION_TOL, ROTATION_TOL, stance_poses
from harmony_cli.robot.reach import arm_joints
from harmony_cli.scenario import load_scenario, robot_of

PAPER = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
# the cylinder north-west of the drop table's near edge: the base cannot stand behind the place as written, and
# the poses beside it are inside the cylinder's margin
SCENE = ["world.obstacles.cylinder.position=[5.14,0.64,1.0]"]
PLACE = np.array([[[6.1, 0.154, 1.245], [6.1, -0.154, 1.245]]])  # the paper's lower phase: heading 0
STEP_M, STEP_DEG = 0.05, 7.5
REACH = 1.2  # [m] the grid's poses within this of the targets' midpoint: beyond the arms' reach


def _outlines(scenario):
    """Plan-view polygons: the table legs (the footprint keeps the base margin from them) and the table tops (the
    trunk keeps out from under them)."""
    legs, tops = [], []
    for table in scenario.world.tables:
        yaw = table.yaw_deg
        top = rotate(box(-table.top[0] / 2, -table.top[1] / 2, table.top[0] / 2, table.top[1] / 2), yaw, (0, 0))
        tops.append(translate(top, *table.position))
        leg = 0.05
        for sx in (-1, 1):
            for sy in (-1, 1):
                x, y = sx * (table.top[0] / 2 - leg), sy * (table.top[1] / 2 - leg)
                square = rotate(box(x - leg / 2, y - leg / 2, x + leg / 2, y + leg / 2), yaw, (0, 0))
                legs.append(translate(square, *table.position))
    return legs, tops


def _grid_reliefs(scenario, poses: np.ndarray) -> np.ndarray:
    """Per base pose (n, 3), how far its footprint goes into the cylinder's margin [m] (inf: into a table leg's
    margin, or the trunk under a table's top, or into the cylinder itself)."""
    robot = scenario.robot
    cylinder = scenario.world.obstacles[0]
    centre, radius = np.asarray(cylinder.position[:2]), cylinder.size[0] / 2
    legs, tops = _outlines(scenario)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    reliefs = np.zeros(len(poses))
    for x, y, r in robot.footprint:
        px, py = poses[:, 0] + c * x - s * y, poses[:, 1] + s * x + c * y
        gap = np.hypot(px - centre[0], py - centre[1]) - radius - r
        reliefs = np.maximum(reliefs, cylinder.margin - gap)
        reliefs[gap < 0.0] = np.inf
        points = shapely.points(px, py)
        for leg in legs:
            reliefs[shapely.distance(points, leg) - r < robot.base_margin] = np.inf
    for x, y, r, _, _ in robot.trunk:
        points = shapely.points(poses[:, 0] + c * x - s * y, poses[:, 1] + s * x + c * y)
        for top in tops:
            reliefs[shapely.distance(points, top) < r] = np.inf
    return np.maximum(reliefs, 0.0)


class _Reach:
    """Pinocchio's damped least-squares IK of both hands with the base fixed at a pose."""

    def __init__(self, robot, chest_joints: list[str]):
        self.robot, self.chest = robot, [robot.index(j) for j in chest_joints]
        self.model = pin.buildModelFromUrdf(str(robot.urdf))
        self.data = self.model.createData()
        self.q_index = [self.model.joints[self.model.getJointId(j)].idx_q for j in robot.joint_names]
        self.v_index = [self.model.joints[self.model.getJointId(j)].idx_v for j in robot.joint_names]
        self.frames = [self.model.getFrameId(link) for link in robot.end_effectors]
        self.free, self.lower, self.upper = arm_joints(robot)
        self.rotations = [r for _, r in robot.hand_poses_numeric(robot.home)]

    def reaches(self, base: np.ndarray, targets: np.ndarray, heading: float, iterations: int = 150) -> bool:
        q = self.robot.home.copy()
        q[list(self.robot.base_joints)] = base
        toward = np.arctan2(*(targets.mean(axis=0)[:2] - base[:2])[::-1]) - base[2]  # the chest turned to them
        q[self.chest] = np.clip(
            (toward + np.pi) % (2 * np.pi) - np.pi, self.robot.lower[self.chest], self.robot.upper[self.chest]
        )
        wanted = [rot_z(np.asarray(heading)) @ r for r in self.rotations]
        columns = [self.v_index[i] for i in self.free]
        best = np.inf
        for it in range(iterations):
            q_pin = np.zeros(self.model.nq)
            q_pin[self.q_index] = q
            pin.computeJointJacobians(self.model, self.data, q_pin)
            pin.updateFramePlacements(self.model, self.data)
            errors, rows = [], []
            for frame, target, rotation in zip(self.frames, targets, wanted):
                placement = self.data.oMf[frame]
                errors.append(np.r_[target - placement.translation, pin.log3(rotation @ placement.rotation.T)])
                J = pin.getFrameJacobian(self.model, self.data, frame, pin.LOCAL_WORLD_ALIGNED)
                rows.append(J[:, columns])
            e, J = np.concatenate(errors), np.vstack(rows)
            # the search's own tolerances: each coordinate within POSITION_TOL, ||R - R_ref||_F^2 within ROTATION_TOL
            positions_ok = all(np.abs(err[:3]).max() <= POSITION_TOL for err in errors)
            rotations_ok = all(4 * (1 - np.cos(np.linalg.norm(err[3:]))) <= ROTATION_TOL for err in errors)
            if positions_ok and rotations_ok:
                return True
            if it % 10 == 0:  # stalled: no better by a millimetre (or a milliradian) over ten iterations
                if np.linalg.norm(e) > best - 1e-3:
                    return False
                best = np.linalg.norm(e)
            step = J.T @ np.linalg.solve(J @ J.T + 1e-3 * np.eye(len(e)), e)
            q[self.free] = np.clip(q[self.free] + np.clip(step, -0.2, 0.2), self.lower, self.upper)
        return False


def test_the_search_goes_no_further_into_a_margin_than_the_best_pose_of_a_grid_and_a_grid_pose_goes_as_far():
    scenario = load_scenario(PAPER, SCENE)
    robot = robot_of(scenario, PAPER.parent)
    found = stance_poses(scenario, robot, PLACE, np.zeros(1))
    assert found, "the search finds a pose"
    searched = float(found[0].reliefs[0])
    assert searched > 0.05  # the scene makes every pose the search finds go into the cylinder's margin
    xs, ys = np.arange(4.9, 6.3, STEP_M), np.arange(-1.6, 1.6, STEP_M)
    yaws = np.deg2rad(np.arange(-180.0, 180.0, STEP_DEG))
    grid = np.array(np.meshgrid(xs, ys, yaws, indexing="ij")).reshape(3, -1).T
    grid = grid[np.hypot(*(grid[:, :2] - PLACE[0, :, :2].mean(axis=0)).T) < REACH]
    reliefs = _grid_reliefs(scenario, grid)
    reach = _Reach(robot, scenario.robot.chest_joints)
    # the search's footprint distance is a soft-min over its circles, below their min by up to SOFTMIN ln(circles)
    slack = SOFTMIN * np.log(len(scenario.robot.footprint)) + STEP_M  # that bias and a grid step
    # no grid pose that goes less far into the margin than the search's, by more than the slack, reaches
    better = np.flatnonzero(reliefs < searched - slack)
    assert len(better) > 100  # many poses to try (those clear of the margin among them)
    assert [k for k in better if reach.reaches(grid[k], PLACE[0], 0.0)] == []
    # and the least relief of a grid pose that reaches is within the slack of the search's
    within = np.flatnonzero(reliefs <= searched + slack)
    first = next((k for k in within[np.argsort(reliefs[within])] if reach.reaches(grid[k], PLACE[0], 0.0)), None)
    assert first is not None and abs(reliefs[first] - searched) <= slack
