"""Robots: URDF reading and preparation, the kinematic model every MPC uses, and robot presets (data files of a
robot's defaults: URDF, hands, joint roles, home pose, base footprint)."""
