"""The scenario as written, placed in the world: a phase's hand target (relative ones from where the box starts or
a table's top), and which trunk circles stand at a table top's height (robot.trunk)."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.shapes import Shape, table_shape, table_top, table_top_pose
from harmony_cli.scenario import Scenario
from harmony_cli.scenario.task import RelativeTarget


def target_position(target, scenario: Scenario) -> np.ndarray | None:
    """A hand target's world position as the scenario writes it (relative ones from where the box starts)."""
    if target is None:
        return None
    if not isinstance(target, RelativeTarget):
        return np.asarray(target, dtype=float)
    if target.relative_to == "box":
        box = scenario.world.box
        assert box is not None  # the scenario's checks guarantee it
        origin, yaw = np.asarray(box.position, dtype=float), float(np.deg2rad(box.yaw_deg))  # as the box starts
    else:
        table = next(t for t in scenario.world.tables if t.name == target.relative_to)
        origin, yaw = table_top_pose(table)
    c, s = np.cos(yaw), np.sin(yaw)
    x, y, z = target.offset
    return origin + [c * x - s * y, s * x + c * y, z]


def trunk_under_tops(scenario: Scenario) -> list[tuple[np.ndarray, Shape]]:
    """Each trunk circle (x, y, radius in the base frame) with the outline of each table whose top is at its height
    (robot.trunk): the block to the floor, so that distances to it are plan-view ones, not to the slab's faces."""
    tops = [(table_top(t), table_shape(t)) for t in scenario.world.tables]
    return [
        (np.array(circle[:3]), outline)
        for circle in scenario.robot.trunk
        for top, outline in tops
        if heights_meet((circle[3], circle[4]), z_range(top))
    ]


def heights_meet(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return a[0] < b[1] and b[0] < a[1]


def z_range(shape: Shape) -> tuple[float, float]:
    return shape.centre[2] - shape.half[2], shape.centre[2] + shape.half[2]
