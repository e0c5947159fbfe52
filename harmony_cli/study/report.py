"""`harmony study report DIR`: from study.parquet, report.md with, per grid point, the successes over every draw
the controller was given (its own failures before the robot moved, such as `no stance`, included) with the Wilson
95 % interval, and the draws refused as impossible by a proof from geometry (tasks/scene_check.py) counted apart
by kind; outcomes by category, distributions of the run metrics, success against every varied field (plots) and
the runs that did not succeed, each with the command that shows its replay (`harmony view`) and the one that runs
it again."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from harmony_cli.planning.stance import StanceClass
from harmony_cli.provenance import made_of, record
from harmony_cli.report.figure import plt, save
from harmony_cli.report.text import markdown_cell
from harmony_cli.study.claims import claim_lines
from harmony_cli.study.disagreement import disagreement_lines
from harmony_cli.study.draw_map import draw_map
from harmony_cli.study.intervals import wilson
from harmony_cli.study.run_again import run_again
from harmony_cli.study.scene_kind import COLUMN as SCENE_KIND
from harmony_cli.study.spec import Claim
from harmony_cli.study.table import IMPOSSIBLE, SUCCESS, SUCCESS_LATE, TABLE

METRICS = (  # (column or prefix, what it is, unit scale, unit): distributions in the report
    ("summary.task.box_goal_error_m", "box goal error", 100.0, "cm"),
    ("summary.task.grip_off_square_deg", "box off square against the pads, first held", 1.0, "deg"),
    ("summary.task.grip_shear_m", "one pad ahead of the other, first held", 1000.0, "mm"),
    ("summary.task.min_clearance_m.", "min clearance (robot and box, every obstacle)", 100.0, "cm"),
    ("summary.task.loop_time_ms.p95", "loop time p95", 1.0, "ms"),
    ("summary.task.loop_time_ms.max", "loop time max", 1.0, "ms"),
    ("summary.failed_solves", "failed whole-body solves", 1.0, ""),
    ("summary.task.planner_failures", "failed planner solves", 1.0, ""),
)


def metric(table: pd.DataFrame, column: str) -> pd.Series:
    """A metric per run; a prefix (ending in '.') is the minimum over its columns."""
    if column.endswith("."):
        columns = [c for c in table.columns if c.startswith(column)]
        if not columns:
            return pd.Series(np.nan, index=table.index)
        return table[columns].apply(pd.to_numeric, errors="coerce").min(axis=1)
    return pd.to_numeric(table[column], errors="coerce") if column in table else pd.Series(np.nan, index=table.index)


def varied_columns(table: pd.DataFrame) -> list[str]:
    """The sampled values that vary (vector fields by component)."""
    return [c for c in table.columns if c.startswith("vary.") and table[c].nunique(dropna=True) > 1]


def success_rates(table: pd.DataFrame) -> pd.DataFrame:
    """Per grid point: `planned` (its runs), `runs` (the draws the controller was given, with a result), successes
    (`late`: those with a phase that ended late), rate, Wilson 95 % interval, `refused` (draws refused as
    impossible: drawn again before they ran, or ended so before the robot moved) and the runs without a result
    (interrupted, cut off or not run yet)."""
    out = []
    for point, runs in table.groupby("point", sort=False):
        impossible = runs["outcome"] == IMPOSSIBLE
        results = runs[runs["success"].notna() & ~impossible]
        k, n = int(results["success"].astype(bool).sum()), len(results)
        low, high = wilson(k, n)
        out.append(
            {"point": point, "planned": len(runs), "runs": n, "successes": k}
            | {"rate": k / n if n else math.nan, "low": low, "high": high}
            | {"late": int((results["outcome"] == SUCCESS_LATE).sum())}
            | {"refused": int(_resamples(runs) + impossible.sum()), "no_result": int(runs["success"].isna().sum())}
        )
    return pd.DataFrame(out)


def _resamples(runs: pd.DataFrame) -> int:
    return int(runs.groupby("sample")["resamples"].first().sum()) if "resamples" in runs else 0


# a scene check's refusal (tasks/scene_check.py) -> its kind, as the report counts them
REFUSALS = (
    (r"^obstacle .* overlaps the robot's start", "an obstacle overlapping the robot's start"),
    (r"^obstacle .* overlaps", "an obstacle overlapping a table or the box"),
    (r"out of reach from every collision-free base pose", "a hand target beyond the arms' reach"),
    (r"no passage for the base", "no passage for the base"),
    (r"^invalid: ", "an invalid scenario"),
)


def refusal_kind(reason: str) -> str:
    """The kind of a refused draw's reason (REFUSALS; anything else, e.g. validation: "other")."""
    return next((kind for pattern, kind in REFUSALS if re.search(pattern, reason)), "other")


