"""The task-space planner's data: the hands' measured state, an obstacle as the planner sees it, and a plan (both
hands' Bezier curves and their common heading) that the controllers sample."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np

from harmony_cli.maths.bezier import bernstein_basis
from harmony_cli.maths.rotations import rot_z
from harmony_cli.maths.shapes import Shape

ROWS = 7  # hand 0 xyz, hand 1 xyz, heading


@dataclass(frozen=True)
class HandState:
    positions: np.ndarray  # (2, 3) world
    velocities: np.ndarray  # (2, 3)
    heading: float  # psi [rad]
    heading_rate: float = 0.0  # [rad/s]


@dataclass(frozen=True)
class Obstacle:
    shape: Shape  # where it is at t = 0
    clearance: float  # required signed distance of a hand centre [m] (margin + hand radius)
    motion: Callable[[np.ndarray], np.ndarray] | None = None  # absolute times (n,) -> predicted centres (n, 3)


@dataclass(frozen=True)
class Plan:
    """The planned curves over [start, start + horizon]; held at the goal after the end."""

    control_points: np.ndarray  # (7, M)
    start: float
    horizon: float
    home_rotations: np.ndarray  # (2, 3, 3)

    def rates(self, t: float) -> np.ndarray:
        """d/dt of the 7 curves at absolute time t (zero after the end)."""
        s = (t - self.start) / self.horizon
        if s >= 1.0:
            return np.zeros(ROWS)
        n = self.control_points.shape[1] - 1
        hodograph = n * (self.control_points[:, 1:] - self.control_points[:, :-1]) / self.horizon  # np.diff's, faster
        return hodograph @ bernstein_basis(n, max(s, 0.0))[0]

    def sample(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Hand positions (n, 2, 3) and rotations (n, 2, 3, 3) at absolute times."""
        s = ((np.atleast_1d(times) - self.start) / self.horizon).clip(0.0, 1.0)  # np.clip's ufunc, ~3 us less
        values = self.control_points @ bernstein_basis(self.control_points.shape[1], s).T  # (7, n)
        positions = values[:6].T.reshape(-1, 2, 3)
        rotations = np.einsum("nij,hjk->nhik", rot_z(values[6]), self.home_rotations)
        return positions, rotations


@dataclass(frozen=True)
class PlannerResult:
    plan: Plan
    success: bool
    status: str  # for the steps log (Solved.status)
    iterations: int
    solve_time: float
    min_clearance: float  # predicted, over samples and obstacles [m] (inf without obstacles)
    routed: bool = False  # the SQP was seeded on a route round the obstacles
    shortfall: float = 0.0  # [m] the largest clearance the plan falls short of (its QP's slack)


Ends = tuple[HandState, np.ndarray, float]  # the measured state, the goal (2, 3), the goal heading


class Outcome(Enum):
    """How an SQP ended: its last step below the tolerance, its iterations spent, or a QP that failed."""

    CONVERGED = "converged"
    STEPPED = "stepped"
    FAILED = "qp failed"


SHORT = 5e-3  # [m] a slack above this is a clearance the plan falls short of


@dataclass(frozen=True)
class Solved:
    """One SQP's outcome: control points, horizon, how it ended, iterations, predicted clearance, the largest
    clearance shortfall it took (its slack) and the base footprint's predicted margin; `routed`: seeded on a route."""

    C: np.ndarray
    T: float
    outcome: Outcome
    iterations: int
    clearance: float
    shortfall: float = 0.0
    base_clearance: float = np.inf  # the base footprint's smallest predicted margin [m] (soft: may be < 0)
    routed: bool = False

    @property
    def success(self) -> bool:
        return self.outcome is not Outcome.FAILED

    @property
    def converged(self) -> bool:
        return self.outcome is Outcome.CONVERGED

    @property
    def status(self) -> str:
        """For the steps log: the outcome, "(route)" when routed, the shortfall when there is one."""
        routed = " (route)" if self.routed else ""
        short = f" (short {100 * self.shortfall:.1f} cm)" if self.shortfall > SHORT else ""
        return f"{self.outcome.value}{routed}{short}"
