"""Scenario files: pydantic models (unknown keys rejected), `--set` overrides and one-line errors."""

from __future__ import annotations

import copy
import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args

import numpy as np
import yaml
from pydantic import (BaseModel, ConfigDict, Field, PositiveFloat, ValidationError, ValidationInfo, field_validator,
                      model_validator)

from harmony_cli.urdf_prep import fixed_joints_above

EVA_HOME_DEG = {"LARM_JOINT2": -30.0, "LARM_JOINT4": 30.0, "LARM_JOINT5": 90.0,
                "RARM_JOINT2": -30.0, "RARM_JOINT4": 30.0, "RARM_JOINT5": -90.0}


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message is one line naming file, field, value and choices."""


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RobotSpec(Strict):
    urdf: str = Field("../robots/eva.urdf", description="URDF path, relative to the scenario file")
    end_effectors: dict[str, str] = Field(
        default_factory=lambda: {"left": "LARM_grasp", "right": "RARM_grasp"},
        description="hand label -> end-effector link (the frame every MPC controls)")
    base_joints: list[str] = Field(["base_x", "base_y", "base_yaw"], min_length=3, max_length=3,
                                   description="virtual planar base joints x, y, yaw, commanded by velocity; added "
                                               "(prismatic, prismatic, revolute) when the URDF has none of them")
    package_paths: list[str] = Field([], description="where package:// mesh URIs resolve (relative to the file)")
    wrist_sensors: dict[str, str] | None = Field(
        None, description="hand -> fixed joint carrying the tool, where PyBullet measures the wrist force/torque; "
                          "one of the fixed joints between the end effector and the last movable joint above it; "
                          "default: the joint whose child holds the end-effector frame (EVA: *ARM_TOOL_JOINT)")
    pinned_joints: list[str] = Field(["HEAD_JOINT0", "HEAD_JOINT1"], description="held at home in every MPC")
    chest_joints: list[str] = Field(["CHEST_JOINT0"], description="torso joints (regularised towards 0)")
    mirrored_joints: list[tuple[str, str]] = Field([("LARM_JOINT0", "RARM_JOINT0")],
                                                   description="pairs regularised to (a + b)^2 -> 0")
    home_deg: dict[str, float] = Field(default_factory=lambda: dict(EVA_HOME_DEG),
                                       description="joint -> home angle in degrees (metres for prismatic); others 0")
    footprint: list[tuple[float, float, float]] = Field(
        default_factory=lambda: [(x, y, 0.2036) for x in (-0.4028, -0.2014, 0.0, 0.2014, 0.4028)
                                 for y in (-0.1768, 0.1768)],
        description="circles [x, y, radius] in the base frame covering the base (default: EVA's 1.007 x 0.707 m "
                    "box, 2 x 5 circles)")
    base_margin: float = Field(0.03, ge=0, description="clearance the footprint keeps from table legs [m]")


class SCurveReference(Strict):
    """Both hands sweep along a lane-change 'S' while their yaw follows the path heading."""

    type: Literal["s_curve"]
    duration: PositiveFloat = Field(24.0, description="time to traverse the S [s] (quintic time scaling)")
    length: float = Field(5.0, description="forward travel of the hands' midpoint [m]")
    lateral: float = Field(2.0, description="sideways shift of the midpoint over the S [m]")
    start: float = Field(0.0, ge=0, description="time at which the sweep begins [s]")


class HoldReference(Strict):
    """The hands hold their home poses (smoke tests)."""

    type: Literal["hold"]


Reference = Annotated[Union[SCurveReference, HoldReference], Field(discriminator="type")]


class Weights(Strict):
    position: float = Field(1.0, ge=0, description="hand position tracking, mean over knots [1/m^2]")
    orientation: float = Field(1.0, ge=0, description="hand rotation-matrix error ||R - R_ref||_F^2, mean over knots")
    chest_yaw: float = Field(10.0, ge=0)
    arm_symmetry: float = Field(0.1, ge=0, description="(LARM_JOINT0 + RARM_JOINT0)^2")
    posture: float = Field(0.001, ge=0, description="arm joints away from home")
    velocity: float = Field(0.01, ge=0, description="joint velocity at the knots")
    clearance: float = Field(1.0e4, ge=0, description="squared clearance violation (mpc.clearance: soft only)")
    acceleration: float = Field(0.001, ge=0, description="joint acceleration at the knots")


class MpcSpec(Strict):
    transcription: Literal["bezier", "traditional"] = "bezier"
    integration: Literal["euler", "trapezoidal"] = Field("euler", description="traditional transcription only")
    horizon: PositiveFloat = Field(5.0, description="prediction horizon T [s]")
    knots: int = Field(26, ge=2, description="time knots K where the cost is evaluated (independent of N)")
    control_points: int = Field(6, ge=2, description="Bezier control points N (bezier only)")
    clearance: Literal["hard", "soft"] = Field(
        "hard", description="obstacle clearance of the base footprint and hands: constraint rows at knots k >= 1 "
                            "(hard) or a squared-hinge cost weighted by weights.clearance (soft)")
    weights: Weights = Weights()


class PlannerWeights(Strict):
    smoothness: float = Field(0.05, ge=0, description="first differences of the control points")
    acceleration: float = Field(0.02, ge=0, description="second differences of the control points")
    level: float = Field(1.0, ge=0, description="both hands at one height, at every control point")
    facing: float = Field(3.0, ge=0, description="inter-hand vector across the heading (pads face each other)")
    width: float = Field(3.0, ge=0, description="distance between the hands stays the goal's (grip width)")


class PlannerSpec(Strict):
    """Task-space planner (MPC-T) for both hands; see planner.py."""

    control_points: int = Field(11, ge=6, description="Bezier control points M per curve")
    min_horizon: PositiveFloat = Field(1.0, description="lower clamp of the remaining phase time [s]")
    max_speed: tuple[float, float, float] = Field((0.9, 0.9, 0.5), description="hand speed bound x, y, z [m/s]")
    max_acceleration: tuple[float, float, float] = Field((1.0, 1.0, 1.0), description="[m/s^2]")
    max_yaw_rate: PositiveFloat = Field(0.8, description="heading rate bound [rad/s]")
    max_yaw_acceleration: PositiveFloat = Field(1.5, description="[rad/s^2]")
    samples: int = Field(20, ge=2, description="sample times for clearance and facing")
    hand_radius: float = Field(0.08, ge=0, description="added to every obstacle margin for a hand centre [m]")
    period: int = Field(1, ge=1, description="re-plan every `period` control steps")
    start_velocity: Literal["plan", "measured"] = Field(
        "plan", description="initial hand velocity of each re-plan (the pose is always the measured one): the "
                            "previous plan's, or the measured one (restarts from rest when the robot lags)")
    iterations: int = Field(1, ge=1, description="SQP iterations per re-plan (1: real-time iteration)")
    phase_iterations: int = Field(10, ge=1, description="SQP iterations at the start of a phase")
    tol: PositiveFloat = Field(1e-5, description="SQP step tolerance [m]")
    qp: Literal["daqp", "qpoases", "osqp", "proxqp"] = "daqp"
    weights: PlannerWeights = PlannerWeights()


Vector3 = tuple[float, float, float]


class MotionSpec(Strict):
    """How an obstacle moves (kinematically: nothing pushes it; its yaw stays): `velocity` from `start` to `stop`
    (from its `position`), or piecewise-linear `waypoints` [t, x, y, z], held before the first and after the last."""

    velocity: Vector3 | None = Field(None, description="constant velocity [m/s]")
    start: float = Field(0.0, ge=0, description="velocity only: the obstacle is at `position` until then [s]")
    stop: float | None = Field(None, description="velocity only: it stays where it is from then on [s]")
    waypoints: list[tuple[float, float, float, float]] | None = Field(
        None, min_length=2, description="[t, x, y, z] centres at strictly increasing times [s, m]")

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
                raise ValueError(f"times must be strictly increasing: waypoint {i} at t = {waypoints[i][0]:g} s "
                                 f"follows t = {waypoints[i - 1][0]:g} s")
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
    size: Vector3
    margin: float = Field(0.05, ge=0, description="clearance the MPCs keep from its surface [m]")
    motion: MotionSpec | None = Field(None, description="none: static")

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
            raise ValueError(f"position {given.tolist()} is not the waypoints' centre at t = 0 "
                             f"{[round(v, 9) for v in at_zero]}; leave position out or make them agree")
        return raw


class TableSpec(Strict):
    name: str
    position: tuple[float, float] = Field(description="centre of the top in x, y [m]")
    yaw_deg: float = 0.0
    top: tuple[float, float] = Field((1.5, 0.8), description="top size x, y [m]")
    height: PositiveFloat = Field(1.015, description="top surface above the floor [m]")
    thickness: PositiveFloat = 0.03
    friction: PositiveFloat = 0.6


class BoxSpec(Strict):
    """The object to carry: a free PyBullet body held only by friction between the pads."""

    size: Vector3 = (0.308, 0.305, 0.3)
    mass: PositiveFloat = 0.8
    position: Vector3 = Field(description="centre [m]")
    yaw_deg: float = 0.0
    friction: PositiveFloat = 0.8
    spinning_friction: float = Field(0.1, ge=0, description="torsional friction about a contact normal [m]: "
                                                            "keeps the box from pivoting between the pads")
    goal: Vector3 | None = Field(None, description="where the box should end (centre) [m]; success within 5 cm")


class WorldSpec(Strict):
    tables: list[TableSpec] = []
    box: BoxSpec | None = None
    obstacles: list[ObstacleSpec] = []


class RelativeTarget(Strict):
    relative_to: str = Field(description="`box` or a table name; the offset is in that object's frame")
    offset: Vector3


HandTarget = Union[Vector3, RelativeTarget, None]


class PhaseSpec(Strict):
    """One task phase: hand goals reached at rest at the end of `duration` (null: stay where it is)."""

    name: str
    duration: PositiveFloat
    hands: dict[str, HandTarget] = Field(description="hand label -> absolute [x, y, z], relative target or null")
    squeeze: float = Field(0.0, ge=0, description="goals moved towards each other by this much in total [m]")
    force: float = Field(0.0, ge=0, description="squeeze force reference per pad [N] (admittance; without it, "
                                                "a position squeeze per pad: admittance.off_squeeze, or force / "
                                                "stiffness when that is null)")
    grasp: bool = Field(False, description="the box is held from the end of this phase")
    release: bool = Field(False, description="the box is let go during this phase")


class TaskSpec(Strict):
    phases: list[PhaseSpec] = Field(min_length=1)


class AdmittanceSpec(Strict):
    """Compliance along each pad's normal inside the whole-body MPC (formulation.md section 3): per hand a compliant
    offset dp (Bezier control points, or values at the knots) with F_meas + m dp'' + D dp' + K dp -> F_ref."""

    enabled: bool = False
    mass: PositiveFloat = Field(0.3113, description="m [kg]")
    stiffness: PositiveFloat = Field(1500.0, description="K [N/m]")
    damping: PositiveFloat | None = Field(None, description="D [N s/m]; null: critical, 2 sqrt(m K)")
    weight: float = Field(0.1, ge=0, description="admittance cost ||F_hat - F_ref||^2 [1/N^2], mean over knots")
    ramp: PositiveFloat = Field(1.0, description="quintic blend of the force reference at a phase start [s]")
    off_squeeze: float | None = Field(
        None, ge=0, description="enabled: false only: the position squeeze per pad [m] that stands in for a phase's "
                          "force; null: F / K, the admittance's free-space offset")
    force_filter: float = Field(
        0.05, ge=0, description="time constant [s] of the first-order low-pass on the sensed force the admittance "
                                "sees; 0: raw. Without it the loop chatters at half the control rate against stiff "
                                "contact (the offset is a static map of the force, loop gain k_contact / K > 1)")
    max_offset: PositiveFloat = Field(0.05, description="bound on the compliant offset [m]")
    max_offset_rate: PositiveFloat = Field(0.5, description="bound on its rate [m/s]")

    @property
    def damping_value(self) -> float:
        return self.damping if self.damping is not None else 2.0 * math.sqrt(self.mass * self.stiffness)


