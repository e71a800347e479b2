"""Candidate generation and the extract stage's work around the physics, per core.

    .venv/bin/python -m benchmarks.speed.bench_candidates [--candidates 2000]

1. Candidate generation (antipodal sampling + open-gripper collision check) on a 10,000-point object
   (pybullet:random_urdfs[0]): candidates/s/core, against the per-pose collision check it replaced
   (`reference_collides` below, run in the same process on the same raw, unfiltered poses: the baseline; both
   must agree).
2. A profile of `extract_arrays` on the same object (cProfile, one core): seconds per part (sampling, physics,
   crops, the rest) and candidates/s, so the page shows what is left that is not the physics.
3. A profile of the label stage's work on the one object (`label_patches` on three shards of a 4-object job's
   one object): per patch, the trials (physics) against the set-up around them (loading the patch, crops, rows),
   and label trials/s against the protocol's rate on whole objects (benchmarks/results/sim.json).
Single-threaded BLAS (one core). Writes benchmarks/results/candidates.json. Target (issue 16): >= 10,000
candidates/s/core.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import cProfile
import json
import platform
import pstats
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
from onepiece_dist.core.frames import in_box, to_gripper_frame  # noqa: E402
from onepiece_dist.core.mesh import sample_surface  # noqa: E402
from onepiece_dist.core.sampling import (  # noqa: E402
    _antipodal_poses,
    collides,
    gripper_boxes,
    object_rng,
    sample_candidates,
)
from onepiece_dist.job.stages.extract import extract_arrays  # noqa: E402
from onepiece_dist.objects import load_object, resolve_source  # noqa: E402
from onepiece_dist.specs.job import JobSpec  # noqa: E402

OBJECT = "pybullet:random_urdfs[0:1]"
TARGET = 10_000
REPEATS = 5
PARTS = {"sampling": "core/sampling.py", "physics": "sim/", "crops": "core/voxel.py"}


def _copy(rng: np.random.Generator) -> np.random.Generator:
    """A generator in the same state as ``rng`` (so each repeat draws the same candidates)."""
    twin = np.random.Generator(type(rng.bit_generator)())
    twin.bit_generator.state = rng.bit_generator.state
    return twin


def reference_collides(points: np.ndarray, poses: np.ndarray, gripper) -> np.ndarray:
    """The check before issue 16: every probe point moved into every pose's frame, 3 boxes tested with in_box."""
    boxes = gripper_boxes(gripper)
    hit = np.zeros(len(poses), dtype=bool)
    step = max(1, 4_000_000 // max(len(points), 1))
    for start in range(0, len(poses), step):
        pts_g = to_gripper_frame(points, poses[start:start + step])
        inside = np.zeros(pts_g.shape[:2], dtype=bool)
        for lower, upper in boxes:
            inside |= in_box(pts_g, lower, upper)
        hit[start:start + step] = inside.any(axis=1)
    return hit


def generation(spec: JobSpec, mesh, count: int) -> dict:
    rng = object_rng(mesh.content_id, spec.seed)
    points, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
    sample_candidates(mesh, points, normals, 64, spec.gripper, spec.sampler, np.random.default_rng(1))  # warm up
    times = []
    for _ in range(REPEATS):  # the same candidates each time (same generator state): the median time is reported
        start = time.perf_counter()
        cands = sample_candidates(mesh, points, normals, count, spec.gripper, spec.sampler, _copy(rng))
        times.append(time.perf_counter() - start)
    seconds = float(np.median(times))
    probe = points[np.random.default_rng(2).permutation(len(points))[:4000]]
    poses, _ = _antipodal_poses(mesh, points, normals, count, spec.gripper, spec.sampler, np.random.default_rng(3))
    t0 = time.perf_counter()
    new = collides(probe, poses, spec.gripper)
    t1 = time.perf_counter()
    old = reference_collides(probe, poses, spec.gripper)
    t2 = time.perf_counter()
    if not np.array_equal(new, old):
        raise SystemExit("the collision check disagrees with its reference")
    return {"surface_points": len(points), "repeats": REPEATS, "candidates": len(cands.poses),
            "poses_tested": cands.tried,
            "collision_check_poses": len(poses), "colliding_share": round(float(new.mean()), 3),
            "seconds": round(seconds, 3), "candidates_per_s_per_core": round(len(cands.poses) / seconds),
            "collision_check_speedup_vs_per_pose": round((t2 - t1) / (t1 - t0), 2)}


def profile(spec: JobSpec, mesh) -> dict:
    folder = Path(tempfile.mkdtemp(prefix="onepiece-profile-"))
    extract_arrays(spec, mesh, folder)  # warm: the convex decomposition is cached, the world built
    prof = cProfile.Profile()
    start = time.perf_counter()
    prof.enable()
    _, meta = extract_arrays(spec, mesh, folder)
    prof.disable()
    total = time.perf_counter() - start
    stats = pstats.Stats(prof).stats
    parts = {name: round(_own_time(stats, fragment), 3) for name, fragment in PARTS.items()}
    parts["rest"] = round(total - sum(parts.values()), 3)
    return {"candidates": spec.grasps_per_object, "grasps": meta["grasps"], "seconds": round(total, 3),
            "candidates_per_s_per_core": round(spec.grasps_per_object / total), "seconds_by_part": parts,
            "physics_share": round(parts["physics"] / total, 3)}


def label_profile() -> dict:
    from onepiece_dist.job.stages.label_one_object import label_patches, label_tasks
    from onepiece_dist.runtime.local import run_local

    output = str(Path(tempfile.mkdtemp(prefix="onepiece-label-")) / "one.zarr")
    spec = JobSpec(objects="pybullet:random_urdfs[0:4]", grasps_per_object=200, output=output,
                   stages=("ingest", "extract", "dedup", "assemble"))
    run_local(spec)
    tasks = label_tasks(spec, output)
    label_patches(spec, tasks[0])  # warm: the one object read once per process, the world built
    prof = cProfile.Profile()
    start = time.perf_counter()
    prof.enable()
    for task in tasks[1:4]:
        label_patches(spec, task)
    prof.disable()
    total = time.perf_counter() - start
    patches = sum(task.stop - task.start for task in tasks[1:4])
    trials = patches * spec.sim.label_trials_per_patch()
    physics = _own_time(pstats.Stats(prof).stats, "sim/trials.py")
    protocol = json.loads((HERE / "results" / "sim.json").read_text())["label_trials_per_s_per_core"]
    return {"patches": patches, "trials_per_patch": trials // patches, "seconds": round(total, 3),
            "ms_per_patch": round(1000 * total / patches, 1), "trials_ms_per_patch": round(1000 * physics / patches, 1),
            "setup_share": round(1 - physics / total, 3), "label_trials_per_s_per_core": round(trials / total, 1),
            "protocol_label_trials_per_s_per_core": protocol,
            "rate_over_protocol": round(trials / total / protocol, 3)}


def _own_time(stats: dict, fragment: str) -> float:
    """Cumulative seconds of the outermost calls into files matching ``fragment`` (their callees included)."""
    total = 0.0
    for (file, _, _), (_, _, _, cumulative, callers) in stats.items():
        if fragment in file and not any(fragment in caller[0] for caller in callers):
            total += cumulative
    return total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", type=int, default=2000)
    args = parser.parse_args()
    spec = JobSpec(objects=OBJECT, grasps_per_object=args.candidates, stages=("ingest", "extract", "dedup"))
    mesh = load_object(resolve_source(OBJECT)[0], spec).mesh
    result = {"command": f"python -m benchmarks.speed.bench_candidates --candidates {args.candidates}",
              "date": str(date.today()), "machine": f"{platform.machine()}, {os.cpu_count()} cores",
              "object": OBJECT, "target_candidates_per_s_per_core": TARGET,
              "generation": generation(spec, mesh, args.candidates), "extract_profile": profile(spec, mesh),
              "label_profile": label_profile(), "targets": {"label_setup_share": 0.2, "label_rate_over_protocol": 0.8}}
    (HERE / "results" / "candidates.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
