"""The premise, measured: how far B's one label per shape holds for the grasps that share it, against A's labels
of the very same candidates (A and B sample the same candidates: same objects, seed and sampler), and how much a
shared code decides A's labels."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.core.similar import similar_clusters
from onepiece_dist.job.stages.label_transfer import patch_labels
from onepiece_dist.stats.ceiling import threshold_ap
from onepiece_dist.store import DatasetReader
from onepiece_dist.study.result import LabelFit, Premise
from onepiece_dist.study.stats import label_agreement, pair_agreement, share_decided


def match_rows(b: DatasetReader, a: DatasetReader) -> np.ndarray:
    """(N_b,) row in ``a`` of each grasp of ``b`` with the same object (by name) and candidate pose; -1 if none."""
    a_names, b_names = a.object_names, b.object_names
    a_keys = {(a_names[o], p.tobytes()): k for k, (o, p) in enumerate(zip(a["grasps/object"],
                                                                          a["grasps/candidate_pose"], strict=True))}
    return np.array([a_keys.get((b_names[o], p.tobytes()), -1)
                     for o, p in zip(b["grasps/object"], b["grasps/candidate_pose"], strict=True)], dtype=np.int64)


def label_transfer(a: DatasetReader, b: DatasetReader, seed: int) -> dict:
    """B's patch label against A's label of (a) the patch's representative grasp and (b) every grasp of its code
    or cluster; (c) the floor: the same with the patch labels shuffled across patches. Grasps of B that A did not
    keep are left out (counted)."""
    in_a = match_rows(b, a)
    code_index, representative = b["grasps/code_index"], b["unique/representative"]
    success = np.where(in_a >= 0, a["grasps/success"][np.maximum(in_a, 0)], -1).astype(np.float64)
    quality = np.where(in_a >= 0, a_quality(a)[np.maximum(in_a, 0)], np.nan).astype(np.float64)
    patch_success = np.full(len(representative), np.nan)
    patch_quality = np.full(len(representative), np.nan)
    for k, (patch_s, patch_q) in patch_labels(b).items():  # each patch's label at its placement
        patch_success[k], patch_quality[k] = patch_s, patch_q
    shuffled = np.random.default_rng([seed, 19]).permutation(len(representative))

    def agree(rows: np.ndarray, codes: np.ndarray, order: np.ndarray) -> dict:
        keep = ~np.isnan(patch_success[order][codes]) & (in_a[rows] >= 0)
        rows, codes = rows[keep], codes[keep]
        return label_agreement(patch_success[order][codes], patch_quality[order][codes], success[rows],
                               quality[rows])

    codes, every = np.arange(len(representative)), np.arange(len(code_index))
    kept = ~np.isnan(patch_success[code_index]) & (in_a >= 0)
    p, q = patch_success[code_index][kept].mean(), success[kept].mean()  # labels that ignore the shape agree at:
    return {"matched_grasps": int(np.sum(in_a >= 0)), "unmatched_grasps": int(np.sum(in_a < 0)),
            "patch_vs_representative": agree(representative, codes, codes),
            "patch_vs_every_grasp": agree(every, code_index, codes),
            "shuffled_patches": agree(every, code_index, shuffled),
            "independent_floor": round(float(p * q + (1 - p) * (1 - q)), 4) if kept.any() else None}


def a_quality(a: DatasetReader) -> np.ndarray:
    """A's graded label: the share of trials held, or, where no trial ran (force-closure labels without lifting
    anything), the binary label itself."""
    return a["grasps/quality"] if a.has("grasps/quality") else a["grasps/success"]


def code_clusters(a: DatasetReader, radius: int) -> np.ndarray:
    """(N,) cluster of each of A's grasps: its exact code, merged within Hamming ``radius``."""
    exact = unique_codes(a["grasps/code"])
    nbits = int(np.prod(a.attrs["grid_shape"]))
    return similar_clusters(exact.unique, exact.counts, nbits, radius).cluster[exact.inverse]


def premise(a: DatasetReader, b: DatasetReader, radius: int, seed: int) -> Premise:
    transfer = label_transfer(a, b, seed)
    pairs = pair_agreement(a["grasps/success"].astype(np.float64), a_quality(a).astype(np.float64),
                           code_clusters(a, radius), seed)
    same, floor = pairs["same_code"]["success_agreement"], pairs["random_pairs"]["success_agreement"]
    return Premise(radius=radius, matched_grasps=transfer["matched_grasps"],
                   patch_vs_representative=transfer["patch_vs_representative"]["success_agreement"],
                   patch_vs_every_grasp=transfer["patch_vs_every_grasp"]["success_agreement"],
                   shuffled_patches=transfer["shuffled_patches"]["success_agreement"],
                   same_code=same, random_pairs=floor, share_decided=share_decided(same, floor, 1.0))


def label_fit(heldout: DatasetReader, good_mu: float) -> LabelFit:
    """The force-closure label against physics success on the held-out candidates (they carry both)."""
    physics = heldout["grasps/success"].astype(bool)
    stored = heldout["grasps/fc_mu"]
    closure = stored <= stored.dtype.type(good_mu)  # in the stored precision: a level of 0.6 is stored as 0.6f
    fc_mu = stored.astype(np.float64)
    objects = heldout["grasps/object"].astype(np.int64)
    rank = -np.where(np.isfinite(fc_mu), fc_mu, np.nanmax(fc_mu[np.isfinite(fc_mu)], initial=0.0) + 1.0)
    best = [physics[objects == o][rank[objects == o] == rank[objects == o].max()].mean() for o in np.unique(objects)]
    return LabelFit(label="force_closure", good_mu=good_mu, grasps=int(len(physics)),
                    closure_positive_rate=round(float(closure.mean()), 4),
                    physics_positive_rate=round(float(physics.mean()), 4),
                    agreement=round(float(np.mean(closure == physics)), 4),
                    ap=round(threshold_ap(rank, physics), 4), top1=round(float(np.mean(best)), 4))
