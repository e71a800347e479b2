"""Patch building on the worker pool: the per-patch work of the assemble stage (clipping each representative's
convex pieces to its patch box, cutting its surface points) in shards, each written as a part by a worker, so
the central actor only reads them back in patch order, lays the patches out, checks and commits (issue 43).

Shards hold patches of few source objects (patches sorted by source object), so a worker loads few sources. A
shard's part is keyed by the representatives, their poses, the objects and the spec fields that shape a patch:
a retried or resumed job finds finished shards and reuses them. The patches are the ones the central actor cut
alone before (the same function, ``build_patches``, on the same rows).
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from onepiece_dist.core.ragged import row_offsets, split_rows, stack_rows
from onepiece_dist.errors import JobError
from onepiece_dist.job.made_once import shard_once
from onepiece_dist.job.patches import (
    Patches,
    as_stored,
    build_patches,
    source_geometry,
)
from onepiece_dist.job.results import PatchTask, ShardResult
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore
from onepiece_dist.store.dataset import DatasetReader

PATCH_SHARD_PATCHES = 64  # patches per task: a few hundred milliseconds of work


def patch_order(reader: DatasetReader) -> np.ndarray:
    """(U,) int64 patches sorted by source object (stable): the order shards cut them in."""
    objects = reader["grasps/object"][reader["unique/representative"]].astype(np.int64)
    return np.argsort(objects, kind="stable")


def patch_key(spec: JobSpec, reader: DatasetReader) -> str:
    """Hash of what decides the patches: the representatives, their poses, the objects and the spec's gripper,
    voxel grid and extraction (its result key)."""
    representative = reader["unique/representative"]
    digest = hashlib.blake2b(digest_size=8)
    digest.update(np.ascontiguousarray(representative).tobytes())
    digest.update(np.ascontiguousarray(reader.array("grasps/pose").oindex[np.sort(representative)]).tobytes())
    digest.update(reader.array("objects/id")[:].tobytes())
    digest.update(json.dumps({"gripper": spec.gripper.model_dump(mode="json"), "voxel": spec.voxel.model_dump(
        mode="json"), "result_key": spec.result_key()}, sort_keys=True).encode())
    return digest.hexdigest()


def patch_tasks(spec: JobSpec, path: str | os.PathLike) -> list[PatchTask]:
    """The patches of the committed dataset at ``path`` in shards of PATCH_SHARD_PATCHES (in :func:`patch_order`)."""
    reader = DatasetReader(path)
    count = int(reader.array("unique/representative").shape[0])
    key = patch_key(spec, reader)
    return [PatchTask(start, min(start + PATCH_SHARD_PATCHES, count), str(path), key)
            for start in range(0, count, PATCH_SHARD_PATCHES)]


def build_patch_shard(spec: JobSpec, task: PatchTask, index: int, parts: PartStore) -> ShardResult:
    """Cut one shard's patches into its part (once: a committed part is reused). Runs in a worker."""
    def make() -> dict[str, np.ndarray]:
        reader = DatasetReader(task.dataset)
        positions = patch_order(reader)[task.start:task.stop]
        patches = build_patches(spec, reader, parts, reader["unique/representative"][positions])
        pieces = [piece for patch in patches.pieces for piece in patch]
        return {"position": positions.astype(np.int64),
                "patch_piece_count": np.array([len(p) for p in patches.pieces], dtype=np.int64),
                "piece_vertex_count": np.array([len(p) for p in pieces], dtype=np.int64),
                "piece_vertices": stack_rows(pieces, np.float32),
                "point_count": np.array([len(p) for p in patches.points], dtype=np.int64),
                "points": stack_rows(patches.points, np.float32), "source_volume": patches.source_volume}

    return shard_once(parts, task.part_key, index, make, {"patches": [task.start, task.stop]},
                      lambda: task.stop - task.start)


def merge_patch_shards(spec: JobSpec, reader: DatasetReader, parts: PartStore, tasks: list[PatchTask],
                       results: list[ShardResult]) -> Patches:
    """Every patch, in patch order, from the shards' parts, with the sources they were cut from."""
    for task, result in zip(tasks, results, strict=True):
        if result.status != "ok":
            raise JobError(f"patch shard {result.index} (patches {task.start}-{task.stop - 1}): {result.reason}")
    representative = reader["unique/representative"].astype(np.int64)
    pieces: list[list[np.ndarray]] = [[] for _ in representative]
    points: list[np.ndarray] = [np.zeros((0, 3))] * len(representative)
    volume = np.zeros(len(representative))
    for task in tasks:
        shard = parts.read(task.part_key)
        piece_list = split_rows(shard["piece_vertices"], shard["piece_vertex_count"])
        firsts = row_offsets(shard["patch_piece_count"])
        shard_points = split_rows(shard["points"], shard["point_count"])
        for j, k in enumerate(shard["position"]):
            pieces[k] = piece_list[firsts[j]:firsts[j + 1]]
            points[k] = shard_points[j]
            volume[k] = shard["source_volume"][j]
    objects = reader["grasps/object"][representative].astype(np.int64)
    used = np.unique(objects)
    sources = [as_stored(source_geometry(reader, parts, int(obj)).surface) for obj in used]
    return Patches(representative, pieces, points, volume, sources, np.searchsorted(used, objects).astype(np.int64),
                   reader["grasps/pose"][representative].astype(np.float32))
