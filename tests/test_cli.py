import json
import os
import time

import pytest
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


def test_run_with_an_address_that_does_not_answer_fails_within_seconds_naming_it(tmp_path, record_figure):
    import time

    start = time.monotonic()
    result = CliRunner().invoke(app, ["run", "--objects", "primitives[0:1]", "--address", "127.0.0.1:1",
                                      "--out", str(tmp_path / "x.zarr")])
    assert result.exit_code == 3 and "127.0.0.1:1" in result.output
    assert time.monotonic() - start < 20
    record_figure(f"exit 3 in {time.monotonic() - start:.1f} s, naming the address")


@pytest.mark.ray
@pytest.mark.slow
def test_embedded_runs_start_their_own_ray_even_with_a_dead_cluster_on_record(tmp_path, record_figure):
    """A cluster that died without `ray stop` leaves its address in Ray's temp folder; an embedded run must not
    try to join it (it used to hang for minutes on GCS time-outs)."""
    import subprocess
    import sys
    from pathlib import Path

    record = Path("/tmp/ray/ray_current_cluster")
    saved = record.read_text() if record.is_file() else None
    record.parent.mkdir(parents=True, exist_ok=True)
    record.write_text("127.0.0.1:1")
    started = time.monotonic()
    try:
        out = subprocess.run([sys.executable, "-m", "onepiece_dist.cli", "run", "--objects", "primitives[0:1]",
                              "--grasps", "4", "--stages", "ingest,extract,dedup", "--out", str(tmp_path / "e.zarr")],
                             capture_output=True, text=True, timeout=180, env={**os.environ, "RAY_ADDRESS": ""})
    finally:
        record.write_text(saved) if saved is not None else record.unlink(missing_ok=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().endswith("e.zarr")
    elapsed = time.monotonic() - started
    record_figure(f"dead cluster on record: the run started its own Ray and finished in {elapsed:.1f} s")
