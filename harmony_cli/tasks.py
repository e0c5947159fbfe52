"""The phase schedule: which phase runs at time t, and its hand goals (fixed when the phase starts)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harmony_cli.scenario import PhaseSpec, RelativeTarget, TaskSpec


@dataclass(frozen=True)
class ActivePhase:
    index: int
    spec: PhaseSpec
    start: float
    end: float


class Schedule:
    """Phases back to back from t = 0; after the last phase its goal is held."""

    def __init__(self, task: TaskSpec, hand_names: tuple[str, ...]):
        self.phases, self.hand_names = task.phases, hand_names
        self.ends = np.cumsum([p.duration for p in task.phases])
        self.duration = float(self.ends[-1])

    def at(self, t: float) -> ActivePhase:
        i = min(int(np.searchsorted(self.ends, t, side="right")), len(self.phases) - 1)
        start = float(self.ends[i - 1]) if i else 0.0
        return ActivePhase(i, self.phases[i], start, float(self.ends[i]))

    def goal(self, phase: PhaseSpec, hands_now: np.ndarray, poses: dict[str, tuple[np.ndarray, float]]) -> np.ndarray:
        """Hand goals (hands, 3): absolute, relative to an object's pose (position, yaw) or where the hand is;
        then `squeeze` moves them towards each other by that much in total."""
        goal = hands_now.copy()
        for h, name in enumerate(self.hand_names):
            target = phase.hands[name]
            if isinstance(target, RelativeTarget):
                position, yaw = poses[target.relative_to]
                c, s = np.cos(yaw), np.sin(yaw)
                ox, oy, oz = target.offset
                goal[h] = position + np.array([c * ox - s * oy, s * ox + c * oy, oz])
            elif target is not None:
                goal[h] = target
        if phase.squeeze and len(goal) == 2:
            across = goal[1] - goal[0]
            across /= max(np.linalg.norm(across), 1e-9)
            goal[0] += 0.5 * phase.squeeze * across
            goal[1] -= 0.5 * phase.squeeze * across
        return goal

    def holding(self, t: float) -> bool:
        """The box is held from the end of a grasp phase until a release phase starts."""
        held = False
        for phase, end in zip(self.phases, self.ends):
            start = end - phase.duration
            if phase.release and t >= start:
                held = False
            if phase.grasp and t >= end:
                held = True
        return held
