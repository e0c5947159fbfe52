"""The EVA URDF: home pose from formulation.md, and OpTaS == Pinocchio == PyBullet forward kinematics."""

import numpy as np
import pinocchio as pin
from conftest import needs_pybullet

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass


def test_home_configuration_puts_grasp_frames_where_the_reference_says(eva):
    poses = dict(zip(eva.end_effectors, eva.hand_poses_numeric(eva.home)))
    np.testing.assert_allclose(poses["LARM_grasp"][0].ravel(), [0.7628, 0.15, 0.9327], atol=1e-3)
    np.testing.assert_allclose(poses["RARM_grasp"][0].ravel(), [0.7628, -0.15, 0.9327], atol=1e-3)
    # pads face each other: the grasp z axis is the contact normal
    np.testing.assert_allclose(poses["LARM_grasp"][1][:, 2], [0, -1, 0], atol=1e-9)
    np.testing.assert_allclose(poses["RARM_grasp"][1][:, 2], [0, 1, 0], atol=1e-9)


def test_robot_has_the_eighteen_joints_in_the_optimiser_order(eva):
    assert eva.n_dof == 18
    assert eva.joint_names[:6] == ("base_x", "base_y", "base_yaw", "CHEST_JOINT0", "HEAD_JOINT0", "HEAD_JOINT1")
    assert eva.joint_names[6:12] == tuple(f"LARM_JOINT{i}" for i in range(6))
    assert eva.joint_names[12:] == tuple(f"RARM_JOINT{i}" for i in range(6))


def _random_configurations(robot, rng, n=50):
    lo = np.where(robot.lower < -10, -3.0, robot.lower)
    hi = np.where(robot.upper > 10, 3.0, robot.upper)
    return rng.uniform(lo, hi, size=(n, robot.n_dof))


@needs_pybullet
def test_optas_pinocchio_and_pybullet_agree_on_grasp_frames_at_50_random_configurations(eva, rng):
    model = pin.buildModelFromUrdf(str(eva.urdf))
    data = model.createData()
    pin_index = [model.joints[model.getJointId(j)].idx_q for j in eva.joint_names]
    client = BulletClient(connection_mode=pybullet.DIRECT)
    body = client.loadURDF(str(eva.urdf), useFixedBase=True)
    names = {client.getJointInfo(body, i)[1].decode(): i for i in range(client.getNumJoints(body))}
    links = {client.getJointInfo(body, i)[12].decode(): i for i in range(client.getNumJoints(body))}
    for q in _random_configurations(eva, rng):
        q_pin = np.zeros(model.nq)
        q_pin[pin_index] = q
        pin.framesForwardKinematics(model, data, q_pin)
        for j, name in enumerate(eva.joint_names):
            client.resetJointState(body, names[name], q[j])
        for h, link in enumerate(eva.end_effectors):
            p_optas, r_optas = eva.hand_poses_numeric(q)[h]
            frame = data.oMf[model.getFrameId(link)]
            state = client.getLinkState(body, links[link], computeForwardKinematics=True)
            r_bullet = np.reshape(client.getMatrixFromQuaternion(state[5]), (3, 3))
            np.testing.assert_allclose(p_optas.ravel(), frame.translation, atol=1e-6)
            np.testing.assert_allclose(r_optas, frame.rotation, atol=1e-6)
            np.testing.assert_allclose(p_optas.ravel(), state[4], atol=1e-6)
            np.testing.assert_allclose(r_optas, r_bullet, atol=1e-6)
    client.disconnect()
