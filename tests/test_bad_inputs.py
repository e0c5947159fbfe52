"""A corpus of bad inputs, as a careful user and a security reviewer would try them: every one, through both
`validate` and `run`, exits 2 with one line naming the file, the field and the value — no traceback, no run
directory — within 10 s and 1 GiB of memory."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from harmony_cli.cli import app

runner = CliRunner()
EVA_URDF = Path(__file__).resolve().parents[1] / "harmony_cli/robot/presets/eva.urdf"
BASE = {
    "name": "corpus",
    "world": {
        "tables": [{"name": "table", "position": [1.6, 0.0], "yaw_deg": 90, "top": [1.5, 0.8], "height": 1.015}],
        "box": {"position": [1.36, 0.0, 1.165], "goal": [1.36, 0.0, 1.3]},
        "obstacles": [{"name": "pillar", "shape": "cylinder", "position": [0.0, 2.0, 1.0], "size": [0.4, 0.4, 2]}],
    },
    "task": {
        "phases": [
            {
                "name": "approach",
                "duration": 2,
                "hands": {
                    "left": {"relative_to": "box", "offset": [0.0, 0.3, 0.08]},
                    "right": {"relative_to": "box", "offset": [0.0, -0.3, 0.08]},
                },
            },
            {"name": "hold", "duration": 1, "hands": {"left": None, "right": None}},
        ]
    },
    "pushes": [{"name": "nudge", "body": "box", "force": [0, 5, 0], "start": 1, "duration": 0.5}],
    "mpc": {"horizon": 2.0, "knots": 6},
    "solver": {"name": "rti"},
    "sim": {"duration": 2.0},
}
EE = "robot.end_effectors={left: LARM_grasp, right: RARM_grasp}"
FOOT = "robot.footprint=[[0, 0, 0.5]]"
OWN_URDF = [EE, FOOT, "robot.urdf=robot.urdf"]  # a scenario with its own URDF file (no preset)

# (id, overrides, pieces the one line must contain besides the file); the file is the base scenario
SET_CASES = [
    # numbers that are not finite, wherever a number is read
    ("inf-horizon", ["mpc.horizon=.inf"], ["mpc.horizon", "inf"]),
    ("nan-horizon", ["mpc.horizon=.nan"], ["mpc.horizon", "nan"]),
    ("inf-duration", ["sim.duration=.inf"], ["sim.duration", "inf"]),
    ("nan-string-duration", ['sim.duration="NaN"'], ["sim.duration", "NaN"]),
    ("inf-string-horizon", ['mpc.horizon="inf"'], ["mpc.horizon", "inf"]),
    ("nan-obstacle", ["world.obstacles.0.position=[.nan, 2, 1]"], ["world.obstacles.0.position.0", "nan"]),
    ("nan-box", ["world.box.position=[1.36, .nan, 1.165]"], ["world.box.position.1", "nan"]),
    ("inf-goal", ["world.box.goal=[.inf, 0, 1]"], ["world.box.goal.0", "inf"]),
    ("nan-target", ["task.phases.0.hands.left=[0, .nan, 1]"], ["task.phases.0.hands.left.1", "nan"]),
    ("nan-push", ["pushes.0.force=[.nan, 0, 0]"], ["pushes.0.force.0", "nan"]),
    ("inf-table", ["world.tables.0.position=[.inf, 0]"], ["world.tables.0.position.0", "inf"]),
    ("nan-stiffness", ["admittance.stiffness=.nan"], ["admittance.stiffness", "nan"]),
    ("inf-weight", ["mpc.weights.position=.inf"], ["mpc.weights.position", "inf"]),
    ("nan-home", ["robot.home={LARM_JOINT2: .nan}"], ["robot.home.LARM_JOINT2", "nan"]),
    ("nan-base-pose", ["robot.base_pose=[0, 0, .nan]"], ["robot.base_pose.2", "nan"]),
    ("nan-solver-option", ["solver.name=ipopt", "solver.options={ipopt.tol: .nan}"], ["solver.options", "nan"]),
    # sizes, counts and durations out of range, or beyond what this machine can build and run
    ("knots-million", ["mpc.knots=1000000"], ["mpc.knots", "1000000"]),
    ("knots-zero", ["mpc.knots=0"], ["mpc.knots", "0"]),
    ("knots-negative", ["mpc.knots=-3"], ["mpc.knots", "-3"]),
    ("control-points-1000", ["mpc.control_points=1000"], ["mpc.control_points", "1000"]),
    ("duration-1e9", ["sim.duration=1.0e9"], ["sim.duration", "1e+09", "steps"]),
    ("duration-negative", ["sim.duration=-1"], ["sim.duration", "-1"]),
    ("duration-zero", ["sim.duration=0"], ["sim.duration", "0"]),
    ("physics-dt-zero", ["sim.physics_dt=0"], ["sim.physics_dt", "0"]),
    ("physics-dt-tiny", ["sim.physics_dt=1.0e-7"], ["sim.physics_dt", "1e-07"]),
    ("substeps-huge", ["sim.physics_dt=0.0001", "sim.control_dt=1.0"], ["sim.control_dt", "10000"]),
    ("control-dt-not-multiple", ["sim.control_dt=0.031"], ["sim.control_dt", "0.031"]),
    ("obstacle-size-negative", ["world.obstacles.0.size=[-0.4, 0.4, 2]"], ["world.obstacles.0.size.0", "-0.4"]),
    ("obstacle-size-zero", ["world.obstacles.0.size=[0.4, 0, 2]"], ["world.obstacles.0.size.1", "0"]),
    ("box-size-negative", ["world.box.size=[0.3, 0.3, -0.3]"], ["world.box.size.2", "-0.3"]),
    ("box-mass-zero", ["world.box.mass=0"], ["world.box.mass", "0"]),
    ("table-top-negative", ["world.tables.0.top=[1.5, -0.8]"], ["world.tables.0.top.1", "-0.8"]),
    ("table-height-negative", ["world.tables.0.height=-1"], ["world.tables.0.height", "-1"]),
    ("push-duration-zero", ["pushes.0.duration=0"], ["pushes.0.duration", "0"]),
    ("planner-samples-huge", ["planner.samples=100000"], ["planner.samples", "100000"]),
    ("planner-points-huge", ["planner.control_points=500"], ["planner.control_points", "500"]),
    ("admittance-mass-negative", ["admittance.mass=-1"], ["admittance.mass", "-1"]),
    ("margin-negative", ["world.obstacles.0.margin=-0.1"], ["world.obstacles.0.margin", "-0.1"]),
    # names given twice
    ("phase-twice", ["task.phases.1.name=approach"], ["task", "'approach'", "2 times"]),
    ("obstacle-named-like-table", ["world.obstacles.0.name=table"], ["world", "'table'", "2 times"]),
    ("obstacle-named-box", ["world.obstacles.0.name=box"], ["world", "'box'"]),
    (
        "push-twice",
        [
            "pushes=[{name: a, body: box, force: [0,5,0], start: 1, duration: 1}, "
            "{name: a, body: box, force: [0,5,0], start: 2, duration: 1}]"
        ],
        ["pushes.1.name", "'a'"],
    ),
    (
        "table-twice",
        ["world.tables=[{name: t, position: [1.6, 0]}, {name: t, position: [4, 0]}]"],
        ["world", "'t'", "2 times"],
    ),
    # wrong types, unknown keys and choices, names that do not exist
    ("transcription-unknown", ["mpc.transcription=magic"], ["mpc.transcription", "'magic'", "bezier"]),
    ("solver-unknown", ["solver.name=snopt2"], ["solver.name", "'snopt2'", "rti"]),
    ("qp-unknown", ["solver.qp=foo"], ["solver.qp", "'foo'", "daqp"]),
    ("shape-unknown", ["world.obstacles.0.shape=cone"], ["world.obstacles.0.shape", "'cone'", "cylinder"]),
    ("knots-word", ["mpc.knots=six"], ["mpc.knots", "'six'"]),
    ("knots-list", ["mpc.knots=[6]"], ["mpc.knots", "[6]"]),
    ("section-number", ["mpc=3"], ["mpc", "3"]),
    ("reference-and-task", ["reference={type: hold}"], ["reference / task", "both"]),
    ("neither-reference-nor-task", ["task=null"], ["reference / task", "missing"]),
    ("unknown-top-key", ["colour=red"], ["colour", "unknown key", "'red'"]),
    ("unknown-nested-key", ["mpc.knotz=6"], ["mpc.knotz", "unknown key", "knots"]),
    ("preset-unknown", ["robot.preset=pr3"], ["robot", "'pr3'", "pr2"]),
    ("urdf-without-preset", [f"robot.urdf={EVA_URDF}"], ["robot", "end_effectors", "two hands", "set preset", "eva"]),
    ("actuators-unknown", ["robot.actuators=strong"], ["robot.actuators", "'strong'", "ideal"]),
    ("relative-to-missing", ["task.phases.0.hands.left.relative_to=shelf"], ["relative_to", "'shelf'", "table"]),
    ("push-body-missing", ["pushes.0.body=ghost"], ["pushes.0.body", "'ghost'", "pillar"]),
    ("push-link-missing", ["pushes.0.body=robot", "pushes.0.link=LARM_lnk"], ["pushes.0.link", "'LARM_lnk'"]),
    (
        "end-effector-misspelt",
        ["robot.end_effectors={left: LARM_grsp, right: RARM_grasp}"],
        ["end_effectors.left", "'LARM_grsp'", "LARM_grasp"],
    ),
    ("active-joint-missing", ["robot.active_joints=[nope_joint]"], ["robot.active_joints", "nope_joint"]),
    ("home-joint-missing", ["robot.home={NOPE: 1}"], ["robot.home", "'NOPE'"]),
    ("home-outside-limits", ["robot.home={LARM_JOINT0: 500}"], ["LARM_JOINT0", "500"]),
    ("base-joints-on-top", ["robot.base_joints=[bx, by, byaw]"], ["robot.base_joints", "'bx'", "base_x"]),
    (
        "tool-parent-missing",
        ["robot.tools={left: {parent: LARM_lnk6, xyz: [0, 0, 0.1]}}"],
        ["robot.tools.left.parent", "'LARM_lnk6'"],
    ),
    ("mount-on-own-base", ["robot.mount={xyz: [0, 0, 1]}"], ["robot.mount", "base joints"]),
    ("footprint-empty", ["robot.footprint=[]"], ["robot.footprint", "empty"]),
    ("options-for-rti", ["solver.options={max_iter: 3}"], ["solver.options", "max_iter", "rti takes no options"]),
    ("ipopt-option-unknown", ["solver.name=ipopt", "solver.options={bogus: 1}"], ["solver.options", "bogus"]),
    ("ipopt-option-type", ["solver.name=ipopt", "solver.options={ipopt.max_iter: abc}"], ["ipopt.max_iter", "abc"]),
    ("ipopt-inner-unknown", ["solver.name=ipopt", "solver.options={ipopt.bogus: 1}"], ["ipopt.bogus", "IPOPT"]),
    (
        "motion-both",
        ["world.obstacles.0.motion={velocity: [0, 1, 0], waypoints: [[0, 0, 2, 1], [1, 0, 3, 1]]}"],
        ["world.obstacles.0.motion", "waypoints"],
    ),
    # malformed overrides
    ("set-unclosed-list", ["mpc.knots=[6"], ["--set 'mpc.knots=[6'", "not valid YAML"]),
    ("set-no-key", ["=3"], ["--set '=3'", "key.path=value"]),
    ("set-no-value", ["mpc.knots"], ["--set 'mpc.knots'", "key.path=value"]),
    ("set-index-out", ["world.obstacles.5.size=[1, 1, 1]"], ["--set", "'5' is not an index"]),
    ("set-into-number", ["mpc.knots.x=3"], ["--set", "'knots' is not a section"]),
    # user text that a terminal or a markup printer could misread: printed literally, escaped
    ("markup-in-key", ["[/bold]=1"], ["[/bold]", "unknown key"]),
    ("markup-in-value", ['solver.name="[red]x"'], ["solver.name", "[red]x"]),
    ("escape-in-key", ["\x1b[31mred=1"], ["\\x1b[31mred", "unknown key"]),
    ("newline-in-value", ['solver.name="a\\nb"'], ["solver.name", "a\\nb"]),
]


def _bomb(levels: int = 9, indent: int = 0) -> str:
    """YAML "billion laughs": 10^levels values from a few hundred bytes (as mapping entries, indented)."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]")
    return "".join(" " * indent + line + "\n" for line in lines)


