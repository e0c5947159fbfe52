"""The measurement under the scenario's sensing imperfections (experiment/sensing.py): noise, bias and delay."""

import numpy as np
import pinocchio as pin
import pytest

from harmony_cli.experiment.sensing import Sensors
from harmony_cli.robot.observation import Observation
from harmony_cli.scenario.sensing import SensingSpec
from harmony_cli.tasks.obstacle_estimate import ObstacleTracks


class PinocchioRobotSim:
    """A simulator stand-in whose state is set by hand and whose hands Pinocchio computes (no physics)."""

    def __init__(self, robot):
        self.robot = robot
        self.model = pin.buildModelFromUrdf(str(robot.urdf))
        self.data = self.model.createData()
        self.index_q = [self.model.joints[self.model.getJointId(j)].idx_q for j in robot.joint_names]
        self.index_v = [self.model.joints[self.model.getJointId(j)].idx_v for j in robot.joint_names]
        self.q, self.qd = robot.home.copy(), np.zeros(robot.n_dof)
        self.observed = 0

    def hands(self, q, qd):
        """Positions (hands, 3), rotations (hands, 3, 3), linear velocities (hands, 3), yaw rates (hands,)."""
        q_pin, v_pin = np.zeros(self.model.nq), np.zeros(self.model.nv)
        q_pin[self.index_q], v_pin[self.index_v] = q, qd
        pin.forwardKinematics(self.model, self.data, q_pin, v_pin)
        pin.updateFramePlacements(self.model, self.data)
        out = [], [], [], []
        for link in self.robot.end_effectors:
            frame = self.model.getFrameId(link)
            velocity = pin.getFrameVelocity(self.model, self.data, frame, pin.LOCAL_WORLD_ALIGNED)
            for values, value in zip(
                out,
                (self.data.oMf[frame].translation, self.data.oMf[frame].rotation, velocity.linear, velocity.angular[2]),
            ):
                values.append(np.array(value))
        return tuple(np.array(v) for v in out)

    def observe(self):
        self.observed += 1
        p, r, v, wz = self.hands(self.q, self.qd)
        wrenches = np.tile([1.0, 2.0, -20.0, 0.1, 0.2, 0.3], (2, 1))
        return Observation(self.q.copy(), self.qd.copy(), p, r, v, float(wz.mean()), wrenches, np.zeros(3))


def _spec(**noise) -> SensingSpec:
    return SensingSpec.model_validate({"noise": noise})


def _sensors(sim, robot, spec, seed=0):
    return Sensors(sim, spec, robot, 0.02, seed, ObstacleTracks([], 0.0, 0.02))


def test_the_hands_seen_under_joint_noise_are_where_pinocchio_puts_them_at_the_noisy_joints(eva, rng):
    sim = PinocchioRobotSim(eva)
    sim.q = eva.home + rng.normal(0.0, 0.2, eva.n_dof) * (np.arange(eva.n_dof) >= 3)
    sim.qd = rng.normal(0.0, 0.3, eva.n_dof)
    noise = {"std": 0.05, "bias": 0.02}
    spec = _spec(joint_position=noise, joint_velocity=noise, base_position=noise, base_yaw=noise, base_velocity=noise)
    seen = _sensors(sim, eva, spec).observe(0.0)
    p, r, v, wz = sim.hands(seen.q, seen.qd)
    assert np.abs(seen.q - sim.q).max() > 0.01  # the joints are noisy
    np.testing.assert_allclose(seen.hand_positions, p, atol=1e-9)
    np.testing.assert_allclose(seen.hand_rotations, r, atol=1e-9)
    np.testing.assert_allclose(seen.hand_velocities, v, atol=1e-9)
    assert seen.heading_rate == pytest.approx(float(wz.mean()), abs=1e-9)


def test_each_channel_s_noise_has_its_written_spread_about_a_bias_fixed_for_the_run(eva):
    sim = PinocchioRobotSim(eva)
    spec = _spec(joint_position={"std": 0.01, "bias": 0.05}, wrist_force={"std": 2.0}, box_position={"std": 0.004})
    sensors = _sensors(sim, eva, spec, seed=3)
    seen = [sensors.observe(0.02 * k) for k in range(2000)]
    joints = np.array([s.q - sim.q for s in seen])[:, 3:]
    assert joints.std(axis=0) == pytest.approx(np.full(eva.n_dof - 3, 0.01), rel=0.1)
    bias = joints.mean(axis=0)
    assert np.abs(bias).max() > 0.01  # drawn once with a 0.05 rad spread: not zero, the same at every step
    np.testing.assert_allclose(bias, sensors.q_bias[3:], atol=0.01 * 4 / np.sqrt(2000))
    forces = np.array([s.wrenches[:, :3] for s in seen]) - sim.observe().wrenches[:, :3]
    assert forces.std() == pytest.approx(2.0, rel=0.05)
    torques = np.array([s.wrenches[:, 3:] for s in seen]) - sim.observe().wrenches[:, 3:]
    assert np.all(torques == 0.0)
    assert np.array([s.box_position for s in seen]).std() == pytest.approx(0.004, rel=0.05)
    np.testing.assert_array_equal(np.array([s.q[:3] for s in seen]), np.tile(sim.q[:3], (2000, 1)))


def test_the_same_seed_draws_the_same_noise_and_another_seed_other_noise(eva):
    spec = _spec(joint_position={"std": 0.01, "bias": 0.01})
    first, again, other = (_sensors(PinocchioRobotSim(eva), eva, spec, seed).observe(0.0) for seed in (1, 1, 2))
    np.testing.assert_array_equal(first.q, again.q)
    assert not np.array_equal(first.q, other.q)


def test_a_delay_of_k_control_steps_hands_over_the_measurement_of_k_steps_before(eva):
    sim = PinocchioRobotSim(eva)
    sensors = _sensors(sim, eva, SensingSpec(delay=0.06))
    seen = []
    for k in range(8):
        sim.q = eva.home + 0.01 * k
        seen.append(sensors.observe(0.02 * k).q)
    expected = [eva.home + 0.01 * max(0, k - 3) for k in range(8)]
    np.testing.assert_allclose(seen, expected, atol=1e-12)


def test_without_noise_or_delay_the_simulator_s_observation_passes_through_untouched(eva):
    sim = PinocchioRobotSim(eva)
    sensors = _sensors(sim, eva, SensingSpec())
    a = sensors.observe(0.0)
    b = sim.observe()
    for field in ("q", "qd", "hand_positions", "hand_rotations", "hand_velocities", "wrenches"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
