"""benchmarks/paper_experiment.py: its statistics, its page rendered from the committed results, and `--quick` as a
smoke test of the whole script (every arm generated, trained and scored for real)."""

import dataclasses
import importlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.store.format import FORMAT_VERSION

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
learn = importlib.import_module("benchmarks.experiment_learn")
page = importlib.import_module("onepiece_dist.study.experiment_page")
training = importlib.import_module("benchmarks.experiment_train")


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
    result = json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
    assert result["args"].get("name", "paper_experiment") == name
    page.write_page(result, tmp_path / "page.md", ROOT / "benchmarks" / "results")
    assert (ROOT / "docs" / f"{name}.md").read_text() == (tmp_path / "page.md").read_text(), \
        f"docs/{name}.md is stale: rerun benchmarks/paper_experiment.py (or render its results)"
    for plot in ("cost", "tradeoff"):
        assert f"]({name}_{plot}.png)" in (tmp_path / "page.md").read_text()
        assert (ROOT / "docs" / f"{name}_{plot}.png").stat().st_size > 1000


def test_a_training_result_is_reused_only_for_the_same_job_on_the_same_datasets(tmp_path):
    experiment = training
    status, cache = tmp_path / "A.zarr.status.json", tmp_path / "trained"
    status.write_text('{"state": "succeeded"}')
    job = learn.TrainJob("A", 0, str(tmp_path / "A.zarr"), "grasps", np.arange(5), str(tmp_path / "heldout.zarr"),
                         "pointnet", 10, 8, 1e-3, 0.2)
    run = {"arm": "A", "seed": 0, "train_seconds": 1.5, "scores": np.linspace(0, 1, 7, dtype=np.float32)}
    assert experiment._cached_run(job, cache) is None
    experiment._store_run(job, run, cache)
    back = experiment._cached_run(job, cache)
    assert back["reused"] and back["train_seconds"] == 1.5 and np.array_equal(back["scores"], run["scores"])
    assert experiment._cached_run(dataclasses.replace(job, seed=1), cache) is None
    assert experiment._cached_run(dataclasses.replace(job, rows=np.arange(6)), cache) is None
    status.write_text('{"state": "succeeded", "made": "again"}')  # the dataset was made again
    assert experiment._cached_run(job, cache) is None


def _job(arm: str, seed: int) -> "learn.TrainJob":
    return learn.TrainJob(arm, seed, f"{arm}.zarr", "grasps", None, "heldout.zarr", "pointnet", 10, 8, 1.0, 0.2)


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
    runs, search = training.train_with_search(jobs, training.parse_rates("0.01,0.001,0.003"), train)
    assert {arm: row["chosen"] for arm, row in search.items()} == best
    assert search["A"]["probes"][0] == {"learning_rate": 0.001, "val_loss": 1.5}  # the lowest of its curve
    assert len(calls[0]) == 6 and {seed for _, seed, _ in calls[0]} == {0}  # probes: seed 0 at every rate
    assert sorted(calls[1]) == [("A", 1, 0.01), ("A", 2, 0.01), ("B r0", 1, 0.001), ("B r0", 2, 0.001)]
    assert [(r["arm"], r["seed"], r["rate"]) for r in runs] == [(j.arm, j.seed, best[j.arm]) for j in jobs]
    runs, search = training.train_with_search(jobs, [0.002], train)  # one rate: no search
    assert search == {} and {r["rate"] for r in runs} == {0.002}
    with pytest.raises(ValueError, match="--learning-rates"):
        training.parse_rates("0.001,-1")


