"""Where an obstacle is at any time: its scenario motion (constant velocity or waypoints) as a pure function.

The simulation moves the PyBullet body along it and both MPCs use it as their predictor (the true future motion,
known from the scenario), sampled at their own knot / sample times."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from harmony_cli.scenario.world import ObstacleSpec

# absolute times (n,) -> centres (obstacles, n, 3)
Predictor = Callable[[np.ndarray], np.ndarray]


def centre_at(spec: ObstacleSpec, times: ArrayLike) -> np.ndarray:
    """Centre (n, 3) of obstacle `spec` at `times` (n,) [s]: static without a motion; with `velocity`, moving
    from `position` between `start` and `stop`; with `waypoints`, piecewise linear, held before the first and
    after the last."""
    times = np.atleast_1d(np.asarray(times, dtype=float))
    position, motion = np.asarray(spec.position, dtype=float), spec.motion
    if motion is None:
        return np.tile(position, (times.size, 1))
    if motion.velocity is not None:
        stop = np.inf if motion.stop is None else motion.stop
        travelled = np.clip(times, motion.start, stop) - motion.start
        return position + travelled[:, None] * np.asarray(motion.velocity, dtype=float)
    w = np.asarray(motion.waypoints, dtype=float)
    return np.stack([np.interp(times, w[:, 0], w[:, 1 + axis]) for axis in range(3)], axis=1)


def obstacle_predictor(obstacles: list[ObstacleSpec]) -> Predictor | None:
    """Predicted centres of all `obstacles` (scenario order) at absolute times; None when none of them moves."""
    if not any(o.motion is not None for o in obstacles):
        return None
    return lambda times: np.stack([centre_at(o, times) for o in obstacles])
