"""The paper experiment's statistics (study.stats), its learning-rate search (study.training), and its committed pages
rendered by the package from the committed results. The experiment itself is now a study configuration
(examples/studies/paper.yaml; tests/test_study.py runs studies for real)."""

import dataclasses
import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.study.training import search_rates

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
learn = importlib.import_module("onepiece_dist.study.stats")
page = importlib.import_module("benchmarks.pages.experiment_page")


def test_the_bootstrap_interval_holds_the_mean_and_narrows_with_more_objects():
    rng = np.random.default_rng(0)
    few, many = rng.random(10) < 0.7, rng.random(400) < 0.7
    low, high = learn.bootstrap_interval(few.astype(float))
    assert low <= few.mean() <= high
    wide = high - low
    low, high = learn.bootstrap_interval(many.astype(float))
    assert low <= many.mean() <= high and high - low < wide / 3


def test_top_k_success_takes_each_objects_best_scored_grasps():
    labels = np.array([0, 1, 1, 0, 0, 0, 1], dtype=float)
    groups = np.array([0, 0, 0, 1, 1, 1, 1])
    scores = np.array([0.9, 0.8, 0.1, 0.2, 0.3, 0.1, 0.95])
    top1, top5 = learn.per_object_top(scores, labels, groups)
    assert top1.tolist() == [0.0, 1.0]
    assert top5.tolist() == [pytest.approx(2 / 3), 0.25]
    base = learn.baselines(labels, groups)
    assert base["oracle"] == 1.0 and base["random_choice"] == pytest.approx((2 / 3 + 0.25) / 2)


def test_pair_agreement_is_perfect_when_the_code_decides_the_label_and_lower_for_random_pairs():
    cluster = np.repeat(np.arange(40), 5)
    quality = np.repeat(np.linspace(0, 1, 40), 5)
    success = (quality > 0.5).astype(float)
    out = learn.pair_agreement(success, quality, cluster, seed=0)
    assert out["same_code"]["success_agreement"] == 1.0 and out["same_code"]["pairs"] == 160
    assert out["same_code"]["quality_correlation"] == pytest.approx(1.0)
    assert out["random_pairs"]["success_agreement"] < 0.7


@pytest.mark.parametrize("name", ["paper_experiment", "paper_experiment_grasp_load"])
def test_the_committed_page_is_the_rendering_of_the_committed_results(tmp_path, name):
    result = json.loads((RESULTS / f"{name}.json").read_text())
    assert result["args"].get("name", "paper_experiment") == name
    page.write_page(result, tmp_path / "page.md", ROOT / "benchmarks" / "results")
    assert (ROOT / "docs" / f"{name}.md").read_text() == (tmp_path / "page.md").read_text(), \
        f"docs/{name}.md is stale: render its results (benchmarks/pages/experiment_page.py)"
    for plot in ("cost", "tradeoff"):
        assert f"]({name}_{plot}.png)" in (tmp_path / "page.md").read_text()
        assert (ROOT / "docs" / f"{name}_{plot}.png").stat().st_size > 1000


@dataclasses.dataclass(frozen=True)
class _Job:
    arm: str
    seed: int
    learning_rate: float = 1.0


def _job(arm: str, seed: int) -> _Job:
    return _Job(arm, seed)


def _lowest(run: dict) -> float:
    return round(min(point["val_loss"] for point in run["curve"]), 5)


def test_each_arm_keeps_the_learning_rate_its_validation_loss_picks_and_trains_its_other_seeds_at_it():
    best = {"A": 0.01, "B r0": 0.001}  # a trainer whose validation loss is lowest at each arm's own rate
    calls = []

    def train(jobs):
        calls.append([(job.arm, job.seed, job.learning_rate) for job in jobs])
        return [{"arm": job.arm, "seed": job.seed, "rate": job.learning_rate,
                 "curve": [{"step": 5, "val_loss": 1 + abs(np.log10(job.learning_rate / best[job.arm]))},
                           {"step": 10, "val_loss": 0.5 + abs(np.log10(job.learning_rate / best[job.arm]))}]}
                for job in jobs]

    jobs = [_job(arm, seed) for arm in ("A", "B r0") for seed in (0, 1, 2)]
    runs, search = search_rates(jobs, [0.01, 0.001, 0.003], train, _lowest)
    assert {arm: row["chosen"] for arm, row in search.items()} == best
    assert search["A"]["probes"][0] == {"learning_rate": 0.001, "val_loss": 1.5}  # the lowest of its curve
    assert len(calls[0]) == 6 and {seed for _, seed, _ in calls[0]} == {0}  # probes: seed 0 at every rate
    assert sorted(calls[1]) == [("A", 1, 0.01), ("A", 2, 0.01), ("B r0", 1, 0.001), ("B r0", 2, 0.001)]
    assert [(r["arm"], r["seed"], r["rate"]) for r in runs] == [(j.arm, j.seed, best[j.arm]) for j in jobs]
    runs, search = search_rates(jobs, [0.002], train, _lowest)  # one rate: no search
    assert search == {} and {r["rate"] for r in runs} == {0.002}


