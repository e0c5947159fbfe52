"""Obstacle clearance as the whole-body MPC sees it: margins (>= 0: clear) of the base footprint and the hands
from every obstacle and table leg, as CasADi expressions of q and the per-knot obstacle poses."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from harmony_cli.maths.shapes import obstacle_shape, symbolic_distance, table_legs
from harmony_cli.mpc.knot_params import KnotLayout
from harmony_cli.robot.model import Robot

if TYPE_CHECKING:
    from harmony_cli.scenario.world import WorldSpec

SOFTMIN = 0.01  # [m] smoothing of the footprint's min over circles; the soft-min is below the min by <= this * ln n


@dataclass(frozen=True)
class Clearance:
    """An obstacle as the whole-body MPC sees it: its centre (3) and yaw are parameters at every knot (so it
    may move); the base footprint circles keep `base` [m] from it in x, y and the hands `hand` [m] in 3-D
    (None: the hands may touch it, e.g. a table)."""

    kind: str
    half: np.ndarray
    base: float
    hand: float | None


def scene_clearances(
    world: WorldSpec, hand_radius: float, base_margin: float
) -> tuple[tuple[Clearance, ...], np.ndarray]:
    """The world's obstacles (scenario order: moving ones update their poses), then every table leg (the base
    may pass under a table's top), and their poses [centre; yaw] stacked (4 per clearance) where they start."""
    shapes = [obstacle_shape(o) for o in world.obstacles]
    clearances = tuple(
        Clearance(s.kind, s.half, o.margin, o.margin + hand_radius) for o, s in zip(world.obstacles, shapes)
    )
    legs = [leg for t in world.tables for leg in table_legs(t)]
    clearances += tuple(Clearance("box", leg.half, base_margin, None) for leg in legs)
    poses = [np.r_[s.centre, s.yaw] for s in shapes + legs]
    return clearances, np.concatenate(poses or [np.zeros(0)])


def clearance_margins(
    robot: Robot,
    q,
    ref,
    layout: KnotLayout,
    clearances: tuple[Clearance, ...],
    footprint: tuple[tuple[float, float, float], ...],
) -> list:
    """Clearance margins (>= 0: clear) of a configuration q: per obstacle, the base footprint (a smooth soft-min
    over its circles, a lower bound of their minimum; planar) if there is a footprint, then each hand (3-D) if
    the obstacle keeps hands away. The obstacles' poses are read from the knot parameters `ref`."""
    hands = [robot.hand_pose(h, q)[0] for h in range(len(robot.end_effectors))]
    bx, by, byaw = (q[i] for i in robot.base_joints)
    circles = [
        (cs.vertcat(bx + cs.cos(byaw) * x - cs.sin(byaw) * y, by + cs.sin(byaw) * x + cs.cos(byaw) * y, 0), r)
        for x, y, r in footprint
    ]
    margins = []
    for o, obstacle in enumerate(clearances):
        centre, yaw = ref[layout.obstacle_centre(o)], ref[layout.obstacle_yaw(o)]
        if circles:
            m = cs.vertcat(
                *[
                    symbolic_distance(obstacle.kind, obstacle.half, centre, yaw, point, planar=True)
                    - obstacle.base
                    - radius
                    for point, radius in circles
                ]
            )
            low = cs.mmin(m)  # shifted log-sum-exp: exact, smooth, no overflow
            margins.append(low - SOFTMIN * cs.log(cs.sum1(cs.exp(-(m - low) / SOFTMIN))))
        if obstacle.hand is not None:
            margins += [symbolic_distance(obstacle.kind, obstacle.half, centre, yaw, p) - obstacle.hand for p in hands]
    return margins


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
