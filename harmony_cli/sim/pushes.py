"""Scripted pushes: external forces on the robot, the box or an obstacle, applied in PyBullet every physics
substep while active (PyBullet clears external forces after each stepSimulation). A push is a set force, or a
spring pusher (`stiffness`) whose force depends on how far the pushed point gives way."""

from __future__ import annotations

import numpy as np
import pybullet

EPS = 1e-9  # [s] substep times are multiples of physics_dt: keep t = start + duration outside the window


def active(push, t: float) -> bool:
    """The push acts at time t: start <= t < start + duration."""
    return push.start - EPS <= t < push.start + push.duration - EPS


class Pushes:
    """The scenario's pushes resolved to PyBullet (body, link index) targets."""

    def __init__(self, client, specs, robot_body: int, robot_base_link: int, world=None, physics_dt: float = 0.004):
        self.client, self.specs, self.dt = client, list(specs), physics_dt
        self.applied = [np.zeros(3) for _ in self.specs]  # the force of the last physics substep [N]
        self.previous = [None] * len(self.specs)  # spring pushers: the point in the substep before the push
        self.origin = [None] * len(self.specs)  # spring pushers: (point, velocity) when the push began
        links = {client.getJointInfo(robot_body, i)[12].decode(): i for i in range(client.getNumJoints(robot_body))}
        links[client.getBodyInfo(robot_body)[0].decode()] = -1
        self.targets = []
        for spec in self.specs:
            if spec.body == "robot":
                self.targets.append((robot_body, robot_base_link if spec.link is None else links[spec.link]))
            elif spec.body == "box":
                self.targets.append((world.box, -1))
            else:
                self.targets.append((world.obstacles[spec.body], -1))

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

    def _spring_force(self, i: int, spec, t: float, point: np.ndarray) -> np.ndarray:
        """Spring pusher: stiffness x (tip travel - the point's give along the push since it began, less the
        motion it had then), never negative."""
        if self.origin[i] is None:
            before = point if self.previous[i] is None else self.previous[i]
            self.origin[i] = (point, (point - before) / self.dt)
        p0, v0 = self.origin[i]
        magnitude = float(np.linalg.norm(spec.force))
        direction = np.asarray(spec.force) / magnitude
        travel = magnitude / spec.stiffness * min(1.0, (t - spec.start) / (spec.duration / 4))
        give = float(direction @ (point - p0 - v0 * (t - spec.start)))
        return direction * spec.stiffness * max(0.0, travel - give)

    def apply(self, t: float) -> None:
        """Call before each stepSimulation with the substep's start time."""
        for i, (spec, (body, link)) in enumerate(zip(self.specs, self.targets)):
            self.applied[i] = np.zeros(3)
            if not active(spec, t):
                if spec.stiffness is not None and spec.start - self.dt - EPS <= t < spec.start:  # for its velocity
                    self.previous[i] = self._world_point(body, link, spec.point)
                continue
            point = self._world_point(body, link, spec.point)
            force = np.asarray(spec.force, float) if spec.stiffness is None else self._spring_force(i, spec, t, point)
            self.client.applyExternalForce(body, link, force.tolist(), point.tolist(), pybullet.WORLD_FRAME)
            self.applied[i] = force

    def magnitudes(self, t: float) -> dict[str, float]:
        """Per push, `push_<name>_N`: a set force's magnitude if it acts at t, else 0; a spring pusher's force in
        the last physics substep (it depends on the motion still to come)."""
        set_force = lambda s: float(np.linalg.norm(s.force)) if active(s, t) else 0.0
        return {
            f"push_{s.name}_N": set_force(s) if s.stiffness is None else float(np.linalg.norm(f))
            for s, f in zip(self.specs, self.applied)
        }
