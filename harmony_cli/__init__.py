"""harmony: YAML-driven whole-body Bezier MPC experiments for dual-arm mobile manipulators."""

__version__ = "0.1.0"
