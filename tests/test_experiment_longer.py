"""benchmarks/experiment_longer.py: the experiment's arms trained with a larger budget on exported arrays (torch
and numpy only), scored with the experiment's statistics, its page rendered from the committed results."""

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
longer = importlib.import_module("benchmarks.experiment_longer")
learn = importlib.import_module("benchmarks.experiment_learn")


def _separable(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 32, 3) int8 point sets whose label is which side of the gripper's x axis they lie on, and (n,) labels."""
    rng = np.random.default_rng(seed)
    labels = (rng.random(n) < 0.5).astype(np.uint8)
    points = rng.integers(5, 120, (n, 32, 3))
    points[:, :, 0] *= np.where(labels == 1, 1, -1)[:, None]
    return points.astype(np.int8), labels


def test_a_run_learns_a_separable_set_and_scores_the_heldout_grasps_with_its_best_checkpoint():
    torch = pytest.importorskip("torch")
    points, labels = _separable(200, 0)
    held, held_labels = _separable(100, 1)
    data = {"scale": np.float64(0.0004), "points_toy": points, "success_toy": labels, "points_heldout": held}
    arm = longer.ArmData(data, "toy", torch.device("cpu"))
    run = longer.fit(arm, torch.arange(150), torch.arange(150, 200), 3e-3, seed=0, steps=60, batch=32,
                     evaluations=4)
    assert [c["step"] for c in run["curve"]] == [15, 30, 45, 60]
    best = min(run["curve"], key=lambda c: c["val_loss"])
    assert run["best_step"] == best["step"] and run["best_val_loss"] == pytest.approx(best["val_loss"], abs=1e-4)
    assert run["scores"].shape == (100,) and run["train_grasps"] == 150
    from onepiece_dist.learn.train import average_precision

    assert average_precision(run["scores"], held_labels.astype(float)) > 0.95


def test_a_plan_takes_the_two_core_runs_rate_only_when_told_to():
    run = {"cpu_learning_rate": 0.003}
    assert longer._rates("chosen", run) == [0.003]
    assert longer._rates("0.001,0.01", run) == [0.001, 0.01]


def _arm(name: str, top1: float, ap: float, low: float, best_step: int = 10) -> dict:
    held = {"top1": {"mean": top1, "ci95": [low, top1 + 0.05]}, "ap": {"mean": ap},
            "seeds": [{"best_step": 10}, {"best_step": best_step}, {"best_step": 20}]}
    return {"arm": name, "heldout": held, "cpu_heldout": {"ap": ap - 0.03}}


def test_the_verdict_names_the_b_arms_within_as_interval_and_compares_each_with_its_r():
    out = {"steps": 20, "arms": [_arm("A", 0.80, 0.70, 0.72), _arm("B r0", 0.75, 0.66, 0.6),
                                 _arm("B r2", 0.70, 0.69, 0.6, best_step=20), _arm("R r0", 0.78, 0.69, 0.7),
                                 _arm("R r2", 0.74, 0.68, 0.66)]}
    decision = longer.decide(out)
    assert decision["qualifying_b"] == ["B r0"] and decision["a_top1_low"] == 0.72
    assert decision["b_at_least_r"] == {"B r0": False, "B r2": True}
    text = "\n".join(longer._verdict(out))
    assert "72.0%):** B r0." in text and "own objects) within A's interval:** R r0, R r2." in text
    assert "B r2 at least as good as R r2 (AP):** holds: 0.690 against 0.680" in text
    assert "more than 0.02 for:** A, B r0, B r2, R r0, R r2" in text
    assert "last one):** B r2: a longer run" in text  # its median best checkpoint is the last step


COMMITTED = sorted(p.stem for p in (ROOT / "benchmarks" / "results").glob("*_longer*.json"))


def test_a_tagged_budget_has_its_own_files_beside_the_first():
    assert longer.longer_name({"source": "paper_experiment", "tag": ""}) == "paper_experiment_longer"
    assert longer.longer_name({"source": "paper_experiment", "tag": "gpu"}) == "paper_experiment_longer_gpu"
    assert longer.parse_args(["report", "--data", "d", "--runs", "r", "--results", "x", "--train-command", "c",
                              "--tag", "gpu"]).tag == "gpu"


@pytest.mark.parametrize("name", COMMITTED)
def test_the_committed_longer_page_is_the_rendering_of_its_results(name):
    result = json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
    assert longer.longer_name(result) == name and result["source"] == name.split("_longer")[0]
    assert result["decision"] == json.loads(json.dumps(longer.decide(result)))
    assert (ROOT / "docs" / f"{name}.md").read_text() == longer.page(result), \
        f"docs/{name}.md is stale: rerun benchmarks/experiment_longer.py report"


def test_both_budgets_are_committed_and_linked_from_the_experiment_page():
    assert {"paper_experiment_grasp_load_longer", "paper_experiment_grasp_load_longer_gpu32",
            "paper_experiment_grasp_load_longer_gpu64"} <= set(COMMITTED)
    text = (ROOT / "docs" / "paper_experiment_grasp_load.md").read_text()
    assert all(f"docs/{name}.md (" in text for name in COMMITTED if name.startswith("paper_experiment_grasp_load"))
