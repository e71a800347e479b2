"""Grippers people own (issue 50): a gripper read from a URDF's finger links (pybullet_data's Franka Panda),
agreeing with the Panda preset where both come from the same geometry, refused with the file and the fix when the
URDF does not describe a parallel gripper, and simulated like any other."""

from __future__ import annotations

from pathlib import Path

import pytest

from onepiece_dist.errors import SpecError
from onepiece_dist.gripper.presets import PRESETS
from onepiece_dist.gripper.urdf import gripper_from_urdf
from onepiece_dist.specs.job import JobSpec


@pytest.fixture(scope="module")
def panda_urdf() -> Path:
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"


def test_the_pandas_urdf_gives_its_stroke_palm_and_fingers(panda_urdf):
    fields = gripper_from_urdf(panda_urdf)
    preset = PRESETS["panda"]
    assert fields["name"] == "panda" and fields["max_opening"] == pytest.approx(0.08)  # two 0-4 cm joints
    assert fields["palm_depth"] == pytest.approx(preset["palm_depth"])  # the finger joints' 5.84 cm offset
    assert fields["finger_length"] == pytest.approx(0.0537, abs=5e-4)  # collision/finger.obj along z
    assert fields["finger_height"] == pytest.approx(0.021, abs=5e-4) and fields["closing_force"] == 20.0
    assert (fields["closing_width"], fields["closing_depth"], fields["closing_height"]) == pytest.approx(
        (0.08, 0.05, 0.02))
    spec = JobSpec(gripper={"urdf": str(panda_urdf), "closing_force": 70.0})
    assert spec.gripper.name == "panda" and spec.gripper.closing_force == 70.0
    assert JobSpec.model_validate_json(spec.model_dump_json()) == spec  # a worker gets the fields, not the file


def test_a_urdf_that_is_not_a_parallel_gripper_is_refused_with_the_fix(tmp_path):
    arm = tmp_path / "arm.urdf"
    arm.write_text('<robot name="arm"><link name="base"/><link name="tool"/><joint name="j" type="revolute">'
                   '<parent link="base"/><child link="tool"/></joint></robot>')
    with pytest.raises(SpecError, match=r"arm\.urdf has 0 prismatic joints to links named '\*finger\*'"):
        gripper_from_urdf(arm)
    with pytest.raises(ValueError, match="arm.urdf"):
        JobSpec(gripper={"urdf": str(arm)})


def test_a_finger_mesh_outside_the_urdfs_folder_is_refused(tmp_path, panda_urdf):
    text = panda_urdf.read_text().replace("package://meshes/collision/finger.obj", "../../etc/finger.obj")
    (tmp_path / "hand").mkdir()
    copy = tmp_path / "hand" / "panda.urdf"
    copy.write_text(text)
    with pytest.raises(SpecError, match=r"'../../etc/finger.obj' is not a file under"):
        gripper_from_urdf(copy)


@pytest.mark.sim
def test_a_job_with_the_urdfs_gripper_grasps_a_box(panda_urdf, tmp_path):
    from onepiece_dist.job.stages.extract import extract_object
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.store import PartStore

    spec = JobSpec(gripper={"urdf": str(panda_urdf)}, grasps_per_object=8, output=str(tmp_path / "d.zarr"))
    ref = resolve_source("primitives[0:1]")[0]
    result = extract_object(spec, ref, 0, PartStore(tmp_path / "parts"))
    assert result.status == "ok" and result.grasps > 0, result.reason
