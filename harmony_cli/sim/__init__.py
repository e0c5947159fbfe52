"""The simulator: a PyBullet world (own DIRECT client) with the robot, tables, box and obstacles; wrist
force/torque sensing, scripted pushes and video. It hands controllers an Observation and the logs a Truth."""
