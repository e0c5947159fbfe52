"""The closed loop: observe -> references at the knots -> whole-body MPC -> command -> physics -> log."""

from __future__ import annotations

from typing import Callable

import numpy as np

from harmony_cli.reference import HandReference
from harmony_cli.sim import Simulation
from harmony_cli.wholebody import WholeBodyMPC


def hand_reference_matrix(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(K, hands, 3) positions and (K, hands, 3, 3) rotations -> (12 * hands) x K, per hand [p; vec(R)]."""
    K, hands = positions.shape[:2]
    vec_r = rotations.transpose(0, 1, 3, 2).reshape(K, hands, 9)  # column-major vec(R), as casadi.vec
    return np.concatenate([positions, vec_r], axis=2).reshape(K, 12 * hands).T


def rotation_error_deg(r: np.ndarray, r_ref: np.ndarray) -> float:
    cos = (np.trace(r_ref.T @ r) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def run_loop(mpc: WholeBodyMPC, sim: Simulation, reference: HandReference, duration: float, control_dt: float,
             substeps: int, record: Callable[[dict], None], on_step: Callable[[int, int], None] = lambda i, n: None):
    """Run the whole scenario; every step's record goes to `record` as soon as it exists (nothing is lost)."""
    robot = mpc.robot
    n_steps = int(round(duration / control_dt))
    for step in range(n_steps):
        t = step * control_dt
        obs = sim.observe()  # the MPC always starts from the measured state
        positions, rotations = reference.poses(t + mpc.knot_times)
        p = hand_reference_matrix(positions, rotations)
        command, result = mpc.step(obs.q, p)
        row = {"step": step, "t": t, "solve_ms": 1e3 * result.solve_time, "build_ms": 1e3 * result.build_time,
               "status": result.status,
               "success": result.success, "held_last_plan": command.held, "iterations": result.iterations}
        row |= {f"cost_{k}": v for k, v in mpc.problem.evaluate_terms(result.x, p.ravel(order="F")).items()}
        for h, hand in enumerate(robot.hand_names):
            err = obs.hand_positions[h] - positions[0, h]
            row |= {f"{hand}_ref_{a}": v for a, v in zip("xyz", positions[0, h])}
            row |= {f"{hand}_meas_{a}": v for a, v in zip("xyz", obs.hand_positions[h])}
            row[f"{hand}_error_m"] = float(np.linalg.norm(err))
            row[f"{hand}_rot_error_deg"] = rotation_error_deg(obs.hand_rotations[h], rotations[0, h])
        row |= {f"q_{j}": v for j, v in zip(robot.joint_names, obs.q)}
        row |= {f"cmd_q_{j}": v for j, v in zip(robot.joint_names, command.q)}
        row |= {f"cmd_qd_{j}": v for j, v in zip(robot.joint_names, command.qd)}
        record(row)
        sim.apply(command.q, command.qd)
        sim.step(substeps)
        on_step(step + 1, n_steps)
