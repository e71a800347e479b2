"""The sections of docs/picks.md that ask what orders the network's best grasps: their scores under pose noise
(results/pick_robust_rank.json) and what the view shows of them (results/pick_rank_features.json)."""

from __future__ import annotations

from benchmarks.pages.pick_check_noise_section import noise_lines
from benchmarks.pages.pick_check_slip_section import slip_lines
from benchmarks.pages.pick_sets import pct1

RULES = {
    "shipped": "the network's score (its own order)",
    "near_mean": "the mean score of the view's candidates within {m:g} m and {deg:g} degrees",
    "near_and_nominal": "that and its own score, averaged",
    "mean": "the mean score of {samples} perturbed poses",
    "q25": "the lower quartile of those",
    "min": "the least of those",
    "mean_with_nominal": "the mean of those and its own",
}


def _rule(name: str, result: dict) -> str:
    base, _, scale = name.rpartition("_x") if "_x" in name else (name, "", "")
    words = RULES[base].format(samples=result["samples"], **result["near"])
    return f"{words}, {scale}x the protocol's noise" if scale else words


def robust_rank_section(result: dict) -> list[str]:
    """The shipped network's best grasps ordered by their scores under pose noise and by their neighbourhoods."""
    sets = result["sets"]
    names = list(next(iter(sets.values()))["chosen"])
    rows = [f"| {_rule(name, result)} | " + " | ".join(f"{pct1(s['chosen'][name]['3'])} | "
                                                       f"{pct1(s['chosen'][name]['10'])}" for s in sets.values())
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
            f"Against the network's own order, of its first three: {verdict} (as `jittered` found for the whole "
            "pool, in Rankings tried below). The mean under the protocol's own "
            "noise: " + " and ".join(f"{100 * g['mean_x1']:+.1f} points on the {w} set" for w, g in gains.items())
            + "; the neighbourhood's mean: " + " and ".join(f"{100 * g['near_mean']:+.1f}" for g in gains.values())
            + "."]


ENDS = ("picked", "slipped_lifting", "dropped_shaking", "no_contact", "start_collision")
END_WORDS = ("picked", "slipped when lifted", "dropped when shaken", "closed on nothing", "start in collision")


def rank_features_section(result: dict) -> list[str]:
    """How the network's best grasps fail, object by object, and whether a prior on what the view shows of them
    orders them better (results/pick_rank_features.json)."""
    sets, prior = result["sets"], result["prior"]
    agree = ", ".join(f"{100 * s['draws_agree']:.1f}% on the {w} set" for w, s in sets.items())
    lines = [f"## Why the network's best grasps fail: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}, {result['seconds']:.0f} s. The views of the ranked grasps "
             "above seen again and the first 10 of each executed at the same 8 draws, now keeping how each ended "
             f"(the draws agree with the stored ones: {agree}). How the draws of the network's first, second and "
             "third grasp ended:", "",
             "| set | rank | " + " | ".join(END_WORDS) + " |", "| --- | --- |" + " --- |" * len(ENDS)]
    for which, s in sets.items():
        for rank, ends in s["failures"].items():
            lines.append(f"| {which} | {rank} | " + " | ".join(str(ends.get(e, 0)) for e in ENDS) + " |")
    lines += ["", "By object: how the first grasp's 8 draws per view ended, and the mean share of draws of the "
              "first, of the surest of the first 3 and of the first 10 (the surest: the most draws picked, an "
              "oracle's choice):", "",
              "| set | object | " + " | ".join(END_WORDS) + " | first | surest of 3 | surest of 10 |",
              "| --- | --- |" + " --- |" * (len(ENDS) + 3)]
    for which, s in sets.items():
        for name, o in s["objects"].items():
            lines.append(f"| {which} | {name} | " + " | ".join(str(o["first"].get(e, 0)) for e in ENDS) + " | "
                         + " | ".join(pct1(v) for v in o["shares"]) + " |")
    never = [f"{name} ({which})" for which, s in sets.items() for name, o in s["objects"].items()
             if o["shares"][2] < 0.1]
    lines += ["", "Objects on which even the surest of the first 10 picks under 10% of its draws (no ranking of "
              "the network's grasps picks them): " + (", ".join(never) if never else "none") + ".", "",
              *_prior_lines(result, prior)]
    return lines


