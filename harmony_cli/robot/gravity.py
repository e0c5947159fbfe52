"""Can the robot hold its home pose? Gravity torques (Pinocchio, from the prepared URDF's masses) against the
URDF's effort limits, joint by joint; cached on disk by the URDF's content, the joints and the pose (Pinocchio
takes ~0.3 s to import and build the model: a warm run needs neither)."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from harmony_cli.cache import CACHE_DIR
from harmony_cli.capture import captured_output


def gravity_torques(urdf: Path, joint_names: tuple[str, ...], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per joint of `joint_names` at `q` (that order): the torque [N m | N] holding the robot against gravity and
    the URDF's effort limit."""
    key = hashlib.sha256(urdf.read_bytes() + repr((tuple(joint_names), np.asarray(q).tolist())).encode())
    cached = CACHE_DIR / "gravity" / f"{key.hexdigest()[:24]}.json"
    try:
        values = json.loads(cached.read_text())
        return np.array(values["torque"], dtype=float), np.array(values["effort"], dtype=float)
    except (OSError, ValueError, KeyError, TypeError):
        pass
    torque, effort = _pinocchio_gravity(urdf, joint_names, q)
    try:
        cached.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=cached.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as out:
            json.dump({"torque": torque.tolist(), "effort": effort.tolist()}, out)  # floats round-trip exactly
        os.replace(tmp, cached)
    except OSError:
        pass  # a read-only cache: computed again next time
    return torque, effort


def _pinocchio_gravity(urdf: Path, joint_names: tuple[str, ...], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import pinocchio as pin  # ~0.3 s to import: only when the cache does not have the answer

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
