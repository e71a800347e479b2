"""Real household meshes as they come (issue 50): robosuite's object meshes, fetched at test time (never
committed; skipped with the reason where they cannot be had), accepted in their units, repaired when wound
inwards, refused with the fitting units when in centimetres."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.mesh import signed_volume
from onepiece_dist.errors import MeshRejected
from onepiece_dist.job.stages.extract import extract_object
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def household():
    from benchmarks.experiments.household import HouseholdUnavailable, household_objects

    try:
        return household_objects()
    except HouseholdUnavailable as err:
        pytest.skip(f"household meshes unavailable: {err}")


def write_obj(path, vertices, faces):
    path.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in vertices)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))
    return path


@pytest.fixture(scope="module")
def panda_acronym(household, tmp_path_factory):
    """Every household mesh (units given) through a Panda-preset labelled job, exported to ACRONYM."""
    from typer.testing import CliRunner

    from onepiece_dist.cli.main import app

    folder = tmp_path_factory.mktemp("panda")
    (folder / "job.yaml").write_text("gripper: panda\ngrasps_per_object: 24\nstages: [ingest, extract]\n"
                                     "sim: {label: true}\n")
    run = CliRunner().invoke(app, ["run", str(folder / "job.yaml"), "--objects", str(household), "--units", "m",
                                   "--out", str(folder / "d.zarr"), "--in-process"])
    assert run.exit_code == 0, run.output
    exported = CliRunner().invoke(app, ["export", str(folder / "d.zarr"), "--format", "acronym", "--out",
                                        str(folder / "acronym")])
    assert exported.exit_code == 0, exported.output
    return folder


@pytest.mark.slow
def test_every_household_mesh_is_accepted_in_metres_and_yields_grasps(panda_acronym):
    from onepiece_dist.store import open_dataset

    reader = open_dataset(panda_acronym / "d.zarr")
    from benchmarks.experiments.household import OBJECTS

    assert len(reader.object_names) == len(OBJECTS) == 16 and reader.attrs["stats"]["objects_rejected"] == 0
    counts = dict(zip(reader.object_names, reader["objects/grasp_count"].tolist(), strict=True))
    assert all(n > 0 for n in counts.values()), counts
    repairs = {row["name"]: row["repairs"] for row in reader.attrs["ingest"]}  # the scan's seams, recorded
    assert repairs["can.obj"] == "38 vertices split at UV seams or duplicated: welded (480 remain)", repairs


# The Franka hand in its own frame (ACRONYM's franka_gripper_collision_mesh.stl, bounds read at NVlabs/acronym
# d02f58f): the hand body below the fingers' base, and each open finger beside the closing region.
PANDA_PALM = ((-0.1004, 0.1040), (-0.0316, 0.0316), (-0.0259, 0.0660))
PANDA_FINGER = ((0.041, 0.0653), (-0.0105, 0.0105), (0.0660, 0.1122))  # and its mirror in x
PANDA_BETWEEN = ((-0.040, 0.040), (-0.0105, 0.0105), (0.0660, 0.1122))


def acronym_load(h5_path, mesh_root):
    """acronym_tools' load_grasps and load_mesh, as they read the file (h5py's grasps/transforms and
    grasps/qualities/flex/object_in_gripper; trimesh at object/file from the mesh root, at object/scale)."""
    import h5py
    import trimesh

    with h5py.File(h5_path, "r") as data:
        transforms = np.array(data["grasps/transforms"])
        success = np.array(data["grasps/qualities/flex/object_in_gripper"])
        mesh_file, scale = data["object/file"][()].decode("utf-8"), data["object/scale"][()]
    return transforms, success, trimesh.load(f"{mesh_root}/{mesh_file}").apply_scale(scale)


def inside(points, box, margin=0.0):
    return np.all([(points[..., k] > lo + margin) & (points[..., k] < hi - margin)
                   for k, (lo, hi) in enumerate(box)], axis=0)


@pytest.mark.slow
def test_acronyms_loader_finds_each_held_grasp_around_the_object_with_the_hand_outside(panda_acronym):
    """Read as ACRONYM reads it, a held grasp of the Panda preset has the object between the Panda's open fingers
    and no part of the hand (palm, fingers) more than 2 mm inside the object, for >= 95% of the held grasps."""
    root = panda_acronym / "acronym"
    verdicts = []
    for h5 in sorted((root / "grasps").glob("*.h5")):
        transforms, success, mesh = acronym_load(h5, root)
        surface = np.asarray(mesh.sample(20_000, seed=0))
        for pose in transforms[success > 0]:
            local = (surface - pose[:3, 3]) @ pose[:3, :3]  # the object's surface in the hand's frame
            mirrored = local * [-1, 1, 1]
            hand_hit = any(inside(p, box, margin=0.002).any() for p, box in
                           ((local, PANDA_PALM), (local, PANDA_FINGER), (mirrored, PANDA_FINGER)))
            verdicts.append(inside(local, PANDA_BETWEEN).any() and not hand_hit)
    assert len(verdicts) >= 30 and np.mean(verdicts) >= 0.95, (len(verdicts), np.mean(verdicts))


def test_an_inward_wound_copy_is_flipped_and_gives_the_same_mesh(household, tmp_path):
    original = load_object(resolve_source(str(household / "can.obj"))[0], JobSpec())
    mesh = original.mesh
    assert signed_volume(mesh.vertices, mesh.faces) > 0  # the scan's 38 seam vertices welded, said so
    assert original.repairs == ("38 vertices split at UV seams or duplicated: welded (480 remain)",)
    inward = write_obj(tmp_path / "can_inward.obj", mesh.vertices, mesh.faces[:, ::-1])
    loaded = load_object(resolve_source(str(inward))[0], JobSpec())
    assert loaded.repairs == ("faces wound inwards (negative enclosed volume): flipped",)
    assert np.array_equal(loaded.mesh.faces, mesh.faces) and loaded.content_id == mesh.content_id  # same grasps


@pytest.mark.slow
def test_the_inward_copy_yields_the_originals_grasps(household, tmp_path):
    mesh = load_object(resolve_source(str(household / "can.obj"))[0], JobSpec()).mesh
    (tmp_path / "inward").mkdir()
    inward = write_obj(tmp_path / "inward" / "can.obj", mesh.vertices, mesh.faces[:, ::-1])
    spec = JobSpec(grasps_per_object=12, seed=3)
    first = extract_object(spec, resolve_source(str(household / "can.obj"))[0], 0, PartStore(tmp_path / "a"))
    second = extract_object(spec, resolve_source(str(inward))[0], 0, PartStore(tmp_path / "b"))
    assert first.grasps == second.grasps > 0 and not second.reused and "flipped" in second.repairs
    poses = [PartStore(tmp_path / p).read_array(r.part_key, "pose") for p, r in (("a", first), ("b", second))]
    assert np.array_equal(*poses)


def test_a_centimetre_copy_is_refused_with_the_units_that_fit_and_accepted_with_them(household, tmp_path):
    mesh = load_object(resolve_source(str(household / "milk.obj"))[0], JobSpec()).mesh
    copy = write_obj(tmp_path / "milk_cm.obj", mesh.vertices * 100, mesh.faces)
    ref = resolve_source(str(copy))[0]
    with pytest.raises(MeshRejected, match=r"looks like cm: set units: cm .*gives a 0\.1\d+ m diagonal"):
        load_object(ref, JobSpec())
    scaled = load_object(ref, JobSpec(units="cm")).mesh
    np.testing.assert_allclose(scaled.vertices, mesh.vertices, rtol=1e-12, atol=1e-12)
    assert load_object(ref, JobSpec(units="mm", scale=10)).mesh.extents == pytest.approx(mesh.extents)


def test_an_object_that_keeps_few_grasps_says_why(household, tmp_path):
    from onepiece_dist.job.results import ObjectPartMeta
    from onepiece_dist.job.stages.extract import shortfall

    spec = JobSpec(grasps_per_object=16, gripper={"max_opening": 0.03, "closing_width": 0.03,
                                                  "finger_thickness": 0.005},
                   voxel={"resolution": 0.005})  # a 3 cm gripper on a 16 cm cereal box
    result = extract_object(spec, resolve_source(str(household / "cereal.obj"))[0], 0, PartStore(tmp_path))
    assert result.status == "rejected" and "narrower than max_opening=0.03 m" in result.reason  # too wide
    counts = {"content_id": "c", "grasps": 2, "collisions": 40, "dropped_no_contact": 5, "empty_crops": 0,
              "candidates_tried": 60}
    assert shortfall(ObjectPartMeta.from_attrs(counts), 16) == (
        "2 of 16 grasps kept: 40 met the object with the open gripper while sampled; 5 closed on nothing (too wide, "
        "or the object slipped out)")
    assert shortfall(ObjectPartMeta.from_attrs({**counts, "grasps": 9}), 16) == ""


@pytest.fixture(scope="module")
def unseen():
    from benchmarks.experiments.household import UNSEEN, HouseholdUnavailable, household_objects

    try:
        return household_objects(objects=UNSEEN)
    except HouseholdUnavailable as err:
        pytest.skip(f"unseen household meshes unavailable: {err}")


def test_the_unseen_set_shares_no_mesh_with_the_household_set_and_each_loads(household, unseen):
    """Nothing chosen on the household set may be judged again on the unseen one: no mesh twice (LIBERO ships
    colour variants of one mesh under several names), each a graspable household size in metres."""
    job = JobSpec(objects=str(unseen), output="unused.zarr")
    seen = {load_object(ref, job).mesh.content_id: ref.name for ref in resolve_source(str(household))}
    loaded = {}
    for ref in resolve_source(str(unseen)):
        mesh = load_object(ref, job).mesh
        assert mesh.content_id not in seen and mesh.content_id not in loaded, ref.name
        loaded[mesh.content_id] = ref.name
        extents = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
        assert 0.015 < extents.min() and extents.max() < 0.2, (ref.name, extents)
    assert len(loaded) == 12
