"""Evaluation of a trained grasp network on objects it never saw: every candidate of the held-out objects labelled
in simulation by the job's protocol (a labelling job through the worker pool), then the network's scores against
those labels: the success of each object's top-ranked candidate beside a random choice, AP and accuracy."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from onepiece_dist.job.status import EvaluationReport, JobStatus
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.stats.intervals import against_a_guess, bootstrap_interval
from onepiece_dist.stats.ranking import SEPARABLE, average_precision, can_separate, per_group_success


def heldout_sim(spec: JobSpec):
    """The job's physics with the evaluation's label protocol: every candidate labelled, K = evaluate.label_trials
    trials, a success only when every trial held."""
    return spec.sim.model_copy(update={"label": True, "label_trials": spec.evaluate.label_trials,
                                       "success": "every_trial"})


def evaluation_spec(spec: JobSpec) -> JobSpec:
    """The job that labels every candidate of ``spec.evaluate.objects`` (seed + 1, beside the dataset), with the
    job's physics and the evaluation's label protocol (:func:`heldout_sim`); no assembly, training or evaluation
    of its own."""
    return spec.model_copy(update={
        "objects": spec.evaluate.objects, "grasps_per_object": spec.evaluate.grasps_per_object,
        "seed": spec.seed + 1, "output": f"{Path(spec.output)}.eval.zarr", "cache_dir": None,
        "stages": ("ingest", "extract", "dedup"), "sim": heldout_sim(spec)})


def objects_scored(status: JobStatus) -> int:
    """Objects of a finished labelling job that were not rejected."""
    return status.progress.objects_done - len(status.rejections)


def protocol_of(spec: JobSpec) -> str:
    sim = spec.sim
    return (f"{sim.label_trials} label trial{'s' * (sim.label_trials > 1)} per candidate, "
            f"{'every one must hold' if sim.success == 'every_trial' else 'the nominal one decides'}")


def verdict(positive_rate: float, top1: float, random_choice: float) -> tuple[bool, str]:
    """Whether held-out candidates with this positive rate can separate a network from a guess, and why."""
    if not can_separate(positive_rate):
        side = "succeed" if positive_rate > SEPARABLE[1] else "fail"
        return False, (f"{positive_rate:.0%} of the held-out candidates {side}: this evaluation cannot separate a "
                       f"network from a guess (top-1 {top1:.2f} against random {random_choice:.2f} says nothing); "
                       "raise evaluate.label_trials or use harder objects")
    return True, (f"{positive_rate:.0%} of the held-out candidates succeed: top-1 {top1:.2f} against random "
                  f"{random_choice:.2f}")


def score_heldout(checkpoint: str | os.PathLike, dataset: str, device: str, objects: int,
                  protocol: str = "") -> EvaluationReport:
    """The network at ``checkpoint`` scored on every labelled grasp of ``dataset`` (on ``device``), judged by
    ``protocol`` (said in the report, with whether the positive rate lets it separate a network from a guess)."""
    from onepiece_dist.learn.dataset import GraspDataset
    from onepiece_dist.learn.train import load_model, predict, resolve_device

    labelled = GraspDataset(dataset, "grasps")
    scores = predict(load_model(checkpoint), labelled, device=resolve_device(device))
    labels = labelled.labels()
    per_top, per_random = per_group_success(scores, labels, labelled.groups)
    top, random = (float(np.mean(per_top)), float(np.mean(per_random))) if len(per_top) else (0.0, 0.0)
    positive = float(labels.mean()) if len(labels) else 0.0
    separable, sentence = verdict(positive, top, random)
    difference, said = against_a_guess(per_top, per_random)
    if separable:
        sentence = (f"{sentence}; top-1 minus random {difference[0]:+.2f} to {difference[1]:+.2f} (95%, objects "
                    f"resampled): {said}")
    return EvaluationReport(objects=objects, grasps=int(len(labels)), positive_rate=positive, top1=top,
                            random_choice=random, ap=average_precision(scores, labels),
                            accuracy=float(np.mean((scores > 0.5) == (labels > 0.5))) if len(labels) else 0.0,
                            checkpoint=str(checkpoint), dataset=dataset, protocol=protocol, separable=separable,
                            verdict=sentence, top1_interval=bootstrap_interval(per_top),
                            random_choice_interval=bootstrap_interval(per_random), above_guess_interval=difference)


def record_evaluation(spec: JobSpec, report: EvaluationReport) -> EvaluationReport:
    """Keep the report in the dataset's ``evaluation`` attribute."""
    from onepiece_dist.store.dataset import update_attributes

    update_attributes(spec.output, {"evaluation": report.model_dump(mode="json")})
    return report


def top_ranked_success(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray) -> tuple[float, float]:
    """Success rate of executing each object's best-scored grasp, and the expected rate of a random one."""
    top, random = per_group_success(scores, labels, groups)
    return (float(np.mean(top)), float(np.mean(random))) if len(top) else (0.0, 0.0)
