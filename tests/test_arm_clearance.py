"""The arms' clearance rows: their points placed as PyBullet places the links, their margins against PyBullet's
closest points to a table top, the soft mode's cost and both transcriptions built from the same rows, and a closed
loop whose elbows touch a table without the rows and not with them."""

from __future__ import annotations

import casadi as cs
import numpy as np
import pytest
from conftest import ROOT, TABLE1, assert_exit_follows_outcome, needs_pybullet
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.maths.shapes import table_top
from harmony_cli.mpc.clearance import SOFTMIN, Clearance, arm_points, clearance_function, scenario_clearances
from harmony_cli.mpc.knot_params import KnotLayout
from harmony_cli.mpc.transcription import make_transcription
from harmony_cli.mpc.wholebody_problem import build_problem
from harmony_cli.robot.arm_points import MARGIN
from harmony_cli.scenario import ScenarioError, TableSpec, load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass

BOX_LIFT = ROOT / "scenarios" / "smoke" / "box_lift.yaml"
TOP = table_top(TableSpec(name="t", position=(0.0, 0.0), top=(1.5, 0.8), height=1.0))


@pytest.fixture(scope="module")
def bullet_eva(eva):
    """EVA in PyBullet (its prepared URDF, fixed base), a table top's slab, and joint name -> PyBullet index."""
    client = BulletClient(connection_mode=pybullet.DIRECT)
    body = client.loadURDF(str(eva.urdf), useFixedBase=True)
    index = {client.getJointInfo(body, i)[1].decode(): i for i in range(client.getNumJoints(body))}
    slab = client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=TOP.half.tolist()))
    yield client, body, slab, index
    client.disconnect()


def _random_pose(eva, rng) -> np.ndarray:
    """Every joint but the pinned ones uniform within its limits, the base at the origin turned at random."""
    q = eva.home.copy()
    free = [i for i in range(eva.n_dof) if i not in eva.pinned_joints and i not in eva.base_joints]
    q[free] = rng.uniform(eva.lower[free], eva.upper[free])
    q[eva.base_joints[2]] = rng.uniform(-np.pi, np.pi)
    return q


def _pose(client, body, index, eva, q) -> None:
    for name, value in zip(eva.joint_names, q):
        client.resetJointState(body, index[name], value)


