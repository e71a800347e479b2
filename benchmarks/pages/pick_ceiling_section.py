"""docs/picks.md's section on the pool's ceiling without the draw (results/pick_ceiling.json,
benchmarks/experiments/pick_ceiling.py): what a chooser that knew which grasps pick again reaches, beside the
one-draw oracle, the network and the targets."""

from __future__ import annotations

import numpy as np

from benchmarks.pages.pick_clutter_section import hand_words
from benchmarks.pages.pick_sets import pct1
from onepiece_dist.stats.intervals import bootstrap_interval


def _network(picks: dict | None, name: str) -> str:
    found = next((s for s in (picks or {}).get("sets", []) if s["name"] == name), None)
    if found is None:
        return "-"
    return pct1(next(m["first_attempt"] for m in found["methods"] if m["method"] == "network"))


def pooled_ceiling(result: dict) -> tuple[float, tuple[float, float], int]:
    """The held-out rate over every object of both sets (the mean of per-object rates, as the headline pools), its
    95% bootstrap interval over objects, and how many objects."""
    rates = np.array([o["best_held_out"] / o["views"] for s in result["sets"].values()
                      for o in s["per_object"].values() if o["views"]])
    return float(rates.mean()), bootstrap_interval(rates), len(rates)


def ceiling_section(result: dict, picks: dict | None, pooled_top_down: float | None,
                    targets: dict | None) -> list[str]:
    """The section: each set's one-draw share, repeated share and held-out rate; pooled against the benchmark's
    ``targets`` (first_attempt, above_heuristics) where given."""
    screen, selection, shortlist, judge = (result[k] for k in ("screen", "selection", "shortlist", "judge"))
    rows = [f"| {name} | {s['views']} | {s['candidates']} | {pct1(s['one_draw']['rate'])} | "
            f"{pct1(s['repeated']['rate'])} | {pct1(s['first_held_out']['rate'])} | "
            f"{pct1(s['best_held_out']['rate'])} [{pct1(s['best_held_out']['interval'][0])}, "
            f"{pct1(s['best_held_out']['interval'][1])}] | {_network(picks, name)} |"
            for name, s in result["sets"].items()]
    rate, (low, high), objects = pooled_ceiling(result)
    words = [f"Pooled over the {objects} objects, the ceiling is **{pct1(rate)}** [{pct1(low)}, {pct1(high)}]"]
    if targets is not None:
        target, above = targets["first_attempt"], targets["above_heuristics"]
        inside = " (though within its interval)" if rate < target <= high else ""
        words[0] += (f": the target of {pct1(target)} at the first attempt lies "
                     f"{'within' if rate >= target else 'above'} it{inside}")
    if targets is not None and pooled_top_down is not None:
        needed = pooled_top_down + above
        words.append(f"{100 * above:.0f} points above top-down ({pct1(pooled_top_down)}) needs {pct1(needed)}, "
                     f"{'within' if needed <= rate else 'above'} it"
                     f"{' and its interval' if needed > high else ''}")
    hand = ", the Franka hand" if result.get("gripper") else ""
    return [f"## The pool's ceiling without the draw{hand}: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}.{hand_words(result)} The oracle above counts a view as picked "
            "where any of its candidates won the one draw every chooser meets; no chooser sees that draw (two "
            "executions of one grasp agree about 90% of the time: docs/studies/pick_labels). Here every candidate "
            "of each view (the shipped network's pool) is executed at draw 0 (so the one-draw share is the "
            f"oracle's again), those that picked again at draws 1 to {screen - 1}; of those that picked at all "
            f"{screen}, the first {shortlist} (index order) are drawn until they fail, up to draw {selection - 1}, "
            f"and the one that held longest (the first on ties) is judged at draws {selection} to "
            f"{selection + judge - 1}, which no choice saw: its share of them is what a chooser that knew which "
            "grasps pick again reaches at the first attempt. Beside it, the first candidate (index order) that "
            f"passed the {screen} draws, judged at draws {screen} to {screen + judge - 1}.", "",
            f"| set | views | candidates | one draw (the oracle) | picked at all {screen} draws | the first of "
            f"those, {judge} draws | the best of {shortlist} of those, {judge} draws no choice saw [95% CI over "
            "objects] | the network, first attempt |", "| --- | --- | --- | --- | --- | --- | --- | --- |", *rows,
            "",
            "; ".join(words) + ". It is a floor under what the pool holds, not a cap: its chooser shortlists the "
            "survivors in index order and knows only their draws, and a grasp that held at all of them picks about "
            "nine times in ten at the next ones, the protocol's own noise."]


