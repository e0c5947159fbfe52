"""The scenario file's top level and its controller, solver and simulation sections (unknown keys rejected)."""

from __future__ import annotations

import importlib.util
import math
from typing import Any, Literal

from pydantic import ConfigDict, Field, PositiveFloat, ValidationInfo, field_validator

from harmony_cli.mpc.registry import HARMONY_SOLVERS, QpName
from harmony_cli.scenario.base import Strict
from harmony_cli.scenario.robot import RobotSpec
from harmony_cli.scenario.sensing import ControlSpec, SensingSpec
from harmony_cli.scenario.task import Reference, TaskSpec
from harmony_cli.scenario.world import PushSpec, WorldSpec


class Weights(Strict):
    position: float = Field(1.0, ge=0, description="hand position tracking, mean over knots [1/m^2]")
    orientation: float = Field(1.0, ge=0, description="hand rotation-matrix error ||R - R_ref||_F^2, mean over knots")
    chest_yaw: float = Field(10.0, ge=0)
    arm_symmetry: float = Field(0.1, ge=0, description="(a + b)^2 over robot.mirrored_joints pairs")
    posture: float = Field(0.001, ge=0, description="arm joints away from home")
    velocity: float = Field(0.01, ge=0, description="joint velocity at the knots")
    clearance: float = Field(1.0e4, ge=0, description="squared clearance violation (mpc.clearance: soft only)")
    acceleration: float = Field(0.001, ge=0, description="joint acceleration at the knots")
    stance: float = Field(
        0.0,
        ge=0,
        description="the base towards the stance the planning layer chose, where it chose one [1/m^2] (0: off)",
    )
    late_task: float = Field(
        100.0,
        ge=1,
        description="a phase waiting for its goal multiplies the hands' tracking weights by up to this, ramped in "
        "over its wait's first second, so that the posture regularisers yield to the task (1: off)",
    )


class MpcSpec(Strict):
    transcription: Literal["bezier", "traditional"] = "bezier"
    integration: Literal["euler", "trapezoidal"] = Field("euler", description="traditional transcription only")
    horizon: PositiveFloat = Field(5.0, description="prediction horizon T [s]")
    knots: int = Field(26, ge=2, le=400, description="time knots K where the cost is evaluated (independent of N)")
    control_points: int = Field(6, ge=2, le=40, description="Bezier control points N (bezier only)")
    max_acceleration: PositiveFloat | None = Field(
        2.0,
        description="[rad/s^2, m/s^2] how fast a joint's commanded velocity may change: q_dot(0) of each solve "
        "within this times the control period of the last plan's (null: free)",
    )
    clearance: Literal["hard", "soft"] = Field(
        "hard",
        description="obstacle clearance of the base footprint, hands and arms: constraint rows at knots k >= 1 "
        "(hard) or a squared-hinge cost weighted by weights.clearance (soft)",
    )
    weights: Weights = Weights()


class PlannerWeights(Strict):
    smoothness: float = Field(0.05, ge=0, description="first differences of the control points")
    acceleration: float = Field(0.02, ge=0, description="second differences of the control points")
    level: float = Field(1.0, ge=0, description="both hands at one height, at every control point")
    facing: float = Field(3.0, ge=0, description="inter-hand vector across the heading (pads face each other)")
    width: float = Field(3.0, ge=0, description="distance between the hands stays the goal's (grip width)")
    base: float = Field(
        10.0, ge=0, description="soft rows keeping the base footprint, carried behind the hands, clear [1/m]"
    )


