"""Which dedup key decides the label (study.keys; the key study of docs/key_study.md as a study option).

The study's own lookup (study.lookup) asks how far the job's voxel code decides the label on held-out objects.
With ``keys`` in the spec it asks the same of other keys, computed from every grasp's crop at its settled pose:
occupancy codes at other resolutions (core.voxel) and contact keys, the relief under each finger pad
(core.contact), or both at once. A crop is what the job crops: the object's surface points, sampled as its job
samples them, inside the closing region at the settled pose (grasps/pose); so the occupancy key at the job's own
resolution is the job's code, grasp for grasp. No network and no further labels: A's labels on the train objects
and the held-out labels, looked up through each key.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.contact import ContactKeySpec, contact_keys
from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.core.mesh import sample_surface
from onepiece_dist.core.sampling import object_rng
from onepiece_dist.core.voxel import crop_regions, pack_codes, voxel_indices
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.study.lookup import key_lookup
from onepiece_dist.study.result import KeyMeasure
from onepiece_dist.study.spec import StudyKey


@dataclass(frozen=True)
class Crops:
    """Every grasp's crop at its settled pose: points (q, 3) float64 gripper frame, rows (q,) int64 the grasp of
    each point, count grasps."""

    points: np.ndarray
    rows: np.ndarray
    count: int


def settled_crops(spec: JobSpec) -> Crops:
    """Every grasp of the job's dataset (``spec.output``) cropped at its settled pose from its object's surface
    points, sampled as the job samples them."""
    from onepiece_dist.store import open_dataset

    ds = open_dataset(spec.output)
    owner, poses = ds["grasps/object"].astype(np.int64), ds["grasps/pose"].astype(np.float64)
    refs = {ref.name: ref for ref in resolve_source(spec.objects)}
    grid = spec.voxel.grid_shape(spec.gripper)
    points, rows = [np.zeros((0, 3))], [np.zeros(0, dtype=np.int64)]
    for k, name in enumerate(ds.object_names):
        mine = np.flatnonzero(owner == k)
        if len(mine):
            mesh = load_object(refs[name], spec).mesh
            cloud = sample_surface(mesh, spec.sampler.surface_points, object_rng(mesh.content_id, spec.seed))[0]
            _, counts, kept = crop_regions(cloud, poses[mine], grid, spec.voxel.resolution, keep_points=True)
            points += kept
            rows.append(np.repeat(mine, counts))
    return Crops(np.concatenate(points), np.concatenate(rows), len(owner))


def occupancy(crops: Crops, region: tuple[float, float, float], resolution: float) -> np.ndarray:
    """(n, B) uint8 packed occupancy codes of the crops at ``resolution`` (core.voxel's layout)."""
    grid = tuple(int(round(x / resolution)) for x in region)
    occupied = np.zeros((crops.count, int(np.prod(grid))), dtype=bool)
    flat = voxel_indices(crops.points, grid, resolution)
    occupied[crops.rows[flat >= 0], flat[flat >= 0]] = True
    return pack_codes(occupied)


def key_of(crops: Crops, key: StudyKey, region: tuple[float, float, float]) -> np.ndarray:
    """(n, K) uint8 each crop's key."""
    parts = []
    if key.kind in ("occupancy", "both"):
        parts.append(occupancy(crops, region, key.resolution))
    if key.kind in ("contact", "both"):
        contact = ContactKeySpec(region, cell=key.cell, step=key.step, levels=key.levels, width_step=key.width_step)
        parts.append(contact_keys(crops.rows, crops.points, crops.count, contact))
    return np.concatenate(parts, axis=1)


def key_measures(keys: tuple[StudyKey, ...], a: JobSpec, heldout: JobSpec, seed: int) -> list[KeyMeasure]:
    """Each key's unique fraction among A's grasps and its lookup from A's labels to the held-out labels (the
    jobs' datasets)."""
    from onepiece_dist.store import open_dataset

    if not keys:
        return []
    train, held = settled_crops(a), settled_crops(heldout)
    train_success = open_dataset(a.output)["grasps/success"].astype(bool)
    held_success = open_dataset(heldout.output)["grasps/success"].astype(bool)
    g = a.gripper
    region = (g.closing_depth, g.closing_width, g.closing_height)
    out = []
    for key in keys:
        train_keys, held_keys = key_of(train, key, region), key_of(held, key, region)
        unique = len(unique_codes(train_keys).unique)
        out.append(KeyMeasure(name=key.name, key_bytes=int(train_keys.shape[1]), unique=unique,
                              unique_fraction=round(unique / max(train.count, 1), 4),
                              lookup=key_lookup(train_keys, train_success, held_keys, held_success, seed)))
    return out
