"""Bootstrap intervals over objects (pure numpy): the study's and the pick benchmark's uncertainty."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

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


@dataclass(frozen=True)
class PairedGain:
    """A tried design against its base on the same objects' views, seed for seed: the mean gain in first-attempt
    rate, the bootstrap interval over objects of the per-object gain (each object's rate averaged over the seeds),
    the seeds, and the verdict: 'kept' where the interval lies above zero at two seeds or more."""

    gain: float
    interval: tuple[float, float]
    seeds: int
    verdict: str


def paired_gain(tried: Sequence[Mapping[str, int]], base: Sequence[Mapping[str, int]], views: int,
                seed: int = 0, draws: int = 10_000, confidence: float = 0.95) -> PairedGain:
    """``tried`` and ``base``: per seed, object name -> views picked at the first attempt (of ``views`` each);
    the objects both judged at every seed are compared."""
    names = sorted(set.intersection(*(set(p) for p in [*tried, *base]))) if tried and base else []
    if not names or len(tried) != len(base):
        return PairedGain(0.0, (0.0, 0.0), min(len(tried), len(base)), "not compared")
    rates = [np.array([[p[n] / views for n in names] for p in side]).mean(axis=0) for side in (tried, base)]
    difference = rates[0] - rates[1]
    low, high = bootstrap_interval(difference, seed, draws, confidence)
    verdict = ("one seed: undecided" if len(tried) < 2 else "kept" if low > 0 else "not kept")
    return PairedGain(round(float(difference.mean()), 4), (round(low, 4), round(high, 4)), len(tried), verdict)


def against_a_guess(top: np.ndarray, random: np.ndarray, seed: int = 0) -> tuple[tuple[float, float], str]:
    """The 95% interval (objects resampled) of top-1 minus a random choice, and what it says: above a guess,
    below it, or not told apart from it by these objects."""
    difference = bootstrap_interval(top - random, seed=seed)
    if difference[0] > 0:
        return difference, "the network is above a guess"
    if difference[1] < 0:
        return difference, "the network is below a guess"
    return difference, "these held-out objects cannot tell the network from a guess"
