"""The label stage on the one object: the label protocol at each patch's placement and at perturbed poses
around it, so the labelled data cover each unique shape's neighbourhood (docs/assembly.md).

A trial at one patch must not depend on the rest of the assembly, so each patch is simulated as its own body:
its convex pieces (real geometry clipped from the source object, service/patches.py), with the source object's
mass (the mass rule: the fingers lift and shake what they lifted and shook on the source). Crops for codes and
points come from the patch's real surface points. Results go to ``assembled/grasps/`` in the same layout as
``grasps/``.
"""

from __future__ import annotations

import os

import numpy as np

from onepiece_dist.core.frames import perturb_pose
from onepiece_dist.core.mesh import resample_points
from onepiece_dist.core.sampling import object_rng
from onepiece_dist.core.voxel import crop_codes, crop_points
from onepiece_dist.service.patches import Patches, read_patches
from onepiece_dist.service.status import LabelReport
from onepiece_dist.spec import JobSpec
from onepiece_dist.store.dataset import DatasetReader, write_group
from onepiece_dist.store.format import grasp_arrays


def patch_cloud(patches: Patches, k: int, spec: JobSpec) -> np.ndarray:
    """(m, 3) points of patch ``k`` in its own frame: its surface points, or with ``views.crop='partial'`` what a
    depth camera behind the palm, looking along the approach axis, sees of its pieces."""
    if spec.views.crop == "full":
        return patches.points[k]
    from onepiece_dist.core.clip import hull_mesh
    from onepiece_dist.core.mesh import merge_meshes
    from onepiece_dist.sim.views import camera_at, framing_distance, views_from

    g = spec.gripper
    radius = 0.5 * float(np.linalg.norm([g.closing_depth, g.closing_width, g.closing_height]))
    target = np.array([g.closing_depth / 2, 0.0, 0.0])
    eye = target - [framing_distance(radius, spec.views.fov_deg), 0.0, 0.0]
    camera = camera_at(eye, target, spec.views.image_size, spec.views.fov_deg)
    vertices, faces = merge_meshes([hull_mesh(piece) for piece in patches.pieces[k]])
    return views_from(vertices, faces, [camera]).points.astype(np.float64)


def perturbed_poses(count: int, rng: np.random.Generator, shift: float = 0.004, angle: float = 0.1) -> np.ndarray:
    """The placement (identity) and ``count`` poses around it, by the label trials' perturbation
    (``core.frames.perturb_pose``) with wider noise. (1+count, 4, 4)"""
    return np.stack([np.eye(4)] + [perturb_pose(np.eye(4), rng, shift, angle) for _ in range(count)])


def label_assembly(spec: JobSpec, path: str | os.PathLike) -> LabelReport:
    """Run the label protocol around every patch (``spec.sim.perturbations_per_patch`` perturbed poses besides
    the placement); store ``assembled/grasps/`` and return counts."""
    from onepiece_dist.sim.trials import LabelNoise, run_trials
    from onepiece_dist.sim.world import process_world

    reader = DatasetReader(path)
    placements = reader["assembled/placement"].astype(np.float64)
    patches = read_patches(reader)
    perturbations = spec.sim.perturbations_per_patch
    world = process_world(spec.gripper)
    noise = LabelNoise.from_spec(spec.sim)
    rows: dict[str, list] = {k: [] for k in ("patch", "pose", "candidate_pose", "width", "shift", "success",
                                             "quality", "slip", "code", "candidate_code", "points")}
    for k, placement in enumerate(placements):
        if not patches.pieces[k]:
            continue  # nothing of the source object in the patch box: nothing to grasp
        world.load_object(patches.pieces[k], float(patches.source_volume[k]), spec.gripper.friction)
        rng = object_rng(f"{k:032x}", spec.seed, stream=2)
        poses = perturbed_poses(perturbations, rng)
        batch = run_trials(world, poses, label=True, noise=noise, rng=rng)
        _collect(rows, k, placement, patch_cloud(patches, k, spec), poses, batch, spec, rng)
    arrays = {name: np.concatenate(values) if values else np.zeros(0) for name, values in rows.items()}
    summary = LabelReport(label_trials=int(len(placements) * (1 + perturbations) * spec.sim.label_trials),
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
    rows["pose"].append(placement @ settled)
    rows["candidate_pose"].append(placement @ poses[ok])
    for name in ("width", "shift", "quality", "slip", "success"):
        rows[name].append(getattr(batch, name)[ok])
    rows["code"].append(crop_codes(points, settled, grid, res)[0])
    rows["candidate_code"].append(crop_codes(points, poses[ok], grid, res)[0])
    count = max(spec.sim.points_per_grasp, 1)
    rows["points"].append(np.stack([resample_points(crop_points(points, p, grid, res), count, rng)
                                    for p in settled]))
