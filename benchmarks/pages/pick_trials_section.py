"""Design trials on docs/picks.md made on labels of today's pick world: the swept space (results/pick_space.json,
benchmarks/experiments/pick_space.py: the shipped design and the one that also reads the hand's swept space, fitted
on the same labels seed for seed), labels on policy, training objects shaped like the lost ones, the top-down grasps
and more of each crop's points. Every trial is judged by one rule (stats.intervals.paired_gain): fitted seed for seed
on the same labels, a change is kept where the bootstrap interval over household objects of its gain (each object's
rate averaged over the seeds) lies above zero."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from onepiece_dist.stats.intervals import PairedGain, paired_gain

BASE, TRIED = "context_balanced", "context_space"
VIEWS = 8
RULE = ("kept where the paired interval over the household objects lies above zero (every trial's rule: "
        "benchmarks/pages/pick_trials_section.py)")


def gain_words(gain: PairedGain) -> str:
    """``+x.x points over n seeds (paired interval over objects [lo, hi]): verdict``."""
    low, high = gain.interval
    return (f"{100 * gain.gain:+.1f} points over {gain.seeds} seed{'s' if gain.seeds != 1 else ''} (paired "
            f"interval over objects [{100 * low:+.1f}, {100 * high:+.1f}]): {gain.verdict}")


def _first(point: dict) -> float:
    return point["picks"]["methods"]["network"]["first_attempt"]


def paired(space: dict) -> dict[int, dict[int, dict[str, dict]]]:
    """size -> seed -> design -> point, for the sizes and seeds where both designs were fitted."""
    found: dict[int, dict[int, dict[str, dict]]] = defaultdict(lambda: defaultdict(dict))
    for p in space["points"]:
        found[p["labels"]][p["seed"]][p["design"]] = p
    return {size: {seed: pair for seed, pair in seeds.items() if {BASE, TRIED} <= set(pair)}
            for size, seeds in sorted(found.items())}


def _per_object(point: dict) -> dict[str, int]:
    return point["picks"]["per_object"]["network"]


def verdict(pairs: dict[int, dict[str, dict]]) -> PairedGain:
    """TRIED against BASE over the seeds of ``pairs``, paired over the household objects."""
    seeds = sorted(pairs)
    return paired_gain([_per_object(pairs[s][TRIED]) for s in seeds], [_per_object(pairs[s][BASE]) for s in seeds],
                       VIEWS)


def space_section(space: dict) -> list[str]:
    labels = space["labels"]
    lines = [f"## The hand's swept space: `{space['command']}`", "",
             f"{space['date']}, {space['machine']}. What lies around the fingers as the camera saw it (issue 55): a "
             "6 x 10 x 3 grid of 1 cm cells over the fingers and palm, each read against the view's depth (free, "
             "on the surface, behind it or unseen: core/cloud/swept_space.py), beside the crop and its context. "
             f"The first label batch made again with today's pick world ({labels['rows']} labels, success rate "
             f"{labels['success_rate']:.2f}; the curve's points above were fitted on labels an earlier pick world "
             f"made), `{BASE}` (the shipped design) and `{TRIED}` fitted on the same subset at each seed (a seed "
             "draws the subset, the validation objects and the initial weights), household first attempt:", "",
             f"| labels | seed | {BASE} | {TRIED} | difference |", "| --- | --- | --- | --- | --- |"]
    rows, words = [], []
    for size, pairs in paired(space).items():
        for seed, pair in sorted(pairs.items()):
            base, tried = _first(pair[BASE]), _first(pair[TRIED])
            rows.append(f"| {size} | {seed} | {100 * base:.1f}% | {100 * tried:.1f}% | {100 * (tried - base):+.1f} |")
        words.append(f"at {size} labels the swept space gives {gain_words(verdict(pairs))}")
    return [*lines, *rows, "", "; ".join(words).capitalize() + f"; {RULE}.", "", base_spread_line(space)]


def base_spread(space: dict) -> tuple[int, list[float]]:
    """(labels, sorted rates over seeds) of the shipped design alone, at the size where it moves most."""
    by_size = {size: sorted(_first(pair[BASE]) for pair in pairs.values()) for size, pairs in paired(space).items()}
    return max(by_size.items(), key=lambda item: (item[1][-1] - item[1][0], item[0]))


def base_spread_line(space: dict) -> str:
    """What the shipped design alone gives over seeds, at the size where it moves most."""
    size, rates = base_spread(space)
    return (f"The shipped design alone, at {size} labels, picks {' and '.join(f'{100 * r:.1f}%' for r in rates)} "
            f"of the household views at {len(rates)} seeds: a network's figure on these views moves by "
            f"{100 * (rates[-1] - rates[0]):.1f} points with its seed, so a seed is never chosen on them.")


def on_policy_section(result: dict) -> list[str]:
    """The on-policy trial (results/pick_on_policy.json): the same design on the first batch joined with the second
    batch's views labelled at random or half from the first batch's network's best-scored, seed for seed."""
    policy = result["policy"]
    found = {(p["second_batch"], p["seed"]): p for p in result["points"]}
    seeds = sorted({seed for _, seed in found})
    rows = [f"| {seed} | {name.replace('_', '-')} | {found[(name, seed)]['labels']} | "
            f"{found[(name, seed)]['second_success_rate']:.2f} | {100 * _first(found[(name, seed)]):.1f}% "
            f"[{_interval(found[(name, seed)])}] |"
            for seed in seeds for name in ("random", "on_policy") if (name, seed) in found]
    both = [s for s in seeds if ("on_policy", s) in found and ("random", s) in found]
    gain = paired_gain([_per_object(found[("on_policy", s)]) for s in both],
                       [_per_object(found[("random", s)]) for s in both], VIEWS)
    words = f"On-policy labels give {gain_words(gain)}" if both else "No pair fitted yet"
    return [f"## Labels on policy: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The second label batch's objects and views labelled twice: "
            f"16 random candidates a view, or {100 * policy['top_share']:.0f}% of them the best-scored by "
            f"`{policy['checkpoint']}` ({policy['design']} on the first batch's {policy['labels']} labels: it picks "
            f"{100 * policy['first_attempt']:.1f}% of the household views) and the rest at random; `{BASE}` fitted "
            "on the first batch joined with each (the same size), household first attempt:", "",
            "| seed | second batch | labels | its success rate | household first attempt [95% CI] |",
            "| --- | --- | --- | --- | --- |", *rows, "", f"{words}; {RULE}."]


