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
from pathlib import Path

import numpy as np
import pandas as pd
import pinocchio as pin

from harmony_cli.scenario import load_scenario, robot_of


def hand_positions(model, data, robot, q: np.ndarray) -> np.ndarray:
    """(hands, 3) world positions of the robot's end effectors at its joint vector q (Pinocchio)."""
    q_pin = np.zeros(model.nq)
    q_pin[[model.joints[model.getJointId(j)].idx_q for j in robot.joint_names]] = q
    pin.framesForwardKinematics(model, data, q_pin)
    return np.array([data.oMf[model.getFrameId(link)].translation for link in robot.end_effectors])


def grip_table(run_dir: Path, start: float, end: float, every: int) -> pd.DataFrame:
    scenario = load_scenario(run_dir / "scenario.resolved.yaml")
    robot = robot_of(scenario, run_dir)  # as `harmony run RUN_DIR/scenario.resolved.yaml` resolves its paths
    model = pin.buildModelFromUrdf(str(robot.urdf))
    data = model.createData()
    steps = pd.read_csv(run_dir / "steps.csv")
    steps = steps[(steps.t >= start) & (steps.t <= end)].iloc[::every]
    left, right = robot.hand_names
    rows = []
    for _, r in steps.iterrows():
        commanded = hand_positions(model, data, robot, r[[f"cmd_q_{j}" for j in robot.joint_names]].to_numpy(float))
        width = {
            kind: 1e3
            * float(
                np.linalg.norm(
                    r[[f"{right}_{kind}_{a}" for a in "xyz"]].to_numpy(float)
                    - r[[f"{left}_{kind}_{a}" for a in "xyz"]].to_numpy(float)
                )
            )
            for kind in ("ref", "meas")
        }
        rows.append(
            {
                "t": r.t,
                "reference_mm": width["ref"],
                "commanded_mm": 1e3 * float(np.linalg.norm(commanded[1] - commanded[0])),
                "measured_mm": width["meas"],
                f"{left}_offset_mm": 1e3 * r[f"{left}_offset_m"],
                f"{right}_offset_mm": 1e3 * r[f"{right}_offset_m"],
                f"{left}_force_N": r[f"{left}_force_normal_N"],
                f"{right}_force_N": r[f"{right}_force_normal_N"],
            }
        )
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--from", dest="start", type=float, default=0.0, help="first time [s]")
    parser.add_argument("--to", dest="end", type=float, default=np.inf, help="last time [s]")
    parser.add_argument("--every", type=int, default=1, help="every n-th control step")
    args = parser.parse_args()
    print(grip_table(args.run_dir, args.start, args.end, args.every).round(2).to_string(index=False))


if __name__ == "__main__":
    main()
