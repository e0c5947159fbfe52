"""`harmony view RUN_DIR --video out.mp4`: a run's video rendered after the fact from its logs, so a video need not
be asked for before the run. The logged states (joints, box pose, moving obstacles) are put into a world built as
the run's, in the engine the run used (PyBullet: sim/world.py, drawn by TinyRenderer; MuJoCo: the run's model, drawn
by MuJoCo's renderer), seen by the camera of `harmony run --video`; no physics runs, so the frames show exactly what
was logged."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from harmony_cli.sim.video import VideoRecorder, frame_every
from harmony_cli.view.run_data import RunData

FPS, SIZE = 10.0, (480, 360)  # as `harmony run --video` records
Scene = tuple[Callable[[], np.ndarray], Callable[[int], None]]  # render a frame; put step i's logged state in place


def render_video(run: RunData, path: Path, fps: float = FPS, size: tuple[int, int] = SIZE) -> Path:
    """Every 1 / fps simulated seconds of `run` as one frame of `path` (.mp4 or .gif)."""
    x, y = run.base_xy()
    shown = [0]  # the step being drawn: the camera follows its base
    follow = lambda: np.array([x[shown[0]], y[shown[0]], 0.6])
    scene = _mujoco_scene if run.scenario.sim.engine == "mujoco" else _bullet_scene
    with scene(run, size, follow) as (render, show), VideoRecorder(path, render, fps=fps) as video:
        for i in range(0, len(run.times), frame_every(run.control_dt, fps)):
            shown[0] = i
            show(i)
            video.capture()
    return path


@contextmanager
def _bullet_scene(run: RunData, size: tuple[int, int], follow: Callable[[], np.ndarray]) -> Iterator[Scene]:
    from harmony_cli.capture import captured_output
    from harmony_cli.sim.bullet_camera import BulletCamera
    from harmony_cli.sim.bullet_import import BulletClient, pybullet
    from harmony_cli.sim.world import World

    with captured_output():  # PyBullet's C banner
        client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_PLANE))
        body = client.loadURDF(str(run.urdf), useFixedBase=True)
        joints = {client.getJointInfo(body, j)[1].decode(): j for j in range(client.getNumJoints(body))}
        world = World(client, run.scenario.world)
        box_pose = run.arrays.get("box_pose")

        def show(i: int) -> None:
            for name, value in run.joints(i).items():
                if name in joints:
                    client.resetJointState(body, joints[name], value)
            if world.box is not None and box_pose is not None and i < len(box_pose):
                client.resetBasePositionAndOrientation(world.box, box_pose[i, :3], box_pose[i, 3:])
            world.move_obstacles(float(run.times[i]))

        yield BulletCamera(client, size, follow).render, show
    finally:
        client.disconnect()


@contextmanager
def _mujoco_scene(run: RunData, size: tuple[int, int], follow: Callable[[], np.ndarray]) -> Iterator[Scene]:
    from harmony_cli.scenario import robot_of
    from harmony_cli.sim.mujoco_sim import MujocoSimulation

    scenario = run.scenario
    sim = MujocoSimulation(robot_of(scenario, run.path), scenario.sim, scenario.world)
    box_pose = run.arrays.get("box_pose")

    def show(i: int) -> None:
        sim.show(run.joints(i), None if box_pose is None or i >= len(box_pose) else box_pose[i], float(run.times[i]))

    try:
        yield sim.camera(size, follow), show
    finally:
        sim.close()
