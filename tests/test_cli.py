import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from onepiece_dist.cli.main import app

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
    result = runner.invoke(app, ["run", str(spec), "--objects", "primitives[0:2]", "--out", str(out_path),
                                 "--in-process"])  # runs on an embedded Ray: test_service, and the test below
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


@pytest.mark.cluster  # rewrites the machine's cluster record: one at a time with the cluster tests
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


def test_version_prints_the_installed_package_version():
    from importlib.metadata import version

    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.stdout.strip() == f"onepiece-dist {version('onepiece-dist')}"


def test_the_exit_code_table_is_in_help_and_in_the_readme():
    from onepiece_dist.cli.common import EXIT_CODES

    help_text = " ".join(runner.invoke(app, ["--help"], terminal_width=400).output.split())
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    assert sorted(EXIT_CODES) == [0, 1, 2, 3, 4]  # a loop over no code would pass
    for code, meaning in EXIT_CODES.items():
        assert f"{code} {meaning}" in help_text
        assert f"| {code} | {meaning} |" in readme


def test_help_shows_the_spec_defaults_and_the_address_environment_variable():
    text = " ".join(runner.invoke(app, ["run", "--help"], terminal_width=400).output.split())
    assert "(default: 64)" in text and "(default: pybullet:named)" in text and "RAY_ADDRESS" in text


def test_run_json_prints_the_final_status_and_progress_lines_name_every_stage(tmp_path):
    out = tmp_path / "j.zarr"
    result = runner.invoke(app, ["run", "--objects", "primitives[0:2]", "--grasps", "8", "--in-process", "--json",
                                 "--stages", "ingest,extract,dedup,assemble", "--out", str(out)])
    assert result.exit_code == 0, result.output
    final = json.loads(result.stdout)
    assert final["state"] == "succeeded" and final["output"] == str(out)
    assert final["progress"]["unique_codes"] > 0
    for stage in ("ingest", "extract", "dedup", "assemble"):
        assert f": {stage} started" in result.stderr and f": {stage} done in" in result.stderr, stage
    assert "extract 2/2 objects" in result.stderr


def test_the_progress_bar_is_stopped_when_a_job_fails(monkeypatch):
    import io

    from onepiece_dist.cli.common import ProgressDisplay

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(sys, "stderr", Terminal())
    with pytest.raises(RuntimeError), ProgressDisplay() as display:
        assert display.bar is not None and display.bar.live.is_started
        raise RuntimeError("the job failed")
    assert not display.bar.live.is_started  # the cursor is shown again


def test_wait_on_a_path_without_a_status_exits_2(tmp_path):
    result = runner.invoke(app, ["wait", str(tmp_path / "nothing.zarr"), "--timeout", "5"])
    assert result.exit_code == 2 and "no job status at" in result.output


def write_running_status(path: Path, driver: str) -> None:
    from onepiece_dist.job.status import JobStatus

    JobStatus(job_id="job-x", state="running", stage="extract", output=str(path), driver=driver).save(path)


def test_wait_on_a_job_whose_driver_is_gone_exits_1_and_says_how_to_resume(tmp_path):
    import socket

    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    write_running_status(tmp_path / "d.zarr", f"{socket.gethostname()}:{ended.stdout.strip()}")
    result = runner.invoke(app, ["wait", str(tmp_path / "d.zarr"), "--timeout", "30"])
    assert result.exit_code == 1 and f"onepiece resume {tmp_path / 'd.zarr'}" in result.output


def test_wait_past_its_timeout_exits_4(tmp_path):
    import socket

    write_running_status(tmp_path / "d.zarr", f"{socket.gethostname()}:{os.getpid()}")  # alive: this process
    started = time.monotonic()
    result = runner.invoke(app, ["wait", str(tmp_path / "d.zarr"), "--timeout", "1"])
    assert result.exit_code == 4 and "still running" in result.output and time.monotonic() - started < 10


def test_cancel_and_logs_without_an_address_exit_2():
    for command in (["cancel", "job-x"], ["logs", "job-x"]):
        result = runner.invoke(app, command, env={"RAY_ADDRESS": ""})
        assert result.exit_code == 2 and "--address" in result.output, command


def test_submit_refuses_a_relative_output_before_contacting_the_cluster():
    result = runner.invoke(app, ["submit", "--address", "http://127.0.0.1:9", "--objects", "primitives[0:1]",
                                 "--out", "onepiece-out/dataset.zarr"])
    assert result.exit_code == 2 and "output" in result.output and "relative" in result.output


def test_run_refuses_a_jobs_api_url_from_the_environment():
    result = runner.invoke(app, ["run", "--objects", "primitives[0:1]"], env={"RAY_ADDRESS": "http://127.0.0.1:8265"})
    assert result.exit_code == 2 and "onepiece submit" in result.output


def test_a_failed_evaluation_exits_1_without_a_traceback(monkeypatch, tmp_path):
    from onepiece_dist import api
    from onepiece_dist.errors import JobError

    def failing(model, spec):
        raise JobError("job job-eval failed: the simulator crashed")  # the fault injected

    monkeypatch.setattr(api, "evaluate_model", failing)
    result = runner.invoke(app, ["evaluate", str(tmp_path / "best.pt"), "--objects", "primitives[0:1]"])
    assert result.exit_code == 1 and "evaluation failed" in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)


def test_a_submitted_drivers_log_ends_with_its_final_status_that_a_client_reads_and_a_user_never_sees(tmp_path):
    """`run --final-status` (what `submit` runs on a cluster) logs the job's final status, so a client reads a job
    that ended from its driver's log instead of starting a Ray job to ask the registry (api.Client.status)."""
    from onepiece_dist.api import read_status
    from onepiece_dist.job.status import JobStatus, without_status_lines

    out = tmp_path / "f.zarr"
    result = subprocess.run([sys.executable, "-m", "onepiece_dist.cli", "run", "--objects", "primitives[0:1]",
                             "--grasps", "4", "--stages", "ingest,extract,dedup", "--out", str(out), "--in-process",
                             "--final-status"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    log = result.stderr + result.stdout  # the Jobs API's log holds both
    logged = JobStatus.from_log(log)
    assert logged is not None and logged.state == "succeeded" and logged == read_status(out)
    shown = without_status_lines(log)
    assert logged.log_line() not in shown and shown.count("\n") == log.count("\n") - 1
    assert JobStatus.from_log(shown) is None  # a log without one: the client asks the registry instead
