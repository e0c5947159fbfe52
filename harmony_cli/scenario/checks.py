"""Cross-checks no single field can make: names that must exist in the URDF, the world or the solver registry."""

from __future__ import annotations

from pathlib import Path

from harmony_cli.robot.urdf import joints_and_links, wrist_sensor_joints
from harmony_cli.scenario.errors import ScenarioError
from harmony_cli.scenario.models import Scenario
from harmony_cli.scenario.task import RelativeTarget


def check_robot(path: Path, scenario: Scenario) -> None:
    urdf = (path.parent / scenario.robot.urdf).resolve()
    if not urdf.is_file():
        raise ScenarioError(f"{path}: robot.urdf: {scenario.robot.urdf!r} does not exist (looked at {urdf})")
    joints, links = joints_and_links(urdf)
    for hand, link in scenario.robot.end_effectors.items():
        if link not in links:
            raise ScenarioError(
                f"{path}: robot.end_effectors.{hand}: {link!r} is not a link of {urdf.name}; "
                f"links: {', '.join(sorted(links))}"
            )
    base = scenario.robot.base_joints
    if not set(base) & joints:  # none of them: prepare_urdf adds all three
        joints = joints | set(base)
    named = {
        "base_joints": base,
        "pinned_joints": scenario.robot.pinned_joints,
        "chest_joints": scenario.robot.chest_joints,
        "mirrored_joints": [j for pair in scenario.robot.mirrored_joints for j in pair],
        "home_deg": list(scenario.robot.home_deg),
    }
    for field, names in named.items():
        for joint in names:
            if joint not in joints:
                raise ScenarioError(
                    f"{path}: robot.{field}: {joint!r} is not a joint of {urdf.name}; "
                    f"joints: {', '.join(sorted(joints))}"
                )
    if not scenario.robot.footprint and (scenario.world.obstacles or scenario.world.tables):
        raise ScenarioError(
            f"{path}: robot.footprint: empty, but the world has obstacles or tables the base must "
            f"keep clear of; give circles [x, y, radius] in the base frame covering the base"
        )
    try:
        wrist_sensor_joints(scenario.robot, urdf)
    except ValueError as err:
        raise ScenarioError(f"{path}: {err}") from None


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
                f"links: {', '.join(sorted(links))}"
            )


def check_solver(path: Path, scenario: Scenario) -> None:
    from harmony_cli.mpc.registry import available_solvers, unavailable_message  # loads casadi: not for `schema`

    if scenario.solver.name not in available_solvers():
        raise ScenarioError(f"{path}: {unavailable_message(scenario.solver.name)}")
