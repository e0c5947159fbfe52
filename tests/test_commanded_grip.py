"""tools/commanded_grip.py's widths: its Pinocchio kinematics of the commanded joints against OpTaS's (the robot
model the controllers use), on joint vectors built here."""

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd

from harmony_cli.scenario import load_scenario, robot_of

ROOT = Path(__file__).parents[1]
PAPER = ROOT / "scenarios" / "paper" / "pick_and_carry.yaml"


def _tool():
    spec = importlib.util.spec_from_file_location("commanded_grip", ROOT / "tools" / "commanded_grip.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_commanded_width_from_pinocchio_equals_optas_hands_apart_on_random_joints():
    scenario = load_scenario(PAPER)
    robot = robot_of(scenario, PAPER.parent)
    rng = np.random.default_rng(3)
    joints = np.clip(robot.home + rng.normal(0.0, 0.3, (5, robot.n_dof)), robot.lower, robot.upper)
    left, right = robot.hand_names
    rows = []
    for t, q in enumerate(joints):
        p0, p1 = (np.ravel(p) for p, _ in robot.hand_poses_numeric(q))
        row = {"t": float(t)} | {f"cmd_q_{j}": v for j, v in zip(robot.joint_names, q)}
        for kind, (a, b) in {"ref": (p0, p0 + [0.3, 0, 0]), "meas": (p0, p1)}.items():
            row |= {f"{left}_{kind}_{x}": v for x, v in zip("xyz", a)}
            row |= {f"{right}_{kind}_{x}": v for x, v in zip("xyz", b)}
        rows.append(row | {f"{h}_{c}": 0.0 for h in (left, right) for c in ("offset_m", "force_normal_N")})
    widths = _tool().grip_widths(robot, pd.DataFrame(rows))
    optas = [
        1e3 * np.linalg.norm(np.ravel(p1) - np.ravel(p0)) for (p0, _), (p1, _) in map(robot.hand_poses_numeric, joints)
    ]
    np.testing.assert_allclose(widths.commanded_mm, optas, atol=1e-6)  # two kinematics libraries, one robot
    np.testing.assert_allclose(widths.measured_mm, optas, atol=1e-9)
    np.testing.assert_allclose(widths.reference_mm, 300.0, atol=1e-9)
