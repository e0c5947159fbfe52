"""The draws on which a study's grid points disagree: the same sample (the same scene) succeeding at one point and
not at another, e.g. in one physics engine and not the other. Only samples with a result at every point are
compared; a refused draw is refused at every point alike (the scene check does not depend on the grid)."""

from __future__ import annotations

import pandas as pd

from harmony_cli.report.text import markdown_cell
from harmony_cli.study.table import IMPOSSIBLE


def disagreements(table: pd.DataFrame) -> pd.DataFrame:
    """One row per sample whose success differs between grid points, indexed by sample: per point its outcome
    and its reason (columns `<point>` and `<point> reason`), in the points' order; empty with one point."""
    points = list(dict.fromkeys(table["point"]))
    decided = table[table["success"].notna() & (table["outcome"] != IMPOSSIBLE)]
    if len(points) < 2 or decided.empty:
        return pd.DataFrame()
    success = decided.pivot_table(index="sample", columns="point", values="success", aggfunc="first")
    success = success.reindex(columns=points).dropna()
    differ = success.index[success.astype(bool).nunique(axis=1) > 1]
    by_point = decided.set_index(["sample", "point"])
    rows = {
        sample: {
            column: by_point.loc[(sample, point), field]
            for point in points
            for column, field in ((point, "outcome"), (f"{point} reason", "reason"))
        }
        for sample in differ
    }
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("sample")


def disagreement_lines(table: pd.DataFrame) -> list[str]:
    """report.md's section on the draws the grid points disagree on (none with a single grid point)."""
    points = list(dict.fromkeys(table["point"]))
    if len(points) < 2:
        return []
    differ = disagreements(table)
    compared = table[table["success"].notna() & (table["outcome"] != IMPOSSIBLE)].groupby("sample")["point"].nunique()
    lines = ["", f"## Draws the grid points disagree on ({len(differ)} of {int((compared == len(points)).sum())})", ""]
    if differ.empty:
        return lines + ["Every draw with a result at every grid point has the same success at each."]
    lines += ["| sample | " + " | ".join(points) + " | why it did not succeed |", "|---:|" + "---|" * (len(points) + 1)]
    for sample, row in differ.iterrows():
        why = "; ".join(f"{p}: {row[f'{p} reason']}" for p in points if isinstance(row[f"{p} reason"], str))
        lines.append(f"| {sample} | " + " | ".join(str(row[p]) for p in points) + f" | {markdown_cell(why, 240)} |")
    return lines
