"""VHACD and CoACD side by side (issue 50): seconds per object and label agreement with a converged reference.

    python -m benchmarks.experiments.decomposition   # writes benchmarks/results/decomposition.json, then
                                                     # docs/decomposition.md

Per object (robosuite's household meshes and procedural random_urdfs): the same candidates (the job's antipodal
sampler), labelled by the label protocol (4 trials, every one must hold) on each decomposition's pieces. The
reference is CoACD at a fine concavity threshold (0.02); every decomposition meets the same perturbation draws per
grasp, and the reference's labels drawn again with other draws give the label's own repeatability (how far apart
two executions of the same grasp on the same geometry already are). Times are each decomposition's wall seconds in a
fresh cache, one thread.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.experiments.household import household_objects
from benchmarks.pages.committed import RESULTS
from onepiece_dist.core.mesh import enclosed_volume, sample_surface
from onepiece_dist.core.sampling import object_rng, sample_candidates
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.sim.collision import convex_pieces
from onepiece_dist.sim.trials import LabelNoise, run_trials
from onepiece_dist.sim.world import process_world
from onepiece_dist.specs.job import JobSpec

GRASPS = 48
SETTINGS = {"vhacd": ("vhacd", {}), "coacd": ("coacd", {}), "vhacd_fine": ("vhacd", {"resolution": 1_000_000}),
            "reference": ("coacd", {"threshold": 0.02})}
REFERENCE_SEED, REPEAT_SEED = 7, 8


def labels(spec: JobSpec, mesh, pieces, poses: np.ndarray, seed: int) -> np.ndarray:
    """(n,) bool: held by every label trial on ``pieces``. Each grasp draws its perturbations from its own
    generator ([seed, i]), so two decompositions meet the same draws and differ only by their geometry."""
    world = process_world(spec.gripper)
    world.load_object(pieces, enclosed_volume(mesh), spec.sim.density)
    noise, held = LabelNoise.from_spec(spec.sim), np.zeros(len(poses), dtype=bool)
    for i in range(len(poses)):
        batch = run_trials(world, poses[i:i + 1], label=True, noise=noise, rng=np.random.default_rng([seed, i]))
        held[i] = batch.outcome[0] == 0 and batch.success[0]
    return held


def measure_object(spec: JobSpec, ref) -> dict:
    mesh = load_object(ref, spec).mesh
    rng = object_rng(mesh.content_id, spec.seed)
    points, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
    poses = sample_candidates(mesh, points, normals, GRASPS, spec.gripper, spec.sampler, rng).poses
    row: dict = {"name": ref.name, "faces": int(len(mesh.faces)), "grasps": int(len(poses)), "methods": {}}
    found = {}
    for name, (method, options) in SETTINGS.items():
        with tempfile.TemporaryDirectory() as cache:
            start = time.perf_counter()
            pieces = convex_pieces(mesh, Path(cache), method, **options)
            seconds = time.perf_counter() - start
        found[name] = labels(spec, mesh, pieces, poses, REFERENCE_SEED)
        row["methods"][name] = {"seconds": round(seconds, 2), "pieces": len(pieces),
                                "positive_rate": float(found[name].mean())}
    repeat = labels(spec, mesh, pieces, poses, REPEAT_SEED)  # the reference's pieces (the last setting)
    for name in SETTINGS:
        row["methods"][name]["agreement"] = float(np.mean(found[name] == found["reference"]))
    row["label_repeatability"] = float(np.mean(repeat == found["reference"]))
    return row


def summary(rows: list[dict]) -> dict:
    grasps = np.array([r["grasps"] for r in rows], dtype=float)
    out = {}
    for name in SETTINGS:
        agree = np.array([r["methods"][name]["agreement"] for r in rows])
        out[name] = {"seconds_median": float(np.median([r["methods"][name]["seconds"] for r in rows])),
                     "seconds_total": float(sum(r["methods"][name]["seconds"] for r in rows)),
                     "agreement": float(np.sum(agree * grasps) / grasps.sum())}
    repeat = np.array([r["label_repeatability"] for r in rows])
    out["label_repeatability"] = float(np.sum(repeat * grasps) / grasps.sum())
    return out


def main() -> None:
    spec = JobSpec(units="m", sim={"label": True, "label_trials": 4, "success": "every_trial"})
    refs = resolve_source(f"{household_objects()}+pybullet:random_urdfs[0:4]")
    rows = []
    for ref in refs:
        rows.append(measure_object(spec, ref))
        print(json.dumps(rows[-1]), flush=True)
    result = {"grasps_per_object": GRASPS, "settings": {k: {"method": m, **o} for k, (m, o) in SETTINGS.items()},
              "protocol": "label trials 4, every_trial; same candidates for every decomposition",
              "objects": rows, "summary": summary(rows)}
    (RESULTS / "decomposition.json").write_text(json.dumps(result, indent=1) + "\n")
    from benchmarks.pages.report import write_page

    write_page("docs/decomposition.md")


if __name__ == "__main__":
    main()
