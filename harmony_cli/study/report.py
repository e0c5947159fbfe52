"""`harmony study report DIR`: from study.parquet, report.md with the success rate and its Wilson 95 % interval per
grid point, outcomes by category, distributions of the run metrics, success against every varied field (plots)
and the runs that did not succeed, each with the command that shows its replay (`harmony view`) and the one that
runs it again."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from harmony_cli.report.figure import plt, save
from harmony_cli.study.draw_map import draw_map
from harmony_cli.study.table import TABLE

Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile
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


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (good at small n and at rates near 0 or 1)."""
    if n == 0:
        return (math.nan, math.nan)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


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
    """Per grid point: runs with a result, successes, rate, Wilson 95 % interval, and the runs without a result."""
    out = []
    for point, runs in table.groupby("point", sort=False):
        results = runs[runs["success"].notna()]
        k, n = int(results["success"].astype(bool).sum()), len(results)
        low, high = wilson(k, n)
        out.append(
            {"point": point, "runs": n, "successes": k, "rate": k / n if n else math.nan, "low": low, "high": high}
            | {"no_result": len(runs) - n}
        )
    return pd.DataFrame(out)


# a scene check's refusal (tasks/scene_check.py, tasks/stance_check.py) -> its kind, as the report counts them
REFUSALS = (
    (r"^stance: no base pose found", "no base pose found at a blocked stance"),
    (r"^obstacle .* overlaps", "an obstacle overlapping a table or the box"),
    (r"^obstacle .* from the robot's start", "an obstacle within its margin of the robot's start"),
    (r"out of reach from every collision-free base pose", "a hand target out of reach"),
    (r"no passage for the base", "no passage for the base"),
)


def refusal_kind(reason: str) -> str:
    """The kind of a refused draw's reason (REFUSALS; anything else, e.g. validation: "other")."""
    return next((kind for pattern, kind in REFUSALS if re.search(pattern, reason)), "other")


def _refusals(table: pd.DataFrame) -> str:
    """The scene check's line: how many draws it refused, and of what kind when the table says why."""
    per_sample = table.groupby("sample").first()
    refused = int(per_sample["resamples"].sum())
    line = f"Scene check: {refused} draws refused and drawn again over {len(per_sample)} samples"
    if "rejected" not in per_sample or not refused:
        return line + "."
    reasons = [
        r for cell in per_sample["rejected"].dropna() for r in (json.loads(cell) if isinstance(cell, str) else cell)
    ]
    kinds = pd.Series([refusal_kind(r) for r in reasons]).value_counts()
    return line + ": " + ", ".join(f"{n} {kind}" for kind, n in kinds.items()) + "."


def _pct(x: float) -> str:
    return "-" if x != x else f"{100 * x:.0f} %"


def write_report(study: Path) -> list[Path]:
    """report.md, outcomes.png, metrics.png, success_vs_<field>.png and draws_map.png in the study directory."""
    table = pd.read_parquet(study / TABLE)
    rates = success_rates(table)
    spec = study / "study.yaml"  # the study file as run
    name = yaml.safe_load(spec.read_text()).get("name", study.name) if spec.is_file() else study.name
    lines = [f"# Study {name}", "", f"{len(table)} runs ({TABLE}; one row per run).", ""]
    lines += ["## Success rate (Wilson 95 % interval)", "", "| grid point | runs | successes | rate | 95 % interval |"]
    lines += ["|---|---:|---:|---:|---|"]
    lines += [
        f"| {r.point} | {r.runs} | {r.successes} | {_pct(r.rate)} | {_pct(r.low)} - {_pct(r.high)} |"
        for r in rates.itertuples()
    ]
    missing = int(rates["no_result"].sum())
    if missing:
        lines += ["", f"{missing} runs have no result (interrupted or not run): not counted above."]
    counts = table.groupby(["point", "outcome"], sort=False).size().unstack(fill_value=0)
    lines += ["", "## Outcomes by category", "", _markdown(counts.reset_index())]
    lines += ["", _refusals(table)]
    lines += ["", "## Run metrics (median / p95 / max over runs with a value)", ""]
    lines += ["| metric | grid point | runs | median | p95 | max |", "|---|---|---:|---:|---:|---:|"]
    for column, what, scale, unit in METRICS:
        for point, runs in table.groupby("point", sort=False):
            values = metric(runs, column).dropna() * scale
            if len(values):
                q = np.percentile(values, [50, 95, 100])
                label = f"{what} [{unit}]" if unit else what
                lines.append(f"| {label} | {point} | {len(values)} | {q[0]:.3g} | {q[1]:.3g} | {q[2]:.3g} |")
    failed = table[table["outcome"] != "success"]
    lines += ["", f"## Runs that did not succeed ({len(failed)})", ""]
    if len(failed):
        header = "| sample | grid point | outcome | reason | look at it | run it again |"
        lines += [header, "|---:|---|---|---|---|---|"]
        lines += [
            f"| {r['sample']} | {r['point']} | {r['outcome']} | {_cell(r['reason'])} | "
            f"`harmony view {r['run_dir']}` | `harmony run {r['run_dir']}/scenario.resolved.yaml` |"
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
    return [report, *figures]


def _cell(text) -> str:
    return "" if text is None or text != text else str(text).replace("|", "/").replace("\n", " ")[:160]


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
