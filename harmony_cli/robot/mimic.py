"""Mimic joints: a follower's value is its leader's times the multiplier plus the offset.

How harmony models a follower that moves (its leader is active, robot/active.py): it stays a movable joint of the
prepared URDF, <mimic> element kept, so it is a joint of every model - OpTaS and PyBullet read no <mimic> and
Pinocchio reads it only when asked to, so all three take the follower as an independent joint - and harmony keeps
every joint vector it makes on the coupling: the home pose, the whole-body MPC's trajectory (equality rows,
mpc/transcription.py), the measured state each solve starts from, and the reach and stance searches (the follower
is not one of their variables: its value is the leader's, `coupled`). The simulator then gets each joint's target
from a coupled command, and the three models agree on the hands because they are given the same joint values.

Why not replace the follower in the prepared URDF: its motion is not a fixed transform, and no URDF construct other
than <mimic> ties two joints. Why not each model's own mimic support: only Pinocchio has one, so the models would
disagree. Why not drop the follower from the MPC's variables: its decision vector would then differ from the
models' joint vector, and every knot function would need the map between them; equality rows reuse the linear
rows every solver already takes (a row on values the solve holds fixed is dropped, mpc/reduction.py).

A follower of a follower follows the first leader up the line, with the multipliers and offsets composed.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import casadi as cs
import numpy as np

from harmony_cli.robot.urdf import required


@dataclass(frozen=True)
class Mimic:
    """What a follower joint mimics: its value = multiplier * the leader's + offset."""

    master: str  # the leader joint's name
    multiplier: float
    offset: float

    def value(self, master_value: float) -> float:
        return self.multiplier * master_value + self.offset


@dataclass(frozen=True)
class Coupling:
    """A follower joint moving with its leader, as indices into a robot's joint vector."""

    follower: int
    leader: int
    multiplier: float
    offset: float


def mimic_joints(robot: ET.Element) -> dict[str, Mimic]:
    """Follower joint -> the joint it follows, a follower's leader resolved to the first joint up the line that
    mimics none (multipliers and offsets composed). ValueError (`robot.urdf: ...`) for mimic joints in a cycle."""
    declared = {}
    for joint in robot.findall("joint"):
        element = joint.find("mimic")
        if element is not None:
            declared[required(joint, "name", "joint")] = Mimic(
                required(element, "joint", "mimic"),
                float(element.get("multiplier", 1.0)),
                float(element.get("offset", 0.0)),
            )
    resolved = {}
    for follower, mimic in declared.items():
        line = [follower]
        while mimic.master in declared:
            if mimic.master in line:
                raise ValueError(f"robot.urdf: mimic joints follow each other in a cycle: {' -> '.join(line)}")
            line.append(mimic.master)
            above = declared[mimic.master]
            mimic = Mimic(above.master, mimic.multiplier * above.multiplier, mimic.value(above.offset))
        resolved[follower] = mimic
    return resolved


def coupled(q, couplings: tuple[Coupling, ...]):
    """`q` (a numpy joint vector, or rows of them, or a CasADi vector) with every follower at its leader's value
    times the multiplier plus the offset; `q` itself when there is no coupling."""
    if not couplings:
        return q
    if isinstance(q, np.ndarray):
        q = q.copy()
        for c in couplings:
            q[..., c.follower] = c.multiplier * q[..., c.leader] + c.offset
        return q
    q = cs.SX(q) if isinstance(q, (cs.SX, cs.DM)) else cs.MX(q)
    for c in couplings:
        q[c.follower] = c.multiplier * q[c.leader] + c.offset
    return q
