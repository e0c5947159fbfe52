"""One run drawn in a viser scene under /run<k>: the robot from its URDF meshes, tables, box and obstacles, the
reference and measured hand paths (whole run), and at the shown step the planner's plan, the whole-body MPC's
knots, the wrist and push forces. `show(i)` moves everything to step i; the first run keeps the URDF's colours, the
others are tinted and translucent so overlaid runs tell apart."""

from __future__ import annotations

import numpy as np
import viser
import yourdfpy
from viser.extras import ViserUrdf

from harmony_cli.maths.bezier import evaluate
from harmony_cli.maths.shapes import table_legs
from harmony_cli.view.run_data import RunData

TINTS = [None, (0.25, 0.55, 1.0, 0.55), (0.2, 0.8, 0.3, 0.55), (0.9, 0.5, 0.1, 0.55)]  # robot colour per run
REF, MEAS, PLAN, KNOTS, FORCE = (40, 160, 40), (30, 90, 230), (230, 140, 0), (200, 0, 200), (220, 30, 30)
FORCE_SCALE = 0.01  # [m/N] of a force arrow
PLAN_SAMPLES = 30


def _wxyz(yaw_deg: float) -> np.ndarray:
    half = np.deg2rad(yaw_deg) / 2
    return np.array([np.cos(half), 0.0, 0.0, np.sin(half)])


def _path(points: np.ndarray) -> np.ndarray:
    """Consecutive points as (n - 1, 2, 3) segments (NaN rows dropped)."""
    points = points[np.isfinite(points).all(axis=1)]
    return np.stack([points[:-1], points[1:]], axis=1) if len(points) > 1 else np.zeros((0, 2, 3))


