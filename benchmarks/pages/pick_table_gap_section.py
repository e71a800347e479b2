"""How low the open gripper may go over the table (results/pick_table_gap.json,
benchmarks/experiments/pick_table_gap.py): the shipped network's picks at each height the planner keeps above the
support plane, paired over objects against the height it kept before."""

from __future__ import annotations

from benchmarks.pages.pick_sets import interval, method_of, pct, pct1, pooled, views_kept
from benchmarks.pages.pick_sets import paired_first_attempts as paired

SETS = ("household", "unseen")
HANDS = {"panda": "Franka hand", "robotiq_2f85": "Robotiq 2F-85", "robotiq_2f140": "Robotiq 2F-140"}
CHOSEN = "0.008"  # the height kept: chosen among 5, 8 and 12 mm on the box gripper's views 8-23 (commit 3146b2e)
CHOSEN_BEFORE = 24  # the box gripper's views from here on were judged after that choice


def _cm(gap: str) -> str:
    return f"{1000 * float(gap):g} mm"


def _cell(result: dict) -> str:
    network = method_of(result, "network")
    return f"{pct(network['first_attempt'])} {interval(network['first_attempt_interval'])}"


def _gain(pair: dict | None) -> str:
    if pair is None:
        return "-"
    low, high = pair["interval"]
    return f"{100 * pair['mean']:+.1f} [{100 * low:+.1f}, {100 * high:+.1f}]"


def _judged_after(sets: list[dict]) -> list[dict]:
    """``sets`` cut to the views from CHOSEN_BEFORE on: those judged after the planner's height was chosen."""
    return views_kept(sets, lambda view: view >= CHOSEN_BEFORE)


def _after(run: dict, base: dict, set_names: tuple[str, ...]) -> str:
    """``run`` against ``base`` on the views from CHOSEN_BEFORE on, paired over the objects of ``set_names``."""

    def later(judged: dict) -> list[dict]:
        return _judged_after([s for s in judged["sets"] if s["name"] in set_names])

    return _gain(paired(later(run), later(base), "network"))


def _on_another_hand(runs: dict, kept: str) -> list[str]:
    """What the height the planner keeps (chosen on the box gripper) does on this hand, over both sets."""
    run = runs.get(CHOSEN)
    if run is None or "versus" not in run:
        return [f"The planner keeps {kept}, chosen on the box gripper's views; not judged on this hand."]
    low, high = run["versus"]["all objects"]["interval"]
    said = "a gain" if low > 0 else "a loss" if high < 0 else "neither a gain nor a loss"
    return [f"The planner keeps {kept} for every hand, chosen on the box gripper's views: on this hand it shows "
            f"{said} over both sets ({_gain(run['versus']['all objects'])})."]


def _verdict(gap: str, run: dict) -> str:
    household = run["versus"]["household"]["interval"][0] > 0
    return f"{_cm(gap)}: {'kept' if household else 'not kept'}"


def table_gap_section(result: dict) -> list[str]:
    from onepiece_dist.specs.plan import PlanSpec

    base, runs = result["base"], result["runs"]
    views = runs[base]["views"]
    hand = result["command"].partition("--gripper ")[2]
    title = "How low the open gripper may go over the table" + (f", the {HANDS.get(hand, hand)}" if hand else "")
    lines = [f"## {title}: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. The planner pushes each sampled hand in until its open gripper "
             "meets an observed point or comes within `PlanSpec.table_clearance` of the support plane. Of the "
             "shipped network's first attempts on the benchmark's views, those whose fingertips stopped nearest the "
             "table picked least often (the diagnosis: commit bd3857a); the top-down grasp keeps its fingertips "
             "5 mm above the object's lowest point. The network shipped for the hand "
             f"(`{result.get('network', 'pick_view.pt')}`), its chooser alone at each height, "
             f"its first 3 grasps checked, {views} views an object (the first 8 the benchmark's, the others seen "
             f"by no choice made before), first attempt, paired over objects against {_cm(base)}:", "",
             "| the open gripper above the plane | household [95% CI over objects] | unseen | both sets | "
             "against the first, household | unseen | both sets |", "| --- | --- | --- | --- | --- | --- | --- |"]
    ordered = sorted(runs.items(), key=lambda item: float(item[0]))
    for gap, run in ordered:
        by_set = {s["name"]: s for s in run["sets"]}
        both = pooled(run["sets"], "network")
        versus = run.get("versus", {})
        lines.append(f"| {_cm(gap)} | {_cell(by_set['household'])} | {_cell(by_set['unseen'])} | "
                     f"{pct(both['first_attempt'])} {interval(both['first_attempt_interval'])} | "
                     f"{_gain(versus.get('household'))} | {_gain(versus.get('unseen'))} | "
                     f"{_gain(versus.get('all objects'))} |")
    kept = _cm(str(PlanSpec().table_clearance))
    if hand:
        return [*lines, "", *_on_another_hand(runs, kept), ""]
    tried = [_verdict(gap, run) for gap, run in ordered if gap != base]
    lines += ["", f"Each height against {_cm(base)}, kept where the paired interval over the household objects lies "
              f"above zero (the trials' rule): {'; '.join(tried)}. The planner keeps {kept} "
              "(`onepiece grasp --table-clearance`).", ""]
    if CHOSEN in runs and views > CHOSEN_BEFORE:
        chosen = runs[CHOSEN]
        lines += [f"{_cm(CHOSEN)} was chosen on the box gripper's views 8 to {CHOSEN_BEFORE - 1} among 5, 8 and "
                  "12 mm, so the figures above flatter it by that choice. "
                  f"On views {CHOSEN_BEFORE} to {views - 1} alone, against {_cm(base)}: household "
                  f"{_after(chosen, runs[base], ('household',))}, unseen {_after(chosen, runs[base], ('unseen',))}, "
                  f"both sets {_after(chosen, runs[base], SETS)}.", ""]
    return lines


def more_views_line(result: dict | None, target: float) -> list[str]:
    """The headline's figure at every view of ``result``'s run at the planner's height (pick_table_gap.json): the
    same network and planner, five times the views, and the views judged after every choice alone."""
    run = (result or {}).get("runs", {}).get(CHOSEN)
    if run is None:
        return []
    sets = [s for s in run["sets"] if s["name"] in SETS]
    every, later = pooled(sets, "network"), pooled(_judged_after(sets), "network")
    by_set = ", ".join(f"{s['name']} {pct1(method_of(s, 'network')['first_attempt'])}" for s in sets)
    said = "**met** there" if every["first_attempt"] >= target else "**not met** there either"
    return [f"At {run['views']} views an object (the table-gap run at the planner's default, below: the same "
            f"network and planner; the first 8 views are these), it picks {pct1(every['first_attempt'])} "
            f"{interval(every['first_attempt_interval'])} pooled over {every['objects']} objects ({by_set}): "
            f"the target of {pct(target)} {said}; on views {CHOSEN_BEFORE} to "
            f"{run['views'] - 1} alone, judged after every choice the planner's defaults were made on, "
            f"{pct1(later['first_attempt'])} {interval(later['first_attempt_interval'])}."]
