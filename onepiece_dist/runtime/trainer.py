"""The train stage: a trainer (an actor on Ray, asking for a GPU when the cluster has one) fits the grasp
network on the job's labelled grasps and writes its per-epoch metrics to the dataset's ``train/`` group."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from queue import SimpleQueue
from typing import TYPE_CHECKING

import numpy as np

from onepiece_dist.errors import JobError
from onepiece_dist.job.stages.evaluate import evaluation_spec, protocol_of, score_heldout
from onepiece_dist.job.status import EvaluationReport, TrainingReport
from onepiece_dist.runtime.actors import ActorClient, restartable_actor
from onepiece_dist.specs.job import JobSpec

if TYPE_CHECKING:  # torch loads where a trainer trains, not where a job is described
    from onepiece_dist.learn.train import StepResult, StepRun


def checkpoint_dir(spec: JobSpec) -> Path:
    return Path(f"{Path(spec.output)}.train")


class Trainer:
    """Plain class; :class:`TrainerClient` runs it as an actor."""

    def fit(self, spec: JobSpec) -> TrainingReport:
        from onepiece_dist.learn.train import crop_record, train_model
        from onepiece_dist.store.dataset import write_group

        result = train_model(spec.output, spec.train, checkpoint_dir(spec), seed=spec.seed, crop=crop_record(spec))
        rows = [m.to_json() for m in result.metrics]
        keys = [k for k in rows[0] if k != "epoch"] if rows else []
        arrays = {k: np.array([row[k] for row in rows], dtype=np.float32) for k in keys}
        report = TrainingReport(model=spec.train.model, data=spec.train.data, epochs=len(result.metrics),
                                stopped_early=result.stopped_early, checkpoint=str(result.best_checkpoint),
                                device=result.device, final=result.metrics[-1] if result.metrics else None)
        write_group(spec.output, "train", arrays, {"training": report.model_dump(mode="json")})
        return report


    def score(self, spec: JobSpec, dataset: str, objects: int) -> EvaluationReport:
        """The job's trained network (its best checkpoint) scored on the labelled held-out ``dataset``."""
        from onepiece_dist.learn.train import BEST

        checkpoint = checkpoint_dir(spec) / BEST
        if not checkpoint.is_file():
            raise JobError(f"evaluate needs a trained network: {checkpoint} is missing (run the 'train' stage)")
        return score_heldout(checkpoint, dataset, spec.train.device, objects, protocol_of(evaluation_spec(spec)))

    def fit_steps(self, run: StepRun) -> StepResult:
        """One training run with a budget in gradient steps (a study's arm and seed), scored on its held-out set;
        one CPU thread per run on a CPU, so runs beside each other do not share cores."""
        import torch

        from onepiece_dist.learn.train import fit_steps, resolve_device

        if resolve_device(run.device).type == "cpu":
            torch.set_num_threads(1)
        return fit_steps(run)


class TrainerClient(ActorClient):
    """The trainer as a Ray actor: one GPU when ``train.device`` is 'cuda', or 'auto' and the cluster has GPU
    nodes; else one CPU."""

    served = Trainer

    @classmethod
    def start(cls, spec: JobSpec, job_id: str) -> TrainerClient:
        """The job's trainer actor ``trainer-<job>``; restarted by Ray if it dies, and a restarted trainer resumes
        from the last epoch's checkpoint (``last.pt``) when the call is made again."""
        import ray

        gpus = trainer_gpus(spec.train.device, ray.cluster_resources().get("GPU", 0))
        name = f"trainer-{job_id}"
        handle = restartable_actor(Trainer, name, num_gpus=gpus, num_cpus=0 if gpus else 1).remote()
        return cls(handle, f"trainer actor {name}")

    def fit(self, spec: JobSpec) -> TrainingReport:
        return self.call("fit", spec)

    def score(self, spec: JobSpec, dataset: str, objects: int) -> EvaluationReport:
        return self.call("score", spec, dataset, objects)

    @classmethod
    def start_named(cls, name: str, device: str) -> TrainerClient:
        """A trainer actor ``name`` for step runs: one GPU where ``device`` asks for it, else one CPU."""
        import ray

        gpus = trainer_gpus(device, ray.cluster_resources().get("GPU", 0))
        handle = restartable_actor(Trainer, name, num_gpus=gpus, num_cpus=0 if gpus else 1).remote()
        return cls(handle, f"trainer actor {name}")

    def fit_steps(self, run: StepRun) -> StepResult:
        return self.call("fit_steps", run)


def trainers_on_ray(prefix: str, device: str, limit: int) -> list[TrainerClient]:
    """Trainer actors for step runs, as many as the cluster can run at once (its GPUs when it has them and
    ``device`` allows, else its CPUs), at most ``limit``."""
    import ray

    resources = ray.cluster_resources()
    gpus = trainer_gpus(device, resources.get("GPU", 0))
    count = int(resources.get("GPU", 0)) if gpus else int(resources.get("CPU", 1))
    return [TrainerClient.start_named(f"{prefix}-{k}", device) for k in range(max(1, min(count, limit)))]


def run_step_runs(runs: list[StepRun], trainers: list[Callable[[StepRun], StepResult]],
                  done: Callable[[int, StepResult], None] = lambda index, result: None) -> list[StepResult]:
    """Every run's result in the order given, the runs spread over ``trainers`` (each trains one run at a time);
    ``done(index, result)`` is called as each finishes (to keep it before the others end)."""
    todo: SimpleQueue = SimpleQueue()
    for item in enumerate(runs):
        todo.put(item)
    results: list[StepResult | None] = [None] * len(runs)

    def drain(trainer) -> None:
        while not todo.empty():
            index, run = todo.get()
            results[index] = trainer(run)
            done(index, results[index])

    with ThreadPoolExecutor(len(trainers)) as pool:
        for future in [pool.submit(drain, trainer) for trainer in trainers]:
            future.result()
    return results  # type: ignore[return-value]


def trainer_gpus(device: str, cluster_gpus: float) -> int:
    """GPUs the trainer actor asks Ray for."""
    return int(device == "cuda" or (device == "auto" and cluster_gpus >= 1))
