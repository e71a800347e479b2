"""The label stage on the one object: the label protocol at each patch's placement and at perturbed poses
around it, so the labelled data cover each unique shape's neighbourhood (docs/assembly.md).

A trial at one patch must not depend on the rest of the assembly, so each patch is simulated as its own body:
its convex pieces (real geometry clipped from the source object, job/patches.py), with the source object's
mass (the mass rule: the fingers lift and shake what they lifted and shook on the source; with ``sim.load: grasp``
every trial, here and on the sources, lifts the same payload at the grasp centre instead). Crops for codes and
points come from the patch's real surface points. Results go to ``assembled/grasps/`` in the same layout as
``grasps/``.
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from onepiece_dist.core.clip import pieces_mesh
from onepiece_dist.core.frames import compose_poses, perturb_pose
from onepiece_dist.core.sampling import object_rng
from onepiece_dist.core.voxel import crop_codes, crop_regions, network_inputs, stored_codes
from onepiece_dist.job.made_once import shard_once
from onepiece_dist.job.patches import Patches, read_patches
from onepiece_dist.job.results import LabelTask, ShardResult
from onepiece_dist.job.stages import label_budget  # the module: a test injects a fault into its shard function
from onepiece_dist.job.stages.extract import closure_labelled
from onepiece_dist.job.status import LabelReport
from onepiece_dist.sim.views import camera_at, framing_distance, views_from
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore
from onepiece_dist.store.dataset import DatasetReader, write_group
from onepiece_dist.store.format import grasp_arrays, grasp_row_shape


def patch_cloud(patches: Patches, k: int, spec: JobSpec) -> np.ndarray:
    """(m, 3) points of patch ``k`` in its own frame: its surface points, or with ``views.crop='partial'`` what a
    depth camera behind the palm, looking along the approach axis, sees of its pieces."""
    if spec.views.crop == "full":
        return patches.points[k]

    g = spec.gripper
    radius = 0.5 * float(np.linalg.norm([g.closing_depth, g.closing_width, g.closing_height]))
    target = np.array([g.closing_depth / 2, 0.0, 0.0])
    eye = target - [framing_distance(radius, spec.views.fov_deg), 0.0, 0.0]
    camera = camera_at(eye, target, spec.views.image_size, spec.views.fov_deg)
    vertices, faces = pieces_mesh(patches.pieces[k])
    return views_from(vertices, faces, [camera]).points.astype(np.float64)


def perturbed_poses(count: int, rng: np.random.Generator, shift: float = 0.004, angle: float = 0.1) -> np.ndarray:
    """The placement (identity) and ``count`` poses around it, by the label trials' perturbation
    (``core.frames.perturb_pose``) with wider noise. (1+count, 4, 4)"""
    return np.stack([np.eye(4)] + [perturb_pose(np.eye(4), rng, shift, angle) for _ in range(count)])


LABEL_SHARD_PATCHES = 16  # patches per label task: enough work to hide a task's overhead, many tasks to share


def label_tasks(spec: JobSpec, path: str | os.PathLike) -> list[LabelTask]:
    """The label stage of the one object at ``path`` in shards of LABEL_SHARD_PATCHES patches, keyed by what
    decides their labels (the placed patches and the label-relevant spec), so a re-run reuses finished shards."""
    reader = DatasetReader(path)
    patches = int(reader.array("assembled/placement").shape[0])
    key = label_key(spec, reader)
    return [LabelTask(start, min(start + LABEL_SHARD_PATCHES, patches), str(path), key)
            for start in range(0, patches, LABEL_SHARD_PATCHES)]


def label_key(spec: JobSpec, reader: DatasetReader) -> str:
    """Hash of the one object's patches and placements and of the spec fields labels depend on."""
    digest = hashlib.blake2b(digest_size=8)
    for name in ("placement", "piece_vertices", "piece_vertex_count", "patch_piece_count", "source_points",
                 "source_point_count", "source_box", "source_object", "source_pose", "source_volume"):
        digest.update(np.ascontiguousarray(reader[f"assembled/{name}"]).tobytes())
    relevant = spec.model_dump(mode="json", include={"seed", "gripper", "voxel", "views", "closure"})
    relevant["sim"] = spec.sim.model_dump(mode="json", exclude={"transfer_codes", "transfer_grasps"})
    digest.update(json.dumps(relevant, sort_keys=True).encode())
    return digest.hexdigest()


def label_shard(spec: JobSpec, task: LabelTask, index: int, parts: PartStore) -> ShardResult:
    """Label one shard into its part (once: a committed part is reused). Runs in a worker."""
    if task.rows is not None:
        return label_budget.label_budget_shard(spec, task, index, parts)
    return shard_once(parts, task.part_key, index, lambda: label_patches(spec, task),
                      {"patches": [task.start, task.stop]},
                      lambda: int(parts.array_shapes(task.part_key)["patch"][0][0]))