HARMONY_SOLVERS = ("gauss_newton", "rti")  # harmony's own Gauss-Newton SQP and real-time iteration


class SolverSpec(Strict):
    name: str = Field("ipopt", description="ipopt | gauss_newton | rti | knitro | any CasADi nlpsol plugin")
    qp: Literal["auto", "daqp", "qpoases", "osqp", "proxqp"] = Field(
        "auto", description="QP solver of gauss_newton and rti; auto: daqp up to 300 variables, else osqp (rti) "
                            "or proxqp (gauss_newton)")
    hessian: Literal["exact", "gauss_newton"] = Field(
        "exact", description="NLP plugins: exact Hessian, or the Gauss-Newton one (both on the knot structure)")
    max_iter: int = Field(30, ge=1, description="Gauss-Newton SQP iterations per solve (rti: always 1)")
    tol: PositiveFloat = Field(1e-6, description="Gauss-Newton SQP step tolerance")
    options: dict[str, Any] = Field(default_factory=dict, description="passed to the CasADi plugin")


class SimSpec(Strict):
    physics_dt: PositiveFloat = Field(0.004, description="PyBullet step [s]")
    control_dt: PositiveFloat = Field(0.02, description="MPC period [s]; a whole multiple of physics_dt")
    duration: PositiveFloat = Field(26.0, description="closed-loop run length [s]")
    position_gain: float = Field(0.5, gt=0, le=1, description="PyBullet position-control gain of chest/arms/head")
    velocity_gain: float = Field(1.0, gt=0, description="PyBullet velocity gain of chest/arms/head")
    pad_stiffness: PositiveFloat | None = Field(
        None, description="contact stiffness of the tools below the wrist sensors [N/m] (a rubber pad); null: rigid")
    pad_damping: PositiveFloat = Field(100.0, description="contact damping of the pads when pad_stiffness is set "
                                                           "[N s/m]")

    @field_validator("control_dt")
    @classmethod
    def _control_is_whole_multiple(cls, control_dt: float, info: ValidationInfo) -> float:
        physics_dt = info.data.get("physics_dt")
        if physics_dt is None:
            return control_dt
        ratio = control_dt / physics_dt
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(f"not a whole multiple of sim.physics_dt {physics_dt} (ratio {ratio:.4g}); valid: "
                             f"k x physics_dt, e.g. {round(max(1, ratio)) * physics_dt:.6g}, or set physics_dt "
                             f"{control_dt / max(1, round(ratio)):.6g}")
        return control_dt

    @property
    def substeps(self) -> int:
        return round(self.control_dt / self.physics_dt)


