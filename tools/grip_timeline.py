"""Where a held box's grip let go in a run, and which layer opened it first.

    python tools/grip_timeline.py RUN_DIR [--window SECONDS]

A grip lets go when the pads' contact force falls away from what the force loop asks: here, the first control
step with the box held at which a pad's contact force is below half of its squeeze reference. Over the window
before it, the grip's width (the distance between the two hands) is read three ways: as the task-space planner
asked (the hands' references), as the whole-body MPC commanded (forward kinematics of the commanded joint
positions) and as measured. The squeeze is a few millimetres of the pads' contact, so the layer whose width first
grew by more than OPENED over its value at the window's start is where the grip was lost (at the same step, the
earlier layer of plan -> command -> measurement): the plan, the whole-body command, or neither (then the robot
pressing on the box, if the steps log saw it, or the execution). Printed: one line with that verdict and how much
each width grew, then the window's steps.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np
import pandas as pd

from harmony_cli.robot.model import Robot
from harmony_cli.scenario import ScenarioError, load_scenario, robot_of

LOOSE = 0.5  # a pad below this share of its squeeze reference: the grip lets go
OPENED = 0.5e-3  # [m] a width that grew by more than this since the window's start opened


class Opened(Enum):
    """The first layer whose grip width opened before the grip let go."""

    PLAN = "the planner's reference"
    COMMAND = "the whole-body MPC's command"
    PRESSED = "neither: the robot pressed on the box"
    EXECUTION = "neither: the measured hands alone"


@dataclass(frozen=True)
class Loosening:
    t: float  # [s] the first step at which a pad fell below LOOSE of its squeeze reference
    phase: str
    opened: Opened
    grew: pd.Series  # [m] how much each width (reference, command, measured) grew over the window
    window: pd.DataFrame  # the steps before it (and a few after): time, widths [mm], forces, base command, status


class NotAGripRun(ValueError):
    """A run directory this tool cannot read: the message names what is missing."""


def widths(steps: pd.DataFrame, robot: Robot) -> pd.DataFrame:
    """Per step: the grip width [m] as referenced, as commanded (forward kinematics of cmd_q) and as measured."""

    def apart(kind: str) -> np.ndarray:
        first, second = (steps[[f"{h}_{kind}_{a}" for a in "xyz"]].to_numpy() for h in robot.hand_names)
        return np.linalg.norm(second - first, axis=1)

    commanded = steps[[f"cmd_q_{name}" for name in robot.joint_names]].to_numpy()
    hands = [np.array([p.ravel() for p, _ in robot.hand_poses_numeric(q)]) for q in commanded]
    return pd.DataFrame(
        {
            "reference": apart("ref"),
            "command": [float(np.linalg.norm(h[1] - h[0])) for h in hands],
            "measured": apart("meas"),
        },
        index=steps.index,
    )


def first_loosening(steps: pd.DataFrame, hands: tuple[str, ...]) -> int | None:
    """The index of the first step with the box held at which a pad's contact force is below LOOSE of its squeeze
    reference (where that is positive); None if there is none."""
    held = steps.holding.astype(bool)
    loose = np.zeros(len(steps), dtype=bool)
    for h in hands:
        reference = steps[f"{h}_force_ref_N"].fillna(0.0)
        loose |= (held & (reference > 0.0) & (steps[f"{h}_contact_N"] < LOOSE * reference)).to_numpy()
    return int(steps.index[np.argmax(loose)]) if loose.any() else None


def first_opened(width: pd.DataFrame, pressed: pd.Series) -> Opened:
    """The layer whose width first grew by more than OPENED over its first row (the upstream one at the same step);
    where none did, whether the robot pressed on the box (`pressed`, per row)."""
    grew = width - width.iloc[0]
    firsts = {layer: int(np.argmax(grew[layer] > OPENED)) for layer in width if (grew[layer] > OPENED).any()}
    if "reference" in firsts and firsts["reference"] <= firsts.get("command", len(width)):
        return Opened.PLAN
    if "command" in firsts and firsts["command"] <= firsts.get("measured", len(width)):
        return Opened.COMMAND
    return Opened.PRESSED if pressed.any() else Opened.EXECUTION


def diagnose(run: Path, window: float = 0.3) -> Loosening | None:
    """The run's first loosening and which layer's width opened first over `window` [s] before it (None: the grip
    held in every held phase)."""
    steps = pd.read_csv(run / "steps.csv", low_memory=False)
    robot = robot_of(load_scenario(run / "scenario.resolved.yaml", runnable=False), run)
    hands = robot.hand_names
    needed = ["t", "phase", "planner_status", "holding", "box_on_robot_N"]
    needed += [f"{h}_{c}" for h in hands for c in ("force_ref_N", "contact_N", "ref_x", "meas_x")]
    needed += [f"cmd_q_{name}" for name in robot.joint_names]
    missing = [c for c in needed if c not in steps]
    if len(hands) != 2 or missing:
        raise NotAGripRun(f"{len(hands)} hands" if len(hands) != 2 else f"steps.csv has no column {missing[0]}")
    at = first_loosening(steps, hands)
    if at is None:
        return None
    t = float(steps.t[at])
    rows = steps[(steps.t >= t - window - 1e-9) & (steps.t <= t + 0.1 + 1e-9)]
    width = widths(rows, robot)
    before = rows.t <= t + 1e-9
    opened = first_opened(width[before], rows.loc[before, "box_on_robot_N"].fillna(0.0) > 0.0)
    grew = width[before].iloc[-1] - width[before].iloc[0]
    base = [c for c in ("cmd_qd_base_x", "cmd_qd_base_y", "cmd_qd_base_yaw") if c in rows]
    shown = rows[["t", "phase", "planner_status", *[f"{h}_contact_N" for h in hands], *base, "box_on_robot_N"]]
    table = pd.concat([shown, 1e3 * width.add_suffix("_width_mm")], axis=1)
    return Loosening(t, str(steps.phase[at]), opened, grew, table)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run", type=Path, help="a run directory (steps.csv, scenario.resolved.yaml)")
    parser.add_argument("--window", type=float, default=0.3, help="[s] how far back the widths are compared")
    args = parser.parse_args(argv)
    if args.window <= 0.0:
        print(f"--window: {args.window:g}: must be a positive number of seconds", file=sys.stderr)
        return 2
    if not (args.run / "steps.csv").is_file():
        print(f"{args.run}: no steps.csv: not a run directory", file=sys.stderr)
        return 2
    try:
        found = diagnose(args.run, args.window)
    except NotAGripRun as error:
        print(f"{args.run}: not a run of two hands holding a box with the force loop on: {error}", file=sys.stderr)
        return 2
    except ScenarioError as error:  # already one line naming the file, the field and the choices
        print(error, file=sys.stderr)
        return 2
    if found is None:
        print(f"{args.run}: the grip held in every phase with the box held")
        return 0
    print(
        f"{args.run}: the grip let go at t = {found.t:.2f} s ({found.phase}: a pad below {LOOSE:.0%} of its squeeze "
        f"reference); opened first: {found.opened.value} (over {args.window:g} s before: "
        + ", ".join(f"{name} {1e3 * value:+.1f} mm" for name, value in found.grew.items())
        + ")"
    )
    with pd.option_context("display.width", 250, "display.max_columns", 30):
        print(found.window.round(3).to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
