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
    that two draws of one grasp agree; ceiling_ap, the best AP against one draw (leave-one-out)."""

    grasps: int
    draws: int
    positive_rate: float
    agreement: float
    ceiling_ap: float

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
    return LabelCeiling(n, r, float(draws.mean()), agreement, ceiling)
