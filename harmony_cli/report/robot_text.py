"""`harmony robots show` / `--check FILE`: what harmony makes of a robot - its active joints and limits, locked
joints, hand frames and wrist sensors, what preparing its URDF changed (the chains to the hands, the mount), how
high its hands reach together, and whether it can hold its home pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harmony_cli.robot.model import Robot
from harmony_cli.robot.reach import hand_ceiling


def robot_lines(name: str, robot: Robot) -> list[str]:
    torque, effort = robot.home_gravity, robot.effort
    assert torque is not None and effort is not None, "a robot from load_robot"
    lines = [f"{name}: {robot.n_dof} active joints (3 base), prepared URDF {robot.urdf}"]
    lines.append(
        f"  {'joint':<28} {'type':<11} {'lower':>9} {'upper':>9} {'velocity':>9} {'home':>9}  gravity / effort"
    )
    lines.append("  (deg, deg/s and N m; m, m/s and N for prismatic joints)")
    for i, joint in enumerate(robot.joint_names):
        prismatic = i in robot.prismatic
        kind = "continuous" if i in robot.continuous else "prismatic" if prismatic else "revolute"
        scale = 1.0 if prismatic else 180 / np.pi
        lower, upper = (-np.inf, np.inf) if i in robot.continuous else (robot.lower[i], robot.upper[i])
        load = "(base)" if i in robot.base_joints else f"{abs(torque[i]):.3g} / {effort[i]:.3g}"
        if i not in robot.base_joints and abs(torque[i]) > effort[i]:
            load += "  too weak"
        lines.append(
            f"  {joint:<28} {kind:<11} {lower * scale:>9.4g} {upper * scale:>9.4g} "
            f"{robot.velocity_limit[i] * scale:>9.4g} {robot.home[i] * scale:>9.4g}  {load}"
        )
    for hand, link, sensor in zip(robot.hand_names, robot.end_effectors, robot.wrist_sensors, strict=True):
        lines.append(f"  hand {hand}: frame {link}, wrist sensor {sensor}")
    lines += [f"  {note}" for note in robot.notes if not note.startswith("urdf parser")]
    verdict = (
        f"cannot hold home with the URDF's efforts at {', '.join(robot.overloaded)} (set robot.actuators: ideal)"
        if robot.overloaded
        else "holds home within the URDF's efforts"
    )
    lines.append(f"  gravity check (Pinocchio): {verdict}")
    return lines


def scenario_robot_lines(path: Path) -> list[str]:
    """robot_lines for the robot section of the scenario file at `path`, and the hands' reach: the highest both get
    together with the pads level, as far apart as at home (robot/reach.py)."""
    from harmony_cli.scenario import load_scenario, robot_of

    robot = robot_of(load_scenario(path), path.parent)
    (left, _), (right, _) = robot.hand_poses_numeric(robot.home)[:2]
    width = float(np.linalg.norm(np.asarray(right) - np.asarray(left)))
    ceiling = hand_ceiling(robot, width)
    reach = "no pose found" if ceiling is None else f"z = {ceiling:.3f} m"
    return [*robot_lines(path.name, robot), f"  reach: both hands together, pads level, {width:.3f} m apart: {reach}"]
