"""The whole-body MPC's built structure (transcription, scene clearances, knot layout and the Problem with its CasADi
graphs and compiled maps), kept in this process and reused by every later run that shares it.

A study's worker runs scene after scene of one scenario; what differs between them is, for the whole-body MPC,
numbers it takes as parameters or at run time: obstacle and table poses (knot parameters), the box (not in this
MPC), the robot's start (robot.base_pose moves only the base joints' home, which no cost or constraint uses) and
the references. The key below is everything the build reads; what is not in it must not change the structure.
Nothing here keeps state between runs: each run makes its own solver (QP/NLP instances, warm starts), filters and
plan (WholeBodyMPC), and the shared derivative maps only cache a deterministic function's last value."""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.mpc.clearance import Clearance, scenario_clearances
from harmony_cli.mpc.knot_params import KnotLayout
from harmony_cli.mpc.problem import Problem
from harmony_cli.mpc.transcription import Transcription, make_transcription
from harmony_cli.mpc.wholebody_problem import build_problem, joint_limits
from harmony_cli.robot.model import Robot

if TYPE_CHECKING:
    from harmony_cli.scenario.models import Scenario

KEEP = 4  # structures kept per process (a compare grid may cycle through a few; each holds its CasADi graphs)


@dataclass(frozen=True)
class Structure:
    transcription: Transcription
    clearances: tuple[Clearance, ...]
    layout: KnotLayout
    problem: Problem


_BUILT: OrderedDict[tuple, Structure] = OrderedDict()
builds = 0  # structures built in this process (tests: a reused one is not built again)


def structure_key(robot: Robot, scenario: Scenario) -> tuple:
    """Everything the whole-body MPC's structure is built from: the robot's kinematics (its URDF's content), joints,
    mimic couplings, limits and home (base joints excluded: robot.base_pose), the mpc section, chest and mirrored
    joints, the admittance section when enabled, the obstacles', table legs' and tops' shapes and margins (the arms'
    radius among them), the footprint."""
    home = robot.home.copy()
    home[list(robot.base_joints)] = 0.0
    clearances, _ = scenario_clearances(scenario)
    spec = scenario.robot
    return (
        hashlib.sha256(robot.urdf.read_bytes()).hexdigest(),
        robot.joint_names,
        robot.end_effectors,
        robot.hand_names,
        robot.base_joints,
        robot.pinned_joints,
        robot.couplings,
        *(a.tobytes() for a in (robot.lower, robot.upper, robot.velocity_limit, home)),
        scenario.mpc.model_dump_json(),
        tuple(spec.chest_joints),
        tuple(map(tuple, spec.mirrored_joints)),
        scenario.admittance.model_dump_json() if scenario.admittance.enabled else None,
        tuple((c.kind, np.asarray(c.half, dtype=float).tobytes(), c.base, c.hand, c.arm, c.give) for c in clearances),
        tuple(map(tuple, spec.footprint)) if clearances else (),
    )


def build_structure(robot: Robot, scenario: Scenario) -> Structure:
    admittance = scenario.admittance if scenario.admittance.enabled else None
    transcription = make_transcription(scenario.mpc, joint_limits(robot, admittance)[0].size)
    clearances, _ = scenario_clearances(scenario)
    problem = build_problem(
        robot,
        transcription,
        scenario.mpc.weights,
        scenario.robot.chest_joints,
        scenario.robot.mirrored_joints,
        clearances,
        tuple(map(tuple, scenario.robot.footprint)) if clearances else (),
        scenario.mpc.clearance,
        admittance,
    )
    layout = KnotLayout(
        len(robot.end_effectors), len(clearances), admittance is not None, len(scenario.robot.chest_joints)
    )
    return Structure(transcription, clearances, layout, problem)


def structure_for(robot: Robot, scenario: Scenario) -> tuple[Structure, bool]:
    """The structure of this robot and scenario, and whether it was reused (built by an earlier run here)."""
    global builds
    key = structure_key(robot, scenario)
    if key in _BUILT:
        _BUILT.move_to_end(key)
        return _BUILT[key], True
    structure = _BUILT[key] = build_structure(robot, scenario)
    builds += 1
    while len(_BUILT) > KEEP:
        _BUILT.popitem(last=False)
    return structure, False


def forget_structures() -> None:
    """Drop every kept structure (the next run builds its own)."""
    _BUILT.clear()
