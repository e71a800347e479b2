"""The section of docs/picks.md on the planner's check drawn by single trials (results/pick_check_trials.json)."""

from __future__ import annotations

AS_GOOD = -0.02  # a check is as good as the protocol's where its paired interval over all objects lies above this
CHEAPER = 0.75  # and it replaces it only where it costs at most this share of the protocol's seconds a view


def _points(pair) -> str:
    return f"[{100 * pair[0]:+.1f}, {100 * pair[1]:+.1f}]"


def _name(key: str, result: dict) -> str:
    if key == "protocol":
        return f"the protocol's, {result['draws']} draws (the planner's)"
    n = int(key.removeprefix("trials_"))
    return "the nominal trial alone" if n == 0 else f"the nominal trial, then {n} perturbed"


def _verdict(result: dict) -> str:
    pooled = result["sets"]["all objects"]
    base = pooled["protocol"]["seconds_a_view"]
    kept = [f"trials_{n}" for n in result["counts"]
            if pooled[f"trials_{n}"]["versus_protocol"]["interval"][0] > AS_GOOD
            and pooled[f"trials_{n}"]["seconds_a_view"] <= CHEAPER * base]
    rule = (f"(a check replaces the protocol's where its interval over all objects against it lies above "
            f"{100 * AS_GOOD:+.0f} points and it costs at most {100 * CHEAPER:.0f}% of its seconds a view)")
    if kept:
        return f"As good and cheaper: {', '.join(_name(k, result) for k in kept)} {rule}."
    good = [f"trials_{n}" for n in result["counts"]
            if pooled[f"trials_{n}"]["versus_protocol"]["interval"][0] > AS_GOOD]
    costs = ", ".join(f"{_name(k, result)}: {pooled[k]['seconds_a_view']:.3f} s" for k in good)
    return (f"No check by single trials is as good as the protocol's and cheaper {rule}: **not kept**; the planner "
            f"checks by the protocol's draws ({base:.3f} s a view here). As good, at the same cost or more: "
            f"{costs or 'none'}.")


def check_trials_section(result: dict) -> list[str]:
    """Each check's first against the network's first and against the protocol's check, with its seconds."""
    keys = ["protocol", *(f"trials_{n}" for n in result["counts"])]
    rows = [f"| {_name(key, result)} | {which} | {100 * m[key]['checked']:.1f}% | {100 * m[key]['gain']:+.1f} "
            f"{_points(m[key]['interval'])} | "
            + (f"{100 * m[key]['versus_protocol']['mean']:+.1f} {_points(m[key]['versus_protocol']['interval'])}"
               if key != "protocol" else "-")
            + f" | {m[key]['seconds_a_view']:.3f} |" for key in keys for which, m in result["sets"].items()]
    return [f"## The check drawn by single trials: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}, {result['seconds']:.0f} s. The check executes each of the "
            f"network's first {result['checked']} grasps {result['draws']} times by the pick protocol: the nominal "
            "trial, then perturbed trials until one fails. The nominal trial is the same at every draw, so the "
            "check executes it once (`picks.shape_check.protocol_draws`: the same outcomes and draws from the "
            "stream as every draw executing it). Drawn by single trials instead, the check would execute the "
            "nominal trial once and then n perturbed trials, and order the grasps by how many held. Both run on "
            "the same hull on the ranked-draws views (above), each judged by the share of 8 draws of the grasp it "
            "puts first, paired over objects; the seconds are what each would execute in the planner's lazy order "
            "(it stops where the first grasp held every draw), one worker of two.", "",
            "| the check | set | the check's first | gain over the network's first [95% CI] "
            "| against the protocol's check [95% CI] | seconds a view |",
            "| --- | --- | --- | --- | --- | --- |", *rows, "", _verdict(result)]


def _points_words(v: dict) -> str:
    return f"{100 * v['mean']:+.1f} points {_points(v['interval'])}"


KEPT_VARIANTS = {"top_down": ("With the best top-down grasp checked beside", "`check_top_down` stays off",
                              "`check_top_down` is turned on"),
                 "check_5": ("With the first 5 checked", "`check_first` stays 3", "`check_first` becomes 5")}


def _variant_verdict(name: str, v: dict) -> str:
    """What a variant's pairing against the first 3 checked says."""
    versus = v["versus"]["network"]
    if name in KEPT_VARIANTS:
        words, stays, becomes = KEPT_VARIANTS[name]
        kept = versus["interval"][0] > 0
        return (f"{words}: {_points_words(versus)} against the first 3 checked alone, "
                f"{_points_words(v['versus']['top_down'])} against top-down: "
                + ("**kept**" if kept else "**not kept**")
                + " (kept where the interval against the first 3 alone lies above zero); "
                + f"{becomes if kept else stays}.")
    shown = ("the check helps on this hand" if versus["interval"][1] < 0 else
             "the check hurts on this hand" if versus["interval"][0] > 0 else
             "these views cannot tell whether the check helps on this hand")
    return (f"Without the check (the network's order alone): {_points_words(versus)} against the first 3 checked, "
            f"{_points_words(v['versus']['top_down'])} against top-down: {shown}.")


