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


class ConstantVelocityKalman:
    """A Kalman filter for points moving at a constant velocity, perturbed by white accelerations of standard
    deviation `acceleration` [m/s^2], measured in position with white noise of standard deviation `measurement` [m]
    every `dt` [s]. Each axis is its own (position, velocity) filter; all share one covariance, as they share the
    model. Written out rather than taken from a library: it is ten lines of textbook algebra (the discretised white
    noise acceleration model), and the test checks its gain against the discrete Riccati equation's."""

    def __init__(self, acceleration: float, measurement: float, dt: float):
        self.F = np.array([[1.0, dt], [0.0, 1.0]])
        self.Q = acceleration**2 * np.array([[dt**4 / 4.0, dt**3 / 2.0], [dt**3 / 2.0, dt**2]])
        self.R = measurement**2
        self.state: np.ndarray | None = None  # (2, points, 3): positions and velocities
        self.P = np.zeros((2, 2))

    def update(self, measured: np.ndarray, speed: float = 1.0) -> np.ndarray:
        """Predict one step and correct with the `measured` positions (points, 3); the filtered positions. The
        first measurement starts the filter at rest with a velocity uncertainty of `speed` [m/s]."""
        z = np.asarray(measured, dtype=float)
        if self.state is None:
            self.state = np.stack([z, np.zeros_like(z)])
            self.P = np.diag([max(self.R, 1e-12), speed**2])
            return z.copy()
        x = np.tensordot(self.F, self.state, axes=1)
        P = self.F @ self.P @ self.F.T + self.Q
        gain = P[:, 0] / (P[0, 0] + self.R)  # H = [1, 0]
        self.state = x + gain[:, None, None] * (z - x[0])[None]
        self.P = P - np.outer(gain, P[0])
        return self.state[0].copy()

    @property
    def gain(self) -> np.ndarray:
        """The gain the last correction used would use again (2,): positions' and velocities'."""
        P = self.F @ self.P @ self.F.T + self.Q
        return P[:, 0] / (P[0, 0] + self.R)
