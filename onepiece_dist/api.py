"""Python API: run a job, open a dataset."""

from __future__ import annotations

from onepiece_dist.service.local import ProgressFn, run_local
from onepiece_dist.service.status import JobStatus
from onepiece_dist.spec import JobSpec
from onepiece_dist.store import DatasetReader, open_dataset

__all__ = ["DatasetReader", "JobSpec", "JobStatus", "open_dataset", "run_job"]


def run_job(spec: JobSpec, progress: ProgressFn | None = None) -> JobStatus:
    """Run ``spec`` to completion in this process and return its final status (the Ray runner is issue #4)."""
    return run_local(spec, progress=progress)
