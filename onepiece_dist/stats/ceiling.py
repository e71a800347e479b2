"""How far a label lets any predictor go (pure numpy): from repeated draws of the label per grasp (the same grasp
executed again with fresh perturbations), its self-agreement, its positive-rate floor and the best AP a predictor
could reach against one draw.

A predictor cannot beat knowing each grasp's success probability p; the best it can do against one draw is rank by
p. Here p is estimated for each draw from the grasp's other draws (leave one out), so the ceiling is not flattered
by the draw it is judged against: a deterministic label (every draw the same) reaches AP 1; a label that is pure
noise (draws independent of the grasp) stays at the floor. With few draws the estimate is conservative (3 draws of
uniform odds: 0.67, 12 draws: 0.79, against 0.84 for the odds themselves; tests/test_ceiling.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def threshold_ap(scores: np.ndarray, labels: np.ndarray) -> float:
    """Average precision over the distinct score thresholds: grasps with equal scores count together (a lookup
    gives every grasp of a key one score, and their order must not decide the figure). 0 without a positive."""
    labels = np.asarray(labels, dtype=bool)
    if not labels.any():
        return 0.0
    order = np.argsort(-np.asarray(scores, dtype=np.float64), kind="stable")
    ranked, hits = np.asarray(scores)[order], np.cumsum(labels[order])
    ends = np.r_[np.flatnonzero(ranked[1:] != ranked[:-1]), len(ranked) - 1]  # last grasp of each tie group
    precision, recall = hits[ends] / (ends + 1), hits[ends] / hits[-1]
    return float(np.sum(np.diff(np.r_[0.0, recall]) * precision))


@dataclass(frozen=True)
class LabelCeiling:
    """grasps and draws per grasp; positive_rate (the floor: the AP of a constant predictor); agreement, the chance
    that two draws of one grasp agree; ceiling_ap, the best AP against one draw as the draws alone show it
    (leave-one-out: a lower bound with few draws); fitted_ap, the best AP with the grasps' odds spread as the draws
    say (a beta distribution of the odds fitted to the draws' counts; see fitted_ceiling)."""

    grasps: int
    draws: int
    positive_rate: float
    agreement: float
    ceiling_ap: float
    fitted_ap: float = float("nan")

    def share_of_way(self, ap: float) -> float | None:
        """Where ``ap`` stands from the floor (0) to the ceiling (1); None when the ceiling is the floor."""
        span = self.ceiling_ap - self.positive_rate
        return None if span <= 1e-12 else (ap - self.positive_rate) / span


def label_ceiling(draws: np.ndarray) -> LabelCeiling:
    """The ceiling of a label from ``draws`` (n, r) bool, r >= 2 independent draws of each of n grasps' label."""
    draws = np.asarray(draws, dtype=bool)
    n, r = draws.shape
    if r < 2 or n == 0:
        raise ValueError(f"label_ceiling needs at least 2 draws of at least one grasp, got {draws.shape}")
    wins = draws.sum(axis=1).astype(np.float64)
    agreement = float(np.mean((wins * (wins - 1) + (r - wins) * (r - wins - 1)) / (r * (r - 1))))
    others = (wins[:, None] - draws) / (r - 1)  # each draw's grasp, scored by its other draws
    ceiling = float(np.mean([threshold_ap(others[:, j], draws[:, j]) for j in range(r)]))
    return LabelCeiling(n, r, float(draws.mean()), agreement, ceiling, fitted_ceiling(draws))


def fitted_ceiling(draws: np.ndarray, samples: int = 200_000, seed: int = 0) -> float:
    """The AP of ranking by the true odds against one draw, with the odds of the grasps spread as a beta
    distribution whose mean and variance are those the draws' counts give (method of moments: the variance of
    the per-grasp success shares, less what r draws add by themselves). A deterministic label (odds 0 or 1) gives
    1; draws independent of the grasp (no spread of odds) give the floor. Seeded: the same draws give the same
    figure."""
    draws = np.asarray(draws, dtype=bool)
    n, mean = len(draws), float(draws.mean())
    if mean in (0.0, 1.0):
        return mean
    seen, by_chance, spread = _share_variance(draws, mean)
    if seen - by_chance <= seen * np.sqrt(2 / max(n - 1, 1)):  # within a standard error of none
        return mean
    if spread >= mean * (1 - mean) * (1 - 1e-9):
        return 1.0
    total = mean * (1 - mean) / spread - 1  # a + b of the beta
    rng = np.random.default_rng([seed, 51])
    odds = rng.beta(mean * total, (1 - mean) * total, samples)
    return threshold_ap(odds, rng.random(samples) < odds)


def _share_variance(draws: np.ndarray, mean: float) -> tuple[float, float, float]:
    """The variance of the grasps' success shares, what r draws add to it by themselves, and what is left: the
    variance of the odds themselves (the method of moments that fitted_ceiling and moment_range share)."""
    r = draws.shape[1]
    seen, by_chance = float(draws.mean(axis=1).var(ddof=1)), mean * (1 - mean) / r
    return seen, by_chance, (seen - by_chance) / (1 - 1 / r)


def ap_against_draws(scores: np.ndarray, draws: np.ndarray) -> float:
    """The mean AP of ``scores`` (n,) against each of the draws (n, r) of the same grasps' label."""
    return float(np.mean([threshold_ap(scores, draws[:, j]) for j in range(draws.shape[1])]))


# the odds a grasp may have, where the measured ceiling places the grasps (1% apart)
ODDS_GRID = np.linspace(0.0, 1.0, 101)
MEASURED_DRAWS = 8  # draws per grasp from which the ceiling is measured, not only bounded and fitted
ITERATIONS = 200  # of expectation-maximisation from even weights: stopped early, it keeps the odds smooth


@dataclass(frozen=True)
class MeasuredCeiling:
    """The ceiling measured from many draws per grasp (issue 58): ``ap``, the AP of ranking by the odds against
    one draw with the grasps' odds distributed as their draws show it (the distribution of odds that makes the
    draws' counts most likely, on ODDS_GRID), and its 95% interval (``low``, ``high``) from resampling the grasps;
    ``moment_range``, the AP of every two-point odds distribution with the draws' mean and spread of odds (what
    two moments alone allow: a cross-check, not the figure)."""

    grasps: int
    draws: int
    positive_rate: float
    ap: float
    low: float
    high: float
    moment_range: tuple[float, float]


def measured_ceiling(draws: np.ndarray, resamples: int = 400, seed: int = 0) -> MeasuredCeiling:
    """The ceiling of a label from ``draws`` (n, r) bool: r >= 8 draws of each of n grasps (16 draws on 128-256
    grasps measure it to a few points). Seeded: the same draws give the same figures."""
    draws = np.asarray(draws, dtype=bool)
    n, r = draws.shape
    if r < MEASURED_DRAWS or n == 0:
        raise ValueError(f"measured_ceiling needs at least 8 draws of at least one grasp, got {draws.shape}")
    counts = np.bincount(draws.sum(axis=1), minlength=r + 1)
    rng = np.random.default_rng([seed, 58])
    again = [odds_ap(ODDS_GRID, odds_distribution(rng.multinomial(n, counts / n), r)) for _ in range(resamples)]
    ap = odds_ap(ODDS_GRID, odds_distribution(counts, r))
    low, high = 2 * ap - np.percentile(again, [97.5, 2.5])  # the basic bootstrap: the resamples' bias turned back
    return MeasuredCeiling(n, r, float(draws.mean()), ap, float(low), float(high), moment_range(draws))


def odds_distribution(counts: np.ndarray, draws: int, iterations: int = ITERATIONS) -> np.ndarray:
    """The weights on ODDS_GRID of the odds distribution that makes ``counts`` (r + 1,) (how many grasps held k of
    ``draws`` draws) most likely (the nonparametric maximum likelihood, by expectation-maximisation)."""
    k = np.arange(draws + 1)[:, None]
    like = ODDS_GRID ** k * (1 - ODDS_GRID) ** (draws - k)  # numpy's 0 ** 0 is 1: the grid's ends
    weights = np.full(len(ODDS_GRID), 1.0 / len(ODDS_GRID))
    share = np.asarray(counts, dtype=np.float64) / max(float(np.sum(counts)), 1.0)
    for _ in range(iterations):
        mixed = like @ weights
        weights = weights * (like.T @ np.where(mixed > 0, share / np.where(mixed > 0, mixed, 1.0), 0.0))
    return weights / weights.sum()


def odds_ap(odds: np.ndarray, weights: np.ndarray) -> float:
    """The AP of ranking grasps by their ``odds`` against one draw, for grasps whose odds take the values ``odds``
    with ``weights`` (many grasps: each group of equal odds counts together, as threshold_ap counts ties)."""
    order = np.argsort(-np.asarray(odds, dtype=np.float64), kind="stable")
    p, w = np.asarray(odds, dtype=np.float64)[order], np.asarray(weights, dtype=np.float64)[order]
    keep = w > 0
    p, w = p[keep], w[keep]
    positives = np.cumsum(w * p)
    if positives[-1] <= 0:
        return 0.0
    return float(np.sum(w * p / positives[-1] * positives / np.cumsum(w)))


def moment_range(draws: np.ndarray, steps: int = 200) -> tuple[float, float]:
    """The lowest and highest AP of the two-point odds distributions whose mean and variance are those the draws'
    counts give (fitted_ceiling's moments): two moments do not fix the ceiling, and this is by how much."""
    draws = np.asarray(draws, dtype=bool)
    n, mean = len(draws), float(draws.mean())
    spread = _share_variance(draws, mean)[2] if n > 1 else 0.0
    if mean in (0.0, 1.0) or spread <= 0:
        return (mean, mean)
    spread = min(spread, mean * (1 - mean) * (1 - 1e-9))
    aps = []
    for low in np.linspace(0.0, mean - spread / (1 - mean), steps):  # the lower odds; the higher one then follows
        high = mean + spread / (mean - low)
        weight = (mean - low) / (high - low)
        aps.append(odds_ap(np.array([low, high]), np.array([1 - weight, weight])))
    return (float(min(aps)), float(max(aps)))
