"""The squeeze force while a box is held, from the load the grip carries: each pad's friction must hold what the
wrist sensors measure along the pad's face, with a margin (the grip-force / load-force coupling of human and robot
grasping), and never less than the box's weight needs.

A pad pressing with normal force F holds at most mu F along its face. The box's weight, its accelerations and
whatever else pushes on it (an arm touching it, the hands shearing it between them) reach the pads as tangential
forces, which the wrist sensors measure (grasp frame: x, y along the face, z out of the pad). The reference is

    F = clip(max(F_written, margin max(m g / 2, f_t) / mu), F_written, scale F_written)

with f_t the larger tangential force of the two wrists (low-passed), the same for both pads (unequal squeezes
push the box sideways). It rises at `RISE` N/s at most (the admittance follows a ramp, not a step) and falls
back at `FALL` N/s, so a load that comes and goes does not make the grip pump.

`friction_used` is the share of their friction the pads spend as the wrists see it (f_t / (mu F_measured)), which
the carry's pace follows (planning/carry_pace.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81
RISE, FALL = 50.0, 5.0  # [N/s] the most the reference rises and falls per second


@dataclass(frozen=True)
class GripLaw:
    """The box's `mass` [kg], the pad-box friction coefficient `friction`, the `margin` on the friction the
    squeeze provides over the load, the most a pad squeezes as a multiple of the written force (`scale`), and the
    time constant of the low-pass on the wrists' tangential force [s] (`filter`)."""

    mass: float
    friction: float
    margin: float
    scale: float
    filter: float

    def needed(self, tangential: float) -> float:
        """[N] the squeeze per pad that holds a tangential load of `tangential` [N] per pad, and the box's weight,
        with the margin."""
        return self.margin * max(0.5 * self.mass * GRAVITY, tangential) / self.friction


class GripForce:
    """Per control step, the squeeze reference while a box is held (`GripLaw`), and the friction the pads use."""

    def __init__(self, law: GripLaw, dt: float):
        self.law, self.dt = law, dt
        self._load = 0.0  # [N] the low-passed larger tangential force of the wrists
        self._force: float | None = None  # [N] the last reference (None: not holding)
        self.friction_used = 0.0

    def __call__(self, written: np.ndarray, wrenches: np.ndarray, holding: bool) -> np.ndarray:
        """The squeeze reference (hands, K) from the `written` one (hands, K) and the wrists' `wrenches` (hands, 6,
        grasp frame); the written one while not `holding` or where it asks for no force."""
        tangential = float(np.hypot(wrenches[:, 0], wrenches[:, 1]).max())
        blend = 1.0 if self.law.filter <= 0.0 else min(self.dt / self.law.filter, 1.0)
        self._load += blend * (tangential - self._load)
        floor = float(written.min())
        if not holding or floor <= 0.0:
            self._force, self.friction_used = None, float("nan")
            return written
        pressing = np.maximum(-wrenches[:, 2], 1e-6)
        self.friction_used = float((np.hypot(wrenches[:, 0], wrenches[:, 1]) / (self.law.friction * pressing)).max())
        wanted = min(max(floor, self.law.needed(self._load)), self.law.scale * floor)
        last = floor if self._force is None else self._force
        self._force = float(np.clip(wanted, last - FALL * self.dt, last + RISE * self.dt))
        return np.maximum(written, self._force)
