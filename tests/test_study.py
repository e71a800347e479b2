"""The study wing run end to end (onepiece_dist/study): a small study in process (the result against its published
schema, the page rendered again from the JSON), a study killed mid-way that finishes with the same result, and the
evaluate stage of a job; its statistics, decision and refusals: tests/test_study_spec.py."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.errors import SpecError
from onepiece_dist.study.spec import StudySpec, load_study_spec
from tests.factories import TINY_STUDY as TINY
from tests.factories import comparable_study as comparable

ROOT = Path(__file__).resolve().parents[1]
ONEPIECE = [sys.executable, "-m", "onepiece_dist.cli"]




























@pytest.mark.sim
@pytest.mark.slow
def test_a_study_extended_with_an_arm_reuses_every_job_and_run_and_only_with_extend(tmp_path):
    from onepiece_dist.study.runner import Where, run_study

    base = StudySpec(**{**TINY, "training": {**TINY["training"], "seeds": 1}})
    first = run_study(base, tmp_path, Where(in_process=True))
    more = StudySpec(**{**base.model_dump(), "budgets": [0.5, 0.25]})
    with pytest.raises(SpecError, match=r"or add --extend: it differs only in its arms"):
        run_study(more, tmp_path, Where(in_process=True))
    other = StudySpec(**{**base.model_dump(), "seed": 3, "budgets": [0.5, 0.25]})
    with pytest.raises(SpecError, match=r"another study's results \(study [0-9a-f]+, not [0-9a-f]+\); give another "
                                        r"--out, or remove that folder$"):
        run_study(other, tmp_path, Where(in_process=True), extend=True)  # not the same jobs: no extending
    extended = run_study(more, tmp_path, Where(in_process=True), extend=True)
    assert set(extended.reused_jobs) == {"heldout", "A", "B r0"}  # every job reused
    assert extended.reused_runs >= first.reused_runs + 4 and "R 0.25" in {arm.name for arm in extended.arms}
    assert {arm.name: arm.heldout for arm in first.arms} == {arm.name: arm.heldout for arm in extended.arms
                                                              if arm.name != "R 0.25"}
    assert StudySpec.model_validate_json((tmp_path / "study.spec.json").read_text()) == more


TINY_BOTH = {**TINY, "judge": "both", "picks": {"views": 1}}


@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory):
    from onepiece_dist.study.runner import Where, run_study

    folder = tmp_path_factory.mktemp("study")  # judged by picks and by candidates (issue 51)
    return folder, run_study(StudySpec(**TINY_BOTH), folder, Where(in_process=True))


@pytest.mark.sim
@pytest.mark.slow
def test_a_small_study_holds_every_arm_validates_against_its_schema_and_renders_again(tiny_study):
    import jsonschema

    folder, result = tiny_study
    document = json.loads((folder / "study.json").read_text())
    jsonschema.validate(document, json.loads((ROOT / "schemas" / "study_result.schema.json").read_text()))
    assert [a.name for a in result.arms] == ["A", "B r0", "R 0.5", "R ~B r0"]
    a, b = result.arms[0], result.arms[1]
    assert a.cost.labelled_grasps > b.cost.labelled_grasps > 0 and a.cost.core_seconds > 0
    for arm in result.arms:
        assert len(arm.heldout.seeds) == 2 and arm.heldout.top1.interval[0] <= arm.heldout.top1.interval[1]
        assert 0 <= arm.heldout.ap.mean <= 1 and arm.cost.core_seconds > 0
    assert result.arms[3].cost.labelled_grasps == b.cost.labelled_grasps  # R of B's size
    picks, ceiling = result.picks, result.ceiling  # issue 51: judged by picks too, against the label's ceiling
    assert [arm.name for arm in picks.arms] == [arm.name for arm in result.arms] and picks.objects == 3
    assert picks.cheapest in {arm.name for arm in picks.arms if arm.within_a}
    assert all(0 <= arm.first_attempt.interval[0] <= arm.first_attempt.mean <= arm.first_attempt.interval[1] <= 1
               for arm in picks.arms)
    assert sorted((folder / "runs" / "weights").glob("A-s*-lr*.pt")) and len(picks.b_beats_random) == 1
    assert ceiling.draws == 3 and ceiling.grasps == result.heldout.grasps <= 256  # every held-out candidate here
    assert ceiling.positive_rate <= ceiling.ceiling_ap <= 1 and 0.5 <= ceiling.agreement <= 1
    assert 0 <= ceiling.fitted_ap <= 1 and set(ceiling.arm_ap) == {arm.name for arm in result.arms}
    assert set(ceiling.single_ap) == set(ceiling.arm_ap) and all(0 <= ap <= 1 for ap in ceiling.single_ap.values())
    assert json.loads((folder / "ceiling.json").read_text())["rows"]  # the draws are kept: a rerun reuses them
    page = (folder / "study.md").read_text().splitlines()
    assert page[2].startswith("**Judged by picks.**")
    answer = page[:page.index("## Arms")]
    assert any("of the way from the floor to the ceiling" in line for line in answer)
    assert any(line.startswith("**Labels to reach a pick level**") for line in answer)
    assert any("Its networks one at a time" in line for line in page)
    assert "## Judged by picks and by candidates" in page
    k = result.lookup  # the study's own code as a lookup, no network
    assert list(k.ranked) == ["A", "B", "R", "S"] and k.ranked["A"].labels == a.cost.labelled_grasps
    assert k.ranked["B"].labels == k.ranked["R"].labels == k.train_codes and 0 < k.coverage <= 1
    assert k.ranked["A"].coverage == pytest.approx(k.coverage, abs=1e-4)
    assert result.decision.cheapest in {arm.name for arm in result.arms if arm.within_a}
    page = (folder / "study.md").read_text()
    first = page.split("## Arms")[0].splitlines()  # the picks' judgement, the levels, then the candidates'
    assert any(line.startswith("**Answer.**") for line in first) and f"{100 * a.heldout.top1.mean:.1f}%" in page
    assert "## The code as a lookup (no network)" in page and f"{k.ranked['B'].ap:.3f}" in page
    (folder / "study.md").unlink()
    shown = subprocess.run([*ONEPIECE, "study", "report", str(folder)], capture_output=True, text=True, timeout=120)
    assert shown.returncode == 0, shown.stderr[-2000:]
    assert (folder / "study.md").read_text() == page


@pytest.mark.sim
@pytest.mark.slow
def test_other_keys_are_looked_up_from_settled_crops_and_the_jobs_own_resolution_gives_its_code(tiny_study):
    """study.keys (the key study as a study option): the occupancy key at the job's resolution, computed again
    from every grasp's crop at its settled pose, is the job's code, so its lookup is the study's own."""
    from onepiece_dist.study.jobs import study_jobs
    from onepiece_dist.study.keys import key_measures
    from onepiece_dist.study.page import render_page
    from onepiece_dist.study.spec import StudyKey

    folder, result = tiny_study
    keys = (StudyKey(name="occupancy 10 mm", kind="occupancy", resolution=0.01),
            StudyKey(name="contact 10 mm, 2 mm", kind="contact", cell=0.01, step=0.002),
            StudyKey(name="both", kind="both", resolution=0.01, cell=0.01, step=0.002),
            StudyKey(name="occupancy 20 mm", kind="occupancy", resolution=0.02))
    jobs = study_jobs(StudySpec(**TINY), folder)
    own, contact, both, coarse = key_measures(keys, jobs.a, jobs.heldout, result.spec.seed)
    assert own.lookup == result.lookup and own.unique == result.lookup.train_codes
    assert both.unique >= max(own.unique, contact.unique) and coarse.unique <= own.unique
    assert both.key_bytes == own.key_bytes + contact.key_bytes
    page = render_page(result.model_copy(update={"keys": [own, contact, both, coarse]}))
    assert "## Other keys as lookups" in page and f"| contact 10 mm, 2 mm | {contact.key_bytes} |" in page
    with pytest.raises(SpecError, match="does not divide"):
        load_study_spec(None, {**TINY, "keys": [{"name": "x", "kind": "occupancy", "resolution": 0.03}]})