class PushSpec(Strict):
    """A scripted external force, applied every physics substep while start <= t < start + duration."""

    name: str = Field(pattern=r"^[A-Za-z0-9_]+$", description="label; logged per step as push_<name>_N")
    body: str = Field(description="robot, box or an obstacle name")
    link: str | None = Field(None, description="robot only: the link pushed (default: the base, the link the "
                                               "base yaw joint moves)")
    point: Vector3 | None = Field(None, description="where, in the link's frame (URDF link frame; box and "
                                                    "obstacles: their body frame) [m]; default: its centre of mass")
    force: Vector3 = Field(description="[fx, fy, fz] in the world frame [N]")
    start: float = Field(ge=0, description="[s]")
    duration: PositiveFloat = Field(description="[s]")
    stiffness: PositiveFloat | None = Field(
        None, description="[N/m] a spring pusher instead of a set force: its tip travels |force| / stiffness along "
                          "the force over the push's first quarter and holds there; it presses with stiffness x (tip "
                          "travel - how far the point has given way along the force since the push began, beyond "
                          "the motion it had then), never pulls: |force| against a body that does not give")


class Scenario(Strict):
    name: str
    description: str = ""
    seed: int = 0
    robot: RobotSpec = RobotSpec()
    reference: Reference | None = None
    task: TaskSpec | None = None
    world: WorldSpec = WorldSpec()
    planner: PlannerSpec = PlannerSpec()
    mpc: MpcSpec = MpcSpec()
    admittance: AdmittanceSpec = AdmittanceSpec()
    solver: SolverSpec = SolverSpec()
    sim: SimSpec = SimSpec()
    pushes: list[PushSpec] = Field([], description="scripted external forces (see PushSpec)")


