"""The Ray service: registry, central dedup, API and CLI on an embedded Ray, worker faults, quarantine."""

import os
import re
import signal
import time
from pathlib import Path

import psutil
import pytest
from typer.testing import CliRunner

from onepiece_dist.api import Client, read_status
from onepiece_dist.cli.main import app
from onepiece_dist.job.status import JobStatus
from onepiece_dist.objects import resolve_source
from onepiece_dist.runtime.local import run_local
from onepiece_dist.runtime.registry import JobRegistry
from onepiece_dist.runtime.writer import DatasetWriter
from onepiece_dist.specs.job import default_job_id
from onepiece_dist.store import PartStore, open_dataset
from onepiece_dist.store.dataset import content_digest
from tests.factories import objects_done_at_least


def assert_same_dataset(a: str, b: str) -> None:
    """Every array and content attribute equal (training left out: its float sums depend on thread counts)."""
    assert content_digest(a, training=False) == content_digest(b, training=False)


def job_spec(spec_factory, tmp_path, name, objects="primitives[0:8]", grasps=64):
    return spec_factory(objects=objects, grasps_per_object=grasps, output=str(tmp_path / f"{name}.zarr"))


def test_registry_claims_a_job_id_once_while_it_runs():
    reg = JobRegistry()
    assert reg.claim("j", {"state": "running"}) is True
    assert reg.claim("j", {"state": "running"}) is False
    reg.update("j", {"state": "succeeded"})
    assert reg.claim("j", {"state": "running"}) is True
    assert reg.request_cancel("j") and reg.cancel_requested("j") and not reg.request_cancel("other")


def test_central_dedup_state_is_rebuilt_from_the_store(spec_factory, tmp_path, record_figure):
    spec = job_spec(spec_factory, tmp_path, "ref", grasps=16)
    reference = run_local(spec)
    from onepiece_dist.job.stages.extract import extract_object

    parts = PartStore(spec.parts_folder())
    results = [extract_object(spec, ref, i, parts) for i, ref in enumerate(resolve_source(spec.objects))]
    fresh = spec.model_copy(update={"output": str(tmp_path / "rebuilt.zarr"), "cache_dir": spec.parts_folder()})
    central = DatasetWriter(fresh)
    central.add(results[0].index, results[0].part_key)  # merged before a "restart"
    summary = DatasetWriter(fresh).commit(results)  # a restarted actor starts empty and folds in every part
    assert summary.unique_codes == reference.progress.unique_codes
    assert_same_dataset(spec.output, fresh.output)
    record_figure(f"{summary.unique_codes} unique codes rebuilt from the parts, identical dataset")


@pytest.mark.ray
@pytest.mark.slow
def test_api_and_cli_run_a_small_job_on_embedded_ray(ray_session, spec_factory, tmp_path, fault_free):
    spec = job_spec(spec_factory, tmp_path, "api")
    handle = Client().submit(spec)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded" and final.progress.objects_done == 8 and final.progress.grasps > 0
    assert read_status(spec.output).state == "succeeded"
    assert_same_dataset(spec.output, fault_free(spec))
    out = CliRunner().invoke(app, ["run", "--objects", "primitives[0:2]", "--grasps", "16",
                                   "--stages", "ingest,extract,dedup,assemble", "--out", str(tmp_path / "cli.zarr")])
    assert out.exit_code == 0, out.output
    written = open_dataset(tmp_path / "cli.zarr")
    assert written.summary()["objects"] == 2 and written.summary()["unique_codes"] > 0
    assert written.has("assembled/vertices")  # the one object


@pytest.mark.ray
@pytest.mark.slow
def test_killing_a_worker_mid_job_gives_the_fault_free_dataset(ray_session, spec_factory, tmp_path, fault_free,
                                                               record_figure):
    ray = ray_session
    spec = job_spec(spec_factory, tmp_path, "faulty")
    job_id = default_job_id(spec)
    client = Client()
    handle = client.submit(spec)
    objects_done_at_least(client, job_id, 1)
    started = time.monotonic()
    ray.kill(ray.get_actor(f"sim-{job_id}-0", namespace="onepiece"), no_restart=False)
    final = handle.wait(timeout=300)
    done_s = time.monotonic() - started
    assert final.state == "succeeded" and final.retries >= 1 and done_s < 120
    assert_same_dataset(spec.output, fault_free(spec))
    assert final.progress.grasps == open_dataset(spec.output).summary()["grasps"]  # no grasp stored twice
    record_figure(f"1 kill, {final.retries} re-runs, dataset identical, job done {done_s:.1f} s after the kill")


