"""`robot.mount: auto` (the default): a robot whose URDF puts part of it below the floor stands on the ground, its
lowest collision point at home measured again by PyBullet after loading; an explicit mount wins; a robot already
on the ground keeps its URDF's placement; the run's resolved scenario records the height used."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import needs_pybullet
from scipy.spatial.transform import Rotation

from harmony_cli.experiment.run_dir import write_inputs
from harmony_cli.robot.ground import lowest_point
from harmony_cli.scenario import load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.world import BODY_FLAGS
except ImportError:
    pass

RESTING_M = 1e-3  # the bound: the lowest point within 1 mm of the ground
INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'


def _revolute(name: str, parent: str, child: str, xyz: str) -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="50" velocity="2"/></joint>'
    )


def pedestal_urdf(path: Path) -> Path:
    """A two-armed robot whose root link is the top of its 0.9 m pedestal, with a strut on a revolute joint ending
    in a foot (a sphere) that reaches below the pedestal only as far as the strut's angle lets it."""
    parts = [
        '<robot name="pedestal_robot">',
        f'<link name="pedestal">{INERTIAL}<collision><origin xyz="0 0 -0.45"/>'
        '<geometry><box size="0.4 0.4 0.9"/></geometry></collision></link>',
        f'<link name="strut">{INERTIAL}<collision><origin xyz="0 0 -0.5"/>'
        '<geometry><sphere radius="0.1"/></geometry></collision></link>',
        _revolute("stand", "pedestal", "strut", "0.3 0 -0.5"),
    ]
    for side, y in (("l", 0.2), ("r", -0.2)):
        parts += [
            f'<link name="{side}_arm">{INERTIAL}<collision><origin xyz="0.15 0 0"/>'
            '<geometry><box size="0.3 0.05 0.05"/></geometry></collision></link>',
            _revolute(f"{side}_shoulder", "pedestal", f"{side}_arm", f"0 {y} 0.3"),
            f'<link name="{side}_forearm">{INERTIAL}</link>',
            _revolute(f"{side}_wrist", f"{side}_arm", f"{side}_forearm", "0.3 0 0"),
            f'<link name="{side}_hand"/><joint name="{side}_hand_joint" type="fixed"><parent link="{side}_forearm"/>'
            f'<child link="{side}_hand"/><origin xyz="0.05 0 0"/></joint>',
        ]
    path.write_text("\n".join(parts + ["</robot>"]))
    return path


def _scenario(tmp_path: Path, mount: str | None = None) -> Path:
    """A hold scenario of the pedestal robot, its strut turned at home; `mount`: the field's YAML (None: unset)."""
    pedestal_urdf(tmp_path / "pedestal.urdf")
    robot = {"urdf": "pedestal.urdf", "end_effectors": {"left": "l_hand", "right": "r_hand"}, "home": {"stand": 30}}
    if mount is not None:
        robot["mount"] = yaml.safe_load(mount)
    path = tmp_path / "pedestal.yaml"
    path.write_text(yaml.safe_dump({"name": "pedestal", "robot": robot, "reference": {"type": "hold"}}))
    return path


def _pybullet_lowest(robot) -> float:
    """The robot's lowest point as PyBullet finds it: its signed distance to a ground plane, the prepared URDF
    loaded as the simulator loads it and posed at home."""
    client = BulletClient(pybullet.DIRECT)
    try:
        ground = client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_PLANE))
        body = client.loadURDF(str(robot.urdf), useFixedBase=True, flags=BODY_FLAGS)
        joints = {client.getJointInfo(body, i)[1].decode(): i for i in range(client.getNumJoints(body))}
        for name, value in zip(robot.joint_names, robot.home):
            client.resetJointState(body, joints[name], value)
        links = range(-1, client.getNumJoints(body))
        return min(p[8] for link in links for p in client.getClosestPoints(body, ground, 10.0, linkIndexA=link))
    finally:
        client.disconnect()


@needs_pybullet
def test_mount_auto_rests_the_lowest_collision_point_at_home_on_the_ground(tmp_path):
    path = _scenario(tmp_path)
    robot = robot_of(load_scenario(path), tmp_path)
    assert robot.mount is not None and robot.mount[0][2] > 0.9  # the pedestal alone reaches 0.9 m down
    assert abs(_pybullet_lowest(robot)) <= RESTING_M


def test_a_mesh_s_lowest_point_is_its_lowest_vertex_with_its_scale_and_pose(tmp_path):
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2), (3, 4, 8), (3, 8, 7)]
    faces += [(1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]
    mesh = tmp_path / "cube.obj"
    lines = [f"v {x} {y} {z}" for x, y, z in corners] + [f"f {a} {b} {c}" for a, b, c in faces]
    mesh.write_text("\n".join(lines) + "\n")
    rpy, xyz, scale = (0.4, -0.7, 0.2), (0.1, 0.0, -0.3), (0.2, 0.1, 0.6)
    urdf = (
        f'<robot name="cube"><link name="block"><collision><origin xyz="{" ".join(map(str, xyz))}" '
        f'rpy="{" ".join(map(str, rpy))}"/><geometry><mesh filename="{mesh}" scale="{" ".join(map(str, scale))}"/>'
        "</geometry></collision></link></robot>"
    )
    placed = corners * scale @ Rotation.from_euler("xyz", rpy).as_matrix().T + xyz
    lowest = lowest_point(ET.fromstring(urdf), {})
    assert lowest.link == "block" and lowest.z == pytest.approx(placed[:, 2].min(), abs=1e-6)


@needs_pybullet
def test_an_explicit_mount_wins_over_auto(tmp_path):
    path = _scenario(tmp_path, "{xyz: [0, 0, 1.5], rpy_deg: [0, 0, 0]}")
    robot = robot_of(load_scenario(path), tmp_path)
    assert robot.mount == ([0.0, 0.0, 1.5], [0.0, 0.0, 0.0])
    foot = 0.5 + 0.5 * np.cos(np.deg2rad(30)) + 0.1  # the sphere's bottom below the root at home
    assert _pybullet_lowest(robot) == pytest.approx(1.5 - foot, abs=1e-6)


@pytest.mark.parametrize("preset", ["twin_arm", "pr2"])
def test_a_robot_not_below_the_ground_keeps_its_urdf_placement(tmp_path, preset):
    path = tmp_path / "robot.yaml"
    path.write_text(f"name: x\nrobot: {{preset: {preset}}}\nreference: {{type: hold}}\n")
    auto = robot_of(load_scenario(path), tmp_path)
    placed = robot_of(load_scenario(path, ["robot.mount=null"]), tmp_path)
    assert auto.mount is None and auto.urdf == placed.urdf


def test_the_resolved_scenario_records_the_height_auto_chose(tmp_path):
    path = _scenario(tmp_path)
    scenario = load_scenario(path)
    write_inputs(tmp_path / "run", path, [], scenario)
    resolved = tmp_path / "run" / "scenario.resolved.yaml"
    height = robot_of(scenario, tmp_path).mount[0][2]
    assert yaml.safe_load(resolved.read_text())["robot"]["mount"] == {"xyz": [0, 0, height], "rpy_deg": [0, 0, 0]}
    assert robot_of(load_scenario(resolved), resolved.parent).urdf == robot_of(scenario, tmp_path).urdf
