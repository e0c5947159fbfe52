"""What a reference source hands the whole-body MPC each control step."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from harmony_cli.robot.observation import Observation


@dataclass(frozen=True)
class HandTargets:
    positions: np.ndarray  # (K, hands, 3) hand positions at t + the MPC's knot times
    rotations: np.ndarray  # (K, hands, 3, 3)
    now: np.ndarray  # (hands, 3) where the hands are asked to be at t (what tracking errors are measured from)
    force_ref: np.ndarray | None = None  # (hands, K) squeeze force references [N] when the admittance is on
    chest_ref: np.ndarray | None = None  # (chest joints, K) [rad] where the chest cost pulls (None: straight)
    stance: np.ndarray | None = None  # (4, K) where the base's cost pulls: x, y [m], yaw [rad], weight (None: none)
    reliefs: np.ndarray | None = None  # (clearances,) [m] how far the whole-body MPC's margins are lowered (None: 0)
    task_weight: float = 1.0  # the hands' tracking weights' multiplier in the whole-body MPC (a late phase's > 1)
    log: dict = field(default_factory=dict)  # fields for the step record (phase, planner status and timing)


class References(Protocol):
    def plan(self, t: float, obs: Observation, knot_times: np.ndarray) -> HandTargets: ...

    @property
    def delay(self) -> float:
        """[s] how much longer than written the run must last (a task's phases waiting for their goals)."""
        ...