class PoisonWorker:
    """A simulation worker with one poison object: it segfaults the worker process (as a malformed mesh can make
    pybullet do), or, with ``kills``, the process is SIGKILLed (as from outside) its first ``kills`` times on it."""

    def __init__(self, spec, poison: str, crashes: str, kills: int = 0, counter: str = ""):
        from onepiece_dist.runtime.ray_runner import SimWorker

        self.inner, self.poison, self.kills, self.counter = SimWorker(spec, crashes=crashes), poison, kills, counter

    def extract(self, ref, index):
        self.inner.starting("extract", index)
        if ref.name == self.poison and not self.kills:
            os.kill(os.getpid(), signal.SIGSEGV)
        if ref.name == self.poison:
            counter = Path(self.counter)
            done = int(counter.read_text()) if counter.exists() else 0
            if done < self.kills:
                counter.write_text(str(done + 1))
                os.kill(os.getpid(), signal.SIGKILL)
        return self.inner.extract(ref, index)


class _RecordedCall:
    def __init__(self, log: list, name: str):
        self.log, self.name = log, name

    def remote(self, *args):
        self.log.append((self.name, args))
        return object()  # a distinct handle per call, as an ObjectRef is


class RecordingActor:
    """Stands in for an actor handle: every ``handle.method.remote(...)`` is recorded (no Ray)."""

    def __init__(self):
        self.log: list = []

    def __getattr__(self, name: str) -> _RecordedCall:
        return _RecordedCall(self.log, name)


def test_the_last_items_go_only_to_idle_workers():
    from collections import deque

    from onepiece_dist.runtime.ray_runner import IN_FLIGHT_PER_WORKER, WorkerPool

    actors = [RecordingActor(), RecordingActor()]
    pool = WorkerPool(actors, registry=None, status=None, on_result=lambda result: None)
    pool.ready = {0, 1}
    todo = deque(enumerate("abcdef"))
    pool._fill(todo)  # plenty left: each worker gets IN_FLIGHT_PER_WORKER, the last two wait here
    assert len(pool.pending) == 2 * IN_FLIGHT_PER_WORKER and [i for i, _ in todo] == [4, 5]

    def finish_one_of(position: int) -> None:
        handle = next(h for h, (_, _, p, _) in pool.pending.items() if p == position)
        del pool.pending[handle]

    finish_one_of(0)
    pool._fill(todo)  # worker 0 still runs one: no second item queued behind it while worker 1 may free up
    assert [i for i, _ in todo] == [4, 5]
    finish_one_of(0)
    pool._fill(todo)
    assert [i for i, _ in todo] == [5] and actors[0].log[-1] == ("extract", ("e", 4))


def run_poison_pool(ray, spec, job_id: str, **poison) -> tuple[list, JobStatus]:
    from onepiece_dist.runtime.crashes import crash_folder
    from onepiece_dist.runtime.ray_runner import WorkerPool
    from onepiece_dist.runtime.registry import RegistryClient

    refs = resolve_source(spec.objects)
    crashes = crash_folder(spec.parts_folder(), job_id)
    actor = ray.remote(PoisonWorker).options(max_restarts=-1, max_task_retries=0, num_cpus=1)
    workers = [actor.remote(spec, refs[1].name, str(crashes), **poison) for _ in range(2)]
    status = JobStatus(job_id=job_id, output=spec.output)
    registry = RegistryClient()
    registry.claim(job_id, status.model_dump(mode="json"))
    try:
        return WorkerPool(workers, registry, status, lambda result: None, crashes=crashes).run(refs), status
    finally:
        for worker in workers:
            ray.kill(worker)


@pytest.mark.ray
@pytest.mark.slow
def test_a_poison_object_is_quarantined_and_the_rest_proceeds(ray_session, spec_factory, tmp_path, record_figure):
    from onepiece_dist.runtime.ray_runner import MAX_CRASHES

    spec = job_spec(spec_factory, tmp_path, "poison", objects="primitives[0:3]", grasps=8)
    results, status = run_poison_pool(ray_session, spec, "poison-test")
    assert [r.status for r in results] == ["ok", "rejected", "ok"]
    assert f"crashed its worker {MAX_CRASHES} times" in results[1].reason and status.retries >= MAX_CRASHES
    record_figure(f"poison (SIGSEGV) quarantined after {MAX_CRASHES} crashes alone ({status.retries} re-runs); 2 of 2 "
                  "others ok")


