"""Scores steadied over fresh draws of each crop's points (issue 55; plan.redraw, PlanSpec.score_draws): the
network's 32 best-scored candidates of each view scored again on further draws of the points inside their closing
region and ranked by the mean, against one draw, judged by `onepiece pick` on the household and unseen sets (8
views an object, the planner's defaults otherwise: its first 3 grasps checked), the network chooser alone, for each
network of NETWORKS with the hand it was made for.

    .venv/bin/python -m benchmarks.experiments.pick_score_draws [--draws 1,4]

Results: benchmarks/results/pick_score_draws.json (written as each run lands; a run again judges only what is not in
it), rendered on docs/picks.md. The networks are the rows' "seeds": a draw count is kept where its gain over one
draw, paired over the objects of both sets, lies above zero over them.
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_own_network import ROOT, SETS, VIEWS, tag
from onepiece_dist.specs.plan import PICK_LABEL_OBJECTS

HERE = Path(__file__).resolve().parents[1]
MIX = tag(PICK_LABEL_OBJECTS)  # the folders' prefix of pick_own_network's networks on pick-labels' default objects
NETWORKS = {  # name -> (checkpoint, gripper preset; None: the shipped network, the default job's box gripper)
    "shipped": (None, None),
    "shipped_panda": (None, "panda"),
    "own_mix_l0_f0": (f"data/own_network/net_{MIX}l0_f0/best.pt", None),
    "own_mix_l1_f0": (f"data/own_network/net_{MIX}l1_f0/best.pt", None),
    "own_panda_mix_l0_f0": (f"data/own_network_panda/net_{MIX}l0_f0/best.pt", "panda"),
}  # the own_* networks: pick_own_network's on pick-labels' default objects


def judged(name: str, draws: int) -> dict:
    """NETWORKS[name] with ``draws`` score draws on each of SETS, as `onepiece pick` judges it."""
    from benchmarks.experiments import pick_own_network
    from onepiece_dist.specs.plan import PlanSpec

    checkpoint, gripper = NETWORKS[name]
    return pick_own_network.judged(None if checkpoint is None else ROOT / checkpoint, name, gripper,
                                   plan=PlanSpec(score_draws=draws),
                                   folder=ROOT / "data" / "score_draws" / f"{name}_d{draws}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", default="1,4")
    args = parser.parse_args()
    path = HERE / "results" / "pick_score_draws.json"
    result = json.loads(path.read_text()) if path.is_file() else {"runs": []}
    machine = f"{platform.machine()}, {platform.processor() or 'cpu'}"
    result.update({"command": ".venv/bin/python -m benchmarks.experiments.pick_score_draws", "views": VIEWS,
                   "date": date.today().isoformat(), "machine": machine,
                   "networks": {name: {"checkpoint": c, "gripper": g} for name, (c, g) in NETWORKS.items()}})
    done = {(r["network"], r["draws"]) for r in result["runs"]}
    for name in NETWORKS:
        for draws in (int(d) for d in args.draws.split(",")):
            if (name, draws) in done:
                continue
            result["runs"].append({"network": name, "draws": draws, "picks": judged(name, draws)})
            path.write_text(json.dumps(result, indent=1) + "\n")
            print(name, draws, {s: result["runs"][-1]["picks"][s]["first_attempt"] for s in SETS}, flush=True)
    print(path)


if __name__ == "__main__":
    main()
