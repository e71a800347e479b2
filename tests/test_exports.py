"""The field's formats, read the way their public loaders read them: ACRONYM (h5py, trimesh at object/scale),
GraspGen (json, its documented fields, grasps[mask]), a URDF per patch in pybullet, PointNetGPD's crop."""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from onepiece_dist.cli.main import app
from onepiece_dist.core.hand_frames import (
    PANDA_CLOSING_CENTRE,
    PANDA_FINGER_BASE_Z,
    PANDA_FINGER_X,
    PANDA_FINGERTIP_Z,
    from_panda,
    to_panda,
)
from onepiece_dist.errors import PathEscape
from onepiece_dist.job.exports.grasp_files import ExportFolder, safe_names
from onepiece_dist.learn.dataset import GraspDataset, pointnetgpd_crop
from onepiece_dist.store import open_dataset

OBJECTS = "pybullet:named[3:4]+pybullet:random_urdfs[0:2]"  # the duck, and names with a '/' in them


@pytest.fixture(scope="module")
def labelled_both(tmp_path_factory):
    """Every object's grasps labelled (sim.label) and the one object assembled and labelled."""
    folder = tmp_path_factory.mktemp("exports")
    spec = folder / "job.yaml"
    spec.write_text("grasps_per_object: 24\nstages: [ingest, extract, dedup, assemble, label]\n"
                    "sim: {label: true, perturbations_per_patch: 2, points_per_grasp: 64}\n")
    out = folder / "ds.zarr"
    result = CliRunner().invoke(app, ["run", str(spec), "--objects", OBJECTS, "--out", str(out), "--in-process"])
    assert result.exit_code == 0, result.output
    return out


def export(dataset, fmt: str, out, *extra: str):
    result = CliRunner().invoke(app, ["export", str(dataset), "--format", fmt, "--out", str(out), *extra])
    return result


@pytest.fixture(scope="module")
def acronym(labelled_both, tmp_path_factory):
    out = tmp_path_factory.mktemp("acronym")
    result = export(labelled_both, "acronym", out)
    assert result.exit_code == 0, result.output
    return out


def test_the_panda_frame_is_ours_renamed_with_the_fingertips_together():
    rng = np.random.default_rng(0)
    from onepiece_dist.core.frames import pose_from_axes

    poses = pose_from_axes(rng.normal(size=(50, 3)), rng.normal(size=(50, 3)), rng.normal(size=(50, 3)))
    panda = to_panda(poses, finger_length=0.04)
    assert np.allclose(panda[:, :3, 2], poses[:, :3, 0]) and np.allclose(panda[:, :3, 0], poses[:, :3, 1])
    assert np.allclose(panda[:, :3, 1], np.cross(panda[:, :3, 2], panda[:, :3, 0]))  # y = z x x, right-handed
    tips_ours = poses[:, :3, 3] + 0.04 * poses[:, :3, 0]
    assert np.allclose(panda[:, :3, 3] + PANDA_FINGERTIP_Z * panda[:, :3, 2], tips_ours)
    assert np.allclose(from_panda(panda, 0.04), poses, atol=1e-15)


def test_acronym_files_have_its_keys_and_their_meshes_load_at_object_scale(acronym, labelled_both):
    import h5py
    import trimesh

    index = json.loads((acronym / "index.json").read_text())
    reader = open_dataset(labelled_both)
    assert [row["name"] for row in index["objects"]] == [*reader.object_names, "one_object"]
    assert len({row["file"] for row in index["objects"]}) == len(index["objects"])
    for row in index["objects"]:
        assert "/" not in os.path.basename(row["file"]) and (acronym / row["file"]).is_file()
        with h5py.File(acronym / row["file"], "r") as h5:
            transforms = h5["grasps/transforms"][:]
            held = h5["grasps/qualities/flex/object_in_gripper"][:]
            assert transforms.shape == (row["grasps"], 4, 4) and held.shape == (row["grasps"],)
            assert int((held > 0).sum()) == row["held"] and set(np.unique(held)) <= {0, 1}
            mesh_file, scale = h5["object/file"][()].decode(), float(h5["object/scale"][()])
            mesh = trimesh.load(os.path.join(acronym, mesh_file), force="mesh").apply_scale(scale)
        assert len(mesh.faces) > 0 and mesh_file == row["mesh"]
    one = h5py.File(acronym / index["objects"][-1]["file"], "r")
    assert len(one["onepiece/patch"]) == len(reader["assembled/grasps/success"])


