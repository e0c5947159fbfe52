"""Wrist force/torque sensing in real PyBullet: no load reads zero (still or moving), a hung load reads its
weight, a squeeze reads what the pad's contacts carry, and a wrong sensor joint in YAML is a one-line error."""

import numpy as np
import pytest
from conftest import ROOT, TABLE1, assert_rejected, needs_pybullet, swinging

from harmony_cli.robot.urdf import wrist_sensor_joints
from harmony_cli.scenario import load_scenario

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.bullet import BulletSimulation
    from harmony_cli.sim.wrench import WristSensors
except ImportError:
    pass

SIM = load_scenario(TABLE1).sim
SUBSTEPS = SIM.substeps
# a second arm posture: shoulder raised, elbow rolled, wrist turned (pads no longer horizontal-facing)
RAISED_DEG = {
    "LARM_JOINT1": -40,
    "LARM_JOINT3": 60,
    "LARM_JOINT5": 30,
    "RARM_JOINT1": -30,
    "RARM_JOINT3": -70,
    "RARM_JOINT5": -50,
}


def _posture(robot, name):
    q = robot.home.copy()
    for joint, degrees in (RAISED_DEG if name == "raised" else {}).items():
        q[robot.index(joint)] += np.deg2rad(degrees)
    return q


def _hold(sim, q, steps):
    for _ in range(steps):
        sim.apply(q, np.zeros(len(q)))
        sim.step(SUBSTEPS)
    return sim.observe()


@pytest.fixture
def sim(eva):
    simulation = BulletSimulation(eva, SIM)
    yield simulation
    simulation.close()


@needs_pybullet
@pytest.mark.parametrize("posture", ["home", "raised"])
def test_no_load_reads_zero_once_the_tool_is_compensated(sim, eva, posture):
    assert np.all(sim.observe().wrenches == 0)  # before the first step PyBullet has no reaction yet
    obs = _hold(sim, _posture(eva, posture), 50)
    tool_weight = sim.wrists.masses[0].sum() * 9.81  # what the sensor carries before compensation
    assert tool_weight > 3.0
    assert np.abs(obs.wrenches[:, :3]).max() < 0.01 * tool_weight
    assert np.abs(obs.wrenches[:, 3:]).max() < 1e-3


@needs_pybullet
def test_no_load_reads_zero_while_the_arms_swing_and_inertia_compensation_is_what_makes_it(eva):
    readings = {}
    for inertia in (True, False):
        sim = BulletSimulation(eva, SIM)
        sim.wrists.inertia = inertia
        forces = []
        for step in range(100):
            sim.apply(*swinging(eva, step * SIM.control_dt))
            sim.step(SUBSTEPS)
            forces.append(np.linalg.norm(sim.observe().wrenches[:, :3], axis=1))
        sim.close()
        readings[inertia] = np.max(forces)
    print(f"max |F| swinging, no load: {readings[True]:.3f} N compensated, {readings[False]:.3f} N gravity only")
    assert readings[True] < 0.05  # [N]; hand speeds up to ~0.15 m/s
    assert readings[False] > 0.5  # gravity compensation alone leaves the tool's m a in the reading


def _hang(sim, hand, mass, offset):
    """A box of `mass` fixed to the pad, its centre `offset` [m] out along the pad normal (grasp z)."""
    c, obs = sim.client, sim.observe()
    centre = obs.hand_positions[hand] + obs.hand_rotations[hand] @ [0, 0, offset]
    box = c.createMultiBody(
        mass,
        c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.03] * 3),
        -1,
        centre.tolist(),
        c.getLinkState(sim.body, sim.hand_links[hand])[5],
    )
    for link in range(c.getNumJoints(sim.body)):  # the load acts through the constraint only
        c.setCollisionFilterPair(sim.body, box, link, -1, 0)
    constraint = c.createConstraint(
        sim.body, sim.hand_links[hand], box, -1, pybullet.JOINT_FIXED, [0, 0, 0], [0, 0, offset], [0, 0, 0]
    )
    c.changeConstraint(constraint, maxForce=1e4)


