"""Labels made where the network is used (issue 55, docs/picks.md): each training object settled on the table and
seen as the pick benchmark sees it (picks.views), a seeded subset of the planner's candidates on each view executed
by the pick protocol; each label keeps the candidate's crop, its context, the hand's swept space as the camera
saw it, the object's outline seen from the grasp, whether it picked and why not.

One task per object, in this process or on the job's Ray worker pool; the labels go to ``pick_labels.zarr``
(store.pick_labels) in object order, whatever order the workers finish in.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.outline import OUTLINE_POINTS, outline
from onepiece_dist.errors import MeshRejected, SpecError, StoreError
from onepiece_dist.objects import ObjectRef, load_object, resolve_source
from onepiece_dist.picks.runner import PoolStatus, run_each_in_process
from onepiece_dist.picks.views import Executions, index_of, observe_view
from onepiece_dist.plan.scorer import CropRecord, GraspScorer
from onepiece_dist.runtime.actors import restartable_actor
from onepiece_dist.runtime.ray_env import connect
from onepiece_dist.runtime.registry import RegistryClient
from onepiece_dist.sim.collision import load_simulated
from onepiece_dist.specs.plan import PickLabelSpec
from onepiece_dist.store.pick_labels import FAILURE_CODES, LabelledObject, read_pick_labels, write_pick_labels

SAME_POSE, SAME_CONTEXT = 1e-9, 1e-6  # m (and unit vectors): a view seen again is the labelled one within these


def crop_record(spec: PickLabelSpec) -> CropRecord:
    """The crop of a network that reads everything a label keeps (crop, context and swept space)."""
    return CropRecord(spec.gripper, spec.voxel, spec.points_per_grasp, "pointnet_context_space")


def label_object(spec: PickLabelSpec, ref: ObjectRef, index: int) -> LabelledObject:
    """Every view of one object labelled; a bad object becomes a rejected result, never an exception."""
    return labelled_object(spec, ref, index, _label_view, spec.views)


def labelled_object(spec: PickLabelSpec, ref: ObjectRef, index: int, view_rows, views: int) -> LabelledObject:
    """One object's rows: ``view_rows(spec, world, mesh, view)`` (a view's columns, or None where it held no
    candidate) for each of its first ``views`` views, joined; a bad object, or one whose views held none, is a
    rejected result, never an exception."""
    start = time.perf_counter()
    try:
        world, loaded = labelling_world(spec, ref)
    except MeshRejected as err:
        return LabelledObject.rejected(index, ref.name, err.reason)
    parts = [view_rows(spec, world, loaded.mesh, view) for view in range(views)]
    parts = [p for p in parts if p is not None]
    if not parts:
        return LabelledObject.rejected(index, ref.name, "no view held a candidate", time.perf_counter() - start)
    joined = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return LabelledObject(index, ref.name, "ok", seconds=time.perf_counter() - start, **joined)


def labelling_world(spec: PickLabelSpec, ref: ObjectRef):
    """This process's pick world holding ``ref`` as ``spec`` loads it: (world, loaded object); a bad object raises
    MeshRejected."""
    from onepiece_dist.sim.pick import pick_world

    loaded = load_object(ref, spec.object_job())
    world = pick_world(spec.gripper)
    load_simulated(world, loaded, Path(spec.output) / "collision", spec.sim.collision, spec.sim.density)
    return world, loaded


def _label_view(spec: PickLabelSpec, world, mesh, view: int) -> dict[str, np.ndarray] | None:
    seen = observe_view(spec, crop_record(spec), world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return None
    chosen = _chosen(spec, proposals, seen.rng)
    executions = Executions(spec, world, mesh, seen.resting, view)
    return label_rows(spec, proposals, chosen, [executions.run("view", i, proposals.poses[i]) for i in chosen], view)


def label_rows(spec: PickLabelSpec, proposals, chosen, outcomes: list, view: int) -> dict[str, np.ndarray]:
    """The label columns of ``proposals``' candidates ``chosen`` of ``view``, each executed with ``outcomes``
    (sim.pick.PickOutcome, in the same order)."""
    crops, poses = proposals.crops, proposals.poses[chosen]
    return {"points": crops.points[chosen].astype(np.float16), "context": crops.context[chosen].astype(np.float32),
            "space": crops.space[chosen].astype(np.float16),
            "outline": outline(proposals.object_points, poses, spec.gripper.closing_depth).astype(np.float16),
            "success": np.array([o.success for o in outcomes], bool),
            "held": np.array([o.held for o in outcomes], np.int8),
            "failure": np.array([FAILURE_CODES.index(o.failure) for o in outcomes], np.int8),
            "view": np.full(len(chosen), view, np.int16), "pose": poses.astype(np.float64)}


def outlines_again(spec: PickLabelSpec, ref: ObjectRef, view: np.ndarray, pose: np.ndarray,
                   context: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The outlines (n, K, 3) float16 of one object's labels made before labels kept them, and (n,) bool which
    rows have one: each of its ``view`` (n,) seen again (the same seeded settle, camera and cloud) and the outline
    cut for each row's gripper ``pose`` (n, 4, 4). A view has outlines only where, seen again, it gives each row's
    pose and stored ``context`` (n, 6) to within rounding: Bullet leaves the last bits of a settle to what the
    process simulated before, and now and then a settle that far apart ends elsewhere."""
    world, loaded = labelling_world(spec, ref)
    out, same = np.zeros((len(view), OUTLINE_POINTS, 3), np.float16), np.zeros(len(view), bool)
    for number in np.unique(view):
        rows = np.flatnonzero(view == number)
        proposals = observe_view(spec, crop_record(spec), world, loaded.mesh, int(number)).proposals
        found = [index_of(proposals.poses, p) for p in pose[rows]]
        if (np.abs(proposals.poses[found] - pose[rows]).max() < SAME_POSE
                and np.abs(proposals.crops.context[found] - context[rows]).max() < SAME_CONTEXT):
            out[rows] = outline(proposals.object_points, pose[rows], spec.gripper.closing_depth)
            same[rows] = True
    return out, same


