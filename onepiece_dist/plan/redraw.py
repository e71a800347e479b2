"""Scores steadied over fresh draws of each crop's points (issue 55). A crop holds a seeded random subset of the
observed points inside the closing region (``points_per_grasp`` of them), so its score moves with the draw: two
draws of the same grasp on the same view can rank it apart from its neighbours. The best-scored candidates are
scored again on ``score_draws - 1`` further draws, each from its own seeded stream, and ranked by the mean; the rest
keep their one score (they lie below the rescored ones' first draw, where the first attempts are chosen)."""

from __future__ import annotations

import numpy as np

from onepiece_dist.plan.planner import Proposals, Seen, planned_crops
from onepiece_dist.plan.scorer import GraspScorer
from onepiece_dist.specs.plan import PlanSpec

REDRAWN = 32  # the best-scored candidates drawn again: the first attempts and the check's come from them
REDRAW_STREAM = 6161  # the stream of the further draws, apart from every other stream of a view


def redrawn_scores(proposals: Proposals, scorer: GraspScorer, spec: PlanSpec) -> np.ndarray:
    """(n,) ``scorer``'s scores of ``proposals``' crops; with ``spec.score_draws`` k > 1, the REDRAWN best of them
    the mean of k scores, each of a crop cut again from a fresh draw of the view's points (every other input the
    same)."""
    scores = scorer.score(proposals.crops, spec.batch_size)
    if spec.score_draws == 1 or len(scores) == 0:
        return scores
    best = np.argsort(-scores, kind="stable")[:REDRAWN]
    seen, total = Seen.of(proposals), scores[best].copy()
    for draw in range(1, spec.score_draws):
        rng = np.random.default_rng([spec.seed, REDRAW_STREAM, draw])
        crops, _ = planned_crops(seen, proposals.poses[best], scorer.record, rng)
        total += scorer.score(crops, spec.batch_size)
    out = scores.copy()
    out[best] = total / spec.score_draws
    return out
