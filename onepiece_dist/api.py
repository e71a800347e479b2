"""Python API: run or submit jobs, watch them, open datasets. The CLI is a thin layer over this module.

    from onepiece_dist.api import Client, JobSpec
    handle = Client().submit(JobSpec(objects="pybullet:random_urdfs[0:8]"))
    print(handle.wait().progress)

    from onepiece_dist.api import PickSpec, run_picks   # the pick benchmark (docs/picks.md)
    report = run_picks(PickSpec(checkpoint="data/x.zarr.train/best.pt", objects="meshes/"))

    from onepiece_dist.api import plan_grasps           # grasps on a camera's files (docs/planning.md)
    planned = plan_grasps("depth.png", intrinsics="k.json", camera_pose="camera.json")  # first 3 checked in sim

``Client(address=None)`` runs jobs on an embedded Ray (loopback only) in a background thread of this process;
``Client(address="http://127.0.0.1:8265")`` submits them to a cluster through the Ray Jobs API, where they keep
running when the submitter goes away.
"""

from __future__ import annotations

import contextlib
import json
import shlex
import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

from onepiece_dist.errors import ClusterUnreachable, DriverGone, JobError, JobNotFound, SpecError, VersionMismatch
from onepiece_dist.job.pipeline import ProgressFn
from onepiece_dist.job.relabel import RelabelReport, relabel_report, relabel_spec
from onepiece_dist.job.stages.evaluate import heldout_sim, objects_scored, protocol_of, score_heldout
from onepiece_dist.job.status import STATUS_SUFFIX, EvaluationReport, JobStatus, status_path, without_status_lines
from onepiece_dist.objects import resolve_source
from onepiece_dist.picks.pick_labels import run_pick_labels
from onepiece_dist.picks.runner import PickReport, run_picks
from onepiece_dist.picks.shape_check import plan_checked as plan_grasps
from onepiece_dist.plan.robot import RobotPlan
from onepiece_dist.runtime.local import run_local, with_user_decompositions
from onepiece_dist.runtime.ray_env import connect, loopback_environment
from onepiece_dist.runtime.registry import CLUSTER_INFO_MARK, RegistryClient, job_row, jobs_api_state
from onepiece_dist.specs.job import JobSpec, default_job_id
from onepiece_dist.specs.plan import PickLabelSpec, PickSpec, PlanSpec
from onepiece_dist.store import DatasetReader, open_dataset
from onepiece_dist.version import package_version

LEARN = ("PickNetwork", "design_options", "train_pick_network")  # onepiece_dist.learn.pick_network's, with torch
__all__ = ["Client", "ClusterUnreachable", "DatasetReader", "JobHandle", "JobSpec", "JobStatus", "PickLabelSpec",
           "PickReport", "PickSpec", "PlanSpec", "RelabelReport", "RobotPlan", "evaluate_model", "open_dataset",
           "plan_grasps", "relabel_report", "relabel_spec", "resolve_source", "run_job", "run_pick_labels",
           "run_picks", *LEARN]


def __getattr__(name: str):
    """The names of LEARN, imported when first asked for: importing the API loads no torch."""
    if name not in LEARN:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from onepiece_dist.learn import pick_network

    return getattr(pick_network, name)


TERMINAL = ("succeeded", "failed", "cancelled")


def run_job(spec: JobSpec, address: str | None = None, in_process: bool = False, job_id: str | None = None,
            workers: int | None = None, progress: ProgressFn | None = None) -> JobStatus:
    """Run ``spec`` to completion here and return its final status: on an embedded Ray (default), on the
    cluster at ``address`` (this process is the driver), or without Ray (``in_process``)."""
    job_id = job_id or default_job_id(spec)
    spec = with_user_decompositions(spec) if in_process or not address else spec  # a local run's folder
    refs = resolve_source(spec.objects)  # a bad source is a usage error, found before any Ray starts
    if in_process:
        return run_local(spec, job_id=job_id, progress=progress, refs=refs)
    import ray

    from onepiece_dist.runtime.ray_runner import run_on_ray

    started_here = not ray.is_initialized()
    _connect_or_raise(connect, address)
    try:
        return run_on_ray(spec, job_id, workers=workers, progress=progress, refs=refs)
    finally:
        if started_here:
            with contextlib.suppress(Exception):  # a runtime that died under the job may not shut down cleanly
                ray.shutdown()


