"""The search for the planned base's nearest footprint circle (PlannedBase.margins' `nearest`) in compiled C: numpy
spends ~0.2 ms a planner step on (circles x samples) arrays per body near the footprint (a narrow passage: every
step). C finds each sample's nearest circle and its margin; plan_base takes that circle's gradient, so margins and
gradients equal the numpy search's to the bit (a test)."""

from __future__ import annotations

import casadi as cs
import numpy as np

from harmony_cli.mpc.codegen import Buffered, Compiling, code_path
from harmony_cli.mpc.plan_base import PlannedBase


def _distance(dx, dy, body, round_: bool):
    """plan_base._plan_distance's signed distance of one point relative to a body's centre; `body`: the symbols cos
    and sin of its yaw, half sizes (2)."""
    c, s, half = body[0], body[1], body[2:4]
    if round_:
        return cs.fmax(cs.hypot(dx, dy), 1e-12) - half[0]
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    ex, ey = cs.fabs(lx) - half[0], cs.fabs(ly) - half[1]
    outside = cs.hypot(cs.fmax(ex, 0.0), cs.fmax(ey, 0.0))
    return cs.if_else(outside == 0.0, cs.fmax(ex, ey), outside)


def margin_function(base: PlannedBase, round_: bool) -> cs.Function:
    """One sample: hands' midpoint (2), cos and sin of the base's yaw (from numpy), a body's centre (2) and shape (cos
    and sin of its yaw, half sizes (2), clearance), round or a box -> the margin to it of the footprint's circle
    nearest it and that circle's index (the first of equals, as argmin). The body is an input: one compiled function
    per robot and kind serves every scene."""
    mid, turn, centre = cs.SX.sym("mid", 2), cs.SX.sym("turn", 2), cs.SX.sym("centre", 2)
    body = cs.SX.sym("body", 5)
    c, s = turn[0], turn[1]
    best, index = None, None
    for k, ((ox, oy), radius) in enumerate(zip(base.offsets, base.circles[:, 2])):
        wx, wy = c * ox - s * oy, s * ox + c * oy
        margin = _distance(mid[0] + wx - centre[0], mid[1] + wy - centre[1], body, round_) - radius
        if best is None:
            best, index = margin, cs.SX(0.0)
        else:
            take = margin < best
            best, index = cs.if_else(take, margin, best), cs.if_else(take, float(k), index)
    assert best is not None
    names = (["mid", "turn", "centre", "body"], ["margin", "nearest"])
    return cs.Function(
        f"harmony_footprint_{'round' if round_ else 'box'}", [mid, turn, centre, body], [best - body[4], index], *names
    )


class CompiledMargins:
    """PlannedBase.margins' `nearest` for `samples` points, compiled (in the background from construction): a buffer
    per body, holding its shape, so only the bodies near the footprint are evaluated."""

    def __init__(self, base: PlannedBase, samples: int):
        self.base, self.samples = base, samples
        kinds = {bool(r) for r in base._round}
        self._code = {r: Compiling(margin_function(base, r).map(samples)) for r in sorted(kinds)}
        self._f: list[Buffered | None] = [None] * len(base.bodies)

    def load(self, k: int) -> Buffered:
        """Body k's compiled code (the first call waits for gcc), its shape in its buffer."""
        f = self._f[k]
        if f is None:
            base = self.base
            f = self._f[k] = Buffered(self._code[bool(base._round[k])].function)
            yaw, half = base._yaws[k], base._halves[k]
            shape = [np.cos(yaw), np.sin(yaw), half[0], half[1], base._clearances[k]]
            f.args["body"].reshape(-1, 5)[:] = shape  # column-major (5, S): sample-major
        return f

    def code_path(self) -> str:
        """ "compiled C", or "CasADi VM" without gcc (codegen.py), "none" without bodies; loads every body's code."""
        for k in range(len(self._f)):
            self.load(k)
        return code_path(next(iter(self._code.values())).function) if self._code else "none"

    def __call__(self, k: int, c: np.ndarray, s: np.ndarray, midpoints: np.ndarray, centres: np.ndarray):
        """Body k's margin (S,) and nearest circle (S,) with the base yaw's cos and sin `c`, `s` (S,), the hands'
        `midpoints` (S, 2) and the body's centres (S or 1, 2)."""
        f = self.load(k)
        turn = f.args["turn"].reshape(-1, 2)  # the buffers are column-major: (2, S) is (S, 2) in C order
        f.args["mid"].reshape(-1, 2)[:], f.args["centre"].reshape(-1, 2)[:] = midpoints, centres
        turn[:, 0], turn[:, 1] = c, s
        f()  # the buffers set above in place: no inputs to copy
        return f.res["margin"].copy(), f.res["nearest"].astype(int)
