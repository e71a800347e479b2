"""The Ray runtime of a job's pipeline: simulation worker actors (extraction, then the label shards of the one
object) fed with bounded in-flight work (``ray.wait``),
the central actor and the trainer behind their clients, the registry, retries of objects whose worker died,
quarantine of poison objects, cancellation.

Workers write their objects' parts themselves, send their codes to the central actor and return small
:class:`ObjectResult` summaries; no large array travels back to the driver. The same pipeline, per-object
function and central actor as the in-process runner, so both give the same dataset, with or without faults.
"""

from __future__ import annotations

import contextlib
import dataclasses
import shutil
from collections import Counter, deque
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ray.exceptions import OutOfMemoryError, RaySystemError

from onepiece_dist.errors import JobCancelled, JobError, RuntimeLost
from onepiece_dist.job.pipeline import ProgressFn, Runtime, new_status, run_pipeline
from onepiece_dist.job.results import LabelTask, ObjectResult, PatchTask, ShardResult
from onepiece_dist.job.stages.extract import extract_object
from onepiece_dist.job.stages.label_one_object import label_shard
from onepiece_dist.job.stages.patch_shards import build_patch_shard
from onepiece_dist.job.status import EvaluationReport, JobStatus, TrainingReport
from onepiece_dist.objects import ObjectRef
from onepiece_dist.runtime.actors import ActorClient, restartable_actor
from onepiece_dist.runtime.crashes import CrashLog, crash_folder, crashed_on, running
from onepiece_dist.runtime.registry import RegistryClient
from onepiece_dist.runtime.trainer import Trainer, TrainerClient, trainer_gpus
from onepiece_dist.runtime.writer import WriterClient, central_name
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore

if TYPE_CHECKING:
    from onepiece_dist.learn.train import StepResult, StepRun

IN_FLIGHT_PER_WORKER = 2
MAX_CRASHES = 3  # an item that crashes its worker (a crash record, Ray's OOM kill) this many times alone: quarantined
MAX_UNEXPLAINED = 20  # deaths alone with no record (SIGKILL from outside): only bounds a job something keeps killing
POLL_SECONDS = 0.5


class SimWorker:
    """One pybullet client per actor: extracts objects and labels shards of the one object. A plain class,
    testable without Ray."""

    def __init__(self, spec: JobSpec, central: str | None = None, crashes: str | None = None):
        self.spec = spec
        self.parts = PartStore(spec.parts_folder())
        self.central = central
        self.crash_log = CrashLog(crashes) if crashes else None

    def fit_steps(self, run: StepRun) -> StepResult:
        """An adaptive round's network fitted in this worker, as a trainer fits it (Trainer.fit_steps)."""
        return Trainer().fit_steps(run)

    def starting(self, method: str, index: int) -> None:
        """Note the item in this process's crash record (see :mod:`onepiece_dist.runtime.crashes`)."""
        if self.crash_log is not None:
            self.crash_log.starting(method, index)

    def label(self, task: LabelTask, index: int) -> ShardResult:
        """Label one shard of the one object into its part."""
        with running(self.crash_log, "label", index):
            result = label_shard(self.spec, task, index, self.parts)
        return dataclasses.replace(result, node=node_id())

    def patch(self, task: PatchTask, index: int) -> ShardResult:
        """Cut one shard of the one object's patches into its part."""
        with running(self.crash_log, "patch", index):
            result = build_patch_shard(self.spec, task, index, self.parts)
        return dataclasses.replace(result, node=node_id())

    def extract(self, ref: ObjectRef, index: int) -> ObjectResult:
        """Extract one object; its codes go to the central actor (named ``central``), once. When that message
        is lost (the actor restarting), the central actor's commit reads them from the part instead."""
        with running(self.crash_log, "extract", index):
            result = extract_object(self.spec, ref, index, self.parts)
            central = WriterClient.find(self.central) if self.central and result.status == "ok" else None
            if central is not None:
                central.send_codes(index, result.part_key, self.parts.read_array(result.part_key, "code"))
        return dataclasses.replace(result, node=node_id())


