"""The grip a run asked for, commanded and got: whether a held box is let go by the references, by the whole-body
MPC's command or by the arms' execution of it.

    python tools/commanded_grip.py RUN_DIR --from 40.2 --to 40.8 [--every 2]

For each control step in the window (from the run's steps.csv), the hands' distance apart [mm]:
  reference   the task planner's references at t (what the whole-body MPC tracks)
  commanded   the whole-body MPC's joint command put through Pinocchio's kinematics (independent of OpTaS)
  measured    the hands as PyBullet reports them
and each hand's compliant offset at t + dt [mm] and pad force [N]. The robot is loaded from the run's
scenario.resolved.yaml as `harmony run` loads it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

import numpy as np
import pandas as pd
import pinocchio as pin

from harmony_cli.robot.model import Robot
from harmony_cli.scenario import ScenarioError, load_scenario, robot_of


def grip_widths(robot: Robot, steps: pd.DataFrame) -> pd.DataFrame:
    """Per row of a steps.csv frame: the hands' distance apart as referenced, commanded and measured [mm], the
    compliant offsets [mm] and the pad forces [N]."""
    model = pin.buildModelFromUrdf(str(robot.urdf))
    data = model.createData()
    columns = [model.joints[model.getJointId(j)].idx_q for j in robot.joint_names]
    frames = [model.getFrameId(link) for link in robot.end_effectors]
    commanded = []
    for q in steps[[f"cmd_q_{j}" for j in robot.joint_names]].to_numpy(float):
        q_pin = np.zeros(model.nq)
        q_pin[columns] = q
        pin.framesForwardKinematics(model, data, q_pin)
        commanded.append(data.oMf[frames[1]].translation - data.oMf[frames[0]].translation)
    left, right = robot.hand_names
    apart = lambda kind: (
        steps[[f"{right}_{kind}_{a}" for a in "xyz"]].to_numpy(float)
        - steps[[f"{left}_{kind}_{a}" for a in "xyz"]].to_numpy(float)
    )
    return pd.DataFrame(
        {
            "t": steps.t.to_numpy(),
            "reference_mm": 1e3 * np.linalg.norm(apart("ref"), axis=1),
            "commanded_mm": 1e3 * np.linalg.norm(np.reshape(commanded, (-1, 3)), axis=1),
            "measured_mm": 1e3 * np.linalg.norm(apart("meas"), axis=1),
            **{f"{h}_offset_mm": 1e3 * steps[f"{h}_offset_m"].to_numpy() for h in (left, right)},
            **{f"{h}_force_N": steps[f"{h}_force_normal_N"].to_numpy() for h in (left, right)},
        }
    )


def _fail(message: str) -> NoReturn:
    """Bad input: one line, exit 2."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--from", dest="start", type=float, default=0.0, help="first time [s]")
    parser.add_argument("--to", dest="end", type=float, default=np.inf, help="last time [s]")
    parser.add_argument("--every", type=int, default=1, help="every n-th control step")
    args = parser.parse_args()
    if args.every < 1:
        _fail(f"--every {args.every}: a number of control steps, 1 or more")
    missing = [n for n in ("steps.csv", "scenario.resolved.yaml") if not (args.run_dir / n).is_file()]
    if missing:
        _fail(f"{args.run_dir}: not a run directory (no {' or '.join(missing)})")
    try:
        scenario = load_scenario(args.run_dir / "scenario.resolved.yaml", runnable=False)
        robot = robot_of(scenario, args.run_dir)  # as `harmony run RUN_DIR/scenario.resolved.yaml` resolves paths
    except ScenarioError as exc:
        _fail(str(exc))
    if len(robot.hand_names) != 2:
        _fail(f"{args.run_dir}: the robot has {len(robot.hand_names)} hands; a grip needs 2")
    steps = pd.read_csv(args.run_dir / "steps.csv")
    steps = steps[(steps.t >= args.start) & (steps.t <= args.end)].iloc[:: args.every]
    if steps.empty:
        _fail(f"{args.run_dir}: no control step between --from {args.start} and --to {args.end}")
    print(grip_widths(robot, steps).round(2).to_string(index=False))


if __name__ == "__main__":
    main()
