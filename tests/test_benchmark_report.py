"""docs/performance.md is rendered from the committed benchmark results."""

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load_report():
    return importlib.import_module("benchmarks.pages.performance_page")


def test_every_committed_result_renders_with_its_command_and_date():
    page = load_report().render()
    for title in ("End to end", "Candidate generation and extraction overhead", "Exact dedup", "Global merge",
                  "Grasp trials", "Service scaling",
                  "Similar-shape filter", "Storage per grasp"):
        assert f"## {title}: `python benchmarks/" in page
    assert "Not run yet" not in page


def test_the_committed_page_is_the_rendered_one():
    assert (ROOT / "docs" / "performance.md").read_text() == load_report().render(), \
        "docs/performance.md is stale: run `python -m benchmarks.pages.report`"


def test_the_assembly_figures_are_the_rendered_ones():
    from benchmarks.pages.assembly_page import PAGE, render_assembly_page

    assert PAGE.read_text() == render_assembly_page(), \
        "docs/assembly.md figures are stale: run `python -m benchmarks.pages.report`"


def test_the_picks_page_is_the_rendered_one_and_answers_first():
    from benchmarks.pages.picks_page import PAGE, render_picks_page

    page = render_picks_page()
    assert PAGE.read_text() == page, "docs/picks.md is stale: run `python -m benchmarks.pages.report`"
    lines = page.split("\n")
    assert lines[4].startswith("On ") and " real household meshes" in lines[4].split(",")[0]
    targets = [line for line in lines[:16] if line.startswith("| household first attempt >= 85%")]
    assert len(targets) == 1 and ("**met**" in targets[0] or "**not met**" in targets[0])  # the answer, first
    for picture in (line.split("(")[1].rstrip(")") for line in page.splitlines() if line.startswith("![")):
        assert (ROOT / "docs" / picture).is_file(), picture


def test_the_household_figure_pools_both_sets_over_their_objects():
    from benchmarks.pages.picks_page import pooled

    def picks_set(rates: list[list[bool]]) -> dict:
        return {"objects": [{"status": "ok", "views": [{"attempts": {"network": [hit, False]}} for hit in views]}
                            for views in rates] + [{"status": "rejected", "views": []}]}

    first = picks_set([[True, True], [False, False]])
    second = picks_set([[True, False, False, False]])
    both = pooled([first, second], "network")
    assert both["objects"] == 3 and both["views"] == 8
    assert abs(both["first_attempt"] - (1.0 + 0.0 + 0.25) / 3) < 1e-12  # objects weigh alike, views do not
    low, high = both["first_attempt_interval"]
    assert 0.0 <= low < both["first_attempt"] < high <= 1.0


def test_the_scaling_plan_is_the_rendered_one():
    from benchmarks.pages.scaling_page import PAGE, render_scaling_page

    assert PAGE.read_text() == render_scaling_page(), \
        "docs/scaling.md plan is stale: run `python -m benchmarks.pages.report`"


def test_the_label_rule_figures_are_the_rendered_ones():
    from benchmarks.pages.trials_page import PAGE, render_trials_page

    assert PAGE.read_text() == render_trials_page(), "docs/trials.md is stale: run `python -m benchmarks.pages.report`"


def test_the_reliability_figures_are_the_rendered_ones():
    from benchmarks.pages.reliability_page import PAGE, render_reliability_page

    assert PAGE.read_text() == render_reliability_page(), \
        "docs/reliability.md figures are stale: run `python -m benchmarks.pages.report`"


def test_every_guarantee_names_tests_that_exist_and_each_recorded_its_figure():
    from benchmarks.pages.reliability_page import GUARANTEES_END, GUARANTEES_START, PAGE, test_ids

    page = PAGE.read_text()
    rows = [line for line in page[page.index(GUARANTEES_START):page.index(GUARANTEES_END)].splitlines()
            if line.startswith("| ")][2:]
    assert len(rows) >= 15
    for row in rows:
        ids = test_ids(row.split(" | ")[2])
        assert ids, row
        for test_id in ids:
            file, name = test_id.split("::")
            assert f"def {name}(" in (ROOT / "tests" / file).read_text(), test_id
        assert "not recorded" not in row, f"no figure recorded for {ids}: run scripts/dev test --record-figures"


