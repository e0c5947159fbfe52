"""One row of steps.csv per control step: timing, solver status and cost terms, references and measurements
per hand, forces, joints and commands, and the simulator's ground truth.

Column names are made once per name (cached), not formatted every step; values are computed as they always were
(the same numpy calls per hand), so the rows are what they were, only cheaper to build."""

from __future__ import annotations

import time
from functools import cache
from typing import NamedTuple

import numpy as np

from harmony_cli.maths.rotations import rotation_error_deg
from harmony_cli.mpc.problem import SolveResult
from harmony_cli.mpc.wholebody import Command, WholeBodyMPC
from harmony_cli.robot.observation import Observation
from harmony_cli.sim.truth import Truth
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
    row |= targets.log
    row |= watched
    costs = result.cost_terms
    row |= zip(_prefixed("cost_", tuple(costs)), costs.values())
    row["constraint_violation"] = result.max_violation
    _add_hands(row, robot.hand_names, obs, targets, command, mpc.force_seen, truth)
    row |= truth.push_N
    q, cmd_q, cmd_qd = _joint_columns(robot.joint_names)
    row |= zip(q, obs.q)
    row |= zip(cmd_q, command.q)
    row |= zip(cmd_qd, command.qd)
    for name, position in truth.obstacle_positions.items():
        row |= zip(_obstacle_columns(name), position)
    for name, clearance in truth.clearance_robot_m.items():  # the true distances, measured by PyBullet
        robot_column, box_column = _clearance_columns(name)
        row[robot_column] = clearance
        if name in truth.clearance_box_m:
            row[box_column] = truth.clearance_box_m[name]
    for name, depth in truth.contact_robot_m.items():  # PyBullet's contact points (sim/touches.py)
        row[_contact_column("robot", name)] = depth
    for name, depth in truth.contact_box_m.items():
        row[_contact_column("box", name)] = depth
    return row


@cache
def _prefixed(prefix: str, names: tuple[str, ...]) -> tuple[str, ...]:
    """prefix + name for each name (cost terms, joints), made once per set of names."""
    return tuple(prefix + name for name in names)


@cache
def _joint_columns(joints: tuple[str, ...]) -> tuple[tuple[str, ...], ...]:
    """The joint columns' names (q_, cmd_q_, cmd_qd_)."""
    return tuple(_prefixed(prefix, joints) for prefix in ("q_", "cmd_q_", "cmd_qd_"))


@cache
def _obstacle_columns(name: str) -> tuple[str, ...]:
    return tuple(f"obstacle_{name}_{a}" for a in "xyz")


@cache
def _clearance_columns(name: str) -> tuple[str, str]:
    return f"clearance_robot_{name}_m", f"clearance_box_{name}_m"


@cache
def _contact_column(who: str, name: str) -> str:
    return f"contact_{who}_{name}_m"


class _HandColumns(NamedTuple):
    ref: tuple[str, ...]
    meas: tuple[str, ...]
    error: str
    rotation_error: str
    normal: str
    force_ref: str
    offset: str
    force_seen: str
    force: tuple[str, ...]
    contact: str
    contact_points: str
    friction_used: str
    normal_off_face: str


@cache
def _hand_columns(hand: str) -> _HandColumns:
    return _HandColumns(
        ref=tuple(f"{hand}_ref_{a}" for a in "xyz"),
        meas=tuple(f"{hand}_meas_{a}" for a in "xyz"),
        error=f"{hand}_error_m",
        rotation_error=f"{hand}_rot_error_deg",
        normal=f"{hand}_force_normal_N",
        force_ref=f"{hand}_force_ref_N",
        offset=f"{hand}_offset_m",
        force_seen=f"{hand}_force_seen_N",
        force=tuple(f"{hand}_force_{a}_N" for a in "xyz"),
        contact=f"{hand}_contact_N",
        contact_points=f"{hand}_contact_points",
        friction_used=f"{hand}_friction_used",
        normal_off_face=f"{hand}_contact_normal_off_face_deg",
    )


def _add_hands(
    row: dict,
    hands: tuple[str, ...],
    obs: Observation,
    targets: HandTargets,
    command: Command,
    force_seen: np.ndarray,
    truth: Truth,
) -> None:
    """Per hand, its reference and measured position, errors, sensed forces and, with admittance, its force loop."""
    pad_forces, errors = obs.pad_forces, obs.hand_positions - targets.now
    for h, hand in enumerate(hands):
        c = _hand_columns(hand)
        row |= zip(c.ref, targets.now[h])
        row |= zip(c.meas, obs.hand_positions[h])
        row[c.error] = float(np.sqrt(errors[h].dot(errors[h])))  # np.linalg.norm's computation, without its checks
        row[c.rotation_error] = rotation_error_deg(obs.hand_rotations[h], targets.rotations[0, h])
        row[c.normal] = float(pad_forces[h])
        if targets.force_ref is not None:
            row[c.force_ref] = float(targets.force_ref[h, 0])
            row[c.offset] = float(command.offsets[h])  # compliant offset commanded along the normal
            row[c.force_seen] = float(force_seen[h])  # the low-passed force the admittance used
        row |= zip(c.force, obs.wrenches[h, :3])  # grasp frame
        if truth.pad_contacts is not None:  # sim/contacts.py
            row[c.contact] = float(truth.pad_contacts.normal_N[h])  # PyBullet's pad-box contact normal force
            row[c.contact_points] = int(truth.pad_contacts.points[h])
            row[c.friction_used] = float(truth.pad_contacts.friction_used[h])
            row[c.normal_off_face] = float(truth.pad_contacts.normal_off_face_deg[h])
