"""prepare_urdf: a virtual planar base is added when missing, package:// meshes become absolute paths."""

from __future__ import annotations

from pathlib import Path

import casadi
import numpy as np
import optas
import pytest
from conftest import needs_pybullet

from harmony_cli.robot.prepare import UrdfPlan, prepare_urdf
from harmony_cli.robot.urdf import actuated_joint_names

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass

ROOT = Path(__file__).resolve().parents[1]
TWIN_ARM = ROOT / "harmony_cli/robot/presets/twin_arm.urdf"
EVA = ROOT / "harmony_cli/robot/presets/eva.urdf"
BASE = ("base_x", "base_y", "base_yaw")
ARM_JOINTS = [
    f"{side}_{name}"
    for side in "lr"
    for name in ("shoulder_pitch", "shoulder_roll", "elbow", "wrist_pitch", "wrist_yaw")
]
GRASPS = ("l_grasp", "r_grasp")
HAND_MESH_URI = "package://twin_arm_meshes/meshes/hand.stl"
TETRAHEDRON_STL = """solid tetrahedron
facet normal 0 0 -1
 outer loop
  vertex 0 0 0
  vertex 0.05 0 0
  vertex 0 0.05 0
 endloop
endfacet
facet normal 0 -1 0
 outer loop
  vertex 0 0 0
  vertex 0 0 0.05
  vertex 0.05 0 0
 endloop
endfacet
facet normal -1 0 0
 outer loop
  vertex 0 0 0
  vertex 0 0.05 0
  vertex 0 0 0.05
 endloop
endfacet
facet normal 0.577 0.577 0.577
 outer loop
  vertex 0.05 0 0
  vertex 0 0 0.05
  vertex 0 0.05 0
 endloop
endfacet
endsolid tetrahedron
"""


def _prepare(urdf: Path, package_paths: list[Path], cache: Path) -> Path:
    return prepare_urdf(urdf, UrdfPlan(BASE, tuple(package_paths)), cache).path


@pytest.fixture
def bullet():
    client = BulletClient(pybullet.DIRECT)
    yield client
    client.disconnect()


def _link_indices(client, body) -> dict[str, int]:
    """PyBullet link name -> link index (the index of the joint whose child it is)."""
    return {client.getJointInfo(body, i)[12].decode(): i for i in range(client.getNumJoints(body))}


def _joint_indices(client, body) -> dict[str, int]:
    return {client.getJointInfo(body, i)[1].decode(): i for i in range(client.getNumJoints(body))}


def _optas_position(model, link: str, q: np.ndarray) -> np.ndarray:
    return np.array(casadi.DM(model.get_global_link_position(link, q))).ravel()


def _twin_arm_with_mesh(tmp_path: Path) -> Path:
    """A copy of twin_arm whose left hand visual is a package:// mesh."""
    text = TWIN_ARM.read_text()
    hand_geometry = '<geometry><cylinder radius="0.035" length="0.04"/></geometry>'
    assert hand_geometry in text
    text = text.replace(hand_geometry, f'<geometry><mesh filename="{HAND_MESH_URI}"/></geometry>', 1)
    copy = tmp_path / "twin_arm_mesh.urdf"
    copy.write_text(text)
    return copy


def test_twin_arm_gets_the_virtual_base_first(tmp_path):
    out = _prepare(TWIN_ARM, [], tmp_path)
    assert out.parent == tmp_path and out != TWIN_ARM
    assert actuated_joint_names(TWIN_ARM) == ARM_JOINTS
    assert actuated_joint_names(out) == [*BASE, *ARM_JOINTS]
    model = optas.RobotModel(urdf_filename=str(out), time_derivs=[0])
    assert model.actuated_joint_names == [*BASE, *ARM_JOINTS]


@needs_pybullet
def test_optas_and_pybullet_agree_on_the_grasp_frames(tmp_path, bullet, rng):
    out = _prepare(TWIN_ARM, [], tmp_path)
    model = optas.RobotModel(urdf_filename=str(out), time_derivs=[0])
    body = bullet.loadURDF(str(out), useFixedBase=True)
    joints = [_joint_indices(bullet, body)[name] for name in model.actuated_joint_names]
    links = _link_indices(bullet, body)
    lower = np.array(model.lower_actuated_joint_limits).ravel().clip(-2.0, 2.0)
    upper = np.array(model.upper_actuated_joint_limits).ravel().clip(-2.0, 2.0)
    for q in rng.uniform(lower, upper, size=(20, model.ndof)):
        for index, value in zip(joints, q):
            bullet.resetJointState(body, index, value)
        for grasp in GRASPS:
            in_bullet = bullet.getLinkState(body, links[grasp], computeForwardKinematics=True)[4]
            np.testing.assert_allclose(_optas_position(model, grasp, q), in_bullet, atol=1e-6)