def test_test_ids_follow_the_file_named_before():
    from benchmarks.pages.reliability_page import test_ids

    ids = test_ids("`a.py::test_x`, `::test_y`, `b.py::test_z`")
    assert ids == ["a.py::test_x", "a.py::test_y", "b.py::test_z"]


def test_a_stage_rate_is_met_only_against_the_fastest_protocol_timing_of_its_run():
    from benchmarks.pages.end_to_end_section import _drift_verdict as verdict

    protocol = {"label_trials_per_s_per_core": 80.0,
                "rounds": [{"label_trials_per_s_per_core": 60.0}, {"label_trials_per_s_per_core": 100.0}]}
    assert verdict(85.0, protocol, "label", 0.8) == "met"
    assert verdict(70.0, protocol, "label", 0.8).startswith("not established: 0.70 x")  # 0.88 of the median
    assert verdict(60.0, protocol, "label", 0.8) == "not met"
    assert verdict(60.0, None, "label", 0.8) == ""


def test_the_physics_floor_is_given_at_one_copys_rates_and_at_two_at_once():
    from benchmarks.pages.end_to_end_section import _physics_floor as floor

    run = {"objects": 10, "candidates_per_object": 100, "workers": 2,
           "protocol": {"extract_trials_per_s_per_core": 10.0, "label_trials_per_s_per_core": 5.0}}
    label = {"trials_one_object": 900, "trials_transfer": 100}
    alone = floor(run, label, 200)  # 1000 / 20 = 50 s to extract, 1000 / 10 = 100 s to label
    assert "50 s to extract and 100 s to label: 150 s" in alone and "(within it)" in alone and "two copies" not in alone
    run["protocol"]["two_at_once"] = {"extract_trials_per_s_per_core": 5.0, "label_trials_per_s_per_core": 2.5}
    both = floor(run, label, 200)
    assert both.startswith(alone) and "100 s and 200 s, 300 s (above the target)" in both


def test_the_cpu_block_says_met_only_when_no_array_differs():
    from benchmarks.experiments.bench_cpu_independence import cpu_section

    result = {"command": "python -m benchmarks.experiments.bench_cpu_independence", "date": "2026-11-27",
              "machine": "x86_64",
              "settings": {"SSE": {"OPENBLAS_CORETYPE": "Prescott"}}, "extract_objects": "primitives[0:1]",
              "rows": [{"job": "pinned", "setting": "SSE", "arrays": 44, "differing": []}],
              "numpy_sines": {"angles_with_another_sine_or_cosine": 0.06, "grasps": 100,
                              "settled_poses_moved_over_1e-4": 2, "codes_changed": 1},
              "blas_patches": {"labels": 230, "labels_changed": 3},
              "embree_hits": {"arrays": 44, "differing": ["grasps/code"] * 35, "reproduces_pins_before_raycast": True,
                              "labels": 230, "labels_after": 231, "labels_changed": None,
                              "extraction_codes_changed": 2}}
    assert "under every setting: met." in cpu_section(result)
    result["rows"][0]["differing"] = ["assembled/grasps/slip"]
    block = cpu_section(result)
    assert "not met (assembled/grasps/slip)" in block
    assert "| pinned (44 arrays) | SSE | `assembled/grasps/slip` |" in block
    assert "3 of the pinned job's 230 labels" in block
    assert "moved 35 of the pinned job's 44 arrays, 2 extraction codes and the number of its labelled grasps (230 " \
           "to 231)" in block
    result["embree_hits"].update(labels_after=230, labels_changed=4)
    assert "2 extraction codes and 4 of its 230 labels" in cpu_section(result)