def test_patch_weights_follow_the_code_counts_with_mean_one_and_only_on_the_one_object(tmp_path):
    import zarr

    from onepiece_dist.learn.train import patch_weights

    group = zarr.open_group(str(tmp_path / "b.zarr"), mode="w")
    group.create_array("unique/count", data=np.array([1, 4, 9, 16], dtype=np.int64))
    path = str(tmp_path / "b.zarr")
    assert patch_weights(path, "assembled/grasps", "none") is None  # the experiment's B: every patch weighs 1
    count = patch_weights(path, "assembled/grasps", "count").numpy()
    root = patch_weights(path, "assembled/grasps", "sqrt").numpy()
    assert np.allclose(count, np.array([1, 4, 9, 16]) / 7.5) and np.allclose(root, np.array([1, 2, 3, 4]) / 2.5)
    assert patch_weights(path, "grasps", "count") is None
    with pytest.raises(ValueError, match="'cube'"):
        patch_weights(path, "assembled/grasps", "cube")


def _variant_row(radius: int, variant: str, ap: float, top1: float) -> dict:
    return {"radius": radius, "variant": variant, "top1": top1, "top1_ci95": [top1 - 0.05, top1 + 0.05], "ap": ap,
            "ap_std": 0.01, "ap_ci95": [ap - 0.02, ap + 0.02], "seeds": 3, "experiment_b_ap": 0.69,
            "experiment_r_ap": 0.71, "experiment_r_top1": 0.89}


def test_the_variants_page_says_whether_perfect_patches_reach_r_and_how_far_labels_repeat():
    page = importlib.import_module("benchmarks.pages.experiment_sections")
    rows = [_variant_row(radius, variant, ap, top1) for radius, variant, ap, top1 in (
        (0, "as_trained", 0.69, 0.84), (0, "representatives", 0.692, 0.87), (0, "source_labels", 0.72, 0.90),
        (2, "as_trained", 0.67, 0.83), (2, "representatives", 0.66, 0.82), (2, "source_labels", 0.70, 0.95))]
    r = {"command": "python -m benchmarks.experiment_b_variants", "date": "2026-11-27", "machine": "x86_64",
         "experiment": "python -m benchmarks.paper_experiment", "experiment_date": "2026-11-27", "model": "pointnet",
         "steps": 500, "heldout_random_choice": 0.42, "rows": rows,
         "label_transfer": {"0": {"patch_vs_representative": 0.66, "patch_vs_every_grasp": 0.525}},
         "label_repeatability": {"grasps": 2560, "agreement": 0.75, "quality_correlation": 0.6,
                                 "positive_rate": 0.44, "positive_rate_again": 0.45, "independent_floor": 0.5}}
    text = "\n".join(page.variants_section(r, RESULTS))
    assert "Lifts B to R: r0 representatives' own crops and A's labels." in text  # r2's AP 0.70 < R's 0.71
    perfect = [line for line in text.splitlines() if line.startswith("- r")]
    assert "reaches R" in perfect[0] and "from 0.690 to 0.692" in perfect[0] and "still trails R" in perfect[1]
    assert "agree with A's labels 75.0%" in text and "r0: 66.0% with their representatives'" in text
    r["label_repeatability"] = None
    assert "repeats itself" not in "\n".join(page.variants_section(r, RESULTS))
    r["dataset_counts"] = {"B r0": [11118, 11128], "heldout": [7502, 7500]}
    assert "B r0 11,118 (11,128), heldout 7,502 (7,500)" in "\n".join(page.variants_section(r, RESULTS))
    r["dataset_counts"] = {"B r0": [11128, 11128], "heldout": [7500, 7500]}
    assert "the experiment's own (same counts)" in "\n".join(page.variants_section(r, RESULTS))


def test_the_page_says_which_label_load_the_run_lifted():
    grasp = page._label_load({"args": {"load": "grasp", "load_mass": 0.25}})
    assert "payload of 0.25 kg at the grasp centre" in grasp and "docs/paper_experiment.md" in grasp
    assert "docs/paper_experiment_grasp_load.md" in page._label_load({"args": {"load": "object"}})
