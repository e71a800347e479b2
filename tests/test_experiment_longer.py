"""The committed longer trainings of the experiment's arms (study/longer_page.py): their verdict and their pages
rendered from the committed results. Longer budgets are now a study's `training.steps`."""

import importlib
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
longer = importlib.import_module("benchmarks.pages.longer_page")


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


@pytest.mark.parametrize("name", COMMITTED)
def test_the_committed_longer_page_is_the_rendering_of_its_results(name):
    result = json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
    assert longer.longer_name(result) == name and result["source"] == name.split("_longer")[0]
    assert result["decision"] == json.loads(json.dumps(longer.decide(result)))
    assert (ROOT / "docs" / f"{name}.md").read_text() == longer.page(result), \
        f"docs/{name}.md is stale: render its results (benchmarks/pages/longer_page.py)"


def test_both_budgets_are_committed_and_linked_from_the_experiment_page():
    assert {"paper_experiment_grasp_load_longer", "paper_experiment_grasp_load_longer_gpu32",
            "paper_experiment_grasp_load_longer_gpu64"} <= set(COMMITTED)
    text = (ROOT / "docs" / "paper_experiment_grasp_load.md").read_text()
    assert all(f"docs/{name}.md (" in text for name in COMMITTED if name.startswith("paper_experiment_grasp_load"))
