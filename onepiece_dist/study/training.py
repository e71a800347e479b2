"""Training every arm of a study: the same network and step budget, each arm at the learning rate its own
validation split picks, several seeds; runs spread over trainer actors and kept in the study's folder, so a study
run again trains only what it had not finished.

Each arm's first-seed run trains at every candidate rate; the arm keeps the rate whose run reached the lowest loss
on its validation split (the loss that also picks the checkpoint), and its other seeds train at that rate.
Held-out scores of the runs not kept are never looked at.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from onepiece_dist.learn.train import StepResult, StepRun

Job = TypeVar("Job")  # a frozen dataclass with ``arm``, ``seed`` and ``learning_rate``
Train = Callable[[list[Any]], list[Any]]  # jobs -> their results, in order
Trainers = Callable[[list[StepRun], Callable[[int, StepResult], None]], list[StepResult]]  # runs, on done -> results


@dataclass(frozen=True)
class ArmRun:
    """One arm's training run at one seed."""

    arm: str
    seed: int
    learning_rate: float
    run: StepRun


def search_rates(jobs: Sequence[Job], rates: Sequence[float], train: Train,
                 loss_of: Callable[[Any], float]) -> tuple[list[Any], dict]:
    """Results of ``jobs`` (in their order), each arm at the rate its validation split picks among ``rates``; and
    the search's record: per arm the chosen rate and every probed rate's lowest validation loss. With one rate
    there is nothing to search: every job trains at it."""
    rates = sorted(set(rates))
    if len(rates) == 1:
        return train([dataclasses.replace(job, learning_rate=rates[0]) for job in jobs]), {}
    first = min(job.seed for job in jobs)
    probes = [dataclasses.replace(job, learning_rate=rate) for job in jobs if job.seed == first for rate in rates]
    probed = {(job.arm, job.learning_rate): run for job, run in zip(probes, train(probes), strict=True)}
    search = {arm: [{"learning_rate": rate, "val_loss": loss_of(probed[(arm, rate)])} for rate in rates]
              for arm in dict.fromkeys(job.arm for job in probes)}
    chosen = {arm: min(rows, key=lambda row: row["val_loss"])["learning_rate"] for arm, rows in search.items()}
    rest = [dataclasses.replace(job, learning_rate=chosen[job.arm]) for job in jobs if job.seed != first]
    trained = iter(train(rest))
    runs = [probed[(job.arm, chosen[job.arm])] if job.seed == first else next(trained) for job in jobs]
    return runs, {arm: {"chosen": chosen[arm], "probes": rows} for arm, rows in search.items()}


def with_rate(job: ArmRun) -> StepRun:
    """The run at the job's rate; a run that keeps its weights keeps them in a file of that rate's."""
    run = dataclasses.replace(job.run, learning_rate=job.learning_rate)
    return dataclasses.replace(run, save_to=weights_at(run.save_to, job.learning_rate)) if run.save_to else run


def weights_at(base: str, rate: float) -> str:
    """Where a run saved under ``base`` (``.../NAME.pt``) at learning rate ``rate`` keeps its weights."""
    return f"{base.removesuffix('.pt')}-lr{rate:g}.pt"


# StepRun fields added after runs were first stored: left out of a run's key while at their defaults, so a run
# stored before they existed is found again (they did not change what such a run computes).
LATER_FIELDS = ("validation_groups", "warm_start", "save_to", "heldout_labelled")


def run_fields(run: StepRun) -> dict:
    """What a run's key digests: its fields, less the later ones at their defaults."""
    defaults = {f.name: f.default for f in dataclasses.fields(StepRun) if f.name in LATER_FIELDS}
    return {k: v for k, v in dataclasses.asdict(run).items() if not (k in defaults and v == defaults[k])}


class RunStore:
    """Finished step runs kept in ``folder``: metadata as JSON, scores as a plain .npy (never pickled), keyed by
    a digest of the run and of the status files of its datasets (they change whenever a dataset is made again)."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.reused = 0

    def key(self, run: StepRun) -> str:
        digest = hashlib.sha256(json.dumps(run_fields(run), sort_keys=True, default=str).encode())
        for path in (Path(f"{run.path}.status.json"), Path(f"{run.heldout_path}.status.json")):
            digest.update(path.read_bytes() if path.is_file() else b"-")
        return digest.hexdigest()[:24]

    def get(self, run: StepRun) -> StepResult | None:
        key = self.key(run)
        meta, scores = self.folder / f"{key}.json", self.folder / f"{key}.npy"
        if not (meta.is_file() and scores.is_file()):
            return None
        self.reused += 1
        return StepResult.from_json(np.load(scores, allow_pickle=False), json.loads(meta.read_text()))

    def train(self, runs: list[StepRun], trainers: Trainers) -> list[StepResult]:
        """Each run's result: read back when stored, else trained by ``trainers`` and stored as it finishes."""
        found = [self.get(run) for run in runs]
        todo = [run for run, result in zip(runs, found, strict=True) if result is None]
        fresh = iter(trainers(todo, lambda index, result: self.put(todo[index], result)) if todo else [])
        return [result if result is not None else next(fresh) for result in found]

    def put(self, run: StepRun, result: StepResult) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        key = self.key(run)
        np.save(self.folder / f"{key}.npy.tmp.npy", result.scores, allow_pickle=False)
        Path(self.folder / f"{key}.npy.tmp.npy").replace(self.folder / f"{key}.npy")
        (self.folder / f"{key}.json").write_text(json.dumps(result.to_json()))


def train_arms(jobs: list[ArmRun], rates: Sequence[float], store: RunStore, trainers: Trainers
               ) -> tuple[list[tuple[ArmRun, StepResult]], dict]:
    """Every arm run's result, with the learning-rate search; runs found in ``store`` are not trained again, and
    each fresh run is stored as it finishes."""

    def train(batch: list[ArmRun]) -> list[StepResult]:
        return store.train([with_rate(job) for job in batch], trainers)

    results, search = search_rates(jobs, rates, train, StepResult.best_validation_loss)
    chosen = [dataclasses.replace(job, learning_rate=search[job.arm]["chosen"]) if search else
              dataclasses.replace(job, learning_rate=rates[0]) for job in jobs]
    return list(zip(chosen, results, strict=True)), search
