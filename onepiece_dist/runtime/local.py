"""In-process runner: the job's pipeline with one object at a time, the central actor and the trainer as plain
objects in this process.

Used for debugging and as the reference that the distributed runner must match byte for byte. Simulation runs
with glibc's math functions pinned as on every worker: here, or in a child where this process is not pinned.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from onepiece_dist.job.pipeline import ProgressFn, Runtime, new_status, run_pipeline
from onepiece_dist.job.results import LabelTask, ObjectResult, PatchTask, ShardResult
from onepiece_dist.job.stages.extract import extract_object
from onepiece_dist.job.stages.label_one_object import label_shard
from onepiece_dist.job.stages.patch_shards import build_patch_shard
from onepiece_dist.job.status import EvaluationReport, JobStatus, TrainingReport
from onepiece_dist.objects import ObjectRef
from onepiece_dist.runtime.pinned_child import PinnedSimulation
from onepiece_dist.runtime.trainer import Trainer
from onepiece_dist.runtime.writer import DatasetWriter
from onepiece_dist.sim.collision import user_decompositions
from onepiece_dist.specs.job import JobSpec

if TYPE_CHECKING:
    from onepiece_dist.learn.train import StepResult, StepRun


def with_user_decompositions(spec: JobSpec) -> JobSpec:
    """``spec`` keeping its decompositions in this user's folder (sim.collision.user_decompositions) unless it
    names one: a local run's (the API's and the CLI's), so that its objects are decomposed once on this machine,
    not once a job. The folder is a place, not content: the dataset's content digest leaves it out."""
    return spec if spec.decompositions else spec.model_copy(update={"decompositions": str(user_decompositions())})


def run_local(spec: JobSpec, job_id: str = "local", progress: ProgressFn | None = None,
              refs: list[ObjectRef] | None = None) -> JobStatus:
    """Run the spec's stages in this process on ``refs`` (default: resolved from ``spec.objects``). Without
    'extract', the later stages run on the committed dataset."""
    runtime = LocalRuntime(spec, job_id, progress)
    try:
        return run_pipeline(spec, new_status(spec, job_id), runtime, refs)
    finally:
        runtime.close()


class LocalRuntime(Runtime):
    """One object or shard at a time, simulated in a pinned process; the central actor and the trainer are plain
    objects here."""

    def __init__(self, spec: JobSpec, job_id: str, progress: ProgressFn | None = None):
        self.spec, self.job_id, self.progress = spec, job_id, progress
        self.central = DatasetWriter(spec)
        self.central.parts.remove_stale_temporaries()
        self.simulate = PinnedSimulation()
        self.trainer = Trainer()

    def close(self) -> None:
        self.simulate.close()

    def report(self, status: JobStatus) -> None:
        status.save(self.spec.output)
        if self.progress:
            self.progress(status)

    def extract(self, refs: list[ObjectRef], on_result: Callable[[ObjectResult], None]) -> list[ObjectResult]:
        results = []
        for index, ref in enumerate(refs):
            results.append(self.simulate(extract_object, self.spec, ref, index, self.central.parts))
            if results[-1].status == "ok":
                self.central.add(index, results[-1].part_key)
            on_result(results[-1])
        return results

    def label(self, tasks: list[LabelTask]) -> list[ShardResult]:
        return [self.simulate(label_shard, self.spec, task, index, self.central.parts)
                for index, task in enumerate(tasks)]

    def patch(self, tasks: list[PatchTask]) -> list[ShardResult]:
        return [build_patch_shard(self.spec, task, index, self.central.parts) for index, task in enumerate(tasks)]

    def train(self, spec: JobSpec) -> TrainingReport:
        return self.trainer.fit(spec)

    def fit_round(self, run: StepRun) -> StepResult:
        return self.trainer.fit_steps(run)

    def label_heldout(self, heldout: JobSpec) -> JobStatus:
        return run_local(heldout, job_id=f"{self.job_id}-evaluate")

    def score(self, job: JobSpec, dataset: str, objects: int) -> EvaluationReport:
        return self.trainer.score(job, dataset, objects)