class RoundTrainer(ActorClient):
    """A simulation worker of the job fitting an adaptive round's network on its CPU (SimWorker.fit_steps),
    waiting out its restarts as a trainer's client does."""

    served = SimWorker

    def fit_steps(self, run: StepRun) -> StepResult:
        return self.call("fit_steps", run)


def node_id() -> str:
    try:
        import ray

        return ray.get_runtime_context().get_node_id() if ray.is_initialized() else ""
    except Exception:  # noqa: BLE001 - outside a Ray worker there is no node
        return ""


def worker_count(spec_workers: int | None, items: int | None) -> int:
    """Workers for a stage of ``items`` tasks (None: not known yet): as asked, else one per CPU of the cluster;
    never more than there are tasks."""
    import ray

    limit = spec_workers or int(ray.cluster_resources().get("CPU", 1))
    return max(1, limit if items is None else min(limit, items or 1))


def run_on_ray(spec: JobSpec, job_id: str, workers: int | None = None, progress: ProgressFn | None = None,
               refs: list[ObjectRef] | None = None) -> JobStatus:
    """Run the job's pipeline on the connected Ray, on ``refs`` (default: resolved from ``spec.objects``).
    Raises :class:`JobError` if it fails, is cancelled, or a job with the same id is already running."""
    registry = RegistryClient()
    status = new_status(spec, job_id)
    if not registry.claim(job_id, status.model_dump(mode="json")):
        raise JobError(f"job {job_id} is already running")
    PartStore(spec.parts_folder()).remove_stale_temporaries()
    runtime = RayRuntime(spec, job_id, registry, status, workers, progress)
    try:
        return run_pipeline(spec, status, runtime, refs)
    except JobError as err:
        if isinstance(err, RuntimeLost) or isinstance(err.__cause__, RuntimeLost | RaySystemError):
            lost = err if isinstance(err, RuntimeLost) else err.__cause__
            raise RuntimeLost(f"job {job_id} lost the Ray runtime during its {status.stage} stage "
                              f"({type(lost.__cause__ or lost).__name__}); committed work is kept: finish it with "
                              f"`onepiece resume {spec.output}`") from None
        raise
    finally:
        runtime.close()


