"""The MuJoCo engine: the robot from the prepared URDF through MuJoCo's URDF compiler (mujoco_robot.py) in the
scenario's world (mujoco_world.py), commanded and sensed as the PyBullet engine is; the Simulator of engine.py."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.robot.observation import Observation
from harmony_cli.sim.mujoco_contact_model import set_pad_contacts
from harmony_cli.sim.mujoco_contacts import MujocoTouches
from harmony_cli.sim.mujoco_pushes import MujocoPushes
from harmony_cli.sim.mujoco_robot import MujocoRobot, robot_spec, tool_bodies
from harmony_cli.sim.mujoco_world import MujocoWorld, add_world
from harmony_cli.sim.truth import BoxTruth, Truth, assemble

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from harmony_cli.robot.model import Robot
    from harmony_cli.scenario.models import SimSpec
    from harmony_cli.scenario.world import PushSpec, WorldSpec


class MujocoSimulation:
    """The robot at home in the world; base through its virtual planar joints (velocity), every other joint by
    position + velocity targets."""

    def __init__(
        self, robot: Robot, sim_spec: SimSpec, world: WorldSpec | None = None, pushes: Sequence[PushSpec] = ()
    ):
        self.spec = sim_spec
        spec = robot_spec(robot, sim_spec)
        add_world(spec, world, sim_spec)
        set_pad_contacts(spec, tool_bodies(spec, robot), sim_spec, world.box if world is not None else None)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.arm = MujocoRobot(self.model, self.data, robot, sim_spec)
        self.arm.reset_home()
        self.world = MujocoWorld(self.model, self.data, world)
        self.tools = [set(bodies) for bodies in self.arm.tool_bodies]
        links = {self.model.body(b).name: b for b in self.arm.body_ids}
        base = int(self.model.jnt_bodyid[self.model.joint(robot.joint_names[robot.base_joints[2]]).id])
        self.pushes = MujocoPushes(self.model, self.data, pushes, base, links, self.world, sim_spec.physics_dt)
        self.touches = MujocoTouches(self.model, self.data, self.arm.body_ids, self.world)
        self.pad_friction = world.box.friction if world is not None and world.box is not None else 0.0
        mujoco.mj_forward(self.model, self.data)
        self.notes = [
            f"mujoco: {mujoco.__version__}; {self.model.nbody} bodies, {self.model.ngeom} geoms, "
            f"{self.model.nu} actuators, step {self.model.opt.timestep} s"
        ]
        self.physics_steps = 0
        self._open = True

    def observe(self) -> Observation:
        positions, rotations, velocities, yaw_rates = self.arm.hands()
        box = self.world.box_pose() if self.world.box is not None else None
        return Observation(
            q=self.arm.q(),
            qd=self.arm.qd(),
            hand_positions=positions,
            hand_rotations=rotations,
            hand_velocities=velocities,
            heading_rate=float(np.mean(yaw_rates)),
            wrenches=self.arm.wrenches(),
            box_position=None if box is None else box[0],
            box_yaw=0.0 if box is None else box[1],
        )

    def truth(self) -> Truth:
        world = self.world
        return assemble(
            None if world.box is None else self._box_truth(world.box),
            self.pushes.magnitudes(self.time),
            {name: world.obstacle_position(name) for name in world.moving},
            world.clearances(self.arm.body_ids),
            self.touches,
        )

    def _box_truth(self, box: int) -> BoxTruth:
        world = self.world
        centre, z_axis, quaternion = world.box_state()
        pads = world.pad_contacts(self.tools, self.arm.body_ids, self.pad_friction)
        touching = bool(pads.points.sum() > 0 or pads.other_links)
        others = tuple(self.arm.link_name(body) for body in pads.other_links)
        return BoxTruth(centre, z_axis, quaternion, touching, pads, others, world.clearances({box}))

    def apply(self, q_target: np.ndarray, qd_target: np.ndarray) -> None:
        self.arm.apply(q_target, qd_target)

    def step(self, substeps: int) -> None:
        """`substeps` physics steps under the last command, then the readings brought up to date (mj_forward)."""
        self.touches.clear()
        for _ in range(substeps):
            self.pushes.apply(self.time)
            mujoco.mj_step(self.model, self.data)
            self.touches.after_physics_step()
            self.physics_steps += 1
            self.world.move_obstacles(self.time)
        mujoco.mj_forward(self.model, self.data)

    @property
    def time(self) -> float:
        return self.physics_steps * self.spec.physics_dt

    @property
    def connected(self) -> bool:
        return self._open

    def penetrations(self) -> list[tuple[str, str, float]]:
        """Contacts of the robot with the scene, and its geoms below the ground (which it does not collide with)."""
        mujoco.mj_forward(self.model, self.data)
        bodies, found, n = self.arm.body_ids, self._below_ground(), self.data.ncon
        for (g1, g2), dist in zip(self.data.contact.geom[:n].tolist(), self.data.contact.dist[:n].tolist()):
            a, b = (int(self.model.geom_bodyid[g]) for g in (g1, g2))
            if (a in bodies) != (b in bodies):
                mine, other = (a, b) if a in bodies else (b, a)
                found.append((self.arm.link_name(mine), self._body_label(other), float(dist)))
        return found

    def _below_ground(self) -> list[tuple[str, str, float]]:
        ground = self.model.geom("ground").id
        robot = np.flatnonzero(np.isin(self.model.geom_bodyid, list(self.arm.body_ids)))
        found = []
        for geom in robot.tolist():
            distance = mujoco.mj_geomDistance(self.model, self.data, geom, ground, 0.01, None)
            if distance < 0.0:
                found.append((self.arm.link_name(int(self.model.geom_bodyid[geom])), "the ground", float(distance)))
        return found

    def _body_label(self, body: int) -> str:
        """A world body as the run's messages name it (the ground, table T, obstacle O, the box)."""
        name = self.model.body(body).name
        if body == 0:
            return "the ground"
        if name == "box":
            return "the box"
        kind, _, rest = name.partition(":")
        return f"{kind} {rest}" if kind in ("table", "obstacle") else f"body {name}"

    def show(self, joints: dict[str, float], box_pose: np.ndarray | None, t: float) -> None:
        """A logged state put in place without physics (replays): joints by name, the box's centre and (x, y, z, w)
        quaternion, the moving obstacles at time t."""
        self.arm.place(joints)
        if box_pose is not None:
            self.world.place_box(box_pose[:3], box_pose[3:])
        self.world.move_obstacles(t)
        mujoco.mj_forward(self.model, self.data)

    def camera(self, size: tuple[int, int], follow: Callable[[], np.ndarray]) -> Callable[[], np.ndarray]:
        from harmony_cli.sim.mujoco_camera import MujocoCamera  # an OpenGL context only when a video is asked for

        return MujocoCamera(self.model, self.data, size, follow).render

    def close(self) -> None:
        self._open = False
