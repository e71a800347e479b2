"""What a user's own network picks (results/pick_own_network.json, benchmarks/experiments/pick_own_network.py):
networks made by `onepiece pick-labels` and `onepiece pick-train` with their defaults, at several label and fit
seeds, judged beside the shipped network on the same views of the household and unseen sets."""

from __future__ import annotations

import numpy as np

from benchmarks.experiments.pick_own_network import FIRST_OBJECTS, label_height
from benchmarks.pages.pick_trials_section import VIEWS, gain_words
from onepiece_dist.specs.plan import PICK_LABEL_OBJECTS, PLANNER_CLEARANCE_BEFORE
from onepiece_dist.stats.intervals import bootstrap_interval, paired_gain

SETS = ("household", "unseen")
SHIPPED_LABELS = 81152  # both shipped networks': plan/networks/*.json


def both_sets(picks: dict) -> dict[str, int]:
    """Object name -> views picked at the first attempt, over both sets."""
    return {name: n for set_name in SETS for name, n in picks[set_name]["per_object"].items()}


def heuristic_picks(picks: dict, method: str = "top_down") -> dict:
    """The picks of the heuristic ``method`` judged on the same views as a network's ``picks``, set by set."""
    return {s: picks[s]["others"][method] for s in SETS}


def pooled_rate(picks: dict) -> tuple[float, tuple[float, float]]:
    """The first-attempt rate over both sets' objects and its interval over objects."""
    rates = np.array([n / VIEWS for n in both_sets(picks).values()])
    return float(rates.mean()), bootstrap_interval(rates)


def cell(figure: dict) -> str:
    low, high = figure["interval"]
    return f"{100 * figure['first_attempt']:.0f}% [{100 * low:.0f}%, {100 * high:.0f}%]"


def pooled_cell(picks: dict) -> str:
    rate, (low, high) = pooled_rate(picks)
    return f"{100 * rate:.0f}% [{100 * low:.0f}%, {100 * high:.0f}%]"


def _started(n: dict) -> str:
    """Where the fit of ``n`` started ('' from fresh weights)."""
    if not n.get("start_from"):
        return ""
    return f"fit started from `{n['network']['start_from'].rsplit('/', 1)[-1]}` (the box gripper's shipped network)"


def _height(n: dict) -> str:
    """How high over the table the candidates of ``n``'s labels kept the open gripper ('' at the 2 mm of every
    row labelled before the height was a field)."""
    height = label_height(n)
    return "" if height == PLANNER_CLEARANCE_BEFORE else f"labelled {1000 * height:g} mm over the table"


def _source(n: dict) -> str:
    """The objects a network was labelled on, how high over the table where not at 2 mm, and where its fit started
    where not from fresh weights."""
    return ", ".join([f"`{n['made']['objects']}`", *(words for words in (_height(n), _started(n)) if words)])


Group = tuple[str, float, str | None]  # objects, the labels' height over the table, where the fit started


def _group(n: dict) -> Group:
    return n["made"]["objects"], label_height(n), n.get("start_from")


def _groups(networks: list[dict]) -> dict[Group, list[dict]]:
    """``networks`` by group (_group), in their order."""
    groups: dict[Group, list[dict]] = {}
    for n in networks:
        groups.setdefault(_group(n), []).append(n)
    return groups


def _row(n: dict) -> str:
    made, fitted, val = n["made"], n["network"], n["network"]["validation"]
    return (f"| {_source(n)} | {n['label_seed']} | {n['fit_seed']} | {made['labels']} | "
            f"{made['core_seconds']:.0f} | {fitted['fit_seconds']:.0f} | "
            f"{100 * val['top1']:.0f}% against {100 * val['guess']:.0f}% | "
            f"{cell(n['picks']['household'])} | {cell(n['picks']['unseen'])} | {pooled_cell(n['picks'])} |")


def _hand(made: dict) -> str:
    gripper = made.get("gripper", "onepiece_box")
    if "urdf" in made:
        return f"the Franka Panda's hand read from pybullet_data's `{made['urdf']}` (`--gripper` a YAML naming it)"
    return "the default job's box gripper" if gripper == "onepiece_box" else f"the `{gripper}` hand (`--gripper`)"


def _title(made: dict) -> str:
    gripper = made.get("gripper", "onepiece_box")
    if "urdf" in made:
        return ", the Franka Panda read from its URDF"
    return {"onepiece_box": "", "franka_panda": ", the Franka hand"}.get(gripper, f", the `{gripper}` hand")


