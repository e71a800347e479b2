"""A job submitted to a local multi-node cluster, followed, cancelled and kept apart from embedded runs (a driver
killed mid-job then resumed: tests/test_resume.py)."""

import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

from onepiece_dist.api import Client, read_status
from onepiece_dist.job.status import JobStatus, status_path
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import open_dataset
from onepiece_dist.store.dataset import content_digest
from tests.factories import TINY_STUDY as TINY
from tests.factories import comparable_study as comparable
from tests.test_libm import DIFFERS_BY_BUILD

ROOT = Path(__file__).resolve().parents[1]
ONEPIECE = [sys.executable, "-m", "onepiece_dist.cli"]
SMALL = ["--objects", "primitives[0:8]", "--grasps", "64", "--stages", "ingest,extract,dedup"]
AGENT_PORT = 52300  # cluster/local_cluster.sh's first agent port (the head's; worker node i: + i)
SMALL_SPEC = JobSpec(objects="primitives[0:8]", grasps_per_object=64, stages=("ingest", "extract", "dedup"))


def wait_for(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}")










def objects_done(output: Path) -> int:
    try:
        return json.loads(status_path(output).read_text())["progress"]["objects_done"]
    except (OSError, ValueError, KeyError):
        return 0


def cluster_exposed_sockets() -> list:
    """Listening sockets of Ray processes (raylet, GCS, agents, workers) that are not on loopback."""
    ray_pids = {p.pid for p in psutil.process_iter(["name", "cmdline"])
                if p.info["name"] in ("raylet", "gcs_server") or "ray" in " ".join(p.info["cmdline"] or []).lower()}
    return [(c.laddr.ip, c.laddr.port) for c in psutil.net_connections(kind="inet")
            if c.status == psutil.CONN_LISTEN and c.pid in ray_pids
            and c.laddr.ip not in ("127.0.0.1", "::ffff:127.0.0.1", "::1")]


RAY_DEFAULT_AGENT_PORT = 52365  # what every embedded Ray's agent takes (ray.init has no switch for it)
EMBEDDED_RAY = ("from onepiece_dist.runtime.ray_env import connect; connect(None, num_cpus=1); "
                "print('up', flush=True); import sys; sys.stdin.read()")  # holds its Ray until stdin closes


def port_taken(port: int) -> bool:
    return any(c.laddr.port == port and c.status == psutil.CONN_LISTEN for c in psutil.net_connections("inet"))


@pytest.fixture(scope="module")
def local_cluster():
    """One local multi-node cluster for the module's tests, in file order: the node with an older CPU's paths joins
    late (the study and the picks train and run on the two nodes of this CPU), the node-removal test comes last. It
    starts while an embedded Ray runs on the machine, as a user's `onepiece run` may: the cluster must not need the
    agent port that Ray gives every embedded Ray (its head's Jobs API had no agent and refused every job)."""
    script = ROOT / "cluster" / "local_cluster.sh"
    embedded = subprocess.Popen([sys.executable, "-c", EMBEDDED_RAY], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                text=True)
    try:
        assert embedded.stdout.readline().strip() == "up"
        wait_for(lambda: port_taken(RAY_DEFAULT_AGENT_PORT), 60, "the embedded Ray's agent on Ray's default port")
        started = subprocess.run([str(script), "start", "2"], capture_output=True, text=True, timeout=240)
    finally:
        embedded.stdin.close()
        embedded.wait(timeout=120)
    assert started.returncode == 0, started.stderr[-3000:]
    try:
        yield started.stdout.strip().splitlines()[-1]
    finally:
        subprocess.run([str(script), "stop"], capture_output=True, timeout=120)


