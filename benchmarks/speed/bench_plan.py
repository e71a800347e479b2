"""Planning latency per view on one CPU core (issue 49): 500 candidates sampled on a depth camera's cloud, their
collision checks, crops and PointNet scores, ranked; against a baseline run beside it that crops and scores the
same candidates one at a time (what a per-grasp planner loop costs).

    .venv/bin/python -m benchmarks.speed.bench_plan

Scenes: each object of SCENES settled on the pick benchmark's table and seen from a seeded camera (0.5-0.8 m, 30-70
degrees), as `onepiece pick` sees it; and one of them made a 2-million-point cloud (each point repeated with 0.5 mm
jitter), thinned by the planner first. The network is the shipped one (onepiece_dist/plan/networks/; PointNet
width 32 with the grasp's context, 128 points per crop), or that architecture with fresh weights where the package
has none: latency does not depend on what it learnt; the Franka hand (the panda preset: HANDS) plans the same views
with the network shipped for it. Several of the objects side by side (FILE_SCENES) are planned as `onepiece grasp`
plans a depth camera's own files: `onepiece scene`'s PNG, intrinsics and camera pose read back in the robot's
frame. Torch and BLAS on one thread. Targets: at most 0.3 s per view on one core; at most 1 s for the
2-million-point cloud; at most 30 ms of scoring on a GPU (measured only where one is present). Results:
benchmarks/results/plan.json, rendered into docs/picks.md by benchmarks/pages/report.py.
"""

from __future__ import annotations

import json
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
SCENES = "primitives[3:6]+pybullet:named[0:3]"
CANDIDATES, REPEATS = 500, 3
HANDS = ("panda",)  # gripper presets planned on the same views beside the default job's gripper
FILE_SCENES = ((2, 0), (2, 1), (2, 2), (4, 0), (4, 1), (4, 2))  # (objects on the table, seed): `onepiece scene`
TARGETS = {"cpu_seconds_per_view": 0.3, "gpu_score_seconds": 0.03, "dense_seconds": 1.0}


def scenes():
    """(name, Observation) per object: settled on the table, seen by one seeded camera."""
    from onepiece_dist.core.mesh import enclosed_volume
    from onepiece_dist.objects import load_object, resolve_source
    from onepiece_dist.plan.observation import Observation
    from onepiece_dist.sim.pick import PickWorld, observe, pick_camera
    from onepiece_dist.specs.job import GripperSpec, JobSpec

    world, out = PickWorld(GripperSpec()), []
    for k, ref in enumerate(resolve_source(SCENES)):
        mesh = load_object(ref, JobSpec()).mesh
        world.load_object([mesh.vertices], enclosed_volume(mesh), 400.0)
        rng = np.random.default_rng([k, 49])
        resting = world.settle(rng, mesh.vertices)
        camera = pick_camera(resting[:3, 3], rng, (0.5, 0.8), (30.0, 70.0), 320, 45.0).camera
        cloud = observe(mesh.vertices, mesh.faces, resting, camera, rng)
        if len(cloud) < 50:
            continue
        out.append((ref.name, Observation(cloud, camera.pose[:3, 3], ref.name)))
    world.close()
    return out


def scorer(folder: Path, device: str = "cpu"):
    import torch

    from onepiece_dist.learn.models import PointNetWithContext
    from onepiece_dist.learn.train import crop_record
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import NETWORK
    from onepiece_dist.specs.job import JobSpec

    if NETWORK.is_file():
        return GraspScorer(NETWORK, device=device)
    path = folder / "pointnet_context.pt"
    torch.manual_seed(0)
    torch.save({"model": "pointnet_context", "state_dict": PointNetWithContext().state_dict(),
                "crop": {**crop_record(JobSpec()), "points_per_grasp": 128}}, path)
    return GraspScorer(path, device=device)


