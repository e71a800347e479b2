"""Scores steadied over fresh draws of each crop's points (issue 55). A crop holds a seeded random subset of the
observed points inside the closing region (``points_per_grasp`` of them), so its score moves with the draw: two
draws of the same grasp on the same view can rank it apart from its neighbours. The best-scored candidates are
scored again on ``score_draws - 1`` further draws, each from its own seeded stream, and ranked by the mean; the rest
keep their one score (they lie below the rescored ones' first draw, where the first attempts are chosen)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from onepiece_dist.plan.scorer import Crops, GraspScorer
from onepiece_dist.specs.plan import PlanSpec

REDRAWN = 32  # the best-scored candidates drawn again: the first attempts and the check's come from them
REDRAW_STREAM = 6161  # the stream of the further draws, apart from every other stream of a view


def redrawn_scores(crops: Crops, poses: np.ndarray, scorer: GraspScorer, spec: PlanSpec,
                   recut: Callable[[np.ndarray, np.random.Generator], Crops]) -> np.ndarray:
    """(n,) ``scorer``'s scores of ``crops`` (of ``poses``, (n, 4, 4)); with ``spec.score_draws`` k > 1, the
    REDRAWN best of them the mean of k scores, each further one of the crops ``recut(poses, rng)`` cuts again from a
    fresh draw of the view's points (every other input the same: planner.planned_crops)."""
    scores = scorer.score(crops, spec.batch_size)
    if spec.score_draws == 1 or len(scores) == 0:
        return scores
    best = np.argsort(-scores, kind="stable")[:REDRAWN]
    total = scores[best].copy()
    for draw in range(1, spec.score_draws):
        total += scorer.score(recut(poses[best], np.random.default_rng([spec.seed, REDRAW_STREAM, draw])),
                              spec.batch_size)
    out = scores.copy()
    out[best] = total / spec.score_draws
    return out
