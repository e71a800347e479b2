"""Dedup throughput: 10 million 64-bit codes on one core, against a pairwise-comparison baseline.

Run: .venv/bin/python -m benchmarks.speed.bench_dedup  (writes benchmarks/results/dedup.json)
The pairwise baseline compares every pair of a sample vectorized row by row and is extrapolated to N.
"""

from __future__ import annotations

import json
import os
import platform
import resource
import time
from datetime import date
from pathlib import Path

import numpy as np

from onepiece_dist.core.dedup import unique_codes

N = int(os.environ.get("BENCH_DEDUP_N", 10_000_000))
SAMPLE = 20_000


def synthetic_codes(n: int, rng: np.random.Generator) -> np.ndarray:
    """64-bit codes with realistic redundancy: a Zipf-like draw from a vocabulary of n/10 shapes."""
    vocab = rng.integers(0, 2**63, n // 10 + 1, dtype=np.int64).view(np.uint8).reshape(-1, 8)
    pick = np.minimum(rng.zipf(1.3, n) - 1, len(vocab) - 1)
    return vocab[pick]


def pairwise_seconds_per_pair(codes: np.ndarray) -> float:
    words = codes.view(np.uint64)[:, 0]
    start = time.perf_counter()
    for i in range(len(words)):
        np.any(words[i + 1:] == words[i])
    pairs = len(words) * (len(words) - 1) / 2
    return (time.perf_counter() - start) / pairs


def main() -> dict:
    rng = np.random.default_rng(0)
    codes = synthetic_codes(N, rng)
    base_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    result = unique_codes(codes)
    seconds = time.perf_counter() - start
    peak_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base_rss) / 1024
    per_pair = pairwise_seconds_per_pair(codes[:SAMPLE])
    baseline = per_pair * N * (N - 1) / 2
    out = {
        "benchmark": "dedup", "date": date.today().isoformat(), "machine": f"{platform.machine()}, "
        f"{os.cpu_count()} cores", "codes": N, "code_bits": 64, "unique": int(len(result.unique)),
        "seconds": round(seconds, 3), "codes_per_second": round(N / seconds), "extra_peak_rss_mb": round(peak_mb),
        "pairwise_baseline_seconds_estimated": round(baseline, 1), "speedup_vs_pairwise": round(baseline / seconds),
        "targets": {"seconds_max": 3.0, "peak_rss_mb_max": 1024},
        "command": "python -m benchmarks.speed.bench_dedup",
    }
    path = Path(__file__).resolve().parents[1] / "results" / "dedup.json"
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
