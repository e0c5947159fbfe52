"""Cross-checks no single field can make: names that must exist in the URDF, the world or the solver registry."""

from __future__ import annotations

import os
import sys
import xml.etree.ElementTree as ET
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

from harmony_cli.names import closest
from harmony_cli.robot.presets import PresetUnavailable, distribution_path
from harmony_cli.robot.tools import tool_link
from harmony_cli.robot.urdf import joints_and_links
from harmony_cli.scenario.errors import ScenarioError, brief
from harmony_cli.scenario.models import Scenario, installed_engines
from harmony_cli.scenario.robot import RobotSpec
from harmony_cli.scenario.source import read_text
from harmony_cli.scenario.task import RelativeTarget

if TYPE_CHECKING:
    from harmony_cli.robot.model import Robot


MAX_URDF_BYTES = 20 << 20  # the largest URDFs of robot packages are ~1 MB; meshes are separate files


def check_urdf(path: Path, urdf: Path) -> None:
    """The URDF is a readable XML file (expat >= 2.4 bounds entity expansion), a <robot>, and every joint joins
    links it defines."""
    try:
        text = read_text(urdf, "URDF", MAX_URDF_BYTES)
        root = ET.fromstring(text)
    except ScenarioError as err:
        raise ScenarioError(f"{path}: robot.urdf: {err}") from None
    except ET.ParseError as err:
        raise ScenarioError(f"{path}: robot.urdf: {urdf.name} is not XML ({err})") from None
    if root.tag != "robot":
        raise ScenarioError(
            f"{path}: robot.urdf: {urdf.name} is not a URDF: its root element is <{root.tag}>, not <robot>"
        )
    links = {link.get("name") for link in root.findall("link")}
    for joint in root.findall("joint"):
        for end in ("parent", "child"):
            element = joint.find(end)
            link = None if element is None else element.get("link")
            if link not in links:
                raise ScenarioError(
                    f"{path}: robot.urdf: {urdf.name}: joint {joint.get('name')!r} names {end} link {link!r}, "
                    f"which it does not define; {closest(str(link), {str(n) for n in links})}"
                )


def urdf_file(path: Path, urdf: str) -> Path:
    """A robot.urdf as written, resolved against the scenario's folder (or inside an installed robot package);
    ScenarioError naming the field and the path when nothing is there (before anything else about the robot: a
    moved URDF is not a robot without hands)."""
    try:
        inside = distribution_path(urdf)  # `example-robot-data:<path>`, as the presets write it
    except PresetUnavailable as err:
        raise ScenarioError(f"{path}: robot.urdf: {urdf!r} {err}") from None
    try:
        resolved = (path.parent / (inside or urdf)).resolve()
        there = resolved.exists()
    except (OSError, ValueError) as err:  # a NUL character, a name too long for the file system
        raise ScenarioError(f"{path}: robot.urdf: {brief(urdf)} is not a usable path ({err})") from None
    if not there:
        raise ScenarioError(f"{path}: robot.urdf: {urdf!r} does not exist (looked at {resolved})")
    return resolved


def check_robot(path: Path, scenario: Scenario) -> None:
    """Names the robot section gives exist in the URDF (the three closest suggested when not)."""
    spec = scenario.robot
    urdf = urdf_file(path, spec.urdf)
    check_urdf(path, urdf)
    try:
        joints, links = joints_and_links(urdf)
    except (ET.ParseError, ValueError) as err:
        raise ScenarioError(f"{path}: robot.urdf: {urdf.name} is not a readable URDF: {err}") from None
    links |= {tool_link(hand) for hand in spec.tools}
    for hand, link in spec.end_effectors.items():
        if link not in links:
            raise ScenarioError(
                f"{path}: robot.end_effectors.{hand}: {link!r} is not a link of {urdf.name}; {closest(link, links)}"
            )
    for hand, tool in spec.tools.items():
        if tool.parent not in links:
            raise ScenarioError(
                f"{path}: robot.tools.{hand}.parent: {tool.parent!r} is not a link of {urdf.name}; "
                f"{closest(tool.parent, links)}"
            )
    if not set(spec.base_joints) & joints:  # none of them: prepare_urdf adds all three
        joints = joints | set(spec.base_joints)
    named = {
        "base_joints": spec.base_joints,
        "pinned_joints": spec.pinned_joints,
        "chest_joints": spec.chest_joints,
        "mirrored_joints": [j for pair in spec.mirrored_joints for j in pair],
        "home": list(spec.home),
    }
    for field, names in named.items():
        for joint in names:
            if joint not in joints:
                raise ScenarioError(
                    f"{path}: robot.{field}: {joint!r} is not a joint of {urdf.name}; {closest(joint, joints)}"
                )
    if not spec.footprint and (scenario.world.obstacles or scenario.world.tables):
        raise ScenarioError(
            f"{path}: robot.footprint: empty, but the world has obstacles or tables the base must "
            f"keep clear of; give circles [x, y, radius] in the base frame covering the base"
        )


