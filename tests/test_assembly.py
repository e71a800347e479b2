"""ONE PIECE assembly of a real dataset: round trip, export, render, labels on the one object (the parts without a
dataset: tests/test_assembly_parts.py)."""

import zlib

import numpy as np
import pytest
from typer.testing import CliRunner

from onepiece_dist.cli.main import app
from onepiece_dist.core.assembly_layout import (
    assembly_geometry,
    layout_patches,
    patch_box,
    region_codes,
)
from onepiece_dist.job.patches import QUANTUM_LEVELS, read_patches
from onepiece_dist.job.stages.assemble import one_object_points
from onepiece_dist.runtime.local import run_local
from onepiece_dist.specs.job import GripperSpec
from onepiece_dist.store import open_dataset


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    from onepiece_dist.specs.job import JobSpec

    out = tmp_path_factory.mktemp("asm") / "ds.zarr"
    spec = JobSpec(objects="primitives[0:6]", grasps_per_object=24, output=str(out),
                   sampler={"surface_points": 3000}, stages=("ingest", "extract", "dedup", "assemble"))
    status = run_local(spec)
    return spec, out, status


def test_each_unique_code_is_represented_by_its_first_grasp(small_dataset):
    _, out, _ = small_dataset
    ds = open_dataset(out)
    codes, representative, code_index = ds["unique/code"], ds["unique/representative"], ds["grasps/code_index"]
    assert np.array_equal(ds["grasps/code"][representative], codes)
    first = np.array([np.flatnonzero(code_index == k)[0] for k in range(len(codes))])
    assert np.array_equal(representative, first)
    assert np.array_equal(ds["assembled/representative"], representative)


def test_the_one_object_is_made_of_the_real_geometry_and_reproduces_every_unique_code(small_dataset):
    spec, out, status = small_dataset
    ds = open_dataset(out)
    report = ds.attrs["assembly"]
    assert report["fidelity"] == 1.0 and report["fidelity_failures"] == [] and report["corridor_intrusions"] == 0
    assert status.assembly.unique_codes == len(ds["unique/code"]) and report["patch_pieces"] >= len(ds["unique/code"])
    assert {"extract", "dedup", "assemble"} <= set(status.timings) and "label" not in status.timings
    # recomputed here from the points derived from the store and the placements, independently of the stage
    codes = region_codes(one_object_points(ds)[0].astype(np.float64), ds["assembled/placement"].astype(np.float64),
                         spec.grid_shape(), spec.voxel.resolution)
    assert np.array_equal(codes, ds["unique/code"])
    # every patch point is a point of its source object's surface sample, seen from the representative's pose
    patches = read_patches(ds)
    k = int(np.argmax([len(p) for p in patches.points]))
    row = patches.representative[k]
    source = source_surface(spec, out, int(ds["grasps/object"][row]))
    pose = ds["grasps/pose"][row].astype(np.float64)
    placed = patches.points[k] @ pose[:3, :3].T + pose[:3, 3]
    half_step = 0.5 * np.ptp(source, axis=0).max() / QUANTUM_LEVELS  # the store's steps over the source's box
    assert np.abs(placed[:, None, :] - source[None]).max(axis=2).min(axis=1).max() < half_step + 1e-7
    lower, upper = patch_box(spec.gripper, spec.voxel.resolution)
    for piece in (p for patch in patches.pieces for p in patch):
        assert np.all((piece >= lower - 1e-9) & (piece <= upper + 1e-9))
    assert report["chamfer_patches"] > 0 and report["chamfer_max_mm"] < 1.0  # 750 stored points per grasp


def test_a_range_of_patches_read_alone_equals_that_range_of_the_whole(small_dataset):
    ds = open_dataset(small_dataset[1])
    whole = read_patches(ds)
    for start, stop in ((0, 1), (3, 11), (len(whole) - 5, len(whole)), (0, len(whole))):
        part = read_patches(ds, start, stop)
        assert len(part) == stop - start
        assert np.array_equal(part.representative, whole.representative[start:stop])
        assert np.array_equal(part.source_volume, whole.source_volume[start:stop])
        for k in range(start, stop):
            assert np.array_equal(part.points[k - start], whole.points[k])
            assert len(part.pieces[k - start]) == len(whole.pieces[k])
            assert all(np.array_equal(a, b) for a, b in zip(part.pieces[k - start], whole.pieces[k], strict=True))


