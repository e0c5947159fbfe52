"""The search for the planned base's nearest footprint circle (PlannedBase.margins' `nearest`) in compiled C: numpy
spends ~0.2 ms a planner step on (circles x samples) arrays per body near the footprint (a narrow passage: every
step). C finds each sample's nearest circle, its margin and that circle's gradient in the same operations as
plan_base's numpy, so margins and gradients equal the numpy search's to the bit (a test)."""

from __future__ import annotations

import casadi as cs
import numpy as np

from harmony_cli.mpc.codegen import Buffered, Compiling, code_path
from harmony_cli.planning.plan_base import PlannedBase


def _distance(dx, dy, body, round_: bool):
    """plan_base._plan_distance, operation for operation: the signed distance of one point relative to a body's
    centre and its gradient (gx, gy); `body`: the symbols cos and sin of its yaw, half sizes (2). A Function keeps
    only what its outputs use: a distance alone, or a gradient alone, costs only its own operations."""
    if round_:
        radial = cs.fmax(cs.hypot(dx, dy), 1e-12)
        return radial - body[2], dx / radial, dy / radial
    c, s, half = body[0], body[1], body[2:4]
    lx, ly = c * dx + s * dy, -s * dx + c * dy  # in the body's frame
    ex, ey = cs.fabs(lx) - half[0], cs.fabs(ly) - half[1]
    ox, oy = cs.fmax(ex, 0.0), cs.fmax(ey, 0.0)
    outside = cs.hypot(ox, oy)
    inside = outside == 0.0
    # fmax(1 / x, 0) = 1 / x, but keeps ox * scale a product: CasADi folds x * (1 / y) into x / y, rounded apart
    scale = cs.if_else(inside, 0.0, cs.fmax(1.0 / cs.fmax(outside, 1e-12), 0.0))
    gx = cs.sign(lx) * cs.if_else(inside, ex >= ey, ox * scale)
    gy = cs.sign(ly) * cs.if_else(inside, ex < ey, oy * scale)
    return cs.if_else(inside, cs.fmax(ex, ey), outside), c * gx - s * gy, s * gx + c * gy


def margin_function(base: PlannedBase, round_: bool) -> cs.Function:
    """One sample: hands' midpoint (2), cos and sin of the base's yaw (from numpy), a body's centre (2) and shape (cos
    and sin of its yaw, half sizes (2), clearance), round or a box -> the margin to it of the footprint's circle
    nearest it (the first of equals, as argmin), that margin's gradient with respect to the midpoint (2) and the
    base's heading (at that circle only, as plan_base). The body is an input: one compiled function per robot and
    kind serves every scene."""
    mid, turn, centre = cs.SX.sym("mid", 2), cs.SX.sym("turn", 2), cs.SX.sym("centre", 2)
    body = cs.SX.sym("body", 5)
    c, s = turn[0], turn[1]
    best = None
    for (ox, oy), radius in zip(base.offsets, base.circles[:, 2]):
        wx, wy = c * ox - s * oy, s * ox + c * oy
        px, py = mid[0] + wx, mid[1] + wy
        circle = [_distance(px - centre[0], py - centre[1], body, round_)[0] - radius, px, py, wx, wy]
        if best is None:
            best = circle
        else:
            take = circle[0] < best[0]
            best = [cs.if_else(take, new, old) for new, old in zip(circle, best)]
    assert best is not None
    margin, px, py, wx, wy = best
    _, gx, gy = _distance(px - centre[0], py - centre[1], body, round_)  # at the nearest circle only
    names = (["mid", "turn", "centre", "body"], ["margin", "gx", "gy", "d_psi"])
    outputs = [margin - body[4], gx, gy, gy * wx - gx * wy]  # d/d(heading) of the offset is (-wy, wx)
    return cs.Function(f"harmony_footprint_{'round' if round_ else 'box'}", [mid, turn, centre, body], outputs, *names)


class CompiledMargins:
    """PlannedBase.margins' `nearest` for `samples` points, compiled (in the background from construction): a map
    over the samples per kind of body (round, box), the body's shape one input they share, so a step writes the
    midpoints and headings once and each body near the footprint costs one call."""

    def __init__(self, base: PlannedBase, samples: int):
        self.base, self.samples = base, samples
        kinds = sorted({bool(r) for r in base._round})
        self._code = {r: Compiling(margin_function(base, r).map("map", "serial", samples, [3], [])) for r in kinds}
        self._f: dict[bool, Buffered] = {}
        self._shapes = np.column_stack([np.cos(base._yaws), np.sin(base._yaws), base._halves, base._clearances])

    def load(self, round_: bool) -> Buffered:
        """A kind's compiled code (the first call waits for gcc)."""
        f = self._f.get(round_)
        if f is None:
            f = self._f[round_] = Buffered(self._code[round_].function)
        return f

    def code_path(self) -> str:
        """ "compiled C", or "CasADi VM" without gcc (codegen.py), "none" without bodies; loads every kind's code."""
        for round_ in self._code:
            self.load(round_)
        return code_path(next(iter(self._code.values())).function) if self._code else "none"

    def __call__(self, picked: np.ndarray, c: np.ndarray, s: np.ndarray, midpoints: np.ndarray, centres: np.ndarray):
        """The `picked` bodies' margins (picked, S) and their gradients, (picked, S, 2) with respect to the midpoint
        and (picked, S) to the heading, with the base yaw's cos and sin `c`, `s` (S,), the hands' `midpoints` (S, 2)
        and every body's centres (bodies, S or 1, 2)."""
        S, kinds = self.samples, self.base._round[picked]
        margins, grads, d_psi = np.empty((len(picked), S)), np.empty((len(picked), S, 2)), np.empty((len(picked), S))
        for round_ in {bool(r) for r in kinds}:
            f = self.load(round_)
            turn = f.args["turn"].reshape(S, 2)  # the buffers are column-major: (2, S) is (S, 2) in C order
            f.args["mid"].reshape(S, 2)[:], turn[:, 0], turn[:, 1] = midpoints, c, s
        for i, (k, round_) in enumerate(zip(picked.tolist(), kinds.tolist())):
            f = self._f[round_]
            f.args["body"][:], f.args["centre"].reshape(S, 2)[:] = self._shapes[k], centres[k]
            f()  # the buffers set above in place: no inputs to copy
            res = f.res
            margins[i], grads[i, :, 0], grads[i, :, 1], d_psi[i] = res["margin"], res["gx"], res["gy"], res["d_psi"]
        return margins, grads, d_psi
