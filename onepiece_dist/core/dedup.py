"""Exact deduplication of packed voxel codes.

A bucket key (a hash) groups candidates; byte equality decides, so two different codes never merge,
whatever the hash. The unique codes come out in ascending byte order (lexicographic), which depends only
on the set of codes, so partial results from shards merge into the same answer in any order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

HashFn = Callable[[np.ndarray], np.ndarray]
_MIX = np.uint64(0x9E3779B97F4A7C15)


@dataclass(frozen=True)
class UniqueCodes:
    """unique : (U, B) uint8 in byte order; inverse : (N,) int64 into unique; counts : (U,) int64."""

    unique: np.ndarray
    inverse: np.ndarray
    counts: np.ndarray


def code_words(codes: np.ndarray) -> np.ndarray:
    """(N, B) uint8 -> (N, W) uint64, W = ceil(B / 8), big-endian so word order is byte order."""
    codes = np.ascontiguousarray(codes, dtype=np.uint8)
    n, nbytes = codes.shape
    width = -(-nbytes // 8) * 8
    if width != nbytes:
        padded = np.zeros((n, width), dtype=np.uint8)
        padded[:, :nbytes] = codes
        codes = padded
    return codes.view(">u8").astype(np.uint64)


def mix_hash(words: np.ndarray) -> np.ndarray:
    """A 64-bit bucket key per row of (N, W) uint64 words (splitmix-style mixing)."""
    h = np.zeros(len(words), dtype=np.uint64)
    with np.errstate(over="ignore"):
        for col in range(words.shape[1]):
            h = (h ^ words[:, col]) * _MIX
            h ^= h >> np.uint64(31)
    return h


def unique_codes(codes: np.ndarray, weights: np.ndarray | None = None,
                 hash_fn: HashFn | None = None) -> UniqueCodes:
    """Unique codes, inverse index and counts; exact and vectorized.

    codes : (N, B) uint8
    weights : (N,) int64 or None   added up per unique code (defaults to 1 each)
    hash_fn : maps (N, W) uint64 words to (N,) uint64 bucket keys; any function gives the same answer
    """
    codes = np.asarray(codes, dtype=np.uint8)
    if codes.ndim != 2:
        raise ValueError(f"codes must be (N, B) uint8, got shape {codes.shape}")
    words = code_words(codes)
    order = _sort_order(words, hash_fn)
    sorted_words = words[order]
    starts = _run_starts(sorted_words)
    group = np.cumsum(starts) - 1
    counts = _group_counts(starts, group, order, weights)
    unique = codes[order[starts]]
    rank = _byte_order_rank(sorted_words[starts]) if hash_fn is not None else np.arange(len(unique))
    inverse = np.empty(len(codes), dtype=np.int64)
    inverse[order] = rank[group]
    ranked = np.empty_like(rank)
    ranked[rank] = np.arange(len(rank))
    return UniqueCodes(unique[ranked], inverse, counts[ranked])


def _group_counts(starts: np.ndarray, group: np.ndarray, order: np.ndarray,
                  weights: np.ndarray | None) -> np.ndarray:
    if weights is None:
        return np.diff(np.flatnonzero(starts), append=len(starts)).astype(np.int64)
    summed = np.zeros(int(starts.sum()), dtype=np.int64)
    np.add.at(summed, group, np.asarray(weights, dtype=np.int64)[order])
    return summed


def _run_starts(sorted_words: np.ndarray) -> np.ndarray:
    """(N,) bool, True where a sorted row differs from the one before it."""
    starts = np.ones(len(sorted_words), dtype=bool)
    if sorted_words.shape[1] == 1:
        np.not_equal(sorted_words[1:, 0], sorted_words[:-1, 0], out=starts[1:])
    else:
        starts[1:] = np.any(sorted_words[1:] != sorted_words[:-1], axis=1)
    return starts


def _sort_order(words: np.ndarray, hash_fn: HashFn | None) -> np.ndarray:
    """Rows sorted so that equal codes are adjacent: by bucket key, then by every word."""
    if hash_fn is None:
        if words.shape[1] == 1:
            return np.argsort(words[:, 0], kind="stable")
        return np.lexsort(words.T[::-1])
    keys = np.asarray(hash_fn(words), dtype=np.uint64)
    return np.lexsort((*words.T[::-1], keys))


def _byte_order_rank(words: np.ndarray) -> np.ndarray:
    """Rank of each (distinct) row in byte order. (U, W) uint64 -> (U,) int64."""
    order = np.lexsort(words.T[::-1]) if len(words) else np.zeros(0, dtype=np.int64)
    rank = np.empty(len(words), dtype=np.int64)
    rank[order] = np.arange(len(words))
    return rank


def merge_unique(parts: Sequence[tuple[np.ndarray, np.ndarray]],
                 hash_fn: HashFn | None = None) -> tuple[UniqueCodes, list[np.ndarray]]:
    """Merge partial results ``(unique (U_i, B) uint8, counts (U_i,) int64)`` from shards.

    returns : the merged UniqueCodes (its ``inverse`` indexes the concatenated parts' rows) and, per part,
              a (U_i,) int64 map from the part's unique index to the merged one.
    """
    if not parts:
        raise ValueError("merge_unique needs at least one part")
    codes = np.concatenate([p[0] for p in parts])
    counts = np.concatenate([np.asarray(p[1], dtype=np.int64) for p in parts])
    merged = unique_codes(codes, weights=counts, hash_fn=hash_fn)
    bounds = np.cumsum([0] + [len(p[0]) for p in parts])
    remaps = [merged.inverse[bounds[i]:bounds[i + 1]] for i in range(len(parts))]
    return merged, remaps


class DedupIndex:
    """Running global dedup: add shard results in any order, read the same answer.

    Holds only the unique codes and counts (not every grasp), so memory follows U, not N.
    """

    def __init__(self, code_bytes: int):
        self.unique = np.zeros((0, code_bytes), dtype=np.uint8)
        self.counts = np.zeros(0, dtype=np.int64)

    def add(self, codes: np.ndarray, counts: np.ndarray | None = None) -> None:
        """Fold in (n, B) uint8 codes (with optional (n,) int64 counts)."""
        part = unique_codes(codes, weights=counts)
        merged, _ = merge_unique([(self.unique, self.counts), (part.unique, part.counts)])
        self.unique, self.counts = merged.unique, merged.counts

    def lookup(self, codes: np.ndarray) -> np.ndarray:
        """Index into ``unique`` of each (n, B) uint8 code; raises KeyError for a code never added."""
        both = unique_codes(np.concatenate([self.unique, np.asarray(codes, dtype=np.uint8)]))
        if len(both.unique) != len(self.unique):
            raise KeyError(f"{len(both.unique) - len(self.unique)} code(s) were never added to this index")
        return both.inverse[len(self.unique):]
