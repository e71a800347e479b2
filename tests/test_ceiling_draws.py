"""The label drawn again (issue 51): each draw a new execution, its nominal trial perturbed too, so the draws of a
grasp on the margin differ while the stored label's nominal trial repeats itself; without noise every draw is the
nominal one. Real pybullet on a procedural object."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.mesh import enclosed_volume, sample_surface
from onepiece_dist.core.sampling import object_rng, sample_candidates
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.stats.ceiling import label_ceiling

pytestmark = pytest.mark.sim


def test_a_repeat_is_a_new_execution_and_without_noise_the_nominal_one(tmp_path):
    from onepiece_dist.sim.collision import convex_pieces
    from onepiece_dist.sim.trials import LabelNoise, label_draws, run_trials
    from onepiece_dist.sim.world import SimWorld

    spec = JobSpec(sim={"label_trials": 1, "success": "nominal", "pose_noise": 0.006, "friction_noise": 0.3})
    mesh = load_object(resolve_source("pybullet:random_urdfs[3:4]")[0], spec).mesh
    rng = object_rng(mesh.content_id, 0)
    points, normals = sample_surface(mesh, 4000, rng)
    poses = sample_candidates(mesh, points, normals, 24, spec.gripper, spec.sampler, rng).poses
    world = SimWorld(spec.gripper)
    world.load_object(convex_pieces(mesh, tmp_path, "vhacd"), enclosed_volume(mesh), spec.sim.density)
    noise = LabelNoise.from_spec(spec.sim)
    nominal = [run_trials(world, poses, label=True, noise=noise).success for _ in range(2)]
    assert np.array_equal(*nominal)  # the stored label's nominal trial: the same execution every time
    draws = label_draws(world, poses, [np.random.default_rng([5, i]) for i in range(len(poses))], noise, 6)
    mixed = (draws.any(axis=1) & ~draws.all(axis=1)).sum()
    assert mixed >= 2, draws.astype(int)  # grasps on the margin: their executions differ
    still = LabelNoise(1, 0.0, 0.0, 0.0)
    repeats = label_draws(world, poses, [np.random.default_rng([5, i]) for i in range(len(poses))], still, 3)
    assert np.array_equal(repeats, np.repeat(nominal[0][:, None], 3, axis=1))
    world.close()
    ceiling = label_ceiling(draws)
    assert ceiling.positive_rate <= ceiling.ceiling_ap <= 1 and ceiling.agreement < 1
