"""Training the arms of benchmarks/paper_experiment.py: two runs at a time, read back from the work folder when
the same job already ran on the same datasets, and the learning-rate search (issue 17: hyper-parameters chosen on a
validation split of the train objects, never on the held-out set).

Each arm's seed-0 run is trained at every candidate rate; the arm keeps the rate whose run reached the lowest loss
on the arm's own validation split (the same loss that picks the checkpoint), and its other seeds train at that
rate. Held-out scores of the runs not kept are never looked at.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks.experiment_learn import TrainJob, fit_and_score
from onepiece_dist.study.training import search_rates

ROOT = Path(__file__).resolve().parents[1]

Train = Callable[[list[TrainJob]], list[dict]]  # jobs -> their runs, in order (train_all on a pool)


def parse_rates(text: str) -> list[float]:
    """Learning rates from a comma-separated list, e.g. '0.0003,0.001,0.003'; at least one, all positive."""
    rates = [float(x) for x in text.split(",") if x.strip()]
    if not rates or min(rates) <= 0:
        raise ValueError(f"--learning-rates {text!r}: give one or more positive rates, comma-separated")
    return sorted(set(rates))


def train_with_search(jobs: list[TrainJob], rates: list[float], train: Train) -> tuple[list[dict], dict]:
    """Runs of ``jobs`` (in their order), each arm at the rate its validation split picks among ``rates``, and the
    search's record (the package's ``study.training.search_rates``, on these scripts' dict runs)."""
    return search_rates(jobs, rates, train, best_validation_loss)


def best_validation_loss(run: dict) -> float:
    """The lowest validation loss a run reached at its evaluations (fit_and_score's ``curve``)."""
    return round(min(point["val_loss"] for point in run["curve"]), 5)


@contextlib.contextmanager
def work_folder(folder: Path | None, prefix: str):
    """``folder`` (made if missing, kept afterwards), or a temporary folder removed afterwards when it is None."""
    work = folder or Path(tempfile.mkdtemp(prefix=prefix))
    work.mkdir(parents=True, exist_ok=True)
    try:
        yield work
    finally:
        if folder is None:
            shutil.rmtree(work, ignore_errors=True)


def spawn_context():
    import multiprocessing

    os.environ["OMP_NUM_THREADS"] = "1"  # inherited by the spawned workers: one core each
    return multiprocessing.get_context("spawn")


def train_all(jobs: list[TrainJob], cache: Path | None, pool: ProcessPoolExecutor) -> list[dict]:
    """Every job's training result (with the job's ``learning_rate``), on the ``pool``'s processes (two, one core
    each); with a kept work folder (``cache``), a job trained before on the very same data and settings is read
    back instead (``_train_key``)."""
    found = [_cached_run(job, cache) for job in jobs]
    todo = [job for job, run in zip(jobs, found, strict=True) if run is None]
    fresh = iter(pool.map(fit_and_score, todo))
    runs = [run if run is not None else next(fresh) for run in found]
    for job, run, old in zip(jobs, runs, found, strict=True):
        if cache is not None and old is None:
            _store_run(job, run, cache)
    return [{**run, "learning_rate": job.learning_rate} for job, run in zip(jobs, runs, strict=True)]


def _train_key(job: TrainJob) -> str:
    """A digest of everything a training result depends on: the job's settings and rows, the status files of its
    train and held-out datasets (they change whenever a dataset is made again) and the training code."""
    digest = hashlib.sha256()
    for name, value in sorted(vars(job).items()):
        digest.update(f"{name}={value.tobytes().hex() if isinstance(value, np.ndarray) else value};".encode())
    for path in (Path(f"{job.path}.status.json"), Path(f"{job.heldout_path}.status.json"),
                 ROOT / "benchmarks" / "experiment_learn.py"):
        digest.update(path.read_bytes() if path.exists() else b"-")
    return digest.hexdigest()[:24]


def _cached_run(job: TrainJob, cache: Path | None) -> dict | None:
    key = _train_key(job) if cache is not None else None
    if key is None or not (cache / f"{key}.json").exists():
        return None
    run = json.loads((cache / f"{key}.json").read_text())
    run["scores"] = np.load(cache / f"{key}.npy", allow_pickle=False)
    return {**run, "reused": True}


def _store_run(job: TrainJob, run: dict, cache: Path) -> None:
    cache.mkdir(parents=True, exist_ok=True)
    key = _train_key(job)
    np.save(cache / f"{key}.npy", run["scores"], allow_pickle=False)
    (cache / f"{key}.json").write_text(json.dumps({k: v for k, v in run.items() if k != "scores"}))
