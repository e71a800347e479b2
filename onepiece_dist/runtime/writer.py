"""The central actor: the one writer of the global arrays. It merges each object's codes as its part is
committed, commits the dataset, assembles the one object, cuts its label stage into shards for the workers and
merges what they label. A plain class (tested without Ray);
:class:`WriterClient` is its thin client on Ray.

After a restart its state is rebuilt from the store: :meth:`DatasetWriter.commit` folds in every part it has not
merged yet, and the later stages read what the commit wrote when they do not hold it in memory.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.dedup import DedupIndex
from onepiece_dist.errors import JobError, MissingAssembly
from onepiece_dist.job.results import CommitSummary, LabelTask, ObjectResult, PatchTask, ShardResult
from onepiece_dist.job.stages.assemble import assemble_dataset
from onepiece_dist.job.stages.commit import commit_dataset
from onepiece_dist.job.stages.label_budget import budget_tasks, write_budget_labels
from onepiece_dist.job.stages.label_one_object import label_tasks, write_labels
from onepiece_dist.job.stages.label_rounds import round_weights
from onepiece_dist.job.stages.label_transfer import measure_transfer
from onepiece_dist.job.stages.patch_shards import merge_patch_shards, patch_tasks
from onepiece_dist.job.status import AdaptiveReport, AssemblyReport, LabelReport
from onepiece_dist.runtime.actors import ActorClient, restartable_actor
from onepiece_dist.runtime.ray_env import NAMESPACE
from onepiece_dist.runtime.registry import on_this_node
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import DatasetReader, PartStore
from onepiece_dist.store.dataset import update_attributes, write_groups


class DatasetWriter:
    def __init__(self, spec: JobSpec):
        self.spec = spec
        self.parts = PartStore(spec.parts_folder())
        self.index = DedupIndex(spec.code_bytes())
        self.merged: set[int] = set()
        self.unique_codes: np.ndarray | None = None  # (U, B) uint8 as committed, while this process holds them
        self.grasps: int | None = None

    def add(self, object_index: int, part_key: str, codes: np.ndarray | None = None) -> int:
        """Merge the codes of object ``object_index``, once (a repeated call changes nothing): ``codes`` as sent
        by the worker that committed the part, or else read from the part. Returns the unique-code count so
        far: an upper bound until the pending runs are compacted, so that a call costs O(part), not O(all)."""
        if object_index not in self.merged:
            self.index.add(self.parts.read_array(part_key, "code") if codes is None else codes)
            self.merged.add(object_index)
        return self.index.size_bound()

    def commit(self, results: list[ObjectResult]) -> CommitSummary:
        """Fold in anything not merged yet, then write the dataset."""
        for result in results:
            if result.status == "ok":
                self.add(result.index, result.part_key)
        summary, self.unique_codes = commit_dataset(self.spec, results, self.parts, self.index)
        self.grasps = summary.grasps
        return summary

    def committed(self) -> CommitSummary:
        """The counts of the dataset committed at the spec's output (by this actor or an earlier job)."""
        reader = DatasetReader(self.spec.output)
        exact = "exact/code" if reader.has("exact/code") else "unique/code"
        return CommitSummary(grasps=int(reader.array("grasps/code").shape[0]),
                             unique_codes=int(reader.array("unique/code").shape[0]),
                             exact_unique_codes=int(reader.array(exact).shape[0]))

    def patch_tasks(self) -> list[PatchTask]:
        """The patch cutting in shards for the workers."""
        return patch_tasks(self.spec, self.spec.output)

    def assemble(self, tasks: list[PatchTask], results: list[ShardResult]) -> AssemblyReport:
        """Read the patches the workers cut (each unique code's, from its representative's source object), build
        the one object from them and store it under ``assembled/``."""
        reader = DatasetReader(self.spec.output)
        if self.unique_codes is None or self.grasps is None:
            self.unique_codes, self.grasps = reader["unique/code"], int(reader.array("grasps/code").shape[0])
        patches = merge_patch_shards(self.spec, reader, self.parts, tasks, results)
        return assemble_dataset(self.spec, self.spec.output, self.unique_codes, patches, self.grasps)

    def label_tasks(self) -> list[LabelTask]:
        """The label stage in shards for the workers (the one object must be assembled)."""
        if self.spec.budget.enabled:
            return budget_tasks(self.spec, self.spec.output)
        if not DatasetReader(self.spec.output).attrs.get("assembly"):
            raise MissingAssembly(f"{self.spec.output}: the label stage needs an assembled object "
                                  "(run the assemble stage first)")
        return label_tasks(self.spec, self.spec.output)

    def merge_labels(self, tasks: list[LabelTask], results: list[ShardResult]) -> LabelReport:
        """Write the workers' labelled shards as ``assembled/grasps/``, then measure label transfer."""
        for task, result in zip(tasks, results, strict=True):
            if result.status != "ok":
                raise JobError(f"label shard {result.index} (patches {task.start}-{task.stop - 1}): {result.reason}")
        if self.spec.budget.enabled or self.spec.adaptive.enabled:
            seconds = sum(result.made_seconds for result in results)
            return write_budget_labels(self.spec, self.spec.output, tasks, self.parts, seconds)
        report = write_labels(self.spec, self.spec.output, tasks, self.parts)
        if self.spec.sim.transfer_codes:
            transfer = measure_transfer(self.spec, DatasetReader(self.spec.output), self.parts)
            report = report.model_copy(update={"transfer": transfer})
            update_attributes(self.spec.output, {"assembly_labels": report.model_dump(mode="json")})
        return report

    def record_rounds(self, record: AdaptiveReport, scores: np.ndarray) -> None:
        """Adaptive labelling's rounds: ``adaptive/`` (each round's scores of every candidate, the validation
        objects, each round's network under ``round_NNN/``) and the ``adaptive`` attribute."""
        groups = {"adaptive": {"scores": scores.astype(np.float32),  # the parent first, then its round groups
                               "validation_objects": np.asarray(record.validation_objects, dtype=np.int64)}}
        groups.update({f"adaptive/round_{r.round:03d}": round_weights(self.parts, r.part) for r in record.rounds})
        write_groups(self.spec.output, groups,
                     {"adaptive": {**record.model_dump(mode="json"), "model": self.spec.train.model}})


