"""One object of the pick benchmark (docs/picks.md), run by a worker: for each seeded view (picks.views), each
chooser's ranked grasps executed one after another (up to ``attempts``), every execution by the label protocol.

Choosers: the network on the view (the product); a random collision-free candidate; the analytic antipodal score
on the view's cloud; the top-down grasp a user tries first (core.top_down); the network, and a random choice,
among candidates sampled on the full mesh (the full-mesh figure apart: the pool against the ranking); and the
oracle, which executes every candidate of the view and so says how often the pool holds a grasp that picks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.grasps import SupportPlane, above_plane, antipodal_scores, cloud_normals
from onepiece_dist.core.cloud.top_down import top_down_grasps
from onepiece_dist.core.frames import compose_poses, transform_points
from onepiece_dist.core.grasp_context import WORLD_DOWN, object_centre
from onepiece_dist.core.mesh import sample_surface
from onepiece_dist.core.sampling import sample_candidates
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef
from onepiece_dist.picks.shape_check import view_check
from onepiece_dist.picks.views import Executions, PickView, index_of, observe_view, simulated_object
from onepiece_dist.plan.drawing import draw_plan
from onepiece_dist.plan.observation import Observation
from onepiece_dist.plan.planner import (
    PlanCounts,
    PlannedGrasp,
    Proposals,
    Seen,
    check_ranked,
    checked_count,
    gravity,
    rank,
    scores_of,
    with_context,
)
from onepiece_dist.plan.scorer import GraspScorer, cut_crops
from onepiece_dist.specs.plan import PickSpec


@dataclass(frozen=True)
class ViewPicks:
    """One view of one object: the camera's distance (m) and elevation (degrees), the observed points, the
    planner's candidates, and per method the outcome of each attempt in rank order (True: picked) with the
    failure reasons ('' for a pick); with the oracle, how many of the view's candidates it executed and how many
    of those picked."""

    view: int
    distance: float
    elevation_deg: float
    points: int
    candidates: int
    attempts: dict[str, tuple[bool, ...]]
    failures: dict[str, tuple[str, ...]]
    pool_executed: int = 0
    pool_picked: int = 0

    def first(self, method: str) -> bool:
        return bool(self.attempts[method][:1] == (True,))

    def within(self, method: str, k: int) -> bool:
        return any(self.attempts[method][:k])


@dataclass(frozen=True)
class ObjectPicks:
    """Every view of one object; ``status`` 'ok', or 'rejected' with ``reason`` (the object could not be loaded)."""

    index: int
    name: str
    status: str
    views: tuple[ViewPicks, ...] = ()
    reason: str = ""
    seconds: float = 0.0
    node: str = ""


_SCORERS: dict[tuple[str, str, bool], GraspScorer] = {}
# m: a full-mesh candidate is sampled at a fixed depth and cannot be pushed back as the view's hands are
# (PlanSpec.table_clearance); it is dropped only where its open gripper would meet the table
MESH_TABLE_CLEARANCE = 0.002


def process_scorer(spec: PickSpec) -> GraspScorer:
    """This process's scorer of ``spec.checkpoint`` (loaded once), on the CPU with one thread: each worker holds
    one core."""
    import torch

    torch.set_num_threads(1)  # one core per worker; and the same sums, so the same ranking, in every process
    key = (spec.checkpoint, spec.gripper.model_dump_json() if spec.gripper else "", spec.carried)
    if key not in _SCORERS:
        _SCORERS[key] = GraspScorer(spec.checkpoint, spec.gripper, "cpu", spec.carried)
    return _SCORERS[key]


def pick_object(spec: PickSpec, ref: ObjectRef, index: int) -> ObjectPicks:
    """Every view of one object; a bad object becomes a rejected result, never an exception."""
    start = time.perf_counter()
    scorer = process_scorer(spec)
    try:
        world, loaded = simulated_object(spec, scorer.record, ref)
    except MeshRejected as err:
        return ObjectPicks(index, ref.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    views = tuple(_pick_view(spec, scorer, world, loaded.mesh, view) for view in spec.view_indices)
    return ObjectPicks(index, ref.name, "ok", views, seconds=time.perf_counter() - start)


@dataclass(frozen=True)
class Choice:
    """A chooser's ranked grasps: the pool they come from and, per grasp, its index there and its pose."""

    pool: str
    indices: tuple[int, ...]
    poses: np.ndarray
    ranked: tuple[PlannedGrasp, ...] = ()  # the ranked grasps, where a ranking made them


def _pick_view(spec: PickSpec, scorer: GraspScorer, world, mesh, view: int) -> ViewPicks:
    seen = observe_view(spec, scorer.record, world, mesh, view)
    geometry = (seen.distance, seen.elevation_deg)
    empty = {m: () for m in spec.methods}
    if seen.proposals is None:
        return ViewPicks(view, *geometry, len(seen.cloud), 0, empty, empty)
    executions = Executions(spec, world, mesh, seen.resting, view)
    full_mesh = _full_mesh_proposals(spec, scorer, mesh, seen) if _needs_full_mesh(spec) else None
    return picked_view(spec, scorer, seen, executions, full_mesh, mesh.name)


