"""Out of the box for a robot (issue 56): a depth camera's own files, grasps in the robot's base frame, the table
told from a box's side, a view of the table alone refused, and the shipped network used without --checkpoint."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from onepiece_dist.cli.main import app
from onepiece_dist.core.cloud.support_check import support_plane
from onepiece_dist.core.frames import matrix_from_quat, quat_from_matrix
from tests.test_plan import save_checkpoint

FX, FY, CX, CY = 300.0, 300.0, 80.0, 60.0
# camera 0.6 m above the base's (0.4, 0.1, 0): looking straight down, image x along base x, image y along -y
CAMERA_POSE = np.array([[1.0, 0, 0, 0.4], [0, -1.0, 0, 0.1], [0, 0, -1.0, 0.6], [0, 0, 0, 1]])


def depth_millimetres() -> np.ndarray:
    """(120, 160) uint16 depth of a table 600 mm away with a 40 x 30 mm box on it, 50 mm tall."""
    depth = np.full((120, 160), 600, np.uint16)
    rows, cols = np.mgrid[0:120, 0:160]
    x, y = (cols - CX) * 0.55 / FX, (rows - CY) * 0.55 / FY
    depth[(np.abs(x) < 0.02) & (np.abs(y) < 0.015)] = 550
    return depth


def write_png(path, depth: np.ndarray) -> None:
    import open3d as o3d

    assert o3d.io.write_image(str(path), o3d.geometry.Image(np.ascontiguousarray(depth)))


def grasps(result) -> list[dict]:
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)["grasps"]


@pytest.mark.sim
def test_a_depth_png_with_intrinsics_json_and_a_camera_pose_gives_grasps_in_the_base_frame(tmp_path):
    checkpoint = save_checkpoint(tmp_path / "net.pt")
    depth = depth_millimetres()
    write_png(tmp_path / "depth.png", depth)
    np.save(tmp_path / "depth.npy", depth.astype(np.float64) / 1000)
    (tmp_path / "k.json").write_text(json.dumps({"K": [[FX, 0, CX], [0, FY, CY], [0, 0, 1]]}))
    quaternion = quat_from_matrix(CAMERA_POSE[:3, :3])
    (tmp_path / "pose.json").write_text(json.dumps({"position": CAMERA_POSE[:3, 3].tolist(),
                                                    "quaternion": quaternion}))
    runner = CliRunner()
    base = grasps(runner.invoke(app, ["grasp", str(tmp_path / "depth.png"), "--checkpoint", str(checkpoint),
                                      "--intrinsics", str(tmp_path / "k.json"), "--camera-pose",
                                      str(tmp_path / "pose.json"), "--out", str(tmp_path / "a"), "--json"]))
    camera = grasps(runner.invoke(app, ["grasp", str(tmp_path / "depth.npy"), "--checkpoint", str(checkpoint),
                                        "--intrinsics", f"{FX},{FY},{CX},{CY}", "--out", str(tmp_path / "b"),
                                        "--json"]))
    assert len(base) == len(camera) > 0
    for in_base, in_camera in zip(base, camera, strict=True):
        assert np.allclose(np.array(in_base["pose"]), CAMERA_POSE @ np.array(in_camera["pose"]), atol=1e-6)
        hand = np.array(in_base["panda_pose"])
        assert np.allclose(in_base["position"], hand[:3, 3])
        assert np.allclose(matrix_from_quat(in_base["quaternion"]), hand[:3, :3], atol=1e-6)
        assert np.allclose(np.array(in_base["pregrasp"]["position"]), hand[:3, 3] - 0.05 * hand[:3, 2])
    assert all(g["pose"][2][3] > 0.0 for g in base)  # in the base frame every palm is above the table (z = 0)


@pytest.mark.sim
def test_a_view_of_the_table_alone_exits_2_naming_the_plane(tmp_path):
    checkpoint = save_checkpoint(tmp_path / "net.pt")
    rng = np.random.default_rng(0)
    np.save(tmp_path / "table.npy", np.c_[rng.uniform(-0.2, 0.2, (3000, 2)), rng.normal(0, 0.0005, 3000)])
    result = CliRunner().invoke(app, ["grasp", str(tmp_path / "table.npy"), "--checkpoint", str(checkpoint),
                                      "--viewpoint", "0.3,0,0.5", "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "no object above the plane" in result.output and "normal" in result.output


def test_a_box_side_seen_head_on_is_not_taken_as_the_table():
    """A box's side (0.2 x 0.2 m) holds more points than the strip of table seen in front of it; with the base
    frame's up known, the table is the plane the box stands on."""
    side_y, side_z = np.meshgrid(np.linspace(-0.1, 0.1, 60), np.linspace(0.005, 0.2, 60))
    side = np.c_[np.zeros(side_y.size), side_y.ravel(), side_z.ravel()]
    table_x, table_y = np.meshgrid(np.linspace(0.005, 0.12, 30), np.linspace(-0.15, 0.15, 50))
    table = np.c_[table_x.ravel(), table_y.ravel(), np.zeros(table_x.size)]
    points = np.concatenate([side, table])
    assert len(side) > len(table)
    towards = np.array([0.5, 0.0, 0.3]) - points.mean(axis=0)
    dominant = support_plane(points, np.random.default_rng(0), towards=towards)
    assert dominant is not None and dominant.normal[0] > 0.99  # without a known up: the side (documented)
    plane = support_plane(points, np.random.default_rng(0), towards=towards, up=np.array([0, 0, 1.0]))
    assert plane is not None and plane.normal[2] > 0.99
    assert plane.inliers[len(side):].all() and not plane.inliers[:len(side)].any()


