"""Contacts between the pads and the box follow the box as it turns (sim/world.py's BODY_FLAGS with enableSAT):
a box riding one of EVA's disc pads while the pad tilts keeps its contact normals on its face."""

import numpy as np
from conftest import needs_pybullet

from harmony_cli.sim.contacts import pad_contacts

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.world import BODY_FLAGS, load_box
except ImportError:
    pass
pytestmark = needs_pybullet  # every test here checks against PyBullet

TILT = np.deg2rad(11.5)  # [rad] how far the pad turns, slowly, with the box on it
PAD = """<?xml version="1.0"?>
<robot name="pad">
  <link name="stand"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial></link>
  <joint name="tilt" type="revolute"><parent link="stand"/><child link="pad"/><origin xyz="0 0 0.5"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1000" velocity="1"/></joint>
  <link name="pad"><inertial><mass value="0.1"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/>
    </inertial><collision><geometry><cylinder radius="0.045" length="0.01"/></geometry></collision></link>
</robot>
"""


def _largest_normal_angle_after_tilt(tmp_path, flags: int, sat: bool) -> float:
    """The largest angle [deg] of a pad-box contact normal from the box's nearest face, once the pad has tilted."""
    client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        client.setGravity(0, 0, -9.81)
        client.setPhysicsEngineParameter(fixedTimeStep=1 / 240, enableSAT=int(sat))
        (tmp_path / "pad.urdf").write_text(PAD)
        pad = client.loadURDF(str(tmp_path / "pad.urdf"), useFixedBase=True, flags=flags)
        box = load_box(client, (0.06, 0.06, 0.04), 0.3, (0, 0, 0.525), (0, 0, 0, 1))
        client.changeDynamics(box, -1, lateralFriction=1.0, spinningFriction=1.0)
        client.changeDynamics(pad, 0, lateralFriction=1.0, spinningFriction=1.0)
        for step in range(960):  # 1 s to settle, 3 s to tilt
            angle = TILT * min(1.0, max(0.0, (step - 240) / 720))
            client.setJointMotorControl2(pad, 0, pybullet.POSITION_CONTROL, targetPosition=angle, force=1000)
            client.stepSimulation()
        rotation = np.reshape(client.getMatrixFromQuaternion(client.getBasePositionAndOrientation(box)[1]), (3, 3))
        contacts = client.getContactPoints(box, pad)
        assert contacts, "the box left the pad"
        return float(pad_contacts(contacts, {0: [0]}, 1, rotation, friction=1.0).normal_off_face_deg[0])
    finally:
        client.disconnect()


def test_contacts_made_afresh_keep_their_normals_on_the_box_face_as_the_pad_tilts(tmp_path):
    assert _largest_normal_angle_after_tilt(tmp_path, BODY_FLAGS, sat=True) < 1.0


def test_without_polyhedral_features_the_normals_stay_behind_the_turning_face(tmp_path):
    """The check above can fail: GJK's persistent contacts, made before the tilt, keep their normals."""
    assert _largest_normal_angle_after_tilt(tmp_path, pybullet.URDF_USE_INERTIA_FROM_FILE, sat=False) > 3.0
