"""The phase schedule: which phase runs at time t, and its hand goals (fixed when the phase starts). A phase whose
hands have not reached their goal when it would end waits for them, at most its own duration again (twice that
after a stall's recovery)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harmony_cli.maths.scalings import quintic
from harmony_cli.scenario.models import AdmittanceSpec
from harmony_cli.scenario.task import PhaseSpec, RelativeTarget, TaskSpec

REACHED = 0.03  # [m] both hands this close to their phase goal (plus half its squeeze): the phase is complete


@dataclass(frozen=True)
class ActivePhase:
    index: int
    spec: PhaseSpec
    start: float
    end: float


class Schedule:
    """Phases back to back from t = 0; after the last phase its goal is held. Squeeze forces go to the admittance
    (blended in over `admittance.ramp` at a phase start) or, without it, become a position squeeze F / K per pad.
    `wait` moves a lagging phase's end (and every later one's) back; the times here are the moved ones."""

    def __init__(self, task: TaskSpec, hand_names: tuple[str, ...], admittance: AdmittanceSpec | None = None):
        self.phases, self.hand_names = task.phases, hand_names
        self.ends = np.cumsum([p.duration for p in task.phases])
        self.duration = float(self.ends[-1])  # as written, without waits
        self.waited = np.zeros(len(task.phases))  # [s] per phase, how long it waited for its goal
        self.allowed = np.array([p.duration for p in task.phases], dtype=float)  # [s] the most it may wait
        self.admittance = admittance if admittance is not None else AdmittanceSpec()

    def force(self, times: np.ndarray) -> np.ndarray:
        """Squeeze force reference per pad [N] at each time (0 without admittance)."""
        if not self.admittance.enabled:
            return np.zeros(np.size(times))
        target = np.array([p.force for p in self.phases])
        i = np.minimum(np.searchsorted(self.ends, times, side="right"), len(self.phases) - 1)
        start = np.concatenate([[0.0], self.ends[:-1]])[i]
        before = np.concatenate([[0.0], target[:-1]])[i]
        return before + (target[i] - before) * quintic((np.asarray(times) - start) / self.admittance.ramp)

    def squeeze(self, phase: PhaseSpec) -> float:
        """Total position squeeze [m]: the phase's own, plus, when no admittance loop controls the force, 2 F / K
        (or twice `admittance.off_squeeze` for phases with a force)."""
        a = self.admittance
        if a.enabled or not phase.force:
            return phase.squeeze
        return phase.squeeze + 2 * (a.off_squeeze if a.off_squeeze is not None else phase.force / a.stiffness)

    @property
    def delay(self) -> float:
        """[s] how far the waits have moved the schedule's end."""
        return float(self.waited.sum())

    def wait(self, t: float, dt: float, goal_error: float) -> None:
        """At control time t (steps of dt), with the hands `goal_error` [m] (the larger) from the phase's goal: a
        phase about to end with its goal not reached lasts dt longer (every later phase moves with it), until it
        has waited its own duration. A robot that lags (a detour, a base that had to go round) then still grasps
        where the box is instead of closing on air; one that never arrives goes on as written after the wait."""
        i = self._lagging(t, dt, goal_error)
        if i is not None and self.waited[i] + dt <= self.allowed[i] + 1e-9:
            self.ends[i:] += dt
            self.waited[i] += dt

    def stalled(self, t: float, dt: float, goal_error: float) -> int | None:
        """The phase at t if it ends at this step with its goal not reached and its wait used up (None if not)."""
        i = self._lagging(t, dt, goal_error)
        return i if i is not None and self.waited[i] + dt > self.allowed[i] + 1e-9 else None

    def retry(self, index: int) -> None:
        """Phase `index` may wait its own duration once more (a stall's recovery: planning/planner.py)."""
        self.allowed[index] += self.phases[index].duration

    def _lagging(self, t: float, dt: float, goal_error: float) -> int | None:
        """The phase at t, when t is its last step and its hands are `goal_error` [m] from its goal, short of it
        (None otherwise; the last phase never waits)."""
        active = self.at(t)
        i, phase = active.index, active.spec
        ending = active.end - t < 1.5 * dt  # t is its last step (half a step for the sums' rounding)
        if i == len(self.phases) - 1 or not ending or goal_error < REACHED + phase.squeeze / 2:
            return None
        return i

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
        squeeze = self.squeeze(phase)
        if squeeze and len(goal) == 2:
            across = goal[1] - goal[0]
            across /= max(np.linalg.norm(across), 1e-9)
            goal[0] += 0.5 * squeeze * across
            goal[1] -= 0.5 * squeeze * across
        return goal

    def holding(self, t: float) -> bool:
        """The box is held from the end of a grasp phase until a release phase starts."""
        held, start = False, 0.0
        for phase, end in zip(self.phases, self.ends.tolist()):  # floats: a step's few calls cost microseconds
            if phase.release and t >= start:
                held = False
            if phase.grasp and t >= end:
                held = True
            start = end
        return held
