"""Each robot preset's trunk circles (robot.trunk) cover the URDF's trunk links as PyBullet sees their collision
shapes at home, at their heights: what the stance search and the scene check keep out from under table tops."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import needs_pybullet

from harmony_cli.scenario import load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass
pytestmark = needs_pybullet  # every test here checks against PyBullet

SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "robots" / "s_shape.yaml"
TRUNKS = {  # the links each preset's trunk covers (its comments name them)
    "eva": ["WAIST", "CHEST"],
    "pr2": ["torso_lift_link"],
    "tiago_dual": ["torso_lift_link"],
    "baxter": ["torso"],
    "twin_arm": ["torso"],
}


@pytest.mark.parametrize("preset", sorted(TRUNKS))
def test_the_trunk_circles_cover_the_trunk_links_bounding_boxes_and_span_their_heights(preset):
    scenario = load_scenario(SCENE, [f"robot.preset={preset}"])
    robot = robot_of(scenario, SCENE.parent)
    client = BulletClient(connection_mode=pybullet.DIRECT)
    body = client.loadURDF(str(robot.urdf), useFixedBase=True)
    joints = {client.getJointInfo(body, i)[1].decode(): i for i in range(client.getNumJoints(body))}
    links = {client.getJointInfo(body, i)[12].decode(): i for i in range(client.getNumJoints(body))}
    home = robot.home.copy()
    home[list(robot.base_joints)] = 0.0
    for j, name in enumerate(robot.joint_names):
        client.resetJointState(body, joints[name], home[j])
    circles = np.array(scenario.robot.trunk)
    for link in TRUNKS[preset]:
        lo, hi = (np.array(v) for v in client.getAABB(body, links[link]))
        centre, half = (lo + hi)[:2] / 2, (hi - lo)[:2] / 2
        # the box's edge midpoints: a shape's extreme points along x and y (a cylinder's too) lie on them
        extremes = centre + np.array([[half[0], 0], [-half[0], 0], [0, half[1]], [0, -half[1]]])
        heights = circles[:, 3] <= lo[2] + 0.01  # the circles that reach down to the link's bottom...
        heights &= circles[:, 4] >= hi[2] - 0.01  # ...and up to its top
        assert heights.any(), (link, lo[2], hi[2])
        gaps = np.linalg.norm(extremes[:, None] - circles[None, heights, :2], axis=2) - circles[None, heights, 2]
        assert gaps.min(axis=1).max() <= 0.0025, (link, gaps)  # PyBullet pads its boxes by a 2 mm margin
    client.disconnect()
