"""Budgeted labelling: label only a seeded subset of the extracted candidates, on their own objects, spread over
every object (the R plan of a study, as a job; issue 39).

The extract stage settles, crops and codes every candidate (the cheap part); the label stage then labels the
chosen candidates with the label protocol at their candidate poses on their own source objects, in shards on the
worker pool (each shard is a part: a re-run reuses finished shards), and the central actor writes them as
``labelled/grasps/``: the rows of ``grasps/`` with their labels, and ``row``, where each came from.
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from onepiece_dist.errors import SpecError
from onepiece_dist.job.made_once import shard_once
from onepiece_dist.job.results import LabelTask, ShardResult
from onepiece_dist.job.stages.label_transfer import label_on_sources
from onepiece_dist.job.status import LabelReport
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore
from onepiece_dist.store.dataset import DatasetReader, write_group
from onepiece_dist.store.format import GRASP_DTYPES, grasp_arrays

BUDGET_SHARD_GRASPS = 32  # labelled candidates per task, all of one object


def allocate(capacity: np.ndarray, size: int, rng: np.random.Generator) -> np.ndarray:
    """(n,) int64 labels per object: ``size`` in all (at most the total capacity), as equal as each object's
    ``capacity`` (its candidates) allows; the remainder of an uneven split goes to objects in a seeded order."""
    capacity = np.asarray(capacity, dtype=np.int64)
    quota = np.zeros(len(capacity), dtype=np.int64)
    left = min(int(size), int(capacity.sum()))
    order = rng.permutation(len(capacity))
    while left > 0:
        room = order[quota[order] < capacity[order]]
        share = left // len(room)
        if share == 0:
            quota[room[:left]] += 1
            break
        add = np.minimum(share, capacity[room] - quota[room])
        quota[room] += add
        left -= int(add.sum())
    return quota


def budget_rows(owner: np.ndarray, size: int, seed: int) -> np.ndarray:
    """Sorted rows of grasps/ to label: ``size`` of them (or all), spread over the objects by :func:`allocate`,
    drawn at random within each object (seeded by the job's seed and the object's row)."""
    objects, counts = np.unique(owner, return_counts=True)
    quota = allocate(counts, size, np.random.default_rng([seed, 39]))
    rows = [np.sort(np.random.default_rng([seed, 39, int(obj)]).choice(np.flatnonzero(owner == obj), q,
                                                                         replace=False))
            for obj, q in zip(objects, quota, strict=True) if q]
    return np.sort(np.concatenate(rows)) if rows else np.zeros(0, dtype=np.int64)


def check_budget(spec: JobSpec, objects: int) -> None:
    """A count below the number of objects cannot spread over every object: refused, naming the field."""
    if spec.budget.count is not None and spec.budget.count < objects:
        raise SpecError(f"budget.count={spec.budget.count} is below the job's {objects} objects: a budget labels "
                        "at least one candidate of each object (give a larger count, or budget.fraction)")


def labels_key(spec: JobSpec, reader: DatasetReader, rows: np.ndarray | None, plan: str,
               extra: dict | None = None) -> str:
    """Hash of the candidates a labelling plan chooses among (``rows``, None: all of them), of the objects, and of
    the spec fields their labels depend on (``plan``: the plan's own field, budget or adaptive; ``extra``: more)."""
    digest = hashlib.blake2b(digest_size=8)
    poses = reader.array("grasps/candidate_pose")
    if rows is not None:
        digest.update(np.ascontiguousarray(rows).tobytes())
    digest.update(np.ascontiguousarray(poses[:] if rows is None else poses.oindex[rows]).tobytes())
    digest.update(reader.array("objects/id")[:].tobytes())
    relevant = spec.model_dump(mode="json", include={"seed", "gripper", "voxel", "closure", plan})
    relevant["sim"] = spec.sim.model_dump(mode="json", exclude={"transfer_codes", "transfer_grasps"})
    relevant.update(extra or {})
    digest.update(json.dumps(relevant, sort_keys=True).encode())
    return digest.hexdigest()


def row_shards(dataset: str, owner: np.ndarray, rows: np.ndarray, key: str,
               number: int | None = None) -> list[LabelTask]:
    """Label tasks for ``rows`` of grasps/ (sorted): shards of at most BUDGET_SHARD_GRASPS rows of one object
    each (``owner``: each row's object), positioned in row order; ``number``: an adaptive round's."""
    tasks, start = [], 0
    for obj in np.unique(owner[rows]):
        mine = rows[owner[rows] == obj]
        for first in range(0, len(mine), BUDGET_SHARD_GRASPS):
            chunk = mine[first:first + BUDGET_SHARD_GRASPS]
            tasks.append(LabelTask(start, start + len(chunk), dataset, key, tuple(int(r) for r in chunk), number))
            start += len(chunk)
    return tasks


def budget_tasks(spec: JobSpec, path: str | os.PathLike) -> list[LabelTask]:
    """The chosen candidates in shards of at most BUDGET_SHARD_GRASPS rows of one object each."""
    reader = DatasetReader(path)
    owner = reader["grasps/object"].astype(np.int64)
    rows = budget_rows(owner, spec.budget.size(len(owner)), spec.seed)
    return row_shards(str(path), owner, rows, labels_key(spec, reader, rows, "budget"))


def label_budget_shard(spec: JobSpec, task: LabelTask, index: int, parts: PartStore) -> ShardResult:
    """Label one shard of chosen candidates on their own object into its part (once). Runs in a worker."""
    def make() -> dict[str, np.ndarray]:
        rows = np.asarray(task.rows, dtype=np.int64)
        success, quality = label_on_sources(spec, DatasetReader(task.dataset), parts, rows)
        return {"row": rows, "success": success.astype(np.uint8), "quality": quality.astype(np.float32)}

    return shard_once(parts, task.part_key, index, make, {"rows": [task.start, task.stop]},
                      lambda: task.stop - task.start)


def write_budget_labels(spec: JobSpec, path: str | os.PathLike, tasks: list[LabelTask], parts: PartStore,
                        core_seconds: float = 0.0) -> LabelReport:
    """``labelled/grasps/``: the chosen rows of ``grasps/`` (every array the extraction stored) with their labels,
    in row order, and the ``budget_labels`` attribute (with what the label stage cost, ``core_seconds``)."""
    reader = DatasetReader(path)
    shards = [parts.read(task.part_key) for task in tasks]
    rows = np.concatenate([s["row"] for s in shards]) if shards else np.zeros(0, dtype=np.int64)
    order = np.argsort(rows, kind="stable")
    rows = rows[order]
    labels = {name: np.concatenate([s[name] for s in shards])[order] if shards else np.zeros(0)
              for name in ("success", "quality")}
    arrays = {name: reader.array(f"grasps/{name}").oindex[rows] for name in _grasp_names(reader)}
    arrays.update({**labels, "row": rows})
    if tasks and tasks[0].round is not None:  # adaptive labelling: the round of each labelled grasp
        rounds = [np.full(len(shard["row"]), task.round) for task, shard in zip(tasks, shards, strict=True)]
        arrays["round"] = np.concatenate(rounds)[order]
    candidates = int(reader.array("grasps/object").shape[0])
    summary = LabelReport(label_trials=int(len(rows) * spec.sim.label_trials), labelled_grasps=int(len(rows)),
                          success_rate=float(np.mean(labels["success"])) if len(rows) else 0.0)
    requested = spec.budget.count if spec.budget.count is not None else spec.budget.fraction or spec.adaptive.limit
    write_group(path, "labelled/grasps", grasp_arrays(arrays), {"budget_labels": {
        **summary.model_dump(mode="json"), "requested": requested, "candidates": candidates,
        "all_candidates": bool(len(rows) == candidates), "objects": int(len(np.unique(arrays["object"]))),
        "label_core_seconds": round(core_seconds, 3)}})
    return summary


def _grasp_names(reader: DatasetReader) -> list[str]:
    """The per-grasp arrays of grasps/ a labelled grasp keeps (not its old labels, nor the dedup's bookkeeping)."""
    skipped = ("success", "quality", "code_index", "exact_index")
    return sorted(name for name, _ in reader.root["grasps"].arrays() if name in GRASP_DTYPES and name not in skipped)