def onepiece(*args: str, cwd: Path, timeout: float = 180, background: bool = False):
    """The CLI as a user runs it, from ``cwd`` (another folder than the dataset's); ``background``: a Popen."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ.get('PATH', '')}"}
    if background:
        return subprocess.Popen([*ONEPIECE, *args], cwd=cwd, env=env, text=True, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE)
    return subprocess.run([*ONEPIECE, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.mark.cluster
@pytest.mark.slow
def test_a_job_on_the_local_multi_node_cluster_is_followed_from_another_folder(local_cluster, tmp_path,
                                                                               record_figure, monkeypatch):
    out, elsewhere, job = tmp_path / "cluster.zarr", tmp_path / "elsewhere", "cluster-follow"
    elsewhere.mkdir()
    address = ["--address", local_cluster]
    spec = elsewhere / "job.yaml"  # every stage; the voxel network (PointNet's 10 epochs cost ~30 s on one CPU) and
    spec.write_text("train:\n  model: voxel\n  epochs: 2\n"  # held-out primitives (4 random_urdfs: 12 of 30 s)
                    "evaluate:\n  objects: primitives[4:6]\n  grasps_per_object: 16\n")
    submitted = onepiece("submit", str(spec), *address, "--objects", "primitives[0:4]", "--grasps", "16", "--out",
                         str(out), "--job-id", job, "--wait", "--timeout", "300", cwd=elsewhere, background=True)
    wait_for(lambda: _stage_in_file(out), 180, "the job's first stage in its status file")  # no client per poll
    watched = wait_for(lambda: _running_status(job, address, elsewhere), 60, "the job's status from the registry")
    follow = onepiece("logs", job, *address, "--follow", cwd=elsewhere, background=True)
    stdout, stderr = submitted.communicate(timeout=360)
    assert submitted.returncode == 0 and stdout.strip() == job, stderr[-2000:]
    followed, _ = follow.communicate(timeout=120)
    assert follow.returncode == 0 and "extract 4/4 objects" in followed and f"job {job} succeeded" in followed
    status_path(out).rename(tmp_path / "moved.status.json")  # what the client reads next is the cluster's
    shown, listing = (onepiece(*command, *address, "--json", cwd=elsewhere, background=True)
                      for command in (("status", job), ("list",)))  # two clients at once
    final = json.loads(shown.communicate(timeout=120)[0])
    assert final["state"] == "succeeded" and final["progress"]["objects_done"] == 4 and len(final["nodes"]) >= 2
    client = Client(local_cluster)  # the job ended: its status is its driver's last log line, the registry's record
    assert JobStatus.model_validate(final) == JobStatus.model_validate(client.cluster_info()["jobs"][job])
    monkeypatch.setattr(Client, "cluster_info", lambda *a, **k: pytest.fail("asked the registry with a Ray job"))
    assert client.status(job) == JobStatus.model_validate(final)
    listed = {row["job_id"]: row for row in json.loads(listing.communicate(timeout=120)[0])}
    assert listed[job]["state"] == "succeeded" and listed[job]["objects_done"] == 4
    assert open_dataset(out).summary()["objects"] == 4
    assert cluster_exposed_sockets() == []
    assert onepiece("status", job, "--address", "http://127.0.0.1:9", cwd=elsewhere).returncode == 3
    record_figure(f"followed from another folder: status (registry) showed stage {watched['stage']!r}, logs "
                  f"--follow ended with the job, submit --wait exit 0; {len(final['nodes'])} nodes")


def _stage_in_file(out: Path) -> str | None:
    """The running job's stage as its status file beside the dataset says (each `onepiece status --address` asks
    the cluster with a short Ray job of its own: a few CPU-seconds a poll)."""
    path = status_path(out)
    status = json.loads(path.read_text()) if path.is_file() else {}
    return status.get("stage") if status.get("state") == "running" else None


def _running_status(job: str, address: list[str], cwd: Path) -> dict | None:
    shown = onepiece("status", job, *address, "--json", cwd=cwd, timeout=120)
    if shown.returncode != 0:
        return None  # not submitted yet
    status = json.loads(shown.stdout)
    return status if status["state"] == "running" and status["stage"] else None


@pytest.mark.cluster
@pytest.mark.slow
def test_cluster_commands_say_what_is_wrong_with_their_exit_codes(local_cluster, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from onepiece_dist.cli.main import app

    address = ["--address", local_cluster]
    missing = onepiece("wait", "job-nonexistent", *address, "--timeout", "5", cwd=tmp_path)
    assert missing.returncode == 2 and "no job job-nonexistent" in missing.stderr
    bad = ["--objects", "pybullet:nope", "--out", str(tmp_path / "bad.zarr"), "--job-id", "doomed"]
    first = onepiece("submit", *address, *bad, "--wait", cwd=tmp_path)
    assert first.returncode == 1, first.stderr[-2000:]
    again = onepiece("submit", *address, *bad, cwd=tmp_path)
    assert again.returncode == 0 and again.stdout.strip() == "doomed-2" and "submitted as doomed-2" in again.stderr
    assert onepiece("wait", "doomed-2", *address, "--timeout", "120", cwd=tmp_path).returncode == 1
    ended = onepiece("cancel", "doomed", *address, cwd=tmp_path)
    assert ended.returncode == 0 and "already ended (failed)" in ended.stderr
    monkeypatch.setattr("onepiece_dist.api.package_version", lambda: "9.9.9")
    other = CliRunner().invoke(app, ["submit", *address, "--objects", "primitives[0:1]", "--out",
                                     str(tmp_path / "v.zarr")])
    assert other.exit_code == 2 and "this client 9.9.9" in other.output


def driver_jobs(address: str) -> int:
    """How many drivers (jobs) the cluster at ``address`` has seen, leaving out our clients' registry readers
    (``onepiece-info-*``, whose entries outlive their deletion)."""
    return sum(not (job.submission_id or "").startswith("onepiece-info-")
               for job in Client(address).jobs_api().list_jobs())


@pytest.mark.cluster
@pytest.mark.slow
def test_an_embedded_run_never_joins_a_live_cluster_on_record(local_cluster, tmp_path, record_figure):
    """`ray start --head` put the local cluster on record (/tmp/ray/ray_current_cluster); a run without --address
    starts its own Ray all the same."""
    record = Path("/tmp/ray/ray_current_cluster")
    assert record.is_file() and record.read_text().strip().endswith(":6390")
    before = driver_jobs(local_cluster)
    started = time.monotonic()
    out = subprocess.run([*ONEPIECE, "run", "--objects", "primitives[0:1]", "--grasps", "4", "--stages",
                          "ingest,extract,dedup", "--out", str(tmp_path / "e.zarr")], capture_output=True, text=True,
                         timeout=180, env={**os.environ, "RAY_ADDRESS": ""})
    assert out.returncode == 0, out.stderr[-2000:]
    assert read_status(tmp_path / "e.zarr").state == "succeeded"
    assert driver_jobs(local_cluster) == before  # the cluster saw no new driver
    record_figure(f"live cluster on record: the run started its own Ray, the cluster saw 0 new drivers, "
                  f"{time.monotonic() - started:.1f} s")


@pytest.mark.cluster
@pytest.mark.slow
def test_stopping_one_local_cluster_leaves_another_running(local_cluster, record_figure):
    script = ROOT / "cluster" / "local_cluster.sh"
    other = {**os.environ, "ONEPIECE_RAY_PORT": "6395", "ONEPIECE_DASHBOARD_PORT": "8275",
             "ONEPIECE_AGENT_PORT": "52380"}
    ours, jobs_before = gcs_processes(6390), driver_jobs(local_cluster)
    started = subprocess.run([str(script), "start", "0"], capture_output=True, text=True, timeout=240, env=other)
    assert started.returncode == 0, started.stderr[-3000:]
    stopped = subprocess.run([str(script), "stop"], capture_output=True, text=True, timeout=120, env=other)
    assert stopped.returncode == 0, stopped.stderr[-2000:]
    assert not gcs_processes(6395)
    assert ours and gcs_processes(6390) == ours  # the same GCS process as before, not a new one
    assert driver_jobs(local_cluster) == jobs_before  # ours still answers, with every job it had
    record_figure(f"{stopped.stderr.strip().splitlines()[-1]}; the module's cluster still answers")


def gcs_processes(port: int) -> list[psutil.Process]:
    return [p for p in psutil.process_iter(["name", "cmdline"]) if p.info["name"] == "gcs_server"
            and f"--gcs_server_port={port}" in (p.info["cmdline"] or [])]


def worker_node_raylet(agent_port: int) -> psutil.Process:
    """The raylet of the local cluster's worker node whose agent listens on ``agent_port``."""
    for proc in psutil.process_iter(["name", "cmdline"]):
        if proc.info["name"] == "raylet" and f"--listen-port={agent_port}" in " ".join(proc.info["cmdline"] or []):
            return proc
    raise AssertionError(f"no raylet with agent port {agent_port}")


