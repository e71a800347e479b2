"""One spine for every job: its stages in order, each inside one :func:`stage` block that names the stage in the
status, times it, saves the status and reports progress.

The in-process and Ray runtimes (runtime.local.LocalRuntime, runtime.ray_runner.RayRuntime) implement
:class:`Runtime`: how extraction is spread, where the central actor lives and who trains. Stages: ingest,
extract, dedup (the commit), assemble, label, train, evaluate.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Protocol

from onepiece_dist.errors import JobCancelled, JobError, SourceError, SpecError
from onepiece_dist.job.results import CommitSummary, LabelTask, ObjectResult, PatchTask, ShardResult
from onepiece_dist.job.stages.evaluate import evaluation_spec, objects_scored, record_evaluation
from onepiece_dist.job.status import (
    AdaptiveReport,
    AssemblyReport,
    EvaluationReport,
    JobStatus,
    LabelReport,
    Rejection,
    TrainingReport,
)
from onepiece_dist.objects import ObjectRef, resolve_source
from onepiece_dist.specs.job import JobSpec

if TYPE_CHECKING:  # torch loads where a trainer trains
    import numpy as np

    from onepiece_dist.learn.train import StepResult, StepRun

Report = Callable[[JobStatus], None]  # called whenever the status changes: save it, publish it, draw progress
ProgressFn = Callable[[JobStatus], None]  # a caller's progress display, called after each report
log = logging.getLogger("onepiece_dist.job")  # progress lines: the CLI shows them on stderr, `ray job logs` too


class Central(Protocol):
    """The central actor's job-facing methods: :class:`~onepiece_dist.runtime.writer.DatasetWriter` in process,
    its client on Ray."""

    def commit(self, results: list[ObjectResult]) -> CommitSummary: ...
    def committed(self) -> CommitSummary: ...
    def patch_tasks(self) -> list[PatchTask]: ...
    def assemble(self, tasks: list[PatchTask], results: list[ShardResult]) -> AssemblyReport: ...
    def label_tasks(self) -> list[LabelTask]: ...
    def merge_labels(self, tasks: list[LabelTask], results: list[ShardResult]) -> LabelReport: ...
    def record_rounds(self, record: AdaptiveReport, scores: np.ndarray) -> None: ...


class Runtime(ABC):
    """Where a job's work runs: in this process (``runtime.local.LocalRuntime``) or on Ray
    (``runtime.ray_runner.RayRuntime``). The pipeline calls these methods in stage order; ``central`` is the
    dataset's single writer (the central actor)."""

    central: Central

    @abstractmethod
    def report(self, status: JobStatus) -> None:
        """The status changed: save it where the job's users read it."""

    @abstractmethod
    def extract(self, refs: list[ObjectRef], on_result: Callable[[ObjectResult], None]) -> list[ObjectResult]:
        """Every object's extraction, its results in object order (``on_result`` as each comes)."""

    @abstractmethod
    def patch(self, tasks: list[PatchTask]) -> list[ShardResult]:
        """The patch shards cut by the workers, their results in task order."""

    @abstractmethod
    def label(self, tasks: list[LabelTask]) -> list[ShardResult]:
        """The label shards simulated by the workers (not the central actor), their results in task order."""

    @abstractmethod
    def train(self, spec: JobSpec) -> TrainingReport:
        """The network trained on the job's labelled grasps."""

    @abstractmethod
    def fit_round(self, run: StepRun) -> StepResult:
        """Adaptive labelling: one round's training."""

    @abstractmethod
    def label_heldout(self, heldout: JobSpec) -> JobStatus:
        """The held-out objects' labelling job (``evaluation_spec``), run on this runtime."""

    @abstractmethod
    def score(self, job: JobSpec, dataset: str, objects: int) -> EvaluationReport:
        """The job's trained network scored on the labelled held-out dataset of ``objects`` objects."""

    def prepare(self, stage: str) -> None:
        """Start what ``stage`` will need (its workers) while the central actor is busy with the stage before it;
        by default nothing (workers start when the stage does)."""
        return None

    def evaluate(self, job: JobSpec) -> EvaluationReport:
        """The evaluate stage, the same on every runtime: a labelling job on the held-out objects, then the trained
        network scored on them."""
        heldout = evaluation_spec(job)
        labelled = self.label_heldout(heldout)
        return record_evaluation(job, self.score(job, heldout.output, objects_scored(labelled)))


def new_status(spec: JobSpec, job_id: str) -> JobStatus:
    return JobStatus(job_id=job_id, state="running", stage="ingest", output=spec.output,
                     spec=spec.model_dump(mode="json"), driver=f"{socket.gethostname()}:{os.getpid()}")


