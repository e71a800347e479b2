"""The pick learning curve and the design trials on docs/picks.md, from results/pick_curve.json
(benchmarks/experiments/pick_curve.py), and its picture docs/picks/curve.png drawn from the same figures, the
heuristics and the oracle of results/picks.json drawn flat beside it."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PICTURE = ROOT / "docs" / "picks" / "curve.png"
DESIGN_WORDS = {
    "context": "crop + context (gravity, object offset in the gripper frame), every-trial target",
    "crop_only": "crop alone (no context), every-trial target",
    "context_balanced": "crop + context, balanced batches",
    "context_share": "crop + context, target: the share of trials that held",
    "context_wide": "crop + context, PointNet at width 64 (four times the compute of width 32)",
    "context_listwise": "crop + context, every-trial target plus a listwise term pushing each view's successes "
                        "above its failures (batches of whole views)",
}
FLAT = ("random", "analytic", "top_down", "oracle")


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def _first(point: dict) -> dict:
    return point["picks"]["methods"]["network"]


def curve_section(curve: dict, picks: dict | None) -> list[str]:
    labels = curve["labels"]
    spec = labels["spec"]
    rows = [f"| {p['design']} | {p['labels']} | {p['core_seconds']:.0f} | {p['best_epoch']['val_ap']:.2f} | "
            f"{p['best_epoch']['val_view_top1']:.2f} | {_pct(_first(p)['first_attempt'])} "
            f"[{_pct(_first(p)['interval'][0])}, {_pct(_first(p)['interval'][1])}] |"
            for p in sorted(curve["points"], key=lambda p: (p["design"], p["labels"]))]
    designs = sorted({p["design"] for p in curve["points"]})
    specs = labels.get("specs") or [spec]
    batches = " and ".join(f"`{b['objects']}`" for b in specs)
    lines = ["## The pick learning curve: `" + curve["command"] + "`", "",
             f"{curve['date']}, {curve['machine']}. Pick labels: {labels['rows']} executions on {labels['objects']} "
             f"training objects ({len(specs)} batch{'es' * (len(specs) > 1)}: {batches}), {spec['views']} views "
             f"each, {spec['per_view']} of each view's candidates executed by the pick protocol (success rate "
             f"{labels['success_rate']:.2f}), {labels['core_seconds']:.0f} core-seconds. Each point: a network "
             "fitted on a seeded random subset of the labels (points up to the first batch's size drew from the "
             "first batch; validation: 10% of the objects), judged by first-attempt picks on the household set "
             "(network chooser alone, the same views as above). Core-seconds: the labels' share of the labelling "
             "plus the fit. The household views that judge these points are those of the benchmark above: the "
             "shipped design was chosen on them (the largest point of each design, the best of those; a design "
             "whose largest network picks within one design's spread over seeds of the shipped one (Rankings "
             "tried, below) does not replace it: benchmarks/experiments/ship_network.py).", "",
             "![pick learning curve](picks/curve.png)", "",
             "| design | labels | core-seconds | val AP | val view top-1 | household first attempt [95% CI] |",
             "| --- | --- | --- | --- | --- | --- |", *rows, "", "Designs tried:", ""]
    lines += [f"- `{d}`: {DESIGN_WORDS.get(d, d)}{_design_verdict(curve, d)}" for d in designs]
    return lines


def _design_verdict(curve: dict, design: str) -> str:
    mine = sorted((p for p in curve["points"] if p["design"] == design), key=lambda p: p["labels"])
    largest = mine[-1]
    return f"; at {largest['labels']} labels it picks {_pct(_first(largest)['first_attempt'])}."


def draw_curve(curve: dict | None, picks: dict | None) -> None:
    """docs/picks/curve.png from the committed results (the report's main draws it; rendering the page does not)."""
    import importlib.util

    if curve is None:
        return
    if importlib.util.find_spec("matplotlib") is None:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    for design in sorted({p["design"] for p in curve["points"]}):
        mine = sorted((p for p in curve["points"] if p["design"] == design), key=lambda p: p["labels"])
        xs = [p["labels"] for p in mine]
        ys = [100 * _first(p)["first_attempt"] for p in mine]
        low = [100 * _first(p)["interval"][0] for p in mine]
        high = [100 * _first(p)["interval"][1] for p in mine]
        ax.plot(xs, ys, marker="o", label=design)
        ax.fill_between(xs, low, high, alpha=0.12)
    ax.set_xscale("log")
    left = min(p["labels"] for p in curve["points"])
    if picks is not None:
        household = next(s for s in picks["sets"] if s["name"] == "household")
        for m in household["methods"]:
            if m["method"] in FLAT:
                ax.axhline(100 * m["first_attempt"], linestyle="--", linewidth=1, color="grey")
                ax.text(left, 100 * m["first_attempt"] + 1, m["method"].replace("_", "-"), fontsize=7, color="grey")
    ax.axhline(85, linestyle=":", color="red", linewidth=1)
    ax.text(left, 86, "target 85%", fontsize=7, color="red")
    ax.set_ylim(0, 100)
    ax.set_xlabel("pick labels")
    ax.set_ylabel("household first-attempt picks (%)")
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    PICTURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(PICTURE, metadata={"Software": None})
    plt.close(fig)


RANKING_WORDS = {
    "network": "the network's score (the product)",
    "jittered": "the mean score of the candidate and 8 copies at the label's pose noise (the 16 best scored again)",
    "jittered_x2": "the same at twice the label's pose noise",
    "ensemble_2": "the mean score of the shipped network and the curve's `context` network at 81152 labels",
    "ensemble_4": "the mean score of those two, `context` at 121858 labels and `context_wide` at 40960",
    "flipped": "the mean score of the candidate and of the same grasp turned half a turn about its approach",
    "ensemble_4_flipped": "the mean of `ensemble_4` and of its four networks' scores of the turned grasps",
    "with_top_down": "the network's best of the view's candidates and the three top-down grasps (all scored by it)",
    "top_down_vetted": "the first top-down grasp the network scores at least 0.5, else the network's choice",
    "view_input_base": "a network fitted on the first label batch's views whose cameras were found again "
                       "(`pick_view_input`), the stored context",
    "view_input": "the same labels and fit, with the direction to the camera in the gripper frame as an input",
    "view_input_base_seed1": "`view_input_base` fitted again with another seed (validation objects, initial "
                             "weights, batches)",
}


def rankings_section(rankings: dict) -> list[str]:
    """Rankings of the shipped network's scores tried as choosers (results/pick_rankings.json): chosen on the
    selection set, judged on the household set; kept only where both rise."""
    sets = {s["name"]: s for s in rankings["sets"]}
    chosen, judged = sets["selection"], sets["household"]

    def cell(result: dict, name: str) -> str:
        r = result["rankings"][name]
        return f"{_pct(r['first_attempt'])} [{_pct(r['interval'][0])}, {_pct(r['interval'][1])}]"

    names = list(chosen["rankings"])
    rows = [f"| `{n}`: {RANKING_WORDS.get(n, _prior_words(n))} | {cell(chosen, n)} | {cell(judged, n)} |"
            for n in names]
    base = chosen["rankings"]["network"]["first_attempt"], judged["rankings"]["network"]["first_attempt"]
    best = max(names[1:], key=lambda n: chosen["rankings"][n]["first_attempt"])
    rises = (chosen["rankings"][best]["first_attempt"] > base[0], judged["rankings"][best]["first_attempt"] > base[1])
    verdict = (f"The best on the selection set, `{best}`, "
               f"{'rises' if rises[0] else 'does not rise'} there and "
               f"{'rises' if rises[1] else 'does not rise'} on the household set: "
               f"{'kept' if all(rises) else 'not kept; the product ranks by the network score alone'}.")
    return ["## Rankings tried: `.venv/bin/python -m benchmarks.experiments.pick_rankings`", "",
            "The scores of the network shipped before the top-down trial was kept (`context_balanced`, 81152 "
            "labels) ranked other ways, other networks' scores and a pool with the top-down grasps, first attempt "
            "only; each ranking chosen on "
            f"{chosen['views']} views of {chosen['loaded']} procedural objects the network never saw "
            f"(`{chosen['objects']}`), judged on the {judged['views']} household views.", "",
            "| ranking | selection first attempt [95% CI] | household first attempt [95% CI] |",
            "| --- | --- | --- |", *rows, "", verdict, *_view_input_lines(chosen, judged)]


def _view_input_lines(chosen: dict, judged: dict) -> list[str]:
    """The camera's direction as an input, against the same fit without it and, where measured, the spread of
    that fit by its seed alone (nothing when the networks were not judged)."""
    names = ("view_input", "view_input_base", "view_input_base_seed1")
    if not set(names) <= set(chosen["rankings"]):
        return []
    sets = (("selection", chosen), ("household", judged))
    rate = {(n, label): 100 * result["rankings"][n]["first_attempt"] for label, result in sets for n in names}
    gains = {label: rate["view_input", label] - rate["view_input_base", label] for label, _ in sets}
    spread = {label: abs(rate["view_input_base_seed1", label] - rate["view_input_base", label]) for label, _ in sets}
    within = [label for label, _ in sets if gains[label] <= spread[label]]
    verdict = ("kept" if not within else "not kept: the gain is within the seed's spread on the "
               + " and ".join(f"{label} set" for label in within))
    words = " on the selection set, ".join(f"{gains[label]:+.1f} points" for label, _ in sets)
    moves = " and ".join(f"{spread[label]:.1f}" for label, _ in sets)
    return ["", f"The direction to the camera as an input (`view_input` against the same labels and fit without it, "
            f"`view_input_base`): {words} on the household set; `view_input_base` fitted again with another seed "
            f"moves by {moves} points on the same sets: {verdict}."]


def pool_size_lines(pool: dict) -> list[str]:
    """More candidates per view for the network to rank (results/pick_pool_size.json)."""
    points = sorted(pool["points"], key=lambda p: (p["set"] != "selection", p["candidates"]))
    rows = [f"| {p['set']} | {p['candidates']} | {_pct(p['first_attempt'])} [{_pct(p['interval'][0])}, "
            f"{_pct(p['interval'][1])}] |" for p in points]
    smallest = min(p["candidates"] for p in points)
    default = {p["set"]: p["first_attempt"] for p in points if p["candidates"] == smallest}
    rises = [p for p in points if p["candidates"] > smallest and p["first_attempt"] > default[p["set"]]]
    verdict = ("More candidates raise the first attempt on " + ", ".join(sorted({p['set'] for p in rises}))
               if rises else "More candidates raise the first attempt on neither set: the default stays")
    return ["More candidates per view for the network to rank (`.venv/bin/python -m "
            "benchmarks.experiments.pick_pool_size`; the network alone):", "",
            "| set | candidates per view | first attempt [95% CI] |", "| --- | --- | --- |", *rows, "", verdict + "."]


def _prior_words(name: str) -> str:
    weight = name.removeprefix("top_prior_")
    return f"the score plus {weight} x how straight down the approach points (a top-down prior)"