def test_every_page_in_the_catalogue_is_the_rendering_of_the_committed_results():
    """Issue 48: one page convention: every page rendered from committed results is listed in
    benchmarks/pages/report.py with the function that renders it, and each committed page is that rendering."""
    from benchmarks.pages.report import pages

    listed = pages()
    assert len(listed) >= 17 and len({page.path for page in listed}) == len(listed)
    stale = [page.path for page in listed if (ROOT / page.path).read_text() != page.render()]
    assert stale == [], f"stale pages {stale}: run `python -m benchmarks.pages.report`"
    mark = re.compile(r"(?i)<!-- [^>]*rendered by benchmarks/pages/|Rendered from benchmarks/results/"
                      r"|Generated by `benchmarks/")
    marked = {str(path.relative_to(ROOT)) for path in (ROOT / "docs").glob("*.md") if mark.search(path.read_text())}
    assert len(marked) >= 15
    assert marked - {page.path for page in listed} == set(), "a rendered page missing from the catalogue"



def test_a_design_replaces_the_shipped_network_only_beyond_one_designs_spread_over_seeds():
    from benchmarks.experiments.ship_network import best_point

    def point(design: str, labels: int, rate: float) -> dict:
        return {"design": design, "labels": labels, "options": {"model": "pointnet_context"},
                "picks": {"methods": {"network": {"first_attempt": rate}}}}

    curve = {"points": [point("shipped", 8000, 0.90), point("shipped", 80000, 0.836),
                        point("challenger", 80000, 0.844), point("wide", 40000, 0.80)]}
    assert best_point(curve)["design"] == "challenger"  # nothing shipped yet: the best largest point
    assert best_point(curve, "shipped", spread=0.031)["labels"] == 80000  # +0.8 points: within the spread
    assert best_point(curve, "shipped", spread=0.031)["design"] == "shipped"
    curve["points"].append(point("better", 80000, 0.90))
    assert best_point(curve, "shipped", spread=0.031)["design"] == "better"  # +6.4 points: beyond it


def views_picked(counts: list[int]) -> dict[str, int]:
    """Per-object first picks (of 8 views) of objects o0, o1, ..."""
    return {f"o{k}": c for k, c in enumerate(counts)}


STEADY = [6, 7, 5, 8, 6, 4, 7, 6]


def test_a_trial_is_kept_only_where_its_paired_interval_over_objects_lies_above_zero():
    from onepiece_dist.stats.intervals import paired_gain

    lifted = [min(c + 1, 8) for c in STEADY]  # one view more on nearly every object
    kept = paired_gain([views_picked(lifted)] * 2, [views_picked(STEADY)] * 2, 8)
    assert kept.verdict == "kept" and kept.seeds == 2 and kept.interval[0] > 0
    assert kept.gain == round(sum(a - b for a, b in zip(lifted, STEADY, strict=True)) / 8 / 8, 4)
    assert paired_gain([views_picked(lifted)], [views_picked(STEADY)], 8).verdict == "one seed: undecided"
    same = paired_gain([views_picked(STEADY)] * 3, [views_picked(STEADY)] * 3, 8)
    assert same.verdict == "not kept" and same.gain == 0 and same.interval == (0.0, 0.0)
    one_object = [views_picked([8, *STEADY[1:]])] * 2  # +2 views on one object alone: the objects do not agree
    assert paired_gain(one_object, [views_picked(STEADY)] * 2, 8).verdict == "not kept"
    assert paired_gain([views_picked(STEADY)], [], 8).verdict == "not compared"