def dense(observation, count: int = 2_000_000):
    """``observation`` made a ``count``-point cloud: its points repeated with 0.5 mm of seeded jitter."""
    from onepiece_dist.plan.observation import Observation

    rng = np.random.default_rng(7)
    points = observation.points[rng.integers(0, len(observation.points), count)]
    return Observation(points + rng.normal(0, 0.0005, points.shape), observation.viewpoint,
                       f"{observation.source} x {count // 1_000_000}M points")


def one_at_a_time(proposals, net, rng) -> float:
    """The baseline: each candidate cropped and scored on its own. Returns seconds."""
    from dataclasses import replace

    from onepiece_dist.plan.scorer import cut_crops

    start = time.perf_counter()
    for k, pose in enumerate(proposals.poses):
        crops = cut_crops(proposals.object_points, pose[None], net.record, rng)
        net.score(replace(crops, context=proposals.crops.context[k:k + 1]))
    return time.perf_counter() - start


def measure(folder: Path) -> dict:
    import torch

    from onepiece_dist.plan.planner import plan_grasps, propose
    from onepiece_dist.specs.plan import PlanSpec

    torch.set_num_threads(1)
    net, spec, rows = scorer(folder), PlanSpec(candidates=CANDIDATES, check_first=0), []
    seen = scenes()
    for name, observation in [*seen, (f"{seen[0][0]} (2M points)", dense(seen[0][1]))]:
        plans = [plan_grasps(observation, net, spec) for _ in range(REPEATS)]
        best = min(plans, key=lambda p: p.seconds["total"])
        proposals = propose(observation, net.record, spec, np.random.default_rng(0))
        baseline = one_at_a_time(proposals, net, np.random.default_rng(0))
        rows.append({"object": name, "points": len(observation.points), **best.counts.to_json(),
                     "seconds": {k: round(v, 4) for k, v in best.seconds.items()},
                     "baseline_seconds": round(baseline + best.seconds["sample"], 4),
                     **(check_seconds(observation, net, spec) if len(observation.points) < 1_000_000 else {})})
    return {"rows": rows, "gpu": gpu_scoring(folder), "hands": [hand_seconds(seen, hand) for hand in HANDS],
            "files": file_scenes(folder, net)}


def file_scenes(folder: Path, net) -> dict:
    """Several of SCENES' objects side by side on the table, written as a depth camera's own files (`onepiece
    scene`: FILE_SCENES) and read back as `onepiece grasp` reads them (plan.robot.read_observation, the scene's
    workspace): each view's planning (the least of REPEATS) without and with the planner's default check."""
    from onepiece_dist.picks.scene_files import write_scene
    from onepiece_dist.plan.planner import plan_grasps
    from onepiece_dist.plan.robot import read_observation
    from onepiece_dist.specs.plan import PlanSpec

    spec, rows = PlanSpec(candidates=CANDIDATES, check_first=0), []
    for count, seed in FILE_SCENES:
        files = write_scene(SCENES, folder / f"scene_{count}_{seed}", count, seed)
        observation, _ = read_observation(files.folder / "depth.png", str(files.folder / "intrinsics.json"),
                                          camera_pose=files.folder / "camera_pose.json", workspace=files.workspace())
        best = min((plan_grasps(observation, net, spec) for _ in range(REPEATS)), key=lambda p: p.seconds["total"])
        rows.append({"objects": list(files.objects), "seed": seed, "points": len(observation.points),
                     "found": len(best.objects), **best.counts.to_json(),
                     "seconds": {k: round(v, 4) for k, v in best.seconds.items()},
                     **check_seconds(observation, net, spec)})
    return {"rows": rows, "median_seconds_per_view": float(np.median([r["seconds"]["total"] for r in rows])),
            "median_checked_seconds": float(np.median([r["seconds"]["total"] + r["check_seconds"] for r in rows]))}


