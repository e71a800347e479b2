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

    Holds only the unique codes and counts (not every grasp), so memory follows U, not N. Log-structured:
    each ``add`` sorts only its own batch into a pending run; pending runs are folded into the main sorted table
    when they hold a quarter of its rows (at least ``flush_rows``), so each code is moved O(log N) times.
    Single-word codes (up to 64 voxels) merge linearly by binary search; wider codes by a sort.
    """

    def __init__(self, code_bytes: int, flush_rows: int = 1 << 16):
        self.code_bytes = code_bytes
        self.flush_rows = flush_rows
        self._words = np.zeros((0, -(-code_bytes // 8)), dtype=np.uint64)
        self._counts = np.zeros(0, dtype=np.int64)
        self._pending: list[tuple[np.ndarray, np.ndarray]] = []
        self._pending_rows = 0

    def add(self, codes: np.ndarray, counts: np.ndarray | None = None) -> None:
        """Fold in (n, B) uint8 codes (with optional (n,) int64 counts)."""
        codes = np.asarray(codes, dtype=np.uint8).reshape(-1, self.code_bytes)
        part = unique_codes(codes, weights=counts)
        self._pending.append((code_words(part.unique), part.counts))
        self._pending_rows += len(part.unique)
        if self._pending_rows >= max(self.flush_rows, len(self._words) // 4):
            self._compact()

    @property
    def unique(self) -> np.ndarray:
        """(U, B) uint8 distinct codes in byte order."""
        self._compact()
        return words_to_codes(self._words, self.code_bytes)

    @property
    def counts(self) -> np.ndarray:
        """(U,) int64 rows added per distinct code."""
        self._compact()
        return self._counts

    def __len__(self) -> int:
        self._compact()
        return len(self._words)

    def size_bound(self) -> int:
        """An upper bound of ``len(self)`` without compacting (exact right after a compaction): cheap progress."""
        return len(self._words) + self._pending_rows

    def nbytes(self) -> int:
        """Bytes held by the index (main table and pending runs)."""
        return int(self._words.nbytes + self._counts.nbytes + sum(w.nbytes + c.nbytes for w, c in self._pending))

    def _compact(self) -> None:
        if not self._pending:
            return
        words = np.concatenate([w for w, _ in self._pending])
        counts = np.concatenate([c for _, c in self._pending])
        self._pending, self._pending_rows = [], 0
        if words.shape[1] == 1:
            run = unique_codes(words_to_codes(words, 8), weights=counts)
            self._words, self._counts = _merge_sorted_keys(self._words[:, 0], self._counts,
                                                           code_words(run.unique)[:, 0], run.counts)
        else:
            merged = unique_codes(words_to_codes(np.concatenate([self._words, words]), 8 * words.shape[1]),
                                  weights=np.concatenate([self._counts, counts]))
            self._words, self._counts = code_words(merged.unique), merged.counts

    def lookup(self, codes: np.ndarray) -> np.ndarray:
        """Index into ``unique`` of each (n, B) uint8 code; raises KeyError for a code never added."""
        self._compact()
        codes = np.asarray(codes, dtype=np.uint8).reshape(-1, self.code_bytes)
        if self._words.shape[1] == 1:
            keys, table = code_words(codes)[:, 0], self._words[:, 0]
            found = np.minimum(np.searchsorted(table, keys), max(len(table) - 1, 0))
            missing = int(np.sum(table[found] != keys)) if len(table) else len(keys)
            if missing:
                raise KeyError(f"{missing} code(s) were never added to this index")
            return found.astype(np.int64)
        unique = self.unique
        both = unique_codes(np.concatenate([unique, codes]))
        if len(both.unique) != len(unique):
            raise KeyError(f"{len(both.unique) - len(unique)} code(s) were never added to this index")
        return both.inverse[len(unique):]


def words_to_codes(words: np.ndarray, code_bytes: int) -> np.ndarray:
    """(N, W) uint64 words -> (N, code_bytes) uint8 (the inverse of :func:`code_words`)."""
    raw = np.ascontiguousarray(words.astype(">u8")).view(np.uint8).reshape(len(words), 8 * words.shape[1])
    return np.ascontiguousarray(raw[:, :code_bytes])


def _merge_sorted_keys(keys: np.ndarray, counts: np.ndarray, new_keys: np.ndarray,
                       new_counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge sorted distinct (n,) uint64 keys with counts and sorted distinct new keys in O(n + m)."""
    at = np.searchsorted(keys, new_keys)
    present = at < len(keys)
    present[present] = keys[at[present]] == new_keys[present]
    counts = counts.copy()
    counts[at[present]] += new_counts[present]
    fresh = ~present
    merged_keys = np.insert(keys, at[fresh], new_keys[fresh])
    merged_counts = np.insert(counts, at[fresh], new_counts[fresh])
    return merged_keys[:, None], merged_counts


def partition_of(codes: np.ndarray, partitions: int) -> np.ndarray:
    """(N,) int64 partition of each (N, B) uint8 code: the top bits of its mixed hash (a hash prefix), so each
    partition owns a fixed, disjoint set of codes whatever the order they arrive in."""
    if partitions < 1:
        raise ValueError(f"partitions={partitions} must be at least 1")
    hashes = mix_hash(code_words(codes))
    return ((hashes >> np.uint64(32)) * np.uint64(partitions) >> np.uint64(32)).astype(np.int64)


class PartitionedDedup:
    """Exact dedup split by hash prefix over ``partitions`` independent indexes (one per actor in a cluster).

    The partitions own disjoint codes, so the union of their unique sets, put in byte order, is exactly what one
    :class:`DedupIndex` gives.
    """

    def __init__(self, code_bytes: int, partitions: int):
        self.code_bytes = code_bytes
        self.shards = [DedupIndex(code_bytes) for _ in range(partitions)]

    def add(self, codes: np.ndarray, counts: np.ndarray | None = None) -> None:
        codes = np.asarray(codes, dtype=np.uint8).reshape(-1, self.code_bytes)
        owner = partition_of(codes, len(self.shards))
        for k, shard in enumerate(self.shards):
            mine = owner == k
            if mine.any():
                shard.add(codes[mine], None if counts is None else np.asarray(counts)[mine])

    def merged(self) -> DedupIndex:
        """One DedupIndex holding every partition's codes and counts."""
        return merge_partitions([(s.unique, s.counts) for s in self.shards], self.code_bytes)


def merge_partitions(states: Sequence[tuple[np.ndarray, np.ndarray]], code_bytes: int) -> DedupIndex:
    """Union of disjoint partitions' (unique (U_k, B), counts (U_k,)) as one DedupIndex in byte order."""
    index = DedupIndex(code_bytes)
    codes = [u for u, _ in states if len(u)]
    if codes:
        index.add(np.concatenate(codes), np.concatenate([c for u, c in states if len(u)]))
    return index
