"""A depth camera's noise taken out of a view before planning (core.cloud.denoise, PlanSpec.denoise): measured under
the support plane, the table widened to it and the object's fuzz smoothed; an exact view planned as it came."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.denoise import (
    CUT,
    CUT_MEDIAN,
    HALF_NORMAL_MAD,
    NOISE_FLOOR,
    denoised,
    plane_noise,
    smoothed,
    widened,
)
from onepiece_dist.core.cloud.support_check import PLANE_TOLERANCE, support_plane


def _table_and_box(noise: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(points, is_table): a 30 cm table at z = 0 seen from above and a 6 x 4 x 5 cm box's top and two sides on it,
    each point moved along z by Gaussian ``noise`` (m)."""
    rng = np.random.default_rng(seed)
    table = np.column_stack([rng.uniform(-0.15, 0.15, (12000, 2)), np.zeros(12000)])
    table = table[~((np.abs(table[:, 0]) < 0.03) & (np.abs(table[:, 1]) < 0.02))]
    top = np.column_stack([rng.uniform(-0.03, 0.03, 1500), rng.uniform(-0.02, 0.02, 1500), np.full(1500, 0.05)])
    side = np.column_stack([np.full(800, 0.03), rng.uniform(-0.02, 0.02, 800), rng.uniform(0.0, 0.05, 800)])
    points = np.vstack([table, top, side])
    points[:, 2] += rng.normal(0.0, noise, len(points)) if noise else 0.0
    return points, np.arange(len(points)) < len(table)


def _plane(points: np.ndarray):
    return support_plane(points, np.random.default_rng(1), up=np.array([0.0, 0.0, 1.0]))


def test_the_noise_under_the_table_is_measured_and_an_exact_view_reads_as_exact():
    exact, _ = _table_and_box(0.0)
    assert plane_noise(exact, _plane(exact)) < NOISE_FLOOR
    for noise in (0.001, 0.002, 0.004):
        points, _ = _table_and_box(noise)
        assert 0.8 * noise < plane_noise(points, _plane(points)) < 1.2 * noise


def test_a_cloud_cut_short_under_the_table_still_measures_the_whole_noise():
    from scipy.special import erf, erfinv

    assert np.allclose(CUT_MEDIAN, np.sqrt(2) * erfinv(erf(CUT / np.sqrt(2)) / 2), atol=1e-6)
    assert abs(CUT_MEDIAN[-1] * HALF_NORMAL_MAD - 1) < 1e-5  # cut beyond the table, a half-normal's median
    for noise in (0.002, 0.004):
        points, _ = _table_and_box(noise, seed=3)
        cut = points[points[:, 2] > -0.005]  # a workspace crop 5 mm under the table
        assert 0.9 * noise < plane_noise(cut, _plane(cut)) < 1.1 * noise
    median_alone = HALF_NORMAL_MAD * np.median(-cut[cut[:, 2] < 0, 2])
    assert median_alone < 0.9 * noise  # at 4 mm the crop cuts the half-normal at 1.25 deviations


def test_a_noisy_table_is_taken_whole_and_the_objects_fuzz_is_smoothed_its_shape_kept():
    points, is_table = _table_and_box(0.002)
    plane = _plane(points)
    noise = plane_noise(points, plane)
    wide = widened(points, plane, noise, PLANE_TOLERANCE)
    assert plane.inliers[is_table].mean() < 0.96 and wide.inliers[is_table].mean() > 0.995  # no specks left
    objects = points[~wide.inliers]
    top = (objects[:, 2] > 0.04) & (np.abs(objects[:, 0]) < 0.025) & (np.abs(objects[:, 1]) < 0.015)
    flat = smoothed(objects)
    assert np.std(flat[top, 2]) < 0.5 * np.std(objects[top, 2])  # the box's top face twice as flat
    assert abs(np.mean(flat[top, 2]) - 0.05) < 0.001  # and where it was


