"""A bounded chaos run on the local multi-node cluster: several jobs at once, worker actors and a worker node killed
at seeded random times, every job's dataset compared with its fault-free run.

Run: .venv/bin/python -m benchmarks.reliability.chaos [--jobs 3] [--seed 0]
     (minutes; writes benchmarks/results/chaos.json)
Starts its own cluster (cluster/local_cluster.sh, its own ports) and stops only the nodes it started. Reports jobs,
kills, recoveries (jobs that succeeded after a kill), and grasps lost or duplicated against the fault-free runs
(targets 0 and 0); a job counts as identical when its content digest (store.content_digest) equals the fault-free
one's.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import subprocess
import tempfile
import time
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
from onepiece_dist.api import Client  # noqa: E402
from onepiece_dist.runtime.local import run_local  # noqa: E402
from onepiece_dist.specs.job import JobSpec, default_job_id  # noqa: E402
from onepiece_dist.store import open_dataset  # noqa: E402
from onepiece_dist.store.dataset import content_digest  # noqa: E402

PORTS = {"ONEPIECE_RAY_PORT": "6410", "ONEPIECE_DASHBOARD_PORT": "8290", "ONEPIECE_AGENT_PORT": "52400"}


def job_specs(count: int, folder: Path) -> list[JobSpec]:
    return [JobSpec(objects="primitives[0:6]", grasps_per_object=48, seed=seed,
                    output=str(folder / f"chaos{seed}.zarr"),
                    sampler={"surface_points": 3000}, stages=("ingest", "extract", "dedup", "assemble", "label"),
                    sim={"perturbations_per_patch": 2, "points_per_grasp": 64, "transfer_codes": 0})
            for seed in range(count)]


def cluster(command: str, *args: str) -> str:
    env = {**os.environ, **PORTS}
    return subprocess.run([str(ROOT / "cluster" / "local_cluster.sh"), command, *args], env=env, check=True,
                          capture_output=True, text=True, timeout=300).stdout.strip()


def kill_random_worker(rng: random.Random) -> str | None:
    """Kill (SIGKILL) the process of one simulation worker actor of any job, as a crash would; returns what."""
    import psutil

    workers = sorted((p for p in psutil.process_iter(["pid", "cmdline"])
                      if p.info["cmdline"] and p.info["cmdline"][0].startswith("ray::SimWorker")),
                     key=lambda p: p.info["pid"])
    if not workers:
        return None
    victim = rng.choice(workers)
    try:
        what = f"{victim.info['cmdline'][0]} (pid {victim.pid})"
        victim.kill()
    except psutil.NoSuchProcess:
        return None
    return what


def kill_worker_node(agent_port: int) -> str | None:
    """Kill (SIGKILL) the raylet of the worker node whose agent listens on ``agent_port``: the node is gone, with
    every worker actor on it; a replacement node joins (``local_cluster.sh add``)."""
    import psutil

    for proc in psutil.process_iter(["name", "cmdline"]):
        if proc.info["name"] == "raylet" and f"--listen-port={agent_port}" in " ".join(proc.info["cmdline"] or []):
            proc.kill()
            cluster("add", "3")
            return f"worker node with agent port {agent_port} (raylet pid {proc.pid}); a replacement node joined"
    return None


def run(jobs: int, seed: int) -> dict:
    rng = random.Random(seed)
    folder = Path(tempfile.mkdtemp(prefix="onepiece-chaos-"))
    specs = job_specs(jobs, folder)
    address = cluster("start", "2")
    kills: list[str] = []
    node_kill_at = rng.randint(3, 8)  # the node goes after this many worker kills
    try:
        client = Client(address)
        handles = [client.submit(spec) for spec in specs]
        start = time.monotonic()
        while time.monotonic() - start < 900:
            states = [client.status(h.job_id).state for h in handles]
            if all(s in ("succeeded", "failed", "cancelled") for s in states):
                break
            time.sleep(rng.uniform(3.0, 10.0))
            killed = (kill_worker_node(int(PORTS["ONEPIECE_AGENT_PORT"]) + 1) if len(kills) == node_kill_at
                      else kill_random_worker(rng))
            if killed:
                kills.append(killed)
        finals = [client.status(h.job_id) for h in handles]
    finally:
        cluster("stop")
    return compare(specs, finals, kills, folder)


def compare(specs: list[JobSpec], finals, kills: list[str], folder: Path) -> dict:
    rows = []
    for spec, final in zip(specs, finals, strict=True):
        clean = spec.model_copy(update={"output": str(folder / f"clean-{Path(spec.output).name}")})
        run_local(clean)
        ok = final.state == "succeeded"
        grasps = open_dataset(spec.output).summary()["grasps"] if ok else 0
        expected = open_dataset(clean.output).summary()["grasps"]
        rows.append({"job": default_job_id(spec), "state": final.state, "retries": final.retries,
                     "identical": ok and content_digest(spec.output, training=False)
                     == content_digest(clean.output, training=False),
                     "lost_grasps": max(0, expected - grasps), "duplicated_grasps": max(0, grasps - expected),
                     "quarantined": [r.name for r in final.rejections if r.reason.startswith("quarantined")],
                     "error": final.error[-400:]})
    return {"jobs": rows, "kills": kills, "recoveries": sum(r["state"] == "succeeded" and r["retries"] > 0
                                                             for r in rows),
            "lost_grasps": sum(r["lost_grasps"] for r in rows),
            "duplicated_grasps": sum(r["duplicated_grasps"] for r in rows),
            "identical_jobs": sum(r["identical"] for r in rows)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    result = {"command": f"python -m benchmarks.reliability.chaos --jobs {args.jobs} --seed {args.seed}",
              "date": str(date.today()), "machine": f"{platform.machine()}, {os.cpu_count()} cores",
              "targets": {"lost_grasps": 0, "duplicated_grasps": 0}, **run(args.jobs, args.seed)}
    (ROOT / "benchmarks" / "results" / "chaos.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