def _prior_lines(result: dict, prior: dict) -> list[str]:
    unseen, left_out = prior["unseen"]["3"], prior["household_left_out"]["3"]
    gains = (unseen[1] - unseen[0], left_out[1] - left_out[0])
    kept = all(g > 0 for g in gains)
    weights = ", ".join(f"{name} {w:+.2f}" for name, w in zip(result["features"], prior["weights"], strict=False))
    return [f"A prior on what the view shows of a grasp ({', '.join(f'`{f}`' for f in result['features'])}: "
            "`picks.rank_features`; `score_under_noise`: the mean score of 16 perturbed poses, above), a logistic "
            "model of each grasp's share of draws on those and the network's score, fitted on the household "
            "set's ranked grasps (standardized weights: "
            f"{weights}): choosing the first 3's best by it picks {pct1(unseen[1])} of the unseen set's draws "
            f"against the network's order's {pct1(unseen[0])} ({100 * gains[0]:+.1f} points), and on the household "
            f"set, each object judged by a model fitted without it, {pct1(left_out[1])} against {pct1(left_out[0])} "
            f"({100 * gains[1]:+.1f}): " + ("kept." if kept else "not kept: what the view shows of a grasp beyond "
                                             "the network's score does not tell the surer apart.")]


def shape_check_section(result: dict) -> list[str]:
    """The network's first grasps checked on the shape the view implies (results/pick_shape_check.json)."""
    from benchmarks.experiments.pick_shape_check import paired_check

    sets, checks = result["sets"], [str(k) for k in result["checks"]]
    rows = [f"| {which} | {k or 'none'} | {pct1(m[k]['first_attempt'])} [{pct1(m[k]['interval'][0])}, "
            f"{pct1(m[k]['interval'][1])}] | {pct1(m[k]['within_3'])} | {m[k]['views']} | "
            + _lost(m[k]["failures"])
            + f" | {m[k]['seconds']:.0f} |" for which, m in sets.items() for k in checks]
    gains = [paired_check(result, k) for k in checks[1:]]
    lines = [f"## The first grasps checked on the shape the view implies: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. What the view shows does not tell the surer of the network's "
             "first grasps apart as numbers (above); executed, it might. The planner's option `check_first` "
             "(`onepiece grasp --check N`; `picks.shape_check`) executes each of the first N ranked grasps "
             f"{result['draws']} times by the pick protocol (its pose and friction noise) on the shape one view "
             "implies, the observed points and their shadows on the table as one convex hull at the protocol's "
             "density, in a pick world of its own, and reorders them by how often they held (the network's order on "
             "ties). The object itself is never seen by the check. The shipped network alone, the benchmark's views, "
             "judged by the benchmark's own executions:", "",
             "| set | checked | first attempt [95% CI over objects] | within 3 | views | first attempts lost | "
             "seconds |", "| --- | --- | --- | --- | --- | --- | --- |", *rows, ""]
    drawn = result.get("expected", {})
    if drawn:
        lines += ["One draw per view is a noisy judge of a reordering; the ranked-draws views (above: the network's "
                  "first 10, each executed at 8 draws) judge it by the share of its 8 draws the grasp the check "
                  "puts first picks, the check run as the benchmark runs it:", "",
                  "| checked | set | views | the network's first | the check's first | gain over objects [95% CI] | "
                  "the surest of those (an oracle) | reordered | the check held the network's first |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
                  *(f"| {k} | {w} | {d['views']} | {pct1(d['first'])} | {pct1(d['checked'])} | "
                    f"{100 * d['gain_by_object']:+.1f} [{100 * d['gain_interval'][0]:+.1f}, "
                    f"{100 * d['gain_interval'][1]:+.1f}] | {pct1(d['surest'])} | {d['reordered']} views | "
                    f"{pct1(d['check_held_first'])} of its draws |" for k, by_set in drawn.items()
                    for w, d in by_set.items()), ""]
    lines += _density_lines(result.get("expected_density", {}))
    lines += shape_lines(result.get("expected_shapes", {}))
    lines += draws_lines(result.get("expected_draws", {}))
    lines += noise_lines(result.get("expected_noise", {}))
    lines += noise_lines(result.get("expected_friction", {}), "friction")
    lines += slip_lines(result.get("expected_slip", {}))
    lines += judged_shape_lines(result)
    for gain in gains:
        k = str(gain["checked"])
        pooled = drawn.get(k, {}).get("all objects")
        drawn_words = "" if pooled is None else (
            f"; by the 8 draws over all objects {100 * pooled['gain_by_object']:+.1f} points "
            f"[{100 * pooled['gain_interval'][0]:+.1f}, {100 * pooled['gain_interval'][1]:+.1f}]")
        extra = {w: m[k]["seconds"] - m["0"]["seconds"] for w, m in sets.items()}
        cost = ", ".join(f"{s_:.1f} s a view on the {w} set" for w, s_ in
                         ((w, extra[w] / max(sets[w][k]["views"], 1)) for w in sets))
        lines.append(f"Checking the first {k}, by the benchmark's one draw: " + "; ".join(
            f"{name} {100 * g['mean']:+.1f} points [{100 * g['interval'][0]:+.1f}, {100 * g['interval'][1]:+.1f}]"
            for name, g in gain["sets"].items()) + f" (paired over objects){drawn_words}; the check costs {cost} "
            f"(the runs' wall time, two workers). At the benchmark's {_views_an_object(sets)} views an object: "
            f"**{gain['verdict']}** as the planner's default (kept where its interval over all objects lies above "
            "zero)" + ("; more views decide (below)." if "more_views" in result else "."))
        lines.append("")
    return lines[:-1] + more_views_lines(result.get("more_views"))