@pytest.mark.sim
def test_a_cloud_without_a_viewpoint_gets_an_estimated_camera_said_in_the_plan_or_is_refused(tmp_path):
    from onepiece_dist.core.frames import transform_points
    from onepiece_dist.errors import CloudRejected
    from onepiece_dist.plan import GraspScorer, Observation, depth_to_cloud, plan_grasps
    from onepiece_dist.specs.plan import PlanSpec

    scorer = GraspScorer(save_checkpoint(tmp_path / "net.pt"))
    seen = depth_to_cloud(depth_millimetres() / 1000, FX, FY, CX, CY)
    cloud = Observation(transform_points(seen.points, CAMERA_POSE), None, "cloud.ply")  # base frame, no camera
    plan = plan_grasps(cloud, scorer, PlanSpec(check_first=0))  # the planner alone has no simulator
    assert len(plan.notes) == 1 and "camera was estimated" in plan.notes[0] and plan.grasps
    estimated = np.array([float(v) for v in plan.notes[0].split("(")[1].split(")")[0].split(",")])
    assert estimated[2] > 0.3  # above the table (z = 0), on the side the box stands
    box_alone = Observation(cloud.points[cloud.points[:, 2] > 0.01], None, "box.ply")
    with pytest.raises(CloudRejected, match="--viewpoint"):
        plan_grasps(box_alone, scorer, PlanSpec(support_plane="none", check_first=0))


