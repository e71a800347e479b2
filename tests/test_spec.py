import json

import pytest
from pydantic import ValidationError

from onepiece_dist.errors import SpecError
from onepiece_dist.specs.job import GripperSpec, JobSpec, load_job_spec, parse_job_spec


def test_defaults_are_a_panda_like_hand_and_64_bit_codes():
    spec = JobSpec()
    assert spec.gripper.max_opening == pytest.approx(0.08)
    assert spec.grid_shape() == (4, 8, 2)
    assert spec.code_bytes() == 8


def test_specs_are_frozen_and_forbid_unknown_fields():
    spec = JobSpec()
    with pytest.raises(ValidationError):
        spec.seed = 3
    with pytest.raises(SpecError, match="grasp_per_object"):
        parse_job_spec({"grasp_per_object": 3})


def test_error_names_field_value_and_rule():
    with pytest.raises(SpecError) as info:
        parse_job_spec({"gripper": {"max_opening": -1.0}}, "job.yaml")
    text = str(info.value)
    assert "job.yaml" in text and "gripper.max_opening" in text and "-1.0" in text and "greater than 0" in text


def test_cross_field_error_names_both_fields():
    with pytest.raises(ValidationError, match="closing_width=0.1 must not exceed max_opening=0.08"):
        GripperSpec(closing_width=0.1)


def test_resolution_must_divide_the_closing_region():
    with pytest.raises(SpecError, match=r"voxel.resolution=0.03 must divide gripper.closing_depth"):
        parse_job_spec({"voxel": {"resolution": 0.03}})


def test_load_yaml_and_json(tmp_path):
    (tmp_path / "a.yaml").write_text("seed: 7\nvoxel:\n  resolution: 0.005\n")
    (tmp_path / "b.json").write_text(json.dumps({"seed": 7, "voxel": {"resolution": 0.005}}))
    a, b = load_job_spec(tmp_path / "a.yaml"), load_job_spec(tmp_path / "b.json")
    assert a == b and a.grid_shape() == (8, 16, 4)
    assert load_job_spec(tmp_path / "a.yaml", {"seed": 9}).seed == 9


def test_bad_files_are_spec_errors(tmp_path):
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(SpecError, match="must be a mapping"):
        load_job_spec(tmp_path / "list.yaml")
    with pytest.raises(SpecError, match="cannot read spec"):
        load_job_spec(tmp_path / "missing.yaml")


def test_result_key_ignores_paths_but_not_physics():
    base = JobSpec()
    assert base.result_key() == JobSpec(output="elsewhere.zarr").result_key()
    assert base.result_key() != JobSpec(seed=1).result_key()
    assert base.result_key() != JobSpec(gripper={"friction": 0.5}).result_key()