def test_a_held_grasps_closing_region_in_the_panda_hand_holds_the_object(acronym, labelled_both):
    """From the exported transform and the documented Panda geometry alone: the centre between the Panda's
    fingers lies in or near the object for a grasp that held, and what our gripper held lies between its fingers.
    Our contacts lie at 30-90% of the fingers' depth, so for a grasp at the tips of a small part the fingers'
    middle is beyond it: most centres are inside, a few up to about a centimetre off. Taking the Panda's origin
    for our palm's (a converter's usual slip) puts them 5 cm beyond our fingertips."""
    import h5py
    import trimesh

    reader = open_dataset(labelled_both)
    index = json.loads((acronym / "index.json").read_text())
    distances, slipped = [], []
    for k, row in enumerate(index["objects"][:-1]):
        with h5py.File(acronym / row["file"], "r") as h5:
            transforms = h5["grasps/transforms"][:]
            held = h5["grasps/qualities/flex/object_in_gripper"][:] > 0
        mesh = trimesh.load(acronym / row["mesh"], force="mesh")
        centres = (transforms[:, :3, :3] @ PANDA_CLOSING_CENTRE + transforms[:, :3, 3])[held]
        inside = np.abs(winding_numbers(mesh.triangles, centres)) > 0.5
        distances += np.where(inside, 0.0, surface_distances(mesh, centres)).tolist()
        palm = to_panda(from_panda(transforms, 0.04), PANDA_FINGERTIP_Z)[held]  # origin at our palm centre
        wrong = palm[:, :3, :3] @ PANDA_CLOSING_CENTRE + palm[:, :3, 3]
        slipped += np.where(np.abs(winding_numbers(mesh.triangles, wrong)) > 0.5, 0.0,
                            surface_distances(mesh, wrong)).tolist()
        first = int(reader["objects/grasp_start"][k])
        points = reader["grasps/points"][first:first + len(held)].astype(np.float64) if reader.has(
            "grasps/points") else None
        if points is not None:  # our crop, in the Panda frame through our pose: inside the Panda's fingers
            in_object = np.einsum("nij,npj->npi", reader["grasps/pose"][first:first + len(held), :3, :3],
                                  points) + reader["grasps/pose"][first:first + len(held), None, :3, 3]
            local = np.einsum("nji,npj->npi", transforms[:, :3, :3], in_object - transforms[:, None, :3, 3])
            assert np.all(np.abs(local[..., 0]) <= PANDA_FINGER_X + 1e-3)
            assert np.all((local[..., 2] >= PANDA_FINGER_BASE_Z - 1e-3) & (local[..., 2] <= PANDA_FINGERTIP_Z + 1e-3))
    distances, slipped = np.array(distances), np.array(slipped)
    assert len(distances) >= 20 and np.mean(distances < 0.005) >= 0.85 and distances.max() < 0.012, distances
    assert np.mean(slipped < 0.005) < 0.5 and slipped.max() > 0.03  # the test tells a wrong origin apart


