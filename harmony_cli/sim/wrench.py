"""Wrist force/torque sensing: PyBullet's reaction at each hand's sensor joint, less the tool's own gravity and
inertia, as the external wrench the environment applies to the tool, in the grasp frame.

PyBullet reports (measured, see tests/test_wrench.py) the wrench the parent link exerts on the sensor joint's
child, expressed in the child's inertial (COM) frame, torque about the child's COM. Newton-Euler on the links
below the sensor (the tool): support + gravity + external = rate of change of their momentum.

Every hand's tool links are handled at once, in stacked arrays: numpy's stacked matmul makes the same BLAS call
per matrix as a single one, and elementwise operations round per element, so the readings are bit for bit those
of a loop over hands and links (a reading feeds the admittance loop: a last-bit change changes the whole run).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from harmony_cli.sim.bullet_import import pybullet


class WristSensors:
    """Enables a joint force/torque sensor per hand; `read()` gives the compensated external wrenches
    (`inertia=False`: gravity compensation only, which leaves the tool's m a in the reading)."""

    def __init__(self, client, body: int, sensor_joints: list[int], grasp_links: list[int], inertia: bool = True):
        self.body, self.inertia = body, inertia
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
        # what one getLinkStates call fetches: every tool link, hand after hand, then the grasp links
        self.tool_links = [link for tool in self.tools for link in tool]
        self.links = self.tool_links + self.grasp_links
        ends = np.cumsum([len(tool) for tool in self.tools])
        self._rows = [slice(end - len(tool), end) for tool, end in zip(self.tools, ends)]  # a hand's tool links
        self._sensor_rows = ends - [len(tool) for tool in self.tools]  # the sensor joint's child comes first
        self._hand_of_row = np.repeat(np.arange(len(self.tools)), [len(tool) for tool in self.tools])
        masses = np.concatenate(self.masses)
        self._mass_column, self._weight = masses[:, None], masses[:, None] * -self.gravity  # constant
        self._inertia_diagonals = np.array([np.diag(i) for i in np.concatenate(self.inertias)])
        # tool links' (COM velocities, angular velocities) before the last physics step, (links, 3) each
        self.previous: tuple[np.ndarray, np.ndarray] | None = None
        # bound once: a BulletClient attribute is a new functools.partial on every access
        self._link_states, self._joint_states = client.getLinkStates, client.getJointStates
        for joint in self.sensors:
            client.enableJointForceTorqueSensor(body, joint, True)

    def link_states(self, links: list[int]) -> list:
        """PyBullet's states of `links`, with velocities, from forward kinematics of the current joint state."""
        return self._link_states(self.body, links, computeLinkVelocity=True, computeForwardKinematics=True)

    def before_physics_step(self) -> None:
        """Call before the stepSimulation that precedes a `read` (at least): the tool's accelerations over that
        step come from these velocities."""
        states = self.link_states(self.tool_links)
        self.previous = (np.array([s[6] for s in states]), np.array([s[7] for s in states]))

    def read(self) -> np.ndarray:
        """(hands, 6): external force [N] and torque about the grasp-frame origin [N m], both in the grasp frame;
        zeros before the first physics step (PyBullet computes reactions in the step)."""
        reactions = np.array([s[2] for s in self._joint_states(self.body, self.sensors)])
        states = self.link_states(self.links)
        return self.wrenches(reactions, states, rotation_matrices([s[5] for s in states[len(self.tool_links) :]]))

    def wrenches(self, reactions: np.ndarray, states: Sequence, grasp_rotations: np.ndarray) -> np.ndarray:
        """`read()` from what the caller fetched: the sensor joints' reactions (hands, 6), `link_states(links)`
        and the grasp frames' rotations (hands, 3, 3)."""
        if self.previous is None:
            return np.zeros((len(self.sensors), 6))
        hands, links = len(self.sensors), len(self.tool_links)
        origins = np.array([s[4] for s in states[links:]])
        coms, v1, w1 = np.array([(s[0], s[6], s[7]) for s in states[:links]]).transpose(1, 0, 2)
        rotations = rotation_matrices([s[1] for s in states[:links]])  # the tool links' COM frames
        lever_arms = coms - origins[self._hand_of_row]  # from the hand's grasp origin to each tool link's COM
        # the reaction's force and moment, from the sensor's child's COM frame to the world
        support, support_moment = _apply(rotations[self._sensor_rows], reactions.reshape(-1, 2, 3).swapaxes(0, 1))
        # momentum rate minus gravity, per tool link: what support and environment together apply
        (v0, w0), net = self.previous, self._weight
        if self.inertia:
            net = net + self._mass_column * (v1 - v0) / self.dt
        inertia = rotations @ self._inertia_diagonals @ rotations.transpose(0, 2, 1)
        spin_up, momentum = _apply(inertia, np.array((w1 - w0, w1)))
        # every cross product in one go: the support's moment about the grasp origin, the links' moments, their
        # gyroscopic torques w x I w (unused, like spin_up, without inertia compensation)
        crossed = _cross(
            np.concatenate((lever_arms[self._sensor_rows], lever_arms, w1)), np.concatenate((support, net, momentum))
        )
        support_torque = support_moment + crossed[:hands]
        net_torque = np.zeros((hands, 3))
        if self.inertia:
            link_torque = spin_up / self.dt + crossed[hands + links :]
            for h, rows in enumerate(self._rows):  # a running sum from zero, link by link
                for row in range(rows.start, rows.stop):
                    net_torque[h] += link_torque[row]
        # per hand, (links, 6).sum(axis=0): numpy sums an outer axis row by row, as it did the hand's own arrays
        forces_moments = np.concatenate((net, crossed[hands : hands + links]), axis=1)
        sums = np.array([forces_moments[rows].sum(axis=0) for rows in self._rows])
        force, torque = sums[:, :3] - support, net_torque + sums[:, 3:] - support_torque
        return np.concatenate(_apply(grasp_rotations.transpose(0, 2, 1), np.array((force, torque))), axis=1)


def rotation_matrices(quaternions: Sequence) -> np.ndarray:
    """(n, 3, 3) from PyBullet quaternions (x, y, z, w) through PyBullet's own conversion, the module function (no
    physics server): the same formula in numpy (maths/rotations.py's quaternion_matrices) is bit-identical but 5x slower
    for a handful."""
    return np.array([pybullet.getMatrixFromQuaternion(q) for q in quaternions]).reshape(-1, 3, 3)


def _below(link: int, joint: int, parent: dict[int, int]) -> bool:
    """`link` is the sensor joint's child (same index) or one of its descendants."""
    while link != -1:
        if link == joint:
            return True
        link = parent[link]
    return False


def _apply(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """matrices @ vectors, (..., 3, 3) by (..., 3), broadcast: the same BLAS gemv per vector as a 3x3 matrix
    times a 1-D vector."""
    return (matrices @ vectors[..., None])[..., 0]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of 3-vectors (or rows of them, a and b of one shape), the same products and differences in the
    same order (to the bit), without its ~50 us of axis handling per call."""
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out
