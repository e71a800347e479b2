"""A grasp network fitted on pick labels (store.pick_labels, issue 55): crops of the candidates a camera's view
gives, each labelled by executing it on the table, with each grasp's context (gravity and the object's centre in
the gripper frame) where the model reads it.

Validation by object (never by grasp); early stopping on the validation AP; the reported ranking figure is the
validation views' top-1: the share of views whose best-scored candidate picked. The gripper is symmetric under a
half turn about its approach axis: each batch turns a seeded half of its grasps that way (points and context).
Checkpoints hold plain values only (``weights_only`` loads them) and the crop record a planner checks.
"""

from __future__ import annotations

import pickle
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from onepiece_dist.core.cloud.outline import OUTLINE_MODELS
from onepiece_dist.core.cloud.swept_space import SPACE_MODELS, turned_half
from onepiece_dist.learn.models import CONTEXT_MODELS, MODELS
from onepiece_dist.stats.ranking import average_precision, per_group_success
from onepiece_dist.store.pick_labels import PickLabels

HALF_TURN = np.array([1.0, -1.0, -1.0], np.float32)  # (u, v, t) -> (u, -v, -t)


@dataclass(frozen=True)
class PickTrainOptions:
    """How to fit: the model, the target (every trial held, the share of trials that held, or the share of a
    row's executions that picked), whether batches are balanced (as many successes as failures drawn), the weight
    of a listwise ranking term (each batch then holds whole views, and each view's successes are pushed above its
    failures: what the planner's first choice needs), epochs, patience, batch size, the points of each crop the
    network sees (a seeded subset of the stored ones; a planner then resamples its crops to as many), learning rate
    and its schedule (constant with early stopping, or cosine: decayed to zero over every epoch, never stopped
    early, the best epoch kept), the share of objects held out for validation, the seed, and a checkpoint of the
    same model to start from (None: fresh weights)."""

    model: str = "pointnet_context"
    target: str = "every_trial"  # or "share" (of the trials that held), or "draws" (of the executions that picked)
    balanced: bool = False
    ranking: float = 0.0  # weight of the per-view listwise term (0: every candidate on its own)
    epochs: int = 30
    patience: int = 5
    batch_size: int = 256
    points: int = 128  # of each stored crop's, drawn anew every batch; the checkpoint's points_per_grasp
    learning_rate: float = 1e-3
    schedule: str = "constant"  # or "cosine"
    validation: float = 0.1
    seed: int = 0
    start_from: str | None = None  # a checkpoint of the same model whose weights the fit starts from


@dataclass(frozen=True)
class EpochRecord:
    epoch: int
    train_loss: float
    val_ap: float
    val_view_top1: float


@dataclass(frozen=True)
class PickTrainResult:
    """The best checkpoint, every epoch's record, the labels it saw, their success rate, the fit's seconds."""

    checkpoint: Path
    epochs: tuple[EpochRecord, ...]
    labels: int
    success_rate: float
    seconds: float

    @property
    def best(self) -> EpochRecord:
        return max(self.epochs, key=lambda e: (e.val_ap, -e.epoch))