def hand_seconds(seen, hand: str) -> dict:
    """The same views planned for the gripper preset ``hand`` with the network shipped for it (its own collision
    test and, in the check, its own hand in the pick world): the seconds of each without and with the planner's
    default check, and their medians."""
    from onepiece_dist.gripper.presets import gripper_fields
    from onepiece_dist.plan.planner import plan_grasps
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.job import GripperSpec
    from onepiece_dist.specs.plan import PlanSpec

    gripper = GripperSpec.model_validate(gripper_fields(hand))
    net, spec, rows = GraspScorer(shipped_network(gripper), gripper, "cpu"), PlanSpec(candidates=CANDIDATES,
                                                                                     check_first=0), []
    for name, observation in seen:
        best = min((plan_grasps(observation, net, spec) for _ in range(REPEATS)), key=lambda p: p.seconds["total"])
        rows.append({"object": name, "total_seconds": round(best.seconds["total"], 4),
                     **check_seconds(observation, net, spec)})
    return {"hand": hand, "gripper": gripper.name, "rows": rows,
            "median_seconds_per_view": float(np.median([r["total_seconds"] for r in rows])),
            "median_checked_seconds": float(np.median([r["total_seconds"] + r["check_seconds"] for r in rows]))}


def check_seconds(observation, net, spec) -> dict:
    """The planner's default check (PlanSpec.check_first, picks.shape_check) on ``observation``: its seconds (the
    least of REPEATS, the check's pick world made before) and whether the cloud gave it a support plane to stand
    its shape on."""
    from onepiece_dist.picks.shape_check import view_check
    from onepiece_dist.plan.planner import plan_grasps
    from onepiece_dist.specs.plan import PlanSpec

    checked = spec.model_copy(update={"check_first": PlanSpec().check_first})
    plans = [plan_grasps(observation, net, checked, view_check(checked)) for _ in range(REPEATS)]
    return {"check_first": checked.check_first, "check_draws": checked.check_draws,
            "check_seconds": round(min(p.seconds["check"] for p in plans), 4),
            "check_plane": plans[0].plane is not None}


def gpu_scoring(folder: Path) -> dict | None:
    """Scoring 500 crops on a CUDA GPU (median of 20 after warm-up), where one is present."""
    import torch

    if not torch.cuda.is_available():
        return None
    from onepiece_dist.plan.scorer import Crops

    net = scorer(folder, "cuda")
    points = net.record.points_per_grasp
    crops = Crops(np.zeros((CANDIDATES, 4), np.uint8), np.full(CANDIDATES, points),
                  np.random.default_rng(0).normal(0, 0.01, (CANDIDATES, points, 3)).astype(np.float16),
                  np.zeros((CANDIDATES, 6), np.float32))
    times = []
    for _ in range(25):
        torch.cuda.synchronize()
        start = time.perf_counter()
        net.score(crops, 512)
        torch.cuda.synchronize()
        times.append(time.perf_counter() - start)
    return {"device": torch.cuda.get_device_name(), "score_seconds": float(np.median(times[5:]))}


def main() -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        measured = measure(Path(folder))
    totals = [r["seconds"]["total"] for r in measured["rows"] if r["points"] < 1_000_000]
    millions = [r for r in measured["rows"] if r["points"] >= 1_000_000]
    result = {"command": ".venv/bin/python -m benchmarks.speed.bench_plan", "date": date.today().isoformat(),
              "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}, one thread",
              "candidates": CANDIDATES, "targets": TARGETS, **measured,
              "median_seconds_per_view": float(np.median(totals)),
              "dense_seconds": millions[0]["seconds"]["total"] if millions else None,
              "median_baseline_seconds": float(np.median([r["baseline_seconds"] for r in measured["rows"]])),
              "median_checked_seconds": float(np.median([r["seconds"]["total"] + r["check_seconds"]
                                                         for r in measured["rows"] if "check_seconds" in r]))}
    out = HERE / "results" / "plan.json"
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(out)


if __name__ == "__main__":
    main()