def label_patches(spec: JobSpec, task: LabelTask) -> dict[str, np.ndarray]:
    """The label protocol around each patch of ``task`` (``spec.sim.perturbations_per_patch`` perturbed poses
    besides the placement): their labelled grasps in the layout of ``assembled/grasps/``. Reads only the task's
    patches and placements."""
    from onepiece_dist.sim.trials import LabelNoise, run_trials
    from onepiece_dist.sim.world import process_world

    reader = DatasetReader(task.dataset)
    placements = reader.array("assembled/placement")[task.start:task.stop].astype(np.float64)
    patch_set = read_patches(reader, task.start, task.stop)
    world, noise = process_world(spec.gripper), LabelNoise.from_spec(spec.sim)
    rows: dict[str, list] = {k: [] for k in grasp_rows(spec)}
    for local, k in enumerate(range(task.start, task.stop)):
        if not patch_set.pieces[local]:
            continue  # nothing of the source object in the patch box: nothing to grasp
        world.load_object(patch_set.pieces[local], float(patch_set.source_volume[local]), spec.sim.density)
        rng = object_rng(f"{k:032x}", spec.seed, stream=2)
        poses = perturbed_poses(spec.sim.perturbations_per_patch, rng)
        batch = run_trials(world, poses, label=True, noise=noise, rng=rng)
        _collect(rows, k, placements[local], patch_cloud(patch_set, local, spec), poses, batch, spec, rng)
        if spec.closure.enabled:
            _score_closure(rows, patch_set.pieces[local], batch, spec)
    return grasp_arrays({name: np.concatenate(values) if values else _empty(name, spec)
                         for name, values in rows.items()})


GRASP_ROWS = ("patch", "pose", "candidate_pose", "width", "shift", "success", "quality", "slip", "code",
              "candidate_code", "points")
CLOSURE_ROWS = ("fc_mu", "fc_epsilon", "fc_contacts")


def grasp_rows(spec: JobSpec) -> tuple[str, ...]:
    """The arrays of ``assembled/grasps/`` this spec's label stage writes."""
    closure = CLOSURE_ROWS + (("physics_success",) if spec.closure.label != "physics" else ())
    return GRASP_ROWS + (closure if spec.closure.enabled else ())


def _score_closure(rows, pieces: list[np.ndarray], batch, spec: JobSpec) -> None:
    """Force closure and epsilon of the held trials on the patch's real geometry (its convex pieces as one mesh,
    in the patch frame where the settled poses are)."""
    ok = batch.outcome == 0
    if ok.any():
        vertices, faces = pieces_mesh(pieces)
        scored = closure_labelled(spec, vertices, faces, batch.settled_pose[ok], rows["success"][-1])
        if "physics_success" in scored:
            rows["success"][-1] = scored.pop("success")  # the label this job's protocol asks for
        for name, values in scored.items():
            rows[name].append(values)


def _empty(name: str, spec: JobSpec) -> np.ndarray:
    """No rows of grasp array ``name``, in its row shape."""
    return np.zeros((0, *grasp_row_shape(name, spec.code_bytes(), max(spec.sim.points_per_grasp, 1))))


def write_labels(spec: JobSpec, path: str | os.PathLike, tasks: list[LabelTask], parts: PartStore) -> LabelReport:
    """Store the shards' labelled grasps, in patch order, as ``assembled/grasps/``; return the counts."""
    shards = [parts.read(task.part_key) for task in tasks]
    arrays = {name: np.concatenate([shard[name] for shard in shards]) if shards else _empty(name, spec)
              for name in grasp_rows(spec)}
    patches = tasks[-1].stop if tasks else 0
    summary = LabelReport(label_trials=int(patches * spec.sim.label_trials_per_patch()),
                          labelled_grasps=int(len(arrays["patch"])),
                          success_rate=float(np.mean(arrays["success"])) if len(arrays["patch"]) else 0.0)
    write_group(path, "assembled/grasps", grasp_arrays(arrays), {"assembly_labels": summary.model_dump(mode="json")})
    return summary


def _collect(rows, k, placement, points, poses, batch, spec, rng) -> None:
    ok = batch.outcome == 0
    if not ok.any():
        return
    settled = batch.settled_pose[ok]
    grid, res = spec.grid_shape(), spec.voxel.resolution
    rows["patch"].append(np.full(int(ok.sum()), k))
    rows["pose"].append(compose_poses(placement, settled))
    rows["candidate_pose"].append(compose_poses(placement, poses[ok]))
    for name in ("width", "shift", "quality", "slip", "success"):
        rows[name].append(getattr(batch, name)[ok])
    codes, _, inside = crop_regions(points, settled, grid, res, keep_points=True)
    canonical = spec.voxel.canonical
    codes, crops = network_inputs(codes, inside, grid, canonical, max(spec.sim.points_per_grasp, 1), rng)
    rows["code"].append(codes)
    rows["candidate_code"].append(stored_codes(crop_codes(points, poses[ok], grid, res)[0], grid, canonical))
    rows["points"].append(crops)