def evaluate_model(model_path: str | Path, spec: JobSpec) -> EvaluationReport:
    """Label the candidates of ``spec.objects`` in simulation (in process, by the evaluation's protocol), then
    score the model on them (``onepiece evaluate``)."""
    labelled = with_user_decompositions(spec).model_copy(update={"stages": ("ingest", "extract", "dedup"),
                                                                 "sim": heldout_sim(spec)})
    status = run_local(labelled, job_id="evaluate")
    return score_heldout(model_path, labelled.output, spec.train.device, objects_scored(status),
                         protocol_of(labelled))


def _connect_or_raise(connect, address: str | None) -> None:
    try:
        connect(address)
    except ConnectionError as err:
        raise ClusterUnreachable(f"no Ray cluster at {address}: {err}") from None


def read_status(dataset: str | Path) -> JobStatus:
    """The status written beside a dataset (readable after the cluster is gone)."""
    path = status_path(dataset)
    if not path.is_file():
        raise JobNotFound(f"no job status at {path} (without --address, give the dataset path)")
    return JobStatus.load(dataset)


def wait_for_dataset(dataset: str | Path, timeout: float | None = None, poll: float = 1.0) -> JobStatus:
    """Block until the job writing ``dataset`` ends (its status file says so); its final status. Raises
    JobNotFound (no status file), DriverGone (its driver on this machine has exited without ending the job),
    TimeoutError after ``timeout`` s."""
    deadline = None if timeout is None else time.monotonic() + timeout
    while (current := read_status(dataset)).state not in TERMINAL:
        if not _driver_alive(current.driver):
            raise DriverGone(f"job {current.job_id}'s driver ({current.driver}) ended during its {current.stage} "
                             f"stage without finishing it; finish it with `onepiece resume {dataset}`")
        if deadline is not None and time.monotonic() > deadline:
            raise TimeoutError(f"job {current.job_id} still {current.state} after {timeout} s")
        time.sleep(poll)
    return current


def _driver_alive(driver: str) -> bool:
    """Whether the 'host:pid' driver still runs; a driver on another machine counts as alive (it cannot be
    checked from here)."""
    import os
    import socket

    host, _, pid = driver.rpartition(":")
    if host != socket.gethostname() or not pid.isdigit():
        return True
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, someone else's
        pass
    return True


def local_jobs(folder: str | Path) -> list[dict]:
    """A row per job status file under ``folder`` (as :meth:`Client.jobs` gives)."""
    return [job_row(JobStatus.load(str(path)[: -len(STATUS_SUFFIX)]).model_dump(mode="json"))
            for path in sorted(Path(folder).glob(f"**/*{STATUS_SUFFIX}"))]


