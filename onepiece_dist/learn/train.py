"""Training and evaluation of grasp networks: seeded, early stopping on a validation split by object (never by
grasp), per-epoch metrics, checkpoints as plain state dicts loaded with ``weights_only=True``, resumable."""

from __future__ import annotations

import os
import pickle
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader

from onepiece_dist.errors import CheckpointRejected
from onepiece_dist.learn.dataset import MODEL_INPUTS, ChunkBatchSampler, GraspDataset, collate
from onepiece_dist.learn.metrics import CurvePoint, EpochMetrics, Validation
from onepiece_dist.learn.models import MODELS
from onepiece_dist.specs.job import JobSpec, TrainSpec
from onepiece_dist.stats.ranking import average_precision

LAST, BEST = "last.pt", "best.pt"


@dataclass(frozen=True)
class TrainResult:
    metrics: tuple[EpochMetrics, ...]
    best_checkpoint: Path
    stopped_early: bool
    device: str


def resolve_device(choice: str) -> torch.device:
    """The torch device for ``train.device``: 'auto' is CUDA when this process sees a GPU, else the CPU."""
    if choice == "cuda" and not torch.cuda.is_available():
        raise RuntimeError("train.device='cuda' but this process sees no CUDA GPU (use 'auto' or 'cpu')")
    return torch.device("cuda" if choice == "cuda" or (choice == "auto" and torch.cuda.is_available()) else "cpu")


def to_device(batch: dict[str, torch.Tensor], device: torch.device) -> dict[str, torch.Tensor]:
    return {k: v.to(device, non_blocking=True) for k, v in batch.items()}


def load_checkpoint(path: str | os.PathLike) -> dict:
    """A checkpoint (tensors and plain values only); never unpickles arbitrary objects."""
    return torch.load(path, map_location="cpu", weights_only=True)


@dataclass(frozen=True)
class SavedNetwork:
    """A grasp network's checkpoint as read: the model's name (learn.models.MODELS), its weights, and the crop
    record it was trained on (None in checkpoints older than crop records)."""

    path: str
    model: str
    state_dict: dict
    crop: dict | None

    def build(self) -> torch.nn.Module:
        """The model with these weights, in evaluation mode, on the CPU."""
        model = MODELS[self.model]()
        model.load_state_dict(self.state_dict)
        return model.eval()


def read_network(path: str | os.PathLike) -> SavedNetwork:
    """The network saved at ``path``; :class:`CheckpointRejected` names the file and what is wrong with it."""
    path = str(path)
    try:
        saved = load_checkpoint(path)
    except (OSError, RuntimeError, EOFError, pickle.UnpicklingError) as err:  # a planted pickle lands here too
        why = str(err).splitlines()[0][:200]
        raise CheckpointRejected(f"{path}: not a readable checkpoint ({type(err).__name__}: {why})") from None
    if not isinstance(saved, dict) or "model" not in saved or "state_dict" not in saved:
        raise CheckpointRejected(f"{path}: not a grasp-network checkpoint (no model and state_dict)")
    if saved["model"] not in MODELS:
        raise CheckpointRejected(f"{path}: its model {saved['model']!r} is not one this package builds "
                                 f"({', '.join(sorted(MODELS))}): train it with this version, or upgrade")
    return SavedNetwork(path, saved["model"], saved["state_dict"], saved.get("crop"))


def load_round_model(dataset: str | os.PathLike, number: int) -> torch.nn.Module:
    """The network of adaptive labelling's round ``number``, from the dataset's ``adaptive/round_NNN/`` arrays
    (plain arrays: nothing is unpickled)."""
    import zarr

    root = zarr.open_group(str(dataset), mode="r")
    group = root[f"adaptive/round_{number:03d}"]
    model = MODELS[root.attrs["adaptive"]["model"]]()
    model.load_state_dict({name: torch.from_numpy(np.asarray(array[...])) for name, array in group.arrays()})
    return model.eval()


def load_model(path: str | os.PathLike) -> torch.nn.Module:
    return read_network(path).build()


def predict(model: torch.nn.Module, dataset: GraspDataset, batch_size: int = 256,
            device: torch.device | None = None) -> np.ndarray:
    """Success probabilities (n,) in dataset order, computed on ``device`` (default: the model's)."""
    device = device or next(model.parameters()).device
    model = model.to(device).eval()
    out = []
    with torch.no_grad():
        for start in range(0, len(dataset), batch_size):
            batch = to_device(dataset.batch(np.arange(start, min(start + batch_size, len(dataset)))), device)
            out.append(torch.sigmoid(model(batch).float()).cpu().numpy())
    return np.concatenate(out) if out else np.zeros(0)


