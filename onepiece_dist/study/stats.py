"""The statistics of a study, pure numpy: held-out top-1 and top-k per object, average precision (plain and over
tied scores), bootstrap intervals over held-out objects, the agreement of paired labels and how much a shared code
decides the label.

Every interval resamples whole held-out objects (a grasp's label is not independent of its object's other grasps),
seeded so the same scores give the same interval.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.stats.ceiling import threshold_ap  # noqa: F401 - the study's AP over tied scores
from onepiece_dist.stats.intervals import bootstrap_interval, percentile_interval
from onepiece_dist.stats.ranking import average_precision


def per_object_top(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray,
                   k: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """(objects,) success of each object's best-scored grasp and mean success of its ``k`` best, objects in
    sorted order (ties broken by grasp order)."""
    top1, topk = [], []
    for g in np.unique(groups):
        mine = groups == g
        order = np.argsort(-scores[mine], kind="stable")
        top1.append(labels[mine][order[0]])
        topk.append(labels[mine][order[:k]].mean())
    return np.asarray(top1, dtype=np.float64), np.asarray(topk, dtype=np.float64)


def heldout_metrics(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray) -> dict[str, float]:
    """Per-object success of the best-scored grasp (top1) and mean of its 5 best (top5), AP over all grasps and
    accuracy at one half."""
    top1, top5 = per_object_top(scores, labels, groups)
    return {"top1": float(top1.mean()), "top5": float(top5.mean()), "ap": average_precision(scores, labels),
            "accuracy": float(np.mean((scores > 0.5) == (labels > 0.5)))}


def baselines(labels: np.ndarray, groups: np.ndarray) -> dict[str, float | int]:
    """Expected success of a random choice per object, of an oracle (1 when the object has any success), the
    positive rate, and the counts."""
    objects = np.unique(groups)
    return {"random_choice": float(np.mean([labels[groups == g].mean() for g in objects])),
            "oracle": float(np.mean([labels[groups == g].max() for g in objects])),
            "positive_rate": float(labels.mean()), "objects": int(len(objects)), "grasps": int(len(labels))}




def ap_interval(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray, seed: int = 0, draws: int = 1000,
                confidence: float = 0.95) -> tuple[float, float]:
    """Percentile interval of the AP of ``scores`` when the held-out objects are resampled with replacement."""
    objects = np.unique(groups)
    members = [np.flatnonzero(groups == g) for g in objects]
    rng = np.random.default_rng([seed, 23])
    values = []
    for _ in range(draws):
        rows = np.concatenate([members[k] for k in rng.integers(0, len(objects), len(objects))])
        values.append(average_precision(scores[rows], labels[rows]))
    return percentile_interval(values, confidence)


def arm_summary(runs: list[dict], labels: np.ndarray, groups: np.ndarray, draws: int = 2000, ap_draws: int = 1000,
                confidence: float = 0.95) -> dict:
    """Mean and spread over training seeds (``runs``: dicts with ``scores``, ``seed``, ``best_step``,
    ``train_seconds``, ``train_grasps``); the interval of top-1 over held-out objects on the seed-averaged
    per-object success, and of AP on the seed-averaged scores."""
    per_seed = [heldout_metrics(run["scores"], labels, groups) for run in runs]
    top1_objects = np.mean([per_object_top(run["scores"], labels, groups)[0] for run in runs], axis=0)
    out = {key: {"mean": float(np.mean([m[key] for m in per_seed])), "std": float(np.std([m[key] for m in per_seed]))}
           for key in ("top1", "top5", "ap", "accuracy")}
    low, high = bootstrap_interval(top1_objects, draws=draws, confidence=confidence)
    out["top1"]["ci95"] = [round(low, 4), round(high, 4)]
    out["ap"]["ci95"] = [round(x, 4) for x in ap_interval(np.mean([run["scores"] for run in runs], axis=0),
                                                             labels, groups, draws=ap_draws, confidence=confidence)]
    out["seeds"] = [{"seed": run["seed"], **{k: round(v, 4) for k, v in m.items()}, "best_step": run["best_step"],
                     "train_seconds": run["train_seconds"], "train_grasps": run["train_grasps"]}
                    for run, m in zip(runs, per_seed, strict=True)]
    return out


def label_agreement(success_a: np.ndarray, quality_a: np.ndarray, success_b: np.ndarray,
                    quality_b: np.ndarray) -> dict:
    """Success agreement and quality correlation (None when either side is constant) of paired labels."""
    success_a, success_b = np.asarray(success_a, np.float64), np.asarray(success_b, np.float64)
    quality_a, quality_b = np.asarray(quality_a, np.float64), np.asarray(quality_b, np.float64)
    if len(success_a) == 0:
        return {"pairs": 0, "success_agreement": None, "quality_correlation": None}
    agree = float(np.mean((success_a > 0.5) == (success_b > 0.5)))
    spread = quality_a.std() > 0 and quality_b.std() > 0
    corr = float(np.corrcoef(quality_a, quality_b)[0, 1]) if spread else None
    return {"pairs": int(len(success_a)), "success_agreement": round(agree, 4),
            "quality_correlation": None if corr is None else round(corr, 4)}


def pair_agreement(success: np.ndarray, quality: np.ndarray, cluster: np.ndarray, seed: int,
                   per_cluster: int = 5) -> dict:
    """How much a shared cluster (code) decides the label: over pairs (first member, each of up to
    ``per_cluster - 1`` others) of every cluster with two or more grasps, and over as many random pairs of grasps
    in different clusters: success agreement and quality correlation."""
    rng = np.random.default_rng([seed, 13])
    order = np.argsort(cluster, kind="stable")
    starts = np.flatnonzero(np.r_[True, cluster[order][1:] != cluster[order][:-1]])
    ends = np.r_[starts[1:], len(order)]
    firsts, others = [], []
    for a, b in zip(starts, ends, strict=True):
        for k in range(a + 1, min(b, a + per_cluster)):
            firsts.append(order[a])
            others.append(order[k])
    i, j = np.asarray(firsts, dtype=np.int64), np.asarray(others, dtype=np.int64)
    same = label_agreement(success[i], quality[i], success[j], quality[j])
    n = max(len(firsts), 1)
    i, j = rng.integers(0, len(cluster), n), rng.integers(0, len(cluster), n)
    keep = cluster[i] != cluster[j]
    i, j = i[keep], j[keep]
    return {"same_code": same, "random_pairs": label_agreement(success[i], quality[i], success[j], quality[j])}


def share_decided(same: float | None, floor: float | None, repeatability: float | None) -> float | None:
    """How much of the label a shared key decides: the same-key agreement's lift over the floor (random pairs),
    scaled by the headroom the label's own repeatability leaves; None when a figure is missing or there is no
    headroom."""
    if same is None or floor is None or repeatability is None or repeatability - floor <= 1e-9:
        return None
    return round((same - floor) / (repeatability - floor), 4)
