"""Obstacle clearance as the whole-body MPC sees it: margins (>= 0: clear) of the base footprint, the hands and the
arms from every obstacle, table leg and table top, as CasADi expressions of q and the per-knot obstacle poses."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from harmony_cli.maths.shapes import obstacle_shape, symbolic_distance, symbolic_distances, table_legs, table_top
from harmony_cli.mpc.knot_params import KnotLayout
from harmony_cli.robot.arm_points import MARGIN as ARM_MARGIN
from harmony_cli.robot.model import Robot

if TYPE_CHECKING:
    from harmony_cli.scenario.models import Scenario
    from harmony_cli.scenario.world import WorldSpec

SOFTMIN = 0.01  # [m] smoothing of a min over circles or points; the soft-min is below the min by <= this * ln n
# [m] the least clearance a relieved margin keeps: the footprint's circles and the hands' spheres only approximate
# the bodies, and the knots sample the motion between them
FLOOR = 0.05


@dataclass(frozen=True)
class Clearance:
    """An obstacle as the whole-body MPC sees it: its centre (3) and yaw are parameters at every knot (so it
    may move); the base footprint circles keep `base` [m] from it in x, y (None: the base passes under it, a
    table's top), the hands `hand` [m] in 3-D (None: the hands may touch it, e.g. a table) and the spheres along
    each arm `arm` [m], their radius included (None: not kept from the arms). `give` [m]: how far the base's and
    the hands' margins may be lowered where a stance cannot keep them (a relief, in the knot parameters): an
    obstacle's margin is a preference down to FLOOR, its body a hard limit."""

    kind: str
    half: np.ndarray
    base: float | None
    hand: float | None
    arm: float | None = None
    give: float = 0.0


def scene_clearances(
    world: WorldSpec, hand_radius: float, base_margin: float, arm_radius: float | None = None
) -> tuple[tuple[Clearance, ...], np.ndarray]:
    """The world's obstacles (scenario order: moving ones update their poses), then every table leg (the base
    may pass under a table's top), then every table's top when the arms are kept clear (`arm_radius` not None),
    and their poses [centre; yaw; relief 0] stacked (knot_params.POSE_ROWS per clearance) where they start. The
    arms keep their radius plus ARM_MARGIN from obstacles and tops: the obstacle's own margin is the base's and the
    hands' (a planning buffer the arms, between them, mostly keep anyway), and the hands work just above a table's
    top."""
    arm = None if arm_radius is None else arm_radius + ARM_MARGIN
    shapes = [obstacle_shape(o) for o in world.obstacles]
    clearances = tuple(
        Clearance(s.kind, s.half, o.margin, o.margin + hand_radius, arm, max(o.margin - FLOOR, 0.0))
        for o, s in zip(world.obstacles, shapes)
    )
    legs = [leg for t in world.tables for leg in table_legs(t)]
    clearances += tuple(Clearance("box", leg.half, base_margin, None) for leg in legs)
    tops = [table_top(t) for t in world.tables] if arm is not None else []
    clearances += tuple(Clearance("box", top.half, None, None, arm) for top in tops)
    poses = [np.r_[s.centre, s.yaw, 0.0] for s in shapes + legs + tops]
    return clearances, np.concatenate(poses or [np.zeros(0)])


def scenario_clearances(scenario: Scenario) -> tuple[tuple[Clearance, ...], np.ndarray]:
    """scene_clearances of a scenario's world, with its hand radius, base margin and arm radius."""
    robot = scenario.robot
    return scene_clearances(scenario.world, scenario.planner.hand_radius, robot.base_margin, robot.arm_radius)


def soft_min(margins) -> cs.SX:
    """A smooth lower bound of the smallest of `margins` (a column), by at most SOFTMIN * ln(their number):
    one row for many, C-infinity (a shifted log-sum-exp: exact, no overflow)."""
    low = cs.mmin(margins)
    return low - SOFTMIN * cs.log(cs.sum1(cs.exp(-(margins - low) / SOFTMIN)))


def arm_points(robot: Robot, q) -> list[list]:
    """Per hand, the world positions of its arm's points (robot.arms) at q."""
    return [
        chain.positions(robot.model.get_global_link_transform(chain.base_link, q), lambda j: q[robot.index(j)])
        for chain in robot.arms
    ]


def clearance_margins(
    robot: Robot,
    q,
    ref,
    layout: KnotLayout,
    clearances: tuple[Clearance, ...],
    footprint: tuple[tuple[float, float, float], ...],
) -> list:
    """Clearance margins (>= 0: clear) of a configuration q: per obstacle, the base footprint (a smooth soft-min
    over its circles, a lower bound of their minimum; planar) if there is a footprint and it keeps the base away
    and each hand (3-D) if it keeps hands away; after every obstacle's, per obstacle that keeps the arms away each
    arm's (a soft-min over the arm's points, 3-D: last, see arm_rows). The obstacles' poses and reliefs (an
    obstacle that gives: its base and hand margins less the relief) are read from the knot parameters `ref`."""
    hands = [robot.hand_pose(h, q)[0] for h in range(len(robot.end_effectors))]
    arms = [ps for ps in arm_points(robot, q) if ps] if any(c.arm is not None for c in clearances) else []
    bx, by, byaw = (q[i] for i in robot.base_joints)
    circles = [
        (cs.vertcat(bx + cs.cos(byaw) * x - cs.sin(byaw) * y, by + cs.sin(byaw) * x + cs.cos(byaw) * y, 0), r)
        for x, y, r in footprint
    ]
    margins, arm_margins = [], []
    for o, obstacle in enumerate(clearances):
        shape = obstacle.kind, obstacle.half, ref[layout.obstacle_centre(o)], ref[layout.obstacle_yaw(o)]
        relief = ref[layout.obstacle_relief(o)] if obstacle.give > 0.0 else 0.0
        if circles and obstacle.base is not None:
            base = obstacle.base - relief
            margins.append(
                soft_min(cs.vertcat(*[symbolic_distance(*shape, p, planar=True) - base - r for p, r in circles]))
            )
        if obstacle.hand is not None:
            margins += [symbolic_distance(*shape, p) - (obstacle.hand - relief) for p in hands]
        if obstacle.arm is not None:
            arm_margins += [soft_min(cs.vertcat(*symbolic_distances(*shape, ps)) - obstacle.arm) for ps in arms]
    return margins + arm_margins


def arm_rows(robot: Robot, clearances: tuple[Clearance, ...]) -> int:
    """How many of clearance_margins' rows are the arms' (its last ones)."""
    return sum(c.arm is not None for c in clearances) * sum(chain.n_points > 0 for chain in robot.arms)


def clearance_function(
    robot: Robot, clearances: tuple[Clearance, ...], footprint: tuple, compliant: bool = False, n_chest: int = 0
) -> cs.Function:
    """h(q, ref) >= 0 per knot (q, ref as in task_residual_function): the hard clearance constraints."""
    layout = KnotLayout(len(robot.end_effectors), len(clearances), compliant, n_chest)
    q = cs.SX.sym("q", robot.n_dof + (layout.n_hands if compliant else 0))
    ref = cs.SX.sym("ref", layout.rows)
    return cs.Function(
        "clearance",
        [q, ref],
        [cs.vertcat(*clearance_margins(robot, q[: robot.n_dof], ref, layout, clearances, footprint))],
    )
