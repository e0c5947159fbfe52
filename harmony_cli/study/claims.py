"""The study report's claims (a study file's `claims:`): each metric per grid point as its median over the draws
with a bootstrap interval, and, where the claim pairs two settings, the comparison draw by draw on the same draws
(common random numbers: both settings ran every draw) with the interval of the paired statistic and whether it
excludes no effect (a ratio of 1, a difference of 0)."""

from __future__ import annotations

import pandas as pd

from harmony_cli.study.intervals import Estimate, median_interval, paired_difference, paired_ratio
from harmony_cli.study.spec import Claim, Paired

METHOD = "BCa bootstrap over draws, 9999 resamples, 95 %"


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


def paired_estimates(table: pd.DataFrame, values: pd.Series, paired: Paired) -> list[tuple[str, Estimate]]:
    """Per combination of the other grid fields (its label, `all` without any), the paired statistic of a against
    b over the draws that have a value at both."""
    column = "point" if paired.field == "point" else f"grid.{paired.field}"
    # named points are one axis; a product grid's other fields are held
    others = [] if column == "point" else [c for c in table.columns if c.startswith("grid.") and c != column]
    frame = table.assign(_value=values)
    a = frame[frame[column].astype(str) == str(paired.a)].set_index(["sample", *others])["_value"]
    b = frame[frame[column].astype(str) == str(paired.b)].set_index(["sample", *others])["_value"]
    both = pd.concat({"a": a, "b": b}, axis=1).dropna()
    statistic = paired_ratio if paired.statistic == "ratio" else paired_difference
    if not others:
        return [("all", statistic(both["a"], both["b"]))]
    out = []
    for key, group in both.groupby(level=others, sort=False):
        key = key if isinstance(key, tuple) else (key,)
        label = ", ".join(f"{c.removeprefix('grid.').split('.')[-1]} = {v}" for c, v in zip(others, key))
        out.append((label, statistic(group["a"], group["b"])))
    return out


def _paired_lines(table: pd.DataFrame, values: pd.Series, paired: Paired) -> list[str]:
    what = "median of a / b" if paired.statistic == "ratio" else "mean of a - b"
    no_effect = 1.0 if paired.statistic == "ratio" else 0.0
    lines = ["", f"Paired on the same draws: a = {paired.field} {paired.a}, b = {paired.b}; {what} per draw.", ""]
    lines += ["| held | pairs | statistic (95 % interval) | the interval excludes no effect |", "|---|---:|---|---|"]
    for label, estimate in paired_estimates(table, values, paired):
        holds = "n/a" if estimate.n < 2 else ("yes" if estimate.excludes(no_effect) else "no")
        lines.append(f"| {label} | {estimate.n} | {estimate.text()} | {holds} |")
    return lines


def _values(table: pd.DataFrame, claim: Claim) -> pd.Series:
    """The claim's metric per run, scaled (nan where a run has none)."""
    if claim.metric not in table:
        return pd.Series(float("nan"), index=table.index)
    column = table[claim.metric]
    numbers = column.astype(float) if column.dtype == object and column.dropna().map(type).eq(bool).all() else column
    return pd.to_numeric(numbers, errors="coerce") * claim.scale  # `success`: True / False / None -> 1 / 0 / nan