@needs_pybullet
@pytest.mark.parametrize(
    "posture, hand, mass", [("home", 0, 0.5), ("home", 1, 2.0), ("raised", 0, 2.0), ("raised", 1, 1.0)]
)
def test_a_load_hung_on_a_pad_reads_m_g(sim, eva, posture, hand, mass):
    q = _posture(eva, posture)
    _hold(sim, q, 30)
    offset = 0.05
    _hang(sim, hand, mass, offset)
    obs = _hold(sim, q, 40)
    rotation = obs.hand_rotations[hand]
    weight = mass * np.array([0.0, 0.0, -9.81])
    force = rotation @ obs.wrenches[hand, :3]  # grasp -> world
    assert np.linalg.norm(force - weight) < 0.02 * np.linalg.norm(weight), force
    moment = np.cross(rotation @ [0, 0, offset], weight)  # the weight, acting where the load is attached
    assert np.linalg.norm(rotation @ obs.wrenches[hand, 3:] - moment) < 0.02 * np.linalg.norm(moment)
    assert np.abs(obs.wrenches[1 - hand]).max() < 0.01  # the other hand carries nothing


@needs_pybullet
def test_a_squeeze_reads_the_sum_of_the_pad_contact_normal_forces(sim, eva):
    c, obs = sim.client, _hold(sim, eva.home, 20)
    gap = np.linalg.norm(obs.hand_positions[0] - obs.hand_positions[1])
    middle = obs.hand_positions.mean(axis=0)
    assert np.allclose(obs.hand_rotations[0][:, 2] @ obs.hand_rotations[1][:, 2], -1, atol=1e-3)  # pads face
    half = [0.05, 0.05, gap / 2 + 0.005]  # in the right grasp frame: 5 mm into each pad
    c.createMultiBody(
        0.5,
        c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half),
        -1,
        middle.tolist(),
        c.getLinkState(sim.body, sim.hand_links[1])[5],
    )
    c.createMultiBody(
        0,
        c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.05, 0.05, 0.01]),
        -1,
        (middle - [0, 0, 0.06]).tolist(),
    )  # a stand under the box
    _hold(sim, eva.home, 40)
    sensed, contacts = [], []
    for _ in range(20):
        sensed.append(_hold(sim, eva.home, 1).pad_forces)
        contacts.append(
            [
                sum(
                    point[9]
                    for link in tool  # normal force of every contact on the tool's links
                    for point in c.getContactPoints(bodyA=sim.body, linkIndexA=link)
                )
                for tool in sim.wrists.tools
            ]
        )
    sensed, contacts = np.mean(sensed, axis=0), np.mean(contacts, axis=0)
    print(f"squeeze: sensed {sensed.round(2)} N, pad contacts {contacts.round(2)} N")
    assert np.all(contacts > 5.0)  # a real squeeze, on both pads
    assert np.all(np.abs(sensed - contacts) < 0.05 * contacts), (sensed, contacts)


