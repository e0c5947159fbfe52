"""The scene in MuJoCo (sim/mujoco_world.py, mujoco_contacts.py, mujoco_pushes.py): built into an empty MjSpec,
checked against PyBullet's World for the same scenario and against the physics it should obey."""

import mujoco
import numpy as np
import pytest
from conftest import needs_pybullet

from harmony_cli.scenario import load_scenario
from harmony_cli.scenario.models import SimSpec
from harmony_cli.scenario.world import PushSpec, WorldSpec
from harmony_cli.sim.mujoco_contact_model import set_pad_contacts
from harmony_cli.sim.mujoco_contacts import MujocoTouches
from harmony_cli.sim.mujoco_pushes import MujocoPushes
from harmony_cli.sim.mujoco_world import MujocoWorld, add_world
from harmony_cli.tasks.motion import centre_at

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.world import World
except ImportError:
    pass

TOP, BOX = 1.015, 0.3  # [m] a table's top, the box's edge
SIM = SimSpec()


def _scene(world: WorldSpec, sim: SimSpec = SIM, extra=None) -> MujocoWorld:
    """The world compiled alone (with `extra(spec)` adding test bodies first)."""
    spec = mujoco.MjSpec()
    add_world(spec, world, sim)
    if extra is not None:
        extra(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    return MujocoWorld(model, data, world)


def _step(w: MujocoWorld, seconds: float, each=None) -> None:
    for _ in range(round(seconds / w.model.opt.timestep)):
        mujoco.mj_step(w.model, w.data)
        if each is not None:
            each()


def _table_and_box(z: float, obstacles=()) -> WorldSpec:
    return WorldSpec.model_validate(
        {
            "tables": [{"name": "table", "position": [0.0, 0.0]}],
            "box": {"size": [BOX] * 3, "position": [0.0, 0.0, z]},
            "obstacles": list(obstacles),
        }
    )


def test_box_dropped_on_a_table_settles_on_its_top_and_stays():
    w = _scene(_table_and_box(TOP + BOX / 2 + 0.01))
    _step(w, 1.0)
    centres = []
    _step(w, 2.0, lambda: centres.append(w.box_pose()[0]))
    centres = np.array(centres)
    assert np.abs(centres[:, 2] - (TOP + BOX / 2)).max() < 1e-3
    assert np.abs(centres - centres[0]).max() < 1e-4
    assert w.box_state()[1] == pytest.approx([0, 0, 1], abs=1e-6)


def _probe(spec: mujoco.MjSpec) -> None:
    """A mocap sphere of radius 0.1 m to measure clearances with."""
    body = spec.worldbody.add_body(name="probe", mocap=True, pos=[0, 0, 5])
    body.add_geom(name="probe", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.1, 0, 0])


@pytest.fixture
def client():
    client = BulletClient(connection_mode=pybullet.DIRECT)
    yield client
    client.disconnect()


@needs_pybullet
def test_pick_and_carry_scene_matches_pybullets(client):
    world_spec = load_scenario("scenarios/paper/pick_and_carry.yaml").world
    w = _scene(world_spec, extra=_probe)
    mujoco.mj_forward(w.model, w.data)
    bullet = World(client, world_spec)
    geom = lambda name: mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_GEOM, name)
    for name, bodies in bullet.tables.items():
        names = [f"table:{name}:top"] + [f"table:{name}:leg{i}" for i in range(4)]
        for body, g in zip(bodies, map(geom, names)):
            position, orientation = client.getBasePositionAndOrientation(body)
            assert w.data.geom_xpos[g] == pytest.approx(position, abs=1e-9)
            assert np.abs(w.data.geom_xquat[g] @ np.roll(orientation, 1)) == pytest.approx(1.0)
            assert 2 * w.model.geom_size[g] == pytest.approx(client.getCollisionShapeData(body, -1)[0][3])
    assert w.obstacle_position("cylinder") == pytest.approx(bullet.obstacle_position("cylinder"))
    assert w.box_state()[0] == pytest.approx(bullet.box_state()[0])
    assert w.clearances({w.box})["cylinder"] == pytest.approx(bullet.clearance(bullet.box, "cylinder"), abs=1e-3)
    probe = client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_SPHERE, radius=0.1))
    body = mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_BODY, "probe")
    # beside the cylinder, above it, off its rim and inside it
    for point in ([4.67 + 0.75, 1.63, 1.0], [4.67, 1.63, 2.3], [5.2, 2.1, 2.05], [4.67 + 0.65, 1.63, 1.0]):
        client.resetBasePositionAndOrientation(probe, point, [0, 0, 0, 1])
        w.data.mocap_pos[w.model.body_mocapid[body]] = point
        expected = bullet.clearance(probe, "cylinder")
        assert w.clearances({body})["cylinder"] == pytest.approx(expected, abs=1e-3)


