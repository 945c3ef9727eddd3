"""Paired statistics of the evaluation: one configuration against a reference, seed by seed.

Every cell of the study runs the same seeds, and a seed fixes the truth (common random
numbers), so a configuration x is compared with the reference r through the per-seed
differences d_s = x_s - r_s (issue 14, item 6):

- the mean difference;
- its 95 % bootstrap confidence interval, resampling seeds (``scipy.stats.bootstrap`` with
  ``paired=True``, BCa; when BCa is undefined, as when nearly every difference is equal, the
  percentile interval; undefined (NaN) for fewer than two seeds);
- the two-sided Wilcoxon signed-rank p-value (``scipy.stats.wilcoxon``, zero differences
  dropped as in Wilcoxon's original test; every difference zero gives p = 1);
- ``significant``: p < ALPHA = 0.01.

``ratio_of_means`` gives mean(x) / mean(r) with the same paired bootstrap: a policy's detected
share as a fraction of the oracle sweep's (the ceiling). Seeds where either value is missing
(None or NaN, e.g. a time to detection with no target) are left out of both.
``mean_interval`` is the one unpaired figure: a mean over seeds with its t interval, for the
diagnostics.

The resampling generator is seeded (BOOTSTRAP_SEED), so a study's tables are reproducible.
"""

from dataclasses import dataclass
import math
from typing import Mapping, Optional, Tuple
import warnings

import numpy as np
from scipy import stats

ALPHA = 0.01
CONFIDENCE = 0.95
RESAMPLES = 9999
BOOTSTRAP_SEED = 14


@dataclass(frozen=True)
class Interval:
    """An estimate with its confidence interval [low, high] over n paired seeds."""

    n: int
    estimate: float
    low: float
    high: float

    def describe(self, digits: int = 2) -> str:
        """'estimate [low, high]' to the digits given; the estimate alone without an interval."""
        if not (_finite(self.low) and _finite(self.high)):
            return f'{self.estimate:.{digits}f}'
        return f'{self.estimate:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]'


@dataclass(frozen=True)
class PairedDifference(Interval):
    """Mean paired difference, its bootstrap CI and the Wilcoxon signed-rank p-value."""

    p_value: float = math.nan

    @property
    def significant(self) -> bool:
        """Whether p < ALPHA (False when p is undefined)."""
        return bool(self.p_value < ALPHA)


def paired_values(values: Mapping[int, Optional[float]],
                  reference: Mapping[int, Optional[float]]) -> Tuple[np.ndarray, np.ndarray]:
    """Align two {seed: value} maps on the seeds where both have a finite value."""
    seeds = sorted(s for s in set(values) & set(reference)
                   if _finite(values[s]) and _finite(reference[s]))
    return (np.array([values[s] for s in seeds], dtype=float),
            np.array([reference[s] for s in seeds], dtype=float))


def paired_difference(values, reference, confidence: float = CONFIDENCE,
                      resamples: int = RESAMPLES) -> PairedDifference:
    """Mean of values - reference (paired arrays) with its CI and Wilcoxon p (docstring)."""
    x, r = _pair(values, reference)
    differences = x - r
    interval = _bootstrap(x, r, lambda a, b, axis: np.mean(a - b, axis=axis),
                          confidence, resamples)
    if not differences.size:
        p_value = math.nan
    elif not np.any(differences):
        p_value = 1.0
    else:
        p_value = float(stats.wilcoxon(differences).pvalue)
    return PairedDifference(interval.n, interval.estimate, interval.low, interval.high,
                            p_value)


def ratio_of_means(values, reference, confidence: float = CONFIDENCE,
                   resamples: int = RESAMPLES) -> Interval:
    """mean(values) / mean(reference) over paired seeds, with its paired bootstrap CI."""
    x, r = _pair(values, reference)
    if not r.size or np.mean(r) == 0:
        return Interval(int(r.size), math.nan, math.nan, math.nan)
    return _bootstrap(x, r, _ratio, confidence, resamples)


def mean_interval(values, confidence: float = CONFIDENCE) -> Interval:
    """Return the mean of unpaired per-seed values with its t interval (none for < 2 values).

    For the diagnostics' figures over seeds (scripts/ospa_breakdown.py, search_coverage.py),
    which compare nothing paired.
    """
    values = np.asarray(values, dtype=float)
    mean = float(values.mean())
    if len(values) < 2:
        return Interval(len(values), mean, math.nan, math.nan)
    half = stats.t.ppf(0.5 + confidence / 2.0, len(values) - 1) * stats.sem(values)
    return Interval(len(values), mean, mean - half, mean + half)


def _ratio(a, b, axis):
    with np.errstate(divide='ignore', invalid='ignore'):
        return np.mean(a, axis=axis) / np.mean(b, axis=axis)


def _pair(values, reference):
    x = np.asarray(values, dtype=float).reshape(-1)
    r = np.asarray(reference, dtype=float).reshape(-1)
    if x.shape != r.shape:
        raise ValueError(f'paired samples differ in length: {x.size} and {r.size}')
    return x, r


def _bootstrap(x, r, statistic, confidence, resamples) -> Interval:
    n = int(x.size)
    estimate = float(statistic(x, r, axis=-1)) if n else math.nan
    if n < 2:
        return Interval(n, estimate, math.nan, math.nan)
    for method in ('BCa', 'percentile'):
        with warnings.catch_warnings(), np.errstate(invalid='ignore', divide='ignore'):
            # BCa is undefined on degenerate resamples (NaN); the percentile interval is not.
            warnings.simplefilter('ignore', stats.DegenerateDataWarning)
            result = stats.bootstrap((x, r), statistic, paired=True, vectorized=True,
                                     confidence_level=confidence, n_resamples=resamples,
                                     method=method, rng=np.random.default_rng(BOOTSTRAP_SEED))
        low, high = result.confidence_interval
        if np.isfinite(low) and np.isfinite(high):
            break
    return Interval(n, estimate, float(low), float(high))


def _finite(value) -> bool:
    return value is not None and math.isfinite(float(value))
