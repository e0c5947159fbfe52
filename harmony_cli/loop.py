"""The closed loop: observe -> references at the knots -> whole-body MPC -> command -> physics -> log."""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from harmony_cli.motion import Predictor
from harmony_cli.reference import HandReference
from harmony_cli.sim import Simulation
from harmony_cli.wholebody import WholeBodyMPC
from harmony_cli.wrench import normal_forces


# (t, observation, knot times) -> positions (K, hands, 3), rotations (K, hands, 3, 3), extra log fields
References = Callable[[float, object, np.ndarray], tuple[np.ndarray, np.ndarray, dict]]


def hand_reference_matrix(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(K, hands, 3) positions and (K, hands, 3, 3) rotations -> (12 * hands) x K, per hand [p; vec(R)]."""
    K, hands = positions.shape[:2]
    vec_r = rotations.transpose(0, 1, 3, 2).reshape(K, hands, 9)  # column-major vec(R), as casadi.vec
    return np.concatenate([positions, vec_r], axis=2).reshape(K, 12 * hands).T


def rotation_error_deg(r: np.ndarray, r_ref: np.ndarray) -> float:
    cos = (np.trace(r_ref.T @ r) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def run_loop(mpc: WholeBodyMPC, sim: Simulation, references: References, duration: float, control_dt: float,
             substeps: int, record: Callable[[dict], None], on_step: Callable[[int, int], None] = lambda i, n: None,
             watch: Callable[[float, object], dict] | None = None, predict: Predictor | None = None):
    """Run the whole scenario; every step's record goes to `record` as soon as it exists (nothing is lost).

    `loop_ms` is the wall time from the observation to the command: references (planner) + obstacle prediction +
    whole-body MPC; `watch(t, obs)` adds logged fields measured outside it. `predict` (moving obstacles) gives the
    whole-body MPC the obstacles' centres at t + its knot times every step."""
    robot = mpc.robot
    n_steps = int(round(duration / control_dt))
    for step in range(n_steps):
        t = step * control_dt
        obs = sim.observe()  # the MPC always starts from the measured state
        start = time.perf_counter()
        positions, rotations, extra = references(t, obs, mpc.knot_times)
        p = hand_reference_matrix(positions, rotations)
        force_ref = extra.pop("force_ref", None)  # hands x K squeeze forces, when the admittance is on
        pad_forces = normal_forces(obs.wrenches)  # wrist sensors, pad pressed > 0
        if predict is not None:
            mpc.set_obstacle_centres(predict(t + mpc.knot_times))
        command, result = mpc.step(obs.q, p, force_ref, pad_forces)
        loop_ms = 1e3 * (time.perf_counter() - start)
        row = {"step": step, "t": t, "solve_ms": 1e3 * result.solve_time, "build_ms": 1e3 * result.build_time,
               "loop_ms": loop_ms, "status": result.status,
               "success": result.success, "held_last_plan": command.held, "iterations": result.iterations}
        reference_now = extra.pop("reference_now", positions[0])
        row |= extra | (watch(t, obs) if watch else {})
        row |= {f"cost_{k}": v for k, v in mpc.problem.evaluate_terms(result.x, mpc.params).items()}
        contact = sim.pad_contact_forces() if sim.world is not None and sim.world.box is not None else None
        for h, hand in enumerate(robot.hand_names):
            err = obs.hand_positions[h] - reference_now[h]
            row |= {f"{hand}_ref_{a}": v for a, v in zip("xyz", reference_now[h])}
            row |= {f"{hand}_meas_{a}": v for a, v in zip("xyz", obs.hand_positions[h])}
            row[f"{hand}_error_m"] = float(np.linalg.norm(err))
            row[f"{hand}_rot_error_deg"] = rotation_error_deg(obs.hand_rotations[h], rotations[0, h])
            row[f"{hand}_force_normal_N"] = float(pad_forces[h])
            if force_ref is not None:
                row[f"{hand}_force_ref_N"] = float(force_ref[h, 0])
                row[f"{hand}_offset_m"] = float(command.offsets[h])  # compliant offset commanded along the normal
                row[f"{hand}_force_seen_N"] = float(mpc.force_seen[h])  # the low-passed force the admittance used
            row |= {f"{hand}_force_{a}_N": v for a, v in zip("xyz", obs.wrenches[h, :3])}  # grasp frame
            if contact is not None:
                row[f"{hand}_contact_N"] = float(contact[h])  # PyBullet's pad-box contact normal force
        row |= sim.pushes.magnitudes(t)  # push_<name>_N, the force acting over the coming physics steps
        row |= {f"q_{j}": v for j, v in zip(robot.joint_names, obs.q)}
        row |= {f"cmd_q_{j}": v for j, v in zip(robot.joint_names, command.q)}
        row |= {f"cmd_qd_{j}": v for j, v in zip(robot.joint_names, command.qd)}
        if sim.world is not None:  # the true distances, measured by PyBullet
            for name in sim.world.moving:
                row |= {f"obstacle_{name}_{a}": v for a, v in zip("xyz", sim.world.obstacle_position(name))}
            for name in sim.world.obstacles:
                row[f"clearance_robot_{name}_m"] = sim.world.clearance(sim.body, name)
                if sim.world.box is not None:
                    row[f"clearance_box_{name}_m"] = sim.world.clearance(sim.world.box, name)
        record(row)
        sim.apply(command.q, command.qd)
        sim.step(substeps)
        on_step(step + 1, n_steps)


def trajectory_references(reference: HandReference) -> References:
    """A fixed hand trajectory (Table 1) as the loop's reference source."""
    return lambda t, obs, knot_times: (*reference.poses(t + knot_times), {})