def _scenario_text(extra: str = "") -> str:
    return yaml.safe_dump(BASE, sort_keys=False) + extra


FILE_CASES = {
    # (what to write as the scenario file, pieces)
    "binary": (bytes(range(256)) * 4, ["binary data"]),
    "not-utf8": ("name: caf\u00e9\n".encode("latin-1"), ["not UTF-8", "0xe9"]),
    "empty": (b"", ["expected a mapping", "NoneType"]),
    "top-level-list": (b"- a\n- b\n", ["expected a mapping", "list"]),
    "top-level-string": (EVA_URDF.read_bytes()[:2000], ["not valid YAML"]),
    "too-big": (b"name: x\n" + b"#" * (1 << 20) + b"\n", ["bytes", "at most"]),
    "yaml-syntax": (b"name: x\nmpc: {knots: 6\n", [":3:1", "not valid YAML"]),
    "yaml-tab": (b"name: x\nmpc:\n\tknots: 6\n", [":3:1", "not valid YAML"]),
    "duplicate-key": (b"name: x\nname: y\nreference: {type: hold}\n", [":2:1", "'name' given twice"]),
    "duplicate-nested-key": (b"name: x\nmpc: {knots: 6, knots: 7}\nreference: {type: hold}\n", ["'knots' given twice"]),
    "bomb-in-options": (
        _scenario_text().replace("name: rti", "name: ipopt\n  options:\n" + _bomb(indent=4)).encode(),
        ["more than", "aliases"],
    ),
    "bomb-in-string-field": (
        (_bomb() + "name: *a8\nreference: {type: hold}\n").encode(),
        ["more than", "aliases"],
    ),
    "deep-nesting": (b"name: x\nsolver: {options: " + b"[" * 5000 + b"]" * 5000 + b"}\n", ["nested too deeply"]),
}


