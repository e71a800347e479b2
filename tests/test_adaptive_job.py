"""Adaptive labelling jobs (issue 39, item 2): rounds of labels chosen by the network, a stop by the stated rule,
every round kept in the dataset, and a job killed mid-round that resumes at that round with the same dataset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.errors import JobError, SpecError
from onepiece_dist.specs.job import JobSpec, parse_job_spec
from onepiece_dist.store import open_dataset
from onepiece_dist.store.dataset import content_digest

ADAPTIVE = {"enabled": True, "first": 0.1, "batch": 0.05, "rounds": 4, "patience": 2, "margin": 0.0,
            "limit": 0.5, "validation": 0.34, "validation_grasps": 8, "steps": 20}
STAGES = ("ingest", "extract", "dedup", "label", "train")


def adaptive_spec(tmp_path, name: str) -> JobSpec:
    return JobSpec(objects="pybullet:random_urdfs[0:6]", grasps_per_object=24, output=str(tmp_path / f"{name}.zarr"),
                   sampler={"surface_points": 3000}, sim={"points_per_grasp": 32, "label_trials": 2},
                   stages=STAGES, train={"data": "budget", "epochs": 2, "batch_size": 16}, adaptive=ADAPTIVE)


def test_an_adaptive_spec_outside_its_rules_is_refused_with_the_field_named():
    with pytest.raises(SpecError, match=r"adaptive labels candidates .* 'label' and 'train'"):
        parse_job_spec({"adaptive": ADAPTIVE})  # the default stages assemble the one object
    with pytest.raises(SpecError, match=r"adaptive.*'train'"):
        parse_job_spec({"adaptive": ADAPTIVE, "stages": ["ingest", "extract", "dedup", "label"]})
    with pytest.raises(SpecError, match=r"set train\.data: budget"):
        parse_job_spec({"adaptive": ADAPTIVE, "stages": list(STAGES)})
    with pytest.raises(SpecError, match=r"adaptive\.limit"):
        parse_job_spec({"adaptive": ADAPTIVE, "stages": list(STAGES), "train": {"data": "budget"},
                        "budget": {"count": 10}})
    with pytest.raises(SpecError, match=r"adaptive\.first = 1\.5"):
        parse_job_spec({"adaptive": {**ADAPTIVE, "first": 1.5}, "stages": list(STAGES), "train": {"data": "budget"}})


def stop_by_rule(record: dict, plan: dict, labels: int) -> str | None:
    """The stop rule, replayed from the validation APs the job recorded."""
    best, stale = -np.inf, 0
    for entry in record["rounds"]:
        ap = entry["validation_ap"]
        best, stale = (ap, 0) if ap > best + plan["margin"] else (best, stale + 1)
        if stale >= plan["patience"]:
            return "patience"
        if entry["round"] >= plan["rounds"]:
            return "rounds"
        if entry["labels"] >= record["limit"]:
            return "limit"
    return None


@pytest.mark.sim
@pytest.mark.slow
def test_an_adaptive_job_stops_by_its_rule_and_keeps_every_round_in_the_dataset(tmp_path, fault_free):
    """Read on the suite's one in-process run of the adaptive spec (``fault_free``), which the job killed mid-round
    and the job on Ray are compared with: its dataset and the status it saved."""
    from onepiece_dist.api import read_status
    from onepiece_dist.learn.dataset import GraspDataset
    from onepiece_dist.learn.train import load_round_model, predict

    output = Path(fault_free(adaptive_spec(tmp_path, "a")))
    status = read_status(output)
    ds = open_dataset(output)
    record = ds.attrs["adaptive"]
    assert record == status.adaptive.model_dump(mode="json") | {"model": "pointnet"}
    assert record["stopped"] == stop_by_rule(record, ADAPTIVE, len(ds["labelled/grasps/row"]))
    assert len(record["rounds"]) >= 2 and record["rounds"][-1]["labels"] <= record["limit"]
    rows, rounds, owner = ds["labelled/grasps/row"], ds["labelled/grasps/round"], ds["grasps/object"]
    assert len(np.unique(rows)) == len(rows) == status.labels.labelled_grasps
    assert [int((rounds == r["round"]).sum()) for r in record["rounds"]] == [r["new"] for r in record["rounds"]]
    held = set(record["validation_objects"])
    on_held = np.isin(owner[rows], list(held))
    assert on_held.sum() == record["validation_labels"] and set(rounds[on_held]) == {0}  # fixed, from round 0
    code = ds["grasps/code_index"]
    first = rows[(rounds == 0) & ~on_held]
    assert len(np.unique(code[first])) == len(first)  # round 0: one candidate per code
    scores = ds["adaptive/scores"]
    assert scores.shape == (len(record["rounds"]), len(owner))
    for later in record["rounds"][1:]:  # each later batch: where the last round's network was least sure
        k = later["round"]
        new = rows[rounds == k]
        free = np.setdiff1d(np.flatnonzero(~np.isin(owner, list(held))), rows[rounds < k])
        others = free[~np.isin(code[free], code[new])]
        doubt = np.abs(scores[k - 1] - 0.5)
        assert not np.isin(owner[new], list(held)).any()
        assert len(others) == 0 or doubt[new].max() <= doubt[others].min()
    candidates = GraspDataset(output, "grasps", inputs=("points",), labelled=False)
    for entry in record["rounds"]:  # the round's network, read from the dataset, gave the round's scores
        assert np.allclose(predict(load_round_model(output, entry["round"]), candidates),
                           scores[entry["round"]], atol=1e-6)
    assert status.training is not None and status.training.data == "budget"
    from onepiece_dist.store.dataset import DatasetReader, delivered_groups

    assert delivered_groups(output) == ["labelled", "objects", "train"]  # the rounds are records
    assert DatasetReader(output).summary()["adaptive"]["stopped"] == record["stopped"]  # inspect


@pytest.mark.sim
@pytest.mark.slow
def test_an_adaptive_job_killed_mid_round_resumes_at_that_round_with_the_same_dataset(tmp_path, monkeypatch,
                                                                                      fault_free):
    from onepiece_dist.job.stages import label_budget as budget
    from onepiece_dist.runtime import trainer
    from onepiece_dist.runtime.local import run_local

    spec = adaptive_spec(tmp_path, "killed")
    reference = fault_free(spec)
    rounds = len(open_dataset(reference).attrs["adaptive"]["rounds"])
    assert rounds >= 3
    label = budget.label_budget_shard
    shards = []

    def dies_in_round_two(spec, task, index, parts):
        shards.append(task.round)
        if task.round == 2 and shards.count(2) == 2:
            raise RuntimeError("worker lost in round 2")
        return label(spec, task, index, parts)

    monkeypatch.setattr(budget, "label_budget_shard", dies_in_round_two)
    with pytest.raises(JobError, match="round 2"):
        run_local(spec)
    monkeypatch.setattr(budget, "label_budget_shard", label)
    trained = []
    fit = trainer.Trainer.fit_steps
    monkeypatch.setattr(trainer.Trainer, "fit_steps", lambda self, run: trained.append(run.warm_start) or fit(self,
                                                                                                            run))
    status = run_local(spec)
    assert len(trained) == rounds - 2  # rounds 0 and 1 were kept: the job resumed in round 2
    assert status.adaptive.rounds[2].checkpoint != trained[0]  # and warm-started from round 1's network
    assert content_digest(spec.output) == content_digest(reference)


@pytest.mark.ray
def test_an_adaptive_job_on_ray_labels_on_the_workers_and_gives_the_in_process_dataset(ray_session, tmp_path,
                                                                                      fault_free, monkeypatch):
    """Each round's network is fitted on one of the job's simulation workers (on a CPU): no trainer actor starts
    for a round, and the workers that label round 0 label every round after it."""
    from onepiece_dist.api import Client
    from onepiece_dist.runtime import ray_runner

    started, start = [], ray_runner.restartable_actor
    monkeypatch.setattr(ray_runner, "restartable_actor",
                        lambda cls, *a, **k: started.append(cls) or start(cls, *a, **k))
    monkeypatch.setattr(ray_runner.TrainerClient, "start_named", lambda *a: pytest.fail("a round's trainer actor"))
    spec = adaptive_spec(tmp_path, "ray")
    final = Client().submit(spec).wait(timeout=300)
    assert final.state == "succeeded" and len(final.adaptive.rounds) >= 2
    assert started.count(ray_runner.SimWorker) == 2  # one a CPU of the embedded Ray, started once for the job
    assert final.label_seconds > 0 and final.labels.labelled_grasps == final.adaptive.rounds[-1].labels
    assert content_digest(spec.output, training=False) == content_digest(fault_free(spec), training=False)
