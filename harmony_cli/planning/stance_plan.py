"""What a blocked stance changes in the two-stage controller, once before the run: for each group of phases whose
written stance is blocked (stance.py's warning), a base pose that works at its pivot (stance_pose.py), and from it

- a via: the group's first plan routes the hands through the pose's position, so they come to the pivot from where
  the base can stand and the base, which follows them, arrives on that side of whatever blocks the written stance
  (only when the group's first phase works at the pivot: an approach's pose is not the one found);
- a stance: at the knots whose planned hands are at the pivot of a blocked group, the whole-body MPC's stance cost
  pulls the base towards the pose found nearest where it stands;
- a chest posture: near the pivot of a blocked group, the whole-body MPC's chest cost pulls the chest to the
  angle of the pose found nearest where the base stands (poses from every start of the search: one each side of
  the pivot, typically), instead of straight ahead, so the base may stand turned where the scene leaves room. Why:
  a pose found for a place blocked from its front stands the base turned and the chest turned back; a chest cost
  pulling to 0 holds the chest straight and the hands short of the goal instead. The posture is the nearest pose's
  (a pose from the pivot's other side turns the arms the wrong way), fixed rather than squared to the measured
  base (nothing would then hold the base's yaw), and only in the group's phases;
- reliefs: where the pose goes into an obstacle's margin (no pose found keeps it, stance_pose.py), the whole-body
  MPC's margins of that obstacle are lowered as far in the group's phases, so it can stand the base there.
Cost: the search's starts, once before the loop (about 2 s with a blocked stance, nothing without one).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from harmony_cli.planning.stance import Stance
from harmony_cli.planning.stance_pose import STARTS, StancePose, stance_poses
from harmony_cli.robot.model import Robot
from harmony_cli.scenario import Scenario

NEAR = 0.2  # [m] a phase works at its group's pivot when its hands' midpoint is this near it (plan view)
BLEND = 1.0  # [m] the chest posture blends in over this distance of the planned hands' midpoint to NEAR
# [m] the stance blends in over this distance: it is where the base ends, at the knots whose planned hands are at the
# pivot; on the way there the base follows the hands (a stance pulled while carrying twists the grip)
STANCE_BLEND = 0.3
RELIEF_SPREAD = 0.05  # [m] poses kept: those going this much further into margins than the least does, at most
# [m] added to a relief the poses need: a pose found stands at its limits, and the whole-body MPC, which tracks the
# hands, needs room round it to get there
RELIEF_SPARE = 0.05


@dataclass(frozen=True)
class Posture:
    """A blocked group's phases (indices) at `pivot` (2,), and the poses found there: their base poses (n, 3: x, y,
    yaw) and chest angles (n, chest joints) [rad]."""

    phases: frozenset[int]
    pivot: np.ndarray
    bases: np.ndarray
    chests: np.ndarray

    def _nearest(self, hands: np.ndarray, base: np.ndarray, width: float) -> tuple[int, np.ndarray]:
        """The pose nearest the base's measured position (2,), and its blend at the planned `hands` (K, 2, 3): 1
        within NEAR of the pivot (plan view), fading to 0 at NEAR + `width`."""
        near = np.linalg.norm(hands.mean(axis=1)[:, :2] - self.pivot, axis=1)
        nearest = int(np.argmin(np.linalg.norm(self.bases[:, :2] - base, axis=1)))
        return nearest, np.clip(1.0 - (near - NEAR) / width, 0.0, 1.0)

    def chest(self, hands: np.ndarray, base: np.ndarray) -> np.ndarray:
        """(chest joints, K): the nearest pose's chest angles, blended over BLEND."""
        nearest, blend = self._nearest(hands, base, BLEND)
        return self.chests[nearest][:, None] * blend[None]

    def stance(self, hands: np.ndarray, base: np.ndarray) -> np.ndarray:
        """(4, K): the base where the nearest pose stands it from the pivot, carried with the planned hands'
        midpoint (x, y; its yaw the pose's), and its weight, the blend over STANCE_BLEND."""
        nearest, blend = self._nearest(hands, base, STANCE_BLEND)
        offset = self.bases[nearest][:2] - self.pivot
        xy = hands.mean(axis=1)[:, :2] + offset  # (K, 2)
        return np.vstack([xy.T, np.full(blend.size, self.bases[nearest][2]), blend])


@dataclass(frozen=True)
class StancePlan:
    vias: dict[int, np.ndarray]  # phase index -> (2,) the pose's position, for that phase's first plan
    postures: list[Posture]
    unplaced: list[Stance]  # blocked groups for which no pose was found
    reliefs: dict[int, np.ndarray]  # phase index -> per world obstacle, how far the whole-body MPC's margin drops

    def posture(self, phase: int) -> Posture | None:
        """The first posture of `phase`'s (its chest reference and the base's stance); None outside a blocked group:
        the chest straight, no stance."""
        return next((p for p in self.postures if phase in p.phases), None)

    def recovered(self, posture: Posture, reliefs: np.ndarray | None) -> StancePlan:
        """This plan with `posture` before every earlier one for its phases (a stalled phase's, stalled_posture)
        and, where it needs reliefs, the larger of its own and the earlier ones per obstacle."""
        updated = dict(self.reliefs)
        if reliefs is not None:
            for phase in posture.phases:
                earlier = updated.get(phase)
                updated[phase] = reliefs if earlier is None else np.maximum(earlier, reliefs)
        return replace(self, postures=[posture, *self.postures], reliefs=updated)


