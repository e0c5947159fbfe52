"""What a grip can carry: the squeeze force while a box is held, from the load the wrists measure, and the carry's
rate bounds, from the friction the pads have at the most they squeeze and from the slip the wrists see.

A pad pressing with normal force F holds at most mu F along its face. The box's weight, its accelerations and
whatever else pushes on it (an arm touching it, the hands shearing it between them) reach the pads as tangential
forces, which the wrist sensors measure (grasp frame: x, y along the face, z out of the pad). The squeeze is the
grip-force / load-force coupling of human and robot grasping:

    F = clip(max(F_written, margin max(m g / 2, f_t) / mu), F_written, scale F_written)

with f_t the larger tangential force of the two wrists (low-passed), the same for both pads (unequal squeezes push
the box sideways). It rises at `RISE` N/s at most (the admittance follows a ramp, not a step) and falls back at
`FALL` N/s, so a load that comes and goes does not make the grip pump.

The carry's bounds: at the most the pads squeeze, each holds C = mu scale F_written / margin along its face, of
which the weight takes m g / 2; what is left bounds the box's horizontal acceleration (2 sqrt(C^2 - (m g / 2)^2)
/ m), its vertical one (2 C / m - g) and its yaw acceleration (the pads' opposite tangential forces at half the
grip's width apart against the box's inertia). And a pace: while the wrists see more of the friction used than
`slow` (halfway between what the margin leaves and sliding), the hands' speed bounds shrink towards `SLOWEST` of
theirs (their acceleration bounds stay the grip's: slowing down needs them); the pace comes back at `RECOVER` per
second."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.robot.model import Robot
from harmony_cli.tasks.as_written import target_position

if TYPE_CHECKING:
    from harmony_cli.scenario.models import Scenario

GRAVITY = 9.81
RISE, FALL = 50.0, 5.0  # [N/s] the most the squeeze reference rises and falls per second
SLOWEST, RECOVER = 0.25, 0.5  # the least pace, and how fast [1/s] the pace returns to 1
LEAST = 0.05  # the share of the planner's acceleration bounds kept when the grip has no friction to spare
# the most friction used a step adds to the low-pass: a pad that barely touches reads a huge share for a step
MOST_USED = 2.0


@dataclass(frozen=True)
class GripLaw:
    """The box's `mass` [kg] and plan-view `size` (2,) [m] with the pads on its faces `width` [m] apart, the
    pad-box friction coefficient `friction`, the `margin` on the friction the squeeze provides over the load, the
    most a pad squeezes as a multiple of the written force (`scale`), and the time constant of the low-pass on the
    wrists' forces [s] (`filter`)."""

    mass: float
    size: tuple[float, float]
    width: float
    friction: float
    margin: float
    scale: float
    filter: float

    def needed(self, tangential: float) -> float:
        """[N] the squeeze per pad that holds a tangential load of `tangential` [N] per pad, and the box's weight,
        with the margin."""
        return self.margin * max(0.5 * self.mass * GRAVITY, tangential) / self.friction

    def accelerations(self, written: float) -> tuple[float, float, float]:
        """The box's most horizontal and vertical acceleration [m/s^2] and yaw acceleration [rad/s^2] the pads
        hold with the margin when they squeeze their most (`scale` x the `written` force [N])."""
        hold = self.friction * self.scale * written / self.margin  # per pad, along its face
        weight = 0.5 * self.mass * GRAVITY
        spare = float(np.sqrt(max(hold**2 - weight**2, 0.0)))
        inertia = self.mass * (self.size[0] ** 2 + self.size[1] ** 2) / 12.0
        return 2.0 * spare / self.mass, 2.0 * hold / self.mass - GRAVITY, self.width * spare / inertia


class GripForce:
    """Per control step, the squeeze reference while a box is held (`GripLaw`), the friction the pads use as the
    wrists see it, and the carry's pace."""

    def __init__(self, law: GripLaw, dt: float):
        self.law, self.dt = law, dt
        self._load = 0.0  # [N] the low-passed larger tangential force of the wrists
        self._used = 0.0  # the low-passed friction used
        self._force: float | None = None  # [N] the last reference (None: not holding)
        self.friction_used = float("nan")
        self.pace = 1.0

    def __call__(self, written: np.ndarray, wrenches: np.ndarray, holding: bool) -> np.ndarray:
        """The squeeze reference (hands, K) from the `written` one (hands, K) and the wrists' `wrenches` (hands, 6,
        grasp frame); the written one while not `holding` or where it asks for no force."""
        tangential = np.hypot(wrenches[:, 0], wrenches[:, 1])
        blend = 1.0 if self.law.filter <= 0.0 else min(self.dt / self.law.filter, 1.0)
        self._load += blend * (float(tangential.max()) - self._load)
        floor = float(written.min())
        if not holding or floor <= 0.0:
            self._force, self.friction_used, self._used, self.pace = None, float("nan"), 0.0, 1.0
            return written
        pressing = np.maximum(-wrenches[:, 2], 1e-6)
        self.friction_used = float((tangential / (self.law.friction * pressing)).max())
        self._used += blend * (min(self.friction_used, MOST_USED) - self._used)
        slow = 0.5 * (1.0 + 1.0 / self.law.margin)  # the friction used above which the carry slows
        slowed = float(np.clip((1.0 - self._used) / (1.0 - slow), SLOWEST, 1.0))
        self.pace = min(slowed, self.pace + RECOVER * self.dt)
        wanted = min(max(floor, self.law.needed(self._load)), self.law.scale * floor)
        last = floor if self._force is None else self._force
        self._force = float(np.clip(wanted, last - FALL * self.dt, last + RISE * self.dt))
        return np.maximum(written, self._force)

    def bounds(self, speeds: np.ndarray, accelerations: np.ndarray, written: float) -> tuple[np.ndarray, np.ndarray]:
        """The hands' rate bounds per curve (both hands' x, y, z, then the heading: (7,) each) while the box is
        held with the `written` force [N]: the planner's, within what the grip holds, at the pace."""
        horizontal, vertical, yaw = self.law.accelerations(written)
        grip = np.array([horizontal, horizontal, vertical] * 2 + [yaw])
        held = np.clip(grip, LEAST * accelerations, accelerations)
        return self.pace * speeds, held


def grip_of(scenario: Scenario, width: float) -> GripForce | None:
    """The squeeze and the carry's bounds while the box is held with the pads `width` [m] apart (None: no box, no
    admittance loop, or a zero margin)."""
    box, a = scenario.world.box, scenario.admittance
    if box is None or not a.enabled or a.grip_margin <= 0.0:
        return None
    size = (float(box.size[0]), float(box.size[1]))
    law = GripLaw(box.assumed_mass, size, width, box.friction, a.grip_margin, a.grip_scale, a.force_filter)
    return GripForce(law, scenario.sim.control_dt)


def grip_width(scenario: Scenario, robot: Robot, hands: np.ndarray) -> float:
    """[m] the hands' distance apart in the grasp phase as written (at home without one)."""
    assert scenario.task is not None
    grasp = next((p for p in scenario.task.phases if p.grasp), None)
    ends = [] if grasp is None else [target_position(grasp.hands.get(h), scenario) for h in robot.hand_names]
    pair = [e for e in ends if e is not None]
    return float(np.linalg.norm(pair[1] - pair[0]) if len(pair) == 2 else np.linalg.norm(hands[1] - hands[0]))