def check_robot_builds(path: Path, scenario: Scenario) -> None:
    """The robot is prepared and built as a run builds it: what a run would reject about it, rejected here."""
    try:
        robot_of(scenario, path.parent)
    except (ValueError, FileNotFoundError, ET.ParseError) as err:
        raise ScenarioError(f"{path}: {str(err).strip().splitlines()[0]}") from None
    check_budget(path, scenario)


MAX_STEPS = 1_000_000  # control steps of one run: ~5.6 h simulated at 50 Hz, ~1.5 h of wall time at ~5 ms a step
STEP_S = 0.005  # [s] wall time of a control step (planner + whole-body MPC + physics), for the estimate only
# Peak memory of building the whole-body MPC (CasADi graphs, generated C and its compiler), measured with an empty
# cache on the 2-core AMD EPYC VM (s_shape_short, EVA, no obstacles): bezier K = 26/50/100/200/400 took
# 0.62/0.88/1.65/3.9/11.6 GiB (build 3/6/14/36/82 s); traditional K = 26/50/100, 0.48/0.65/1.31 GiB. The fit
# a + b K^p bounds them all (obstacles add rows per knot: more than this).
BUILD_GIB = (0.45, 7.7e-4, 1.6)
MEMORY_SHARE = 0.4  # of this machine's RAM one run may take: the OS, a browser, a second run keep the rest


