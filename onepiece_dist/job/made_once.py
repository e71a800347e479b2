"""A shard of a stage made once: its part written by a worker and reused when a retried or resumed job finds it
committed, with the time it took to make kept in its metadata (so a rerun charges what the work cost then)."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from onepiece_dist.job.results import ShardResult
from onepiece_dist.store import PartStore


def shard_once(parts: PartStore, part_key: str, index: int, make: Callable[[], dict[str, np.ndarray]], meta: dict,
               count: Callable[[], int]) -> ShardResult:
    """Write the part ``part_key`` from ``make()`` unless it is committed; its result, with ``count()`` items."""
    start = time.perf_counter()
    reused = parts.is_committed(part_key)
    if not reused:
        parts.write(part_key, make(), {**meta, "made_seconds": time.perf_counter() - start})
    seconds = time.perf_counter() - start
    made = float(parts.read_meta(part_key).get("made_seconds", seconds))
    return ShardResult(index, "ok", part_key, count(), reused=reused, seconds=seconds, made_seconds=made)
