"""The Ray driver of a job: extraction worker actors fed with bounded in-flight work (``ray.wait``), a central
dedup actor, the registry, retries of objects whose worker died, quarantine of poison objects, cancellation.

Workers write their objects' parts themselves and return small :class:`ObjectResult` summaries; no large array
travels through Ray's object store. The same per-object function and commit as the in-process runner, so both
give the same dataset, with or without faults.
"""

from __future__ import annotations

import dataclasses
import time
from collections import deque

from onepiece_dist.errors import JobError
from onepiece_dist.objects import ObjectRef, resolve_source
from onepiece_dist.service.dedup_actor import CentralDedup
from onepiece_dist.service.extract import ObjectResult, extract_object, parts_for
from onepiece_dist.service.local import ProgressFn, finish, record_result
from onepiece_dist.service.registry import on_this_node, registry
from onepiece_dist.service.status import JobStatus
from onepiece_dist.spec import JobSpec

IN_FLIGHT_PER_WORKER = 2
MAX_ATTEMPTS = 3  # an object whose worker dies this many times is quarantined
POLL_SECONDS = 0.5
ACTOR_PATIENCE_S = 120.0  # how long a central actor may take to come back


class ExtractionWorker:
    """One pybullet client per actor. A plain class, testable without Ray."""

    def __init__(self, spec: JobSpec, dedup_name: str | None = None):
        self.spec = spec
        self.parts = parts_for(spec)
        self.dedup_name = dedup_name

    def extract(self, ref: ObjectRef, index: int) -> ObjectResult:
        """Extract one object; its codes go straight to the central dedup actor (named ``dedup_name``), so the
        central path need not read parts (it still does when a message is lost: the driver's own call)."""
        result = extract_object(self.spec, ref, index, self.parts)
        if self.dedup_name and result.status == "ok":
            self._send_codes(index, result.part_key)
        return dataclasses.replace(result, node=_node_id())

    def _send_codes(self, index: int, part_key: str) -> None:
        import ray

        from onepiece_dist.service.ray_env import NAMESPACE

        try:
            dedup = ray.get_actor(self.dedup_name, namespace=NAMESPACE)
        except ValueError:  # restarting or gone: the driver's add() reads the part instead
            return
        dedup.add.remote(index, part_key, self.parts.read_array(part_key, "code"))


def _node_id() -> str:
    try:
        import ray

        return ray.get_runtime_context().get_node_id() if ray.is_initialized() else ""
    except Exception:  # noqa: BLE001 - outside a Ray worker there is no node
        return ""


def worker_count(spec_workers: int | None, objects: int) -> int:
    import ray

    cpus = int(ray.cluster_resources().get("CPU", 1))
    return max(1, min(spec_workers or cpus, objects or 1))


def run_on_ray(spec: JobSpec, job_id: str, workers: int | None = None,
               progress: ProgressFn | None = None) -> JobStatus:
    """Run the job on the connected Ray. Raises :class:`JobError` if it fails, is cancelled, or a job with the
    same id is already running."""
    import ray

    reg = registry()
    status = JobStatus(job_id=job_id, state="running", stage="ingest", output=spec.output,
                       spec=spec.model_dump(mode="json"))
    if not ray.get(reg.claim.remote(job_id, status.model_dump(mode="json"))):
        raise JobError(f"job {job_id} is already running")
    actors: list = []
    try:
        refs = resolve_source(spec.objects)
        status.progress.objects_total = len(refs)
        parts = parts_for(spec)
        parts.remove_stale_temporaries()
        dedup = _actor(CentralDedup, f"dedup-{job_id}", num_cpus=0, scheduling_strategy=on_this_node()).remote(spec)
        actors = [dedup] + [_actor(ExtractionWorker, f"extract-{job_id}-{k}", num_cpus=1,
                                   scheduling_strategy="SPREAD").remote(spec, f"dedup-{job_id}")
                            for k in range(worker_count(workers, len(refs)))]
        status.stage = "extract"
        t0 = time.perf_counter()
        pool = ExtractionPool(actors[1:], dedup, reg, status, progress)
        results = pool.run(refs if "extract" in spec.stages else [])
        status.timings["extract"] = time.perf_counter() - t0
        for worker in actors[1:]:
            ray.kill(worker)  # free their CPUs for the trainer
        done = finish(spec, status, results, parts, commit=lambda rs: _call(dedup.commit, rs),
                      train=lambda s: _train_remote(s, actors))
        ray.get(reg.update.remote(job_id, done.model_dump(mode="json")))
        return done
    except BaseException as err:
        status.state = "cancelled" if isinstance(err, JobCancelled) else "failed"
        status.error = f"{type(err).__name__}: {err}"
        status.save(spec.output)
        ray.get(reg.update.remote(job_id, status.model_dump(mode="json")))
        raise JobError(f"job {job_id} {status.state}: {err}") from err
    finally:
        for actor in actors:
            ray.kill(actor)


def _train_remote(spec: JobSpec, actors: list) -> dict:
    import ray

    from onepiece_dist.service.trainer import remote_trainer

    trainer = remote_trainer()
    actors.append(trainer)
    return ray.get(trainer.fit.remote(spec))


