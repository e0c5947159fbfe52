"""A study's claims (study/claims.py) and named grid points: metrics with intervals, settings paired per draw."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import ROOT

from harmony_cli.scenario import ScenarioError
from harmony_cli.study.claims import claim_lines, paired_comparisons
from harmony_cli.study.runner import Options, plan_study
from harmony_cli.study.spec import Claim, Paired

STUDY = ROOT / "studies" / "smoke_box_lift.yaml"


def _table1_like(rng) -> pd.DataFrame:
    """30 draws of very different difficulty, each at traditional and bezier for K = 6 and 26: traditional takes
    about twice bezier's time on every draw at K = 26 and the same at K = 6."""
    rows = []
    for sample in range(30):
        hard = rng.lognormal(0.0, 0.5)
        for knots, factor in ((6, 1.0), (26, 2.0)):
            for transcription in ("traditional", "bezier"):
                slow = factor if transcription == "traditional" else 1.0
                rows.append(
                    {"sample": sample, "point": f"transcription-{transcription}_knots-{knots}"}
                    | {"grid.mpc.transcription": transcription, "grid.mpc.knots": knots}
                    | {"summary.solve_time_ms.median": hard * slow * rng.uniform(0.95, 1.05)}
                )
    return pd.DataFrame(rows)


def test_a_paired_ratio_is_stated_per_value_of_the_other_grid_fields_and_holds_only_where_there_is_an_effect(rng):
    table = _table1_like(rng)
    values = table["summary.solve_time_ms.median"]
    paired = Paired(field="mpc.transcription", a="traditional", b="bezier")
    estimates = {c.label: c.estimate for c in paired_comparisons(table, values, paired)}
    assert set(estimates) == {"knots = 6", "knots = 26"}
    assert estimates["knots = 26"].value == pytest.approx(2.0, abs=0.05) and estimates["knots = 26"].excludes(1.0)
    assert not estimates["knots = 6"].excludes(1.0) and estimates["knots = 6"].n == 30


def test_the_claims_section_states_each_point_s_median_with_its_interval_and_the_method():
    table = _table1_like(np.random.default_rng(3))
    claim = Claim(
        name="bezier is faster",
        metric="summary.solve_time_ms.median",
        unit="ms",
        paired=Paired(field="mpc.transcription", a="traditional", b="bezier"),
    )
    text = "\n".join(claim_lines(table, [claim]))
    assert "bootstrap over draws, BCa" in text and "### bezier is faster: summary.solve_time_ms.median [ms]" in text
    assert text.count("n = 30") == 4 + 2  # four grid points, two paired rows
    rows = {line.split(" | ")[0]: line for line in text.splitlines() if line.startswith("| knots = ")}
    assert rows["| knots = 26"].endswith("| yes | - |") and "| 30 | 2" in rows["| knots = 26"]
    assert "| no |" in rows["| knots = 6"]


def test_named_points_pair_by_name_and_a_success_rate_difference_is_a_paired_mean():
    rows = [
        {"sample": s, "point": point, "success": ok}
        for s in range(40)
        for point, ok in (("baseline", True), ("noisy", s % 4 != 0))  # the noise loses every fourth draw
    ]
    table = pd.DataFrame(rows).astype({"success": object})
    claim = Claim(
        name="noise", metric="success", paired=Paired(field="point", a="noisy", b="baseline", statistic="difference")
    )
    [comparison] = paired_comparisons(table, table["success"].astype(float), claim.paired)
    assert comparison.label == "all" and comparison.estimate.value == pytest.approx(-0.25)
    assert comparison.estimate.excludes(0.0)
    assert comparison.against(0.0) == []  # no draw the noise saved
    assert len(comparison.per_draw[comparison.per_draw < 0]) == 10


def test_the_draws_against_a_comparison_are_those_whose_own_ratio_goes_the_other_way():
    rows = [
        {"sample": s, "point": p, "grid.x": x, "t": t}
        for s, (slow, fast) in enumerate([(2.0, 1.0), (3.0, 1.0), (1.0, 2.0), (2.5, 1.0)])
        for p, x, t in (("x-a", "a", slow), ("x-b", "b", fast))
    ]
    table = pd.DataFrame(rows)
    [comparison] = paired_comparisons(table, table["t"], Paired(field="x", a="a", b="b"))
    assert comparison.estimate.value > 1.0 and comparison.against(1.0) == [2]


def test_a_study_with_named_points_runs_every_draw_at_each_point_under_its_name(tmp_path):
    path = tmp_path / "study.yaml"
    text = STUDY.read_text().replace("../scenarios", str(ROOT / "scenarios"))
    path.write_text(text + "points:\n  quiet: {}\n  noisy: {sensing.noise.joint_position.std: 0.001}\n")
    plan = plan_study(path, Options(out=tmp_path / "out", samples=2, progress=False))
    assert [(run.sample.index, run.label) for run in plan.runs] == [
        (0, "quiet"),
        (0, "noisy"),
        (1, "quiet"),
        (1, "noisy"),
    ]
    assert plan.runs[1].overrides[-1] == "sensing.noise.joint_position.std=0.001"
    assert plan.runs[0].name.startswith("s00000-quiet-")


@pytest.mark.parametrize(
    ("extra", "piece"),
    [
        ("grid: {mpc.knots: [6, 26]}\npoints: {a: {}}\n", "a grid or named points, not both"),
        ("claims:\n  - {name: c, metric: success, paired: {field: mpc.knots, a: 6, b: 26}}\n", "not a grid field"),
        (
            "grid: {mpc.knots: [6, 26]}\nclaims:\n  - {name: c, metric: success, paired: {field: mpc.knots, a: 6, "
            "b: 12}}\n",
            "12 is not a value of grid 'mpc.knots'",
        ),
    ],
)
def test_a_claim_or_point_that_names_nothing_in_the_study_is_refused_in_one_line(tmp_path, extra, piece):
    path = tmp_path / "study.yaml"
    path.write_text(STUDY.read_text().replace("../scenarios", str(ROOT / "scenarios")) + extra)
    with pytest.raises(ScenarioError) as info:
        plan_study(path, Options(out=tmp_path / "out", samples=1, progress=False))
    assert piece in str(info.value) and "\n" not in str(info.value) and str(path) in str(info.value)


def test_the_claims_table_of_several_studies_has_a_row_per_paired_comparison_and_says_whether_it_holds(tmp_path):
    from harmony_cli.study.claims import summary_lines

    study = tmp_path / "table1"
    study.mkdir()
    _table1_like(np.random.default_rng(5)).to_parquet(study / "study.parquet")
    claim = {"name": "speed", "metric": "summary.solve_time_ms.median"}
    claim["paired"] = {"field": "mpc.transcription", "a": "traditional", "b": "bezier"}
    (study / "study.yaml").write_text(yaml.safe_dump({"name": "table1", "claims": [claim]}))
    rows = [line for line in summary_lines([study]) if line.startswith("| table1 |")]
    assert len(rows) == 2
    assert rows[0].startswith("| table1 | speed | traditional / bezier | knots = 6 | 30 |") and "| no |" in rows[0]
    assert "| yes |" in rows[1]