def _entity_bomb() -> bytes:
    """XML "billion laughs": entities of ten entities each, 10^9 characters from one short DOCTYPE."""
    entities = [b'<!ENTITY a "aaaaaaaaaa">']
    for i in range(9):
        entities.append(b'<!ENTITY %c "%s">' % (98 + i, b"&%c;" % (97 + i) * 10))
    return b'<?xml version="1.0"?><!DOCTYPE r [' + b"".join(entities) + b"]><robot name='&j;'/>"


def _two_hands(inside: bytes = b"", joint: bytes = b"") -> bytes:
    """A URDF with the scenario's two hands on arm joints, `inside` its root link and `joint` in the left arm's."""
    arms = b"".join(
        b'<link name="%s_grasp"/><joint name="%s_JOINT" type="revolute"><parent link="body"/><child link="%s_grasp"/>'
        b'<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>%s</joint>'
        % (arm, arm, arm, joint if arm == b"LARM" else b"")
        for arm in (b"LARM", b"RARM")
    )
    return b'<robot name="r"><link name="body">%s</link>%s</robot>' % (inside, arms)


URDF_CASES = {
    # (what to write as robot.urdf, pieces)
    "urdf-not-xml": (b"this is not xml\n", ["robot.urdf", "not XML", "line 1"]),
    "urdf-binary": (bytes(range(256)) * 8, ["robot.urdf", "binary data"]),
    "urdf-not-utf8": (b"<robot name='r\xe9'/>", ["robot.urdf", "not UTF-8"]),
    "urdf-not-robot": (b"<html><body/></html>", ["robot.urdf", "<html>", "not <robot>"]),
    "urdf-missing-link": (
        b'<robot name="r"><link name="a"/><joint name="j" type="fixed"><parent link="a"/>'
        b'<child link="bb"/></joint></robot>',
        ["robot.urdf", "joint 'j'", "'bb'"],
    ),
    "urdf-entity-bomb": (_entity_bomb(), ["robot.urdf", "not XML"]),
    "urdf-is-a-scenario": (b"name: x\nreference: {type: hold}\n", ["robot.urdf", "not XML"]),
    "urdf-no-hands": (b'<robot name="r"><link name="a"/></robot>', ["LARM_grasp", "not a link"]),
    "urdf-joint-type": (
        _two_hands().replace(b'type="revolute"', b'type="hinge"', 1),
        ["robot.urdf: robot.urdf: joint 'LARM_JOINT'", "'hinge'", "choose one of: revolute, continuous"],
    ),
    "urdf-collision-shape": (
        _two_hands(b"<collision><geometry><plane/></geometry></collision>"),
        ["robot.urdf: robot.urdf: link 'body'", "<plane>", "choose one of: box (size), cylinder"],
    ),
    "urdf-missing-mesh": (
        _two_hands(b'<visual><geometry><mesh filename="body.stl"/></geometry></visual>'),
        ["robot.urdf: robot.urdf: mesh 'body.stl' not found"],
    ),
    "urdf-inertial-no-mass": (
        _two_hands(b'<inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'),
        ["robot.urdf: robot.urdf: OpTaS (urdf_parser_py) cannot read it", "inertial", "mass"],
    ),
    "urdf-empty-dynamics": (
        _two_hands(joint=b"<dynamics/>"),
        ["robot.urdf: robot.urdf: Pinocchio (urdfdom) cannot read it", "no damping and no friction"],
    ),
}


