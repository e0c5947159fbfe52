"""When a command acts (experiment/actuation.py): at once, a fixed latency later, or its compute time later."""

import numpy as np
import pytest

from harmony_cli.experiment.actuation import Actuator


class Recorder:
    """A simulator stand-in that records at which physics step each command arrives."""

    def __init__(self):
        self.steps, self.applied = 0, []

    def apply(self, q, qd):
        self.applied.append((self.steps, float(q[0])))

    def step(self, substeps):
        self.steps += substeps


def _drive(actuator, commands, substeps=5, compute_s=0.0):
    for k in range(commands):
        actuator.send(np.array([float(k)]), np.zeros(1), substeps, actuator.delay(compute_s))


@pytest.mark.parametrize("k", [1, 3, 5, 7, 12])
def test_a_fixed_latency_of_k_physics_steps_applies_each_command_exactly_k_steps_after_it_was_computed(k):
    sim = Recorder()
    _drive(Actuator(sim, k * 0.004, 0.004), 10)
    acted = [(step, int(q)) for step, q in sim.applied]
    # command j is computed at physics step 5 j; it acts at 5 j + k (those due after the tenth period never do)
    assert acted == [(5 * j + k, j) for j in range(10) if 5 * j + k < 50]
    assert sim.steps == 50


def test_without_latency_each_command_acts_at_once_for_the_whole_control_period():
    sim = Recorder()
    _drive(Actuator(sim, 0.0, 0.004), 4)
    assert sim.applied == [(0, 0.0), (5, 1.0), (10, 2.0), (15, 3.0)]


def test_a_measured_latency_rounds_the_compute_time_up_to_physics_steps():
    actuator = Actuator(Recorder(), "measured", 0.004)
    assert [actuator.delay(s) for s in (0.0, 0.001, 0.004, 0.0041, 0.0123)] == [0, 1, 1, 2, 4]


def test_a_command_that_acts_before_an_older_one_is_never_overridden_by_it():
    sim = Recorder()
    actuator = Actuator(sim, "measured", 0.004)
    actuator.send(np.array([0.0]), np.zeros(1), 5, 8)  # slow: due at step 8
    actuator.send(np.array([1.0]), np.zeros(1), 5, 1)  # quick: due at step 6, before it
    actuator.send(np.array([2.0]), np.zeros(1), 5, 0)
    assert sim.applied == [(6, 1.0), (10, 2.0)]
