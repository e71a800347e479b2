"""Ray runner (first cut): extraction worker actors, one pybullet client each, fed objects with bounded
in-flight work through ``ray.wait``; results are small summaries, parts are written by the workers themselves;
the driver is the single committer. Same per-object and commit functions as the in-process runner, so both give
the same dataset.
"""

from __future__ import annotations

import time

from onepiece_dist.objects import ObjectRef, resolve_source
from onepiece_dist.service.extract import ObjectResult, extract_object
from onepiece_dist.service.local import ProgressFn, finish, parts_for, record_result
from onepiece_dist.service.status import JobStatus
from onepiece_dist.spec import JobSpec

NAMESPACE = "onepiece"
IN_FLIGHT_PER_WORKER = 2


class ExtractionWorker:
    """Plain class (testable without Ray); wrapped by ``ray.remote`` in :func:`run_ray`."""

    def __init__(self, spec: JobSpec):
        self.spec = spec
        self.parts = parts_for(spec)

    def extract(self, ref: ObjectRef, index: int) -> ObjectResult:
        return extract_object(self.spec, ref, index, self.parts)


def start_local_ray(num_cpus: int | None = None) -> None:
    """An embedded Ray bound to 127.0.0.1 with the dashboard off."""
    import ray

    if not ray.is_initialized():
        ray.init(num_cpus=num_cpus, include_dashboard=False, _node_ip_address="127.0.0.1", namespace=NAMESPACE,
                 log_to_driver=False, configure_logging=False)


def run_ray(spec: JobSpec, workers: int | None = None, job_id: str = "ray",
            progress: ProgressFn | None = None) -> JobStatus:
    """Run the job on the connected (or a new embedded) Ray; the driver commits the dataset."""
    import ray

    start_local_ray()
    status = JobStatus(job_id=job_id, state="running", stage="extract", output=spec.output)
    refs = resolve_source(spec.objects)
    status.progress.objects_total = len(refs)
    count = max(1, min(workers or int(ray.available_resources().get("CPU", 1)), len(refs) or 1))
    actor_cls = ray.remote(num_cpus=1, max_restarts=3, max_task_retries=3)(ExtractionWorker)
    actors = [actor_cls.remote(spec) for _ in range(count)]
    t0 = time.perf_counter()
    results = _drain(refs, actors, status, progress)
    status.timings["extract"] = time.perf_counter() - t0
    for actor in actors:
        ray.kill(actor)
    return finish(spec, status, sorted(results, key=lambda r: r.index), parts_for(spec))


def _drain(refs: list[ObjectRef], actors: list, status: JobStatus, progress: ProgressFn | None) -> list[ObjectResult]:
    """Keep at most IN_FLIGHT_PER_WORKER tasks per actor in flight; collect summaries as they finish."""
    import ray

    pending: dict = {}
    results: list[ObjectResult] = []
    todo = list(enumerate(refs))
    while todo or pending:
        while todo and len(pending) < IN_FLIGHT_PER_WORKER * len(actors):
            index, ref = todo.pop(0)
            actor = actors[index % len(actors)]
            pending[actor.extract.remote(ref, index)] = index
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            pending.pop(ref)
            results.append(ray.get(ref))
            record_result(status, results[-1])
            if progress:
                progress(status)
    return results
