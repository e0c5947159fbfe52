"""Two studies of the same draws, paired (tools/compare_studies.py): what a change gained and lost."""

from __future__ import annotations

import importlib.util

import pandas as pd
from conftest import ROOT

from harmony_cli.study.table import IMPOSSIBLE

spec = importlib.util.spec_from_file_location("compare_studies", ROOT / "tools" / "compare_studies.py")
assert spec is not None and spec.loader is not None
compare = importlib.util.module_from_spec(spec)
spec.loader.exec_module(compare)


def _study(directory, outcomes: list[str], draws: str = "dev", points: tuple[str, ...] = ("base",)):
    directory.mkdir()
    rows = [
        {"draws": draws, "seed": 7, "sample": i, "point": point, "success": o == "success", "outcome": o}
        for i, o in enumerate(outcomes)
        for point in points
    ]
    pd.DataFrame(rows).to_parquet(directory / "study.parquet")
    return directory


def test_the_draws_whose_success_flips_are_counted_each_way_and_tested_as_a_coin(tmp_path, capsys):
    before = _study(tmp_path / "a", ["success", "dropped", "dropped", "stalled", "success", "success"])
    after = _study(tmp_path / "b", ["success", "success", "success", "dropped", "dropped", "success"])
    assert compare.main([str(before), str(after)]) == 0
    out = capsys.readouterr().out
    assert "success flipped on 3 draws: 2 gained, 1 lost (exact McNemar p = 1)" in out
    assert "  dev 3 (base): stalled -> dropped" in out and "  dev 0 (base)" not in out


def test_only_draws_run_on_both_sides_are_paired(tmp_path, capsys):
    before = _study(tmp_path / "a", ["success"] * 4)
    after = _study(tmp_path / "b", ["dropped"] * 2)
    assert compare.main([str(before), str(after)]) == 0
    assert "before: 2 of 2" in capsys.readouterr().out


def test_two_studies_of_one_grid_point_each_pair_by_draw_whatever_their_points_are_named(tmp_path, capsys):
    before = _study(tmp_path / "a", ["success", "success", "dropped"])
    after = _study(tmp_path / "b", ["success", "collision", "dropped"], points=("world.box.friction-0.8000001",))
    assert compare.main([str(before), str(after)]) == 0
    out = capsys.readouterr().out
    assert "paired by draw: base (before) against world.box.friction-0.8000001 (after)" in out
    assert "before: 2 of 3" in out and "after:  1 of 3" in out and "  dev 1 (base): success -> collision" in out


def test_studies_of_several_grid_points_pair_only_the_same_points(tmp_path, capsys):
    before = _study(tmp_path / "a", ["success", "dropped"], points=("x", "y"))
    after = _study(tmp_path / "b", ["dropped", "dropped"], points=("y", "z"))
    assert compare.main([str(before), str(after)]) == 0
    out = capsys.readouterr().out
    assert "before: 1 of 2" in out and "paired by draw" not in out


def test_a_draw_refused_as_impossible_on_either_side_counts_on_neither(tmp_path, capsys):
    before = _study(tmp_path / "a", ["success", "success", IMPOSSIBLE])
    after = _study(tmp_path / "b", ["success", IMPOSSIBLE, "dropped"])
    assert compare.main([str(before), str(after)]) == 0
    assert "before: 1 of 1" in capsys.readouterr().out


def test_validation_draws_are_refused_in_one_line(tmp_path, capsys):
    before = _study(tmp_path / "a", ["success"], draws="validation")
    after = _study(tmp_path / "b", ["success"], draws="validation")
    assert compare.main([str(before), str(after)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "validation" in err and str(before) in err
