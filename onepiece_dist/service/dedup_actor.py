"""The central dedup and assembly actor: merges each object's codes as its part is committed and is the only
writer of the global arrays. A plain class (tested without Ray); its state is rebuilt from the committed parts
after a restart, because :meth:`CentralDedup.commit` folds in every part it has not merged yet."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.dedup import DedupIndex, partition_of
from onepiece_dist.service.commit import commit_dataset
from onepiece_dist.service.extract import ObjectResult, parts_for
from onepiece_dist.spec import JobSpec


class CentralDedup:
    def __init__(self, spec: JobSpec):
        self.spec = spec
        self.parts = parts_for(spec)
        self.index = DedupIndex(spec.code_bytes())
        self.merged: set[int] = set()

    def add(self, object_index: int, part_key: str, codes: np.ndarray | None = None) -> int:
        """Merge the codes of object ``object_index``, once (a retried call changes nothing): ``codes`` as sent
        by the worker that committed the part, or else read from the part. Returns the unique-code count so
        far: an upper bound until the pending runs are compacted, so that a call costs O(part), not O(all)."""
        if object_index not in self.merged:
            self.index.add(self.parts.read_array(part_key, "code") if codes is None else codes)
            self.merged.add(object_index)
        return self.index.size_bound()

    def commit(self, results: list[ObjectResult]) -> dict:
        """Fold in anything not merged yet, then write the dataset."""
        for result in results:
            if result.status == "ok":
                self.add(result.index, result.part_key)
        return commit_dataset(self.spec, results, self.parts, self.spec.output, index=self.index)


class DedupShard:
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