def test_format_2_stores_each_source_once_and_derives_the_points_the_label_stage_used(small_dataset):
    import dataclasses
    import hashlib

    from onepiece_dist.job.patches import build_patches
    from onepiece_dist.store import PartStore

    spec, out, _ = small_dataset
    ds = open_dataset(out)
    assert ds.attrs["onepiece_format"] == 2
    assert not ds.has("assembled/points") and not ds.has("assembled/patch_points")  # no dense cloud stored
    sources = ds["assembled/source_point_count"]
    assert len(sources) == len(np.unique(ds["grasps/object"][ds["unique/representative"]]))  # once per object
    # the points a label shard derives from the store are, to the bit, the ones the assembly cut and checked
    built = build_patches(spec, ds, PartStore(spec.parts_folder()), ds["unique/representative"])
    derived = read_patches(ds)

    def digest(points: list) -> str:
        return hashlib.blake2b(b"".join(np.ascontiguousarray(p).tobytes() for p in points)).hexdigest()

    assert digest(derived.points) == digest(built.points)
    layout = layout_patches(ds["assembled/plane"], spec.gripper, spec.voxel.resolution)
    stored = dataclasses.replace(layout, placements=ds["assembled/placement"].astype(np.float64))  # as labelled
    geometry = assembly_geometry(stored, built.pieces, built.points, spec.voxel.resolution)
    points, owner = one_object_points(ds)
    assert np.array_equal(points, geometry["points"].astype(np.float32))
    assert np.array_equal(owner, geometry["point_patch"])


def test_a_dataset_of_an_older_format_is_refused_with_its_version_named(small_dataset, tmp_path):
    import shutil

    import zarr

    from onepiece_dist.errors import StoreError

    old = tmp_path / "old.zarr"
    shutil.copytree(small_dataset[1], old)
    zarr.open_group(str(old), mode="a").attrs["onepiece_format"] = 1
    with pytest.raises(StoreError, match=r"onepiece_format=1, this reader knows 2 \(format 1 stored the one "
                                         r"object's dense point cloud twice.*run its job again"):
        open_dataset(old)


def source_surface(spec, out, obj: int) -> np.ndarray:
    from onepiece_dist.job.results import part_key
    from onepiece_dist.store import PartStore

    content_id = bytes(open_dataset(out)["objects/id"][obj]).hex()
    return PartStore(spec.parts_folder()).read_array(part_key(content_id, spec.result_key()), "object_surface")








def test_export_obj_ply_urdf_and_a_single_pybullet_body_of_the_pieces(small_dataset, tmp_path):
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
    groups = (tmp_path / "one.pieces.obj").read_text().count("\no piece") + 1
    assert groups == open_dataset(out).attrs["assembly"]["patch_pieces"] + 1  # the pieces and the core
    urdf = (tmp_path / "one.urdf").read_text()
    mass = float(urdf.split('mass value="')[1].split('"')[0])
    assert 0.01 < mass < 100 and mass != 1.0  # from the geometry at the simulation's density
    client = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(str(tmp_path / "one.urdf"), useFixedBase=True, physicsClientId=client)
        assert pb.getNumBodies(physicsClientId=client) == 1 and pb.getNumJoints(body, physicsClientId=client) == 0
        # a compound of the pieces, not their hull: a ray between two patches reaches the core
        ds = open_dataset(out)
        placement, core_top = ds["assembled/placement"][0].astype(np.float64), ds["assembled/vertices"][-8:].max(0)
        pitch_v = ds.attrs["assembly"]["grid_pitch_m"][0]
        normal, gap = -placement[:3, 0], placement[:3, 3] + 0.5 * pitch_v * placement[:3, 1]
        hit = pb.rayTest((gap + normal).tolist(), (gap - normal).tolist(), physicsClientId=client)[0]
        face = int(np.argmax(np.abs(normal)))
        assert hit[0] == body and abs(hit[3][face] - core_top[face]) < 0.005
    finally:
        pb.disconnect(client)


