"""Budgeted labelling jobs (issue 39, item 1): a seeded subset of the candidates labelled on their own objects,
spread over every object, exactly the budget, the same subset and labels for the same spec and seed, refusals that
name the field, and a network trained on what it labelled."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.errors import SpecError
from onepiece_dist.job.stages.label_budget import allocate, budget_rows
from onepiece_dist.specs.job import JobSpec, parse_job_spec
from onepiece_dist.store import open_dataset
from onepiece_dist.store.dataset import content_digest


def test_the_budget_is_spread_as_evenly_as_each_object_allows_and_met_exactly():
    rng = np.random.default_rng(0)
    assert allocate(np.array([10, 10, 10]), 9, rng).tolist() == [3, 3, 3]
    uneven = allocate(np.array([1, 50, 50, 2]), 40, np.random.default_rng(1))
    assert uneven.sum() == 40 and uneven[0] == 1 and uneven[3] == 2 and abs(int(uneven[1]) - int(uneven[2])) <= 1
    assert allocate(np.array([3, 4]), 100, rng).tolist() == [3, 4]  # more than there are: all of them
    owner = np.repeat(np.arange(5), [20, 3, 40, 40, 7])
    rows = budget_rows(owner, 30, seed=7)
    assert len(rows) == 30 and len(np.unique(rows)) == 30 and set(np.unique(owner[rows])) == set(range(5))
    assert np.array_equal(rows, budget_rows(owner, 30, seed=7)) and not np.array_equal(rows, budget_rows(owner, 30, 8))


def test_a_budget_outside_its_range_is_refused_with_the_field_named():
    with pytest.raises(SpecError, match=r"budget\.fraction = 1\.5"):
        parse_job_spec({"budget": {"fraction": 1.5}, "stages": ["ingest", "extract", "dedup", "label"]})
    with pytest.raises(SpecError, match=r"budget\.fraction = 0"):
        parse_job_spec({"budget": {"fraction": 0}, "stages": ["ingest", "extract", "dedup", "label"]})
    with pytest.raises(SpecError, match=r"budget.*count or a fraction, not both"):
        parse_job_spec({"budget": {"count": 5, "fraction": 0.5}, "stages": ["ingest", "extract", "dedup", "label"]})
    with pytest.raises(SpecError, match=r"budget.*'assemble'"):
        parse_job_spec({"budget": {"count": 5}})


def budget_spec(tmp_path, name: str, **budget) -> JobSpec:
    return JobSpec(objects="primitives[0:4]", grasps_per_object=16, output=str(tmp_path / f"{name}.zarr"),
                   sampler={"surface_points": 3000}, budget=budget, sim={"points_per_grasp": 32, "label_trials": 2},
                   stages=("ingest", "extract", "dedup", "label"))


@pytest.mark.sim
def test_a_count_below_the_objects_is_refused_before_any_work(tmp_path):
    from onepiece_dist.runtime.local import run_local

    with pytest.raises(SpecError, match=r"budget\.count=3 is below the job's 4 objects"):
        run_local(budget_spec(tmp_path, "few", count=3))
    assert not (tmp_path / "few.zarr").exists()


@pytest.mark.sim
@pytest.mark.slow
def test_a_budget_job_labels_exactly_its_budget_over_every_object_and_again_the_same(tmp_path):
    from onepiece_dist.learn.dataset import GraspDataset
    from onepiece_dist.runtime.local import run_local

    first = run_local(budget_spec(tmp_path, "a", count=10))
    ds = open_dataset(tmp_path / "a.zarr")
    rows = ds["labelled/grasps/row"]
    assert len(rows) == 10 == first.labels.labelled_grasps and first.labels.label_trials == 20
    assert set(np.unique(ds["labelled/grasps/object"])) == set(np.unique(ds["grasps/object"]))  # every object
    assert np.array_equal(ds["labelled/grasps/code"], ds["grasps/code"][rows])  # the candidates' own records
    assert ds["labelled/grasps/points"].shape == (10, 32, 3) and first.label_seconds > 0
    assert ds.attrs["budget_labels"]["requested"] == 10 and not ds.attrs["budget_labels"]["all_candidates"]
    again = run_local(budget_spec(tmp_path, "b", count=10))
    assert content_digest(tmp_path / "a.zarr") == content_digest(tmp_path / "b.zarr")
    assert again.labels == first.labels
    rerun = run_local(budget_spec(tmp_path, "a", count=10))  # resumable: every shard is a part, reused
    assert content_digest(tmp_path / "a.zarr") == content_digest(tmp_path / "b.zarr") and rerun.label_seconds > 0
    everything = run_local(budget_spec(tmp_path, "all", fraction=1.0))
    assert everything.labels.labelled_grasps == len(open_dataset(tmp_path / "all.zarr")["grasps/object"])
    assert open_dataset(tmp_path / "all.zarr").attrs["budget_labels"]["all_candidates"]
    from onepiece_dist.store.dataset import delivered_groups

    assert delivered_groups(tmp_path / "a.zarr") == ["labelled", "objects"]  # the extraction records may stay home
    labelled = GraspDataset(tmp_path / "a.zarr", "labelled/grasps")
    assert len(labelled) == 10 and set(labelled.labels()) <= {0.0, 1.0}


@pytest.mark.ray
def test_killing_a_worker_while_it_labels_a_budget_gives_the_fault_free_dataset(ray_session, tmp_path, fault_free):
    import time
    from pathlib import Path

    from onepiece_dist.api import Client
    from onepiece_dist.specs.job import default_job_id
    from tests.factories import stage_reached

    spec = budget_spec(tmp_path, "kill", fraction=0.5).model_copy(update={"grasps_per_object": 48})
    client = Client()
    handle = client.submit(spec)
    assert stage_reached(client, default_job_id(spec), "label")
    deadline = time.monotonic() + 120
    while not list(Path(spec.parts_folder()).glob("label-*.zarr")) and time.monotonic() < deadline:
        time.sleep(0.05)  # until a shard is labelled: the workers are busy with the next ones
    ray_session.kill(ray_session.get_actor(f"sim-{default_job_id(spec)}-0", namespace="onepiece"), no_restart=False)
    final = handle.wait(timeout=300)
    assert final.state == "succeeded" and final.retries >= 1
    assert content_digest(spec.output, training=False) == content_digest(fault_free(spec), training=False)
    attrs = open_dataset(spec.output).attrs["budget_labels"]
    assert attrs["labelled_grasps"] == final.labels.labelled_grasps and attrs["label_core_seconds"] > 0