class RayRuntime(Runtime):
    """The job's stages on Ray: one pool of :class:`SimWorker` actors that every simulation stage uses in turn
    (released when a trainer or another job needs their CPUs), the central actor and the trainer behind their
    clients, progress published to the registry."""

    def __init__(self, spec: JobSpec, job_id: str, registry: RegistryClient, status: JobStatus,
                 workers: int | None = None, progress: ProgressFn | None = None):
        self.spec, self.job_id, self.registry, self.status = spec, job_id, registry, status
        self.workers, self.progress = workers, progress
        self.central = WriterClient.start(spec, job_id)
        self.trainers: list[TrainerClient] = []  # killed before evaluation's labelling, and at the end
        self.crashes = crash_folder(spec.parts_folder(), job_id)
        self.pool: list = []  # the job's simulation workers, alive from the first stage that needs them
        self.started = 0  # workers started so far: each one's name is new

    def report(self, status: JobStatus) -> None:
        status.save(self.spec.output)
        try:
            self.registry.update(self.job_id, status.model_dump(mode="json"), wait=status.state != "running")
        except (RuntimeLost, RaySystemError):
            if status.state == "running":
                raise  # while running, a lost runtime ends the job; once it has ended, the status file says it
        if self.progress:
            self.progress(status)

    def _workers(self, count: int) -> list:
        """``count`` of the job's simulation workers: those alive (started by an earlier stage) first, then new
        ones; any others stay alive, idle, for the next stage. Every stage (extract, patch, label) uses them: a
        worker's start-up (a process, its imports, pybullet) is paid once per job, not once per stage."""
        while len(self.pool) < count:
            self.pool.append(restartable_actor(SimWorker, f"sim-{self.job_id}-{self.started}", num_cpus=1,
                                               scheduling_strategy="SPREAD")
                             .remote(self.spec, central_name(self.job_id), str(self.crashes)))
            self.started += 1
        return self.pool[:count]

    def release_workers(self) -> None:
        """The simulation workers killed: their CPUs go to the trainer or another job."""
        import ray

        for actor in self.pool:
            with contextlib.suppress(Exception):  # a runtime that is gone has nothing left to kill
                ray.kill(actor)
        self.pool = []

    def prepare(self, stage: str) -> None:
        self._workers(worker_count(self.workers, None))

    def _on_pool(self, stage: str, items: list, on_result: Callable, quarantined: Callable) -> list:
        """``items`` through ``SimWorker.<stage>`` on the job's workers (kept for the next stage)."""
        actors = self._workers(worker_count(self.workers, len(items)))
        return WorkerPool(actors, self.registry, self.status, on_result, stage, quarantined,
                          self.crashes).run(items)

    def extract(self, refs: list[ObjectRef], on_result: Callable[[ObjectResult], None]) -> list[ObjectResult]:
        return self._on_pool("extract", refs, on_result, quarantined_object)

    def label(self, tasks: list[LabelTask]) -> list[ShardResult]:
        return self._on_pool("label", tasks, lambda result: None, quarantined_shard)

    def patch(self, tasks: list[PatchTask]) -> list[ShardResult]:
        return self._on_pool("patch", tasks, lambda result: None, quarantined_shard)

    def train(self, spec: JobSpec) -> TrainingReport:
        self.release_workers()
        self.trainers.append(TrainerClient.start(spec, self.job_id))
        return self.trainers[-1].fit(spec)

    def fit_round(self, run: StepRun) -> StepResult:
        """One adaptive round's network. On a CPU, one of the job's simulation workers fits it: the round's label
        shards wait for it, so that worker's CPU is the trainer's, and no worker stops and starts again, nor a
        trainer starts, each round. On a GPU, a trainer actor holding one, the workers released."""
        import ray

        if not trainer_gpus(self.spec.train.device, ray.cluster_resources().get("GPU", 0)):
            return RoundTrainer(self._workers(1)[0], f"simulation worker of job {self.job_id}").fit_steps(run)
        self.release_workers()  # the round's trainer gets their CPUs; the next round starts them again
        trainer = TrainerClient.start_named(f"trainer-{self.job_id}-round", self.spec.train.device)
        try:
            return trainer.fit_steps(run)
        finally:
            trainer.kill()  # its CPU goes back to the next round's label workers

    def label_heldout(self, heldout: JobSpec) -> JobStatus:
        self.release_workers()
        self._kill_trainers()  # the labelling workers get the trainer's CPU
        return run_on_ray(heldout, f"{self.job_id}-evaluate", workers=self.workers)

    def score(self, job: JobSpec, dataset: str, objects: int) -> EvaluationReport:
        self.release_workers()
        self.trainers.append(TrainerClient.start(job, f"{self.job_id}-evaluate"))
        return self.trainers[-1].score(job, dataset, objects)

    def _kill_trainers(self) -> None:
        for trainer in self.trainers:
            with contextlib.suppress(Exception):  # a runtime that is gone has nothing left to kill
                trainer.kill()
        self.trainers.clear()

    def close(self) -> None:
        """Every actor this job started, killed; its crash records removed."""
        for client in [self.central, *self.trainers]:
            with contextlib.suppress(Exception):  # a runtime that is gone has nothing left to kill
                client.kill()
        self.release_workers()
        shutil.rmtree(self.crashes, ignore_errors=True)


def quarantined_object(index: int, ref: ObjectRef, reason: str) -> ObjectResult:
    return ObjectResult(index, ref.name, "rejected", reason=reason)


def quarantined_shard(index: int, task: LabelTask, reason: str) -> ShardResult:
    return ShardResult(index, "rejected", reason=reason)


