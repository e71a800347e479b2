"""Training with a budget in gradient steps, held-out scoring and the statistics of benchmarks/paper_experiment.py.

Every arm trains the same network for the same number of gradient steps; the checkpoint kept is the one with the
lowest loss on the arm's own validation split (whole objects for A and R, whole patches for B), as is the
learning rate (benchmarks/experiment_train.py); nothing is chosen on the held-out objects. The loop is the
package's (``learn.train.fit_steps``) and the statistics are the study's (``study.stats``); this module adapts the
scripts' dict results to them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.study.stats import (  # noqa: F401  (re-exported for the scripts)
    ap_interval,
    arm_summary,
    baselines,
    bootstrap_interval,
    heldout_metrics,
    label_agreement,
    pair_agreement,
    per_object_top,
)


@dataclass(frozen=True)
class TrainJob:
    """One training run: ``rows`` of ``group`` in the dataset at ``path`` (None: all), scored on the held-out
    dataset's grasps."""

    arm: str
    seed: int
    path: str
    group: str
    rows: np.ndarray | None
    heldout_path: str
    model: str
    steps: int
    batch_size: int
    learning_rate: float
    validation: float
    evaluations: int = 10
    validation_cap: int = 4096  # grasps of the validation split scored at each evaluation (a seeded sample)
    patch_weighting: str = "none"  # B only: each patch's loss weighed by its code's grasp count ("count"), its root
    # ("sqrt"), or not ("none"; benchmarks/experiment_b_variants.py)


def fit_and_score(job: TrainJob) -> dict:
    """Train ``job.steps`` gradient steps, keep the best validation checkpoint, score every held-out grasp.
    Runs on one CPU thread (the experiment runs two of these at once on two cores)."""
    import torch

    from onepiece_dist.learn.train import StepRun, fit_steps

    torch.set_num_threads(1)
    rows = None if job.rows is None else tuple(int(r) for r in job.rows)
    result = fit_steps(StepRun(job.path, job.group, rows, job.heldout_path, job.model, job.steps, job.batch_size,
                               job.learning_rate, job.validation, job.seed, job.evaluations, job.validation_cap,
                               job.patch_weighting))
    return {"arm": job.arm, "seed": job.seed, "train_grasps": result.train_grasps,
            "validation_grasps": result.validation_grasps, "train_seconds": result.train_seconds,
            "best_step": result.best_step, "curve": result.curve, "scores": result.scores}
