"""The train stage: a trainer (an actor on Ray, asking for a GPU when the cluster has one) fits the grasp
network on the job's labelled grasps and writes its per-epoch metrics to the dataset's ``train/`` group."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from onepiece_dist.spec import JobSpec


def checkpoint_dir(spec: JobSpec) -> Path:
    return Path(f"{Path(spec.output)}.train")


class Trainer:
    """Plain class; :func:`remote_trainer` wraps it as an actor."""

    def fit(self, spec: JobSpec) -> dict:
        import torch

        from onepiece_dist.learn.train import train_model
        from onepiece_dist.store.dataset import write_group

        result = train_model(spec.output, spec.train, checkpoint_dir(spec), seed=spec.seed)
        keys = [k for k in result.metrics[0] if k != "epoch"] if result.metrics else []
        arrays = {k: np.array([m[k] for m in result.metrics], dtype=np.float32) for k in keys}
        summary = {"model": spec.train.model, "data": spec.train.data, "epochs": len(result.metrics),
                   "stopped_early": result.stopped_early, "checkpoint": str(result.best_checkpoint),
                   "device": "cuda" if torch.cuda.is_available() else "cpu",
                   "final": result.metrics[-1] if result.metrics else {}}
        write_group(spec.output, "train", arrays, {"training": summary})
        return summary


def remote_trainer():
    """The trainer as a Ray actor: one GPU when the cluster has one, else one CPU."""
    import ray

    gpus = 1 if ray.cluster_resources().get("GPU", 0) >= 1 else 0
    return ray.remote(Trainer).options(num_gpus=gpus, num_cpus=0 if gpus else 1).remote()
