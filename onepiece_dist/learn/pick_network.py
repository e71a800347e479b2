"""A network that picks, fitted for the user's own objects and gripper (issue 55): pick labels (store.pick_labels,
made by picks.pick_labels: each object settled on the table, seen by a camera, the planner's candidates executed by
the pick protocol) fitted by one of the pick learning curve's designs (docs/picks.md; the shipped networks' by
default), and what its validation views say of it: how often each view's best-scored candidate picked, against a
random choice of the same views, with an interval over the validation objects."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from onepiece_dist.learn.models import MODELS
from onepiece_dist.learn.pick_train import (
    PickTrainOptions,
    PickTrainResult,
    score_rows,
    split_by_object,
    train_on_pick_labels,
    view_keys,
    weights_of,
)
from onepiece_dist.stats.intervals import against_a_guess
from onepiece_dist.stats.ranking import can_separate, per_group_success
from onepiece_dist.store.pick_labels import PickLabels, read_pick_labels

DESIGNS = {  # the pick learning curve's designs (docs/picks.md): name -> PickTrainOptions fields
    "context": {"model": "pointnet_context"},
    "crop_only": {"model": "pointnet_small"},
    "context_balanced": {"model": "pointnet_context", "balanced": True},
    "context_share": {"model": "pointnet_context", "target": "share"},
    "context_wide": {"model": "pointnet_context_wide"},
    "context_listwise": {"model": "pointnet_context", "ranking": 1.0},
    "context_space": {"model": "pointnet_context_space", "balanced": True},
}
SHIPPED_DESIGN = "context_balanced"  # the design of the networks shipped in plan/networks/
RECORD = "network.json"


def design_options(design: str, seed: int = 0, **fields) -> PickTrainOptions:
    """The fit of ``design`` (DESIGNS) at ``seed``, ``fields`` (PickTrainOptions') over it; ValueError naming the
    designs where it is none of them."""
    if design not in DESIGNS:
        raise ValueError(f"no design {design!r}: the designs are {', '.join(DESIGNS)} (docs/picks.md, the pick "
                         f"learning curve; {SHIPPED_DESIGN} is the shipped networks')")
    return replace(PickTrainOptions(seed=seed), **{**DESIGNS[design], **fields})


def pick_crop(labels: PickLabels) -> dict:
    """The crop record a checkpoint fitted on ``labels`` carries (the planner checks its gripper and voxels)."""
    spec = labels.attrs["spec"]
    return {"gripper": spec["gripper"], "voxel": spec["voxel"], "points_per_grasp": spec["points_per_grasp"],
            "source": "pick_labels"}


@dataclass(frozen=True)
class ValidationPicks:
    """The best checkpoint on the validation objects' views: ``top1``, the share of views whose best-scored
    candidate picked, against ``guess``, a random candidate's expected share; the interval over the objects of
    their difference, and what it says (stats.intervals.against_a_guess, or that the views cannot separate)."""

    objects: int
    views: int
    top1: float
    guess: float
    above_guess: tuple[float, float]
    verdict: str

    @classmethod
    def of(cls, labels: PickLabels, rows: np.ndarray, scores: np.ndarray) -> ValidationPicks:
        keys = view_keys(labels, rows)
        first, guess = per_group_success(scores, labels.success[rows], keys)  # a view each, in sorted order
        views, opening = np.unique(keys, return_index=True)
        owner = labels.object[rows[opening]]
        objects = np.unique(owner)
        per_top = np.array([first[owner == o].mean() for o in objects])
        per_guess = np.array([guess[owner == o].mean() for o in objects])
        difference, verdict = against_a_guess(per_top, per_guess)
        top1, chance = (float(first.mean()), float(guess.mean())) if len(views) else (0.0, 0.0)
        if not can_separate(chance):
            verdict = (f"a random candidate of these views picks {chance:.0%}: they cannot tell a network from a "
                       "guess")
        return cls(len(objects), len(views), top1, chance, difference, verdict)

    def sentence(self) -> str:
        low, high = self.above_guess
        return (f"on {self.views} views of {self.objects} validation objects the best-scored candidate picked "
                f"{self.top1:.0%}, a random one {self.guess:.0%}: top-1 minus random {low:+.2f} to {high:+.2f} "
                f"(95%, objects resampled): {self.verdict}")


@dataclass(frozen=True)
class PickNetwork:
    """A fitted network (``result.checkpoint``), its design, what its validation views say of it, and the
    checkpoint its fit started from (None: fresh weights)."""

    design: str
    result: PickTrainResult
    validation: ValidationPicks
    labels: str
    start_from: str | None = None

    def to_json(self) -> dict:
        started = {} if self.start_from is None else {"start_from": self.start_from}
        return {"checkpoint": str(self.result.checkpoint), "design": self.design, "labels": self.labels, **started,
                "training_rows": self.result.labels, "success_rate": round(self.result.success_rate, 4),
                "best_epoch": asdict(self.result.best), "epochs": len(self.result.epochs),
                "validation": {**asdict(self.validation), "above_guess": list(self.validation.above_guess)}}


def train_pick_network(labels_path: str | Path, folder: str | Path, options: PickTrainOptions,
                       design: str = SHIPPED_DESIGN) -> PickNetwork:
    """``options`` (design_options) fitted on the pick labels at ``labels_path``; ``folder/best.pt`` and
    ``folder/network.json`` (what it is and what its validation views say) written."""
    if options.start_from is not None:
        weights_of(options.start_from, options.model)  # refused before any work where it cannot start the fit
    labels = read_pick_labels(labels_path)
    if len(labels) == 0:
        raise ValueError(f"{labels_path}: these pick labels hold no row (every object rejected or no view held a "
                         "candidate: see its objects); label other objects")
    train, _ = split_by_object(labels, options.validation, options.seed)
    if len(train) == 0:
        raise ValueError(f"{labels_path}: labels of {len(np.unique(labels.object))} object(s), and a validation share "
                         f"of {options.validation:g} holds them all out: no object is left to train on (label more "
                         "objects, or give a smaller validation share)")
    result = train_on_pick_labels(labels, folder, pick_crop(labels), options)
    network = PickNetwork(design, result, validation_of(labels, result.checkpoint, options), str(labels_path),
                          options.start_from)
    (Path(folder) / RECORD).write_text(json.dumps(network.to_json(), indent=1) + "\n")
    return network


def validation_of(labels: PickLabels, checkpoint: Path, options: PickTrainOptions) -> ValidationPicks:
    """What the validation views (the fit's split) say of ``checkpoint``."""
    _, val = split_by_object(labels, options.validation, options.seed)
    model = MODELS[options.model]()
    model.load_state_dict(weights_of(str(checkpoint), options.model))
    return ValidationPicks.of(labels, val, score_rows(model, labels, val, options.points))


__all__ = ["DESIGNS", "SHIPPED_DESIGN", "PickNetwork", "ValidationPicks", "design_options", "pick_crop",
           "train_pick_network", "validation_of"]