def test_home_grasp_frames_face_each_other_and_ride_on_base_x(tmp_path):
    model = optas.RobotModel(urdf_filename=str(_prepare(TWIN_ARM, [], tmp_path)), time_derivs=[0])
    home = np.zeros(model.ndof)
    left, right = (_optas_position(model, grasp, home) for grasp in GRASPS)
    assert 0.6 <= left[0] <= 0.7 and 0.9 <= left[2] <= 1.0 and left[1] == pytest.approx(0.15, abs=0.02)
    np.testing.assert_allclose(right, left * [1, -1, 1], atol=1e-12)
    left_normal = np.array(casadi.DM(model.get_global_link_rotation("l_grasp", home)))[:, 2]
    right_normal = np.array(casadi.DM(model.get_global_link_rotation("r_grasp", home)))[:, 2]
    np.testing.assert_allclose(left_normal, [0, -1, 0], atol=1e-9)
    np.testing.assert_allclose(right_normal, [0, 1, 0], atol=1e-9)
    moved = home.copy()
    moved[0] = 1.0
    for grasp in GRASPS:
        np.testing.assert_allclose(
            _optas_position(model, grasp, moved) - _optas_position(model, grasp, home), [1, 0, 0], atol=1e-12
        )


def test_arms_move_the_hands_in_every_direction_at_home(tmp_path):
    model = optas.RobotModel(urdf_filename=str(_prepare(TWIN_ARM, [], tmp_path)), time_derivs=[0])
    home = np.zeros(model.ndof)
    for side in "lr":
        jacobian = np.array(casadi.DM(model.get_global_link_geometric_jacobian(f"{side}_grasp", home)))
        arm = [model.actuated_joint_names.index(name) for name in ARM_JOINTS if name.startswith(side)]
        assert np.linalg.svd(jacobian[:3, arm], compute_uv=False).min() > 0.05


def test_a_urdf_that_already_has_the_base_comes_back_unchanged(tmp_path):
    assert _prepare(EVA, [], tmp_path) == EVA
    assert list(tmp_path.iterdir()) == []


def test_a_partial_virtual_base_is_rejected_naming_the_missing_joints(tmp_path):
    partial = tmp_path / "partial.urdf"
    partial.write_text("""<?xml version="1.0"?>
<robot name="partial">
  <link name="world"/>
  <link name="body"/>
  <joint name="base_x" type="prismatic">
    <parent link="world"/><child link="body"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
""")
    with pytest.raises(ValueError, match="base_y") as error:
        _prepare(partial, [], tmp_path / "cache")
    assert "base_yaw" in str(error.value) and "partial.urdf" in str(error.value)


@needs_pybullet
def test_package_meshes_resolve_against_the_search_paths(tmp_path, bullet):
    stl = tmp_path / "search/twin_arm_meshes/meshes/hand.stl"
    stl.parent.mkdir(parents=True)
    stl.write_text(TETRAHEDRON_STL)
    source = _twin_arm_with_mesh(tmp_path)
    out = _prepare(source, [tmp_path / "elsewhere", tmp_path / "search"], tmp_path / "cache")
    text = out.read_text()
    assert HAND_MESH_URI not in text and f'filename="{stl.resolve()}"' in text
    body = bullet.loadURDF(str(out), useFixedBase=True)
    assert bullet.getNumJoints(body) == len(_link_indices(bullet, body)) == 18


def test_a_package_search_path_may_point_inside_the_package(tmp_path):
    stl = tmp_path / "twin_arm_meshes/meshes/hand.stl"
    stl.parent.mkdir(parents=True)
    stl.write_text(TETRAHEDRON_STL)
    out = _prepare(_twin_arm_with_mesh(tmp_path), [tmp_path / "twin_arm_meshes"], tmp_path / "cache")
    assert f'filename="{stl.resolve()}"' in out.read_text()


def test_an_unresolvable_package_mesh_names_the_uri(tmp_path):
    with pytest.raises(FileNotFoundError, match=HAND_MESH_URI):
        _prepare(_twin_arm_with_mesh(tmp_path), [], tmp_path / "cache")


def test_relative_mesh_filenames_become_absolute(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes/hand.stl").write_text(TETRAHEDRON_STL)
    source = _twin_arm_with_mesh(tmp_path)
    source.write_text(source.read_text().replace(HAND_MESH_URI, "meshes/hand.stl"))
    out = _prepare(source, [], tmp_path / "cache")
    assert f'filename="{(tmp_path / "meshes/hand.stl").resolve()}"' in out.read_text()


def test_the_cache_is_keyed_by_content(tmp_path):
    first = _prepare(TWIN_ARM, [], tmp_path)
    second = _prepare(TWIN_ARM, [], tmp_path)
    assert first == second and first.name.startswith("twin_arm_") and len(first.stem) == len("twin_arm_") + 16
    assert [path.name for path in tmp_path.iterdir()] == [first.name]  # no temp files left behind
