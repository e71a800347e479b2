"""The Franka hand's section of docs/picks.md, from results/pick_panda.json (benchmarks/experiments/pick_panda.py):
a network labelled with the ``panda`` preset's hand and judged by picks that hand executes, every chooser beside it,
the issue's targets on that hand and each chooser's figure beside the box palm's (results/picks.json)."""

from __future__ import annotations

from typing import NamedTuple

from benchmarks.pages.pick_clutter_section import solver_words
from benchmarks.pages.pick_relabelled_section import against_shipped, mm, replaces_shipped
from benchmarks.pages.pick_sets import (
    HOUSEHOLD_SETS,
    LABELS,
    failure_table,
    first_attempt_share,
    interval,
    method_of,
    paired_first_attempts,
    pct,
    pooled,
    target_rows,
)
from onepiece_dist.specs.plan import PLANNER_CLEARANCE_BEFORE


def _height(result: dict) -> float:
    """The height (m) over the table the open gripper kept in the labels' candidates (runs before it was recorded:
    the planner's 2 mm then)."""
    return result["batches"][0].get("table_clearance", PLANNER_CLEARANCE_BEFORE)


def _ships(shipped_here: bool) -> str:
    if shipped_here:
        return ("Seed 0's network ships for the `panda` preset (`onepiece_dist/plan/networks/pick_view_panda.pt`, "
                "`python -m benchmarks.experiments.ship_network --gripper panda`; a seed is never chosen): `onepiece "
                "grasp --gripper` with that preset plans with it.")
    return ("The network shipped for the `panda` preset (`onepiece_dist/plan/networks/pick_view_panda.pt`) stays the "
            "one this recipe made before (below): `onepiece grasp --gripper` with that preset plans with it.")


def _how(result: dict, point: dict, shipped_here: bool = True) -> str:
    batches = "; ".join(f"`{b['objects']}`{' executing the top-down grasps' if b['top_down'] else ''}: {b['labels']} "
                        f"labels, {pct(b['success_rate'])} of them picked, {b['core_seconds'] / 3600:.1f} core-hours"
                        for b in result["batches"])
    net = point["network"]
    spec = point["sets"][0]["spec"]
    return (f"{result['date']}, {result['machine']}. The shipped network's recipe made again for the "
            f"`{result['gripper']}` preset, whose physics and collision test carry the Franka hand's own collision "
            "mesh (pybullet_data franka_panda/meshes/collision/hand.obj, 20 cm across the closing axis, where "
            f"the box palm spans the 8 cm opening and its two 1 cm fingers{solver_words(result)}): the same two "
            f"label batches labelled with that hand, the open gripper {mm(_height(result))} over the table "
            f"({batches}); design "
            f"`{net['design']}` fitted on all {net['labels']} labels; at seed {point['seed']} "
            f"({net['fit_seconds'] / 60:.0f} min, best epoch {net['best_epoch']['epoch']}, held-out AP "
            f"{net['best_epoch']['val_ap']:.3f}; `{net['checkpoint']}`) it is judged by the pick benchmark as above "
            f"({spec['views']} views an object, first {spec['plan'].get('check_first', 0)} grasps checked), every "
            "chooser's grasps executed by the Franka hand. " + _ships(shipped_here))


class Shipped(NamedTuple):
    """The run the network shipped for the preset came from (results/pick_panda_2mm.json) and that network's picks
    by today's planner on the benchmark's views (pick_own_network_panda.json's shipped row)."""

    record: dict
    picks: dict


def _box_rates(picks: dict | None) -> dict[tuple[str, str], float]:
    """(set, chooser) -> the box palm's first attempt on the committed benchmark."""
    return {(s["name"], m["method"]): m["first_attempt"] for s in (picks or {}).get("sets", [])
            for m in s["methods"]}


def _comparison(point: dict, picks: dict | None) -> list[str]:
    box = _box_rates(picks)
    rows = [f"| {s['name']} | {LABELS[m['method']]} | {pct(m['first_attempt'])} "
            f"{interval(m['first_attempt_interval'])} | {pct(m['within_k'])} | "
            f"{pct(box[(s['name'], m['method'])]) if (s['name'], m['method']) in box else '-'} |"
            for s in point["sets"] for m in s["methods"]]
    return ["| set | chooser | Franka hand: first attempt [95% CI over objects] | within 3 | box palm (above) |",
            "| --- | --- | --- | --- | --- |", *rows]


