"""In-process runner: the job's pipeline with one object at a time, the central actor and the trainer as plain
objects in this process.

Used for debugging and as the reference that the distributed runner must match byte for byte. Simulation runs
with glibc's math functions pinned as on every worker: here, or in a child where this process is not pinned.
"""

from __future__ import annotations

from collections.abc import Callable

from onepiece_dist.job.pipeline import ProgressFn, Runtime, new_status, run_pipeline
from onepiece_dist.job.results import LabelShardResult, LabelTask, ObjectResult, PatchTask
from onepiece_dist.job.runtime.pinned_child import PinnedSimulation
from onepiece_dist.job.runtime.trainer import Trainer, objects_scored
from onepiece_dist.job.runtime.writer import CentralActor
from onepiece_dist.job.stages.evaluate import evaluation_spec, record_evaluation
from onepiece_dist.job.stages.extract import extract_object
from onepiece_dist.job.stages.label_one_object import label_shard
from onepiece_dist.job.stages.patch_shards import build_patch_shard
from onepiece_dist.job.status import EvaluationReport, JobStatus
from onepiece_dist.objects import ObjectRef
from onepiece_dist.spec import JobSpec


def run_local(spec: JobSpec, job_id: str = "local", progress: ProgressFn | None = None,
              refs: list[ObjectRef] | None = None) -> JobStatus:
    """Run the spec's stages in this process on ``refs`` (default: resolved from ``spec.objects``). Without
    'extract', the later stages run on the committed dataset."""
    central = CentralActor(spec)
    central.parts.remove_stale_temporaries()
    simulate = PinnedSimulation()

    def extract(refs: list[ObjectRef], on_result: Callable[[ObjectResult], None]) -> list[ObjectResult]:
        results = []
        for index, ref in enumerate(refs):
            results.append(simulate(extract_object, spec, ref, index, central.parts))
            if results[-1].status == "ok":
                central.add(index, results[-1].part_key)
            on_result(results[-1])
        return results

    def report(status: JobStatus) -> None:
        status.save(spec.output)
        if progress:
            progress(status)

    def label(tasks: list[LabelTask]) -> list[LabelShardResult]:
        return [simulate(label_shard, spec, task, index, central.parts) for index, task in enumerate(tasks)]

    def patch(tasks: list[PatchTask]) -> list[LabelShardResult]:
        return [build_patch_shard(spec, task, index, central.parts) for index, task in enumerate(tasks)]

    trainer = Trainer()

    def evaluate(job: JobSpec) -> EvaluationReport:
        heldout = evaluation_spec(job)
        labelled = run_local(heldout, job_id=f"{job_id}-evaluate")
        return record_evaluation(job, trainer.score(job, heldout.output, objects_scored(labelled)))

    runtime = Runtime(extract=extract, central=central, label=label, patch=patch, train=trainer.fit,
                      evaluate=evaluate, fit_round=trainer.fit_steps)
    try:
        return run_pipeline(spec, new_status(spec, job_id), runtime, report, refs)
    finally:
        simulate.close()
