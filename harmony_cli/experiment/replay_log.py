"""replay.npz beside steps.csv: per control step what a replay draws and steps.csv lacks, as arrays (one row a
step): the whole-body MPC's joint positions at its knots, the hand references it was given at them, the
planner's current plan (Bezier control points, start, horizon) and the box's pose (the simulator's truth).

Cheap by construction: a step copies a few small arrays into lists (no formatting, no file access); the file
is written once, when the run ends however it ends (`write`: completed, failed or interrupted)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from harmony_cli.mpc.wholebody import WholeBodyMPC
from harmony_cli.planning.hand_plan import Plan
from harmony_cli.sim.truth import Truth
from harmony_cli.tasks.targets import HandTargets

REPLAY = "replay.npz"


class ReplayLog:
    """Rows appended by `add` during the loop; `write` stacks them into replay.npz (float32: ~1 mm at 100 m)."""

    def __init__(self) -> None:
        self.columns: dict[str, list[np.ndarray]] = {}

    def _append(self, name: str, value: Any) -> None:
        column = self.columns.get(name)
        if column is None:
            column = self.columns[name] = []
        column.append(np.array(value, dtype=np.float32))  # a copy: the controllers reuse their arrays

    def add(self, mpc: WholeBodyMPC, targets: HandTargets, plan: Plan | None, truth: Truth) -> None:
        """One step: q at the knots (K, n_dof) of the plan the command came from, the references at the knots
        (K, hands, 3), the planner's plan when there is one and the box's centre and quaternion."""
        transcription = mpc.transcription
        if mpc.x is not None:
            q_knots = transcription.positions(mpc.x) @ transcription.position_basis.T  # (n_dof [+ offsets], K)
            self._append("knot_q", q_knots[: mpc.robot.n_dof].T)
        self._append("knot_ref", targets.positions)
        if plan is not None:
            self._append("plan_points", plan.control_points)
            self._append("plan_span", (plan.start, plan.horizon))
        if truth.box_pose is not None:
            self._append("box_pose", truth.box_pose)

    def arrays(self) -> dict[str, np.ndarray]:
        """Each column stacked (steps first); a column whose rows changed shape is left out."""
        stacked = {}
        for name, rows in self.columns.items():
            if rows and all(r.shape == rows[0].shape for r in rows):
                stacked[name] = np.stack(rows)
        return stacked

    def write(self, out: Path) -> Path | None:
        """replay.npz in `out` (nothing when no step was logged)."""
        arrays: dict[str, Any] = self.arrays()
        if not arrays:
            return None
        path = out / REPLAY
        np.savez_compressed(path, **arrays)
        return path
