"""The pages that ask what orders the network's best grasps (issue 55): a rule is kept only where it raises both
sets, failures are counted by rank and object, and a prior is judged on grasps it was not fitted on."""

from __future__ import annotations

import numpy as np
import pytest


def _robust_result(unseen_mean: float) -> dict:
    chosen = {"household": {"shipped": 0.80, "mean_x1": 0.82, "near_mean": 0.79},
              "unseen": {"shipped": 0.70, "mean_x1": unseen_mean, "near_mean": 0.72}}
    return {"command": "c", "date": "d", "machine": "m", "seconds": 1.0, "samples": 16, "scales": [1.0],
            "near": {"m": 0.01, "deg": 20.0},
            "sets": {w: {"views": 2, "views_elsewhere": [], "chosen": {n: {"3": v, "10": v} for n, v in c.items()}}
                     for w, c in chosen.items()}}


def test_a_rule_under_pose_noise_is_kept_only_where_it_raises_both_sets():
    from benchmarks.experiments.pick_robust_rank import _rules
    from benchmarks.pages.pick_rank_section import robust_rank_section

    nominal = np.array([0.9, 0.8])
    rules = _rules(nominal, {1.0: np.array([[0.5, 0.7], [0.9, 0.9]])}, np.array([0.6, 0.7]))
    assert np.allclose(rules["mean_x1"], [0.6, 0.9]) and np.allclose(rules["min_x1"], [0.5, 0.9])
    assert np.allclose(rules["near_and_nominal"], [0.75, 0.75]) and rules["shipped"] is nominal
    kept = robust_rank_section(_robust_result(0.75))[-1]
    assert "raising both sets: the mean score of 16 perturbed poses, 1x the protocol's noise (+2.0 / +5.0" in kept
    assert "no rule raises both sets: not kept" in robust_rank_section(_robust_result(0.69))[-1]


def _row(name: str, shares: list[float], signal: list[float], scores: list[float]) -> dict:
    """A view's ranked grasps: 8 draws each picking ``shares`` of the time; a feature ``signal`` beside ``scores``."""
    picked = [[d < round(8 * s) for d in range(8)] for s in shares]
    failures = [["" if p else "slipped_lifting" for p in each] for each in picked]
    features = [[score, sig] + [0.0] * 10 for score, sig in zip(scores, signal, strict=True)]
    return {"object": name, "view": 0, "stored": picked, "picked": picked, "failures": failures,
            "features": features}


def test_failures_are_counted_by_rank_and_object_and_a_prior_is_judged_on_grasps_it_was_not_fitted_on():
    from benchmarks.experiments.pick_rank_features import by_object, chosen_share, failure_table, prior_trial
    from benchmarks.pages.pick_rank_section import rank_features_section

    # the network ranks a weaker grasp first; the second feature says which grasp holds
    rows = {w: [_row(f"{w}{i}", [0.5, 1.0, 0.0], [0.1, 0.9, 0.0], [0.9, 0.8, 0.7]) for i in range(4)]
            for w in ("household", "unseen")}
    assert failure_table(rows["unseen"])["1"] == {"picked": 16, "slipped_lifting": 16}
    assert by_object(rows["unseen"][:1])["unseen0"] == {"first": {"picked": 4, "slipped_lifting": 4},
                                                        "shares": [0.5, 1.0, 1.0]}
    assert chosen_share(rows["unseen"], None, 3) == 0.5
    prior = prior_trial(rows["household"], rows["unseen"])
    assert prior["unseen"]["3"] == [0.5, 1.0] and prior["household_left_out"]["3"] == [0.5, 1.0]
    result = {"command": "c", "date": "d", "machine": "m", "seconds": 1.0, "features": ["score", "signal"],
              "prior": prior, "sets": {w: {"draws_agree": 1.0, "failures": failure_table(r),
                                           "objects": by_object(r)} for w, r in rows.items()}}
    assert rank_features_section(result)[-1].endswith("(+50.0): kept.")
    useless = {w: [_row(f"{w}{i}", [0.5, 1.0, 0.0], [0.0, 0.0, 0.0], [0.9, 0.8, 0.7]) for i in range(4)]
               for w in rows}
    assert prior_trial(useless["household"], useless["unseen"])["unseen"]["3"] == [0.5, 0.5]


