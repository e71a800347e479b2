"""One object of the pick benchmark (docs/picks.md), run by a worker: for each seeded view, the object settled on
the table, the camera's cloud, the planner's candidates, and each method's ranked grasps executed one after
another (up to ``attempts``), every execution by the label protocol.

Methods: the network on the view (the product), a random collision-free candidate, the analytic antipodal score
on the view's cloud, and the network ranking candidates sampled on the full mesh (what held-out top-1 measures).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud_grasps import SupportPlane, above_plane, antipodal_scores, cloud_normals
from onepiece_dist.core.frames import compose_poses, transform_points
from onepiece_dist.core.mesh import sample_surface
from onepiece_dist.core.sampling import object_rng, sample_candidates
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef, load_object
from onepiece_dist.plan.drawing import draw_plan
from onepiece_dist.plan.observation import Observation
from onepiece_dist.plan.planner import PlannedGrasp, Proposals, propose, rank
from onepiece_dist.plan.scorer import GraspScorer, cut_crops
from onepiece_dist.plan_spec import PickSpec
from onepiece_dist.sim.collision import load_simulated


@dataclass(frozen=True)
class ViewPicks:
    """One view of one object: the camera's distance (m) and elevation (degrees), the observed points, the
    planner's candidates, and per method the outcome of each attempt in rank order (True: picked) with the
    failure reasons ('' for a pick)."""

    view: int
    distance: float
    elevation_deg: float
    points: int
    candidates: int
    attempts: dict[str, tuple[bool, ...]]
    failures: dict[str, tuple[str, ...]]

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


_SCORERS: dict[tuple[str, str], GraspScorer] = {}


def process_scorer(spec: PickSpec) -> GraspScorer:
    """This process's scorer of ``spec.checkpoint`` (loaded once), on the CPU with one thread: each worker holds
    one core."""
    import torch

    torch.set_num_threads(1)  # one core per worker; and the same sums, so the same ranking, in every process
    key = (spec.checkpoint, spec.gripper.model_dump_json() if spec.gripper else "")
    if key not in _SCORERS:
        _SCORERS[key] = GraspScorer(spec.checkpoint, spec.gripper, device="cpu")
    return _SCORERS[key]


def pick_object(spec: PickSpec, ref: ObjectRef, index: int) -> ObjectPicks:
    """Every view of one object; a bad object becomes a rejected result, never an exception."""
    from onepiece_dist.sim.pick import pick_world

    start = time.perf_counter()
    scorer = process_scorer(spec)
    try:
        loaded = load_object(ref, spec.object_job(scorer.gripper, scorer.record.voxel))
    except MeshRejected as err:
        return ObjectPicks(index, ref.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    world = pick_world(scorer.gripper)
    load_simulated(world, loaded, Path(spec.output) / "collision", spec.sim.collision, spec.sim.density)
    views = tuple(_pick_view(spec, scorer, world, loaded.mesh, view) for view in range(spec.views))
    return ObjectPicks(index, ref.name, "ok", views, seconds=time.perf_counter() - start)


def _pick_view(spec: PickSpec, scorer: GraspScorer, world, mesh, view: int) -> ViewPicks:
    from onepiece_dist.sim.pick import execute_pick, observe, pick_camera
    from onepiece_dist.sim.trials import LabelNoise

    rng = object_rng(mesh.content_id, spec.seed, stream=100 + view)
    resting = world.settle(rng, mesh.vertices)
    cam = spec.camera
    drawn = pick_camera(resting[:3, 3], rng, cam.distance, cam.elevation_deg, cam.image_size, cam.fov_deg)
    cloud = observe(mesh.vertices, mesh.faces, resting, drawn.camera, rng, cam.depth_noise)
    eye, geometry = drawn.camera.pose[:3, 3], (drawn.distance, drawn.elevation_deg)
    if len(cloud) < 50:
        return ViewPicks(view, *geometry, len(cloud), 0, {m: () for m in spec.methods}, {m: () for m in spec.methods})
    observation = Observation(cloud, eye, f"{mesh.name} view {view}")
    proposals = propose(observation, scorer.record, spec.plan, rng)
    noise = LabelNoise.from_spec(spec.sim)
    attempts, failures = {}, {}
    for method in spec.methods:
        ranked = _ranked(method, spec, scorer, proposals, mesh, resting, rng)
        outcomes = [execute_pick(world, grasp.pose, resting, noise, rng) for grasp in ranked[: spec.attempts]]
        attempts[method] = tuple(o.success for o in outcomes)
        failures[method] = tuple(o.failure for o in outcomes)
        if method == "network" and view < spec.pictures:
            _draw(spec, scorer, observation, proposals, ranked, mesh.name, view, outcomes)
    return ViewPicks(view, *geometry, len(cloud), len(proposals.poses), attempts, failures)


def _ranked(method: str, spec: PickSpec, scorer: GraspScorer, proposals: Proposals, mesh, resting: np.ndarray,
            rng: np.random.Generator) -> tuple[PlannedGrasp, ...]:
    """The grasps ``method`` would try, best first (at most ``spec.attempts``); a random choice ranks a seeded
    permutation."""
    if method == "network_full_mesh":
        return _full_mesh_choice(spec, scorer, mesh, resting, proposals.plane, rng)
    if len(proposals.poses) == 0:
        return ()
    if method == "random":
        scores = rng.permutation(len(proposals.poses)).astype(np.float64)
        return rank(proposals, scores, scorer.record, spec.plan.model_copy(update={"nms_distance": 0.0}),
                    keep=spec.attempts)
    if method == "analytic":
        normals = cloud_normals(proposals.object_points, proposals.object_points, proposals.viewpoint)
        scores = antipodal_scores(proposals.object_points, normals, proposals.poses, scorer.gripper)
    else:
        scores = scorer.score(proposals.crops, spec.plan.batch_size)
    return rank(proposals, scores, scorer.record, spec.plan, keep=spec.attempts)


def _full_mesh_choice(spec: PickSpec, scorer: GraspScorer, mesh, resting: np.ndarray, plane: SupportPlane | None,
                      rng: np.random.Generator) -> tuple[PlannedGrasp, ...]:
    """The network ranking candidates sampled on the complete mesh (the study's held-out setting), cropped from
    the complete surface, moved to where the object rests, those that would meet the table dropped."""
    gripper = scorer.gripper
    surface, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
    found = sample_candidates(mesh, surface, normals, spec.mesh_candidates, gripper, spec.sampler, rng)
    poses = compose_poses(resting[None], found.poses)
    table = SupportPlane(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, bool))
    poses = poses[above_plane(poses, gripper, table)]
    world_surface = transform_points(surface, resting)
    crops, keep = cut_crops(world_surface, poses, scorer.record, rng).holding(spec.plan.min_points)
    if not keep.any():
        return ()
    proposals = Proposals(poses[keep], crops, world_surface, plane, {})
    scores = scorer.score(crops, spec.plan.batch_size)
    return rank(proposals, scores, scorer.record, spec.plan, keep=spec.attempts)


def _draw(spec: PickSpec, scorer: GraspScorer, observation: Observation, proposals: Proposals, ranked, name: str,
          view: int, outcomes) -> None:
    """The view's cloud with the network's ranked grasps, for the benchmark's page."""
    import importlib.util

    if importlib.util.find_spec("matplotlib") is None:  # the plots extra: no pictures without it
        return

    result = ", ".join("picked" if o.success else o.failure for o in outcomes) or "no grasp"
    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name)
    picture = Path(spec.output) / "pictures" / f"{safe}-view{view}.png"
    table = None if proposals.plane is None else observation.points[proposals.plane.inliers]
    draw_plan(proposals.object_points, ranked, scorer.gripper, picture, observation.viewpoint,
              f"{name}, view {view}: {result}", table)