def own_network_section(result: dict, target: float) -> list[str]:
    networks, shipped = result["networks"], result["shipped"]
    if not networks:
        return []
    made = networks[0]["made"]
    groups = _groups(networks)
    return [f"## A network made by the two commands{_title(made)}: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. What a user gets from `onepiece pick-labels` with its defaults "
            f"({made['views']} views an object, {made['per_view']} candidates executed a view, {_hand(made)}; "
            "docs/planning.md) on the objects each row names (`--objects`; its default objects were "
            f"`{FIRST_OBJECTS}`, and are `{PICK_LABEL_OBJECTS}` since this page's trials; their candidates planned "
            f"with the open gripper {1000 * PLANNER_CLEARANCE_BEFORE:g} mm over the table, the planner's height then, "
            "unless the row says otherwise), and `onepiece pick-train` "
            "with its defaults (the shipped design; from fresh weights unless the row says its fit started from "
            "the network shipped for the default job's box gripper, `--start-from shipped`), at each label seed "
            "and fit seed; each network judged as "
            f"`onepiece pick` judges it ({result['views']} views an object, its first 3 grasps checked), the network "
            "chooser alone, on the views that judge the shipped network above, executed by the same hand"
            f"{_shipped_words(shipped)}. Nothing here was chosen on either set.", "",
            "| objects | label seed | fit seed | labels | labelling core-seconds | fit seconds | validation views' "
            "top-1 | household first attempt | unseen first attempt | both sets (28 objects) |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
            *(_row(n) for n in networks),
            *(_beside_heuristics(networks, target) if shipped is None else [
                f"| shipped | | | {SHIPPED_LABELS} | | | | {cell(shipped['household'])} | {cell(shipped['unseen'])} "
                f"| {pooled_cell(shipped)} |", "",
                *(line for group in groups.values()
                  for line in (_verdict(group, shipped, target) + _against_first(group, groups), ""))]),
            *(_started_beside(groups) if shipped is None else [])]


def _shipped_words(shipped: dict | None) -> str:
    if shipped is None:
        return " (no network shipped for it when the first of these was judged; each is judged beside the heuristics)"
    return " (shipped: the network shipped for it, the same run's figures)"


HEURISTICS = {"random": "random collision-free candidate", "top_down": "top-down across the narrow axis"}


def _beside_heuristics(networks: list[dict], target: float) -> list[str]:
    """For a hand no network ships for: each network beside random and top-down on the same views, both sets."""
    lines = ["", "Each network judged beside the heuristics on the same views, both sets (28 objects; no network "
             "shipped for this hand when the first of them was judged):", "",
             "| objects | label seed | fit seed | network | "
             + " | ".join(HEURISTICS.values()) + " | network against top-down |", "| --- | --- | --- | --- | "
             + "--- | " * len(HEURISTICS) + "--- |"]
    for n in networks:
        picks = n["picks"]
        others = {m: heuristic_picks(picks, m) for m in HEURISTICS}
        gain = paired_gain([both_sets(picks)], [both_sets(others["top_down"])], VIEWS)
        lines.append(f"| {_source(n)} | {n['label_seed']} | {n['fit_seed']} | {pooled_cell(picks)} | "
                     + " | ".join(pooled_cell(others[m]) for m in HEURISTICS) + f" | {gain_words(gain)} |")
    pooled = [pooled_rate(n["picks"])[0] for n in networks]
    met = sum(rate >= target for rate in pooled)
    return [*lines, "", *_groups_against_top_down(networks),
            f"The first-attempt target over both sets (>= {100 * target:.0f}%) reached by {met} of the "
            f"{len(pooled)} networks: {'**met**' if met == len(pooled) else '**not met**'}.", ""]


def _groups_against_top_down(networks: list[dict]) -> list[str]:
    """Each group of two networks or more (the same objects, height and start) against top-down on the same views
    over both sets, paired over objects over its seeds: one seed alone decides nothing, several may."""
    lines = []
    for group in (g for g in _groups(networks).values() if len(g) > 1):
        top_down = [both_sets(heuristic_picks(n["picks"])) for n in group]
        gain = paired_gain([both_sets(n["picks"]) for n in group], top_down, VIEWS)
        low, high = gain.interval
        where = "above top-down" if low > 0 else "below top-down" if high < 0 else "not shown above top-down"
        lines += [f"The {len(group)} networks on {_source(group[0])}, against top-down on the same views over both "
                  f"sets, paired over objects over the {gain.seeds} networks (label and fit seeds): "
                  f"{100 * gain.gain:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]: **{where}**.", ""]
    return lines