def test_a_check_is_judged_by_the_benchmark_paired_over_objects_and_by_the_draws_of_what_it_chose():
    from benchmarks.experiments.pick_shape_check import drawn_summary, paired_check
    from benchmarks.pages.pick_rank_section import shape_check_section

    rows = [{"object": "a", "shares": [0.5, 1.0, 0.0, 1.0, 0.0], "held_hull": [0.0, 0.75, 0.75, 1.0, 0.0]},
            {"object": "a", "shares": [1.0, 0.0, 0.0, 0.0, 0.0], "held_hull": None},  # no plane: the network's order
            {"object": "b", "shares": [0.25, 0.5, 1.0, 1.0, 1.0], "held_hull": [0.5, 0.5, 0.5, 0.5, 0.5]}]  # ties
    three = drawn_summary(rows, 3)
    assert three["first"] == 0.5833333333333334 and three["checked"] == 0.75 and three["reordered"] == 1
    assert three["surest"] == (1.0 + 1.0 + 1.0) / 3 and three["gain_by_object"] == 0.125  # a: +0.25, b: 0
    assert drawn_summary(rows, 5)["checked"] == (1.0 + 1.0 + 0.25) / 3  # the fourth held at every draw
    bench = {"0": {"views": 4, "per_object": {"a": 2, "b": 3}}, "3": {"views": 4, "per_object": {"a": 4, "b": 4}}}
    result = {"command": "c", "date": "d", "machine": "m", "draws": 8, "checks": [0, 3],
              "sets": {"household": {k: {**v, "first_attempt": 0.5, "interval": [0, 1], "within_3": 1.0,
                                         "failures": {}, "seconds": 1.0} for k, v in bench.items()}},
              "expected": {"3": {"household": three}}}
    gain = paired_check(result, "3")
    assert gain["sets"]["household"]["mean"] == 0.75 and gain["verdict"] == "kept"  # a +2 of 2 views, b +1
    lines = shape_check_section(result)
    assert "| 3 | household | 3 | 58.3% | 75.0% | +12.5 [" in "\n".join(lines)
    assert lines[-1].startswith("Checking the first 3, by the benchmark's one draw: household +75.0 points")
    assert "**kept**" in lines[-1]
    result["sets"]["household"]["3"]["per_object"] = {"a": 4, "b": 1}  # one object up, the other down
    assert paired_check(result, "3")["verdict"] == "not kept"
    result["expected_density"] = {"2": {"3": {"household": three}}}
    assert "| 2x | 3 | household | 75.0% | +12.5 [" in "\n".join(shape_check_section(result))
    carved = {"views": 4, "per_object": {"a": 4, "b": 4}, "first_attempt": 1.0, "seconds": 2.0}
    result["judged_shapes"] = {"carved": {"household": {"3": carved}}}
    assert paired_check(result, "3", "carved")["sets"]["household"]["mean"] == 0.75  # against the unchecked runs
    assert ("The first 3 checked on the carved shape, by the benchmark's one draw: household 50.0% -> 100.0% (2 s); "
            "paired over objects household +75.0 points [") in "\n".join(shape_check_section(result))


def test_two_shapes_are_compared_by_the_draws_of_what_each_check_chose_paired_over_objects():
    from benchmarks.experiments.pick_shape_check import drawn_summary, shape_difference
    from benchmarks.pages.pick_rank_section import shape_lines

    rows = [{"object": "a", "shares": [0.5, 1.0, 0.0], "held_hull": [0.0, 0.0, 0.5], "held_carved": [0.0, 1.0, 0.5],
             "seconds_carved": 3.0},
            {"object": "a", "shares": [1.0, 0.0, 0.0], "held_hull": [0.0, 1.0, 0.0], "held_carved": None},
            {"object": "b", "shares": [0.0, 1.0, 0.5], "held_hull": [1.0, 0.0, 0.0], "held_carved": [0.0, 1.0, 0.0]}]
    versus = shape_difference(rows, 3, "hull", "carved")  # each view: 1.0 against 0.0 (None: the network's first)
    assert versus["mean"] == 1.0 and versus["shapes"] == ["hull", "carved"]
    by_shape = {shape: {"3": {"all objects": drawn_summary(rows, 3, shape)}} for shape in ("hull", "carved")}
    page = "\n".join(shape_lines({**by_shape, "versus": {"carved": {"3": {"all objects": versus}}}}))
    assert "| carved | 3 | all objects | 100.0% | +62.5 [" in page and "| hull | 3 | all objects | 0.0% |" in page
    assert "of its draws | 3.0 |" in page and "of its draws | - |" in page  # timed where the run timed it
    assert "the carved shape **kept**" in page
    worse = shape_difference(rows, 3, "carved", "hull")
    assert "the hull shape **not kept**" in "\n".join(shape_lines({"versus": {"hull": {"3": {"all objects": worse}}}}))
    assert shape_lines({}) == []


