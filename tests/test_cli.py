import json

from typer.testing import CliRunner

from onepiece_dist.cli import app

runner = CliRunner()


def test_help_lists_commands():
    out = runner.invoke(app, ["--help"])
    assert out.exit_code == 0
    for command in ("run", "inspect", "schema"):
        assert command in out.output


def test_run_writes_a_dataset_and_prints_its_path(tmp_path):
    spec = tmp_path / "job.yaml"
    spec.write_text("grasps_per_object: 12\nsampler:\n  surface_points: 2000\nstages: [ingest, extract, dedup]\n")
    out_path = tmp_path / "d.zarr"
    result = runner.invoke(app, ["run", str(spec), "--objects", "primitives[0:2]", "--out", str(out_path)])
    assert result.exit_code == 0, result.output
    assert result.stdout.strip().splitlines()[-1] == str(out_path)
    summary = json.loads(runner.invoke(app, ["inspect", str(out_path), "--json"]).stdout)
    assert summary["objects"] == 2 and summary["grasps"] > 0 and 0 < summary["unique_fraction"] <= 1


def test_bad_spec_exits_2_and_names_the_field(tmp_path):
    spec = tmp_path / "job.yaml"
    spec.write_text("voxel:\n  resolution: -1\n")
    result = runner.invoke(app, ["run", str(spec)])
    assert result.exit_code == 2
    assert "voxel.resolution" in result.output


def test_unknown_source_exits_2(tmp_path):
    result = runner.invoke(app, ["run", "--objects", "pybullet:nope", "--out", str(tmp_path / "x.zarr")])
    assert result.exit_code == 2 and "unknown built-in set" in result.output
