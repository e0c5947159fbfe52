"""Shape.distance (maths/shapes.py) as compiled C for the task-space planner's clearance rows: both hands and the
carried object against an obstacle at every sample, each SQP iteration. numpy spends ~0.2 ms an obstacle on those
few dozen points; C takes microseconds. The same formulas, branch for branch (Shape.distance stays the reference
the tests hold this to). The shape and the object's growth are inputs: one compiled function per kind of shape
serves every scene and carried size (a study's scenes compile nothing new)."""

from __future__ import annotations

import casadi as cs
import numpy as np

from harmony_cli.maths.shapes import Shape
from harmony_cli.mpc.codegen import Buffered, Compiling, code_path


def _box(local: list, half: list):
    """shapes._box_distance for one point (any dimension): signed distance and gradient (box frame)."""
    excess = [cs.fabs(x) - h for x, h in zip(local, half)]
    outside = [cs.fmax(e, 0.0) for e in excess]
    d_out = cs.sqrt(sum(o * o for o in outside))
    inside = d_out == 0.0
    largest, axis = excess[0], [1.0] + [0.0] * (len(excess) - 1)  # the first axis of the largest excess
    for a in range(1, len(excess)):
        take = excess[a] > largest
        largest = cs.if_else(take, excess[a], largest)
        axis = [cs.if_else(take, float(a == b), axis[b]) for b in range(len(excess))]
    grad = [
        cs.if_else(inside, axis[a] * cs.if_else(x >= 0.0, 1.0, -1.0), cs.sign(x) * o / cs.fmax(d_out, 1e-12))
        for a, (x, o) in enumerate(zip(local, outside))
    ]
    return cs.if_else(inside, largest, d_out), grad


def distance_function(kind: str) -> cs.Function:
    """One point (3), how far the shape is grown sideways (a sphere: every way), and the shape of this `kind`: centre
    (3), cos and sin of its yaw, half sizes (3) -> signed distance, gradient (3). The shape is an input, so one
    compiled function serves every scene."""
    point, grow, centre = cs.SX.sym("point", 3), cs.SX.sym("grow"), cs.SX.sym("centre", 3)
    turn, size = cs.SX.sym("turn", 2), cs.SX.sym("half", 3)
    c, s = turn[0], turn[1]
    d = point - centre
    local = [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]]
    half = [size[0] + grow, size[1] + grow, size[2] + (grow if kind == "sphere" else 0.0)]
    if kind == "sphere":
        norm = cs.sqrt(local[0] * local[0] + local[1] * local[1] + local[2] * local[2])
        dist, grad = norm - half[0], [x / cs.fmax(norm, 1e-12) for x in local]
    elif kind == "cylinder":  # a box in (radial, z) coordinates
        radial = cs.sqrt(local[0] * local[0] + local[1] * local[1])
        dist, (g_radial, g_z) = _box([radial, local[2]], [half[0], half[2]])
        grad = [local[0] / cs.fmax(radial, 1e-12) * g_radial, local[1] / cs.fmax(radial, 1e-12) * g_radial, g_z]
    else:
        dist, grad = _box(local, half)
    world = cs.vertcat(c * grad[0] - s * grad[1], s * grad[0] + c * grad[1], grad[2])
    names = ["point", "grow", "centre", "turn", "half"], ["distance", "gradient"]
    return cs.Function(f"harmony_distance_{kind}", [point, grow, centre, turn, size], [dist, world], *names)


class CompiledDistance:
    """`Shape.distance` of `points` points at once (each with its own growth), compiled in the background from
    construction; `distance` returns views of its buffers, valid until the next call."""

    def __init__(self, shape: Shape, points: int):
        self.shape = shape
        self._code = Compiling(distance_function(shape.kind).map(points))
        self._f: Buffered | None = None
        self.grow = np.zeros(points)  # per point: how far the shape is grown for it (the caller sets it)

    def load(self) -> Buffered:
        """The compiled code (the first call waits for gcc) and its buffers as (points, 3) views."""
        if self._f is None:
            self._f = Buffered(self._code.function)
            self._points, self._grow = self._f.args["point"].reshape(-1, 3), self._f.args["grow"]
            self._dist, self._grad = self._f.res["distance"], self._f.res["gradient"].reshape(-1, 3)
            args, shape = self._f.args, self.shape  # the shape, the same at every point (column-major: point-major)
            args["centre"].reshape(-1, 3)[:], args["half"].reshape(-1, 3)[:] = shape.centre, shape.half
            args["turn"].reshape(-1, 2)[:] = np.cos(shape.yaw), np.sin(shape.yaw)
        return self._f

    def code_path(self) -> str:
        """ "compiled C", or "CasADi VM" without gcc (codegen.py); loads the code."""
        self.load()
        return code_path(self._code.function)

    def distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points, 3) -> signed distances (points,) and gradients (points, 3)."""
        f = self.load()
        self._points[:], self._grow[:] = points, self.grow
        f()  # the buffers set above in place: no inputs to copy
        return self._dist, self._grad
