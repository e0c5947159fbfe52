from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from conftest import needs_pybullet

from harmony_cli.sim.video import VideoRecorder, frame_every

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.bullet_camera import BulletCamera
except ImportError:
    pass

FRAMES, WIDTH, HEIGHT = 10, 160, 120


@pytest.fixture
def world():
    """Ground plane plus a red 1 m box that falls a little while recording."""
    client = BulletClient(connection_mode=pybullet.DIRECT)
    client.setGravity(0, 0, -9.81)
    client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_PLANE))
    box = client.createMultiBody(
        1.0,
        client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.5, 0.5, 0.5]),
        client.createVisualShape(pybullet.GEOM_BOX, halfExtents=[0.5, 0.5, 0.5], rgbaColor=[0.9, 0.1, 0.1, 1]),
        basePosition=[0, 0, 1.0],
    )
    yield client, box
    client.disconnect()


@needs_pybullet
@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_records_visible_frames(world, tmp_path, suffix):
    client, box = world

    def follow():
        return np.array(client.getBasePositionAndOrientation(box)[0])

    camera = BulletCamera(client, (WIDTH, HEIGHT), follow)
    with VideoRecorder(tmp_path / f"run{suffix}", camera.render, fps=25) as video:
        for _ in range(FRAMES):
            client.stepSimulation()
            video.capture()
    path = video.close()  # idempotent after the context manager closed it
    assert path == tmp_path / f"run{suffix}" and path.stat().st_size > 0
    assert client.isConnected()  # the caller still owns the client

    frames = iio.imread(path, index=None)
    assert frames.shape[:3] == (FRAMES, HEIGHT, WIDTH) and frames.shape[3] in (3, 4)
    assert all(frame[..., :3].astype(float).var() > 0 for frame in frames)


@needs_pybullet
def test_render_is_rgb_uint8_with_the_box_in_view(world):
    client, _ = world
    image = BulletCamera(client, (WIDTH, HEIGHT)).render()
    assert image.dtype == np.uint8 and image.shape == (HEIGHT, WIDTH, 3)
    red = (image[..., 0] > 150) & (image[..., 1] < 80) & (image[..., 2] < 80)
    assert red.sum() > 100  # the box, centred by the default target


@needs_pybullet
def test_unknown_suffix_names_path_and_choices(world, tmp_path):
    client, _ = world
    with pytest.raises(ValueError, match=r"run\.avi.*\.mp4, \.gif"):
        VideoRecorder(tmp_path / "run.avi", BulletCamera(client).render)


def test_frame_every():
    assert frame_every(0.02, 25) == 2
    assert frame_every(0.1, 25) == 1  # never fewer than one control step
    assert frame_every(0.001, 30) == 33


def test_mujoco_s_camera_renders_the_same_view_offscreen_with_the_box_in_it():
    import mujoco

    from harmony_cli.sim.mujoco_camera import MujocoCamera

    def scene(rgba: str) -> mujoco.MjModel:
        box = f'<geom type="box" size=".5 .5 .5" pos="0 0 1" rgba="{rgba}"/>'
        return mujoco.MjModel.from_xml_string(
            f'<mujoco><worldbody><geom type="plane" size="0 0 1"/>{box}</worldbody></mujoco>'
        )

    red, model = [], None
    for rgba in ("0.9 0.1 0.1 1", "0.9 0.1 0.1 0"):  # the box, then the same scene without it
        model = scene(rgba)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        image = MujocoCamera(model, data, (WIDTH, HEIGHT), lambda: np.array([0.0, 0.0, 0.5])).render()
        assert image.dtype == np.uint8 and image.shape == (HEIGHT, WIDTH, 3)
        red.append(((image[..., 0] > 120) & (image[..., 1] < 80) & (image[..., 2] < 80)).sum())
    assert red[0] > 100 and red[1] == 0