def split_by_object(labels: PickLabels, share: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Row indices of the training and validation objects (a seeded ``share`` of the objects, at least one)."""
    objects = np.unique(labels.object)
    rng = np.random.default_rng([seed, 55])
    held = rng.permutation(objects)[: max(1, int(round(share * len(objects))))]
    val = np.isin(labels.object, held)
    return np.flatnonzero(~val), np.flatnonzero(val)


def _batch(labels: PickLabels, rows: np.ndarray, turn: np.ndarray | None = None,
           points_seen: np.ndarray | None = None) -> dict[str, torch.Tensor]:
    points = labels.points[rows].astype(np.float32)
    if points_seen is not None:
        points = points[:, points_seen]
    context = labels.context[rows].astype(np.float32)
    space = labels.space[rows].astype(np.float32)
    outline = labels.outline[rows].astype(np.float32)
    if turn is not None and turn.any():
        points[turn] *= HALF_TURN
        outline[turn] *= HALF_TURN
        context[turn] *= np.tile(HALF_TURN, context.shape[1] // 3)  # each of its 3-vectors
        if space.shape[1]:
            space[turn] = turned_half(space[turn])
    return {"points": torch.from_numpy(points), "context": torch.from_numpy(context),
            "space": torch.from_numpy(space), "outline": torch.from_numpy(outline)}


def targets(labels: PickLabels, rows: np.ndarray, target: str, trials: int) -> np.ndarray:
    if target == "share":
        return (labels.held[rows].astype(np.float32) / trials).clip(0, 1)
    if target == "draws":  # the share of the row's executions that picked (its success where it had one)
        return labels.picks[rows].astype(np.float32)
    return labels.success[rows].astype(np.float32)


def score_rows(model: torch.nn.Module, labels: PickLabels, rows: np.ndarray, points: int,
               batch: int = 512) -> np.ndarray:
    """Scores of ``rows``, each crop's first ``points`` points (stored resampled in random order)."""
    model.eval()
    out = []
    seen = np.arange(min(points, labels.points.shape[1]))
    with torch.inference_mode():
        for start in range(0, len(rows), batch):
            out.append(torch.sigmoid(model(_batch(labels, rows[start:start + batch], None, seen))).numpy())
    return np.concatenate(out) if out else np.zeros(0)


def view_top1(labels: PickLabels, rows: np.ndarray, scores: np.ndarray) -> float:
    """Share of the views (object, view) among ``rows`` whose best-scored row picked."""
    top, _ = per_group_success(scores, labels.success[rows], view_keys(labels, rows))
    return float(top.mean()) if len(top) else 0.0


def train_on_pick_labels(labels: PickLabels, folder: str | Path, crop: dict,
                         options: PickTrainOptions = PickTrainOptions()) -> PickTrainResult:
    """Fit ``options.model`` on ``labels``; the best epoch's checkpoint is ``folder/best.pt``."""
    start = time.perf_counter()
    torch.manual_seed(options.seed)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if options.model in SPACE_MODELS and labels.space.shape[1] == 0:
        raise ValueError(f"model {options.model!r} reads the hand's swept space, and these pick labels carry none "
                         "(made before labels kept it): make them again with run_pick_labels")
    if options.model in OUTLINE_MODELS and labels.outline.shape[1] == 0:
        raise ValueError(f"model {options.model!r} reads the object's outline, and these pick labels carry none "
                         "(made before labels kept it): make them again with run_pick_labels")
    train, val = split_by_object(labels, options.validation, options.seed)
    model = MODELS[options.model]()
    if options.start_from is not None:
        model.load_state_dict(weights_of(options.start_from, options.model))
    optimiser = torch.optim.Adam(model.parameters(), lr=options.learning_rate)
    trials = int(labels.attrs["spec"]["sim"]["label_trials"])
    rng = np.random.default_rng([options.seed, 56])
    records, best, bad = [], -1.0, 0
    for epoch in range(options.epochs):
        for group in optimiser.param_groups:
            group["lr"] = learning_rate(options, epoch)
        loss = _epoch(model, optimiser, labels, train, options, trials, rng)
        scores = score_rows(model, labels, val, options.points)
        record = EpochRecord(epoch, loss, average_precision(scores, labels.success[val]),
                             view_top1(labels, val, scores))
        records.append(record)
        if record.val_ap > best:
            best, bad = record.val_ap, 0
            torch.save({"model": options.model, "state_dict": model.state_dict(),
                        "crop": {**crop, "points_per_grasp": options.points}, "epoch": epoch,
                        "val_ap": record.val_ap}, folder / "best.pt")
        else:
            bad += 1
            if bad >= options.patience and options.schedule == "constant":
                break
    return PickTrainResult(folder / "best.pt", tuple(records), len(train), float(labels.success[train].mean()),
                           time.perf_counter() - start)


def weights_of(checkpoint: str, model: str) -> dict:
    """The state dict of ``checkpoint`` (loaded weights-only), which must hold a ``model`` network."""
    try:
        saved = torch.load(checkpoint, map_location="cpu", weights_only=True)
    except (RuntimeError, EOFError, pickle.UnpicklingError) as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(f"{checkpoint}: not a checkpoint a fit can start from ({reason}): name a best.pt of "
                         "`onepiece pick-train`") from None
    if not isinstance(saved, dict) or saved.get("model") != model:
        held = saved.get("model") if isinstance(saved, dict) else type(saved).__name__
        raise ValueError(f"{checkpoint}: holds a {held!r} network; a fit of {model!r} cannot start "
                         "from it: name a checkpoint of the same model")
    return saved["state_dict"]


def learning_rate(options: PickTrainOptions, epoch: int) -> float:
    """The learning rate of ``epoch``: constant, or cosine from ``options.learning_rate`` towards zero."""
    if options.schedule == "constant":
        return options.learning_rate
    if options.schedule != "cosine":
        raise ValueError(f"schedule {options.schedule!r}: use 'constant' or 'cosine'")
    return 0.5 * options.learning_rate * (1.0 + np.cos(np.pi * epoch / options.epochs))


def _epoch(model, optimiser, labels: PickLabels, rows: np.ndarray, options: PickTrainOptions, trials: int,
           rng: np.random.Generator) -> float:
    model.train()
    order = (_view_order(labels, rows, rng) if options.ranking else
             _balanced_order(labels, rows, rng) if options.balanced else rng.permutation(rows))
    losses = []
    for start in range(0, len(order) - 1, options.batch_size):
        chunk = order[start:start + options.batch_size]
        if len(chunk) < 2:  # batch norm needs two
            continue
        seen = np.sort(rng.permutation(labels.points.shape[1])[: options.points])
        batch = _batch(labels, chunk, rng.random(len(chunk)) < 0.5, seen)
        if options.model not in CONTEXT_MODELS:
            batch.pop("context")
        if options.model not in SPACE_MODELS:
            batch.pop("space")
        if options.model not in OUTLINE_MODELS:
            batch.pop("outline")
        target = torch.from_numpy(targets(labels, chunk, options.target, trials))
        logits = model(batch)
        loss = torch.nn.functional.binary_cross_entropy_with_logits(logits, target)
        if options.ranking:
            loss = loss + options.ranking * listwise_loss(logits, target, view_keys(labels, chunk))
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        losses.append(loss.item())
    return float(np.mean(losses)) if losses else 0.0


def view_keys(labels: PickLabels, rows: np.ndarray) -> np.ndarray:
    return labels.object[rows].astype(np.int64) * 100_000 + labels.view[rows]


def _view_order(labels: PickLabels, rows: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``rows`` with each view's rows together (in a seeded order) and the views in a seeded order."""
    keys = view_keys(labels, rows)
    views, group = np.unique(keys, return_inverse=True)
    rank = rng.permutation(len(views))[group]
    return rows[np.lexsort((rng.random(len(rows)), rank))]


def listwise_loss(logits: torch.Tensor, target: torch.Tensor, keys: np.ndarray) -> torch.Tensor:
    """Mean over the views in ``keys`` that hold a success and a failure of -log(softmax mass on the successes):
    it is small only where the view's successes score above its failures."""
    terms = []
    for key in np.unique(keys):
        mine = torch.from_numpy(np.flatnonzero(keys == key))
        good = target[mine] > 0.5
        if good.all() or not good.any():
            continue
        scores = logits[mine]
        terms.append(torch.logsumexp(scores, 0) - torch.logsumexp(scores[good], 0))
    return torch.stack(terms).mean() if terms else logits.sum() * 0.0


def _balanced_order(labels: PickLabels, rows: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """As many rows as ``rows``, half successes and half failures (each side drawn with replacement)."""
    good, bad = rows[labels.success[rows]], rows[~labels.success[rows]]
    if len(good) == 0 or len(bad) == 0:
        return rng.permutation(rows)
    half = len(rows) // 2
    return rng.permutation(np.concatenate([rng.choice(good, half), rng.choice(bad, len(rows) - half)]))
