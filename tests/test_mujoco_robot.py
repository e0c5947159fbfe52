"""The robot in MuJoCo (sim/mujoco_robot.py): its hand frames are OpTaS's, it holds home and follows commands
like PyBullet's motors, and its wrist sensors read an external load as sim/wrench.py does."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from conftest import ROOT, needs_pybullet, swinging
from test_joint_chains import _robot

from harmony_cli.scenario import load_scenario, robot_of

mujoco = pytest.importorskip("mujoco")
from harmony_cli.sim.mujoco_robot import MujocoRobot, robot_spec  # noqa: E402

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    from harmony_cli.sim.bullet import BulletSimulation  # noqa: E402
    from harmony_cli.sim.wrench import rotation_matrices  # noqa: E402
except ImportError:
    pass

PAPER = ROOT / "scenarios/paper/pick_and_carry.yaml"
S_SHAPE = ROOT / "scenarios/robots/s_shape.yaml"
SIM = load_scenario(PAPER).sim
SUBSTEPS = round(SIM.control_dt / SIM.physics_dt)


@pytest.fixture(scope="module")
def eva():
    return robot_of(load_scenario(PAPER), PAPER.parent)


@functools.cache
def _catalogue(preset: str):
    """A catalogue robot: twin_arm of primitives; pr2 (STL meshes), tiago_dual and baxter (STL and COLLADA)."""
    return robot_of(load_scenario(S_SHAPE, [f"robot.preset={preset}"]), S_SHAPE.parent)


def _bound(robot, spec=None) -> MujocoRobot:
    model = (spec or robot_spec(robot, SIM)).compile()
    sim = MujocoRobot(model, mujoco.MjData(model), robot, SIM)
    sim.reset_home()
    return sim


def _random_q(robot, rng) -> np.ndarray:
    lower, upper = np.maximum(robot.lower, -np.pi), np.minimum(robot.upper, np.pi)
    q = rng.uniform(lower, upper)
    q[list(robot.base_joints)] = rng.uniform(-2, 2, 3)
    return robot.coupled(q)


def _assert_hands_match(sim: MujocoRobot, robot, q: np.ndarray) -> None:
    sim.data.qpos[sim.qpos] = q
    mujoco.mj_forward(sim.model, sim.data)
    positions, rotations, _, _ = sim.hands()
    for h, (position, rotation) in enumerate(robot.hand_poses_numeric(q)):
        assert np.linalg.norm(positions[h] - position.ravel()) < 1e-3
        angle = np.arccos(np.clip((np.trace(rotations[h].T @ rotation) - 1) / 2, -1, 1))
        assert angle < 1e-3


@pytest.mark.parametrize("name", ["eva", "twin_arm", "pr2", "tiago_dual", "baxter"])
def test_hand_frames_are_optas_s_at_home_and_at_random_joint_vectors(eva, name, rng):
    robot = eva if name == "eva" else _catalogue(name)
    sim = _bound(robot)
    for q in [robot.home] + [_random_q(robot, rng) for _ in range(5)]:
        _assert_hands_match(sim, robot, q)


def test_hand_frames_are_optas_s_with_a_mimic_wrist_on_the_chain(tmp_path, rng):
    _, robot = _robot(tmp_path, wrist_mimic=True)
    assert robot.couplings
    sim = _bound(robot)
    for q in [robot.home] + [_random_q(robot, rng) for _ in range(3)]:
        _assert_hands_match(sim, robot, q)


@needs_pybullet
def test_a_converted_collada_mesh_lies_where_pybullet_s_own_loader_puts_it():
    robot = _catalogue("baxter")
    sim, bullet = _bound(robot), BulletSimulation(robot, SIM)
    links = {
        bullet.client.getJointInfo(bullet.body, i)[12].decode(): i
        for i in range(bullet.client.getNumJoints(bullet.body))
    }
    model, data = sim.model, sim.data
    for link in ("torso", "pedestal"):  # their collision meshes are .DAE files
        geom = next(
            g
            for g in range(model.ngeom)
            if model.geom_bodyid[g] == model.body(link).id and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
        )
        mesh = model.geom_dataid[geom]
        start = model.mesh_vertadr[mesh]
        vertices = model.mesh_vert[start : start + model.mesh_vertnum[mesh]] @ data.geom_xmat[geom].reshape(3, 3).T
        ours = data.geom_xpos[geom] + vertices
        state = bullet.client.getLinkState(bullet.body, links[link], computeForwardKinematics=True)
        _, theirs = bullet.client.getMeshData(bullet.body, links[link])  # in the link's inertial frame
        theirs = np.array(state[0]) + np.array(theirs) @ rotation_matrices([state[1]])[0].T
        assert np.abs(ours.min(axis=0) - theirs.min(axis=0)).max() < 1e-3
        assert np.abs(ours.max(axis=0) - theirs.max(axis=0)).max() < 1e-3
    bullet.close()


def test_eva_holds_home_under_gravity_for_two_seconds(eva):
    # gravity is compensated through the actuators, so home is an equilibrium of the servos: what remains is
    # round-off, far below 1e-6 rad (a micrometre at a 1 m arm); a servo or compensation error would show in mrad
    sim = _bound(eva)
    worst = 0.0
    for _ in range(round(2.0 / SIM.control_dt)):
        sim.apply(eva.home, np.zeros(eva.n_dof))
        sim.step(SUBSTEPS)
        worst = max(worst, np.abs(sim.q() - eva.home).max())
    assert worst < 1e-6, worst


def test_a_joint_commanded_along_a_smooth_ramp_follows_it_with_a_bounded_lag(eva):
    sim, joint = _bound(eva), eva.index("LARM_JOINT1")
    lags = []
    for step in range(round(2.0 / SIM.control_dt)):
        t = step * SIM.control_dt
        # 0.6 rad over 2 s, a cosine ramp: speed up to 0.47 rad/s
        q, qd = eva.home.copy(), np.zeros(eva.n_dof)
        q[joint] += 0.3 * (1 - np.cos(np.pi * t / 2))
        qd[joint] = 0.3 * np.pi / 2 * np.sin(np.pi * t / 2)
        sim.apply(q, qd)
        sim.step(SUBSTEPS)
        lags.append(abs(sim.q()[joint] - (eva.home[joint] + 0.3 * (1 - np.cos(np.pi * (t + SIM.control_dt) / 2)))))
    # the position target is held over a control period while the reference moves on: the bound is one period's
    # travel at the top speed (0.47 rad/s x 0.02 s = 9.4 mrad); the velocity feed-forward keeps the lag below it
    assert max(lags) < 1e-2, max(lags)


def _hang(spec, robot, sim: MujocoRobot, hand: int, mass: float, offset: float) -> None:
    """A box of `mass` welded to the hand frame, its centre `offset` out along the grasp z, colliding with nothing."""
    position, rotation = sim.data.site_xpos[sim.hand_sites[hand]], sim.data.site_xmat[sim.hand_sites[hand]]
    quaternion = np.zeros(4)
    mujoco.mju_mat2Quat(quaternion, rotation)
    load = spec.worldbody.add_body(name="load", pos=position + rotation.reshape(3, 3) @ [0, 0, offset], quat=quaternion)
    load.add_freejoint()
    load.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03] * 3, mass=mass, contype=0, conaffinity=0)
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_WELD,
        objtype=mujoco.mjtObj.mjOBJ_BODY,
        name1=robot.end_effectors[hand],
        name2="load",
        data=np.r_[0, 0, 0, 0, 0, offset, 1, 0, 0, 0, 1, np.zeros(mujoco.mjNEQDATA - 11)],
    )


@pytest.mark.parametrize("hand, mass", [(0, 0.5), (1, 2.0)])
def test_a_load_welded_to_a_tool_reads_its_weight_and_moment_with_the_tool_s_own_compensated(eva, hand, mass):
    spec, offset = robot_spec(eva, SIM), 0.05
    _hang(spec, eva, _bound(eva), hand, mass, offset)
    sim = _bound(eva, spec)
    for _ in range(round(1.0 / SIM.control_dt)):
        sim.apply(eva.home, np.zeros(eva.n_dof))
        sim.step(SUBSTEPS)
    _, rotations, _, _ = sim.hands()
    wrenches, rotation = sim.wrenches(), rotations[hand]
    weight = mass * np.array([0.0, 0.0, -9.81])
    assert np.linalg.norm(rotation @ wrenches[hand, :3] - weight) < 0.02 * np.linalg.norm(weight)
    moment = np.cross(rotation @ [0, 0, offset], weight)
    assert np.linalg.norm(rotation @ wrenches[hand, 3:] - moment) < 0.02 * np.linalg.norm(moment)
    assert np.abs(wrenches[1 - hand]).max() < 1e-6  # the other tool carries nothing: its weight compensated


def test_base_velocity_commands_move_the_base_at_that_speed(eva):
    sim, base = _bound(eva), list(eva.base_joints)
    qd = np.zeros(eva.n_dof)
    qd[base] = [0.3, -0.2, 0.4]  # [m/s, m/s, rad/s]
    start = None
    for step in range(round(2.0 / SIM.control_dt)):
        if step == round(1.0 / SIM.control_dt):
            start = sim.q()[base]
        sim.apply(eva.home, qd)
        sim.step(SUBSTEPS)
    assert start is not None
    assert np.allclose(sim.q()[base] - start, qd[base] * 1.0, rtol=1e-3)
    assert np.allclose(sim.qd()[base], qd[base], rtol=1e-3)


def test_an_unloaded_tool_reads_zero_while_the_arms_swing(eva):
    # the tool's weight (3 N) and its m a (hands up to ~0.15 m/s) are compensated with MuJoCo's own accelerations
    sim, worst = _bound(eva), 0.0
    for step in range(round(2.0 / SIM.control_dt)):
        sim.apply(*swinging(eva, step * SIM.control_dt))
        sim.step(SUBSTEPS)
        worst = max(worst, np.abs(sim.wrenches()).max())
    assert worst < 1e-6, worst
