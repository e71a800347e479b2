"""Evaluation of a trained grasp network on objects it never saw: (a) accuracy and AP against physics labels;
(b) grasp success in simulation when the robot executes the model's top-ranked candidate on each object, next to
the expected success of a random choice among the same candidates."""

from __future__ import annotations

import os

import numpy as np

from onepiece_dist.service.local import run_local
from onepiece_dist.spec import JobSpec


def evaluation_spec(spec: JobSpec) -> JobSpec:
    """The job that labels every candidate of the evaluation objects (no assembly, no training)."""
    return spec.model_copy(update={"stages": ("ingest", "extract", "dedup"),
                                   "sim": spec.sim.model_copy(update={"label": True})})


def evaluate_model(model_path: str | os.PathLike, spec: JobSpec) -> dict:
    """Label the candidates of ``spec.objects`` in simulation, then score the model on them."""
    from onepiece_dist.learn.dataset import GraspDataset
    from onepiece_dist.learn.train import average_precision, load_model, predict, resolve_device

    labelled = evaluation_spec(spec)
    status = run_local(labelled, job_id="evaluate")
    dataset = GraspDataset(labelled.output, "grasps")
    scores = predict(load_model(model_path), dataset, device=resolve_device(spec.train.device))
    labels = dataset.labels()
    top, random = top_ranked_success(scores, labels, dataset.groups)
    return {"objects": status.progress.objects_done - len(status.rejections), "grasps": int(len(labels)),
            "accuracy": float(np.mean((scores > 0.5) == (labels > 0.5))) if len(labels) else 0.0,
            "ap": average_precision(scores, labels), "label_positive_rate": float(labels.mean()) if len(labels) else 0,
            "top_ranked_success": top, "random_choice_success": random, "dataset": labelled.output}


def top_ranked_success(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray) -> tuple[float, float]:
    """Success rate of executing each object's best-scored grasp, and the expected rate of a random one."""
    objects = np.unique(groups)
    if len(objects) == 0:
        return 0.0, 0.0
    top = [labels[groups == g][np.argmax(scores[groups == g])] for g in objects]
    random = [labels[groups == g].mean() for g in objects]
    return float(np.mean(top)), float(np.mean(random))
