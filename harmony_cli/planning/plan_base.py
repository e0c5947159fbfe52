"""The base as the task-space planner sees it: the footprint circles carried rigidly behind the hands, as they stand
at home, turning with the plan's heading. The base follows the hands (the whole-body MPC moves both), so a plan
whose hands pass an obstacle where the base cannot follow is a plan the whole-body MPC cannot track: it then stops
the hands (the grip twists on a held box) or finds no feasible step. The planner keeps this footprint clear of
the obstacles and table legs by soft rows (the arms may stretch: the true base is only near this one).
"""

from __future__ import annotations

import numpy as np

from harmony_cli.planning.hand_plan import Obstacle


class PlannedBase:
    """`circles` (n, 3): x, y, radius in the base frame; `offsets` (n, 2): each circle's centre from the hands'
    midpoint at home, in the base frame; `yaw_home`: the base's yaw at heading 0; `bodies`: what the footprint
    keeps `clearance` from in plan view (obstacles with their margin, table legs with the base's)."""

    def __init__(self, circles: np.ndarray, offsets: np.ndarray, yaw_home: float, bodies: tuple[Obstacle, ...]):
        self.circles, self.offsets, self.yaw_home, self.bodies = circles, offsets, yaw_home, bodies
        # the bodies as arrays (plan view), for every body at once: centres at t = 0, yaws, half sizes, round or not
        shapes = [body.shape for body in bodies]  # in plan view: a sphere by its outline, like a cylinder
        self._centres = np.array([s.centre[:2] for s in shapes]).reshape(-1, 2)
        self._yaws = np.array([s.yaw for s in shapes])
        self._halves = np.array([s.half[:2] for s in shapes]).reshape(-1, 2)
        self._round = np.array([s.kind != "box" for s in shapes])
        self._clearances = np.array([b.clearance for b in bodies])
        radii = np.where(self._round, self._halves[:, 0], np.hypot(self._halves[:, 0], self._halves[:, 1]))
        self._hub = offsets.mean(axis=0) if len(offsets) else np.zeros(2)  # the footprint's middle
        spread = np.hypot(*(offsets - self._hub).T) + circles[:, 2]
        self._moving = tuple(k for k, b in enumerate(bodies) if b.motion is not None)
        # what the screen takes off a body's distance: the footprint's bounding circle, the body's plan-view radius
        # about its centre, its clearance
        self._reserve = spread.max(initial=0.0) + radii + self._clearances

    @classmethod
    def at_home(cls, circles: np.ndarray, base_pose: np.ndarray, hands: np.ndarray, bodies: list[Obstacle]):
        """From the footprint, the base pose (x, y, yaw) at home and the hands (2, 3) there."""
        c, s = np.cos(base_pose[2]), np.sin(base_pose[2])
        d = hands[:, :2].mean(axis=0) - base_pose[:2]
        midpoint = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])  # in the base frame
        return cls(circles, circles[:, :2] - midpoint, float(base_pose[2]), tuple(bodies))

    def margins(self, midpoints: np.ndarray, headings: np.ndarray, times: np.ndarray, near=None, nearest=None):
        """Per body (those `near`, a mask; all by default) and sample, the smallest margin (>= 0: clear) of any circle
        of the footprint placed at the hands' `midpoints` (S, 2) and `headings` (S,) at absolute `times` (S,); with
        its gradient with respect to the midpoint (bodies, S, 2) and the heading (bodies, S). `nearest(picked,
        c, s, midpoints, centres)`: the picked bodies' margins and gradients (footprint_code.py's compiled C, `c`, `s`:
        the base yaw's cos and sin); by default every circle here, (circles, S) arrays a body (a few are near)."""
        picked = np.flatnonzero(np.ones(len(self.bodies), dtype=bool) if near is None else near)
        yaw = self.yaw_home + headings
        c, s = np.cos(yaw), np.sin(yaw)
        if nearest is not None:
            return nearest(picked, c, s, midpoints, self._centres_at(times))
        centres = np.broadcast_to(self._centres_at(times), (len(self.bodies), len(times), 2))
        margins, d_psi = np.empty((len(picked), len(times))), np.empty((len(picked), len(times)))
        grads = np.empty((len(picked), len(times), 2))
        ox, oy = self.offsets[:, 0:1], self.offsets[:, 1:2]  # (n, 1) against (S,)
        wx, wy = c * ox - s * oy, s * ox + c * oy  # (n, S) the offsets turned; d/d(yaw) is (-wy, wx)
        px, py = midpoints[:, 0] + wx, midpoints[:, 1] + wy
        columns = np.arange(len(times))
        for i, k in enumerate(picked.tolist()):
            body = centres[k], self._yaws[k], self._halves[k], self._round[k]
            margin = _plan_distance(px, py, *body)[0] - self.circles[:, 2:3]
            index = np.argmin(margin, axis=0)  # (S,): the circle that matters at each sample
            margins[i] = margin[index, columns] - self._clearances[k]
            at = index, columns
            _, gx, gy = _plan_distance(px[at][None], py[at][None], *body)  # that circle's gradient
            grads[i, :, 0], grads[i, :, 1] = gx[0], gy[0]
            d_psi[i] = gy[0] * wx[at] - gx[0] * wy[at]
        return margins, grads, d_psi

    def _centres_at(self, times: np.ndarray) -> np.ndarray:
        """(bodies, S, 2), or (bodies, 1, 2) when none moves: where each body stands at `times` (S,)."""
        if not self._moving:
            return self._centres[:, None]
        centres = np.repeat(self._centres[:, None], len(times), axis=1)
        for k in self._moving:
            centres[k] = self.bodies[k].motion(times)[:, :2]  # type: ignore[misc]
        return centres

    def screen(self, mx: np.ndarray, my: np.ndarray, headings: np.ndarray, times: np.ndarray) -> np.ndarray:
        """Per body, a lower bound of the footprint's margin to it over the midpoints (`mx`, `my`: (S,) each) and
        `headings` (S,) at `times`: the distance from the footprint's bounding circle to the body's centre less the
        body's plan-view radius. A body it puts above 0 has no row to add (most are table legs across the room)."""
        yaw = self.yaw_home + headings
        c, s = np.cos(yaw), np.sin(yaw)
        ox, oy = self._hub
        centres = self._centres_at(times)
        gaps = np.hypot(mx + (c * ox - s * oy) - centres[..., 0], my + (s * ox + c * oy) - centres[..., 1])
        return gaps.min(axis=1) - self._reserve

    def rows(self, curves, times, weight: float, basis: np.ndarray, nearest=None):
        """The planner's soft rows at the plan's `curves` (7, 1 + S): its fixed start (s = 0), then its S samples (the
        last is its fixed goal) at absolute `times` (1 + S,): the active ones only (a margin short of 0), residuals
        r (m,) = weight * (margin + relief) and their Jacobian J (m, 7 * free columns) over the free control points
        (`basis`: (free columns, S)); and the smallest margin (relieved; a bound above 0 when nothing is near).
        `nearest`: see `margins` (footprint_code.py's compiled C; by default numpy).
        A body's relief is how far the footprint at either fixed end is inside its clearance: a path cannot do
        better than its ends, and asking it to would bend the hands' path where the whole-body MPC stands the base
        elsewhere anyway."""
        mx, my = 0.5 * (curves[0] + curves[3]), 0.5 * (curves[1] + curves[4])
        bound = self.screen(mx, my, curves[6], times)
        near = bound <= 0.0
        if not near.any():
            return np.zeros(0), np.zeros((0, 7 * basis.shape[0])), float(bound.min())
        margins, d_mid, d_psi = self.margins(np.column_stack([mx, my]), curves[6], times, near, nearest)
        reliefs = np.maximum(-np.minimum(margins[:, 0], margins[:, -1]), 0.0)
        margins = margins[:, 1:] + reliefs[:, None]
        smallest = min(float(margins.min(initial=np.inf)), float(bound[~near].min(initial=np.inf)))
        body, sample = np.nonzero(margins < 0.0)
        if not len(body):
            return np.zeros(0), np.zeros((0, 7 * basis.shape[0])), smallest
        d_mid, d_psi = d_mid[:, 1:], d_psi[:, 1:]
        J = np.zeros((len(body), 7, basis.shape[0]))
        along = basis[:, sample].T  # (m, free columns)
        for curve, axis in ((0, 0), (1, 1), (3, 0), (4, 1)):  # the midpoint is half of each hand
            J[:, curve] = along * (0.5 * weight * d_mid[body, sample, axis])[:, None]
        J[:, 6] = along * (weight * d_psi[body, sample])[:, None]
        return weight * margins[body, sample], J.reshape(len(body), 7 * basis.shape[0]), smallest


