"""The Franka hand's trial (issue 55, what to build 4): its labels are the shipped network's batches with only the
hand changed, and its section judges the issue's targets on that hand beside the box palm's figures."""

from __future__ import annotations

import copy
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_franka_hands_labels_are_the_shipped_batches_with_only_the_hand_changed():
    from benchmarks.experiments.pick_curve import BATCHES, label_spec
    from benchmarks.experiments.pick_panda import panda_specs

    specs = panda_specs()
    assert [spec.plan.top_down for _, spec, _, _ in specs] == [True, False]  # as the shipped network's batches
    for (objects, folder, shapes, seed), (name, spec, panda_shapes, panda_seed) in zip(BATCHES, specs, strict=False):
        box = label_spec(objects, folder)
        assert spec.gripper.name == "franka_panda" and box.gripper.name == "onepiece_box"
        assert spec.output == f"data/{name}" != box.output and (panda_shapes, panda_seed) == (shapes, seed)
        differs = {k for k, v in spec.model_dump().items() if box.model_dump()[k] != v}
        assert differs == {"gripper", "output", "plan"} if spec.plan.top_down else {"gripper", "output"}


def _panda_result(picks: dict, network_rate: float) -> dict:
    """A Franka hand result shaped as the experiment writes it, its sets the committed box palm's with the
    network's first attempt of every view set to ``network_rate`` (all or none)."""
    sets = copy.deepcopy([s for s in picks["sets"] if s["name"] in ("household", "unseen")])
    for s in sets:
        for o in s["objects"]:
            for v in o["views"]:
                v["attempts"]["network"] = [network_rate == 1.0]
        next(m for m in s["methods"] if m["method"] == "network")["first_attempt"] = network_rate
    network = {"design": "context_balanced", "options": {"seed": 0}, "labels": 80000, "fit_seconds": 600.0,
               "best_epoch": {"epoch": 7, "val_ap": 0.8}, "checkpoint": "data/pick_curve/panda/panda_s0/best.pt"}
    batch = {"objects": "o", "top_down": True, "labels": 40000, "success_rate": 0.3, "core_seconds": 3600.0}
    return {"command": "c", "date": "d", "machine": "m", "gripper": "panda", "batches": [batch],
            "points": [{"seed": 0, "network": network, "sets": sets}]}


def test_the_franka_hands_section_judges_the_targets_on_that_hand_beside_the_box_palms_figures():
    from benchmarks.pages.pick_panda_section import panda_section

    picks = json.loads((ROOT / "benchmarks" / "results" / "picks.json").read_text())
    every = panda_section(_panda_result(picks, 1.0), picks)
    none = panda_section(_panda_result(picks, 0.0), picks)
    target = next(line for line in every if line.startswith("| household first attempt >= 85%"))
    assert "| 100% | **met** |" in target
    assert "| 0% | **not met** |" in next(line for line in none if line.startswith("| household first attempt"))
    box = next(m for s in picks["sets"] if s["name"] == "household" for m in s["methods"] if m["method"] == "network")
    row = next(line for line in every if line.startswith("| household | network on the view |"))
    assert row.startswith("| household | network on the view | 100% [")
    assert row.endswith(f"| {100 * box['first_attempt']:.0f}% |")  # the box palm's figure beside it
    assert "No set has been judged yet." in panda_section({**_panda_result(picks, 1.0), "points": []}, picks)
    assert not any(line.startswith("| seed |") for line in every)  # one seed: no table of seeds
    two = _panda_result(picks, 1.0)
    two["points"].append({**_panda_result(picks, 0.0)["points"][0], "seed": 1})
    seeds = panda_section(two, picks)
    assert "| 0 | 100% | 100% | 100% |" in " ".join(seeds) and "| 1 | 0% | 0% | 0% |" in " ".join(seeds)
    assert "| mean | 50% | 50% | 50% |" in " ".join(seeds)  # the seeds weigh alike


def test_the_franka_hand_at_the_table_is_named_and_only_the_runs_made_are_compared():
    from benchmarks.pages.pick_clearance_section import clearance_section
    from benchmarks.pages.pick_clutter_section import clutter_section

    results = ROOT / "benchmarks" / "results"
    clutter = json.loads((results / "pick_clutter.json").read_text())
    box_lines = clutter_section(clutter)
    clutter = {**clutter, "gripper": "panda", "runs": {"default": clutter["runs"]["default"]}}
    for scenes in clutter["scenes"].values():
        for key in ("checked_vs_unchecked", "apart_vs_as_one"):
            del scenes[key]
        for runs in scenes["sets"].values():
            for run in ("unchecked", "as_one"):
                del runs[run]
    lines = clutter_section(clutter)
    assert lines[0].startswith("## Several objects on the table, the Franka hand: `")
    assert "executed by the `panda` preset's hand" in lines[2] and "Franka" not in box_lines[0] + box_lines[2]
    assert sum("paired over scenes" in line for line in lines) == len(clutter["scenes"])  # top-down alone
    assert not any("its order alone" in line or "taken for one object" in line for line in lines)
    clearance = json.loads((results / "pick_clearance.json").read_text())
    assert clearance_section({**clearance, "gripper": "panda"})[0].startswith("## Clearing the table, the Franka hand")
    assert "Franka" not in clearance_section(clearance)[0] + clearance_section(clearance)[2]


