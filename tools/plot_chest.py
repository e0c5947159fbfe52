"""Where a run's base stood and what its chest did, runs side by side: the chest angle, the base's yaw and the
farther hand's distance from its phase goal over time, and the base's path in plan view with the obstacles.

    python tools/plot_chest.py RUN_DIR [RUN_DIR ...] --label before --label after --out chest.png

Each run's steps.csv gives the joints (`q_<chest joint>`, `q_base_*`) and the goal errors; its
scenario.resolved.yaml the obstacles and the chest joint. Written for issue 14's blocked stances (docs/results.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

from harmony_cli.scenario import load_scenario  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--label", action="append", default=[], help="one per run (default: the directory's name)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    labels = args.label + [run.name for run in args.runs[len(args.label) :]]
    fig, axes = plt.subplots(1, 4, figsize=(17, 3.8))
    for run, label in zip(args.runs, labels):
        steps = pd.read_csv(run / "steps.csv")
        scenario = load_scenario(run / "scenario.resolved.yaml", runnable=False)
        chest = scenario.robot.chest_joints[0]
        axes[0].plot(steps.t, np.rad2deg(steps[f"q_{chest}"]), label=label)
        axes[1].plot(steps.t, np.rad2deg(steps.q_base_yaw), label=label)
        axes[2].plot(steps.t, np.maximum(steps.left_goal_error_m, steps.right_goal_error_m), label=label)
        axes[3].plot(steps.q_base_x, steps.q_base_y, label=label)
    for obstacle in scenario.world.obstacles:  # the last run's scene: the runs compared share it
        x, y, _ = obstacle.position
        axes[3].add_patch(Circle((x, y), obstacle.size[0] / 2, color="grey", alpha=0.5))
        axes[3].add_patch(Circle((x, y), obstacle.size[0] / 2 + obstacle.margin, fill=False, ls="--", color="grey"))
    if scenario.world.box is not None and scenario.world.box.goal is not None:
        axes[3].plot(*scenario.world.box.goal[:2], "k*", label="box goal")
    titles = ["chest angle [deg]", "base yaw [deg]", "farther hand from its phase goal [m]", "base path (plan view)"]
    for ax, title in zip(axes, titles):
        ax.set_title(title)
        ax.grid(alpha=0.3)
    for ax in axes[:3]:
        ax.set_xlabel("t [s]")
    axes[2].set_ylim(0, 0.5)
    axes[3].set_aspect("equal")
    axes[3].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
