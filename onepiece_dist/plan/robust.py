"""A grasp's score under the pose noise it will be executed with: the network's score of each of a grasp's poses
perturbed as a pick's trials perturb it (core.frames.perturb_poses: a turn about a random axis, a shift), each
crop cut again from the same observation as the planner cuts it (planner.planned_crops). A pick succeeds when every
trial holds, so a grasp whose neighbours score low is one the hand's error can push off its good shape (Dex-Net's
robust quality, estimated by the network instead of by analytic samples)."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.frames import perturb_poses
from onepiece_dist.plan.planner import Proposals, Seen, planned_crops
from onepiece_dist.plan.scorer import CropRecord, GraspScorer


def perturbed_scores(proposals: Proposals, indices: np.ndarray, scorer: GraspScorer, record: CropRecord,
                     samples: int, translation: float, rotation: float, rng: np.random.Generator,
                     batch_size: int | None = None) -> np.ndarray:
    """(len(indices), samples) the network's scores of ``samples`` perturbations of each proposal ``indices``
    (``translation`` m per axis, ``rotation`` rad: std of the pick trials' noise), drawn from ``rng`` all at once
    (every pose's turns, then shifts), cut and scored in one batch."""
    indices = np.asarray(indices, dtype=np.int64)
    if len(indices) == 0 or samples == 0:
        return np.zeros((len(indices), samples), np.float32)
    poses = np.repeat(proposals.poses[indices], samples, axis=0)
    moved = perturb_poses(poses, rng, translation, rotation)
    crops, _ = planned_crops(Seen.of(proposals), moved, record, rng)
    return scorer.score(crops, batch_size).reshape(len(indices), samples)