@pytest.mark.ray
@pytest.mark.slow
def test_an_object_whose_worker_is_killed_from_outside_is_not_taken_for_a_poison(ray_session, spec_factory,
                                                                                   tmp_path, record_figure):
    from onepiece_dist.runtime.ray_runner import MAX_CRASHES

    spec = job_spec(spec_factory, tmp_path, "killed", objects="primitives[0:3]", grasps=8)
    results, status = run_poison_pool(ray_session, spec, "killed-test", kills=MAX_CRASHES + 1,
                                      counter=str(tmp_path / "kills"))
    assert [r.status for r in results] == ["ok", "ok", "ok"]  # SIGKILLs leave no crash record
    assert status.retries >= MAX_CRASHES + 1
    record_figure(f"worker SIGKILLed {MAX_CRASHES + 1} times on one object ({status.retries} re-runs): 3 of 3 objects "
                  "ok, none quarantined")


@pytest.mark.ray
def test_every_socket_of_our_ray_is_on_loopback(ray_session, record_figure):
    from onepiece_dist.runtime.ray_env import TOKEN_FILE

    ours = {p.pid for p in psutil.Process().children(recursive=True)}
    listening = [c for c in psutil.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN and c.pid in ours]
    assert listening, "expected Ray's servers among this process's children"
    exposed = [(c.laddr.ip, c.laddr.port) for c in listening if c.laddr.ip not in ("127.0.0.1", "::ffff:127.0.0.1",
                                                                                  "::1")]
    assert exposed == []
    assert TOKEN_FILE.stat().st_mode & 0o077 == 0  # made before Ray started (ensure_token_file), owner-only
    record_figure(f"{len(listening)} listening sockets, {len(exposed)} beyond loopback")


def _token_at_the_barrier(path: str, barrier) -> str:
    """``ensure_token_file`` in a process of its own, all starting together, each slow to make its token (the
    fault: a wide window between finding no token and having written one)."""
    import secrets

    from onepiece_dist.runtime.ray_env import ensure_token_file

    make = secrets.token_hex
    secrets.token_hex = lambda nbytes: (time.sleep(0.2), make(nbytes))[1]
    barrier.wait()
    return ensure_token_file(Path(path))


RACERS = 4  # each a spawned interpreter importing this module (about 1.5 CPU-s): eight cost 12 CPU-s a run


def test_processes_making_the_token_at_once_all_get_the_one_token_that_stays(tmp_path):
    """Ray writes a missing token non-atomically: two Rays starting at once on a fresh machine each wrote theirs,
    and one Ray's workers read the other's. Four processes racing for it here (more than a 2-core machine runs
    at once) must agree on one."""
    import multiprocessing

    from onepiece_dist.runtime.ray_env import ensure_token_file

    path = tmp_path / ".ray" / "auth_token"
    context = multiprocessing.get_context("spawn")
    barrier = context.Manager().Barrier(RACERS)
    with context.Pool(RACERS) as pool:
        tokens = pool.starmap(_token_at_the_barrier, [(str(path), barrier)] * RACERS)
    assert len(set(tokens)) == 1 and path.read_text() == tokens[0]
    assert re.fullmatch("[0-9a-f]{64}", tokens[0])  # 256 bits as lowercase hex, Ray's format
    assert path.stat().st_mode & 0o777 == 0o600
    assert [p.name for p in path.parent.iterdir()] == ["auth_token"]  # no draft left behind
    path.write_text("kept")
    assert ensure_token_file(path) == "kept"  # an existing token is never replaced


@pytest.mark.ray
def test_our_ray_declares_a_dead_node_dead_within_seconds(ray_session):
    """The GCS checks each node every second (Ray's default, 3 s, took 15 s to declare a killed node dead)."""
    from ray._raylet import Config

    from onepiece_dist.runtime.ray_env import HEALTH_CHECK_PERIOD_MS

    period_s, failures = Config.health_check_period_ms() / 1000, Config.health_check_failure_threshold()
    assert period_s == HEALTH_CHECK_PERIOD_MS / 1000 and period_s * failures <= 5


