"""The network shipped with the package (issue 56, onepiece_dist/plan/shipped.py): the pick learning curve's best
design at its largest size (benchmarks/results/pick_curve.json, data/pick_curve/), or, where the top-down trial is
kept (benchmarks/results/pick_top_down.json; the trials' paired rule, docs/picks.md), the kept trial's seed-0
network (the top-down trial's, or of a trial judged against it that is kept: pick_points.json,
pick_top_down_both.json, pick_schedule.json, pick_outline.json, pick_top_draws.json; a seed is never chosen),
copied into onepiece_dist/plan/networks/pick_view.pt with its record; after the pick benchmark
(benchmarks/experiments/picks.py) has judged it, run again with --record-picks to write its household figures into
the record. With --gripper panda it ships the Franka hand's network instead (pick_panda_2mm.json's seed 0, with the
figures the benchmark gave it on that hand) as onepiece_dist/plan/networks/pick_view_panda.pt. With --gripper
robotiq_2f85 (or robotiq_2f140) it ships the network `onepiece pick-labels` and `onepiece pick-train` made with
their defaults for that hand (benchmarks/experiments/pick_own_network.py, seed 0) as pick_view_robotiq_2f85.pt.
With --record-picks and --gripper, that hand's record takes its figures at the planner's default from
pick_table_gap's run for the hand (its first 8 views an object: the benchmark's views and draws).

    .venv/bin/python -m benchmarks.experiments.ship_network [--record-picks]
        [--gripper panda|robotiq_2f85|robotiq_2f140]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent


def best_point(curve: dict, shipped: str | None = None, spread: float = 0.0) -> dict:
    """The design whose largest network picks most on the household views; ties go to the network cheaper to run
    (fewer weights: a robot plans with it), then to fewer labels. The ``shipped`` design stays unless the best
    picks more than ``spread`` (a rate) above it: a gain within one design's spread over seeds is not one."""
    largest = {}
    for point in curve["points"]:
        if point["labels"] >= largest.get(point["design"], {"labels": -1})["labels"]:
            largest[point["design"]] = point
    best = max(largest.values(), key=lambda p: (_rate(p), -weights(p["options"]["model"]), -p["labels"]))
    incumbent = largest.get(shipped)
    return incumbent if incumbent is not None and _rate(best) - _rate(incumbent) <= spread else best


def _rate(point: dict) -> float:
    return point["picks"]["methods"]["network"]["first_attempt"]


def seed_spread() -> float:
    """How far one design's network fitted again with another seed moves on the household views
    (results/pick_rankings.json: view_input_base against view_input_base_seed1); 0 where not measured."""
    path = HERE / "results" / "pick_rankings.json"
    sets = json.loads(path.read_text())["sets"] if path.is_file() else []
    rankings = next((s["rankings"] for s in sets if s["name"] == "household"), {})
    if not {"view_input_base", "view_input_base_seed1"} <= set(rankings):
        return 0.0
    return abs(rankings["view_input_base_seed1"]["first_attempt"] - rankings["view_input_base"]["first_attempt"])


def weights(model: str) -> int:
    """How many weights the model ``model`` has."""
    from onepiece_dist.learn.models import MODELS

    return sum(t.numel() for t in MODELS[model]().parameters())


def ship(point: dict, curve: dict) -> dict:
    """The curve's ``point`` shipped."""
    return _ship(point, " + ".join(spec["objects"] for spec in trained_on(point, curve)),
                 "python -m benchmarks.experiments.pick_curve",
                 _household(point["picks"]["methods"]["network"], "benchmarks/results/pick_curve.json"))


# trials judged against the top-down trial's networks, fitted on or beside its labels
FOLLOWERS = ("pick_points", "pick_top_down_both", "pick_schedule", "pick_outline", "pick_top_draws")
TRIAL_OBJECTS = {"pick_top_down_both": "{0} (labels executing the top-down grasps) + {1} (the same)",
                 "pick_top_draws": "{0} (labels executing the top-down grasps) + {1} + {0} (the shipped network's "
                                   "best grasps drawn again)"}