VARIANT_NAMES = {"top_down": "the first 3 and the best top-down grasp checked", "unchecked": "no check",
                 "check_5": "the first 5 checked"}


def panda_check_section(result: dict, panda: dict | None) -> list[str]:
    """The Franka hand's network planned otherwise (results/pick_panda_check.json): with its best top-down grasp
    checked beside its first ones, and without the check, against pick_panda's run of the same network and views."""
    from benchmarks.pages.pick_sets import method_of, pct, pooled

    point = next((p for p in (panda or {}).get("points", []) if p["seed"] == result["seed"]), None)
    variants = {name: v for name, v in result.get("variants", {}).items()
                if "versus" in v and "network" in v["versus"] and v.get("views", 8) == 8}
    if point is None or not variants:
        return []
    before = {s["name"]: s for s in point["sets"]}
    rates = {name: {s["name"]: method_of(s, "network")["first_attempt"] for s in v["sets"]}
             for name, v in variants.items()}
    rows = [f"| {name} | " + " | ".join(pct(rates[v][name]) if name in rates[v] else "-" for v in variants)
            + f" | {pct(method_of(s, 'network')['first_attempt'])} | {pct(method_of(s, 'top_down')['first_attempt'])} |"
            for name, s in before.items() if any(name in r for r in rates.values())]
    both = [s for s in point["sets"] if s["name"] in rates[next(iter(variants))]]
    rows.append("| household meshes pooled | "
                + " | ".join(pct(pooled(v["sets"], "network")["first_attempt"]) for v in variants.values())
                + "".join(f" | {pct(pooled(both, m)['first_attempt'])}" for m in ("network", "top_down")) + " |")
    columns = " | ".join(VARIANT_NAMES[v] for v in variants)
    return [f"## The Franka hand's network planned otherwise: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. On the Franka hand top-down nearly matches the network, and "
            "where one misses the other often picks. With `PlanSpec(check_top_down=True)` the best-scored top-down "
            "grasp is checked beside the network's first 3 and comes first only where it held more often than "
            "each; with `check_first=0` nothing is checked (the check was kept on the box palm's measure); with "
            "`check_first=5` the first 5 are. The "
            f"network shipped for the preset (seed {result['seed']}), the network chooser alone, the same views and "
            "draws as the section above, first attempt:", "",
            f"| set | {columns} | the first 3 checked (above) | top-down (above) |",
            "| --- |" + " --- |" * (len(variants) + 2), *rows, "",
            *(line for name, v in variants.items()
              for line in (f"Paired over the {v['versus']['network']['objects']} household meshes. "
                           + _variant_verdict(name, v), "")), *_more_views(result)][:-1]


def _more_views(result: dict) -> list[str]:
    """The first 5 checked against the first 3 at more views an object (the ``..._32_views`` variants)."""
    from benchmarks.pages.pick_sets import method_of, pct, pooled

    variants = result.get("variants", {})
    five, three = variants.get("check_5_32_views"), variants.get("check_3_32_views")
    if not five or not three or "versus" not in five:
        return []

    def rates(v: dict) -> str:
        return ", ".join([*(f"{s['name']} {pct(method_of(s, 'network')['first_attempt'])}" for s in v["sets"]),
                          f"household meshes pooled {pct(pooled(v['sets'], 'network')['first_attempt'])}"])

    versus = five["versus"]["check_3_32_views"]
    kept = versus["interval"][0] > 0
    return [f"The same at {five['views']} views an object (the first 8 the section above's; one draw a view): the "
            f"first 3 checked {rates(three)}; the first 5 checked {rates(five)}. Paired over the "
            f"{versus['objects']} household meshes, the first 5 against the first 3: {_points_words(versus)}: "
            + ("on this hand the first 5 pick more (the interval lies above zero). The planner's default stays 3, "
               "chosen on the box palm's measure and the same for every hand: `onepiece grasp --check 5` "
               "(`PlanSpec(check_first=5)`) plans so on this hand" if kept else
               "**not kept** (kept where the interval lies above zero)") + "." + _second_network(variants), ""]


def _second_network(variants: dict) -> str:
    """The first 5 against the first 3 at 32 views with pick_panda's second network (the ``..._s1`` variants)."""
    from benchmarks.pages.pick_sets import pct, pooled

    five, three = variants.get("check_5_32_views_s1"), variants.get("check_3_32_views_s1")
    if not five or not three or "versus" not in five:
        return ""
    versus = five["versus"]["check_3_32_views_s1"]
    holds = versus["interval"][0] > 0
    return (f" With the network of seed {five['seed']} (fitted on the same labels), the same views: household meshes "
            f"pooled {pct(pooled(three['sets'], 'network')['first_attempt'])} with the first 3 checked, "
            f"{pct(pooled(five['sets'], 'network')['first_attempt'])} with the first 5; paired "
            f"{_points_words(versus)}: " + ("the first 5 pick more with this network too" if holds else
                                             "with this network the interval does not lie above zero, so the gain "
                                             "is not shown to hold beyond the network it was measured on") + ".")
