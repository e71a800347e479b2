"""The shipped network's recipe labelled again by the planner as it ships (results/pick_relabelled.json,
benchmarks/experiments/pick_relabelled.py): each seed's network against the shipped one on the same views."""

from __future__ import annotations

from benchmarks.pages.pick_own_section import SETS, SHIPPED_LABELS, both_sets, cell, pooled_cell
from benchmarks.pages.pick_table_gap_section import _gain
from benchmarks.pages.pick_trials_section import VIEWS, gain_words
from onepiece_dist.specs.plan import PLANNER_CLEARANCE_BEFORE
from onepiece_dist.stats.intervals import paired_gain


def mm(metres: float) -> str:
    return f"{1000 * metres:g} mm"


def _batch(batch: dict) -> str:
    return (f"| `{batch['folder']}` | `{batch['objects']}` | {batch['labels']} | {100 * batch['success_rate']:.0f}% | "
            f"{'yes' if batch['top_down'] else 'no'} | {mm(batch['table_clearance'])} | "
            f"{batch['core_seconds']:.0f} |")


def _point(point: dict) -> str:
    best = point["best_epoch"]
    return (f"| {point['seed']} | {point['labels']} | {point['fit_seconds']:.0f} | {best['val_ap']:.3f} | "
            f"{cell(point['picks']['household'])} | {cell(point['picks']['unseen'])} | "
            f"{pooled_cell(point['picks'])} |")


def replaces_shipped(seeds: list[dict], shipped: dict) -> bool:
    """Whether the seeds' networks replace the shipped one: the trials' rule, the paired interval over the household
    objects above zero."""
    household = paired_gain([picks["household"]["per_object"] for picks in seeds],
                            [shipped["household"]["per_object"]] * len(seeds), VIEWS)
    return household.verdict == "kept"


def against_shipped(seeds: list[dict], shipped: dict) -> str:
    """The seeds' networks (each seed's picks: set -> {"per_object": ...}) against the shipped one on the same views:
    both sets, each set, and the trials' rule."""
    def gain(picked) -> str:
        return gain_words(paired_gain([picked(picks) for picks in seeds], [picked(shipped)] * len(seeds), VIEWS))
    by_set = "".join(f"; on the {name} set: {gain(lambda picks, n=name: picks[n]['per_object'])}" for name in SETS)
    replaces = "it does" if replaces_shipped(seeds, shipped) else "the shipped one stays"
    return (f"Against the shipped network on the same views, over both sets: {gain(both_sets)}{by_set} (the labels "
            "made again replace the shipped network's where the household interval lies above zero, every trial's "
            f"rule: {replaces}).")


def _more_views(options: dict | None) -> list[str]:
    """The seeds' networks at 40 views an object, where the planner's options judged them (pick_plan_options)."""
    runs = {name: run for name, run in (options or {}).get("variants", {}).items() if "relabelled" in run}
    if not runs:
        return []
    views = next(iter(runs.values()))["views"]
    said = "; ".join(f"seed {run['relabelled']}: {_gain(run['versus']['all objects'])} over both sets, household "
                     f"{_gain(run['versus']['household'])}" for run in runs.values())
    return ["", f"At {views} views an object (the planner's options, above: the `relabelled_` variants), against the "
            f"shipped network on the same views and draws: {said}."]


def relabelled_section(result: dict, options: dict | None = None) -> list[str]:
    points, shipped = result["points"], result["shipped"]
    if not points:
        return []
    heights = sorted({b["table_clearance"] for b in result["batches"]})
    return [f"## The shipped network's labels made again by the planner as it ships: `{result['command']}`", "",
            f"{result['date']}, {result['machine']}. The shipped network was fitted on labels whose candidates were "
            f"planned with the open gripper {mm(PLANNER_CLEARANCE_BEFORE)} over the table, the planner's height "
            f"then; it plans {' and '.join(mm(h) for h in heights)} over it. Its two label batches labelled again "
            "by today's planner (the same objects, views, seeds and executions' protocol; the first executing the "
            "top-down grasps, as the shipped network's did):", "",
            "| folder | objects | labels | picked | top-down grasps executed | open gripper over the table | "
            "labelling core-seconds |", "| --- | --- | --- | --- | --- | --- | --- |",
            *(_batch(b) for b in result["batches"]), "",
            f"`{result['design']}` (the shipped design) fitted on all of them at each seed, judged as `onepiece pick` "
            "judges the shipped network (8 views an object, its first 3 grasps checked), the network chooser alone, "
            "on the views that judge it above; shipped: its figures on those views (pick_own_network's shipped row).",
            "", "| seed | labels | fit seconds | held-out AP | household first attempt | unseen first attempt | "
            "both sets (28 objects) |", "| --- | --- | --- | --- | --- | --- | --- |",
            *(_point(p) for p in points),
            f"| shipped | {SHIPPED_LABELS} | | | {cell(shipped['household'])} | {cell(shipped['unseen'])} | "
            f"{pooled_cell(shipped)} |", "", against_shipped([p["picks"] for p in points], shipped),
            *_more_views(options)]