def _seed_rates(point: dict) -> dict[str, float]:
    """One seed's network: its first attempt on each set judged, and pooled over the household meshes beside
    top-down's ("pooled", "top_down pooled") where both household sets were judged."""
    rates = {s["name"]: method_of(s, "network")["first_attempt"] for s in point["sets"]}
    both = [s for s in point["sets"] if s["name"] in HOUSEHOLD_SETS]
    if len(both) == len(HOUSEHOLD_SETS):
        rates.update(pooled=pooled(both, "network")["first_attempt"],
                     top_down_pooled=pooled(both, "top_down")["first_attempt"])
    return rates


def _seeds(result: dict) -> list[str]:
    """Each seed's network on every set judged and pooled over the household meshes, beside top-down's, and their
    mean over the seeds."""
    columns = [s["name"] for s in result["points"][0]["sets"]] + ["pooled", "top_down_pooled"]
    every = [(str(point["seed"]), _seed_rates(point)) for point in result["points"]]
    mean = {c: sum(r[c] for _, r in every) / len(every) for c in columns if all(c in r for _, r in every)}
    rows = [f"| {seed} | " + " | ".join(pct(rates[c]) if c in rates else "-" for c in columns) + " |"
            for seed, rates in [*every, ("mean", mean)]]
    names = columns[:-2] + ["household meshes pooled", "top-down, pooled"]
    return [f"| seed | {' | '.join(names)} |", "|" + " --- |" * (len(names) + 1), *rows]


def _paired(before: list[dict], after: list[dict], method: str) -> tuple[float, list[float], int]:
    """``method``'s first attempt after minus before, over the household meshes both judged: the mean of the
    per-object differences, its 95% bootstrap interval over objects, and how many objects."""
    household = ([s for s in sets if s["name"] in HOUSEHOLD_SETS] for sets in (after, before))
    change = paired_first_attempts(*household, method)
    return change["mean"], change["interval"], change["objects"]


def _side_by_side(was: dict, point: dict, columns: str) -> list[str]:
    """Each chooser's first attempt in the earlier run's point ``was`` beside ``point``'s, under ``columns`` (the
    two runs' names), and the two paired over the household meshes (network and top-down)."""
    rates = {(s["name"], m["method"]): m["first_attempt"] for s in was["sets"] for m in s["methods"]}
    rows = [f"| {s['name']} | {LABELS[m['method']]} | {pct(rates[(s['name'], m['method'])])} | "
            f"{pct(m['first_attempt'])} |" for s in point["sets"] for m in s["methods"]
            if (s["name"], m["method"]) in rates]
    words, objects = [], 0
    for method in ("network", "top_down"):
        change, (low, high), objects = _paired(was["sets"], point["sets"], method)
        words.append(f"{LABELS[method]} {100 * change:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]")
    return [f"| set | chooser | {columns} |", "| --- | --- | --- | --- |", *rows, "",
            f"Paired over the {objects} household meshes, now against then: " + "; ".join(words) + "."]


def before_the_solver(before: dict, point: dict, then: dict | None = None, now: str = "now") -> list[str]:
    """The same recipe labelled, fitted and judged where the worlds stepped the 70 N grip at the default gripper's
    50 solver iterations (``before``, results/pick_panda_50_iterations.json), beside ``point`` (the same seed; its
    column named ``now``); ``then``: that network judged at the grip's iterations (results/pick_panda_then.json)."""
    was = next((p for p in before["points"] if p["seed"] == point["seed"]), None)
    if was is None or "solver_iterations" in before:
        return []
    labels = "; ".join(f"{b['labels']} labels, {pct(b['success_rate'])} picked" for b in before["batches"])
    return [f"Before the worlds' solver iterations grew with the grip (`sim.world.physics_for`, docs/trials.md), "
            f"this recipe was labelled ({labels}), fitted and judged at the default gripper's 50 iterations, "
            "where the 70 N grip's shake dropped light objects no real hand drops "
            f"(`{before['command']}` then; results/pick_panda_50_iterations.json). Seed {point['seed']}, first "
            "attempt:", "", *_side_by_side(was, point, f"at 50 iterations | {now}"), *_then_judged_now(then, point)]


def _then_judged_now(then: dict | None, point: dict) -> list[str]:
    """The network labelled at 50 iterations judged by picks at the grip's (``then``) against ``point``'s, whose
    labels were made again at those iterations: both judged alike."""
    if not then or not then["sets"]:
        return []
    rates = "; ".join(f"{s['name']} {pct(method_of(s, 'network')['first_attempt'])}" for s in then["sets"])
    change, (low, high), objects = _paired(then["sets"], point["sets"], "network")
    return ["", f"The network labelled at 50 iterations judged at {then['solver_iterations']} (`{then['command']}`, "
            f"the network chooser alone): {rates}. Paired over the {objects} household meshes, the network of the "
            f"labels made again against it: {100 * change:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]."]


