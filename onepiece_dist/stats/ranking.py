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


def per_group_success(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(g,) the success of the best-scored candidate of each of the g ``groups`` (objects, or a view's candidates;
    in sorted order, the first of equal scores) and (g,) a random candidate's expected one."""
    found = np.unique(groups)
    top = [labels[groups == g][np.argmax(scores[groups == g])] for g in found]
    random = [labels[groups == g].mean() for g in found]
    return np.asarray(top, np.float64), np.asarray(random, np.float64)
