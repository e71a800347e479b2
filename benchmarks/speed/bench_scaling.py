"""Throughput of the Ray service with 1 and 2 workers on this machine, for extraction and for the label stage on
the one object, and orchestration overhead.

Run: .venv/bin/python -m benchmarks.speed.bench_scaling  (writes benchmarks/results/scaling.json)
Each configuration runs the same job on a fresh embedded Ray with a fresh parts folder (nothing reused).
Parallel efficiency = (objects/s with 2 workers) / (2 x objects/s with 1 worker). Orchestration overhead per
object = (extract-stage wall time x workers - sum of per-object worker time) / objects: time a worker slot spends
outside extract_object (scheduling, result transfer, central dedup merge, status writes). The label stage's
speed-up = (label stage wall time with 1 worker) / (with 2): shards on workers, plus the central actor's sharding
and merge (label transfer is off here: it is measured in the central actor). Each figure is the median over
REPEATS pairs of runs (every pair's value is recorded); the table shows the pair with the median efficiency.

This machine's CPU speed drifts between runs (by a fifth, at times within minutes), which a ratio of two runs
takes for scaling. So each run is bracketed by a speed probe (the extract protocol on one object, one core,
nothing else running, just before and just after the run), and each pair's ratio is also given adjusted by the
two runs' probe speeds: adjusted = raw x (speed during the 1-worker run) / (speed during the 2-worker run).
"""

from __future__ import annotations

import json
import os
import platform
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np

from benchmarks.speed.bench_sim import load_all, time_protocols
from benchmarks.speed.process_tree import ProcessTree, process_kind
from onepiece_dist.runtime.ray_env import connect
from onepiece_dist.specs.job import JobSpec

OBJECTS = os.environ.get("BENCH_SCALING_OBJECTS", "pybullet:random_urdfs[0:16]")
GRASPS = int(os.environ.get("BENCH_SCALING_GRASPS", 128))


PROBE_OBJECTS, PROBE_GRASPS, PROBE_REPEATS = "pybullet:random_urdfs[0:2]", 128, 2


class SpeedProbe:
    """Extract-protocol trials/s on PROBE_OBJECTS (PROBE_GRASPS candidates each), one core: the machine's speed now
    (the median of PROBE_REPEATS timings)."""

    def __init__(self, folder: Path):
        from onepiece_dist.objects import resolve_source

        self.spec = JobSpec(grasps_per_object=PROBE_GRASPS)
        self.loaded = load_all(self.spec, folder, resolve_source(PROBE_OBJECTS), PROBE_GRASPS)

    def speed(self) -> float:
        seconds, extracted = time_protocols(self.spec, self.loaded, PROBE_REPEATS, ("extract",))
        return extracted.shape[1] / float(np.median(seconds["extract"]))


def measure(workers: int, probe: SpeedProbe) -> dict:
    import ray

    from onepiece_dist.runtime.ray_runner import run_on_ray

    before = probe.speed()
    with tempfile.TemporaryDirectory() as folder:
        spec = JobSpec(objects=OBJECTS, grasps_per_object=GRASPS, output=f"{folder}/ds.zarr",
                       stages=("ingest", "extract", "dedup", "assemble", "label"), sim={"transfer_codes": 0})
        connect(None, num_cpus=2)
        try:
            with ProcessTree(kind=process_kind) as cpu:
                start = time.perf_counter()
                status = run_on_ray(spec, f"bench-{workers}", workers=workers)
        finally:
            ray.shutdown()
        worker_seconds = _worker_seconds(Path(f"{folder}/ds.zarr.status.json"))
    after = probe.speed()
    begins = dict(zip(status.timings, np.cumsum([0.0, *status.timings.values()]) + start, strict=False))
    extract_cpu, label_cpu = (_rounded(cpu.cpu_by_kind(begins[s], begins[s] + status.timings[s]))
                              for s in ("extract", "label"))
    wall = status.timings["extract"]
    objects = status.progress.objects_done
    label_trials = status.labels.label_trials
    return {"workers": workers, "objects": objects, "extract_seconds": round(wall, 2),
            "objects_per_second": round(objects / wall, 3), "worker_seconds": round(worker_seconds, 2),
            "orchestration_overhead_per_object_s": round((wall * workers - worker_seconds) / objects, 4),
            "patches": status.assembly.unique_codes, "label_trials": label_trials,
            "label_seconds": round(status.timings["label"], 2),
            "label_trials_per_second": round(label_trials / status.timings["label"], 1),
            "extract_cpu_seconds_by_process": extract_cpu, "label_cpu_seconds_by_process": label_cpu,
            "probe_trials_per_s": [round(before, 1), round(after, 1)]}


def probe_speed(run: dict) -> float:
    """The machine's speed during ``run``: the mean of its probes before and after."""
    return float(np.mean(run["probe_trials_per_s"]))


def _rounded(seconds: dict[str, float]) -> dict[str, float]:
    return {name: round(value, 2) for name, value in seconds.items() if value > 0.005}


def _worker_seconds(status_file: Path) -> float:
    return float(json.loads(status_file.read_text())["worker_seconds"])


REPEATS = 3  # pairs of runs (1 worker, then 2); the median pair counts: one pair's efficiency varied 83-91% here


def main() -> dict:
    with tempfile.TemporaryDirectory() as cache:
        probe = SpeedProbe(Path(cache))
        pairs = [(measure(1, probe), measure(2, probe)) for _ in range(REPEATS)]
    raw = [two["objects_per_second"] / (2 * one["objects_per_second"]) for one, two in pairs]
    raw_speedup = [one["label_seconds"] / two["label_seconds"] for one, two in pairs]
    drift = [probe_speed(one) / probe_speed(two) for one, two in pairs]
    efficiency = [e * d for e, d in zip(raw, drift, strict=True)]
    speedup = [x * d for x, d in zip(raw_speedup, drift, strict=True)]
    one, two = pairs[int(np.argsort(efficiency)[len(pairs) // 2])]  # the pair with the median efficiency
    out = {"benchmark": "scaling", "date": date.today().isoformat(), "machine": f"{platform.machine()}, "
           f"{os.cpu_count()} cores", "objects": OBJECTS, "grasps_per_object": GRASPS, "runs": [one, two],
           "parallel_efficiency_2_workers": round(float(np.median(efficiency)), 3), "target_efficiency": 0.9,
           "label_speedup_2_workers": round(float(np.median(speedup)), 3),
           "target_label_speedup": 1.8,  # issue 16: 90% efficiency at 2 workers, extraction and labelling
           "repeats": REPEATS, "efficiency_per_pair": [round(e, 3) for e in efficiency],
           "label_speedup_per_pair": [round(x, 3) for x in speedup],
           "speed_adjusted": True, "probe": {"objects": PROBE_OBJECTS, "grasps": PROBE_GRASPS},
           "speed_ratio_per_pair": [round(d, 3) for d in drift],
           "raw_efficiency_per_pair": [round(e, 3) for e in raw],
           "raw_label_speedup_per_pair": [round(x, 3) for x in raw_speedup],
           "command": "python -m benchmarks.speed.bench_scaling"}
    (Path(__file__).resolve().parents[1] / "results" / "scaling.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
