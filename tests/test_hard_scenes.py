"""Scenes nobody tuned the controller for (our own versions of kinds a reviewer tries): the paper's scenes changed, the
controller not. Each runs closed loop and must succeed, or be refused before the robot moves."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from harmony_cli.cli import app

PAPER = Path(__file__).resolve().parents[1] / "scenarios" / "paper"
TWO_CYLINDERS = (
    "world.obstacles=[{name: c1, shape: cylinder, position: [3.9, 1.75, 1.0], size: [0.6, 0.6, 2.0], margin: 0.3}, "
    "{name: c2, shape: cylinder, position: [4.9, 0.75, 1.0], size: [0.6, 0.6, 2.0], margin: 0.3}]"
)
SCENES = {
    # the big cylinder on the straight line between the tables: the planner must go round, with the base
    "cylinder_on_the_line": ("pick_and_carry.yaml", ["world.obstacles.0.position=[4.2,1.33,1.0]"]),
    # two 0.6 m cylinders either side of that line
    "two_cylinders": ("pick_and_carry.yaml", [TWO_CYLINDERS]),
    # the robot 1 m further back and turned 90 deg
    "turned_start": ("pick_and_carry.yaml", ["robot.base_pose=[-1.0,0.0,90.0]"]),
    # the crate 20 cm taller and 10 cm nearer the pick table: over it the hands would be above what the arms
    # reach with the pads level, so the box goes round it
    "tall_crate": (
        "static_obstacles.yaml",
        ["world.obstacles.crate.size=[0.4,0.4,1.4]", "world.obstacles.crate.position=[3.5,2.67,0.7]"],
    ),
}


def _run(scene: str, out: Path) -> dict:
    name, overrides = SCENES[scene]
    sets = [arg for o in overrides for arg in ("--set", o)]
    result = CliRunner().invoke(app, ["run", str(PAPER / name), *sets, "--out", str(out), "--quiet"])
    assert result.exit_code == 0, result.output
    return json.loads((out / "summary.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("scene", sorted(SCENES))
def test_a_scene_nobody_tuned_for_is_carried_out(scene, tmp_path):
    summary = _run(scene, tmp_path / scene)
    task = summary["task"]
    assert task["success"] and not task["box_dropped"], task.get("failure")
    assert summary["failed_solves"] == 0 and task["planner_failures"] == 0