def _interval(point: dict) -> str:
    low, high = point["picks"]["methods"]["network"]["interval"]
    return f"{100 * low:.0f}%, {100 * high:.0f}%"


def unseen_section(unseen: dict, picks: dict | None) -> list[str]:
    """The curve's networks on the unseen set beside their household figures (results/pick_unseen.json)."""
    networks = unseen["networks"]
    rows = [f"| `{name}` | {n['what']} | {_pct(n['household'])} | {_pct(n['unseen']['first_attempt'])} "
            f"[{_pct(n['unseen']['interval'][0])}, {_pct(n['unseen']['interval'][1])}] |"
            for name, n in networks.items()]
    household = [n["household"] for n in networks.values() if n["household"] is not None]
    rates = [n["unseen"]["first_attempt"] for n in networks.values()]
    set_ = next((s for s in (picks or {}).get("sets", []) if s["name"] == "unseen"), None)
    others = ""
    if set_ is not None:
        rate = {m["method"]: m["first_attempt"] for m in set_["methods"]}
        others = (f" On the same views top-down picks {_pct(rate['top_down'])} and the oracle over the view's "
                  f"candidates {_pct(rate['oracle'])}.")
    return [f"## On objects nothing was chosen on: `{unseen['command']}`", "",
            f"{unseen['date']}. Every design, ranking and seed above was chosen on the household set's views; the "
            "unseen set (12 more household meshes, none of them the household set's) judges the networks the curve "
            "and the trials made, the network alone, first attempt. Nothing is chosen on it.", "",
            "| network | what | household first attempt | unseen first attempt [95% CI] |", "| --- | --- | --- | --- |",
            *rows, "",
            f"The {len(rates)} networks of the shipped design pick {_pct(min(household))}-{_pct(max(household))} of "
            f"the household views and {_pct(min(rates))}-{_pct(max(rates))} of the unseen ones: their seeds and "
            "label plans move them less than the objects do, and a figure on the household set alone overstates "
            f"what the design picks of objects it was not chosen on.{others}"]


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f}%"


