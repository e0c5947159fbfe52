"""Scripted pushes in MuJoCo, as sim/pushes.py has them in PyBullet: a set force, or a spring pusher whose force
depends on how far the pushed point gives way, on a robot body, the box or an obstacle, applied every physics step
while active. MuJoCo keeps data.xfrc_applied (a force and a torque about the body's centre of mass, in the world)
from step to step: `apply` writes the pushed bodies' rows every step, zero when no push acts."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.sim.pushes import PushForces, push_target

if TYPE_CHECKING:
    from collections.abc import Sequence

    from harmony_cli.scenario.world import PushSpec
    from harmony_cli.sim.mujoco_world import MujocoWorld


class MujocoPushes:
    """The scenario's pushes resolved to MuJoCo bodies: a robot link by `robot_links` (link name -> body id; the
    default `robot_base` body), the box, an obstacle (a static or mocap body: nothing moves it, as in PyBullet)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        specs: Sequence[PushSpec],
        robot_base: int,
        robot_links: dict[str, int],
        world: MujocoWorld | None = None,
        physics_dt: float = 0.004,
    ):
        self.model, self.data = model, data
        self.law = PushForces(specs, physics_dt)
        robot = lambda link: robot_base if link is None else robot_links[link]
        box = None if world is None else world.box
        obstacles = {} if world is None else world.obstacles
        self.targets = [push_target(spec, robot, box, obstacles) for spec in self.law.specs]

    def _world_point(self, i: int) -> np.ndarray:
        """Push i's point in the world: the body's centre of mass, or `point` in the body's frame."""
        body, point = self.targets[i], self.law.specs[i].point
        if point is None:
            return self.data.xipos[body].copy()
        return self.data.xpos[body] + self.data.xmat[body].reshape(3, 3) @ np.asarray(point, dtype=float)

    def apply(self, t: float) -> None:
        """Call before each mj_step with the step's start time: sets the pushed bodies' xfrc_applied."""
        if not self.targets:
            return
        for body in self.targets:
            self.data.xfrc_applied[body] = 0.0
        if not self.law.wants_points(t):
            self.law.applied = [np.zeros(3) for _ in self.targets]
            return
        mujoco.mj_kinematics(self.model, self.data)  # mj_step leaves the frames one step behind
        for i, force, point in self.law.forces(t, self._world_point):
            body = self.targets[i]
            self.data.xfrc_applied[body, :3] += force
            self.data.xfrc_applied[body, 3:] += np.cross(point - self.data.xipos[body], force)

    def magnitudes(self, t: float) -> dict[str, float]:
        return self.law.magnitudes(t)
