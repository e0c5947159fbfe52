"""Impossible scenes, refused before they run, on a proof from geometry alone: bodies overlapping (an obstacle and a
table, the box where it starts or at its goal, or the robot's start), or a hand target beyond the arm's reach from
every base pose whose footprint clears the bodies' physical outlines (margins not included), or from every such
pose the base can drive to from its start (passage.py). The margins the controllers keep are their preference,
not the world's: a scene they cannot solve within them is their failure, and counts.

Geometry is planar where the bodies are vertical prisms (tables, boxes, cylinders, the base footprint as the robot
section declares it) and exact for them; heights are compared as intervals. The reach is a bound that holds for
every joint value (robot/reach_bound.py); the grid of base poses tried errs towards "reachable" by how far a true
pose can be from the nearest one tried. Collision-free: the footprint clear of obstacles and table legs (it may
pass under a table's top), the trunk (robot.trunk) out from under the tops at its height."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from harmony_cli.maths.shapes import Shape, obstacle_shape, table_legs, table_shape
from harmony_cli.robot.model import Robot
from harmony_cli.robot.reach_bound import ReachBound, reach_bound
from harmony_cli.scenario import Scenario, robot_of
from harmony_cli.tasks.as_written import heights_meet, target_position, trunk_under_tops, z_range
from harmony_cli.tasks.passage import Passage, planar_distance

BASE_YAWS = 16  # base headings tried at each candidate position
BASE_STEP = 0.05  # [m] spacing of candidate base positions


def planar_gap(a: Shape, b: Shape) -> float:
    """Signed distance in x, y between two vertical shapes (negative: their outlines overlap)."""
    if a.kind == "box" and b.kind == "box":
        return _box_gap(a, b)
    circle, other = (a, b) if a.kind != "box" else (b, a)
    return float(planar_distance(other, circle.centre[None, :2])[0] - circle.half[0])


def _box_gap(a: Shape, b: Shape) -> float:
    """Separating axes for the overlap depth; separated, the nearest pair includes a corner of one of them."""
    ca, cb = a.corners(), b.corners()
    depth = np.inf
    for yaw in (a.yaw, b.yaw):
        for axis in (np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])):
            pa, pb = ca @ axis, cb @ axis
            overlap = min(pa.max(), pb.max()) - max(pa.min(), pb.min())
            if overlap <= 0:
                return float(min(planar_distance(b, ca).min(), planar_distance(a, cb).min()))
            depth = min(depth, overlap)
    return float(-depth)


class SceneCheck:
    """The scene check of a study (each robot's reach worked out once)."""

    def __init__(self, scenario_dir: Path, clearance: float = 0.0):
        self.scenario_dir, self.clearance = scenario_dir, clearance
        self._robots: dict[str, Robot] = {}
        self._bounds: dict[str, list[ReachBound]] = {}

    def __call__(self, scenario: Scenario) -> str | None:
        """Why the scene is impossible, or None."""
        return self._overlap(scenario) or self.unreachable(scenario)

    def robot(self, scenario: Scenario) -> Robot:
        key = scenario.robot.model_dump_json(exclude={"base_pose"})  # where it starts does not change its arms
        if key not in self._robots:
            self._robots[key] = robot_of(scenario, self.scenario_dir)
        return self._robots[key]

    def bounds(self, scenario: Scenario) -> list[ReachBound]:
        """Each hand's reach bound (robot/reach_bound.py)."""
        key = scenario.robot.model_dump_json(exclude={"base_pose"})
        if key not in self._bounds:
            robot = self.robot(scenario)
            self._bounds[key] = [reach_bound(robot, h) for h in range(len(robot.end_effectors))]
        return self._bounds[key]

    def _overlap(self, scenario: Scenario) -> str | None:
        world, robot = scenario.world, scenario.robot
        footprint = _footprint(robot.footprint, robot.base_pose)
        bodies: list[tuple[str, Shape]] = [(f"table {t.name}", table_shape(t)) for t in world.tables]
        if world.box is not None:
            size, half = np.asarray(world.box.size), np.asarray(world.box.size) / 2
            yaw = np.deg2rad(world.box.yaw_deg)
            bodies.append(("the box", Shape("box", np.asarray(world.box.position), yaw, half)))
            if world.box.goal is not None:
                bodies.append(("the box at its goal", Shape("box", np.asarray(world.box.goal), yaw, size / 2)))
        for obstacle in world.obstacles:
            shape = obstacle_shape(obstacle)
            for name, body in bodies:
                gap = planar_gap(shape, body)
                if heights_meet(z_range(shape), z_range(body)) and gap < self.clearance:
                    return f"obstacle {obstacle.name} overlaps {name} ({_gap_text(gap)})"
            for circle in footprint:
                gap = planar_gap(shape, circle)
                if gap < 0.0:
                    return f"obstacle {obstacle.name} overlaps the robot's start ({_gap_text(gap)})"
        return None

    def unreachable(self, scenario: Scenario) -> str | None:
        """Why some phase's hand targets cannot be reached (no collision-free base pose has them all within the
        arms' reach, or none the base can drive to from its start), or None."""
        if scenario.task is None:
            return None
        blocked, bounds, spec = _static_outlines(scenario), self.bounds(scenario), scenario.robot
        trunk = trunk_under_tops(scenario)
        phases = []
        for phase in scenario.task.phases:
            written = [
                (h, label, target_position(phase.hands.get(label), scenario))
                for h, label in enumerate(spec.end_effectors)
            ]
            phases.append((phase.name, [(h, label, t) for h, label, t in written if t is not None]))
        circles = np.asarray(spec.footprint, dtype=float).reshape(-1, 3)
        passage = None
        ends = np.array([t[:2] for _, targets in phases for *_, t in targets])
        if len(circles) and len(ends):
            passage = Passage(blocked, circles, np.asarray(spec.base_pose[:2], dtype=float), ends)
        for name, targets in phases:
            if not targets:
                continue
            radii = [bounds[h].radius(float(t[2])) for h, _, t in targets]
            found = _base_place(radii, np.array([t for *_, t in targets]), blocked, circles, passage, trunk)
            where = " and ".join(f"the {label} hand's target {np.round(t, 3).tolist()}" for _, label, t in targets)
            if found == "out of reach":
                return f"phase {name}: {where} out of reach from every collision-free base pose"
            if found == "no passage" and passage is not None:
                return (
                    f"phase {name}: no passage for the base from its start to where {where} in reach; the "
                    f"footprint is {passage.width:.3f} m wide at its narrowest, and no gap between the bodies "
                    f"is that wide"
                )
        return None


def _base_place(
    radii: list[float | None],
    targets: np.ndarray,
    blocked: list,
    circles: np.ndarray,
    passage: Passage | None,
    trunk: Sequence[tuple[np.ndarray, Shape]] = (),
) -> str:
    """Whether some base pose (a grid of positions x BASE_YAWS headings) has its footprint clear of `blocked` and
    its `trunk` circles out from under the table tops at their height, every target (n, 3) within its hand's
    plan-view `radii` of the base's origin and the `passage` to it from the start: "ok", "out of reach" or "no
    passage". Conservative (a necessary condition): the radii grow and the bodies shrink by how far a true pose can
    be from the nearest one tried."""
    if any(r is None for r in radii):
        return "out of reach"
    reach = np.array(radii, dtype=float) + BASE_STEP / np.sqrt(2)
    span = np.arange(-reach.max(), reach.max() + BASE_STEP, BASE_STEP)
    grid = targets[:, :2].mean(axis=0) + np.stack(np.meshgrid(span, span), axis=-1).reshape(-1, 2)
    near = grid[(np.linalg.norm(grid[:, None] - targets[None, :, :2], axis=2) <= reach).all(axis=1)]
    if len(near) == 0:
        return "out of reach"
    arm = np.hypot(circles[:, 0], circles[:, 1])  # a circle's centre moves by at most arm * half a yaw step
    give = BASE_STEP / np.sqrt(2) + arm * np.sin(np.pi / BASE_YAWS)
    extent = reach.max() + arm.max() + circles[:, 2].max()
    near_target = [  # shapes no candidate footprint can touch drop out
        (shape, margin)
        for shape, margin in blocked
        if np.hypot(*(shape.centre[:2] - targets[:, :2].mean(axis=0)))
        <= extent + np.linalg.norm(shape.half[:2]) + margin
    ]
    found = "out of reach"
    for yaw in np.linspace(0, 2 * np.pi, BASE_YAWS, endpoint=False):
        turn = np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])  # row vectors turned by yaw
        centres = (near[:, None, :] + (circles[:, :2] @ turn)[None]).reshape(-1, 2)  # (positions x circles, 2)
        clear = np.ones(len(centres), dtype=bool)
        for shape, margin in near_target:
            clear &= planar_distance(shape, centres) - np.tile(circles[:, 2] - give, len(near)) >= margin
        fits = clear.reshape(len(near), len(circles)).all(axis=1)
        for circle, top in trunk:
            centre = near + circle[:2] @ turn
            give_trunk = BASE_STEP / np.sqrt(2) + np.hypot(*circle[:2]) * np.sin(np.pi / BASE_YAWS)
            fits &= planar_distance(top, centre) >= circle[2] - give_trunk
        places = near[fits]
        if len(places):
            if passage is None or passage.reaches(places):
                return "ok"
            found = "no passage"
    return found


def _footprint(circles, pose) -> list[Shape]:
    """The base footprint's circles in the world at a pose (x, y, yaw [deg])."""
    x, y, yaw = pose[0], pose[1], np.deg2rad(pose[2])
    c, s = np.cos(yaw), np.sin(yaw)
    return [
        Shape("cylinder", np.array([x + c * px - s * py, y + s * px + c * py, 0.0]), 0.0, np.array([r, r, 1.0]))
        for px, py, r in circles
    ]


def _static_outlines(scenario: Scenario) -> list[tuple[Shape, float]]:
    """What a base cannot stand in, with no margin: static obstacles and table legs, their physical outlines."""
    shapes = [obstacle_shape(o) for o in scenario.world.obstacles if o.motion is None]
    legs = [leg for t in scenario.world.tables for leg in table_legs(t)]
    return [(shape, 0.0) for shape in shapes + legs]


def _gap_text(gap: float) -> str:
    return f"{100 * gap:.1f} cm" if gap >= 0 else f"overlapping by {-100 * gap:.1f} cm"
