"""When a command acts (scenario `control.latency`): the command computed from the state at t reaches the simulator
at t plus a latency, in whole physics steps; until then the one before it drives the joints. A fixed latency is
written in seconds; `measured` takes each command's own compute time (observation to command, wall clock), rounded
up to physics steps, so such a run depends on the machine that runs it. Without latency a command acts at once, as
one `apply` and one `step` of the control period: the same calls as a loop that drives the simulator directly."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from harmony_cli.sim.engine import Simulator


class Actuator:
    """Sends commands to `sim`, stepped in physics steps of `physics_dt` [s], `latency` [s] (or `measured`) after
    they were computed."""

    def __init__(self, sim: Simulator, latency: Literal["measured"] | float, physics_dt: float):
        self.sim, self.physics_dt = sim, physics_dt
        self.measured = latency == "measured"
        self.fixed = 0 if self.measured else round(float(latency) / physics_dt)
        self.pending: list[tuple[int, int, np.ndarray, np.ndarray]] = []  # (due physics step, order, q, qd)
        self.now = 0  # physics steps taken
        self.sent = 0  # commands sent so far

    @property
    def immediate(self) -> bool:
        return not self.measured and self.fixed == 0

    def delay(self, compute_s: float) -> int:
        """Physics steps from its computation to its action for a command computed in `compute_s` [s]."""
        return math.ceil(compute_s / self.physics_dt - 1e-9) if self.measured else self.fixed

    def send(self, q: np.ndarray, qd: np.ndarray, substeps: int, delay: int) -> None:
        """The command (q, qd) computed from the state now, acting `delay` physics steps from now; then `substeps`
        physics steps."""
        if self.immediate:
            self.sim.apply(q, qd)
            self.sim.step(substeps)
            return
        self.pending.append((self.now + delay, self.sent, q, qd))
        self.sent += 1
        end = self.now + substeps
        while self.now < end:
            self._apply_due()
            due = min((p[0] for p in self.pending), default=end)
            run = max(1, min(end, due) - self.now)
            self.sim.step(run)
            self.now += run

    def _apply_due(self) -> None:
        """The newest command due by now acts; it and every command computed before it leave the queue (an older
        command never overrides a newer one that acts first)."""
        due = [p for p in self.pending if p[0] <= self.now]
        if not due:
            return
        newest = max(due, key=lambda p: p[1])
        self.sim.apply(newest[2], newest[3])
        self.pending = [p for p in self.pending if p[1] > newest[1]]

    def log(self, delay: int) -> dict[str, int]:
        """For the steps log: `delay`, a step's command's physics steps from computation to action (nothing when
        commands act at once)."""
        return {} if self.immediate else {"latency_steps": delay}
