"""Wrist force/torque sensing: PyBullet's reaction at each hand's sensor joint, less the tool's own gravity and
inertia, as the external wrench the environment applies to the tool, in the grasp frame.

PyBullet reports (measured, see tests/test_wrench.py) the wrench the parent link exerts on the sensor joint's
child, expressed in the child's inertial (COM) frame, torque about the child's COM. Newton-Euler on the links
below the sensor (the tool): support + gravity + external = rate of change of their momentum.
"""

from __future__ import annotations

import numpy as np


class WristSensors:
    """Enables a joint force/torque sensor per hand; `read()` gives the compensated external wrenches
    (`inertia=False`: gravity compensation only, which leaves the tool's m a in the reading)."""

    def __init__(self, client, body: int, sensor_joints: list[int], grasp_links: list[int], inertia: bool = True):
        self.client, self.body, self.inertia = client, body, inertia
        self.sensors, self.grasp_links = list(sensor_joints), list(grasp_links)
        parent = {i: client.getJointInfo(body, i)[16] for i in range(client.getNumJoints(body))}
        # the links below each sensor, the joint's own child first (PyBullet numbers parents before children)
        self.tools = [[i for i in parent if _below(i, joint, parent)] for joint in self.sensors]
        dynamics = [[client.getDynamicsInfo(body, i) for i in links] for links in self.tools]
        self.masses = [np.array([d[0] for d in tool]) for tool in dynamics]
        self.inertias = [np.array([d[2] for d in tool]) for tool in dynamics]  # principal, in the COM frames
        params = client.getPhysicsEngineParameters()
        self.gravity = np.array([params[f"gravityAcceleration{a}"] for a in "XYZ"])
        self.dt = params["fixedTimeStep"]
        # tool links' (COM velocity, angular velocity) before the last physics step
        self.previous: list[list[tuple[np.ndarray, np.ndarray]]] | None = None
        for joint in self.sensors:
            client.enableJointForceTorqueSensor(body, joint, True)

    def _states(self, tool: list[int]) -> list:
        return self.client.getLinkStates(self.body, tool, computeLinkVelocity=True, computeForwardKinematics=True)

    def before_physics_step(self) -> None:
        """Call before the stepSimulation that precedes a `read` (at least): the tool's accelerations over that
        step come from these velocities."""
        self.previous = [[(np.array(s[6]), np.array(s[7])) for s in self._states(tool)] for tool in self.tools]

    def read(self) -> np.ndarray:
        """(hands, 6): external force [N] and torque about the grasp-frame origin [N m], both in the grasp frame;
        zeros before the first physics step (PyBullet computes reactions in the step)."""
        if self.previous is None:
            return np.zeros((len(self.sensors), 6))
        c, wrenches = self.client, []
        for h, joint in enumerate(self.sensors):
            reaction = np.array(c.getJointState(self.body, joint)[2])
            frame = c.getLinkState(self.body, self.grasp_links[h], computeForwardKinematics=True)
            origin, rotation = np.array(frame[4]), _matrix(c, frame[5])
            states = self._states(self.tools[h])
            sensor_com, sensor_rotation = np.array(states[0][0]), _matrix(c, states[0][1])
            support = sensor_rotation @ reaction[:3]
            support_torque = sensor_rotation @ reaction[3:] + _cross(sensor_com - origin, support)
            # momentum rate minus gravity, per tool link: what support and environment together apply
            masses, coms = self.masses[h], np.array([s[0] for s in states])
            net = masses[:, None] * -self.gravity
            net_torque = np.zeros(3)
            if self.inertia:
                for i, s in enumerate(states):
                    (v0, w0), v1, w1 = self.previous[h][i], np.array(s[6]), np.array(s[7])
                    net[i] += masses[i] * (v1 - v0) / self.dt
                    r = _matrix(c, s[1])
                    inertia = r @ np.diag(self.inertias[h][i]) @ r.T
                    net_torque += inertia @ (w1 - w0) / self.dt + _cross(w1, inertia @ w1)
            force = net.sum(axis=0) - support
            torque = net_torque + _cross(coms - origin, net).sum(axis=0) - support_torque
            wrenches.append(np.concatenate([rotation.T @ force, rotation.T @ torque]))
        return np.array(wrenches)


def _below(link: int, joint: int, parent: dict[int, int]) -> bool:
    """`link` is the sensor joint's child (same index) or one of its descendants."""
    while link != -1:
        if link == joint:
            return True
        link = parent[link]
    return False


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of 3-vectors (or rows of them), the same products and differences in the same order (to the bit),
    without its ~50 us of axis handling per call."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _matrix(client, quaternion) -> np.ndarray:
    return np.reshape(client.getMatrixFromQuaternion(quaternion), (3, 3))