class ChestRamp:
    """The chest reference in time: it never steps. A posture that starts or ends (a blocked group's phases begin
    or end, the pose nearest the base changes) moves the reference from where it was at most `rate` [rad/s] per
    second of the whole-body MPC's knot times, and at most `held_rate` while the hands hold the box: a chest that
    turns under a held box moves both arms round it, which the whole-body MPC tracks with a lag that shears the
    grip, so a chest turned at the grasp comes back slowly. None while the chest is straight and no posture is
    asked for (nothing to ramp)."""

    def __init__(self, rate: float, held_rate: float):
        self.rate, self.held_rate = rate, held_rate
        self._last: tuple[float, np.ndarray] | None = None  # when the last reference was asked for, its first knot

    def __call__(
        self, target: np.ndarray | None, t: float, knot_times: np.ndarray, measured: np.ndarray, held: bool = False
    ):
        """The reference (chest joints, K) at t + `knot_times` towards `target` (None: straight), within the rate
        (`held`: the box is held) of the last reference's first knot (the `measured` chest angles the first time)
        over the time since."""
        if target is None and self._last is None and not (held and measured.any()):
            return None
        since, now = (t, measured.astype(float)) if self._last is None else self._last
        goal = np.zeros((now.size, knot_times.size)) if target is None else target
        reach = (self.held_rate if held else self.rate) * (knot_times - knot_times[0] + t - since)
        ramped = now[:, None] + np.clip(goal - now[:, None], -reach, reach)
        if target is None and not ramped.any():
            self._last = None  # back to straight: as if no posture had been asked for
            return None
        self._last = (t, ramped[:, 0])
        return ramped


def stance_plan(scenario: Scenario, robot: Robot, found: list[Stance], heading_offset: float) -> StancePlan:
    """The vias, postures, stances and reliefs of the blocked groups among `found`, and the groups with no pose
    found. The poses kept are those that go no further into a margin than the least does by RELIEF_SPREAD; the
    group's reliefs are the most any of them needs."""
    assert scenario.task is not None
    names = [p.name for p in scenario.task.phases]
    chest = [robot.index(j) for j in scenario.robot.chest_joints]
    vias, postures, unplaced = {}, [], []
    reliefs: dict[int, np.ndarray] = {}
    for stance in found:
        if not stance.blocked:
            continue
        at_pivot = pivot_targets(stance, heading_offset)
        if at_pivot is None:
            continue
        poses = stance_poses(scenario, robot, *at_pivot[:2])
        if not poses:
            if at_pivot[2]:
                unplaced.append(stance)
            continue
        if at_pivot[2]:
            vias[names.index(stance.phases[0])] = poses[0].base[:2]
        phases = frozenset(names.index(n) for n in stance.phases)
        posture, needed = posture_of(poses, phases, stance.pivot_position[:2], chest)
        if needed is not None:
            reliefs |= dict.fromkeys(phases, needed)
        postures.append(posture)
    return StancePlan(vias, postures, unplaced, reliefs)


def posture_of(
    poses: list[StancePose], phases: frozenset[int], pivot: np.ndarray, chest: list[int]
) -> tuple[Posture, np.ndarray | None]:
    """The posture of `phases` at `pivot` (2,) from the `poses` found there (least relief first): those that go no
    further into a margin than the least does by RELIEF_SPREAD; and the reliefs its phases need (None: none), the
    most any of them needs, with RELIEF_SPARE (`chest`: the chest joints' indices)."""
    least = float(poses[0].reliefs.sum())
    poses = [pose for pose in poses if float(pose.reliefs.sum()) <= least + RELIEF_SPREAD]
    needed = None
    if least > 0.0:
        most = np.max([pose.reliefs for pose in poses], axis=0)
        needed = np.where(most > 0.0, most + RELIEF_SPARE, 0.0)
    bases = np.array([pose.base for pose in poses])
    chests = np.array([np.median(pose.joints[:, chest], axis=0) for pose in poses]).reshape(len(poses), -1)
    return Posture(phases, pivot, bases, chests), needed


def stalled_posture(
    scenario: Scenario, robot: Robot, phase: int, goal: np.ndarray, heading_offset: float, base: np.ndarray
) -> tuple[Posture, np.ndarray | None] | None:
    """A stalled `phase`'s own posture at its hands' `goal` (2, 3) now, and the reliefs it needs (posture_of), from
    a stance search whose first start turns the base as the measured `base` pose (x, y, yaw) stands; None when no
    start converged. The group's stance serves its phases at once from the box as written: a phase that waited its
    whole wait in vain is held short by it (where the base stands, how the chest turns), not by its plan."""
    across = goal[1] - goal[0]
    heading = float(np.arctan2(across[1], across[0])) + heading_offset
    turn = (float(base[2]) - float(robot.home[robot.base_joints[2]]) - heading + np.pi) % (2 * np.pi) - np.pi
    starts = ((float(np.rad2deg(turn)), 1.0), *STARTS)
    poses = stance_poses(scenario, robot, goal[None], np.array([heading]), starts=starts)
    chest = [robot.index(j) for j in scenario.robot.chest_joints]
    return posture_of(poses, frozenset({phase}), goal.mean(axis=0)[:2], chest) if poses else None


def pivot_targets(stance: Stance, heading_offset: float) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """The hand targets (phases, hands, 3) of a stance's phases that work at its pivot (within NEAR of it), the
    planner's headings there (phases,), what stance_poses asks for, and whether the group's first phase is one of
    them (not an approach); None when none is."""
    pairs = stance.targets
    at = np.linalg.norm(pairs.mean(axis=1)[:, :2] - stance.pivot_position[:2], axis=1) <= NEAR
    if not at.any():
        return None
    d = pairs[at, 1] - pairs[at, 0]
    return pairs[at], np.arctan2(d[:, 1], d[:, 0]) + heading_offset, bool(at[0])
