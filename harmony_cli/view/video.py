"""`harmony view RUN_DIR --video out.mp4`: a run's video rendered after the fact from its logs, so a video need not
be asked for before the run. The logged states (joints, box pose, moving obstacles) are put into a PyBullet world
built as the run's (sim/world.py) and drawn by the same TinyRenderer camera as `harmony run --video`; no physics
runs, so the frames show exactly what was logged."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet
from pybullet_utils.bullet_client import BulletClient

from harmony_cli.capture import captured_output
from harmony_cli.sim.bullet_camera import BulletCamera
from harmony_cli.sim.video import VideoRecorder, frame_every
from harmony_cli.sim.world import World
from harmony_cli.view.run_data import RunData

FPS, SIZE = 10.0, (480, 360)  # as `harmony run --video` records


def render_video(run: RunData, path: Path, fps: float = FPS, size: tuple[int, int] = SIZE) -> Path:
    """Every 1 / fps simulated seconds of `run` as one frame of `path` (.mp4 or .gif)."""
    with captured_output():  # PyBullet's C banner
        client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_PLANE))
        body = client.loadURDF(str(run.urdf), useFixedBase=True)
        joints = {client.getJointInfo(body, j)[1].decode(): j for j in range(client.getNumJoints(body))}
        world = World(client, run.scenario.world)
        x, y = run.base_xy()
        box_pose = run.arrays.get("box_pose")
        dt = run.control_dt
        shown = [0]  # the step being drawn: the camera follows its base
        follow = lambda: np.array([x[shown[0]], y[shown[0]], 0.6])
        with VideoRecorder(path, BulletCamera(client, size, follow).render, fps=fps) as video:
            for i in range(0, len(run.times), frame_every(dt, fps)):
                shown[0] = i
                for name, value in run.joints(i).items():
                    if name in joints:
                        client.resetJointState(body, joints[name], value)
                if world.box is not None and box_pose is not None and i < len(box_pose):
                    client.resetBasePositionAndOrientation(world.box, box_pose[i, :3], box_pose[i, 3:])
                world.move_obstacles(float(run.times[i]))
                video.capture()
        return path
    finally:
        client.disconnect()
