"""Python API: run a job, open a dataset."""

from __future__ import annotations

from onepiece_dist.service.local import ProgressFn, run_local
from onepiece_dist.service.status import JobStatus
from onepiece_dist.spec import JobSpec
from onepiece_dist.store import DatasetReader, open_dataset

__all__ = ["DatasetReader", "JobSpec", "JobStatus", "open_dataset", "run_job"]


def run_job(spec: JobSpec, use_ray: bool = False, progress: ProgressFn | None = None) -> JobStatus:
    """Run ``spec`` to completion and return its final status: in this process, or on an embedded Ray with
    extraction worker actors (``use_ray``; then Ray is shut down again)."""
    if not use_ray:
        return run_local(spec, progress=progress)
    import ray

    from onepiece_dist.service.ray_runner import run_ray

    try:
        return run_ray(spec, progress=progress)
    finally:
        ray.shutdown()
