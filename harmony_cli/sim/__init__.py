"""The simulator behind one interface (engine.py): PyBullet (bullet.py, own DIRECT client) or MuJoCo
(mujoco_sim.py), each with the robot, tables, box and obstacles; wrist force/torque sensing, scripted pushes and
video. It hands controllers an Observation and the logs a Truth."""

import os

from harmony_cli.capture import captured_output

os.environ.setdefault("MUJOCO_GL", "egl")  # MuJoCo renders videos offscreen (no display), chosen at its import

with captured_output() as PYBULLET_BANNER:  # PyBullet prints its build time on import: run.log, not the console
    try:
        import pybullet  # noqa: F401
    except ImportError:  # a Python without PyBullet's wheels: MuJoCo alone
        pass
