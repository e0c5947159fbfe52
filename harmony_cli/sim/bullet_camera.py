"""PyBullet's camera for videos: TinyRenderer, placed as sim/video.py says."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from harmony_cli.sim.bullet_import import pybullet
from harmony_cli.sim.video import CAMERA_DISTANCE, CAMERA_FOV, CAMERA_PITCH, CAMERA_YAW, DEFAULT_TARGET


class BulletCamera:
    """A 3/4 view of a caller-owned DIRECT BulletClient (never disconnected here) by TinyRenderer, aimed at
    `follow()` (or `target`) for each frame."""

    def __init__(
        self,
        client,
        size: tuple[int, int] = (640, 480),
        follow: Callable[[], np.ndarray] | None = None,
        target: Sequence[float] = DEFAULT_TARGET,
    ):
        self.client, self.follow = client, follow
        self.width, self.height = size
        self.target = np.asarray(target, dtype=float)
        self.projection = client.computeProjectionMatrixFOV(
            fov=CAMERA_FOV, aspect=self.width / self.height, nearVal=0.05, farVal=50.0
        )

    def look_at(self) -> np.ndarray:
        """World point the camera is aimed at for the next frame."""
        return self.target if self.follow is None else np.asarray(self.follow(), dtype=float)[:3]

    def render(self) -> np.ndarray:
        """One (height, width, 3) uint8 RGB image of the current world state."""
        view = self.client.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=self.look_at().tolist(),
            distance=CAMERA_DISTANCE,
            yaw=CAMERA_YAW,
            pitch=CAMERA_PITCH,
            roll=0.0,
            upAxisIndex=2,
        )
        _, _, rgba, _, _ = self.client.getCameraImage(
            self.width, self.height, view, self.projection, renderer=pybullet.ER_TINY_RENDERER
        )
        return np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)[..., :3]