@pytest.mark.sim
@pytest.mark.slow
def test_a_b_static_arm_builds_the_one_object_from_crops_at_the_candidate_pose_with_its_own_control(tmp_path):
    """static_radii (the paper's static extraction as a study arm): its job crops at the candidate pose, its
    extraction is charged apart from the settled B's, and its control is R ~B static r."""
    from onepiece_dist.api import read_status
    from onepiece_dist.store import open_dataset
    from onepiece_dist.study.jobs import core_seconds, study_jobs
    from onepiece_dist.study.runner import Where, run_study

    spec = StudySpec(**{**TINY, "static_radii": [0], "budgets": []})
    result = run_study(spec, tmp_path, Where(in_process=True))
    arms = {arm.name: arm for arm in result.arms}
    assert list(arms) == ["A", "B r0", "B static r0", "R ~B r0", "R ~B static r0"]
    jobs = study_jobs(spec, tmp_path).b
    static = open_dataset(jobs["B static r0"].output)
    assert np.array_equal(static["grasps/code"], static["grasps/candidate_code"])  # no settling: the nominal crop
    assert not jobs["B static r0"].sim.physics and jobs["B static r0"].cache_dir != jobs["B r0"].cache_dir
    for name in ("B r0", "B static r0"):  # each charged its own parts cache's extraction, not the other's
        assert arms[name].cost.stages["extract"] == core_seconds(read_status(jobs[name].output))["extract"]
    assert arms["R ~B static r0"].cost.labelled_grasps == min(arms["B static r0"].cost.labelled_grasps,
                                                              arms["A"].cost.labelled_grasps)  # at most A's
    assert set(result.decision.b_beats_random) == {"B r0", "B static r0"} and len(result.premise) == 1
    assert "B static r does the same from crops at each candidate's pose" in (tmp_path / "study.md").read_text()


