"""A network's own best grasps drawn again (issue 55: where the ranking errs). Of the view's candidates a network
ranks first, about one in seven picks at fewer than half of fresh executions, while candidates beside them pick at
every one: a label drawn once cannot tell the two apart, and random labels hold few of either. Here each training
view's top-ranked candidates (the planner's ranking: non-maximum suppression included) are executed ``draws``
times by the pick protocol; each becomes a label row whose ``picks`` is the share of those draws that picked
(draw 0 is the row's own execution: its success, held trials and failure).

One object per task; an object's rows are a LabelledObject with the ``picks`` column, written as any pick labels
(store.pick_labels).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from onepiece_dist.core.cloud.outline import outline
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef
from onepiece_dist.picks.pick_labels import cached_scorer, crop_record, labelling_world
from onepiece_dist.picks.views import Executions, index_of, observe_view
from onepiece_dist.plan.planner import rank
from onepiece_dist.specs.plan import PickLabelSpec
from onepiece_dist.store.pick_labels import FAILURE_CODES, LabelledObject


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
    start = time.perf_counter()
    try:
        world, loaded = labelling_world(spec, ref)
    except MeshRejected as err:
        return LabelledObject.rejected(index, ref.name, err.reason)
    parts = [_view(spec, world, loaded.mesh, view, wanted) for view in range(min(wanted.views, spec.views))]
    parts = [p for p in parts if p is not None]
    if not parts:
        return LabelledObject.rejected(index, ref.name, "no view held a candidate", time.perf_counter() - start)
    joined = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return LabelledObject(index, ref.name, "ok", seconds=time.perf_counter() - start, **joined)


def _view(spec: PickLabelSpec, world, mesh, view: int, wanted: TopDraws) -> dict[str, np.ndarray] | None:
    seen = observe_view(spec, crop_record(spec), world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return None
    scorer = cached_scorer(wanted.checkpoint, spec.gripper)
    crops = proposals.crops
    scores = scorer.score(dataclasses.replace(crops, points=crops.points[:, : scorer.record.points_per_grasp]))
    ranked = rank(proposals, scores, scorer.record, spec.plan, keep=wanted.top)
    chosen = np.array([index_of(proposals.poses, g.pose) for g in ranked], int)
    executions = Executions(spec, world, mesh, seen.resting, view)
    first = [executions.run("view", i, proposals.poses[i]) for i in chosen]
    again = [[executions.again("view", i, proposals.poses[i], d).success for d in range(1, wanted.draws)]
             for i in chosen]
    picks = [(o.success + sum(a)) / wanted.draws for o, a in zip(first, again, strict=True)]
    return {"points": crops.points[chosen].astype(np.float16), "context": crops.context[chosen].astype(np.float32),
            "space": crops.space[chosen].astype(np.float16),
            "outline": outline(proposals.object_points, proposals.poses[chosen],
                               spec.gripper.closing_depth).astype(np.float16),
            "success": np.array([o.success for o in first], bool),
            "held": np.array([o.held for o in first], np.int8),
            "failure": np.array([FAILURE_CODES.index(o.failure) for o in first], np.int8),
            "view": np.full(len(chosen), view, np.int16), "pose": proposals.poses[chosen].astype(np.float64),
            "picks": np.array(picks, np.float32)}


__all__ = ["TopDraws", "top_draws_object"]
