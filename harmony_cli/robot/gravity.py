"""Can the robot hold its home pose? Gravity torques (Pinocchio, from the prepared URDF's masses) against the
URDF's effort limits, joint by joint."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harmony_cli.capture import captured_output


def gravity_torques(urdf: Path, joint_names: tuple[str, ...], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per joint of `joint_names` at `q` (that order): the torque [N m | N] holding the robot against gravity and
    the URDF's effort limit."""
    import pinocchio as pin  # ~0.5 s to import: only when a robot is loaded

    with captured_output():
        model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    config = pin.neutral(model)
    index = {name: model.joints[model.getJointId(name)] for name in joint_names}
    for i, name in enumerate(joint_names):
        config[index[name].idx_q] = q[i]
    tau = pin.computeGeneralizedGravity(model, data, config)
    torque = np.array([tau[index[name].idx_v] for name in joint_names])
    effort = np.array([model.effortLimit[index[name].idx_v] for name in joint_names])
    return torque, effort