def _lost(failures: dict) -> str:
    """A run's first attempts lost, by reason."""
    return ", ".join(f"{n} {reason.replace('_', ' ')}" for reason, n in sorted(failures.items()))


def _views_an_object(sets: dict) -> int:
    m = next(iter(sets.values()))["0"]
    return round(m["views"] / max(len(m["per_object"]), 1))


def more_views_lines(more: dict | None) -> list[str]:
    """The check judged by the benchmark's one draw at more views an object (results' more_views): the runs, each
    gain paired over objects, and whether the planner checks by default."""
    from benchmarks.experiments.pick_shape_check import TOP_DOWN
    from onepiece_dist.specs.plan import PlanSpec

    if not more:
        return []
    sets = more["sets"]
    lines = ["", f"The same by the benchmark's one draw at {more['views']} views an object (the first 8 the "
             f"benchmark's), the check at its default {more['check_draws']} draws a grasp:", "",
             "| set | checked | first attempt [95% CI over objects] | views | first attempts lost | seconds |",
             "| --- | --- | --- | --- | --- | --- |",
             *(f"| {which} | {_run_name(k)} | {pct1(m[k]['first_attempt'])} [{pct1(m[k]['interval'][0])}, "
               f"{pct1(m[k]['interval'][1])}] | {m[k]['views']} | "
               + _lost(m[k]["failures"])
               + f" | {m[k]['seconds']:.0f} |" for which, m in sets.items() for k in m), ""]
    runs = list(next(iter(sets.values())))
    lines += [_more_views_verdict(more, k) for k in runs if k.isdigit() and k != "0"]
    default = str(PlanSpec().check_first)
    if default in runs:  # each other number checked against the planner's
        lines += [_against_default(more, k) for k in runs if k.isdigit() and k not in ("0", default)]
    lines += [_top_down_verdict(more, k) for k in runs if k.endswith(TOP_DOWN)]
    return lines


def _against_default(more: dict, k: str) -> str:
    """The first ``k`` checked against the planner's default number, paired over objects."""
    from benchmarks.experiments.pick_shape_check import paired_check
    from onepiece_dist.specs.plan import PlanSpec

    default = PlanSpec().check_first
    gain = paired_check(more, k, base=str(default))
    return (f"The first {k} checked against the first {default} (the planner's default) at {more['views']} views an "
            f"object: {_gain_words(gain)} (paired over objects): **{gain['verdict']}** in its place (kept where its "
            f"interval over all objects lies above zero); `PlanSpec.check_first` = {default}.")


def _run_name(key: str) -> str:
    from benchmarks.experiments.pick_shape_check import TOP_DOWN

    if key == "0":
        return "none"
    return f"{key.removesuffix(TOP_DOWN)} and the best top-down grasp" if key.endswith(TOP_DOWN) else key


def _gain_words(gain: dict) -> str:
    return "; ".join(f"{name} {100 * g['mean']:+.1f} points [{100 * g['interval'][0]:+.1f}, "
                     f"{100 * g['interval'][1]:+.1f}]" for name, g in gain["sets"].items())


def _more_views_verdict(more: dict, k: str) -> str:
    from benchmarks.experiments.pick_shape_check import paired_check
    from onepiece_dist.specs.plan import PlanSpec

    gain, default = paired_check(more, k), PlanSpec().check_first
    planner = (f"the planner checks its first {default} by default (`PlanSpec.check_first` = {default})"
               if default else "the planner does not check by default (`PlanSpec.check_first` = 0)")
    return (f"Checking the first {k} at {more['views']} views an object: {_gain_words(gain)} (paired over "
            f"objects): **{gain['verdict']}** as the planner's default (kept where its interval over all objects "
            f"lies above zero); {planner}.")