def test_the_swept_space_is_judged_seed_for_seed_by_the_paired_rule():
    from benchmarks.pages.pick_trials_section import paired, space_section, verdict

    def point(design: str, seed: int, counts: list[int], labels: int = 8000) -> dict:
        return {"design": design, "labels": labels, "seed": seed,
                "picks": {"methods": {"network": {"first_attempt": sum(counts) / 64}},
                          "per_object": {"network": views_picked(counts)}}}

    lifted = [min(c + 1, 8) for c in STEADY]
    space = {"command": "c", "date": "d", "machine": "m", "labels": {"rows": 8000, "success_rate": 0.2},
             "points": [point("context_balanced", 0, STEADY), point("context_space", 0, lifted),
                        point("context_space", 2, lifted)]}  # seed 2 has no pair: left out
    assert sorted(paired(space)[8000]) == [0]
    assert verdict(paired(space)[8000]).verdict == "one seed: undecided"
    space["points"] += [point("context_balanced", 1, STEADY), point("context_space", 1, lifted)]
    assert verdict(paired(space)[8000]).verdict == "kept"
    space["points"] = [point(d, s, STEADY) for d in ("context_balanced", "context_space") for s in (0, 1)]
    assert ": not kept;" in space_section(space)[-3]


def test_labels_on_policy_are_kept_only_over_seeds_and_where_the_objects_agree():
    from benchmarks.pages.pick_trials_section import on_policy_section

    def point(batch: str, seed: int, counts: list[int]) -> dict:
        rate = sum(counts) / 64
        return {"second_batch": batch, "seed": seed, "labels": 100, "second_success_rate": 0.3,
                "picks": {"methods": {"network": {"first_attempt": rate, "interval": [rate - 0.1, rate + 0.1]}},
                          "per_object": {"network": views_picked(counts)}}}

    lifted = [min(c + 1, 8) for c in STEADY]
    result = {"command": "c", "date": "d", "machine": "m", "points": [point("random", 0, STEADY),
                                                                    point("on_policy", 0, lifted)],
              "policy": {"checkpoint": "x.pt", "design": "context_balanced", "labels": 50, "first_attempt": 0.8,
                         "top_share": 0.5}}
    assert ": one seed: undecided;" in on_policy_section(result)[-1]
    result["points"] += [point("random", 1, STEADY), point("on_policy", 1, lifted)]
    assert ": kept;" in on_policy_section(result)[-1]
    result["points"][3] = point("on_policy", 1, [8, *STEADY[1:]])
    result["points"][1] = point("on_policy", 0, [8, *STEADY[1:]])
    assert ": not kept;" in on_policy_section(result)[-1]


def test_a_trial_on_household_objects_is_kept_by_the_household_set_alone_never_the_unseen():
    from benchmarks.pages.pick_trials_section import top_down_section, vessels_section

    lifted = [min(c + 1, 8) for c in STEADY]

    def top_down(seed: int, base: list[int], tried: list[int], unseen: list[int]) -> dict:
        judged = {"household": {"first_attempt": sum(tried) / 64, "per_object": views_picked(tried)},
                  "unseen": {"first_attempt": sum(unseen) / 64, "per_object": views_picked(unseen)}}
        return {"seed": seed, "labels": 100, "with_pool": judged,
                "base": {"household": sum(base) / 64, "unseen": sum(STEADY) / 64, "labels": 100, "with_pool": judged,
                         "per_object": {"household": views_picked(base), "unseen": views_picked(STEADY)}}}

    result = {"command": "c", "date": "d", "machine": "m", "labels": 100, "success_rate": 0.3,
              "points": [top_down(0, STEADY, lifted, STEADY)]}
    assert ": one seed: undecided" in top_down_section(result)[-1]
    result["points"].append(top_down(1, STEADY, lifted, STEADY))
    assert "]): kept" in top_down_section(result)[-1]
    result["points"] = [top_down(s, STEADY, STEADY, [8] * 8) for s in (0, 1)]
    words = top_down_section(result)[-1]
    assert "]): not kept" in words and "nothing is chosen, +" in words  # the unseen gain decides nothing
    vessels = {"command": "c", "date": "d", "machine": "m", "batch": "b", "labels": 100, "success_rate": 0.3,
               "points": [{"seed": s, "labels": 200,
                           "picks": {"methods": {"network": {"first_attempt": 0.8}},
                                     "per_object": {"network": views_picked(STEADY)}},
                           "unseen": {"first_attempt": 0.9, "per_object": views_picked([8] * 8)},
                           "base": {"household": 0.8, "unseen": 0.5, "labels": 200,
                                    "per_object": {"household": views_picked(STEADY), "unseen": views_picked(STEADY)}}}
                          for s in (0, 1)]}
    assert ": not kept;" in vessels_section(vessels)[-1]




