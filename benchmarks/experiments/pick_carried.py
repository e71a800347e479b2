"""The default job's network carried to other hands (issue 55: a network out of the box for a hand none ships for):
the shipped box gripper's network planning for each preset hand, its crops cut in that hand's closing region and its
grasps proposed, checked and executed by that hand, judged by `onepiece pick` on the household and unseen sets (8
views an object, the planner's defaults: its first 3 grasps checked), beside the hand's own shipped network and the
top-down baseline on the same views.

    .venv/bin/python -m benchmarks.experiments.pick_carried

The Franka hand and the Robotiq 2F-85 cut their crops in the box gripper's closing region (4 x 8 x 2 cm): there
the carried network sees the shapes it was trained on. The 2F-140's region is wider and deeper: the counter-case.
Results: benchmarks/results/pick_carried.json, rendered on docs/picks.md; the planner's record of what carrying
picks (plan.shipped.carried_summary): onepiece_dist/plan/networks/carried.json.
"""

from __future__ import annotations

import json
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np

from benchmarks.experiments.pick_own_network import ROOT, SETS, VIEWS, hand, judged

HERE = Path(__file__).resolve().parents[1]
HANDS = ("panda", "robotiq_2f85", "robotiq_2f140")
RESULTS = HERE / "results" / "pick_carried.json"


def both_sets(picks: dict) -> dict[str, int]:
    """Object name -> views picked at the first attempt, over both sets."""
    return {name: n for set_name in SETS for name, n in picks[set_name]["per_object"].items()}


def pooled(picks: dict) -> dict:
    """The first-attempt rate over both sets' objects, its interval over objects and its views."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    rates = np.array([n / VIEWS for n in both_sets(picks).values()])
    low, high = bootstrap_interval(rates)
    return {"rate": float(rates.mean()), "interval": [low, high], "views": VIEWS * len(rates)}


def measured(preset: str) -> dict:
    """The carried network and the hand's own on the same views, top-down beside them."""
    from onepiece_dist.plan.shipped import NETWORK, REGION
    from onepiece_dist.specs.job import GripperSpec

    gripper, default, folder = hand(preset), GripperSpec(), ROOT / "data" / "carried" / preset
    start = time.perf_counter()
    carried = judged(NETWORK, "carried", preset, ("top_down",), folder=folder / "carried", carried=True)
    own = judged(None, "own", preset, folder=folder / "own")
    return {"preset": preset, "gripper": gripper.name,
            "same_region": all(getattr(gripper, n) == getattr(default, n) for n in REGION),
            "region": {n: getattr(gripper, n) for n in REGION}, "carried_picks": carried, "own_picks": own,
            "seconds": round(time.perf_counter() - start, 1)}


def record(hands: list[dict]) -> dict:
    """What the planner quotes of carrying (plan.shipped.carried_summary): per hand, pooled over both sets."""
    from onepiece_dist.plan.shipped import NETWORK
    from onepiece_dist.specs.job import GripperSpec

    def top_down(h: dict) -> dict:
        return {s: h["carried_picks"][s]["others"]["top_down"] for s in SETS}

    return {"network": NETWORK.name, "trained_for": GripperSpec().name,
            "made_by": "python -m benchmarks.experiments.pick_carried", "from": "benchmarks/results/pick_carried.json",
            "hands": [{"preset": h["preset"], "gripper": h["gripper"], "same_region": h["same_region"],
                       "carried": pooled(h["carried_picks"]), "own": pooled(h["own_picks"]),
                       "top_down": pooled(top_down(h))} for h in hands]}


def main() -> None:
    from onepiece_dist.plan.shipped import CARRIED

    hands = [measured(preset) for preset in HANDS]
    result = {"command": ".venv/bin/python -m benchmarks.experiments.pick_carried", "date": date.today().isoformat(),
              "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "views": VIEWS, "hands": hands}
    RESULTS.write_text(json.dumps(result, indent=1) + "\n")
    CARRIED.write_text(json.dumps(record(hands), indent=1) + "\n")
    print(RESULTS, CARRIED)


if __name__ == "__main__":
    main()