def test_moving_obstacle_follows_its_motion():
    world_spec = load_scenario("scenarios/paper/dynamic_obstacle.yaml").world
    w = _scene(world_spec)
    (name, spec), *_ = w.moving.items()
    body = w.obstacles[name]
    for t in np.arange(35.0, 48.0, 0.25):
        w.move_obstacles(t)
        mujoco.mj_forward(w.model, w.data)
        assert w.obstacle_position(name) == pytest.approx(centre_at(spec, t)[0], abs=1e-12)
        assert w.data.xpos[body] == pytest.approx(centre_at(spec, t)[0], abs=1e-12)
    assert np.ptp(centre_at(spec, np.arange(35.0, 48.0, 0.25)), axis=0).max() > 0.5  # it did move


def test_push_gives_the_free_box_its_impulse():
    world = WorldSpec.model_validate({"box": {"size": [BOX] * 3, "position": [0.0, 0.0, 10.0]}})
    w = _scene(world)
    force, duration, arm = np.array([20.0, 0.0, 0.0]), 0.048, 0.02  # 12 steps; the box turns ~0.04 rad while pushed
    push = PushSpec(name="shove", body="box", force=force.tolist(), start=0.1, duration=duration, point=[0, arm, 0])
    pushes = MujocoPushes(w.model, w.data, [push], 0, {}, w, SIM.physics_dt)
    dt, seen = SIM.physics_dt, []
    for k in range(round(0.5 / dt)):
        pushes.apply(k * dt)
        seen.append(pushes.magnitudes(k * dt)["push_shove_N"])
        mujoco.mj_step(w.model, w.data)
    momentum = 0.8 * w.data.qvel[:2]  # across gravity
    assert momentum == pytest.approx(force[:2] * duration, rel=0.02, abs=1e-9)
    izz = 0.8 / 12 * 2 * BOX**2
    assert w.data.qvel[5] * izz == pytest.approx(-arm * force[0] * duration, rel=0.01)  # (0, arm, 0) x F
    assert sum(seen) * dt == pytest.approx(np.linalg.norm(force) * duration)


def test_spring_pusher_on_a_static_obstacle_presses_with_its_full_force():
    world = WorldSpec.model_validate(
        {"obstacles": [{"name": "post", "shape": "box", "position": [0, 0, 0.5], "size": [0.2, 0.2, 1.0]}]}
    )
    w = _scene(world)
    push = PushSpec(name="spring", body="post", force=[0, 30.0, 0], start=0.0, duration=0.4, stiffness=1000.0)
    pushes = MujocoPushes(w.model, w.data, [push], 0, {}, w, SIM.physics_dt)
    for k in range(round(0.3 / SIM.physics_dt)):
        pushes.apply(k * SIM.physics_dt)
        mujoco.mj_step(w.model, w.data)
    assert pushes.magnitudes(0.3)["push_spring_N"] == pytest.approx(30.0)


def test_box_pressed_against_an_obstacle_and_a_ball_on_the_table_are_touches():
    post = {"name": "post", "shape": "box", "position": [BOX + 0.0005, 0.0, TOP + BOX / 2], "size": [BOX] * 3}

    def ball(spec):
        body = spec.worldbody.add_body(name="ball", pos=[0.5, 0.3, TOP + 0.1])
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.1, 0, 0], mass=1.0)

    w = _scene(_table_and_box(TOP + BOX / 2, [post]), extra=ball)
    ball_body = mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_BODY, "ball")
    touches = MujocoTouches(w.model, w.data, {ball_body}, w)
    w.data.xfrc_applied[w.box, :3] = [20.0, 0.0, 0.0]
    _step(w, 0.2, touches.after_physics_step)
    assert touches.box_m["post"] <= 0.0
    assert touches.robot_m["table"] <= 0.0 and "post" not in touches.robot_m
    assert touches.robot_bodies == ["table", "post"] and touches.box_bodies == ["post"]
    touches.clear()
    assert touches.robot_m == {} and touches.box_m == {}