ON_CLUSTER = {**TINY, "budgets": [], "training": {**TINY["training"], "seeds": 1, "learning_rates": [1e-3]}}
"""The tiny study with one seed, one learning rate and no random arm of its own: each of its three jobs and three
training runs is still placed on the cluster's nodes (the tiny study's eight runs and probes cost about 40
CPU-seconds more here)."""


@pytest.mark.cluster
@pytest.mark.slow
def test_a_study_on_the_local_multi_node_cluster_gives_the_in_process_result(local_cluster, tmp_path,
                                                                             record_figure):
    """``onepiece study run --address``: every job's workers on the cluster's two worker nodes, the training runs
    on trainer actors there, and the same figures as the study run in process."""
    from onepiece_dist.study.runner import Where, run_study
    from onepiece_dist.study.spec import StudySpec

    study = tmp_path / "tiny.json"
    study.write_text(json.dumps(ON_CLUSTER))
    ran = onepiece("study", "run", str(study), "--address", "127.0.0.1:6390", "--out", str(tmp_path / "cluster"),
                   "--json", cwd=tmp_path, timeout=600)
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert "study: A: extract" in ran.stderr and "study: training" in ran.stderr  # progress per arm and stage
    on_cluster = json.loads(ran.stdout)
    nodes = {node for name in ("heldout", "A", "B-r0") for node in
             read_status(tmp_path / "cluster" / "jobs" / f"{name}.zarr").nodes}
    assert len(nodes) >= 2, nodes  # the worker nodes shared the extraction (an earlier test may add a third)
    here = run_study(StudySpec(**ON_CLUSTER), tmp_path / "here", Where(in_process=True))
    assert comparable(on_cluster) == comparable(json.loads(here.model_dump_json()))
    record_figure(f"study on 2 worker nodes in {on_cluster['wall_seconds']:.0f} s: {len(on_cluster['arms'])} arms, "
                  "the in-process figures")


