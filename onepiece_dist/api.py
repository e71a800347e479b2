"""Python API: run or submit jobs, watch them, open datasets. The CLI is a thin layer over this module.

    from onepiece_dist.api import Client, JobSpec
    handle = Client().submit(JobSpec(objects="pybullet:random_urdfs[0:8]"))
    print(handle.wait().progress)

``Client(address=None)`` runs jobs on an embedded Ray (loopback only) in a background thread of this process;
``Client(address="http://127.0.0.1:8265")`` submits them to a cluster through the Ray Jobs API, where they keep
running when the submitter goes away.
"""

from __future__ import annotations

import contextlib
import shlex
import threading
import time
from pathlib import Path

from onepiece_dist.errors import ClusterUnreachable, JobError
from onepiece_dist.objects import resolve_source
from onepiece_dist.service.local import run_local
from onepiece_dist.service.pipeline import ProgressFn
from onepiece_dist.service.status import JobStatus, status_path
from onepiece_dist.spec import JobSpec, default_job_id
from onepiece_dist.store import DatasetReader, open_dataset

__all__ = ["Client", "ClusterUnreachable", "DatasetReader", "JobHandle", "JobSpec", "JobStatus", "open_dataset",
           "run_job"]

TERMINAL = ("succeeded", "failed", "cancelled")
_RAY_JOB_STATES = {"PENDING": "pending", "RUNNING": "running", "SUCCEEDED": "succeeded", "FAILED": "failed",
                   "STOPPED": "cancelled"}


def run_job(spec: JobSpec, address: str | None = None, in_process: bool = False, job_id: str | None = None,
            workers: int | None = None, progress: ProgressFn | None = None) -> JobStatus:
    """Run ``spec`` to completion here and return its final status: on an embedded Ray (default), on the
    cluster at ``address`` (this process is the driver), or without Ray (``in_process``)."""
    job_id = job_id or default_job_id(spec)
    refs = resolve_source(spec.objects)  # a bad source is a usage error, found before any Ray starts
    if in_process:
        return run_local(spec, job_id=job_id, progress=progress, refs=refs)
    import ray

    from onepiece_dist.service.ray_env import connect
    from onepiece_dist.service.ray_runner import run_on_ray

    started_here = not ray.is_initialized()
    _connect_or_raise(connect, address)
    try:
        return run_on_ray(spec, job_id, workers=workers, progress=progress, refs=refs)
    finally:
        if started_here:
            with contextlib.suppress(Exception):  # a runtime that died under the job may not shut down cleanly
                ray.shutdown()


def _connect_or_raise(connect, address: str | None) -> None:
    try:
        connect(address)
    except ConnectionError as err:
        raise ClusterUnreachable(f"no Ray cluster at {address}: {err}") from None


def read_status(dataset: str | Path) -> JobStatus:
    """The status written beside a dataset (readable after the cluster is gone)."""
    path = status_path(dataset)
    if not path.is_file():
        raise JobError(f"no job status at {path}")
    return JobStatus.load(dataset)