def test_the_shapes_checks_summed_choose_what_holds_most_over_all_three_from_rows_of_the_same_draws():
    from benchmarks.experiments.pick_shape_check import expected_summed, summed_rows
    from benchmarks.pages.pick_rank_section import shape_lines

    def row(obj, shares, hull, other, name):  # a shape's measure: its own check beside the hull's
        return {"object": obj, "shares": shares, "held_hull": hull, f"held_{name}": other, "seconds_hull": 1.0,
                f"seconds_{name}": 2.0}

    # each shape alone puts another grasp first; over all three, the second holds most (2.25 of 3 draws' shares)
    carved = [row("a", [0.0, 1.0, 0.5], [1.0, 0.75, 0.0], [0.0, 1.0, 0.0], "carved"),
              row("b", [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], None, "carved")]  # no shape: the network's order stays
    mirrored = [row("a", [0.0, 1.0, 0.5], [1.0, 0.75, 0.0], [0.0, 0.5, 1.0], "mirrored"),
                row("b", [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], "mirrored")]
    joined = summed_rows({"carved": {"s": carved}, "mirrored": {"s": mirrored}})["s"]
    assert joined[0]["held_summed"] == [1 / 3, 0.75, 1 / 3] and joined[1]["held_summed"] is None
    assert joined[0]["seconds_summed"] == 5.0
    kept = {"rows": {"carved": {"s": carved}, "mirrored": {"s": mirrored}}, "versus": {}}
    expected_summed(kept)
    assert kept["summed"]["3"]["s"]["checked"] == 1.0  # both views' chosen grasps hold at every judging draw
    assert kept["versus"]["summed"]["3"]["s"]["mean"] == 0.5  # object a: 1.0 against the hull's 0.0; b: the same
    page = "\n".join(shape_lines(kept))
    assert "Summed, a grasp counts" in page and "| summed | 3 | s | 100.0% |" in page
    assert "Summed" not in "\n".join(shape_lines({"hull": kept["summed"]}))
    with pytest.raises(AssertionError):  # rows of other draws are never summed
        summed_rows({"carved": {"s": carved}, "mirrored": {"s": [mirrored[1], mirrored[0]]}})


def test_the_checks_draws_are_judged_by_their_first_draws_and_more_draws_must_choose_better():
    from benchmarks.experiments.pick_shape_check import drawn_summary, draws_difference, first_draws
    from benchmarks.pages.pick_rank_section import draws_lines

    rows = [{"object": "a", "shares": [0.0, 1.0, 0.5], "drawn_hull": [[1, 0, 0, 0], [0, 1, 1, 1], [1, 1, 0, 0]]},
            {"object": "b", "shares": [1.0, 0.0, 0.0], "drawn_hull": None}]
    assert first_draws(rows, 1)[0]["held_hull"] == [1.0, 0.0, 1.0] and first_draws(rows, 1)[1]["held_hull"] is None
    one, four = (drawn_summary(first_draws(rows, n), 3) for n in (1, 4))
    assert one["checked"] == 0.5 and four["checked"] == 1.0  # one draw keeps the network's first, four see the second
    page = "\n".join(draws_lines({"1": {"3": {"all objects": one}}, "4": {"3": {"all objects": four}}}))
    assert "| 4 | 3 | all objects | 100.0% | +50.0 [" in page and "4 draws choose +50.0 points against 1" in page
    assert "more draws choose better" in page
    same = "\n".join(draws_lines({"1": {"3": {"all objects": four}}, "4": {"3": {"all objects": four}}}))
    assert "bounded by its shape, not by its draws" in same and draws_lines({}) == []
    versus = draws_difference(rows, 3, 1, 4)  # a: the network's first (0.0) against the second (1.0); b: alike
    assert versus["mean"] == -0.5 and versus["draws"] == [4, 1]
    page = "\n".join(draws_lines({"1": {"3": {"all objects": one}}, "4": {"3": {"all objects": four}},
                                  "versus": {"1": {"3": {"all objects": versus}}}}))
    assert "The check's first of 3 with 1 draw against 4, paired over objects: all objects -50.0 points [" in page
    assert "1 draw not shown as good" in page and "below" not in page.split("more draws choose better")[1][:20]
    alike = draws_difference(rows, 3, 4, 4)
    assert "4 draws as good" in "\n".join(draws_lines({"4": {"3": {"all objects": four}},
                                                         "versus": {"4": {"3": {"all objects": alike}}}}))
    # 1 draw worse, 2 as good as 4: noise bounds the check below 2 draws, its shape from 2 on
    page = "\n".join(draws_lines({"1": {"3": {"all objects": one}}, "2": {"3": {"all objects": four}},
                                  "4": {"3": {"all objects": four}},
                                  "versus": {"1": {"3": {"all objects": versus}}, "2": {"3": {"all objects": alike}}}}))
    assert "noise below 2 draws; from 2 on (as good as 4, paired below) it is bounded by its shape" in page