def _chosen(spec: PickLabelSpec, proposals, rng: np.random.Generator) -> np.ndarray:
    """Which candidates of a view to execute, in index order: a seeded random subset of ``per_view``; with a
    checkpoint, its ``top_share`` best-scored first (the top-down grasps scored as any other), the rest at random
    among the others. Without one, the top-down grasps (plan.top_down) are always among them, in place of as many
    random ones."""
    crops, count = proposals.crops, len(proposals.crops.counts)
    if proposals.top_down and spec.checkpoint is None:
        sampled = count - proposals.top_down
        forced = np.arange(sampled, count)
        rest = rng.permutation(sampled)[: max(spec.per_view - len(forced), 0)]
        return np.sort(np.concatenate([rest, forced]))
    if spec.checkpoint is None:
        return np.sort(rng.permutation(count)[: spec.per_view])
    scorer = cached_scorer(spec.checkpoint, spec.gripper)
    seen = crops.points[:, : scorer.record.points_per_grasp]  # stored in random order: the first P as it trained
    scores = scorer.score(dataclasses.replace(crops, points=seen))
    top = np.lexsort((np.arange(count), -scores))[: int(round(spec.top_share * spec.per_view))]
    rest = np.setdiff1d(np.arange(count), top)
    return np.sort(np.concatenate([top, rest[rng.permutation(len(rest))[: spec.per_view - len(top)]]]))


@functools.lru_cache(maxsize=2)
def cached_scorer(checkpoint: str, gripper) -> GraspScorer:
    return GraspScorer(checkpoint, gripper, device="cpu")


class PickLabelWorker:
    """One pybullet client per actor: labels objects. A plain class, testable without Ray."""

    def __init__(self, spec: PickLabelSpec):
        self.spec = spec

    def label(self, ref: ObjectRef, index: int) -> LabelledObject:
        return label_object(self.spec, ref, index)


def run_pick_labels(spec: PickLabelSpec, address: str | None = None, in_process: bool = False,
                    progress: Callable[[LabelledObject], None] | None = None) -> Path:
    """Label every object of ``spec.objects``; write ``pick_labels.zarr`` into ``spec.output``; return its path.
    ``progress`` sees each object's labels as they land (in the order they finish)."""
    refs = resolve_source(spec.objects)
    if spec.checkpoint is not None:  # one for another gripper or crop is refused here, before any object is labelled
        cached_scorer(spec.checkpoint, spec.gripper)
    Path(spec.output).mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    results = (run_each_in_process(label_object, spec, refs, progress) if in_process
               else _run_on_ray(spec, refs, address, progress))
    path = Path(spec.output) / "pick_labels.zarr"
    core_seconds = sum(r.seconds for r in results)
    write_pick_labels(path, results, spec.model_dump(mode="json"), core_seconds, time.perf_counter() - start)
    return path


def labels_made(spec: PickLabelSpec) -> Path | None:
    """The pick labels ``spec.output`` holds for ``spec`` itself (None where it holds none); :class:`SpecError`
    where it holds labels of another spec: they are never replaced by others (give another output)."""
    path = Path(spec.output) / "pick_labels.zarr"
    if not path.exists():
        return None
    try:
        stored = PickLabelSpec.stored(read_pick_labels(path).attrs["spec"])
    except (StoreError, KeyError, ValueError) as err:
        raise SpecError(f"{path}: exists and is not a pick-labels store of ours ({err}): give another output "
                        "folder") from None
    stored = stored.model_copy(update={"workers": spec.workers, "output": spec.output})  # neither moves a label
    if stored != spec:
        before = stored.model_dump()
        changed = sorted(k for k, v in spec.model_dump().items() if before[k] != v)
        raise SpecError(f"{path}: holds pick labels of another spec (they differ in {', '.join(changed)}): "
                        "they are kept; give another output folder for these")
    return path


def _run_on_ray(spec: PickLabelSpec, refs: list[ObjectRef], address: str | None,
                progress: Callable[[LabelledObject], None] | None = None) -> list[LabelledObject]:
    import ray

    from onepiece_dist.runtime.ray_runner import WorkerPool, worker_count

    started_here = not ray.is_initialized()
    connect(address)
    job_id = "pick-labels-" + hashlib.blake2b(spec.model_dump_json().encode(), digest_size=6).hexdigest()
    actors = [restartable_actor(PickLabelWorker, f"{job_id}-{k}", num_cpus=1, scheduling_strategy="SPREAD")
              .remote(spec) for k in range(worker_count(spec.workers, len(refs)))]
    try:
        pool = WorkerPool(actors, RegistryClient(), PoolStatus(job_id), progress or (lambda result: None), "label",
                          lambda i, ref, reason: LabelledObject.rejected(i, ref.name, reason))
        return pool.run(refs)
    finally:
        for actor in actors:
            ray.kill(actor)
        if started_here:
            ray.shutdown()


__all__ = ["PickLabelWorker", "cached_scorer", "crop_record", "label_object", "label_rows", "labelled_object",
           "labelling_world", "labels_made", "outlines_again", "run_pick_labels"]