@needs_pybullet
def test_the_arm_points_sit_on_their_links_where_pybullet_places_the_links(eva, bullet_eva, rng):
    client, body, _, index = bullet_eva
    for _ in range(20):
        q = _random_pose(eva, rng)
        _pose(client, body, index, eva, q)
        for chain, points in zip(eva.arms, arm_points(eva, q)):
            expected = []
            for joint in chain.joints:  # a joint's child link has the joint's PyBullet index
                state = client.getLinkState(body, index[joint.name], computeForwardKinematics=True)
                R = np.array(client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
                expected += [R @ p + np.array(state[4]) for p in joint.points]
            np.testing.assert_allclose([np.array(cs.DM(p)).ravel() for p in points], expected, atol=1e-6)
        assert all(not j.name.endswith(("FT_JOINT", "TOOL_JOINT", "GRASP_JOINT")) for c in eva.arms for j in c.joints)


# Measured over these 300 poses (EVA, arm radius 5 cm): the 142 clear of the top have rows 1.0 to 5.9 cm below the
# links' distance; the 158 touching have rows below -1.7 cm. A row is the margin below the distance but for EVA's
# shoulder box, whose corners stand 7 mm beyond the radius (and Bullet's 1 mm collision margin), so a row that
# holds keeps the links off; at most the radius, the margin and the soft-min's bound below it: a cylinder's flat
# end seen along its axis, which its sphere overstates by the radius.
@needs_pybullet
def test_an_arm_row_is_the_arm_links_distance_to_a_table_top_less_the_margin_to_within_the_radius(eva, bullet_eva):
    client, body, slab, index = bullet_eva
    radius = 0.05
    rows = clearance_function(eva, (Clearance("box", TOP.half, None, None, radius + MARGIN),), ())
    links = [index[j.name] for chain in eva.arms for j in chain.joints if len(j.points)]
    n_points = max(chain.n_points for chain in eva.arms)
    rng, tried = np.random.default_rng(3), 0
    while tried < 300:
        q = _random_pose(eva, rng)
        _pose(client, body, index, eva, q)
        points = [np.array(cs.DM(p)).ravel() for arm in arm_points(eva, q) for p in arm]
        below = points[rng.integers(len(points))]
        centre = np.r_[below[:2] + rng.uniform(-0.9, 0.9, 2), below[2] - rng.uniform(0.0, 0.25) - TOP.half[2]]
        yaw = rng.uniform(-np.pi, np.pi)
        client.resetBasePositionAndOrientation(slab, centre.tolist(), pybullet.getQuaternionFromEuler([0, 0, yaw]))
        client.performCollisionDetection()
        closest = [c[8] for link in links for c in client.getClosestPoints(body, slab, 1.0, linkIndexA=link)]
        if not closest or min(closest) > 0.2:
            continue
        tried += 1
        distance = min(closest)
        pose = np.r_[centre, yaw, 0.0][:, None]  # its relief 0
        row = float(np.min(rows(q, KnotLayout(2, 1).stack(np.zeros((KnotLayout(2, 1).hands_end, 1)), pose))))
        if distance >= 0.0:
            assert row <= distance + 1e-3  # a row that holds keeps every link off the top
            assert row >= distance - radius - MARGIN - SOFTMIN * np.log(n_points) - 1e-3
        else:
            assert row < 0.0  # a link touching the top violates its arm's row


@pytest.mark.parametrize("transcription", ["bezier", "traditional"])
def test_soft_clearance_costs_the_squared_hinge_of_the_hard_rows_arm_rows_included(eva, rng, transcription):
    tables = "world.tables=[{name: t, position: [0.9, 0.0], yaw_deg: 90, top: [1.5, 0.8], height: 0.95}]"
    hard, soft = (
        load_scenario(TABLE1, [tables, f"mpc.transcription={transcription}", "mpc.knots=6", f"mpc.clearance={c}"])
        for c in ("hard", "soft")
    )
    tr = make_transcription(hard.mpc, eva.n_dof)
    clearances, poses = scenario_clearances(hard)
    footprint = tuple(map(tuple, hard.robot.footprint))
    built = [
        build_problem(eva, tr, s.mpc.weights, [], [], clearances, footprint, s.mpc.clearance) for s in (hard, soft)
    ]
    assert built[0].reverse_rows == 2  # one row per arm against the table's top, after the footprint's and hands'
    layout = KnotLayout(2, 5)  # four legs, the top
    p = layout.stack(np.zeros((layout.hands_end, tr.n_knots)), np.tile(poses[:, None], tr.n_knots))
    p = p.reshape(layout.rows, tr.n_knots, order="F")
    x = np.tile(eva.home, tr.n_vars // eva.n_dof) + 0.3 * rng.standard_normal(tr.n_vars)
    h = np.array(built[0].constraint_at_knots(built[0].knot_positions(x), p))
    assert h[-2:].min() < 0  # some arm sphere inside the top's margin
    cost = soft.mpc.weights.clearance / tr.n_knots * np.sum(np.maximum(0.0, -h) ** 2)
    terms = built[1].evaluate_terms(x, p.ravel(order="F"))
    assert terms["clearance"] == pytest.approx(cost, rel=1e-12)


def test_an_arm_radius_of_null_leaves_the_arms_without_points_and_a_radius_of_zero_is_refused():
    scenario = load_scenario(TABLE1, ["robot.arm_radius=null"])
    assert robot_of(scenario, TABLE1.parent).arms == ()
    with pytest.raises(ScenarioError, match="arm_radius"):
        load_scenario(TABLE1, ["robot.arm_radius=0"])


# box_lift's raise, then its approach with the pads 13 cm above the table's top beside the box: EVA's elbow links
# (LARM2 / RARM2 hang below the elbow) reach down onto the top
LOW = [f"task.phases.approach.hands.{hand}.offset=[0.0, {y}, -0.02]" for hand, y in (("left", 0.3), ("right", -0.3))]


def _task(out, overrides: list[str]) -> dict:
    sets = [arg for o in ["sim.duration=8.0", *LOW, *overrides] for arg in ("--set", o)]
    result = CliRunner().invoke(app, ["run", str(BOX_LIFT), "--out", str(out), "--quiet", *sets])
    return assert_exit_follows_outcome(result, out)["task"]


def test_hands_sent_low_over_a_table_rest_the_elbows_on_it_without_the_arm_rows_and_not_with_them(tmp_path):
    without = _task(tmp_path / "without", ["robot.arm_radius=null"])
    assert [(c["who"], c["body"]) for c in without["contacts"]] == [("robot", "table table")]
    with_rows = _task(tmp_path / "with", [])
    assert with_rows["contacts"] == [] and with_rows["contact_free"] is True