@pytest.mark.sim
def test_grasp_without_a_checkpoint_plans_with_the_shipped_network_and_says_which(tmp_path):
    import torch

    from onepiece_dist.plan.shipped import NETWORK, shipped_record

    assert NETWORK.is_file(), "the shipped network is package data: python -m benchmarks.experiments.ship_network"
    saved = torch.load(NETWORK, weights_only=True)  # plain values only
    assert saved["model"] == shipped_record()["model"] and saved["crop"]["points_per_grasp"] > 0
    np.save(tmp_path / "depth.npy", depth_millimetres().astype(np.float64) / 1000)
    result = CliRunner().invoke(app, ["grasp", str(tmp_path / "depth.npy"), "--intrinsics", f"{FX},{FY},{CX},{CY}",
                                      "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "planning with the shipped network pick_view.pt" in result.output and "household" in result.output
    plan = json.loads((tmp_path / "out" / "grasps.json").read_text())
    assert plan["checkpoint"] == "shipped" and plan["grasps"]


@pytest.mark.sim
def test_the_panda_preset_plans_with_the_franka_hands_shipped_network_and_others_are_told_what_ships(tmp_path):
    from onepiece_dist.gripper.presets import gripper_fields
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import NETWORK, shipped_network, shipped_record
    from onepiece_dist.specs.job import GripperSpec

    panda = GripperSpec.model_validate(gripper_fields("panda"))
    assert shipped_network(panda) != NETWORK and shipped_network() == shipped_network(GripperSpec()) == NETWORK
    assert GraspScorer(shipped_network(panda), panda, device="cpu").gripper == panda  # trained for this hand
    assert shipped_record(panda)["gripper"] == "franka_panda" and shipped_record(panda)["labels"] > 0
    np.save(tmp_path / "depth.npy", depth_millimetres().astype(np.float64) / 1000)
    run = ["grasp", str(tmp_path / "depth.npy"), "--intrinsics", f"{FX},{FY},{CX},{CY}"]
    (tmp_path / "my_hand.yaml").write_text("name: my_hand\nmax_opening: 0.1\nclosing_width: 0.1\n")
    example = Path(__file__).resolve().parents[1] / "examples" / "grippers" / "panda.yaml"  # the README's
    result = CliRunner().invoke(app, [*run, "--gripper", str(example), "--out", str(tmp_path / "p")])
    assert result.exit_code == 0, result.output
    assert "planning with the shipped network pick_view_panda.pt" in result.output and "franka_panda" in result.output
    assert json.loads((tmp_path / "p" / "grasps.json").read_text())["grasps"]
    refused = CliRunner().invoke(app, [*run, "--gripper", str(tmp_path / "my_hand.yaml"), "--out",
                                       str(tmp_path / "r")])
    assert refused.exit_code != 0 and "no network ships for the gripper 'my_hand'" in refused.output
    assert "--checkpoint" in refused.output and not (tmp_path / "r" / "grasps.json").exists()
    by_name = CliRunner().invoke(app, [*run, "--gripper", "panda", "--check", "0", "--out", str(tmp_path / "n")])
    assert by_name.exit_code == 0 and "pick_view_panda.pt" in by_name.output  # a preset by its name
    for preset in ("robotiq_2f85", "robotiq_2f140"):  # networks made by pick-labels and pick-train ship for both
        robotiq = CliRunner().invoke(app, [*run, "--gripper", preset, "--check", "0", "--out", str(tmp_path / preset)])
        assert robotiq.exit_code == 0 and f"pick_view_{preset}.pt" in robotiq.output, robotiq.output
        assert json.loads((tmp_path / preset / "grasps.json").read_text())["grasps"]
    typo = CliRunner().invoke(app, [*run, "--gripper", "pandas", "--out", str(tmp_path / "t")])
    assert typo.exit_code == 2 and "pandas: not a gripper spec: no such file, nor a preset (panda," in typo.output


@pytest.mark.sim
def test_a_hand_none_ships_for_is_planned_for_by_the_network_carried_only_when_asked_and_its_region_holds(tmp_path):
    from onepiece_dist.errors import CheckpointRejected
    from onepiece_dist.picks.runner import with_network
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import CARRIED, NETWORK, REGION, PlanningNetwork, planning_network
    from onepiece_dist.specs.job import GripperSpec, VoxelSpec
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    default = GripperSpec()
    hand = GripperSpec(name="my_hand", max_opening=0.1, closing_width=0.1, finger_length=0.06, closing_depth=0.05,
                       palm_depth=0.05, closing_force=60.0)  # a closing region larger than the network's
    with pytest.raises(CheckpointRejected, match="another gripper"):  # given as a checkpoint: refused as before
        GraspScorer(NETWORK, hand, device="cpu")
    carried = GraspScorer(NETWORK, hand, device="cpu", carried=True)  # the hand's geometry, the network's region
    assert carried.gripper == hand.model_copy(update={n: getattr(default, n) for n in REGION})
    assert carried.record.grid_shape() == GraspScorer(NETWORK).record.grid_shape() != VoxelSpec().grid_shape(hand)
    with pytest.raises(CheckpointRejected, match="no network ships for the gripper 'my_hand'.*--carry: carried to"):
        planning_network(hand)  # not asked: refused, saying what carrying picked
    assert planning_network(hand, carry=True) == PlanningNetwork(NETWORK, "onepiece_box")
    assert planning_network(GripperSpec(), carry=True).carried_from is None
    with pytest.raises(CheckpointRejected, match="no network ships"):
        with_network(PickSpec(gripper=hand))
    picks = with_network(PickSpec(gripper=hand, plan=PlanSpec(carry=True)))
    assert picks.checkpoint == str(NETWORK) and picks.carried and not with_network(PickSpec()).carried
    small = GripperSpec(name="small", max_opening=0.05, closing_width=0.05)
    with pytest.raises(CheckpointRejected, match="closing region holds its own .* closing_width=0.05"):
        planning_network(small, carry=True)
    for measured in json.loads(CARRIED.read_text())["hands"]:  # the hands the planner quotes, each one it carries to
        assert all(measured["region"][n] >= getattr(default, n) for n in REGION)
    np.save(tmp_path / "depth.npy", depth_millimetres().astype(np.float64) / 1000)
    (tmp_path / "my_hand.yaml").write_text(hand.model_dump_json())
    run = ["grasp", str(tmp_path / "depth.npy"), "--intrinsics", f"{FX},{FY},{CX},{CY}", "--gripper",
           str(tmp_path / "my_hand.yaml")]
    refused = CliRunner().invoke(app, [*run, "--out", str(tmp_path / "r")])
    assert refused.exit_code == 2 and "--carry" in refused.output and not (tmp_path / "r").exists()
    result = CliRunner().invoke(app, [*run, "--carry", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "no network ships for the gripper 'my_hand': planning with the default job's network" in result.output
    panda = next(h for h in json.loads(CARRIED.read_text())["hands"] if h["gripper"] == "franka_panda")
    quoted = f"franka_panda {100 * panda['carried']['rate']:.0f}% against its own network"
    assert quoted in " ".join(result.output.split())  # what carried.json holds
    plan = json.loads((tmp_path / "out" / "grasps.json").read_text())
    assert plan["carried_from"] == "onepiece_box" and plan["grasps"]
    (tmp_path / "small.yaml").write_text(small.model_dump_json())
    refused = CliRunner().invoke(app, ["pick", "--objects", "primitives[0:1]", "--gripper",
                                       str(tmp_path / "small.yaml"), "--carry", "--in-process", "--out",
                                       str(tmp_path / "picks")])
    assert refused.exit_code == 2 and "closing region holds its own" in refused.output, refused.output
    assert not (tmp_path / "picks" / "picks.json").exists()


def test_intrinsics_made_for_another_image_are_refused_and_a_ros_camera_info_is_read(tmp_path):
    from onepiece_dist.plan.robot import read_observation

    write_png(tmp_path / "depth.png", depth_millimetres())  # 160 x 120
    k = [FX, 0, CX, 0, FY, CY, 0, 0, 1]
    (tmp_path / "k.json").write_text(json.dumps({"K": [k[:3], k[3:6], k[6:]]}))
    (tmp_path / "info.json").write_text(json.dumps({"k": k, "width": 160, "height": 120}))  # a ROS 2 CameraInfo's
    seen = read_observation(tmp_path / "depth.png", str(tmp_path / "k.json"))[0]
    assert np.array_equal(read_observation(tmp_path / "depth.png", str(tmp_path / "info.json"))[0].points,
                          seen.points)
    (tmp_path / "colour.json").write_text(json.dumps({"K": k, "width": 640, "height": 480}))  # another stream's
    (tmp_path / "elsewhere.json").write_text(json.dumps({"fx": FX, "fy": FY, "cx": 4 * CX, "cy": 4 * CY}))
    refused = {name: CliRunner().invoke(app, ["grasp", str(tmp_path / "depth.png"), "--intrinsics",
                                              str(tmp_path / f"{name}.json"), "--out", str(tmp_path / name)])
               for name in ("colour", "elsewhere")}
    assert all(result.exit_code == 2 for result in refused.values())
    assert "colour.json: these intrinsics are for a 640x480 image" in refused["colour"].output
    assert "is 160x120" in refused["colour"].output and "scaled by 0.25" in refused["colour"].output
    assert "elsewhere.json: the principal point (320, 240) lies outside" in refused["elsewhere"].output


def test_a_camera_pose_in_opengl_axes_and_a_workspace_beside_the_cloud_are_refused_saying_why(tmp_path):
    write_png(tmp_path / "depth.png", depth_millimetres())
    opengl = CAMERA_POSE @ np.diag([1.0, -1.0, -1.0, 1.0])  # the same camera, y up and z backward
    (tmp_path / "opengl.json").write_text(json.dumps({"matrix": opengl.tolist()}))
    (tmp_path / "pose.json").write_text(json.dumps({"matrix": CAMERA_POSE.tolist()}))
    args = ["grasp", str(tmp_path / "depth.png"), "--intrinsics", f"{FX},{FY},{CX},{CY}", "--out", str(tmp_path)]
    turned = CliRunner().invoke(app, [*args, "--camera-pose", str(tmp_path / "opengl.json")])
    assert turned.exit_code == 2 and "opengl.json: with this camera pose 100% of" in turned.output
    assert "OpenCV's camera axes" in turned.output
    beside = CliRunner().invoke(app, [*args, "--camera-pose", str(tmp_path / "pose.json"), "--workspace",
                                      "1,1,0,2,2,1"])
    assert beside.exit_code == 2 and "none of its 19200 points lies in the workspace" in beside.output
    assert re.search(r"z \[[+-]0\.00, \+0\.05\] m", beside.output)  # the table at z = 0, the box's top 5 cm up
