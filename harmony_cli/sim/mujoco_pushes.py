"""Scripted pushes in MuJoCo, as sim/pushes.py has them in PyBullet: a set force, or a spring pusher whose force
depends on how far the pushed point gives way, on a robot body, the box or an obstacle, applied every physics step
while active. MuJoCo keeps data.xfrc_applied (a force and a torque about the body's centre of mass, in the world)
from step to step: `apply` writes the pushed bodies' rows every step, zero when no push acts."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.sim.pushes import EPS, active

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
        self.model, self.data, self.specs, self.dt = model, data, list(specs), physics_dt
        self.applied = [np.zeros(3) for _ in self.specs]  # the force of the last physics substep [N]
        # spring pushers: the point in the substep before the push, and (point, velocity) when the push began
        self.previous: list[np.ndarray | None] = [None] * len(self.specs)
        self.origin: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(self.specs)
        self.targets: list[int] = []
        for spec in self.specs:
            if spec.body == "robot":
                self.targets.append(robot_base if spec.link is None else robot_links[spec.link])
            elif world is not None and spec.body == "box" and world.box is not None:
                self.targets.append(world.box)
            elif world is not None and spec.body in world.obstacles:
                self.targets.append(world.obstacles[spec.body])
            else:
                raise ValueError(f"push {spec.name}: no body {spec.body!r} in the world")

    def _world_point(self, body: int, point) -> np.ndarray:
        """The push point in the world: the body's centre of mass, or `point` in the body's frame."""
        if point is None:
            return self.data.xipos[body].copy()
        return self.data.xpos[body] + self.data.xmat[body].reshape(3, 3) @ np.asarray(point, dtype=float)

    def _spring_force(self, i: int, spec: PushSpec, stiffness: float, t: float, point: np.ndarray) -> np.ndarray:
        """Spring pusher: stiffness x (tip travel - the point's give along the push since it began, less the
        motion it had then), never negative (sim/pushes.py)."""
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

    def _needs_points(self, t: float) -> bool:
        """Some push acts at t, or a spring pusher's point is wanted for its velocity before it begins."""
        return any(
            active(s, t) or (s.stiffness is not None and s.start - self.dt - EPS <= t < s.start) for s in self.specs
        )

    def apply(self, t: float) -> None:
        """Call before each mj_step with the step's start time: sets the pushed bodies' xfrc_applied."""
        if not self.specs:
            return
        for body in self.targets:
            self.data.xfrc_applied[body] = 0.0
        if not self._needs_points(t):
            self.applied = [np.zeros(3) for _ in self.specs]
            return
        mujoco.mj_kinematics(self.model, self.data)  # mj_step leaves the frames one step behind
        for i, (spec, body) in enumerate(zip(self.specs, self.targets)):
            self.applied[i] = np.zeros(3)
            if not active(spec, t):
                if spec.stiffness is not None and spec.start - self.dt - EPS <= t < spec.start:  # for its velocity
                    self.previous[i] = self._world_point(body, spec.point)
                continue
            point = self._world_point(body, spec.point)
            force = (
                np.asarray(spec.force, float)
                if spec.stiffness is None
                else self._spring_force(i, spec, spec.stiffness, t, point)
            )
            self.data.xfrc_applied[body, :3] += force
            self.data.xfrc_applied[body, 3:] += np.cross(point - self.data.xipos[body], force)
            self.applied[i] = force

    def magnitudes(self, t: float) -> dict[str, float]:
        """Per push, `push_<name>_N`: a set force's magnitude if it acts at t, else 0; a spring pusher's force in
        the last physics substep (it depends on the motion still to come)."""
        set_force = lambda s: float(np.linalg.norm(s.force)) if active(s, t) else 0.0
        return {
            f"push_{s.name}_N": set_force(s) if s.stiffness is None else float(np.linalg.norm(f))
            for s, f in zip(self.specs, self.applied)
        }
