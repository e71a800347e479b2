"""Hash-prefix partitions of the global dedup, for corpora where one central index is not enough
(docs/scaling.md); the job's own central actor is in runtime/writer.py."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.dedup import DedupIndex, partition_of


class DedupPartition:
    """One hash-prefix partition of the global dedup, for corpora where one central index is not enough
    (docs/scaling.md). A plain class; on a cluster each is an actor fed only the codes it owns
    (:func:`route_codes`), and the committer unions their states (``core.dedup.merge_partitions``)."""

    def __init__(self, code_bytes: int, partition: int, partitions: int):
        self.partition, self.partitions = partition, partitions
        self.index = DedupIndex(code_bytes)

    def add(self, codes: np.ndarray) -> int:
        """Fold in codes of this partition (others are a routing bug and refused). Returns rows added."""
        if len(codes) and np.any(partition_of(codes, self.partitions) != self.partition):
            raise ValueError(f"codes of another partition sent to partition {self.partition}/{self.partitions}")
        self.index.add(codes)
        return len(codes)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.index.unique, self.index.counts

    def nbytes(self) -> int:
        return self.index.nbytes()


def route_codes(codes: np.ndarray, partitions: int) -> list[np.ndarray]:
    """The (n, B) codes split by owning partition, in partition order."""
    owner = partition_of(codes, partitions)
    return [codes[owner == k] for k in range(partitions)]
