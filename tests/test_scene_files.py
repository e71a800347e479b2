"""`onepiece scene` (picks.scene_files): a depth camera's own files of objects on a simulated table, read back by
`onepiece grasp` as the pick benchmark sees the same view."""

from __future__ import annotations

import json
import shlex

import numpy as np
import pytest
from typer.testing import CliRunner

from onepiece_dist.cli.main import app


@pytest.mark.sim
def test_a_scenes_depth_png_read_back_in_the_base_frame_is_the_benchmarks_cloud_of_that_view(tmp_path):
    from onepiece_dist.core.frames import transform_points
    from onepiece_dist.objects import load_object, resolve_source
    from onepiece_dist.picks.clutter import WORKSPACE
    from onepiece_dist.picks.scene_files import OPENCV, write_scene
    from onepiece_dist.plan.robot import read_observation
    from onepiece_dist.sim.pick import TABLE_BOX
    from onepiece_dist.sim.views import back_project, camera_at, depth_images
    from onepiece_dist.specs.job import JobSpec
    from onepiece_dist.specs.plan import CameraSpec

    written = write_scene("primitives[3:4]", tmp_path, seed=3)
    f = written.folder
    observation, pose = read_observation(f / "depth.png", str(f / "intrinsics.json"),
                                         camera_pose=f / "camera_pose.json")
    seen = transform_points(observation.points, pose)
    # the benchmark's points of the same objects and camera (sim.views.back_project, before sim.pick.observe_scene
    # crops them), pixel for pixel: both read the pixels row by row
    scene, camera = json.loads((f / "scene.json").read_text()), CameraSpec()
    mesh = load_object(resolve_source("primitives[3:4]")[0], JobSpec()).mesh
    resting = np.array(scene["objects"][0]["resting_pose"])
    eye, centre = np.array(json.loads((f / "camera_pose.json").read_text())["matrix"])[:3, 3], np.array(written.centre)
    view = camera_at(eye, centre, camera.image_size, camera.fov_deg)
    assert np.allclose(view.pose @ OPENCV, pose)
    truth = back_project(depth_images(transform_points(mesh.vertices, resting), mesh.faces, [view], TABLE_BOX)[0],
                         view)
    assert len(seen) == len(truth)
    assert np.abs(seen - truth).max() < 0.001  # the half millimetre the PNG keeps, along a slanted ray
    near = np.all(np.abs(seen[:, :2] - centre[:2]) < WORKSPACE, axis=1) & (seen[:, 2] > -0.005)
    files = ("depth.png", "intrinsics.json", "camera_pose.json", "scene.json")
    before = [(f / name).read_bytes() for name in files]
    write_scene("primitives[3:4]", tmp_path, seed=3)
    assert [(f / name).read_bytes() for name in files] == before  # the same objects and seed, the same bytes
    table = seen[near & (np.abs(seen[:, 2]) < 0.005)]
    assert len(table) > 0.5 * near.sum() and np.median(np.abs(table[:, 2])) < 0.0005  # the table top is z = 0


@pytest.mark.sim
def test_onepiece_grasp_plans_on_the_files_onepiece_scene_writes_grasps_above_its_table(tmp_path):
    runner = CliRunner()
    made = runner.invoke(app, ["scene", "primitives[3:6]", "--count", "2", "--out", str(tmp_path / "my scene")])
    assert made.exit_code == 0, made.output
    command = json.loads((tmp_path / "my scene" / "scene.json").read_text())["grasp"]
    assert command in made.output
    args = shlex.split(command)[1:]
    planned = runner.invoke(app, [*args, "--out", str(tmp_path / "g"), "--json"])
    assert planned.exit_code == 0, planned.output
    plan = json.loads(planned.stdout)
    assert plan["grasps"] and all(g["pose"][2][3] > 0.0 for g in plan["grasps"])  # every palm above the table
    assert len(plan["objects"]) == 2  # both objects seen, told apart
    too_many = runner.invoke(app, ["scene", "primitives[3:4]", "--count", "2", "--out", str(tmp_path / "x")])
    assert too_many.exit_code == 2 and "1 object(s) found, 2 asked for" in too_many.output


@pytest.mark.sim
def test_a_scenes_depth_noise_moves_each_seen_pixel_by_about_its_deviation_and_no_empty_one(tmp_path):
    from onepiece_dist.picks.scene_files import write_scene
    from onepiece_dist.plan.camera_files import read_depth
    from onepiece_dist.specs.plan import CameraSpec

    write_scene("primitives[3:4]", tmp_path / "clean", seed=1)
    write_scene("primitives[3:4]", tmp_path / "noisy", seed=1, camera=CameraSpec(depth_noise=0.002))
    clean, noisy = read_depth(tmp_path / "clean" / "depth.png"), read_depth(tmp_path / "noisy" / "depth.png")
    seen = clean > 0
    assert np.array_equal(seen, noisy > 0)  # the same pixels saw something
    assert 0.0018 < float(np.std(noisy[seen] - clean[seen])) < 0.0023  # 2 mm, and the PNG's millimetre steps


@pytest.mark.sim
def test_a_scenes_flying_pixels_stand_between_an_edges_two_depths_and_nowhere_else(tmp_path):
    from onepiece_dist.picks.scene_files import write_scene
    from onepiece_dist.plan.camera_files import read_depth
    from onepiece_dist.specs.plan import CameraSpec

    write_scene("primitives[3:4]", tmp_path / "clean", seed=1)
    write_scene("primitives[3:4]", tmp_path / "flying", seed=1, camera=CameraSpec(flying_pixels=1.0))
    clean, flying = read_depth(tmp_path / "clean" / "depth.png"), read_depth(tmp_path / "flying" / "depth.png")
    padded = np.pad(clean, 1)
    around = np.stack([padded[:-2, 1:-1], padded[2:, 1:-1], padded[1:-1, :-2], padded[1:-1, 2:]])
    seen_around = np.where(around > 0, around, clean)
    edge = np.max(np.abs(seen_around - clean), axis=0) > 0.019  # a neighbour 2 cm nearer or further (in mm)
    moved = np.abs(flying - clean) > 0.0015  # beyond the PNG's millimetre steps
    assert moved.sum() > 50 and not np.any(moved & ~edge)
    low, high = np.minimum(clean, seen_around.min(axis=0)), np.maximum(clean, seen_around.max(axis=0))
    assert np.all((flying[moved] >= low[moved] - 0.001) & (flying[moved] <= high[moved] + 0.001))
