"""Time scalings: smooth 0 -> 1 blends."""

from __future__ import annotations

import numpy as np


def quintic(s: np.ndarray) -> np.ndarray:
    """10 s^3 - 15 s^4 + 6 s^5: 0 -> 1 with zero slope and curvature at both ends, for s in [0, 1] (clipped
    outside): starts and ends at rest."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)