class WriterClient(ActorClient):
    """The central actor of one job on Ray, on the driver's node (losing a worker node does not take it down)."""

    served = DatasetWriter

    @classmethod
    def start(cls, spec: JobSpec, job_id: str) -> WriterClient:
        name = central_name(job_id)
        handle = restartable_actor(DatasetWriter, name, num_cpus=0, scheduling_strategy=on_this_node()).remote(spec)
        return cls(handle, f"central actor {name}")

    @classmethod
    def find(cls, name: str) -> WriterClient | None:
        """The running central actor ``name``, or None while it is restarting or gone."""
        import ray


        try:
            return cls(ray.get_actor(name, namespace=NAMESPACE), f"central actor {name}")
        except ValueError:
            return None

    def send_codes(self, object_index: int, part_key: str, codes: np.ndarray) -> None:
        self.send("add", object_index, part_key, codes)

    def commit(self, results: list[ObjectResult]) -> CommitSummary:
        return self.call("commit", results)

    def committed(self) -> CommitSummary:
        return self.call("committed")

    def patch_tasks(self) -> list[PatchTask]:
        return self.call("patch_tasks")

    def assemble(self, tasks: list[PatchTask], results: list[ShardResult]) -> AssemblyReport:
        return self.call("assemble", tasks, results)

    def label_tasks(self) -> list[LabelTask]:
        return self.call("label_tasks")

    def merge_labels(self, tasks: list[LabelTask], results: list[ShardResult]) -> LabelReport:
        return self.call("merge_labels", tasks, results)

    def record_rounds(self, record: AdaptiveReport, scores: np.ndarray) -> None:
        return self.call("record_rounds", record, scores)


def central_name(job_id: str) -> str:
    return f"central-{job_id}"
