"""URDF intake: each defect class robot packages ship, on a small synthetic dual-arm URDF, prepared and then read
by OpTaS, Pinocchio and PyBullet, which must agree with the original robot (locked where the scenario locks); what
no parser can read refused in one line."""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import casadi
import numpy as np
import optas
import pinocchio as pin
import pytest
from conftest import needs_pybullet
from typer.testing import CliRunner

import harmony_cli.robot.prepare as prepare_module
from harmony_cli.cli import app
from harmony_cli.robot.arm_points import arm_chains
from harmony_cli.robot.prepare import PYBULLET_MAX_JOINTS, UrdfPlan, prepare_urdf
from harmony_cli.robot.sanitize import CONTINUOUS_LIMIT, MASSLESS_LINK_MASS
from harmony_cli.robot.urdf import joints_and_links

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass

BASE = ("base_x", "base_y", "base_yaw")
ARMS = ("l_shoulder", "l_roll", "l_wrist", "r_shoulder", "r_roll", "r_wrist")


def _inertial(mass: float) -> str:
    return (
        f'<inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="{mass}"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
    )


def _joint(name, kind, parent, child, xyz="0 0 0.1", rpy="0 0 0", extra="") -> str:
    limit = '<limit lower="-2" upper="2" effort="50" velocity="2"/>' if kind in ("revolute", "prismatic") else ""
    if kind == "continuous":
        limit = '<limit effort="50" velocity="2"/>'
    axis = '<axis xyz="0 1 0"/>' if kind != "fixed" else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/>{axis}{limit}{extra}</joint>'
    )


def synthetic_urdf(path: Path, rack_links: int = 0) -> Path:
    """A torso with two 3-joint arms (shoulder revolute, forearm roll continuous, wrist revolute), a parallel
    gripper per hand (finger prismatic, the other finger mimicking it), a tool frame without <inertial>, a
    transmission without <type>, a gazebo element; `rack_links` fixed links chained on the torso."""
    parts = ['<robot name="synthetic">', f'<link name="torso">{_inertial(10)}</link>']
    for side, y in (("l", 0.2), ("r", -0.2)):
        names = [f"{side}_upper", f"{side}_fore", f"{side}_hand", f"{side}_finger_a", f"{side}_finger_b"]
        parts += [f'<link name="{n}">{_inertial(1.0)}</link>' for n in names]
        parts += [
            _joint(f"{side}_shoulder", "revolute", "torso", names[0], xyz=f"0 {y} 0.5"),
            _joint(f"{side}_roll", "continuous", names[0], names[1], rpy="0.3 0 0"),
            _joint(f"{side}_wrist", "revolute", names[1], names[2]),
            _joint(f"{side}_finger", "prismatic", names[2], names[3], xyz="0.02 0 0.05"),
            _joint(
                f"{side}_finger_mirror",
                "prismatic",
                names[2],
                names[4],
                xyz="-0.02 0 0.05",
                extra=f'<mimic joint="{side}_finger" multiplier="-1" offset="0.01"/>',
            ),
            f'<link name="{side}_tool"/>',
            _joint(f"{side}_tool_joint", "fixed", names[2], f"{side}_tool", xyz="0 0 0.12"),
            f'<transmission name="{side}_shoulder_trans"><joint name="{side}_shoulder"/></transmission>',
        ]
    parent = "torso"
    for i in range(rack_links):
        parts += [f'<link name="rack_{i}">{_inertial(0.1)}</link>']
        parts += [_joint(f"rack_{i}_joint", "fixed", parent, f"rack_{i}", xyz="0.01 0 0.01", rpy="0 0 0.1")]
        parent = f"rack_{i}"
    parts += ['<gazebo reference="torso"><material>Gazebo/Grey</material></gazebo>', "</robot>"]
    path.write_text("\n".join(parts))
    return path


PLAN = UrdfPlan(BASE, active=ARMS, home={"l_finger": 0.5, "r_finger": 0.5}, keep=("l_tool", "r_tool"))
FINGER = 0.5  # the finger joints are prismatic: home in metres


@pytest.fixture
def bullet():
    client = BulletClient(pybullet.DIRECT)
    yield client
    client.disconnect()


def _pin_frame(model, data, frame: str) -> np.ndarray:
    return data.oMf[model.getFrameId(frame)].translation.copy()


def _pin_config(model, values: dict[str, float]) -> np.ndarray:
    q = pin.neutral(model)
    for name, value in values.items():
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 2:  # Pinocchio's continuous joint: (cos, sin)
            q[joint.idx_q : joint.idx_q + 2] = np.cos(value), np.sin(value)
        else:
            q[joint.idx_q] = value
    return q


