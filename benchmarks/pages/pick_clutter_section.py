"""The several-objects section of docs/picks.md, from results/pick_clutter.json
(benchmarks/experiments/pick_clutter.py): per scene size, each chooser's first attempt over scenes beside the same
objects alone, how the first attempts ended, and the planner's parts judged on the same views (the check; telling
the objects apart)."""

from __future__ import annotations

import numpy as np

# (run, method) -> what the row is
ROWS = {("default", "network"): "network on the view (as shipped: objects told apart, first 3 checked)",
        ("unchecked", "network"): "network on the view, its order alone (check_first=0)",
        ("as_one", "network"): "network on the view, the cloud taken for one object (objects_apart=False)",
        ("default", "random"): "random collision-free candidate",
        ("default", "analytic"): "antipodal score on the view",
        ("default", "top_down"): "top-down across the narrow axis of the largest object",
        ("as_one", "top_down"): "top-down across the narrow axis of the whole cloud"}
REASONS = ("start_collision", "no_contact", "slipped_lifting", "dropped_shaking", "no_grasp")
RULE = "shown where the interval over all scenes lies above zero"


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def _points(gain: dict) -> str:
    low, high = gain["interval"]
    return f"{100 * gain['mean']:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]"


def _rows(result: dict):
    """Each (run, method) row present: its run and method."""
    return [(run, method) for run, method in ROWS if method in result["runs"].get(run, {}).get("methods", ())]


def pooled_rate(scenes: dict, views: int, run: str, method: str) -> dict:
    """``run``'s ``method`` over the scenes of every set of one size: the mean of per-scene first-attempt rates
    and its 95% bootstrap interval over scenes."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    rates = np.array([picked / views for runs in scenes["sets"].values()
                      for picked in runs[run]["per_scene"][method].values()])
    return {"rate": float(rates.mean()) if len(rates) else 0.0, "interval": list(bootstrap_interval(rates)),
            "scenes": len(rates)}


def _table(result: dict, size: str) -> list[str]:
    lines = []
    for name, runs in result["scenes"][size]["sets"].items():
        alone = result.get("single", {}).get(name, {})
        for run, method in _rows(result):
            m = runs[run]["methods"][method]
            single = _pct(alone[method]) if method in alone and run == "default" else "-"
            lines.append(f"| {size} | {name} | {ROWS[(run, method)]} | {_pct(m['first_attempt'])} "
                         f"[{_pct(m['interval'][0])}, {_pct(m['interval'][1])}] | {_pct(m['within_3'])} | {single} | "
                         f"{m['views']} |")
    return lines


def _failures(result: dict, size: str) -> list[str]:
    lines = []
    for name, runs in result["scenes"][size]["sets"].items():
        for run, method in _rows(result):
            m = runs[run]["methods"][method]
            lost = sum(m["failures"].values())
            lines.append(f"| {size} | {name} | {ROWS[(run, method)]} | {m['views'] - lost} | "
                         + " | ".join(str(m["failures"].get(r, 0)) for r in REASONS) + " |")
    return lines


def _paired_line(size: str, what: str, gain: dict) -> str:
    sets = "; ".join(f"{name} {_points(g)}" for name, g in gain.items())
    verdict = "it helps" if gain["all scenes"]["interval"][0] > 0 else "not shown to help"
    return f"{size} objects: {what}, paired over scenes: {sets}: {verdict} ({RULE})."


HEURISTICS = {"random": "a random candidate", "analytic": "the antipodal score", "top_down": "top-down on the "
              "largest object"}


def _headline(result: dict, size: str) -> str:
    scenes = result["scenes"][size]
    net = pooled_rate(scenes, result["views"], "default", "network")
    tried = [m for m in HEURISTICS if m in result["runs"]["default"]["methods"]]
    rates = {m: pooled_rate(scenes, result["views"], "default", m) for m in tried}
    best = max(tried, key=lambda m: rates[m]["rate"])
    others = ", ".join(f"{HEURISTICS[m]} {_pct(rates[m]['rate'])}" for m in tried)
    verdicts = " ".join(f"{name.capitalize()}: {runs['default']['verdict']}." for name, runs in scenes["sets"].items())
    return (f"{size} objects a scene, over all {net['scenes']} scenes: the shipped planner picks "
            f"**{_pct(net['rate'])}** [{_pct(net['interval'][0])}, {_pct(net['interval'][1])}] at the first attempt, "
            f"{100 * (net['rate'] - rates[best]['rate']):+.0f} points over the best heuristic ({others}). "
            f"{verdicts}")


def hand_words(result: dict) -> str:
    """Which hand executes and which network plans, where a result names a gripper preset (else nothing)."""
    if not result.get("gripper"):
        return ""
    return (f" Every grasp here is executed by the `{result['gripper']}` preset's hand (the Franka hand's own "
            f"collision mesh{solver_words(result)}), and the network is the one shipped for it "
            "(`pick_view_panda.pt`, above).")


def solver_words(result: dict) -> str:
    """The solver iterations a result's hand was stepped with, where it records them (sim.world.physics_for)."""
    if "solver_iterations" not in result:
        return ""
    return (f"; its grip stepped at {result['solver_iterations']} solver iterations, the default gripper's 50 scaled "
            "by its force (docs/trials.md)")


