"""Discrete-time filters."""

from __future__ import annotations

import numpy as np


class LowPass:
    """First-order low-pass y += a (u - y), a = dt / (tau + dt), starting at the first sample; tau = 0 passes u."""

    def __init__(self, tau: float, dt: float):
        self.alpha = dt / (tau + dt)
        self.value: np.ndarray | None = None

    def __call__(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        self.value = u.copy() if self.value is None else self.value + self.alpha * (u - self.value)
        return self.value.copy()