@pytest.mark.sim
@pytest.mark.slow
def test_b_weighting_reaches_only_the_one_objects_runs(tiny_study):
    """training.b_weighting (the variants of docs/performance.md as a study setting) weighs B's patches only."""
    from onepiece_dist.study.jobs import run_or_reuse, study_jobs
    from onepiece_dist.study.runner import plan_runs

    folder, _ = tiny_study
    spec = StudySpec(**{**TINY, "training": {**TINY["training"], "b_weighting": "sqrt"}})
    jobs = study_jobs(spec, folder)
    records = {name: run_or_reuse(name, job, lambda *_: pytest.fail("every job is finished")) for name, job
               in jobs.named()}
    weighting = {(run.arm, run.run.weighting) for run in plan_runs(spec, jobs, records)}
    assert weighting == {("A", "none"), ("B r0", "sqrt"), ("R 0.5", "none"), ("R ~B r0", "none")}


@pytest.mark.sim
@pytest.mark.slow
def test_a_force_closure_study_trains_on_closure_and_judges_by_physics(tmp_path):
    """Issue 40: the paper's label in a study. A and R learn force closure scored without lifting anything, B
    scores its patches at their settled pose, the held-out objects keep physics as the truth and carry the scores,
    and the result says how well the label itself predicts that truth."""
    from onepiece_dist.store import open_dataset
    from onepiece_dist.study.premise import label_fit
    from onepiece_dist.study.runner import Where, run_study

    spec = StudySpec(**{**TINY, "label": "force_closure", "good_mu": 0.6})
    result = run_study(spec, tmp_path, Where(in_process=True))
    a, heldout = open_dataset(tmp_path / "jobs" / "A.zarr"), open_dataset(tmp_path / "jobs" / "heldout.zarr")
    assert np.array_equal(a["grasps/success"].astype(bool), a["grasps/fc_mu"] <= 0.6)
    assert not a.has("grasps/quality")  # no trial ran to label A
    b = open_dataset(tmp_path / "jobs" / "B-r0.zarr")
    assert np.array_equal(b["assembled/grasps/success"].astype(bool), b["assembled/grasps/fc_mu"] <= 0.6)
    truth = heldout["grasps/success"].astype(bool)
    assert heldout.has("grasps/quality") and not np.array_equal(truth, heldout["grasps/fc_mu"] <= 0.6)
    arms = {arm.name: arm for arm in result.arms}
    assert arms["A"].cost.label_trials == 0 and arms["R 0.5"].cost.label_trials == 0
    assert arms["B r0"].cost.label_trials == arms["B r0"].unique_codes  # one trial per patch
    assert result.label_fit == label_fit(heldout, 0.6)
    assert result.label_fit.agreement == pytest.approx(np.mean(truth == (heldout["grasps/fc_mu"] <= 0.6)), abs=1e-4)
    assert result.heldout.positive_rate == pytest.approx(truth.mean())
    page = (tmp_path / "study.md").read_text()
    assert "trained on force closure" in page and "## The label against the held-out truth" in page


