"""The scene of a scenario as PyBullet bodies: tables, the box and obstacles, and the true clearances PyBullet
measures (closest points).

A moving obstacle is a static (massless) body put where its motion says after every physics step: kinematic,
nothing pushes it, and closest points are measured at its true position. It has no velocity in Bullet, so a
contact would be resolved by penetration recovery alone (the runs require clearance > 0: no contact).

The robot and the box are loaded with BODY_FLAGS: their convex shapes get polyhedral features, so that (with the
client's enableSAT) Bullet finds their contacts by the separating axis test, afresh every physics step, with normals
along the faces as they are now and no collision margin. Without them, GJK keeps a contact point from step to step
with the normal it was made with (behind the box's faces when pads and box turn together) and reports contacts
1 mm before the surfaces touch."""

from __future__ import annotations

import tempfile
from operator import itemgetter
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.shapes import table_legs
from harmony_cli.sim.bullet_import import pybullet
from harmony_cli.tasks.motion import centre_at

if TYPE_CHECKING:
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.scenario.world import WorldSpec

FAR = 5.0  # [m] clearances beyond this are reported as FAR (PyBullet only searches this far)
_distance = itemgetter(8)  # of a closest point: signed, negative inside
# inertia as the URDF gives it; polyhedral features for the separating axis test (only loadURDF reads this flag:
# createCollisionShape ignores it)
BODY_FLAGS = pybullet.URDF_USE_INERTIA_FROM_FILE | pybullet.URDF_INITIALIZE_SAT_FEATURES


def _quaternion(yaw_deg: float) -> list[float]:
    return list(pybullet.getQuaternionFromEuler([0.0, 0.0, np.deg2rad(yaw_deg)]))


def box_urdf(size, mass: float) -> str:
    """A URDF of one solid box of uniform density: its collision and visual shapes and its inertia about its
    centre (what createMultiBody would compute for the same shape)."""
    x, y, z = (float(v) for v in size)
    ixx, iyy, izz = (mass / 12.0 * (a * a + b * b) for a, b in ((y, z), (x, z), (x, y)))
    box = f'<geometry><box size="{x} {y} {z}"/></geometry>'
    return (
        '<?xml version="1.0"?>\n<robot name="box"><link name="box">'
        f'<inertial><mass value="{mass}"/>'
        f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>'
        f'<visual>{box}<material name="box"><color rgba="0.85 0.6 0.3 1"/></material></visual>'
        f"<collision>{box}</collision></link></robot>\n"
    )


def load_box(client: BulletClient, size, mass: float, position, orientation) -> int:
    """The box as a free body with polyhedral features (BODY_FLAGS), loaded from a URDF written for it."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "box.urdf"
        path.write_text(box_urdf(size, mass))
        return client.loadURDF(str(path), list(position), list(orientation), flags=BODY_FLAGS)


class World:
    """Static tables, static or kinematic obstacles, and the box as a free body (held only by friction when
    carried)."""

    def __init__(self, client: BulletClient, spec: WorldSpec):
        self.client, self.spec = client, spec
        # bound once: a BulletClient attribute is a new functools.partial on every access (these run every step)
        self._closest_points, self._base_pose = client.getClosestPoints, client.getBasePositionAndOrientation
        self._reset_base_pose = client.resetBasePositionAndOrientation
        self.tables = {t.name: self._table(t) for t in spec.tables}
        self.obstacles = {o.name: self._obstacle(o) for o in spec.obstacles}
        self.moving = {o.name: o for o in spec.obstacles if o.motion is not None}
        self._orientations = {name: _quaternion(o.yaw_deg) for name, o in self.moving.items()}  # motions translate
        self.move_obstacles(0.0)
        self.box = None
        if spec.box is not None:
            b = spec.box
            self.box = load_box(client, b.size, b.mass, b.position, _quaternion(b.yaw_deg))
            client.changeDynamics(self.box, -1, lateralFriction=b.friction, spinningFriction=b.spinning_friction)

    def _table(self, t) -> list[int]:
        c = self.client
        top_half = [t.top[0] / 2, t.top[1] / 2, t.thickness / 2]
        colour = [0.55, 0.45, 0.35, 1]
        top = c.createMultiBody(
            0,
            c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=top_half),
            c.createVisualShape(pybullet.GEOM_BOX, halfExtents=top_half, rgbaColor=colour),
            [*t.position, t.height - t.thickness / 2],
            _quaternion(t.yaw_deg),
        )
        c.changeDynamics(top, -1, lateralFriction=t.friction)
        bodies = [top]
        for leg in table_legs(t):
            bodies.append(
                c.createMultiBody(
                    0,
                    c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=leg.half),
                    c.createVisualShape(pybullet.GEOM_BOX, halfExtents=leg.half, rgbaColor=colour),
                    leg.centre,
                    _quaternion(t.yaw_deg),
                )
            )
        return bodies

    def _obstacle(self, o) -> int:
        c, half, colour = self.client, np.asarray(o.size) / 2, [0.7, 0.2, 0.2, 1]
        if o.shape == "box":
            col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
            vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=colour)
        elif o.shape == "cylinder":
            col = c.createCollisionShape(pybullet.GEOM_CYLINDER, radius=half[0], height=o.size[2])
            vis = c.createVisualShape(pybullet.GEOM_CYLINDER, radius=half[0], length=o.size[2], rgbaColor=colour)
        else:
            col = c.createCollisionShape(pybullet.GEOM_SPHERE, radius=half[0])
            vis = c.createVisualShape(pybullet.GEOM_SPHERE, radius=half[0], rgbaColor=colour)
        return c.createMultiBody(0, col, vis, o.position, _quaternion(o.yaw_deg))

    def move_obstacles(self, t: float) -> None:
        """Every moving obstacle to where its motion says at time t."""
        for name, o in self.moving.items():
            self._reset_base_pose(self.obstacles[name], centre_at(o, t)[0].tolist(), self._orientations[name])

    def obstacle_position(self, name: str) -> np.ndarray:
        """An obstacle's centre as PyBullet has it."""
        return np.array(self._base_pose(self.obstacles[name])[0])

    def box_pose(self) -> tuple[np.ndarray, float]:
        """The box's centre and yaw."""
        position, orientation = self._base_pose(self.box)
        return np.array(position), pybullet.getEulerFromQuaternion(orientation)[2]

    def box_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Box centre, its z axis in the world (upright: z axis ~ (0, 0, 1)) and its quaternion (x, y, z, w)."""
        position, orientation = self._base_pose(self.box)
        z_axis = np.array(pybullet.getMatrixFromQuaternion(orientation)[2::3])  # row-major 3x3
        return np.array(position), z_axis, np.array(orientation)

    def clearance(self, body: int, obstacle: str) -> float:
        """Smallest distance between any part of `body` and an obstacle (negative: penetration), up to FAR."""
        return min(map(_distance, self._closest_points(body, self.obstacles[obstacle], FAR)), default=FAR)

    def clearances(self, body: int) -> dict[str, float]:
        """`clearance` to every obstacle, by name."""
        return {name: self.clearance(body, name) for name in self.obstacles}