@pytest.mark.ray
def test_an_embedded_ray_starts_in_a_process_that_first_talked_to_a_cluster(tmp_path):
    """Ray reads its auth mode once per process: a cluster call (which sets token auth) before an embedded run
    used to leave a GCS that asks for tokens and a driver that sends none (InvalidAuthToken, then a failed start)."""
    import subprocess
    import sys

    script = ("import ray\nfrom typer.testing import CliRunner\nfrom onepiece_dist.cli.main import app\n"
              "from onepiece_dist.runtime.ray_env import connect\n"
              f"out = {str(tmp_path / 'x.zarr')!r}\n"
              "first = CliRunner().invoke(app, ['run', '--address', '127.0.0.1:9', '--out', out])\n"
              "assert first.exit_code == 3, first.output\n"
              "connect(None, num_cpus=1)\nprint(ray.get(ray.remote(lambda: 7).remote()))\nray.shutdown()\n")
    env = {k: v for k, v in os.environ.items() if k not in ("RAY_AUTH_MODE", "RAY_ADDRESS")}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0 and done.stdout.strip() == "7", done.stderr[-2000:]


def test_each_later_stage_runs_on_its_own_on_a_committed_dataset(spec_factory, tmp_path):
    spec = job_spec(spec_factory, tmp_path, "stages", objects="primitives[0:2]", grasps=8)
    run_local(spec)  # ingest, extract, dedup
    with pytest.raises(Exception, match="assembled object"):
        run_local(spec.model_copy(update={"stages": ("label",)}))
    assembled = run_local(spec.model_copy(update={"stages": ("assemble", "label"),
                                                  "sim": spec.sim.model_copy(update={"points_per_grasp": 32})}))
    assert assembled.assembly.fidelity == 1.0 and assembled.labels.label_trials > 0
    assert assembled.progress.objects_done == 0  # nothing was extracted again
    trained = run_local(spec.model_copy(update={"stages": ("train",), "train": spec.train.model_copy(
        update={"epochs": 1, "model": "voxel"})}))
    assert trained.training.epochs == 1
    assert open_dataset(spec.output).attrs["training"]["epochs"] == 1


@pytest.mark.slow
def test_the_status_names_each_stage_while_it_runs_and_times_it(spec_factory, tmp_path):
    spec = spec_factory(objects="primitives[0:2]", grasps_per_object=8, output=str(tmp_path / "stages.zarr"),
                        stages=["ingest", "extract", "dedup", "assemble", "label", "train"],
                        sim={"points_per_grasp": 32, "perturbations_per_patch": 1},
                        train={"epochs": 1, "model": "voxel"})
    seen = []

    def watch(status: JobStatus) -> None:
        if not seen or seen[-1] != status.stage:
            seen.append(status.stage)
        assert read_status(spec.output).stage == status.stage  # saved before it is reported
        if status.stage in ("ingest", "extract"):
            assert status.progress.unique_codes == 0  # no count that is not the unique count

    final = run_local(spec, progress=watch)
    assert seen == ["ingest", "extract", "dedup", "assemble", "label", "train", "done"]
    assert set(final.timings) == {"ingest", "extract", "dedup", "assemble", "label", "train"}
    assert final.assembly.unique_codes == final.progress.unique_codes and final.labels.labelled_grasps > 0
    assert final.progress.unique_codes == open_dataset(spec.output).array("unique/code").shape[0]
    assert_the_layout_names_everything_in(spec.output)


def assert_the_layout_names_everything_in(path: str) -> None:
    """Every array and root attribute the writer wrote is in store/layout.py (so in the docs and the schema)."""
    import zarr

    from onepiece_dist.store.layout import ARRAYS, DatasetAttributes

    def arrays(group, prefix=""):
        found = {prefix + name for name, _ in group.arrays()}
        for name, sub in group.groups():
            found |= arrays(sub, f"{prefix}{name}/")
        return found

    root = zarr.open_group(path, mode="r")
    assert arrays(root) - {entry[0] for entry in ARRAYS} == set()
    assert set(root.attrs) - set(DatasetAttributes.model_fields) == set()
    assert {"train/val_ap", "assembled/grasps/success"} <= arrays(root)
