"""The pick benchmark end to end (docs/picks.md): one task per held-out object on the Ray worker pool (or in this
process), then the report: per object and per method the first-attempt pick success and the success within k,
overall with bootstrap intervals over objects, and whether the benchmark can separate a network from a guess."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.errors import SpecError
from onepiece_dist.objects import ObjectRef, resolve_source
from onepiece_dist.picks.clutter import groups_of, pick_scene
from onepiece_dist.picks.object_picks import ObjectPicks, ViewPicks, pick_object
from onepiece_dist.plan.scorer import GraspScorer
from onepiece_dist.plan.shipped import planning_network
from onepiece_dist.runtime.actors import restartable_actor
from onepiece_dist.runtime.crashes import CrashLog, crash_folder, running
from onepiece_dist.runtime.pinned_child import PinnedSimulation
from onepiece_dist.runtime.ray_env import connect
from onepiece_dist.runtime.registry import RegistryClient
from onepiece_dist.specs.plan import PickSpec
from onepiece_dist.stats.intervals import bootstrap_interval
from onepiece_dist.stats.ranking import SEPARABLE, can_separate

REPORT_FILE = "picks.json"


@dataclass(frozen=True)
class MethodSummary:
    """One method over every object: the mean of the per-object rates, with 95% bootstrap intervals, and how its
    first attempts failed (reason: views; 'no_grasp' where it had none to try)."""

    method: str
    first_attempt: float
    first_attempt_interval: tuple[float, float]
    within_k: float
    within_k_interval: tuple[float, float]
    views: int
    first_failures: dict[str, int] = dataclasses.field(default_factory=dict)


@dataclass(frozen=True)
class PickReport:
    """The benchmark's result: its spec, every object's views, each method's summary and the verdict on whether
    the picks can tell a network from a guess."""

    spec: dict
    objects: tuple[ObjectPicks, ...]
    methods: tuple[MethodSummary, ...]
    separable: bool | None
    verdict: str

    def method(self, name: str) -> MethodSummary:
        return next(m for m in self.methods if m.method == name)

    def first_picks(self, method: str) -> dict[str, int]:
        """Per loaded object (its name): the views ``method`` picked at the first attempt (what a paired
        comparison of two networks on the same views reads)."""
        return {o.name: sum(bool(v.first(method)) for v in o.views) for o in self.objects if o.status == "ok"}

    def to_json(self) -> dict:
        return {"spec": self.spec, "separable": self.separable, "verdict": self.verdict,
                "methods": [dataclasses.asdict(m) for m in self.methods],
                "objects": [dataclasses.asdict(o) for o in self.objects]}


def object_rate(picks: ObjectPicks, method: str, k: int | None) -> float:
    """An object's share of views picked by ``method`` at the first attempt (k None) or within ``k``."""
    views = picks.views
    hits = [view.first(method) if k is None else view.within(method, k) for view in views]
    return float(np.mean(hits)) if hits else 0.0


def first_failures(done: list[ObjectPicks], method: str) -> dict[str, int]:
    """How ``method``'s first attempts failed, over every view: reason -> views (sorted by reason)."""
    reasons = Counter()
    for picks in done:
        for view in picks.views:
            tried = view.failures.get(method, ())
            if not tried:
                reasons["no_grasp"] += 1
            elif tried[0]:
                reasons[tried[0]] += 1
    return dict(sorted(reasons.items()))


def summarise(spec: PickSpec, results: list[ObjectPicks]) -> PickReport:
    """Per-method rates over the objects that could be loaded, with intervals, and the verdict."""
    done = [r for r in results if r.status == "ok"]
    summaries = []
    for method in spec.methods:
        first = np.array([object_rate(r, method, None) for r in done])
        within = np.array([object_rate(r, method, spec.attempts) for r in done])
        summaries.append(MethodSummary(method, float(first.mean()) if len(first) else 0.0,
                                       bootstrap_interval(first, seed=spec.seed),
                                       float(within.mean()) if len(within) else 0.0,
                                       bootstrap_interval(within, seed=spec.seed), sum(len(r.views) for r in done),
                                       first_failures(done, method)))
    separable, verdict = _verdict(spec, summaries, len(done))
    return PickReport(spec.model_dump(mode="json"), tuple(results), tuple(summaries), separable, verdict)


def _verdict(spec: PickSpec, summaries: list[MethodSummary], objects: int) -> tuple[bool | None, str]:
    if objects == 0:
        return None, "no object could be loaded: nothing was picked"
    if "random" not in spec.methods:
        return None, "without the random method the benchmark cannot say whether it separates a network from a guess"
    rate = next(s.first_attempt for s in summaries if s.method == "random")
    if not can_separate(rate):
        side = "succeeds" if rate > SEPARABLE[1] else "fails"
        return False, (f"a random collision-free grasp {side} at {rate:.0%} of first attempts: these picks cannot "
                       "separate a network from a guess (make them harder: more label trials, other objects)")
    return True, f"a random collision-free grasp picks {rate:.0%} at the first attempt: the picks can separate"


