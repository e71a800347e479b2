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
import time
from datetime import date
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
VIEWS = 8
SETS = ("household", "unseen")
MIX = "pybullet_random_urdfs_0_32__shapes_groceries_0_16__shapes_vessels_0_16"  # pick_own_network.tag's folders
NETWORKS = {  # name -> (checkpoint, gripper preset; None: the shipped network, the default job's box gripper)
    "shipped": (None, None),
    "shipped_panda": (None, "panda"),
    "own_mix_l0_f0": (f"data/own_network/net_{MIX}_l0_f0/best.pt", None),
    "own_mix_l1_f0": (f"data/own_network/net_{MIX}_l1_f0/best.pt", None),
    "own_panda_mix_l0_f0": (f"data/own_network_panda/net_{MIX}_l0_f0/best.pt", "panda"),
}  # the own_* networks: pick_own_network's on pick-labels' default objects


def judged(name: str, draws: int) -> dict:
    """NETWORKS[name] with ``draws`` score draws on each of SETS, as `onepiece pick` judges it."""
    from benchmarks.experiments.pick_own_network import hand
    from benchmarks.experiments.picks import sets
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    checkpoint, gripper = NETWORKS[name]
    path, out = None if checkpoint is None else str(ROOT / checkpoint), {}
    for set_name in SETS:
        spec = PickSpec(objects=sets()[set_name][0](), checkpoint=path,
                        output=str(ROOT / "data" / "score_draws" / f"{name}_d{draws}" / set_name), views=VIEWS,
                        methods=("network",), pictures=0, gripper=hand(gripper), plan=PlanSpec(score_draws=draws))
        start = time.perf_counter()
        report = run_picks(spec)
        method = report.methods[0]
        out[set_name] = {"first_attempt": method.first_attempt, "interval": list(method.first_attempt_interval),
                         "views": method.views, "per_object": report.first_picks("network"),
                         "seconds": round(time.perf_counter() - start, 1)}
    return out


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