def test_the_last_kept_trial_ships_and_none_where_the_top_down_trial_is_not_kept():
    from benchmarks.experiments.ship_network import kept_trial

    lifted = [min(c + 1, 8) for c in STEADY]
    higher = [min(c + 2, 8) for c in STEADY]

    def judged(counts: list[int]) -> dict:
        return {w: {"first_attempt": sum(counts) / 64, "per_object": views_picked(counts)}
                for w in ("household", "unseen")}

    def top_down(tried: list[int]) -> dict:
        return {"points": [{"seed": s, "checkpoint": f"td{s}", "with_pool": judged(tried),
                            "base": {"per_object": {w: views_picked(STEADY) for w in ("household", "unseen")},
                                     "with_pool": judged(STEADY)}} for s in (0, 1)]}

    def points(tried: list[int]) -> dict:
        return {"points": [{"seed": s, "checkpoint": f"pts{s}", "with_pool": judged(tried)} for s in (0, 1)]}

    best = [8] * 8
    assert kept_trial(top_down(STEADY), {"pick_points": points(higher)}) is None  # rests on a trial not kept
    name, point = kept_trial(top_down(lifted), {"pick_points": points(lifted)})
    assert (name, point["checkpoint"]) == ("pick_top_down", "td0")  # more points gain nothing over it
    name, point = kept_trial(top_down(lifted), {"pick_points": points(higher), "pick_top_down_both": None})
    assert (name, point["checkpoint"]) == ("pick_points", "pts0")  # seed 0, never the best seed
    assert kept_trial(top_down(lifted), {"pick_points": None})[0] == "pick_top_down"
    both = kept_trial(top_down(lifted), {"pick_points": points(higher), "pick_top_down_both": points(best)})
    assert both[0] == "pick_top_down_both"  # of two kept, the one that gains most


def test_the_outline_trial_names_the_views_it_left_out_and_is_judged_against_the_top_down_networks():
    from benchmarks.pages.pick_trials_section import outline_section

    def judged(counts: list[int]) -> dict:
        return {w: {"first_attempt": sum(counts) / 64, "per_object": views_picked(counts)}
                for w in ("household", "unseen")}

    def fitted(top1: float) -> dict:
        return {"val_view_top1": top1, "val_ap": top1}

    top_down = {"points": [{"seed": s, "with_pool": judged(STEADY), "best_epoch": fitted(0.7)} for s in (0, 1)]}
    result = {"command": "c", "date": "d", "machine": "m", "design": "context_balanced_outline", "labels": 81136,
              "views_not_again": ["random_urdfs/223 view 6"],
              "points": [{"seed": s, "with_pool": judged([min(c + 1, 8) for c in STEADY]),
                          "best_epoch": fitted(0.8 - 0.2 * s)} for s in (0, 1)]}
    lines = outline_section(result, top_down)
    assert "1 view that settled elsewhere when seen again left out: random_urdfs/223 view 6; 81136 labels" in lines[2]
    assert "the outline gives" in lines[-3] and "]): kept" in lines[-3]
    assert "picked in 70.0% of the views against 70.0% (higher at 1 of 2 seeds)" in lines[-1]
    result["views_not_again"] = []
    assert "left out" not in outline_section(result, top_down)[2]


