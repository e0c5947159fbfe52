"""The simulator behind one interface (engine.py): PyBullet (bullet.py, own DIRECT client) or MuJoCo
(mujoco_sim.py), each with the robot, tables, box and obstacles; wrist force/torque sensing, scripted pushes and
video. It hands controllers an Observation and the logs a Truth."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # MuJoCo renders videos offscreen (no display), chosen at its import
