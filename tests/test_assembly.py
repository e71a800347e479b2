"""ONE PIECE assembly: classifier, layout, round trip, export, render."""

import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from onepiece_dist.cli import app
from onepiece_dist.core.classifier import PLANES, classify_occupancy, l_feature_count
from onepiece_dist.core.layout import assembly_geometry, corridor_intrusions, layout_patches, region_codes
from onepiece_dist.core.spatial import PointGrid
from onepiece_dist.core.voxel import pack_codes
from onepiece_dist.service.local import run_local
from onepiece_dist.spec import GripperSpec
from onepiece_dist.store import open_dataset

GRID = (4, 8, 2)


def occupancy(*cells):
    occ = np.zeros((1, *GRID), dtype=bool)
    for cell in cells:
        occ[(0, *cell)] = True
    return occ


def test_l_features_count_windows_with_exactly_three_cells():
    checker = np.array([[[1, 0, 1], [0, 1, 0], [1, 0, 1]]], dtype=bool)  # every window has two cells
    corners = np.array([[[1, 1, 1], [1, 0, 1], [1, 1, 1]]], dtype=bool)  # every window is an L
    full = np.ones((1, 3, 3), dtype=bool)
    assert l_feature_count(checker)[0] == 0 and l_feature_count(corners)[0] == 4 and l_feature_count(full)[0] == 0


def test_a_plane_of_l_corners_wins_over_flat_projections():
    # an L in (v, t) repeated at every u: the vt projection has one L window; uv and ut are filled rectangles
    cells = [(u, v, t) for u in range(4) for v, t in ((3, 0), (4, 0), (3, 1))]
    result = classify_occupancy(occupancy(*cells))
    assert result.features[0].tolist() == [0, 0, 1]
    assert PLANES[result.plane[0]] == "vt"
    assert result.areas[0].tolist() == [8, 8, 3]
    assert result.scores[0, 2] == pytest.approx(3 / 19)


def test_a_flat_patch_has_no_features_and_ties_go_to_the_largest_area():
    flat = occupancy(*[(u, 5, t) for u in range(4) for t in range(2)])  # the plane v = 5
    result = classify_occupancy(flat)
    assert result.features[0].tolist() == [0, 0, 0] and result.areas[0].tolist() == [4, 8, 2]
    assert PLANES[result.plane[0]] == "ut"


def test_equal_scores_and_areas_fall_back_to_plane_order():
    result = classify_occupancy(np.zeros((1, *GRID), dtype=bool))
    assert PLANES[result.plane[0]] == "uv"


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    from onepiece_dist.spec import JobSpec

    out = tmp_path_factory.mktemp("asm") / "ds.zarr"
    spec = JobSpec(objects="primitives[0:6]", grasps_per_object=24, output=str(out),
                   sampler={"surface_points": 3000}, stages=("ingest", "extract", "dedup", "assemble"))
    status = run_local(spec)
    return spec, out, status


def test_assembled_object_reproduces_every_unique_code(small_dataset):
    spec, out, status = small_dataset
    ds = open_dataset(out)
    report = ds.attrs["assembly"]
    assert report["fidelity"] == 1.0 and report["fidelity_failures"] == [] and report["corridor_intrusions"] == 0
    assert status.assembly.unique_codes == len(ds["unique/code"])
    assert {"extract", "dedup", "assemble"} <= set(status.timings) and "label" not in status.timings
    # recomputed here from the stored points and placements, independently of the stage's own check
    codes = region_codes(ds["assembled/points"].astype(np.float64), ds["assembled/placement"].astype(np.float64),
                         spec.grid_shape(), spec.voxel.resolution)
    assert np.array_equal(codes, ds["unique/code"])
    assert report["label_trials_one_object"] < report["label_trials_all_grasps"]


