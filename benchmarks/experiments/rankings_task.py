"""One object of benchmarks/experiments/pick_rankings.py, run in the pinned simulation child (a module of its
own: run as ``__main__``, the script's functions would pickle as ``__main__.*``, which the child cannot find):
each ranking of the shipped network's scores ranks the view's candidates, its first choice is executed."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.grasps import dot3
from onepiece_dist.core.cloud.top_down import top_down_grasps
from onepiece_dist.core.frames import perturb_poses
from onepiece_dist.core.grasp_context import object_centre
from onepiece_dist.picks.object_picks import ObjectPicks, ViewPicks, process_scorer
from onepiece_dist.picks.views import Executions, index_of, observe_view, simulated_object
from onepiece_dist.plan.planner import Proposals, gravity, rank, with_context
from onepiece_dist.plan.scorer import GraspScorer, cut_crops
from onepiece_dist.specs.plan import PickSpec

RANKINGS = ("network", "jittered", "jittered_x2", "top_prior_0.05", "top_prior_0.1", "top_prior_0.2", "ensemble_2",
            "ensemble_4", "flipped", "ensemble_4_flipped", "with_top_down", "top_down_vetted", "view_input_base",
            "view_input", "view_input_base_seed1")
# networks of benchmarks/experiments/pick_view_input.py, each on its own: the camera's direction as an input or not
VIEW_INPUT = ("view_input_base", "view_input", "view_input_base_seed1")
WITH_TOP_DOWN = ("with_top_down", "top_down_vetted")  # choose among the view's pool and the top-down grasps
VETO = 0.5  # top_down_vetted: the first top-down grasp the network scores at least this
JITTERS, JITTERED = 8, 16  # copies per candidate; the network's best candidates scored again
CURVE = Path(__file__).resolve().parents[2] / "data" / "pick_curve"  # pick_curve's networks (not committed)
ENSEMBLES = {"ensemble_2": ("context_81152",),  # the shipped network's score averaged with these curve points'
             "ensemble_4": ("context_81152", "context_121858", "context_wide_40960")}


def ranked_scores(name: str, proposals: Proposals, scorer: GraspScorer, spec: PickSpec, scores: np.ndarray,
                  rng: np.random.Generator) -> np.ndarray:
    """(n,) the scores ranking ``name`` ranks the view's candidates by."""
    if name.startswith("top_prior_"):
        along = np.clip(dot3(proposals.poses[:, :3, 0], gravity(proposals.plane)), 0.0, 1.0)  # u: approach
        return np.round(scores + float(name.removeprefix("top_prior_")) * along, 6)
    if name.startswith("jittered"):
        return _jittered(proposals, scorer, spec, scores, rng, 2.0 if name.endswith("x2") else 1.0)
    if name in ENSEMBLES:
        members = [_member(point, spec).score(proposals.crops, spec.plan.batch_size) for point in ENSEMBLES[name]]
        return np.round(np.mean([scores, *members], axis=0), 6)
    if name == "flipped":
        return np.round((scores + _flipped_scores(proposals, scorer, spec, rng)) / 2, 6)
    if name == "ensemble_4_flipped":
        networks = [scorer, *(_member(point, spec) for point in ENSEMBLES["ensemble_4"])]
        turned = np.mean([_flipped_scores(proposals, n, spec, rng) for n in networks], axis=0)
        return np.round((ranked_scores("ensemble_4", proposals, scorer, spec, scores, rng) + turned) / 2, 6)
    return scores


def _scores_at(poses: np.ndarray, proposals: Proposals, scorer: GraspScorer, spec: PickSpec,
               rng: np.random.Generator) -> np.ndarray:
    """(k,) ``scorer``'s scores of grasps at other ``poses`` on the view's object points, cut and given their
    context as the planner does; 0 where a crop holds fewer than ``spec.plan.min_points`` points."""
    crops = with_context(cut_crops(proposals.object_points, poses, scorer.record, rng), poses,
                         object_centre(proposals.object_points), gravity(proposals.plane), scorer.gripper.closing_depth)
    return np.where(crops.counts >= spec.plan.min_points, scorer.score(crops, spec.plan.batch_size), 0.0)


def _flipped_scores(proposals: Proposals, scorer: GraspScorer, spec: PickSpec, rng: np.random.Generator) -> np.ndarray:
    """(n,) the scores of each candidate turned half a turn about its approach: the same grasp of a symmetric
    gripper, which the network sees mirrored across its closing and height axes."""
    turned = proposals.poses.copy()
    turned[:, :3, 1:3] *= -1.0
    return _scores_at(turned, proposals, scorer, spec, rng)


_MEMBERS: dict[str, GraspScorer] = {}


def _member(point: str, spec: PickSpec) -> GraspScorer:
    """The network of the learning curve's ``point`` (benchmarks/experiments/pick_curve.py writes it), loaded once."""
    if point not in _MEMBERS:
        path = CURVE / point / "best.pt"
        if not path.is_file():
            raise FileNotFoundError(f"{path}: run python -m benchmarks.experiments.pick_curve first")
        _MEMBERS[point] = GraspScorer(path, spec.gripper, device="cpu")
    return _MEMBERS[point]