def _peak_reset() -> int:
    """Reset this process's peak RSS (Linux clear_refs 5) and return the current RSS [bytes]."""
    Path("/proc/self/clear_refs").write_text("5")
    return _status_kb("VmRSS") * 1024


def _status_kb(field: str) -> int:
    return int(re.search(rf"^{field}:\s+(\d+)", Path("/proc/self/status").read_text(), re.M).group(1))


def _check(args: list[str], path: Path, out: Path, pieces: list[str]) -> None:
    before = _peak_reset()
    start = time.perf_counter()
    result = runner.invoke(app, args)
    elapsed = time.perf_counter() - start
    grown = _status_kb("VmHWM") * 1024 - before
    text = result.output.strip()
    assert result.exit_code == 2, (args, result.exit_code, text, result.exception)
    assert "\n" not in text and text.startswith(f"error: {path}"), text
    assert "Traceback" not in text and not isinstance(result.exception, (AssertionError, TypeError)), text
    for piece in pieces:
        assert piece in text, (piece, text)
    assert not out.exists(), "a run directory was made for bad input"
    assert elapsed < 10.0 and grown < 1 << 30, (elapsed, grown)


def _both(tmp_path: Path, scenario: Path, overrides: list[str], pieces: list[str]) -> None:
    sets = [a for o in overrides for a in ("--set", o)]
    out = tmp_path / "run"
    _check(["validate", str(scenario), *sets], scenario, out, pieces)
    _check(["run", str(scenario), *sets, "--out", str(out), "--quiet"], scenario, out, pieces)