class PlannerSpec(Strict):
    """Task-space planner (MPC-T) for both hands; see planner.py."""

    control_points: int = Field(11, ge=6, le=40, description="Bezier control points M per curve")
    min_horizon: PositiveFloat = Field(1.0, description="lower clamp of the remaining phase time [s]")
    max_speed: tuple[float, float, float] = Field((0.9, 0.9, 0.5), description="hand speed bound x, y, z [m/s]")
    max_acceleration: tuple[float, float, float] = Field((1.0, 1.0, 1.0), description="[m/s^2]")
    max_yaw_rate: PositiveFloat = Field(0.8, description="heading rate bound [rad/s]")
    max_yaw_acceleration: PositiveFloat = Field(1.5, description="[rad/s^2]")
    held_chest_rate: PositiveFloat = Field(
        0.2, description="the most the chest's reference turns while the box is held [rad/s] (stance_plan.ChestRamp)"
    )
    samples: int = Field(20, ge=2, le=400, description="sample times for clearance and facing")
    hand_radius: float = Field(0.08, ge=0, description="added to every obstacle margin for a hand centre [m]")
    period: int = Field(1, ge=1, description="re-plan every `period` control steps")
    start_velocity: Literal["plan", "measured"] = Field(
        "plan",
        description="initial hand velocity of each re-plan (the pose is always the measured one): the "
        "previous plan's, or the measured one (restarts from rest when the robot lags)",
    )
    iterations: int = Field(1, ge=1, description="SQP iterations per re-plan (1: real-time iteration)")
    phase_iterations: int = Field(10, ge=1, description="SQP iterations of a phase's first plan")
    step_iterations: int = Field(
        2,
        ge=1,
        description="the most SQP iterations of a phase's first plan on one control step: the rest run on the "
        "next steps while the hands track the last plan taken (bounds a step's time; = phase_iterations: all at "
        "once)",
    )
    tol: PositiveFloat = Field(1e-5, description="SQP step tolerance [m]")
    qp: QpName = "daqp"
    weights: PlannerWeights = PlannerWeights()


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
        None,
        ge=0,
        description="enabled: false only: the position squeeze per pad [m] that stands in for a phase's "
        "force; null: F / K, the admittance's free-space offset",
    )
    force_filter: float = Field(
        0.05,
        ge=0,
        description="time constant [s] of the first-order low-pass on the sensed force the admittance "
        "sees; 0: raw. Without it the loop chatters at half the control rate against stiff "
        "contact (the offset is a static map of the force, loop gain k_contact / K > 1)",
    )
    grip_margin: float = Field(
        2.0,
        ge=0,
        description="while a box is held, the squeeze gives the pads this many times the friction the load the "
        "wrists measure along their faces needs (and the box's weight); 0: the written force only "
        "(planning/grip_force.py)",
    )
    grip_scale: float = Field(
        2.0, ge=1, description="the most a pad squeezes while a box is held, as a multiple of the written force"
    )
    max_offset: PositiveFloat = Field(0.05, description="bound on the compliant offset [m]")
    max_offset_rate: PositiveFloat = Field(0.5, description="bound on its rate [m/s]")

    @property
    def damping_value(self) -> float:
        return self.damping if self.damping is not None else 2.0 * math.sqrt(self.mass * self.stiffness)


class SolverSpec(Strict):
    name: str = Field(
        "ipopt",
        description=f"{' | '.join(HARMONY_SOLVERS)} | any CasADi nlpsol plugin that loads "
        f"here (ipopt, sqpmethod, blocksqp, fatrop, knitro with its licence, ...)",
    )
    qp: Literal["auto"] | QpName = Field(
        "auto",
        description="QP solver of gauss_newton and rti; auto: daqp up to 300 variables, else osqp (rti) "
        "or proxqp (gauss_newton)",
    )
    hessian: Literal["exact", "gauss_newton"] = Field(
        "exact", description="NLP plugins: exact Hessian, or the Gauss-Newton one (both on the knot structure)"
    )
    max_iter: int = Field(30, ge=1, description="Gauss-Newton SQP iterations per solve (rti: always 1)")
    tol: PositiveFloat = Field(1e-6, description="Gauss-Newton SQP step tolerance")
    damping: PositiveFloat = Field(
        1e-6,
        description="gauss_newton and rti: Levenberg-Marquardt damping added to the Gauss-Newton Hessian's "
        "diagonal (a cost on each step's size); larger damps steps the linearised constraints make overshoot",
    )
    options: dict[str, Any] = Field(default_factory=dict, description="passed to the CasADi plugin")


MAX_SUBSTEPS = 1000  # physics steps per control step: more is a unit mistake (ms for s), not a simulation
Engine = Literal["pybullet", "mujoco"]
ENGINES: tuple[Engine, ...] = ("pybullet", "mujoco")


def installed_engines() -> list[Engine]:
    """The physics engines this Python has, found without importing them (PyBullet has wheels up to 3.11 only)."""
    found = []
    for engine in ENGINES:
        try:
            if importlib.util.find_spec(engine) is not None:
                found.append(engine)
        except (ImportError, ValueError):  # an import hook refusing it, a module without a spec
            pass
    return found


def default_engine() -> Engine:
    """sim.engine when a scenario does not say: PyBullet where it is installed, else MuJoCo."""
    return "pybullet" if "pybullet" in installed_engines() else "mujoco"