@needs_pybullet
def test_the_reaction_convention_holds_for_a_tool_with_a_rotated_inertial_frame(tmp_path):
    """PyBullet gives the reaction in the child's COM frame, about its COM: a tool whose inertial frame is
    rotated and offset from its link frame still reads zero without load, in a tilted posture."""
    urdf = (ROOT / "harmony_cli/robot/presets/eva.urdf").read_text()
    tool = '<origin xyz="-0.04 0 -0.03" rpy="0 0 0"/>\n      <mass value="0.3113"/>'
    assert urdf.count(tool) == 2
    rotated = tmp_path / "eva_rotated_tool.urdf"
    rotated.write_text(
        urdf.replace(tool, tool.replace('xyz="-0.04 0 -0.03" rpy="0 0 0"', 'xyz="-0.05 0.01 -0.02" rpy="0.3 0.5 0.7"'))
    )
    c = BulletClient(connection_mode=pybullet.DIRECT)
    c.setGravity(0, 0, -9.81)
    body = c.loadURDF(str(rotated), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    index = {c.getJointInfo(body, i)[1].decode(): i for i in range(c.getNumJoints(body))}
    for joint, angle in {"LARM_JOINT2": -0.5, "LARM_JOINT3": 0.7, "LARM_JOINT4": 0.4, "LARM_JOINT5": 1.1}.items():
        c.resetJointState(body, index[joint], angle)
    wrists = WristSensors(c, body, [index["LARM_TOOL_JOINT"]], [index["LARM_GRASP_JOINT"]])
    movable = [i for i in index.values() if c.getJointInfo(body, i)[2] != pybullet.JOINT_FIXED]
    targets = [c.getJointState(body, i)[0] for i in movable]
    for _ in range(100):
        c.setJointMotorControlArray(body, movable, pybullet.POSITION_CONTROL, targetPositions=targets)
        wrists.before_physics_step()
        c.stepSimulation()
    wrench = wrists.read()[0]
    c.disconnect()
    assert np.abs(wrench[:3]).max() < 0.01 and np.abs(wrench[3:]).max() < 1e-3, wrench


@needs_pybullet
def test_sensing_does_not_change_the_dynamics(eva):
    """The same commands with sensing (sensors on, read every step) and without (sensors off, bare physics)."""
    trajectories = []
    for sensing in (True, False):
        sim = BulletSimulation(eva, SIM)
        for joint in sim.wrists.sensors if not sensing else []:
            sim.client.enableJointForceTorqueSensor(sim.body, joint, False)
        q, path = _posture(eva, "raised"), []
        for _ in range(25):
            sim.apply(q, np.zeros(eva.n_dof))
            for _ in range(SUBSTEPS):
                sim.step(1) if sensing else sim.client.stepSimulation()
            path.append(sim.observe().q)
        trajectories.append(path)
        sim.close()
    assert np.array_equal(*trajectories)


def _write(tmp_path, robot):
    path = tmp_path / "bad.yaml"
    path.write_text(f"name: x\nrobot: {{preset: eva, {robot}}}\nreference: {{type: hold}}\n")
    return path


@pytest.mark.parametrize(
    "robot, expected",
    [
        (
            "wrist_sensors: {left: LARM_TOOL_JOINT, right: RARM_TOOL_JOIN}",
            ["robot.wrist_sensors.right", "'RARM_TOOL_JOIN'", "RARM_FT_JOINT, RARM_TOOL_JOINT, RARM_GRASP_JOINT"],
        ),
        (
            "wrist_sensors: {left: LARM_JOINT5, right: RARM_TOOL_JOINT}",
            ["robot.wrist_sensors.left", "'LARM_JOINT5'", "LARM_FT_JOINT, LARM_TOOL_JOINT, LARM_GRASP_JOINT"],
        ),
        ("wrist_sensors: {left: LARM_TOOL_JOINT}", ["robot.wrist_sensors", "['left']", "left, right"]),
    ],
)
def test_a_wrong_sensor_joint_is_one_line_naming_file_field_value_and_choices(tmp_path, robot, expected):
    path = _write(tmp_path, robot)
    assert_rejected(path, expected)


def test_sensor_joints_default_to_the_joint_above_the_link_holding_the_grasp_frame():
    twin = ROOT / "scenarios/smoke/twin_arm_turn.yaml"
    spec = load_scenario(twin).robot
    assert wrist_sensor_joints(None, spec.end_effectors, (twin.parent / spec.urdf).resolve()) == {
        "left": "l_ft_joint",
        "right": "r_ft_joint",
    }
    eva = load_scenario(TABLE1).robot
    assert wrist_sensor_joints(None, eva.end_effectors, (TABLE1.parent / eva.urdf).resolve()) == {
        "left": "LARM_TOOL_JOINT",
        "right": "RARM_TOOL_JOINT",
    }


def test_the_force_low_pass_is_first_order_with_the_given_time_constant():
    from harmony_cli.maths.filters import LowPass

    dt, tau = 0.02, 0.05
    low = LowPass(tau, dt)
    assert np.allclose(low([0.0, 10.0]), [0.0, 10.0])  # starts at the first sample
    out = [low([20.0, 10.0]) for _ in range(10)]
    alpha = dt / (tau + dt)
    assert np.allclose(out[-1][0], 20.0 * (1 - (1 - alpha) ** 10)) and np.allclose(out[-1][1], 10.0)
    raw = LowPass(0.0, dt)
    raw([1.0])
    assert np.allclose(raw([7.0]), [7.0])  # tau = 0 passes the input
