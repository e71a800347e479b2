"""The end-to-end budget: the 64-object job with 2000 candidates per object, wall time per stage and peak memory.

    .venv/bin/python -m benchmarks.speed.bench_end_to_end [--objects 64] [--grasps 2000]
        [--stages ingest,extract,dedup,assemble,label,train] [--train-model voxel] [--train-epochs 2]

Runs the job as a user does (`onepiece.api.run_job` on an embedded Ray, one extraction worker per core, physics
on) with a fresh cache, so every object is simulated and decomposed. Memory: resident set of the whole process
tree (this driver and every Ray process it started), sampled every 0.2 s; reported in all, and above the tree's
level just before the job (Ray's own idle daemons). RSS counts shared pages once per process, so it is an upper
bound. Core-seconds per stage: the tree's summed CPU time (user + system) sampled at the same times, differenced
over the stage's window. The train stage runs the model and epochs given (PointNet at 750 points trains at about
165 samples/s on 2 cores, so the default is the voxel CNN for 2 epochs; both are recorded). Targets (issue 16):
extract + dedup + assemble + label under 10 minutes, peak memory under 4 GiB, the extract stage at >= 400
candidates/s/core (candidates / (extract seconds x cores)) on 2 cores, and the label stage at >= 0.8 x the label
protocol's trials/s/core (label trials / the stage's core-seconds). The protocols (bench_sim's extract and label
trials, one core, nothing else running) are timed in the same run, on every eighth of the job's objects, before
and after the job: this machine's speed drifts by a fifth between runs, so a rate measured on another day is no
yardstick. After the job, the label protocol is also timed on the job's own patches (ranges spread over the one
object, one core): a trial on a patch (a compound of clipped convex pieces) costs more physics than one on a whole
object, so the stage's rate is given against both. Writes benchmarks/results/bench_end_to_end.json.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from datetime import date
from pathlib import Path

import numpy as np
import psutil

from benchmarks.speed.bench_sim import load_all, protocol_rates, time_protocols
from benchmarks.speed.process_tree import ProcessTree
from onepiece_dist.api import run_job
from onepiece_dist.objects import resolve_source
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import open_dataset
from onepiece_dist.store.dataset import disk_bytes

HERE = Path(__file__).resolve().parents[1]
GIB = 2**30
WORKERS = os.cpu_count() or 1  # one extraction worker per core (the job's default)
PROTOCOL_EVERY, PROTOCOL_GRASPS, PROTOCOL_REPEATS = 8, 64, 2  # objects, candidates each, timings before and after
PATCH_RANGES, PATCHES_PER_RANGE = 8, 16  # the label protocol on the job's own patches: ranges spread over them
CHILD_START_S = 20.0  # two protocol children start timing together this long after they are started


def stage_windows(start: float, timings: dict[str, float]) -> dict[str, tuple[float, float]]:
    """(begin, end) of each stage; the stages run one after another in this order."""
    windows, clock = {}, start
    for stage in ("ingest", "extract", "dedup", "assemble", "label", "train"):
        if stage in timings:
            windows[stage] = (clock, clock + timings[stage])
            clock += timings[stage]
    return windows


def objects_source(count: int) -> str:
    named = len(resolve_source("pybullet:named"))
    return f"pybullet:named+pybullet:random_urdfs[0:{max(count - named, 0)}]"


def main() -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=64)
    parser.add_argument("--grasps", type=int, default=2000)
    parser.add_argument("--stages", default="ingest,extract,dedup,assemble,label,train")
    parser.add_argument("--train-model", choices=("pointnet", "voxel"), default="voxel")
    parser.add_argument("--train-epochs", type=int, default=2)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="onepiece-e2e-"))
    spec = JobSpec(objects=objects_source(args.objects), grasps_per_object=args.grasps,
                   output=str(folder / "e2e.zarr"), stages=tuple(args.stages.split(",")),
                   train={"model": args.train_model, "epochs": args.train_epochs})
    import ray

    from onepiece_dist.runtime.ray_env import connect

    protocols = ProtocolClock(spec, folder)
    protocols.time()  # before Ray starts: one core, nothing else running
    connect(None)
    try:
        with ProcessTree() as memory:
            time.sleep(1.0)
            idle = memory.peak()
            start = time.perf_counter()
            status = run_job(spec)
            wall = time.perf_counter() - start
        windows = stage_windows(start, status.timings)
        by_stage = {stage: memory.peak(*window) for stage, window in windows.items()}
        cores = {stage: memory.core_seconds(*window) for stage, window in windows.items()}
        summary = open_dataset(spec.output).summary()
        result = _result(args, spec, status, wall, memory.peak(), idle, by_stage, summary)
        result["core_seconds_by_stage"] = {stage: round(value, 1) for stage, value in cores.items()}
        ray.shutdown()
        protocols.time()
        result["protocol"] = protocols.summary()
        result["protocol"]["two_at_once"] = protocols.time_two_at_once()
        result["extract_over_protocol_two_at_once"] = round(
            result["extract_candidates_per_s_per_core"]
            / result["protocol"]["two_at_once"]["extract_trials_per_s_per_core"], 3)
        result["extract_over_protocol"] = round(result["extract_candidates_per_s_per_core"]
                                                / result["protocol"]["extract_trials_per_s_per_core"], 3)
        if status.labels is not None and cores.get("label"):
            result["label"] = label_rate(status.labels, cores["label"],
                                         result["protocol"]["label_trials_per_s_per_core"])
            patches = protocols.time_patches(spec.output, result["patches"])
            result["label"]["patch_protocol"] = patches
            rate = result["label"]["trials_per_s_per_core"]
            result["label"]["rate_over_patch_protocol"] = round(rate / patches["label_trials_per_s_per_core"], 3)
            result["label"]["rate_over_patch_protocol_two_at_once"] = round(
                rate / patches["two_at_once_label_trials_per_s_per_core"], 3)
    finally:
        ray.shutdown()
        shutil.rmtree(folder, ignore_errors=True)
    (HERE / "results" / "bench_end_to_end.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return result


class ProtocolClock:
    """Times bench_sim's extract and label protocols on every PROTOCOL_EVERY-th object of ``spec``'s source
    (PROTOCOL_GRASPS candidates each, one core), PROTOCOL_REPEATS times per call of :meth:`time`, in a child
    process that is gone before the job starts: the driver's memory, which the job's peak counts, holds none of it."""

    def __init__(self, spec: JobSpec, folder: Path):
        self.spec = spec.model_copy(update={"grasps_per_object": PROTOCOL_GRASPS})
        self.refs = resolve_source(spec.objects)[::PROTOCOL_EVERY]
        self.cache = folder / "protocol-cache"  # the convex pieces, decomposed on the first call
        self.cache.mkdir(parents=True, exist_ok=True)
        self.rounds: list[dict[str, list[float]]] = []
        self.trials = self.loaded = 0

    def time(self) -> None:
        (seconds, self.trials, self.loaded), = in_children(1, timed_protocols, self.spec.model_dump_json(),
                                                           self.refs, str(self.cache))
        self.rounds.append(seconds)

    def time_two_at_once(self) -> dict:
        """The protocols in two child processes at once (one per core, as the job's two workers run): trials/s
        of each core while the other is busy too, and that over the last round's (one core, the other idle)."""
        copies = in_children(2, timed_protocols, self.spec.model_dump_json(), self.refs, str(self.cache))
        both = {name: [s for seconds, _, _ in copies for s in seconds[name]] for name in copies[0][0]}
        rates, alone = protocol_rates(both, self.trials), protocol_rates(self.rounds[-1], self.trials)
        return {**rates, "over_alone": {name: round(rates[name] / alone[name], 3) for name in rates}}

    def time_patches(self, dataset: str, patches: int) -> dict:
        """The label protocol on the finished job's own patches (PATCH_RANGES ranges of PATCHES_PER_RANGE spread
        over its ``patches``), PROTOCOL_REPEATS times on one core, then in two child processes at once; compared
        with the whole-object label protocol of the last round (timed just before)."""
        ranges, spec_json = patch_ranges(patches), self.spec.model_dump_json()
        alone = in_children(1, timed_patch_protocol, spec_json, dataset, ranges)[0]
        together = [s for seconds in in_children(2, timed_patch_protocol, spec_json, dataset, ranges) for s in seconds]
        timed = sum(stop - start for start, stop in ranges)
        trials = timed * self.spec.sim.label_trials_per_patch()
        rate, both = trials / float(np.median(alone)), trials / float(np.median(together))
        beside = protocol_rates(self.rounds[-1], self.trials)["label_trials_per_s_per_core"]
        return {"patches": timed, "trials": trials,
                "repeats": PROTOCOL_REPEATS, "label_trials_per_s_per_core": round(rate, 1),
                "two_at_once_label_trials_per_s_per_core": round(both, 1),
                "whole_object_label_trials_per_s_per_core": beside, "over_whole_objects": round(rate / beside, 3)}

    def summary(self) -> dict:
        """Rates from the median of every timing, and per round (before the job, after it)."""
        every = {name: [s for seconds in self.rounds for s in seconds[name]] for name in self.rounds[0]}
        return {"objects": [ref.name for ref in self.refs], "objects_loaded": self.loaded,
                "trials": self.trials, "repeats": PROTOCOL_REPEATS, **protocol_rates(every, self.trials),
                "rounds": [protocol_rates(seconds, self.trials) for seconds in self.rounds]}


def in_children(copies: int, timed, *args) -> list:
    """``timed(*args, start_at)`` in ``copies`` spawned processes at once; each times its work from ``start_at``
    (wall clock, after its imports and loading), so that the copies overlap. Their results, in order."""
    with ProcessPoolExecutor(copies, mp_context=multiprocessing.get_context("spawn")) as pool:
        start_at = time.time() + (CHILD_START_S if copies > 1 else 0.0)
        return [job.result() for job in [pool.submit(timed, *args, start_at) for _ in range(copies)]]


def wait_until(start_at: float) -> None:
    time.sleep(max(start_at - time.time(), 0.0))


def timed_protocols(spec_json: str, refs: list, cache: str, start_at: float) -> tuple[dict[str, list[float]], int,
                                                                                        int]:
    """(In the child process) seconds of each protocol per repeat, trials per repeat, objects loaded."""
    spec = JobSpec.model_validate_json(spec_json)
    loaded = load_all(spec, Path(cache), refs, PROTOCOL_GRASPS)
    wait_until(start_at)
    seconds, extracted = time_protocols(spec, loaded, PROTOCOL_REPEATS, ("extract", "label"))
    return seconds, int(extracted.shape[1]), len(loaded)


def patch_ranges(patches: int) -> list[tuple[int, int]]:
    """PATCH_RANGES [start, stop) ranges of PATCHES_PER_RANGE patches, evenly spread over ``patches``."""
    starts = np.linspace(0, max(patches - PATCHES_PER_RANGE, 0), PATCH_RANGES).astype(int)
    return [(int(a), int(min(a + PATCHES_PER_RANGE, patches))) for a in np.unique(starts)]


def timed_patch_protocol(spec_json: str, dataset: str, ranges: list[tuple[int, int]], start_at: float) -> list[float]:
    """(In the child process) seconds per repeat of labelling the patches of ``ranges`` as the label stage does."""
    from onepiece_dist.job.results import LabelTask
    from onepiece_dist.job.stages.label_one_object import label_patches

    spec = JobSpec.model_validate_json(spec_json)
    tasks = [LabelTask(start, stop, dataset, "protocol") for start, stop in ranges]
    wait_until(start_at)
    seconds = []
    for _ in range(PROTOCOL_REPEATS):
        start = time.perf_counter()
        for task in tasks:
            label_patches(spec, task)
        seconds.append(time.perf_counter() - start)
    return seconds


def label_rate(labels, core_seconds: float, protocol: float) -> dict:
    """Label trials of the label stage (on the one object, plus the label-transfer measure's trials on source
    objects) per core-second of the stage, against the label protocol's trials/s/core ``protocol``."""
    transfer = labels.transfer.label_trials if labels.transfer is not None else 0
    rate = (labels.label_trials + transfer) / core_seconds
    return {"trials_one_object": labels.label_trials, "trials_transfer": transfer,
            "labelled_grasps": labels.labelled_grasps, "trials_per_s_per_core": round(rate, 1),
            "protocol_trials_per_s_per_core": protocol, "rate_over_protocol": round(rate / protocol, 3),
            "target_rate_over_protocol": 0.8}


def _result(args, spec: JobSpec, status, wall: float, peak: int, idle: int, by_stage: dict[str, int],
            summary: dict) -> dict:
    stages = list(by_stage)
    budget = sum(status.timings.get(s, 0.0) for s in ("ingest", "extract", "dedup", "assemble", "label"))
    return {
        "benchmark": "bench_end_to_end", "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, {psutil.virtual_memory().total / GIB:.0f} GiB",
        "objects": args.objects, "candidates_per_object": args.grasps, "state": status.state,
        "objects_ok": status.progress.objects_done - len(status.rejections), "rejected": len(status.rejections),
        "grasps": summary["grasps"], "unique_codes": summary["unique_codes"],
        "patches": summary.get("assembly", {}).get("unique_codes"),
        "stage_seconds": {s: round(status.timings[s], 1) for s in stages},
        "workers": WORKERS, "extract_worker_seconds": round(status.worker_seconds, 1),
        "extract_candidates_per_s_per_core": round(args.objects * args.grasps
                                                   / (status.timings["extract"] * WORKERS), 1),
        "extract_candidates_per_s_per_busy_core": round(args.objects * args.grasps / status.worker_seconds, 1),
        "budget_seconds": round(budget, 1), "budget_stages": [s for s in stages if s not in ("ingest", "train")],
        "train": {"model": spec.train.model, "epochs": spec.train.epochs}, "wall_seconds": round(wall, 1),
        "peak_memory_bytes": peak, "peak_memory_gib": round(peak / GIB, 2),
        "ray_idle_memory_gib": round(idle / GIB, 2), "peak_above_idle_gib": round((peak - idle) / GIB, 2),
        "peak_memory_gib_by_stage": {s: round(by_stage[s] / GIB, 2) for s in stages},
        "dataset_bytes": summary["bytes_on_disk"], "parts_bytes": disk_bytes(Path(f"{spec.output}.parts")),
        "targets": {"budget_seconds": 600, "peak_memory_gib": 4,
                    "extract_candidates_per_s_per_core": 400},
        "command": "python -m benchmarks.speed.bench_end_to_end " + " ".join(sys.argv[1:]),
    }


if __name__ == "__main__":
    main()
