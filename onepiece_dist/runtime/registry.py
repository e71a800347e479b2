"""Job registry: a named detached actor (namespace ``onepiece``, ``num_cpus=0``) holding job states.

:class:`JobRegistry` is a plain class, usable and tested without Ray; :class:`RegistryClient` reaches the
cluster-wide actor. Each job's status is also written beside its dataset, so it outlives the cluster.
"""

from __future__ import annotations

from onepiece_dist.runtime.actors import ActorClient
from onepiece_dist.runtime.ray_env import NAMESPACE
from onepiece_dist.version import package_version

ACTIVE = ("pending", "running")
REGISTRY_NAME = "onepiece-registry"


class JobRegistry:
    """Job id -> latest status (a JSON-ready dict) and cancel requests."""

    def __init__(self):
        self._jobs: dict[str, dict] = {}
        self._cancel: set[str] = set()

    def claim(self, job_id: str, status: dict) -> bool:
        """Register a job; False when a job with this id is already pending or running (it keeps running)."""
        current = self._jobs.get(job_id)
        if current is not None and current.get("state") in ACTIVE:
            return False
        self._jobs[job_id] = status
        self._cancel.discard(job_id)
        return True

    def update(self, job_id: str, status: dict) -> None:
        self._jobs[job_id] = status

    def get(self, job_id: str) -> dict | None:
        return self._jobs.get(job_id)

    def jobs(self) -> list[dict]:
        return list(self._jobs.values())

    def request_cancel(self, job_id: str) -> bool:
        if job_id not in self._jobs:
            return False
        self._cancel.add(job_id)
        return True

    def cancel_requested(self, job_id: str) -> bool:
        return job_id in self._cancel


class RegistryClient(ActorClient):
    """The cluster's registry actor (created on first use; needs a connected Ray)."""

    served = JobRegistry

    def __init__(self):
        import ray


        actor = ray.remote(num_cpus=0, max_restarts=-1)(JobRegistry)
        handle = actor.options(name=REGISTRY_NAME, namespace=NAMESPACE, lifetime="detached", get_if_exists=True,
                               scheduling_strategy=on_this_node()).remote()
        super().__init__(handle, "job registry")

    def claim(self, job_id: str, status: dict) -> bool:
        return self.call("claim", job_id, status)

    def update(self, job_id: str, status: dict, wait: bool = True) -> None:
        (self.call if wait else self.send)("update", job_id, status)

    def get(self, job_id: str) -> dict | None:
        return self.call("get", job_id)

    def jobs(self) -> list[dict]:
        return self.call("jobs")

    def request_cancel(self, job_id: str) -> bool:
        return self.call("request_cancel", job_id)

    def cancel_requested(self, job_id: str) -> bool:
        return self.call("cancel_requested", job_id)


def on_this_node():
    """Prefer the caller's node (the driver's, usually the head) for the 0-CPU central actors, so losing a
    worker node does not take them down; soft, so they can still go elsewhere."""
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    return NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=True)


CLUSTER_INFO_MARK = "ONEPIECE_CLUSTER_INFO "


def cluster_info() -> dict:
    """What a client outside the cluster asks of it (run inside it, by ``onepiece cluster-info``): the package
    version the cluster runs and every job's latest status from the registry."""
    return {"version": package_version(), "jobs": {status["job_id"]: status for status in RegistryClient().jobs()}}


RAY_JOB_STATES = {"PENDING": "pending", "RUNNING": "running", "SUCCEEDED": "succeeded", "FAILED": "failed",
                  "STOPPED": "cancelled"}


def jobs_api_state(ray_status) -> str:
    """A Jobs API status (``JobStatus.RUNNING``...) in our words."""
    return RAY_JOB_STATES.get(str(ray_status).split(".")[-1], "pending")


def job_row(status: dict) -> dict:
    """One row of `onepiece list`: a job's status (as JSON) in a few fields."""
    progress = status.get("progress") or {}
    return {"job_id": status["job_id"], "state": status.get("state", "pending"), "stage": status.get("stage", ""),
            "objects_done": progress.get("objects_done", 0), "objects_total": progress.get("objects_total", 0),
            "output": status.get("output", "")}
