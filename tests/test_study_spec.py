"""The study wing's statistics, its decision and its refusals before any work (onepiece_dist/study; a study run
end to end: tests/test_study.py)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.errors import SourceError, SpecError
from onepiece_dist.study import stats
from onepiece_dist.study.decide import ArmDraft, decide, finish_arms
from onepiece_dist.study.result import ArmCost, HeldoutScore, Measure
from onepiece_dist.study.spec import StudySpec, StudyTargets, load_study_spec
from tests.factories import TINY_STUDY as TINY

ROOT = Path(__file__).resolve().parents[1]


def test_ap_over_thresholds_equals_the_usual_ap_without_ties_and_ignores_order_within_ties():
    rng = np.random.default_rng(2)
    scores, labels = rng.random(200), rng.random(200) < 0.3
    assert stats.threshold_ap(scores, labels) == pytest.approx(stats.average_precision(scores, labels))
    tied = np.round(scores, 1)
    order = rng.permutation(200)
    assert stats.threshold_ap(tied, labels) == pytest.approx(stats.threshold_ap(tied[order], labels[order]))
    assert stats.average_precision(tied, labels) != pytest.approx(stats.average_precision(tied[order], labels[order]))
    assert stats.threshold_ap(np.zeros(200), labels) == pytest.approx(labels.mean())
    assert stats.threshold_ap(scores, np.zeros(200, bool)) == 0.0


def test_the_interval_holds_the_mean_and_narrows_with_a_lower_confidence():
    per_object = (np.random.default_rng(1).random(40) < 0.6).astype(float)
    wide, narrow = (stats.bootstrap_interval(per_object, confidence=c) for c in (0.95, 0.8))
    assert wide[0] <= narrow[0] <= per_object.mean() <= narrow[1] <= wide[1] and narrow != wide


def test_the_share_decided_is_the_lift_over_the_floor_scaled_by_the_headroom():
    assert stats.share_decided(0.8, 0.6, 1.0) == pytest.approx(0.5)
    assert stats.share_decided(0.6, 0.6, 1.0) == 0 and stats.share_decided(None, 0.6, 1.0) is None
    assert stats.share_decided(0.7, 0.6, 0.6) is None  # no headroom above the floor: nothing to decide


def score(top1: float, ap: float, spread: float = 0.05) -> HeldoutScore:
    def m(v: float) -> Measure:
        return Measure(mean=v, std=0.0, interval=(v - spread, v + spread))

    return HeldoutScore(top1=m(top1), top5=m(top1), ap=m(ap), accuracy=m(0.7), learning_rate=1e-3, seeds=[])


def cost(seconds: float, labelled: int) -> ArmCost:
    return ArmCost(core_seconds=seconds, stages={"extract": seconds}, label_trials=4 * labelled,
                   labelled_grasps=labelled, labelled_bytes=100 * labelled, dataset_bytes=200 * labelled,
                   delivered_bytes=120 * labelled)


def arms(b_top1: float = 0.78):
    return finish_arms([ArmDraft("A", "A", cost(100, 1000), score(0.8, 0.7)),
                        ArmDraft("B r0", "B", cost(20, 100), score(b_top1, 0.69), radius=0, unique_codes=100),
                        ArmDraft("R 0.05", "R", cost(5, 50), score(0.70, 0.60), share=0.05),
                        ArmDraft("R 0.1", "R", cost(10, 100), score(0.79, 0.68), share=0.1),
                        ArmDraft("R ~B r0", "R", cost(10, 100), score(0.77, 0.69), radius=0)])


def test_the_decision_is_the_cheapest_arm_inside_a_s_intervals_with_targets_from_the_spec():
    decided = decide(arms(), StudyTargets(time_ratio=8.0))
    assert decided.cheapest == "R 0.1" and decided.cheapest_time_ratio == 10.0 and decided.time_met
    assert decided.best_b == "B r0" and decided.b_beats_random == {"B r0": True}
    assert not decide(arms(), StudyTargets(time_ratio=12.0)).time_met  # the target is the spec's, not the code's
    assert decide(arms(b_top1=0.70), StudyTargets()).best_b is None  # below A's interval
    assert decide(arms(b_top1=0.76), StudyTargets()).b_beats_random == {"B r0": False}  # below R of its size


def test_the_adaptive_arm_meets_its_targets_only_inside_a_s_intervals_at_its_share_of_a_s_cost():
    def with_u(seconds: float, top1: float, ap: float):
        return finish_arms([ArmDraft("A", "A", cost(100, 1000), score(0.8, 0.7)),
                            ArmDraft("R 0.05", "R", cost(5, 50), score(0.70, 0.60), share=0.05),
                            ArmDraft("R 0.1", "R", cost(10, 100), score(0.79, 0.68), share=0.1),
                            ArmDraft("U", "U", cost(seconds, 80), score(top1, ap)),
                            ArmDraft("R ~U", "R", cost(8, 80), score(0.7, 0.6))])

    cheap = decide(with_u(9, 0.79, 0.69), StudyTargets(adaptive_share=0.1))
    assert cheap.u_met and cheap.u_cost_share == 0.09 and cheap.r_labels_at_u_ap is None  # no R reaches its AP
    assert not decide(with_u(9, 0.79, 0.69), StudyTargets(adaptive_share=0.05)).u_met  # the spec's share
    assert not decide(with_u(9, 0.70, 0.69), StudyTargets()).u_met  # outside A's top-1 interval
    assert decide(with_u(9, 0.79, 0.60), StudyTargets()).r_labels_at_u_ap == 50  # R 0.05 reaches AP 0.60


def test_a_study_with_views_crops_every_job_from_depth_views_and_refuses_keys_of_the_full_surface():
    spec = StudySpec(**{**TINY, "views": 8})
    jobs = [spec.job_spec(spec.train, 4, 0, "a.zarr"), spec.job_spec(spec.heldout, 4, 1, "h.zarr")]
    assert all(job.views.crop == "partial" and job.views.count == 8 for job in jobs)
    assert all(job.views.sampling == "view" for job in jobs)  # proposed as the planner proposes (issue 51)
    mesh = StudySpec(**{**TINY, "views": 8, "view_sampling": "mesh"}).job_spec(spec.train, 4, 0, "a.zarr")
    assert mesh.views.sampling == "mesh" and mesh.views.crop == "partial"
    assert StudySpec(**TINY).job_spec(spec.train, 4, 0, "a.zarr").views.crop == "full"
    with pytest.raises(SpecError, match="keys are computed from crops of the full surface"):
        load_study_spec(None, {**TINY, "views": 8, "keys": [{"name": "k", "kind": "occupancy"}]})


def test_a_study_spec_names_the_field_it_refuses(tmp_path):
    with pytest.raises(SpecError, match=r"budgets"):
        load_study_spec(None, {"budgets": [0.0]})
    bad = tmp_path / "study.yaml"
    bad.write_text("radii: [0, 0]\n")
    with pytest.raises(SpecError, match=rf"{bad}: invalid study\n  radii"):
        load_study_spec(bad, {})
    assert load_study_spec(None, {"train": "x"}, quick=True).training.model == "voxel"


@pytest.mark.parametrize("path", sorted((ROOT / "examples" / "studies").glob("*.yaml")), ids=lambda p: p.stem)
def test_every_example_study_is_a_valid_study(path):
    spec = load_study_spec(path, {})
    assert spec.train and spec.heldout and spec.train != spec.heldout


def test_quick_is_the_quick_example_study():
    given = {"train": "pybullet:random_urdfs[0:8]", "heldout": "pybullet:random_urdfs[500:508]"}
    assert load_study_spec(None, given, quick=True) == load_study_spec(ROOT / "examples/studies/quick.yaml", {})


def test_a_stage_the_pipeline_does_not_run_is_refused_by_the_spec():
    from onepiece_dist.job import pipeline
    from onepiece_dist.specs.job import STAGES, parse_job_spec

    with pytest.raises(SpecError, match=r"stages\.1 = \"report\""):
        parse_job_spec({"stages": ["ingest", "report"]})
    run = set(re.findall(r'stage\(status, "(\w+)"', Path(pipeline.__file__).read_text()))
    assert run == set(STAGES)  # every name the spec takes is a stage the pipeline runs


@pytest.mark.sim
def test_bad_input_is_refused_before_any_work_and_names_the_objects(tmp_path):
    from onepiece_dist.study.runner import Where, run_study

    overlap = StudySpec(**{**TINY, "heldout": "pybullet:random_urdfs[2:5]"})
    with pytest.raises(SourceError, match=r"2 held-out objects are also train objects.*random_urdfs/002"):
        run_study(overlap, tmp_path / "a", Where(in_process=True))
    assert not (tmp_path / "a").exists()  # nothing written
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "nan.obj").write_text("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    rejected = StudySpec(**{**TINY, "train": str(tmp_path / "bad")})
    with pytest.raises(SourceError, match=r"all 1 objects were rejected:\n  nan.obj: .*not finite"):
        run_study(rejected, tmp_path / "b", Where(in_process=True))
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "study.spec.json").write_text(StudySpec(**{**TINY, "seed": 5}).model_dump_json())
    with pytest.raises(SpecError, match=r"holds another study's results"):
        run_study(StudySpec(**TINY), tmp_path / "c", Where(in_process=True))
