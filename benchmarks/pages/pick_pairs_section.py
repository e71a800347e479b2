"""The two-objects section of docs/picks.md, from results/pick_pairs.json (benchmarks/experiments/pick_pairs.py):
each chooser's first attempt over pairs beside the same objects alone, how the first attempts ended, and the
planner's parts judged on the same views (the check; telling the objects apart)."""

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


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def _points(gain: dict) -> str:
    low, high = gain["interval"]
    return f"{100 * gain['mean']:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]"


def _rows(result: dict):
    """Each (run, method) row present: its run and method."""
    return [(run, method) for run, method in ROWS if method in result["runs"].get(run, {}).get("methods", ())]


def pooled_rate(result: dict, run: str, method: str) -> dict:
    """``run``'s ``method`` over the pairs of every set: the mean of per-pair first-attempt rates and its 95%
    bootstrap interval over pairs."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    rates = np.array([picked / result["views"] for runs in result["sets"].values()
                      for picked in runs[run]["per_pair"][method].values()])
    return {"rate": float(rates.mean()) if len(rates) else 0.0, "interval": list(bootstrap_interval(rates)),
            "pairs": len(rates)}


def _table(result: dict) -> list[str]:
    lines = ["| set | chooser | first attempt [95% CI over pairs] | within 3 | the same objects alone, first "
             "attempt | views |", "| --- | --- | --- | --- | --- | --- |"]
    for name, runs in result["sets"].items():
        alone = result.get("single", {}).get(name, {})
        for run, method in _rows(result):
            m = runs[run]["methods"][method]
            single = _pct(alone[method]) if method in alone and run == "default" else "-"
            lines.append(f"| {name} | {ROWS[(run, method)]} | {_pct(m['first_attempt'])} [{_pct(m['interval'][0])}, "
                         f"{_pct(m['interval'][1])}] | {_pct(m['within_3'])} | {single} | {m['views']} |")
    return lines


def _failures(result: dict) -> list[str]:
    lines = ["| set | chooser | picked | " + " | ".join(r.replace("_", " ") for r in REASONS) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in REASONS) + " |"]
    for name, runs in result["sets"].items():
        for run, method in _rows(result):
            m = runs[run]["methods"][method]
            lost = sum(m["failures"].values())
            lines.append(f"| {name} | {ROWS[(run, method)]} | {m['views'] - lost} | "
                         + " | ".join(str(m["failures"].get(r, 0)) for r in REASONS) + " |")
    return lines


def _paired_line(what: str, gain: dict, rule: str) -> str:
    sets = "; ".join(f"{name} {_points(g)}" for name, g in gain.items())
    verdict = "it helps" if gain["all pairs"]["interval"][0] > 0 else "not shown to help"
    return f"{what}, paired over pairs: {sets}: {verdict} ({rule})."


def pairs_section(result: dict) -> list[str]:
    net = pooled_rate(result, "default", "network")
    top = pooled_rate(result, "default", "top_down")
    verdicts = " ".join(f"{name.capitalize()}: {runs['default']['verdict']}."
                        for name, runs in result["sets"].items())
    rule = "shown where the interval over all pairs lies above zero"
    return [f"## Two objects on the table: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. A robot's table holds more than one object: `onepiece pick "
            "--pairs` (`PickSpec.pairs`) sets two on it. Each object of the household and unseen sets stands in two "
            "pairs (with the next object of its set; the last with the "
            f"first), {result['views']} seeded views a pair: the first object dropped at the table centre and "
            "settled, the second dropped 1-5 cm beyond it along a seeded direction, both settled, one camera aimed "
            "between them (as above). Every chooser plans on the cloud of both; a grasp picks when it lifts and "
            "holds the object it closes on (the one with the most of its true surface between the fingers) "
            f"through the pick protocol, the other standing beside it in every trial; up to {result['attempts']} "
            "attempts from the scene at rest. Each candidate's execution has a generator of its own, so the rows "
            "below compare view for view.", "",
            f"Over all {net['pairs']} pairs the shipped planner picks **{_pct(net['rate'])}** "
            f"[{_pct(net['interval'][0])}, {_pct(net['interval'][1])}] at the first attempt, top-down on the "
            f"largest object {_pct(top['rate'])} [{_pct(top['interval'][0])}, {_pct(top['interval'][1])}]. "
            f"{verdicts}", "", *_table(result), "", "First attempts by how they ended:", "", *_failures(result), "",
            _paired_line("The network's first 3 checked against its order alone", result["checked_vs_unchecked"],
                         rule),
            _paired_line("The objects told apart against the cloud taken for one object (the planner's check, "
                         "contexts and top-down grasps)", result["apart_vs_as_one"], rule),
            _paired_line("The shipped planner against top-down on the largest object", result["network_vs_top_down"],
                         rule)]
