"""What the whole-body MPC and the grip did while the box was held, per run of a study: how many held steps the MPC
took with its clearance rows relaxed (the strict QP had no step) or left violated by more than 1 cm, and the grip
as the carry started (the pads' shear along the box face, the chest angle). Prints the failures and the
crosstab of success against relaxed held steps; plots one against the other.

    python tools/held_diagnostics.py results/studies/pick_and_carry_random --out held.png

Each run's steps.csv gives `holding`, `status`, `constraint_violation`, `grip_shear_m`, `phase` and the chest joint
(from its scenario.resolved.yaml); its summary.json the outcome. Written for issue 14 (docs/results.md).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from harmony_cli.scenario import load_scenario  # noqa: E402

VIOLATED_M = 0.01  # [m] a clearance row this far inside its margin after the step counts as violated


def held(run: Path) -> dict:
    """One run's row: its sample (directory name), success, failure category and the held-phase numbers."""
    task = json.loads((run / "summary.json").read_text())["task"]
    steps = pd.read_csv(run / "steps.csv")
    chest = load_scenario(run / "scenario.resolved.yaml", runnable=False).robot.chest_joints
    hold = steps[steps.holding.astype(bool)]
    carry = steps.index[steps.phase == "carry"]
    start = steps.loc[carry[0]] if len(carry) else None
    return {
        "run": run.name,
        "success": bool(task["success"]),
        "category": (task.get("failure") or {}).get("category", ""),
        "held_relaxed": int(hold.status.str.contains("relaxed", regex=False).sum()),
        "held_violated": int((hold.constraint_violation > VIOLATED_M).sum()),
        "carry_shear_mm": float("nan") if start is None else 1e3 * start.grip_shear_m,
        "carry_chest_rad": float("nan") if start is None or not chest else start[f"q_{chest[0]}"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", type=Path, help="a study's output directory (its runs/ hold the runs)")
    parser.add_argument("--out", type=Path, required=True, help="the plot (.png)")
    args = parser.parse_args()
    runs = sorted(p for p in (args.study / "runs").iterdir() if (p / "summary.json").exists())
    table = pd.DataFrame([held(run) for run in runs])
    pd.set_option("display.width", 200)
    print(table[~table.success | (table.held_relaxed > 0)].round(3).to_string(index=False))
    print(pd.crosstab(table.success, table.held_relaxed > 0, rownames=["success"], colnames=["relaxed while held"]))
    fig, ax = plt.subplots(figsize=(6, 4))
    for ok, marker in ((True, "o"), (False, "x")):
        part = table[table.success == ok]
        ax.scatter(part.carry_shear_mm, part.held_relaxed, marker=marker, label="success" if ok else "failure")
    for _, row in table[~table.success].iterrows():
        ax.annotate(row.run[:6], (row.carry_shear_mm, row.held_relaxed), fontsize=7)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel("grip shear as the carry starts [mm]")
    ax.set_ylabel("held steps with clearance relaxed")
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
