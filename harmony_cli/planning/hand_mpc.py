"""Task-space planner (MPC-T): both hands' paths from their measured state to the phase goal at rest, re-planned
every step by the hands' SQP (hand_sqp.py): `phase_iterations` QPs for a phase's first plan, at most
`step_iterations` a control step (phase_start.py), `iterations` (1: real-time iteration) on every other step.

A phase's first plan's horizon is the phase's remaining time, or, where that is too short for the rate bounds from
the measured state, the least that is long enough, in closed form (plan_horizon.py); later plans keep its end
while its QP is feasible, and take the closed-form horizon when the hands have fallen too far behind to meet it.
A plan that runs past its phase's end comes back to the earliest end its path meets the bounds by, never before
the phase's: a carry slowed for a moment (grip_force.py) does not stay slow.
Global guidance (phase_start.py): a local SQP linearised at the straight line cannot find its way round an
obstacle on it, so a phase's first plan that is not clean is searched for again from the line moved onto the
shortest planar route round obstacles and tables, wide enough for the base (plan_seed.py, route.py).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.bezier import shift_matrix
from harmony_cli.mpc.problem import NoPlanToHold
from harmony_cli.planning.clear_goal import goal_reliefs
from harmony_cli.planning.hand_plan import Ends, HandState, Obstacle, Outcome, Plan, PlannerResult, Solved
from harmony_cli.planning.hand_sqp import HandSQP
from harmony_cli.planning.phase_start import Awaiting, Search, Step, is_clean, route_seed
from harmony_cli.planning.plan_base import PlannedBase
from harmony_cli.planning.plan_horizon import least_horizon, meets, retimed
from harmony_cli.planning.plan_seed import Ground, straight_to, warm_outlines

if TYPE_CHECKING:
    from harmony_cli.scenario.models import PlannerSpec

MAX_STRETCH = 5.0  # the longest horizon as a multiple of the phase's remaining time
RETIME_MARGIN = 1.1  # a plan re-timed to its bounds takes this much more than the least horizon


class HandMPC:
    """Built once for a set of obstacles; `step` re-plans from the measured hand state."""

    def __init__(
        self,
        spec: PlannerSpec,
        obstacles: list[Obstacle],
        home_rotations: np.ndarray,
        heading_offset: float,
        ground: Ground | None = None,
        base: PlannedBase | None = None,
        ceiling: float | None = None,
    ):
        self.spec, self.obstacles, self.home_rotations, self.ground = spec, obstacles, home_rotations, ground
        self.heading_offset = heading_offset  # heading = angle(p_1 - p_0) + offset (pads face each other)
        self.sqp = HandSQP(spec, obstacles, heading_offset, base, ceiling)
        self.M = spec.control_points
        self.C: np.ndarray | None = None  # the last good plan's control points, over [t_plan, t_plan + T_plan]
        self.phase: int | None = None
        self.t_plan, self.T_plan = 0.0, 1.0
        self.via: np.ndarray | None = None  # (2,) a point a phase's first plan routes through (a chosen stance)
        self.awaiting: Awaiting | None = None  # a line's plan that is not clean: the next step tries a route
        self.search: Search | None = None  # the phase's first plan while its SQP runs over the steps
        self._relief_key: tuple | None = None  # the goal whose reliefs the SQP has
        warm_outlines(obstacles, ground)  # before the loop, as the compiled code is loaded

    def goal_heading(self, goal: np.ndarray, heading_now: float) -> float:
        d = goal[1] - goal[0]
        heading = np.arctan2(d[1], d[0]) + self.heading_offset
        return heading_now + (heading - heading_now + np.pi) % (2 * np.pi) - np.pi  # nearest to heading_now

    def step(
        self,
        t: float,
        state: HandState,
        goal: np.ndarray,
        phase_end: float,
        phase: int,
        carrying_radius: float | None = None,
        carrying_drop: float = 0.0,
    ) -> PlannerResult:
        """Re-plan at time t towards `goal` (2, 3) for phase number `phase` ending at `phase_end`.

        While carrying, the object is the point `carrying_drop` below the hands' midpoint (its bottom centre)
        kept clear of every obstacle grown sideways by `carrying_radius` (its half diagonal): a box-like object
        over a flat-topped obstacle needs its bottom above the top, not a sphere's worth above it."""
        carried = None if carrying_radius is None else (carrying_radius, carrying_drop)
        start_time = time.perf_counter()
        ends = (state, goal, self.goal_heading(goal, state.heading))
        width = float(np.linalg.norm(goal[1] - goal[0]))
        if self.search is not None and self.search.phase != phase:
            self.search = None  # the phase changed while its first plan was searched
        if self.awaiting is not None and self.awaiting.phase != phase:
            self.awaiting = None
        solved, how, key, load = None, Step.ENDED, (phase, carried is None, goal), (carried, width)
        if (awaiting := self.awaiting) is not None:  # the line's plan wants a route: its SQP from this step on
            self.awaiting = None
            end = awaiting.t + awaiting.line.T
            seed = route_seed(self.sqp, self.ground, max(end - t, self.spec.min_horizon), ends, carried)
            if seed is not None:
                self.search = Search(awaiting.phase, seed, end, self.spec.phase_iterations, True, line=awaiting)
            else:  # no route: the line's plan, as of its own step, steps on
                self._take(awaiting.line, awaiting.phase, awaiting.t)
        elif self.search is None and phase != self.phase:  # a new phase: its first plan's search
            self.search = self._phase_search(t, ends, phase, phase_end, carried)
        if self.search is not None:
            solved, how = self._search_step(self.search, t, ends, load, key)
        if how is Step.RUNNING:  # the search goes on: the last plan taken, before any the hands held where they are
            outcome = Outcome.SEARCHING
            if self.C is None:
                self.C = np.repeat(np.r_[state.positions.ravel(), state.heading][:, None], self.M, axis=1)
                self.t_plan, self.T_plan = t, self.spec.min_horizon
        else:
            if solved is None or how is Step.LINE_TAKEN:  # a later plan: the plan taken steps on
                solved = self._later_step(t, state, ends, phase_end, load, key)
            outcome = solved.outcome
            if outcome.success and not np.isfinite(solved.C).all():  # NaN / inf is never the plan: the last is held
                outcome = Outcome.NON_FINITE
            if outcome.success:
                self._take(solved, phase, t)
        assert solved is not None  # a phase without a plan taken has a search
        if self.C is None:
            raise NoPlanToHold(f"first planner solve failed ({solved.status}); no plan to hold")
        plan = Plan(self.C.copy(), self.t_plan, self.T_plan, self.home_rotations)
        elapsed = time.perf_counter() - start_time
        return PlannerResult(
            plan, outcome, solved.iterations, elapsed, solved.clearance, solved.routed, solved.shortfall
        )

    def _phase_search(self, t: float, ends: Ends, phase: int, phase_end: float, carried) -> Search:
        """A new phase's first plan's search: from the route through its point to pass, if it has one and a
        route goes there, else from the straight line."""
        T = max(self.horizon(ends, phase_end - t), self.spec.min_horizon)
        via, self.via = self.via, None  # Planner sets it at a phase change: the phase's first plan only
        seed = None if via is None else route_seed(self.sqp, self.ground, T, ends, carried, via)
        if seed is not None:
            return Search(phase, seed, t + T, self.spec.phase_iterations, routed=True, via=True)
        return Search(phase, straight_to(ends, self.M), t + T, self.spec.phase_iterations)

    def _search_step(self, search: Search, t: float, ends: Ends, load: tuple, key: tuple) -> tuple[Solved, Step]:
        """This step's share of the search's SQP and how it ended. A line's plan is taken when it is clean; when
        it is not, the route's SQP starts on the next step (at once when the line's QP failed) and the route's
        plan is taken if its QP does not fail, else the line's; a point to pass that no route reaches starts the
        line's SQP at once."""
        carried, width = load
        T = max(search.end - t, self.spec.min_horizon)
        self._reliefs(key, search.end, carried)
        share = min(self.spec.step_iterations, search.left)  # this step's QPs, taken from what is left
        search.left -= share
        solved = self.sqp.solve(search.C, t, T, ends, share, carried, width)
        solved = replace(solved, routed=search.routed)
        if solved.success and not solved.converged and search.left > 0:
            return solved, Step.RUNNING
        self.search = None
        if search.routed and not solved.success and search.via:  # no way through the point: the line's SQP
            self.search = Search(search.phase, straight_to(ends, self.M), search.end, self.spec.phase_iterations)
            return self._search_step(self.search, t, ends, load, key)
        if search.routed:
            if solved.success or search.line is None:
                return solved, Step.ENDED
            self._take(search.line.line, search.phase, search.line.t)  # the line's plan, as of its own step
            return solved, Step.LINE_TAKEN
        if not self.obstacles or is_clean(solved, self.sqp.B, self.obstacles):
            return solved, Step.ENDED
        if solved.success:
            self.awaiting = Awaiting(search.phase, solved, t)
            return solved, Step.RUNNING
        seed = route_seed(self.sqp, self.ground, T, ends, carried)
        if seed is None:
            return solved, Step.ENDED
        self.search = Search(search.phase, seed, search.end, self.spec.phase_iterations, routed=True)
        routed, how = self._search_step(self.search, t, ends, load, key)
        return (solved if how is Step.ENDED and not routed.success else routed), how

    def _later_step(self, t: float, state: HandState, ends: Ends, phase_end: float, load: tuple, key) -> Solved:
        """The taken plan from now on (de Casteljau), re-planned by `iterations` QPs over the horizon a later plan
        keeps (_kept_horizon); when that fails because the hands fell behind its end, the closed-form horizon (the
        clearance rows' slack is always feasible), which later plans then keep."""
        assert self.C is not None
        carried, width = load
        tau = min(max((t - self.t_plan) / self.T_plan, 0.0), 0.99)  # np.clip costs ~4 us on a float
        C = self.C @ shift_matrix(self.M, tau) if tau > 0 else self.C.copy()
        T = max(self._kept_horizon(C, state, phase_end - t, self.t_plan + self.T_plan - t), self.spec.min_horizon)
        self._reliefs(key, t + T, carried)
        solved = self.sqp.solve(C, t, T, ends, self.spec.iterations, carried, width)
        if not solved.success and (longer := self.horizon(ends, T)) > T:
            solved = self.sqp.solve(C, t, longer, ends, self.spec.iterations, carried, width)
        return solved

    def _take(self, solved: Solved, phase: int, t: float) -> None:
        """`solved`'s plan, over [t, t + its horizon], is the plan the hands track from now on."""
        self.C, self.phase, self.t_plan, self.T_plan = solved.C, phase, t, solved.T

    def _reliefs(self, key: tuple, end: float, carried) -> None:
        """The SQP's clearance reliefs for the goal in `key` = (phase, free-handed, goal) at time `end`, computed
        once per key (goal_reliefs)."""
        phase, free, goal = key
        if (phase, free, goal.tobytes()) != self._relief_key:
            self.sqp.reliefs = goal_reliefs(self.obstacles, goal, end, carried)
            self._relief_key = (phase, free, goal.tobytes())

    def _kept_horizon(self, C: np.ndarray, state: HandState, remaining: float, left: float) -> float:
        """A later plan's horizon: the phase's `remaining` time, or, for a plan `left` [s] to run past the phase's
        end (stretched for slower bounds, or behind), the least over which the same path meets the bounds now
        (plan_horizon.retimed, with a margin) when that is sooner: a plan slowed once returns to its phase's
        pace when its bounds allow."""
        if left <= remaining:
            return remaining
        velocity = np.r_[state.velocities.ravel(), state.heading_rate]
        least = RETIME_MARGIN * retimed(C, velocity, self.sqp.speeds, self.sqp.accelerations)
        return min(left, max(remaining, least))

    def horizon(self, ends: Ends, remaining: float) -> float:
        """A phase's first plan's horizon: the phase's remaining time (at least min_horizon), or the least that
        meets the rate bounds from the measured state when that is longer (plan_horizon.py), at most MAX_STRETCH
        times it. Later plans keep the first's end (or the phase's, if later; _kept_horizon): the last plan from now on
        meets the bounds over it."""
        T = max(remaining, self.spec.min_horizon)
        state, goal, heading = ends
        curves = (
            np.r_[state.positions.ravel(), state.heading],
            np.r_[state.velocities.ravel(), state.heading_rate],
            np.r_[goal.ravel(), heading],
            self.sqp.speeds,
            self.sqp.accelerations,
            self.M,
        )
        if meets(T, *curves):
            return T
        return min(max(T, least_horizon(*curves)), MAX_STRETCH * T)
