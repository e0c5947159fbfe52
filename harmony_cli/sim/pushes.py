"""Scripted pushes: external forces on the robot, the box or an obstacle, applied every physics step while active.
A push is a set force, or a spring pusher (`stiffness`) whose force depends on how far the pushed point gives way.
PushForces is the law both engines share (which push acts, with what force, where); `Pushes` applies it in PyBullet
(which clears external forces after each stepSimulation), mujoco_pushes.py in MuJoCo. PyBullet is imported only by
the Pushes of a PyBullet run."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.scenario.world import PushSpec
    from harmony_cli.sim.world import World

EPS = 1e-9  # [s] substep times are multiples of physics_dt: keep t = start + duration outside the window


def active(push: PushSpec, t: float) -> bool:
    """The push acts at time t: start <= t < start + duration."""
    return push.start - EPS <= t < push.start + push.duration - EPS


T = TypeVar("T")


def push_target(spec: PushSpec, robot: Callable[[str | None], T], box: T | None, obstacles: dict[str, T]) -> T:
    """What a push acts on, in an engine's terms: `robot(link)` (None: the base), the box, or an obstacle by name."""
    if spec.body == "robot":
        return robot(spec.link)
    if spec.body == "box" and box is not None:
        return box
    if spec.body in obstacles:
        return obstacles[spec.body]
    raise ValueError(f"push {spec.name}: no body {spec.body!r} in the world")


class PushForces:
    """The pushes' forces over time, whatever engine applies them: `forces(t, point_of)` gives the pushes acting at
    t with their force and point of application, `point_of(i)` being where push i's point is now in the world."""

    def __init__(self, specs: Sequence[PushSpec], physics_dt: float):
        self.specs, self.dt = list(specs), physics_dt
        self.applied = [np.zeros(3) for _ in self.specs]  # the force of the last physics substep [N]
        # spring pushers: the point in the substep before the push, and (point, velocity) when the push began
        self.previous: list[np.ndarray | None] = [None] * len(self.specs)
        self.origin: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(self.specs)

    def _just_before(self, spec: PushSpec, t: float) -> bool:
        """A spring pusher's last substep before it begins: its point then gives the point's velocity."""
        return spec.stiffness is not None and spec.start - self.dt - EPS <= t < spec.start

    def wants_points(self, t: float) -> bool:
        """Some push acts at t, or a spring pusher's point is wanted for its velocity before it begins."""
        return any(active(s, t) or self._just_before(s, t) for s in self.specs)

    def forces(self, t: float, point_of: Callable[[int], np.ndarray]) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """(push index, force [N], point) of every push acting at t, for the coming physics step."""
        acting = []
        for i, spec in enumerate(self.specs):
            self.applied[i] = np.zeros(3)
            if not active(spec, t):
                if self._just_before(spec, t):
                    self.previous[i] = point_of(i)
                continue
            point = point_of(i)
            force = (
                np.asarray(spec.force, float)
                if spec.stiffness is None
                else self._spring_force(i, spec, spec.stiffness, t, point)
            )
            self.applied[i] = force
            acting.append((i, force, point))
        return acting

    def _spring_force(self, i: int, spec: PushSpec, stiffness: float, t: float, point: np.ndarray) -> np.ndarray:
        """Spring pusher: stiffness x (tip travel - the point's give along the push since it began, less the
        motion it had then), never negative."""
        origin = self.origin[i]
        if origin is None:
            before = self.previous[i]
            origin = self.origin[i] = (point, (point - (point if before is None else before)) / self.dt)
        p0, v0 = origin
        magnitude = float(np.linalg.norm(spec.force))
        direction = np.asarray(spec.force) / magnitude
        travel = magnitude / stiffness * min(1.0, (t - spec.start) / (spec.duration / 4))
        give = float(direction @ (point - p0 - v0 * (t - spec.start)))
        return direction * stiffness * max(0.0, travel - give)

    def magnitudes(self, t: float) -> dict[str, float]:
        """Per push, `push_<name>_N`: a set force's magnitude if it acts at t, else 0; a spring pusher's force in
        the last physics substep (it depends on the motion still to come)."""
        set_force = lambda s: float(np.linalg.norm(s.force)) if active(s, t) else 0.0
        return {
            f"push_{s.name}_N": set_force(s) if s.stiffness is None else float(np.linalg.norm(f))
            for s, f in zip(self.specs, self.applied)
        }


class Pushes:
    """The scenario's pushes resolved to PyBullet (body, link index) targets."""

    def __init__(
        self,
        client: BulletClient,
        specs: Sequence[PushSpec],
        robot_body: int,
        robot_base_link: int,
        world: World | None = None,
        physics_dt: float = 0.004,
    ):
        from harmony_cli.sim.bullet_import import pybullet  # a PyBullet run's: mujoco_pushes.py shares the law

        self.client, self.world_frame = client, pybullet.WORLD_FRAME
        self.law = PushForces(specs, physics_dt)
        links = {client.getJointInfo(robot_body, i)[12].decode(): i for i in range(client.getNumJoints(robot_body))}
        links[client.getBodyInfo(robot_body)[0].decode()] = -1
        robot = lambda link: (robot_body, robot_base_link if link is None else links[link])
        box = None if world is None or world.box is None else (world.box, -1)
        obstacles = {} if world is None else {name: (body, -1) for name, body in world.obstacles.items()}
        self.targets = [push_target(spec, robot, box, obstacles) for spec in self.law.specs]

    def _world_point(self, i: int) -> np.ndarray:
        """Push i's point in the world: the link's COM, or `point` in the link frame (base: the body frame)."""
        c, (body, link), point = self.client, self.targets[i], self.law.specs[i].point
        if link == -1:
            position, orientation = c.getBasePositionAndOrientation(body)
        else:
            state = c.getLinkState(body, link, computeForwardKinematics=True)
            if point is None:
                return np.array(state[0])
            position, orientation = state[4], state[5]
        if point is None:
            return np.array(position)
        rotation = np.reshape(c.getMatrixFromQuaternion(orientation), (3, 3))
        return np.array(position) + rotation @ np.asarray(point)

    def apply(self, t: float) -> None:
        """Call before each stepSimulation with the substep's start time."""
        for i, force, point in self.law.forces(t, self._world_point):
            body, link = self.targets[i]
            self.client.applyExternalForce(body, link, force.tolist(), point.tolist(), self.world_frame)

    def magnitudes(self, t: float) -> dict[str, float]:
        return self.law.magnitudes(t)
