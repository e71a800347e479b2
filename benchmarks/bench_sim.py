"""Trial throughput on pybullet:random_urdfs objects with the default gripper, one core.

Run: .venv/bin/python benchmarks/bench_sim.py  (writes benchmarks/results/sim.json)
Measures the extract protocol (early stall exit), the label protocol (extract + lift + shake), and a plain
fixed-step baseline (close then lift, 240 steps of 1/240 s, no early exit) on the same candidates. Then label
fidelity: the same candidates labelled with a converged reference (1/480 s steps, 100 solver iterations, cone
friction) and with cheaper or other settings; each row says how many success labels agree with the reference,
beside the noise floor (the default settings with every candidate moved by 10 micrometres).
"""

from __future__ import annotations

import json
import os
import platform
import sys
import tempfile
import time
from dataclasses import asdict
from datetime import date
from pathlib import Path

import numpy as np
import pybullet as pb

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from onepiece_dist.core.mesh import enclosed_volume, sample_surface  # noqa: E402
from onepiece_dist.core.sampling import object_rng, sample_candidates  # noqa: E402
from onepiece_dist.objects import load_object, resolve_source  # noqa: E402
from onepiece_dist.sim.collision import convex_pieces  # noqa: E402
from onepiece_dist.sim.trials import place, run_trials  # noqa: E402
from onepiece_dist.sim.world import PhysicsSettings, SimWorld, process_world  # noqa: E402
from onepiece_dist.spec import JobSpec  # noqa: E402

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


def main() -> dict:
    spec = JobSpec(grasps_per_object=GRASPS)
    world = process_world(spec.gripper)
    timings = {"extract": 0.0, "label": 0.0, "baseline": 0.0}
    trials = held = closing_steps = 0
    loaded = []
    with tempfile.TemporaryDirectory() as cache:
        for ref in resolve_source(OBJECTS):
            try:
                mesh = load_object(ref, spec).mesh
            except ValueError:
                continue
            rng = object_rng(mesh.content_id, spec.seed)
            points, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
            poses = sample_candidates(mesh, points, normals, GRASPS, spec.gripper, spec.sampler, rng).poses
            loaded.append((convex_pieces(mesh, Path(cache), "vhacd"), enclosed_volume(mesh), poses))
            world.load_object(*loaded[-1][:2], spec.sim.density)
            for name, run in (("extract", lambda p: run_trials(world, p)),
                              ("label", lambda p: run_trials(world, p, label=True)),
                              ("baseline", lambda p: baseline(world, p))):
                start = time.perf_counter()
                batch = run(poses)
                timings[name] += time.perf_counter() - start
                if name == "extract":
                    held += int(np.sum(batch.outcome == 0))
                    closing_steps += int(np.sum(batch.steps))
            trials += len(poses)
    rates = {f"{k}_trials_per_s_per_core": round(trials / v, 1) for k, v in timings.items()}
    out = {"benchmark": "sim", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores (one used)", "objects": OBJECTS,
           "trials": trials, "extract_held_fraction": round(held / max(trials, 1), 3),
           "extract_closing_steps_per_trial": round(closing_steps / max(trials, 1), 1), **rates,
           "extract_speedup_vs_baseline": round(timings["baseline"] / timings["extract"], 2),
           "label_speedup_vs_baseline": round(timings["baseline"] / timings["label"], 2),
           "physics": asdict(PhysicsSettings()),
           "physical_defaults": {"pad_friction": spec.gripper.friction, "closing_force_n": spec.gripper.closing_force,
                                 "density_kg_m3": spec.sim.density},
           "targets": {"extract_trials_per_s_per_core": 300, "label_trials_per_s_per_core": 150},
           "label_fidelity": fidelity(spec, loaded),
           "command": "python benchmarks/bench_sim.py"}
    (Path(__file__).parent / "results" / "sim.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


REFERENCE = PhysicsSettings(time_step=1 / 480, solver_iterations=100, cone_friction=True)
VARIANTS = {"default": PhysicsSettings(), "cone friction": PhysicsSettings(cone_friction=True),
            "30 solver iterations": PhysicsSettings(solver_iterations=30),
            "20 solver iterations": PhysicsSettings(solver_iterations=20),
            "1/120 s step": PhysicsSettings(time_step=1 / 120)}
JITTER = 1e-5  # m: the noise floor moves every candidate by this much


def label_all(spec: JobSpec, loaded: list, physics: PhysicsSettings,
              jitter: float = 0.0) -> tuple[np.ndarray, float]:
    """Success labels (n,) bool of every candidate (False when not held) and label trials/s/core."""
    world = SimWorld(spec.gripper, physics)
    rng = np.random.default_rng(7)
    seconds, success = 0.0, []
    for pieces, volume, poses in loaded:
        world.load_object(pieces, volume, spec.sim.density)
        moved = poses.copy()
        moved[:, :3, 3] += rng.normal(0, jitter, (len(poses), 3)) if jitter else 0.0
        start = time.perf_counter()
        batch = run_trials(world, moved, label=True)
        seconds += time.perf_counter() - start
        success.append(np.where(batch.outcome == 0, batch.success, False))
    world.close()
    success = np.concatenate(success)
    return success, len(success) / seconds


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


if __name__ == "__main__":
    main()