@pytest.mark.parametrize("overrides, pieces", [c[1:] for c in SET_CASES], ids=[c[0] for c in SET_CASES])
def test_a_bad_field_gets_one_line_naming_file_field_and_value(tmp_path, overrides, pieces):
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(_scenario_text())
    _both(tmp_path, scenario, overrides, pieces)


@pytest.mark.parametrize("content, pieces", list(FILE_CASES.values()), ids=list(FILE_CASES))
def test_a_bad_scenario_file_gets_one_line_naming_it(tmp_path, content, pieces):
    scenario = tmp_path / "scenario.yaml"
    scenario.write_bytes(content)
    _both(tmp_path, scenario, [], pieces)


@pytest.mark.parametrize("content, pieces", list(URDF_CASES.values()), ids=list(URDF_CASES))
def test_a_bad_urdf_gets_one_line_naming_the_scenario_and_robot_urdf(tmp_path, content, pieces):
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(_scenario_text())
    (tmp_path / "robot.urdf").write_bytes(content)
    _both(tmp_path, scenario, OWN_URDF, pieces)


@pytest.mark.parametrize(
    "name, pieces",
    [("missing.yaml", ["file not found"]), ("a_directory", ["is a directory"])],
    ids=["missing-file", "directory"],
)
def test_a_scenario_that_is_not_a_file_gets_one_line(tmp_path, name, pieces):
    scenario = tmp_path / name
    if name == "a_directory":
        scenario.mkdir()
    _both(tmp_path, scenario, [], pieces)


@pytest.mark.parametrize(
    "urdf, pieces",
    [("nowhere.urdf", ["does not exist"]), (".", ["is a directory"])],
    ids=["urdf-missing", "urdf-directory"],
)
def test_a_robot_urdf_that_is_not_a_file_gets_one_line(tmp_path, urdf, pieces):
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(_scenario_text())
    _both(tmp_path, scenario, [EE, FOOT, f"robot.urdf={urdf}"], ["robot.urdf", *pieces])


def test_the_corpus_holds_at_least_90_bad_inputs():
    assert len(SET_CASES) + len(FILE_CASES) + len(URDF_CASES) + 5 >= 90


def test_validate_reports_every_file_and_exits_2_if_any_is_bad(tmp_path):
    good, bad = tmp_path / "good.yaml", tmp_path / "bad.yaml"
    good.write_text(_scenario_text())
    bad.write_bytes(b"\xff\xfe")
    result = runner.invoke(app, ["validate", str(bad), str(tmp_path / "none.yaml"), str(good)])
    assert result.exit_code == 2
    assert f"{good}: ok" in result.output and "not UTF-8" in result.output and "file not found" in result.output


def test_a_run_whose_build_needs_more_memory_than_the_machine_has_is_refused_with_the_figure(tmp_path, monkeypatch):
    # K = 300 needs ~7.5 GiB to build (the measured model); an 8 GiB laptop allows 3.2
    monkeypatch.setattr("harmony_cli.scenario.checks.machine_memory", lambda: 8 << 30)
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(_scenario_text())
    _both(tmp_path, scenario, ["mpc.knots=300"], ["mpc.knots", "300", "GiB", "3.2 GiB"])
