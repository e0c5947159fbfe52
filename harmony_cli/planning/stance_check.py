"""The controller's search for a stance before the robot moves: where the written stance at the box or at its goal
is blocked (stance.py), a base pose that works there is searched for (stance_pose.py) from SEARCH's starts, the
planning search's first. None found ends the run as the controller's failure (`no stance`), naming the phases, the
pivot and what blocks the written stance: each start is a local solve, so none found is not a proof that none
exists, and such a draw stays in a study's denominator. Obstacles that move are left out: where one starts does
not block a stance for good."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.shapes import table_legs
from harmony_cli.mpc.clearance import FLOOR
from harmony_cli.planning.hand_plan import Motion, Obstacle, planned_obstacles
from harmony_cli.planning.plan_base import PlannedBase
from harmony_cli.planning.stance import Stance, StanceClass, stances
from harmony_cli.planning.stance_plan import pivot_targets
from harmony_cli.planning.stance_pose import STARTS, stance_poses
from harmony_cli.robot.model import Robot
from harmony_cli.scenario import Scenario

# the planning search's starts, then every 22.5 deg between them and nearer to and farther from the targets
SEARCH = STARTS + tuple(
    (float(turn), share)
    for share in (1.0, 0.75, 1.25)
    for turn in np.arange(-157.5, 180.1, 22.5)
    if (turn, share) not in STARTS
)


def _standing(scenario: Scenario) -> Scenario:
    """The scenario without its moving obstacles (where one starts does not block a stance for good)."""
    standing = [o for o in scenario.world.obstacles if o.motion is None]
    return scenario.model_copy(update={"world": scenario.world.model_copy(update={"obstacles": standing})})


def written_stance_class(scenario: Scenario, robot: Robot) -> StanceClass:
    """How blocked the scene's written stances are, among the bodies that stand still (stance.StanceClass): the
    worst of the stances' classes (CLEAR without any)."""
    blocked = [stance for stance in written_stances(scenario, robot, *home_hands(robot)) if stance.blocked]
    if any(stance.turn_deg is None for stance in blocked):
        return StanceClass.NO_TURN_CLEARS
    return StanceClass.TURN_CLEARS if blocked else StanceClass.CLEAR


def unposed(scenario: Scenario, robot: Robot) -> str | None:
    """Why the hands cannot work where a blocked stance's phases put them (no base pose found from SEARCH's
    starts), or None."""
    still = _standing(scenario)
    hands, offset = home_hands(robot)
    for stance in written_stances(still, robot, hands, offset):
        if not stance.blocked:
            continue
        at_pivot = pivot_targets(stance, offset)
        if at_pivot is None or stance_poses(still, robot, *at_pivot[:2], first=True, starts=SEARCH):
            continue
        return f"{no_pose(stance, bool(scenario.robot.trunk), len(SEARCH))}; {stance.warning()}"
    return None


def no_pose(stance: Stance, trunk: bool, starts: int) -> str:
    """That no base pose was found for a stance's phases from `starts` starts (`trunk`: the robot has one)."""
    where = stance.phases[0] if len(stance.phases) == 1 else f"{stance.phases[0]} to {stance.phases[-1]}"
    clear = f"clear of the scene (obstacles' margins down to {FLOOR:g} m"
    clear += "; the trunk out from under table tops)" if trunk else ")"
    return (
        f"stance: no base pose found, {clear}, from which the hands reach phases {where} at {stance.pivot} "
        f"({starts} starts searched; not a proof that none exists)"
    )


def home_hands(robot: Robot) -> tuple[np.ndarray, float]:
    """The hands' positions at home (hands, 3) and the planner's heading offset [rad] (its heading is 0 at home)."""
    p0, p1 = (p.ravel() for p, _ in robot.hand_poses_numeric(robot.home))
    return np.array([p0, p1]), float(-np.arctan2(p1[1] - p0[1], p1[0] - p0[0]))


def base_bodies(scenario: Scenario, motions: list[Motion] | None = None) -> tuple[list[Obstacle], list[str]]:
    """What the footprint keeps clear of, as the whole-body MPC does, and their names: every obstacle (scenario
    order; a moving one predicted by `motions` or else its true motion) by its margin, every table leg by the
    base's."""
    bodies = planned_obstacles(scenario.world.obstacles, 0.0, motions)
    names = [f"obstacle {o.name}" for o in scenario.world.obstacles]
    for table in scenario.world.tables:
        legs = table_legs(table)
        bodies += [Obstacle(leg, scenario.robot.base_margin) for leg in legs]
        names += [f"table {table.name}'s leg"] * len(legs)
    return bodies, names


def written_stances(scenario: Scenario, robot: Robot, hands: np.ndarray, heading_offset: float) -> list[Stance]:
    """Where the base stands to grip and to place as written (stance.py), among the bodies that stand still."""
    circles = np.asarray(scenario.robot.footprint, dtype=float).reshape(-1, 3)
    if len(circles) == 0:
        return []
    bodies, names = base_bodies(_standing(scenario))
    footprint = PlannedBase.at_home(circles, robot.home[list(robot.base_joints)], hands, bodies)
    return stances(scenario, robot.hand_names, (footprint, names), heading_offset)