def evaluate(model: torch.nn.Module, dataset: GraspDataset) -> Validation:
    labels = dataset.labels().astype(np.float32)
    scores = predict(model, dataset).astype(np.float32)
    loss = torch.nn.functional.binary_cross_entropy(torch.from_numpy(scores).clamp(1e-6, 1 - 1e-6),
                                                    torch.from_numpy(labels)).item() if len(labels) else 0.0
    return Validation(loss, float(np.mean((scores > 0.5) == (labels > 0.5))) if len(labels) else 0.0,
                      average_precision(scores, labels), float(labels.mean()) if len(labels) else 0.0)


def train_model(dataset_path: str | os.PathLike, spec: TrainSpec, checkpoint_dir: str | os.PathLike,
                seed: int = 0, crop: dict | None = None) -> TrainResult:
    """Fit ``spec.model`` on the labelled grasps; resumes from ``checkpoint_dir/last.pt`` if present. ``crop``
    (plain values: the gripper, voxel and point count the crops were cut with) is kept in every checkpoint, so a
    planner crops a camera's cloud the same way and refuses another gripper."""
    torch.manual_seed(seed)
    device = resolve_device(spec.device)
    folder = Path(checkpoint_dir)
    folder.mkdir(parents=True, exist_ok=True)
    group = {"assembled": "assembled/grasps", "all": "grasps", "budget": "labelled/grasps"}[spec.data]
    train_set, val_set = GraspDataset(dataset_path, group, inputs=MODEL_INPUTS[spec.model]).split_by_group(
        spec.validation, seed)
    model = MODELS[spec.model]().to(device)
    optimiser = torch.optim.Adam(model.parameters(), lr=spec.learning_rate)
    state = _resume(folder, model, optimiser)
    loader = DataLoader(train_set, batch_sampler=ChunkBatchSampler(train_set, spec.batch_size, seed),
                        collate_fn=collate, num_workers=spec.loader_workers, pin_memory=device.type == "cuda",
                        persistent_workers=spec.loader_workers > 0)
    loader.batch_sampler.epoch = state["epoch"]
    weighting = "count" if spec.weight_by_count else "none"
    step = TrainStep(model, optimiser, device, spec.precision, patch_weights(dataset_path, group, weighting))
    for epoch in range(state["epoch"], spec.epochs):
        train_loss = _train_epoch(step, loader)
        metrics = EpochMetrics.after(epoch, train_loss, evaluate(model, val_set))
        state["metrics"].append(metrics.to_json())  # plain values: a checkpoint loads with weights_only
        state = _after_epoch(folder, spec, model, optimiser, state, metrics, crop)
        if state["bad_epochs"] >= spec.patience:
            return _result(state, folder, True, device)
    return _result(state, folder, False, device)


def _result(state: dict, folder: Path, stopped_early: bool, device: torch.device) -> TrainResult:
    metrics = tuple(EpochMetrics.from_json(m) for m in state["metrics"])
    return TrainResult(metrics, folder / BEST, stopped_early, device.type)


def patch_weights(dataset_path, group: str, weighting: str) -> torch.Tensor | None:
    """(U,) float32 loss weight per patch of the one object's grasps (mean 1): its code's grasp count
    (``assembled/code_count``, how many extracted grasps the patch's label stands for, with "count") or that
    count's square root ("sqrt"); None with "none" or on grasps of their own objects (every grasp weighs 1)."""
    if weighting not in ("none", "count", "sqrt"):
        raise ValueError(f"patch weighting {weighting!r}: none, sqrt or count")
    if weighting == "none" or not group.startswith("assembled"):
        return None
    import zarr

    root = zarr.open_group(str(dataset_path), mode="r")
    counts = root["assembled/code_count" if "assembled/code_count" in root else "unique/count"][:].astype(np.float64)
    weights = counts if weighting == "count" else np.sqrt(counts)
    return torch.from_numpy((weights / weights.mean()).astype(np.float32))


