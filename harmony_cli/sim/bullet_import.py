"""PyBullet, loaded on first use with the build banner it prints on import captured (for run.log, not the console).
Every harmony module that uses PyBullet takes it from here, so a MuJoCo run never loads PyBullet."""

from harmony_cli.capture import captured_output

with captured_output() as BANNER:
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

__all__ = ["BANNER", "BulletClient", "pybullet"]