def test_the_franka_hands_ceiling_is_judged_against_that_hands_network_and_top_down():
    from benchmarks.pages import picks_page
    from benchmarks.pages.pick_sets import HOUSEHOLD_SETS, pooled

    results = ROOT / "benchmarks" / "results"
    ceiling = json.loads((results / "pick_ceiling.json").read_text())
    from benchmarks.experiments.pick_clutter import SINGLE
    from benchmarks.experiments.pick_panda import SHIPPED

    assert SINGLE["panda"] == SHIPPED  # the clutter trials' one-object rates are the shipped network's
    panda = json.loads(SHIPPED.read_text())  # the run the shipped network came from
    franka = picks_page._panda_picks(panda, json.loads((results / "picks.json").read_text()))
    assert franka["sets"] == panda["points"][0]["sets"]  # seed 0: the network shipped for the preset
    lines = picks_page._ceiling({**ceiling, "gripper": "panda"}, franka)
    assert lines[0].startswith("## The pool's ceiling without the draw, the Franka hand: `")
    assert "executed by the `panda` preset's hand" in lines[2] and "solver iterations" not in lines[2]
    stepped = picks_page._ceiling({**ceiling, "gripper": "panda", "solver_iterations": 88}, franka)[2]
    assert "its grip stepped at 88 solver iterations" in stepped  # where the result records them
    top_down = pooled([s for s in franka["sets"] if s["name"] in HOUSEHOLD_SETS], "top_down")["first_attempt"]
    assert f"top-down ({100 * top_down:.1f}%) needs {100 * (top_down + 0.2):.1f}%" in lines[-1]
    network = next(m for m in franka["sets"][0]["methods"] if m["method"] == "network")["first_attempt"]
    assert lines[6].endswith(f"| {100 * network:.1f}% |")  # the household row's network is the Franka hand's
    assert "Franka" not in "".join(picks_page._ceiling(ceiling, json.loads((results / "picks.json").read_text())))


def test_the_franka_hands_section_sets_each_chooser_beside_its_figure_at_50_solver_iterations():
    from benchmarks.pages.pick_panda_section import panda_section

    picks = json.loads((ROOT / "benchmarks" / "results" / "picks.json").read_text())
    before, now = _panda_result(picks, 0.0), {**_panda_result(picks, 1.0), "solver_iterations": 88}
    lines = panda_section(now, picks, before)
    assert any(line.startswith("Before the worlds' solver iterations grew with the grip") for line in lines)
    assert "| household | network on the view | 0% | 100% |" in lines
    paired = next(line for line in lines if line.startswith("Paired over the"))
    assert paired.startswith(f"Paired over the {sum(len(s['objects']) for s in now['points'][0]['sets'])} household")
    assert "network on the view +100.0 points [+100.0, +100.0]" in paired
    assert "top-down across the narrow axis +0.0 points" in paired  # top-down's attempts are the same in both
    assert panda_section(now, picks, {**before, "solver_iterations": 88}) == panda_section(now, picks)  # not before
    then = {"command": "c", "solver_iterations": 88, "sets": before["points"][0]["sets"]}  # judged alike: none
    judged = panda_section(now, picks, before, then)
    line = next(line for line in judged if line.startswith("The network labelled at 50 iterations judged at 88"))
    assert "household 0%; unseen 0%" in line and "made again against it: +100.0 points" in line


def test_the_franka_hands_network_planned_otherwise_is_judged_against_its_first_three_checked():
    from benchmarks.experiments.pick_panda_check import paired
    from benchmarks.pages.pick_check_section import panda_check_section

    picks = json.loads((ROOT / "benchmarks" / "results" / "picks.json").read_text())

    def section(before: bool, rate: float) -> list[str]:
        panda = _panda_result(picks, 0.0)
        for s in panda["points"][0]["sets"]:  # in-memory reports hold tuples where JSON holds lists
            for o in s["objects"]:
                for v in o["views"]:
                    v["attempts"]["network"] = (before,)
        after = _panda_result(picks, rate)["points"][0]["sets"]
        versus = {base: paired(after, panda["points"][0]["sets"], "network", base) for base in ("network", "top_down")}
        more = {"check_3_32_views": paired(after, panda["points"][0]["sets"], "network", "network")}
        return panda_check_section({"command": "c", "date": "d", "machine": "m", "seed": 0, "variants": {
            "top_down": {"sets": after, "versus": versus}, "unchecked": {"sets": after, "versus": versus},
            "check_3_32_views": {"views": 32, "sets": panda["points"][0]["sets"]},
            "check_5_32_views": {"views": 32, "sets": after, "versus": more}}}, panda)

    def verdicts(lines: list[str]) -> tuple[str, str]:
        return (next(line for line in lines if "With the best top-down grasp" in line),
                next(line for line in lines if "Without the check" in line))

    raised, same, lower = section(False, 1.0), section(True, 1.0), section(True, 0.0)
    assert "+100.0 points [+100.0, +100.0] against the first 3 checked alone" in verdicts(raised)[0]
    assert "**kept**" in verdicts(raised)[0] and "the check hurts on this hand" in verdicts(raised)[1]
    assert any(line.startswith("| household | 100% | 100% | 0% |") for line in raised)
    assert any(line.startswith("| household meshes pooled | 100% | 100% | 0% |") for line in raised)
    assert "+0.0 points" in verdicts(same)[0] and "**not kept**" in verdicts(same)[0]
    assert "cannot tell whether the check helps" in verdicts(same)[1]
    assert "-100.0 points" in verdicts(lower)[0] and "**not kept**" in verdicts(lower)[0]
    assert "the check helps on this hand" in verdicts(lower)[1]
    at_32 = [next(line for line in lines if line.startswith("The same at 32 views")) for lines in (raised, same)]
    assert "the first 5 against the first 3: +100.0 points [+100.0, +100.0]: on this hand the first 5 pick more" \
        in at_32[0]
    assert "+0.0 points [+0.0, +0.0]: **not kept**" in at_32[1] and "household meshes pooled 100%" in at_32[1]


