"""The simulator the experiment loop drives, whichever physics engine is behind it (`sim.engine`): what the
controllers see of it (an Observation), what the logs see (a Truth), the joint-level command and time. Each engine
implements this one interface; the experiment package sees only it."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    import numpy as np

    from harmony_cli.robot.model import Robot
    from harmony_cli.robot.observation import Observation
    from harmony_cli.scenario.models import SimSpec
    from harmony_cli.scenario.world import PushSpec, WorldSpec
    from harmony_cli.sim.truth import Truth


class Simulator(Protocol):
    """A robot in a world, stepped in physics steps of sim.physics_dt under the last joint-level command."""

    notes: list[str]  # what run.log says of the engine (its version, what it made of the URDF)
    physics_steps: int

    def observe(self) -> Observation:
        """What the controllers see: joints, hand frames, wrist wrenches and the box's pose."""
        ...

    def truth(self) -> Truth:
        """Ground truth for the logs (never for the controllers)."""
        ...

    def apply(self, q_target: np.ndarray, qd_target: np.ndarray) -> None:
        """The command: the base joints by velocity, every other joint by position and velocity targets."""
        ...

    def step(self, substeps: int) -> None:
        """`substeps` physics steps under the last command."""
        ...

    @property
    def time(self) -> float:
        """Simulated time [s]."""
        ...

    @property
    def connected(self) -> bool:
        """Whether the engine still answers."""
        ...

    def penetrations(self) -> list[tuple[str, str, float]]:
        """(robot link, other body, signed distance [m]) of every contact of the robot, before the first step."""
        ...

    def close(self) -> None:
        """Idempotent."""
        ...

    def camera(self, size: tuple[int, int], follow: Callable[[], np.ndarray]) -> Callable[[], np.ndarray]:
        """A function rendering the scene as it is now, one (height, width, 3) uint8 RGB frame of `size` (width,
        height) from sim/video.py's 3/4 view, aimed at `follow()`."""
        ...


def open_simulator(
    robot: Robot, sim_spec: SimSpec, world: WorldSpec | None = None, pushes: Sequence[PushSpec] = ()
) -> Simulator:
    """The engine sim_spec.engine names, with the robot at home in the world."""
    if sim_spec.engine == "mujoco":
        from harmony_cli.sim.mujoco_sim import MujocoSimulation  # MuJoCo loads only when a scenario asks for it

        return MujocoSimulation(robot, sim_spec, world, pushes)
    from harmony_cli.sim.bullet import BulletSimulation

    return BulletSimulation(robot, sim_spec, world, pushes)


def simulator_errors() -> tuple[type[BaseException], ...]:
    """What an engine raises when it fails or its server is gone (for the run's `simulator` fault), of the engines
    that are installed."""
    errors: list[type[BaseException]] = []
    for module, error in (("pybullet", "error"), ("mujoco", "FatalError")):  # an engine never loaded raised none
        if module in sys.modules:
            errors.append(getattr(sys.modules[module], error))
    return tuple(errors)