@pytest.mark.slow
@pytest.mark.sim
def test_the_quick_experiment_runs_every_arm_and_renders_a_page_that_decides(tmp_path):
    subprocess.run([sys.executable, "-m", "benchmarks.paper_experiment", "--quick", "--out", str(tmp_path),
                    "--folder", str(tmp_path / "work")], check=True, capture_output=True, timeout=600, cwd=ROOT)
    out = json.loads((tmp_path / "benchmarks" / "results" / "paper_experiment.json").read_text())
    arms = {row["arm"]: row for row in out["arms"]}
    assert set(arms) == {"A", "B r0", "B r1", "B static r0", "R r0", "R r1", "R static r0"}  # --quick: static r0
    for name in ("r0", "r1"):  # R labels exactly as many grasps as its B arm, on their own objects
        assert arms[f"R {name}"]["labelled_grasps"] == arms[f"B {name}"]["labelled_grasps"] > 0
    assert arms["B r1"]["unique_codes"] <= arms["B r0"]["unique_codes"]
    for row in out["arms"]:
        held = row["heldout"]
        assert len(held["seeds"]) == 2 and held["top1"]["ci95"][0] <= held["top1"]["mean"] <= held["top1"]["ci95"][1]
        assert held["ap"]["ci95"][0] <= held["ap"]["ci95"][1]
        assert row["time_ratio"] == pytest.approx(arms["A"]["core_seconds"] / row["core_seconds"], rel=1e-2)
    assert out["heldout"]["objects"] >= 2 and 0 <= out["heldout"]["positive_rate"] <= 1
    assert [r["candidates_per_object"] for r in out["cost_curve"]["rows"]] == [12, 12, 24, 24]
    assert {(r["resolution_mm"], r["radius"]) for r in out["tradeoff"]} == {(10.0, 0), (10.0, 1)}
    for row in out["label_transfer"]:  # B's patch labels against A's labels of the same grasps
        every = row["patch_vs_every_grasp"]
        assert row["aligned"] and every["pairs"] > 0 and 0 <= every["success_agreement"] <= 1
        assert row["unmatched_grasps"] < every["pairs"]
    text = (tmp_path / "docs" / "paper_experiment.md").read_text()
    assert "| paper (ONE PIECE) |" in text and "**Time, 8x:**" in text
    assert ("not met" in text) == (not (out["decision"]["time_met"] and out["decision"]["storage_met"]))
    assert (tmp_path / "docs" / "paper_experiment_cost.png").stat().st_size > 1000
    search = out["learning_rate_search"]  # --quick probes 0.001 and 0.003 on each arm's validation split
    assert set(search) == set(arms) and out["training_runs"] == len(arms) * 3  # 2 probes + 1 more seed per arm
    for arm, row in search.items():
        assert row["chosen"] == min(row["probes"], key=lambda p: p["val_loss"])["learning_rate"]
        assert arms[arm]["learning_rate"] == row["chosen"]
    assert "validation split picked among 0.001, 0.003" in text
    _train_longer_on_its_exported_arms(out, tmp_path)


def _train_longer_on_its_exported_arms(out: dict, tmp_path: Path) -> None:
    """benchmarks/experiment_longer.py on the quick run's folder: the exported rows are the ones each seed trained
    on; three arms train again (a few steps) from the arrays alone and are scored on the same held-out grasps."""
    longer = importlib.import_module("benchmarks.experiment_longer")
    longer.export(tmp_path / "work", out, tmp_path / "arms.npz")
    data = np.load(tmp_path / "arms.npz", allow_pickle=False)
    trained = {(row["arm"], s["seed"]): s["train_grasps"] for row in out["arms"] for s in row["heldout"]["seeds"]}
    plan = json.loads(str(data["plan"]))["runs"]
    assert {(r["arm"], r["seed"]) for r in plan} == set(trained)
    assert all(len(data[f"train_{r['key']}"]) == trained[(r["arm"], r["seed"])] for r in plan)
    args = longer.parse_args(["train", "--data", str(tmp_path / "arms.npz"), "--out", str(tmp_path / "runs"),
                              "--steps", "4", "--batch-size", "8", "--rates", "chosen", "--arms", "A,B r0,R r0",
                              "--workers", "1", "--evaluations", "2", "--device", "cpu"])
    assert len(longer.train_all(args)) == 3
    result = longer.report(tmp_path / "arms.npz", tmp_path / "runs", out, "test")
    assert [a["arm"] for a in result["arms"]] == ["A", "B r0", "R r0"]
    for arm in result["arms"]:
        assert arm["learning_rate"] == arm["cpu_learning_rate"] and len(arm["heldout"]["seeds"]) == 2
    assert result["heldout"]["grasps"] == out["heldout"]["grasps"] and "| B r0 |" in longer.page(result)


