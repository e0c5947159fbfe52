"""Pair two studies' runs of the same draws (e.g. the code before and after a change, each run with `harmony study
... --out DIR` in its own checkout) and say what the change did to the outcomes.

    python tools/compare_studies.py BEFORE_DIR AFTER_DIR

Runs are paired by their draw (set, seed, sample) and grid point, or by their draw alone where each side ran one
grid point (the same study run again with one setting changed, `--grid field=value`); only pairs with a result on
both sides count, and a draw refused as impossible on either side counts on neither (as in the study report's
denominator).
Printed: each side's successes of the paired draws with a Wilson 95 % interval, the table of outcomes before
against after, every draw whose outcome changed, and the exact McNemar test on the draws whose success flipped
(a two-sided binomial test of the flips one way against the other): a change whose gains and losses could be
the same coin is not an improvement, however many draws it gains on the ones it was argued from. Contact-rich
carries are chaotic: some draws flip under a change that should do nothing. The base run again with a negligible
perturbation (e.g. `--grid world.box.friction=0.8000001`, the box's friction changed by a part in ten million) and
compared with the base says how many flips a change that does nothing makes.

A change is chosen on development draws; validation draws are run to report, never to choose between variants,
so studies of a `validation` set are refused (exit 2).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
from scipy.stats import binomtest

from harmony_cli.study.intervals import wilson
from harmony_cli.study.table import IMPOSSIBLE, TABLE

KEYS = ["draws", "seed", "sample", "point"]
REPORT_ONLY = "validation"  # the set of draws that is run to report, never to choose


def one_point_each(before: pd.DataFrame, after: pd.DataFrame) -> bool:
    """Whether each side ran a single grid point (its runs then pair by draw, whatever the points are named)."""
    return before.point.nunique() == 1 and after.point.nunique() == 1


def paired(before: pd.DataFrame, after: pd.DataFrame) -> pd.DataFrame:
    """One row per draw and grid point run on both sides (per draw where each side ran one grid point: `point` is
    the before side's): KEYS, success_a/b and outcome_a/b."""
    keys = KEYS[:-1] if one_point_each(before, after) else KEYS
    outcomes = ["success", "outcome"]
    both = before[[*KEYS, *outcomes]].merge(after[[*keys, *outcomes]], on=keys, suffixes=("_a", "_b"))
    refused = (both.outcome_a == IMPOSSIBLE) | (both.outcome_b == IMPOSSIBLE)
    both = both[~refused].dropna(subset=["success_a", "success_b"])
    return both.astype({"success_a": bool, "success_b": bool}).sort_values(KEYS, ignore_index=True)


def rate(successes: int, n: int) -> str:
    """`k of n (rate, Wilson 95 % a - b)`, in the study report's style."""
    low, high = wilson(successes, n)
    return f"{successes} of {n} ({100 * successes / n:.0f} %, Wilson 95 % {100 * low:.0f} % - {100 * high:.0f} %)"


def mcnemar(pairs: pd.DataFrame) -> tuple[int, int, float]:
    """(draws gained, draws lost, the exact two-sided McNemar p-value; 1 without flips)."""
    gained = int((~pairs.success_a & pairs.success_b).sum())
    lost = int((pairs.success_a & ~pairs.success_b).sum())
    flips = gained + lost
    return gained, lost, 1.0 if flips == 0 else float(binomtest(gained, flips, 0.5).pvalue)


def report(pairs: pd.DataFrame) -> list[str]:
    n = len(pairs)
    gained, lost, p = mcnemar(pairs)
    lines = [
        f"before: {rate(int(pairs.success_a.sum()), n)}",
        f"after:  {rate(int(pairs.success_b.sum()), n)}",
        f"success flipped on {gained + lost} draws: {gained} gained, {lost} lost (exact McNemar p = {p:.3g})",
        "",
        "outcomes, before (rows) against after (columns):",
        pd.crosstab(pairs.outcome_a, pairs.outcome_b).to_string(),
    ]
    changed = pairs[pairs.outcome_a != pairs.outcome_b]
    lines += ["", f"draws whose outcome changed: {len(changed)}"]
    lines += [
        f"  {row.draws} {row.sample} ({row.point}): {row.outcome_a} -> {row.outcome_b}" for row in changed.itertuples()
    ]
    return lines


def _load(directory: Path) -> pd.DataFrame:
    path = directory / TABLE
    if not path.is_file():
        raise ValueError(f"{path}: no such file; run `harmony study ... --out {directory}` first")
    table = pd.read_parquet(path)
    if (table["draws"] == REPORT_ONLY).any():
        raise ValueError(
            f"{path}: draws {REPORT_ONLY!r} are run to report, never to choose between variants; compare on a "
            "development set (dev, dev2, ...)"
        )
    return table


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    try:
        before, after = (_load(Path(a)) for a in argv)
    except ValueError as error:
        print(error, file=sys.stderr)
        return 2
    pairs = paired(before, after)
    if pairs.empty:
        print(f"{argv[0]} and {argv[1]}: no draw run on both sides", file=sys.stderr)
        return 2
    named = before.point.iloc[0], after.point.iloc[0]
    if one_point_each(before, after) and named[0] != named[1]:
        print(f"one grid point each side, paired by draw: {named[0]} (before) against {named[1]} (after)")
    print("\n".join(report(pairs)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