@contextmanager
def stage(status: JobStatus, name: str, report: Report) -> Iterator[None]:
    """Run the block as stage ``name``: shown in the status while it runs, its wall time in ``timings``."""
    status.stage = name
    report(status)
    log.info("job %s: %s started", status.job_id, name)
    start = time.perf_counter()
    yield
    status.timings[name] = time.perf_counter() - start
    log.info("job %s: %s done in %.1f s%s", status.job_id, name, status.timings[name], _stage_summary(status, name))
    report(status)


def _stage_summary(status: JobStatus, name: str) -> str:
    p = status.progress
    summaries = {"ingest": f" ({p.objects_total} objects)",
                 "extract": f" ({p.objects_done} objects, {p.grasps} grasps, {len(status.rejections)} rejected)",
                 "dedup": f" ({p.unique_codes} unique codes)"}
    return summaries.get(name, "")


def run_pipeline(spec: JobSpec, status: JobStatus, runtime: Runtime,
                 refs: list[ObjectRef] | None = None) -> JobStatus:
    """Run the spec's stages on ``refs`` (resolved from ``spec.objects`` when not given); the status ends
    'succeeded', or 'failed'/'cancelled' with a :class:`JobError` raised (a :class:`SourceError`, a usage error,
    as it is). Without 'extract', the later stages run on the dataset already committed at the output."""
    report = runtime.report
    try:
        _run_stages(spec, status, runtime, report, refs)
    except BaseException as err:
        status.state = "cancelled" if isinstance(err, JobCancelled) else "failed"
        status.error = f"{type(err).__name__}: {err}"
        log.info("job %s %s during its %s stage (%s)", status.job_id, status.state, status.stage, type(err).__name__)
        report(status)
        if isinstance(err, JobError | SourceError | SpecError) or not isinstance(err, Exception):
            raise
        raise JobError(f"job {status.job_id} {status.state}: {err}") from err
    status.state, status.stage = "succeeded", "done"
    log.info("job %s succeeded", status.job_id)
    report(status)
    return status


def _run_stages(spec: JobSpec, status: JobStatus, runtime: Runtime, report: Report,
                refs: list[ObjectRef] | None) -> None:
    with stage(status, "ingest", report):
        refs = resolve_source(spec.objects) if refs is None else refs
        status.progress.objects_total = len(refs)
        if spec.budget.enabled:
            from onepiece_dist.job.stages.label_budget import check_budget

            check_budget(spec, len(refs))
    if spec.runs("extract"):
        with stage(status, "extract", report):
            results = runtime.extract(refs, lambda result: (record_result(status, result), report(status)))
        with stage(status, "dedup", report):
            summary = runtime.central.commit(results)
            status.progress.unique_codes = summary.unique_codes
    elif spec.runs("assemble") or spec.runs("label"):
        summary = runtime.central.committed()
    else:
        summary = None  # training alone needs only the labelled grasps
    if summary is not None:
        status.progress.unique_codes = summary.unique_codes
    shapes = summary.exact_unique_codes if summary is not None else 0
    if spec.runs("assemble") and shapes:
        with stage(status, "assemble", report):
            tasks = runtime.central.patch_tasks()
            shards = runtime.patch(tasks)  # the workers cut the patches
            if spec.runs("label"):
                runtime.prepare("label")  # label workers start up (imports, pybullet) while the one object is built
            status.assembly = runtime.central.assemble(tasks, shards)
    if spec.runs("label") and shapes and spec.adaptive.enabled:
        from onepiece_dist.job.stages.label_rounds import label_in_rounds

        with stage(status, "label", report):
            status.labels = label_in_rounds(spec, status, runtime.central, runtime.label, runtime.fit_round, report)
    elif spec.runs("label") and shapes:
        with stage(status, "label", report):
            tasks = runtime.central.label_tasks()
            shards = runtime.label(tasks)
            status.label_seconds = sum(shard.made_seconds for shard in shards)
            status.labels = runtime.central.merge_labels(tasks, shards)
    if spec.runs("train"):
        with stage(status, "train", report):
            status.training = runtime.train(spec)
    if spec.runs("evaluate"):
        with stage(status, "evaluate", report):
            status.evaluation = runtime.evaluate(spec)


def record_result(status: JobStatus, result: ObjectResult) -> None:
    """Fold one object's result into the job's progress."""
    status.progress.objects_done += 1
    log.info("job %s: extract %d/%d objects (%s: %s, %d grasps%s)", status.job_id, status.progress.objects_done,
             status.progress.objects_total, result.name, result.status, result.grasps,
             (f"; repaired: {result.repairs}" if result.repairs else "")
             + (f"; {result.shortfall}" if result.shortfall else ""))
    status.worker_seconds += result.seconds
    status.part_seconds += result.made_seconds
    if result.node and result.node not in status.nodes:
        status.nodes.append(result.node)
    status.progress.objects_reused += int(result.reused)
    status.progress.grasps += result.grasps
    if result.status == "rejected":
        status.rejections.append(Rejection(name=result.name, reason=result.reason))