def _arm(name: str, core_seconds: float, top1: float, ap: float) -> dict:
    return {"arm": name, "core_seconds": core_seconds, "labelled_bytes": core_seconds, "dataset_bytes": 1.0,
            "heldout": {"top1": {"mean": top1, "ci95": [top1 - 0.07, top1 + 0.07]}, "ap": {"mean": ap}}}


@pytest.mark.parametrize("b_ap, holds", [(0.70, True), (0.66, False)])
def test_b_is_as_good_as_r_only_when_its_top1_and_its_ap_both_are(b_ap, holds):
    experiment = importlib.import_module("benchmarks.paper_experiment")
    out = {"arms": [_arm("A", 1000.0, 0.85, 0.72), _arm("B r2", 150.0, 0.83, b_ap), _arm("R r2", 20.0, 0.80, 0.70)],
           "heldout": {"positive_rate": 0.44}}
    d = experiment.decide(out)
    assert d["best_b"] == "B r2" and d["control"] == "R r2" and d["time_ratio"] == pytest.approx(6.667, abs=1e-3)
    assert d["b_at_least_r"] is holds and d["b_against_r"] == {"top1": [0.83, 0.8], "ap": [b_ap, 0.7]}
    assert page._against(d) == f": top-1 83.0% against 80.0%, AP {b_ap:.3f} against 0.700; both must be at least R's"


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


def test_the_representatives_dataset_gives_each_labelled_patch_its_representatives_crop(tmp_path):
    import zarr

    from onepiece_dist.learn.dataset import GraspDataset

    variants = importlib.import_module("benchmarks.experiment_b_variants")
    source = zarr.open_group(str(tmp_path / "b.zarr"), mode="w")
    source.attrs.update({"onepiece_format": FORMAT_VERSION, "complete": True, "grid_shape": [4, 8, 2], "code_bytes": 8,
                         "assembly": {"unique_codes": 3}})
    crops = np.random.default_rng(0).normal(size=(3, 16, 3)).astype(np.float16)
    source.create_array("unique/points", data=crops)
    source.create_array("assembled/grasps/patch", data=np.array([2, 0, 2], dtype=np.int32))
    source.create_array("assembled/grasps/success", data=np.array([1, 0, 0], dtype=np.uint8))
    out = variants.representatives_dataset(tmp_path / "b.zarr", tmp_path / "rep.zarr")
    data = GraspDataset(str(out), "grasps", inputs=("points",))
    assert len(data) == 3 and np.array_equal(data.groups, [2, 0, 2])
    batch = data.batch(np.arange(3))
    assert np.array_equal(np.asarray(batch["points"], dtype=np.float16), crops[[2, 0, 2]])
    assert np.array_equal(np.asarray(batch["label"]), [1, 0, 0])
    assert "assembly" not in zarr.open_group(str(out), mode="r").attrs  # the one object's report is not its own


def _group(path, arrays: dict):
    import zarr

    group = zarr.open_group(str(path), mode="w")
    group.attrs.update({"onepiece_format": FORMAT_VERSION, "complete": True, "grid_shape": [4, 8, 2], "code_bytes": 8})
    for name, data in arrays.items():
        group.create_array(name, data=data)
    return group


