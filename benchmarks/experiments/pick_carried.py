"""The default job's network carried to other hands (issue 55: a network out of the box for a hand none ships for):
the shipped box gripper's network planning for each hand, its grasps proposed, checked and executed by that hand and
its crops cut in its own closing region, judged by `onepiece pick` on the household and unseen sets (8 views an
object, the planner's defaults: its first 3 grasps checked), beside the hand's own shipped network where one ships
and the top-down baseline on the same views; for a hand none ships for, also the network its refusal's fix makes
(`onepiece pick-labels --gripper` and `onepiece pick-train` with their defaults).

    .venv/bin/python -m benchmarks.experiments.pick_carried [--hands panda,robotiq_2f140]

Hands: the three presets (the Franka hand and the Robotiq 2F-85 have the box gripper's 4 x 8 x 2 cm closing region;
the 2F-140's is 5 x 14 x 2 cm) and the Franka Panda read from pybullet_data's URDF (`gripper: {urdf: ...}`: 5 cm
fingers, the URDF's 20 N; no network ships for it). ``--hands`` measures those again, keeping the others' results.
Results: benchmarks/results/pick_carried.json, rendered on docs/picks.md; the planner's record of what carrying
picks (plan.shipped.carried_summary): onepiece_dist/plan/networks/carried.json.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_own_network import ROOT, SETS, VIEWS, given, hand, judged
from benchmarks.pages.pick_own_section import both_sets, pooled_rate

HERE = Path(__file__).resolve().parents[1]
RESULTS = HERE / "results" / "pick_carried.json"


def hands() -> dict[str, str | dict]:
    """Each hand measured: its name here -> what `hand` takes."""
    return {"panda": "panda", "robotiq_2f85": "robotiq_2f85", "robotiq_2f140": "robotiq_2f140",
            "panda_urdf": given("panda_urdf")}


def pooled(picks: dict) -> dict:
    """The first-attempt rate over both sets' objects, its interval over objects and its views."""
    rate, (low, high) = pooled_rate(picks)
    return {"rate": rate, "interval": [low, high], "views": VIEWS * len(both_sets(picks))}


def measured(name: str, given: str | dict) -> dict:
    """The carried network and, where one ships, the hand's own on the same views, top-down beside them."""
    from onepiece_dist.plan.shipped import NETWORK, REGION, SHIPPED
    from onepiece_dist.specs.job import GripperSpec

    gripper, default, folder = hand(given), GripperSpec(), ROOT / "data" / "carried" / name
    start = time.perf_counter()
    carried = judged(NETWORK, "carried", given, ("top_down",), folder=folder / "carried", carried=True)
    own = judged(None, "own", given, folder=folder / "own") if gripper.name in SHIPPED else None
    made = None if own else made_network(given, folder)
    return {"hand": name, "gripper": gripper.name, "region": {n: getattr(gripper, n) for n in REGION},
            "same_region": all(getattr(gripper, n) == getattr(default, n) for n in REGION),
            "carried_picks": carried, "own_picks": own, "made": made,
            "seconds": round(time.perf_counter() - start, 1)}


def made_network(given: str | dict, folder: Path) -> dict:
    """For a hand none ships for, the fix its refusal names: `onepiece pick-labels --gripper` with its defaults and
    `onepiece pick-train` (the shipped design, seed 0), judged on the same views."""
    from onepiece_dist.learn.pick_network import SHIPPED_DESIGN, design_options, train_pick_network
    from onepiece_dist.picks.pick_labels import labels_made, run_pick_labels
    from onepiece_dist.specs.plan import PickLabelSpec
    from onepiece_dist.store.pick_labels import read_pick_labels

    spec = PickLabelSpec(output=str(folder / "labels"), gripper=given)
    path = labels_made(spec) or run_pick_labels(spec)
    made = read_pick_labels(path)
    network = train_pick_network(path, folder / "net", design_options(SHIPPED_DESIGN, 0))
    return {"labels": len(made), "objects": spec.objects, "success_rate": round(float(made.success.mean()), 4),
            "core_seconds": made.attrs["core_seconds"], "wall_seconds": made.attrs["wall_seconds"],
            "fit_seconds": round(network.result.seconds, 1), "validation": network.to_json()["validation"],
            "picks": judged(network.result.checkpoint, "made", given, folder=folder / "made")}


def record(measures: list[dict]) -> dict:
    """What the planner quotes of carrying (plan.shipped.carried_summary): per hand, pooled over both sets."""
    from onepiece_dist.plan.shipped import NETWORK
    from onepiece_dist.specs.job import GripperSpec

    def top_down(h: dict) -> dict:
        return {s: h["carried_picks"][s]["others"]["top_down"] for s in SETS}

    return {"network": NETWORK.name, "trained_for": GripperSpec().name,
            "made_by": "python -m benchmarks.experiments.pick_carried", "from": "benchmarks/results/pick_carried.json",
            "hands": [{"hand": h["hand"], "region": h["region"],
                       "gripper": h["gripper"] + (" read from its URDF" if h["hand"].endswith("_urdf") else ""),
                       "carried": pooled(h["carried_picks"]), "own": h["own_picks"] and pooled(h["own_picks"]),
                       "top_down": pooled(top_down(h))} for h in measures]}


def main() -> None:
    from onepiece_dist.plan.shipped import CARRIED

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hands", default=",".join(hands()), help="Hands to measure (again).")
    wanted = parser.parse_args().hands.split(",")
    kept = {h["hand"]: h for h in json.loads(RESULTS.read_text())["hands"]} if RESULTS.is_file() else {}
    for name, fields in hands().items():
        if name not in wanted:
            continue
        kept[name] = measured(name, fields)
        ordered = [kept[k] for k in hands() if k in kept]  # written as each hand lands
        result = {"command": ".venv/bin/python -m benchmarks.experiments.pick_carried", "views": VIEWS,
                  "date": date.today().isoformat(), "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}",
                  "hands": ordered}
        RESULTS.write_text(json.dumps(result, indent=1) + "\n")
        CARRIED.write_text(json.dumps(record(ordered), indent=1) + "\n")
        print(name, RESULTS, CARRIED, flush=True)


if __name__ == "__main__":
    main()