def test_the_pools_ceiling_without_the_draw_says_whether_the_targets_lie_within_it():
    from benchmarks.pages.pick_ceiling_section import ceiling_section, pooled_ceiling

    def measured(held: list[int]) -> dict:
        per_object = {f"o{k}": {"views": 8, "one_draw": 8, "repeated": 8, "first_held_out": 0.0, "best_held_out": h,
                                "candidates": 100} for k, h in enumerate(held)}
        share = {"rate": sum(held) / (8 * len(held)), "interval": [0.5, 1.0]}
        return {"views": 8 * len(held), "candidates": 100 * len(held), "one_draw": share, "repeated": share,
                "first_held_out": share, "best_held_out": share, "per_object": per_object}

    result = {"command": "c", "date": "d", "machine": "m", "screen": 4, "selection": 12, "shortlist": 8, "judge": 4,
              "sets": {"household": measured([8, 8, 6, 8]), "unseen": measured([0, 8])}}
    rate, (low, high), objects = pooled_ceiling(result)
    assert objects == 6 and rate == (8 + 8 + 6 + 8 + 0 + 8) / 48 and low < rate < high
    targets = {"first_attempt": 0.85, "above_heuristics": 0.2}
    words = ceiling_section(result, None, 0.7, targets)[-1]
    assert "the ceiling is **79.2%**" in words and "85.0% at the first attempt lies above it" in words
    assert "needs 90.0%, above it" in words
    assert "lies within" in ceiling_section(result, None, 0.5, {**targets, "first_attempt": 0.75})[-1]
    assert "needs" not in ceiling_section(result, None, None, targets)[-1]


def test_where_the_ranking_loses_judges_the_surest_of_the_first_three_on_draws_it_was_not_chosen_on():
    from benchmarks.experiments.pick_ranked_draws import summary
    from benchmarks.pages.pick_ceiling_section import ranked_draws_section

    views = [{"scores": [0.9, 0.8, 0.7], "draws": [[1, 0, 0, 0], [1, 1, 1, 1], [0, 0, 0, 0]],
              "top_down": [False, True, False]},
             {"scores": [0.9, 0.5], "draws": [[1, 1, 1, 1], [0, 1, 0, 0]], "top_down": [False, False]},
             {"scores": [], "draws": [], "top_down": []}]
    s = summary(views)
    assert s["views"] == 2 and s["first"] == 0.625 and s["first_draw0"] == 1.0 and s["first_judged"] == 0.5
    assert s["best_of_3"] == 1.0  # chosen on draws 0-1 (the second of the first view), judged at draws 2-3
    assert s["pairs"] == 4 and s["pairs_in_order"] == 0.75  # only 0.9 over 0.8 is out of order
    assert s["top_down_share"] == 1.0 and s["top_down_grasps"] == 1 and s["other_share"] == 0.375
    result = {"command": "c", "date": "d", "machine": "m", "top": 3, "draws": 4, "sets": {"household": s}}
    assert "would add 50.0 points on the household set" in ranked_draws_section(result)[-1]


def test_other_networks_ordering_the_best_grasps_are_judged_by_their_choices_share_of_draws():
    import numpy as np

    from benchmarks.experiments.pick_reranked import chosen
    from benchmarks.pages.pick_ceiling_section import reranked_section

    rows = [{"shares": np.array([0.5, 1.0, 0.0, 1.0]), "shipped": np.array([0.9, 0.8, 0.7, 0.6]),
             "other": np.array([0.1, 0.2, 0.3, 0.9])},
            {"shares": np.array([1.0, 0.0]), "shipped": np.array([0.9, 0.8]), "other": np.array([0.5, 0.5])}]
    assert chosen(rows, "shipped", 3) == 0.75 and chosen(rows, "other", 3) == 0.5  # its 0.3 among the first 3
    assert chosen(rows, "other", 10) == 1.0  # the first on ties, and the fourth when it may look that far
    result = {"command": "c", "date": "d", "machine": "m", "sets": {"household": {
        "views": 2, "views_elsewhere": ["o view 5"], "chosen": {
            "shipped": {"3": 0.75, "10": 0.75}, "other": {"3": 0.5, "10": 1.0}}}}}
    lines = reranked_section(result)
    assert "left out, settled elsewhere when seen again: o view 5" in lines[2]
    assert "`shipped` +0.0 points on the household set" in lines[-1]
