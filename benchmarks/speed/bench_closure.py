"""Force-closure and robust-epsilon scores per second on one core (core.closure), against a per-grasp reference
scorer run side by side on the same grasps.

    .venv/bin/python -m benchmarks.speed.bench_closure

Objects: the named pybullet objects and random_urdfs below, antipodal candidates on each. Ours: every grasp's pad
contacts (core.raycast), the smallest friction level of graspnetAPI's sweep and the Ferrari-Canny epsilon,
vectorized per object; the robust epsilon over Dex-Net's 25 perturbations, every perturbation's contacts found in
one call. The reference: the same contacts scored one grasp at a time by the published definitions (dex-net's
two-contact force-closure test per friction level; the wrench hull per grasp with qhull's defaults), and the
robust epsilon one grasp and one perturbation at a time, as a plain transcription would. Also the time of one
wrench hull alone: 25 of them per grasp bound any robust epsilon that computes each sample's hull. Targets
(issue 40): >= 2,000 force-closure scores/s/core, >= 200 robust epsilon/s/core. Results:
benchmarks/results/closure.json, rendered into docs/trials.md by benchmarks/pages/report.py.
"""

from __future__ import annotations

import json
import math
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
OBJECTS = "pybullet:named[0:4]+pybullet:random_urdfs[0:4]"
CANDIDATES, ROBUST_GRASPS, REFERENCE_ROBUST_GRASPS = 500, 40, 10
PAD = {"max_opening": 0.08, "finger_length": 0.04, "finger_height": 0.02}
TARGETS = {"force_closure_per_s": 2000, "robust_epsilon_per_s": 200}


def meshes_and_poses():
    from onepiece_dist.core.mesh import sample_surface
    from onepiece_dist.core.sampling import object_rng, sample_candidates
    from onepiece_dist.objects import load_object
    from onepiece_dist.objects.sources import resolve_source
    from onepiece_dist.specs.job import GripperSpec, JobSpec, SamplerSpec

    out = []
    for ref in resolve_source(OBJECTS):
        mesh = load_object(ref, JobSpec()).mesh
        rng = object_rng(mesh.content_id, 0)
        points, normals = sample_surface(mesh, 3000, rng)
        poses = sample_candidates(mesh, points, normals, CANDIDATES, GripperSpec(), SamplerSpec(), rng).poses
        out.append((mesh, poses))
    return out


def reference_level(c1, c2, n1, n2, levels) -> float:
    """dex-net's force-closure test at each level, smallest first, one grasp at a time."""
    line = (c2 - c1) / np.linalg.norm(c2 - c1)
    angles = (math.acos(min(abs(float(np.dot(n1, line))), 1.0)), math.acos(min(abs(float(np.dot(n2, line))), 1.0)))
    return next((mu for mu in sorted(levels) if max(angles) <= math.atan(mu)), math.inf)


def timed(function):
    start = time.perf_counter()
    value = function()
    return value, time.perf_counter() - start


def measure(mesh, poses) -> dict:
    """Seconds of ours and of the reference on one object's grasps, and how many levels agree."""
    from onepiece_dist.core import closure

    contacts, contact_s = timed(lambda: closure.pad_contacts(mesh.vertices, mesh.faces, poses, **PAD))
    levels, level_s = timed(lambda: closure.smallest_level(closure.required_friction(contacts)))
    _, eps_s = timed(lambda: closure.ferrari_canny(contacts, 0.5))
    two = contacts.state == 0
    reference, ref_s = timed(lambda: [reference_level(*contacts.points[k], *contacts.normals[k],
                                                      closure.GRASPNET_LEVELS) if two[k] else math.inf
                                      for k in range(len(poses))])
    one_at_a_time = [closure.Contacts(contacts.points[k:k + 1], contacts.normals[k:k + 1], contacts.state[k:k + 1],
                                      contacts.approach[k:k + 1]) for k in range(len(poses))]
    _, ref_eps_s = timed(lambda: [reference_epsilon(single, 0.5) for single in one_at_a_time])
    wrenches = closure.contact_wrenches(contacts, 0.5)[two]
    _, hull_s = timed(lambda: [closure.hull_offsets(w) for w in wrenches])
    robust = poses[:ROBUST_GRASPS]
    _, robust_s = timed(lambda: closure.robust_scores(mesh.vertices, mesh.faces, robust, np.random.default_rng(0),
                                                      **PAD))
    _, ref_robust_s = timed(lambda: reference_robust(mesh, robust[:REFERENCE_ROBUST_GRASPS]))
    return {"grasps": len(poses), "robust_grasps": len(robust), "ours_s": contact_s + level_s, "eps_s": eps_s,
            "ref_s": ref_s + contact_seconds_per_grasp(mesh, poses[:50]) * len(poses), "ref_eps_s": ref_eps_s,
            "hulls": int(two.sum()), "hull_s": hull_s, "robust_s": robust_s,
            "ref_robust_grasps": len(robust[:REFERENCE_ROBUST_GRASPS]), "ref_robust_s": ref_robust_s,
            "agree": int(np.sum(levels == np.array(reference)))}