def run_picks(spec: PickSpec, address: str | None = None, in_process: bool = False,
              progress: Callable[[ObjectPicks], None] | None = None) -> PickReport:
    """Run the benchmark: on an embedded Ray (default), the cluster at ``address``, or in this process; write
    ``picks.json`` into ``spec.output`` and return the report."""
    units = pick_units(spec)  # a bad source is a usage error, found before any Ray starts
    spec = with_network(spec)
    GraspScorer(spec.checkpoint, spec.gripper, "cpu", spec.carried)  # a bad checkpoint fails here, not in a worker
    Path(spec.output).mkdir(parents=True, exist_ok=True)
    if in_process:
        results = run_each_in_process(pick_task(spec), spec, units, progress)
    else:
        results = _run_on_ray(spec, units, address, progress)
    report = summarise(spec, results)
    (Path(spec.output) / REPORT_FILE).write_text(json.dumps(report.to_json(), indent=1) + "\n")
    return report


def with_network(spec: PickSpec) -> PickSpec:
    """``spec`` naming its network where it names no checkpoint: the one shipped for its gripper, or the default
    job's carried to it where ``spec.plan.carry`` allows (plan.shipped.planning_network)."""
    if spec.checkpoint is not None:
        return spec
    network = planning_network(spec.gripper, spec.plan.carry)
    return spec.model_copy(update={"checkpoint": str(network.path), "carried": network.carried})


def pick_units(spec: PickSpec) -> list:
    """What the benchmark's tasks pick: the source's objects, or with ``spec.clutter`` N > 1 its scenes of N."""
    refs = resolve_source(spec.objects)
    if spec.clutter == 1:
        return refs
    if len(refs) < spec.clutter:
        raise SpecError(f"clutter: {spec.objects!r} holds {len(refs)} objects; a scene of {spec.clutter} needs as "
                        f"many: name a source of {spec.clutter} or more objects, or a smaller clutter")
    return groups_of(refs, spec.clutter)


def pick_task(spec: PickSpec) -> Callable:
    """The task that picks one unit (pick_units): one object, or one scene."""
    return pick_scene if spec.clutter > 1 else pick_object


def run_each_in_process(task: Callable, spec, refs: list[ObjectRef], progress=None) -> list:
    """``task(spec, ref, index)`` for every object in turn, in a pinned simulation child (runtime.pinned_child),
    results in object order; ``progress`` sees each."""
    simulate, results = PinnedSimulation(), []
    try:
        for index, ref in enumerate(refs):
            results.append(simulate(task, spec, ref, index))
            if progress:
                progress(results[-1])
    finally:
        simulate.close()
    return results


class PickWorker:
    """One pybullet client and one network per actor: picks objects. A plain class, testable without Ray."""

    def __init__(self, spec: PickSpec, crashes: str | None = None):
        self.spec = spec
        self.crash_log = CrashLog(crashes) if crashes else None

    def pick(self, ref: ObjectRef, index: int) -> ObjectPicks:
        from onepiece_dist.runtime.ray_runner import node_id

        with running(self.crash_log, "pick", index):
            picked = pick_task(self.spec)(self.spec, ref, index)
        return dataclasses.replace(picked, node=node_id())


@dataclass
class PoolStatus:
    """What the worker pool reads and counts of a run: its id (for cancel requests) and the retries."""

    job_id: str
    retries: int = 0


def pick_job_id(spec: PickSpec) -> str:
    return "pick-" + hashlib.blake2b(spec.model_dump_json().encode(), digest_size=6).hexdigest()


def _run_on_ray(spec: PickSpec, refs: list, address: str | None, progress) -> list[ObjectPicks]:
    import ray

    from onepiece_dist.runtime.ray_runner import WorkerPool, worker_count

    started_here = not ray.is_initialized()
    connect(address)
    job_id = pick_job_id(spec)
    crashes = crash_folder(spec.output, job_id)
    actors = [restartable_actor(PickWorker, f"{job_id}-{k}", num_cpus=1, scheduling_strategy="SPREAD")
              .remote(spec, str(crashes)) for k in range(worker_count(spec.workers, len(refs)))]
    try:
        pool = WorkerPool(actors, RegistryClient(), PoolStatus(job_id), progress or (lambda result: None), "pick",
                          _quarantined, crashes)
        return pool.run(refs)
    finally:
        for actor in actors:
            ray.kill(actor)
        shutil.rmtree(crashes, ignore_errors=True)
        if started_here:
            ray.shutdown()


def _quarantined(index: int, ref: ObjectRef, reason: str) -> ObjectPicks:
    return ObjectPicks(index, ref.name, "rejected", reason=reason)


__all__ = ["MethodSummary", "ObjectPicks", "PickReport", "PickWorker", "ViewPicks", "run_picks", "summarise"]