@pytest.mark.cluster
@pytest.mark.slow
def test_the_pick_benchmark_on_the_local_multi_node_cluster_gives_the_in_process_picks(local_cluster, tmp_path,
                                                                                        record_figure):
    """``onepiece pick --address``: one task per object on the cluster's worker nodes, the same picks as in
    process."""
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec
    from tests.test_picks import SMALL
    from tests.test_plan import save_checkpoint

    checkpoint = save_checkpoint(tmp_path / "net.pt")
    ran = onepiece("pick", str(checkpoint), "--objects", SMALL["objects"], "--views", "2", "--attempts", "2",
                   "--out", str(tmp_path / "cluster"), "--address", "127.0.0.1:6390", "--json",
                   "--spec", str(_pick_spec_file(tmp_path)), cwd=tmp_path, timeout=600)
    assert ran.returncode == 0, ran.stderr[-3000:]
    on_cluster = json.loads(ran.stdout)
    here = run_picks(PickSpec(**{**SMALL, "pictures": 0}, checkpoint=str(checkpoint), output=str(tmp_path / "here")),
                     in_process=True)
    assert [o["views"] for o in on_cluster["objects"]] == [json.loads(json.dumps(o))["views"]
                                                          for o in here.to_json()["objects"]]
    nodes = {o["node"] for o in on_cluster["objects"]}
    assert all(nodes) and len(nodes) >= 1
    record_figure(f"picks on the cluster: {len(on_cluster['objects'])} objects on {len(nodes)} worker node(s), "
                  "the in-process picks")


def _pick_spec_file(folder: Path) -> Path:
    from tests.test_picks import SMALL

    path = folder / "pick.json"
    path.write_text(json.dumps({key: value for key, value in SMALL.items() if key in ("mesh_candidates", "plan",
                                                                                       "sim")} | {"pictures": 0}))
    return path