def machine_memory() -> int:
    """This machine's RAM [bytes]."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_budget(path: Path, scenario: Scenario) -> None:
    """Refuse, with the figure, a run this machine cannot do: too many control steps, or a whole-body MPC whose
    build needs more memory than MEMORY_SHARE of the RAM (BUILD_GIB's measured model)."""
    sim, mpc = scenario.sim, scenario.mpc
    steps = sim.duration / sim.control_dt
    if steps > MAX_STEPS:
        hours = steps * STEP_S / 3600
        raise ScenarioError(
            f"{path}: sim.duration: {sim.duration:g} s is {steps:.3g} control steps (~{hours:.3g} h of wall time at "
            f"~{1e3 * STEP_S:g} ms a step); at most {MAX_STEPS} steps per run"
        )
    a, b, p = BUILD_GIB
    need, allowed = a + b * mpc.knots**p, MEMORY_SHARE * machine_memory() / 2**30
    if need > allowed:
        raise ScenarioError(
            f"{path}: mpc.knots: {mpc.knots}: building the whole-body MPC needs ~{need:.3g} GiB (measured, growing as "
            f"K^{p}); this machine allows {allowed:.3g} GiB per run ({MEMORY_SHARE:.0%} of its RAM): fewer knots"
        )


def robot_of(scenario: Scenario, scenario_dir: Path) -> Robot:
    """The scenario's robot, built once per process for a robot section (validation, then the run)."""
    pushed = tuple(p.link for p in scenario.pushes if p.body == "robot" and p.link is not None)
    return _robot(scenario.robot.model_dump_json(), scenario_dir.resolve(), pushed)


@cache
def _robot(spec_json: str, scenario_dir: Path, keep: tuple[str, ...]) -> Robot:
    from harmony_cli.robot.model import load_robot  # loads OpTaS and CasADi: not for `schema`

    return load_robot(RobotSpec.model_validate_json(spec_json), scenario_dir, keep)


def robot_warnings(scenario: Scenario, scenario_dir: Path) -> list[str]:
    """What a run of this scenario should be warned about its robot (one line each)."""
    robot = robot_of(scenario, scenario_dir)
    if robot.overloaded and robot.actuators == "urdf":
        return [
            f"robot: at home, gravity needs more than the URDF's effort [N m | N] at {', '.join(robot.overloaded)}: "
            "the simulated robot will sag; set robot.actuators: ideal (strong motors) or choose another home"
        ]
    return []


def check_task(path: Path, scenario: Scenario) -> None:
    """Exactly one of reference / task; phase hands and relative targets name things that exist."""
    if (scenario.reference is None) == (scenario.task is None):
        problem = "both given" if scenario.task else "missing"
        raise ScenarioError(
            f"{path}: reference / task: {problem}; give exactly one (reference: a hand trajectory "
            f"such as s_curve; task: phases for the planner)"
        )
    if scenario.task is None:
        return
    hands, world = set(scenario.robot.end_effectors), scenario.world
    objects = {t.name for t in world.tables} | ({"box"} if world.box else set())
    for i, phase in enumerate(scenario.task.phases):
        where = f"task.phases.{i}"
        if set(phase.hands) != hands:
            raise ScenarioError(
                f"{path}: {where}.hands: {sorted(phase.hands)} must name every hand exactly once; "
                f"hands: {', '.join(sorted(hands))}"
            )
        for hand, target in phase.hands.items():
            if isinstance(target, RelativeTarget) and target.relative_to not in objects:
                raise ScenarioError(
                    f"{path}: {where}.hands.{hand}.relative_to: {target.relative_to!r} is not in "
                    f"the world; choose one of: {', '.join(sorted(objects)) or '(none)'}"
                )
        if (phase.grasp or phase.release) and world.box is None:
            raise ScenarioError(f"{path}: {where}.grasp/release: the world has no box")


def check_pushes(path: Path, scenario: Scenario) -> None:
    """Unique names; each push names a body of the world and, on the robot, one of its links."""
    world = scenario.world
    bodies = ["robot"] + (["box"] if world.box else []) + [o.name for o in world.obstacles]
    _, links = joints_and_links((path.parent / scenario.robot.urdf).resolve())
    seen = set()
    for i, push in enumerate(scenario.pushes):
        where = f"{path}: pushes.{i}"
        if push.name in seen:
            raise ScenarioError(f"{where}.name: {push.name!r} is used by an earlier push; names must be unique")
        seen.add(push.name)
        if push.body not in bodies:
            raise ScenarioError(f"{where}.body: {push.body!r} is not in the world; choose one of: {', '.join(bodies)}")
        if push.link is not None and push.body != "robot":
            raise ScenarioError(
                f"{where}.link: {push.link!r}: only a push on the robot names a link "
                f"(body {push.body!r} is one rigid body); remove link"
            )
        if push.link is not None and push.link not in links:
            raise ScenarioError(
                f"{where}.link: {push.link!r} is not a link of {Path(scenario.robot.urdf).name}; "
                f"{closest(push.link, links)}"
            )


def check_engine(path: Path, scenario: Scenario) -> None:
    """The physics engine sim.engine names is installed on this Python (PyBullet has no wheels past 3.11)."""
    engines = installed_engines()
    if scenario.sim.engine not in engines:
        version = ".".join(map(str, sys.version_info[:2]))
        raise ScenarioError(
            f"{path}: sim.engine: {scenario.sim.engine!r} is not installed on this Python ({version}); "
            f"choose one of: {', '.join(engines) or '(none)'}"
        )


def check_solver(path: Path, scenario: Scenario) -> None:
    from harmony_cli.mpc.registry import available_solvers, options_problem, unavailable_message  # loads casadi

    if scenario.solver.name not in available_solvers():
        raise ScenarioError(f"{path}: {unavailable_message(scenario.solver.name)}")
    problem = options_problem(scenario.solver.name, dict(scenario.solver.options))
    if problem:
        raise ScenarioError(f"{path}: solver.options: {brief(dict(scenario.solver.options))}: {problem}")
