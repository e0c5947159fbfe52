"""Record a headless simulation to an .mp4 or .gif, one frame of an engine's camera per capture(); the camera's
placement (a 3/4 view following the base) is shared by the engines, whose cameras are bullet_camera.py (PyBullet's
TinyRenderer) and mujoco_camera.py. No engine is imported here."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

VIDEO_SUFFIXES = (".mp4", ".gif")
CAMERA_DISTANCE = 4.5  # m from the look-at point
CAMERA_YAW = -50.0  # deg
CAMERA_PITCH = -35.0  # deg, negative looks down
CAMERA_FOV = 60.0  # deg, vertical
DEFAULT_TARGET = (0.0, 0.0, 0.5)  # world xyz looked at when nothing is followed


def frame_every(control_dt: float, fps: float) -> int:
    """Control steps between two captures so the video runs at about `fps` in simulated time."""
    if control_dt <= 0 or fps <= 0:
        raise ValueError(f"control_dt and fps must be positive, got {control_dt=} {fps=}")
    return max(1, round(1.0 / (fps * control_dt)))


def _open_writer(path: Path, fps: float):
    import imageio.v2 as imageio  # only when a video is recorded

    if path.suffix.lower() == ".mp4":
        # macro_block_size=2: libx264/yuv420p needs even sides; imageio scales odd ones up by a pixel.
        return imageio.get_writer(
            path, format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=7, macro_block_size=2
        )
    # Pillow can only save a whole animated GIF at close, so frames wait there: bits=8 keeps each
    # one as a 256-colour palette image (1 byte/pixel). Duration is per frame in ms; loop=0 repeats.
    return imageio.get_writer(path, format="pillow", mode="I", duration=1000.0 / fps, loop=0, bits=8)


class VideoRecorder:
    """Appends one frame of `render()` (an engine's camera) per capture() to `path`, .mp4 or .gif."""

    def __init__(self, path: Path, render: Callable[[], np.ndarray], fps: float = 25.0):
        self.path = Path(path)
        if self.path.suffix.lower() not in VIDEO_SUFFIXES:
            raise ValueError(f"cannot record video to {self.path}: suffix must be one of {', '.join(VIDEO_SUFFIXES)}")
        self.render, self.fps = render, fps
        self.frames = 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = _open_writer(self.path, fps)

    def capture(self) -> None:
        """Render the current state and append it to the video."""
        if self._writer is None:
            raise RuntimeError(f"video {self.path} is already closed")
        self._writer.append_data(self.render())
        self.frames += 1

    def close(self) -> Path:
        """Finish the file (idempotent) and return its path; without frames it may be missing or empty."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()
        return self.path

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