def kept_trial(top_down: dict | None, followers: dict[str, dict | None]) -> tuple[str, dict] | None:
    """(the trial's results name, its seed-0 point) of the trial kept on the household set: of the ``followers``
    (results name -> results, each judged against the top-down trial's networks) kept, the one that gains most;
    else the top-down trial where kept; else None (the curve's best ships)."""
    from benchmarks.pages.pick_trials_section import gains_over_top_down, top_down_gains

    if top_down is None or top_down_gains(top_down)[0]["household"].verdict != "kept":
        return None
    gains = {name: gains_over_top_down(result, top_down)["household"]
             for name, result in followers.items() if result is not None}
    kept = [name for name, gain in gains.items() if gain.verdict == "kept"]
    name = max(kept, key=lambda n: gains[n].gain) if kept else "pick_top_down"
    point = next((p for p in (followers.get(name) or top_down)["points"] if p["seed"] == 0), None)
    return None if point is None else (name, point)


def ship_trial(name: str, point: dict) -> dict:
    """A kept trial's ``point`` shipped: fitted on the labels that executed the top-down grasps, it plans with
    them in its pool (plan.top_down)."""
    from benchmarks.experiments.pick_curve import BATCHES

    objects = TRIAL_OBJECTS.get(name, "{0} (labels executing the top-down grasps) + {1}")
    return _ship(point, objects.format(BATCHES[0][0], BATCHES[1][0]), f"python -m benchmarks.experiments.{name}",
                 _household(point["with_pool"]["household"], f"benchmarks/results/{name}.json"), pool=POOL)


POOL = "the view's sampled candidates and the three top-down grasps (plan.top_down)"


def _household(household: dict, source: str) -> dict:
    """A trial's household first attempt (``first_attempt``, ``interval``; its views not kept) as a record keeps
    it."""
    return {"household_first_attempt": {"rate": household["first_attempt"], "interval": household["interval"],
                                         "views": None, "from": source}}


def _ship(point: dict, objects: str, made_by: str, figures: dict, pool: str | None = None,
          network: Path | None = None) -> dict:
    """``point``'s checkpoint copied to ``network`` (default: the default job's gripper's, plan.shipped.NETWORK)
    with its record beside it, its pick ``figures`` (_household, _figures) in it."""
    from onepiece_dist.plan.shipped import NETWORK

    network = network or NETWORK
    saved = torch.load(ROOT / point["checkpoint"], map_location="cpu", weights_only=True)
    network.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"model": saved["model"], "state_dict": saved["state_dict"], "crop": saved["crop"]}, network)
    gripper = saved["crop"]["gripper"]["name"]
    record = {"design": point["design"], "model": saved["model"], "labels": point["labels"],
              "training_objects": objects,
              "trained_by": f"{made_by}, then python -m benchmarks.experiments.ship_network",
              **({"pool": pool} if pool else {}), **({"gripper": gripper} if network != NETWORK else {}), **figures}
    network.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    return record


def trained_on(point: dict, curve: dict) -> list[dict]:
    """The label batches' specs the point's network was fitted on (its first ``batches``)."""
    specs = curve["labels"].get("specs") or [curve["labels"]["spec"]]
    return specs[: point.get("batches", 1)]


def record_picks() -> dict:
    """The record with the committed pick benchmark's household figures (both sets) for the shipped network."""
    from onepiece_dist.plan.shipped import RECORD

    record = json.loads(RECORD.read_text())
    picks = json.loads((HERE / "results" / "picks.json").read_text())
    record.update(_figures(picks["sets"], "benchmarks/results/picks.json"))
    RECORD.write_text(json.dumps(record, indent=1) + "\n")
    return record


def record_hand_picks(gripper: str) -> dict:
    """The record of the network shipped for the preset ``gripper`` with its figures at the planner's default
    (hand_figures)."""
    from benchmarks.experiments.pick_own_network import hand
    from onepiece_dist.plan.shipped import network_path

    record_path = network_path(hand(gripper)).with_suffix(".json")
    record = {**json.loads(record_path.read_text()), **hand_figures(gripper)}
    record_path.write_text(json.dumps(record, indent=1) + "\n")
    return record


def hand_figures(gripper: str) -> dict:
    """The first attempts on the household and unseen sets of the network shipped for ``gripper`` at the
    planner's default: pick_table_gap_<gripper>.json's run at ``PlanSpec().table_clearance``, its first VIEWS
    views an object (the pick benchmark's views and draws: the box gripper's run gives picks.json's figures)."""
    from benchmarks.experiments.picks import VIEWS
    from benchmarks.pages.pick_sets import pooled, views_kept
    from onepiece_dist.specs.plan import PlanSpec

    source = "benchmarks/results/pick_table_gap" + ("" if gripper == "default" else f"_{gripper}") + ".json"
    run = json.loads((ROOT / source).read_text())["runs"][f"{PlanSpec().table_clearance:g}"]
    figures = {}
    for judged in views_kept(run["sets"], lambda view: view < VIEWS):
        network = pooled([judged], "network")
        figures[f"{judged['name']}_first_attempt"] = {
            "rate": network["first_attempt"], "interval": list(network["first_attempt_interval"]),
            "views": network["views"], "from": f"{source} (the planner's default, its first {VIEWS} views an object)"}
    return figures