def apply_overrides(raw: dict, overrides: list[str]) -> dict:
    """Apply `a.b.c=value` overrides (value parsed as YAML) to a raw scenario mapping; a number indexes a list
    (`world.obstacles.0.motion=null`)."""
    raw = copy.deepcopy(raw)
    for item in overrides:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ScenarioError(f"--set {item!r}: expected key.path=value, e.g. mpc.knots=26")
        node = raw
        *parents, leaf = key.split(".")
        for part in parents:
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise ScenarioError(f"--set {item!r}: {part!r} is not an index of a list of {len(node)}")
                node = node[int(part)]
            else:
                node = node.setdefault(part, {})
            if not isinstance(node, (dict, list)):
                raise ScenarioError(f"--set {item!r}: {part!r} is not a section or a list")
        if isinstance(node, list):
            if not leaf.isdigit() or int(leaf) >= len(node):
                raise ScenarioError(f"--set {item!r}: {leaf!r} is not an index of a list of {len(node)}")
            leaf = int(leaf)
        node[leaf] = yaml.safe_load(text)
    return raw


def _model_at(loc: tuple) -> type[BaseModel] | None:
    """The model at a location such as ('world', 'obstacles', 0, 'motion'), through lists and optionals."""
    model: Any = Scenario
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or part not in model.model_fields:
            return None
        ann = model.model_fields[part].annotation
        models = [a for a in (ann, *get_args(ann), *(b for a in get_args(ann) for b in get_args(a)))
                  if isinstance(a, type) and issubclass(a, BaseModel)]
        model = models[0] if len(set(models)) == 1 else None  # a union of models: no single list of keys
    return model


