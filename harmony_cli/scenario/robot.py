"""The robot section: a URDF, its hands, the roles of its joints and its base footprint, each field defaulting to
the robot profile's (EVA's when neither `profile` nor `urdf` is given)."""

from __future__ import annotations

from typing import Any

from pydantic import Field, field_validator, model_validator

from harmony_cli.robot.profiles import available_profiles, load_profile
from harmony_cli.scenario.base import Strict

DEFAULT_PROFILE = "eva"


class RobotSpec(Strict):
    profile: str | None = Field(
        None,
        description=f"robot profile (harmony_cli/robot/profiles/<name>.yaml) that gives every field not set "
        f"here; default {DEFAULT_PROFILE!r} when `urdf` is not given, else none",
    )
    urdf: str = Field(description="URDF path, relative to the scenario file (required without a profile)")
    end_effectors: dict[str, str] = Field(
        description="hand label -> end-effector link (the frame every MPC controls; required without a profile)"
    )
    base_joints: list[str] = Field(
        ["base_x", "base_y", "base_yaw"],
        min_length=3,
        max_length=3,
        description="virtual planar base joints x, y, yaw, commanded by velocity; added "
        "(prismatic, prismatic, revolute) when the URDF has none of them",
    )
    package_paths: list[str] = Field([], description="where package:// mesh URIs resolve (relative to the file)")
    wrist_sensors: dict[str, str] | None = Field(
        None,
        description="hand -> fixed joint carrying the tool, where PyBullet measures the wrist force/torque; "
        "one of the fixed joints between the end effector and the last movable joint above it; "
        "default: the joint whose child holds the end-effector frame (EVA: *ARM_TOOL_JOINT)",
    )
    pinned_joints: list[str] = Field([], description="held at home in every MPC (EVA: the head)")
    chest_joints: list[str] = Field([], description="torso joints (regularised towards 0)")
    mirrored_joints: list[tuple[str, str]] = Field([], description="pairs regularised to (a + b)^2 -> 0")
    home_deg: dict[str, float] = Field(
        {}, description="joint -> home angle in degrees (metres for prismatic); others 0"
    )
    footprint: list[tuple[float, float, float]] = Field(
        [],
        description="circles [x, y, radius] in the base frame covering the base, kept clear of obstacles and "
        "table legs (EVA: its 1.007 x 0.707 m box, 2 x 5 circles); required with a world",
    )
    base_margin: float = Field(0.03, ge=0, description="clearance the footprint keeps from table legs [m]")

    @model_validator(mode="before")
    @classmethod
    def _from_profile(cls, raw: Any) -> Any:
        """Fields not given come from the profile (an unknown profile is reported by the field's validator)."""
        if not isinstance(raw, dict):
            return raw
        name = raw.get("profile", DEFAULT_PROFILE if "urdf" not in raw else None)
        if name not in available_profiles():
            return raw
        return load_profile(name) | raw | {"profile": name}

    @field_validator("profile")
    @classmethod
    def _known_profile(cls, name: str | None) -> str | None:
        if name is not None and name not in available_profiles():
            raise ValueError(f"not a robot profile; choose one of: {', '.join(available_profiles())}")
        return name