def _plan_distance(px, py, centre, yaw, half, round_):
    """Signed distance in plan view of the points (`px`, `py`: (n, S)) to a body at `centre` ((S, 2) or (1, 2)),
    turned by `yaw`, of half size `half` (2,) (round: radius half[0]), and its gradient (gx, gy): Shape.distance's."""
    dx, dy = px - centre[:, 0], py - centre[:, 1]
    if round_:
        radial = np.maximum(np.hypot(dx, dy), 1e-12)
        return radial - half[0], dx / radial, dy / radial
    c, s = np.cos(yaw), np.sin(yaw)
    lx, ly = c * dx + s * dy, -s * dx + c * dy  # in the body's frame
    ex, ey = np.abs(lx) - half[0], np.abs(ly) - half[1]
    ox, oy = np.maximum(ex, 0.0), np.maximum(ey, 0.0)
    outside = np.hypot(ox, oy)
    inside = outside == 0.0
    dist = np.where(inside, np.maximum(ex, ey), outside)
    scale = np.where(inside, 0.0, 1.0 / np.maximum(outside, 1e-12))
    gx = np.sign(lx) * np.where(inside, ex >= ey, ox * scale)  # inside: the nearest face's normal
    gy = np.sign(ly) * np.where(inside, ex < ey, oy * scale)
    return dist, c * gx - s * gy, s * gx + c * gy  # back to the world frame