def _same_seeds(networks: list[dict], base: list[dict], set_name: str | None = None
                ) -> tuple[list[dict], list[dict]]:
    """``networks`` and ``base`` paired at the same label and fit seeds (those both hold): their first picks per
    object over both sets, or on ``set_name`` alone."""
    by_seeds = {(n["label_seed"], n["fit_seed"]): n for n in base}
    pairs = [(n, by_seeds[n["label_seed"], n["fit_seed"]]) for n in networks
             if (n["label_seed"], n["fit_seed"]) in by_seeds]

    def picked(n: dict) -> dict[str, int]:
        return both_sets(n["picks"]) if set_name is None else n["picks"][set_name]["per_object"]
    return [picked(n) for n, _ in pairs], [picked(b) for _, b in pairs]


def _base(networks: list[dict], groups: dict[Group, list[dict]]) -> tuple[list[dict], str]:
    """The networks ``networks`` are paired against and what they are: labels made higher over the table against
    those made at the 2 mm before, on the same objects and fitted the same way, where there are such; else a fit
    started from the shipped network against the fresh fits on the same labels; else fresh fits against those
    labelled on FIRST_OBJECTS."""
    objects, height, started = _group(networks[0])
    if height != PLANNER_CLEARANCE_BEFORE and (objects, PLANNER_CLEARANCE_BEFORE, started) in groups:
        return (groups[objects, PLANNER_CLEARANCE_BEFORE, started],
                f"labelled {1000 * PLANNER_CLEARANCE_BEFORE:g} mm over the table on the same objects, fitted the "
                "same way,")
    if started:
        return groups.get((objects, height, None), []), "fitted from fresh weights on the same labels"
    if objects == FIRST_OBJECTS:
        return [], ""
    base = groups.get((FIRST_OBJECTS, height, None), [])
    return base, f"labelled on `{FIRST_OBJECTS}` ({base[0]['made']['labels'] if base else 0} labels)"


def _against_first(networks: list[dict], groups: dict[Group, list[dict]]) -> str:
    """`` Against ...``: ``networks`` against those ``_base`` pairs them with at the same label and fit seeds ('' where
    none pair)."""
    base, against = _base(networks, groups)
    tried, paired = _same_seeds(networks, base)
    if not tried:
        return ""
    gain = paired_gain(tried, paired, VIEWS)
    by_set = "" if label_height(networks[0]) == PLANNER_CLEARANCE_BEFORE else "".join(
        f"; on the {name} set: {gain_words(paired_gain(*_same_seeds(networks, base, name), VIEWS))}" for name in SETS)
    again = (" The planner's options (above) judge such pairs again at 40 views an object."
             if by_set and not networks[0].get("start_from") and networks[0]["made"]["gripper"] == "onepiece_box"
             else "")  # the planner's options judge the box gripper's fresh fits
    return f" Against the networks {against} at the same seeds, over both sets: {gain_words(gain)}{by_set}.{again}"


def _started_beside(groups: dict[Group, list[dict]]) -> list[str]:
    """For a hand judged beside the heuristics: each group of fits started from the shipped network against the
    fresh fits on the same labels at the same seeds."""
    lines = []
    for group in groups.values():
        sentence = _against_first(group, groups).strip() if group[0].get("start_from") else ""
        lines += [sentence, ""] if sentence else []
    return lines


def _verdict(networks: list[dict], shipped: dict, target: float) -> str:
    """``networks`` (one source, one start) against the shipped one, and the target over both sets."""
    gain = paired_gain([both_sets(n["picks"]) for n in networks], [both_sets(shipped)] * len(networks), VIEWS)
    household = paired_gain([n["picks"]["household"]["per_object"] for n in networks],
                            [shipped["household"]["per_object"]] * len(networks), VIEWS)
    pooled = [pooled_rate(n["picks"])[0] for n in networks]
    met = sum(rate >= target for rate in pooled)
    started = _started(networks[0]) and f", each {_started(networks[0])}"
    height = _height(networks[0]) and f", {_height(networks[0])}"
    return (f"Labelled on `{networks[0]['made']['objects']}` ({networks[0]['made']['labels']} labels){height}"
            f"{started}, "
            "against the shipped network on the "
            f"same views, over both sets: {gain_words(gain)}; on the household set alone: {gain_words(household)} "
            "(a network made so replaces the shipped one where the household interval lies above zero: "
            f"{'it does' if household.verdict == 'kept' else 'the shipped one stays'}). The first-attempt target "
            f"over both sets (>= {100 * target:.0f}%) reached by {met} of the {len(pooled)} networks (mean "
            f"{100 * float(np.mean(pooled)):.1f}%): {'**met**' if met == len(pooled) else '**not met**'}.")