@pytest.mark.sim
@pytest.mark.slow
def test_a_study_killed_mid_way_finishes_with_the_same_result(tiny_study, tmp_path):
    folder = tmp_path / "killed"
    study = tmp_path / "tiny.json"
    study.write_text(json.dumps(TINY_BOTH))
    command = [*ONEPIECE, "study", "run", str(study), "--out", str(folder), "--in-process"]
    driver = subprocess.Popen(command, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not (folder / "jobs" / "A.zarr.parts").is_dir() and time.monotonic() < deadline:  # held-out done, A begun
        time.sleep(0.2)
    os.killpg(driver.pid, signal.SIGKILL)
    driver.wait()
    assert not (folder / "study.json").exists()
    finished = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert finished.returncode == 0, finished.stderr[-3000:]
    again = json.loads((folder / "study.json").read_text())
    assert "heldout" in again["reused_jobs"]
    assert comparable(again) == comparable(json.loads((tiny_study[0] / "study.json").read_text()))


@pytest.mark.sim
@pytest.mark.slow
def test_a_job_that_trains_also_evaluates_on_unseen_objects_and_says_so(tmp_path):
    from onepiece_dist.store import open_dataset

    spec = tmp_path / "job.yaml"
    spec.write_text("objects: pybullet:random_urdfs[0:3]\ngrasps_per_object: 16\nsim: {points_per_grasp: 64}\n"
                    "train: {model: voxel, epochs: 2}\nevaluate: {objects: 'pybullet:random_urdfs[500:502]', "
                    "grasps_per_object: 12}\n")
    run = subprocess.run([*ONEPIECE, "run", str(spec), "--in-process", "--out", str(tmp_path / "d.zarr")],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-3000:]
    scores, protocol, next_step = run.stderr.strip().splitlines()[-3:]
    assert next_step.startswith("grasps on a camera's view with this network: onepiece grasp depth.png")
    assert f"--checkpoint {tmp_path / 'd.zarr.train' / 'best.pt'};" in next_step and "pick_view.pt" in next_step
    assert "onepiece pick-labels --objects" in next_step and "onepiece pick-train" in next_step
    assert scores.startswith("held-out: 2 unseen objects") and "top-1 success" in scores and "random choice" in scores
    assert protocol.startswith("held-out protocol: 4 label trials per candidate, every one must hold; ")
    evaluation = open_dataset(tmp_path / "d.zarr").attrs["evaluation"]
    assert evaluation["objects"] == 2 and 0 <= evaluation["top1"] <= 1 and evaluation["grasps"] > 0
    assert evaluation["separable"] == (0.1 <= evaluation["positive_rate"] <= 0.9) and evaluation["verdict"] in protocol
    heldout = open_dataset(evaluation["dataset"])
    assert heldout.attrs["job_spec"]["objects"] == "pybullet:random_urdfs[500:502]"
    assert (heldout.attrs["job_spec"]["sim"]["label_trials"], heldout.attrs["job_spec"]["sim"]["success"]) == (
        4, "every_trial")
    assert len(heldout["grasps/success"]) == evaluation["grasps"]














def test_the_adaptive_arm_starts_with_one_candidate_per_code_then_asks_where_the_network_is_least_sure():
    from onepiece_dist.stats.selection import first_rows, least_sure

    inverse = np.array([0, 0, 0, 1, 1, 2, 3, 3])
    first = first_rows(inverse, 4, np.random.default_rng(0))
    assert sorted(inverse[first]) == [0, 1, 2, 3]  # every code once before any code twice
    more = first_rows(inverse, 6, np.random.default_rng(0))
    assert len(set(more)) == 6 and set(inverse[more]) == {0, 1, 2, 3}
    scores = np.array([0.5, 0.45, 0.9, 0.52, 0.1, 0.0, 0.6, 0.49])
    assert list(least_sure(scores, np.array([0]), inverse, 2)) == [7, 3]  # codes 3 and 1, least sure first
    assert list(least_sure(scores, np.array([0]), inverse, 5)) == [7, 3, 1, 5, 6]  # codes 0, 2, then the rest


@pytest.mark.sim
@pytest.mark.slow
def test_the_adaptive_arm_stops_by_its_rule(tiny_study):
    """U stops after `patience` rounds without a validation AP gain above the margin, or at its round limit."""
    from onepiece_dist.learn.metrics import CurvePoint, Validation
    from onepiece_dist.learn.train import StepResult
    from onepiece_dist.study.adaptive import adaptive_rows

    folder, _ = tiny_study
    a_output = str(folder / "jobs" / "A.zarr")
    trained = []
    from onepiece_dist.store import open_dataset

    n = len(open_dataset(a_output)["grasps/code"])
    adaptive = {"first": 0.2, "batch": 0.1, "rounds": 5, "patience": 2, "margin": 0.01}
    spec = StudySpec(**{**TINY, "adaptive": adaptive})

    def fake(aps):
        def train_one(run):
            trained.append(run.rows)
            point = CurvePoint(1, Validation(0.5, 0.5, aps[len(trained) - 1], 0.5))
            return StepResult(scores=np.random.default_rng(len(trained)).random(n).astype(np.float32),
                              curve=(point,), best_step=1, train_seconds=0.0,
                              train_grasps=len(run.rows), validation_grasps=0, device="cpu")
        return train_one

    rows, rounds = adaptive_rows(spec, a_output, 1e-3, fake([0.5, 0.6, 0.605, 0.61, 0.9, 0.9]))
    assert [r.validation_ap for r in rounds] == [0.5, 0.6, 0.605, 0.61]  # two rounds within the margin: stop
    assert [r.labels for r in rounds] == [round(0.2 * n), *(round(0.2 * n) + k * round(0.1 * n) for k in (1, 2, 3))]
    assert len(rows) == rounds[-1].labels == len(set(rows)) and list(trained[-1]) == list(rows)
    trained.clear()
    _, capped = adaptive_rows(StudySpec(**{**TINY, "adaptive": {**adaptive, "rounds": 1}}), a_output, 1e-3,
                              fake([0.1, 0.5, 0.9]))
    assert len(capped) == 2  # the round limit


@pytest.mark.sim
@pytest.mark.slow
def test_a_study_with_the_adaptive_arm_compares_it_with_random_labels_of_its_size(tmp_path):
    import jsonschema

    from onepiece_dist.study.runner import Where, run_study

    adaptive = {"first": 0.2, "batch": 0.1, "rounds": 2, "patience": 1, "margin": 0.0}
    result = run_study(StudySpec(**{**TINY, "adaptive": adaptive}), tmp_path, Where(in_process=True))
    arms = {arm.name: arm for arm in result.arms}
    assert arms["U"].kind == "U" and arms["R ~U"].kind == "R"
    assert arms["U"].cost.labelled_grasps == arms["R ~U"].cost.labelled_grasps == result.adaptive[-1].labels
    u, a, b = arms["U"].cost, arms["A"].cost, arms["B r0"].cost
    assert u.stages["extract"] == b.stages["extract"]  # every candidate's code and crop
    assert u.stages["label"] == pytest.approx(max(a.core_seconds - b.stages["extract"], 0.0) * u.labelled_grasps
                                              / a.labelled_grasps, abs=0.02)
    assert 1 <= len(result.adaptive) <= 3 and result.decision.u_beats_random in (True, False)
    document = json.loads((tmp_path / "study.json").read_text())
    jsonschema.validate(document, json.loads((ROOT / "schemas" / "study_result.schema.json").read_text()))
    page = (tmp_path / "study.md").read_text()
    assert "## The adaptive arm" in page and "as many random labels (R ~U" in page


def test_a_stored_run_keeps_its_key_when_step_runs_gain_fields_at_their_defaults(tmp_path):
    """The run store's key of a run as the code before the adaptive job's StepRun fields computed it (at 887feea):
    a study's finished runs are found again after the upgrade; a later field set to something else is another run."""
    import dataclasses

    from onepiece_dist.learn.train import StepRun
    from onepiece_dist.study.training import RunStore

    run = StepRun("/nowhere/A.zarr", "grasps", (1, 2, 3), "/nowhere/heldout.zarr", "pointnet", 500, 64, 0.001, 0.2, 0,
                  10)
    store = RunStore(tmp_path)
    assert store.key(run) == "cbd9dfa5940d47f6102337d0"
    assert store.key(dataclasses.replace(run, warm_start="round-0.pt")) != store.key(run)


