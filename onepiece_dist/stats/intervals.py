"""Bootstrap intervals over objects (pure numpy): the study's and the pick benchmark's uncertainty."""

from __future__ import annotations

import numpy as np


def percentile_interval(values, confidence: float) -> tuple[float, float]:
    """The central ``confidence`` interval of ``values`` by percentiles."""
    tail = 100 * (1 - confidence) / 2
    low, high = np.percentile(values, [tail, 100 - tail])
    return float(low), float(high)


def bootstrap_interval(per_object: np.ndarray, seed: int = 0, draws: int = 2000,
                       confidence: float = 0.95) -> tuple[float, float]:
    """Percentile interval of the mean of ``per_object`` (objects resampled with replacement)."""
    if len(per_object) == 0:
        return 0.0, 0.0
    rng = np.random.default_rng([seed, 5])
    means = per_object[rng.integers(0, len(per_object), (draws, len(per_object)))].mean(axis=1)
    return percentile_interval(means, confidence)
