"""Trial throughput on pybullet:random_urdfs objects with the default gripper, one core.

Run: .venv/bin/python -m benchmarks.speed.bench_sim  (writes benchmarks/results/sim.json)
Measures the extract protocol (early stall exit), the label protocol (extract + lift + shake), and a plain
fixed-step baseline (close then lift, 240 steps of 1/240 s, no early exit) on the same candidates. Then label
fidelity: the same candidates labelled with a converged reference (1/480 s steps, 100 solver iterations, cone
friction) and with cheaper or other settings; each row says how many success labels agree with the reference,
beside the noise floor (the default settings with every candidate moved by 10 micrometres). And extract
fidelity: the same for the extract protocol, whose result is a settled pose and its code (the dedup key): how
often cheaper settings hold the same candidates and give the same code. Protocol rates are the median of REPEATS
timings (their range is recorded); the fidelity rows are timed once.
"""

from __future__ import annotations

import json
import os
import platform
import tempfile
import time
from dataclasses import asdict
from datetime import date
from pathlib import Path

import numpy as np
import pybullet as pb

from onepiece_dist.core.mesh import enclosed_volume, sample_surface
from onepiece_dist.core.sampling import object_rng, sample_candidates
from onepiece_dist.core.voxel import crop_codes
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.sim.collision import convex_pieces
from onepiece_dist.sim.trials import place, run_trials
from onepiece_dist.sim.world import PhysicsSettings, SimWorld, process_world
from onepiece_dist.specs.job import JobSpec

OBJECTS = os.environ.get("BENCH_SIM_OBJECTS", "pybullet:random_urdfs[0:8]")
GRASPS = int(os.environ.get("BENCH_SIM_GRASPS", 64))


def baseline(world, poses: np.ndarray) -> None:
    """Fixed-step loop: close for 120 steps and lift for 120 steps, whatever happens."""
    c, g = world.client, world.gripper
    for pose in poses:
        place(world, pose)
        pb.setGravity(0, 0, 0, physicsClientId=c)
        pb.setJointMotorControlArray(g, [0, 1], pb.VELOCITY_CONTROL, targetVelocities=[0.1, 0.1],
                                     forces=[world.spec.closing_force] * 2, physicsClientId=c)
        for step in range(240):
            if step == 120:
                pb.setGravity(0, 0, -9.81, physicsClientId=c)
            pb.stepSimulation(physicsClientId=c)


REPEATS = 3  # each protocol is timed this many times over all objects; the median counts (runs here vary by ~30%)


def load_all(spec: JobSpec, cache: Path, refs: list | None = None, grasps: int = GRASPS) -> list:
    """(convex pieces, enclosed volume, candidate poses (n, 4, 4), surface points (m, 3)) of every object of
    ``refs`` (default: OBJECTS), ``grasps`` candidates each."""
    loaded = []
    for ref in resolve_source(OBJECTS) if refs is None else refs:
        try:
            mesh = load_object(ref, spec).mesh
        except ValueError:
            continue
        rng = object_rng(mesh.content_id, spec.seed)
        points, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
        poses = sample_candidates(mesh, points, normals, grasps, spec.gripper, spec.sampler, rng).poses
        loaded.append((convex_pieces(mesh, cache, "vhacd"), enclosed_volume(mesh), poses, points))
    return loaded


PROTOCOLS = ("extract", "label", "baseline")


def time_protocols(spec: JobSpec, loaded: list, repeats: int = REPEATS,
                   names: tuple[str, ...] = PROTOCOLS) -> tuple[dict[str, list[float]], np.ndarray]:
    """Seconds of each protocol of ``names`` (extract among them) over all objects, ``repeats`` times; and the
    extract trials' outcomes and closing steps (2, n) of the first repeat."""
    world = process_world(spec.gripper)
    seconds, first = {name: [] for name in names}, None
    protocols = {"extract": lambda p: run_trials(world, p), "label": lambda p: run_trials(world, p, label=True),
                 "baseline": lambda p: baseline(world, p)}
    for _ in range(repeats):
        spent, extracted = dict.fromkeys(seconds, 0.0), []
        for pieces, volume, poses, _ in loaded:
            world.load_object(pieces, volume, spec.sim.density)
            for name in names:
                start = time.perf_counter()
                batch = protocols[name](poses)
                spent[name] += time.perf_counter() - start
                if name == "extract":
                    extracted.append(np.stack([batch.outcome, batch.steps]))
        for name in seconds:
            seconds[name].append(spent[name])
        first = np.concatenate(extracted, axis=1) if first is None else first
    return seconds, first


def protocol_rates(seconds: dict[str, list[float]], trials: int) -> dict[str, float]:
    """Trials/s/core of each protocol: ``trials`` over the median of its timings."""
    return {f"{name}_trials_per_s_per_core": round(trials / float(np.median(values)), 1)
            for name, values in seconds.items()}