def _more_views(gains: list[int]) -> dict:
    """The check's runs at 4 views an object: per object the views picked unchecked (2) and checked (2 + gain)."""
    def run(picks: list[int]) -> dict:
        per_object = {f"o{i}": n for i, n in enumerate(picks)}
        return {"first_attempt": sum(picks) / (4 * len(picks)), "interval": [0.0, 1.0], "views": 4 * len(picks),
                "failures": {"slipped_lifting": 1}, "per_object": per_object, "seconds": 1.0}

    return {"views": 4, "check_draws": 4,
            "sets": {"household": {"0": run([2] * len(gains)), "3": run([2 + g for g in gains])}}}


def test_the_check_judged_at_more_views_is_kept_only_where_its_pooled_interval_lies_above_zero():
    from benchmarks.pages.pick_rank_section import more_views_lines
    from onepiece_dist.specs.plan import PlanSpec

    assert more_views_lines(None) == []
    kept = more_views_lines(_more_views([1, 1, 2, 1, 0, 1]))[-1]
    assert "all objects +25.0 points" in kept and "**kept** as the planner's default" in kept
    assert f"`PlanSpec.check_first` = {PlanSpec().check_first}" in kept
    mixed = more_views_lines(_more_views([1, -1, 0, 1, -1, 0]))[-1]
    assert "all objects +0.0 points" in mixed and "**not kept**" in mixed


def test_the_top_down_grasp_beside_the_check_is_judged_against_the_check_alone():
    from benchmarks.pages.pick_rank_section import more_views_lines

    more = _more_views([1, 1, 2, 1, 0, 1])
    runs = more["sets"]["household"]
    runs["3_top_down"] = {**runs["3"], "per_object": {o: n + 1 for o, n in runs["3"]["per_object"].items()}}
    lines = more_views_lines(more)
    assert any(line.startswith("| household | 3 and the best top-down grasp | ") for line in lines)
    assert "against the first 3 alone at 4 views an object: household +25.0 points" in lines[-1]
    assert "**kept**" in lines[-1] and "`PlanSpec.check_top_down` = False" in lines[-1]
    runs["3_top_down"] = runs["3"]
    assert "all objects +0.0 points" in more_views_lines(more)[-1] and "**not kept**" in more_views_lines(more)[-1]


def test_more_grasps_checked_are_judged_against_the_planners_default_number():
    from benchmarks.pages.pick_rank_section import more_views_lines

    more = _more_views([1, 1, 2, 1, 0, 1])
    runs = more["sets"]["household"]
    runs["5"] = {**runs["3"], "per_object": {o: n + 1 for o, n in runs["3"]["per_object"].items()}}
    lines = more_views_lines(more)
    against = next(line for line in lines if line.startswith("The first 5 checked against the first 3"))
    assert "household +25.0 points" in against and "**kept** in its place" in against
    runs["5"] = runs["3"]
    against = next(line for line in more_views_lines(more) if line.startswith("The first 5 checked against"))
    assert "all objects +0.0 points" in against and "**not kept** in its place" in against


def test_the_picks_page_says_whether_the_network_checked_and_what_the_check_costs_against_the_target():
    from benchmarks.pages.picks_page import _check_words, _checked_line

    assert "ranks by its score alone" in _check_words({"check_first": 0})
    assert "checks its first 3 grasps" in _check_words({"check_first": 3, "check_draws": 4, "check_shape": "hull"})
    row = {"check_first": 3, "check_draws": 4, "check_seconds": 0.4, "check_plane": True}
    plan = {"rows": [{"points": 10}, row], "targets": {"cpu_seconds_per_view": 0.3}}
    assert _checked_line(plan) == ""  # a run before the check was timed
    slow = _checked_line({**plan, "median_checked_seconds": 0.56})
    assert "median 0.560 s a view (the 0.3 s target: **not met**" in slow
    assert "**met**" in _checked_line({**plan, "median_checked_seconds": 0.25})