def vessels_section(result: dict) -> list[str]:
    """The vessel trial (results/pick_vessels.json): the first batch joined with a batch of household-shaped
    objects against the first joined with the curve's second, seed for seed; decided on the household set, the
    unseen set's figures beside it, never chosen on."""
    points = sorted(result["points"], key=lambda p: p["seed"])
    rows = [f"| {p['seed']} | {100 * p['base']['household']:.1f}% | {100 * _first(p):.1f}% | "
            f"{100 * (_first(p) - p['base']['household']):+.1f} | {_pct(p['base']['unseen'])} | "
            f"{_pct(p['unseen']['first_attempt'])} | "
            f"{100 * (p['unseen']['first_attempt'] - p['base']['unseen']):+.1f} |" for p in points]
    gain = paired_gain([_per_object(p) for p in points], [p["base"]["per_object"]["household"] for p in points],
                       VIEWS)
    unseen = paired_gain([p["unseen"]["per_object"] for p in points],
                         [p["base"]["per_object"]["unseen"] for p in points], VIEWS)
    return [f"## Training objects shaped like the lost ones: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The picks the shipped design loses are mostly flat packages, "
            "mugs and bowls, kinds its training shapes lack. A second batch of the curve's size on "
            f"`{result['batch']}` (vessels: flat boxes 1-3.5 cm thin, cups with a handle, thin-walled bowls, "
            f"bottles with a neck; {result['labels']} labels, success rate {result['success_rate']:.2f}) joins the "
            f"first batch ({_sizes(points)}); `{BASE}` fitted on it seed for seed against the first batch joined "
            "with the curve's second (the random points of the on-policy trial above), first attempt:", "",
            "| seed | household, second batch | household, vessels | difference | unseen, second batch | "
            "unseen, vessels | difference |", "| --- | --- | --- | --- | --- | --- | --- |", *rows, "",
            f"On the household set, where designs are chosen, the vessels give {gain_words(gain)}; {RULE}. On "
            f"the unseen set, where nothing is chosen, {_unseen_words(unseen)}."]


def _unseen_words(gain: PairedGain) -> str:
    low, high = gain.interval
    return f"{100 * gain.gain:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]"


def _sizes(points: list[dict]) -> str:
    if not points:
        return "not fitted yet"
    return f"{points[0]['labels']} labels in all, against {points[0]['base']['labels']}"


def top_down_gains(result: dict) -> tuple[dict[str, PairedGain], dict[str, PairedGain]]:
    """The top-down trial's gains over its base on each set: (pool and labels, the pool alone)."""
    points = sorted(result["points"], key=lambda p: p["seed"])

    def gain(where: str, arm) -> PairedGain:
        return paired_gain([arm(p)[where]["per_object"] for p in points],
                           [p["base"]["per_object"][where] for p in points], VIEWS)

    return ({w: gain(w, lambda p: p["with_pool"]) for w in ("household", "unseen")},
            {w: gain(w, lambda p: p["base"]["with_pool"]) for w in ("household", "unseen")})