def test_optas_rejects_the_shipped_urdf_and_reads_the_prepared_one(tmp_path):
    urdf = synthetic_urdf(tmp_path / "robot.urdf")
    with pytest.raises(Exception, match="type"):
        optas.RobotModel(urdf_filename=str(urdf), time_derivs=[0])
    prepared = prepare_urdf(urdf, PLAN, tmp_path / "cache")
    assert prepared.dropped == {"transmission": 2, "gazebo": 1}
    model = optas.RobotModel(urdf_filename=str(prepared.path), time_derivs=[0])
    assert model.actuated_joint_names == [*BASE, *ARMS]


def test_continuous_joints_are_unbounded_in_the_mpc_model(tmp_path):
    prepared = prepare_urdf(synthetic_urdf(tmp_path / "robot.urdf"), PLAN, tmp_path / "cache")
    model = optas.RobotModel(urdf_filename=str(prepared.path), time_derivs=[0])
    lower = dict(zip(model.actuated_joint_names, np.array(model.lower_actuated_joint_limits).ravel(), strict=True))
    upper = dict(zip(model.actuated_joint_names, np.array(model.upper_actuated_joint_limits).ravel(), strict=True))
    assert prepared.continuous == ("l_roll", "r_roll")
    for joint in ("l_roll", "r_roll"):
        assert (lower[joint], upper[joint]) == (-CONTINUOUS_LIMIT, CONTINUOUS_LIMIT)
    assert (lower["l_shoulder"], upper["l_shoulder"]) == (-2.0, 2.0)


def test_a_continuous_home_wraps_and_a_revolute_home_outside_its_limits_is_refused(tmp_path):
    urdf = synthetic_urdf(tmp_path / "robot.urdf")
    wrapped = prepare_urdf(urdf, UrdfPlan(BASE, active=ARMS, home={"l_roll": -186.0}), tmp_path / "cache")
    assert wrapped.home["l_roll"] == pytest.approx(np.deg2rad(174.0))
    with pytest.raises(ValueError, match=r"robot.home.l_shoulder: 120 deg is outside the joint's limits \[-114.6"):
        prepare_urdf(urdf, UrdfPlan(BASE, active=ARMS, home={"l_shoulder": 120.0}), tmp_path / "cache")