def test_the_noises_tail_beyond_the_tables_band_leaves_no_speck_of_an_object_and_nothing_under_the_table():
    points, _ = _table_and_box(0.002)
    plane = _plane(points)
    wide = widened(points, plane, plane_noise(points, plane), PLANE_TOLERANCE)

    def off_the_box(cloud: np.ndarray) -> int:
        return int(np.sum((np.abs(cloud[:, 0]) > 0.035) | (np.abs(cloud[:, 1]) > 0.025)))

    assert off_the_box(points[~wide.inliers]) > 20 and np.sum(wide.distance(points[~wide.inliers]) < 0) > 5
    kept, objects = denoised(points, plane, PLANE_TOLERANCE)
    assert off_the_box(objects) == 0 and objects[:, 2].min() > 0.0
    assert len(objects) > 0.98 * np.sum(~wide.inliers & (np.abs(points[:, 0]) < 0.035) & (np.abs(points[:, 1]) < 0.025))
    assert np.array_equal(kept.inliers, wide.inliers)


def test_an_exact_view_is_planned_the_same_with_denoise_and_without():
    from onepiece_dist.plan.observation import Observation
    from onepiece_dist.plan.planner import propose
    from onepiece_dist.plan.scorer import CropRecord
    from onepiece_dist.specs.job import GripperSpec, VoxelSpec
    from onepiece_dist.specs.plan import PlanSpec

    record = CropRecord(GripperSpec(), VoxelSpec(), 128, "pointnet_context")
    exact = Observation(_table_and_box(0.0)[0], np.array([0.3, 0.0, 0.6]), "exact")
    made = [propose(exact, record, PlanSpec(candidates=100, denoise=d), np.random.default_rng(0))
            for d in ("auto", "none")]
    assert len(made[0].poses) > 0 and np.array_equal(made[0].poses, made[1].poses)
    assert np.array_equal(made[0].object_points, made[1].object_points)


def test_onepiece_grasp_takes_the_noise_out_unless_told_not_to(tmp_path):
    import json

    from typer.testing import CliRunner

    from onepiece_dist.cli.main import app
    from tests.test_robot_io import CX, CY, FX, FY, depth_millimetres

    depth = depth_millimetres().astype(np.float64) / 1000
    np.save(tmp_path / "depth.npy", depth + np.random.default_rng(0).normal(0.0, 0.003, depth.shape))
    plans = []
    for flag in ("--denoise", "--no-denoise"):
        result = CliRunner().invoke(app, ["grasp", str(tmp_path / "depth.npy"), "--intrinsics", f"{FX},{FY},{CX},{CY}",
                                          "--check", "0", "--out", str(tmp_path / flag), "--json", flag])
        assert result.exit_code == 0, result.output
        plans.append(json.loads(result.stdout))
    assert plans[0]["grasps"] and plans[1]["grasps"]
    assert 0.0025 < plans[0]["support_plane"]["depth_noise"] < 0.0035  # 3 mm drawn, the camera looking down
    assert plans[1]["support_plane"]["depth_noise"] == 0
    assert [g["pose"] for g in plans[0]["grasps"]] != [g["pose"] for g in plans[1]["grasps"]]


def test_a_small_object_on_a_noisy_table_keeps_the_table_as_its_support_plane(tmp_path):
    """A 4 x 3 cm box at 60 cm is a few hundred of a view's points, a noisy table's tails thousands on each side of
    it: whichever of them a seeded fit leaves more of, the table holds the box, and the noise is read from it."""
    from onepiece_dist.plan.camera_files import Intrinsics, depth_observation
    from tests.test_robot_io import CX, CY, FX, FY, depth_millimetres

    depth = depth_millimetres().astype(np.float64) / 1000
    for noise in (0.003, 0.004):
        np.save(tmp_path / "depth.npy", depth + np.random.default_rng(0).normal(0.0, noise, depth.shape))
        seen = depth_observation(tmp_path / "depth.npy", Intrinsics(FX, FY, CX, CY))
        towards = seen.viewpoint - seen.points.mean(axis=0)
        for seed in range(8):
            plane = support_plane(seen.points, np.random.default_rng(seed), towards=towards)
            assert abs(plane.offset - 0.6) < 0.001  # the table, 60 cm along the camera's axis
            assert 0.9 * noise < plane_noise(seen.points, plane) < 1.15 * noise
