"""The robot section: a URDF, its hands and tool frames, the joints the MPCs use and the roles of some, its home
pose, placement and base footprint, each field defaulting to the robot preset's (EVA's when neither `preset` nor
`urdf` is given)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from harmony_cli.robot.presets import PresetUnavailable, available_presets, distribution_path, load_preset
from harmony_cli.robot.tools import PAD, tool_link
from harmony_cli.scenario.base import Size3, Strict, Vector3

DEFAULT_PRESET = "eva"


class ToolSpec(Strict):
    """A tool frame and its pad, added below a gripper link: what any gripper squeezes an object with."""

    parent: str = Field(description="gripper link the pad is fixed to")
    xyz: Vector3 = Field(description="the pad's outer face centre in the parent link's frame [m]")
    rpy_deg: Vector3 = Field(
        (0.0, 0.0, 0.0), description="the frame's orientation in the parent's [deg]: z = pad normal, out of the hand"
    )
    pad: Size3 = Field(PAD, description="pad box size x, y, thickness [m], behind the face (along -z)")


class MountSpec(Strict):
    xyz: Vector3 = Field((0.0, 0.0, 0.0), description="the robot's root link on the virtual base [m]")
    rpy_deg: Vector3 = Field((0.0, 0.0, 0.0), description="[deg]")


class RobotSpec(Strict):
    preset: str | None = Field(
        None,
        description=f"robot preset (harmony_cli/robot/presets/<name>.yaml) that gives every field not set "
        f"here; default {DEFAULT_PRESET!r} when `urdf` is not given, else none",
    )
    urdf: str = Field(
        description="URDF path, relative to the scenario file, or `example-robot-data:<path>` inside that "
        "installed package (required without a preset)"
    )
    end_effectors: dict[str, str] = Field(
        {},
        description="hand label -> end-effector link, the frame every MPC controls (z = pad normal, out of the "
        "hand): any link of the arm; a hand with a tool uses the tool's frame, and a link no fixed joint holds "
        "gets a tool at itself; required without a preset",
    )
    tools: dict[str, ToolSpec] = Field(
        {},
        description="hand label -> a tool frame and pad harmony adds (for grippers without such a frame); default: "
        "one at the hand's link when a movable joint holds it, none otherwise",
    )
    active_joints: list[str] | None = Field(
        None,
        description="joints the MPCs use (names or fnmatch patterns such as arm_left_*); every other joint is "
        "locked at its home value (run.log counts them); default: the joints on the chains from the URDF's root to "
        "each hand's link (a tool's parent link) and those of pinned_joints, chest_joints and mirrored_joints (the "
        "base joints always). A mimic joint moves with its leader when the leader is active (one on a chain makes "
        "its leader active) and is locked at the leader's value otherwise; list it with its leader or not at all",
    )
    base_joints: list[str] = Field(
        ["base_x", "base_y", "base_yaw"],
        min_length=3,
        max_length=3,
        description="virtual planar base joints x, y, yaw, commanded by velocity; added "
        "(prismatic, prismatic, revolute) when the URDF has none of them",
    )
    package_paths: list[str] = Field(
        [],
        description="where package:// mesh URIs resolve (relative to the file, or `example-robot-data:` for that "
        "installed package)",
    )
    wrist_sensors: dict[str, str] | None = Field(
        None,
        description="hand -> fixed joint carrying the tool, where PyBullet measures the wrist force/torque; "
        "one of the fixed joints between the end effector and the last movable joint above it; "
        "default: the joint whose child holds the end-effector frame (EVA: *ARM_TOOL_JOINT)",
    )
    pinned_joints: list[str] = Field(
        [], description="held at home in every MPC (EVA: the head); active joints, off the chains to the hands too"
    )
    chest_joints: list[str] = Field(
        [], description="torso yaw joints, regularised towards 0 (EVA: CHEST_JOINT0; not a lift)"
    )
    mirrored_joints: list[tuple[str, str]] = Field([], description="pairs regularised to (a + b)^2 -> 0")
    home: dict[str, float] = Field(
        {},
        description="joint -> home value, degrees for revolute and continuous joints, metres for prismatic; others 0",
    )
    base_pose: Vector3 = Field((0.0, 0.0, 0.0), description="the base's start in the world: x [m], y [m], yaw [deg]")
    mount: MountSpec | Literal["auto"] | None = Field(
        "auto",
        description="pose of the URDF's root link on the virtual base harmony adds (e.g. a mounting height); "
        "auto: where the URDF places it, unless that puts part of the robot below the floor (a root at the pelvis "
        "or a pedestal's top): then raised until the lowest point of its collision model at home rests on the "
        "ground (run.log says by how much; the run's scenario.resolved.yaml holds the mount used); null: where the "
        "URDF places it",
    )
    footprint: list[tuple[float, float, float]] = Field(
        [],
        description="circles [x, y, radius] in the base frame covering the base, kept clear of obstacles and "
        "table legs (EVA: its 1.007 x 0.707 m box, 2 x 5 circles); required with a world",
    )
    actuators: Literal["urdf", "ideal"] = Field(
        "urdf",
        description="simulated motors' force limits: the URDF's efforts, or ideal (strong) for a robot whose "
        "arms the URDF's efforts cannot hold (PR2: its shoulders are balanced by springs the URDF does not model)",
    )
    base_margin: float = Field(0.03, ge=0, description="clearance the footprint keeps from table legs [m]")
    arm_radius: float | None = Field(
        0.05,
        gt=0,
        description="the arms' thickness [m]: spheres this big along each arm (its links from the shoulder to the "
        "wrist) are kept 1 cm clear of table tops and obstacles by the whole-body MPC; null: the arms are not kept",
    )
    trunk: list[tuple[float, float, float, float, float]] = Field(
        [],
        description="circles [x, y, radius, bottom, top] in the base frame covering the body the base carries "
        "(EVA: its waist and chest), from `bottom` to `top` above the floor [m]: kept out from under a table's "
        "top at their height, which the footprint may pass under; none: only the footprint is kept clear",
    )

    @model_validator(mode="before")
    @classmethod
    def _from_preset(cls, raw: Any) -> Any:
        """Fields not given come from the preset (an unknown preset is reported by the field's validator)."""
        if not isinstance(raw, dict):
            return raw
        name = raw.get("preset", DEFAULT_PRESET if "urdf" not in raw else None)
        if name not in available_presets():
            return raw
        try:
            return load_preset(name) | raw | {"preset": name}
        except PresetUnavailable as err:
            raise ValueError(str(err)) from None

    @model_validator(mode="after")
    def _tool_frames(self) -> RobotSpec:
        """A hand with a tool controls the tool's frame; two hands at least."""
        frames = self.end_effectors | {hand: tool_link(hand) for hand in self.tools}
        object.__setattr__(self, "end_effectors", frames)
        if len(frames) < 2:
            # a urdf without a preset takes no preset's fields: say how to keep them (e.g. EVA's with a changed URDF)
            keep = f"; or set preset ({', '.join(available_presets())}) to take its fields" if not self.preset else ""
            raise ValueError(f"end_effectors: {sorted(frames)}: a dual-arm robot needs two hands (or tools){keep}")
        return self

    @field_validator("urdf")
    @classmethod
    def _urdf_in_a_package(cls, value: str) -> str:
        return _in_distribution(value)

    @field_validator("package_paths")
    @classmethod
    def _packages_in_a_package(cls, value: list[str]) -> list[str]:
        return [_in_distribution(path) for path in value]

    @field_validator("mount", mode="before")
    @classmethod
    def _mount_word(cls, value: Any) -> Any:
        """A mount named by a word is auto (else a misspelt word is reported as a pose that is not a mapping)."""
        if isinstance(value, str) and value != "auto":
            raise ValueError("not a mount; give auto, null or {xyz: [x, y, z], rpy_deg: [roll, pitch, yaw]}")
        return value

    @field_validator("trunk")
    @classmethod
    def _trunk_circles(cls, circles: list) -> list:
        for x, y, radius, bottom, top in circles:
            if radius <= 0 or bottom >= top:
                raise ValueError(f"{[x, y, radius, bottom, top]}: a circle needs radius > 0 and bottom < top")
        return circles

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, name: str | None) -> str | None:
        if name is not None and name not in available_presets():
            raise ValueError(f"not a robot preset; choose one of: {', '.join(available_presets())}")
        return name


def _in_distribution(path: str) -> str:
    """A `distribution:relative` path (a robot package's Python distribution, e.g. example-robot-data) made absolute;
    any other path as written (relative to the scenario file)."""
    try:
        inside = distribution_path(path)
    except PresetUnavailable as err:
        raise ValueError(f"{path!r} {err}") from None
    return path if inside is None else inside
