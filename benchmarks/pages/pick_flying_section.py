"""The flying-pixels section of docs/picks.md, from results/pick_flying_pixels.json
(benchmarks/experiments/pick_flying_pixels.py): the shipped planner and top-down where a share of the depth's edge
pixels mix the object with what lies behind it, each paired over objects against exact depth."""

from __future__ import annotations

from benchmarks.experiments.pick_flying_pixels import views_of
from benchmarks.pages.pick_noise_section import _points, _rate, _said
from benchmarks.pages.pick_sets import pct, pooled


def _hand(run: dict) -> str:
    return "the Franka hand (`panda`)" if run["gripper"] else "the default job's gripper"


def flying_section(result: dict) -> list[str]:
    runs = result["runs"]
    rows = [f"| {_hand(r)} | {r['flying']:g} | {views_of(r)} | {s['name']} | {_rate(s, 'network')} | "
            f"{_rate(s, 'top_down')} | {pct(r['exact'][s['name']]['network'])} | "
            f"{pct(r['exact'][s['name']]['top_down'])} |"
            for r in runs for s in r["sets"]]
    lines = [f"## The planner under flying pixels: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. Where a pixel straddles an object's edge, a stereo or "
             "time-of-flight camera reads a depth between the object and what lies behind it: a veil of points "
             "trails off every silhouette into the air. The benchmark renders exact depth; here a share of the "
             "pixels at its depth edges (a neighbour 2 cm nearer or further) each take a depth drawn uniformly "
             "between their own and that neighbour's (`onepiece pick` spec `camera.flying_pixels`; at 1, every "
             "edge pixel, about 230 points of a view's 20-35 thousand standing more than 5 mm off every exact "
             "point). The household and unseen sets judged as the depth-noise section judges them (the shipped "
             "network and the planner's defaults, beside top-down, noise of a micrometre), each paired over "
             "objects against a micrometre level at as many views an object (at 8, that section's; at more, "
             "judged beside the run: `--views`; the same settles and cameras; the mixing's draws come first, so "
             "every later draw differs, a difference of its own), first attempt:", "",
             "| hand | flying share | views an object | set | network on the view | top-down | "
             "network, exact depth | top-down, exact depth |", "| --- | --- | --- | --- | --- | --- | --- | --- |",
             *rows, ""]
    for r in runs:
        net, top = r["versus_exact"]["network"], r["versus_exact"]["top_down"]
        lines.append(f"- {_hand(r)}, share {r['flying']:g}, {views_of(r)} views an object: household meshes pooled "
                     f"{pct(pooled(r['sets'], 'network')['first_attempt'])}; against exact depth, paired over the "
                     f"{net['objects']} meshes, the network {_points(net)} ({_said(net)}), top-down {_points(top)} "
                     f"({_said(top)}); the network over top-down {_points(r['network_vs_top_down'])}.")
    return [*lines, "", *_verdict(_deciding(runs))]


def _deciding(runs: list[dict]) -> list[dict]:
    """Of the runs of each hand and share, those at the most views an object (the narrowest intervals)."""
    most = {}
    for r in runs:
        key = (r["gripper"], r["flying"])
        most[key] = max(most.get(key, 0), views_of(r))
    return [r for r in runs if views_of(r) == most[(r["gripper"], r["flying"])]]


def _verdict(runs: list[dict]) -> list[str]:
    """Which chooser the flying pixels are shown to cost, over the deciding runs (_deciding), and how much the
    network's intervals leave open."""
    def shown_lower(method: str) -> bool:
        return any(r["versus_exact"][method]["interval"][1] < 0 for r in runs)

    network, top_down = shown_lower("network"), shown_lower("top_down")
    worst = min(r["versus_exact"]["network"]["interval"][0] for r in runs)
    said = {(False, True): "top-down is shown to lose picks to them, the network is not",
            (False, False): "neither the network nor top-down is shown to lose picks to them",
            (True, True): "both the network and top-down are shown to lose picks to them",
            (True, False): "the network is shown to lose picks to them, top-down is not"}[(network, top_down)]
    views = sorted({views_of(r) for r in runs})
    tail = ("" if network else f" (its intervals leave a loss of up to {-100 * worst:.1f} points open at "
            f"{' and '.join(map(str, views))} views an object), so the planner takes no filter for them")
    return [f"Flying pixels: {said}{tail}."]
