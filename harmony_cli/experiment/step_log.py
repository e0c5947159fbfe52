"""One row of steps.csv per control step: timing, solver status and cost terms, references and measurements
per hand, forces, joints and commands, and the simulator's ground truth."""

from __future__ import annotations

import time
from functools import cache

import numpy as np

from harmony_cli.maths.rotations import rotation_error_deg
from harmony_cli.mpc.problem import SolveResult
from harmony_cli.mpc.wholebody import Command, WholeBodyMPC
from harmony_cli.robot.observation import Observation
from harmony_cli.sim.simulation import Truth
from harmony_cli.tasks.targets import HandTargets


def step_record(
    step: int,
    t: float,
    loop_ms: float,
    mpc: WholeBodyMPC,
    obs: Observation,
    targets: HandTargets,
    command: Command,
    result: SolveResult,
    truth: Truth,
    watched: dict,
) -> dict:
    robot = mpc.robot
    row = {
        "step": step,
        "t": t,
        "wall_clock_s": time.time(),  # Unix time of this record: what a signal or kill cut off is judged by it
        "solve_ms": 1e3 * result.solve_time,
        "build_ms": 1e3 * result.build_time,
        "loop_ms": loop_ms,
        "status": result.status,
        "success": result.success,
        "held_last_plan": command.held,
        "iterations": result.iterations,
    }
    row |= targets.log | watched
    row |= {f"cost_{k}": v for k, v in result.cost_terms.items()}
    row["constraint_violation"] = result.max_violation
    for h, hand in enumerate(robot.hand_names):
        row |= _hand(hand, h, obs, targets, command, mpc.force_seen, truth)
    row |= truth.push_N
    q, cmd_q, cmd_qd = _joint_columns(robot.joint_names)
    row |= zip(q, obs.q)
    row |= zip(cmd_q, command.q)
    row |= zip(cmd_qd, command.qd)
    for name, position in truth.obstacle_positions.items():
        row |= {f"obstacle_{name}_{a}": v for a, v in zip("xyz", position)}
    for name, clearance in truth.clearance_robot_m.items():  # the true distances, measured by PyBullet
        row[f"clearance_robot_{name}_m"] = clearance
        if name in truth.clearance_box_m:
            row[f"clearance_box_{name}_m"] = truth.clearance_box_m[name]
    return row


@cache
def _joint_columns(joints: tuple[str, ...]) -> tuple[tuple[str, ...], ...]:
    """The joint columns' names (q_, cmd_q_, cmd_qd_), made once per robot, not every step."""
    return tuple(tuple(f"{prefix}{j}" for j in joints) for prefix in ("q_", "cmd_q_", "cmd_qd_"))


def _hand(
    hand: str, h: int, obs: Observation, targets: HandTargets, command: Command, force_seen: np.ndarray, truth: Truth
) -> dict:
    """A hand's reference and measured position, errors, sensed forces and, with admittance, its force loop."""
    row = {f"{hand}_ref_{a}": v for a, v in zip("xyz", targets.now[h])}
    row |= {f"{hand}_meas_{a}": v for a, v in zip("xyz", obs.hand_positions[h])}
    row[f"{hand}_error_m"] = float(np.linalg.norm(obs.hand_positions[h] - targets.now[h]))
    row[f"{hand}_rot_error_deg"] = rotation_error_deg(obs.hand_rotations[h], targets.rotations[0, h])
    row[f"{hand}_force_normal_N"] = float(obs.pad_forces[h])
    if targets.force_ref is not None:
        row[f"{hand}_force_ref_N"] = float(targets.force_ref[h, 0])
        row[f"{hand}_offset_m"] = float(command.offsets[h])  # compliant offset commanded along the normal
        row[f"{hand}_force_seen_N"] = float(force_seen[h])  # the low-passed force the admittance used
    row |= {f"{hand}_force_{a}_N": v for a, v in zip("xyz", obs.wrenches[h, :3])}  # grasp frame
    if truth.pad_contact_N is not None:
        row[f"{hand}_contact_N"] = float(truth.pad_contact_N[h])  # PyBullet's pad-box contact normal force
    return row
