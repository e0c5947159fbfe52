"""The simulator: a PyBullet world (own DIRECT client) with the robot, tables, box and obstacles; wrist
force/torque sensing, scripted pushes and video. It hands controllers an Observation and the logs a Truth."""

from harmony_cli.capture import captured_output

with captured_output() as PYBULLET_BANNER:  # PyBullet prints its build time on import: run.log, not the console
    import pybullet  # noqa: F401
