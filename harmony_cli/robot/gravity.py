"""Can the robot hold its home pose? Gravity torques (Pinocchio, from the prepared URDF's masses) against the
URDF's effort limits, joint by joint; cached on disk by the URDF's content, the joints and the pose (Pinocchio
takes ~0.3 s to import and build the model: a warm run needs neither)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harmony_cli.cache import cached_json
from harmony_cli.capture import captured_output
from harmony_cli.robot.urdf_form import urdfdom_reason


def gravity_torques(urdf: Path, joint_names: tuple[str, ...], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per joint of `joint_names` at `q` (that order): the torque [N m | N] holding the robot against gravity and
    the URDF's effort limit."""
    key = urdf.read_bytes() + repr((tuple(joint_names), np.asarray(q).tolist())).encode()

    def compute() -> dict:
        torque, effort = _pinocchio_gravity(urdf, joint_names, q)
        return {"torque": torque.tolist(), "effort": effort.tolist()}

    values = cached_json("gravity", key, compute)
    return np.array(values["torque"], dtype=float), np.array(values["effort"], dtype=float)


def _pinocchio_gravity(urdf: Path, joint_names: tuple[str, ...], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import pinocchio as pin  # ~0.3 s to import: only when the cache does not have the answer

    with captured_output() as printed:
        try:
            model = pin.buildModelFromUrdf(str(urdf))
        except ValueError:
            model = None
    if model is None:
        raise ValueError(urdfdom_reason(printed) or f"{urdf.name} is not a valid URDF model")
    data = model.createData()
    config = pin.neutral(model)
    index = {name: model.joints[model.getJointId(name)] for name in joint_names}
    for i, name in enumerate(joint_names):
        config[index[name].idx_q] = q[i]
    tau = pin.computeGeneralizedGravity(model, data, config)
    torque = np.array([tau[index[name].idx_v] for name in joint_names])
    effort = np.array([model.effortLimit[index[name].idx_v] for name in joint_names])
    return torque, effort