def top_down_section(result: dict) -> list[str]:
    """The top-down trial (results/pick_top_down.json): the base network on the product's pool and on the pool
    with the top-down grasps, and a network whose labels executed them, seed for seed; decided on the household
    set, the unseen set's figures never chosen on."""
    points = sorted(result["points"], key=lambda p: p["seed"])

    def cells(p: dict, where: str) -> list[float]:
        return [p["base"][where], p["base"]["with_pool"][where]["first_attempt"],
                p["with_pool"][where]["first_attempt"]]

    rows = [f"| {p['seed']} | " + " | ".join(_pct(v) for v in cells(p, "household") + cells(p, "unseen")) + " |"
            for p in points]
    labels, pool = top_down_gains(result)
    above = sum(cells(p, "household")[2] > cells(p, "household")[0] for p in points)
    return [f"## Top-down grasps in the pool and in the labels: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The oracle above says the view's pool lacks what the top-down "
            "baseline finds (flat packages). With `plan.top_down` the planner also proposes the three top-down "
            "grasps, cropped and checked as the sampled ones, and pick labels always execute them in place of three "
            f"random candidates. The first batch labelled again so ({result['labels']} labels, success rate "
            f"{result['success_rate']:.2f}) joined with the curve's second batch; `{BASE}` fitted on it seed for seed "
            "against the base (the random points of the on-policy trial, further seeds fitted on the same labels), "
            "first attempt; base: the product's pool, "
            "+ pool: with the top-down grasps, + labels: the network fitted on the labels that executed them:", "",
            "| seed | household, base | + pool | + pool, + labels | unseen, base | + pool | + pool, + labels |",
            "| --- | --- | --- | --- | --- | --- | --- |", *rows, "",
            f"On the household set, where designs are chosen, the top-down grasps in pool and labels give "
            f"{gain_words(labels['household'])} (above the base at {above} of {len(points)} seeds; the pool alone "
            f"{gain_words(pool['household'])}); {RULE}. On the unseen set, where nothing is chosen, "
            f"{_unseen_words(labels['unseen'])} ({_unseen_words(pool['unseen'])} from the pool alone)."]


def _over_top_down(result: dict, top_down: dict | None) -> list[tuple[dict, dict]]:
    """(a trial's point, the top-down trial's judged network of its seed), for the seeds both fitted: the trials
    that build on the top-down trial's labels are judged against its networks."""
    base = {p["seed"]: p["with_pool"] for p in (top_down or {}).get("points", [])}
    return [(p, base[p["seed"]]) for p in sorted(result["points"], key=lambda p: p["seed"]) if p["seed"] in base]


def gains_over_top_down(result: dict, top_down: dict | None) -> dict[str, PairedGain]:
    """A trial's gain over the top-down trial's networks on each set, over the seeds both fitted."""
    pairs = _over_top_down(result, top_down)
    return {w: paired_gain([p["with_pool"][w]["per_object"] for p, _ in pairs],
                           [b[w]["per_object"] for _, b in pairs], VIEWS) for w in ("household", "unseen")}


def _over_top_down_lines(result: dict, top_down: dict | None, base: str, tried: str, gives: str) -> list[str]:
    """The seed-for-seed table of a trial against the top-down trial's networks and its verdict."""
    gain = gains_over_top_down(result, top_down)
    rows = [f"| {p['seed']} | " + " | ".join(f"{_pct(b[w]['first_attempt'])} | "
                                             f"{_pct(p['with_pool'][w]['first_attempt'])}"
                                             for w in ("household", "unseen")) + " |"
            for p, b in _over_top_down(result, top_down)]
    return [f"| seed | household, {base} | {tried} | unseen, {base} | {tried} |", "| --- | --- | --- | --- | --- |",
            *rows, "", f"On the household set, where designs are chosen, {gives} {gain_words(gain['household'])}; "
            f"{RULE}. On the unseen set, where nothing is chosen, {_unseen_words(gain['unseen'])}."]


