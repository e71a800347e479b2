"""Reliability battery: faults in the middle of jobs, concurrency, a full disk (docs/reliability.md)."""

import errno
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import onepiece_dist.store.parts as parts_module
from onepiece_dist.api import Client, read_status
from onepiece_dist.errors import JobError
from onepiece_dist.runtime.local import run_local
from onepiece_dist.runtime.writer import central_name
from onepiece_dist.specs.job import JobSpec, default_job_id
from onepiece_dist.store import PartStore, open_dataset
from onepiece_dist.store.dataset import content_digest
from tests.factories import objects_done_at_least, stage_reached

pytestmark = pytest.mark.slow


def same(a: str, b: str) -> bool:
    """Every array and content attribute equal (training left out: its float sums depend on thread counts)."""
    return content_digest(a, training=False) == content_digest(b, training=False)


def spec_at(spec_factory, tmp_path, name, objects="primitives[0:6]"):
    return spec_factory(objects=objects, grasps_per_object=48, output=str(tmp_path / f"{name}.zarr"))


def test_disk_full_fails_clearly_commits_nothing_partial_and_resume_gives_the_same_dataset(
        spec_factory, tmp_path, monkeypatch, fault_free, record_figure):
    spec = spec_at(spec_factory, tmp_path, "full")
    original, writes = parts_module.write_array, {"n": 0}

    def no_space_after_two_parts(group, name, data, rows=8192):
        writes["n"] += name == "code"
        if writes["n"] > 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(group, name, data)

    monkeypatch.setattr(parts_module, "write_array", no_space_after_two_parts)
    with pytest.raises(JobError, match="No space left on device"):
        run_local(spec)
    parts = PartStore(f"{spec.output}.parts")
    committed_before = len(parts.committed_keys())
    assert committed_before == 2 and not list(parts.folder.glob(".tmp-*"))
    assert read_status(spec.output).state == "failed"
    monkeypatch.setattr(parts_module, "write_array", original)  # space freed
    resumed = run_local(spec)
    assert resumed.progress.objects_reused == 2
    assert same(spec.output, fault_free(spec))
    record_figure(f"{committed_before} parts committed before ENOSPC, 0 temporaries, "
                  f"{resumed.progress.objects_reused} reused on resume, identical dataset")


@pytest.mark.ray
def test_killing_the_central_actor_mid_job_rebuilds_it_from_the_store(ray_session, spec_factory, tmp_path,
                                                                      fault_free, record_figure):
    ray = ray_session
    spec = spec_at(spec_factory, tmp_path, "dedupkill", objects="primitives[0:8]")
    job_id = default_job_id(spec)
    client = Client()
    handle = client.submit(spec)
    objects_done_at_least(client, job_id, 2)
    ray.kill(ray.get_actor(central_name(job_id), namespace="onepiece"), no_restart=False)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded", handle.error
    assert same(spec.output, fault_free(spec))
    record_figure(f"central actor killed after >= 2 objects; {final.retries} re-runs, identical dataset")


def labelled_spec(spec_factory, tmp_path, name: str):
    """A small job through the label stage on the one object (the faults in assembly and labelling share it)."""
    return spec_factory(objects="primitives[0:6]", grasps_per_object=24, output=str(tmp_path / f"{name}.zarr"),
                        stages=["ingest", "extract", "dedup", "assemble", "label"],
                        sim={"perturbations_per_patch": 3, "points_per_grasp": 32, "transfer_codes": 20})


@pytest.mark.ray
def test_killing_a_worker_while_it_labels_gives_the_fault_free_labels(ray_session, spec_factory, tmp_path,
                                                                      fault_free, record_figure):
    ray = ray_session
    spec = labelled_spec(spec_factory, tmp_path, "labelkill")
    job_id = default_job_id(spec)
    client = Client()
    handle = client.submit(spec)
    assert stage_reached(client, job_id, "label")
    deadline = time.monotonic() + 120
    while not list(Path(spec.parts_folder()).glob("label-*.zarr")) and time.monotonic() < deadline:
        time.sleep(0.05)  # until the workers have labelled a shard: both are busy with the next ones
    ray.kill(ray.get_actor(f"sim-{job_id}-0", namespace="onepiece"), no_restart=False)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded", handle.error
    assert final.retries >= 1 and final.labels.labelled_grasps > 0
    assert same(spec.output, fault_free(spec))
    record_figure(f"1 label worker killed; {final.retries} re-runs, {final.labels.labelled_grasps} labelled grasps, "
                  "identical dataset")


