"""Scripted pushes: external forces on the robot, the box or an obstacle, applied in PyBullet every physics
substep while active (PyBullet clears external forces after each stepSimulation). A push is a set force, or a
spring pusher (`stiffness`) whose force depends on how far the pushed point gives way. The push windows (`active`)
are MuJoCo's too: PyBullet is imported only by the Pushes of a PyBullet run."""

from __future__ import annotations

from typing import TYPE_CHECKING

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
        import pybullet  # a PyBullet run's: mujoco_pushes.py shares `active` on Pythons without PyBullet

        self.client, self.specs, self.dt, self.world_frame = client, list(specs), physics_dt, pybullet.WORLD_FRAME
        self.applied = [np.zeros(3) for _ in self.specs]  # the force of the last physics substep [N]
        # spring pushers: the point in the substep before the push, and (point, velocity) when the push began
        self.previous: list[np.ndarray | None] = [None] * len(self.specs)
        self.origin: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(self.specs)
        links = {client.getJointInfo(robot_body, i)[12].decode(): i for i in range(client.getNumJoints(robot_body))}
        links[client.getBodyInfo(robot_body)[0].decode()] = -1
        self.targets: list[tuple[int, int]] = []
        for spec in self.specs:
            if spec.body == "robot":
                self.targets.append((robot_body, robot_base_link if spec.link is None else links[spec.link]))
            elif world is not None and spec.body == "box" and world.box is not None:
                self.targets.append((world.box, -1))
            elif world is not None and spec.body in world.obstacles:
                self.targets.append((world.obstacles[spec.body], -1))
            else:
                raise ValueError(f"push {spec.name}: no body {spec.body!r} in the world")

    def _world_point(self, body: int, link: int, point) -> np.ndarray:
        """The push point in the world: the link's COM, or `point` in the link frame (base: the body frame)."""
        c = self.client
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

    def apply(self, t: float) -> None:
        """Call before each stepSimulation with the substep's start time."""
        for i, (spec, (body, link)) in enumerate(zip(self.specs, self.targets)):
            self.applied[i] = np.zeros(3)
            if not active(spec, t):
                if spec.stiffness is not None and spec.start - self.dt - EPS <= t < spec.start:  # for its velocity
                    self.previous[i] = self._world_point(body, link, spec.point)
                continue
            point = self._world_point(body, link, spec.point)
            force = (
                np.asarray(spec.force, float)
                if spec.stiffness is None
                else self._spring_force(i, spec, spec.stiffness, t, point)
            )
            self.client.applyExternalForce(body, link, force.tolist(), point.tolist(), self.world_frame)
            self.applied[i] = force

    def magnitudes(self, t: float) -> dict[str, float]:
        """Per push, `push_<name>_N`: a set force's magnitude if it acts at t, else 0; a spring pusher's force in
        the last physics substep (it depends on the motion still to come)."""
        set_force = lambda s: float(np.linalg.norm(s.force)) if active(s, t) else 0.0
        return {
            f"push_{s.name}_N": set_force(s) if s.stiffness is None else float(np.linalg.norm(f))
            for s, f in zip(self.specs, self.applied)
        }