def test_no_patch_enters_another_patch_gripper_corridor():
    rng = np.random.default_rng(0)
    codes = pack_codes(rng.random((60, *GRID)) < 0.4)
    plane = classify_occupancy(rng.random((60, *GRID)) < 0.4).plane
    gripper = GripperSpec()
    layout = layout_patches(codes, plane, GRID, 0.01, gripper)
    geometry = assembly_geometry(layout, 0.01)
    assert corridor_intrusions(geometry["points"], geometry["point_patch"], layout.placements, gripper, 2.0).sum() == 0
    assert np.array_equal(region_codes(geometry["points"], layout.placements, GRID, 0.01), codes)
    # a pitch one voxel tighter lets neighbours in: the check can fail
    tight = layout_patches(codes, np.zeros(60, dtype=np.int8), GRID, 0.01,
                           GripperSpec(max_opening=0.06, closing_width=0.06))
    crowded = assembly_geometry(tight, 0.01)
    squeezed = tight.placements.copy()
    squeezed[:, :3, 3] *= 0.7
    assert corridor_intrusions(crowded["points"], crowded["point_patch"], squeezed, gripper, 2.0).sum() > 0


def test_export_obj_ply_urdf_and_a_single_pybullet_body(small_dataset, tmp_path):
    import pybullet as pb
    import trimesh

    _, out, _ = small_dataset
    runner = CliRunner()
    for fmt in ("obj", "ply", "urdf"):
        result = runner.invoke(app, ["export", str(out), "--format", fmt, "--out", str(tmp_path / f"one.{fmt}")])
        assert result.exit_code == 0, result.output
    mesh = trimesh.load(tmp_path / "one.obj", force="mesh")
    assert isinstance(mesh, trimesh.Trimesh) and len(mesh.faces) == len(open_dataset(out)["assembled/faces"])
    assert len(trimesh.load(tmp_path / "one.ply").faces) == len(mesh.faces)
    client = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(str(tmp_path / "one.urdf"), useFixedBase=True, physicsClientId=client)
        assert pb.getNumBodies(physicsClientId=client) == 1 and pb.getNumJoints(body, physicsClientId=client) == 0
    finally:
        pb.disconnect(client)


def test_render_writes_a_png_that_is_not_blank(small_dataset, tmp_path):
    _, out, _ = small_dataset
    png = tmp_path / "one.png"
    result = CliRunner().invoke(app, ["render", str(out), "--out", str(png)])
    assert result.exit_code == 0, result.output
    views = read_png(png)[:320]
    coloured = np.sum(np.ptp(views.astype(int), axis=2) > 60)  # patch colours, not greys or white
    assert coloured > 500


def read_png(path) -> np.ndarray:
    """(H, W, 3) uint8 of a PNG as write_png writes it (one IDAT, filter 0)."""
    data = path.read_bytes()
    assert data.startswith(b"\x89PNG")
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    idat = data.index(b"IDAT")
    raw = zlib.decompress(data[idat + 4: idat + 4 + int.from_bytes(data[idat - 4:idat], "big")])
    return np.frombuffer(raw, np.uint8).reshape(height, width * 3 + 1)[:, 1:].reshape(height, width, 3)


def labelled_spec(tmp_path, perturbations: int, points: int):
    """Two primitives through assembly and the label stage on the one object."""
    from onepiece_dist.spec import JobSpec

    return JobSpec(objects="primitives[0:2]", grasps_per_object=8, output=str(tmp_path / "ds.zarr"),
                   sampler={"surface_points": 2000}, stages=("ingest", "extract", "dedup", "assemble", "label"),
                   sim={"perturbations_per_patch": perturbations, "points_per_grasp": points})