@pytest.mark.sim
def test_the_gripper_closed_on_the_exported_object_sees_each_patch_code(small_dataset, tmp_path):
    import pybullet as pb

    from onepiece_dist.sim.trials import extract_trial
    from onepiece_dist.sim.world import SimWorld

    spec, out, _ = small_dataset
    exported = CliRunner().invoke(app, ["export", str(out), "--format", "urdf", "--out", str(tmp_path / "one.urdf")])
    assert exported.exit_code == 0, exported.output
    ds = open_dataset(out)
    placements, codes = ds["assembled/placement"].astype(np.float64), ds["unique/code"]
    points = one_object_points(ds)[0].astype(np.float64)
    world = SimWorld(spec.gripper)
    try:
        world.obj = pb.loadURDF(str(tmp_path / "one.urdf"), useFixedBase=True, physicsClientId=world.client)
        world.com = np.zeros(3)
        tried = 0
        for k in np.argsort([-int(np.unpackbits(c).sum()) for c in codes])[:6]:  # the fullest patches
            outcome, settled, width, _, _ = extract_trial(world, placements[k])
            if outcome != 0:
                continue
            tried += 1
            assert width < spec.gripper.max_opening
            assert np.array_equal(region_codes(points, settled[None], spec.grid_shape(), spec.voxel.resolution)[0],
                                  codes[k])
        assert tried >= 2
    finally:
        world.close()


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
    from onepiece_dist.specs.job import JobSpec

    return JobSpec(objects="primitives[0:2]", grasps_per_object=16, output=str(tmp_path / "ds.zarr"),
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
    transfer = status.labels.transfer  # label transfer, measured on the codes with two or more grasps
    shared = int(np.sum(ds["unique/count"] >= 2))
    assert shared > 0 and transfer.codes == min(shared, spec.sim.transfer_codes)
    assert transfer.patch_vs_source.pairs == transfer.codes
    assert transfer.grasps_labelled == transfer.codes + transfer.same_code.pairs
    for measure in (transfer.patch_vs_source, transfer.same_code, transfer.random_pairs):
        for value in (measure.success_agreement, measure.quality_correlation):
            assert value is None or -1 <= value <= 1
        assert measure.success_agreement is None or 0 <= measure.success_agreement <= 1
    assert ds.attrs["assembly_labels"]["transfer"]["codes"] == transfer.codes
    assert "transfer" in CliRunner().invoke(app, ["inspect", spec.output]).output


@pytest.mark.sim
@pytest.mark.slow
def test_a_job_that_labels_on_the_one_object_keeps_points_only_for_representatives(tmp_path):
    from onepiece_dist.store.dataset import disk_bytes

    lean = labelled_spec(tmp_path, perturbations=0, points=64).model_copy(update={
        "cache_dir": str(tmp_path / "cache"), "sim": labelled_spec(tmp_path, 0, 64).sim.model_copy(
            update={"transfer_codes": 0})})
    full = lean.model_copy(update={"keep_all_points": True, "output": str(tmp_path / "full.zarr")})
    run_local(lean), run_local(full)
    small, big = open_dataset(lean.output), open_dataset(full.output)
    assert not small.has("grasps/points") and big.has("grasps/points")
    assert np.array_equal(small["unique/points"], big["grasps/points"][big["unique/representative"]])
    assert np.array_equal(small["assembled/grasps/points"], big["assembled/grasps/points"])
    saved = disk_bytes(big.path / "grasps") - disk_bytes(small.path / "grasps")
    assert saved >= disk_bytes(big.path / "grasps" / "points") > 0  # the clouds, and nothing else, left out








@pytest.mark.sim
@pytest.mark.slow
def test_the_delivered_copy_leaves_the_extraction_records_and_reads_as_the_original(tmp_path):
    from onepiece_dist.errors import StoreError
    from onepiece_dist.learn.dataset import GraspDataset
    from onepiece_dist.specs.job import JobSpec
    from onepiece_dist.store.dataset import delivered_bytes, disk_bytes

    out = tmp_path / "b.zarr"
    run_local(JobSpec(objects="primitives[0:3]", grasps_per_object=16, output=str(out),
                      sampler={"surface_points": 3000},
                      sim={"perturbations_per_patch": 0, "points_per_grasp": 32, "transfer_codes": 0},
                      stages=("ingest", "extract", "dedup", "assemble", "label")))
    copied = CliRunner().invoke(app, ["export", str(out), "--format", "delivered", "--out", str(tmp_path / "d.zarr")])
    assert copied.exit_code == 0, copied.output
    copy = open_dataset(tmp_path / "d.zarr")
    assert not copy.has("grasps/code") and not copy.has("unique/code") and copy.has("assembled/grasps/success")
    assert disk_bytes(tmp_path / "d.zarr") < disk_bytes(out) and delivered_bytes(out) < disk_bytes(out)
    ours, theirs = GraspDataset(out, "assembled/grasps"), GraspDataset(tmp_path / "d.zarr", "assembled/grasps")
    assert np.array_equal(ours.labels(), theirs.labels()) and np.array_equal(ours.groups, theirs.groups)
    a, b = read_patches(open_dataset(out)), read_patches(copy)
    assert all(np.array_equal(p, q) for p, q in zip(a.points, b.points, strict=True))
    assert copy.summary()["delivered_bytes"] > 0 and copy.summary()["grasps"] == 0
    with pytest.raises(StoreError, match="already exists"):
        from onepiece_dist.store.dataset import copy_delivered

        copy_delivered(out, tmp_path / "d.zarr")


def test_patches_cut_in_shards_equal_the_ones_cut_in_one_go_and_a_resumed_stage_reuses_its_shards(small_dataset):
    from onepiece_dist.job.patches import build_patches
    from onepiece_dist.job.stages.patch_shards import build_patch_shard, merge_patch_shards, patch_tasks
    from onepiece_dist.store import PartStore

    spec, out, _ = small_dataset
    reader, parts = open_dataset(out), PartStore(spec.parts_folder())
    tasks = patch_tasks(spec, out)
    results = [build_patch_shard(spec, task, k, parts) for k, task in enumerate(tasks)]
    assert all(result.reused for result in results)  # the job's own assemble stage made these parts
    sharded = merge_patch_shards(spec, reader, parts, tasks, results)
    whole = build_patches(spec, reader, parts, reader["unique/representative"])  # the central actor, alone
    assert np.array_equal(sharded.source_pose, whole.source_pose)
    assert np.array_equal(sharded.source_object, whole.source_object)
    assert all(np.array_equal(a, b) for a, b in zip(sharded.points, whole.points, strict=True))
    for a, b in zip(sharded.pieces, whole.pieces, strict=True):
        assert len(a) == len(b) and all(np.array_equal(p, q) for p, q in zip(a, b, strict=True))
    assert np.array_equal(sharded.source_volume, whole.source_volume)
