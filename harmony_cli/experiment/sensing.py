"""The measurement the controllers get: the simulator's state with the scenario's sensing noise and delay
(scenario/sensing.py), and the measured centres of the obstacles the controllers estimate (tasks/obstacle_estimate.py).

Noise is drawn from the run's seed: the same scenario gives the same noise. The hands' frames, velocities and turn
rate the controllers see follow the noisy joints and base as a robot's forward kinematics would: the engine's value
plus what the noise changes in the model's kinematics (so zero noise gives the engine's values exactly). With every
channel at 0 and no delay the simulator's observation passes through untouched."""

from __future__ import annotations

from collections import deque
from dataclasses import replace

import casadi as cs
import numpy as np

from harmony_cli.robot.model import Robot
from harmony_cli.robot.observation import Observation
from harmony_cli.scenario.sensing import Channel, SensingSpec
from harmony_cli.sim.engine import Simulator
from harmony_cli.tasks.obstacle_estimate import ObstacleTracks

STREAM = 46  # the seed's stream for sensing noise, apart from every other use of the run's seed


class Sensors:
    """Observes `sim` every control step of `control_dt` [s] as `spec` says, feeding `tracks` (if any)."""

    def __init__(
        self, sim: Simulator, spec: SensingSpec, robot: Robot, control_dt: float, seed: int, tracks: ObstacleTracks
    ):
        self.sim, self.robot, self.noise, self.tracks = sim, robot, spec.noise, tracks
        self.rng = np.random.default_rng([seed, STREAM])
        base = list(robot.base_joints)
        joints = np.setdiff1d(np.arange(robot.n_dof), base)
        n, noise = robot.n_dof, spec.noise
        # per joint, the standard deviation and bias of its position and velocity (base x, y, yaw their own)
        self.q_std = _per_joint(n, joints, base, noise.joint_position, noise.base_position, noise.base_yaw, "std")
        self.qd_std = _per_joint(n, joints, base, noise.joint_velocity, noise.base_velocity, noise.base_yaw_rate, "std")
        q_bias = _per_joint(n, joints, base, noise.joint_position, noise.base_position, noise.base_yaw, "bias")
        qd_bias = _per_joint(n, joints, base, noise.joint_velocity, noise.base_velocity, noise.base_yaw_rate, "bias")
        self.q_bias, self.qd_bias = self.rng.normal(0.0, q_bias), self.rng.normal(0.0, qd_bias)
        hands = len(robot.end_effectors)
        wrench_bias = [noise.wrist_force.bias] * 3 + [noise.wrist_torque.bias] * 3
        self.wrench_bias = self.rng.normal(0.0, wrench_bias, (hands, 6))
        self.box_bias = self.rng.normal(0.0, noise.box_position.bias, 3)
        self.obstacle_bias = self.rng.normal(0.0, noise.obstacle_position.bias, (len(tracks.estimated), 3))
        moved = self.q_std.any() or self.qd_std.any() or self.q_bias.any() or self.qd_bias.any()
        self.kinematics = _hand_kinematics(robot) if moved else None
        self.queue: deque[Observation] = deque(maxlen=round(spec.delay / control_dt) + 1)
        self.delay = spec.delay
        self.passes = spec.noise.off and self.queue.maxlen == 1 and not tracks

    def observe(self, t: float) -> Observation:
        """What the controllers see at `t`: the measurement of `delay` ago (the first one until then)."""
        if self.passes:
            return self.sim.observe()
        measured = self._noisy(self.sim.observe())
        self.queue.append(measured)
        if self.tracks:  # the obstacles as measured `delay` ago, like everything else
            centres = self.tracks.true_centres(t - self.delay) + self.obstacle_bias
            centres = centres + self.rng.normal(0.0, self.noise.obstacle_position.std, centres.shape)
            self.tracks.update(t - self.delay, centres)
        return self.queue[0]

    def _noisy(self, obs: Observation) -> Observation:
        if self.noise.off:
            return obs
        q = self.robot.coupled(obs.q + self.q_bias + self.rng.normal(0.0, self.q_std))
        qd = obs.qd + self.qd_bias + self.rng.normal(0.0, self.qd_std)
        wrenches = obs.wrenches + self.wrench_bias + self.rng.normal(0.0, self._wrench_std(), obs.wrenches.shape)
        box = obs.box_position
        if box is not None:
            box = box + self.box_bias + self.rng.normal(0.0, self.noise.box_position.std, 3)
        noisy = replace(obs, q=np.asarray(q, dtype=float), qd=qd, wrenches=wrenches, box_position=box)
        if self.kinematics is None:
            return noisy
        (p0, r0, v0, w0), (p1, r1, v1, w1) = (
            [np.asarray(x) for x in self.kinematics(q_, qd_)] for q_, qd_ in ((obs.q, obs.qd), (noisy.q, qd))
        )
        turn = np.einsum("hij,hkj->hik", _rotations(r1), _rotations(r0))  # per hand, R_seen R_true^T
        return replace(
            noisy,
            hand_positions=obs.hand_positions + (p1 - p0).T,
            hand_rotations=np.einsum("hij,hjk->hik", turn, obs.hand_rotations),
            hand_velocities=obs.hand_velocities + (v1 - v0).T,
            heading_rate=obs.heading_rate + float(np.mean(w1 - w0)),
        )

    def _wrench_std(self) -> np.ndarray:
        return np.array([self.noise.wrist_force.std] * 3 + [self.noise.wrist_torque.std] * 3)

    def log(self, t: float) -> dict[str, float]:
        """For the steps log: the estimated obstacles' errors (nothing without)."""
        return self.tracks.errors(t) if self.tracks else {}


def _per_joint(n: int, joints, base, joint: Channel, planar: Channel, yaw: Channel, field: str) -> np.ndarray:
    """(n,) a channel's `field` per joint: `joint` for the joints, `planar` for base x and y, `yaw` for its yaw."""
    out = np.zeros(n)
    out[joints] = getattr(joint, field)
    out[base[:2]] = getattr(planar, field)
    out[base[2]] = getattr(yaw, field)
    return out


def _rotations(stacked) -> np.ndarray:
    """(hands, 3, 3) from the kinematics' (3, 3 hands) column blocks."""
    r = np.asarray(stacked)
    return np.stack([r[:, 3 * h : 3 * h + 3] for h in range(r.shape[1] // 3)])


def _hand_kinematics(robot: Robot) -> cs.Function:
    """(q, qd) -> the hands' positions (3, hands), rotations (3, 3 hands), linear velocities (3, hands) and yaw
    rates (1, hands), from the model's forward kinematics."""
    q, qd = cs.SX.sym("q", robot.n_dof), cs.SX.sym("qd", robot.n_dof)
    positions, rotations, velocities, yaw_rates = [], [], [], []
    for hand in range(len(robot.end_effectors)):
        p, r = robot.hand_pose(hand, q)
        positions.append(p)
        rotations.append(r)
        velocities.append(cs.jtimes(p, q, qd))
        r_dot = cs.reshape(cs.jtimes(cs.reshape(r, 9, 1), q, qd), 3, 3)
        yaw_rates.append((r_dot @ r.T)[1, 0])
    outputs = [cs.horzcat(*positions), cs.horzcat(*rotations), cs.horzcat(*velocities), cs.horzcat(*yaw_rates)]
    return cs.Function("sensed_hands", [q, qd], outputs)
