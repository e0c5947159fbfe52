"""Where the stance search stands the base for a blocked place, with and without the robot's trunk (plan view).

    python tools/plot_stance_pose.py SCENARIO [--set FIELD=VALUE ...] --out FIGURE.png

For each blocked stance of the scenario (a task_warning): the pose planning/stance_pose.py finds for the phases at
its pivot, once as the scenario says and once with `robot.trunk=[]` (the footprint alone kept clear, as before
issue 14's trunk), drawn over the tables' tops, their legs and the obstacles with their margins: the footprint's
circles, the trunk's circles at a table's height and the hands' targets.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

from harmony_cli.maths.shapes import table_legs  # noqa: E402
from harmony_cli.planning.planner import Planner  # noqa: E402
from harmony_cli.planning.stance_plan import pivot_targets  # noqa: E402
from harmony_cli.planning.stance_pose import stance_pose  # noqa: E402
from harmony_cli.scenario import ScenarioError, load_scenario, robot_of  # noqa: E402


def _rectangle(centre, half, yaw_deg, **style) -> Rectangle:
    c, s = np.cos(np.deg2rad(yaw_deg)), np.sin(np.deg2rad(yaw_deg))
    corner = np.asarray(centre[:2]) - [c * half[0] - s * half[1], s * half[0] + c * half[1]]
    return Rectangle(tuple(corner), 2 * half[0], 2 * half[1], angle=yaw_deg, **style)


def _scene(ax, scenario) -> None:
    for t in scenario.world.tables:
        ax.add_patch(_rectangle(t.position, np.asarray(t.top) / 2, t.yaw_deg, color="tan", alpha=0.5))
        for leg in table_legs(t):
            ax.add_patch(_rectangle(leg.centre, leg.half, t.yaw_deg, color="saddlebrown"))
    for o in scenario.world.obstacles:
        r = o.size[0] / 2
        ax.add_patch(Circle(o.position[:2], r + o.margin, fill=False, ls="--", color="firebrick"))
        ax.add_patch(Circle(o.position[:2], r, color="firebrick", alpha=0.6))


def _robot(ax, scenario, base, colour: str, label: str) -> None:
    c, s = np.cos(base[2]), np.sin(base[2])
    turn = np.array([[c, -s], [s, c]])
    for k, (x, y, r) in enumerate(scenario.robot.footprint):
        ax.add_patch(Circle(base[:2] + turn @ [x, y], r, fill=False, color=colour, label=label if k == 0 else None))
    for x, y, r, *_ in scenario.robot.trunk:
        ax.add_patch(Circle(base[:2] + turn @ [x, y], r, color=colour, alpha=0.5))
    ax.annotate("", base[:2] + 0.4 * turn[:, 0], base[:2], arrowprops={"color": colour, "arrowstyle": "->"})


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", type=Path)
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="FIELD=VALUE")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    try:
        scenario = load_scenario(args.scenario, args.overrides)
        bare = load_scenario(args.scenario, [*args.overrides, "robot.trunk=[]"])
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        sys.exit(2)
    robot = robot_of(scenario, args.scenario.parent)
    references = Planner(robot, scenario)
    fig, ax = plt.subplots(figsize=(7, 6))
    _scene(ax, scenario)
    blocked = [s for s in references.stances if s.warning() is not None]
    if not blocked:
        print(f"{args.scenario}: no blocked stance (no stance warning); the figure shows the scene only")
    for stance in blocked:
        at_pivot = pivot_targets(scenario, robot, stance, references.planner.heading_offset)
        if at_pivot is None:  # no phase of the group works at its pivot
            continue
        pairs, headings, _ = at_pivot
        ax.plot(*pairs[:, :, :2].reshape(-1, 2).T, "k+", label=f"hand targets at {stance.pivot}")
        for which, colour, label in ((bare, "tab:orange", "footprint alone"), (scenario, "tab:blue", "with trunk")):
            pose = stance_pose(which, robot, pairs, headings)
            if pose is None:
                ax.plot([], [], color=colour, label=f"{label}: no pose found")
            else:
                _robot(
                    ax,
                    scenario,
                    pose[0],
                    colour,
                    f"{label}: ({pose[0][0]:.2f}, {pose[0][1]:.2f}) m, {np.degrees(pose[0][2]):.0f} deg",
                )
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"{scenario.name}: the place's stance pose (filled: the trunk)")
    ax.legend(loc="best", fontsize=8)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110, bbox_inches="tight")
    print(args.out)


if __name__ == "__main__":
    main()