def _one_line(path: Path, err: ValidationError) -> str:
    e = err.errors()[0]
    loc = tuple(p for p in e["loc"] if not (isinstance(p, str) and p in ("s_curve", "hold")))
    field = ".".join(str(p) for p in loc) or "(top level)"
    value = e.get("input")
    if e["type"] == "extra_forbidden":
        parent = _model_at(loc[:-1])
        choices = ", ".join(parent.model_fields) if parent else "see `harmony schema`"
        return f"{path}: {field}: unknown key (value {value!r}); valid keys: {choices}"
    if e["type"] == "missing":
        return f"{path}: {field}: required field is missing"
    msg = e["msg"].removeprefix("Value error, ")
    if e["type"] == "union_tag_invalid":
        ctx = e["ctx"]
        return (f"{path}: {field}.{ctx['discriminator'].strip(chr(39))}: {ctx['tag']!r} is not valid; "
                f"choose one of: {ctx['expected_tags']}")
    if e["type"] == "literal_error":
        return f"{path}: {field}: {value!r} is not valid; choose one of: {e['ctx']['expected']}"
    return f"{path}: {field}: {value!r}: {msg}"


def _urdf_joints_and_links(urdf: Path) -> tuple[set[str], set[str]]:
    root = ET.parse(urdf).getroot()
    return {j.get("name") for j in root.iter("joint")}, {l.get("name") for l in root.iter("link")}


def wrist_sensor_joints(spec: RobotSpec, urdf: Path) -> dict[str, str]:
    """Hand -> force/torque sensor joint, given or derived; ValueError (`field: value: reason; choices`) if unusable."""
    given = spec.wrist_sensors
    if given is not None and set(given) != set(spec.end_effectors):
        raise ValueError(f"robot.wrist_sensors: {sorted(given)} must name every hand exactly once; "
                         f"hands: {', '.join(spec.end_effectors)}")
    sensors = {}
    for hand, link in spec.end_effectors.items():
        choices = fixed_joints_above(urdf, link)
        if given is None:
            if not choices:
                raise ValueError(f"robot.wrist_sensors: cannot derive hand {hand}'s sensor joint: {link!r} hangs "
                                 f"from no fixed joint in {urdf.name}; add a fixed wrist joint to the URDF")
            sensors[hand] = choices[-2] if len(choices) > 1 else choices[0]  # the joint above the frame's link
        elif given[hand] in choices:
            sensors[hand] = given[hand]
        else:
            raise ValueError(f"robot.wrist_sensors.{hand}: {given[hand]!r} is not a fixed joint between {link} and "
                             f"the movable joint above it in {urdf.name}; choose one of: "
                             f"{', '.join(choices) or '(none)'}")
    return sensors


def _check_robot(path: Path, scenario: Scenario) -> None:
    urdf = (path.parent / scenario.robot.urdf).resolve()
    if not urdf.is_file():
        raise ScenarioError(f"{path}: robot.urdf: {scenario.robot.urdf!r} does not exist (looked at {urdf})")
    joints, links = _urdf_joints_and_links(urdf)
    for hand, link in scenario.robot.end_effectors.items():
        if link not in links:
            raise ScenarioError(f"{path}: robot.end_effectors.{hand}: {link!r} is not a link of {urdf.name}; "
                                f"links: {', '.join(sorted(links))}")
    base = scenario.robot.base_joints
    if not set(base) & joints:  # none of them: prepare_urdf adds all three
        joints = joints | set(base)
    named = {"base_joints": base, "pinned_joints": scenario.robot.pinned_joints,
             "chest_joints": scenario.robot.chest_joints,
             "mirrored_joints": [j for pair in scenario.robot.mirrored_joints for j in pair],
             "home_deg": list(scenario.robot.home_deg)}
    for field, names in named.items():
        for joint in names:
            if joint not in joints:
                raise ScenarioError(f"{path}: robot.{field}: {joint!r} is not a joint of {urdf.name}; "
                                    f"joints: {', '.join(sorted(joints))}")
    try:
        wrist_sensor_joints(scenario.robot, urdf)
    except ValueError as err:
        raise ScenarioError(f"{path}: {err}") from None