class WorkerPool:
    """Feeds items (objects, label shards) to worker actors' ``method(item, index)``, at most
    IN_FLIGHT_PER_WORKER each, and checks for a cancel request.

    When a worker dies, the items it held are re-run one at a time on an otherwise idle worker (suspects), so a
    later death is attributable: an item that crashes its worker MAX_CRASHES times while running alone (a crash
    record in ``crashes``, see :mod:`onepiece_dist.runtime.crashes`, or a kill by Ray's memory monitor), or whose
    worker dies MAX_UNEXPLAINED times while running it alone with no record (killed from outside), is
    quarantined (``quarantined(index, item, reason)`` is its result); innocent items that only shared a worker
    with it are never counted against. Without a crash folder every death counts as a crash. Results come back
    in item order.
    """

    def __init__(self, actors: list, registry: RegistryClient, status: JobStatus, on_result: Callable,
                 method: str = "extract", quarantined: Callable = quarantined_object, crashes: Path | None = None):
        self.actors, self.registry, self.status, self.on_result = actors, registry, status, on_result
        self.method, self.quarantined, self.crashes = method, quarantined, crashes
        self.pending: dict = {}  # ObjectRef -> (index, object ref, actor position, alone)
        self.deaths: dict[int, Counter] = {}  # item -> {"crash": n, "unexplained": n} while it ran alone
        self.suspects: set[int] = set()
        # work goes only to actors that have started: on a busy cluster some may wait for CPUs for a long time
        self.starting = {actor.__ray_ready__.remote(): k for k, actor in enumerate(actors)}
        self.ready: set[int] = set()

    def run(self, items: list) -> list:
        import ray

        todo = deque(enumerate(items))
        results: list = []
        while todo or self.pending:
            if self.registry.cancel_requested(self.status.job_id):
                raise JobCancelled(f"cancelled after {len(results)} of {len(items)} {self.method} tasks")
            self._note_started()
            self._fill(todo)
            # an actor that finishes starting wakes the loop too, so it gets work at once, not at the next result
            ready, _ = ray.wait([*self.pending, *self.starting], num_returns=1, timeout=POLL_SECONDS)
            ready = [ref for ref in ready if ref in self.pending]
            for ref in ready:
                result = self._collect(ref, todo)
                if result is not None:
                    results.append(result)
                    self.on_result(result)
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
        """Hand out items: up to IN_FLIGHT_PER_WORKER queued per actor (no idle gap between its tasks) while there
        is plenty left; once no more items remain than actors, only to idle actors, so the last items never wait
        in one actor's queue while another actor idles."""
        deferred = deque()
        while todo:
            limit = IN_FLIGHT_PER_WORKER if len(todo) > len(self.actors) else 1
            index, ref = todo.popleft()
            load = self._load()
            alone = index in self.suspects
            free = [k for k, n in enumerate(load) if (n == 0 if alone else n < limit)]
            if not free:
                deferred.append((index, ref))
                if not alone:
                    break
                continue
            position = min(free, key=lambda k: load[k])
            call = getattr(self.actors[position], self.method)
            self.pending[call.remote(ref, index)] = (index, ref, position, alone)
        todo.extendleft(reversed(deferred))

    def _collect(self, object_ref, todo: deque):
        import ray
        from ray.exceptions import RayActorError, WorkerCrashedError

        index, ref, position, alone = self.pending.pop(object_ref)
        try:
            return ray.get(object_ref)
        except (RayActorError, WorkerCrashedError) as err:
            self._restarting(position)
            self.status.retries += 1
            self.suspects.add(index)
            reason = self._death(index, err) if alone else None
            if reason:
                return self.quarantined(index, ref, reason)
            todo.appendleft((index, ref))
            return None

    def _death(self, index: int, err: Exception) -> str | None:
        """Count a death of the worker that ran item ``index`` alone; the quarantine reason, once it is one."""
        crashed = (self.crashes is None or crashed_on(self.crashes, self.method, index)
                   or isinstance(err, OutOfMemoryError) or "low on memory" in str(err))
        deaths = self.deaths.setdefault(index, Counter())
        deaths["crash" if crashed else "unexplained"] += 1
        if deaths["crash"] >= MAX_CRASHES:
            return (f"quarantined: it crashed its worker {deaths['crash']} times while running alone "
                    f"({type(err).__name__})")
        if deaths["unexplained"] >= MAX_UNEXPLAINED:
            return (f"quarantined: its worker died {deaths['unexplained']} times while running it alone, with no "
                    f"crash record (killed from outside?) ({type(err).__name__})")
        return None