def _figures(sets: list[dict], source: str) -> dict:
    """The network's first attempts on the household and unseen ``sets`` (a pick benchmark's), as a record keeps
    them."""
    figures = {}
    for name, key in (("household", "household_first_attempt"), ("unseen", "unseen_first_attempt")):
        found = next((s for s in sets if s["name"] == name), None)
        if found is not None:
            network = next(m for m in found["methods"] if m["method"] == "network")
            figures[key] = {"rate": network["first_attempt"], "interval": network["first_attempt_interval"],
                            "views": network["views"], "from": source}
    return figures


def ship_panda() -> dict:
    """The Franka hand's network (results/pick_panda_2mm.json at seed 0: a seed is never chosen) shipped for the panda
    preset (plan.shipped.SHIPPED), with the figures the pick benchmark gave it on that hand."""
    from benchmarks.experiments.pick_panda import SHIPPED
    from onepiece_dist.gripper.presets import gripper_fields
    from onepiece_dist.plan.shipped import network_path
    from onepiece_dist.specs.job import GripperSpec

    source = str(SHIPPED.relative_to(ROOT))
    result = json.loads(SHIPPED.read_text())
    point = next(p for p in result["points"] if p["seed"] == 0)
    objects = " + ".join(b["objects"] + (" (labels executing the top-down grasps)" if b["top_down"] else "")
                         for b in result["batches"])
    network = network_path(GripperSpec.model_validate(gripper_fields(result["gripper"])))
    return _ship(point["network"], objects, "python -m benchmarks.experiments.pick_panda",
                 _figures(point["sets"], source), POOL, network)


def ship_own(gripper: str) -> dict:
    """A network made by the two commands (pick-labels' default objects, label seed 0, fit seed 0: a seed is never
    chosen; results/pick_own_network_<gripper>.json) shipped for the preset ``gripper``, one no network shipped for,
    with the figures that judged it."""
    from benchmarks.experiments.pick_own_network import hand
    from onepiece_dist.plan.shipped import network_path
    from onepiece_dist.specs.plan import PICK_LABEL_OBJECTS

    source = f"benchmarks/results/pick_own_network_{gripper}.json"
    result = json.loads((ROOT / source).read_text())
    made = next(n for n in result["networks"] if n["made"]["objects"] == PICK_LABEL_OBJECTS
                and (n["label_seed"], n["fit_seed"]) == (0, 0) and not n.get("start_from"))
    point = {"checkpoint": made["network"]["checkpoint"], "design": made["network"]["design"],
             "labels": made["made"]["labels"]}
    figures = {f"{name}_first_attempt": {"rate": made["picks"][name]["first_attempt"],
                                         "interval": made["picks"][name]["interval"],
                                         "views": made["picks"][name]["views"], "from": source}
               for name in ("household", "unseen")}
    return _ship(point, PICK_LABEL_OBJECTS, "onepiece pick-labels and onepiece pick-train (python -m "
                 "benchmarks.experiments.pick_own_network)", figures, POOL, network_path(hand(gripper)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record-picks", action="store_true")
    parser.add_argument("--gripper", choices=("default", "panda", "robotiq_2f85", "robotiq_2f140"), default="default",
                        help="panda: ship the Franka hand's network (benchmarks/experiments/pick_panda.py); "
                             "robotiq_2f85, robotiq_2f140: a network made by the two commands (pick_own_network.py)")
    args = parser.parse_args()
    if args.record_picks and args.gripper != "default":
        print(record_hand_picks(args.gripper))
        return
    if args.gripper == "panda":
        print(ship_panda())
        return
    if args.gripper != "default":
        print(ship_own(args.gripper))
        return
    if args.record_picks:
        print(record_picks())
        return
    from onepiece_dist.plan.shipped import RECORD

    curve = json.loads((HERE / "results" / "pick_curve.json").read_text())
    shipped = json.loads(RECORD.read_text())["design"] if RECORD.is_file() else None
    from benchmarks.pages.committed import load

    trial = kept_trial(load("pick_top_down"), {name: load(name) for name in FOLLOWERS})
    print(ship_trial(*trial) if trial is not None else ship(best_point(curve, shipped, seed_spread()), curve))


if __name__ == "__main__":
    main()