class TrainStep:
    """One optimiser step on a batch: moved to ``device``, with bf16 autocast when ``precision`` says so, each
    grasp's loss weighted by ``group_weights[group]`` when given."""

    def __init__(self, model: torch.nn.Module, optimiser, device: torch.device, precision: str = "fp32",
                 group_weights: torch.Tensor | None = None):
        self.model, self.optimiser, self.device = model, optimiser, device
        self.autocast = precision == "bf16"
        self.group_weights = None if group_weights is None else group_weights.to(device)

    def __call__(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        batch = to_device(batch, self.device)
        self.optimiser.zero_grad(set_to_none=True)
        with torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=self.autocast):
            logits = self.model(batch)
        weight = None if self.group_weights is None else self.group_weights[batch["group"]]
        loss = torch.nn.functional.binary_cross_entropy_with_logits(logits.float(), batch["label"], weight=weight)
        loss.backward()
        self.optimiser.step()
        return loss.detach()


def _train_epoch(step: TrainStep, loader) -> float:
    step.model.train()
    losses = []
    for batch in loader:
        if len(batch["label"]) < 2:
            continue  # batch norm needs two samples
        losses.append(step(batch))
    return float(torch.stack(losses).mean().item()) if losses else 0.0


def _resume(folder: Path, model, optimiser) -> dict:
    state = {"epoch": 0, "metrics": [], "best_loss": float("inf"), "bad_epochs": 0}
    if (folder / LAST).is_file():
        checkpoint = load_checkpoint(folder / LAST)
        model.load_state_dict(checkpoint["state_dict"])
        optimiser.load_state_dict(checkpoint["optimiser"])
        state = {k: checkpoint[k] for k in state}
        if "rng" in checkpoint:  # dropout draws go on as if never interrupted
            torch.set_rng_state(checkpoint["rng"])
    return state


def _after_epoch(folder: Path, spec: TrainSpec, model, optimiser, state: dict, metrics: EpochMetrics,
                 crop: dict | None = None) -> dict:
    improved = metrics.val_loss < state["best_loss"]
    state = {**state, "epoch": metrics.epoch + 1, "bad_epochs": 0 if improved else state["bad_epochs"] + 1,
             "best_loss": min(state["best_loss"], metrics.val_loss)}
    weights = {name: tensor.detach().cpu() for name, tensor in model.state_dict().items()}  # loads anywhere
    checkpoint = {"model": spec.model, "state_dict": weights, "optimiser": optimiser.state_dict(),
                  "rng": torch.get_rng_state(), **state, **({"crop": crop} if crop else {})}
    if improved:
        torch.save(checkpoint, folder / BEST)
    save_atomically(checkpoint, folder / LAST)
    return state


def save_atomically(checkpoint: dict, path: Path) -> None:
    """``checkpoint`` (tensors and plain values) at ``path``, written whole or not at all."""
    tmp = path.with_name(f".{path.name}.tmp")
    torch.save(checkpoint, tmp)
    os.replace(tmp, path)


@dataclass(frozen=True)
class StepRun:
    """A training run with a budget in gradient steps: ``rows`` of ``group`` in the dataset at ``path`` (None:
    all), batches drawn uniformly from the train split, the checkpoint with the lowest loss on the validation split
    (whole objects or patches) kept, then every grasp of the held-out dataset scored."""

    path: str
    group: str
    rows: tuple[int, ...] | None
    heldout_path: str
    model: str
    steps: int
    batch_size: int
    learning_rate: float
    validation: float
    seed: int
    evaluations: int = 10
    validation_cap: int = 4096  # grasps of the validation split scored at each evaluation (a seeded sample)
    weighting: str = "none"  # the one object's grasps: loss per patch weighted by none, count or sqrt
    device: str = "cpu"
    validation_groups: tuple[int, ...] | None = None  # these objects (or patches) are the validation split
    warm_start: str | None = None  # a checkpoint whose weights the network starts from
    save_to: str | None = None  # where the kept checkpoint is written (a plain state dict)
    heldout_labelled: bool = True  # False: the held-out grasps are candidates without labels, only scored