def _check_task(path: Path, scenario: Scenario) -> None:
    """Exactly one of reference / task; phase hands and relative targets name things that exist."""
    if (scenario.reference is None) == (scenario.task is None):
        problem = "both given" if scenario.task else "missing"
        raise ScenarioError(f"{path}: reference / task: {problem}; give exactly one (reference: a hand trajectory "
                            f"such as s_curve; task: phases for the planner)")
    if scenario.task is None:
        return
    hands, world = set(scenario.robot.end_effectors), scenario.world
    objects = {t.name for t in world.tables} | ({"box"} if world.box else set())
    for i, phase in enumerate(scenario.task.phases):
        where = f"task.phases.{i}"
        if set(phase.hands) != hands:
            raise ScenarioError(f"{path}: {where}.hands: {sorted(phase.hands)} must name every hand exactly once; "
                                f"hands: {', '.join(sorted(hands))}")
        for hand, target in phase.hands.items():
            if isinstance(target, RelativeTarget) and target.relative_to not in objects:
                raise ScenarioError(f"{path}: {where}.hands.{hand}.relative_to: {target.relative_to!r} is not in "
                                    f"the world; choose one of: {', '.join(sorted(objects)) or '(none)'}")
        if (phase.grasp or phase.release) and world.box is None:
            raise ScenarioError(f"{path}: {where}.grasp/release: the world has no box")


def _check_pushes(path: Path, scenario: Scenario) -> None:
    """Unique names; each push names a body of the world and, on the robot, one of its links."""
    world = scenario.world
    bodies = ["robot"] + (["box"] if world.box else []) + [o.name for o in world.obstacles]
    _, links = _urdf_joints_and_links((path.parent / scenario.robot.urdf).resolve())
    seen = set()
    for i, push in enumerate(scenario.pushes):
        where = f"{path}: pushes.{i}"
        if push.name in seen:
            raise ScenarioError(f"{where}.name: {push.name!r} is used by an earlier push; names must be unique")
        seen.add(push.name)
        if push.body not in bodies:
            raise ScenarioError(f"{where}.body: {push.body!r} is not in the world; choose one of: {', '.join(bodies)}")
        if push.link is not None and push.body != "robot":
            raise ScenarioError(f"{where}.link: {push.link!r}: only a push on the robot names a link "
                                f"(body {push.body!r} is one rigid body); remove link")
        if push.link is not None and push.link not in links:
            raise ScenarioError(f"{where}.link: {push.link!r} is not a link of {Path(scenario.robot.urdf).name}; "
                                f"links: {', '.join(sorted(links))}")


def _check_solver(path: Path, scenario: Scenario) -> None:
    from harmony_cli.solvers import available_nlp_plugins  # casadi import kept out of schema-only use

    name = scenario.solver.name
    valid = HARMONY_SOLVERS + available_nlp_plugins()
    if name not in valid:
        hint = " (the KNITRO plugin needs libknitro on the loader path and a licence)" if name == "knitro" else ""
        raise ScenarioError(f"{path}: solver.name: {name!r} is not available on this machine{hint}; "
                            f"choose one of: {', '.join(valid)}")


def load_scenario(path: str | Path, overrides: list[str] = ()) -> Scenario:
    """Read, override and validate a scenario; raise ScenarioError with a one-line message."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ScenarioError(f"{path}: file not found") from None
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: expected a mapping at the top level, got {type(raw).__name__}")
    raw = apply_overrides(raw, list(overrides))
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(_one_line(path, err)) from None
    _check_robot(path, scenario)
    _check_task(path, scenario)
    _check_pushes(path, scenario)
    _check_solver(path, scenario)
    return scenario


def scenario_yaml(scenario: Scenario) -> str:
    return yaml.safe_dump(scenario.model_dump(mode="json"), sort_keys=False)
