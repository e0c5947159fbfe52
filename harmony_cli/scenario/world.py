"""The scene: tables, the box to carry, static and moving obstacles, scripted pushes."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, PositiveFloat, ValidationInfo, field_validator, model_validator

from harmony_cli.scenario.base import Size3, Strict, Vector3, unique


class MotionSpec(Strict):
    """How an obstacle moves (kinematically: nothing pushes it; its yaw stays): `velocity` from `start` to `stop`
    (from its `position`), or piecewise-linear `waypoints` [t, x, y, z], held before the first and after the last."""

    velocity: Vector3 | None = Field(None, description="constant velocity [m/s]")
    start: float = Field(0.0, ge=0, description="velocity only: the obstacle is at `position` until then [s]")
    stop: float | None = Field(None, description="velocity only: it stays where it is from then on [s]")
    waypoints: list[tuple[float, float, float, float]] | None = Field(
        None, min_length=2, description="[t, x, y, z] centres at strictly increasing times [s, m]"
    )

    @field_validator("stop")
    @classmethod
    def _stop_after_start(cls, stop: float | None, info: ValidationInfo) -> float | None:
        start = info.data.get("start", 0.0)
        if stop is not None and stop <= start:
            raise ValueError(f"must be after start ({start:g} s)")
        return stop

    @field_validator("waypoints")
    @classmethod
    def _times_increase(cls, waypoints):
        for i in range(1, len(waypoints or ())):
            if waypoints[i][0] <= waypoints[i - 1][0]:
                raise ValueError(
                    f"times must be strictly increasing: waypoint {i} at t = {waypoints[i][0]:g} s "
                    f"follows t = {waypoints[i - 1][0]:g} s"
                )
        return waypoints

    @model_validator(mode="after")
    def _one_kind(self):
        if (self.velocity is None) == (self.waypoints is None):
            raise ValueError("give exactly one of velocity: [vx, vy, vz] or waypoints: [[t, x, y, z], ...]")
        if self.waypoints is not None and ("start" in self.model_fields_set or "stop" in self.model_fields_set):
            raise ValueError("start / stop go with velocity; waypoints carry their own times")
        return self


class ObstacleSpec(Strict):
    """An obstacle, static or moving; `size` is the full extent x, y, z for a box, [diameter, diameter, height]
    for a cylinder and [diameter] * 3 for a sphere."""

    name: str
    shape: Literal["box", "cylinder", "sphere"]
    position: Vector3 = Field(description="centre [m] (at t = 0; with waypoints it may be left out)")
    yaw_deg: float = 0.0
    size: Size3
    margin: float = Field(0.05, ge=0, description="clearance the MPCs keep from its surface [m]")
    motion: MotionSpec | None = Field(None, description="none: static")
    prediction: Literal["truth", "estimated"] = Field(
        "truth",
        description="what both MPCs predict a moving obstacle's motion from: its scripted motion (truth), or a "
        "constant-velocity Kalman filter on its measured centre (sensing.noise.obstacle_position)",
    )

    @model_validator(mode="after")
    def _estimated_moves(self):
        if self.prediction == "estimated" and self.motion is None:
            raise ValueError(
                f"prediction: estimated needs a motion; obstacle {self.name!r} stands where the scenario puts it "
                "(choose truth, or give it a motion)"
            )
        return self

    @model_validator(mode="before")
    @classmethod
    def _position_from_waypoints(cls, raw):
        """With waypoints, `position` defaults to their centre at t = 0 (and must be it when given)."""
        try:
            w = np.asarray(raw["motion"]["waypoints"], dtype=float)
            assert w.ndim == 2 and w.shape[1] == 4
            given = None if raw.get("position") is None else np.asarray(raw["position"], dtype=float)
            assert given is None or given.shape == (3,)
        except (KeyError, TypeError, ValueError, IndexError, AssertionError):
            return raw  # no (valid) waypoints or position: the field validators say what is wrong
        if not np.all(np.diff(w[:, 0]) > 0):  # the waypoints' validator says so
            return raw if given is not None else raw | {"position": w[0, 1:].tolist()}
        at_zero = [float(np.interp(0.0, w[:, 0], w[:, 1 + axis])) for axis in range(3)]
        if given is None:
            return raw | {"position": at_zero}
        if not np.allclose(given, at_zero, atol=1e-9):
            raise ValueError(
                f"position {given.tolist()} is not the waypoints' centre at t = 0 "
                f"{[round(v, 9) for v in at_zero]}; leave position out or make them agree"
            )
        return raw


class TableSpec(Strict):
    name: str
    position: tuple[float, float] = Field(description="centre of the top in x, y [m]")
    yaw_deg: float = 0.0
    top: tuple[PositiveFloat, PositiveFloat] = Field((1.5, 0.8), description="top size x, y [m]")
    height: PositiveFloat = Field(1.015, description="top surface above the floor [m]")
    thickness: PositiveFloat = 0.03
    friction: PositiveFloat = 0.6


class BoxSpec(Strict):
    """The object to carry: a free PyBullet body held only by friction between the pads."""

    size: Size3 = (0.308, 0.305, 0.3)
    mass: PositiveFloat = 0.8
    position: Vector3 = Field(description="centre [m]")
    yaw_deg: float = 0.0
    friction: PositiveFloat = 0.8
    spinning_friction: float = Field(
        0.1,
        ge=0,
        description="torsional friction about a contact normal [m]: keeps the box from pivoting between the pads",
    )
    goal: Vector3 | None = Field(None, description="where the box should end (centre) [m]; success within 5 cm")
    mass_known: bool = Field(True, description="false: the controller's grip law assumes `nominal_mass`, not `mass`")
    nominal_mass: PositiveFloat = Field(1.0, description="[kg] the mass the controller assumes when mass_known: false")

    @property
    def assumed_mass(self) -> float:
        """[kg] the mass the controller works with."""
        return self.mass if self.mass_known else self.nominal_mass


class WorldSpec(Strict):
    tables: list[TableSpec] = []
    box: BoxSpec | None = None
    obstacles: list[ObstacleSpec] = []

    @model_validator(mode="after")
    def _unique_names(self) -> WorldSpec:
        """Tables and obstacles are found by name (targets, pushes, logs); `box` and `robot` are taken."""
        unique([t.name for t in self.tables] + [o.name for o in self.obstacles] + ["box", "robot"], "world name")
        return self


class PushSpec(Strict):
    """A scripted external force, applied every physics substep while start <= t < start + duration."""

    name: str = Field(pattern=r"^[A-Za-z0-9_]+$", description="label; logged per step as push_<name>_N")
    body: str = Field(description="robot, box or an obstacle name")
    link: str | None = Field(
        None, description="robot only: the link pushed (default: the base, the link the base yaw joint moves)"
    )
    point: Vector3 | None = Field(
        None,
        description="where, in the link's frame (URDF link frame; box and "
        "obstacles: their body frame) [m]; default: its centre of mass",
    )
    force: Vector3 = Field(description="[fx, fy, fz] in the world frame [N]")
    start: float = Field(ge=0, description="[s]")
    duration: PositiveFloat = Field(description="[s]")
    stiffness: PositiveFloat | None = Field(
        None,
        description="[N/m] a spring pusher instead of a set force: its tip travels |force| / stiffness along "
        "the force over the push's first quarter and holds there; it presses with stiffness x (tip "
        "travel - how far the point has given way along the force since the push began, beyond "
        "the motion it had then), never pulls: |force| against a body that does not give",
    )