def refused_kinds(runs: pd.DataFrame) -> pd.Series:
    """The draws refused as impossible, counted by kind: those drawn again (the samples' `rejected`) and the runs
    that ended so before the robot moved."""
    reasons = []
    if "rejected" in runs:
        cells = runs.groupby("sample")["rejected"].first().dropna()
        reasons = [r for cell in cells for r in (json.loads(cell) if isinstance(cell, str) else cell)]
    if "reason" in runs:
        reasons += [str(r) for r in runs.loc[runs["outcome"] == IMPOSSIBLE, "reason"]]
    return pd.Series([refusal_kind(r) for r in reasons], dtype=object).value_counts()


def headline(rate, runs: pd.DataFrame) -> str:
    """The line `N successes of M draws (rate, Wilson 95 % a-b); K refused as impossible (by kind)` and what is
    left out, for one grid point's `rate` (a row of success_rates) and its `runs`."""
    kinds = refused_kinds(runs)
    by_kind = f" ({', '.join(f'{n} {kind}' for kind, n in kinds.items())})" if len(kinds) else ""
    line = (
        f"{rate.successes} successes of {rate.runs} draws ({_pct(rate.rate)}, Wilson 95 % {_pct(rate.low)} - "
        f"{_pct(rate.high)}); {rate.refused} refused as impossible{by_kind}"
    )
    if rate.late:
        line += f"; {rate.late} of the successes had a phase that ended late (it waited for its goal)"
    if rate.no_result:
        line += f"; {rate.no_result} of its {rate.planned} runs without a result (interrupted or not run), not counted"
    return line + "."


def scene_kind_lines(table: pd.DataFrame) -> list[str]:
    """Per kind of scene (study/scene_kind.py: how blocked its written stances are) and grid point, the draws run,
    successes, rate with its Wilson interval and the failures by category; nothing when no draw has a kind."""
    if SCENE_KIND not in table or table[SCENE_KIND].isna().all():
        return []
    lines = ["", "## Outcomes by the written stance", ""]
    lines += ["| written stance | grid point | draws run | successes | rate | Wilson 95 % | failures by category |"]
    lines += ["|---|---|---:|---:|---:|---|---|"]
    for kind in StanceClass:
        runs = table[table[SCENE_KIND] == kind.value]
        for rate in success_rates(runs).itertuples():
            ran = runs[(runs["point"] == rate.point) & runs["success"].notna() & (runs["outcome"] != IMPOSSIBLE)]
            failures = ran.loc[~ran["success"].astype(bool), "outcome"].value_counts()
            why = ", ".join(f"{n} {outcome}" for outcome, n in failures.items()) or "-"
            lines.append(
                f"| {kind.value} | {rate.point} | {rate.runs} | {rate.successes} | {_pct(rate.rate)} | "
                f"{_pct(rate.low)} - {_pct(rate.high)} | {why} |"
            )
    return lines


def throughput_lines(study: Path) -> list[str]:
    """The study's last invocation that ran something, from its log: runs, minutes, runs per minute, where."""
    log = study / "study_log.jsonl"
    if not log.is_file():
        return []
    lines = [line for line in log.read_text().splitlines() if line.strip()]
    if not lines:
        return []
    last = json.loads(lines[-1])
    return [
        "",
        f"Last ran {last['runs']} runs in {last['minutes']:.1f} min ({last['runs_per_minute']} runs per minute) on "
        f"{last['engine']} at {last['host']}, ending {last['ended']}.",
    ]


