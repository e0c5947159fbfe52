"""The task-space planner's data: the hands' measured state, an obstacle as the planner sees it, and a plan (both
hands' Bezier curves and their common heading) that the controllers sample."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.bezier import bernstein_basis
from harmony_cli.maths.rotations import rot_z
from harmony_cli.maths.shapes import Shape, obstacle_shape
from harmony_cli.tasks.motion import centre_at

if TYPE_CHECKING:
    from harmony_cli.scenario.world import ObstacleSpec

ROWS = 7  # hand 0 xyz, hand 1 xyz, heading


@dataclass(frozen=True)
class HandState:
    positions: np.ndarray  # (2, 3) world
    velocities: np.ndarray  # (2, 3)
    heading: float  # psi [rad]
    heading_rate: float = 0.0  # [rad/s]


Motion = Callable[[np.ndarray], np.ndarray]  # absolute times (n,) -> predicted centres (n, 3)


@dataclass(frozen=True)
class Obstacle:
    shape: Shape  # where it is at t = 0
    clearance: float  # required signed distance of a hand centre [m] (margin + hand radius)
    motion: Motion | None = None  # its predicted centres (None: it stands)


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


Ends = tuple[HandState, np.ndarray, float]  # the measured state, the goal (2, 3), the goal heading


class Outcome(Enum):
    """How a plan ended: its SQP's last step below the tolerance, its iterations spent, its SQP still running, or a
    QP that failed; or a plan not taken because it holds non-finite numbers or the planner's numerics raised."""

    CONVERGED = "converged"
    STEPPED = "stepped"
    SEARCHING = "searching"  # a first plan's SQP still running: the last plan is tracked (phase_start.py)
    FAILED = "qp failed"
    NON_FINITE = "non-finite plan"
    ERROR = "exception"

    @property
    def success(self) -> bool:
        return self in (Outcome.CONVERGED, Outcome.STEPPED, Outcome.SEARCHING)


SHORT = 5e-3  # [m] a slack above this is a clearance the plan falls short of


class Ended:
    """How an SQP or a step's plan ended, as the steps log says it: whether it succeeded, and its status (the
    outcome, what raised, "(route)" when routed, the shortfall when there is one)."""

    outcome: Outcome
    routed: bool
    shortfall: float
    detail = ""

    @property
    def success(self) -> bool:
        return self.outcome.success

    @property
    def status(self) -> str:
        what = f" {self.detail}" if self.detail else ""
        route = " (route)" if self.routed else ""
        short = f" (short {100 * self.shortfall:.1f} cm)" if self.shortfall > SHORT else ""
        return f"{self.outcome.value}{what}{route}{short}"


@dataclass(frozen=True)
class Solved(Ended):
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
    def converged(self) -> bool:
        return self.outcome is Outcome.CONVERGED


@dataclass(frozen=True)
class PlannerResult(Ended):
    """The hands' MPC's answer at one step: the plan the controllers sample (the last good one when this step's
    was not taken), how this step's plan ended, and what the step log records of it."""

    plan: Plan
    outcome: Outcome
    iterations: int
    solve_time: float
    min_clearance: float  # predicted, over samples and obstacles [m] (inf without obstacles)
    routed: bool = False  # the SQP was seeded on a route round the obstacles
    shortfall: float = 0.0  # [m] the largest clearance the plan falls short of (its QP's slack)
    detail: str = ""  # what raised, for an ERROR


def planned_obstacles(
    obstacles: list[ObstacleSpec], grow: float, motions: list[Motion] | None = None
) -> list[Obstacle]:
    """The scenario's `obstacles` as the planner and the base's footprint keep clear of them: each shape where it
    starts, its margin plus `grow` as the clearance (the hands': their radius; the footprint's: 0), its predictor
    (None: it stands): `motions` (per obstacle, absolute times (n,) -> centres (n, 3)) or else its true motion."""
    return [
        Obstacle(
            obstacle_shape(o),
            o.margin + grow,
            None if o.motion is None else partial(centre_at, o) if motions is None else motions[i],
        )
        for i, o in enumerate(obstacles)
    ]