def ranked_draws_section(result: dict) -> list[str]:
    """Where the ranking loses (results/pick_ranked_draws.json): the network's first grasps drawn again."""
    top, draws = result["top"], result["draws"]
    half = draws // 2
    rows = [f"| {name} | {s['views']} | {pct1(s['first_draw0'])} | {pct1(s['first'])} | {pct1(s['first_judged'])} | "
            f"{pct1(s['best_of_3'])} | {pct1(s['best_of_10'])} | {pct1(s['pairs_in_order'])} of {s['pairs']} | "
            f"{pct1(s['top_down_share'])} ({s['top_down_grasps']}) | {pct1(s['other_share'])} |"
            for name, s in result["sets"].items()]
    gains = {name: s["best_of_3"] - s["first_judged"] for name, s in result["sets"].items()}
    return [f"## Where the ranking loses: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. On every view above, the shipped network's {top} best-ranked "
            f"grasps (the planner's ranking, the top-down grasps in the pool), each executed at {draws} draws (draw 0 "
            "the one every chooser meets). A grasp's share of its draws is how surely it picks: the first's is the "
            f"network's expected first attempt. The best of the first 3 or {top} is chosen on draws 0 to "
            f"{half - 1} and judged at draws {half} to {draws - 1} (a share chosen on the draws that judge it would "
            "flatter it), beside the first judged at the same draws; the pairs column says how often the scores "
            "order two of them whose shares differ as the shares do (a coin: 50%).", "",
            f"| set | views | the first, draw 0 | the first, {draws} draws | the first, draws {half}-{draws - 1} | "
            f"the surest of the first 3, draws {half}-{draws - 1} | the surest of the first {top}, the same | "
            "pairs in order | top-down grasps among them (count) | the others |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, "",
            "Choosing the surest of the network's first three would add "
            + " and ".join(f"{100 * gain:.1f} points on the {name} set" for name, gain in gains.items())
            + " over its first, judged at the same draws."]


def reranked_section(result: dict, fit: dict | None = None) -> list[str]:
    """Other networks ordering the shipped network's best grasps (results/pick_reranked.json); ``fit``: how the
    re-ranking networks were fitted (results/pick_rerank_fit.json)."""
    sets = result["sets"]
    names = list(next(iter(sets.values()))["chosen"])
    rows = [f"| `{name}` | " + " | ".join(f"{pct1(s['chosen'][name]['3'])} | {pct1(s['chosen'][name]['10'])}"
                                          for s in sets.values()) + " |" for name in names]
    moved = [v for s in sets.values() for v in s["views_elsewhere"]]
    best = {w: max(names, key=lambda n: s["chosen"][n]["3"]) for w, s in sets.items()}
    gains = {w: s["chosen"][best[w]]["3"] - s["chosen"]["shipped"]["3"] for w, s in sets.items()}
    header = " | ".join(f"{w}, its best of the first 3 | of the first 10" for w in sets)
    counted = ", ".join(f"{s['views']} {w} views" for w, s in sets.items())
    left = f"; left out, settled elsewhere when seen again: {', '.join(moved)}" if moved else ""
    return [f"## Other networks ordering those grasps: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The same views' ranked grasps and draws, scored by the top-down "
            "trial's networks at each seed (`top_down_s0` is the shipped one), their mean, and the drawn-again "
            "trial's networks (below); each chooses its best among the first 3 and the first 10, judged by that "
            f"grasp's share of its draws ({counted}{left}).{_fit_words(fit)}", "",
            f"| network | {header} |", "| --- |" + " --- | --- |" * len(sets), *rows, "",
            "The best of them over the shipped network's own order of its first three: "
            + " and ".join(f"`{best[w]}` {100 * gains[w]:+.1f} points on the {w} set" for w in sets)
            + ": of what the surest of the first three would add (above), no network here finds more than a "
            "fraction."]


def _fit_words(fit: dict | None) -> str:
    if fit is None:
        return ""
    best = ", ".join(f"epoch {p['best_epoch']['epoch']} (AP {p['best_epoch']['val_ap']:.3f})" for p in fit["points"])
    return (f" `rerank_s*`: the shipped network fitted further on the drawn-again rows alone (`{fit['command']}`: "
            f"{fit['points'][0]['rows']} rows, the share of each row's draws as the target and a listwise term, at "
            f"a rate of {fit['options']['learning_rate']:g}; best epochs by the AP on held-out objects: {best}).")