def _draws(table: pd.DataFrame) -> str:
    """Which set of draws the table holds ("" for a table from before sets of draws)."""
    if "draws" not in table or table["draws"].isna().all():
        return ""
    sets = table[["draws", "seed"]].drop_duplicates().itertuples(index=False)
    return "Draws: " + ", ".join(f"`{d.draws}` (seed {d.seed})" for d in sets) + ". "


def _pct(x: float) -> str:
    return "-" if x != x else f"{100 * x:.0f} %"


def write_report(study: Path) -> list[Path]:
    """report.md, outcomes.png, metrics.png, success_vs_<field>.png and draws_map.png in the study directory."""
    table = pd.read_parquet(study / TABLE)
    rates = success_rates(table)
    spec = study / "study.yaml"  # the study file as run
    name = yaml.safe_load(spec.read_text()).get("name", study.name) if spec.is_file() else study.name
    lines = [f"# Study {name}", "", f"{_draws(table)}{len(table)} runs ({TABLE}; one row per run).", ""]
    points = dict(list(table.groupby("point", sort=False)))
    lines += ["## Success rate", ""] + [f"- {r.point}: {headline(r, points[r.point])}" for r in rates.itertuples()]
    header = "| grid point | planned | draws run | successes | failed | rate | Wilson 95 % | refused as impossible |"
    lines += ["", header + " not run |"]
    lines += ["|---|---:|---:|---:|---:|---:|---|---:|---:|"]
    lines += [
        f"| {r.point} | {r.planned} | {r.runs} | {r.successes} | {r.runs - r.successes} | {_pct(r.rate)} | "
        f"{_pct(r.low)} - {_pct(r.high)} | {r.refused} | {r.no_result} |"
        for r in rates.itertuples()
    ]
    lines += throughput_lines(study)
    counts = table.groupby(["point", "outcome"], sort=False).size().unstack(fill_value=0)
    lines += ["", "## Outcomes by category", "", _markdown(counts.reset_index())] + scene_kind_lines(table)
    lines += disagreement_lines(table)
    claims = yaml.safe_load(spec.read_text()).get("claims", []) if spec.is_file() else []
    lines += claim_lines(table, [Claim.model_validate(c) for c in claims])
    lines += ["", "## Run metrics (median / p95 / max over runs with a value)", ""]
    lines += ["| metric | grid point | runs | median | p95 | max |", "|---|---|---:|---:|---:|---:|"]
    for column, what, scale, unit in METRICS:
        for point, runs in table.groupby("point", sort=False):
            values = metric(runs, column).dropna() * scale
            if len(values):
                q = np.percentile(values, [50, 95, 100])
                label = f"{what} [{unit}]" if unit else what
                lines.append(f"| {label} | {point} | {len(values)} | {q[0]:.3g} | {q[1]:.3g} | {q[2]:.3g} |")
    failed = table[~table["outcome"].isin([SUCCESS, SUCCESS_LATE])]
    lines += ["", f"## Runs that did not succeed ({len(failed)})", ""]
    if len(failed):
        lines += ["Each command runs the draw again into its run directory; `harmony view` it there to replay it.", ""]
        lines += ["| sample | grid point | outcome | reason | run it again |", "|---:|---|---|---|---|"]
        lines += [
            f"| {r['sample']} | {r['point']} | {r['outcome']} | {markdown_cell(r['reason'])} | "
            f"`{run_again(r['run_dir'])}` |"
            for _, r in failed.sort_values(["sample", "point"]).iterrows()
        ]
    figures = [_plot_outcomes(counts, study), _plot_metrics(table, study)]
    figures += [_plot_success_vs(table, column, study) for column in varied_columns(table)]
    lines += ["", "## Figures", ""] + [f"![{f.stem}]({f.name})" for f in figures]
    base = study / "base_scenario.yaml"  # the base scene as run; without it the map has the draws alone
    if drawn := draw_map(table, yaml.safe_load(base.read_text()) if base.is_file() else None, study / "draws_map.png"):
        figures.append(drawn)
        lines += ["", f"{drawn.name}: each draw's robot start, box and obstacles in plan view, coloured by outcome."]
        lines += ["", f"![{drawn.stem}]({drawn.name})"]
    report = study / "report.md"
    report.write_text("\n".join(lines) + "\n")
    if (made := made_of(study / TABLE)) is not None:  # made from the table's runs; an unrecorded table stays so
        record([report, *figures], made)
    return [report, *figures]


