"""Where the base stands to work at the box, said before the robot moves. A scenario writes its grip from one side
(the box-relative phases: approach, grasp, lift) and its place at one heading (the phases after the grasp with
absolute targets: carry, lower, release, retreat). The base standing behind those hands as at home (plan_base.py)
may be inside an obstacle's margin (or a table leg's): the whole-body MPC then stands it elsewhere and twists the
arms, and a held box may slip. Many such scenes still succeed: a warning, not a refusal. It names the body and the
smallest turn of the group's hand targets about its pivot (the box; the box's goal) that would clear the base, for
the author to write.

The targets are not turned automatically: the carry to a turned place twists the grip instead. What harmony does
for a blocked place is find a base pose that works there, route the carry through it and, near a blocked pivot,
pull the chest to the angle of the pose found on the base's side (stance_pose.py, stance_plan.py); where none is
found, the run ends before the robot moves as the controller's failure (stance_check.py)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from harmony_cli.planning.plan_base import PlannedBase
from harmony_cli.scenario import Scenario
from harmony_cli.scenario.task import RelativeTarget
from harmony_cli.tasks.as_written import target_position

STEP_DEG, MOST_DEG = 15, 90  # turns tried: +-15, +-30, ... +-90 deg (a grip from behind the box is not one)
# [m] how far inside a margin a written stance may be without a warning: the whole-body MPC stands the base where
# the arms reach from, not exactly as at home, and makes up about this much by stretching them
TOLERANCE = 0.1


@dataclass(frozen=True)
class Stance:
    """A group of phases (names) and its pivot ("the box", "the box's goal"): the base's smallest margin [m] with
    the hands as written, the body it is nearest, and the smallest turn [deg] about the pivot that clears it
    (None: none up to MOST_DEG); the pivot's position and the phases' hand targets as written (phases, hands, 3)."""

    phases: tuple[str, ...]
    pivot: str
    margin: float
    body: str
    turn_deg: float | None
    pivot_position: np.ndarray
    targets: np.ndarray

    @property
    def blocked(self) -> bool:
        """Whether the written stance is more than TOLERANCE inside a margin."""
        return self.margin < -TOLERANCE

    def warning(self) -> str | None:
        """One line when the written stance is blocked, else None."""
        if not self.blocked:
            return None
        fix = (
            f"turning those hand targets by {self.turn_deg:+g} deg about {self.pivot} would clear it"
            if self.turn_deg is not None
            else f"no turn about {self.pivot} up to {MOST_DEG} deg clears it"
        )
        where = self.phases[0] if len(self.phases) == 1 else f"{self.phases[0]} to {self.phases[-1]}"
        inside = f"is {-self.margin:.2f} m inside {self.body}'s margin"
        return f"stance: in phases {where} the base, behind the hands as written, {inside}; {fix}"


class StanceClass(Enum):
    """How hard a scene's written stances are to work from, easiest first: the base behind the hands as written
    clear of every margin (within TOLERANCE), inside one but clear after a turn of the group's targets about their
    pivot (up to MOST_DEG), or not even then. A study's report breaks its outcomes down by it."""

    CLEAR = "clear"
    TURN_CLEARS = "blocked, a turn clears it"
    NO_TURN_CLEARS = "blocked, no turn clears it"


def stances(
    scenario: Scenario, hand_names: tuple[str, ...], base: tuple[PlannedBase, list[str]], heading_offset: float
) -> list[Stance]:
    """The grip's and the place's stances (none without a box, a grasp phase or two hands; no place without a
    goal), the targets where the scenario writes them. `base`: the footprint with the bodies it keeps clear of, and
    their names; `heading_offset`: the planner's (heading 0 at home)."""
    task, box = scenario.task, scenario.world.box
    grasp = None if task is None else next((i for i, p in enumerate(task.phases) if p.grasp), None)
    if task is None or box is None or grasp is None or len(hand_names) != 2:
        return []
    pick = [p for p in task.phases if all(_on_box(p.hands.get(h)) for h in hand_names)]
    place = [
        p
        for p in task.phases[grasp + 1 :]
        if all(p.hands.get(h) is not None and not isinstance(p.hands[h], RelativeTarget) for h in hand_names)
    ]
    footprint, bodies = base
    found = []
    for group, pivot_name, written in ((pick, "the box", box.position), (place, "the box's goal", box.goal)):
        if not group or written is None:
            continue
        pairs = np.array([[target_position(p.hands[h], scenario) for h in hand_names] for p in group])
        pivot, margins = np.asarray(written, dtype=float), _margins(pairs, footprint, heading_offset)  # (bodies,)
        turn = None  # the smallest clearing turn (of +-a both clear, the roomier)
        for size in range(STEP_DEG, MOST_DEG + 1, STEP_DEG):
            room = {
                a: _margins(turned(pairs, pivot, np.deg2rad(a)), footprint, heading_offset).min() for a in (size, -size)
            }
            best = max(room, key=lambda a: room[a])
            if room[best] >= 0.0:
                turn = float(best)
                break
        nearest = int(np.argmin(margins))
        phases = tuple(p.name for p in group)
        found.append(Stance(phases, pivot_name, float(margins[nearest]), bodies[nearest], turn, pivot, pairs))
    return found


def turned(pairs: np.ndarray, pivot: np.ndarray, angle: float) -> np.ndarray:
    """Hand targets (..., 3) turned by `angle` [rad] about the vertical through `pivot` (3,)."""
    c, s = np.cos(angle), np.sin(angle)
    d = pairs[..., :2] - pivot[:2]
    out = pairs.copy()
    out[..., 0], out[..., 1] = pivot[0] + c * d[..., 0] - s * d[..., 1], pivot[1] + s * d[..., 0] + c * d[..., 1]
    return out


def _on_box(target) -> bool:
    return isinstance(target, RelativeTarget) and target.relative_to == "box"


def _margins(pairs: np.ndarray, base: PlannedBase, heading_offset: float) -> np.ndarray:
    """Per body, the footprint's smallest margin over the stances behind the hand pairs (phases, 2, 3)."""
    d = pairs[:, 1] - pairs[:, 0]
    headings = np.arctan2(d[:, 1], d[:, 0]) + heading_offset
    return base.margins(pairs[:, :, :2].mean(axis=1), headings, np.zeros(len(pairs)))[0].min(axis=1)
