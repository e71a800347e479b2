"""Similar-shape filter: merge codes whose occupancy differs in at most ``radius`` voxels (Hamming distance).

Codes within the radius are linked, and each connected group becomes one cluster, represented by its most
frequent code (ties: the smallest in byte order). The result depends only on the set of codes and their counts,
so shard results merge in any order. Candidate pairs come from multi-index hashing: the bits are split into
radius + 1 blocks, and two codes within the radius agree exactly on at least one block, so only codes that share
a block value are compared (never all pairs). Sparse codes share blocks of zeros, which makes one huge bucket; for
them a ball index (codes with a common neighbour within ceil(radius / 2) flipped bits) proposes far fewer pairs,
and the index that proposes fewer is used. Both propose every pair within the radius, so the clusters are the
same.
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


BALL_WORDS = 1 << 25  # the ball index holds at most this many uint64 words (256 MiB)


def candidate_pairs(codes: np.ndarray, nbits: int, radius: int) -> np.ndarray:
    """(k, 2) int64 pairs (i < j) of (U, B) uint8 codes that may lie within ``radius``: a superset of the pairs
    that do, from whichever index proposes fewer. Multi-index hashing (codes that agree on one of radius + 1 bit
    blocks) suits varied codes; when many codes share a block value (sparse codes: a block of zeros) it proposes
    nearly all pairs, and the ball index (codes with a common neighbour within ceil(radius / 2) flipped bits; its
    buckets hold at most that ball's size) proposes far fewer."""
    bits = np.unpackbits(codes, axis=1, count=nbits, bitorder="big")
    buckets = [np.unique(np.packbits(bits[:, block], axis=1), axis=0, return_inverse=True)[1].ravel()
               for block in np.array_split(np.arange(nbits), radius + 1)]
    block_pairs = sum(int((c * (c - 1) // 2).sum()) for c in (np.bincount(b) for b in buckets))
    ball = len(codes) * ball_size(nbits, (radius + 1) // 2)
    if ball < block_pairs and ball * -(-nbits // 64) <= BALL_WORDS:
        pairs = [_ball_pairs(codes, nbits, (radius + 1) // 2)]
    else:
        pairs = [_pairs_in_buckets(bucket) for bucket in buckets]
    pairs = np.vstack(pairs) if pairs else np.zeros((0, 2), dtype=np.int64)
    if not len(pairs):
        return pairs
    keys = np.unique(pairs[:, 0] * len(codes) + pairs[:, 1])  # one int64 per pair: sorted as (i, j) rows would be
    return np.stack([keys // len(codes), keys % len(codes)], axis=1)


def ball_size(nbits: int, flips: int) -> int:
    """Codes within ``flips`` flipped bits of a code of ``nbits`` bits (itself included)."""
    from math import comb

    return sum(comb(nbits, k) for k in range(flips + 1))


def flip_masks(nbits: int, flips: int) -> np.ndarray:
    """(ball_size(nbits, flips), W) uint64 masks, in the word layout of ``code_words``, that flip at most
    ``flips`` of the first ``nbits`` bits (big-endian bit order: bit 0 is the first byte's top bit)."""
    from itertools import combinations

    width = -(-nbits // 64)
    sets = [c for k in range(flips + 1) for c in combinations(range(nbits), k)]
    masks = np.zeros((len(sets), width), dtype=np.uint64)
    for row, chosen in enumerate(sets):
        for bit in chosen:
            masks[row, bit // 64] |= np.uint64(1) << np.uint64(63 - bit % 64)
    return masks


def _ball_pairs(codes: np.ndarray, nbits: int, flips: int) -> np.ndarray:
    """(k, 2) pairs (i < j) of codes whose balls of ``flips`` flipped bits meet: every pair within 2 x flips."""
    words, masks = code_words(codes), flip_masks(nbits, flips)
    variants = (words[:, None, :] ^ masks[None, :, :]).reshape(-1, words.shape[1])
    owner = np.repeat(np.arange(len(codes), dtype=np.int64), len(masks))
    _, bucket = np.unique(variants, axis=0, return_inverse=True)
    entries = _pairs_in_buckets(bucket.ravel())
    a, b = owner[entries[:, 0]], owner[entries[:, 1]]
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


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