class RunScene:
    """A run's objects in the scene, moved by `show`."""

    def __init__(self, server: viser.ViserServer, run: RunData, k: int):
        self.server, self.run, self.root = server, run, f"/run{k}"
        tint = TINTS[k % len(TINTS)]
        self.urdf = yourdfpy.URDF.load(str(run.urdf), load_meshes=True, build_scene_graph=True)
        self.robot = ViserUrdf(server, self.urdf, root_node_name=f"{self.root}/robot", mesh_color_override=tint)
        self.fk = yourdfpy.URDF.load(str(run.urdf), load_meshes=False, build_scene_graph=True)  # for the knots
        self.names = self.robot.get_actuated_joint_names()
        self.grasp = [run.scenario.robot.end_effectors[h] for h in run.hands]
        self.joint_names = [c[2:] for c in run.steps.columns if c.startswith("q_")]  # knot_q's columns
        self.opacity = None if tint is None else 0.6
        self._world()
        self._paths()

    def _world(self) -> None:
        s, world, root = self.server.scene, self.run.scenario.world, self.root
        for t in world.tables if root == "/run0" else []:  # one scene's tables: drawn once
            colour = (140, 115, 90)
            top = (*t.position, t.height - t.thickness / 2)
            s.add_box(f"/tables/{t.name}/top", colour, (*t.top, t.thickness), position=top, wxyz=_wxyz(t.yaw_deg))
            for j, leg in enumerate(table_legs(t)):
                s.add_box(f"/tables/{t.name}/leg{j}", colour, 2 * leg.half, position=leg.centre, wxyz=_wxyz(t.yaw_deg))
        self.box = None
        if world.box is not None:
            b = world.box
            self.box = s.add_box(
                f"{root}/box", (215, 150, 75), b.size, opacity=self.opacity, position=b.position, wxyz=_wxyz(b.yaw_deg)
            )
        self.obstacles: dict[str, viser.SceneNodeHandle] = {}
        for o in world.obstacles:
            name, colour, at, alpha = f"{root}/obstacles/{o.name}", (180, 50, 50), o.position, self.opacity
            if o.shape == "box":
                handle: viser.SceneNodeHandle = s.add_box(
                    name, colour, o.size, opacity=alpha, wxyz=_wxyz(o.yaw_deg), position=at
                )
            elif o.shape == "cylinder":
                handle = s.add_cylinder(name, o.size[0] / 2, o.size[2], colour, opacity=alpha, position=at)
            else:
                handle = s.add_icosphere(name, o.size[0] / 2, colour, opacity=alpha, position=at)
            self.obstacles[o.name] = handle

    def _paths(self) -> None:
        run = self.run
        for hand in run.hands:
            for kind, colour in (("ref", REF), ("meas", MEAS)):
                xyz = np.stack([run.column(f"{hand}_{kind}_{a}") for a in "xyz"], axis=1)
                self.server.scene.add_line_segments(
                    f"{self.root}/paths/{hand}_{kind}", _path(xyz), colour, thickness=0.008
                )

    def show(self, i: int) -> None:
        """Everything at step i."""
        run, row = self.run, self.run.steps.iloc[i]
        joints = run.joints(i)
        cfg = np.array([joints.get(name, 0.0) for name in self.names])
        self.robot.update_cfg(cfg)
        if self.box is not None:
            pose = run.arrays.get("box_pose")
            if pose is not None and i < len(pose):
                self.box.position, q = pose[i, :3], pose[i, 3:]
                self.box.wxyz = np.array([q[3], q[0], q[1], q[2]])
            elif "box_x" in row and np.isfinite(row["box_x"]):
                self.box.position = np.array([row["box_x"], row["box_y"], row["box_z"]])
        for name, handle in self.obstacles.items():
            if f"obstacle_{name}_x" in row:
                handle.position = np.array([row[f"obstacle_{name}_{a}"] for a in "xyz"])
        self._plan(i)
        self._knots(i)
        self._forces(row)

    def _plan(self, i: int) -> None:
        """The planner's plan at step i, sampled from its control points over its horizon."""
        points, span = self.run.arrays.get("plan_points"), self.run.arrays.get("plan_span")
        if points is None or span is None or i >= len(points):
            return
        start, horizon = span[i]
        now = np.clip((self.run.times[i] - start) / horizon, 0.0, 1.0)  # what is left of the plan
        values = evaluate(points[i], np.linspace(now, 1.0, PLAN_SAMPLES))  # (7, samples): hands' xyz, heading
        segments = np.concatenate([_path(values[3 * h : 3 * h + 3].T) for h in range(2)])
        self.server.scene.add_line_segments(f"{self.root}/plan", segments, PLAN, thickness=0.012)

    def _knots(self, i: int) -> None:
        """The hands at the whole-body MPC's knots (forward kinematics of q at each knot)."""
        knot_q = self.run.arrays.get("knot_q")
        if knot_q is None or i >= len(knot_q):
            return
        points = []
        for q in knot_q[i]:
            joints = dict(zip(self.joint_names, q.astype(float)))
            self.fk.update_cfg(np.array([joints.get(n, 0.0) for n in self.fk.actuated_joint_names]))
            points += [self.fk.get_transform(link)[:3, 3] for link in self.grasp]
        self.server.scene.add_point_cloud(
            f"{self.root}/knots", np.array(points), KNOTS, point_size=0.035, point_shape="circle"
        )

    def _forces(self, row) -> None:
        """Each wrist's sensed force (grasp frame, rotated to the world) from its hand, and each push acting now
        (its world force, ending at the pushed body), as arrows."""
        arrows = []
        for hand, link in zip(self.run.hands, self.grasp):
            force = np.array([row.get(f"{hand}_force_{a}_N", np.nan) for a in "xyz"], dtype=float)
            if np.isfinite(force).all() and np.linalg.norm(force) >= 1.0:
                pose = self.urdf.get_transform(link)
                arrows.append([pose[:3, 3], pose[:3, 3] + FORCE_SCALE * (pose[:3, :3] @ force)])
        for push in self.run.scenario.pushes:
            if abs(row.get(f"push_{push.name}_N", 0.0)) > 0:
                at = self._pushed_point(push)
                arrows.append([at - FORCE_SCALE * np.asarray(push.force), at])
        points = np.array(arrows) if arrows else np.zeros((0, 2, 3))
        self.server.scene.add_arrows(
            f"{self.root}/forces", points, FORCE, shaft_radius=0.012, head_radius=0.03, head_length=0.06
        )

    def _pushed_point(self, push) -> np.ndarray:
        """Where a push acts: its robot link's origin (the base's when none), the box's or the obstacle's centre."""
        if push.body == "robot":
            yaw = self.run.scenario.robot.base_joints[2]
            link = push.link or self.urdf.joint_map[yaw].child  # the base: the link its yaw joint moves
            return self.urdf.get_transform(link)[:3, 3]
        if push.body == "box" and self.box is not None:
            return np.asarray(self.box.position)
        handle = self.obstacles.get(push.body)
        return np.zeros(3) if handle is None else np.asarray(handle.position)
