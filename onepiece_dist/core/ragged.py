"""Ragged rows: many (k_i, 3) arrays stored flat as one (sum k_i, 3) array and a (n,) count per array."""

from __future__ import annotations

import numpy as np


def stack_rows(rows: list[np.ndarray], dtype) -> np.ndarray:
    """(sum k_i, 3) rows of every (k_i, 3) array, cast while copying (no float64 copy of a float32 result)."""
    return np.concatenate(rows, axis=0, dtype=dtype) if rows else np.zeros((0, 3), dtype=dtype)


def split_rows(rows: np.ndarray, counts: np.ndarray) -> list[np.ndarray]:
    """The float64 arrays of ``counts`` rows each that :func:`stack_rows` stacked."""
    return np.split(np.asarray(rows, dtype=np.float64), np.cumsum(counts)[:-1]) if len(counts) else []


def row_offsets(counts: np.ndarray) -> np.ndarray:
    """(n + 1,) int64 first row of each of n runs of ``counts`` (n,) rows, then the total."""
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