def test_the_panda_hand_is_drawn_on_the_gripper_frame():
    from onepiece_dist.core.frames import pose_from_axes
    from onepiece_dist.sim.hand import PANDA_GRASP_TARGET, model_parts, panda_parts

    gripper = GripperSpec()
    rng = np.random.default_rng(4)
    pose = pose_from_axes(rng.normal(size=(1, 3)), rng.normal(size=(1, 3)), rng.normal(size=(1, 3)))[0]
    (_, hand), (_, left), (_, right) = panda_parts(pose, 0.05, gripper)
    centre = pose @ [gripper.closing_depth / 2, 0, 0, 1]
    assert np.allclose(hand @ [0, 0, PANDA_GRASP_TARGET, 1], centre)  # the point between the pads
    assert np.allclose(hand[:3, 2], pose[:3, 0]) and np.allclose(hand[:3, 1], pose[:3, 1])  # z = u, y = v
    assert np.allclose(left[:3, 3] - right[:3, 3], 0.05 * pose[:3, 1])  # fingers 5 cm apart along v
    boxes = model_parts(pose, 0.05, gripper)
    gap = np.linalg.norm(boxes[1][1][:3, 3] - boxes[2][1][:3, 3]) - gripper.finger_thickness
    assert np.isclose(gap, 0.05)


@pytest.mark.sim
@pytest.mark.slow
def test_render_draws_labelled_grasps_with_the_panda_hand_or_the_model(tmp_path):
    spec = labelled_spec(tmp_path, perturbations=1, points=32)
    run_local(spec)
    images = {}
    for hand in ("panda", "model", None):
        png = tmp_path / f"{hand}.png"
        extra = ["--grasps", "3", "--hand", hand] if hand else []
        result = CliRunner().invoke(app, ["render", spec.output, "--out", str(png), *extra])
        assert result.exit_code == 0, result.output
        images[hand] = read_png(png)
    assert images["panda"].shape[0] == images[None].shape[0] + 320  # one row of grasps more
    success = open_dataset(spec.output)["assembled/grasps/success"][:3]
    for hand in ("panda", "model"):
        row = images[hand][320:640].astype(int)
        for k, held in enumerate(success):
            cell = row[:, 320 * k:320 * (k + 1)]
            green = (cell[..., 1] > cell[..., 0] + 40) & (cell[..., 1] > cell[..., 2] + 40)
            red = (cell[..., 0] > cell[..., 1] + 60) & (cell[..., 0] > cell[..., 2] + 60)
            assert (green if held else red).sum() > 300, (hand, k)  # the gripper, in the colour of its label
    assert np.abs(images["panda"][320:640].astype(int) - images["model"][320:640]).sum() > 0
    result = CliRunner().invoke(app, ["render", spec.output, "--grasps", "1", "--hand", "robotiq"])
    assert result.exit_code == 2 and "robotiq" in result.output


@pytest.mark.sim
@pytest.mark.slow
def test_label_stage_runs_the_protocol_around_each_patch_of_the_one_object(tmp_path):
    spec = labelled_spec(tmp_path, perturbations=2, points=64)
    status = run_local(spec)
    ds = open_dataset(spec.output)
    unique, placement = ds["unique/code"], ds["assembled/placement"]
    labels = status.labels
    assert labels.label_trials == len(unique) * 3 and labels.labelled_grasps > 0
    patch, candidate = ds["assembled/grasps/patch"], ds["assembled/grasps/candidate_pose"]
    at_placement = np.all(np.isclose(candidate, placement[patch], atol=1e-6), axis=(1, 2))
    assert at_placement.any()
    # at its placement, the gripper sees exactly the unique code the patch stands for
    assert np.array_equal(ds["assembled/grasps/candidate_code"][at_placement], unique[patch[at_placement]])
    assert ds["assembled/grasps/points"].shape == (len(patch), 64, 3)
    assert set(np.unique(ds["assembled/grasps/success"])) <= {0, 1}
    quality = ds["assembled/grasps/quality"]
    assert np.all((quality >= 0) & (quality <= 1))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 300), st.floats(0.005, 0.2), st.integers(0, 2**31))
def test_point_grid_box_queries_equal_brute_force(count, cell, seed):
    rng = np.random.default_rng(seed)
    points = rng.uniform(-0.3, 0.3, (count, 3))
    grid = PointGrid(points, cell)
    for _ in range(5):
        lower = rng.uniform(-0.5, 0.3, 3)
        upper = lower + rng.uniform(0, 0.4, 3)
        expected = np.flatnonzero(np.all((points >= lower) & (points <= upper), axis=1))
        assert np.array_equal(np.sort(grid.in_box(lower, upper)), expected)