class SimSpec(Strict):
    engine: Engine = Field(
        default_factory=default_engine,
        description="the physics engine, the same scene in both: PyBullet or MuJoCo; default pybullet where PyBullet "
        "is installed (Python <= 3.11), mujoco where it is not (a run's scenario.resolved.yaml names the one used)",
    )
    physics_dt: float = Field(0.004, ge=1e-4, description="physics step [s]")
    control_dt: PositiveFloat = Field(0.02, description="MPC period [s]; a whole multiple of physics_dt")
    duration: PositiveFloat = Field(26.0, description="closed-loop run length [s]")
    position_gain: float = Field(0.5, gt=0, le=1, description="PyBullet position-control gain of chest/arms/head")
    velocity_gain: float = Field(1.0, gt=0, description="PyBullet velocity gain of chest/arms/head")
    pad_stiffness: PositiveFloat | None = Field(
        None, description="contact stiffness of the tools below the wrist sensors [N/m] (a rubber pad); null: rigid"
    )
    pad_damping: PositiveFloat = Field(
        100.0, description="contact damping of the pads when pad_stiffness is set [N s/m]"
    )

    @field_validator("control_dt")
    @classmethod
    def _control_is_whole_multiple(cls, control_dt: float, info: ValidationInfo) -> float:
        physics_dt = info.data.get("physics_dt")
        if physics_dt is None:
            return control_dt
        ratio = control_dt / physics_dt
        if ratio > MAX_SUBSTEPS + 0.5:
            raise ValueError(
                f"{ratio:.0f} physics steps of {physics_dt} s per control step; at most {MAX_SUBSTEPS} (seconds, "
                "not milliseconds?)"
            )
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"not a whole multiple of sim.physics_dt {physics_dt} (ratio {ratio:.4g}); valid: "
                f"k x physics_dt, e.g. {round(max(1, ratio)) * physics_dt:.6g}, or set physics_dt "
                f"{control_dt / max(1, round(ratio)):.6g}"
            )
        return control_dt

    @property
    def substeps(self) -> int:
        return round(self.control_dt / self.physics_dt)


class Scenario(Strict):
    model_config = ConfigDict(**Strict.model_config, serialize_by_alias=True)  # `schema`, as the file has it

    schema_version: Literal[2] = Field(
        2,
        alias="schema",
        description="the scenario format's version; files of schema 1 (no `schema` key, `robot.home_deg` or "
        "EVA's URDF by its path) load with a notice, and `harmony upgrade FILE` rewrites them",
    )
    name: str
    description: str = ""
    seed: int = 0
    robot: RobotSpec = Field(
        default_factory=lambda: RobotSpec.model_validate({}), description="default: the EVA preset"
    )
    reference: Reference | None = None
    task: TaskSpec | None = None
    world: WorldSpec = WorldSpec()
    planner: PlannerSpec = PlannerSpec()
    mpc: MpcSpec = MpcSpec()
    admittance: AdmittanceSpec = AdmittanceSpec()
    solver: SolverSpec = SolverSpec()
    sim: SimSpec = SimSpec()
    sensing: SensingSpec = Field(SensingSpec(), description="measurement noise and delay (scenario/sensing.py)")
    control: ControlSpec = Field(ControlSpec(), description="when a command acts (scenario/sensing.py)")
    pushes: list[PushSpec] = Field([], description="scripted external forces (see PushSpec)")

    @field_validator("sensing")
    @classmethod
    def _delay_in_control_steps(cls, sensing: SensingSpec, info: ValidationInfo) -> SensingSpec:
        sim = info.data.get("sim")
        if sim is not None:
            _whole_multiple("delay", sensing.delay, sim.control_dt, "sim.control_dt")
        return sensing

    @field_validator("control")
    @classmethod
    def _latency_in_physics_steps(cls, control: ControlSpec, info: ValidationInfo) -> ControlSpec:
        sim = info.data.get("sim")
        if sim is not None and control.latency != "measured":
            _whole_multiple("latency", float(control.latency), sim.physics_dt, "sim.physics_dt")
        return control


def _whole_multiple(name: str, value: float, step: float, step_name: str) -> None:
    """ValueError unless `value` [s] is a whole number of `step`s."""
    ratio = value / step
    if abs(ratio - round(ratio)) > 1e-9:
        raise ValueError(
            f"{name} {value:g} s is not a whole multiple of {step_name} {step:g} s; valid: k x {step:g}, e.g. "
            f"{round(ratio) * step:.6g} or {(round(ratio) + 1) * step:.6g}"
        )
