"""The train stage: a trainer (an actor on Ray, asking for a GPU when the cluster has one) fits the grasp
network on the job's labelled grasps and writes its per-epoch metrics to the dataset's ``train/`` group."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from onepiece_dist.service.actors import ActorClient, restartable_actor
from onepiece_dist.service.status import TrainingReport
from onepiece_dist.spec import JobSpec


def checkpoint_dir(spec: JobSpec) -> Path:
    return Path(f"{Path(spec.output)}.train")


class Trainer:
    """Plain class; :class:`TrainerClient` runs it as an actor."""

    def fit(self, spec: JobSpec) -> TrainingReport:
        from onepiece_dist.learn.train import train_model
        from onepiece_dist.store.dataset import write_group

        result = train_model(spec.output, spec.train, checkpoint_dir(spec), seed=spec.seed)
        keys = [k for k in result.metrics[0] if k != "epoch"] if result.metrics else []
        arrays = {k: np.array([m[k] for m in result.metrics], dtype=np.float32) for k in keys}
        report = TrainingReport(model=spec.train.model, data=spec.train.data, epochs=len(result.metrics),
                                stopped_early=result.stopped_early, checkpoint=str(result.best_checkpoint),
                                device=result.device,
                                final=result.metrics[-1] if result.metrics else {})
        write_group(spec.output, "train", arrays, {"training": report.model_dump(mode="json")})
        return report


class TrainerClient(ActorClient):
    """The trainer as a Ray actor: one GPU when ``train.device`` is 'cuda', or 'auto' and the cluster has GPU
    nodes; else one CPU."""

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


def trainer_gpus(device: str, cluster_gpus: float) -> int:
    """GPUs the trainer actor asks Ray for."""
    return int(device == "cuda" or (device == "auto" and cluster_gpus >= 1))
