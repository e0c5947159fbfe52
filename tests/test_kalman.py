"""The constant-velocity Kalman filter (maths/filters.py) and the obstacle tracks built on it."""

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from harmony_cli.maths.filters import ConstantVelocityKalman
from harmony_cli.scenario.world import ObstacleSpec
from harmony_cli.tasks.motion import centre_at
from harmony_cli.tasks.obstacle_estimate import ObstacleTracks

DT = 0.02


def test_the_filter_s_gain_settles_at_the_steady_state_gain_of_the_discrete_riccati_equation(rng):
    kf = ConstantVelocityKalman(acceleration=1.0, measurement=0.02, dt=DT)
    for _ in range(2000):
        kf.update(rng.normal(0.0, 0.02, (1, 3)))
    prior = solve_discrete_are(kf.F.T, np.array([[1.0], [0.0]]), kf.Q, np.array([[kf.R]]))
    np.testing.assert_allclose(kf.gain, prior[:, 0] / (prior[0, 0] + kf.R), rtol=1e-6)


def test_the_estimate_converges_on_a_constant_velocity_track_measured_with_noise(rng):
    velocity, start = np.array([0.4, -0.3, 0.0]), np.array([1.0, 2.0, 1.0])
    kf = ConstantVelocityKalman(acceleration=0.1, measurement=0.02, dt=DT)  # a model that expects little turning
    errors, raw = [], []
    for k in range(500):
        truth = start + velocity * k * DT
        measured = truth + rng.normal(0.0, 0.02, 3)
        errors.append(np.linalg.norm(kf.update(measured[None])[0] - truth))
        raw.append(np.linalg.norm(measured - truth))
    assert np.linalg.norm(kf.state[1, 0] - velocity) < 0.05  # [m/s], from rest at the first measurement
    assert np.mean(errors[-250:]) < 0.5 * np.mean(raw[-250:])  # the filtered position beats the measurement


def test_a_track_s_prediction_a_second_ahead_is_where_a_constant_velocity_obstacle_will_be():
    walker = ObstacleSpec.model_validate(
        {
            "name": "walker",
            "shape": "sphere",
            "position": [0, 0, 1],
            "size": [0.3] * 3,
            "motion": {"velocity": [0.5, 0.2, 0.0]},
            "prediction": "estimated",
        }
    )
    standing = ObstacleSpec.model_validate(
        {"name": "post", "shape": "sphere", "position": [2, 0, 1], "size": [0.3] * 3}
    )
    tracks = ObstacleTracks([standing, walker], noise=0.0, dt=DT)
    assert tracks.estimated == [1]
    for k in range(150):
        tracks.update(k * DT, tracks.true_centres(k * DT))
    t = 149 * DT
    predicted = tracks.predictor()(np.array([t + 1.0]))
    np.testing.assert_allclose(predicted[1, 0], centre_at(walker, t + 1.0)[0], atol=0.01)
    np.testing.assert_allclose(predicted[0, 0], [2, 0, 1])  # a standing obstacle is where it stands
    assert tracks.errors(t)["estimate_walker_error_m"] == pytest.approx(0.0, abs=1e-3)
