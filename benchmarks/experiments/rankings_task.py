"""One object of benchmarks/experiments/pick_rankings.py, run in the pinned simulation child (a module of its
own: run as ``__main__``, the script's functions would pickle as ``__main__.*``, which the child cannot find):
each ranking of the shipped network's scores ranks the view's candidates, its first choice is executed."""

from __future__ import annotations

import time

import numpy as np

from onepiece_dist.core.cloud.grasps import dot3
from onepiece_dist.core.frames import perturb_poses
from onepiece_dist.picks.object_picks import ObjectPicks, ViewPicks, process_scorer
from onepiece_dist.picks.views import Executions, index_of, observe_view, simulated_object
from onepiece_dist.plan.planner import Proposals, gravity, rank, with_context
from onepiece_dist.plan.scorer import GraspScorer, cut_crops
from onepiece_dist.specs.plan import PickSpec

RANKINGS = ("network", "jittered", "jittered_x2", "top_prior_0.05", "top_prior_0.1", "top_prior_0.2")
JITTERS, JITTERED = 8, 16  # copies per candidate; the network's best candidates scored again


def ranked_scores(name: str, proposals: Proposals, scorer: GraspScorer, spec: PickSpec, scores: np.ndarray,
                  rng: np.random.Generator) -> np.ndarray:
    """(n,) the scores ranking ``name`` ranks the view's candidates by."""
    if name.startswith("top_prior_"):
        along = np.clip(dot3(proposals.poses[:, :3, 0], gravity(proposals.plane)), 0.0, 1.0)  # u: approach
        return np.round(scores + float(name.removeprefix("top_prior_")) * along, 6)
    if name.startswith("jittered"):
        return _jittered(proposals, scorer, spec, scores, rng, 2.0 if name.endswith("x2") else 1.0)
    return scores


def _jittered(proposals: Proposals, scorer: GraspScorer, spec: PickSpec, scores: np.ndarray,
              rng: np.random.Generator, scale: float) -> np.ndarray:
    best = np.argsort(-scores, kind="stable")[:JITTERED]
    copies = perturb_poses(np.repeat(proposals.poses[best], JITTERS, axis=0), rng, spec.sim.pose_noise * scale,
                           spec.sim.rotation_noise * scale)
    crops = cut_crops(proposals.object_points, copies, scorer.record, rng)
    crops = with_context(crops, copies, proposals.object_points, gravity(proposals.plane),
                         scorer.gripper.closing_depth)
    again = np.where(crops.counts >= spec.plan.min_points, scorer.score(crops, spec.plan.batch_size), 0.0)
    mean = np.concatenate([scores[best, None], again.reshape(len(best), JITTERS)], axis=1).mean(axis=1)
    out = np.full(len(scores), -1.0)
    out[best] = mean
    return np.round(out, 6)


def rank_object(spec: PickSpec, ref, index: int) -> ObjectPicks:
    """Every view of one object: each ranking's first choice executed."""
    from onepiece_dist.errors import MeshRejected

    start, scorer = time.perf_counter(), process_scorer(spec)
    try:
        world, loaded = simulated_object(spec, scorer.record, ref)
    except MeshRejected as err:
        return ObjectPicks(index, ref.name, "rejected", reason=err.reason)
    views = tuple(_view(spec, scorer, world, loaded.mesh, view) for view in range(spec.views))
    return ObjectPicks(index, ref.name, "ok", views, seconds=time.perf_counter() - start)


def _view(spec: PickSpec, scorer: GraspScorer, world, mesh, view: int) -> ViewPicks:
    seen = observe_view(spec, scorer.record, world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return ViewPicks(view, seen.distance, seen.elevation_deg, len(seen.cloud), 0, {r: () for r in RANKINGS},
                         {r: () for r in RANKINGS})
    executions = Executions(spec, world, mesh, seen.resting, view)
    scores = scorer.score(proposals.crops, spec.plan.batch_size)
    attempts, failures = {}, {}
    for k, name in enumerate(RANKINGS):
        rng = np.random.default_rng([int(mesh.content_id[:16], 16), spec.seed, view, 7, k])
        best = rank(proposals, ranked_scores(name, proposals, scorer, spec, scores, rng), scorer.record, spec.plan,
                    keep=1)
        outcome = executions.run("view", index_of(proposals.poses, best[0].pose), best[0].pose)
        attempts[name], failures[name] = (outcome.success,), (outcome.failure,)
    return ViewPicks(view, seen.distance, seen.elevation_deg, len(seen.cloud), len(proposals.poses), attempts,
                     failures)
