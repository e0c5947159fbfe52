"""Intervals a study reports: the Wilson interval of a success rate, and bootstrap intervals of a metric's median
and of paired comparisons (the same draws under two settings: common random numbers).

Every interval says its method and n. The bootstrap is scipy's (`scipy.stats.bootstrap`, BCa, 9999 resamples,
seeded so that a report is reproducible; the percentile interval where BCa is undefined, as for a statistic of a
few distinct values such as differences of successes); a paired comparison resamples the draws, keeping each
draw's two runs together."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.stats import DegenerateDataWarning, binomtest, bootstrap

CONFIDENCE = 0.95
RESAMPLES = 9999
SEED = 0  # the bootstrap's resampling stream: a report computed twice gives the same intervals


def wilson(successes: int, n: int) -> tuple[float, float]:
    """Wilson score 95 % interval of a binomial proportion (good at small n and at rates near 0 or 1)."""
    if n == 0:
        return (math.nan, math.nan)
    interval = binomtest(successes, n).proportion_ci(confidence_level=CONFIDENCE, method="wilson")
    return (float(interval.low), float(interval.high))


@dataclass(frozen=True)
class Estimate:
    """A statistic of n values and its bootstrap interval (nan without enough values)."""

    value: float
    low: float
    high: float
    n: int

    def excludes(self, no_effect: float) -> bool:
        """Whether the interval lies wholly on one side of `no_effect` (1 for a ratio, 0 for a difference)."""
        return bool(self.low > no_effect or self.high < no_effect)

    def text(self, scale: float = 1.0, digits: int = 3) -> str:
        if self.n < 2:
            return "n/a"
        v, lo, hi = (scale * x for x in (self.value, self.low, self.high))
        return f"{v:.{digits}g} ({lo:.{digits}g} to {hi:.{digits}g}, n = {self.n})"


def median_interval(values) -> Estimate:
    """The median of `values` (nan dropped) with its bootstrap 95 % interval (BCa, or percentile)."""
    return _bootstrap(np.asarray(values, dtype=float), np.median)


def mean_interval(values) -> Estimate:
    """The mean of `values` (nan dropped) with its bootstrap 95 % interval (BCa, or percentile)."""
    return _bootstrap(np.asarray(values, dtype=float), np.mean)


def paired_ratio(a, b) -> Estimate:
    """Per draw a / b, and the median of those ratios with its bootstrap interval (draws with a nan or b = 0
    dropped)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    keep = np.isfinite(a) & np.isfinite(b) & (b != 0)
    return _bootstrap(a[keep] / b[keep], np.median)


def paired_difference(a, b) -> Estimate:
    """Per draw a - b, and the mean of those differences with its bootstrap interval."""
    return _bootstrap(np.asarray(a, dtype=float) - np.asarray(b, dtype=float), np.mean)


def _bootstrap(values: np.ndarray, statistic) -> Estimate:
    values = values[np.isfinite(values)]
    n = int(values.size)
    if n < 2:
        return Estimate(float(statistic(values)) if n else math.nan, math.nan, math.nan, n)
    value = float(statistic(values))
    if np.all(values == values[0]):  # no spread: the interval is the value (BCa is undefined)
        return Estimate(value, value, value, n)
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # BCa's acceleration on few distinct values
            warnings.simplefilter("error", DegenerateDataWarning)
            try:
                result = bootstrap(
                    (values,),
                    statistic,
                    confidence_level=CONFIDENCE,
                    n_resamples=RESAMPLES,
                    method=method,
                    random_state=np.random.default_rng(SEED),
                )
            except DegenerateDataWarning:
                continue  # BCa is undefined here: the percentile interval
        interval = result.confidence_interval
        if np.isfinite(interval.low) and np.isfinite(interval.high):
            return Estimate(value, float(interval.low), float(interval.high), n)
    return Estimate(value, math.nan, math.nan, n)