def _top_down_verdict(more: dict, k: str) -> str:
    from benchmarks.experiments.pick_shape_check import TOP_DOWN, paired_check
    from onepiece_dist.specs.plan import PlanSpec

    first = k.removesuffix(TOP_DOWN)
    gain, default = paired_check(more, k, base=first), PlanSpec().check_top_down
    return (f"The best-scored top-down grasp checked beside the first {first} (`check_top_down`), against the first "
            f"{first} alone at {more['views']} views an object: {_gain_words(gain)} (paired over objects): "
            f"**{gain['verdict']}** as the planner's default (kept where its interval over all objects lies above "
            f"zero); `PlanSpec.check_top_down` = {default}.")


def _density_lines(by_scale: dict) -> list[str]:
    """The check with its shape's mass guessed wrong (results' expected_density): the 8-draw gain of its choice."""
    if not by_scale:
        return []
    rows = [f"| {scale}x | {k} | {w} | {pct1(d['checked'])} | {100 * d['gain_by_object']:+.1f} "
            f"[{100 * d['gain_interval'][0]:+.1f}, {100 * d['gain_interval'][1]:+.1f}] |"
            for scale, by_k in by_scale.items() for k, by_set in by_k.items() for w, d in by_set.items()]
    return ["A robot does not know its object's mass: the same measure with the check's shape at other multiples "
            "of the protocol's density (the objects keep theirs):", "",
            "| the check's density | checked | set | the check's first | gain over objects [95% CI] |",
            "| --- | --- | --- | --- | --- |", *rows, ""]


SUMMED_LINE = (" Summed, a grasp counts its held draws on the three shapes together (a robot that cannot tell "
               "which of them is the object pays for the three checks; `pick_shape_check --summed`, from their rows).")


def shape_lines(by_shape: dict) -> list[str]:
    """The check on each shape (results' expected_shapes): the 8-draw gain of its choice, and the second shape's
    choice against the first's, paired over objects, with a verdict (the second kept where that interval over all
    objects lies above zero)."""
    if not by_shape:
        return []
    shapes = [name for name in by_shape if name not in ("versus", "rows")]
    rows = [f"| {shape} | {k} | {w} | {pct1(d['checked'])} | {100 * d['gain_by_object']:+.1f} "
            f"[{100 * d['gain_interval'][0]:+.1f}, {100 * d['gain_interval'][1]:+.1f}] | {pct1(d['surest'])} | "
            f"{pct1(d['check_held_first'])} of its draws | {_seconds(d.get('seconds_a_view'))} |"
            for shape in shapes for k, by_set in by_shape[shape].items() for w, d in by_set.items()]
    lines = ["The hull fills a mug's or a bowl's opening, so a grasp on its rim meets a solid there. Carved, the hull "
             "loses every voxel (4 mm) whose centre the camera saw through by more than 5 mm (the view's depth "
             "rebuilt from the cloud and the camera's position, as the network's swept space reads it): an opening "
             "it looked into stays open, what it could not see stays solid. Mirrored, the hull also holds the points' "
             "half turn about the vertical axis of the circle that best fits their footprint (what a symmetric "
             "object, a can or a box, shows of its far side)." + SUMMED_LINE * ("summed" in shapes)
             + " The same measure on each shape:", "",
             "| shape | checked | set | the check's first | gain over objects [95% CI] | the surest (an oracle) | "
             "the check held the network's first | the check's seconds a view (one worker) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |", *rows, ""]
    for k, by_set in (item for by_k in by_shape.get("versus", {}).values() for item in by_k.items()):
        first, second = by_set["all objects"]["shapes"]
        pooled = by_set["all objects"]["interval"]
        verdict = "kept" if pooled[0] > 0 else "not kept"
        lines += [f"The check's first among the first {k} on the {second} shape against the {first}, paired over "
                  "objects: " + "; ".join(f"{w} {100 * d['mean']:+.1f} points [{100 * d['interval'][0]:+.1f}, "
                                          f"{100 * d['interval'][1]:+.1f}]" for w, d in by_set.items())
                  + f": the {second} shape **{verdict}** (kept where the interval over all objects lies above "
                  "zero).", ""]
    return lines


