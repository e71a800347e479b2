"""The planner's options at 40 views an object (results/pick_plan_options.json,
benchmarks/experiments/pick_plan_options.py): the shipped network's picks with the planner's spec changed, paired
over objects against the planner's default on the same views and draws."""

from __future__ import annotations

from benchmarks.pages.pick_sets import interval, paired_first_attempts, pct, pooled
from benchmarks.pages.pick_table_gap_section import _cell, _gain

WHAT = {"nms_distance": "suppression distance {:g} m", "nms_angle_deg": "suppression angle {:g} degrees",
        "check_more": "up to {} more grasps checked where none of the first 3 held every draw",
        "check_shape": "checked on the {} shape", "check_draws": "each checked grasp executed {} times",
        "check_density": "the checked shape at {:g} kg/m^3 (the protocol's objects: 400)",
        "check_top_down": "the best-scored top-down grasp checked beside the first 3"}


def _what(run: dict) -> str:
    plan = run["plan"]
    if "relabelled" in run:
        return (f"the shipped recipe labelled again by the planner as it ships (pick_relabelled's network at seed "
                f"{run['relabelled']}), the planner's default")
    if "fresh" in run:
        fresh = run["fresh"]
        return (f"the network a user makes with pick-labels' defaults (label seed {fresh['label']}, labelled "
                f"{1000 * fresh['table_clearance']:g} mm over the table) and pick-train from fresh weights (fit seed "
                f"{fresh['fit']}), pick_own_network's, the planner's default")
    if "network" in run:
        label, fit = run["network"]
        return (f"the network a user makes with pick-labels' defaults (label seed {label}) and pick-train started "
                f"from the shipped one (fit seed {fit}), pick_own_network's, the planner's default")
    if plan.get("nms_distance") == 0:
        return "no non-maximum suppression"
    return ", ".join(WHAT.get(field, field + " {}").format(value) for field, value in plan.items())


def _row(name: str, run: dict, versus: dict | None) -> str:
    by_set = {s["name"]: s for s in run["sets"]}
    both = pooled(run["sets"], "network")
    versus = versus or {}
    return (f"| {name} | {_cell(by_set['household'])} | {_cell(by_set['unseen'])} | "
            f"{pct(both['first_attempt'])} {interval(both['first_attempt_interval'])} | "
            f"{_gain(versus.get('household'))} | {_gain(versus.get('unseen'))} | {_gain(versus.get('all objects'))} |")


def _verdict(name: str, run: dict) -> str:
    kept = run["versus"]["household"]["interval"][0] > 0
    return f"`{name}`: {'kept' if kept else 'not kept'}"


def plan_options_section(result: dict, table_gap: dict) -> list[str]:
    """The variants of ``result`` against the planner's default: ``table_gap``'s run (pick_table_gap.json) at the
    height ``result`` names."""
    gap, variants = result["base"]["gap"], result["variants"]
    base = table_gap["runs"][f"{gap:g}"]
    views = next(iter(variants.values()))["views"] if variants else 0
    relabelled = ("; the `relabelled_` variants: the shipped recipe labelled again by the planner as it ships, below"
                  if any("relabelled" in run for run in variants.values()) else "")
    lines = [f"## The planner's options at {views} views an object: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. The check reorders the network's first 3 grasps by how often "
             "each held on the shape the view implies, so what it can gain is bounded by what those three are: "
             "after non-maximum suppression at 1 cm and 30 degrees they may be near copies of one grasp, and where "
             "none of them held every draw the network's order stands. Each variant changes the planner's spec "
             "(`PlanSpec`) or, where it says so, its network (the `own_` variants: networks a user makes with the "
             "two commands, made as each row says, whose gains at 8 views an object, below, are judged here "
             f"again{relabelled}); else the network shipped for the box gripper (`{result['network']}`), its "
             "chooser alone, "
             f"{views} views an object (the first 8 the benchmark's), first attempt, paired over objects against "
             f"the planner's default on the same views and draws (pick_table_gap's run at {1000 * gap:g} mm, "
             "above):", "",
             "| planner | household [95% CI over objects] | unseen | both sets | against the default, household | "
             "unseen | both sets |", "| --- | --- | --- | --- | --- | --- | --- |",
             _row("the default", base, None)]
    lines += [_row(f"`{name}`: {_what(run)}", run, run.get("versus")) for name, run in variants.items()]
    tried = [_verdict(name, run) for name, run in variants.items()]
    return [*lines, "", "Each against the default, kept where the paired interval over the household objects lies "
            f"above zero (the trials' rule): {'; '.join(tried)}.", "", *_heights(variants)]


def _heights(variants: dict) -> list[str]:
    """The `own_` networks fitted from fresh weights on labels made at two heights over the table, paired over
    objects at the same label and fit seeds (on the same views and draws)."""
    fresh = {(r["fresh"]["label"], r["fresh"]["fit"], r["fresh"]["table_clearance"]): r
             for r in variants.values() if "fresh" in r}
    heights = sorted({height for *_, height in fresh})
    pairs = sorted({(label, fit) for label, fit, _ in fresh if all((label, fit, h) in fresh for h in heights)})
    if len(heights) != 2 or not pairs:
        return []
    low, high = heights

    def said(label: int, fit: int) -> str:
        after, before = fresh[label, fit, high]["sets"], fresh[label, fit, low]["sets"]
        def one(name: str) -> str:
            return _gain(paired_first_attempts([s for s in after if s["name"] == name], before, "network"))
        by_set = "; ".join(f"{name} {one(name)}" for name in ("household", "unseen"))
        both = _gain(paired_first_attempts(after, before, "network"))
        return f"label seed {label}, fit seed {fit}: {both} over both sets ({by_set})"
    return [f"Labels made {1000 * high:g} mm over the table against {1000 * low:g} mm, fitted from fresh weights at "
            "the same seeds (the `own_` rows above), paired over objects on the same views and draws: "
            f"{'; '.join(said(*pair) for pair in pairs)}.", ""]