class JobHandle:
    """A submitted job: ``status()``, ``wait()``, ``cancel()``."""

    def __init__(self, client: Client, job_id: str, output: str, thread: threading.Thread | None = None):
        self.client, self.job_id, self.output, self._thread = client, job_id, output, thread
        self.error: JobError | None = None  # why a job driven from this process did not run or failed

    def status(self) -> JobStatus:
        return self.client.status(self.job_id, self.output)

    def wait(self, timeout: float | None = None, poll: float = 1.0) -> JobStatus:
        """Block until the job ends; returns its final status (raises TimeoutError after ``timeout`` s)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise TimeoutError(f"job {self.job_id} still running after {timeout} s")
            return self.status()
        while (current := self.status()).state not in TERMINAL:
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"job {self.job_id} still running after {timeout} s")
            time.sleep(poll)
        return current

    def cancel(self) -> None:
        self.client.cancel(self.job_id)


class Client:
    """Jobs on an embedded Ray (``address=None``) or on a cluster's Jobs API (``address='http://host:8265'``)."""

    def __init__(self, address: str | None = None):
        self.address = address
        self._jobs_api = None
        self._local: dict[str, JobHandle] = {}

    # -- cluster (Jobs API) -------------------------------------------------------------------------------
    def jobs_api(self):
        if self._jobs_api is None:
            from onepiece_dist.service.ray_env import loopback_environment

            loopback_environment(cluster_client=True)  # token auth, set before Ray reads it
            from ray.exceptions import AuthenticationError
            from ray.job_submission import JobSubmissionClient

            try:
                self._jobs_api = JobSubmissionClient(self.address)
            except (ConnectionError, RuntimeError, ValueError, AuthenticationError) as err:
                raise ClusterUnreachable(f"no Ray Jobs API at {self.address}: {err}") from None
        return self._jobs_api

    def submit(self, spec: JobSpec, job_id: str | None = None, runtime_env: dict | None = None) -> JobHandle:
        job_id = job_id or default_job_id(spec)
        if self.address is None:
            return self._submit_local(spec, job_id)
        entrypoint = (f"python -m onepiece_dist.cli run --address auto --job-id {shlex.quote(job_id)} "
                      f"--spec-json {shlex.quote(spec.model_dump_json())}")
        try:
            self.jobs_api().submit_job(entrypoint=entrypoint, submission_id=job_id, runtime_env=runtime_env,
                                       metadata={"output": spec.output})
        except RuntimeError as err:
            if "already exists" not in str(err):
                raise
        return JobHandle(self, job_id, spec.output)

    def _submit_local(self, spec: JobSpec, job_id: str) -> JobHandle:
        from onepiece_dist.service.ray_env import connect
        from onepiece_dist.service.ray_runner import run_on_ray

        connect(None)
        handle = JobHandle(self, job_id, spec.output)

        def drive() -> None:
            try:
                run_on_ray(spec, job_id)
            except JobError as err:
                handle.error = err

        handle._thread = threading.Thread(target=drive, name=f"onepiece-{job_id}", daemon=True)
        handle._thread.start()
        self._local.setdefault(job_id, handle)
        return handle

    def status(self, job_id: str, output: str | None = None) -> JobStatus:
        """Latest status: the registry (embedded Ray), else the Jobs API state plus the status file."""
        if self.address is None:
            output = output or (self._local[job_id].output if job_id in self._local else None)
            found = self._registry_status(job_id)
            if found is None and output and status_path(output).is_file():
                found = read_status(output)
            return found or JobStatus(job_id=job_id, state="pending", output=output or "")
        info = self.jobs_api().get_job_info(job_id)
        output = output or (info.metadata or {}).get("output")
        status = read_status(output) if output and status_path(output).is_file() else JobStatus(job_id=job_id)
        status.state = _RAY_JOB_STATES.get(str(info.status).split(".")[-1], "pending")  # the driver's fate
        return status

    def _registry_status(self, job_id: str) -> JobStatus | None:
        registry = _registry()
        found = registry.get(job_id) if registry else None
        return JobStatus.model_validate(found) if found else None

    def cancel(self, job_id: str) -> None:
        if self.address is None:
            registry = _registry()
            if registry:
                registry.request_cancel(job_id)
        else:
            self.jobs_api().stop_job(job_id)

    def jobs(self) -> list[dict]:
        if self.address is None:
            registry = _registry()
            return registry.jobs() if registry else []
        return [{"job_id": j.submission_id, "state": _RAY_JOB_STATES.get(str(j.status).split(".")[-1], "pending"),
                 "output": (j.metadata or {}).get("output", "")} for j in self.jobs_api().list_jobs()
                if j.submission_id]

    def logs(self, job_id: str) -> str:
        return self.jobs_api().get_job_logs(job_id)


def _registry():
    """The embedded Ray's job registry, or None when this process has no Ray."""
    import ray

    from onepiece_dist.service.registry import RegistryClient

    return RegistryClient() if ray.is_initialized() else None