def test_the_picks_page_judges_each_hands_planning_with_its_check_against_the_same_target():
    from benchmarks.pages.picks_page import _hands_line

    plan = {"targets": {"cpu_seconds_per_view": 0.3}}
    assert _hands_line(plan) == ""  # a run before other hands were timed
    hand = {"hand": "panda", "gripper": "franka_panda", "rows": [{"check_first": 3}], "median_seconds_per_view": 0.05}
    slow = _hands_line({**plan, "hands": [{**hand, "median_checked_seconds": 0.36}]})
    assert "The `panda` preset (franka_panda" in slow and "0.050 s a view without the check" in slow
    assert "0.360 s with its first 3 checked (the 0.3 s target: **not met**)" in slow
    assert "(the 0.3 s target: **met**)" in _hands_line({**plan, "hands": [{**hand, "median_checked_seconds": 0.29}]})


def test_the_picks_page_judges_planning_from_a_depth_cameras_files_of_several_objects():
    from benchmarks.pages.picks_page import _files_line

    plan = {"targets": {"cpu_seconds_per_view": 0.3}}
    assert _files_line(plan) == ""  # a run before the files were timed
    rows = [{"objects": ["a", "b"], "points": 50000, "check_first": 3},
            {"objects": ["a", "b", "c", "d"], "points": 90000, "check_first": 3}]
    line = _files_line({**plan, "files": {"rows": rows, "median_seconds_per_view": 0.25,
                                          "median_checked_seconds": 0.5}})
    assert "(2 or 4 of the scenes' objects, 2 views)" in line and "50000-90000 points" in line
    assert "0.250 s a view without the check (the 0.3 s target: **met**)" in line
    assert "0.500 s with its first 3 checked (**not met**)" in line


def test_the_picks_page_names_the_gripper_that_executes_the_picks():
    from benchmarks.pages.picks_page import _gripper_words

    box = _gripper_words({"gripper": "onepiece_box"})
    assert "`onepiece_box`" in box and "not the Franka hand's meshes of the `panda` preset" in box
    assert _gripper_words({"gripper": "franka_panda"}).endswith("trained for, `franka_panda`.")
    assert _gripper_words({"checkpoint": "elsewhere.pt"}) == ""


def _check_row(name: str, trials_agree: bool) -> dict:
    """A view whose second grasp picks surely and first half the time: the protocol's check finds it (4 draws,
    1 s); single trials (1 ms each) find it too, or favour the first."""
    protocol = [{"held": [True, False, True, False], "seconds": 1.0}, {"held": [True] * 4, "seconds": 1.0},
                {"held": [False] * 4, "seconds": 1.0}]
    good, bad = [True] * 16, [False] * 16
    trials = [{"nominal": True, "held": bad if trials_agree else good, "seconds": [0.001] * 17},
              {"nominal": True, "held": good if trials_agree else bad, "seconds": [0.001] * 17},
              {"nominal": False, "held": [], "seconds": [0.001]}]
    return {"object": name, "shares": [0.5, 1.0, 0.0], "protocol": protocol, "trials": trials}


def test_a_check_by_single_trials_replaces_the_protocols_only_where_as_good_and_cheaper():
    from benchmarks.experiments.pick_check_trials import COUNTS, measured, protocol_seconds, trial_shares
    from benchmarks.pages.pick_check_section import check_trials_section

    row = _check_row("a", True)
    assert trial_shares(row, 2) == [0.0, 1.0, -1.0] and trial_shares(row, 0) == [0.0, 0.0, -1.0]
    assert protocol_seconds(row) == 3.0  # its first held 2 of 4 draws: every grasp is checked
    assert protocol_seconds({**row, "protocol": row["protocol"][1:]}) == 1.0  # the first held every draw

    def section(agree: bool) -> str:
        rows = [_check_row(name, agree) for name in "abcd"]
        sets = {"household": measured(rows[:2]), "unseen": measured(rows[2:]), "all objects": measured(rows)}
        result = {"command": "c", "date": "d", "machine": "m", "seconds": 1.0, "checked": 3, "draws": 4,
                  "counts": list(COUNTS), "sets": sets}
        assert sets["all objects"]["protocol"]["gain"] == 0.5
        return check_trials_section(result)[-1]

    assert section(True).startswith("As good and cheaper: the nominal trial, then 1 perturbed")
    assert "**not kept**" in section(False) and "As good, at the same cost or more: none" in section(False)