def main() -> dict:
    spec = JobSpec(grasps_per_object=GRASPS)
    with tempfile.TemporaryDirectory() as cache:
        loaded = load_all(spec, Path(cache))
        seconds, extracted = time_protocols(spec, loaded)
    trials = extracted.shape[1]
    timings = {name: float(np.median(values)) for name, values in seconds.items()}
    rates = protocol_rates(seconds, trials)
    spread = {k: [round(trials / max(v), 1), round(trials / min(v), 1)] for k, v in seconds.items()}
    held, closing_steps = int(np.sum(extracted[0] == 0)), int(np.sum(extracted[1]))
    out = {"benchmark": "sim", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores (one used)", "objects": OBJECTS,
           "trials": trials, "extract_held_fraction": round(held / max(trials, 1), 3),
           "extract_closing_steps_per_trial": round(closing_steps / max(trials, 1), 1), **rates,
           "repeats": REPEATS, "rate_range_over_repeats": spread,
           "extract_speedup_vs_baseline": round(timings["baseline"] / timings["extract"], 2),
           "label_speedup_vs_baseline": round(timings["baseline"] / timings["label"], 2),
           "physics": asdict(PhysicsSettings()),
           "physical_defaults": {"pad_friction": spec.gripper.friction, "closing_force_n": spec.gripper.closing_force,
                                 "density_kg_m3": spec.sim.density},
           "targets": {"extract_trials_per_s_per_core": 300, "label_trials_per_s_per_core": 150},
           "label_fidelity": fidelity(spec, loaded), "extract_fidelity": extract_fidelity(spec, loaded),
           "command": "python -m benchmarks.speed.bench_sim"}
    (Path(__file__).resolve().parents[1] / "results" / "sim.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


REFERENCE = PhysicsSettings(time_step=1 / 480, solver_iterations=100, cone_friction=True)
VARIANTS = {"default": PhysicsSettings(), "cone friction": PhysicsSettings(cone_friction=True),
            "30 solver iterations": PhysicsSettings(solver_iterations=30),
            "20 solver iterations": PhysicsSettings(solver_iterations=20),
            "1/120 s step": PhysicsSettings(time_step=1 / 120)}
JITTER = 1e-5  # m: the noise floor moves every candidate by this much


def trials_all(spec: JobSpec, loaded: list, physics: PhysicsSettings, jitter: float = 0.0,
               label: bool = False) -> tuple[list, float]:
    """Every object's TrialBatch under ``physics`` (candidates moved by ``jitter`` m, seeded), paired with the
    object's surface points, and trials/s/core (the trials alone)."""
    world = SimWorld(spec.gripper, physics)
    rng = np.random.default_rng(7)
    seconds, batches = 0.0, []
    for pieces, volume, poses, points in loaded:
        world.load_object(pieces, volume, spec.sim.density)
        moved = poses.copy()
        moved[:, :3, 3] += rng.normal(0, jitter, (len(poses), 3)) if jitter else 0.0
        start = time.perf_counter()
        batches.append((run_trials(world, moved, label=label), points))
        seconds += time.perf_counter() - start
    world.close()
    return batches, sum(len(batch.outcome) for batch, _ in batches) / seconds


def label_all(spec: JobSpec, loaded: list, physics: PhysicsSettings,
              jitter: float = 0.0) -> tuple[np.ndarray, float]:
    """Success labels (n,) bool of every candidate (False when not held) and label trials/s/core."""
    batches, rate = trials_all(spec, loaded, physics, jitter, label=True)
    return np.concatenate([np.where(b.outcome == 0, b.success, False) for b, _ in batches]), rate


def fidelity(spec: JobSpec, loaded: list) -> dict:
    """Labels under each setting against the converged reference, and the noise floor of the default."""
    reference, reference_rate = label_all(spec, loaded, REFERENCE)
    rows, labels = [], {}
    for name, physics in VARIANTS.items():
        labels[name], rate = label_all(spec, loaded, physics)
        rows.append({"settings": name, **asdict(physics), "label_trials_per_s_per_core": round(rate, 1),
                     "success_rate": round(float(labels[name].mean()), 3),
                     "agreement_with_reference": round(float(np.mean(labels[name] == reference)), 3)})
    moved, _ = label_all(spec, loaded, VARIANTS["default"], JITTER)
    floor = {"jitter_m": JITTER, "agreement_with_default": round(float(np.mean(moved == labels["default"])), 3),
             "agreement_with_reference": round(float(np.mean(moved == reference)), 3)}
    return {"reference": {**asdict(REFERENCE), "label_trials_per_s_per_core": round(reference_rate, 1),
                          "success_rate": round(float(reference.mean()), 3)}, "noise_floor": floor, "rows": rows}


def extract_all(spec: JobSpec, loaded: list, physics: PhysicsSettings,
                jitter: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """The extract protocol on every candidate: held (n,) bool, the code of the settled crop (n, B) uint8 (as
    extraction keys it) and extract trials/s/core (the trials alone)."""
    batches, rate = trials_all(spec, loaded, physics, jitter)
    grid = spec.voxel.grid_shape(spec.gripper)
    held = np.concatenate([b.outcome == 0 for b, _ in batches])
    codes = np.concatenate([crop_codes(points, b.settled_pose, grid, spec.voxel.resolution)[0]
                            for b, points in batches])
    return held, codes, rate


def extract_fidelity(spec: JobSpec, loaded: list) -> dict:
    """Cheaper extraction settings against the default: same held outcome, and among candidates held under both,
    the same code (the dedup key); beside the default's own noise floor (candidates moved by JITTER)."""
    held, codes, _ = extract_all(spec, loaded, VARIANTS["default"])

    def compare(other_held: np.ndarray, other_codes: np.ndarray) -> dict:
        both = held & other_held
        same = np.all(codes[both] == other_codes[both], axis=1)
        return {"held_agreement": round(float(np.mean(held == other_held)), 3),
                "code_agreement": round(float(same.mean()), 3) if both.any() else None}

    rows = []
    for name, physics in VARIANTS.items():
        other_held, other_codes, rate = extract_all(spec, loaded, physics)
        rows.append({"settings": name, **asdict(physics), "extract_trials_per_s_per_core": round(rate, 1),
                     "held_fraction": round(float(other_held.mean()), 3), **compare(other_held, other_codes)})
    moved_held, moved_codes, _ = extract_all(spec, loaded, VARIANTS["default"], JITTER)
    return {"rows": rows, "noise_floor": {"jitter_m": JITTER, **compare(moved_held, moved_codes)}}


if __name__ == "__main__":
    main()