def _ball_on_a_pad(sim: SimSpec) -> tuple[MujocoWorld, int, WorldSpec]:
    """A ball of the box's mass resting on a compliant pad (a large plate at z 1.0), the ball's centre 1.1 above."""
    world = WorldSpec.model_validate({"box": {"size": [BOX] * 3, "position": [0.0, 0.0, BOX / 2]}})

    def pad_floor(spec):
        pad = spec.worldbody.add_body(name="pad", pos=[5, 5, 0.9])
        pad.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[1, 1, 0.1])
        set_pad_contacts(spec, [pad], sim, world.box)
        body = spec.worldbody.add_body(name="ball", pos=[5, 5, 1.1])
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.1, 0, 0], mass=world.box.mass)

    w = _scene(world, sim, pad_floor)
    return w, mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_BODY, "ball"), world


def test_compliant_pad_sinks_by_weight_over_stiffness():
    sim = SimSpec(pad_stiffness=20000.0, pad_damping=100.0)
    w, ball, world = _ball_on_a_pad(sim)
    _step(w, 2.0)
    sink = 1.1 - w.data.xpos[ball][2]
    assert sink == pytest.approx(world.box.mass * 9.81 / sim.pad_stiffness, rel=0.02)


def test_compliant_pad_rings_down_with_its_damping_ratio():
    sim = SimSpec(pad_stiffness=20000.0, pad_damping=100.0)
    w, ball, world = _ball_on_a_pad(sim)
    _step(w, 2.0)
    z = w.model.jnt_qposadr[w.model.body_jntadr[ball]] + 2
    rest = w.data.qpos[z]
    pressed = 0.5 * world.box.mass * 9.81 / sim.pad_stiffness  # half the static sink: the ball stays on the pad
    w.data.qpos[z], w.data.qvel[:] = rest - pressed, 0.0
    heights = []
    _step(w, 1.0, lambda: heights.append(w.data.qpos[z] - rest))
    zeta = sim.pad_damping / (2.0 * np.sqrt(sim.pad_stiffness * world.box.mass))
    assert max(heights) / pressed == pytest.approx(np.exp(-np.pi * zeta / np.sqrt(1.0 - zeta**2)), abs=0.03)


def test_two_pads_squeezing_the_box_hold_it_by_friction():
    sim = SimSpec(pad_stiffness=20000.0, pad_damping=100.0)
    world = WorldSpec.model_validate({"box": {"size": [BOX] * 3, "position": [0.0, 0.0, 1.0]}})
    squeeze = 0.002  # [m] each pad into the box

    def pads(spec):
        bodies = []
        for side in (-1, 1):
            body = spec.worldbody.add_body(name=f"pad{side}", mocap=True, pos=[side * (BOX / 2 + 0.01 - squeeze), 0, 1])
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.01, 0.05, 0.05])
            bodies.append(body)
        set_pad_contacts(spec, bodies, sim, world.box)

    w = _scene(world, sim, pads)
    _step(w, 1.0)
    bodies = [mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_BODY, f"pad{side}") for side in (-1, 1)]
    contacts = w.pad_contacts([{bodies[0]}, {bodies[1]}], set(bodies), world.box.friction)
    assert w.box_pose()[0][2] == pytest.approx(1.0, abs=5e-3)
    assert np.all(contacts.points >= 1) and contacts.other_N == 0.0
    assert contacts.normal_N == pytest.approx(contacts.points * sim.pad_stiffness * squeeze, rel=0.05)  # per point
    weight_share = world.box.mass * 9.81 / 2
    assert contacts.friction_used == pytest.approx(weight_share / (world.box.friction * contacts.normal_N), rel=0.05)
    assert np.all(contacts.normal_off_face_deg < 1.0)


def test_a_box_pushed_along_a_table_slides_against_the_product_of_the_two_frictions_as_in_pybullet():
    world = _table_and_box(TOP + BOX / 2)
    box, table = world.box, world.tables[0]
    w = _scene(world)
    _step(w, 0.5)  # settled
    force = 6.0  # [N] along x, above the friction's 0.48 m g = 3.8 N
    w.data.xfrc_applied[w.box, 0] = force
    x0 = w.box_pose()[0][0]
    _step(w, 0.4)
    travelled = w.box_pose()[0][0] - x0
    expected = 0.5 * (force / box.mass - box.friction * table.friction * 9.81) * 0.4**2
    assert travelled == pytest.approx(expected, rel=0.05)
