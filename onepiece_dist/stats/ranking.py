"""How well scores rank labelled candidates: average precision, the one definition training, evaluation and the
study share."""

from __future__ import annotations

import numpy as np

SEPARABLE = (0.1, 0.9)  # success rates of a guess (or of held-out candidates) outside this range rank nothing


def can_separate(rate: float) -> bool:
    """Whether candidates a guess picks (or that succeed) at ``rate`` can tell a ranking from a guess: near 0 or 1
    every chooser scores alike, whatever its ranking (SEPARABLE; the job's evaluation, the pick benchmark and the
    study by picks all ask this)."""
    low, high = SEPARABLE
    return low <= rate <= high


def average_precision(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the precision-recall curve (step interpolation, ties in the given order); 0 without a positive."""
    labels = np.asarray(labels, dtype=np.float64)
    positives = labels.sum()
    if positives == 0:
        return 0.0
    order = np.argsort(-np.asarray(scores), kind="stable")
    hits = labels[order]
    precision = np.cumsum(hits) / np.arange(1, len(hits) + 1)
    return float(np.sum(precision * hits) / positives)
