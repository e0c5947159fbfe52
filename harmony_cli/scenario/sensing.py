"""What the controllers see and when their command acts: the imperfections a real robot has, each off by default.

`sensing.noise` adds white noise and a bias to the measurement, per channel in SI units; `sensing.delay` hands the
controllers the measurement of that long ago; `control.latency` applies the command computed from the state at t
at t plus a fixed time or its measured compute time. All of it is drawn from the run's `seed`."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, NonNegativeFloat

from harmony_cli.scenario.base import Strict


class Channel(Strict):
    """One measured quantity's error: per component, white noise of standard deviation `std` at every control step
    and a bias drawn once per run from a normal distribution of standard deviation `bias` (a calibration error)."""

    std: NonNegativeFloat = 0.0
    bias: NonNegativeFloat = 0.0

    @property
    def off(self) -> bool:
        return self.std == 0.0 and self.bias == 0.0


class NoiseSpec(Strict):
    """The channels; the hands' frames and velocities the controllers see follow the noisy joints (forward
    kinematics), as a robot's would."""

    joint_position: Channel = Field(Channel(), description="arm, chest and head joints [rad; m if prismatic]")
    joint_velocity: Channel = Field(Channel(), description="arm, chest and head joints [rad/s; m/s if prismatic]")
    base_position: Channel = Field(Channel(), description="the base's x and y [m] (its localisation)")
    base_yaw: Channel = Field(Channel(), description="the base's heading [rad]")
    base_velocity: Channel = Field(Channel(), description="the base's x and y rates [m/s]")
    base_yaw_rate: Channel = Field(Channel(), description="the base's turn rate [rad/s]")
    wrist_force: Channel = Field(Channel(), description="each wrist sensor's force, per axis [N]")
    wrist_torque: Channel = Field(Channel(), description="each wrist sensor's torque, per axis [N m]")
    box_position: Channel = Field(Channel(), description="the box's measured centre, per axis [m] (its tracking)")
    obstacle_position: Channel = Field(
        Channel(),
        description="a moving obstacle's measured centre, per axis [m]; what world.obstacles.<n>.prediction: "
        "estimated filters",
    )

    @property
    def off(self) -> bool:
        return all(getattr(self, name).off for name in type(self).model_fields)


class SensingSpec(Strict):
    noise: NoiseSpec = Field(NoiseSpec(), description="measurement errors (all 0: the simulator's state)")
    delay: NonNegativeFloat = Field(
        0.0, description="[s] the controllers get the measurement of this long ago; a whole multiple of sim.control_dt"
    )


class ControlSpec(Strict):
    latency: Literal["measured"] | NonNegativeFloat = Field(
        0.0,
        description="when the command computed from the state at t acts: at t + this [s] (a whole multiple of "
        "sim.physics_dt), or `measured`: at t + the time computing it took, rounded up to physics steps",
    )
