"""The central dedup and assembly actor: merges each object's codes as its part is committed and is the only
writer of the global arrays. A plain class (tested without Ray); its state is rebuilt from the committed parts
after a restart, because :meth:`CentralDedup.commit` folds in every part it has not merged yet."""

from __future__ import annotations

from onepiece_dist.core.dedup import DedupIndex
from onepiece_dist.service.commit import commit_dataset
from onepiece_dist.service.extract import ObjectResult, parts_for
from onepiece_dist.spec import JobSpec


class CentralDedup:
    def __init__(self, spec: JobSpec):
        self.spec = spec
        self.parts = parts_for(spec)
        self.index = DedupIndex(spec.code_bytes())
        self.merged: set[int] = set()

    def add(self, object_index: int, part_key: str) -> int:
        """Merge the codes of object ``object_index`` from its committed part, once (a retried call changes
        nothing). Returns the unique-code count so far."""
        if object_index not in self.merged:
            self.index.add(self.parts.read(part_key)["code"])
            self.merged.add(object_index)
        return len(self.index.unique)

    def commit(self, results: list[ObjectResult]) -> dict:
        """Fold in anything not merged yet, then write the dataset."""
        for result in results:
            if result.status == "ok":
                self.add(result.index, result.part_key)
        return commit_dataset(self.spec, results, self.parts, self.spec.output, index=self.index)
