"""MuJoCo's camera for videos: the 3/4 view of sim/video.py (distance, yaw, pitch, field of view) rendered by
MuJoCo's own renderer, offscreen through EGL (sim/__init__.py selects it before MuJoCo is imported)."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from harmony_cli.sim.video import CAMERA_DISTANCE, CAMERA_FOV, CAMERA_PITCH, CAMERA_YAW

# PyBullet's camera yaw turns the view about z from looking along +y; MuJoCo's azimuth from looking along +x
AZIMUTH_OF_YAW = 90.0
HEADLIGHT = ([0.45] * 3, [0.6] * 3)  # ambient, diffuse: about TinyRenderer's brightness


class MujocoCamera:
    """Renders `data` as it is now, aimed at `follow()`."""

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, size: tuple[int, int], follow: Callable[[], np.ndarray]
    ):
        width, height = size
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        model.vis.global_.fovy = CAMERA_FOV
        model.vis.headlight.ambient, model.vis.headlight.diffuse = HEADLIGHT  # the scene has no lights of its own
        self.data, self.follow = data, follow
        self.renderer = mujoco.Renderer(model, height, width)
        self.view = mujoco.MjvCamera()
        self.view.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.view.distance, self.view.elevation = CAMERA_DISTANCE, CAMERA_PITCH
        self.view.azimuth = CAMERA_YAW + AZIMUTH_OF_YAW

    def render(self) -> np.ndarray:
        """One (height, width, 3) uint8 RGB image."""
        self.view.lookat[:] = np.asarray(self.follow(), dtype=float)[:3]
        self.renderer.update_scene(self.data, self.view)
        return self.renderer.render()
