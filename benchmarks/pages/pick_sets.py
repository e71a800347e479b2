"""What every pick page section reads off one set of the pick benchmark's results (a run_picks report as JSON): the
choosers' names, their rates pooled over sets, and the tables of first attempts and of how they ended."""

from __future__ import annotations

import numpy as np

LABELS = {"network": "network on the view", "random": "random collision-free candidate",
          "analytic": "antipodal score on the view", "top_down": "top-down across the narrow axis",
          "network_full_mesh": "network on full-mesh candidates", "random_full_mesh": "random full-mesh candidate",
          "oracle": "oracle: every view candidate executed"}
HEURISTICS = ("random", "analytic", "top_down")
REASONS = ("start_collision", "no_contact", "slipped_lifting", "dropped_shaking", "no_grasp")


def pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def pct1(value: float) -> str:
    return f"{100 * value:.1f}%"


def against(value: float, target: float) -> str:
    """``value`` as pct does, or to a tenth of a point where the whole percent would read as the other side of
    ``target`` (84.8% against 85% reads "85%" rounded, yet misses it)."""
    rounded = round(100 * value) / 100
    return pct(value) if (rounded >= target) == (value >= target) else pct1(value)


def interval(pair) -> str:
    return f"[{pct(pair[0])}, {pct(pair[1])}]"


def method_of(result: dict, name: str) -> dict:
    return next(m for m in result["methods"] if m["method"] == name)


def met(ok: bool) -> str:
    return "**met**" if ok else "**not met**"


HOUSEHOLD_SETS = ("household", "unseen")  # real household meshes: the set designs were chosen on, and one never


def loaded_objects(sets: list[dict]) -> list[tuple[dict, dict]]:
    """(set, object) for every object of ``sets`` that loaded and has views, in their order."""
    return [(s, o) for s in sets for o in s["objects"] if o["status"] == "ok" and o["views"]]


def views_kept(sets: list[dict], keep) -> list[dict]:
    """``sets`` with each object's views cut to those whose index ``keep(view)`` accepts."""
    return [{**s, "objects": [{**o, "views": [v for v in o.get("views", ()) if keep(v["view"])]}
                              for o in s["objects"]]} for s in sets]


def first_attempt_share(obj: dict, method: str) -> float:
    """``method``'s first-attempt share of one object's views."""
    return sum(list(v["attempts"][method][:1]) == [True] for v in obj["views"]) / len(obj["views"])


def paired_first_attempts(after: list[dict], before: list[dict], method: str, base: str | None = None) -> dict:
    """``method``'s first attempt in ``after`` less ``base``'s (default the same chooser) in ``before``, over the
    objects both judged (the same views): the mean per-object difference, its 95% bootstrap interval, and how
    many objects."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    now = {(s["name"], o["name"]): first_attempt_share(o, method) for s, o in loaded_objects(after)}
    was = {(s["name"], o["name"]): first_attempt_share(o, base or method) for s, o in loaded_objects(before)}
    differences = np.array([now[k] - was[k] for k in sorted(set(now) & set(was))])
    return {"mean": float(differences.mean()), "interval": list(bootstrap_interval(differences)),
            "objects": len(differences)}


def pooled(sets: list[dict], method: str) -> dict:
    """``method`` over every object of ``sets`` that loaded: its first-attempt rate (the mean of per-object rates,
    as each set's), the 95% bootstrap interval over those objects, and how many objects and views."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    rates = np.array([first_attempt_share(o, method) for _, o in loaded_objects(sets)])
    return {"method": method, "first_attempt": float(rates.mean()) if len(rates) else 0.0,
            "first_attempt_interval": bootstrap_interval(rates), "objects": len(rates),
            "views": sum(len(o["views"]) for s in sets for o in s["objects"] if o["status"] == "ok")}


def failure_table(result: dict) -> list[str]:
    """Each chooser's first attempts by how they failed."""
    rows = []
    for m in result["methods"]:
        failures = m.get("first_failures", {})
        picked = m["views"] - sum(failures.values())
        rows.append(f"| {LABELS[m['method']]} | {picked} | " + " | ".join(str(failures.get(r, 0)) for r in REASONS)
                    + " |")
    return ["| chooser | picked | start in collision | closed on nothing | slipped when lifted | dropped when "
            "shaken | no grasp |", "| --- | --- | --- | --- | --- | --- | --- |", *rows]


def method_table(result: dict) -> list[str]:
    k = result["spec"]["attempts"]
    rows = [f"| {LABELS[m['method']]} | {pct(m['first_attempt'])} {interval(m['first_attempt_interval'])} | "
            f"{pct(m['within_k'])} {interval(m['within_k_interval'])} | {m['views']} |" for m in result["methods"]]
    return ["| chooser | first attempt [95% CI over objects] | within " + str(k) + " | views |",
            "| --- | --- | --- | --- |", *rows]


def target_rows(results: list[dict], targets: dict) -> list[str]:
    """The issue's targets, one table row each (target | figure | met or not), judged on the benchmark's sets."""
    sets = [s for s in results if s["name"] in HOUSEHOLD_SETS]
    unseen = next((s for s in sets if s["name"] == "unseen"), None)
    procedural = next((s for s in results if s["name"] == "procedural"), None)
    net, full = pooled(sets, "network"), pooled(sets, "network_full_mesh")
    rate = net["first_attempt"]
    methods = {m["method"] for m in sets[0]["methods"]}
    best = max((pooled(sets, h) for h in HEURISTICS if h in methods), key=lambda m: m["first_attempt"])
    gap = full["first_attempt"] - rate
    lines = [f"| household first attempt >= {pct(targets['first_attempt'])} ({net['objects']} objects) | "
             f"{against(rate, targets['first_attempt'])} | {met(rate >= targets['first_attempt'])} |"]
    if unseen is not None:
        alone = method_of(unseen, "network")
        lines.append(f"| the same on the unseen set alone ({alone['views']} views) | "
                     f"{against(alone['first_attempt'], targets['first_attempt'])} "
                     f"{interval(alone['first_attempt_interval'])} | "
                     f"{met(alone['first_attempt'] >= targets['first_attempt'])} |")
    lines.append(f"| >= {100 * targets['above_heuristics']:.0f} points above the best heuristic "
                 f"({LABELS[best['method']]}, {pct(best['first_attempt'])}) | "
                 f"{100 * (rate - best['first_attempt']):+.0f} points | "
                 f"{met(rate - best['first_attempt'] >= targets['above_heuristics'])} |")
    if procedural is not None:
        p_rate = method_of(procedural, "network")["first_attempt"]
        lines.append(f"| procedural first attempt >= {pct(targets['procedural'])} | "
                     f"{against(p_rate, targets['procedural'])} | {met(p_rate >= targets['procedural'])} |")
    return [*lines, f"| within {100 * targets['full_mesh_gap']:.0f} points of the network on full-mesh candidates "
            f"({pct(full['first_attempt'])}) | {100 * -gap:+.0f} points | {met(gap <= targets['full_mesh_gap'])} |"]
