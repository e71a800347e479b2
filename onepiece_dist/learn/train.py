"""Training and evaluation of grasp networks: seeded, early stopping on a validation split by object (never by
grasp), per-epoch metrics, checkpoints as plain state dicts loaded with ``weights_only=True``, resumable."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader

from onepiece_dist.learn.dataset import ChunkBatchSampler, GraspDataset, collate
from onepiece_dist.learn.models import MODELS
from onepiece_dist.spec import TrainSpec

LAST, BEST = "last.pt", "best.pt"


@dataclass(frozen=True)
class TrainResult:
    metrics: list[dict]
    best_checkpoint: Path
    stopped_early: bool


def average_precision(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the precision-recall curve (step interpolation); 0 when there is no positive."""
    positives = labels.sum()
    if positives == 0:
        return 0.0
    order = np.argsort(-scores, kind="stable")
    hits = labels[order]
    precision = np.cumsum(hits) / np.arange(1, len(hits) + 1)
    return float(np.sum(precision * hits) / positives)


def load_checkpoint(path: str | os.PathLike) -> dict:
    """A checkpoint (tensors and plain values only); never unpickles arbitrary objects."""
    return torch.load(path, map_location="cpu", weights_only=True)


def load_model(path: str | os.PathLike) -> torch.nn.Module:
    checkpoint = load_checkpoint(path)
    model = MODELS[checkpoint["model"]]()
    model.load_state_dict(checkpoint["state_dict"])
    return model.eval()


def predict(model: torch.nn.Module, dataset: GraspDataset, batch_size: int = 256) -> np.ndarray:
    """Success probabilities (n,) in dataset order."""
    model.eval()
    out = []
    with torch.no_grad():
        for start in range(0, len(dataset), batch_size):
            batch = collate(dataset.batch(np.arange(start, min(start + batch_size, len(dataset)))))
            out.append(torch.sigmoid(model(batch)).numpy())
    return np.concatenate(out) if out else np.zeros(0)


def evaluate(model: torch.nn.Module, dataset: GraspDataset) -> dict:
    labels = dataset.labels().astype(np.float32)
    scores = predict(model, dataset).astype(np.float32)
    loss = torch.nn.functional.binary_cross_entropy(torch.from_numpy(scores).clamp(1e-6, 1 - 1e-6),
                                                    torch.from_numpy(labels)).item() if len(labels) else 0.0
    return {"loss": loss, "accuracy": float(np.mean((scores > 0.5) == (labels > 0.5))) if len(labels) else 0.0,
            "ap": average_precision(scores, labels), "positives": float(labels.mean()) if len(labels) else 0.0}


def train_model(dataset_path: str | os.PathLike, spec: TrainSpec, checkpoint_dir: str | os.PathLike,
                seed: int = 0) -> TrainResult:
    """Fit ``spec.model`` on the labelled grasps; resumes from ``checkpoint_dir/last.pt`` if present."""
    torch.manual_seed(seed)
    folder = Path(checkpoint_dir)
    folder.mkdir(parents=True, exist_ok=True)
    group = "assembled/grasps" if spec.data == "assembled" else "grasps"
    train_set, val_set = GraspDataset(dataset_path, group).split_by_group(spec.validation, seed)
    model = MODELS[spec.model]()
    optimiser = torch.optim.Adam(model.parameters(), lr=spec.learning_rate)
    state = _resume(folder, model, optimiser)
    loader = DataLoader(train_set, batch_sampler=ChunkBatchSampler(train_set, spec.batch_size, seed),
                        collate_fn=collate)
    loader.batch_sampler.epoch = state["epoch"]
    for epoch in range(state["epoch"], spec.epochs):
        train_loss = _train_epoch(model, optimiser, loader)
        metrics = {"epoch": epoch, "train_loss": train_loss, **{f"val_{k}": v for k, v in
                                                                 evaluate(model, val_set).items()}}
        state["metrics"].append(metrics)
        state = _after_epoch(folder, spec, model, optimiser, state, metrics)
        if state["bad_epochs"] >= spec.patience:
            return TrainResult(state["metrics"], folder / BEST, True)
    return TrainResult(state["metrics"], folder / BEST, False)


def _train_epoch(model, optimiser, loader) -> float:
    model.train()
    losses = []
    for batch in loader:
        if len(batch["label"]) < 2:
            continue  # batch norm needs two samples
        optimiser.zero_grad()
        loss = torch.nn.functional.binary_cross_entropy_with_logits(model(batch), batch["label"])
        loss.backward()
        optimiser.step()
        losses.append(loss.item())
    return float(np.mean(losses)) if losses else 0.0


def _resume(folder: Path, model, optimiser) -> dict:
    state = {"epoch": 0, "metrics": [], "best_loss": float("inf"), "bad_epochs": 0}
    if (folder / LAST).is_file():
        checkpoint = load_checkpoint(folder / LAST)
        model.load_state_dict(checkpoint["state_dict"])
        optimiser.load_state_dict(checkpoint["optimiser"])
        state = {k: checkpoint[k] for k in state}
    return state


def _after_epoch(folder: Path, spec: TrainSpec, model, optimiser, state: dict, metrics: dict) -> dict:
    improved = metrics["val_loss"] < state["best_loss"]
    state = {**state, "epoch": metrics["epoch"] + 1, "bad_epochs": 0 if improved else state["bad_epochs"] + 1,
             "best_loss": min(state["best_loss"], metrics["val_loss"])}
    checkpoint = {"model": spec.model, "state_dict": model.state_dict(), "optimiser": optimiser.state_dict(),
                  **state}
    if improved:
        torch.save(checkpoint, folder / BEST)
    tmp = folder / f".{LAST}.tmp"
    torch.save(checkpoint, tmp)
    os.replace(tmp, folder / LAST)
    return state
