"""The label stage on the one object: the label protocol at each patch's placement and at perturbed poses
around it, so the labelled data cover each unique shape's neighbourhood (docs/assembly.md).

A trial at one patch must not depend on the mass or inertia of the rest of the assembly, so each patch is
simulated as its own body: its voxel cubes plus a local support slab behind them (the part of the core face
under the patch), with the mass that density gives that volume. Results go to ``assembled/grasps/`` in the same
layout as ``grasps/``.
"""

from __future__ import annotations

import os

import numpy as np

from onepiece_dist.core.frames import perturb_pose
from onepiece_dist.core.layout import box_arrays, cube_points
from onepiece_dist.core.mesh import resample_points
from onepiece_dist.core.sampling import object_rng
from onepiece_dist.core.voxel import crop_codes, crop_points
from onepiece_dist.service.status import LabelReport
from onepiece_dist.spec import JobSpec
from onepiece_dist.store.dataset import DatasetReader, write_group
from onepiece_dist.store.format import grasp_arrays

SUPPORT_THICKNESS = 0.01  # m


def patch_body(cube_centres: np.ndarray, edge: float, pitch: tuple[float, float], spec: JobSpec):
    """Convex pieces (list of (8, 3) vertex arrays) and volume of one patch in its placement (gripper) frame:
    its cubes and a support slab beyond the fingertips covering the patch's cell."""
    gap = spec.voxel.resolution / 2
    slab_centre = np.array([[spec.gripper.closing_depth + gap + SUPPORT_THICKNESS / 2, 0.0, 0.0]])
    slab_edges = np.array([[SUPPORT_THICKNESS, pitch[0], pitch[1]]])
    centres = np.vstack([cube_centres, slab_centre])
    edges = np.vstack([np.full((len(cube_centres), 3), edge), slab_edges])
    vertices, _ = box_arrays(centres, edges)
    volume = len(cube_centres) * edge**3 + float(np.prod(slab_edges))
    return list(vertices.reshape(-1, 8, 3)), volume


def patch_cloud(local: np.ndarray, edge: float, spec: JobSpec) -> np.ndarray:
    """(m, 3) points of a patch's cubes in its placement frame: all faces, or with ``views.crop='partial'`` what
    a depth camera behind the palm, looking along the approach axis, sees of them."""
    if spec.views.crop == "full":
        return cube_points(local, edge)
    from onepiece_dist.sim.views import camera_at, framing_distance, views_from

    g = spec.gripper
    radius = 0.5 * float(np.linalg.norm([g.closing_depth, g.closing_width, g.closing_height]))
    target = np.array([g.closing_depth / 2, 0.0, 0.0])
    eye = target - [framing_distance(radius, spec.views.fov_deg), 0.0, 0.0]
    camera = camera_at(eye, target, spec.views.image_size, spec.views.fov_deg)
    vertices, faces = box_arrays(local, np.full((len(local), 3), edge))
    return views_from(vertices, faces, [camera]).points.astype(np.float64)


def perturbed_poses(count: int, rng: np.random.Generator, shift: float = 0.004, angle: float = 0.1) -> np.ndarray:
    """The placement (identity) and ``count`` poses around it, by the label trials' perturbation
    (``core.frames.perturb_pose``) with wider noise. (1+count, 4, 4)"""
    return np.stack([np.eye(4)] + [perturb_pose(np.eye(4), rng, shift, angle) for _ in range(count)])


def label_assembly(spec: JobSpec, path: str | os.PathLike, pitch: list[float]) -> LabelReport:
    """Run the label protocol around every patch (``spec.sim.perturbations_per_patch`` perturbed poses besides
    the placement); store ``assembled/grasps/`` and return counts. ``pitch`` is the assembly's patch cell (m)."""
    from onepiece_dist.sim.trials import LabelNoise, run_trials
    from onepiece_dist.sim.world import process_world

    reader = DatasetReader(path)
    placements = reader["assembled/placement"].astype(np.float64)
    centres, owner = reader["assembled/cube_centre"].astype(np.float64), reader["assembled/cube_patch"]
    edge, perturbations = 0.8 * spec.voxel.resolution, spec.sim.perturbations_per_patch
    world = process_world(spec.gripper)
    noise = LabelNoise.from_spec(spec.sim)
    rows: dict[str, list] = {k: [] for k in ("patch", "pose", "candidate_pose", "width", "shift", "success",
                                             "quality", "slip", "code", "candidate_code", "points")}
    for k, placement in enumerate(placements):
        local = (centres[owner == k] - placement[:3, 3]) @ placement[:3, :3]  # cube centres in the patch frame
        pieces, volume = patch_body(local, edge, tuple(pitch), spec)
        world.load_object(pieces, volume, spec.gripper.friction)
        rng = object_rng(f"{k:032x}", spec.seed, stream=2)
        poses = perturbed_poses(perturbations, rng)
        batch = run_trials(world, poses, label=True, noise=noise, rng=rng)
        _collect(rows, k, placement, local, edge, poses, batch, spec, rng)
    arrays = {name: np.concatenate(values) if values else np.zeros(0) for name, values in rows.items()}
    summary = LabelReport(label_trials=int(len(placements) * (1 + perturbations) * spec.sim.label_trials),
                          labelled_grasps=int(len(arrays["patch"])),
                          success_rate=float(np.mean(arrays["success"])) if len(arrays["patch"]) else 0.0)
    write_group(path, "assembled/grasps", grasp_arrays(arrays), {"assembly_labels": summary.model_dump(mode="json")})
    return summary


def _collect(rows, k, placement, local, edge, poses, batch, spec, rng) -> None:
    ok = batch.outcome == 0
    if not ok.any():
        return
    points = patch_cloud(local, edge, spec)
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
