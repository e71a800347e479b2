"""Merge rate and memory of the global dedup at 1 M, 5 M and 20 M codes (issue: past one machine).

    .venv/bin/python -m benchmarks.speed.bench_merge [--sizes 1,5,20] [--batch 2000] [--partitions 2]

Synthetic 64-bit codes (the default 10 mm grid, 4 x 8 x 2 voxels) arrive in batches of one object's grasps and
go through the merge path of the central actor: `DedupIndex.add` in process, and the `DatasetWriter` Ray actor
fed as the extraction workers feed it (one `add.remote` per object with its codes); about 57 % are distinct.
Beside it, in the same run:
  - the baseline: the previous index, which re-sorted the whole table on every batch (measured on 1 M codes);
  - partitioned dedup: the codes routed by hash prefix to P `DedupPartition` Ray actors, then unioned;
  - the fallback path that reads each committed part from the store (after an actor restart).
Writes benchmarks/results/bench_merge.json.
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
import psutil

from benchmarks.speed.dedup_partitions import DedupPartition, route_codes
from onepiece_dist.core.dedup import DedupIndex, merge_partitions, merge_unique, unique_codes
from onepiece_dist.runtime.writer import DatasetWriter
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore

HERE = Path(__file__).resolve().parents[1]
CODE_BYTES = 8


def synthetic_batches(total: int, batch: int, seed: int = 0):
    """Batches of (batch, 8) uint8 codes drawn from a pool of 0.8 x total distinct codes (~ 60 % unique)."""
    rng = np.random.default_rng(seed)
    pool = rng.integers(0, 2**63, int(total * 0.8), dtype=np.int64).astype(">u8").view(np.uint8).reshape(-1, 8)
    for start in range(0, total, batch):
        yield pool[rng.integers(0, len(pool), min(batch, total - start))]


def rss() -> int:
    return psutil.Process().memory_info().rss


def central_merge(total: int, batch: int) -> dict:
    index, before = DedupIndex(CODE_BYTES), rss()
    start = time.perf_counter()
    for codes in synthetic_batches(total, batch):
        index.add(codes)
    unique = len(index)
    seconds = time.perf_counter() - start
    return {"codes": total, "unique": unique, "seconds": round(seconds, 2), "codes_per_s": round(total / seconds),
            "state_bytes": index.nbytes(), "rss_growth_bytes": rss() - before}


def resort_baseline(total: int, batch: int) -> dict:
    """The previous DedupIndex: merge_unique of the whole table with each batch."""
    unique, counts = np.zeros((0, CODE_BYTES), np.uint8), np.zeros(0, np.int64)
    start = time.perf_counter()
    for codes in synthetic_batches(total, batch):
        part = unique_codes(codes)
        merged, _ = merge_unique([(unique, counts), (part.unique, part.counts)])
        unique, counts = merged.unique, merged.counts
    seconds = time.perf_counter() - start
    return {"codes": total, "seconds": round(seconds, 2), "codes_per_s": round(total / seconds)}


def partitioned_merge(total: int, batch: int, partitions: int) -> dict:
    """Codes routed to P shard actors (Ray, 1 CPU each would be the cluster setting; 0 here to fit 2 cores)."""
    import ray

    shards = [ray.remote(num_cpus=0)(DedupPartition).remote(CODE_BYTES, k, partitions) for k in range(partitions)]
    ray.get([s.nbytes.remote() for s in shards])
    start, inflight = time.perf_counter(), []
    for codes in synthetic_batches(total, batch * partitions):
        inflight += [s.add.remote(part) for s, part in zip(shards, route_codes(codes, partitions), strict=True)]
        if len(inflight) > 64 * partitions:
            done, inflight = ray.wait(inflight, num_returns=len(inflight) // 2)
    ray.get(inflight)
    states = ray.get([s.state.remote() for s in shards])
    merge_start = time.perf_counter()
    merged = merge_partitions(states, CODE_BYTES)
    end = time.perf_counter()
    shard_bytes = ray.get([s.nbytes.remote() for s in shards])
    for s in shards:
        ray.kill(s)
    return {"codes": total, "partitions": partitions, "unique": len(merged), "seconds": round(end - start, 2),
            "codes_per_s": round(total / (end - start)), "final_union_seconds": round(end - merge_start, 2),
            "largest_shard_state_bytes": max(shard_bytes)}


def central_actor_merge(total: int, batch: int) -> dict:
    """The job's path: each worker sends its object's codes to the DatasetWriter Ray actor (``add.remote``)."""
    import ray

    with tempfile.TemporaryDirectory() as folder:
        spec = JobSpec(output=str(Path(folder) / "ds.zarr"))
        actor = ray.remote(num_cpus=0)(DatasetWriter).remote(spec)
        ray.get(actor.add.remote(-1, "", np.zeros((0, CODE_BYTES), np.uint8)))
        start, inflight = time.perf_counter(), []
        for k, codes in enumerate(synthetic_batches(total, batch)):
            inflight.append(actor.add.remote(k, f"part{k}", codes))
            if len(inflight) > 256:
                _, inflight = ray.wait(inflight, num_returns=128)
        ray.get(inflight)
        seconds = time.perf_counter() - start
        ray.kill(actor)
    return {"codes": total, "seconds": round(seconds, 2), "codes_per_s": round(total / seconds)}


def part_read_overhead(parts: int, batch: int) -> dict:
    """DatasetWriter.add on committed parts (read from the Zarr store, then merged)."""
    with tempfile.TemporaryDirectory() as folder:
        spec = JobSpec(output=str(Path(folder) / "ds.zarr"))
        store = PartStore(f"{spec.output}.parts")
        for k, codes in enumerate(synthetic_batches(parts * batch, batch, seed=1)):
            store.write(f"part{k:05d}", {"code": codes}, {})
        central = DatasetWriter(spec)
        start = time.perf_counter()
        for k in range(parts):
            central.add(k, f"part{k:05d}")
        seconds = time.perf_counter() - start
    return {"parts": parts, "codes": parts * batch, "seconds": round(seconds, 2),
            "ms_per_part": round(1000 * seconds / parts, 2), "codes_per_s": round(parts * batch / seconds)}


def main() -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1,5,20", help="millions of codes")
    parser.add_argument("--batch", type=int, default=2000)
    parser.add_argument("--partitions", type=int, default=2)
    args = parser.parse_args()
    sizes = [int(float(x) * 1_000_000) for x in args.sizes.split(",")]
    central = [central_merge(n, args.batch) for n in sizes]
    baseline = resort_baseline(sizes[0], args.batch)
    from onepiece_dist.runtime.ray_env import connect

    connect(None, num_cpus=os.cpu_count())
    try:
        actor = [central_actor_merge(n, args.batch) for n in sizes]
        partitioned = [partitioned_merge(n, args.batch, args.partitions) for n in sizes]
    finally:
        import ray

        ray.shutdown()
    out = {"benchmark": "bench_merge", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores", "batch": args.batch, "central": central,
           "central_actor": actor,
           "baseline_resort_each_batch": baseline, "partitioned": partitioned,
           "speedup_vs_baseline_at_first_size": round(central[0]["codes_per_s"] / baseline["codes_per_s"], 1),
           "part_read": part_read_overhead(200, args.batch),
           "command": "python -m benchmarks.speed.bench_merge " + " ".join(sys.argv[1:])}
    (HERE / "results" / "bench_merge.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