@needs_pybullet
def test_links_without_inertia_weigh_the_documented_mass_in_pybullet_and_pinocchio(tmp_path, bullet):
    urdf = synthetic_urdf(tmp_path / "robot.urdf")
    shipped = bullet.loadURDF(str(urdf), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    names = {bullet.getJointInfo(shipped, i)[12].decode(): i for i in range(bullet.getNumJoints(shipped))}
    assert bullet.getDynamicsInfo(shipped, names["l_tool"])[0] == 1.0  # what PyBullet does without <inertial>
    prepared = prepare_urdf(urdf, PLAN, tmp_path / "cache")
    assert set(prepared.massless) >= {"l_tool", "r_tool"}
    body = bullet.loadURDF(str(prepared.path), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    names = {bullet.getJointInfo(body, i)[12].decode(): i for i in range(bullet.getNumJoints(body))}
    assert bullet.getDynamicsInfo(body, names["l_tool"])[0] == pytest.approx(MASSLESS_LINK_MASS)
    model = pin.buildModelFromUrdf(str(prepared.path))
    tool = model.frames[model.getFrameId("l_tool")]
    assert model.inertias[tool.parentJoint].mass == pytest.approx(1.0 + 2 * 1.0 + MASSLESS_LINK_MASS)


@needs_pybullet
def test_locked_joints_and_mimics_put_the_fingers_where_the_shipped_robot_has_them(tmp_path, bullet, rng):
    """The finger (locked at 0.5 m) and its mimic (-1 x 0.5 + 0.01) in the prepared URDF (PyBullet) sit where
    Pinocchio puts them in the shipped URDF with those joint values, at random arm configurations."""
    urdf = synthetic_urdf(tmp_path / "robot.urdf")
    prepared = prepare_urdf(urdf, PLAN, tmp_path / "cache")
    assert prepared.locked == {
        "l_finger": FINGER,
        "r_finger": FINGER,
        "l_finger_mirror": -0.49,
        "r_finger_mirror": -0.49,
    }
    shipped = pin.buildModelFromUrdf(str(urdf))
    data = shipped.createData()
    body = bullet.loadURDF(str(prepared.path), useFixedBase=True)
    joints = {bullet.getJointInfo(body, i)[1].decode(): i for i in range(bullet.getNumJoints(body))}
    links = {bullet.getJointInfo(body, i)[12].decode(): i for i in range(bullet.getNumJoints(body))}
    for q in rng.uniform(-1.5, 1.5, size=(5, len(ARMS))):
        values = dict(zip(ARMS, q, strict=True)) | prepared.locked
        pin.framesForwardKinematics(shipped, data, _pin_config(shipped, values))
        for name, value in zip(ARMS, q, strict=True):
            bullet.resetJointState(body, joints[name], value)
        for link in ("l_finger_a", "l_finger_b", "r_finger_b", "r_tool"):
            in_bullet = np.array(bullet.getLinkState(body, links[link], computeForwardKinematics=True)[4])
            np.testing.assert_allclose(in_bullet, _pin_frame(shipped, data, link), atol=1e-7)


@needs_pybullet
def test_more_links_than_pybullet_takes_merge_keeping_mass_and_hand_frames(tmp_path, bullet, monkeypatch):
    """Merged against the same robot prepared unmerged (Pinocchio reads both): same mass, centre of mass and hand
    frames; only the merged one fits PyBullet."""
    urdf = synthetic_urdf(tmp_path / "robot.urdf", rack_links=PYBULLET_MAX_JOINTS + 10)
    prepared = prepare_urdf(urdf, PLAN, tmp_path / "cache")
    assert len(prepared.merged) >= PYBULLET_MAX_JOINTS + 10
    body = bullet.loadURDF(str(prepared.path), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    assert bullet.getNumJoints(body) <= PYBULLET_MAX_JOINTS
    monkeypatch.setattr(prepare_module, "PYBULLET_MAX_JOINTS", 10**6)
    unmerged = prepare_urdf(urdf, PLAN, tmp_path / "cache")
    assert unmerged.merged == () and unmerged.path != prepared.path
    values = {"base_yaw": 0.3, "l_shoulder": 0.4, "l_roll": 1.0, "r_wrist": -0.7}
    outcomes = []
    for path in (unmerged.path, prepared.path):
        model = pin.buildModelFromUrdf(str(path))
        data, q = model.createData(), _pin_config(model, values)
        pin.framesForwardKinematics(model, data, q)
        frames = [_pin_frame(model, data, link) for link in ("l_tool", "r_tool")]
        outcomes.append((sum(i.mass for i in model.inertias), pin.centerOfMass(model, data, q), frames))
    (mass, com, frames), (merged_mass, merged_com, merged_frames) = outcomes
    assert merged_mass == pytest.approx(mass, abs=1e-9)
    np.testing.assert_allclose(merged_com, com, atol=1e-9)
    np.testing.assert_allclose(merged_frames, frames, atol=1e-9)


@needs_pybullet
def test_pinocchio_gravity_torques_match_pybullet_inverse_dynamics(tmp_path, bullet):
    from harmony_cli.robot.gravity import gravity_torques

    prepared = prepare_urdf(synthetic_urdf(tmp_path / "robot.urdf"), PLAN, tmp_path / "cache")
    names = (*BASE, *ARMS)
    q = np.array([0.0, 0.0, 0.0, 0.3, 0.5, -0.4, -0.2, 1.0, 0.6])
    torque, effort = gravity_torques(prepared.path, names, q)
    body = bullet.loadURDF(str(prepared.path), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    bullet.setGravity(0, 0, -9.81)
    order = [bullet.getJointInfo(body, i)[1].decode() for i in range(bullet.getNumJoints(body))]
    movable = [n for n in order if n in names]
    in_bullet = bullet.calculateInverseDynamics(
        body, [float(q[names.index(n)]) for n in movable], [0.0] * len(movable), [0.0] * len(movable)
    )
    np.testing.assert_allclose(torque, [in_bullet[movable.index(n)] for n in names], atol=1e-6)
    np.testing.assert_allclose(effort[3:], 50.0)


def test_optas_hand_frames_match_pinocchio_on_the_reduced_robot(tmp_path):
    prepared = prepare_urdf(synthetic_urdf(tmp_path / "robot.urdf"), PLAN, tmp_path / "cache")
    model = optas.RobotModel(urdf_filename=str(prepared.path), time_derivs=[0])
    reduced = pin.buildModelFromUrdf(str(prepared.path))
    data = reduced.createData()
    q = np.linspace(-0.8, 0.9, model.ndof)
    pin.framesForwardKinematics(reduced, data, _pin_config(reduced, dict(zip(model.actuated_joint_names, q))))
    for link in ("l_tool", "r_tool"):
        in_optas = np.array(casadi.DM(model.get_global_link_position(link, q))).ravel()
        np.testing.assert_allclose(in_optas, _pin_frame(reduced, data, link), atol=1e-9)


@needs_pybullet
def test_a_robot_of_exactly_128_joints_is_merged_below_pybullets_limit(tmp_path, bullet):
    """PyBullet fails its state queries at 128 links (127 is the most it takes): one joint over is merged."""
    plain = prepare_urdf(synthetic_urdf(tmp_path / "robot.urdf"), PLAN, tmp_path / "cache")
    n_plain = len(ET.parse(plain.path).getroot().findall("joint"))
    urdf = synthetic_urdf(tmp_path / "big.urdf", rack_links=128 - n_plain)
    prepared = prepare_urdf(urdf, PLAN, tmp_path / "cache")
    assert prepared.merged
    body = bullet.loadURDF(str(prepared.path), useFixedBase=True)
    assert len(bullet.getJointStates(body, list(range(bullet.getNumJoints(body))))) == bullet.getNumJoints(body)


def test_a_misspelt_active_joint_gets_the_closest_names(tmp_path):
    with pytest.raises(ValueError, match=r"'l_sholder' matches no movable joint of robot.urdf; closest.*l_shoulder"):
        prepare_urdf(synthetic_urdf(tmp_path / "robot.urdf"), UrdfPlan(BASE, active=("l_sholder",)), tmp_path / "c")


def test_prepared_copy_has_no_foreign_elements(tmp_path):
    prepared = prepare_urdf(synthetic_urdf(tmp_path / "robot.urdf"), PLAN, tmp_path / "cache")
    tags = {child.tag for child in ET.parse(prepared.path).getroot()}
    assert tags <= {"link", "joint", "material"}


def _with(urdf: Path, path: Path, inside_torso: str = "", top: str = "") -> Path:
    """A copy of `urdf` with `inside_torso` added to the torso link and `top` to the robot."""
    text = urdf.read_text().replace('<link name="torso">', f'<link name="torso">{inside_torso}', 1)
    path.write_text(text.replace("</robot>", f"{top}</robot>"))
    return path


PLUGIN = (
    '<gazebo><plugin name="mimic" filename="libmimic.so"><joint>l_finger</joint><link name="ghost"/></plugin>'
    '</gazebo><ros2_control name="arms"><joint name="phantom"><command_interface name="position"/></joint>'
    "</ros2_control>"
)


def test_joints_and_links_inside_extensions_are_not_the_models(tmp_path):
    plain = synthetic_urdf(tmp_path / "robot.urdf")
    shipped = _with(plain, tmp_path / "shipped.urdf", top=PLUGIN)
    assert joints_and_links(shipped) == joints_and_links(plain)


def test_a_urdf_with_a_gazebo_plugin_block_prepares_to_the_same_model_as_without(tmp_path):
    plain = synthetic_urdf(tmp_path / "robot.urdf")
    shipped = _with(plain, tmp_path / "shipped.urdf", top=PLUGIN)
    prepared = prepare_urdf(shipped, PLAN, tmp_path / "cache")
    assert prepared.path.read_text() == prepare_urdf(plain, PLAN, tmp_path / "cache").path.read_text()
    assert prepared.dropped == {"transmission": 2, "gazebo": 2, "ros2_control": 1}


SKIN = '<material name="skin"><color rgba="0.9 0.8 0.7 1"/></material>'
TEXTURED_SKIN = SKIN.replace("</material>", "<texture/></material>") + "<material/>"
BOX = '<visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual>'
LOOKS = (  # what exported models carry that only colours or draws them, and the parsers cannot read
    BOX.replace("</visual>", '<material><color rgba="1 0 0 1"/></material></visual>')
    + "<visual/><visual><geometry/></visual><visual><geometry><mesh/></geometry></visual>"
    '<visual><geometry><box size="1 1 1"/><sphere radius="1"/></geometry></visual>'
    '<visual><geometry><cone radius="1"/></geometry></visual>'
)


def test_empty_textures_and_unreadable_looks_are_dropped_leaving_the_same_model(tmp_path):
    plain = _with(synthetic_urdf(tmp_path / "robot.urdf"), tmp_path / "plain.urdf", BOX, SKIN)
    shipped = _with(synthetic_urdf(tmp_path / "robot.urdf"), tmp_path / "shipped.urdf", LOOKS, TEXTURED_SKIN)
    prepared = prepare_urdf(shipped, PLAN, tmp_path / "cache")
    assert prepared.path.read_text() == prepare_urdf(plain, PLAN, tmp_path / "cache").path.read_text()
    assert prepared.dropped == {"transmission": 2, "gazebo": 1, "visual": 5, "texture": 1, "material": 2}


def test_a_scenario_whose_urdf_has_plugins_and_textures_validates(tmp_path):
    _with(synthetic_urdf(tmp_path / "robot.urdf"), tmp_path / "shipped.urdf", LOOKS, TEXTURED_SKIN + PLUGIN)
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(
        "name: x\nrobot: {urdf: shipped.urdf, end_effectors: {left: l_tool, right: r_tool}, "
        f"active_joints: [{', '.join(ARMS)}]}}\nreference: {{type: hold}}\n"
    )
    result = CliRunner().invoke(app, ["validate", str(scenario)])
    assert (result.exit_code, result.output.strip()) == (0, f"{scenario}: ok")


MALFORMED = {  # what to replace in the synthetic URDF (regular expression -> text): what the one line says
    "joint-type": (
        r'(name="l_wrist") type="revolute"',
        r'\1 type="revolut"',
        "joint 'l_wrist': type 'revolut' is not a URDF joint type; choose one of: revolute, continuous, prismatic, "
        "fixed, floating, planar",
    ),
    "collision-shape": (
        r'<link name="torso">',
        '<link name="torso"><collision><geometry><capsule radius="0.1" length="0.2"/></geometry></collision>',
        "link 'torso': <collision> needs one <geometry> shape (found <capsule>); choose one of: box (size), "
        "cylinder (radius and length), sphere (radius), mesh (filename)",
    ),
    "origin-commas": (
        r'xyz="0 0.2 0.5"',
        'xyz="0, 0.2, 0.5"',
        "joint 'l_shoulder': <origin> xyz='0, 0.2, 0.5' is not 3",
    ),
    "no-limit": (r'(name="l_wrist".*?)<limit[^>]*/>', r"\1", "joint 'l_wrist': a revolute joint needs a <limit>"),
    "limit-effort": (r' effort="50"', "", "joint 'l_shoulder': <limit> has no effort"),
    "link-twice": (r"</robot>", '<link name="torso"/></robot>', "link 'torso' is defined more than once"),
    "axis-zero": (r'<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>', "joint 'l_shoulder': <axis> xyz='0 0 0' has no"),
    "mesh-missing": (
        r'<link name="torso">',
        '<link name="torso"><visual><geometry><mesh filename="meshes/none.stl"/></geometry></visual>',
        "mesh 'meshes/none.stl' not found; tried ",
    ),
}


@pytest.mark.parametrize(("pattern", "replacement", "says"), MALFORMED.values(), ids=list(MALFORMED))
def test_a_malformed_urdf_is_refused_in_one_line_naming_the_element_and_the_choices(
    tmp_path, pattern, replacement, says
):
    urdf = synthetic_urdf(tmp_path / "robot.urdf")
    urdf.write_text(re.sub(pattern, replacement, urdf.read_text(), count=1, flags=re.S))
    with pytest.raises((ValueError, FileNotFoundError)) as info:
        prepare_urdf(urdf, PLAN, tmp_path / "cache")
    message = str(info.value)
    assert "\n" not in message and message.startswith("robot.urdf: robot.urdf: ") and says in message, message


def test_a_fixed_joint_with_a_zero_axis_in_an_arm_is_read_as_turning_nothing(tmp_path):
    urdf = synthetic_urdf(tmp_path / "robot.urdf")
    text = re.sub(
        r'(name="l_roll") type="continuous"(.*?)<axis xyz="0 1 0"/>',
        r'\1 type="fixed"\2<axis xyz="0 0 0"/>',
        urdf.read_text(),
        count=1,
        flags=re.S,
    )
    urdf.write_text(text)
    plan = UrdfPlan(BASE, active=tuple(j for j in ARMS if j != "l_roll"), home=PLAN.home, keep=PLAN.keep)
    prepared = prepare_urdf(urdf, plan, tmp_path / "cache")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        left, _ = arm_chains(prepared.path, ("l_tool", "r_tool"), 0.05)
    assert [j.kind for j in left.joints] == ["revolute", "fixed", "revolute"]
    assert all(np.isfinite(j.axis).all() for j in left.joints)