LAYOUTS = {False: ("Several objects on the table", "--clutter N` (`PickSpec.clutter`) sets N on it together",
                   "each next one dropped 1-5 cm beyond those already there along a seeded direction"),
           True: ("Objects piled on the table", "--clutter N --pile` (`PickSpec.pile`) piles N on it",
                  "each next one dropped in a seeded orientation onto those already there (its lowest point 5 mm "
                  "above their highest, its middle within 3 cm of theirs), so they touch and lean")}


def clutter_section(result: dict) -> list[str]:
    sizes = list(result["scenes"])
    hand = ", the Franka hand" if result.get("gripper") else ""
    title, option, layout = LAYOUTS[bool(result.get("pile"))]
    lines = [f"## {title}{hand}: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}.{hand_words(result)} A robot's table holds more than one "
             f"object: `onepiece pick {option}. Each object of the household and unseen sets "
             f"with the next N-1 of its set (wrapping round: each object stands in N scenes), {result['views']} "
             f"seeded views a scene: the first object dropped at the table centre and settled, {layout}, all "
             "settled again, one camera aimed at "
             "their middle (as above; the cloud kept within 0.25 m of it). Every chooser plans on the cloud of them "
             "all; a grasp picks when it lifts and holds the object it closes on (the one with the most of its true "
             f"surface between the fingers) through the pick protocol, the others standing beside it in every trial; "
             f"up to {result['attempts']} attempts from the scene at rest. Each candidate's execution has a "
             "generator of its own, so the rows below compare view for view. A scene picks where any of its objects "
             "is picked, so it can be easier than its objects alone: the planner chooses which to grasp.", ""]
    lines += [_headline(result, size) for size in sizes]
    lines += ["", "| objects | set | chooser | first attempt [95% CI over scenes] | within 3 | the same objects "
              "alone, first attempt | views |", "| --- | --- | --- | --- | --- | --- | --- |"]
    lines += [row for size in sizes for row in _table(result, size)]
    lines += ["", "First attempts by how they ended:", "",
              "| objects | set | chooser | picked | " + " | ".join(r.replace("_", " ") for r in REASONS) + " |",
              "| --- | --- | --- | --- | " + " | ".join("---" for _ in REASONS) + " |"]
    lines += [row for size in sizes for row in _failures(result, size)]
    lines.append("")
    compared = {"checked_vs_unchecked": "the network's first 3 checked against its order alone",
                "apart_vs_as_one": "the objects told apart against the cloud taken for one object (the planner's "
                                   "check, contexts and top-down grasps)",
                "network_vs_top_down": "the shipped planner against top-down on the largest object"}
    for size in sizes:
        scenes = result["scenes"][size]
        lines += [_paired_line(size, what, scenes[key]) for key, what in compared.items() if key in scenes]
    return lines


def clutter_pointer(clutter: dict | None, clearance: dict | None) -> list[str]:
    """One line under the targets: what the planner does with several objects on the table (the sections below),
    and why those figures do not stand in for the targets."""
    parts = []
    if clutter is not None:
        rates = {size: pooled_rate(scenes, clutter["views"], "default", "network")["rate"]
                 for size, scenes in clutter["scenes"].items()}
        parts.append("picks " + " and ".join(f"{_pct(r)} of the views of {size} objects" for size, r in rates.items())
                     + " at the first attempt")
    if clearance is not None:
        cleared = clearance["rates"]["all scenes"]["network"]["declutter"]["rate"]
        parts.append(f"clears {_pct(cleared)} of {clearance['objects']} objects round by round")
    if not parts:
        return []
    return ["", f"With several objects on the table (below) the shipped planner {' and '.join(parts)}; there it "
            "chooses which object to grasp, so those figures do not stand in for the targets above."]