def winding_numbers(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(k,) generalized winding number of each point for (f, 3, 3) triangles: about 1 inside a closed surface,
    0 outside (the solid angles of the triangles, Van Oosterom and Strackee)."""
    a, b, c = (triangles[None, :, i] - points[:, None] for i in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
    det = np.einsum("kfi,kfi->kf", a, np.cross(b, c))
    div = la * lb * lc + np.einsum("kfi,kfi->kf", a, b) * lc + np.einsum("kfi,kfi->kf", a, c) * lb \
        + np.einsum("kfi,kfi->kf", b, c) * la
    return np.arctan2(det, div).sum(axis=1) / (2 * np.pi)


def surface_distances(mesh, points: np.ndarray) -> np.ndarray:
    """(k,) distance from each point to the nearest of 200,000 area-weighted samples of the mesh's surface."""
    samples = np.asarray(mesh.sample(200_000, seed=0))
    return np.array([np.sqrt(np.min(np.sum((samples - p) ** 2, axis=1))) for p in points])


def test_poses_round_trip_through_both_formats(acronym, labelled_both, tmp_path):
    import h5py

    reader = open_dataset(labelled_both)
    index = json.loads((acronym / "index.json").read_text())
    first = index["objects"][0]
    with h5py.File(acronym / first["file"], "r") as h5:
        back = from_panda(h5["grasps/transforms"][:], 0.04)
        assert np.allclose(back, h5["onepiece/pose"][:], atol=1e-12)
    assert np.allclose(back, reader["grasps/pose"][:first["grasps"]], atol=1e-7)  # float32 in the dataset
    assert export(labelled_both, "graspgen", tmp_path / "gg").exit_code == 0
    record = json.loads((tmp_path / "gg" / "grasps" / os.path.basename(first["file"]).replace(".h5", ".json"))
                        .read_text())
    assert np.allclose(from_panda(np.array(record["grasps"]["transforms"]), 0.04), back, atol=1e-12)


def test_graspgen_json_parses_with_its_documented_fields_and_splits_name_mesh_files(labelled_both, tmp_path):
    reader = open_dataset(labelled_both)
    chosen = reader.object_names[1]
    result = export(labelled_both, "graspgen", tmp_path, "--valid-objects", chosen)
    assert result.exit_code == 0, result.output
    files = sorted((tmp_path / "grasps").glob("*.json"))
    assert len(files) == len(reader.object_names) + 1
    for path in files:
        grasps_dict = json.loads(path.read_text())
        object_file, object_scale = grasps_dict["object"]["file"], grasps_dict["object"]["scale"]
        grasps = np.array(grasps_dict["grasps"]["transforms"])
        grasp_mask = np.array(grasps_dict["grasps"]["object_in_gripper"])
        positive, negative = grasps[grasp_mask], grasps[~grasp_mask]  # as GraspGen's docs read them
        assert grasp_mask.dtype == bool and len(positive) + len(negative) == len(grasps)
        assert grasps.shape[1:] == (4, 4) and object_scale == 1.0 and (tmp_path / object_file).is_file()
    train, valid = ((tmp_path / "splits" / f"{s}.txt").read_text().split() for s in ("train", "valid"))
    index = json.loads((tmp_path / "index.json").read_text())
    meshes = {row["name"]: row["mesh"] for row in index["objects"]}
    assert valid == [meshes[chosen]] and sorted(train + valid) == sorted(meshes.values())
    assert export(labelled_both, "graspgen", tmp_path / "x", "--valid-objects", "nope").exit_code == 2


def test_the_per_patch_export_loads_in_pybullet_with_the_label_stages_mass_rule(labelled_both, tmp_path):
    import pybullet as pb

    from onepiece_dist.sim.world import MAX_MASS, MIN_MASS
    from onepiece_dist.specs.job import JobSpec

    result = export(labelled_both, "urdf-patches", tmp_path)
    assert result.exit_code == 0, result.output
    scene = json.loads((tmp_path / "scene.json").read_text())
    reader = open_dataset(labelled_both)
    density = JobSpec.model_validate(reader.attrs["job_spec"]).sim.density
    volume = reader["assembled/source_volume"]
    assert len(scene["patches"]) >= 0.9 * len(volume)
    client = pb.connect(pb.DIRECT)
    try:
        for body in scene["patches"][:25]:
            uid = pb.loadURDF(str(tmp_path / body["urdf"]), body["position"], body["orientation_xyzw"],
                              physicsClientId=client)
            mass = pb.getDynamicsInfo(uid, -1, physicsClientId=client)[0]
            rule = float(np.clip(density * volume[body["patch"]], MIN_MASS, MAX_MASS))
            assert mass == pytest.approx(rule, rel=1e-6) and body["mass"] == pytest.approx(rule)
            position, _ = pb.getBasePositionAndOrientation(uid, physicsClientId=client)  # its centre of mass
            pose = np.array(body["pose"])
            assert np.allclose(position, pose[:3, :3] @ body["com"] + pose[:3, 3], atol=1e-6)
    finally:
        pb.disconnect(client)


def test_exports_without_what_they_need_are_refused_with_the_reason(tmp_path):
    from onepiece_dist.runtime.local import run_local
    from onepiece_dist.specs.job import JobSpec

    bare = tmp_path / "bare.zarr"
    run_local(JobSpec(objects="primitives[0:2]", grasps_per_object=8, output=str(bare),
                      stages=("ingest", "extract", "dedup")))
    for fmt in ("acronym", "graspgen"):
        result = export(bare, fmt, tmp_path / fmt)
        assert result.exit_code == 2 and "no labelled grasps" in result.output
    result = export(bare, "urdf-patches", tmp_path / "patches")
    assert result.exit_code == 2 and "no assembled object" in result.output


def test_names_become_safe_unique_file_names_and_nothing_is_written_outside():
    assert safe_names(["random_urdfs/000", "../../etc", "a b", "a_b", ".hidden", ""]) == [
        "random_urdfs_000", "_.._etc", "a_b", "a_b-2", "hidden", "object"]
    assert safe_names(["mug.obj", "mug.OBJ", "box.stl", "my.mug"]) == ["mug", "mug-2", "box", "my.mug"]  # one suffix


def test_exports_name_the_gripper_as_acronym_and_graspgen_do(acronym, labelled_both, tmp_path):
    import h5py

    from onepiece_dist.specs.job import JobSpec

    with h5py.File(next((acronym / "grasps").glob("*.h5")), "r") as h5:
        assert h5["gripper/type"][()].decode() == "onepiece_box"  # the job's gripper, by name
    assert export(labelled_both, "graspgen", tmp_path / "gg").exit_code == 0
    record = json.loads(next((tmp_path / "gg" / "grasps").glob("*.json")).read_text())
    assert record["gripper"] == "onepiece_box"
    assert JobSpec(gripper="panda").gripper.name == "franka_panda"
    assert JobSpec(gripper={"preset": "robotiq_2f85", "friction": 0.6}).gripper.max_opening == 0.085
    with pytest.raises(ValueError, match="unknown gripper preset 'ur5'.*panda"):
        JobSpec(gripper="ur5")


def test_nothing_is_written_outside_the_export_folder(tmp_path):
    folder = ExportFolder(tmp_path / "out")
    with pytest.raises(PathEscape):
        folder.path("../escaped.json")
    (tmp_path / "out" / "link").symlink_to(tmp_path)
    with pytest.raises(PathEscape):
        folder.path("link/escaped.json")


def test_pointnetgpd_crop_is_its_frame_and_box():
    points = np.array([[0.02, 0.0, 0.004], [0.02, 0.03, 0.0], [0.034, 0.0, 0.0], [0.02, 0.0, 0.013]])
    local, inside = pointnetgpd_crop(points, np.array(0.05), closing_depth=0.04)
    assert np.allclose(local[0], [0.0, 0.0, -0.004])  # (u - d/2, v, -t)
    assert inside.tolist() == [True, False, False, False]  # |y| < w/2 = 0.025, |x| < w/4, |z| < w/4 = 0.0125


def test_the_reader_returns_pointnetgpd_crops_of_the_stored_points(labelled_both):
    plain = GraspDataset(labelled_both, "grasps", inputs=("points",))
    crops = GraspDataset(labelled_both, "grasps", inputs=("points",), crop="pointnetgpd")
    rows = list(range(min(16, len(plain))))
    a, b = plain.batch(rows), crops.batch(rows)
    width = open_dataset(labelled_both)["grasps/width"][rows]
    assert b["points"].shape == a["points"].shape and (b["inside"] > 0).any()
    for k in np.flatnonzero(b["inside"].numpy()):
        half = np.array([width[k] / 4, width[k] / 2, width[k] / 4])
        assert np.all(np.abs(b["points"][k].numpy()) < half + 1e-6)
    assert np.array_equal(crops.batch(rows)["points"], b["points"])  # seeded by row: the same every time
    with pytest.raises(ValueError, match="crop"):
        GraspDataset(labelled_both, "grasps", crop="dexnet")


def test_the_example_reader_crops_as_the_package_does(labelled_both):
    import importlib.util
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "examples" / "read_dataset_with_zarr.py"
    loaded = importlib.util.spec_from_file_location("example_reader", script)
    example = importlib.util.module_from_spec(loaded)
    loaded.loader.exec_module(example)
    points = np.random.default_rng(2).uniform(-0.04, 0.04, (5, 100, 3))
    width = np.linspace(0.01, 0.08, 5)
    for found, expected in zip(example.pointnetgpd_crop(points, width, 0.04), pointnetgpd_crop(points, width, 0.04),
                               strict=True):
        assert np.array_equal(found, expected)
    out = subprocess.run([sys.executable, str(script), str(labelled_both)], capture_output=True, text=True, check=True)
    assert "PointNetGPD crops of 64 labelled grasps" in out.stdout


def relabel(files, out, spec_file=None, *extra):
    args = ["label", *[a for f in files for a in ("--grasps", str(f))], "--out", str(out), "--in-process", *extra]
    result = CliRunner().invoke(app, args + (["--spec", str(spec_file)] if spec_file else []))
    assert result.exit_code == 0, (result.output, result.exception)
    return json.loads(Path(result.output.strip().splitlines()[-1]).read_text())


def test_our_exports_brought_back_in_are_the_same_grasps_and_get_our_labels_again(acronym, labelled_both,
                                                                                 tmp_path):
    """ACRONYM's .h5 and GraspGen's .json, read back (onepiece label --grasps) and labelled by the exporting
    job's own protocol: the same poses come back (from our onepiece/pose, or through the Panda frame when a file
    has only the Panda's transforms), and the labels repeat for most grasps (they start at the settled pose). With
    the converter's usual slip (the Panda's origin taken for our palm centre) most grasps close on nothing."""
    import h5py

    assert export(labelled_both, "graspgen", tmp_path / "gg").exit_code == 0
    same = tmp_path / "same.yaml"
    same.write_text("sim: {label: true, label_trials: 1, success: nominal, points_per_grasp: 64}\n")
    stems = ("duck", "random_urdfs_000", "random_urdfs_001")
    files = [acronym / "grasps" / f"{s}.h5" for s in stems] + [tmp_path / "gg" / "grasps" / f"{s}.json" for s in stems]
    report = relabel(files, tmp_path / "back.zarr", same)
    tables = [row["table"] for row in report["files"]]
    assert [row["format"] for row in report["files"]] == ["acronym"] * 3 + ["graspgen"] * 3
    assert tables[:3] == tables[3:] and report["overall"]["grasps"] == 2 * 59
    assert report["overall"]["agreement"] >= 0.9, report["overall"]
    back = open_dataset(tmp_path / "back.zarr")
    assert back.attrs["gripper"]["name"] == "onepiece_box"
    with h5py.File(files[0], "r") as h5:
        exported, transforms = h5["onepiece/pose"][:], h5["grasps/transforms"][:]
    rows = slice(0, int(back["objects/grasp_count"][0]))
    np.testing.assert_allclose(back["grasps/candidate_pose"][rows], exported[back["grasps/source_row"][rows]],
                               atol=1e-6)
    bare, slipped = (tmp_path / "t" / "grasps" / "bare.h5", tmp_path / "t" / "grasps" / "slipped.h5")
    bare.parent.mkdir(parents=True)
    shutil.copytree(acronym / "meshes", tmp_path / "t" / "meshes")
    for path, shift in ((bare, 0.0), (slipped, PANDA_FINGERTIP_Z - 0.04)):
        with h5py.File(files[0], "r") as source, h5py.File(path, "w") as h5:
            for key in ("object/file", "object/scale", "gripper/type", "grasps/qualities/flex/object_in_gripper"):
                h5[key] = source[key][()]
            moved = transforms.copy()
            moved[:, :3, 3] += shift * transforms[:, :3, 2]  # along the Panda's approach axis
            h5["grasps/transforms"] = moved
    converted = relabel([bare, slipped], tmp_path / "bare.zarr", same)["files"]
    bare_back = open_dataset(tmp_path / "bare.zarr")
    rows = slice(0, int(bare_back["objects/grasp_count"][0]))
    np.testing.assert_allclose(bare_back["grasps/candidate_pose"][rows],
                               exported[bare_back["grasps/source_row"][rows]], atol=1e-6)
    assert converted[0]["table"] == tables[0]
    assert converted[1]["table"]["agreement"] < tables[0]["agreement"] - 0.3, converted[1]


def test_grasp_files_that_cannot_be_brought_in_are_refused_naming_the_file_and_the_fix(tmp_path):
    from onepiece_dist.errors import SourceError
    from onepiece_dist.job.relabel import relabel_spec
    from onepiece_dist.objects.foreign import read_foreign_grasps

    (tmp_path / "grasps").mkdir()
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "box.obj").write_text("v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 0.05\n"
                                                 "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    good = {"object": {"file": "meshes/box.obj", "scale": 1.0}, "gripper": "franka_panda",
            "grasps": {"transforms": [np.eye(4).tolist()], "object_in_gripper": [True]}}
    cases = {"missing.json": ({"object": good["object"]}, r"not a GraspGen grasp file \(KeyError: 'grasps'\)"),
             "escape.json": ({**good, "object": {"file": "../../etc/passwd"}}, r"lies outside"),
             "absent.json": ({**good, "object": {"file": "meshes/none.obj"}}, r"is not a file under"),
             "skewed.json": ({**good, "grasps": {"transforms": [(2 * np.eye(4)).tolist()],
                                                 "object_in_gripper": [1]}}, r"1 grasp transforms are not rigid")}
    for name, (record, why) in cases.items():
        (tmp_path / "grasps" / name).write_text(json.dumps(record))
        with pytest.raises(SourceError, match=rf"{name}: .*{why}"):
            read_foreign_grasps(tmp_path / "grasps" / name)
    (tmp_path / "grasps" / "ur.json").write_text(json.dumps({**good, "gripper": "ur_hand"}))
    with pytest.raises(SourceError, match=r"gripper 'ur_hand' is none of ours .* give the gripper"):
        relabel_spec([tmp_path / "grasps" / "ur.json"], tmp_path / "out.zarr")
    (tmp_path / "grasps" / "acronym.json").write_text(json.dumps({  # ACRONYM's JSON form, as load_grasps reads it
        "object": "meshes/box.obj", "object_scale": 0.5, "transforms": [np.eye(4).tolist()] * 2,
        "quality_flex_object_in_gripper": [1, 0]}))
    found = read_foreign_grasps(tmp_path / "grasps" / "acronym.json")
    assert (found.format, found.scale, found.held.tolist()) == ("acronym", 0.5, [True, False])
    (tmp_path / "grasps" / "ok.json").write_text(json.dumps(good))
    spec = relabel_spec([tmp_path / "grasps" / "ok.json"], tmp_path / "out.zarr")
    assert spec.gripper.name == "franka_panda" and (spec.sim.label_trials, spec.sim.success) == (4, "every_trial")
    assert spec.stages == ("ingest", "extract") and spec.objects == f"grasps:{tmp_path / 'grasps' / 'ok.json'}"
