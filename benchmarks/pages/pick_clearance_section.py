"""The clearing-the-table section of docs/picks.md, from results/pick_clearance.json
(benchmarks/experiments/pick_clearance.py): per chooser, the share of objects cleared and of rounds that picked."""

from __future__ import annotations

from benchmarks.pages.pick_clutter_section import hand_words

LABELS = {"network": "network on the view (as shipped)", "random": "random collision-free candidate",
          "analytic": "antipodal score on the view",
          "top_down": "top-down across the narrow axis of the largest object"}


PILED = {False: ("Clearing the table", "", "What is left stays where it rested: a pick does not push its neighbours."),
         True: ("Clearing a pile", " --pile", "After each object picked what is left comes to rest again, so what "
                "leaned on it falls; after a failed pick the objects stay where the hand's one execution of the grasp "
                "left them (the protocol's nominal trial, the hand then letting go and parking), so what it pushed "
                "or dropped has moved; an object that rests off the table leaves the scene uncleared.")}


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def _cell(rate: dict) -> str:
    return f"{_pct(rate['rate'])} [{_pct(rate['interval'][0])}, {_pct(rate['interval'][1])}]"


def clearance_section(result: dict) -> list[str]:
    rates, methods = result["rates"], result["methods"]
    pooled = rates["all scenes"]
    heuristics = [m for m in methods if m != "network"]
    best = max(heuristics, key=lambda m: pooled[m]["declutter"]["rate"]) if heuristics else None
    scenes = sum(len(s["scenes"]) for s in result["sets"].values())
    hand = ", the Franka hand" if result.get("gripper") else ""
    title, option, left = PILED[bool(result.get("pile"))]
    lines = [f"## {title}{hand}: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}.{hand_words(result)} VGN's declutter protocol on scenes of "
             f"{result['objects']} "
             f"objects (each household and unseen object with the next {result['objects'] - 1} of its set, settled "
             f"as `--clutter {result['objects']}{option}` settles them; {result['views']} settles a scene, {scenes} "
             "scenes): round after round a new seeded camera sees what is left, the chooser's first grasp is "
             "executed by the pick protocol on the object it closes on, and a picked object leaves the table; two "
             "failed rounds in a row, or two rounds an object, end it (onepiece_dist/picks/clearance.py). "
             f"{left} Declutter rate: objects cleared of objects; grasp "
             "success rate: rounds that picked of rounds; each the mean over scenes with its 95% interval.", ""]
    if best is not None:
        net, other = pooled["network"]["declutter"]["rate"], pooled[best]["declutter"]["rate"]
        interval = pooled["network"]["declutter"]["interval"]
        lines += [f"Over all {scenes} scenes the shipped planner clears **{_pct(net)}** [{_pct(interval[0])}, "
                  f"{_pct(interval[1])}] of the objects, {100 * (net - other):+.0f} points over the best "
                  f"heuristic ({LABELS[best]}, {_pct(other)}).", ""]
    lines += ["| set | chooser | declutter rate [95% CI over scenes] | grasp success rate |",
              "| --- | --- | --- | --- |"]
    for name, by in rates.items():
        lines += [f"| {name} | {LABELS[m]} | {_cell(by[m]['declutter'])} | {_cell(by[m]['success'])} |"
                  for m in methods]
    return lines