@pytest.mark.ray
def test_killing_the_central_actor_while_it_assembles_gives_the_fault_free_dataset(ray_session, spec_factory,
                                                                                 tmp_path, fault_free, record_figure):
    ray = ray_session
    spec = labelled_spec(spec_factory, tmp_path, "asmkill")
    job_id = default_job_id(spec)
    client = Client()
    handle = client.submit(spec)
    assert stage_reached(client, job_id, "assemble")
    ray.kill(ray.get_actor(central_name(job_id), namespace="onepiece"), no_restart=False)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded", handle.error
    assert same(spec.output, fault_free(spec))  # the one object, and the labels on it
    record_figure("central actor killed while it assembles; identical dataset")


@pytest.mark.ray
def test_killing_the_trainer_mid_training_resumes_from_its_last_epoch_with_the_same_metrics(ray_session, tmp_path,
                                                                                            record_figure):
    from onepiece_dist.runtime.ray_runner import run_on_ray
    from tests.factories import synthetic_labelled_dataset

    ray = ray_session

    def trained(name: str):
        synthetic_labelled_dataset(tmp_path / f"{name}.zarr", rows=2000, points=32)
        return JobSpec(output=str(tmp_path / f"{name}.zarr"), stages=("train",),
                       train={"model": "pointnet", "epochs": 5, "batch_size": 64, "patience": 5})

    spec, job_id = trained("trainkill"), "trainkill"
    last = Path(f"{spec.output}.train") / "last.pt"
    done = {}
    driver = threading.Thread(target=lambda: done.update(status=run_on_ray(spec, job_id)))
    driver.start()
    deadline = time.monotonic() + 240
    while not last.is_file() and time.monotonic() < deadline:
        time.sleep(0.05)  # the first epoch is checkpointed: kill in the middle of a later one
    time.sleep(1.0)
    ray.kill(ray.get_actor(f"trainer-{job_id}", namespace="onepiece"), no_restart=False)
    driver.join(300)
    resumed = done["status"].training
    reference = run_on_ray(trained("trainclean"), "trainclean").training
    assert resumed.epochs == reference.epochs == 5
    assert resumed.final == reference.final  # the same seed, resumed from last.pt: the same metrics
    assert np.array_equal(open_dataset(spec.output)["train/train_loss"],
                          open_dataset(str(tmp_path / "trainclean.zarr"))["train/train_loss"])
    record_figure(f"trainer killed 1 s after its first checkpoint ({resumed.epochs} epochs); the same final "
                  "metrics and per-epoch losses as a run without the kill")


@pytest.mark.ray
def test_the_same_job_submitted_twice_at_once_runs_once(ray_session, spec_factory, tmp_path, record_figure):
    spec = spec_at(spec_factory, tmp_path, "twice")
    client = Client()
    first, second = client.submit(spec), client.submit(spec)
    first._thread.join(300)
    second._thread.join(300)
    errors = [h.error for h in (first, second) if h.error is not None]
    assert len(errors) == 1 and "already running" in str(errors[0])
    assert read_status(spec.output).state == "succeeded"
    record_figure(f"{len(errors)} of 2 submissions refused (already running)")


@pytest.mark.ray
def test_two_different_jobs_at_once_equal_their_serial_runs(ray_session, spec_factory, tmp_path, record_figure):
    a = spec_at(spec_factory, tmp_path, "a", objects="primitives[0:4]")
    b = spec_at(spec_factory, tmp_path, "b", objects="primitives[4:8]")
    client = Client()
    handles = [client.submit(a), client.submit(b)]
    assert all(h.wait(timeout=300).state == "succeeded" for h in handles)
    for spec, name in ((a, "a_serial"), (b, "b_serial")):
        serial = spec.model_copy(update={"output": str(tmp_path / f"{name}.zarr")})
        run_local(serial)
        assert same(spec.output, serial.output)
    record_figure("2 jobs at once, both equal to their serial runs")


