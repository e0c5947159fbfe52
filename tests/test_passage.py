"""Impossible scenes said before the robot moves, on a proof from geometry: a gap narrower than the base's footprint,
with no way round, is refused with the width it would need; a gap the footprint fits through (the margins the
controllers keep are not the world's), or a way round the wall's end, is not."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from harmony_cli.scenario import load_scenario
from harmony_cli.study.report import refusal_kind
from harmony_cli.tasks.passage import narrowest_width
from harmony_cli.tasks.scene_check import SceneCheck

NARROW = Path(__file__).resolve().parents[1] / "scenarios" / "paper" / "narrow_passage.yaml"


def _gap(width: float, closed: bool) -> list[str]:
    """narrow_passage with its gap (centred at x = 1.0) `width` wide; `closed`: side walls to y = -3 and a back
    wall, so the gap is the only way from the start to the far side."""
    west, east = 1.0 - width / 2, 1.0 + width / 2
    walls = [
        ("wall_west", west - 3.55 / 2, 2.0, 3.55, 0.2),
        ("wall_east", east + 3.55 / 2, 2.0, 3.55, 0.2),
    ]
    if closed:
        walls += [
            ("side_west", -3.1, -0.5, 0.2, 5.2),
            ("side_east", 5.1, -0.5, 0.2, 5.2),
            ("back", 1.0, -3.2, 8.4, 0.2),
        ]
    listed = ", ".join(
        f"{{name: {name}, shape: box, position: [{x}, {y}, 0.75], size: [{sx}, {sy}, 1.5], margin: 0.03}}"
        for name, x, y, sx, sy in walls
    )
    return [f"world.obstacles=[{listed}]"]


def _check(overrides: list[str]) -> str | None:
    return SceneCheck(NARROW.parent)(load_scenario(NARROW, overrides))


def test_the_footprint_width_is_the_narrowest_over_directions():
    circles = np.array([[x, y, 0.2036] for x in (-0.4, -0.2, 0.0, 0.2, 0.4) for y in (-0.1768, 0.1768)])
    assert narrowest_width(circles) == pytest.approx(2 * (0.1768 + 0.2036), abs=1e-9)


def test_a_closed_room_whose_gap_is_narrower_than_the_footprint_is_refused_with_the_width():
    why = _check(_gap(0.70, closed=True))
    assert why is not None and "no passage for the base" in why and "0.761 m" in why, why
    assert refusal_kind(why) == "no passage for the base"  # as a study's report counts it


def test_the_same_room_with_a_gap_the_footprint_fits_but_not_with_the_margins_passes():
    assert _check(_gap(0.78, closed=True)) is None  # 0.761 m of footprint, 2 x 0.03 m of margins


def test_a_narrow_gap_with_a_way_round_the_wall_passes():
    assert _check(_gap(0.70, closed=False)) is None


def test_harmony_run_says_the_scene_is_impossible_before_the_robot_moves(tmp_path):
    from typer.testing import CliRunner

    from harmony_cli.cli import app

    sets = [arg for o in _gap(0.70, closed=True) for arg in ("--set", o)]
    result = CliRunner().invoke(app, ["run", str(NARROW), *sets, "--out", str(tmp_path / "run"), "--quiet"])
    assert result.exit_code == 1, result.output
    assert "no passage for the base" in result.output and len(result.output.strip().splitlines()) == 1
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["failure"] == "impossible"
    assert (
        not (tmp_path / "run" / "steps.csv").exists()
        or len((tmp_path / "run" / "steps.csv").read_text().splitlines()) <= 1
    )
