"""Adaptive labelling (issue 39): the label stage in rounds, the network choosing what to label next.

The extract stage settles, crops and codes every candidate (the cheap part). Round 0 labels a fixed validation set
on validation objects held out from the rounds, and one candidate per voxel code on the others (codes in a seeded
order), so the codes give diversity as ONE PIECE's dedup intends. After each round the trainer fits the network on
the labels so far (warm start from the last round's network), keeps the checkpoint with the lowest loss on the
validation objects and scores every candidate; the next round labels the candidates it is least sure of (score
nearest one half), one per code while codes last. The rounds stop when the validation AP has not risen by more
than ``adaptive.margin`` for ``adaptive.patience`` rounds, after ``adaptive.rounds`` rounds, at ``adaptive.limit``,
or when every candidate is labelled.

Labels run in shards on the worker pool (job/stages/label_budget.py's shards, one part each); each round's network and
scores are parts too, keyed by the labelled rows they were trained on. A job killed mid-round finds every shard
and round it finished and resumes at the round it was in, with the same result: the choices are seeded and each
round's training is deterministic given its rows and the last round's network.
"""

from __future__ import annotations

import hashlib
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from onepiece_dist.errors import JobError, SpecError
from onepiece_dist.job.results import LabelTask, ShardResult
from onepiece_dist.job.stages.label_budget import labels_key, row_shards
from onepiece_dist.job.status import AdaptiveReport, AdaptiveRound, JobStatus
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.stats.selection import first_rows, least_sure
from onepiece_dist.store import PartStore
from onepiece_dist.store.dataset import DatasetReader

log = logging.getLogger("onepiece_dist.job")


@dataclass(frozen=True)
class RoundsPlan:
    """What the rounds choose among: every candidate's object and code, the objects held out for validation and
    their labelled candidates, and a key over everything the rounds' results depend on."""

    owner: np.ndarray  # (n,) int64 row in objects/ of each candidate
    code: np.ndarray  # (n,) int64 code (row in unique/) of each candidate
    validation_objects: np.ndarray  # (V,) int64 rows in objects/
    validation_rows: np.ndarray  # (k,) int64 rows of grasps/ labelled for validation in round 0
    key: str

    @property
    def pool(self) -> np.ndarray:
        """Rows the rounds may label: the candidates of the objects not held out."""
        return np.flatnonzero(~np.isin(self.owner, self.validation_objects))


def rounds_plan(spec: JobSpec, reader: DatasetReader) -> RoundsPlan:
    owner = reader["grasps/object"].astype(np.int64)
    objects, counts = np.unique(owner, return_counts=True)
    if len(objects) < 2:
        raise SpecError(f"adaptive: {spec.objects} gave {len(objects)} object with candidates; adaptive labelling "
                        "holds whole objects out for validation, so it needs at least two")
    rng = np.random.default_rng([spec.seed, 39, 2])
    held = np.sort(rng.permutation(objects)[:min(len(objects) - 1,
                                                 max(1, round(spec.adaptive.validation * len(objects))))])
    quota = np.minimum(counts[np.isin(objects, held)], spec.adaptive.validation_grasps)
    rows = [np.random.default_rng([spec.seed, 39, 3, int(obj)]).choice(np.flatnonzero(owner == obj), q,
                                                                         replace=False)
            for obj, q in zip(held, quota, strict=True)]
    training = {"train": spec.train.model_dump(mode="json", include={"model", "batch_size", "learning_rate"})}
    return RoundsPlan(owner, reader["grasps/code_index"].astype(np.int64), held,
                      np.sort(np.concatenate(rows)), labels_key(spec, reader, None, "adaptive", training))


def round_key(plan: RoundsPlan, number: int, rows: np.ndarray) -> str:
    """Hash of round ``number`` of the plan and of ``rows`` (sorted), what its work depends on."""
    return hashlib.blake2b(f"{plan.key}-{number}".encode() + rows.tobytes(), digest_size=8).hexdigest()


def round_tasks(dataset: str, plan: RoundsPlan, rows: np.ndarray, number: int) -> list[LabelTask]:
    """A round's new rows in the budget's shards of one object each."""
    rows = np.sort(rows)
    return row_shards(dataset, plan.owner, rows, round_key(plan, number, rows), number)


def first_batch(spec: JobSpec, plan: RoundsPlan, limit: int) -> np.ndarray:
    """Round 0: the validation set and, on the other objects, one candidate per code (codes in seeded order)."""
    pool = plan.pool
    size = max(1, min(spec.adaptive.count(spec.adaptive.first, len(plan.owner)), limit - len(plan.validation_rows),
                      len(pool)))
    chosen = pool[first_rows(plan.code[pool], size, np.random.default_rng([spec.seed, 41]))]
    return np.concatenate([plan.validation_rows, chosen])


def next_batch(spec: JobSpec, plan: RoundsPlan, scores: np.ndarray, labelled: np.ndarray, limit: int) -> np.ndarray:
    """The next round's rows: where the network is least sure among the pool's unlabelled candidates."""
    pool = plan.pool
    size = min(spec.adaptive.count(spec.adaptive.batch, len(plan.owner)), limit - len(labelled))
    taken = np.flatnonzero(np.isin(pool, labelled))
    return pool[least_sure(scores[pool], taken, plan.code[pool], size)]