@dataclass(frozen=True)
class StepResult:
    scores: np.ndarray  # (n,) float32 success probability of every held-out grasp, in dataset order
    curve: tuple[CurvePoint, ...]  # each evaluation of the validation split
    best_step: int
    train_seconds: float
    train_grasps: int
    validation_grasps: int
    device: str

    def to_json(self) -> dict:
        """Every field but the scores, plain values (a study's run store writes it beside them)."""
        return {"curve": [point.to_json() for point in self.curve], "best_step": self.best_step,
                "train_seconds": self.train_seconds, "train_grasps": self.train_grasps,
                "validation_grasps": self.validation_grasps, "device": self.device}

    @classmethod
    def from_json(cls, scores: np.ndarray, values: dict) -> StepResult:
        curve = tuple(CurvePoint.from_json(point) for point in values["curve"])
        return cls(scores, curve, **{k: v for k, v in values.items() if k != "curve"})

    def best_validation_loss(self) -> float:
        return round(min(point.validation.loss for point in self.curve), 5)

    def best_point(self) -> CurvePoint:
        """The evaluation whose checkpoint was kept (the lowest validation loss)."""
        return next(point for point in self.curve if point.step == self.best_step)


IN_MEMORY_BYTES = 2**31  # a train set's arrays up to this size are held in memory while it trains


def fit_steps(run: StepRun) -> StepResult:
    """Train ``run.steps`` gradient steps, keep the best validation checkpoint, score every held-out grasp."""
    import time

    torch.manual_seed(run.seed)
    device = resolve_device(run.device)
    inputs = MODEL_INPUTS[run.model]
    # batches are uniform draws over the train rows: the arrays are held in memory, or each batch would decode
    # about one stored chunk per row
    rows = None if run.rows is None else np.asarray(run.rows, dtype=np.int64)
    full = GraspDataset(run.path, run.group, rows=rows, inputs=inputs, memory_bytes=IN_MEMORY_BYTES)
    train, val = (full.split_by_group(run.validation, run.seed) if run.validation_groups is None
                  else full.split_by_groups(run.validation_groups))
    if len(val) > run.validation_cap:  # the same sample at every evaluation: checkpoints stay comparable
        val = val._subset(np.sort(np.random.default_rng([run.seed, 13]).choice(val.rows, run.validation_cap,
                                                                                 replace=False)))
    model = MODELS[run.model]()
    if run.warm_start is not None:
        model.load_state_dict(load_checkpoint(run.warm_start)["state_dict"])
    model = model.to(device)
    step = TrainStep(model, torch.optim.Adam(model.parameters(), lr=run.learning_rate), device,
                     group_weights=patch_weights(run.path, run.group, run.weighting))
    rng = np.random.default_rng([run.seed, 11])
    best, best_state, curve, start = float("inf"), None, [], time.perf_counter()
    every = max(1, run.steps // run.evaluations)
    for k in range(1, run.steps + 1):
        model.train()
        step(collate(train.batch(np.sort(rng.choice(len(train), min(run.batch_size, len(train)), replace=False)))))
        if k % every == 0 or k == run.steps:
            metrics = evaluate(model, val)
            curve.append(CurvePoint(k, metrics.rounded(4)))
            if metrics.loss < best:
                best, best_state = metrics.loss, {n: t.detach().clone() for n, t in model.state_dict().items()}
    seconds = time.perf_counter() - start
    model.load_state_dict(best_state)
    if run.save_to is not None:
        save_weights(run.model, best_state, Path(run.save_to), crop=dataset_crop(run.path))
    scores = predict(model, GraspDataset(run.heldout_path, "grasps", inputs=inputs, labelled=run.heldout_labelled))
    return StepResult(scores.astype(np.float32), tuple(curve), min(curve, key=lambda c: c.validation.loss).step,
                      round(seconds, 1), len(train), len(val), device.type)


def save_weights(model: str, state_dict: dict, path: Path, crop: dict | None = None) -> None:
    """A checkpoint of the network (name and weights, and with ``crop`` how its crops were cut: a planner's
    GraspScorer reads it), written atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    saved = {"model": model, "state_dict": {n: t.detach().cpu() for n, t in state_dict.items()}}
    save_atomically(saved if crop is None else {**saved, "crop": crop}, path)


def crop_record(spec: JobSpec) -> dict:
    """What a checkpoint keeps of how its training crops were cut (plain values, loadable with weights_only):
    the gripper, the voxel grid, the points per grasp and where the crops came from."""
    return {"gripper": spec.gripper.model_dump(mode="json"), "voxel": spec.voxel.model_dump(mode="json"),
            "points_per_grasp": spec.sim.points_per_grasp, "views": spec.views.model_dump(mode="json")}


def dataset_crop(path: str) -> dict:
    """The crop record of the job that made the dataset at ``path``."""
    import zarr

    return crop_record(JobSpec.model_validate(zarr.open_group(str(path), mode="r").attrs["job_spec"]))