def test_the_source_labels_dataset_gives_each_patch_the_label_a_gave_its_representative(tmp_path):
    from onepiece_dist.learn.dataset import GraspDataset
    from onepiece_dist.store.dataset import encode_names

    variants = importlib.import_module("benchmarks.experiment_b_variants")
    poses = np.tile(np.eye(4), (5, 1, 1))
    poses[:, 0, 3] = np.arange(5)  # B's grasp k: object [duck, duck, mug, mug, mug][k], candidate k
    crops = np.random.default_rng(0).normal(size=(3, 16, 3)).astype(np.float16)
    _group(tmp_path / "b.zarr", {"objects/name": encode_names(["duck", "mug"]),
                                 "grasps/object": np.array([0, 0, 1, 1, 1], np.int32), "grasps/candidate_pose": poses,
                                 "unique/points": crops, "unique/representative": np.array([4, 1, 2]),
                                 "assembled/grasps/patch": np.array([2, 0, 2, 1], np.int32),
                                 "assembled/grasps/success": np.array([1, 0, 1, 1], np.uint8)})
    # A lists the objects the other way round and never labelled B's grasp 1 (patch 1's representative)
    _group(tmp_path / "a.zarr", {"objects/name": encode_names(["mug", "duck"]),
                                 "grasps/candidate_pose": poses[[4, 2, 0]],
                                 "grasps/object": np.array([0, 0, 1], np.int32),
                                 "grasps/success": np.array([1, 0, 1], np.uint8)})
    out = variants.source_labels_dataset(tmp_path / "b.zarr", tmp_path / "a.zarr", tmp_path / "src.zarr")
    data = GraspDataset(str(out), "grasps", inputs=("points",))
    assert np.array_equal(data.groups, [2, 0, 2])  # patch 1's row is left out
    batch = data.batch(np.arange(3))
    assert np.array_equal(np.asarray(batch["points"], dtype=np.float16), crops[[2, 0, 2]])
    assert np.array_equal(np.asarray(batch["label"]), [0, 1, 0])  # A's labels of grasps 2, 4, 2; not B's 1, 0, 1


def test_repeat_agreement_counts_equal_labels_against_the_floor_of_independent_ones():
    variants = importlib.import_module("benchmarks.experiment_b_variants")
    first, again = np.array([1, 1, 0, 0], bool), np.array([1, 0, 0, 0], bool)
    out = variants.repeat_agreement(first, again, np.array([1.0, 0.75, 0.5, 0.0]), np.array([1.0, 0.5, 0.25, 0.0]))
    assert out["agreement"] == 0.75 and out["independent_floor"] == 0.5  # 0.5 * 0.25 + 0.5 * 0.75
    assert out["positive_rate"] == 0.5 and out["positive_rate_again"] == 0.25 and out["quality_correlation"] > 0.9
    assert variants.repeat_agreement(first, first, np.ones(4), np.ones(4))["quality_correlation"] is None


def _variant_row(radius: int, variant: str, ap: float, top1: float) -> dict:
    return {"radius": radius, "variant": variant, "top1": top1, "top1_ci95": [top1 - 0.05, top1 + 0.05], "ap": ap,
            "ap_std": 0.01, "ap_ci95": [ap - 0.02, ap + 0.02], "seeds": 3, "experiment_b_ap": 0.69,
            "experiment_r_ap": 0.71, "experiment_r_top1": 0.89}


def test_the_variants_page_says_whether_perfect_patches_reach_r_and_how_far_labels_repeat():
    page = importlib.import_module("onepiece_dist.study.experiment_page")
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


def test_the_label_load_reaches_every_arm_spec_and_the_page_says_which_it_was(tmp_path):
    experiment = importlib.import_module("benchmarks.paper_experiment")
    args = experiment.parse_args(["--quick", "--load", "grasp", "--load-mass", "0.25", "--name", "run_b"])
    spec = experiment.base_spec(args, tmp_path)
    assert (spec.sim.load, spec.sim.load_mass, args.name) == ("grasp", 0.25, "run_b")
    assert experiment.base_spec(experiment.parse_args(["--quick"]), tmp_path).sim.load == "object"
    grasp = page._label_load({"args": vars(args)})
    assert "payload of 0.25 kg at the grasp centre" in grasp and "docs/paper_experiment.md" in grasp
    assert "docs/paper_experiment_grasp_load.md" in page._label_load({"args": {"load": "object"}})
