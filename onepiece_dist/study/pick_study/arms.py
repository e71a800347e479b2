"""The arms of a study on pick labels (issue 58; store.pick_labels): which of the labelled grasps each plan would
have labelled. Pure numpy: an arm is a set of rows of the pick labels, chosen before any label is read.

A labels every candidate; R labels a seeded random share (one arm per size: the learning curve; and one the size of
each B arm); B at similar-shape radius r labels one grasp per shape: the crops' voxel codes (the network's grid over
the closing region) clustered at Hamming radius r (core.similar), one seeded grasp of each cluster's representative
code. The pick protocol lifts an object off a table, so B cannot label the assembled one object here: it labels
each unique shape once, where a camera saw it, which is what the one object would label if a patch held as its
representative grasp does.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.core.similar import similar_clusters
from onepiece_dist.core.voxel import voxel_indices


@dataclass(frozen=True)
class PickArm:
    """``name`` as the page calls it, ``kind`` (A, R or B), ``rows`` (sorted) of the pick labels it labels; for B,
    ``radius`` and the ``seconds`` its dedup took."""

    name: str
    kind: str
    rows: np.ndarray
    radius: int | None = None
    seconds: float = 0.0

    @property
    def labels(self) -> int:
        return len(self.rows)


def crop_codes(points: np.ndarray, grid_shape: tuple[int, int, int], resolution: float) -> np.ndarray:
    """(n, B) uint8 occupancy codes of gripper-frame crops ``points`` (n, p, 3) on the network's voxel grid over the
    closing region (points outside it ignored), packed as a job packs them."""
    flat = voxel_indices(np.asarray(points, dtype=np.float64), grid_shape, resolution)
    occupancy = np.zeros((len(flat), int(np.prod(grid_shape))), dtype=bool)
    rows, cols = np.nonzero(flat >= 0)
    occupancy[rows, flat[rows, cols]] = True
    return np.packbits(occupancy, axis=1, bitorder="big")


def one_per_shape(codes: np.ndarray, radius: int, seed: int) -> np.ndarray:
    """Sorted rows: one per cluster of ``codes`` (n, B) at Hamming ``radius``, a seeded choice among the grasps
    whose code is the cluster's representative. Depends on the codes and the seed, not on the rows' order of
    equal codes."""
    found = unique_codes(codes)
    clusters = similar_clusters(found.unique, found.counts, codes.shape[1] * 8, radius)
    wanted = np.full(len(found.unique), -1, dtype=np.int64)
    wanted[clusters.representative] = np.arange(len(clusters.representative))
    cluster_of_row = wanted[found.inverse]  # -1: a row whose code is not a representative
    rng = np.random.default_rng([seed, radius, 58])
    order = np.lexsort((rng.random(len(codes)), cluster_of_row))
    order = order[cluster_of_row[order] >= 0]
    first = np.r_[True, cluster_of_row[order][1:] != cluster_of_row[order][:-1]]
    return np.sort(order[first])


def random_rows(count: int, size: int, seed: int) -> np.ndarray:
    """Sorted rows: a seeded random ``size`` of ``count`` (the same seed and size give the same rows)."""
    return np.sort(np.random.default_rng([seed, size, 58]).permutation(count)[:size])


def pick_arms(codes: np.ndarray, sizes: tuple[int, ...], radii: tuple[int, ...], seed: int) -> list[PickArm]:
    """A, the R arms of ``sizes`` (those below A's), each B radius and R of its size, in that order."""
    count = len(codes)
    arms = [PickArm("A", "A", np.arange(count))]
    arms += [PickArm(f"R {size:,}", "R", random_rows(count, size, seed)) for size in sorted(set(sizes))
             if size < count]
    for radius in radii:
        start = time.perf_counter()
        rows = one_per_shape(codes, radius, seed)
        b = PickArm(f"B r{radius}", "B", rows, radius, time.perf_counter() - start)
        arms += [b, PickArm(f"R ~B r{radius}", "R", random_rows(count, b.labels, seed))]
    return arms
