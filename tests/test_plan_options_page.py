"""The picks page's section on the planner's options (issue 55): each variant is kept only by the trials' rule on the
household objects, and says what it changed."""

from __future__ import annotations

import copy
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_a_planner_option_is_kept_by_its_household_interval_and_says_what_it_changed():
    from benchmarks.pages.pick_plan_options_section import plan_options_section

    result, table_gap = (json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
                         for name in ("pick_plan_options", "pick_table_gap"))
    page = "\n".join(plan_options_section(result, table_gap))
    for name, run in result["variants"].items():
        verdict = "kept" if run["versus"]["household"]["interval"][0] > 0 else "not kept"
        assert f"`{name}`: {verdict}" in page.rpartition("the trials' rule")[2]
    assert "up to 7 more grasps checked where none of the first 3 held every draw" in page
    assert "no non-maximum suppression" in page
    lifted = copy.deepcopy(result)
    lifted["variants"]["check_more_3"]["versus"]["household"]["interval"] = [0.001, 0.02]
    assert "`check_more_3`: kept" in "\n".join(plan_options_section(lifted, table_gap))  # the rule reads the interval



def test_a_network_variant_says_which_network_and_a_planner_option_plans_with_the_shipped_one():
    from benchmarks.experiments.pick_plan_options import NETWORKS, checkpoint
    from benchmarks.experiments.pick_table_gap import network
    from benchmarks.pages.pick_plan_options_section import plan_options_section

    assert checkpoint("nms_none") == network("default")
    result, table_gap = (json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
                         for name in ("pick_plan_options", "pick_table_gap"))
    page = "\n".join(plan_options_section(result, table_gap))
    judged = [name for name, run in result["variants"].items() if "network" in run]
    assert judged and set(judged) <= set(NETWORKS)
    for name in judged:
        label, fit = result["variants"][name]["network"]
        assert (f"`{name}`: the network a user makes with pick-labels' defaults (label seed {label}) and "
                f"pick-train started from the shipped one (fit seed {fit})") in page


def test_a_relabelled_variant_names_its_seed_and_one_whose_network_is_missing_says_how_to_make_it(tmp_path,
                                                                                                monkeypatch):
    import pytest

    from benchmarks.experiments import pick_plan_options
    from benchmarks.pages.pick_plan_options_section import plan_options_section

    result, table_gap = (json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
                         for name in ("pick_plan_options", "pick_table_gap"))
    page = "\n".join(plan_options_section(result, table_gap))
    relabelled = {name: run["relabelled"] for name, run in result["variants"].items() if "relabelled" in run}
    for name, seed in relabelled.items():
        assert f"`{name}`: the shipped recipe labelled again by the planner as it ships (pick_relabelled's network " \
               f"at seed {seed})" in page
    assert ("the `relabelled_` variants" in page) == bool(relabelled)
    monkeypatch.setattr(pick_plan_options, "ROOT", tmp_path)  # a checkout without the network: refused, saying
    with pytest.raises(SystemExit, match="pick_relabelled --seeds 1"):  # the command that makes it
        pick_plan_options.checkpoint("relabelled_s1")
    made = tmp_path / "data" / "pick_curve" / "relabelled" / "relabelled_s1" / "best.pt"
    made.parent.mkdir(parents=True)
    made.write_bytes(b"")
    assert pick_plan_options.checkpoint("relabelled_s1") == made


def test_fresh_fits_on_labels_made_at_two_heights_are_paired_seed_for_seed():
    from benchmarks.pages.pick_plan_options_section import _heights

    def run(label: int, height: float, picked: int) -> dict:
        views = [{"view": v, "attempts": {"network": [v < picked]}} for v in range(4)]
        sets = [{"name": name, "objects": [{"name": f"{name}.obj", "status": "ok", "views": views}]}
                for name in ("household", "unseen")]
        return {"fresh": {"label": label, "fit": 0, "table_clearance": height}, "sets": sets}

    variants = {"a": run(0, 0.002, 2), "b": run(0, 0.008, 3), "c": run(1, 0.002, 1)}  # label seed 1: one height
    line = _heights(variants)[0]
    assert line.startswith("Labels made 8 mm over the table against 2 mm, fitted from fresh weights at the same seeds")
    assert "label seed 0, fit seed 0: +25.0 [+25.0, +25.0] over both sets (household +25.0" in line
    assert "label seed 1" not in line  # only seeds judged at both heights pair
    assert _heights({"a": variants["a"]}) == [] and _heights({"n": {"plan": {}}}) == []
