"""Similar-shape filter at Hamming radius 2 on 1 million 512-bit codes (one core), against the all-pairs
baseline, whose time is estimated from a sample measured in the same run.

Run: .venv/bin/python -m benchmarks.speed.bench_similar  (writes benchmarks/results/similar.json)
The codes are random with planted near-duplicates (a tenth are copies of others with 1-2 flipped bits).
"""

from __future__ import annotations

import json
import os
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np

from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.core.similar import hamming, similar_clusters

N = int(os.environ.get("BENCH_SIMILAR_N", 1_000_000))
NBYTES, RADIUS, SAMPLE = 64, 2, 3000


def synthetic(n: int, rng: np.random.Generator) -> np.ndarray:
    codes = rng.integers(0, 256, (n, NBYTES), dtype=np.uint8)
    copies = rng.integers(0, n, n // 10)
    near = codes[copies].copy()
    for flips in range(2):
        byte, bit = rng.integers(0, NBYTES, len(near)), rng.integers(0, 8, len(near))
        near[np.arange(len(near)), byte] ^= (1 << bit).astype(np.uint8) * (rng.random(len(near)) < 0.5 + flips)
    codes[rng.integers(0, n, len(near))] = near
    return unique_codes(codes).unique


def main() -> dict:
    codes = synthetic(N, np.random.default_rng(0))
    counts = np.ones(len(codes), dtype=np.int64)
    start = time.perf_counter()
    result = similar_clusters(codes, counts, NBYTES * 8, RADIUS)
    seconds = time.perf_counter() - start
    sample = codes[:SAMPLE]
    start = time.perf_counter()
    for i in range(len(sample) - 1):
        hamming(sample[i + 1:], np.broadcast_to(sample[i], sample[i + 1:].shape))
    per_pair = (time.perf_counter() - start) / (SAMPLE * (SAMPLE - 1) / 2)
    baseline = per_pair * len(codes) * (len(codes) - 1) / 2
    out = {"benchmark": "similar", "date": date.today().isoformat(), "machine": f"{platform.machine()}, "
           f"{os.cpu_count()} cores (one used)", "codes": int(len(codes)), "code_bits": NBYTES * 8, "radius": RADIUS,
           "clusters": int(len(result.representative)), "seconds": round(seconds, 2),
           "all_pairs_seconds_estimated": round(baseline), "speedup": round(baseline / seconds),
           "target_seconds": 60, "command": "python -m benchmarks.speed.bench_similar"}
    (Path(__file__).resolve().parents[1] / "results" / "similar.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
