"""The study's intervals (study/intervals.py): bootstrap intervals that cover what they claim to."""

import numpy as np
import pytest

from harmony_cli.study.intervals import mean_interval, median_interval, paired_difference, paired_ratio


def test_the_bootstrap_interval_of_a_mean_covers_the_true_mean_in_at_least_93_of_100_repetitions():
    rng = np.random.default_rng(46)
    covered = 0
    for _ in range(100):
        estimate = mean_interval(rng.normal(3.0, 1.0, size=50))
        covered += estimate.low <= 3.0 <= estimate.high
    assert covered >= 93


def test_a_paired_ratio_s_interval_excludes_1_when_one_setting_is_slower_on_every_draw_and_not_when_neither_is():
    rng = np.random.default_rng(1)
    base = rng.lognormal(0.0, 0.4, 50)  # draws of very different difficulty, the same under both settings
    slower = paired_ratio(base * rng.uniform(1.8, 2.2, 50), base)
    assert slower.value == pytest.approx(2.0, abs=0.1) and slower.excludes(1.0)
    same = paired_ratio(base * rng.uniform(0.9, 1.1, 50), base)
    assert not same.excludes(1.0)


def test_pairing_finds_a_small_effect_that_the_draws_spread_hides_unpaired():
    rng = np.random.default_rng(2)
    base = rng.normal(10.0, 3.0, 50)
    shifted = base + 0.5 + rng.normal(0.0, 0.2, 50)
    assert paired_difference(shifted, base).excludes(0.0)
    unpaired = mean_interval(shifted).low <= mean_interval(base).high
    assert unpaired  # the two means' intervals overlap


def test_a_median_of_equal_values_is_that_value_with_no_spread_and_too_few_values_give_no_interval():
    assert median_interval([3.0] * 10).text() == "3 (3 to 3, n = 10)"
    assert median_interval([1.0]).text() == "n/a"
    assert np.isnan(median_interval([np.nan, 2.0]).low)


def test_a_difference_of_successes_with_few_distinct_values_gets_the_percentile_interval_without_warnings():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        estimate = paired_difference([0, 0, 0, 1, 0, 0, 0, 0], [1, 1, 1, 1, 1, 1, 1, 1])
    assert estimate.value == pytest.approx(-0.875) and estimate.low <= -0.875 <= estimate.high
    assert np.isfinite(estimate.low) and estimate.high < 0.0
