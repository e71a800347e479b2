"""Planning grasps on what a depth camera sees (issue 49): the planner's crops are the training crops, candidates
that meet the cloud or the table are dropped, the Panda convention turns back into ours, bad input is refused."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from onepiece_dist.core.cloud.grasps import (
    above_plane,
    fit_support_plane,
    sample_cloud_grasps,
    suppress_near,
    voxel_downsample,
)
from onepiece_dist.core.hand_frames import from_panda
from onepiece_dist.core.mesh import box_mesh, cylinder_mesh, resample_crops
from onepiece_dist.core.sampling import collides
from onepiece_dist.errors import CheckpointRejected, CloudRejected
from onepiece_dist.plan import GraspScorer, Observation, depth_to_cloud, plan_grasps, read_cloud
from onepiece_dist.plan.scorer import cut_crops
from onepiece_dist.specs.job import GripperSpec, JobSpec
from onepiece_dist.specs.plan import PlanSpec

pytestmark = pytest.mark.sim


def seen_cloud(mesh, eye=(0.35, 0.1, 0.3)) -> Observation:
    """What one camera at ``eye`` sees of ``mesh`` (pybullet's TinyRenderer, back-projected)."""
    from onepiece_dist.sim.views import camera_at, views_from

    camera = camera_at(np.array(eye), np.zeros(3), 192, 45)
    return Observation(views_from(mesh.vertices, mesh.faces, [camera]).cloud(0).astype(np.float64),
                       camera.pose[:3, 3], mesh.name)


def save_checkpoint(path, spec: JobSpec | None = None, seed: int = 0):
    """A PointNet checkpoint as the train stage writes it (weights and the crop record), weights from ``seed``."""
    from onepiece_dist.learn.models import PointNetGrasp
    from onepiece_dist.learn.train import crop_record

    torch.manual_seed(seed)
    record = crop_record(spec or JobSpec())
    torch.save({"model": "pointnet", "state_dict": PointNetGrasp().state_dict(), "crop": record}, path)
    return path


def test_a_planned_grasps_crop_is_the_training_crop_of_the_same_pose_and_view(tmp_path):
    """A job with partial-view crops stores, per grasp, the points and code cut from the view nearest its approach;
    the planner's crop of that view's cloud at that pose is the same code and the same points."""
    from onepiece_dist.job.stages.extract import crop_codes_from, extract_arrays
    from onepiece_dist.plan.scorer import CropRecord
    from onepiece_dist.sim.views import camera_for_grasps

    spec = JobSpec(grasps_per_object=12, sim={"physics": False, "collision": "hull", "points_per_grasp": 64},
                   views={"count": 4, "crop": "partial", "image_size": 96})
    mesh = box_mesh((0.04, 0.03, 0.06))
    with pytest.warns(UserWarning, match="convex hull"):
        arrays, _ = extract_arrays(spec, mesh, tmp_path)
    record = CropRecord(spec.gripper, spec.voxel, spec.sim.points_per_grasp, "pointnet")
    views = camera_for_grasps(arrays["view_camera"], arrays["pose"])
    for i, (pose, view) in enumerate(zip(arrays["pose"], views, strict=True)):
        cloud = arrays["view_points"][arrays["view_of_point"] == view]
        crops = cut_crops(cloud, pose[None], record, np.random.default_rng(i))
        assert np.array_equal(crops.codes[0], arrays["code"][i])
        stored, planned = {tuple(p) for p in arrays["points"][i]}, {tuple(p) for p in crops.points[0]}
        _, _, inside = crop_codes_from([cloud], np.zeros(1, np.int64), pose[None], spec.grid_shape(),
                                       spec.voxel.resolution, keep_points=True)
        every_inside = {tuple(p) for p in inside[0].astype(np.float16)}
        assert stored <= every_inside and planned <= every_inside  # the same region, frame and points
    again = cut_crops(cloud, arrays["pose"][-1:], record, np.random.default_rng(7))
    expected = resample_crops(inside, spec.sim.points_per_grasp, np.random.default_rng(7))
    assert np.array_equal(again.points, expected)  # and the same resampling for the same draws


def test_candidates_that_meet_the_cloud_or_the_table_are_dropped():
    gripper = GripperSpec()
    seen = seen_cloud(cylinder_mesh(0.02, 0.08))
    cloud = seen.points
    wall = np.stack(np.meshgrid(np.linspace(-0.06, 0.06, 40), [0.035], np.linspace(-0.05, 0.05, 40)),
                    axis=-1).reshape(-1, 3)  # a wall of observed points beside the object
    free = sample_cloud_grasps(cloud, 400, gripper, np.random.default_rng(0), seen.viewpoint)
    walled = sample_cloud_grasps(cloud, 400, gripper, np.random.default_rng(0), seen.viewpoint, obstacles=wall)
    assert len(free.poses) > 50 and 0 < len(walled.poses) < len(free.poses)
    assert not collides(np.vstack([cloud, wall]), walled.poses, gripper).any()
    assert collides(wall, free.poses, gripper).any()  # the wall would have been hit without the check
    table = fit_support_plane(np.vstack([cloud, _floor(-0.04)]), np.random.default_rng(1), up=np.array([0, 0, 1.0]))
    assert table is not None and abs(table.normal @ [0, 0, 1]) > 0.999 and abs(table.offset - 0.04) < 1e-3
    on_table = sample_cloud_grasps(cloud, 400, gripper, np.random.default_rng(0), seen.viewpoint, plane=table)
    assert on_table.below_plane > 0 and above_plane(on_table.poses, gripper, table).all()
    assert not above_plane(free.poses, gripper, table).all()


def _floor(z: float) -> np.ndarray:
    grid = np.linspace(-0.15, 0.15, 80)
    return np.stack(np.meshgrid(grid, grid, [z]), axis=-1).reshape(-1, 3)


def test_a_grasp_in_the_panda_convention_turned_back_is_our_pose(tmp_path):
    checkpoint = save_checkpoint(tmp_path / "net.pt")
    plan = plan_grasps(seen_cloud(cylinder_mesh(0.02, 0.08)), GraspScorer(checkpoint, device="cpu"),
                       PlanSpec(support_plane="none", candidates=200, top_k=5, check_first=0))
    assert len(plan.grasps) == 5
    finger = GripperSpec().finger_length
    for grasp in plan.grasps:
        np.testing.assert_allclose(from_panda(grasp.panda_pose, finger), grasp.pose, atol=1e-12)
        np.testing.assert_allclose(grasp.panda_pose[:3, 2], grasp.pose[:3, 0], atol=1e-12)  # Panda z = our u
        np.testing.assert_allclose(grasp.panda_pose[:3, 0], grasp.pose[:3, 1], atol=1e-12)  # Panda x = our v
    written = plan.to_json()["grasps"][0]
    np.testing.assert_allclose(from_panda(np.array(written["panda_pose"]), finger), written["pose"], atol=1e-8)
    assert [g.score for g in plan.grasps] == sorted((g.score for g in plan.grasps), reverse=True)


def test_non_maximum_suppression_keeps_one_of_two_near_poses():
    pose = np.eye(4)
    near = pose.copy()
    near[:3, 3] = [0.003, 0.0, 0.0]
    turned = np.array([[1.0, 0, 0, 0], [0, -1.0, 0, 0], [0, 0, -1.0, 0], [0, 0, 0, 1]])  # 180 deg about u: the same
    far = pose.copy()
    far[:3, 3] = [0.0, 0.05, 0.0]
    kept = suppress_near(np.stack([pose, near, turned, far]), np.array([0.9, 0.8, 0.7, 0.6]), GripperSpec())
    assert kept.tolist() == [0, 3]


@pytest.mark.parametrize("points, reason", [
    (np.zeros((0, 3)), "empty"),
    (np.full((200, 3), np.nan), "NaN"),
    (np.random.default_rng(0).normal(0, 40.0, (200, 3)), "millimetres"),
    (np.random.default_rng(0).normal(0, 0.02, (20, 3)), "at least 50"),
    (np.zeros((200, 2)), "shape"),
])
def test_bad_clouds_are_refused_with_reasons(tmp_path, points, reason):
    path = tmp_path / "cloud.npy"
    np.save(path, points)
    with pytest.raises(CloudRejected, match=reason) as refused:
        read_cloud(path)
    assert str(path) in str(refused.value)


def test_a_pickled_cloud_and_an_unknown_format_are_refused(tmp_path):
    pickled = tmp_path / "cloud.npy"
    np.save(pickled, np.array([{"x": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(CloudRejected, match="plain numeric"):
        read_cloud(pickled)
    with pytest.raises(CloudRejected, match="unknown cloud format"):
        read_cloud(tmp_path / "cloud.xyz")


def test_a_depth_image_drops_missing_pixels_and_a_checkpoint_for_another_gripper_is_refused(tmp_path):
    depth = np.full((40, 40), 0.6)
    depth[:5] = 0.0
    depth[5:8] = np.nan
    seen = depth_to_cloud(depth, 50.0, 50.0, 20.0, 20.0)
    assert len(seen.points) == 32 * 40 and np.allclose(seen.points[:, 2], 0.6)
    checkpoint = save_checkpoint(tmp_path / "net.pt")
    wider = GripperSpec(max_opening=0.085, closing_width=0.08)
    with pytest.raises(CheckpointRejected, match="another gripper .*max_opening"):
        GraspScorer(checkpoint, wider, device="cpu")
    torch.save({"model": "pointnet", "state_dict": {}}, tmp_path / "old.pt")
    with pytest.raises(CheckpointRejected, match="--gripper"):
        GraspScorer(tmp_path / "old.pt", device="cpu")


def test_onepiece_grasp_writes_json_and_a_picture_and_refuses_bad_input(tmp_path):
    from onepiece_dist.cli.main import app

    checkpoint = save_checkpoint(tmp_path / "net.pt")
    seen = seen_cloud(box_mesh((0.04, 0.03, 0.06)))
    cloud = tmp_path / "cloud.npy"
    np.save(cloud, np.vstack([seen.points, _floor(-0.03)]))
    out = tmp_path / "grasps"
    runner = CliRunner()
    ran = runner.invoke(app, ["grasp", str(cloud), "--checkpoint", str(checkpoint), "--out", str(out),
                              "--viewpoint", ",".join(map(str, seen.viewpoint)), "--top", "4"])
    assert ran.exit_code == 0, ran.output
    written = json.loads((out / "grasps.json").read_text())
    assert len(written["grasps"]) == 4 and 80 * 80 <= written["support_plane"]["points"] < 80 * 80 + 100
    assert (out / "grasps.png").read_bytes()[:4] == b"\x89PNG"
    poses = np.array([g["pose"] for g in written["grasps"]])
    assert not collides(np.vstack([seen.points, _floor(-0.03)]), poses, GripperSpec()).any()
    plain = runner.invoke(app, ["grasp", str(cloud), "--checkpoint", str(checkpoint), "--out", str(tmp_path / "plain"),
                                "--viewpoint", ",".join(map(str, seen.viewpoint)), "--no-top-down"])
    assert plain.exit_code == 0, plain.output
    sampled = json.loads((tmp_path / "plain" / "grasps.json").read_text())["counts"]["sampled"]
    assert written["counts"]["sampled"] == sampled + 3  # the top-down grasps join by default
    np.save(cloud, seen.points * 1000)  # millimetres
    refused = runner.invoke(app, ["grasp", str(cloud), "--checkpoint", str(checkpoint), "--out", str(out)])
    assert refused.exit_code == 2 and "scale by 0.001" in refused.output


def test_the_evaluation_judges_by_the_robust_rule_and_says_when_it_cannot_separate():
    from onepiece_dist.job.stages.evaluate import evaluation_spec, protocol_of, verdict

    heldout = evaluation_spec(JobSpec(evaluate={"label_trials": 6}))
    assert (heldout.sim.label, heldout.sim.label_trials, heldout.sim.success) == (True, 6, "every_trial")
    assert protocol_of(heldout) == "6 label trials per candidate, every one must hold"
    easy, hard, fair = verdict(0.95, 1.0, 0.95), verdict(0.04, 0.0, 0.04), verdict(0.5, 0.8, 0.5)
    assert easy[0] is False and "cannot separate a network from a guess" in easy[1] and "95%" in easy[1]
    assert hard[0] is False and "fail" in hard[1]
    assert fair == (True, "50% of the held-out candidates succeed: top-1 0.80 against random 0.50")


def test_a_job_sampling_on_views_trains_on_the_planners_crops(tmp_path):
    """views.sampling: view samples candidates as the planner samples a camera's cloud: each grasp is free of the
    view it was sampled on, and its stored code and points are that view's crop at its pose."""
    from onepiece_dist.job.stages.extract import extract_arrays
    from onepiece_dist.plan.scorer import CropRecord

    spec = JobSpec(grasps_per_object=16, sim={"physics": False, "collision": "hull", "points_per_grasp": 32},
                   views={"count": 3, "crop": "partial", "sampling": "view", "image_size": 160, "distance": 0.4})
    with pytest.warns(UserWarning, match="convex hull"):
        arrays, meta = extract_arrays(spec, cylinder_mesh(0.025, 0.09), tmp_path)
    assert 8 <= len(arrays["pose"]) <= 18 and meta["candidates_tried"] >= len(arrays["pose"])
    record = CropRecord(spec.gripper, spec.voxel, spec.sim.points_per_grasp, "pointnet")
    clouds = [arrays["view_points"][arrays["view_of_point"] == k].astype(np.float64) for k in range(3)]
    thinned = [cloud[voxel_downsample(cloud, PlanSpec().downsample)] for cloud in clouds]  # what sampling checks
    exact = 0
    for i, pose in enumerate(arrays["pose"].astype(np.float64)):  # stored in float32: boundary points may move
        differ = [int(np.bitwise_count(cut_crops(cloud, pose[None], record, np.random.default_rng(0)).codes[0]
                                       ^ arrays["code"][i]).sum())
                  for k, cloud in enumerate(clouds) if not collides(thinned[k], pose[None], spec.gripper)[0]]
        assert differ and min(differ) <= 2, f"grasp {i} is no view's crop"
        exact += min(differ) == 0
    assert exact >= len(arrays["pose"]) // 2
    with pytest.raises(ValueError, match="crop: partial"):
        JobSpec(views={"count": 2, "sampling": "view"})


def test_a_view_sampled_job_keeps_candidates_that_close_on_nothing():
    """The planner meets candidates whose fingers close on nothing; a view-sampled job keeps them (width 0, never
    a success), a mesh-sampled one drops them as before."""
    from onepiece_dist.core.frames import pose_from_axes
    from onepiece_dist.core.sampling import GraspCandidates
    from onepiece_dist.job.stages.extract import _simulate

    mesh = box_mesh((0.04, 0.03, 0.06))
    held = pose_from_axes(np.array([[-0.05, 0.0, 0.0]]), np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    beside = pose_from_axes(np.array([[-0.05, 0.0, 0.2]]), np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    cands = GraspCandidates(np.concatenate([held, beside]), np.full(2, 0.08), 2, 0)
    views = {"count": 2, "crop": "partial", "sampling": "view"}
    kept = {}
    for sampling, spec in (("view", JobSpec(views=views, sim={"label": True})), ("mesh", JobSpec(sim={"label": True}))):
        grasps, meta, ok = _simulate(spec, mesh, cands, [mesh.vertices])
        kept[sampling] = (ok.tolist(), grasps["width"].tolist(), grasps["success"].tolist(), meta["dropped_no_contact"])
    assert kept["view"][0] == [True, True] and kept["view"][1][1] == 0.0 and kept["view"][2][1] == 0
    assert kept["mesh"][0] == [True, False] and kept["view"][3] == kept["mesh"][3] == 1


def test_a_checkpoint_is_read_as_a_typed_record_and_bad_ones_are_refused_by_name(tmp_path):
    """Issue 57: learn.train.read_network gives the model's name, weights and crop record; a file that is no
    checkpoint, one without weights, and one of a model this package does not build are refused with the file's
    name and what is wrong, never a KeyError."""
    from onepiece_dist.learn.train import read_network

    saved = read_network(save_checkpoint(tmp_path / "net.pt"))
    assert saved.model == "pointnet" and saved.crop["points_per_grasp"] == JobSpec().sim.points_per_grasp
    assert saved.build().training is False
    (tmp_path / "text.pt").write_text("not a checkpoint")
    torch.save({"model": "pointnet"}, tmp_path / "bare.pt")
    torch.save({"model": "transformer", "state_dict": {}}, tmp_path / "other.pt")
    for name, why in (("text.pt", "not a readable checkpoint"), ("bare.pt", "no model and state_dict"),
                      ("other.pt", "'transformer' is not one this package builds")):
        with pytest.raises(CheckpointRejected, match=why) as refused:
            GraspScorer(tmp_path / name, device="cpu")
        assert name in str(refused.value)


def test_the_label_stage_cuts_its_crops_as_the_planner_does_canonical_codes_included():
    """One crop recipe (core.voxel.network_inputs): the label stage's stored codes and points of settled poses are
    the planner's crops of the same points and poses with the same draws, canonical codes included (the label
    stage stored uncanonical codes under a canonical voxel spec before)."""
    from onepiece_dist.core.mesh import sample_surface
    from onepiece_dist.core.sampling import sample_candidates
    from onepiece_dist.core.voxel import canonical_codes
    from onepiece_dist.job.stages.label_one_object import _collect
    from onepiece_dist.plan.scorer import CropRecord
    from onepiece_dist.sim.trials import TrialBatch

    spec = JobSpec(voxel={"canonical": True}, sim={"points_per_grasp": 32})
    mesh = box_mesh((0.05, 0.03, 0.07))
    points, normals = sample_surface(mesh, 3000, np.random.default_rng(0))
    poses = sample_candidates(mesh, points, normals, 24, spec.gripper, spec.sampler, np.random.default_rng(1)).poses
    n = len(poses)
    batch = TrialBatch(np.zeros(n, np.int8), poses, np.zeros(n), np.zeros(n), np.zeros(n, np.int64),
                       np.ones(n, bool), np.ones(n), np.zeros(n))
    rows = {name: [] for name in ("patch", "pose", "candidate_pose", "width", "shift", "quality", "slip",
                                  "success", "code", "candidate_code", "points")}
    _collect(rows, 0, np.eye(4), points, poses, batch, spec, np.random.default_rng(5))
    planned = cut_crops(points, poses, CropRecord(spec.gripper, spec.voxel, 32, "pointnet"),
                        np.random.default_rng(5))
    assert n >= 10 and (planned.counts > 0).all()
    assert np.array_equal(rows["code"][0], planned.codes) and np.array_equal(rows["points"][0], planned.points)
    assert np.array_equal(canonical_codes(rows["code"][0], spec.grid_shape()), rows["code"][0])
    assert np.array_equal(canonical_codes(rows["candidate_code"][0], spec.grid_shape()), rows["candidate_code"][0])
    raw = cut_crops(points, poses, CropRecord(spec.gripper, spec.voxel.model_copy(update={"canonical": False}), 32,
                                              "pointnet"), np.random.default_rng(5))
    assert not np.array_equal(raw.codes, planned.codes)  # the turn matters for some of these crops


def test_the_top_down_grasps_join_the_pool_by_default_and_the_rest_is_unchanged():
    from onepiece_dist.core.cloud.top_down import top_down_grasps
    from onepiece_dist.plan.planner import gravity, propose
    from onepiece_dist.plan.scorer import CropRecord

    seen = seen_cloud(box_mesh((0.03, 0.05, 0.02)), eye=(0.3, 0.1, 0.4))
    observation = Observation(np.vstack([seen.points, _floor(-0.0101)]), seen.viewpoint, "box on a floor")
    spec = JobSpec()
    record = CropRecord(spec.gripper, spec.voxel, spec.sim.points_per_grasp, "pointnet_context")
    plain = propose(observation, record, PlanSpec(top_down=False), np.random.default_rng(0))
    added = propose(observation, record, PlanSpec(), np.random.default_rng(0))  # kept by the pick trials
    assert plain.top_down == 0 and added.top_down == 3
    n = len(plain.poses)
    assert len(added.poses) == n + 3 and np.array_equal(added.poses[:n], plain.poses)
    expected = top_down_grasps(added.object_points, gravity(added.plane), record.gripper)
    assert np.allclose(added.poses[n:], expected)
    assert added.counts.candidates == plain.counts.candidates + 3 and added.counts.sampled == plain.counts.sampled + 3
    assert np.allclose(added.poses[n:, :3, 0] @ gravity(added.plane), 1)  # each approaches along gravity


def test_the_open_gripper_keeps_the_table_clearance_asked_for_from_the_spec_and_the_command(tmp_path):
    from onepiece_dist.cli.main import app
    from onepiece_dist.core.cloud.grasps import PLANE_CLEARANCE, SupportPlane
    from onepiece_dist.plan.planner import propose
    from onepiece_dist.plan.scorer import CropRecord

    seen = seen_cloud(box_mesh((0.04, 0.03, 0.06)))
    floor = SupportPlane(np.array([0.0, 0.0, 1.0]), 0.03, np.zeros(0, bool))  # z = -0.03, under the box
    observation = Observation(np.vstack([seen.points, _floor(-0.03)]), seen.viewpoint, "box on a floor")
    spec, gripper = JobSpec(), GripperSpec()
    record = CropRecord(spec.gripper, spec.voxel, spec.sim.points_per_grasp, "pointnet_context")
    low, high = (propose(observation, record, PlanSpec(table_clearance=gap, top_down=False),
                         np.random.default_rng(0)) for gap in (0.002, 0.012))
    assert above_plane(high.poses, gripper, floor, 0.012 - 1e-3).all() and len(high.poses) > 20
    assert above_plane(low.poses, gripper, floor, 0.002 - 1e-3).all()
    assert not above_plane(low.poses, gripper, floor, 0.012 - 1e-3).all()  # 2 mm lets hands go lower
    assert PlanSpec().table_clearance == PLANE_CLEARANCE  # the sampler's default is the planner's
    checkpoint, out = save_checkpoint(tmp_path / "net.pt"), tmp_path / "grasps"
    cloud = tmp_path / "cloud.npy"
    np.save(cloud, observation.points)
    ran = CliRunner().invoke(app, ["grasp", str(cloud), "--checkpoint", str(checkpoint), "--out", str(out),
                                   "--viewpoint", ",".join(map(str, seen.viewpoint)), "--table-clearance", "0.012",
                                   "--check", "0"])
    assert ran.exit_code == 0, ran.output
    poses = np.array([g["pose"] for g in json.loads((out / "grasps.json").read_text())["grasps"]])
    assert len(poses) and above_plane(poses, gripper, floor, 0.012 - 1e-3).all()


FIRST_PLAN = """
import sys
import numpy as np
from onepiece_dist.plan import GraspScorer, Observation, plan_grasps
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PlanSpec
from tests.test_objects_apart import APART
from tests.test_plan import _floor
from tests.test_shape_check import seen_box

scorer = GraspScorer(shipped_network(), device="cpu")
loaded = {name for name in sys.modules if name.split(".")[0] == "scipy"}
cloud = np.vstack([seen_box(), seen_box() + APART, _floor(0.0)])  # two objects on a table: every step of a plan
plan = plan_grasps(Observation(cloud, np.array([0.3, -0.3, 0.4]), "two"), scorer, PlanSpec(check_first=0))
assert len(plan.objects) == 2 and len(plan.grasps) > 0
print(sorted({name for name in sys.modules if name.split(".")[0] == "scipy"} - loaded))
"""


def test_a_process_first_plan_imports_nothing_the_network_load_did_not():
    """A robot's first plan is planning, not a third of a second of scipy's imports (GraspScorer loads them)."""
    import subprocess
    import sys
    from pathlib import Path

    ran = subprocess.run([sys.executable, "-c", FIRST_PLAN], capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[1])
    assert ran.returncode == 0, ran.stderr[-2000:]
    assert ran.stdout.strip() == "[]"