class JobHandle:
    """A submitted job: ``status()``, ``wait()``, ``cancel()``."""

    def __init__(self, client: Client, job_id: str, output: str, thread: threading.Thread | None = None,
                 note: str = ""):
        self.client, self.job_id, self.output, self._thread, self.note = client, job_id, output, thread, note
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
        if self.client.address is not None:
            return self.client.wait(self.job_id, timeout, poll)
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
            loopback_environment()  # token auth, set before Ray reads it
            from ray.exceptions import AuthenticationError
            from ray.job_submission import JobSubmissionClient

            try:
                self._jobs_api = JobSubmissionClient(self.address)
            except (ConnectionError, RuntimeError, ValueError, AuthenticationError) as err:
                raise ClusterUnreachable(f"no Ray Jobs API at {self.address}: {err}") from None
        return self._jobs_api

    def submit(self, spec: JobSpec, job_id: str | None = None, runtime_env: dict | None = None) -> JobHandle:
        """Start ``spec``: in this process's embedded Ray, or on the cluster (Jobs API) after checking that its
        paths are absolute and that it runs this package's version. Submitting an id whose job is active returns
        that job; one whose job has ended gets a fresh id (``<id>-2``, ...): ``handle.note`` says which."""
        job_id = job_id or default_job_id(spec)
        if self.address is None:
            return self._submit_local(with_user_decompositions(spec), job_id)
        check_remote_paths(spec)
        cluster = self.cluster_info()
        if cluster["version"] != package_version():
            raise VersionMismatch(f"the cluster at {self.address} runs onepiece-dist {cluster['version']}, this "
                                  f"client {package_version()}: install the same version on both")
        job_id, note = self._free_job_id(job_id)
        if note.endswith("still active"):
            return JobHandle(self, job_id, spec.output, note=note)
        entrypoint = (f"python -m onepiece_dist.cli run --address auto --job-id {shlex.quote(job_id)} --final-status "
                      f"--spec-json {shlex.quote(spec.model_dump_json())}")
        self.jobs_api().submit_job(entrypoint=entrypoint, submission_id=job_id, runtime_env=runtime_env,
                                   metadata={"output": spec.output})
        return JobHandle(self, job_id, spec.output, note=note)

    def _free_job_id(self, job_id: str) -> tuple[str, str]:
        """``job_id`` if the cluster has no job by it, the same if that job is still active, else the first free
        ``<job_id>-N``; and a note for the user when it is not simply ``job_id``."""
        for n in range(1, 1000):
            candidate = job_id if n == 1 else f"{job_id}-{n}"
            state = self._ray_state(candidate)
            if state is None:
                return candidate, "" if n == 1 else f"job {job_id} has ended before; submitted as {candidate}"
            if state not in TERMINAL:
                return candidate, f"job {candidate} is still active"
        raise JobError(f"no free job id after {job_id}")

    def _ray_state(self, job_id: str) -> str | None:
        """The Jobs API's state of ``job_id`` in our words, or None when the cluster has no such job."""
        try:
            return jobs_api_state(self.jobs_api().get_job_status(job_id))
        except RuntimeError as err:
            if "does not exist" in str(err) or "not found" in str(err).lower():
                return None
            raise

    def state(self, job_id: str) -> str:
        """The job's state by the cluster's Jobs API (no registry read); JobNotFound when it has no such job."""
        state = self._ray_state(job_id)
        if state is None:
            raise JobNotFound(f"no job {job_id} on the cluster at {self.address}")
        return state

    def cluster_info(self, timeout: float = 120.0) -> dict:
        """The cluster's package version and job registry (``{"version", "jobs": {id: status}}``), read inside the
        cluster by a short Ray job (``onepiece cluster-info``), so a client that reaches only the Jobs API sees
        the jobs' progress as their drivers report it."""
        api, reader = self.jobs_api(), f"onepiece-info-{uuid.uuid4().hex[:12]}"
        api.submit_job(entrypoint="python -m onepiece_dist.cli cluster-info --address auto", submission_id=reader)
        deadline = time.monotonic() + timeout
        while jobs_api_state(api.get_job_status(reader)) not in TERMINAL:
            if time.monotonic() > deadline:
                raise TimeoutError(f"reading the job registry at {self.address} took over {timeout} s")
            time.sleep(0.2)
        logs = api.get_job_logs(reader)
        with contextlib.suppress(Exception):
            api.delete_job(reader)
        lines = [line for line in logs.splitlines() if line.startswith(CLUSTER_INFO_MARK)]
        if not lines:
            raise JobError(f"could not read the job registry at {self.address}: {logs[-800:]}")
        return json.loads(lines[-1][len(CLUSTER_INFO_MARK):])

    def _submit_local(self, spec: JobSpec, job_id: str) -> JobHandle:
        from onepiece_dist.runtime.ray_runner import run_on_ray

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
        """Latest status: the registry (embedded Ray), else the status file; on a cluster, the cluster's registry
        (the driver's own reports), with the Jobs API's word on a driver that ended without reporting."""
        if self.address is None:
            output = output or (self._local[job_id].output if job_id in self._local else None)
            found = self._registry_status(job_id)
            if found is None and output and status_path(output).is_file():
                found = read_status(output)
            return found or JobStatus(job_id=job_id, state="pending", output=output or "")
        ray_state = self.state(job_id)
        final = JobStatus.from_log(self.jobs_api().get_job_logs(job_id)) if ray_state == "succeeded" else None
        if final is not None:  # the driver's last report, in its log (``run --final-status``): no Ray job to read
            return final
        reported = self.cluster_info()["jobs"].get(job_id)
        info = self.jobs_api().get_job_info(job_id)
        status = (JobStatus.model_validate(reported) if reported
                  else JobStatus(job_id=job_id, output=(info.metadata or {}).get("output", "")))
        if ray_state in TERMINAL and status.state not in TERMINAL:  # the driver ended without a last report
            status.state = "cancelled" if ray_state == "cancelled" else "failed"
            status.error = status.error or f"the job's driver ended ({ray_state}): {info.message or ''}".strip()
        elif not reported:
            status.state = ray_state
        return status

    def wait(self, job_id: str, timeout: float | None = None, poll: float = 1.0) -> JobStatus:
        """Block until the cluster's job ends (polling the Jobs API); its final status. TimeoutError after
        ``timeout`` s, JobNotFound when there is no such job."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while (state := self.state(job_id)) not in TERMINAL:
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"job {job_id} still {state} after {timeout} s")
            time.sleep(poll)
        return self.status(job_id)

    def _registry_status(self, job_id: str) -> JobStatus | None:
        registry = _registry()
        found = registry.get(job_id) if registry else None
        return JobStatus.model_validate(found) if found else None

    def cancel(self, job_id: str) -> str:
        """Ask the job to stop; returns its state when asked ('running' or 'pending' means the stop was sent)."""
        if self.address is None:
            registry = _registry()
            if registry is None or not registry.request_cancel(job_id):
                raise JobNotFound(f"no job {job_id} in this process's Ray")
            return "running"
        state = self.state(job_id)
        if state not in TERMINAL:
            self.jobs_api().stop_job(job_id)
        return state

    def jobs(self) -> list[dict]:
        """Every job: id, state, stage, objects done and total, output."""
        if self.address is None:
            registry = _registry()
            return [job_row(s) for s in registry.jobs()] if registry else []
        reported = self.cluster_info()["jobs"]
        rows = []
        for job in self.jobs_api().list_jobs():
            if not job.submission_id or job.submission_id.startswith("onepiece-info-"):
                continue
            state = jobs_api_state(job.status)
            found = reported.get(job.submission_id) or {"job_id": job.submission_id, "state": state,
                                                        "output": (job.metadata or {}).get("output", "")}
            rows.append(job_row({**found, "state": state if state in TERMINAL else found["state"]}))
        return rows

    def logs(self, job_id: str) -> str:
        return without_status_lines(self.jobs_api().get_job_logs(job_id))

    def follow_logs(self, job_id: str) -> Iterator[str]:
        """The job's driver log as it grows, until the job ends."""
        import asyncio

        queue: list[str] = []

        async def tail() -> None:
            async for chunk in self.jobs_api().tail_job_logs(job_id):
                queue.append(chunk)

        thread = threading.Thread(target=lambda: asyncio.run(tail()), daemon=True)
        thread.start()
        while thread.is_alive() or queue:
            while queue:
                yield without_status_lines(queue.pop(0))
            thread.join(0.2)


def check_remote_paths(spec: JobSpec) -> None:
    """A job for a cluster names its paths absolutely: every node resolves a relative one against its own working
    folder, so its parts would scatter over the nodes' disks."""
    for field in ("output", "cache_dir", "decompositions"):
        value = getattr(spec, field)
        if value and not Path(value).is_absolute():
            raise SpecError(f"{field}: {value!r} is relative; a job on a cluster needs an absolute path on the "
                            "volume every node mounts (e.g. /data/dataset.zarr)")


def _registry():
    """The embedded Ray's job registry, or None when this process has no Ray."""
    import ray


    return RegistryClient() if ray.is_initialized() else None
