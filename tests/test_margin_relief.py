"""An obstacle's margin as the whole-body MPC keeps it (mpc/clearance.py): a preference the knot parameters may lower
(a relief) down to FLOOR, where a stance cannot keep it; table legs and tops do not give."""

from __future__ import annotations

import numpy as np
from conftest import ROOT

from harmony_cli.mpc.clearance import FLOOR, clearance_function, scenario_clearances
from harmony_cli.mpc.knot_params import KnotLayout
from harmony_cli.scenario import load_scenario

PAPER = ROOT / "scenarios" / "paper" / "pick_and_carry.yaml"


def test_a_relief_raises_an_obstacle_s_footprint_and_hand_rows_by_its_amount_and_no_other_row(eva, rng):
    scenario = load_scenario(PAPER)
    clearances, poses = scenario_clearances(scenario)
    assert [c.give for c in clearances] == [scenario.world.obstacles[0].margin - FLOOR] + [0.0] * (len(clearances) - 1)
    layout = KnotLayout(2, len(clearances), n_chest=1)
    rows = clearance_function(eva, clearances, tuple(map(tuple, scenario.robot.footprint)), n_chest=1)
    q = eva.home + 0.2 * rng.standard_normal(eva.n_dof)
    relieved = poses.copy()
    relieved[KnotLayout.pose_relief(0)] = 0.12
    before, after = (
        np.asarray(rows(q, layout.stack(np.zeros((layout.hands_end, 1)), p[:, None]))).ravel()
        for p in (poses, relieved)
    )
    raised = np.zeros_like(before)
    raised[:3] = 0.12  # the cylinder's footprint row and its two hand rows come first
    np.testing.assert_allclose(after - before, raised, atol=1e-12)
