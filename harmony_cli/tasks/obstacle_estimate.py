"""What the controllers predict of a moving obstacle whose `prediction` is `estimated`: a constant-velocity Kalman
filter on its measured centre, extrapolated along the estimated velocity over the MPCs' horizons, instead of its
scripted motion. The other obstacles keep their scripted motion (tasks/motion.py)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.filters import ConstantVelocityKalman
from harmony_cli.tasks.motion import Predictor, centre_at

if TYPE_CHECKING:
    from harmony_cli.scenario.world import ObstacleSpec

# [m/s^2] the filter's white accelerations: an obstacle that walks and turns (a person, a cart); larger follows
# turns sooner and smooths the noise less
ACCELERATION = 1.0
LEAST_NOISE = 1e-3  # [m] the measurement noise the filter assumes at least (a measurement is never exact)


class ObstacleTracks:
    """The `obstacles` (scenario order) of which those moving with `prediction: estimated` are filtered from
    measurements every `dt` [s] with white noise of standard deviation `noise` [m]."""

    def __init__(self, obstacles: list[ObstacleSpec], noise: float, dt: float):
        self.obstacles = obstacles
        self.estimated = [i for i, o in enumerate(obstacles) if o.motion is not None and o.prediction == "estimated"]
        self.filter = ConstantVelocityKalman(ACCELERATION, max(noise, LEAST_NOISE), dt)
        self.t = 0.0

    def __bool__(self) -> bool:
        return bool(self.estimated)

    def true_centres(self, t: float) -> np.ndarray:
        """(estimated obstacles, 3) where they are at `t` (their scripted motion: what a sensor measures)."""
        return np.array([centre_at(self.obstacles[i], t)[0] for i in self.estimated])

    def update(self, t: float, measured: np.ndarray) -> None:
        """The measured centres (estimated obstacles, 3) at `t`."""
        self.filter.update(measured)
        self.t = t

    def motion(self, index: int) -> Callable[[np.ndarray], np.ndarray]:
        """Obstacle `index`'s predicted centres (n, 3) at absolute times (n,)."""
        if index not in self.estimated:
            return lambda times: centre_at(self.obstacles[index], times)
        row = self.estimated.index(index)

        def predicted(times: np.ndarray) -> np.ndarray:
            assert self.filter.state is not None, "an estimate is asked before the first measurement"
            ahead = np.atleast_1d(np.asarray(times, dtype=float)) - self.t
            return self.filter.state[0, row] + ahead[:, None] * self.filter.state[1, row]

        return predicted

    def predictor(self) -> Predictor:
        """Every obstacle's predicted centres (obstacles, n, 3) at absolute times (n,): the whole-body MPC's."""
        motions = [self.motion(i) for i in range(len(self.obstacles))]
        return lambda times: np.stack([motion(times) for motion in motions])

    def errors(self, t: float) -> dict[str, float]:
        """For the steps log, per estimated obstacle: the estimate's position and velocity errors [m, m/s]."""
        if self.filter.state is None:
            return {}
        rows = {}
        for row, i in enumerate(self.estimated):
            spec = self.obstacles[i]
            around = centre_at(spec, [t - 1e-3, t + 1e-3])  # its velocity: a central difference of the motion
            velocity = (around[1] - around[0]) / 2e-3
            position = centre_at(spec, t)[0]
            rows[f"estimate_{spec.name}_error_m"] = float(np.linalg.norm(self.filter.state[0, row] - position))
            rows[f"estimate_{spec.name}_speed_error_m_s"] = float(np.linalg.norm(self.filter.state[1, row] - velocity))
        return rows
