import json
import os
import sys

import numpy as np
import pytest

from onepiece_dist.errors import SourceError
from onepiece_dist.job.stages.extract import extract_object
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore
from tests.factories import box_obj_text, broken_inputs_folder, urdf_text


@pytest.fixture
def broken(tmp_path):
    root, outside = tmp_path / "inputs", tmp_path / "outside"
    return root, outside, broken_inputs_folder(root, outside)


class OpenAudit:
    """Records every file path opened while active (sys.addaudithook cannot be removed, so it gates)."""

    installed = False
    active: list | None = None

    @classmethod
    def record(cls):
        if not cls.installed:
            sys.addaudithook(lambda event, args: cls.active is not None and event == "open"
                             and isinstance(args[0], str | bytes) and cls.active.append(os.fsdecode(args[0])))
            cls.installed = True
        cls.active = []
        return cls

    @classmethod
    def stop(cls):
        opened, cls.active = cls.active, None
        return opened


def test_each_bad_file_is_rejected_with_its_reason_and_good_files_proceed(broken, tmp_path, record_figure):
    root, outside, expected = broken
    spec = JobSpec(objects=str(root), grasps_per_object=8, sampler={"surface_points": 1000}, max_file_bytes=20_000,
                   sim={"physics": False})
    refs = resolve_source(spec.objects)
    assert sorted(r.name for r in refs) == sorted(expected)
    parts = PartStore(tmp_path / "parts")
    OpenAudit.record()
    try:
        results = {r.name: extract_object(spec, r, i, parts) for i, r in enumerate(refs)}
    finally:
        opened = OpenAudit.stop()
    for name, outcome in expected.items():
        result = results[name]
        if outcome == "ok":
            assert result.status == "ok" and result.grasps > 0, name
        else:
            assert result.status == "rejected", name
            assert outcome in result.reason, (name, result.reason)
    real_outside = os.path.realpath(outside)
    assert not [p for p in opened if os.path.realpath(p).startswith(real_outside)]
    record_figure(f"{sum(o != 'ok' for o in expected.values())} hostile files, one rejection each with its reason; "
                  f"{sum(o == 'ok' for o in expected.values())} good ones extracted; 0 opens outside the root")


def test_pybullet_sets_resolve_and_load():
    spec = JobSpec()
    named = resolve_source("pybullet:named")
    assert {"duck", "teddy", "mug", "bunny"} <= {r.name for r in named}
    randoms = resolve_source("pybullet:random_urdfs[0:3]")
    assert [r.name for r in randoms] == ["random_urdfs/000", "random_urdfs/001", "random_urdfs/002"]
    duck = load_object(named[[r.name for r in named].index("duck")], spec)
    assert 0.04 < duck.mesh.extents.max() < 0.12  # the URDF's 0.05 scale was applied


def test_content_id_depends_on_geometry_and_scale(tmp_path):
    (tmp_path / "a.obj").write_text(box_obj_text(0.04))
    (tmp_path / "b.obj").write_text(box_obj_text(0.04))
    (tmp_path / "c.obj").write_text(box_obj_text(0.05))
    spec = JobSpec()
    ids = [load_object(r, spec).content_id for r in resolve_source(str(tmp_path))]
    assert ids[0] == ids[1] != ids[2]


def test_glob_source_and_unknown_sources(tmp_path):
    (tmp_path / "a.obj").write_text(box_obj_text())
    (tmp_path / "b.stl").write_text("solid x\nendsolid x\n")
    assert [r.name for r in resolve_source(str(tmp_path / "*.obj"))] == ["a.obj"]
    with pytest.raises(SourceError, match="unknown built-in set"):
        resolve_source("pybullet:nothing")
    with pytest.raises(SourceError, match="neither"):
        resolve_source(str(tmp_path / "missing"))


def test_primitive_set_is_graspable():
    spec = JobSpec()
    refs = resolve_source("primitives")
    assert len(refs) == 8  # the loop below checks something
    for ref in refs:
        mesh = load_object(ref, spec).mesh
        assert np.isfinite(mesh.vertices).all() and len(mesh.faces) >= 12


