"""What a blocked stance changes in the two-stage controller, once before the run: for each group of phases whose
written stance is blocked (stance.py's warning), a base pose that works at its pivot (stance_pose.py), and from it

- a via: the group's first plan routes the hands through the pose's position, so they come to the pivot from where
  the base can stand and the base, which follows them, arrives on that side of whatever blocks the written stance
  (only when the group's first phase works at the pivot: an approach's pose is not the one found);
- a chest posture: near the pivot of a blocked group, the whole-body MPC's chest cost pulls the chest to the
  angle of the pose found nearest where the base stands (poses from every start of the search: one each side of
  the pivot, typically), instead of straight ahead, so the base may stand turned where the scene leaves room. Why:
  a pose found for a place blocked from its front stands the base turned and the chest turned back; a chest cost
  pulling to 0 holds the chest straight and the hands short of the goal instead. The posture is the nearest pose's
  (a pose from the pivot's other side turns the arms the wrong way), fixed rather than squared to the measured
  base (nothing would then hold the base's yaw), and only in the group's phases.
Cost: the search's starts, once before the loop (about 2 s with a blocked stance, nothing without one).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harmony_cli.robot.model import Robot
from harmony_cli.scenario import Scenario
from harmony_cli.tasks.as_written import target_position
from harmony_cli.tasks.stance import Stance
from harmony_cli.tasks.stance_pose import stance_poses

NEAR = 0.2  # [m] a phase works at its group's pivot when its hands' midpoint is this near it (plan view)
BLEND = 1.0  # [m] the chest posture blends in over this distance of the planned hands' midpoint to NEAR


@dataclass(frozen=True)
class ChestPosture:
    """A blocked group's phases (indices) at `pivot` (2,), and the poses found there: their base positions (n, 2) and
    chest angles (n, chest joints) [rad]."""

    phases: frozenset[int]
    pivot: np.ndarray
    bases: np.ndarray
    chests: np.ndarray

    def at(self, hands: np.ndarray, base: np.ndarray) -> np.ndarray:
        """(chest joints, K): with the planned `hands` (K, 2, 3) at the knots and the base's measured position (2,),
        the chest angles of the pose nearest the base, in full within NEAR of the pivot (plan view), fading to 0 at
        NEAR + BLEND."""
        chest = self.chests[int(np.argmin(np.linalg.norm(self.bases - base, axis=1)))]
        near = np.linalg.norm(hands.mean(axis=1)[:, :2] - self.pivot, axis=1)
        return chest[:, None] * np.clip(1.0 - (near - NEAR) / BLEND, 0.0, 1.0)[None]


@dataclass(frozen=True)
class StancePlan:
    vias: dict[int, np.ndarray]  # phase index -> (2,) the pose's position, for that phase's first plan
    postures: list[ChestPosture]  # none for a robot without chest joints
    unplaced: list[Stance]  # blocked groups for which no pose was found

    def chest(self, phase: int, hands: np.ndarray, base: np.ndarray) -> np.ndarray | None:
        """The chest reference (chest joints, K) in `phase` (ChestPosture.at); None (straight) outside a blocked
        group."""
        posture = next((p for p in self.postures if phase in p.phases), None)
        return None if posture is None else posture.at(hands, base)


def stance_plan(scenario: Scenario, robot: Robot, found: list[Stance], heading_offset: float) -> StancePlan:
    """The vias and chest postures of the blocked groups among `found`, and the groups with no pose found."""
    assert scenario.task is not None
    names = [p.name for p in scenario.task.phases]
    chest = [robot.index(j) for j in scenario.robot.chest_joints]
    vias, postures, unplaced = {}, [], []
    for stance in found:
        if stance.warning() is None:
            continue
        at_pivot = pivot_targets(scenario, robot, stance, heading_offset)
        if at_pivot is None or not (at_pivot[2] or chest):  # neither a via nor a posture would use a pose
            continue
        poses = stance_poses(scenario, robot, *at_pivot[:2], first=not chest)
        if not poses:
            if at_pivot[2]:
                unplaced.append(stance)
            continue
        if at_pivot[2]:
            vias[names.index(stance.phases[0])] = poses[0][0][:2]
        if chest:
            phases = frozenset(names.index(n) for n in stance.phases)
            bases = np.array([base[:2] for base, _ in poses])
            chests = np.array([np.median(joints[:, chest], axis=0) for _, joints in poses])
            postures.append(ChestPosture(phases, stance.pivot_position[:2], bases, chests))
    return StancePlan(vias, postures, unplaced)


def pivot_targets(
    scenario: Scenario, robot: Robot, stance: Stance, heading_offset: float
) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """The hand targets (phases, hands, 3) of a stance's phases that work at its pivot (within NEAR of it), the
    planner's headings there (phases,), what stance_pose asks for, and whether the group's first phase is one of
    them (not an approach); None when none is."""
    assert scenario.task is not None
    names = [p.name for p in scenario.task.phases]
    phases = [scenario.task.phases[names.index(n)] for n in stance.phases]
    pairs = np.array([[target_position(p.hands[h], scenario) for h in robot.hand_names] for p in phases])
    at = np.linalg.norm(pairs.mean(axis=1)[:, :2] - stance.pivot_position[:2], axis=1) <= NEAR
    if not at.any():
        return None
    d = pairs[at, 1] - pairs[at, 0]
    return pairs[at], np.arctan2(d[:, 1], d[:, 0]) + heading_offset, bool(at[0])
