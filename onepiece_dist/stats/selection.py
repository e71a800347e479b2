"""Which candidates to label next (pure numpy): one per voxel code first, so the codes give diversity as ONE
PIECE's dedup intends, then where a network is least sure. Shared by the adaptive labelling job
(job/stages/label_rounds.py) and a study's adaptive arm (study/adaptive.py)."""

from __future__ import annotations

import numpy as np


def one_grasp_per_key(inverse: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One row drawn at random among the rows of each key: inverse (n,) int64 key of each row -> (U,) int64 rows,
    in key order (keys need not be dense: a key no row has gets none)."""
    order = rng.permutation(len(inverse))
    first = np.full(int(inverse.max()) + 1 if len(inverse) else 0, -1, dtype=np.int64)
    first[inverse[order][::-1]] = np.arange(len(order))[::-1]  # each key's first place in the shuffled order
    return order[first[first >= 0]]


def first_rows(inverse: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Round 0: ``count`` rows, one per code (codes in random order), then random rows once every code has one:
    inverse (n,) int64 code of each row -> (count,) int64 rows."""
    per_code = rng.permutation(one_grasp_per_key(inverse, rng))[:count]
    if len(per_code) < count:
        rest = np.setdiff1d(np.arange(len(inverse)), per_code)
        per_code = np.concatenate([per_code, rng.permutation(rest)[:count - len(per_code)]])
    return per_code


def least_sure(scores: np.ndarray, labelled: np.ndarray, inverse: np.ndarray, count: int) -> np.ndarray:
    """The ``count`` unlabelled rows whose score is nearest one half, at most one per code while unlabelled codes
    last, then the next least sure: scores (n,), labelled (k,) rows, inverse (n,) code of each row."""
    free = np.ones(len(scores), dtype=bool)
    free[labelled] = False
    order = np.flatnonzero(free)[np.argsort(np.abs(scores[free] - 0.5), kind="stable")]
    _, first = np.unique(inverse[order], return_index=True)
    diverse = order[np.sort(first)]  # each unlabelled code's least sure row, least sure codes first
    picked = diverse[:count]
    if len(picked) < count:
        picked = np.concatenate([picked, np.setdiff1d(order, picked, assume_unique=True)[:count - len(picked)]])
    return picked
