"""What the robot is asked to do: a hand trajectory (`reference`, Table 1) or task phases for the planner."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, PositiveFloat, model_validator

from harmony_cli.scenario.base import Strict, Vector3, unique


class TrackingTolerance(Strict):
    """How far the hands may be from the reference before the run's tracking fails (summary.json `tracking`)."""

    position: PositiveFloat = Field(0.05, description="[m] either hand's distance from its reference")
    rotation_deg: PositiveFloat = Field(15.0, description="[deg] either hand's rotation from its reference")
    duration: PositiveFloat = Field(0.5, description="[s] the longest the hands may stay outside it at a time")


class SCurveReference(Strict):
    """Both hands sweep along a lane-change 'S' while their yaw follows the path heading."""

    type: Literal["s_curve"]
    tolerance: TrackingTolerance = TrackingTolerance()
    duration: PositiveFloat = Field(24.0, description="time to traverse the S [s] (quintic time scaling)")
    length: float = Field(5.0, description="forward travel of the hands' midpoint [m]")
    lateral: float = Field(2.0, description="sideways shift of the midpoint over the S [m]")
    start: float = Field(0.0, ge=0, description="time at which the sweep begins [s]")


class HoldReference(Strict):
    """The hands hold their home poses (smoke tests)."""

    type: Literal["hold"]
    tolerance: TrackingTolerance = TrackingTolerance()


Reference = Annotated[SCurveReference | HoldReference, Field(discriminator="type")]


class RelativeTarget(Strict):
    relative_to: str = Field(description="`box` or a table name; the offset is in that object's frame")
    offset: Vector3


HandTarget = Vector3 | RelativeTarget | None


class PhaseSpec(Strict):
    """One task phase: hand goals reached at rest at the end of `duration` (null: stay where it is)."""

    name: str
    duration: PositiveFloat
    hands: dict[str, HandTarget] = Field(description="hand label -> absolute [x, y, z], relative target or null")
    squeeze: float = Field(0.0, ge=0, description="goals moved towards each other by this much in total [m]")
    force: float = Field(
        0.0,
        ge=0,
        description="squeeze force reference per pad [N] (admittance; without it, "
        "a position squeeze per pad: admittance.off_squeeze, or force / "
        "stiffness when that is null)",
    )
    grasp: bool = Field(False, description="the box is held from the end of this phase")
    release: bool = Field(False, description="the box is let go during this phase")


class TaskSpec(Strict):
    phases: list[PhaseSpec] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique_phases(self) -> TaskSpec:
        """Phases are reported, logged and plotted by name."""
        unique([p.name for p in self.phases], "phase")
        return self