def _jittered(proposals: Proposals, scorer: GraspScorer, spec: PickSpec, scores: np.ndarray,
              rng: np.random.Generator, scale: float) -> np.ndarray:
    best = np.argsort(-scores, kind="stable")[:JITTERED]
    copies = perturb_poses(np.repeat(proposals.poses[best], JITTERS, axis=0), rng, spec.sim.pose_noise * scale,
                           spec.sim.rotation_noise * scale)
    again = _scores_at(copies, proposals, scorer, spec, rng)
    mean = np.concatenate([scores[best, None], again.reshape(len(best), JITTERS)], axis=1).mean(axis=1)
    out = np.full(len(scores), -1.0)
    out[best] = mean
    return np.round(out, 6)


def _with_top_down(name: str, proposals: Proposals, scorer: GraspScorer, spec: PickSpec, scores: np.ndarray,
                   rng: np.random.Generator) -> tuple[str, int, np.ndarray]:
    """(pool, index, pose) chosen among the view's candidates and the three top-down grasps, each scored by the
    network: ``with_top_down`` the best score of both pools; ``top_down_vetted`` the first top-down grasp scored at
    least VETO, else the network's choice."""
    poses = top_down_grasps(proposals.object_points, gravity(proposals.plane), scorer.gripper)
    extra = _scores_at(poses, proposals, scorer, spec, rng)
    best = int(np.argmax(scores))
    if name == "top_down_vetted":
        vetted = np.flatnonzero(extra >= VETO)
        return ("top_down", int(vetted[0]), poses[vetted[0]]) if len(vetted) else ("view", best, proposals.poses[best])
    if len(extra) and extra.max() > scores[best]:
        return "top_down", int(np.argmax(extra)), poses[int(np.argmax(extra))]
    return "view", best, proposals.poses[best]


def _view_input(name: str, proposals: Proposals, spec: PickSpec, eye: np.ndarray) -> tuple[str, int, np.ndarray]:
    """(pool, index, pose): the best of the view's candidates by the network ``name`` (VIEW_INPUT), which reads the
    camera's direction where its context has room for it."""
    network = _member(name, spec)
    crops = proposals.crops
    if network.model.context == 9:
        crops = with_context(crops, proposals.poses, object_centre(proposals.object_points),
                             gravity(proposals.plane), network.gripper.closing_depth, eye)
    best = int(np.argmax(network.score(crops, spec.plan.batch_size)))
    return "view", best, proposals.poses[best]


def _choice(name: str, proposals: Proposals, scorer: GraspScorer, spec: PickSpec, scores: np.ndarray,
            rng: np.random.Generator, eye: np.ndarray) -> tuple[str, int, np.ndarray]:
    """(pool, index, pose) of ranking ``name``'s first choice on the view."""
    if name in VIEW_INPUT:
        return _view_input(name, proposals, spec, eye)
    if name in WITH_TOP_DOWN:
        return _with_top_down(name, proposals, scorer, spec, scores, rng)
    best = rank(proposals, ranked_scores(name, proposals, scorer, spec, scores, rng), scorer.record, spec.plan,
                keep=1)[0]
    return "view", index_of(proposals.poses, best.pose), best.pose


def rank_object(spec: PickSpec, ref, index: int, rankings: tuple[str, ...] = RANKINGS) -> ObjectPicks:
    """Every view of one object: each of ``rankings``' first choice executed."""
    from onepiece_dist.errors import MeshRejected

    start, scorer = time.perf_counter(), process_scorer(spec)
    try:
        world, loaded = simulated_object(spec, scorer.record, ref)
    except MeshRejected as err:
        return ObjectPicks(index, ref.name, "rejected", reason=err.reason)
    views = tuple(_view(spec, scorer, world, loaded.mesh, view, rankings) for view in range(spec.views))
    return ObjectPicks(index, ref.name, "ok", views, seconds=time.perf_counter() - start)


def _view(spec: PickSpec, scorer: GraspScorer, world, mesh, view: int, rankings: tuple[str, ...]) -> ViewPicks:
    seen = observe_view(spec, scorer.record, world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return ViewPicks(view, seen.distance, seen.elevation_deg, len(seen.cloud), 0, {r: () for r in rankings},
                         {r: () for r in rankings})
    executions = Executions(spec, world, mesh, seen.resting, view)
    scores = scorer.score(proposals.crops, spec.plan.batch_size)
    attempts, failures = {}, {}
    for name in rankings:
        rng = np.random.default_rng([int(mesh.content_id[:16], 16), spec.seed, view, 7, RANKINGS.index(name)])
        outcome = executions.run(*_choice(name, proposals, scorer, spec, scores, rng, seen.eye))
        attempts[name], failures[name] = (outcome.success,), (outcome.failure,)
    return ViewPicks(view, seen.distance, seen.elevation_deg, len(seen.cloud), len(proposals.poses), attempts,
                     failures)
