"""The study report's claims (a study file's `claims:`): each metric per grid point as its median over the draws
with a bootstrap interval, and, where the claim pairs two settings, the comparison draw by draw on the same draws
(common random numbers: both settings ran every draw) with the interval of the paired statistic, whether it
excludes no effect (a ratio of 1, a difference of 0), and the draws whose own ratio or difference goes the other
way."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from harmony_cli.study.intervals import Estimate, median_interval, paired_difference, paired_ratio
from harmony_cli.study.spec import Claim, Paired
from harmony_cli.study.table import TABLE

METHOD = "bootstrap over draws, BCa (percentile where BCa is undefined), 9999 resamples, 95 %"
MOST_LISTED = 20  # draws named against a comparison, at most


def claim_lines(table: pd.DataFrame, claims: list[Claim]) -> list[str]:
    """The report's `Claims` section (nothing without claims)."""
    if not claims:
        return []
    lines = ["", f"## Claims ({METHOD})"]
    for claim in claims:
        values = _values(table, claim)
        unit = f" [{claim.unit}]" if claim.unit else ""
        lines += ["", f"### {claim.name}: {claim.metric}{unit}", ""]
        lines += ["| grid point | draws with a value | median (95 % interval) |", "|---|---:|---|"]
        for point, runs in table.groupby("point", sort=False):
            estimate = median_interval(values[runs.index])
            lines.append(f"| {point} | {estimate.n} | {estimate.text()} |")
        if claim.paired is not None:
            lines += _paired_lines(table, values, claim.paired)
    return lines


@dataclass(frozen=True)
class Comparison:
    """A paired comparison at one combination of the other grid fields (`label`; `all` without any): its estimate
    and each draw's own ratio or difference (by sample)."""

    label: str
    estimate: Estimate
    per_draw: pd.Series

    def cells(self, no_effect: float) -> str:
        """A report row's last cells: pairs, the statistic with its interval, whether it holds, the draws against."""
        estimate = self.estimate
        holds = "n/a" if estimate.n < 2 else ("yes" if estimate.excludes(no_effect) else "no")
        return f"{estimate.n} | {estimate.text()} | {holds} | {_listed(self.against(no_effect))} |"

    def against(self, no_effect: float) -> list[int]:
        """The draws whose own value lies on the other side of no effect from the estimate (none without one)."""
        side = np.sign(self.estimate.value - no_effect)
        return sorted(int(s) for s in self.per_draw.index[np.sign(self.per_draw - no_effect) == -side]) if side else []


def paired_comparisons(table: pd.DataFrame, values: pd.Series, paired: Paired) -> list[Comparison]:
    """Per combination of the other grid fields, the paired statistic of a against b over the draws that have a
    value at both."""
    column = "point" if paired.field == "point" else f"grid.{paired.field}"
    # named points are one axis; a product grid's other fields are held
    others = [] if column == "point" else [c for c in table.columns if c.startswith("grid.") and c != column]
    frame = table.assign(_value=values)
    a = frame[frame[column].astype(str) == str(paired.a)].set_index(["sample", *others])["_value"]
    b = frame[frame[column].astype(str) == str(paired.b)].set_index(["sample", *others])["_value"]
    both = pd.concat({"a": a, "b": b}, axis=1).dropna()
    ratio = paired.statistic == "ratio"
    statistic = paired_ratio if ratio else paired_difference
    groups = [((), both)] if not others else list(both.groupby(level=others, sort=False))
    out = []
    for key, group in groups:
        key = key if isinstance(key, tuple) else (key,)
        label = ", ".join(f"{c.removeprefix('grid.').split('.')[-1]} = {v}" for c, v in zip(others, key)) or "all"
        own = group["a"] / group["b"] if ratio else group["a"] - group["b"]
        out.append(Comparison(label, statistic(group["a"], group["b"]), own.droplevel(others) if others else own))
    return out


def _paired_lines(table: pd.DataFrame, values: pd.Series, paired: Paired) -> list[str]:
    what = "median of a / b" if paired.statistic == "ratio" else "mean of a - b"
    lines = ["", f"Paired on the same draws: a = {paired.field} {paired.a}, b = {paired.b}; {what} per draw.", ""]
    header = "| held | pairs | statistic (95 % interval) | the interval excludes no effect | draws against it |"
    lines += [header, "|---|---:|---|---|---|"]
    comparisons = paired_comparisons(table, values, paired)
    return lines + [f"| {c.label} | {c.cells(paired.no_effect)}" for c in comparisons]


def _values(table: pd.DataFrame, claim: Claim) -> pd.Series:
    """The claim's metric per run, scaled (nan where a run has none)."""
    if claim.metric not in table:
        return pd.Series(float("nan"), index=table.index)
    column = table[claim.metric]
    numbers = column.astype(float) if column.dtype == object and column.dropna().map(type).eq(bool).all() else column
    return pd.to_numeric(numbers, errors="coerce") * claim.scale  # `success`: True / False / None -> 1 / 0 / nan


def summary_lines(studies: list[Path]) -> list[str]:
    """One table over the studies' paired claims (each study directory's study.yaml and study.parquet): per claim
    and held combination, the statistic with its interval, whether it holds, and the draws against it."""
    lines = [
        "# The claims over distributions",
        "",
        f"Each row pairs two settings on the same draws ({METHOD});",
        "a claim holds where its interval excludes no effect (a ratio of 1, a difference of 0).",
        "",
        "| study | claim | a against b | held | pairs | statistic (95 % interval) | holds | draws against it |",
        "|---|---|---|---|---:|---|---|---|",
    ]
    for study in studies:
        table = pd.read_parquet(study / TABLE)
        spec = yaml.safe_load((study / "study.yaml").read_text())
        for claim in (Claim.model_validate(c) for c in spec.get("claims", [])):
            if claim.paired is None:
                continue
            paired, name = claim.paired, spec.get("name", study.name)
            what = f"{paired.a} {'/' if paired.statistic == 'ratio' else '-'} {paired.b}"
            for comparison in paired_comparisons(table, _values(table, claim), paired):
                lines.append(
                    f"| {name} | {claim.name} | {what} | {comparison.label} | {comparison.cells(paired.no_effect)}"
                )
    return lines


def _listed(samples: list[int]) -> str:
    return (", ".join(map(str, samples[:MOST_LISTED])) + (", ..." if len(samples) > MOST_LISTED else "")) or "-"