def judged_shape_lines(result: dict) -> list[str]:
    """The check on another shape judged by the benchmark's one draw (results' judged_shapes), paired over objects
    against the unchecked runs."""
    from benchmarks.experiments.pick_shape_check import paired_check

    lines = []
    for shape, by_set in result.get("judged_shapes", {}).items():
        for k in next(iter(by_set.values())):
            gain = paired_check(result, k, shape)
            firsts = "; ".join(f"{w} {pct1(result['sets'][w]['0']['first_attempt'])} -> "
                               f"{pct1(m[k]['first_attempt'])} ({m[k]['seconds']:.0f} s)" for w, m in by_set.items())
            lines += [f"The first {k} checked on the {shape} shape, by the benchmark's one draw: {firsts}; paired over "
                      "objects " + "; ".join(f"{name} {100 * g['mean']:+.1f} points [{100 * g['interval'][0]:+.1f}, "
                                             f"{100 * g['interval'][1]:+.1f}]" for name, g in gain["sets"].items())
                      + f": **{gain['verdict']}** as the planner's default.", ""]
    return lines


FEWER_MARGIN = 2.0  # points: fewer draws are as good where their paired loss is surely under this


def _seconds(value: float | None) -> str:
    """A time in seconds, or "-" where the run did not time it."""
    return "-" if value is None else f"{value:.1f}"


def draws_lines(by_count: dict) -> list[str]:
    """The hull's check with fewer or more draws of each grasp (results' expected_draws): the 8-draw gain of its
    choice, and whether more draws choose better (the largest count's pooled gain against the smallest's)."""
    if not by_count:
        return []
    counts = sorted((n for n in by_count if n != "versus"), key=int)
    rows = [f"| {n} | {k} | {w} | {pct1(d['checked'])} | {100 * d['gain_by_object']:+.1f} "
            f"[{100 * d['gain_interval'][0]:+.1f}, {100 * d['gain_interval'][1]:+.1f}] |"
            for n in counts for k, by_set in by_count[n].items() for w, d in by_set.items()]
    few, many = (by_count[n]["3"]["all objects"] for n in (counts[0], counts[-1]))
    more = many["checked"] - few["checked"]
    words = (f"{counts[-1]} draws choose {100 * more:+.1f} points against {_draws(counts[0])}: "
             + ("more draws choose better, the check is bounded by its noise" if more > 0.01 else
                "more draws do not choose better; the check is bounded by its shape, not by its draws"))
    enough = _fewest_as_good(by_count.get("versus", {}), counts)
    if more > 0.01 and enough is not None and enough != counts[0]:
        words += (f" below {enough} draws; from {enough} on (as good as {counts[-1]}, paired below) it is bounded "
                  "by its shape")
    return ["Is the check bounded by its own noise? The hull's check with each grasp executed more or fewer times "
            "(each count the first draws of one run, a stream of its own), judged as above:", "",
            "| the check's draws | checked | set | the check's first | gain over objects [95% CI] |",
            "| --- | --- | --- | --- | --- |", *rows, "", f"Over all objects, first 3: {words}.", "",
            *_fewer_draws(by_count.get("versus", {}))]


def _draws(n: str) -> str:
    return f"{n} draw" if n == "1" else f"{n} draws"


def _fewest_as_good(versus: dict, counts: list[str]) -> str | None:
    """The fewest draws from which on every count is as good as the most (_fewer_draws' margin), if any."""
    good = [n for n in counts[:-1]
            if n in versus and 100 * versus[n]["3"]["all objects"]["interval"][0] > -FEWER_MARGIN]
    later = [n for n in counts[:-1] if all(m in good for m in counts[counts.index(n):-1])]
    return later[0] if later else None


def _fewer_draws(versus: dict) -> list[str]:
    """Fewer draws against the most, paired over objects: as good where the interval's lower end lies above
    -FEWER_MARGIN (a non-inferiority margin), else worse."""
    lines = []
    for n, by_k in versus.items():
        d = by_k["3"]["all objects"]
        many, low = d["draws"][0], 100 * d["interval"][0]
        verdict = (f"as good (its interval lies above -{FEWER_MARGIN:.0f} points)" if low > -FEWER_MARGIN else
                   f"not shown as good (its interval reaches below -{FEWER_MARGIN:.0f} points)")
        lines += [f"The check's first of 3 with {_draws(n)} against {many}, paired over objects: " + "; ".join(
            f"{w} {100 * v['mean']:+.1f} points [{100 * v['interval'][0]:+.1f}, {100 * v['interval'][1]:+.1f}]"
            for w, v in by_k["3"].items()) + f": {_draws(n)} {verdict}.", ""]
    return lines
