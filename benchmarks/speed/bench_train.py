"""Training throughput: samples/s of full training steps (forward, backward, Adam) fed from the Zarr store through
the DataLoader (our reader: ``__getitems__`` per batch, ``ChunkBatchSampler``) against the same tensors already in
host memory, per model, measured in the same run.

Run: .venv/bin/python -m benchmarks.speed.bench_train                      (CPU here; writes results/train_cpu.json)
     python -m benchmarks.speed.bench_train --device cuda --rows 200000 --workers 12   (a GPU machine: train_gpu.json)
Needs numpy, zarr and torch only (the reader-only set), so it runs on a GPU machine without ray or pybullet.
The dataset is synthetic (random 750-point float16 clouds, which compress worse than real ones: a harder read).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader

from onepiece_dist.learn.dataset import MODEL_INPUTS, ChunkBatchSampler, GraspDataset, collate
from onepiece_dist.learn.models import MODELS
from onepiece_dist.learn.train import TrainStep
from tests.factories import synthetic_labelled_dataset

RESULTS = Path(__file__).resolve().parents[1] / "results"
POINTS = 750


def in_memory(dataset: GraspDataset, device: torch.device) -> dict[str, torch.Tensor]:
    """Every row of the dataset as host tensors (pinned when feeding a GPU)."""
    batch = dataset.__getitems__(np.arange(len(dataset)))
    return {k: v.pin_memory() if device.type == "cuda" else v for k, v in batch.items()}


def timed(batches, step: TrainStep, seconds: float, warmup: int) -> dict:
    """Run ``step`` on batches from the endless iterator ``batches``: ``warmup`` steps, then as many as fit in
    ``seconds``. Returns samples/s over the timed steps."""
    for _ in range(warmup):
        step(next(batches))
    sync(step.device)
    samples, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        batch = next(batches)
        step(batch)
        samples += len(batch["label"])
    sync(step.device)
    elapsed = time.perf_counter() - start
    return {"samples": samples, "seconds": round(elapsed, 2), "samples_per_s": round(samples / elapsed)}


def sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize()


def memory_batches(tensors: dict[str, torch.Tensor], batch: int, seed: int):
    rng = np.random.default_rng(seed)
    n = len(tensors["label"])
    while True:
        rows = torch.from_numpy(rng.integers(0, n, batch))
        yield {k: v[rows] for k, v in tensors.items()}


def store_batches(dataset: GraspDataset, batch: int, workers: int, device: torch.device, seed: int):
    loader = DataLoader(dataset, batch_sampler=ChunkBatchSampler(dataset, batch, seed), collate_fn=collate,
                        num_workers=workers, pin_memory=device.type == "cuda", persistent_workers=workers > 0,
                        prefetch_factor=4 if workers else None)
    while True:
        for item in loader:
            if len(item["label"]) == batch:
                yield item


def measure(path: Path, model: str, batch: int, device: torch.device, precision: str, workers: int,
            seconds: float) -> dict:
    dataset = GraspDataset(path, inputs=MODEL_INPUTS[model])
    torch.manual_seed(0)
    net = MODELS[model]().to(device).train()
    step = TrainStep(net, torch.optim.Adam(net.parameters(), lr=1e-3), device, precision)
    memory = timed(memory_batches(in_memory(dataset, device), batch, 0), step, seconds, warmup=3)
    store = timed(store_batches(dataset, batch, workers, device, 0), step, seconds, warmup=3)
    return {"model": model, "batch": batch, "precision": precision, "loader_workers": workers,
            "in_memory": memory, "store": store,
            "store_over_memory": round(store["samples_per_s"] / memory["samples_per_s"], 3)}


def reader_only(path: Path, model: str, batch: int, workers: int, seconds: float) -> dict:
    """Batches/s the store path delivers with no training step: the reader's ceiling."""
    dataset = GraspDataset(path, inputs=MODEL_INPUTS[model])
    batches = store_batches(dataset, batch, workers, torch.device("cpu"), 1)
    next(batches)
    samples, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        samples += len(next(batches)["label"])
    return {"model": model, "batch": batch, "loader_workers": workers,
            "samples_per_s": round(samples / (time.perf_counter() - start))}


def machine(device: torch.device) -> str:
    cores = f"{os.cpu_count()} cores"
    if device.type == "cuda":
        return f"{torch.cuda.get_device_name(0)}, {cores}, torch {torch.__version__}"
    return f"{platform.machine()} CPU, {cores}, torch {torch.__version__}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu", choices=["cpu", "cuda"])
    parser.add_argument("--rows", type=int, default=20_000, help="rows; clouds over 64 MiB (15,000 rows) are read "
                        "from the store per batch, smaller arrays are held in memory by the reader")
    parser.add_argument("--workers", type=int, default=0, help="DataLoader workers of the store path")
    parser.add_argument("--seconds", type=float, default=15.0, help="timed seconds per measurement")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    device = torch.device(args.device)
    gpu = device.type == "cuda"
    runs = ([("pointnet", 1024, "fp32"), ("pointnet", 4096, "fp32"), ("pointnet", 4096, "bf16"),
             ("voxel", 4096, "fp32"), ("voxel", 4096, "bf16")] if gpu else
            [("pointnet", 64, "fp32"), ("voxel", 256, "fp32")])
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        path = synthetic_labelled_dataset(Path(folder) / "bench.zarr", rows=args.rows, points=POINTS)
        written = time.perf_counter() - start
        rows = [measure(path, model, batch, device, precision, args.workers, args.seconds)
                for model, batch, precision in runs]
        reader = [reader_only(path, model, batch, args.workers, args.seconds / 2)
                  for model, batch in sorted({(m, b) for m, b, _ in runs})]
    result = {"command": "python -m benchmarks.speed.bench_train " + " ".join(sys.argv[1:]), "date": str(date.today()),
              "machine": machine(device), "device": args.device, "rows": args.rows, "points": POINTS,
              "dataset_write_seconds": round(written, 1), "runs": rows, "reader_only": reader,
              "targets": {"store_over_memory_cpu": 0.8, "pointnet_store_samples_per_s_gpu": 50_000}}
    out = args.out or RESULTS / f"train_{'gpu' if gpu else 'cpu'}.json"
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