class JobCancelled(Exception):
    pass


def _actor(cls, name: str, **options):
    """Restartable named actor; methods are not retried by Ray (the pool decides what to re-run)."""
    import ray

    from onepiece_dist.service.ray_env import NAMESPACE

    return ray.remote(cls).options(name=name, namespace=NAMESPACE, max_restarts=-1, max_task_retries=0,
                                   **options)


def _call(method, *args, patience_s: float = ACTOR_PATIENCE_S):
    """Call an actor method; while the actor is unavailable or restarting (its state is rebuilt from the store),
    try again for up to ``patience_s`` seconds."""
    import ray
    from ray.exceptions import RayActorError

    deadline = time.monotonic() + patience_s
    while True:
        try:
            return ray.get(method.remote(*args))
        except RayActorError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)


class ExtractionPool:
    """Feeds objects to worker actors, at most IN_FLIGHT_PER_WORKER each, and checks for a cancel request.

    When a worker dies, the objects it held are re-run one at a time on an otherwise idle worker (suspects), so a
    later death is attributable: an object that kills its worker MAX_ATTEMPTS times while running alone is
    quarantined; innocent objects that only shared a worker with it are never counted against.
    """

    def __init__(self, actors: list, dedup, reg, status: JobStatus, progress: ProgressFn | None):
        self.actors, self.dedup, self.reg, self.status, self.progress = actors, dedup, reg, status, progress
        self.pending: dict = {}  # ObjectRef -> (index, object ref, actor position, alone)
        self.attempts: dict[int, int] = {}
        self.suspects: set[int] = set()
        # work goes only to actors that have started: on a busy cluster some may wait for CPUs for a long time
        self.starting = {actor.__ray_ready__.remote(): k for k, actor in enumerate(actors)}
        self.ready: set[int] = set()

    def run(self, refs: list[ObjectRef]) -> list[ObjectResult]:
        import ray

        todo = deque(enumerate(refs))
        results: list[ObjectResult] = []
        while todo or self.pending:
            if _call(self.reg.cancel_requested, self.status.job_id):
                raise JobCancelled(f"cancelled after {len(results)} of {len(refs)} objects")
            self._note_started()
            self._fill(todo)
            ready, _ = ray.wait(list(self.pending) or list(self.starting), num_returns=1, timeout=POLL_SECONDS)
            ready = [ref for ref in ready if ref in self.pending]
            for ref in ready:
                result = self._collect(ref, todo)
                if result is not None:
                    results.append(result)
                    self._record(result)
        return sorted(results, key=lambda r: r.index)

    def _note_started(self) -> None:
        import ray

        if self.starting:
            started, _ = ray.wait(list(self.starting), num_returns=len(self.starting), timeout=0)
            for ref in started:
                self.ready.add(self.starting.pop(ref))

    def _restarting(self, position: int) -> None:
        """A dead actor gets no work until it has restarted (possibly on another node, possibly much later)."""
        if position in self.ready:
            self.ready.discard(position)
            self.starting[self.actors[position].__ray_ready__.remote()] = position

    def _load(self) -> list[int]:
        """Tasks in flight per actor; an actor running a suspect alone, or not started yet, counts as full."""
        load = [0 if k in self.ready else 2 * IN_FLIGHT_PER_WORKER for k in range(len(self.actors))]
        for _, _, position, alone in self.pending.values():
            load[position] += IN_FLIGHT_PER_WORKER if alone else 1
        return load

    def _fill(self, todo: deque) -> None:
        deferred = deque()
        while todo:
            index, ref = todo.popleft()
            load = self._load()
            alone = index in self.suspects
            free = [k for k, n in enumerate(load) if (n == 0 if alone else n < IN_FLIGHT_PER_WORKER)]
            if not free:
                deferred.append((index, ref))
                if not alone:
                    break
                continue
            position = min(free, key=lambda k: load[k])
            self.pending[self.actors[position].extract.remote(ref, index)] = (index, ref, position, alone)
        todo.extendleft(reversed(deferred))

    def _collect(self, object_ref, todo: deque) -> ObjectResult | None:
        import ray
        from ray.exceptions import RayActorError, WorkerCrashedError

        index, ref, position, alone = self.pending.pop(object_ref)
        try:
            return ray.get(object_ref)
        except (RayActorError, WorkerCrashedError) as err:
            self._restarting(position)
            self.status.retries += 1
            self.suspects.add(index)
            if alone:
                self.attempts[index] = self.attempts.get(index, 0) + 1
            if self.attempts.get(index, 0) >= MAX_ATTEMPTS:
                return ObjectResult(index, ref.name, "rejected", reason=f"quarantined: its worker died "
                                    f"{self.attempts[index]} times while running it alone ({type(err).__name__})")
            todo.appendleft((index, ref))
            return None

    def _record(self, result: ObjectResult) -> None:
        record_result(self.status, result)
        if result.status == "ok":
            self.status.progress.unique_codes = _call(self.dedup.add, result.index, result.part_key)
        self.status.save(self.status.output)
        self.reg.update.remote(self.status.job_id, self.status.model_dump(mode="json"))
        if self.progress:
            self.progress(self.status)
