"""Training with a budget in gradient steps, held-out scoring and the statistics of benchmarks/paper_experiment.py.

Every arm trains the same network for the same number of gradient steps; the checkpoint kept is the one with the
lowest loss on the arm's own validation split (whole objects for A and R, whole patches for B), as is the
learning rate (benchmarks/experiment_train.py); nothing is chosen on the held-out objects.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

IN_MEMORY_BYTES = 2**31  # a train set's arrays up to this size are held in memory while it trains


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

    from onepiece_dist.learn.dataset import MODEL_INPUTS, GraspDataset, collate
    from onepiece_dist.learn.models import MODELS
    from onepiece_dist.learn.train import TrainStep, evaluate, predict

    torch.set_num_threads(1)
    torch.manual_seed(job.seed)
    inputs = MODEL_INPUTS[job.model]
    # batches are uniform draws over the train rows: the arrays are held in memory (A's points: about 220 MB),
    # or each batch would decode about one stored chunk per row
    full = GraspDataset(job.path, job.group, rows=job.rows, inputs=inputs, memory_bytes=IN_MEMORY_BYTES)
    train, val = full.split_by_group(job.validation, job.seed)
    if len(val) > job.validation_cap:  # the same sample at every evaluation: checkpoints stay comparable
        val = val._subset(np.sort(np.random.default_rng([job.seed, 13]).choice(val.rows, job.validation_cap,
                                                                                 replace=False)))
    model = MODELS[job.model]()
    step = TrainStep(model, torch.optim.Adam(model.parameters(), lr=job.learning_rate), torch.device("cpu"),
                     group_weights=patch_weights(job))
    rng = np.random.default_rng([job.seed, 11])
    best, best_state, curve, start = float("inf"), None, [], time.perf_counter()
    every = max(1, job.steps // job.evaluations)
    for k in range(1, job.steps + 1):
        model.train()
        step(collate(train.batch(np.sort(rng.choice(len(train), min(job.batch_size, len(train)), replace=False)))))
        if k % every == 0 or k == job.steps:
            metrics = evaluate(model, val)
            curve.append({"step": k, **{f"val_{key}": round(value, 4) for key, value in metrics.items()}})
            if metrics["loss"] < best:
                best, best_state = metrics["loss"], {n: t.detach().clone() for n, t in model.state_dict().items()}
    seconds = time.perf_counter() - start
    model.load_state_dict(best_state)
    heldout = GraspDataset(job.heldout_path, "grasps", inputs=inputs)
    scores = predict(model, heldout)
    return {"arm": job.arm, "seed": job.seed, "train_grasps": len(train), "validation_grasps": len(val),
            "train_seconds": round(seconds, 1), "best_step": min(curve, key=lambda c: c["val_loss"])["step"],
            "curve": curve, "scores": scores.astype(np.float32)}


def patch_weights(job: TrainJob):
    """(U,) float32 tensor of loss weights per patch of a B arm's one object (mean 1): its code's grasp count
    (``unique/count``: how many extracted grasps the patch's label stands for) or that count's square root; None
    for "none" or a dataset of grasps on their own objects."""
    import torch
    import zarr

    if job.patch_weighting == "none" or not job.group.startswith("assembled"):
        return None
    counts = zarr.open_group(job.path, mode="r")["unique/count"][:].astype(np.float64)
    if job.patch_weighting not in ("count", "sqrt"):
        raise ValueError(f"patch_weighting {job.patch_weighting!r}: none, sqrt or count")
    weights = counts if job.patch_weighting == "count" else np.sqrt(counts)
    return torch.from_numpy((weights / weights.mean()).astype(np.float32))


def heldout_metrics(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray) -> dict:
    """Per-object success of the model's best-scored grasp and mean success of its 5 best; AP over all grasps."""
    from onepiece_dist.learn.train import average_precision

    top1, top5 = per_object_top(scores, labels, groups)
    return {"top1": float(top1.mean()), "top5": float(top5.mean()), "ap": average_precision(scores, labels),
            "accuracy": float(np.mean((scores > 0.5) == (labels > 0.5)))}


def per_object_top(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(objects,) success of each object's top-1 grasp and mean success of its top 5, objects in sorted order."""
    top1, top5 = [], []
    for g in np.unique(groups):
        mine = groups == g
        order = np.argsort(-scores[mine], kind="stable")
        top1.append(labels[mine][order[0]])
        top5.append(labels[mine][order[:5]].mean())
    return np.asarray(top1, dtype=np.float64), np.asarray(top5, dtype=np.float64)


def baselines(labels: np.ndarray, groups: np.ndarray) -> dict:
    """Expected success of a random choice per object, and of an oracle (1 when the object has any success)."""
    objects = np.unique(groups)
    return {"random_choice": float(np.mean([labels[groups == g].mean() for g in objects])),
            "oracle": float(np.mean([labels[groups == g].max() for g in objects])),
            "positive_rate": float(labels.mean()), "objects": int(len(objects)), "grasps": int(len(labels))}


def bootstrap_interval(per_object: np.ndarray, seed: int = 0, draws: int = 2000) -> tuple[float, float]:
    """95% percentile interval of the mean of ``per_object`` (objects resampled with replacement)."""
    if len(per_object) == 0:
        return 0.0, 0.0
    rng = np.random.default_rng([seed, 5])
    means = per_object[rng.integers(0, len(per_object), (draws, len(per_object)))].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return float(low), float(high)


def ap_interval(scores: np.ndarray, labels: np.ndarray, groups: np.ndarray, seed: int = 0,
                draws: int = 1000) -> tuple[float, float]:
    """95% percentile interval of the AP of ``scores`` when the held-out objects are resampled with replacement."""
    from onepiece_dist.learn.train import average_precision

    objects = np.unique(groups)
    members = [np.flatnonzero(groups == g) for g in objects]
    rng = np.random.default_rng([seed, 23])
    values = []
    for _ in range(draws):
        rows = np.concatenate([members[k] for k in rng.integers(0, len(objects), len(objects))])
        values.append(average_precision(scores[rows], labels[rows]))
    low, high = np.percentile(values, [2.5, 97.5])
    return float(low), float(high)


def arm_summary(runs: list[dict], labels: np.ndarray, groups: np.ndarray) -> dict:
    """Mean and spread over training seeds; the CI of top-1 over held-out objects, on the seed-averaged
    per-object success."""
    per_seed = [heldout_metrics(run["scores"], labels, groups) for run in runs]
    top1_objects = np.mean([per_object_top(run["scores"], labels, groups)[0] for run in runs], axis=0)
    out = {key: {"mean": float(np.mean([m[key] for m in per_seed])), "std": float(np.std([m[key] for m in per_seed]))}
           for key in ("top1", "top5", "ap", "accuracy")}
    low, high = bootstrap_interval(top1_objects)
    out["top1"]["ci95"] = [round(low, 4), round(high, 4)]
    out["ap"]["ci95"] = [round(x, 4) for x in ap_interval(np.mean([run["scores"] for run in runs], axis=0),
                                                             labels, groups)]
    out["seeds"] = [{"seed": run["seed"], **{k: round(v, 4) for k, v in m.items()}, "best_step": run["best_step"],
                     "train_seconds": run["train_seconds"], "train_grasps": run["train_grasps"]}
                    for run, m in zip(runs, per_seed, strict=True)]
    return out


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


def label_agreement(success_a: np.ndarray, quality_a: np.ndarray, success_b: np.ndarray,
                    quality_b: np.ndarray) -> dict:
    """Success agreement and quality correlation of paired labels (n,) a and (n,) b: the label stage's own
    measure (service/transfer.py), as a plain dict."""
    from onepiece_dist.service.transfer import agreement

    pairs = list(zip(zip(success_a, quality_a, strict=True), zip(success_b, quality_b, strict=True), strict=True))
    return agreement(pairs).model_dump()
