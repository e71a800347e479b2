"""In-process runner: the same per-object and commit functions the Ray runner uses, one object at a time.

Used for debugging and as the reference that the distributed runner must match byte for byte.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from onepiece_dist.errors import JobError, OnePieceError
from onepiece_dist.objects import resolve_source
from onepiece_dist.service.commit import commit_dataset, existing_summary
from onepiece_dist.service.extract import ObjectResult, extract_object, parts_for
from onepiece_dist.service.status import JobStatus, Rejection
from onepiece_dist.service.trainer import Trainer
from onepiece_dist.spec import JobSpec
from onepiece_dist.store import PartStore

ProgressFn = Callable[[JobStatus], None]


def run_local(spec: JobSpec, job_id: str = "local", progress: ProgressFn | None = None) -> JobStatus:
    """Run the spec's stages in this process. Without 'extract', the later stages run on the committed dataset."""
    status = JobStatus(job_id=job_id, state="running", stage="ingest", output=spec.output,
                       spec=spec.model_dump(mode="json"))
    t0 = time.perf_counter()
    refs = resolve_source(spec.objects)
    status.progress.objects_total = len(refs)
    status.timings["ingest"] = time.perf_counter() - t0
    status.stage = "extract"
    parts = parts_for(spec)
    parts.remove_stale_temporaries()
    results: list[ObjectResult] = []
    t0 = time.perf_counter()
    try:
        for index, ref in enumerate(refs if "extract" in spec.stages else []):
            results.append(extract_object(spec, ref, index, parts))
            record_result(status, results[-1])
            status.save(spec.output)
            if progress:
                progress(status)
        status.timings["extract"] = time.perf_counter() - t0
        return finish(spec, status, results, parts)
    except OnePieceError as err:
        status.state, status.error = "failed", f"{type(err).__name__}: {err}"
        status.save(spec.output)
        raise JobError(f"job {job_id} failed: {err}") from err


def record_result(status: JobStatus, result: ObjectResult) -> None:
    status.progress.objects_done += 1
    status.worker_seconds += result.seconds
    if result.node and result.node not in status.nodes:
        status.nodes.append(result.node)
    status.progress.objects_reused += int(result.reused)
    status.progress.grasps += result.grasps
    if result.status == "rejected":
        status.rejections.append(Rejection(name=result.name, reason=result.reason))


def finish(spec: JobSpec, status: JobStatus, results: list[ObjectResult], parts: PartStore,
           commit=None, train=None) -> JobStatus:
    """Commit the dataset (by ``commit(results)`` when given, e.g. the central dedup actor), run the train stage
    (by ``train(spec)`` when given, e.g. the trainer actor) and close the status."""
    train = train or Trainer().fit
    status.stage = "dedup" if "extract" in spec.stages else "assemble"
    t0 = time.perf_counter()
    if "extract" not in spec.stages:  # later stages only, on the committed dataset
        summary = existing_summary(spec, spec.output)
    else:
        summary = commit(results) if commit else commit_dataset(spec, results, parts, spec.output)
    status.timings["dedup"] = time.perf_counter() - t0
    status.timings.update(summary.get("seconds", {}))  # dedup alone, assemble, label when measured apart
    status.progress.unique_codes = summary["unique_codes"]
    if "assembly" in summary:
        status.assembly = summary["assembly"]
    if "train" in spec.stages:
        status.stage = "train"
        status.save(spec.output)
        t0 = time.perf_counter()
        status.training = train(spec)
        status.timings["train"] = time.perf_counter() - t0
    status.state, status.stage = "succeeded", "done"
    status.save(spec.output)
    return status
