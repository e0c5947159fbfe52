"""Scripted pushes: external forces on the robot, the box or an obstacle, applied in PyBullet every physics
substep while active (PyBullet clears external forces after each stepSimulation)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pybullet

EPS = 1e-9  # [s] substep times are multiples of physics_dt: keep t = start + duration outside the window


def active(push, t: float) -> bool:
    """The push acts at time t: start <= t < start + duration."""
    return push.start - EPS <= t < push.start + push.duration - EPS


def pushed_hand(push, urdf: Path, end_effectors: dict[str, str]) -> str | None:
    """The hand a robot push acts on: the one whose end-effector link is the pushed link or below it (None for
    the box, obstacles, the base or a link above both hands, e.g. the chest)."""
    if push.body != "robot" or push.link is None:
        return None
    parent = {j.find("child").get("link"): j.find("parent").get("link") for j in ET.parse(urdf).getroot().findall("joint")}

    def below(link: str) -> bool:
        while link is not None:
            if link == push.link:
                return True
            link = parent.get(link)
        return False

    hands = [hand for hand, link in end_effectors.items() if below(link)]
    return hands[0] if len(hands) == 1 else None


class Pushes:
    """The scenario's pushes resolved to PyBullet (body, link index) targets."""

    def __init__(self, client, specs, robot_body: int, robot_base_link: int, world=None):
        self.client, self.specs = client, list(specs)
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

    def apply(self, t: float) -> None:
        """Call before each stepSimulation with the substep's start time."""
        for spec, (body, link) in zip(self.specs, self.targets):
            if active(spec, t):
                self.client.applyExternalForce(body, link, list(spec.force),
                                               self._world_point(body, link, spec.point).tolist(),
                                               pybullet.WORLD_FRAME)

    def magnitudes(self, t: float) -> dict[str, float]:
        """Per push, `push_<name>_N`: the force's magnitude if it acts at t, else 0."""
        return {f"push_{s.name}_N": float(np.linalg.norm(s.force)) if active(s, t) else 0.0 for s in self.specs}