def picked_view(spec: PickSpec, scorer: GraspScorer, seen: PickView, executions, full_mesh: Proposals | None,
                name: str) -> ViewPicks:
    """Each of ``spec.methods`` on one seen view: its grasps executed in rank order by ``executions`` (its
    ``run(pool, index, pose)``), the network's drawn for the first ``spec.pictures`` views as ``name``."""
    attempts, failures, pool = {}, {}, (0, 0)
    for method in spec.methods:
        if method == "oracle":
            outcomes, pool = _oracle(spec, seen.proposals, executions)
        else:
            choice = choose(method, spec, scorer, seen, full_mesh)
            outcomes = [executions.run(choice.pool, i, pose)
                        for i, pose in zip(choice.indices, choice.poses, strict=True)]
            if method == "network" and seen.view < spec.pictures:
                _draw(spec, scorer, name, seen, choice.ranked, outcomes)
        attempts[method] = tuple(o.success for o in outcomes)
        failures[method] = tuple(o.failure for o in outcomes)
    return ViewPicks(seen.view, seen.distance, seen.elevation_deg, len(seen.cloud), len(seen.proposals.poses),
                     attempts, failures, *pool)


def _needs_full_mesh(spec: PickSpec) -> bool:
    return any(m in spec.methods for m in ("network_full_mesh", "random_full_mesh"))


def _oracle(spec: PickSpec, proposals: Proposals, executions: Executions) -> tuple[list, tuple[int, int]]:
    """Every candidate of the view executed (at most ``spec.oracle_candidates``); the oracle's ranked grasps are
    those that picked, in candidate order, then the rest."""
    count = min(len(proposals.poses), spec.oracle_candidates)
    outcomes = [executions.run("view", i, proposals.poses[i]) for i in range(count)]
    ranked = sorted(outcomes, key=lambda o: not o.success)[: spec.attempts]
    return ranked, (count, sum(o.success for o in outcomes))


def choose(method: str, spec: PickSpec, scorer: GraspScorer, seen: PickView,
            full_mesh: Proposals | None) -> Choice:
    """The grasps ``method`` would try, best first (at most ``spec.attempts``); a random choice ranks a seeded
    permutation; top-down grasps the largest of the view's objects told apart (core.cloud.objects: all its object
    points where it holds one)."""
    proposals, rng = seen.proposals, seen.rng
    if method == "top_down":
        largest = Seen.of(proposals).separate()[0]
        poses = top_down_grasps(largest, gravity(proposals.plane), scorer.gripper)[: spec.attempts]
        return Choice("top_down", tuple(range(len(poses))), poses)
    if method in ("network_full_mesh", "random_full_mesh"):
        proposals, pool = full_mesh, "mesh"
        method = method.removesuffix("_full_mesh")
    else:
        pool = "view"
    if proposals is None or len(proposals.poses) == 0:
        return Choice(pool, (), np.zeros((0, 4, 4)))
    plan = spec.plan
    if method == "random":
        scores = rng.permutation(len(proposals.poses)).astype(np.float64)
        plan = plan.model_copy(update={"nms_distance": 0.0})
    elif method == "analytic":
        normals = cloud_normals(proposals.object_points, proposals.object_points, proposals.viewpoint)
        scores = antipodal_scores(proposals.object_points, normals, proposals.poses, scorer.gripper)
    else:
        scores = scores_of(proposals, scorer, plan)
    checking = method == "network" and pool == "view" and plan.check_first > 0
    ranked = rank(proposals, scores, scorer.record, plan, keep=max(spec.attempts, checked_count(plan) * checking))
    if checking:
        check = view_check(plan, spec.sim, np.random.default_rng(seen.check_seed))
        ranked = check_ranked(ranked, proposals, scores, scorer.record, plan, check)
    ranked = ranked[: spec.attempts]
    poses = np.array([g.pose for g in ranked]).reshape(-1, 4, 4)
    return Choice(pool, tuple(index_of(proposals.poses, p) for p in poses), poses, ranked)


def _full_mesh_proposals(spec: PickSpec, scorer: GraspScorer, mesh, seen: PickView) -> Proposals | None:
    """Candidates sampled on the complete mesh (the study's held-out setting), cropped from the complete surface,
    moved to where the object rests, those that would meet the table dropped."""
    gripper, rng = scorer.gripper, seen.rng
    surface, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
    found = sample_candidates(mesh, surface, normals, spec.mesh_candidates, gripper, spec.sampler, rng)
    poses = compose_poses(seen.resting[None], found.poses)
    table = SupportPlane(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, bool))
    poses = poses[above_plane(poses, gripper, table, MESH_TABLE_CLEARANCE)]
    world_surface = transform_points(surface, seen.resting)
    crops, keep = cut_crops(world_surface, poses, scorer.record, rng).holding(spec.plan.min_points)
    if not keep.any():
        return None
    crops = with_context(crops, poses[keep], object_centre(world_surface), WORLD_DOWN, gripper.closing_depth)
    counts = PlanCounts(found.tried, found.rejected_collision, len(found.poses) - len(poses), int(np.sum(~keep)),
                        int(np.sum(keep)))
    return Proposals(poses[keep], crops, world_surface, seen.proposals.plane, counts)


def _draw(spec: PickSpec, scorer: GraspScorer, name: str, seen: PickView, ranked: tuple[PlannedGrasp, ...],
          outcomes) -> None:
    """The view's cloud with the network's ranked grasps, for the benchmark's page."""
    import importlib.util

    if importlib.util.find_spec("matplotlib") is None:  # the plots extra: no pictures without it
        return
    proposals = seen.proposals
    result = ", ".join("picked" if o.success else o.failure for o in outcomes) or "no grasp"
    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name)
    picture = Path(spec.output) / "pictures" / f"{safe}-view{seen.view}.png"
    table = None if proposals.plane is None else seen.cloud[proposals.plane.inliers]
    observation = Observation(seen.cloud, seen.eye, f"{name} view {seen.view}")
    draw_plan(proposals.object_points, ranked, scorer.gripper, picture, observation.viewpoint,
              f"{name}, view {seen.view}: {result}", table)