def test_ros_package_paths_resolve_through_the_package_map_inside_the_input_root(tmp_path):
    root, outside = tmp_path / "inputs", tmp_path / "outside"
    (root / "pkgs" / "widget" / "meshes").mkdir(parents=True)
    outside.mkdir()
    (root / "pkgs" / "widget" / "meshes" / "box.obj").write_text(box_obj_text())
    (outside / "secret.obj").write_text(box_obj_text())
    (root / "onepiece_packages.json").write_text(json.dumps({"widget": "pkgs/widget", "leak": "../outside"}))
    single_quoted = urdf_text("package://widget/meshes/box.obj").replace('"', "'")
    for name, text in {"robot/good.urdf": single_quoted, "robot/unmapped.urdf": urdf_text("package://ros/x.obj"),
                       "robot/leaky.urdf": urdf_text("package://leak/secret.obj")}.items():
        (root / name).parent.mkdir(exist_ok=True)
        (root / name).write_text(text)
    os.environ["ROS_PACKAGE_PATH"] = str(outside)  # never consulted
    try:
        refs = resolve_source(str(root))
        # the mesh the URDF claims (single-quoted attribute) is not listed again; the map is not an object
        assert sorted(r.name for r in refs) == ["robot/good.urdf", "robot/leaky.urdf", "robot/unmapped.urdf"]
        spec = JobSpec(grasps_per_object=8, sampler={"surface_points": 1000}, sim={"physics": False})
        OpenAudit.record()
        try:
            results = {r.name: extract_object(spec, r, i, PartStore(tmp_path / "parts")) for i, r in enumerate(refs)}
        finally:
            opened = OpenAudit.stop()
    finally:
        del os.environ["ROS_PACKAGE_PATH"]
    assert results["robot/good.urdf"].status == "ok"
    assert "package 'ros'" in results["robot/unmapped.urdf"].reason and "does not map" in results[
        "robot/unmapped.urdf"].reason
    assert "'..'" in results["robot/leaky.urdf"].reason
    assert not [p for p in opened if os.path.realpath(p).startswith(os.path.realpath(outside))]


def test_a_folder_manifest_gives_units_scale_mass_and_friction_per_object(tmp_path):
    import pybullet as pb

    from onepiece_dist.core.mesh import box_mesh
    from onepiece_dist.job.stages.extract import extract_object
    from onepiece_dist.store import PartStore

    box = box_mesh((4.0, 3.0, 6.0))  # centimetres
    for name in ("a.obj", "b.obj"):
        (tmp_path / name).write_text("".join(f"v {x} {y} {z}\n" for x, y, z in box.vertices)
                                     + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in box.faces))
    (tmp_path / "objects.yaml").write_text("units: cm\nobjects:\n  b.obj: {scale: 0.5, mass: 0.3, friction: 0.7}\n")
    a, b = resolve_source(str(tmp_path))  # the manifest itself is no object
    spec = JobSpec(units="mm", grasps_per_object=8)  # the manifest's units win for its folder
    loaded_a, loaded_b = load_object(a, spec), load_object(b, spec)
    assert np.allclose(loaded_a.mesh.extents, [0.04, 0.03, 0.06]) and np.allclose(loaded_b.mesh.extents,
                                                                                   [0.02, 0.015, 0.03])
    twin = load_object(b.__class__(**{**b.__dict__, "mass": None, "friction": None}), spec)
    assert loaded_b.content_id != twin.content_id == twin.mesh.content_id  # other physics: another object
    result = extract_object(spec, b, 0, PartStore(tmp_path / "parts"))
    meta = PartStore(tmp_path / "parts").read_meta(result.part_key)
    assert meta["density"] == pytest.approx(0.3 / meta["volume"]) and meta["friction"] == 0.7
    from onepiece_dist.sim.world import process_world

    world = process_world(spec.gripper)
    assert pb.getDynamicsInfo(world.obj, -1, physicsClientId=world.client)[1] == pytest.approx(0.7)


@pytest.mark.parametrize("manifest, reason", [
    ("objects:\n  missing.obj: {scale: 2}\n", "names 'missing.obj', which is not a file"),
    ("objects:\n  a.obj: {colour: red}\n", "objects.a.obj: give a mapping of scale, mass, density, friction"),
    ("objects:\n  a.obj: {mass: 1, density: 300}\n", "mass or density, not both"),
    ("units: inch\n", "units='inch': give m, cm or mm"),
    ("objects:\n  a.obj: {scale: -1}\n", "a positive number"),
])
def test_a_bad_manifest_is_refused_naming_itself_and_the_fix(tmp_path, manifest, reason):
    from onepiece_dist.errors import SourceError

    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "objects.yaml").write_text(manifest)
    with pytest.raises(SourceError, match=reason) as refused:
        resolve_source(str(tmp_path))
    assert "objects.yaml" in str(refused.value)
