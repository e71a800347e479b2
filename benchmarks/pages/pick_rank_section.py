"""The sections of docs/picks.md that ask what orders the network's best grasps: their scores under pose noise
(results/pick_robust_rank.json) and what the view shows of them (results/pick_rank_features.json)."""

from __future__ import annotations

RULES = {
    "shipped": "the network's score (its own order)",
    "near_mean": "the mean score of the view's candidates within {m:g} m and {deg:g} degrees",
    "near_and_nominal": "that and its own score, averaged",
    "mean": "the mean score of {samples} perturbed poses",
    "q25": "the lower quartile of those",
    "min": "the least of those",
    "mean_with_nominal": "the mean of those and its own",
}


def _pct(value: float) -> str:
    return f"{100 * value:.1f}%"


def _rule(name: str, result: dict) -> str:
    base, _, scale = name.rpartition("_x") if "_x" in name else (name, "", "")
    words = RULES[base].format(samples=result["samples"], **result["near"])
    return f"{words}, {scale}x the protocol's noise" if scale else words


def robust_rank_section(result: dict) -> list[str]:
    """The shipped network's best grasps ordered by their scores under pose noise and by their neighbourhoods."""
    sets = result["sets"]
    names = list(next(iter(sets.values()))["chosen"])
    rows = [f"| {_rule(name, result)} | " + " | ".join(f"{_pct(s['chosen'][name]['3'])} | "
                                                       f"{_pct(s['chosen'][name]['10'])}" for s in sets.values())
            + " |" for name in names]
    gains = {w: {n: s["chosen"][n]["3"] - s["chosen"]["shipped"]["3"] for n in names} for w, s in sets.items()}
    both = [n for n in names if n != "shipped" and all(g[n] > 0 for g in gains.values())]
    moved = [v for s in sets.values() for v in s["views_elsewhere"]]
    left = f"; left out, settled elsewhere when seen again: {', '.join(moved)}" if moved else ""
    verdict = ("no rule raises both sets: not kept" if not both else
               "raising both sets: " + ", ".join(f"{_rule(n, result)} ("
                                                + " / ".join(f"{100 * g[n]:+.1f}" for g in gains.values())
                                                + " points)" for n in both))
    header = " | ".join(f"{w}, its best of the first 3 | of the first 10" for w in sets)
    return [f"## The network's score under pose noise: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}, {result['seconds']:.0f} s. A pick fails when any of its four "
            "trials fails, three of them at a pose perturbed by the protocol's noise (3 mm per axis, 0.05 rad), so "
            "a grasp whose neighbours score low might be the one its draws drop (Dex-Net's robust quality, the "
            "network standing in for the analytic one). The views of the ranked grasps above are seen again; each "
            f"of the first 10 is scored at {result['samples']} poses perturbed by that noise (and twice it), each "
            "crop cut again from the same view (`plan.robust.perturbed_scores`); each rule chooses its best of the "
            f"first 3 and of the first 10, judged by that grasp's share of its 8 draws{left}.", "",
            f"| rule | {header} |", "| --- |" + " --- | --- |" * len(sets), *rows, "",
            f"Against the network's own order, of its first three: {verdict}. The mean under the protocol's own "
            "noise: " + " and ".join(f"{100 * g['mean_x1']:+.1f} points on the {w} set" for w, g in gains.items())
            + "; the neighbourhood's mean: " + " and ".join(f"{100 * g['near_mean']:+.1f}" for g in gains.values())
            + "."]