def points_section(result: dict, top_down: dict | None) -> list[str]:
    """More of each crop's points (results/pick_points.json) against the top-down trial's networks
    (results/pick_top_down.json) on the same labels, seed for seed, both with the top-down grasps in the pool."""
    return [f"## More of each crop's points: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The shipped design sees 128 of each crop's 256 stored points, "
            "drawn anew every batch (a planner resamples its crops to as many); thin parts (a handle, a rim, a flat "
            f"package's edge) are then a few points. `{result['design']}` sees all 256, fitted seed for seed on the "
            "top-down trial's labels against that trial's networks (128 points), both planning with the top-down "
            "grasps in the pool, first attempt:", "",
            *_over_top_down_lines(result, top_down, "128 points", "256 points", "256 points give")]


def both_section(result: dict, top_down: dict | None) -> list[str]:
    """Both label batches executing the top-down grasps (results/pick_top_down_both.json) against the top-down
    trial's networks (only its first batch executed them), seed for seed, both with the top-down grasps in the
    pool."""
    return [f"## Both label batches executing the top-down grasps: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. Only the first label batch of the kept top-down trial executed "
            "the top-down grasps, and its network still ranks sampled grasps above a top-down grasp that would hold "
            f"on flat packages. The second batch's objects and views labelled again so ({result['labels']} labels, "
            f"success rate {result['success_rate']:.2f}) join the trial's first batch; `{BASE}` fitted on them seed "
            "for seed against the top-down trial's networks, both planning with the top-down grasps in the pool, "
            "first attempt:", "",
            *_over_top_down_lines(result, top_down, "first batch", "both batches", "both batches give")]


def schedule_section(result: dict, top_down: dict | None) -> list[str]:
    """The learning rate's schedule (results/pick_schedule.json) against the top-down trial's networks on the same
    labels, seed for seed, both with the top-down grasps in the pool."""
    return [f"## The learning rate's schedule: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The shipped design fits at a constant rate and stops when the "
            "validation AP has not risen for 5 epochs. `context_balanced_cosine` decays the rate along a cosine over "
            "all 30 epochs, never stopped early, its best epoch by validation AP kept as before; fitted seed for "
            "seed on the top-down trial's labels against that trial's networks, both planning with the top-down "
            "grasps in the pool, first attempt:", "",
            *_over_top_down_lines(result, top_down, "constant", "cosine", "the cosine schedule gives")]


def household_labels_section(result: dict, top_down: dict | None) -> list[str]:
    """Real household meshes in the labels (results/pick_household_labels.json), judged on the unseen set alone
    against the top-down trial's networks, seed for seed: whether such training meshes move the unseen picks;
    never shipped (the household set is trained on)."""
    pairs = [(p["seed"], p["unseen"], b["unseen"]) for p, b in _over_top_down(result, top_down)]
    gain = paired_gain([p["per_object"] for _, p, _ in pairs], [b["per_object"] for _, _, b in pairs], VIEWS)
    rows = [f"| {seed} | {_pct(b['first_attempt'])} | {_pct(p['first_attempt'])} | "
            f"{100 * (p['first_attempt'] - b['first_attempt']):+.1f} |" for seed, p, b in pairs]
    return [f"## Real household meshes in the labels, judged on the unseen set: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. Every trial above plateaus near the same figures on labels of "
            "procedural objects. The household set's 16 meshes labelled too (48 views each, none of them the "
            f"benchmark's; {result['labels']} labels, success rate {result['success_rate']:.2f}) join the top-down "
            f"trial's labels; `{BASE}` fitted on them seed for seed against that trial's networks, judged on the "
            "unseen set alone (the household set is trained on here, so it no longer judges, and this network is "
            "never shipped). It asks whether scanned household shapes in training move the picks of objects never "
            "trained on, before a training source of such meshes outside both sets is sought:",
            "", "| seed | unseen, top-down trial | + household meshes | difference |", "| --- | --- | --- | --- |",
            *rows, "", f"On the unseen set the household meshes give {gain_words(gain)} (the trials' rule applied "
            "to the unseen objects; nothing ships from it)."]