def _markdown(frame: pd.DataFrame) -> str:
    head = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    return "\n".join([head, rule] + ["| " + " | ".join(map(str, row)) + " |" for row in frame.itertuples(index=False)])


def _plot_outcomes(counts: pd.DataFrame, study: Path) -> Path:
    fig, ax = plt.subplots(figsize=(7, 0.5 + 0.45 * max(1, counts.shape[1])))
    counts.T.plot.barh(ax=ax)
    ax.set_xlabel("runs")
    ax.set_title("outcomes by category")
    path = study / "outcomes.png"
    save(fig, path)
    return path


def _plot_metrics(table: pd.DataFrame, study: Path) -> Path:
    columns = -(-len(METRICS) // 2)
    fig, axes = plt.subplots(2, columns, figsize=(4 * columns, 6.5))
    for ax in axes.ravel()[len(METRICS) :]:
        ax.axis("off")
    for ax, (column, what, scale, unit) in zip(axes.ravel()[: len(METRICS)], METRICS, strict=True):
        groups = [(p, metric(r, column).dropna() * scale) for p, r in table.groupby("point", sort=False)]
        groups = [(p, v) for p, v in groups if len(v)]
        if groups:
            ax.hist([v for _, v in groups], bins=20, label=[p for p, _ in groups])
            ax.legend(fontsize=7)
        ax.set_xlabel(f"{what} [{unit}]" if unit else what, fontsize=8)
        ax.set_ylabel("runs")
    path = study / "metrics.png"
    save(fig, path)
    return path


def _plot_success_vs(table: pd.DataFrame, column: str, study: Path, bins: int = 8) -> Path:
    """Each run's success (0/1, jittered) against one varied value, and the binned rate with its interval."""
    fig, ax = plt.subplots(figsize=(6, 3.5))
    rng = np.random.default_rng(0)
    for point, runs in table[table["success"].notna()].groupby("point", sort=False):
        x = pd.to_numeric(runs[column], errors="coerce")
        y = runs["success"].astype(float)
        ax.scatter(x, y + rng.uniform(-0.04, 0.04, len(y)), s=10, alpha=0.5, label=f"{point} runs")
        edges = np.linspace(x.min(), x.max(), bins + 1)
        which = np.clip(np.digitize(x, edges) - 1, 0, bins - 1)
        centres, rate, low, high = [], [], [], []
        for b in range(bins):
            hits = y[which == b]
            if len(hits):
                lo, hi = wilson(int(hits.sum()), len(hits))
                centres.append((edges[b] + edges[b + 1]) / 2)
                rate.append(hits.mean())
                low.append(max(0.0, hits.mean() - lo))  # rounding can put the rate a hair outside its interval
                high.append(max(0.0, hi - hits.mean()))
        ax.errorbar(centres, rate, yerr=[low, high], marker="o", capsize=3, label=f"{point} rate (Wilson 95 %)")
    ax.set_xlabel(column.removeprefix("vary."))
    ax.set_ylabel("success")
    ax.set_ylim(-0.1, 1.1)
    ax.legend(fontsize=7)
    path = study / f"success_vs_{column.removeprefix('vary.').replace('.', '_')}.png"
    save(fig, path)
    return path