def _first_picks(point: dict) -> dict:
    """``point``'s network on the household sets as pick_own_network records a network's picks: set -> object ->
    views picked at the first attempt."""
    return {s["name"]: {"per_object": {o["name"]: round(first_attempt_share(o, "network") * len(o["views"]))
                                       for o in s["objects"]}}
            for s in point["sets"] if s["name"] in HOUSEHOLD_SETS}


def _made_again(result: dict) -> list[dict]:
    """The seeds' networks judged on both household sets, as ``_first_picks``."""
    return [_first_picks(p) for p in result["points"] if set(HOUSEHOLD_SETS) <= {s["name"] for s in p["sets"]}]


def _shipped_here(result: dict, shipped: Shipped | None) -> bool:
    """Whether this run's network ships for the preset: no earlier run shipped, or its seeds replace that one's."""
    return shipped is None or replaces_shipped(_made_again(result), shipped.picks)


def at_the_planners_height(result: dict, shipped: Shipped) -> list[str]:
    """This recipe labelled and judged at the planner's height (``result``) beside the run the shipped network came
    from (``shipped.record``, labelled and judged at the planner's height then), and its networks against the
    shipped one judged by today's planner on the same views (``shipped.picks``)."""
    was = next((p for p in shipped.record["points"] if p["seed"] == result["points"][0]["seed"]), None)
    then, now = mm(_height(shipped.record)), mm(_height(result))
    if was is None or then == now:
        return []
    labels = "; ".join(f"{b['labels']} labels, {pct(b['success_rate'])} picked" for b in shipped.record["batches"])
    return [f"The network shipped for the preset is this recipe's seed {was['seed']} as it ran on "
            f"{shipped.record['date']} ({labels}; results/pick_panda_2mm.json), its labels and every chooser's "
            f"grasps planned with the open gripper {then} over the table, the planner's height then; here both are "
            f"planned {now} over it, as the planner plans today. Seed {was['seed']}, first attempt:", "",
            *_side_by_side(was, result["points"][0], f"{then} | {now}"), "",
            f"Each seed's network of the labels made at {now}, the network chooser judged on both household sets "
            "beside the shipped network judged by today's planner on the same views (pick_own_network's shipped row "
            "for the hand). " + against_shipped(_made_again(result), shipped.picks)]


def panda_section(result: dict, picks: dict | None, before: dict | None = None, then: dict | None = None,
                  shipped: Shipped | None = None) -> list[str]:
    """``shipped``: the run the network shipped for the preset came from, where it is not ``result``, and that
    network's picks by today's planner."""
    lines = [f"## The Franka hand labels and picks: `{result['command']}`", ""]
    point = result["points"][0] if result["points"] else {"sets": []}
    if not point["sets"]:
        return [*lines, "No set has been judged yet."]
    ships = _shipped_here(result, shipped)
    lines += [_how(result, point, ships), ""]
    targets = (picks or {}).get("targets", {"first_attempt": 0.85, "above_heuristics": 0.20, "procedural": 0.80,
                                            "full_mesh_gap": 0.05})
    if set(HOUSEHOLD_SETS) <= {s["name"] for s in point["sets"]}:
        whose = "" if ships else f", labels {mm(_height(result))} over the table, not shipped"
        lines += [f"The issue's targets on the Franka hand (seed {point['seed']}{whose}):", "", "| target | figure | |",
                  "| --- | --- | --- |", *target_rows(point["sets"], targets), ""]
    if len(result["points"]) > 1:
        lines += ["Each seed's network, first attempt:", "", *_seeds(result), ""]
    height = at_the_planners_height(result, shipped) if shipped is not None else []
    lines += [*height, ""] if height else []
    solved, now = point, "now"
    if height:  # the solver's history is the shipped network's run's
        solved = next(p for p in shipped.record["points"] if p["seed"] == point["seed"])
        now = f"at {shipped.record.get('solver_iterations')} iterations, {mm(_height(shipped.record))}"
    earlier = before_the_solver(before, solved, then, now) if before is not None else []
    lines += [*earlier, ""] if earlier else []
    lines += [*_comparison(point, picks), ""]
    for s in point["sets"]:
        lines += [f"{s['name'].capitalize()}: {s['verdict']}. First attempts by how they ended:", "",
                  *failure_table(s), ""]
    return lines[:-1]
