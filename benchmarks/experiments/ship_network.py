"""The network shipped with the package (issue 56, onepiece_dist/plan/shipped.py): the pick learning curve's best
design at its largest size (benchmarks/results/pick_curve.json, data/pick_curve/), copied into
onepiece_dist/plan/networks/pick_view.pt with its record; after the pick benchmark (benchmarks/experiments/picks.py)
has judged it, run again with --record-picks to write its household figures into the record.

    .venv/bin/python -m benchmarks.experiments.ship_network [--record-picks]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent


def best_point(curve: dict) -> dict:
    """The design whose largest network picks most on the household views; ties go to the network cheaper to run
    (fewer weights: a robot plans with it), then to fewer labels."""
    largest = {}
    for point in curve["points"]:
        if point["labels"] >= largest.get(point["design"], {"labels": -1})["labels"]:
            largest[point["design"]] = point
    return max(largest.values(), key=lambda p: (p["picks"]["methods"]["network"]["first_attempt"],
                                                -weights(p["options"]["model"]), -p["labels"]))


def weights(model: str) -> int:
    """How many weights the model ``model`` has."""
    from onepiece_dist.learn.models import MODELS

    return sum(t.numel() for t in MODELS[model]().parameters())


def ship(point: dict, curve: dict) -> dict:
    from onepiece_dist.plan.shipped import NETWORK, RECORD

    saved = torch.load(ROOT / point["checkpoint"], map_location="cpu", weights_only=True)
    NETWORK.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"model": saved["model"], "state_dict": saved["state_dict"], "crop": saved["crop"]}, NETWORK)
    record = {"design": point["design"], "model": saved["model"], "labels": point["labels"],
              "training_objects": " + ".join(spec["objects"] for spec in trained_on(point, curve)), "trained_by":
              "python -m benchmarks.experiments.pick_curve, then python -m benchmarks.experiments.ship_network",
              "household_first_attempt": {"rate": point["picks"]["methods"]["network"]["first_attempt"],
                                          "interval": point["picks"]["methods"]["network"]["interval"],
                                          "views": None, "from": "benchmarks/results/pick_curve.json"}}
    RECORD.write_text(json.dumps(record, indent=1) + "\n")
    return record


def trained_on(point: dict, curve: dict) -> list[dict]:
    """The label batches' specs the point's network was fitted on (its first ``batches``)."""
    specs = curve["labels"].get("specs") or [curve["labels"]["spec"]]
    return specs[: point.get("batches", 1)]


def record_picks() -> dict:
    """The record with the committed pick benchmark's household figures for the shipped network."""
    from onepiece_dist.plan.shipped import RECORD

    record = json.loads(RECORD.read_text())
    picks = json.loads((HERE / "results" / "picks.json").read_text())
    household = next(s for s in picks["sets"] if s["name"] == "household")
    network = next(m for m in household["methods"] if m["method"] == "network")
    record["household_first_attempt"] = {"rate": network["first_attempt"],
                                         "interval": network["first_attempt_interval"], "views": network["views"],
                                         "from": "benchmarks/results/picks.json"}
    RECORD.write_text(json.dumps(record, indent=1) + "\n")
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record-picks", action="store_true")
    args = parser.parse_args()
    if args.record_picks:
        print(record_picks())
        return
    curve = json.loads((HERE / "results" / "pick_curve.json").read_text())
    point = best_point(curve)
    print(ship(point, curve))


if __name__ == "__main__":
    main()