@pytest.mark.ray
def test_repeated_worker_kills_in_one_job_give_the_fault_free_dataset(ray_session, spec_factory, tmp_path,
                                                                      fault_free, record_figure):
    ray = ray_session
    spec = spec_at(spec_factory, tmp_path, "killed3", objects="primitives[0:8]")
    job_id = default_job_id(spec)
    client = Client()
    handle = client.submit(spec)
    recoveries = []
    for kill in range(3):
        done = objects_done_at_least(client, job_id, 2 * kill + 1)
        if done >= 8:
            break
        killed_at = time.monotonic()
        ray.kill(ray.get_actor(f"sim-{job_id}-{kill % 2}", namespace="onepiece"), no_restart=False)
        while client.status(job_id).progress.objects_done <= done and time.monotonic() < killed_at + 120:
            time.sleep(0.05)
        recoveries.append(time.monotonic() - killed_at)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded" and len(recoveries) >= 2 and final.retries >= len(recoveries)
    assert max(recoveries) < 60  # bounded recovery: the next object lands within a minute of each kill
    assert same(spec.output, fault_free(spec))
    print(f"kills={len(recoveries)} re-executions={final.retries} recovery_s={[round(r, 2) for r in recoveries]}")
    record_figure(f"{len(recoveries)} kills, {final.retries} re-runs, next object "
                  f"{min(recoveries):.2f}-{max(recoveries):.2f} s after each kill, identical dataset")


def test_the_store_holds_no_pickled_data(spec_factory, tmp_path, record_figure):
    import json

    spec = spec_at(spec_factory, tmp_path, "nopickle", objects="primitives[0:2]")
    run_local(spec)
    arrays = 0
    for meta in (tmp_path / "nopickle.zarr").rglob("zarr.json"):
        node = json.loads(meta.read_text())
        if node.get("node_type") == "array":
            arrays += 1
            assert node["data_type"] in ("uint8", "int8", "int32", "int64", "float16", "float32", "float64"), meta
            assert all(c["name"] in ("bytes", "blosc", "zstd", "transpose") for c in node["codecs"]), meta
    assert arrays >= 10  # the dataset's arrays were found and checked
    record_figure(f"{arrays} arrays, every one numeric with bytes/blosc codecs")


@pytest.mark.ray
def test_killing_a_worker_while_it_cuts_patches_gives_the_fault_free_dataset(ray_session, spec_factory, tmp_path,
                                                                             fault_free, record_figure):
    """The assemble stage's patches are cut on the worker pool: the worker process that has just begun a patch
    shard (its crash record says so) is killed, its shards run again, and the one object is the fault-free one."""
    import os
    import signal

    from onepiece_dist.runtime.crashes import crash_folder

    spec = labelled_spec(spec_factory, tmp_path, "patchkill")
    job_id = default_job_id(spec)
    client = Client()
    handle = client.submit(spec)
    assert stage_reached(client, job_id, "assemble")
    records, deadline, victim = crash_folder(spec.parts_folder(), job_id), time.monotonic() + 120, None
    while victim is None and time.monotonic() < deadline:
        for record in records.glob("*.log") if records.is_dir() else []:
            if record.read_text(errors="replace").startswith("patch "):
                victim = int(record.stem.rsplit("-", 1)[1])  # <host>-<pid>.log
                break
    assert victim is not None, "no worker began a patch shard"
    os.kill(victim, signal.SIGKILL)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded", handle.error
    assert final.retries >= 1  # its shards ran again elsewhere
    assert same(spec.output, fault_free(spec))
    record_figure(f"1 patch worker killed as the assemble stage began; {final.retries} re-runs, identical dataset")
