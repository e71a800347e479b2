"""A network's own best grasps drawn again (issue 55: where the ranking errs). Of the view's candidates a network
ranks first, the surest of its first three picks 4.9 points more often than its first on the household views and
8.9 on the unseen ones (benchmarks/experiments/pick_ranked_draws.py): a label drawn once says little about which of
a network's best grasps pick again, and random labels hold few of them. Here each training view's top-ranked
candidates (the planner's ranking: non-maximum suppression included) are executed ``draws`` times by the pick
protocol; each becomes a label row whose ``picks`` is the share of those draws that picked (draw 0 is the row's own
execution: its success, held trials and failure).

One object per task; an object's rows are a LabelledObject with the ``picks`` column, written as any pick labels
(store.pick_labels).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from onepiece_dist.objects import ObjectRef
from onepiece_dist.picks.pick_labels import cached_scorer, crop_record, label_rows, labelled_object
from onepiece_dist.picks.views import Executions, observe_view, ranked_indices
from onepiece_dist.specs.plan import PickLabelSpec
from onepiece_dist.store.pick_labels import LabelledObject


@dataclasses.dataclass(frozen=True)
class TopDraws:
    """Which rows to make: each view's ``top`` best-ranked candidates by ``checkpoint``, each drawn ``draws`` times,
    on the first ``views`` views of each object."""

    checkpoint: str
    top: int = 8
    draws: int = 4
    views: int = 8


def top_draws_object(spec: PickLabelSpec, ref: ObjectRef, index: int, wanted: TopDraws) -> LabelledObject:
    """One object's rows; a bad object becomes a rejected result, never an exception."""
    return labelled_object(spec, ref, index, functools.partial(_view, wanted=wanted), min(wanted.views, spec.views))


def _view(spec: PickLabelSpec, world, mesh, view: int, wanted: TopDraws) -> dict[str, np.ndarray] | None:
    seen = observe_view(spec, crop_record(spec), world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return None
    scorer = cached_scorer(wanted.checkpoint, spec.gripper)
    crops = proposals.crops
    scores = scorer.score(dataclasses.replace(crops, points=crops.points[:, : scorer.record.points_per_grasp]))
    chosen = np.array(ranked_indices(proposals, scores, scorer.record, spec.plan, wanted.top)[1], int)
    executions = Executions(spec, world, mesh, seen.resting, view)
    first = [executions.run("view", i, proposals.poses[i]) for i in chosen]  # every row's own label, then the rest
    picks = [np.mean(executions.picked("view", i, proposals.poses[i], wanted.draws)) for i in chosen]
    return {**label_rows(spec, proposals, chosen, first, view), "picks": np.array(picks, np.float32)}


__all__ = ["TopDraws", "top_draws_object"]
