"""The wrist force/torque sensors' readings in MuJoCo, compensated for the tool's weight and inertia: the external
wrench the environment applies to each hand's tool (the bodies below its sensor), in the grasp frame, torque about
the grasp origin, as sim/wrench.py reads it in PyBullet.

The sensor (a MuJoCo force and torque sensor at the sensor joint's child body) reads the support the wrist gives the
tool; the environment's wrench is the tool's rate of change of momentum less its weight, less that support. The
momentum rate comes from MuJoCo's own accelerations of the tool's bodies (mj_objectAcceleration, gravity included)
and is summed over all hands' tool bodies at once (one array per quantity), so the reading costs a few array
operations per control step whatever the number of bodies."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np


class ToolWrenches:
    """The compensated wrench of each hand (`read`); `tool_bodies[h]`: the bodies below hand h's sensor site
    `wrist_sites[h]`, whose force and torque sensors start at rows `sensor_rows[h]` of sensordata."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        hand_sites: Sequence[int],
        wrist_sites: Sequence[int],
        sensor_rows: Sequence[tuple[int, int]],
        tool_bodies: Sequence[Sequence[int]],
    ):
        self.model, self.data = model, data
        self.hand_sites, self.wrist_sites = np.asarray(hand_sites), np.asarray(wrist_sites)
        self.bodies = np.concatenate([np.asarray(bodies, dtype=int) for bodies in tool_bodies])
        self.hand_of = np.repeat(np.arange(len(tool_bodies)), [len(bodies) for bodies in tool_bodies])
        self.sums = (self.hand_of[None, :] == np.arange(len(tool_bodies))[:, None]).astype(float)  # hands x bodies
        self.mass, self.inertia = model.body_mass[self.bodies][:, None], model.body_inertia[self.bodies]
        self.force_rows = np.array([row + np.arange(3) for row, _ in sensor_rows])
        self.torque_rows = np.array([row + np.arange(3) for _, row in sensor_rows])
        self._acceleration, self._velocity = np.zeros((len(self.bodies), 6)), np.zeros((len(self.bodies), 6))

    def read(self) -> np.ndarray:
        """(hands, 6): force [N] and torque about the grasp origin [N m] the environment applies to each tool."""
        data, origins = self.data, self.data.site_xpos[self.hand_sites]
        force, torque = self._momentum_rate(origins)
        wrists = data.site_xmat[self.wrist_sites].reshape(-1, 3, 3)
        support = np.einsum("hij,hj->hi", wrists, data.sensordata[self.force_rows])
        support_torque = np.einsum("hij,hj->hi", wrists, data.sensordata[self.torque_rows])
        support_torque += np.cross(data.site_xpos[self.wrist_sites] - origins, support)
        grasp = data.site_xmat[self.hand_sites].reshape(-1, 3, 3)
        return np.hstack(
            [np.einsum("hji,hj->hi", grasp, force - support), np.einsum("hji,hj->hi", grasp, torque - support_torque)]
        )

    def _momentum_rate(self, origins: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per hand, the rate of change of its tool's momentum less its weight: force and torque about its
        origin, in the world."""
        model, data, acceleration, velocity = self.model, self.data, self._acceleration, self._velocity
        for i, body in enumerate(self.bodies.tolist()):
            mujoco.mj_objectAcceleration(model, data, mujoco.mjtObj.mjOBJ_BODY, body, acceleration[i], 0)
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, velocity[i], 0)
        rotations = data.ximat[self.bodies].reshape(-1, 3, 3)
        inertia_times = lambda v: np.einsum(  # the world inertia R diag(I) R^T times v, per body
            "nij,nj->ni", rotations, self.inertia * np.einsum("nji,nj->ni", rotations, v)
        )
        spin = velocity[:, :3]
        linear = self.mass * acceleration[:, 3:]  # the acceleration has gravity's -g in it
        arm = data.xipos[self.bodies] - origins[self.hand_of]
        torque = inertia_times(acceleration[:, :3]) + np.cross(spin, inertia_times(spin)) + np.cross(arm, linear)
        return self.sums @ linear, self.sums @ torque