def outline_section(result: dict, top_down: dict | None) -> list[str]:
    """The object's outline seen from the grasp (results/pick_outline.json) against the top-down trial's networks
    on the same labels, seed for seed, both with the top-down grasps in the pool; and beside the picks, both
    networks' ranking of the held-out procedural objects' labelled views (their validation)."""
    missed = result.get("views_not_again", [])
    left_out = (f"; {len(missed)} view{'s' if len(missed) != 1 else ''} that settled elsewhere when seen again "
                f"left out: {', '.join(missed)}; {result['labels']} labels" if missed else "")
    return [f"## What the object is outside the fingers: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. A crop holds only the points between the fingers and the "
            "context only the object's centre; the picks lost are mugs dropped when shaken (the body hanging off "
            f"the rim), bowls and flat packages. `{result['design']}` also reads the observed object's outline seen "
            "from the grasp (64 farthest-point samples of its cloud in the gripper frame, core/cloud/outline.py), "
            "through a PointNet of its own. The top-down trial's labels, each view seen again to cut the outlines "
            f"(the same seeded settle, camera and cloud{left_out}); fitted seed for seed against that trial's "
            "networks, both planning with the top-down grasps in the pool, first attempt:", "",
            *_over_top_down_lines(result, top_down, "crop and context", "+ outline", "the outline gives"), "",
            _validation_words(result, top_down)]


def _validation_words(result: dict, top_down: dict | None) -> str:
    """How both networks rank the labelled views of their validation objects (held-out procedural objects, the
    same at a seed), seed for seed."""
    base = {p["seed"]: p["best_epoch"] for p in (top_down or {}).get("points", [])}
    pairs = [(p["best_epoch"], base[p["seed"]]) for p in result["points"] if p["seed"] in base]
    if not pairs:
        return ""
    higher = sum(a["val_view_top1"] > b["val_view_top1"] for a, b in pairs)
    top1 = [np.mean([pair[k]["val_view_top1"] for pair in pairs]) for k in (0, 1)]
    ap = [np.mean([pair[k]["val_ap"] for pair in pairs]) for k in (0, 1)]
    better = top1[0] > top1[1] and ap[0] > ap[1]
    carries = gains_over_top_down(result, top_down)["household"].verdict == "kept"
    last = (" What it learns of the training objects does not carry to the household objects' picks."
            if better and not carries else "")
    return (f"On the labelled views of the held-out procedural objects (each fit's validation) the outline ranks "
            f"{'better' if better else 'no better'}: the best-scored candidate picked in {100 * top1[0]:.1f}% of "
            f"the views against {100 * top1[1]:.1f}% (higher at {higher} of {len(pairs)} seeds), AP {ap[0]:.3f} "
            f"against {ap[1]:.3f}.{last}")


def top_draws_section(result: dict, top_down: dict | None) -> list[str]:
    """The network's own best grasps drawn again (results/pick_top_draws.json) against the top-down trial's
    networks, seed for seed, both with the top-down grasps in the pool."""
    return [f"## The network's best grasps drawn again: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The network's first grasps pick less surely than the surest of "
            "its pool (the ceiling above, most on the unseen set), and a label drawn once says little about which "
            "of its best grasps pick again. Each of the first label "
            "batch's objects seen at 4 of its views, the shipped network's 8 best-ranked candidates of each executed "
            f"{result['their_draws']} times ({result['rows_drawn_again']} rows; {_pct(result['their_first_draw_rate'])}"
            f" picked at their first draw, {_pct(result['their_mean_picks'])} of all draws): they join the top-down "
            f"trial's labels ({result['labels']} in all) with the share of their draws that picked as their target "
            f"(`{result['design']}`; the other rows' target is their one execution); fitted seed for seed against "
            "that trial's networks, both planning with the top-down grasps in the pool, first attempt:", "",
            *_over_top_down_lines(result, top_down, "top-down trial", "+ drawn again",
                                  "the best grasps drawn again give")]