def test_the_checks_pose_noise_is_judged_against_its_own_noise_by_the_draws_of_what_each_chose():
    from benchmarks.experiments.pick_shape_check import noise_summary
    from benchmarks.pages.pick_rank_section import shape_check_section

    base = [{"object": "a", "shares": [0.5, 1.0, 0.0], "held_hull": [1.0, 0.75, 0.0]},
            {"object": "b", "shares": [1.0, 0.0, 0.5], "held_hull": [1.0, 0.0, 0.0]}]
    wider = [{**base[0], "held_hull": [0.25, 0.75, 0.0]},  # a: the second chosen (1.0 against 0.5)
             {**base[1], "held_hull": [0.0, 0.0, 0.5]}]  # b: the third chosen (0.5 against 1.0)
    stored = {"household": [base[0], {**base[1], "held_hull": [0.0, 0.0, 0.0]}]}  # one view as kept before
    summary = noise_summary({"household": {1.0: base, 2.0: wider}}, stored)
    assert summary["stored_agree"] == {"household": 1}
    three = summary["2.0"]["3"]["household"]
    assert three["checked"] == 0.75 and three["versus"]["mean"] == 0.0  # +0.5 on a, -0.5 on b
    assert summary["2.0"]["3"]["all objects"]["versus"] == three["versus"]
    result = {"command": "c", "date": "d", "machine": "m", "draws": 8, "checks": [0], "expected_noise": summary,
              "sets": {"household": {"0": {"views": 2, "per_object": {"a": 1, "b": 2}, "first_attempt": 0.75,
                                           "interval": [0, 1], "within_3": 1.0, "failures": {}, "seconds": 1.0}}}}
    page = "\n".join(shape_check_section(result))
    assert "| 2x | 3 | household | 75.0% | +0.0 [-50.0, +50.0] | +0.0 [-50.0, +50.0] |" in page
    assert "(which gave the shares the shapes' measure above kept on 1 household views)" in page
    assert ("at 2x the protocol's pose noise against 1x, over all objects: +0.0 [-50.0, +50.0] points: **not kept**"
            in page)
    better = noise_summary({"household": {1.0: base, 0.5: [wider[0], base[1]]}}, stored)
    better.pop("stored_agree")  # 1x not measured again: the kept shares are the base
    page = "\n".join(shape_check_section({**result, "expected_friction": better}))
    assert "against the check at the protocol's as the shapes' measure above kept it:" in page
    assert "| the check's finger friction | checked |" in page and "| 0.5x | 3 | household | 100.0% |" in page
    assert "at 0.5x the protocol's friction against 1x, over all objects: +25.0 [+0.0, +50.0] points: **not" in page


def test_the_checks_ties_broken_by_slip_are_judged_by_the_draws_of_what_each_chose():
    from benchmarks.experiments.pick_check_slip import slip_key, slip_summary
    from benchmarks.pages.pick_check_slip_section import slip_lines

    assert slip_key([1.0, 1.0, 0.0], [[9.0, 7.0], [2.0], []]) == [9992.0, 9998.0, -1000.0]
    rows = [{"object": "a", "shares": [0.5, 1.0, 0.0], "held_hull": [1.0, 1.0, 0.0],
             "slips_hull": [[9.0], [2.0], []]},  # a tie on the hull: the second slipped less, and picks surer
            {"object": "b", "shares": [1.0, 0.0, 0.5], "held_hull": [1.0, 0.5, 0.0],
             "slips_hull": [[9.0], [1.0], []]}]  # no tie: the slip does not move the first
    stored = {"household": [rows[0], {**rows[1], "held_hull": [0.0, 0.0, 0.0]}]}  # one view as kept before
    summary = slip_summary([("household", rows)], stored)
    assert summary["stored_agree"] == {"household": 1}
    three = summary["3"]["household"]
    assert (three["checked"], three["changed"], three["versus"]["mean"]) == (1.0, 1, 0.25)
    assert summary["3"]["all objects"]["versus"] == three["versus"]
    assert summary["rows"]["household"][0]["slips_hull"] == [[9.0], [2.0], []]
    page = "\n".join(slip_lines(summary))
    assert "those the shapes' measure above kept on 1 of 2 household views" in page
    assert "| 3 | household | 2 | 75.0% | 100.0% | +25.0 [+0.0, +50.0] | 100.0% | 1 |" in page
    assert "The tie-broken first among the first 3 against the check's, over all objects: +25.0 [+0.0, +50.0] " \
           "points: **not kept**" in page
    assert slip_lines({}) == []