def stop_reason(spec: JobSpec, plan: RoundsPlan, aps: list[float], labelled: int, limit: int) -> str | None:
    """Why the rounds end after the rounds whose validation APs are ``aps`` (None: they go on)."""
    number = len(aps) - 1
    if spec.adaptive.stale(aps) >= spec.adaptive.patience:
        return "patience"
    if number >= spec.adaptive.rounds:
        return "rounds"
    if labelled >= limit:
        return "limit"
    if labelled >= len(plan.pool) + len(plan.validation_rows):
        return "all"
    return None


TrainRound = Callable[["StepRun"], "StepResult"]  # noqa: F821 - learn.train's, loaded where the trainer trains
LabelShards = Callable[[list[LabelTask]], list[ShardResult]]


@dataclass(frozen=True)
class RoundOutcome:
    scores: np.ndarray
    round: AdaptiveRound


def train_round(spec: JobSpec, plan: RoundsPlan, parts: PartStore, number: int, labelled: np.ndarray,
                warm_start: str | None, train: TrainRound) -> RoundOutcome:
    """Round ``number``'s network on the labels so far (labelled/grasps), its validation AP and every candidate's
    score; once: a part keyed by the rows it trained on holds them for a resumed job."""
    from onepiece_dist.learn.train import StepRun

    key = "round-" + round_key(plan, number, np.sort(labelled))
    checkpoint = parts.folder / "rounds" / f"{key}.pt"
    if not (parts.is_committed(key) and checkpoint.is_file()):
        run = StepRun(spec.output, "labelled/grasps", None, spec.output, spec.train.model, spec.adaptive.steps,
                      spec.train.batch_size, spec.train.learning_rate, spec.train.validation, spec.seed,
                      device=spec.train.device, validation_groups=tuple(int(o) for o in plan.validation_objects),
                      warm_start=warm_start, save_to=str(checkpoint), heldout_labelled=False)
        result = train(run)
        weights = {f"{WEIGHT}{name}": array for name, array in checkpoint_arrays(checkpoint).items()}
        parts.write(key, {"scores": result.scores, **weights}, {"validation_ap": result.best_point().validation.ap,
                                                                "best_step": result.best_step,
                                                                "train_seconds": result.train_seconds})
    meta = parts.read_meta(key)
    return RoundOutcome(parts.read_array(key, "scores"), AdaptiveRound(
        round=number, labels=len(labelled), new=0, validation_ap=round(meta["validation_ap"], 4),
        best_step=int(meta["best_step"]), train_seconds=float(meta["train_seconds"]), checkpoint=str(checkpoint),
        part=key))


WEIGHT = "weight."  # a round part's arrays named so hold its network's weights


def checkpoint_arrays(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """A network checkpoint's weights as numpy arrays (loaded with ``weights_only=True``)."""
    from onepiece_dist.learn.train import read_network

    return {name: tensor.numpy() for name, tensor in read_network(path).state_dict.items()}


def round_weights(parts: PartStore, key: str) -> dict[str, np.ndarray]:
    """The weights of the network of the round part ``key``."""
    return {name[len(WEIGHT):]: array for name, array in parts.read(key).items() if name.startswith(WEIGHT)}


def label_in_rounds(spec: JobSpec, status: JobStatus, central, label: LabelShards, train: TrainRound,
                    report: Callable[[JobStatus], None]):
    """Run the rounds; the label report of every label spent. ``central`` writes labelled/grasps after each round
    (its merge_labels) and the rounds' record at the end (record_rounds)."""
    parts = PartStore(spec.parts_folder())
    plan = rounds_plan(spec, DatasetReader(spec.output))
    candidates = len(plan.owner)
    limit = max(len(plan.validation_rows) + 1, spec.adaptive.count(spec.adaptive.limit, candidates))
    record = AdaptiveReport(candidates=candidates, validation_objects=[int(o) for o in plan.validation_objects],
                            validation_labels=len(plan.validation_rows), limit=limit, stopped="", rounds=[])
    tasks: list[LabelTask] = []
    results: list[ShardResult] = []
    labelled, new, scores = np.zeros(0, np.int64), first_batch(spec, plan, limit), []
    aps, warm, reason = [], None, "rounds"
    for number in range(spec.adaptive.rounds + 1):
        batch = round_tasks(spec.output, plan, new, number)
        done = label(batch)
        for task, result in zip(batch, done, strict=True):
            if result.status != "ok":
                raise JobError(f"adaptive round {number}: label shard {result.index} (rows {task.rows[0]}.."
                               f"{task.rows[-1]}): {result.reason}")
        tasks, results = tasks + batch, results + done
        labels = central.merge_labels(tasks, results)
        status.label_seconds = sum(result.made_seconds for result in results)
        labelled = np.sort(np.concatenate([labelled, new]))
        outcome = train_round(spec, plan, parts, number, labelled, warm, train)
        scores.append(outcome.scores)
        warm = outcome.round.checkpoint
        aps.append(outcome.round.validation_ap)
        record.rounds.append(outcome.round.model_copy(update={"new": len(new)}))
        status.adaptive = record
        log.info("job %s: adaptive round %d: %d labels (%d new), validation AP %.3f", status.job_id, number,
                 len(labelled), len(new), aps[-1])
        report(status)
        reason = stop_reason(spec, plan, aps, len(labelled), limit)
        if reason is not None:
            break
        new = next_batch(spec, plan, outcome.scores, labelled, limit)
    record = record.model_copy(update={"stopped": reason})
    status.adaptive = record
    central.record_rounds(record, np.stack(scores))
    return labels
