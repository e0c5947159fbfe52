"""The PyBullet engine (own DIRECT client): the robot from the prepared URDF, commanded like the real one, in the
scenario's world; the Simulator of sim/engine.py."""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.capture import captured_output
from harmony_cli.robot.model import Robot
from harmony_cli.robot.observation import Observation
from harmony_cli.sim.bullet_camera import BulletCamera
from harmony_cli.sim.bullet_import import BANNER, BulletClient, pybullet
from harmony_cli.sim.contacts import pad_contacts
from harmony_cli.sim.motors import efforts
from harmony_cli.sim.pushes import Pushes
from harmony_cli.sim.touches import Touches
from harmony_cli.sim.truth import BoxTruth, Truth, assemble
from harmony_cli.sim.world import BODY_FLAGS, World
from harmony_cli.sim.wrench import WristSensors, rotation_matrices

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from harmony_cli.scenario.models import SimSpec
    from harmony_cli.scenario.world import PushSpec, WorldSpec


ROBOT_FRICTION = 1.0  # every robot link's lateral and spinning friction (Bullet multiplies the two bodies' values)
SimulatorError = pybullet.error  # what every client call raises, e.g. once the physics server is gone


class BulletSimulation:
    """Base through its virtual planar joints (velocity), every other joint by position + velocity targets."""

    def __init__(
        self, robot: Robot, sim_spec: SimSpec, world: WorldSpec | None = None, pushes: Sequence[PushSpec] = ()
    ):
        self.robot, self.spec = robot, sim_spec
        with captured_output() as output:  # PyBullet's C prints ('argv[0]=', URDF warnings): for run.log
            self.client = BulletClient(connection_mode=pybullet.DIRECT)
            self.client.setGravity(0, 0, -9.81)
            self.client.setPhysicsEngineParameter(
                fixedTimeStep=sim_spec.physics_dt, deterministicOverlappingPairs=1, enableSAT=1
            )
            ground = self.client.createCollisionShape(pybullet.GEOM_PLANE)
            self.ground = self.client.createMultiBody(0, ground)
            self.body = self.client.loadURDF(str(robot.urdf), useFixedBase=True, flags=BODY_FLAGS)
        self.notes = [f"pybullet: {line}" for line in BANNER + output]
        by_name = {}
        for i in range(self.client.getNumJoints(self.body)):
            info = self.client.getJointInfo(self.body, i)
            by_name[info[1].decode()] = i
            if info[12].decode() in robot.end_effectors:
                by_name[info[12].decode()] = i  # link index == index of its parent joint
        self.joints = [by_name[j] for j in robot.joint_names]
        self.effort = efforts(robot)
        self.hand_links = [by_name[link] for link in robot.end_effectors]
        self.base = list(robot.base_joints)
        self.others = [i for i in range(robot.n_dof) if i not in robot.base_joints]
        for i, j in enumerate(self.joints):
            self.client.resetJointState(self.body, j, robot.home[i], 0.0)
        for link in range(-1, self.client.getNumJoints(self.body)):
            self.client.changeDynamics(self.body, link, lateralFriction=ROBOT_FRICTION, spinningFriction=ROBOT_FRICTION)
        self.wrists = WristSensors(self.client, self.body, [by_name[j] for j in robot.wrist_sensors], self.hand_links)
        if sim_spec.pad_stiffness is not None:  # compliant pads: what the force loop presses against is not rigid
            for link in {link for tool in self.wrists.tools for link in tool}:
                self.client.changeDynamics(
                    self.body, link, contactStiffness=sim_spec.pad_stiffness, contactDamping=sim_spec.pad_damping
                )
        self.world = World(self.client, world) if world is not None else None
        self.pad_friction = ROBOT_FRICTION * (world.box.friction if world is not None and world.box else 0.0)
        base_link = self.joints[robot.base_joints[2]]  # the link the base yaw joint moves
        self.pushes = Pushes(self.client, pushes, self.body, base_link, self.world, sim_spec.physics_dt)
        w = self.world
        self.touches = Touches(self.client, self.body, *((w.box, w.tables, w.obstacles) if w else (None, {}, {})))
        self.physics_steps = 0

    def observe(self) -> Observation:
        """What the controllers see: joints, hand frames, wrist wrenches and the box's pose."""
        n, wrists = len(self.joints), self.wrists
        positions, velocities, reactions, _ = zip(*self.client.getJointStates(self.body, self._observed_joints))
        links = wrists.link_states(wrists.links)  # the tools' links, then the hands' (the sensors' grasp links)
        hands = links[-len(self.hand_links) :]
        rotations = rotation_matrices([link[5] for link in hands])
        yaw_rates = np.array([link[7][2] for link in hands])
        box = self.world.box_pose() if self.world is not None and self.world.box is not None else None
        return Observation(
            q=np.array(positions[:n]),
            qd=np.array(velocities[:n]),
            hand_positions=np.array([link[4] for link in hands]),
            hand_rotations=rotations,
            hand_velocities=np.array([link[6] for link in hands]),
            heading_rate=float(np.add.reduce(yaw_rates) / yaw_rates.size),  # np.mean's sum and division, quicker
            wrenches=wrists.wrenches(np.array(reactions[n:]), links, rotations),
            box_position=None if box is None else box[0],
            box_yaw=0.0 if box is None else box[1],
        )

    @cached_property
    def _observed_joints(self) -> list[int]:
        """The robot's joints, then the wrist sensors' (for their reactions): one getJointStates call."""
        return self.joints + self.wrists.sensors

    def truth(self) -> Truth:
        """Ground truth for the logs (never for the controllers)."""
        world = self.world
        if world is None:
            return assemble(None, self.pushes.magnitudes(self.time), {}, {}, self.touches)
        return assemble(
            None if world.box is None else self._box_truth(world, world.box),
            self.pushes.magnitudes(self.time),
            {name: world.obstacle_position(name) for name in world.moving},
            world.clearances(self.body),
            self.touches,
        )

    def _box_truth(self, world: World, box: int) -> BoxTruth:
        centre, z_axis, quaternion = world.box_state()
        contacts = self.client.getContactPoints(bodyA=box, bodyB=self.body)  # whether, and where
        rotation = rotation_matrices([quaternion])[0]
        pads = pad_contacts(contacts, self._hands_of_tool_link, len(self.hand_links), rotation, self.pad_friction)
        others = tuple(self._link_name(link) for link in pads.other_links)
        return BoxTruth(centre, z_axis, quaternion, len(contacts) > 0, pads, others, world.clearances(box))

    def apply(self, q_target: np.ndarray, qd_target: np.ndarray) -> None:
        base = [self.joints[i] for i in self.base]
        self.client.setJointMotorControlArray(
            self.body,
            base,
            pybullet.VELOCITY_CONTROL,
            targetVelocities=qd_target[self.base],
            forces=self.effort[self.base],
        )
        others = [self.joints[i] for i in self.others]
        n = len(others)
        self.client.setJointMotorControlArray(
            self.body,
            others,
            pybullet.POSITION_CONTROL,
            targetPositions=q_target[self.others],
            targetVelocities=qd_target[self.others],
            forces=self.effort[self.others],
            positionGains=[self.spec.position_gain] * n,
            velocityGains=[self.spec.velocity_gain] * n,
        )

    def step(self, substeps: int) -> None:
        """`substeps` physics steps under the last command; the touches seen during them are the next truth's."""
        self.touches.clear()
        for substep in range(substeps):
            self.pushes.apply(self.physics_steps * self.spec.physics_dt)
            if substep == substeps - 1:  # the wrist sensors' accelerations are over the last physics step
                self.wrists.before_physics_step()
            self.client.stepSimulation()
            self.touches.after_physics_step()
            self.physics_steps += 1
            if self.world is not None:
                self.world.move_obstacles(self.time)

    @property
    def time(self) -> float:
        return self.physics_steps * self.spec.physics_dt

    @cached_property
    def _hands_of_tool_link(self) -> dict[int, list[int]]:
        """The hands whose wrist sensor a link is below (one, unless sensors nest)."""
        tools = self.wrists.tools
        return {link: [h for h, tool in enumerate(tools) if link in tool] for link in self.wrists.tool_links}

    @property
    def connected(self) -> bool:
        return bool(self.client.isConnected())

    def penetrations(self) -> list[tuple[str, str, float]]:
        """(robot link, other body, signed distance [m]; negative: inside) of every contact between the robot and
        another body, from a collision pass without a physics step (e.g. before the first)."""
        self.client.performCollisionDetection()
        names = {self.ground: "the ground"}
        if self.world is not None:
            names |= {i: f"table {name}" for name, ids in self.world.tables.items() for i in ids}
            names |= {i: f"obstacle {name}" for name, i in self.world.obstacles.items()}
            if self.world.box is not None:
                names[self.world.box] = "the box"
        return [
            (self._link_name(p[3]), names.get(p[2], f"body {p[2]}"), float(p[8]))
            for p in self.client.getContactPoints(bodyA=self.body)
            if p[2] != self.body
        ]

    def _link_name(self, link: int) -> str:
        if link < 0:
            return self.client.getBodyInfo(self.body)[0].decode()
        return self.client.getJointInfo(self.body, link)[12].decode()

    def camera(self, size: tuple[int, int], follow: Callable[[], np.ndarray]) -> Callable[[], np.ndarray]:
        return BulletCamera(self.client, size, follow).render

    def close(self) -> None:
        """Idempotent; a lost connection has nothing to close."""
        if self.connected:
            self.client.disconnect()
