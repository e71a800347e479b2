"""How low the open gripper may go over the table (issue 55). The planner pushes each sampled hand in until its
open gripper meets an observed point or comes within ``PlanSpec.table_clearance`` of the support plane (2 mm).
Of the shipped network's first attempts on the benchmark's views, those whose fingertips stopped within 5 mm of the
table picked 7 of 12 against 56 of 74 at 5-10 mm (a diagnosis of both sets' first grasps, not committed), and the
top-down grasp a user tries first keeps its fingertips 5 mm above the object's lowest point. Each height the
planner keeps is judged here: the shipped network's chooser alone (its first 3 grasps checked, as the product
plans), the household and unseen sets at 40 views an object (the first 8 the benchmark's, the other 32 seen by no
choice made before), paired over objects against the 2 mm the planner used.

    .venv/bin/python -m benchmarks.experiments.pick_table_gap [--gaps 0.002,0.008] [--gripper panda|robotiq_2f85|...]

With ``--gripper panda`` (or robotiq_2f85, robotiq_2f140) the network shipped for that preset hand plans, checks
and executes (results/pick_table_gap_panda.json, and so on).
Results: benchmarks/results/pick_table_gap.json (a height run again replaces its own results only), rendered into
docs/picks.md by benchmarks/pages/pick_table_gap_section.py.
"""

from __future__ import annotations

import json
import platform
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_own_network import hand
from benchmarks.experiments.pick_panda_check import slim
from benchmarks.pages.pick_sets import paired_first_attempts as paired

RESULTS = HERE / "results" / "pick_table_gap.json"
COMMAND = ".venv/bin/python -m benchmarks.experiments.pick_table_gap"
SETS = ("household", "unseen")
GAPS = (0.002, 0.005, 0.008, 0.012)  # m: PlanSpec.table_clearance judged; the first is the planner's before
VIEWS = 40  # an object: the benchmark's 8, then 32 no choice was made on


def network(name: str) -> Path:
    """The network shipped for the hand ``name`` (a preset's name, or default: the default job's box gripper)."""
    from onepiece_dist.plan.shipped import shipped_network

    return shipped_network(hand(None if name == "default" else name))


def judged(gap: float, name: str) -> dict:
    """The network shipped for the hand ``name``, its chooser on both sets at ``gap``: each set's report, cut to
    what is read."""
    from benchmarks.experiments.picks import run_set, sets
    from onepiece_dist.specs.plan import PlanSpec

    found, folder = {"gap": gap, "views": VIEWS, "sets": []}, ROOT / "data" / RESULTS.stem
    for set_name in SETS:
        objects, source = sets()[set_name]
        found["sets"].append(slim(run_set(set_name, objects(), source, network(name),
                                          folder / ("" if name == "default" else name) / f"{gap:g}", ("network",),
                                          PlanSpec(table_clearance=gap), VIEWS)))
        print(gap, set_name, found["sets"][-1]["methods"][0]["first_attempt"], flush=True)
    return found


def versus(runs: dict, base: str) -> None:
    """Each run paired over objects against ``base``'s, per set and over both."""
    for name, run in runs.items():
        if name != base:
            pairs = {s["name"]: paired([s], [b for b in runs[base]["sets"] if b["name"] == s["name"]], "network")
                     for s in run["sets"]}
            run["versus"] = {**pairs, "all objects": paired(run["sets"], runs[base]["sets"], "network")}


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gaps", default=",".join(f"{g:g}" for g in GAPS))
    parser.add_argument("--gripper", choices=("default", "panda", "robotiq_2f85", "robotiq_2f140"), default="default")
    args = parser.parse_args()
    mine = RESULTS if args.gripper == "default" else RESULTS.with_name(f"{RESULTS.stem}_{args.gripper}.json")
    kept = json.loads(mine.read_text())["runs"] if mine.is_file() else {}
    out = {"command": COMMAND + ("" if args.gripper == "default" else f" --gripper {args.gripper}"),
           "date": date.today().isoformat(), "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}",
           "network": network(args.gripper).name, "base": f"{GAPS[0]:g}", "runs": kept}
    for gap in (float(g) for g in args.gaps.split(",")):
        out["runs"][f"{gap:g}"] = judged(gap, args.gripper)
        versus(out["runs"], out["base"])
        mine.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps({name: run.get("versus") for name, run in out["runs"].items()}, indent=1))


if __name__ == "__main__":
    main()
