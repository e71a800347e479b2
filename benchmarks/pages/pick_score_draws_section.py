"""Scores steadied over fresh draws of each crop's points (results/pick_score_draws.json,
benchmarks/experiments/pick_score_draws.py): each network with k draws against one, on the same views."""

from __future__ import annotations

from benchmarks.pages.pick_own_section import both_sets, cell, pooled_cell
from benchmarks.pages.pick_trials_section import VIEWS, gain_words
from onepiece_dist.stats.intervals import paired_gain


def score_draws_section(result: dict) -> list[str]:
    runs = {(r["network"], r["draws"]): r["picks"] for r in result["runs"]}
    names = list(dict.fromkeys(r["network"] for r in result["runs"]))
    counts = sorted({r["draws"] for r in result["runs"]})
    lines = [f"## The best candidates scored on fresh draws of their points: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. A crop holds a seeded random subset of the observed points "
             "inside the closing region (as many as the network reads), so its score moves with the draw. With "
             "`PlanSpec.score_draws` k the planner scores its 32 best-scored candidates again on k - 1 fresh draws "
             "of their points (each draw its own stream; `plan.redraw`) and ranks by the mean; the rest keep their "
             f"one score. Each network judged as `onepiece pick` judges it ({result['views']} views an object, its "
             "first 3 grasps checked), the network chooser alone, by the hand it was made for, on the views that "
             "judge the shipped network above:", "",
             "| network | hand | draws | household first attempt | unseen first attempt | both sets (28 objects) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name in names:
        hand = result["networks"][name]["gripper"] or "box (the default job's)"
        for k in counts:
            if (name, k) in runs:
                picks = runs[name, k]
                lines.append(f"| `{name}` | {hand} | {k} | {cell(picks['household'])} | "
                             f"{cell(picks['unseen'])} | {pooled_cell(picks)} |")
    lines.append("")
    for k in counts[1:]:
        pairs = [(runs[n, k], runs[n, 1]) for n in names if (n, k) in runs and (n, 1) in runs]
        if not pairs:
            continue
        both = paired_gain([both_sets(a) for a, _ in pairs], [both_sets(b) for _, b in pairs], VIEWS)
        house = paired_gain([a["household"]["per_object"] for a, _ in pairs],
                            [b["household"]["per_object"] for _, b in pairs], VIEWS)
        lines += [f"{k} draws against one, the networks as seeds, over both sets: {gain_words(both)}; on the household "
                  f"set alone: {gain_words(house)} (kept where the interval over both sets lies above zero).", ""]
    return lines