def reference_epsilon(contacts, mu: float) -> float:
    """One grasp's epsilon as a plain transcription computes it: its wrenches, then qhull with its defaults."""
    from scipy.spatial import ConvexHull, QhullError

    from onepiece_dist.core import closure

    if contacts.state[0] != 0:
        return 0.0
    try:
        return max(-float(ConvexHull(closure.contact_wrenches(contacts, mu)[0]).equations[:, -1].max()), 0.0)
    except QhullError:
        return 0.0


def reference_robust(mesh, poses) -> list[float]:
    """Dex-Net's robust epsilon one grasp and one perturbation at a time: perturb, find the contacts, score."""
    from onepiece_dist.core import closure
    from onepiece_dist.core.frames import perturb_pose

    rng, out = np.random.default_rng(1), []
    for pose in poses:
        scores = []
        for _ in range(25):
            moved = perturb_pose(pose, rng, math.hypot(0.005, 0.01), 0.01)
            friction = max(0.5 * (1 + 0.1 * rng.normal()), 1e-3)
            scores.append(reference_epsilon(closure.pad_contacts(mesh.vertices, mesh.faces, moved[None], **PAD),
                                            friction))
        out.append(float(np.mean(scores)))
    return out


def main() -> dict:
    rows = [measure(mesh, poses) for mesh, poses in meshes_and_poses()]
    total = {key: sum(row[key] for row in rows) for key in rows[0]}
    out = {"benchmark": "closure", "date": date.today().isoformat(), "machine": platform.machine(),
           "objects": OBJECTS, "grasps": total["grasps"], "robust_grasps": total["robust_grasps"],
           "robust_samples": 25, "force_closure_per_s": total["grasps"] / total["ours_s"],
           "reference_force_closure_per_s": total["grasps"] / total["ref_s"],
           "epsilon_per_s": total["grasps"] / total["eps_s"],
           "reference_epsilon_per_s": total["grasps"] / total["ref_eps_s"],
           "robust_epsilon_per_s": total["robust_grasps"] / total["robust_s"],
           "reference_robust_grasps": total["ref_robust_grasps"],
           "reference_robust_epsilon_per_s": total["ref_robust_grasps"] / total["ref_robust_s"],
           "hull_ms": 1000 * total["hull_s"] / total["hulls"],
           "robust_ceiling_per_s": total["hulls"] / total["hull_s"] / 25,
           "levels_equal_to_reference": total["agree"] / total["grasps"],
           "targets": TARGETS, "command": "python -m benchmarks.speed.bench_closure"}
    (HERE / "results" / "closure.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


def contact_seconds_per_grasp(mesh, poses) -> float:
    """The reference finds each grasp's contacts on its own: the same ray casts, one grasp per call."""
    from onepiece_dist.core import closure

    _, seconds = timed(lambda: [closure.pad_contacts(mesh.vertices, mesh.faces, pose[None], **PAD) for pose in poses])
    return seconds / len(poses)


if __name__ == "__main__":
    main()
