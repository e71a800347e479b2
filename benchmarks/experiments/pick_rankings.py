"""Rankings of the shipped network's scores tried as choosers (docs/picks.md, "Rankings tried"): each changes only
which of a view's candidates goes first, so each is judged by the first attempt on the same views and candidates.

- ``network``: the network's score (the product);
- ``jittered``: each of the network's 16 best candidates scored again at 8 copies perturbed by the label's own pose
  noise (sim.pose_noise, sim.rotation_noise; twice that for ``jittered_x2``) and ranked by the mean: a grasp whose
  neighbours also hold (VGN smooths its quality volume for the same reason);
- ``top_prior_W``: the score plus W times how straight down the approach points (the top-down heuristic's prior);
- ``ensemble_2``, ``ensemble_4``: the mean score of the shipped network and other networks of the learning curve
  (``data/pick_curve``, written by ``python -m benchmarks.experiments.pick_curve``): a seed and design ensemble;
- ``flipped``: the mean score of the candidate and of the same grasp turned half a turn about its approach (the
  network is trained with such turns, so a test-time average of the two), ``ensemble_4_flipped`` both together.

Chosen on a selection set of procedural objects the network never saw (``SELECTION``, 60 objects), judged on the
household set. Every candidate's execution has its own generator (picks.views.Executions): a candidate chosen by
two rankings is one outcome.

    .venv/bin/python -m benchmarks.experiments.pick_rankings        # about 15 minutes on 2 cores
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial
from pathlib import Path

import numpy as np

from benchmarks.experiments.rankings_task import JITTERED, JITTERS, RANKINGS, rank_object
from onepiece_dist.objects import resolve_source
from onepiece_dist.picks.runner import first_failures, object_rate, run_each_in_process
from onepiece_dist.specs.plan import PickSpec
from onepiece_dist.stats.intervals import bootstrap_interval

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results" / "pick_rankings.json"
# the network shipped before the top-down trial was kept (its rankings were tried on the product pool of then)
CHECKPOINT = ROOT / "data" / "pick_curve" / "context_balanced_81152" / "best.pt"
SELECTION = "pybullet:random_urdfs[600:660]"


def judge(name: str, objects: str, rankings: tuple[str, ...] = RANKINGS) -> dict:
    spec = PickSpec(objects=objects, checkpoint=str(CHECKPOINT), output=str(ROOT / "data" / "pick_rankings" / name),
                    views=8, attempts=1, pictures=0, methods=("network",), plan={"top_down": False, "check_first": 0})
    start = time.perf_counter()
    task = partial(rank_object, rankings=rankings)
    done = [r for r in run_each_in_process(task, spec, resolve_source(objects)) if r.status == "ok"]
    rates_of = {}
    for ranking in rankings:
        rates = np.array([object_rate(r, ranking, None) for r in done])
        rates_of[ranking] = {"first_attempt": round(float(rates.mean()), 4),
                             "interval": [round(v, 4) for v in bootstrap_interval(rates, seed=spec.seed)],
                             "failures": first_failures(done, ranking)}
    return {"name": name, "objects": objects, "loaded": len(done), "views": sum(len(r.views) for r in done),
            "rankings": rates_of, "seconds": round(time.perf_counter() - start, 1)}


def _merged(old: dict, new: dict) -> dict:
    """``old`` rankings' results with ``new`` ones replacing or added, in RANKINGS' order."""
    both = {**old, **new}
    return {name: both[name] for name in RANKINGS if name in both}


def main() -> None:
    from benchmarks.experiments.household import household_objects

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rankings", default=",".join(RANKINGS),
                        help="these rankings only, merged into the committed results (each has its own draws)")
    rankings = tuple(parser.parse_args().rankings.split(","))
    sets = [judge("selection", SELECTION, rankings), judge("household", str(household_objects()), rankings)]
    if RESULTS.is_file() and set(rankings) != set(RANKINGS):
        old = {s["name"]: s for s in json.loads(RESULTS.read_text())["sets"]}
        sets = [{**s, "rankings": _merged(old[s["name"]]["rankings"], s["rankings"]),
                 "seconds": old[s["name"]]["seconds"]} for s in sets]
    RESULTS.write_text(json.dumps({"checkpoint": str(CHECKPOINT.relative_to(ROOT)), "jitters": JITTERS,
                                   "jittered": JITTERED, "sets": sets}, indent=1) + "\n")
    for s in sets:
        print(s["name"], {k: v["first_attempt"] for k, v in s["rankings"].items()}, s["seconds"])


if __name__ == "__main__":
    main()
