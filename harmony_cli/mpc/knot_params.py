"""The whole-body MPC's per-knot parameters, named once: one column per knot, rows

    per hand      [p_ref (3); vec(R_ref) (9)]          (column-major vec, as casadi.vec)
    per obstacle  [centre (3); yaw; relief]            (moving obstacles: their predicted poses; relief [m]: how
                                                        far its margins are lowered, clearance.Clearance.give)
    if compliant  per hand F_ref, then per hand F_meas [N]
    per chest joint  its reference [rad] (0: straight; a stance pose's where the written stance is blocked)
    stance        the base's reference x, y [m], yaw [rad], then its weight (0: none)
    task weight   the hands' tracking rows' weight multiplier (1; more where a late phase presses its goal)

The task residual keeps the hands' rows in the same order: per hand 3 position rows, then 9 rotation rows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HAND_ROWS = 12
POSE_ROWS = 5
STANCE_ROWS = 4  # x, y, yaw, weight


@dataclass(frozen=True)
class KnotLayout:
    n_hands: int
    n_obstacles: int
    compliant: bool = False
    n_chest: int = 0

    @property
    def rows(self) -> int:
        return self.task_weight + 1

    @property
    def task_weight(self) -> int:
        """The row of the hands' tracking weight multiplier."""
        return self.stance_start + STANCE_ROWS

    @property
    def stance_start(self) -> int:
        """The first of the base's reference rows (x, y, yaw, weight)."""
        return self.chest_start + self.n_chest

    @property
    def chest_start(self) -> int:
        """The first chest reference row."""
        return HAND_ROWS * self.n_hands + POSE_ROWS * self.n_obstacles + (2 * self.n_hands if self.compliant else 0)

    @property
    def chest_ref(self) -> slice:
        return slice(self.chest_start, self.stance_start)

    def hand_position(self, h: int) -> slice:
        return slice(HAND_ROWS * h, HAND_ROWS * h + 3)

    def hand_rotation(self, h: int) -> slice:
        return slice(HAND_ROWS * h + 3, HAND_ROWS * (h + 1))

    @property
    def hands_end(self) -> int:
        """The first row after the hands' (where obstacle poses, or a residual's extra rows, begin)."""
        return HAND_ROWS * self.n_hands

    @staticmethod
    def pose_centre(o: int) -> slice:
        """Obstacle o's centre rows within the block of obstacle poses (POSE_ROWS per obstacle)."""
        return slice(POSE_ROWS * o, POSE_ROWS * o + 3)

    def obstacle_centre(self, o: int) -> slice:
        within = self.pose_centre(o)
        return slice(self.hands_end + within.start, self.hands_end + within.stop)

    def obstacle_yaw(self, o: int) -> int:
        return self.hands_end + POSE_ROWS * o + 3

    @staticmethod
    def pose_relief(o: int) -> int:
        """Obstacle o's relief row within the block of obstacle poses."""
        return POSE_ROWS * o + 4

    def obstacle_relief(self, o: int) -> int:
        return self.hands_end + self.pose_relief(o)

    def force_ref(self, h: int) -> int:
        return self.hands_end + POSE_ROWS * self.n_obstacles + h

    def force_meas(self, h: int) -> int:
        return self.hands_end + POSE_ROWS * self.n_obstacles + self.n_hands + h

    def stack(
        self,
        hands: np.ndarray,
        obstacle_poses: np.ndarray,
        force_ref: np.ndarray | None = None,
        force_meas: np.ndarray | None = None,
        chest_ref: np.ndarray | None = None,
        stance: np.ndarray | None = None,
        task_weight: float = 1.0,
    ) -> np.ndarray:
        """The parameter vector vec(rows x K): hands (12 hands x K, see hand_rows), obstacle poses (POSE_ROWS
        obstacles x K), when compliant the force references (hands x K) and measured forces (hands,) held over K,
        then the chest joints' references (chest joints x K; 0 by default), then the base's stance (STANCE_ROWS x K:
        x, y, yaw, weight; none by default), then the hands' tracking weight multiplier, held over K."""
        rows = [hands, obstacle_poses]
        if self.compliant:
            K = hands.shape[1]
            rows += [
                np.zeros((self.n_hands, K)) if force_ref is None else force_ref,
                np.tile(np.zeros(self.n_hands) if force_meas is None else force_meas, (K, 1)).T,
            ]
        K = hands.shape[1]
        if self.n_chest:
            rows.append(np.zeros((self.n_chest, K)) if chest_ref is None else chest_ref)
        rows.append(np.zeros((STANCE_ROWS, K)) if stance is None else stance)
        rows.append(np.full((1, K), task_weight))
        return np.vstack(rows).ravel(order="F")


def hand_rows(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(K, hands, 3) positions and (K, hands, 3, 3) rotations -> (12 * hands) x K, per hand [p; vec(R)]."""
    K, hands = positions.shape[:2]
    vec_r = rotations.transpose(0, 1, 3, 2).reshape(K, hands, 9)  # column-major vec(R), as casadi.vec
    return np.concatenate([positions, vec_r], axis=2).reshape(K, HAND_ROWS * hands).T