def test_the_first_fives_gain_is_said_to_hold_for_the_second_network_only_where_its_interval_lies_above_zero():
    from benchmarks.experiments.pick_panda_check import paired
    from benchmarks.pages.pick_check_section import panda_check_section

    picks = json.loads((ROOT / "benchmarks" / "results" / "picks.json").read_text())
    panda = _panda_result(picks, 0.0)
    low, high = panda["points"][0]["sets"], _panda_result(picks, 1.0)["points"][0]["sets"]

    def second(five_sets: list) -> str:
        more = {"check_3_32_views": paired(high, low, "network", "network")}
        s1 = {"check_3_32_views_s1": paired(five_sets, low, "network", "network")}
        versus = {b: paired(high, low, "network", b) for b in ("network", "top_down")}
        lines = panda_check_section({"command": "c", "date": "d", "machine": "m", "seed": 0, "variants": {
            "unchecked": {"sets": high, "versus": versus},
            "check_3_32_views": {"views": 32, "sets": low}, "check_5_32_views": {"views": 32, "sets": high,
                                                                                 "versus": more},
            "check_3_32_views_s1": {"views": 32, "seed": 1, "sets": low},
            "check_5_32_views_s1": {"views": 32, "seed": 1, "sets": five_sets, "versus": s1}}}, panda)
        return next(line for line in lines if line.startswith("The same at 32 views"))

    holds, fails = second(high), second(low)
    assert "With the network of seed 1" in holds and "household meshes pooled 0% with the first 3 checked" in holds
    assert "+100.0 points [+100.0, +100.0]: the first 5 pick more with this network too" in holds
    assert "+0.0 points [+0.0, +0.0]: with this network the interval does not lie above zero" in fails


def test_the_franka_hands_labels_made_at_the_planners_height_replace_the_shipped_network_only_where_they_pick_more():
    from benchmarks.pages.pick_panda_section import Shipped, panda_section

    picks = json.loads((ROOT / "benchmarks" / "results" / "picks.json").read_text())

    def made_at(height: float | None, rate: float) -> dict:
        result = _panda_result(picks, rate)
        result["points"].append({**_panda_result(picks, rate)["points"][0], "seed": 1})
        for batch in result["batches"]:
            if height is not None:
                batch["table_clearance"] = height
        return result

    def shipped(rate: float) -> Shipped:  # the shipped network by today's planner: every view or none picked
        record = made_at(None, 0.0)  # its run: before the height was recorded (2 mm)
        counts = {s["name"]: {"per_object": {o["name"]: int(8 * rate) for o in s["objects"]}}
                  for s in record["points"][0]["sets"]}
        return Shipped(record, counts)

    better = panda_section(made_at(0.008, 1.0), picks, shipped=shipped(0.0))
    worse = panda_section(made_at(0.008, 0.0), picks, shipped=shipped(1.0))
    assert "the open gripper 8 mm over the table" in better[2]
    assert "Seed 0's network ships for the `panda` preset" in better[2]
    assert "stays the one this recipe made before" in worse[2] and "Seed 0's network ships" not in worse[2]
    assert "The issue's targets on the Franka hand (seed 0, labels 8 mm over the table, not shipped):" in worse
    assert "The issue's targets on the Franka hand (seed 0):" in better
    assert "| set | chooser | 2 mm | 8 mm |" in better  # beside the run the shipped network came from
    assert "| household | network on the view | 0% | 100% |" in better
    verdict = next(line for line in better if line.startswith("Each seed's network of the labels made at 8 mm"))
    assert "+100.0 points over 2 seeds" in verdict and "it does)." in verdict
    verdict = next(line for line in worse if line.startswith("Each seed's network of the labels made at 8 mm"))
    assert "-100.0 points over 2 seeds" in verdict and "the shipped one stays)." in verdict
    same = panda_section(made_at(None, 1.0), picks, shipped=shipped(0.0))  # the shipped run itself: no comparison
    assert not any(line.startswith("Each seed's network of the labels made at") for line in same)