OLDEST_CPU = {"OPENBLAS_CORETYPE": "Prescott", "NPY_DISABLE_CPU_FEATURES": "X86_V3",
              "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


@pytest.mark.cluster
@pytest.mark.slow
@pytest.mark.sim
@pytest.mark.skipif(platform.machine() != "x86_64", reason="the older CPU paths forced on one node are x86-64 ones")
def test_a_job_whose_nodes_take_other_cpu_paths_gives_the_in_process_dataset(local_cluster, tmp_path, record_figure,
                                                                             fault_free):
    """A third worker node started with an older CPU's BLAS kernel, numpy SIMD level, glibc variants and one
    thread, beside two nodes on this CPU's own: the job, every stage to label, holds the same content as in
    process (Ray's workers inherit their node's environment)."""
    from tests.test_pinned_job import pinned_spec

    script = ROOT / "cluster" / "local_cluster.sh"
    added = subprocess.run([str(script), "add", "3"], capture_output=True, text=True, timeout=240,
                           env={**os.environ, **OLDEST_CPU})
    assert added.returncode == 0, added.stderr[-3000:]
    older = worker_node_raylet(AGENT_PORT + 3)
    assert all(older.environ().get(k) == v for k, v in OLDEST_CPU.items())
    older_id = next(arg.split("=", 1)[1] for arg in older.cmdline() if arg.startswith("--node_id="))
    spec = pinned_spec(tmp_path / "local.zarr").model_copy(update={"objects": PINNED_ON_CLUSTER})
    spec_file, out = tmp_path / "job.json", tmp_path / "cluster.zarr"
    spec_file.write_text(spec.model_dump_json(exclude={"output"}))
    submitted = onepiece("submit", str(spec_file), "--address", local_cluster, "--out", str(out), "--wait", "--json",
                         "--timeout", "400", cwd=tmp_path, timeout=460)
    assert submitted.returncode == 0, submitted.stderr[-3000:]
    final = json.loads(submitted.stdout)
    nodes = final["nodes"]
    assert final["state"] == "succeeded", final
    assert older_id in nodes, (older_id, nodes)  # the older-CPU node extracted some of the objects
    assert content_digest(out, training=False) == content_digest(fault_free(spec), training=False)
    record_figure(f"{len(set(nodes))} worker nodes extracted, one with {', '.join(OLDEST_CPU)}: the same "
                  f"content digest as in process ({content_digest(out, training=False)[:12]})")


PINNED_ON_CLUSTER = DIFFERS_BY_BUILD  # enough objects for every node to get one; the same in-process run as libm's


@pytest.mark.cluster
@pytest.mark.slow
def test_removing_a_worker_node_mid_job_still_succeeds(local_cluster, tmp_path, fault_free, record_figure):
    out = tmp_path / "lost_node.zarr"
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ.get('PATH', '')}"}
    submitted = subprocess.run([*ONEPIECE, "submit", "--address", local_cluster, *SMALL, "--out", str(out)],
                               capture_output=True, text=True, timeout=120, env=env)
    assert submitted.returncode == 0, submitted.stderr[-2000:]
    wait_for(lambda: objects_done(out) >= 1, 180, "a first object")
    done_at_kill = objects_done(out)
    worker_node_raylet(AGENT_PORT + 2).kill()  # the node is gone, with the worker actor on it
    waited = subprocess.run([*ONEPIECE, "wait", submitted.stdout.strip(), "--address", local_cluster, "--json",
                             "--timeout", "300"], capture_output=True, text=True, timeout=360, env=env)
    assert waited.returncode == 0, waited.stderr[-2000:]
    status = json.loads(waited.stdout)
    assert status["state"] == "succeeded" and status["progress"]["objects_done"] == 8 and done_at_kill < 8
    for name in ("grasps/code", "unique/code", "unique/count"):
        assert np.array_equal(open_dataset(out)[name], open_dataset(fault_free(SMALL_SPEC))[name]), name
    record_figure(f"raylet of 1 of 2 worker nodes SIGKILLed after {done_at_kill} of 8 objects; job succeeded, "
                  f"{status['retries']} re-runs, identical codes")
