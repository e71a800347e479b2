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


def veils_section(result: dict) -> list[str]:
    """The planner dropping the veils (results/pick_veils.json), each share paired against keeping every point,
    and whether the drop is kept: the network picks more under flying pixels, and not shown to pick less on exact
    depth."""
    runs = {r["flying"]: r for r in result["runs"]}
    rows = [f"| {r['flying']:g} | {s['name']} | {_rate(s, 'network')} | {_rate(s, 'top_down')} | "
            f"{pct(r['kept'][s['name']]['network'])} | {pct(r['kept'][s['name']]['top_down'])} |"
            for r in result["runs"] for s in r["sets"]]
    lines = [f"## The planner dropping flying pixels: `{result['command']}` at {result['commit']}", "",
             f"{result['date']}, {result['machine']}. Tried at {result['commit']} (`git checkout "
             f"{result['commit']}` runs it again; taken out of the planner after this run, as the verdict below "
             "says): the planner's option `veils: drop` (PlanSpec; core.cloud.veils there) took out of the view "
             "each point off the support plane whose local plane (its 16 nearest) turns its normal to within 0.2 "
             "(cosine) of square to the point's ray: a veil runs along the rays, a surface the camera sees faces "
             "it (its test there: most of a settled box's veil dropped, none of the box and table). The "
             "household and unseen sets at "
             f"{result['views']} views an object, the Franka hand with the network shipped for it, paired over "
             "objects against the planner keeping every point on the same views (the section above at "
             f"{result['views']} views, and its exact level), first attempt:", "",
             "| flying share | set | network, veils dropped | top-down, veils dropped | network, every point | "
             "top-down, every point |", "| --- | --- | --- | --- | --- | --- |", *rows, ""]
    for r in result["runs"]:
        net, top = r["versus_kept"]["network"], r["versus_kept"]["top_down"]
        lines.append(f"- share {r['flying']:g}: household meshes pooled "
                     f"{pct(pooled(r['sets'], 'network')['first_attempt'])}; dropping the veils against keeping "
                     f"every point, paired over the {net['objects']} meshes: the network {_points(net)} "
                     f"({_said(net)}), top-down {_points(top)} ({_said(top)}).")
    return [*lines, "", _veils_verdict(runs)]


def _veils_verdict(runs: dict) -> str:
    flying, exact = runs.get(1.0), runs.get(0.0)
    if flying is None or exact is None:
        return "Dropping the veils: judged under flying pixels and on exact depth both, or not at all."
    gain, cost = flying["versus_kept"]["network"], exact["versus_kept"]["network"]
    kept = gain["interval"][0] > 0 and cost["interval"][1] >= 0
    return (f"Dropping the veils: **{'kept' if kept else 'not kept'}** as the planner's default (kept where the "
            "network picks more under flying pixels, its interval above zero, and is not shown to pick less on "
            f"exact depth): under flying pixels {_points(gain)}, on exact depth {_points(cost)}.")


def drop_section(result: dict) -> list[str]:
    """The planner dropping a depth image's flying pixels (results/pick_flying_drop.json), each tolerance paired
    against keeping every pixel, and at which tolerance the option is kept (_drop_verdict)."""
    def rate(run: dict, key: str, method: str) -> str:
        return pct(run[key][method]["first_attempt"])

    rows = [f"| {1000 * r['tolerance']:g} mm | {r['flying']:g} | {r['views']} | {rate(r, 'pooled', 'network')} | "
            f"{rate(r, 'kept_pooled', 'network')} | {_points(r['versus_kept']['network'])} | "
            f"{rate(r, 'pooled', 'top_down')} | {rate(r, 'kept_pooled', 'top_down')} | "
            f"{_points(r['versus_kept']['top_down'])} |" for r in result["runs"]]
    lines = [f"## The planner dropping flying pixels from the depth image: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. `onepiece grasp --drop-flying T` (PlanSpec.drop_flying, "
             "core.cloud.flying) drops, before the depth image is back-projected, each pixel that along its row or "
             "column lies more than T inside the depths of its two neighbours each side and fits neither "
             "neighbouring surface's linear continuation within T: a flying pixel mixes a near depth and a far one, "
             "a face seen grazing steps evenly, a thin rim or handle stands nearer than both its sides. The Franka "
             "hand with the network shipped for it, the household and unseen sets at the micrometre level as the "
             f"section above judges them, in blocks of {result['block']} views an object (PickSpec.first_view), "
             "every edge pixel flying (share 1) and exact depth (share 0), household meshes pooled, paired over "
             "the meshes against the planner keeping every pixel on the same views, first attempt:", "",
             "| tolerance | flying share | views an object | network, dropped | network, every pixel | paired | "
             "top-down, dropped | top-down, every pixel | paired |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, ""]
    tried = {r["flying"]: r for r in result.get("first_rule", [])}
    if tried:
        said = "; ".join(f"{'under flying pixels' if share else 'on exact depth'} the network "
                         f"{_points(r['versus_kept']['network'])}, top-down {_points(r['versus_kept']['top_down'])}"
                         for share, r in sorted(tried.items(), reverse=True))
        first = next(iter(tried.values()))
        lines.append(f"First tried at {first['commit']} (branch `image-veils`): every pixel that fits neither "
                     "continuation within 5 mm, inside its neighbours' depths or not, which also took a curved "
                     f"silhouette's last pixels, a bowl's rim and a mug's handle ({first['views']} views an "
                     f"object): {said}.")
    return [*lines, "", _drop_verdict(result["runs"])]


def _drop_verdict(runs: list[dict]) -> str:
    """Kept at the tolerance whose most-viewed runs show the network picking more under flying pixels (its interval
    above zero) and not shown to pick less on exact depth; the option stays off by default either way."""
    kept, said = [], []
    for tolerance in sorted({r["tolerance"] for r in runs}):
        flying, exact = (max((r for r in runs if (r["tolerance"], r["flying"]) == (tolerance, share)),
                             key=lambda r: r["views"], default=None) for share in (1.0, 0.0))
        if flying is None or exact is None:
            judged, where, not_where = ((flying, "under flying pixels", "on exact depth") if flying else
                                        (exact, "on exact depth", "under flying pixels"))
            said.append(f"at {1000 * tolerance:g} mm the network {_points(judged['versus_kept']['network'])} {where} "
                        f"({judged['views']} views), not judged {not_where}")
            continue
        gain, cost = flying["versus_kept"]["network"], exact["versus_kept"]["network"]
        if gain["interval"][0] > 0 and cost["interval"][1] >= 0:
            kept.append(tolerance)
        said.append(f"at {1000 * tolerance:g} mm the network {_points(gain)} under flying pixels ({flying['views']} "
                    f"views), {_points(cost)} on exact depth ({exact['views']} views)")
    verdict = (f"**kept** at {1000 * kept[0]:g} mm as the planner's option for a depth camera's images "
               f"(`onepiece grasp --drop-flying {kept[0]:g}`; off by default, so every run above stands as made)"
               if kept else "**not kept**")
    return (f"Dropping flying pixels from the depth image: {verdict} (kept where the network picks more under "
            f"flying pixels, its interval above zero, and is not shown to pick less on exact depth): "
            f"{'; '.join(said)}.")
