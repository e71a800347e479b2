"""Similar-shape filter: merge codes whose occupancy differs in at most ``radius`` voxels (Hamming distance).

Codes within the radius are linked, and each connected group becomes one cluster, represented by its most
frequent code (ties: the smallest in byte order). The result depends only on the set of codes and their counts,
so shard results merge in any order. Candidate pairs come from multi-index hashing: the bits are split into
radius + 1 blocks, and two codes within the radius agree exactly on at least one block, so only codes that share
a block value are compared (never all pairs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.dedup import code_words


@dataclass(frozen=True)
class SimilarClusters:
    """cluster (U,) int64: cluster of each input code (clusters numbered by their smallest member row);
    representative (C,) int64: input row representing each cluster; counts (C,) int64: grasps per cluster."""

    cluster: np.ndarray
    representative: np.ndarray
    counts: np.ndarray


def hamming(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bit differences between rows of two (n, B) uint8 arrays -> (n,) int64."""
    return np.bitwise_count(np.bitwise_xor(a, b)).sum(axis=1).astype(np.int64)


def candidate_pairs(codes: np.ndarray, nbits: int, radius: int) -> np.ndarray:
    """(k, 2) int64 pairs (i < j) of codes that agree on at least one of radius + 1 bit blocks."""
    bits = np.unpackbits(codes, axis=1, count=nbits, bitorder="big")
    pairs = []
    for block in np.array_split(np.arange(nbits), radius + 1):
        packed = np.packbits(bits[:, block], axis=1)
        _, bucket = np.unique(packed, axis=0, return_inverse=True)
        pairs.append(_pairs_in_buckets(bucket.ravel()))
    pairs = np.vstack(pairs) if pairs else np.zeros((0, 2), dtype=np.int64)
    if not len(pairs):
        return pairs
    keys = np.unique(pairs[:, 0] * len(codes) + pairs[:, 1])  # one int64 per pair: sorted as (i, j) rows would be
    return np.stack([keys // len(codes), keys % len(codes)], axis=1)


def _pairs_in_buckets(bucket: np.ndarray) -> np.ndarray:
    order = np.argsort(bucket, kind="stable")
    sorted_bucket = bucket[order]
    out = []
    for offset in range(1, len(order)):
        same = sorted_bucket[offset:] == sorted_bucket[:-offset]
        if not same.any():
            break
        first = np.flatnonzero(same)
        a, b = order[first], order[first + offset]
        out.append(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1))
    return np.vstack(out) if out else np.zeros((0, 2), dtype=np.int64)


PAIR_CHUNK = 1 << 20  # pairs compared at a time: gathering both codes of every candidate pair at once can take GBs


def _within(codes: np.ndarray, pairs: np.ndarray, radius: int) -> np.ndarray:
    """The (k, 2) ``pairs`` whose codes differ in at most ``radius`` bits, compared PAIR_CHUNK at a time."""
    keep = [chunk[hamming(codes[chunk[:, 0]], codes[chunk[:, 1]]) <= radius]
            for chunk in (pairs[i:i + PAIR_CHUNK] for i in range(0, len(pairs), PAIR_CHUNK))]
    return np.vstack(keep) if keep else np.zeros((0, 2), dtype=np.int64)


def connected_components(count: int, edges: np.ndarray) -> np.ndarray:
    """(count,) int64 component label (the smallest member index) of a graph given by (k, 2) edges."""
    labels = np.arange(count, dtype=np.int64)
    if len(edges) == 0:
        return labels
    a, b = edges[:, 0], edges[:, 1]
    while True:
        low = np.minimum(labels[a], labels[b])
        before = labels.copy()
        np.minimum.at(labels, a, low)
        np.minimum.at(labels, b, low)
        labels = labels[labels]
        if np.array_equal(labels, before):
            return labels


def similar_clusters(codes: np.ndarray, counts: np.ndarray, nbits: int, radius: int,
                     pairs: np.ndarray | None = None) -> SimilarClusters:
    """Cluster unique (U, B) uint8 codes with (U,) counts at Hamming ``radius`` (0 = exact dedup)."""
    counts = np.asarray(counts, dtype=np.int64)
    if radius == 0 or len(codes) < 2:
        edges = np.zeros((0, 2), dtype=np.int64)
    else:
        pairs = candidate_pairs(codes, nbits, radius) if pairs is None else pairs
        edges = _within(codes, pairs, radius)
    labels = connected_components(len(codes), edges)
    roots, cluster = np.unique(labels, return_inverse=True)
    # representative: highest count, then the smallest code in byte order (independent of input order)
    words = code_words(codes)
    byte_rank = np.empty(len(codes), dtype=np.int64)
    byte_rank[np.lexsort(words.T[::-1])] = np.arange(len(codes))
    order = np.lexsort((byte_rank, -counts, cluster))
    first = np.ones(len(order), dtype=bool)
    first[1:] = cluster[order][1:] != cluster[order][:-1]
    return SimilarClusters(cluster.astype(np.int64), order[first].astype(np.int64),
                           np.bincount(cluster, weights=counts, minlength=len(roots)).astype(np.int64))


def brute_force_pairs(count: int) -> np.ndarray:
    """All (i < j) pairs: the reference the index must agree with."""
    i, j = np.triu_indices(count, k=1)
    return np.stack([i, j], axis=1).astype(np.int64)
